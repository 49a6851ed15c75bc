//! Part of the hybrid-test design section: the rehearsal (rehearsal_summary/rehearsal_summary.parquet,
//! rehearsal/rehearsal.parquet) — the recommended λ, the sweep plot (response WNRMSE and energy error
//! against λ, divergence marked) and the tables.

use std::path::Path;

use serde_json::Value;

use super::design::facts_list;
use super::{figure, load, Loaded};
use crate::report::html::{note, table, Cell};
use crate::report::plot::{self, Chart, Mark, RefLine, Series};
use crate::report::table::{Column, Table};
use crate::report::ReportSettings;
use crate::vocab::tables::{self, rehearsal_summary as rs};

/// A JSON object of settings as "key value; key value" (keys' underscores as
/// spaces, numbers to 4 significant digits, units from the key's suffix); other
/// text as it is.
fn in_words(json: &str) -> String {
    let Ok(Value::Object(m)) = serde_json::from_str::<Value>(json) else {
        return json.to_string();
    };
    m.iter()
        .map(|(k, v)| {
            let key = crate::report::html::column_heading(k);
            let value = match v {
                Value::Number(n) => n
                    .as_f64()
                    .map(crate::report::format_number)
                    .unwrap_or_else(|| n.to_string()),
                Value::Bool(true) => "yes".into(),
                Value::Bool(false) => "no".into(),
                Value::String(s) => s.clone(),
                Value::Null => "—".into(),
                other => other.to_string(),
            };
            format!("{} {value}", key.replace('_', " "))
        })
        .collect::<Vec<_>>()
        .join("; ")
}

fn bools(t: &Table, name: &str) -> Vec<bool> {
    match t.columns.get(name) {
        Some(Column::Bool(v)) => v.iter().map(|b| b.unwrap_or(false)).collect(),
        _ => Vec::new(),
    }
}

/// The rehearsal part of the test-design section; empty without rehearsal outputs.
pub(super) fn rehearsal_section(dir: &Path, settings: &ReportSettings) -> String {
    let body = rehearsal_body(dir, settings);
    if body.is_empty() {
        return body;
    }
    format!("<h3>Rehearsal of the hybrid test</h3>{body}")
}

/// The rehearsal: recommended λ and what it rests on, the sweep plot and a
/// compact table of the sweep (one row per run, no list columns); empty
/// without rehearsal outputs.
pub(super) fn rehearsal_body(dir: &Path, _settings: &ReportSettings) -> String {
    let summary = load(dir, &tables::REHEARSAL_SUMMARY, None);
    let Loaded::Ok(t) = &summary else {
        return String::new();
    };
    let mut body = String::new();
    let rec: Option<Value> = t
        .metadata
        .get("quaketwin.recommendation")
        .and_then(|s| serde_json::from_str(s).ok());
    let field = |k: &str| rec.as_ref().and_then(|r| r.get(k)).cloned();
    let num = |k: &str| field(k).and_then(|v| v.as_f64());
    let stable = bools(t, rs::STABLE.name);
    let mut facts = vec![(
        "Recommended time scale (smallest safe λ)".to_string(),
        match (num("time_scale"), num("bandwidth_hz")) {
            (Some(l), Some(b)) => format!(
                "λ = {l} with {} NS modes: bandwidth {b:.3} Hz (design's bandwidth rule: λ = {})",
                num("ns_modes").unwrap_or(0.0),
                num("design_time_scale").unwrap_or(0.0)
            ),
            _ => "none of the swept λ is safe".into(),
        },
    )];
    facts.push((
        "Runs".into(),
        format!(
            "{} ({} stable); scheme {}, Δt = {:.3e} s",
            t.rows,
            stable.iter().filter(|s| **s).count(),
            field("scheme")
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default(),
            num("dt_s").unwrap_or(0.0)
        ),
    ));
    if let Some(a) = t.metadata.get("quaketwin.actuator") {
        facts.push(("Actuator model".into(), in_words(a)));
    }
    if let Some(g) = t.metadata.get("quaketwin.gravity") {
        facts.push(("Gravity".into(), in_words(g)));
    }
    body.push_str(&facts_list(&facts));

    // The sweep: one series per NS mode count, response WNRMSE and energy error against λ;
    // divergent runs drawn as crosses at their energy error.
    if let (Some(ns), Some(lam), Some(w), Some(e)) = (
        t.number(rs::NS_MODES.name),
        t.number(rs::TIME_SCALE.name),
        t.number(rs::RESPONSE_WNRMSE.name),
        t.number(rs::ENERGY_ERROR.name),
    ) {
        let mut counts: Vec<i64> = ns.iter().flatten().map(|v| *v as i64).collect();
        counts.sort_unstable();
        counts.dedup();
        let mut chart = Chart::new(560, 300, "time scale λ", "error");
        chart.log_x = true;
        chart.log_y = true;
        for (c, &n) in counts.iter().enumerate() {
            let rows: Vec<usize> = (0..t.rows)
                .filter(|&i| ns[i].map(|v| v as i64) == Some(n))
                .collect();
            let pts = |y: &[Option<f64>], keep: &dyn Fn(usize) -> bool| -> Vec<(f64, f64)> {
                rows.iter()
                    .filter(|&&i| keep(i))
                    .filter_map(|&i| Some((lam[i]?, y[i]?)))
                    .filter(|p| p.1 > 0.0)
                    .collect()
            };
            let ok = |i: usize| stable.get(i).copied().unwrap_or(false);
            chart.series.push(Series::new(
                format!("response WNRMSE, {n} NS modes"),
                pts(w, &ok),
                2 * c,
                Mark::LinePoints,
            ));
            chart.series.push(Series::new(
                format!("energy error, {n} NS modes"),
                pts(e, &ok),
                2 * c + 1,
                Mark::LinePoints,
            ));
            chart.series.push(Series::new(
                format!("diverged (energy error), {n} NS modes"),
                pts(e, &|i| !ok(i)),
                2 * c + 1,
                Mark::Cross,
            ));
        }
        if let Some(l) = num("time_scale") {
            chart.ref_lines.push(RefLine {
                at: l,
                horizontal: false,
                colour: 0,
            });
        }
        let legend = plot::legend(&chart.series);
        body.push_str(&figure(
            plot::render(&chart),
            "Rehearsal sweep: response WNRMSE against the full twin and energy error (spurious / input energy) per time scale λ; crosses: runs that diverged; vertical line: the recommended λ",
            &legend,
        ));
    }
    body.push_str(&sweep_table(t, &stable));
    body
}

/// The sweep as a compact table: per run NS modes, λ, bandwidth, outcome,
/// response WNRMSE, energy error and the largest tracking error; the
/// per-actuator tracking lists stay in the file.
fn sweep_table(t: &Table, stable: &[bool]) -> String {
    let num = |c: &str, r: usize| t.number(c).and_then(|v| v.get(r).copied().flatten());
    let flag = |c: &str, r: usize| bools(t, c).get(r).copied().unwrap_or(false);
    let mut order: Vec<usize> = (0..t.rows).collect();
    order.sort_by(|&a, &b| {
        let key = |r| {
            (
                num(rs::NS_MODES.name, r).unwrap_or(0.0),
                num(rs::TIME_SCALE.name, r).unwrap_or(0.0),
            )
        };
        key(a)
            .partial_cmp(&key(b))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let rows: Vec<Vec<Cell>> = order
        .iter()
        .map(|&r| {
            let outcome = if !stable.get(r).copied().unwrap_or(false) {
                match num(rs::DIVERGENCE_TIME_S.name, r) {
                    Some(s) => format!("diverged at {s:.2} s"),
                    None => "diverged".into(),
                }
            } else if flag(rs::RECOMMENDED.name, r) {
                "safe — recommended".into()
            } else if flag(rs::SAFE.name, r) {
                "safe".into()
            } else {
                "stable, outside the tolerances".into()
            };
            vec![
                Cell::integer(num(rs::NS_MODES.name, r)),
                Cell::number(num(rs::TIME_SCALE.name, r)),
                Cell::number(num(rs::BANDWIDTH_HZ.name, r)),
                Cell::text(&outcome),
                Cell::number(num(rs::RESPONSE_WNRMSE.name, r).map(|v| 100.0 * v)),
                Cell::number(num(rs::ENERGY_ERROR.name, r).map(|v| 100.0 * v)),
                Cell::number(num(rs::MAX_TRACKING_ERROR_M.name, r).map(|v| 1000.0 * v)),
            ]
        })
        .collect();
    let mut html = table(
        Some("rehearsal-sweep"),
        &[
            "NS modes",
            "λ",
            "bandwidth (Hz)",
            "outcome",
            "response WNRMSE (%)",
            "energy error (%)",
            "largest tracking error (mm)",
        ]
        .map(String::from),
        &rows,
    );
    html.push_str(&note(
        "One row per rehearsed run; the tracking error of each actuator is in the appendix's output files (rehearsal sweep).",
    ));
    html
}
