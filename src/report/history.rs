//! `history.html`: the page of `quaketwin history` — per structure, its
//! events (date, intensity, rating, the flags of its modes, the prediction
//! error), then per followed mode the frequency against the intensity with
//! the amplitude-dependence band shaded (Eqs. H1–H3) and the frequency
//! against the event date, flagged events and a permanent shift marked.
//! Same style as the event report (inline SVG and CSS, no scripts, no
//! network).

use super::html::{escape, format_number};
use super::plot::{render, shade_band, Chart, Mark, RefLine, Series};
use crate::history::{ModeHistory, StructureHistory, G};
use crate::sinks::history_tables::HistoryEventRow;
use crate::vocab::format_epoch_ns;

/// Palette indices: in band, flagged, band, predicted, after the step.
const IN_BAND: usize = 0;
const FLAGGED: usize = 1;
const BAND: usize = 2;
const PREDICTED: usize = 6;
const AFTER_STEP: usize = 3;

/// What the page shows of one structure.
pub struct StructurePage<'a> {
    pub structure: &'a str,
    pub name: Option<&'a str>,
    pub history: &'a StructureHistory,
    /// Rows of history_events/history_events.parquet, in the order of `history.events`.
    pub events: &'a [HistoryEventRow],
}

const NS_PER_YEAR: f64 = 365.2425 * 86_400.0 * 1e9;

fn year(ns: i64) -> f64 {
    1970.0 + ns as f64 / NS_PER_YEAR
}

fn g(x: Option<f64>) -> String {
    x.map(|v| format_number(v / G))
        .unwrap_or_else(|| "—".into())
}

/// The rendered chart, passed through `decorate` (shading), with its
/// legend; a note when it cannot be drawn.
fn figure(chart: &Chart, decorate: impl FnOnce(String) -> String) -> String {
    match render(chart) {
        Ok(svg) => format!("{}{}", decorate(svg), super::plot::legend(&chart.series)),
        Err(e) => format!("<p class=\"note\">No chart: {}</p>", escape(&e)),
    }
}

/// Adds a series of points unless there are none.
fn push_points(chart: &mut Chart, label: &str, points: Vec<(f64, f64)>, colour: usize, mark: Mark) {
    if !points.is_empty() {
        chart.series.push(Series::new(label, points, colour, mark));
    }
}

/// Frequency against intensity (log axis, in g) with the band shaded.
fn intensity_chart(h: &StructureHistory, m: &ModeHistory) -> String {
    let mut groups: [Vec<(f64, f64)>; 3] = Default::default();
    for (k, member) in m.track.members.iter().enumerate() {
        let e = &h.events[member.event];
        let Some(a) = e.intensity_m_s2.filter(|a| *a > 0.0) else {
            continue;
        };
        let v = &m.assessment.verdicts[k];
        let p = (a / G, e.modes[member.mode].frequency_hz);
        let group = if v.status.flagged() {
            1
        } else if v.after_step {
            2
        } else {
            0
        };
        groups[group].push(p);
    }
    let all: Vec<(f64, f64)> = groups.iter().flatten().copied().collect();
    if all.is_empty() {
        return "<p class=\"note\">No event with a known intensity.</p>".into();
    }
    let (lo_a, hi_a) = all.iter().fold((f64::INFINITY, 0.0f64), |(l, h), p| {
        (l.min(p.0), h.max(p.0))
    });
    let (x0, x1) = (lo_a / 1.5, hi_a * 1.5);
    let mut band_points: Vec<(f64, f64, f64)> = Vec::new();
    let mut after_points: Vec<(f64, f64, f64)> = Vec::new();
    if let Some(b) = &m.assessment.band {
        for i in 0..=60 {
            let x = x0 * (x1 / x0).powf(i as f64 / 60.0);
            let (_, l, u) = b.band_at(x * G, false);
            band_points.push((x, l, u));
            if b.step.is_some() {
                let (_, l, u) = b.band_at(x * G, true);
                after_points.push((x, l, u));
            }
        }
    }
    let ys = all.iter().map(|p| p.1).chain(
        band_points
            .iter()
            .chain(&after_points)
            .flat_map(|b| [b.1, b.2]),
    );
    let (lo, hi) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), y| {
        (a.min(y), b.max(y))
    });
    // The band may widen far beyond the data at the ends: keep the data in view.
    let (dlo, dhi) = all
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.1), b.max(p.1))
        });
    let (lo, hi) = (
        lo.max(dlo - 0.5 * (dhi - dlo).max(0.1 * dhi)),
        hi.min(dhi + 0.5 * (dhi - dlo).max(0.1 * dhi)),
    );
    let pad = 0.06 * (hi - lo).max(1e-6 * hi.abs());
    let mut chart = Chart::new(
        560,
        300,
        "intensity: peak acceleration (g)",
        "frequency (Hz)",
    );
    chart.log_x = true;
    chart.x_range = Some((x0, x1));
    chart.y_range = Some((lo - pad, hi + pad));
    if let Some(b) = &m.assessment.band {
        let mid: Vec<(f64, f64)> = band_points
            .iter()
            .map(|p| (p.0, b.band_at(p.0 * G, false).0))
            .collect();
        chart
            .series
            .push(Series::new("predicted (Eq. H1)", mid, BAND, Mark::Line));
        if b.step.is_some() {
            let mid: Vec<(f64, f64)> = after_points
                .iter()
                .map(|p| (p.0, b.band_at(p.0 * G, true).0))
                .collect();
            chart.series.push(Series::new(
                "predicted after the shift",
                mid,
                AFTER_STEP,
                Mark::Dashed,
            ));
        }
    }
    let [ok, flagged, after] = groups;
    push_points(
        &mut chart,
        "in band / no band",
        ok,
        IN_BAND,
        Mark::FilledCircle,
    );
    push_points(
        &mut chart,
        "after the shift",
        after,
        AFTER_STEP,
        Mark::Triangle,
    );
    push_points(
        &mut chart,
        "outside the band",
        flagged,
        FLAGGED,
        Mark::Cross,
    );
    figure(&chart, |svg| {
        let svg = shade_band(&svg, &chart, &band_points, BAND, "prediction band (Eq. H3)");
        if after_points.is_empty() {
            return svg;
        }
        shade_band(
            &svg,
            &chart,
            &after_points,
            AFTER_STEP,
            "prediction band after the shift",
        )
    })
}

/// Frequency against the event date, with the predicted frequency at each
/// event's intensity and the shift's date.
fn date_chart(h: &StructureHistory, m: &ModeHistory) -> String {
    let (mut ok, mut flagged, mut predicted) = (Vec::new(), Vec::new(), Vec::new());
    for (k, member) in m.track.members.iter().enumerate() {
        let e = &h.events[member.event];
        let Some(t) = e.time_ns else { continue };
        let v = &m.assessment.verdicts[k];
        let p = (year(t), e.modes[member.mode].frequency_hz);
        if v.status.flagged() {
            flagged.push(p);
        } else {
            ok.push(p);
        }
        if let Some(b) = v.band {
            predicted.push((p.0, b.0));
        }
    }
    if ok.is_empty() && flagged.is_empty() {
        return "<p class=\"note\">No event with a known date.</p>".into();
    }
    let mut chart = Chart::new(560, 300, "event date (year)", "frequency (Hz)");
    push_points(
        &mut chart,
        "predicted at the event's intensity",
        predicted,
        PREDICTED,
        Mark::HollowCircle,
    );
    push_points(&mut chart, "identified", ok, IN_BAND, Mark::FilledCircle);
    push_points(
        &mut chart,
        "outside the band",
        flagged,
        FLAGGED,
        Mark::Cross,
    );
    if let Some(step) = m.assessment.band.as_ref().and_then(|b| b.step) {
        if let Some(t) = h.events[m.track.members[step.from].event].time_ns {
            chart.ref_lines.push(RefLine {
                at: year(t),
                horizontal: false,
                colour: AFTER_STEP,
            });
        }
    }
    figure(&chart, |svg| svg)
}

fn mode_section(h: &StructureHistory, m: &ModeHistory, confidence: f64) -> String {
    let mut f: Vec<f64> = m
        .track
        .members
        .iter()
        .map(|x| h.events[x.event].modes[x.mode].frequency_hz)
        .collect();
    let median = crate::stats::median_in_place(&mut f);
    let direction = if m.track.direction.is_empty() {
        String::new()
    } else {
        format!(", {}", escape(&m.track.direction))
    };
    let mut s = format!(
        "<h3>Mode {}{direction}: median {} Hz over {} event(s)</h3>\n",
        m.id,
        format_number(median),
        m.track.members.len()
    );
    match (&m.assessment.band, &m.assessment.note) {
        (Some(b), _) => {
            let c = b.coefficients();
            s.push_str(&format!(
                "<p class=\"note\">ln f = {} {} {} ln(A/g){} (Eq. H1), s = {} (ln Hz), fitted on {} of {} events; {} % prediction interval (Eq. H3){}.</p>\n",
                format_number(c[0]),
                if c[1] < 0.0 { "−" } else { "+" },
                format_number(c[1].abs()),
                if c.len() > 2 { format!(" {} {} S", if c[2] < 0.0 { "−" } else { "+" }, format_number(c[2].abs())) } else { String::new() },
                format_number(b.fit.residual_std),
                b.fitted.len(),
                m.track.members.len(),
                super::html::short_number(100.0 * confidence),
                match b.step {
                    Some(st) => format!(
                        "; <b>permanent shift of {:+.1} %</b> from {} (p = {:.2e}, Eq. H5)",
                        100.0 * st.relative_change,
                        escape(&h.events[m.track.members[st.from].event].event),
                        st.p_value
                    ),
                    None => String::new(),
                }
            ));
        }
        (None, Some(note)) => s.push_str(&format!(
            "<p class=\"note\">No band: {}.</p>\n",
            escape(note)
        )),
        (None, None) => {}
    }
    if m.track.members.len() >= 2 {
        s.push_str(&format!(
            "<div style=\"display:flex;flex-wrap:wrap;gap:12px\"><figure>{}</figure><figure>{}</figure></div>\n",
            intensity_chart(h, m),
            date_chart(h, m)
        ));
    }
    s
}

fn rating_cell(r: Option<&str>) -> String {
    match r {
        Some(r) => {
            let class = match r {
                "GREEN" => "r-green",
                "YELLOW" => "r-yellow",
                "ORANGE" => "r-orange",
                "RED" => "r-red",
                _ => "",
            };
            format!(
                "<td><span class=\"badge {class}\">{}</span></td>",
                escape(r)
            )
        }
        None => "<td class=\"null\">—</td>".into(),
    }
}

fn structure_section(p: &StructurePage, confidence: f64) -> String {
    let h = p.history;
    let id = format!(
        "s-{}",
        p.structure
            .replace(|c: char| !c.is_ascii_alphanumeric(), "-")
    );
    let mut s = format!(
        "<h2 id=\"{}\">{}{}</h2>\n",
        escape(&id),
        escape(p.structure),
        p.name
            .map(|n| format!(" — {}", escape(n)))
            .unwrap_or_default()
    );
    let flagged: Vec<&HistoryEventRow> = p.events.iter().filter(|e| !e.flags.is_empty()).collect();
    s.push_str(&format!(
        "<p class=\"lead\">{} event(s), {} followed mode(s); {} event(s) with a mode outside its band or a shift.</p>\n",
        h.events.len(),
        h.modes.len(),
        flagged.len()
    ));
    s.push_str("<div class=\"scroll\"><table><tr><th>date</th><th>event</th><th>peak base (g)</th><th>peak response (g)</th><th>rating</th><th>modes</th><th>status</th><th>flags</th><th>predicted from</th><th>median ε</th><th>own model ε</th></tr>\n");
    for e in p.events {
        s.push_str(&format!(
            "<tr><td>{}</td><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>{}<td class=\"num\">{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td></tr>\n",
            escape(&e.event_time_ns.map(|t| format_epoch_ns(t)[..10].to_string()).unwrap_or_else(|| "—".into())),
            escape(&e.event),
            g(e.peak_base_m_s2),
            g(e.peak_response_m_s2),
            rating_cell(e.rating.as_deref()),
            e.modes,
            escape(&e.status),
            escape(&e.flags.join("; ")),
            escape(e.predicted_from.as_deref().unwrap_or("—")),
            e.prediction_error_median.map(format_number).unwrap_or_else(|| "—".into()),
            e.model_error_median.map(format_number).unwrap_or_else(|| "—".into()),
        ));
    }
    s.push_str("</table></div>\n");
    for m in &h.modes {
        s.push_str(&mode_section(h, m, confidence));
    }
    s
}

/// The whole page.
pub fn page(
    structures: &[StructurePage],
    dataset: &str,
    intensity: &str,
    confidence: f64,
) -> String {
    let mut p = super::sections::page_head("quaketwin — structure history");
    p.push_str("<header><h1>Structure history</h1>");
    p.push_str(&format!(
        "<p class=\"meta\">dataset {} · {} structure(s) · intensity: peak {} acceleration · quaketwin {}</p></header>\n",
        escape(dataset),
        structures.len(),
        escape(intensity),
        env!("CARGO_PKG_VERSION")
    ));
    p.push_str("<nav>");
    for s in structures {
        p.push_str(&format!(
            "<a href=\"#s-{}\">{}</a>",
            escape(
                &s.structure
                    .replace(|c: char| !c.is_ascii_alphanumeric(), "-")
            ),
            escape(s.structure)
        ));
    }
    p.push_str("</nav>\n<main>\n<p class=\"note\">Per structure: its events in date order; per mode followed across them (paired by MAC on the channels two events share), its frequency against the event's intensity with the log-linear amplitude dependence and its prediction interval shaded (docs/history.md, Eqs. H1–H3), and against the date. <code>amplitude_softened</code>: below the band at an intensity stronger than any the band was fitted on, and back inside in a later event; a permanent shift (Eq. H5) is dated by its first event. ε: normalised error ‖y − ŷ‖/‖y‖ of the response predicted by the model of the event before (Eqs. H7–H9), median over the channels.</p>\n");
    for s in structures {
        p.push_str(&structure_section(s, confidence));
    }
    p.push_str("</main>\n</body>\n</html>\n");
    p
}
