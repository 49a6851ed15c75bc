//! Force–drift loops (hysteresis_fit.parquet): the measured loop of every
//! storey or segment — also where the model is not identified — with the
//! model's on top where it is, drawn as curves (decimated in time order,
//! `plot::decimate_curve`), and each loop's peak drift and end offset beside
//! the baseline-corrected residual drift of the drift section.

use std::collections::BTreeMap;

use super::drift::{residual, residual_text, Residual};
use super::{figure_with, rows_points, Loaded};
use crate::report::html::{column_notes, note, table, Cell};
use crate::report::plot::{self, Chart, Mark, Series};
use crate::report::table::Table;
use crate::report::ReportSettings;
use crate::vocab::tables::{drift, hysteresis_fit};

/// Share of the record (its end) over which a loop's end offset is averaged.
pub const END_WINDOW: f64 = 0.05;

/// Share of the data range left free on each side of a loop's axes.
const LOOP_PAD: f64 = 0.08;

/// Peak |drift| and the mean drift over the last [`END_WINDOW`] of the
/// samples (in time order) of one loop, m.
pub fn peak_and_end(drift: &[f64]) -> Option<(f64, f64)> {
    if drift.is_empty() {
        return None;
    }
    let peak = drift.iter().fold(0.0f64, |m, d| m.max(d.abs()));
    let tail = ((drift.len() as f64 * END_WINDOW).ceil() as usize).clamp(1, drift.len());
    let end = &drift[drift.len() - tail..];
    Some((peak, end.iter().sum::<f64>() / end.len() as f64))
}

/// Residual drift of drift.parquet per (direction, segment `L<s−1>-L<s>`).
fn corrected_residuals(drift_table: &Loaded) -> BTreeMap<(String, String), Residual> {
    let mut out = BTreeMap::new();
    let Loaded::Ok(t) = drift_table else {
        return out;
    };
    for r in 0..t.rows {
        let (Some(dir), Some(storey)) = (
            t.key(drift::DIRECTION.name, r),
            t.key(drift::STOREY.name, r)
                .and_then(|s| s.parse::<i32>().ok()),
        ) else {
            continue;
        };
        // The segment's lower level (tables before `lower_level`: storeys only).
        let lower = t
            .key(drift::LOWER_LEVEL.name, r)
            .and_then(|s| s.parse::<i32>().ok())
            .unwrap_or(storey - 1);
        if let Some(res) = residual(t, r) {
            out.insert((dir, format!("L{lower}-L{storey}")), res);
        }
    }
    out
}

pub(super) fn loops_section(
    t: &Table,
    velocity_drift: Option<&str>,
    drift_table: &Loaded,
    settings: &ReportSettings,
) -> String {
    let mut body = String::new();
    let known = [
        hysteresis_fit::DIRECTION.name,
        hysteresis_fit::DOF.name,
        hysteresis_fit::SEGMENT.name,
        hysteresis_fit::T_S.name,
        hysteresis_fit::DRIFT_M.name,
        hysteresis_fit::FORCE_RECORD_N.name,
        hysteresis_fit::FORCE_MODEL_N.name,
    ];
    body.push_str(&column_notes(t, &known));
    if !t.has(hysteresis_fit::DRIFT_M.name) || !t.has(hysteresis_fit::FORCE_RECORD_N.name) {
        return body;
    }
    body.push_str(&note(&format!(
        "Loops use the displacement the hysteresis stage integrates from the as-recorded accelerations (no band-pass; velocity \
         drift control: {}), so a permanent offset shows — and so does integrated sensor noise: the end offset (mean drift over the \
         last {:.0} % of the record) is not corrected for it. The residual drift of the inter-storey drift section is \
         baseline-corrected and carries its uncertainty. Force: storey (segment) shear V = Σ of −m (a + ü) over the instrumented \
         levels above (Eq. 46, lumped masses). Curves keep every reversal: decimated in time order to segments of at most {:.1} % \
         of either axis' data range (unless one sample step is longer) and at most {} points.",
        velocity_drift.unwrap_or("see quaketwin.settings of bouc_wen.parquet"),
        100.0 * END_WINDOW,
        100.0 * plot::CURVE_MAX_STEP,
        settings.max_points_per_loop
    )));
    let corrected = corrected_residuals(drift_table);
    let keys: Vec<&str> = [hysteresis_fit::DIRECTION.name, hysteresis_fit::DOF.name]
        .into_iter()
        .filter(|k| t.has(k))
        .collect();
    let mut figures = String::from("<div class=\"multiples\">");
    let mut rows_html = Vec::new();
    for (key, rows) in t.groups(&keys) {
        let segment = rows
            .first()
            .and_then(|&r| t.key(hysteresis_fit::SEGMENT.name, r))
            .unwrap_or_else(|| format!("dof {}", key.get(1).cloned().unwrap_or_default()));
        let direction = key.first().cloned().unwrap_or_default();
        let kn = |col: &str| -> Vec<(f64, f64)> {
            let pts: Vec<(f64, f64)> = rows_points(t, &rows, hysteresis_fit::DRIFT_M.name, col)
                .into_iter()
                .map(|(d, f)| (d, f / 1000.0))
                .collect();
            plot::decimate_curve(&pts, settings.max_points_per_loop)
        };
        let record = kn(hysteresis_fit::FORCE_RECORD_N.name);
        let model = kn(hysteresis_fit::FORCE_MODEL_N.name);
        let identified = !model.is_empty();
        let drift_series: Vec<f64> = rows_points(
            t,
            &rows,
            hysteresis_fit::T_S.name,
            hysteresis_fit::DRIFT_M.name,
        )
        .into_iter()
        .map(|p| p.1)
        .collect();
        if let Some((peak, end)) = peak_and_end(&drift_series) {
            let res = corrected.get(&(direction.clone(), segment.clone()));
            rows_html.push(vec![
                Cell::text(&direction),
                Cell::text(&segment),
                Cell::number(Some(peak)),
                Cell::number(Some(end)),
                match res {
                    Some(r) => Cell {
                        value: Some(r.drift_m),
                        class: Some("num"),
                        ..Cell::text(&residual_text(r))
                    },
                    None => Cell::number(None),
                },
                Cell::text(if identified {
                    "yes"
                } else {
                    "no: measured loop only"
                }),
            ]);
        }
        let mut chart = Chart::new(440, 320, "storey drift (m)", "storey shear (kN)");
        chart.x_pad = Some(LOOP_PAD);
        chart.y_pad = LOOP_PAD;
        chart
            .series
            .push(Series::new("measured", record, 0, Mark::Line));
        if identified {
            chart
                .series
                .push(Series::new("model", model, 1, Mark::Dashed));
        }
        let legend = plot::legend(&chart.series);
        let caption = if identified {
            format!("Force–drift loop, direction {direction}, storey {segment}: measured and model")
        } else {
            format!(
                "Measured force–drift loop, direction {direction}, storey {segment} (model not identified: see the reason above)"
            )
        };
        figures.push_str(&figure_with(
            "class=\"loop\"",
            plot::render(&chart),
            &caption,
            &legend,
        ));
    }
    figures.push_str("</div>");
    let headers: Vec<String> = [
        "direction",
        "storey (segment)",
        "peak |drift| (m)",
        "end offset (m, uncorrected)",
        "residual drift (baseline-corrected)",
        "model identified",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    body.push_str(&table(Some("loop-drift-table"), &headers, &rows_html));
    body.push_str(&figures);
    body
}
