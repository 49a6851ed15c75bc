//! Digital-twin update: the parameters before and after (start, calibrated,
//! change, bounds), the measured against the model modes before and after,
//! and the ensemble rounds.  The raw candidate rows are in the appendix.

use serde_json::Value;

use super::{require, Outputs};
use crate::report::format_number;
use crate::report::html::{escape, note, table, Cell};
use crate::report::table::Table;
use crate::report::ReportSettings;
use crate::vocab::tables::{self, twin_modes, twin_update};

/// One parameter of the update.
pub(super) struct ParameterChange {
    pub name: String,
    pub unit: Option<String>,
    pub start: Option<f64>,
    pub calibrated: Option<f64>,
    pub lower: Option<f64>,
    pub upper: Option<f64>,
}

impl ParameterChange {
    /// 100 (calibrated − start) / start.
    pub fn change_percent(&self) -> Option<f64> {
        match (self.start, self.calibrated) {
            (Some(s), Some(c)) if s != 0.0 => Some(100.0 * (c - s) / s),
            _ => None,
        }
    }
}

fn meta_json(t: &Table, key: &str) -> Option<Value> {
    t.metadata
        .get(key)
        .and_then(|s| serde_json::from_str(s).ok())
}

/// The parameters from twin_update/twin_update.parquet's metadata: names
/// (`quaketwin.parameters`), calibrated values (`quaketwin.result`), start
/// values and bounds (`quaketwin.parameter_bounds`; for files without it the
/// first round's start point, no bounds).
pub(super) fn parameter_changes(t: &Table) -> Vec<ParameterChange> {
    let names: Vec<String> = meta_json(t, "quaketwin.parameters")
        .and_then(|v| serde_json::from_value(v).ok())
        .unwrap_or_default();
    let result: Vec<f64> = meta_json(t, "quaketwin.result")
        .and_then(|v| serde_json::from_value(v.get("parameters")?.clone()).ok())
        .unwrap_or_default();
    let bounds: Vec<Value> = meta_json(t, "quaketwin.parameter_bounds")
        .and_then(|v| v.as_array().cloned())
        .unwrap_or_default();
    let first_start: Vec<f64> = meta_json(t, "quaketwin.rounds")
        .and_then(|v| serde_json::from_value(v.get(0)?.get("start")?.clone()).ok())
        .unwrap_or_default();
    names
        .into_iter()
        .enumerate()
        .map(|(i, name)| {
            let b = bounds
                .iter()
                .find(|b| b.get("name").and_then(Value::as_str) == Some(name.as_str()));
            let num = |k: &str| b.and_then(|b| b.get(k)).and_then(Value::as_f64);
            ParameterChange {
                unit: b
                    .and_then(|b| b.get("unit"))
                    .and_then(Value::as_str)
                    .map(str::to_string),
                start: num("start").or_else(|| first_start.get(i).copied()),
                calibrated: result.get(i).copied(),
                lower: num("lower"),
                upper: num("upper"),
                name,
            }
        })
        .collect()
}

pub(super) fn twin_section(o: &Outputs, settings: &ReportSettings) -> String {
    let mut body = String::new();
    body.push_str("<h3>Parameters: start and calibrated</h3>");
    if let Some(t) = require(&o.twin_update, &tables::TWIN_UPDATE, &mut body) {
        body.push_str(&parameters_table(t));
        body.push_str(&rounds_table(t, settings));
    }
    body.push_str("<h3>Modes: measured against the twin, before and after</h3>");
    if let Some(t) = require(&o.twin_modes, &tables::TWIN_MODES, &mut body) {
        body.push_str(&modes_table(t));
    }
    body
}

fn parameters_table(t: &Table) -> String {
    let changes = parameter_changes(t);
    if changes.is_empty() {
        return note("The twin update names no parameters.");
    }
    let converged = meta_json(t, "quaketwin.result")
        .and_then(|r| r.get("converged")?.as_bool())
        .map(|c| if c { "converged" } else { "not converged" })
        .unwrap_or("convergence not recorded");
    let mut html = note(&format!(
        "Calibrated values from the ensemble update ({converged}); start values and bounds as the \
         update used them. A value at a bound means the data pull it further than the bounds allow."
    ));
    let rows: Vec<Vec<Cell>> = changes
        .iter()
        .map(|p| {
            let at_bound = match (p.calibrated, p.lower, p.upper) {
                (Some(c), Some(l), Some(u)) => {
                    let tol = 1e-6 * (u - l).abs();
                    if (c - l).abs() <= tol {
                        "at lower bound"
                    } else if (u - c).abs() <= tol {
                        "at upper bound"
                    } else {
                        "inside"
                    }
                }
                _ => "—",
            };
            vec![
                Cell::text(&p.name),
                Cell::text(p.unit.as_deref().unwrap_or("")),
                Cell::number(p.start),
                Cell::number(p.calibrated),
                Cell::number(p.change_percent()),
                Cell::number(p.lower),
                Cell::number(p.upper),
                Cell::text(at_bound),
            ]
        })
        .collect();
    html.push_str(&table(
        Some("twin-parameters"),
        &[
            "parameter",
            "unit",
            "start",
            "calibrated",
            "change (%)",
            "lower bound",
            "upper bound",
            "calibrated value",
        ]
        .map(String::from),
        &rows,
    ));
    html
}

/// Per round: the selected candidate's solver and J (the rows with
/// `selected`), and the round count.
fn rounds_table(t: &Table, settings: &ReportSettings) -> String {
    let (Some(round), Some(selected)) = (
        t.number(twin_update::ROUND.name),
        t.boolean(twin_update::SELECTED.name),
    ) else {
        return String::new();
    };
    let rows: Vec<Vec<Cell>> = (0..t.rows)
        .filter(|&r| selected.get(r).copied().flatten() == Some(true))
        .take(settings.max_table_rows)
        .map(|r| {
            vec![
                Cell::integer(round.get(r).copied().flatten()),
                Cell::of(t, twin_update::SOLVER.name, r),
                Cell::of(t, twin_update::OBJECTIVE_J.name, r),
                Cell::of(t, twin_update::SELECTION_WEIGHT.name, r),
                Cell::of(t, twin_update::EVALUATIONS.name, r),
            ]
        })
        .collect();
    let mut html = note(
        "Ensemble rounds: the candidate each round selected (every candidate, with its scores per voter, is in the appendix).",
    );
    html.push_str(&table(
        Some("twin-rounds"),
        &[
            "round",
            "selected solver",
            "objective J",
            "selection weight",
            "evaluations",
        ]
        .map(String::from),
        &rows,
    ));
    html
}

/// Measured frequency, then per stage (initial, updated) the paired model
/// frequency, its error and the MAC — one row per measured mode.
fn modes_table(t: &Table) -> String {
    let mut by_mode: std::collections::BTreeMap<i64, [Option<usize>; 2]> = Default::default();
    let Some(modes) = t.number(twin_modes::MODE.name) else {
        return note("The twin modes carry no mode numbers.");
    };
    for r in 0..t.rows {
        let Some(m) = modes.get(r).copied().flatten() else {
            continue;
        };
        let slot = match t.key(twin_modes::STAGE.name, r).as_deref() {
            Some("initial") => 0,
            Some("updated") => 1,
            _ => continue,
        };
        by_mode.entry(m as i64).or_default()[slot] = Some(r);
    }
    let num = |c: &str, r: Option<usize>| {
        r.and_then(|r| t.number(c).and_then(|v| v.get(r).copied().flatten()))
    };
    let rows: Vec<Vec<Cell>> = by_mode
        .iter()
        .map(|(m, [before, after])| {
            let mut row = vec![
                Cell::text(&m.to_string()),
                Cell::number(num(twin_modes::F_EXP_HZ.name, before.or(*after))),
            ];
            for r in [before, after] {
                row.push(Cell::number(num(twin_modes::F_NUM_HZ.name, *r)));
                row.push(Cell::number(
                    num(twin_modes::REL_ERROR.name, *r).map(|e| 100.0 * e),
                ));
                row.push(Cell::number(num(twin_modes::MAC.name, *r)));
            }
            row
        })
        .collect();
    let mut html = String::new();
    if let Some(s) = meta_json(t, "quaketwin.summary") {
        let get = |stage: &str, k: &str| s.get(stage)?.get(k)?.as_f64();
        if let (Some(f0), Some(f1)) = (
            get("initial", "frequency_error"),
            get("updated", "frequency_error"),
        ) {
            let mut text = format!(
                "Mean frequency error {} % → {} %",
                format_number(100.0 * f0),
                format_number(100.0 * f1)
            );
            if let (Some(s0), Some(s1)) =
                (get("initial", "shape_error"), get("updated", "shape_error"))
            {
                text.push_str(&format!(
                    "; mean (1 − MAC) {} → {}",
                    format_number(s0),
                    format_number(s1)
                ));
            }
            html.push_str(&format!(
                "<p id=\"twin-summary\">{} (unpaired modes count 1).</p>",
                escape(&text)
            ));
        }
    }
    html.push_str(&table(
        Some("twin-modes"),
        &[
            "mode",
            "f measured (Hz)",
            "f twin before (Hz)",
            "error before (%)",
            "MAC before",
            "f twin after (Hz)",
            "error after (%)",
            "MAC after",
        ]
        .map(String::from),
        &rows,
    ));
    html
}
