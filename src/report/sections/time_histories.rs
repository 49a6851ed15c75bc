//! Section 5, acceleration time histories (samples.parquet) as small multiples.

use std::collections::BTreeMap;
use std::path::Path;

use super::{channel_info, figure, load, require, rows_points, Loaded};
use crate::report::format_number;
use crate::report::html::note;
use crate::report::plot::{self, Chart, Mark, Series};
use crate::report::ReportSettings;
use crate::vocab::tables::{self, channels, samples};

pub(super) fn time_history_section(
    dir: &Path,
    channels: &Loaded,
    settings: &ReportSettings,
) -> String {
    let mut body = String::new();
    let loaded = load(
        dir,
        &tables::SAMPLES,
        Some(&[
            samples::CHANNEL_ID.name,
            samples::T_S.name,
            samples::ACC_M_S2.name,
        ]),
    );
    let Some(t) = require(&loaded, &tables::SAMPLES, &mut body) else {
        return body;
    };
    let missing = t.missing(&[
        samples::CHANNEL_ID.name,
        samples::T_S.name,
        samples::ACC_M_S2.name,
    ]);
    if !missing.is_empty() {
        body.push_str(&note(&format!(
            "samples.parquet: column(s) needed for the plots not present: {}.",
            missing.join(", ")
        )));
        return body;
    }
    let info = channel_info(channels);
    let pga: BTreeMap<String, f64> = match channels {
        Loaded::Ok(c) => (0..c.rows)
            .filter_map(|r| {
                Some((
                    c.key(channels::CHANNEL_ID.name, r)?,
                    c.number(channels::PGA_M_S2.name)?
                        .get(r)
                        .copied()
                        .flatten()?,
                ))
            })
            .collect(),
        _ => BTreeMap::new(),
    };
    let groups = t.groups(&[samples::CHANNEL_ID.name]);
    let traces: Vec<(String, Vec<(f64, f64)>)> = groups
        .into_iter()
        .map(|(k, rows)| {
            let pts = rows_points(t, &rows, samples::T_S.name, samples::ACC_M_S2.name);
            (
                k.join(""),
                plot::decimate_min_max(&pts, settings.max_points_per_trace),
            )
        })
        .collect();
    // Common symmetric y-axis so amplitudes compare across the multiples.
    let peak = traces
        .iter()
        .flat_map(|(_, p)| p.iter().map(|x| x.1.abs()))
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    let y = if peak > 0.0 { 1.05 * peak } else { 1.0 };
    body.push_str(&note(&format!(
        "Conditioned acceleration, common vertical scale. Traces drawn with at most {} points (min–max decimation keeps the peaks); PGA values from channels.parquet.",
        settings.max_points_per_trace
    )));
    body.push_str("<div class=\"multiples\">");
    for (i, (id, pts)) in traces.into_iter().enumerate() {
        let mut chart = Chart::new(440, 170, "t (s)", "a (m/s²)");
        chart.y_range = Some((-y, y));
        chart
            .series
            .push(Series::new(id.clone(), pts, i % 7, Mark::Line));
        let (dir, level) = info.get(&id).cloned().unwrap_or((None, None));
        let caption = format!(
            "{id} — level {}, direction {}{}",
            level.unwrap_or_else(|| "?".into()),
            dir.unwrap_or_else(|| "?".into()),
            pga.get(&id)
                .map(|p| format!(", PGA {} m/s²", format_number(*p)))
                .unwrap_or_default()
        );
        body.push_str(&figure(plot::render(&chart), &caption, ""));
    }
    body.push_str("</div>");
    body
}
