//! The compare-test report: its own page for the output of `quaketwin compare-test`
//! (docs/lab-tests.md, "Comparing a hybrid test with its rehearsal") — the logged test against
//! the design's rehearsal and the rehearsal updated from the log: tracking (lag, noise, error),
//! energy, response against the log and the twin; the tracking error and the specimen's loop of
//! the most telling actuators, logged over predicted.

use std::path::Path;

use serde_json::Value;

use super::design::facts_list;
use super::{figure, load, section, Loaded};
use crate::report::html::{escape, note, table, Cell};
use crate::report::plot::{self, Chart, Mark, Series};
use crate::report::table::Table;
use crate::report::ReportSettings;
use crate::vocab::tables::{
    self, compare_test as ct, compare_test_actuators as ca, compare_test_summary as cs,
};

/// The sections of the page, in order.
pub const SECTIONS: [(&str, &str); 3] = [
    (
        "compare-test",
        "Comparing the hybrid test with its rehearsal",
    ),
    ("tracking", "Actuator tracking"),
    ("specimen", "Specimen: logged and predicted restoring force"),
];

/// A compare-test output directory: its summary table is there.
pub(super) fn applies(dir: &Path) -> bool {
    matches!(
        load(dir, &tables::COMPARE_TEST_SUMMARY, Some(&[])),
        Loaded::Ok(_)
    )
}

fn meta(t: &Table, key: &str) -> Option<Value> {
    t.metadata
        .get(key)
        .and_then(|s| serde_json::from_str(s).ok())
}

fn summary_body(dir: &Path) -> (String, Option<Value>) {
    let loaded = load(dir, &tables::COMPARE_TEST_SUMMARY, None);
    let mut body = String::new();
    let Some(t) = super::require(&loaded, &tables::COMPARE_TEST_SUMMARY, &mut body) else {
        return (body, None);
    };
    let base = meta(t, "quaketwin.time_base");
    let specimen = meta(t, "quaketwin.specimen_update");
    let num =
        |v: &Option<Value>, k: &str| v.as_ref().and_then(|v| v.get(k)).and_then(Value::as_f64);
    let mut facts = vec![
        (
            "Design".to_string(),
            t.metadata.get("quaketwin.design").cloned().unwrap_or_default(),
        ),
        ("Log".into(), t.metadata.get("quaketwin.log").cloned().unwrap_or_default()),
        (
            "Time base".into(),
            format!(
                "λ = {}, {} steps of Δt = {:.4e} s ({} per motion step), {:.4} s of laboratory time per step",
                num(&base, "time_scale").unwrap_or(f64::NAN),
                num(&base, "steps").unwrap_or(0.0),
                num(&base, "dt_s").unwrap_or(f64::NAN),
                num(&base, "substeps").unwrap_or(0.0),
                num(&base, "lab_step_s").unwrap_or(f64::NAN)
            ),
        ),
    ];
    let fit = specimen
        .as_ref()
        .and_then(|s| s.get("fit"))
        .filter(|f| !f.is_null());
    facts.push((
        "Specimen update".into(),
        match (&specimen, fit) {
            (None, _) | (Some(Value::Null), _) => "not run (--no-update)".into(),
            (Some(s), Some(f)) => format!(
                "{} fitted on actuator {}: initial stiffness {:.4e} N/m (design {:.4e}), force NRMSE {:.3}",
                f.get("form").and_then(Value::as_str).unwrap_or("?"),
                s.get("actuator").and_then(Value::as_u64).unwrap_or(0),
                f.get("initial_stiffness_n_per_m").and_then(Value::as_f64).unwrap_or(f64::NAN),
                s.get("design_stiffness_n_per_m").and_then(Value::as_f64).unwrap_or(f64::NAN),
                f.get("force_nrmse").and_then(Value::as_f64).unwrap_or(f64::NAN)
            ),
            (Some(s), None) => format!(
                "not identified ({}); the updated rehearsal has the identified actuator and the design's specimen",
                s.get("failure").and_then(Value::as_str).unwrap_or("no reason given")
            ),
        },
    ));
    body.push_str(&facts_list(&facts));
    let text = t.text(cs::SOURCE.name).unwrap_or(&[]);
    let n = |c: &str, r: usize| t.number(c).and_then(|v| v.get(r).copied().flatten());
    let pct = |c: &str, r: usize| n(c, r).map(|v| 100.0 * v);
    let rows: Vec<Vec<Cell>> = (0..t.rows)
        .map(|r| {
            vec![
                Cell::text(text.get(r).cloned().flatten().as_deref().unwrap_or("")),
                Cell::number(n(cs::LAG_S.name, r).map(|v| 1000.0 * v)),
                Cell::number(n(cs::NOISE_STD_M.name, r).map(|v| 1e6 * v)),
                Cell::number(n(cs::POOLED_TRACKING_RMS_M.name, r).map(|v| 1e6 * v)),
                Cell::number(n(cs::MAX_TRACKING_ERROR_M.name, r).map(|v| 1e6 * v)),
                Cell::number(pct(cs::ENERGY_ERROR.name, r)),
                Cell::number(pct(cs::COMMAND_WNRMSE.name, r)),
                Cell::number(pct(cs::FORCE_WNRMSE.name, r)),
                Cell::number(pct(cs::RESPONSE_WNRMSE.name, r)),
                Cell::number(pct(cs::TWIN_WNRMSE.name, r)),
            ]
        })
        .collect();
    body.push_str(&table(
        Some("compare-test-summary"),
        &[
            "source",
            "lag (ms)",
            "noise (µm)",
            "tracking RMS (µm)",
            "largest tracking error (µm)",
            "energy error (%)",
            "command WNRMSE vs log (%)",
            "force WNRMSE vs log (%)",
            "response WNRMSE vs log (%)",
            "response WNRMSE vs twin (%)",
        ]
        .map(String::from),
        &rows,
    ));
    body.push_str(&note(
        "Logged: the test's log; lag and noise identified (measured = command delayed by the lag, plus noise). Rehearsal: the design's rehearsal settings at the log's λ and step; its lag is the actuator model's delay + servo lag. Updated rehearsal: the identified actuator (pure delay, noise) and specimen. Energy error: spurious / input energy (Mosqueda). WNRMSE: Eq. 84, against the log (or the twin's response at the motion's steps).",
    ));
    (body, specimen)
}

/// Rows of `t` for `actuator`, in file (step) order.
fn rows_of(t: &Table, column: &str, actuator: f64) -> Vec<usize> {
    let a = t.number(column).unwrap_or(&[]);
    (0..t.rows)
        .filter(|&r| a.get(r).copied().flatten() == Some(actuator))
        .collect()
}

/// (x, y₁ − y₂) over `rows`.
fn difference(t: &Table, rows: &[usize], x: &str, y1: &str, y2: &str) -> Vec<(f64, f64)> {
    let (Some(xs), Some(a), Some(b)) = (t.number(x), t.number(y1), t.number(y2)) else {
        return Vec::new();
    };
    rows.iter()
        .filter_map(|&r| Some((xs[r]?, a[r]? - b[r]?)))
        .collect()
}

fn tracking_body(dir: &Path, histories: &Loaded, settings: &ReportSettings) -> String {
    let loaded = load(dir, &tables::COMPARE_TEST_ACTUATORS, None);
    let mut body = String::new();
    let Some(t) = super::require(&loaded, &tables::COMPARE_TEST_ACTUATORS, &mut body) else {
        return body;
    };
    let n = |c: &str, r: usize| t.number(c).and_then(|v| v.get(r).copied().flatten());
    let worst = (0..t.rows).max_by(|&a, &b| {
        n(ca::LOGGED_TRACKING_RMS_M.name, a)
            .unwrap_or(0.0)
            .total_cmp(&n(ca::LOGGED_TRACKING_RMS_M.name, b).unwrap_or(0.0))
    });
    if let (Some(w), Loaded::Ok(h)) = (worst, histories) {
        let actuator = n(ca::ACTUATOR.name, w).unwrap_or(0.0);
        let rows = rows_of(h, ct::ACTUATOR.name, actuator);
        let series = vec![
            (
                "logged".to_string(),
                difference(
                    h,
                    &rows,
                    ct::TIME_S.name,
                    ct::COMMAND_M.name,
                    ct::MEASURED_M.name,
                ),
            ),
            (
                "rehearsal".to_string(),
                difference(
                    h,
                    &rows,
                    ct::TIME_S.name,
                    ct::REHEARSAL_COMMAND_M.name,
                    ct::REHEARSAL_MEASURED_M.name,
                ),
            ),
            (
                "updated rehearsal".to_string(),
                difference(
                    h,
                    &rows,
                    ct::TIME_S.name,
                    ct::UPDATED_COMMAND_M.name,
                    ct::UPDATED_MEASURED_M.name,
                ),
            ),
        ];
        let chart = Chart::new(640, 260, "simulation time (s)", "command − measured (m)");
        body.push_str(&super::time_series_figure(
            chart,
            series.into_iter().filter(|(_, p)| !p.is_empty()).collect(),
            None,
            settings,
            &format!("Tracking error of actuator {actuator} (the largest logged RMS): logged, rehearsed and updated"),
        ));
    }
    let rows: Vec<Vec<Cell>> = (0..t.rows)
        .map(|r| {
            let um = |c: &str| Cell::number(n(c, r).map(|v| 1e6 * v));
            vec![
                Cell::integer(n(ca::ACTUATOR.name, r)),
                Cell::of(t, ca::DIRECTION.name, r),
                Cell::number(n(ca::LAG_S.name, r).map(|v| 1000.0 * v)),
                um(ca::NOISE_STD_M.name),
                um(ca::LOGGED_TRACKING_RMS_M.name),
                um(ca::REHEARSAL_TRACKING_RMS_M.name),
                um(ca::UPDATED_TRACKING_RMS_M.name),
                um(ca::LOGGED_TRACKING_MAX_M.name),
            ]
        })
        .collect();
    body.push_str(&table(
        Some("compare-test-actuators"),
        &[
            "actuator",
            "direction",
            "lag (ms)",
            "noise (µm)",
            "logged RMS (µm)",
            "rehearsal RMS (µm)",
            "updated RMS (µm)",
            "logged peak (µm)",
        ]
        .map(String::from),
        &rows,
    ));
    body
}

fn specimen_body(histories: &Loaded, specimen: Option<Value>) -> String {
    let Loaded::Ok(h) = histories else {
        return note("No time histories of the comparison.");
    };
    let actuator = specimen
        .as_ref()
        .and_then(|s| s.get("actuator"))
        .and_then(Value::as_f64);
    let Some(actuator) = actuator else {
        return note("The specimen update was not run: no actuator was chosen for its loop.");
    };
    let rows = rows_of(h, ct::ACTUATOR.name, actuator);
    let mut chart = Chart::new(480, 320, "measured displacement (m)", "restoring force (N)");
    for (i, (label, x, y)) in [
        ("logged", ct::MEASURED_M.name, ct::FORCE_N.name),
        (
            "rehearsal",
            ct::REHEARSAL_MEASURED_M.name,
            ct::REHEARSAL_FORCE_N.name,
        ),
        (
            "updated rehearsal",
            ct::UPDATED_MEASURED_M.name,
            ct::UPDATED_FORCE_N.name,
        ),
    ]
    .into_iter()
    .enumerate()
    {
        let pts = super::rows_points(h, &rows, x, y);
        if !pts.is_empty() {
            chart.series.push(Series::new(
                label,
                plot::decimate_curve(&pts, 4000),
                i,
                Mark::Line,
            ));
        }
    }
    let legend = plot::legend(&chart.series);
    figure(
        plot::render(&chart),
        &format!("Restoring force against measured displacement at actuator {actuator} (the one whose displacement spans the widest range; its loop is what the specimen update fits)"),
        &legend,
    )
}

/// The whole compare-test page.
pub(super) fn page(dir: &Path, settings: &ReportSettings) -> String {
    let histories = load(dir, &tables::COMPARE_TEST, None);
    let (summary, specimen) = summary_body(dir);
    let tracking = tracking_body(dir, &histories, settings);
    let loop_html = specimen_body(&histories, specimen);
    let title = settings
        .title
        .clone()
        .unwrap_or_else(|| "Hybrid test against its rehearsal".to_string());
    let mut page = String::with_capacity(1 << 18);
    page.push_str(&super::page_head(&title));
    page.push_str(&format!("<main>\n<h1>{}</h1>\n", escape(&title)));
    for (i, ((id, t), body)) in SECTIONS
        .iter()
        .zip([summary, tracking, loop_html])
        .enumerate()
    {
        page.push_str(&section(id, i + 1, t, &body));
    }
    page.push_str(&format!(
        "</main>\n<footer><p>{}</p></footer>\n</body>\n</html>\n",
        escape("Every number on this page is read from the compare-test outputs in this directory (compare_test_summary/compare_test_summary.parquet, compare_test_actuators/compare_test_actuators.parquet, compare_test/compare_test.parquet).")
    ));
    page
}
