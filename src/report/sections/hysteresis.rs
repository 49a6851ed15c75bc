//! Bouc-Wen fit: per storey the test of the hysteretic terms, the identified
//! parameters, why a direction is not identifiable, the instantaneous
//! exponent and the force–drift loops (`loops`).

use std::path::Path;

use super::{known_columns_first, load, require, rows_points, time_series_figure, Loaded, Outputs};
use crate::report::html::{escape, missing_columns_note, note, table, Cell};
use crate::report::plot::Chart;
use crate::report::table::Table;
use crate::report::ReportSettings;
use crate::vocab::tables::{self, bouc_wen, bouc_wen_instantaneous};

/// Columns that hold one value per storey (repeated on its parameter rows):
/// shown once per storey, not on every parameter.
const PER_STOREY: [&str; 7] = [
    bouc_wen::STATUS.name,
    bouc_wen::REASON.name,
    bouc_wen::COST_J.name,
    bouc_wen::COST_RELATIVE.name,
    bouc_wen::HYSTERETIC_SHARE.name,
    bouc_wen::F_STATISTIC.name,
    bouc_wen::P_VALUE.name,
];

pub(super) fn hysteresis_section(dir: &Path, o: &Outputs, settings: &ReportSettings) -> String {
    let mut body = String::new();
    let fit = load(dir, &tables::HYSTERESIS_FIT, None);
    let params = load(dir, &tables::BOUC_WEN, None);
    body.push_str("<h3>Identified Bouc-Wen parameters</h3>");
    if let Some(t) = require(&params, &tables::BOUC_WEN, &mut body) {
        if t.has(bouc_wen::PARAMETER.name) && t.has(bouc_wen::VALUE.name) {
            body.push_str(&long_parameters(t, settings));
        } else {
            // A wide layout (one column per parameter) from another writer.
            let known = [
                bouc_wen::DIRECTION.name,
                bouc_wen::DOF.name,
                "k0_n_m",
                "beta",
                "gamma",
                "n_exponent",
                bouc_wen::COST_J.name,
            ];
            body.push_str(&missing_columns_note(t, &known));
            let cols = known_columns_first(t, &known);
            let rows: Vec<usize> = (0..t.rows.min(settings.max_table_rows)).collect();
            body.push_str(&rows_table("bouc-wen-table", t, &cols, &rows));
        }
    }
    body.push_str("<h3>Instantaneous estimates</h3>");
    let inst = load(dir, &tables::BOUC_WEN_INSTANTANEOUS, None);
    if let Some(t) = require(&inst, &tables::BOUC_WEN_INSTANTANEOUS, &mut body) {
        body.push_str(&instantaneous(t, o.time_axis, settings));
    }
    body.push_str("<h3>Force–drift loops: measured and model</h3>");
    if let Some(t) = require(&fit, &tables::HYSTERESIS_FIT, &mut body) {
        let velocity_drift = match &params {
            Loaded::Ok(p) => p
                .metadata
                .get("quaketwin.settings")
                .and_then(|s| serde_json::from_str::<serde_json::Value>(s).ok())
                .and_then(|v| v.get("velocity_drift")?.as_str().map(str::to_string)),
            _ => None,
        };
        let samples =
            super::listed(dir, tables::SAMPLES.file).then(|| dir.join(tables::SAMPLES.file));
        body.push_str(&super::loops::loops_section(
            t,
            velocity_drift.as_deref(),
            &o.drift,
            samples.as_deref(),
            settings,
        ));
    }
    body
}

/// A table of `rows` of `t` in the columns `cols`.
fn rows_table(id: &str, t: &Table, cols: &[String], rows: &[usize]) -> String {
    let cells: Vec<Vec<Cell>> = rows
        .iter()
        .map(|&r| cols.iter().map(|c| Cell::of(t, c, r)).collect())
        .collect();
    format!(
        "<div class=\"scroll\">{}</div>",
        table(Some(id), cols, &cells)
    )
}

/// The long layout (one row per direction, DoF and parameter): per storey
/// the status and the F-test of the hysteretic terms, then the parameters
/// of the identified storeys, then why a direction is not identifiable —
/// the reason as written, which states F and p where the test decided.
fn long_parameters(t: &Table, settings: &ReportSettings) -> String {
    let mut body = String::new();
    let known = [
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
    ];
    body.push_str(&missing_columns_note(t, &known));
    let not_identifiable =
        |r: usize| t.key(bouc_wen::STATUS.name, r).as_deref() == Some("not_identifiable");
    let identified: Vec<usize> = (0..t.rows).filter(|&r| !not_identifiable(r)).collect();
    // Per storey: one row per (direction, dof) of the identified rows.
    let storey_keys: Vec<&str> = [
        bouc_wen::DIRECTION.name,
        bouc_wen::DOF.name,
        bouc_wen::SEGMENT.name,
    ]
    .into_iter()
    .filter(|c| t.has(c))
    .collect();
    let per_storey: Vec<&str> = PER_STOREY
        .into_iter()
        .filter(|c| t.has(c) && *c != bouc_wen::REASON.name)
        .collect();
    if !identified.is_empty() && !per_storey.is_empty() {
        let mut seen = std::collections::BTreeSet::new();
        let firsts: Vec<usize> = identified
            .iter()
            .copied()
            .filter(|&r| {
                seen.insert(
                    storey_keys
                        .iter()
                        .map(|k| t.key(k, r).unwrap_or_default())
                        .collect::<Vec<_>>(),
                )
            })
            .collect();
        let cols: Vec<String> = storey_keys
            .iter()
            .chain(&per_storey)
            .map(|s| s.to_string())
            .collect();
        body.push_str(&note(
            "Per storey: status, the fit cost and the F-test of the hysteretic terms (β, γ, N) against the nested linear \
             model — identifiable when p < the significance level.",
        ));
        body.push_str(&rows_table("bouc-wen-storeys", t, &cols, &firsts));
    }
    if !identified.is_empty() {
        let cols: Vec<String> = known_columns_first(t, &known)
            .into_iter()
            .filter(|c| !PER_STOREY.contains(&c.as_str()))
            .collect();
        let shown: Vec<usize> = identified
            .iter()
            .copied()
            .take(settings.max_table_rows)
            .collect();
        body.push_str(&rows_table("bouc-wen-table", t, &cols, &shown));
        if identified.len() > shown.len() {
            body.push_str(&note(&format!(
                "Showing {} of {} parameter rows.",
                shown.len(),
                identified.len()
            )));
        }
    }
    let reasons: Vec<String> = (0..t.rows)
        .filter(|&r| not_identifiable(r))
        .map(|r| {
            // The F-test finding nothing is not a finding of a linear response.
            let what = match t.key(bouc_wen::VERDICT.name, r).as_deref() {
                Some("no_significant_hysteresis") => {
                    "no significant hysteresis seen by the F-test (not a finding of a linear, undamaged response: docs/hysteresis.md)"
                }
                _ => "not identifiable",
            };
            format!(
                "<li><b>Direction {}</b>: {what} — {}</li>",
                escape(&t.key(bouc_wen::DIRECTION.name, r).unwrap_or_default()),
                escape(&t.key(bouc_wen::REASON.name, r).unwrap_or_default())
            )
        })
        .collect();
    if !reasons.is_empty() {
        body.push_str(&format!(
            "<ul class=\"not-identifiable\">{}</ul>",
            reasons.join("")
        ));
    }
    body
}

/// Instantaneous exponent N(t) per (direction, DoF), on the page's time axis.
fn instantaneous(t: &Table, time_axis: Option<(f64, f64)>, settings: &ReportSettings) -> String {
    let keys: Vec<&str> = [
        bouc_wen_instantaneous::DIRECTION.name,
        bouc_wen_instantaneous::DOF.name,
    ]
    .into_iter()
    .filter(|k| t.has(k))
    .collect();
    if t.number(bouc_wen_instantaneous::T_S.name).is_none()
        || t.number(bouc_wen_instantaneous::N_EXPONENT.name).is_none()
    {
        return note("The instantaneous estimates lack their times or exponents: not drawn.");
    }
    let series = t
        .groups(&keys)
        .into_iter()
        .map(|(key, rows)| {
            let label = keys
                .iter()
                .zip(&key)
                .map(|(k, v)| format!("{k} {v}"))
                .collect::<Vec<_>>()
                .join(", ");
            let pts = rows_points(
                t,
                &rows,
                bouc_wen_instantaneous::T_S.name,
                bouc_wen_instantaneous::N_EXPONENT.name,
            );
            (label, pts)
        })
        .collect();
    time_series_figure(
        Chart::new(560, 260, "end of growing window t (s)", "exponent N"),
        series,
        time_axis,
        settings,
        "Instantaneous Bouc-Wen exponent N(t) (growing window)",
    )
}
