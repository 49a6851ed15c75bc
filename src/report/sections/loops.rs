//! Section 8, force–drift loops (hysteresis_fit.parquet): the measured loop
//! of every storey or segment — also where the model is not identified — with
//! the model's on top where it is, and the peak and residual drift of the
//! displacement the loops are drawn from.

use super::{figure, rows_points};
use crate::report::html::{column_notes, note, table, Cell};
use crate::report::plot::{self, Chart, Mark, Series};
use crate::report::table::Table;
use crate::report::ReportSettings;
use crate::vocab::tables::hysteresis_fit;

/// Share of the record (its end) over which the residual drift is averaged.
pub const RESIDUAL_WINDOW: f64 = 0.05;

/// The storey drift of one loop's rows, in time order.
fn drift_series(t: &Table, rows: &[usize]) -> Vec<f64> {
    rows_points(
        t,
        rows,
        hysteresis_fit::T_S.name,
        hysteresis_fit::DRIFT_M.name,
    )
    .into_iter()
    .map(|p| p.1)
    .collect()
}

/// Peak |drift| and residual drift (mean over the last `RESIDUAL_WINDOW` of
/// the rows, in time order) of one loop, m.
pub fn peak_and_residual(drift: &[f64]) -> Option<(f64, f64)> {
    if drift.is_empty() {
        return None;
    }
    let peak = drift.iter().fold(0.0f64, |m, d| m.max(d.abs()));
    let tail = ((drift.len() as f64 * RESIDUAL_WINDOW).ceil() as usize).clamp(1, drift.len());
    let end = &drift[drift.len() - tail..];
    Some((peak, end.iter().sum::<f64>() / end.len() as f64))
}

/// Residual drift (m) per (direction, segment) of a hysteresis_fit table.
pub(super) fn residual_drifts(t: &Table) -> std::collections::BTreeMap<(String, String), f64> {
    let mut out = std::collections::BTreeMap::new();
    let keys = [hysteresis_fit::DIRECTION.name, hysteresis_fit::DOF.name];
    if !keys.iter().all(|k| t.has(k)) || !t.has(hysteresis_fit::SEGMENT.name) {
        return out;
    }
    for (key, rows) in t.groups(&keys) {
        let Some(segment) = rows
            .first()
            .and_then(|&r| t.key(hysteresis_fit::SEGMENT.name, r))
        else {
            continue;
        };
        let drift = drift_series(t, &rows);
        if let Some((_, residual)) = peak_and_residual(&drift) {
            out.insert((key[0].clone(), segment), residual);
        }
    }
    out
}

pub(super) fn loops_section(
    t: &Table,
    velocity_drift: Option<&str>,
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
        "Loops and the drift columns below use the displacement the hysteresis stage integrates from the as-recorded accelerations \
         (no band-pass; velocity drift control: {}), so a permanent offset shows as residual drift: the mean drift over the last {:.0} % \
         of the record. The peak drift ratios of the inter-storey drift section come from the band-passed displacements of the \
         condition stage: a band-pass removes a permanent offset by construction, so they measure the oscillation only and stay below \
         the loops' extremes when residual drift builds up. Force: storey (segment) shear V = Σ of −m (a + ü) over the instrumented \
         levels above (Eq. 46, lumped masses).",
        velocity_drift.unwrap_or("see quaketwin.settings of bouc_wen.parquet"),
        100.0 * RESIDUAL_WINDOW
    )));
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
            plot::decimate_curve(&pts, settings.max_points_per_trace)
        };
        let record = kn(hysteresis_fit::FORCE_RECORD_N.name);
        let model = kn(hysteresis_fit::FORCE_MODEL_N.name);
        let identified = !model.is_empty();
        let drift = drift_series(t, &rows);
        if let Some((peak, residual)) = peak_and_residual(&drift) {
            rows_html.push(vec![
                Cell::text(&direction),
                Cell::text(&segment),
                Cell::number(Some(peak)),
                Cell::number(Some(residual)),
                Cell::text(if identified {
                    "yes"
                } else {
                    "no: measured loop only"
                }),
            ]);
        }
        let mut chart = Chart::new(440, 300, "storey drift (m)", "storey shear (kN)");
        chart
            .series
            .push(Series::new("record", record, 0, Mark::Line));
        if identified {
            chart
                .series
                .push(Series::new("model", model, 1, Mark::Dashed));
        }
        let legend = plot::legend(&chart.series);
        let caption = if identified {
            format!("Force–drift loop, direction {direction}, storey {segment}")
        } else {
            format!(
                "Measured force–drift loop, direction {direction}, storey {segment} (model not identified: see the reason in the parameter table)"
            )
        };
        figures.push_str(&figure(plot::render(&chart), &caption, &legend));
    }
    figures.push_str("</div>");
    let headers: Vec<String> = [
        "direction",
        "storey (segment)",
        "peak |drift| (m)",
        "residual drift (m)",
        "model identified",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    body.push_str(&table(Some("loop-drift-table"), &headers, &rows_html));
    body.push_str(&figures);
    body
}
