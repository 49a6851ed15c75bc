//! Section 8, Bouc-Wen fit: identified parameters, instantaneous exponent and
//! force–drift loops of record and model.

use std::path::Path;

use super::{figure, known_columns_first, load, require, rows_points, stride};
use crate::report::html::{cells, column_notes, missing_columns_note, note, table};
use crate::report::plot::{self, Chart, Mark, Series};
use crate::report::ReportSettings;
use crate::vocab::tables::{self, bouc_wen, bouc_wen_instantaneous, hysteresis_fit};

pub(super) fn hysteresis_section(dir: &Path, settings: &ReportSettings) -> String {
    let mut body = String::new();
    let fit = load(dir, &tables::HYSTERESIS_FIT, None);
    let params = load(dir, &tables::BOUC_WEN, None);
    body.push_str("<h3>Identified Bouc-Wen parameters</h3>");
    if let Some(t) = require(&params, &tables::BOUC_WEN, &mut body) {
        // Long layout (one row per parameter: `parameter`, `value`, `unit`…)
        // or wide (one column per parameter).
        let known: &[&str] = if t.has(bouc_wen::PARAMETER.name) && t.has(bouc_wen::VALUE.name) {
            &[
                bouc_wen::DIRECTION.name,
                bouc_wen::DOF.name,
                bouc_wen::PARAMETER.name,
                bouc_wen::COUPLED_DOF.name,
                bouc_wen::VALUE.name,
                bouc_wen::UNIT.name,
                bouc_wen::STABILITY_STD.name,
                bouc_wen::STABLE.name,
                bouc_wen::STATUS.name,
                bouc_wen::COST_J.name,
            ]
        } else {
            &[
                bouc_wen::DIRECTION.name,
                bouc_wen::DOF.name,
                "k0_n_m",
                "beta",
                "gamma",
                "n_exponent",
                bouc_wen::COST_J.name,
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
    let inst = load(dir, &tables::BOUC_WEN_INSTANTANEOUS, None);
    if let Some(t) = require(&inst, &tables::BOUC_WEN_INSTANTANEOUS, &mut body) {
        let keys: Vec<&str> = [
            bouc_wen_instantaneous::DIRECTION.name,
            bouc_wen_instantaneous::DOF.name,
        ]
        .into_iter()
        .filter(|k| t.has(k))
        .collect();
        if t.number(bouc_wen_instantaneous::T_S.name).is_some()
            && t.number(bouc_wen_instantaneous::N_EXPONENT.name).is_some()
        {
            let mut chart = Chart::new(560, 260, "end of growing window t (s)", "exponent N");
            for (i, (key, rows)) in t.groups(&keys).into_iter().enumerate() {
                let label = group_label(&keys, &key);
                let pts = rows_points(
                    t,
                    &rows,
                    bouc_wen_instantaneous::T_S.name,
                    bouc_wen_instantaneous::N_EXPONENT.name,
                );
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
    if let Some(t) = require(&fit, &tables::HYSTERESIS_FIT, &mut body) {
        let known = [
            hysteresis_fit::DIRECTION.name,
            hysteresis_fit::DOF.name,
            hysteresis_fit::T_S.name,
            hysteresis_fit::DRIFT_M.name,
            hysteresis_fit::FORCE_RECORD_N.name,
            hysteresis_fit::FORCE_MODEL_N.name,
        ];
        body.push_str(&column_notes(t, &known));
        if !t.has(hysteresis_fit::DRIFT_M.name)
            || !(t.has(hysteresis_fit::FORCE_RECORD_N.name)
                || t.has(hysteresis_fit::FORCE_MODEL_N.name))
        {
            return body;
        }
        let keys: Vec<&str> = [hysteresis_fit::DIRECTION.name, hysteresis_fit::DOF.name]
            .into_iter()
            .filter(|k| t.has(k))
            .collect();
        body.push_str("<div class=\"multiples\">");
        for (key, rows) in t.groups(&keys) {
            let kn = |col: &str| -> Vec<(f64, f64)> {
                let pts: Vec<(f64, f64)> = rows_points(t, &rows, hysteresis_fit::DRIFT_M.name, col)
                    .into_iter()
                    .map(|(d, f)| (d, f / 1000.0))
                    .collect();
                stride(pts, settings.max_points_per_trace)
            };
            let mut chart = Chart::new(440, 300, "inter-storey drift (m)", "storey force (kN)");
            chart.series.push(Series::new(
                "record",
                kn(hysteresis_fit::FORCE_RECORD_N.name),
                0,
                Mark::Line,
            ));
            chart.series.push(Series::new(
                "model",
                kn(hysteresis_fit::FORCE_MODEL_N.name),
                1,
                Mark::Dashed,
            ));
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
