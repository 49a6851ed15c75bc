//! `tracking.html`: the page of `quaketwin track` — per tracked mode, the
//! frequency over time with the 99 % band of its regression shaded, the
//! flagged windows marked, the training period and the anomaly onset as
//! vertical lines; then a summary table (reference frequency, mean shift of
//! the flagged windows after training, first flagged window); then the
//! environmental compensation's control chart (T² per subgroup against its
//! threshold, docs/monitoring.md Eqs. E3–E5).  Same style as the event
//! report (inline SVG and CSS, no scripts, no network).

use super::html::{escape, format_number};
use super::plot::{render, shade_band, Chart, Mark, RefLine, Series};
use crate::monitor::compensation::RunCompensation;
use crate::monitor::Tracking;
use crate::vocab::format_epoch_ns;

const NS_PER_H: f64 = 3.6e12;
/// Colours (palette indices): identified, flagged, band.
const IDENTIFIED: usize = 0;
const FLAGGED: usize = 1;
const BAND: usize = 2;

/// One mode's chart: hours since `origin` on x.
fn mode_chart(t: &Tracking, id: usize, origin: i64) -> String {
    let hours = |ns: i64| (ns - origin) as f64 / NS_PER_H;
    let mid = |w: usize| {
        let win = &t.windows[w];
        hours(win.start_ns) + 0.5 * (win.end_ns - win.start_ns) as f64 / NS_PER_H
    };
    let (mut ok, mut flagged, mut band) = (Vec::new(), Vec::new(), Vec::new());
    for (r, b) in t.rows.iter().zip(&t.bands).filter(|(r, _)| r.mode_id == id) {
        let x = mid(r.window);
        match b {
            Some(b) if b.flagged => flagged.push((x, r.frequency_hz)),
            _ => ok.push((x, r.frequency_hz)),
        }
        if let Some(b) = b {
            band.push((x, b.low_hz, b.high_hz));
        }
    }
    if ok.is_empty() && flagged.is_empty() {
        return "<p class=\"note\">Not found in any window.</p>".into();
    }
    let end = t.windows.last().map(|w| hours(w.end_ns)).unwrap_or(1.0);
    let ys = ok
        .iter()
        .chain(&flagged)
        .map(|p| p.1)
        .chain(band.iter().flat_map(|b| [b.1, b.2]));
    let (lo, hi) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), y| {
        (a.min(y), b.max(y))
    });
    let pad = 0.08 * (hi - lo).max(1e-6 * hi.abs());
    let mut chart = Chart::new(
        880,
        260,
        "time since the first window (h)",
        "frequency (Hz)",
    );
    chart.x_range = Some((0.0, end.max(1e-9)));
    chart.y_range = Some((lo - pad, hi + pad));
    let predicted: Vec<(f64, f64)> = band.iter().map(|b| (b.0, 0.5 * (b.1 + b.2))).collect();
    if !predicted.is_empty() {
        chart.series.push(Series::new(
            "predicted (Eq. M1)",
            predicted,
            BAND,
            Mark::Line,
        ));
    }
    chart.series.push(Series::new(
        "identified",
        ok,
        IDENTIFIED,
        Mark::FilledCircle,
    ));
    if !flagged.is_empty() {
        chart.series.push(Series::new(
            "flagged (outside the band)",
            flagged,
            FLAGGED,
            Mark::Cross,
        ));
    }
    let training_end = hours(t.band_settings.training_end_ns);
    if training_end > 0.0 && training_end < end {
        chart.ref_lines.push(RefLine {
            at: training_end,
            horizontal: false,
            colour: 6,
        });
    }
    if let Some(i) = t.anomaly_from {
        chart.ref_lines.push(RefLine {
            at: hours(t.windows[i].start_ns),
            horizontal: false,
            colour: FLAGGED,
        });
    }
    match render(&chart) {
        Ok(svg) => format!(
            "{}{}",
            shade_band(&svg, &chart, &band, BAND, "99 % prediction band"),
            super::plot::legend(&chart.series)
        ),
        Err(e) => format!("<p class=\"note\">No chart: {}</p>", escape(&e)),
    }
}

/// The control chart of the compensation (control_chart/control_chart.parquet):
/// T²_g of each subgroup (Eq. E3) at its mid-time, hours since `origin`,
/// against the threshold (horizontal line, Eq. E4); training subgroups
/// hollow, out-of-control ones crossed, the alarm (Eq. E5) a vertical line.
/// A note when the run has no chart.
pub fn control_chart_section(c: &RunCompensation, origin: i64) -> String {
    let head = "<h2 id=\"control-chart\">Control chart (environmental compensation)</h2>\n";
    let Some(chart_of) = &c.chart else {
        let why = if c.warnings.is_empty() {
            "the run was not compensated".to_string()
        } else {
            c.warnings.join("; ")
        };
        return format!(
            "{head}<p class=\"note\">No control chart: {}</p>\n",
            escape(&why)
        );
    };
    let hours = |ns: i64| (ns - origin) as f64 / NS_PER_H;
    let (mut training, mut in_control, mut out) = (Vec::new(), Vec::new(), Vec::new());
    for g in &c.subgroups {
        let Some(t2) = g.statistic else { continue };
        let point = (0.5 * (hours(g.start_ns) + hours(g.end_ns)), t2);
        match (g.training, g.out_of_control) {
            (true, _) => training.push(point),
            (false, Some(true)) => out.push(point),
            _ => in_control.push(point),
        }
    }
    let all: Vec<f64> = training
        .iter()
        .chain(&in_control)
        .chain(&out)
        .map(|p| p.1)
        .collect();
    if all.is_empty() {
        return format!("{head}<p class=\"note\">No subgroup is charted.</p>\n");
    }
    let hi = all.iter().fold(chart_of.threshold, |a, &b| a.max(b));
    let end = c.subgroups.last().map(|g| hours(g.end_ns)).unwrap_or(1.0);
    let mut chart = Chart::new(
        880,
        260,
        "time since the first window (h)",
        "T² of the subgroup",
    );
    chart.x_range = Some((0.0, end.max(1e-9)));
    chart.y_range = Some((0.0, 1.08 * hi));
    for (name, points, colour, mark) in [
        ("training", training, 6, Mark::HollowCircle),
        ("in control", in_control, IDENTIFIED, Mark::FilledCircle),
        ("out of control (Eq. E4)", out, FLAGGED, Mark::Cross),
    ] {
        if !points.is_empty() {
            chart.series.push(Series::new(name, points, colour, mark));
        }
    }
    chart.ref_lines.push(RefLine {
        at: chart_of.threshold,
        horizontal: true,
        colour: FLAGGED,
    });
    if let Some(g) = c.alarm_from.and_then(|i| c.subgroups.get(i)) {
        chart.ref_lines.push(RefLine {
            at: hours(g.start_ns),
            horizontal: false,
            colour: FLAGGED,
        });
    }
    let figure = match render(&chart) {
        Ok(svg) => format!("{svg}{}", super::plot::legend(&chart.series)),
        Err(e) => format!("<p class=\"note\">No chart: {}</p>", escape(&e)),
    };
    format!(
        "{head}<p class=\"note\">Model `{}`; horizontal line: the threshold {} (k = {}, α = {}); vertical line: the alarm{}.</p>\n<figure>{figure}</figure>\n",
        escape(&c.model),
        format_number(chart_of.threshold),
        chart_of.dof,
        chart_of.false_alarm_rate,
        c.alarm_from
            .and_then(|i| c.subgroups.get(i))
            .map(|g| format!(" from {}", escape(&format_epoch_ns(g.start_ns))))
            .unwrap_or_else(|| " (none)".into()),
    )
}

/// The whole page.
pub fn page(t: &Tracking, units: &str, streams: &[String]) -> String {
    let origin = t.windows.first().map(|w| w.start_ns).unwrap_or(0);
    let training_end = t.band_settings.training_end_ns;
    let mut p = super::sections::page_head("quaketwin — frequency tracking");
    p.push_str("<header><h1>Continuous monitoring: frequency tracking</h1>");
    p.push_str(&format!(
        "<p class=\"meta\">{} windows from {} · streams {} · RMS in {} · quaketwin {}</p></header>\n<main>\n",
        t.windows.len(),
        escape(&format_epoch_ns(origin)),
        escape(&streams.join(", ")),
        escape(units),
        env!("CARGO_PKG_VERSION")
    ));
    let identified = t.windows.iter().filter(|w| !w.modes.is_empty()).count();
    let verdict = match t.anomaly_from {
        Some(i) => format!(
            "<div class=\"rating-box r-red\"><p class=\"big\"><b>Anomaly from {}</b></p><p>At least half of the tracked modes left their 99 % band in {} or more consecutive windows (Eq. M5).</p></div>",
            escape(&format_epoch_ns(t.windows[i].start_ns)),
            t.band_settings.min_run
        ),
        None => "<div class=\"rating-box r-green\"><p class=\"big\"><b>No sustained anomaly</b></p><p>No run of anomalous windows after the training period (Eq. M5).</p></div>".into(),
    };
    p.push_str(&verdict);
    p.push_str(&format!(
        "<p class=\"lead\">{identified} of {} windows identified; reference modes from {}; band trained on the windows before {} (regression of the frequency on the window's RMS level and the time of day, 99 % prediction interval: docs/monitoring.md).</p>\n",
        t.windows.len(),
        escape(&t.reference.source),
        escape(&format_epoch_ns(training_end)),
    ));
    // Summary table.
    p.push_str("<h2 id=\"summary\">Tracked modes</h2>\n<div class=\"scroll\"><table><tr><th>mode</th><th>direction</th><th>reference f (Hz)</th><th>windows found</th><th>flagged after training</th><th>mean shift of the flagged windows (%)</th><th>first flagged window</th></tr>\n");
    for (k, m) in t.reference.modes.iter().enumerate() {
        let id = k + 1;
        let after: Vec<f64> = t
            .rows
            .iter()
            .zip(&t.bands)
            .filter(|(r, _)| r.mode_id == id && t.windows[r.window].start_ns >= training_end)
            .filter_map(|(r, b)| {
                b.filter(|b| b.flagged).map(|b| {
                    (
                        r,
                        100.0 * (r.frequency_hz - b.predicted_hz) / b.predicted_hz,
                    )
                })
            })
            .map(|(_, d)| d)
            .collect();
        let first = t
            .rows
            .iter()
            .zip(&t.bands)
            .find(|(r, b)| {
                r.mode_id == id
                    && t.windows[r.window].start_ns >= training_end
                    && b.is_some_and(|b| b.flagged)
            })
            .map(|(r, _)| format_epoch_ns(t.windows[r.window].start_ns));
        let found = t.rows.iter().filter(|r| r.mode_id == id).count();
        let mean = (!after.is_empty()).then(|| after.iter().sum::<f64>() / after.len() as f64);
        p.push_str(&format!(
            "<tr><td class=\"num\">{id}</td><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{found}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{}</td></tr>\n",
            escape(&m.direction),
            format_number(m.frequency_hz),
            after.len(),
            mean.map(format_number).unwrap_or_else(|| "—".into()),
            escape(first.as_deref().unwrap_or("—")),
        ));
    }
    p.push_str("</table></div>\n");
    // Charts.
    p.push_str("<h2 id=\"frequencies\">Frequency over time</h2>\n<p class=\"note\">Shaded: the 99 % prediction band; black vertical line: end of the training period; vermillion vertical line: start of the sustained anomaly.</p>\n");
    for (k, m) in t.reference.modes.iter().enumerate() {
        p.push_str(&format!(
            "<figure><h3>Mode {} ({} Hz{})</h3>{}</figure>\n",
            k + 1,
            format_number(m.frequency_hz),
            if m.direction.is_empty() {
                String::new()
            } else {
                format!(", {}", escape(&m.direction))
            },
            mode_chart(t, k + 1, origin)
        ));
    }
    p.push_str(&control_chart_section(&t.compensation, origin));
    let skipped: Vec<String> = t
        .windows
        .iter()
        .filter_map(|w| {
            w.skipped.as_ref().map(|s| {
                format!(
                    "<li>{}: {}</li>",
                    escape(&format_epoch_ns(w.start_ns)),
                    escape(s)
                )
            })
        })
        .collect();
    if !skipped.is_empty() {
        p.push_str(&format!(
            "<h2 id=\"skipped\">Skipped windows</h2><ul>{}</ul>\n",
            skipped.join("")
        ));
    }
    // Damaged MiniSEED skipped by the reader (file, byte offset, time
    // without samples), under the windows it cost.
    let damaged: Vec<String> = t
        .windows
        .iter()
        .flat_map(|w| {
            w.notes
                .iter()
                .filter(|n| n.starts_with(crate::readers::sds::DAMAGE_NOTE))
                .map(|n| {
                    format!(
                        "<li>{}: {}</li>",
                        escape(&format_epoch_ns(w.start_ns)),
                        escape(n)
                    )
                })
        })
        .collect();
    if !damaged.is_empty() {
        p.push_str(&format!(
            "<h2 id=\"damaged\">Damaged records</h2><p class=\"note\">Skipped by the reader; each costs only the windows it overlaps (a gap, filled as gaps are, or the window skipped when nothing of the stream is left).</p><ul>{}</ul>\n",
            damaged.join("")
        ));
    }
    p.push_str("</main>\n</body>\n</html>\n");
    p
}
