//! Section 8, Bouc-Wen fit: identified parameters (and why a direction is
//! not identifiable), instantaneous exponent and force–drift loops
//! (`loops`).

use std::path::Path;

use super::{figure, known_columns_first, load, require, rows_points};
use crate::report::html::{cells, missing_columns_note, note, table};
use crate::report::plot::{self, Chart, Mark, Series};
use crate::report::ReportSettings;
use crate::vocab::tables::{self, bouc_wen, bouc_wen_instantaneous};

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
                bouc_wen::SEGMENT.name,
                bouc_wen::PARAMETER.name,
                bouc_wen::COUPLED_DOF.name,
                bouc_wen::VALUE.name,
                bouc_wen::UNIT.name,
                bouc_wen::STABILITY_STD.name,
                bouc_wen::STABLE.name,
                bouc_wen::STATUS.name,
                bouc_wen::REASON.name,
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
    body.push_str("<h3>Force–drift loops: record and model</h3>");
    if let Some(t) = require(&fit, &tables::HYSTERESIS_FIT, &mut body) {
        let velocity_drift = match &params {
            super::Loaded::Ok(p) => p
                .metadata
                .get("quaketwin.settings")
                .and_then(|s| serde_json::from_str::<serde_json::Value>(s).ok())
                .and_then(|v| v.get("velocity_drift")?.as_str().map(str::to_string)),
            _ => None,
        };
        body.push_str(&super::loops::loops_section(
            t,
            velocity_drift.as_deref(),
            settings,
        ));
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
