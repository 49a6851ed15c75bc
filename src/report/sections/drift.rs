//! Section 6, inter-storey drift ratios (drift.parquet): table, ratings and profile.

use super::{figure, present_columns, rating_cell, require, rows_points, Loaded};
use crate::report::format_number;
use crate::report::html::{column_notes, note, table, Cell};
use crate::report::plot::{self, Chart, Mark, RefLine, Series};
use crate::report::{Assessment, ReportSettings};
use crate::vocab::tables::{self, drift};

/// `residual`: residual drift (m) per (direction, segment `L<a>–L<b>`) from
/// the hysteresis stage's unfiltered displacement (`loops::residual_drifts`).
pub(super) fn drift_section(
    drift: &Loaded,
    residual: &std::collections::BTreeMap<(String, String), f64>,
    settings: &ReportSettings,
    out: &mut Vec<Assessment>,
) -> String {
    let mut body = String::new();
    let Some(t) = require(drift, &tables::DRIFT, &mut body) else {
        return body;
    };
    let known = [
        drift::DIRECTION.name,
        drift::STOREY.name,
        drift::LOWER_CHANNEL.name,
        drift::UPPER_CHANNEL.name,
        drift::STOREY_HEIGHT_M.name,
        drift::PEAK_DRIFT_RATIO.name,
    ];
    body.push_str(&column_notes(t, &known));
    let Some(ratio) = t.number(drift::PEAK_DRIFT_RATIO.name) else {
        return body;
    };
    let th = settings.drift;
    body.push_str(&note(&format!(
        "Rating of the peak drift ratio: GREEN < {} ≤ YELLOW < {} ≤ RED.",
        format_number(th.yellow),
        format_number(th.red)
    )));
    body.push_str(&note(
        "Peak drift from the band-passed displacements of the condition stage: the oscillation only, since a band-pass removes a \
         permanent offset. The residual drift column comes from the hysteresis stage's displacement, integrated from the as-recorded \
         accelerations without a band-pass (mean over the end of the record; loops and details in the Bouc-Wen section), where that \
         stage formed the storey.",
    ));
    let present = present_columns(t, &known);
    let mut headers: Vec<String> = present.iter().map(|s| s.to_string()).collect();
    headers.push("drift (%)".into());
    headers.push("rating".into());
    if !residual.is_empty() {
        headers.push("residual drift (m, unfiltered)".into());
    }
    let mut rows = Vec::new();
    for r in 0..t.rows {
        let v = ratio.get(r).copied().flatten();
        let rating = v.and_then(|v| th.rate(v));
        let mut row: Vec<Cell> = present.iter().map(|c| Cell::of(t, c, r)).collect();
        row.push(match v {
            Some(v) => Cell::text(&format!("{:.3}", 100.0 * v)),
            None => Cell::number(None),
        });
        row.push(rating_cell(rating));
        if !residual.is_empty() {
            let key = (
                t.key(drift::DIRECTION.name, r).unwrap_or_default(),
                t.key(drift::STOREY.name, r)
                    .and_then(|s| s.parse::<i32>().ok())
                    .map(|s| format!("L{}–L{s}", s - 1))
                    .unwrap_or_default(),
            );
            row.push(Cell::number(residual.get(&key).copied()));
        }
        rows.push(row);
        if let (Some(v), Some(rating)) = (v, rating) {
            out.push(Assessment {
                criterion: "peak inter-storey drift ratio".into(),
                subject: format!(
                    "storey {}, direction {}",
                    t.key(drift::STOREY.name, r).unwrap_or_else(|| "?".into()),
                    t.key(drift::DIRECTION.name, r)
                        .unwrap_or_else(|| "?".into())
                ),
                value: v,
                rating,
                source: tables::DRIFT.file.into(),
            });
        }
    }
    body.push_str(&table(Some("drift-table"), &headers, &rows));
    // Drift profile: storey on the vertical axis, one line per direction.
    if t.has(drift::STOREY.name) {
        let mut chart = Chart::new(
            520,
            300,
            "peak inter-storey drift ratio",
            drift::STOREY.name,
        );
        for (i, (dir, rows)) in t.groups(&[drift::DIRECTION.name]).into_iter().enumerate() {
            let mut pts: Vec<(f64, f64)> =
                rows_points(t, &rows, drift::PEAK_DRIFT_RATIO.name, drift::STOREY.name);
            pts.sort_by(|a, b| a.1.total_cmp(&b.1));
            chart.series.push(Series::new(
                format!("direction {}", dir.join("")),
                pts,
                i,
                Mark::LinePoints,
            ));
        }
        let max = ratio.iter().flatten().fold(0.0f64, |a, b| a.max(*b));
        chart.x_range = Some((0.0, (1.1 * max).max(1.1 * th.yellow)));
        chart.ref_lines.push(RefLine {
            at: th.yellow,
            horizontal: false,
            colour: 4,
        });
        chart.ref_lines.push(RefLine {
            at: th.red,
            horizontal: false,
            colour: 1,
        });
        let legend = plot::legend(&chart.series);
        body.push_str(&figure(
            plot::render(&chart),
            "Peak drift ratio per storey; dashed lines: yellow (orange) and red (vermillion) thresholds",
            &legend,
        ));
    }
    body
}
