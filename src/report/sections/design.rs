//! Section 11, hybrid-test design: key facts from the design tables and their
//! metadata, the interface-refinement trade-off, POD energies and the tables.

use std::path::Path;

use serde_json::Value;

use super::{figure, load, Loaded};
use crate::report::html::escape;
use crate::report::plot::{self, Chart, Mark, Series};
use crate::report::ReportSettings;
use crate::vocab::tables::{self, actuator_layout, hybrid_prototype, interface_refinement, pod};

/// The design in facts, from the tables and their metadata
/// (docs/test-design.md): empty without design outputs.
pub(super) fn design_facts(dir: &Path) -> Vec<(String, String)> {
    let pod = load(dir, &tables::POD, None);
    let layout = load(dir, &tables::ACTUATOR_LAYOUT, None);
    let validation = load(dir, &tables::REDUCTION_VALIDATION, None);
    let hybrid = load(dir, &tables::HYBRID_PROTOTYPE, None);
    let meta = |l: &Loaded, key: &str| -> String {
        match l {
            Loaded::Ok(t) => t.metadata.get(key).cloned().unwrap_or_else(|| "—".into()),
            _ => "—".into(),
        }
    };
    let mut facts: Vec<(String, String)> = Vec::new();
    if let Loaded::Ok(t) = &pod {
        let retained = meta(&pod, "quaketwin.retained_poms");
        let energy = t
            .number(pod::CUMULATIVE_ENERGY.name)
            .and_then(|c| {
                retained
                    .parse::<usize>()
                    .ok()
                    .and_then(|k| c.get(k.checked_sub(1)?).copied().flatten())
            })
            .map(|e| format!("{:.4} %", 100.0 * e))
            .unwrap_or_else(|| "—".into());
        facts.push(("Snapshots".into(), meta(&pod, "quaketwin.snapshot_source")));
        facts.push(("Base motion".into(), meta(&pod, "quaketwin.motion")));
        facts.push((
            "Retained POMs (energy)".into(),
            format!("{retained} ({energy})"),
        ));
        if let Some(mac) = t.metadata.get("quaketwin.pom_mac_with_twin") {
            let first: Vec<String> = serde_json::from_str::<Vec<f64>>(mac)
                .unwrap_or_default()
                .iter()
                .take(3)
                .map(|v| format!("{v:.3}"))
                .collect();
            facts.push(("MAC of recorded vs twin POMs 1–3".into(), first.join(", ")));
        }
    }
    if let Loaded::Ok(t) = &layout {
        let control = t.text(actuator_layout::CONTROL_MODE.name).unwrap_or(&[]);
        let force = control
            .iter()
            .filter(|c| c.as_deref() == Some("force"))
            .count();
        facts.push((
            "Actuators".into(),
            format!(
                "{} ({} displacement-, {force} force-controlled)",
                t.rows,
                t.rows - force
            ),
        ));
    }
    if let Loaded::Ok(_) = &validation {
        facts.push(("Reduced vs full twin at the PS (WNRMSE)".into(), {
            let fmt = |k: &str| {
                meta(&validation, k)
                    .parse::<f64>()
                    .map(|v| format!("{v:.2e}"))
                    .unwrap_or_else(|_| "—".into())
            };
            format!(
                "deformation {}, total displacement {}",
                fmt("quaketwin.wnrmse"),
                fmt("quaketwin.wnrmse_total")
            )
        }));
    }
    if let Loaded::Ok(_) = &hybrid {
        let rec: Option<Value> =
            serde_json::from_str(&meta(&hybrid, "quaketwin.recommendation")).ok();
        let num = |k: &str| rec.as_ref().and_then(|r| r.get(k)).and_then(Value::as_f64);
        let text = match (num(hybrid_prototype::NS_MODES.name), num(hybrid_prototype::TIME_SCALE.name), num(hybrid_prototype::BANDWIDTH_HZ.name), num("highest_frequency_hz")) {
            (Some(n), Some(l), Some(b), Some(top)) => format!(
                "Craig–Bampton prototype with {n} NS modes (highest frequency {top:.1} Hz); time scale λ = {l}: hybrid bandwidth {b:.3} Hz"
            ),
            _ => "—".into(),
        };
        facts.push(("Hybrid recommendation".into(), text));
    }
    facts
}

/// A definition list of facts.
pub(super) fn facts_list(facts: &[(String, String)]) -> String {
    let mut dl = String::from("<dl class=\"facts\">");
    for (k, v) in facts {
        dl.push_str(&format!("<dt>{}</dt><dd>{}</dd>", escape(k), escape(v)));
    }
    dl.push_str("</dl>");
    dl
}

/// Whether the run has any design output (listed: a pipeline with a design stage).
pub(super) fn has_design(dir: &Path) -> bool {
    [
        &tables::POD,
        &tables::ACTUATOR_LAYOUT,
        &tables::REDUCTION_VALIDATION,
        &tables::INTERFACE_REFINEMENT,
        &tables::HYBRID_PROTOTYPE,
    ]
    .iter()
    .any(|t| !matches!(load(dir, t, Some(&[])), Loaded::Absent(None)))
}

pub(super) fn design_section(dir: &Path, settings: &ReportSettings) -> String {
    // A run without any design output (a post-earthquake run): one line,
    // not one "absent" line per design table.
    if !has_design(dir) {
        return crate::report::html::note(
            "No hybrid-test design in this run: its pipeline has no design stage (pipelines/test-design.toml or \
             `quaketwin design` make one; docs/test-design.md).",
        );
    }
    let mut body = design_body(dir);
    body.push_str(&super::rehearsal::rehearsal_section(dir, settings));
    body
}

/// The design: its facts, the actuator layout drawn on the twin, the
/// interface refinement, the Craig–Bampton prototype's frequencies and the
/// POD energies — compact, no table dumped.
pub(super) fn design_body(dir: &Path) -> String {
    let mut body = String::new();
    let facts = design_facts(dir);
    if !facts.is_empty() {
        body.push_str(&facts_list(&facts));
    }
    let layout = load(dir, &tables::ACTUATOR_LAYOUT, None);
    body.push_str("<h3>Actuator layout</h3>");
    if let Some(t) = super::require(&layout, &tables::ACTUATOR_LAYOUT, &mut body) {
        body.push_str(&super::actuators::actuator_figure(t));
        body.push_str(&super::actuators::actuator_list(t));
    }
    let refinement = load(dir, &tables::INTERFACE_REFINEMENT, None);
    let pod = load(dir, &tables::POD, None);
    body.push_str("<h3>Reduction and interface</h3><div class=\"grid2\">");
    // The trade-off of the interface refinement: accuracy against actuators.
    if let Loaded::Ok(t) = &refinement {
        if let (Some(act), Some(def), Some(tot)) = (
            t.number(interface_refinement::ACTUATORS.name),
            t.number(interface_refinement::WNRMSE_DEFORMATION.name),
            t.number(interface_refinement::WNRMSE_TOTAL.name),
        ) {
            let pts = |y: &[Option<f64>]| -> Vec<(f64, f64)> {
                act.iter()
                    .zip(y)
                    .filter_map(|(a, y)| Some((((*a)?), (*y)?)))
                    .collect()
            };
            let mut chart = Chart::new(460, 240, "actuators", "WNRMSE");
            chart
                .series
                .push(Series::new("deformation", pts(def), 0, Mark::LinePoints));
            chart.series.push(Series::new(
                "total displacement",
                pts(tot),
                1,
                Mark::LinePoints,
            ));
            let legend = plot::legend(&chart.series);
            body.push_str(&figure(
                plot::render(&chart),
                "Interface refinement: the reduced twin's error (WNRMSE at the physical substructure) against the number of actuators, step by step",
                &legend,
            ));
        }
    }
    // POD energy per mode.
    if let Loaded::Ok(t) = &pod {
        if let Some(v) = t.number(pod::ENERGY_FRACTION.name) {
            let pts: Vec<(f64, f64)> = v
                .iter()
                .enumerate()
                .filter_map(|(i, x)| x.map(|x| ((i + 1) as f64, x)))
                .collect();
            let mut chart = Chart::new(460, 240, "POM", "energy fraction");
            chart.log_y = pts.iter().all(|p| p.1 > 0.0);
            chart
                .series
                .push(Series::new("energy fraction", pts, 0, Mark::LinePoints));
            body.push_str(&figure(
                plot::render(&chart),
                "Proper orthogonal decomposition: energy fraction per POM",
                "",
            ));
        }
    }
    body.push_str("</div>");
    body.push_str("<h3>Craig–Bampton prototype</h3>");
    let hybrid = load(dir, &tables::HYBRID_PROTOTYPE, None);
    if let Some(t) = super::require(&hybrid, &tables::HYBRID_PROTOTYPE, &mut body) {
        body.push_str(&prototype_table(t));
    }
    body
}

/// The prototype's frequencies against the full twin's, in band or not,
/// and in laboratory time.
fn prototype_table(t: &crate::report::table::Table) -> String {
    use crate::report::html::{table, Cell};
    let num = |c: &str, r: usize| t.number(c).and_then(|v| v.get(r).copied().flatten());
    let in_band = |r: usize| {
        t.boolean(hybrid_prototype::IN_BAND.name)
            .and_then(|v| v.get(r).copied().flatten())
    };
    // In-band modes and the first ones beyond: the table stays short.
    let shown: Vec<usize> = (0..t.rows)
        .filter(|&r| in_band(r) != Some(false) || r < 6)
        .take(12)
        .collect();
    let rows: Vec<Vec<Cell>> = shown
        .iter()
        .map(|&r| {
            vec![
                Cell::integer(num(hybrid_prototype::MODE.name, r)),
                Cell::number(num(hybrid_prototype::PROTOTYPE_FREQUENCY_HZ.name, r)),
                Cell::number(num(hybrid_prototype::FULL_FREQUENCY_HZ.name, r)),
                Cell::number(num(hybrid_prototype::RELATIVE_ERROR.name, r).map(|e| 100.0 * e)),
                Cell::text(match in_band(r) {
                    Some(true) => "yes",
                    Some(false) => "no",
                    None => "—",
                }),
                Cell::number(num(hybrid_prototype::TEST_FREQUENCY_HZ.name, r)),
            ]
        })
        .collect();
    let mut html = table(
        Some("prototype-table"),
        &[
            "mode",
            "prototype f (Hz)",
            "full twin f (Hz)",
            "error (%)",
            "in band",
            "laboratory f (Hz)",
        ]
        .map(String::from),
        &rows,
    );
    if shown.len() < t.rows {
        html.push_str(&crate::report::html::note(&format!(
            "{} of {} prototype frequencies shown (those in the band of interest and the first beyond).",
            shown.len(),
            t.rows
        )));
    }
    html
}
