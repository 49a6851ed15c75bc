//! The dashboard's pages: `index.html` (the map and the structures, most
//! urgent first) and one page per structure (its latest assessment, its
//! history when there is one, its identified frequencies across events and
//! its events, each linking to its report).  Inline CSS and SVG; one small
//! inline script sorts a table by a clicked column (the pages read fine
//! without it).

use super::scan::{EventView, StructureView};
use crate::report::plot::{legend, render, Chart, Mark, Series};
use crate::report::{escape, format_number, page_head_with_script, rating_badge};
use crate::vocab::format_epoch_ns;

/// Rank of an inspection priority (ShakeCast's order): most urgent highest.
pub fn priority_rank(priority: Option<&str>) -> u8 {
    match priority {
        Some("high") => 4,
        Some("medium-high") => 3,
        Some("medium") => 2,
        Some("low") => 1,
        _ => 0,
    }
}

/// Links of one structure's files inside the site.
pub struct Links {
    /// Its page, relative to the site root.
    pub page: String,
    /// Its copied history page, relative to the site root.
    pub history: Option<String>,
    /// Per event (in the structure's order): its copied report, relative to the site root.
    pub reports: Vec<Option<String>>,
}

const EXTRA_CSS: &str = r#"<style>
th[data-sort]{cursor:pointer;text-decoration:underline dotted}
svg.map{max-width:100%;height:auto;border:1px solid var(--line)}
svg.map .map-bg{fill:#f7fbff}
svg.map .grid{stroke:#ccd;stroke-width:0.5}
svg.map .grid-label{font-size:10px;fill:#667}
svg.map .place{font-size:11px;fill:#222}
svg.map .dot{stroke:#222;stroke-width:1}
svg.map .dot.r-green{fill:#009e73}svg.map .dot.r-yellow{fill:#f0e442}svg.map .dot.r-orange{fill:#e69f00}
svg.map .dot.r-red{fill:#d55e00}svg.map .dot.r-none{fill:#bbb}
</style>
"#;

/// Sorts a table's body by the clicked header: numbers by `data-value` of
/// the cells when present, else text; a second click reverses.
const SORT_SCRIPT: &str = r#"<script>
document.querySelectorAll('table.sortable').forEach(function(t){
  t.querySelectorAll('th[data-sort]').forEach(function(th, i){
    th.addEventListener('click', function(){
      var body = t.tBodies[0], rows = Array.prototype.slice.call(body.rows);
      var col = Array.prototype.indexOf.call(th.parentNode.children, th);
      var dir = th.getAttribute('data-dir') === 'desc' ? 1 : -1;
      th.setAttribute('data-dir', dir === 1 ? 'asc' : 'desc');
      rows.sort(function(a, b){
        var x = a.cells[col], y = b.cells[col];
        var xv = x.getAttribute('data-value'), yv = y.getAttribute('data-value');
        if (xv !== null && yv !== null) return dir * (parseFloat(xv) - parseFloat(yv));
        return dir * x.textContent.localeCompare(y.textContent);
      });
      rows.forEach(function(r){ body.appendChild(r); });
    });
  });
});
</script>
"#;

fn page_end() -> String {
    format!("{SORT_SCRIPT}</body>\n</html>\n")
}

fn time_text(ns: Option<i64>) -> String {
    ns.map(|t| {
        let s = format_epoch_ns(t);
        // To the second: 2026-01-15T10:20:30Z.
        format!("{}Z", &s[..19])
    })
    .unwrap_or_else(|| "–".into())
}

fn opt(s: Option<&str>) -> String {
    s.map(escape).unwrap_or_else(|| "–".into())
}

/// The event's rating cell: the badge, and the rating as data.
fn rating_cell(e: &EventView) -> String {
    let rating = e.rating();
    let rank = e
        .assessment
        .as_ref()
        .map(|a| priority_rank(a.priority.as_deref()))
        .unwrap_or(0);
    format!(
        "<td class=\"rating\" data-value=\"{rank}\">{}</td>",
        rating_badge(rating)
    )
}

/// `index.html`.
pub fn index(
    structures: &[&StructureView],
    links: &[Links],
    map: Option<String>,
    dataset: &str,
) -> String {
    let mut p = page_head_with_script("Fleet dashboard");
    p.push_str(EXTRA_CSS);
    let events: usize = structures.iter().map(|s| s.events.len()).sum();
    p.push_str(&format!(
        "<header><h1>Fleet dashboard</h1><p class=\"meta\">{} structures, {events} events, from the dataset <code>{}</code>. Most urgent first: inspection priority of each structure's latest event (high, medium-high, medium, low, not rated). Click a column heading to sort by it.</p></header>\n",
        structures.len(),
        escape(dataset)
    ));
    if let Some(svg) = map {
        p.push_str("<section id=\"map\"><h2>Map</h2>\n");
        p.push_str(&svg);
        p.push_str("<p class=\"note\">Structures whose event.toml states <code>structure.latitude_deg</code> and <code>longitude_deg</code>, coloured by their latest rating.</p></section>\n");
    }
    p.push_str("<section id=\"fleet\"><h2>Structures</h2>\n<div class=\"scroll\"><table id=\"structures\" class=\"sortable\"><thead><tr>");
    for (h, sortable) in [
        ("Latest rating", true),
        ("Priority", true),
        ("Structure", true),
        ("Kind", true),
        ("Damage state", true),
        ("Latest event", true),
        ("Origin (UTC)", true),
        ("Events", true),
        ("Drivers", false),
    ] {
        if sortable {
            p.push_str(&format!("<th data-sort=\"1\">{h}</th>"));
        } else {
            p.push_str(&format!("<th>{h}</th>"));
        }
    }
    p.push_str("</tr></thead>\n<tbody>\n");
    for (s, l) in structures.iter().zip(links) {
        let e = s.latest();
        let a = e.assessment.as_ref();
        let priority = a.and_then(|a| a.priority.as_deref());
        p.push_str(&format!(
            "<tr data-structure=\"{key}\" data-rating=\"{rating}\" data-priority=\"{prio}\" data-event=\"{event}\">{rating_cell}<td data-value=\"{rank}\">{prio_text}</td><td><a href=\"{href}\">{name}</a></td><td>{kind}</td><td>{ds}</td><td>{ev}</td><td data-value=\"{t}\">{origin}</td><td class=\"num\" data-value=\"{n}\">{n}</td><td>{drivers}</td></tr>\n",
            key = escape(&s.key),
            rating = escape(e.rating()),
            prio = escape(priority.unwrap_or("")),
            event = escape(&e.event),
            rating_cell = rating_cell(e),
            rank = priority_rank(priority),
            prio_text = opt(priority),
            href = escape(&l.page),
            name = escape(&s.display_name()),
            kind = opt(s.kind().as_deref()),
            ds = opt(a.and_then(|a| a.damage_state.as_deref())),
            ev = escape(e.name.as_deref().unwrap_or(&e.event)),
            t = e.time_key().0,
            origin = time_text(e.origin_ns),
            n = s.events.len(),
            drivers = a.map(|a| escape(&a.drivers.join("; "))).unwrap_or_default(),
        ));
    }
    p.push_str("</tbody></table></div></section>\n");
    p.push_str(&page_end());
    p
}

/// The frequencies of each event's modes, by direction: the event's origin
/// year on x when every event has one, else its number in time order.
fn frequency_chart(s: &StructureView) -> Option<String> {
    let years = s.events.iter().all(|e| e.origin_ns.is_some());
    let x_of = |i: usize, e: &EventView| match (years, e.origin_ns) {
        (true, Some(t)) => 1970.0 + t as f64 / (365.2425 * 86_400e9),
        _ => (i + 1) as f64,
    };
    let mut directions: Vec<String> = Vec::new();
    let mut points: Vec<Vec<(f64, f64)>> = Vec::new();
    for (i, e) in s.events.iter().enumerate() {
        for m in &e.modes {
            let d = m.direction.clone().unwrap_or_else(|| "unlabelled".into());
            let at = match directions.iter().position(|x| *x == d) {
                Some(at) => at,
                None => {
                    directions.push(d);
                    points.push(Vec::new());
                    directions.len() - 1
                }
            };
            points[at].push((x_of(i, e), m.frequency_hz));
        }
    }
    if directions.is_empty() {
        return None;
    }
    let x_label = if years {
        "origin (year)"
    } else {
        "event (in time order)"
    };
    let mut chart = Chart::new(720, 300, x_label, "frequency (Hz)");
    chart.x_pad = Some(0.05);
    chart.series = directions
        .iter()
        .zip(points)
        .enumerate()
        .map(|(i, (d, pts))| Series::new(format!("direction {d}"), pts, i, Mark::FilledCircle))
        .collect();
    let svg = render(&chart).ok()?;
    Some(format!(
        "<figure class=\"frequencies\">{svg}{}<figcaption>Identified modes of each event (the <code>modes</code> table), by direction. Mode numbers are per event; pairing them across events is the structure history's.</figcaption></figure>",
        legend(&chart.series)
    ))
}

/// One structure's page (`structures/<S>.html`; links relative to it).
pub fn structure(
    s: &StructureView,
    links: &Links,
    history_tables: &[(String, String)],
    up: &str,
) -> String {
    let name = s.display_name();
    let mut p = page_head_with_script(&format!("{name} — fleet dashboard"));
    p.push_str(EXTRA_CSS);
    let e = s.latest();
    p.push_str(&format!(
        "<nav><a href=\"{up}index.html\">← all structures</a></nav><header><h1>{}</h1><p class=\"meta\">Partition <code>structure={}</code>, {} events.</p></header>\n",
        escape(&name),
        escape(&s.key),
        s.events.len()
    ));
    p.push_str("<section id=\"latest\"><h2>Latest event</h2><dl class=\"facts\">");
    p.push_str(&format!(
        "<dt>Event</dt><dd>{}</dd><dt>Origin (UTC)</dt><dd>{}</dd><dt>Rating</dt><dd id=\"latest-rating\" data-rating=\"{}\">{}</dd><dt>Priority</dt><dd>{}</dd><dt>Damage state</dt><dd>{}</dd>",
        escape(e.name.as_deref().unwrap_or(&e.event)),
        time_text(e.origin_ns),
        escape(e.rating()),
        rating_badge(e.rating()),
        opt(e.assessment.as_ref().and_then(|a| a.priority.as_deref())),
        opt(e.assessment.as_ref().and_then(|a| a.damage_state.as_deref())),
    ));
    if let Some(k) = s.kind() {
        p.push_str(&format!("<dt>Kind</dt><dd>{}</dd>", escape(&k)));
    }
    if let Some((lat, lon)) = s.position() {
        let ns = if lat < 0.0 { 'S' } else { 'N' };
        let ew = if lon < 0.0 { 'W' } else { 'E' };
        p.push_str(&format!(
            "<dt>Position</dt><dd>{:.5}° {ns}, {:.5}° {ew}</dd>",
            lat.abs(),
            lon.abs()
        ));
    }
    p.push_str("</dl></section>\n");

    p.push_str("<section id=\"history\"><h2>History</h2>\n");
    match &links.history {
        Some(h) => p.push_str(&format!(
            "<p><a id=\"history-page\" href=\"{up}{}\">The structure's history</a> (modes paired across events, frequency against intensity, permanent shifts).</p>\n",
            escape(h)
        )),
        None if history_tables.is_empty() => p.push_str(
            "<p class=\"note\">No history yet (<code>quaketwin history</code> writes it; <code>quaketwin watch</code> refreshes it after each event).</p>\n",
        ),
        None => {}
    }
    for (file, table) in history_tables {
        p.push_str(&format!("<h3><code>{}</code></h3>{table}\n", escape(file)));
    }
    if let Some(chart) = frequency_chart(s) {
        p.push_str(&chart);
    }
    p.push_str("</section>\n");

    p.push_str("<section id=\"events\"><h2>Events</h2>\n<div class=\"scroll\"><table id=\"event-list\" class=\"sortable\"><thead><tr>");
    for h in [
        "Rating",
        "Event",
        "Origin (UTC)",
        "Magnitude",
        "Priority",
        "Damage state",
        "Confidence",
        "Frequencies (Hz)",
        "Report",
    ] {
        p.push_str(&format!("<th data-sort=\"1\">{h}</th>"));
    }
    p.push_str("</tr></thead>\n<tbody>\n");
    for (ev, report) in s.events.iter().zip(&links.reports).rev() {
        let a = ev.assessment.as_ref();
        let freqs: Vec<String> = ev
            .modes
            .iter()
            .map(|m| format_number(m.frequency_hz))
            .collect();
        let report_cell = match report {
            Some(r) => format!("<a class=\"report\" href=\"{up}{}\">report</a>", escape(r)),
            None => "–".into(),
        };
        let rating_note = ev
            .assessment_error
            .as_ref()
            .map(|e| {
                format!(
                    " <span class=\"note\">(assessment unreadable: {})</span>",
                    escape(e)
                )
            })
            .unwrap_or_default();
        p.push_str(&format!(
            "<tr data-event=\"{key}\" data-rating=\"{rating}\">{rating_cell}<td>{name}{rating_note}</td><td data-value=\"{t}\">{origin}</td><td class=\"num\">{mag}</td><td>{prio}</td><td>{ds}</td><td>{conf}</td><td>{freqs}</td><td>{report_cell}</td></tr>\n",
            key = escape(&ev.event),
            rating = escape(ev.rating()),
            rating_cell = rating_cell(ev),
            name = escape(ev.name.as_deref().unwrap_or(&ev.event)),
            t = ev.time_key().0,
            origin = time_text(ev.origin_ns),
            mag = ev.magnitude.map(format_number).unwrap_or_else(|| "–".into()),
            prio = opt(a.and_then(|a| a.priority.as_deref())),
            ds = opt(a.and_then(|a| a.damage_state.as_deref())),
            conf = opt(a.map(|a| a.confidence.as_str())),
            freqs = freqs.join(", "),
        ));
    }
    p.push_str("</tbody></table></div></section>\n");
    p.push_str(&page_end());
    p
}
