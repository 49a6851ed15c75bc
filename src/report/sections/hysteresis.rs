//! Section 8, Bouc-Wen fit: identified parameters, instantaneous exponent and
//! force–drift loops of record and model.

use std::path::Path;

use super::{figure, known_columns_first, load, require, rows_points, stride};
use crate::report::html::{cells, column_notes, missing_columns_note, note, table};
use crate::report::plot::{self, Chart, Mark, Series};
use crate::report::ReportSettings;

pub(super) fn hysteresis_section(dir: &Path, settings: &ReportSettings) -> String {
    let mut body = String::new();
    let fit = load(dir, "hysteresis_fit.parquet", None);
    let params = load(dir, "bouc_wen.parquet", None);
    body.push_str("<h3>Identified Bouc-Wen parameters</h3>");
    if let Some(t) = require(&params, "bouc_wen.parquet", &mut body) {
        // Long layout (one row per parameter: `parameter`, `value`, `unit`…)
        // or wide (one column per parameter).
        let known: &[&str] = if t.has("parameter") && t.has("value") {
            &[
                "direction",
                "dof",
                "parameter",
                "coupled_dof",
                "value",
                "unit",
                "stability_std",
                "stable",
                "status",
                "cost_j",
            ]
        } else {
            &[
                "direction",
                "dof",
                "k0_n_m",
                "beta",
                "gamma",
                "n_exponent",
                "cost_j",
            ]
        };
        body.push_str(&missing_columns_note(t, known));
        let cols = known_columns_first(t, known);
        let rows = cells(t, &cols, settings.max_table_rows);
        body.push_str(&format!(
            "<div class=\"scroll\">{}</div>",
            table(Some("bouc-wen-table"), &cols, &rows)
        ));
    }
    body.push_str("<h3>Instantaneous estimates</h3>");
    let inst = load(dir, "bouc_wen_instantaneous.parquet", None);
    if let Some(t) = require(&inst, "bouc_wen_instantaneous.parquet", &mut body) {
        let keys: Vec<&str> = ["direction", "dof"]
            .into_iter()
            .filter(|k| t.has(k))
            .collect();
        if t.number("t_s").is_some() && t.number("n_exponent").is_some() {
            let mut chart = Chart::new(560, 260, "end of growing window t (s)", "exponent N");
            for (i, (key, rows)) in t.groups(&keys).into_iter().enumerate() {
                let label = group_label(&keys, &key);
                let pts = rows_points(t, &rows, "t_s", "n_exponent");
                chart.series.push(Series::new(
                    label,
                    plot::decimate_min_max(&pts, settings.max_points_per_trace),
                    i,
                    Mark::Line,
                ));
            }
            let legend = plot::legend(&chart.series);
            body.push_str(&figure(
                plot::render(&chart),
                "Instantaneous Bouc-Wen exponent N(t) (growing window)",
                &legend,
            ));
        } else {
            body.push_str(&note(
                "bouc_wen_instantaneous.parquet: columns t_s and n_exponent needed for the plot.",
            ));
        }
        body.push_str(&note(&format!(
            "bouc_wen_instantaneous.parquet columns: {}.",
            t.names.join(", ")
        )));
    }
    body.push_str("<h3>Hysteresis loops: record and model</h3>");
    if let Some(t) = require(&fit, "hysteresis_fit.parquet", &mut body) {
        let known = [
            "direction",
            "dof",
            "t_s",
            "drift_m",
            "force_record_n",
            "force_model_n",
        ];
        body.push_str(&column_notes(t, &known));
        if !t.has("drift_m") || !(t.has("force_record_n") || t.has("force_model_n")) {
            return body;
        }
        let keys: Vec<&str> = ["direction", "dof"]
            .into_iter()
            .filter(|k| t.has(k))
            .collect();
        body.push_str("<div class=\"multiples\">");
        for (key, rows) in t.groups(&keys) {
            let kn = |col: &str| -> Vec<(f64, f64)> {
                let pts: Vec<(f64, f64)> = rows_points(t, &rows, "drift_m", col)
                    .into_iter()
                    .map(|(d, f)| (d, f / 1000.0))
                    .collect();
                stride(pts, settings.max_points_per_trace)
            };
            let mut chart = Chart::new(440, 300, "inter-storey drift (m)", "storey force (kN)");
            chart
                .series
                .push(Series::new("record", kn("force_record_n"), 0, Mark::Line));
            chart
                .series
                .push(Series::new("model", kn("force_model_n"), 1, Mark::Dashed));
            let label = group_label(&keys, &key);
            let legend = plot::legend(&chart.series);
            body.push_str(&figure(
                plot::render(&chart),
                &format!("Force–drift loop, {label}"),
                &legend,
            ));
        }
        body.push_str("</div>");
    }
    body
}

/// "direction X, dof 2": a group's key columns with their values.
fn group_label(keys: &[&str], key: &[String]) -> String {
    keys.iter()
        .zip(key)
        .map(|(k, v)| format!("{k} {v}"))
        .collect::<Vec<_>>()
        .join(", ")
}
