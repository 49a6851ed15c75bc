//! Files of `quaketwin compare-test` (docs/lab-tests.md, docs/formats.md):
//! `compare_test_summary/compare_test_summary.parquet`, `compare_test_actuators/compare_test_actuators.parquet`, `compare_test/compare_test.parquet`,
//! and of `quaketwin synth-hybrid-log`: the log (`hybrid_log.csv`) and its `truth.json`. Every
//! file is written atomically.

use std::path::{Path, PathBuf};

use super::atomic::write_bytes_atomically;
use super::parquet::{write_parquet, TableBuilder};
use crate::error::{Error, Result};
use crate::hybrid_test::{Comparison, HybridLog};
use crate::vocab::tables::{
    compare_test as ct, compare_test_actuators as ca, compare_test_summary as cs, COMPARE_TEST,
    COMPARE_TEST_ACTUATORS, COMPARE_TEST_SUMMARY,
};

/// Every file `write_comparison` writes, in order.
pub const COMPARE_TEST_FILES: &[&str] = &[
    COMPARE_TEST_SUMMARY.file,
    COMPARE_TEST_ACTUATORS.file,
    COMPARE_TEST.file,
];

/// The log as CSV and the generator's truth as JSON into `out_dir`.
pub fn write_hybrid_log(
    out_dir: &Path,
    log: &HybridLog,
    truth: &impl serde::Serialize,
) -> Result<Vec<PathBuf>> {
    let csv = out_dir.join(crate::hybrid_test::log::LOG_FILE);
    write_bytes_atomically(&csv, log.to_csv().as_bytes())?;
    let json = out_dir.join("truth.json");
    let text =
        serde_json::to_string_pretty(truth).map_err(|e| Error::numerical(format!("truth: {e}")))?;
    write_bytes_atomically(&json, text.as_bytes())?;
    Ok(vec![csv, json])
}

/// The comparison's three tables into `out_dir`; `design` and `log` name the inputs.
pub fn write_comparison(
    out_dir: &Path,
    c: &Comparison,
    log: &HybridLog,
    design: &str,
) -> Result<Vec<PathBuf>> {
    let json = |v: serde_json::Value| v.to_string();
    let meta = vec![
        ("quaketwin.design".to_string(), design.to_string()),
        ("quaketwin.log".into(), log.source.clone()),
        (
            "quaketwin.time_base".into(),
            json(serde_json::json!({
                "time_scale": c.time_scale,
                "dt_s": c.dt_s,
                "substeps": c.substeps,
                "lab_step_s": c.lab_step_s,
                "steps": log.steps(),
            })),
        ),
        (
            "quaketwin.tracking".into(),
            json(serde_json::json!({
                "lag_s": c.tracking.lag_s,
                "noise_std_m": c.tracking.noise_std_m,
                "method": "least squares of measured = command delayed by L (piecewise-linear command in laboratory time) pooled over actuators; noise: residual RMS",
            })),
        ),
        (
            "quaketwin.rehearsal_settings".into(),
            serde_json::to_string(&c.rehearsal_settings).unwrap_or_default(),
        ),
        (
            "quaketwin.updated_settings".into(),
            serde_json::to_string(&c.updated_settings).unwrap_or_default(),
        ),
        (
            "quaketwin.specimen_update".into(),
            serde_json::to_string(&c.specimen).unwrap_or_default(),
        ),
    ];
    let runs = &c.runs;
    let summary = TableBuilder::new(&COMPARE_TEST_SUMMARY)
        .str(
            cs::SOURCE,
            &runs.iter().map(|r| r.source.as_str()).collect::<Vec<_>>(),
        )
        .f64(cs::TIME_SCALE, vec![c.time_scale; runs.len()])
        .opt_f64(
            cs::LAG_S,
            runs.iter()
                .map(|r| r.lag_s.is_finite().then_some(r.lag_s))
                .collect(),
        )
        .f64(
            cs::NOISE_STD_M,
            runs.iter().map(|r| r.noise_std_m).collect(),
        )
        .f64(
            cs::POOLED_TRACKING_RMS_M,
            runs.iter().map(|r| r.pooled_tracking_rms_m()).collect(),
        )
        .f64(
            cs::MAX_TRACKING_ERROR_M,
            runs.iter()
                .map(|r| r.tracking_peak_m.iter().copied().fold(0.0, f64::max))
                .collect(),
        )
        .f64(
            cs::ENERGY_ERROR,
            runs.iter().map(|r| r.energy_error).collect(),
        )
        .opt_f64(
            cs::COMMAND_WNRMSE,
            runs.iter().map(|r| r.command_wnrmse).collect(),
        )
        .opt_f64(
            cs::FORCE_WNRMSE,
            runs.iter().map(|r| r.force_wnrmse).collect(),
        )
        .opt_f64(
            cs::RESPONSE_WNRMSE,
            runs.iter().map(|r| r.response_wnrmse).collect(),
        )
        .opt_f64(
            cs::TWIN_WNRMSE,
            runs.iter().map(|r| r.twin_wnrmse).collect(),
        )
        .bool(cs::STABLE, runs.iter().map(|r| r.stable).collect())
        .opt_f64(
            cs::DIVERGENCE_TIME_S,
            runs.iter().map(|r| r.divergence_time_s).collect(),
        )
        .build()?;
    let summary_path = out_dir.join(COMPARE_TEST_SUMMARY.file);
    write_parquet(&summary_path, &[summary], &meta)?;

    let acts = &c.model.actuators;
    let m = acts.len();
    let finite = |v: f64| v.is_finite().then_some(v);
    let (rehearsal, updated) = (&runs[1], runs.get(2));
    let per = TableBuilder::new(&COMPARE_TEST_ACTUATORS)
        .u32(
            ca::ACTUATOR,
            acts.iter().map(|a| a.actuator as u32).collect(),
        )
        .i64(ca::NODE_ID, acts.iter().map(|a| a.node_id).collect())
        .str(
            ca::DIRECTION,
            &acts
                .iter()
                .map(|a| a.direction.as_str())
                .collect::<Vec<_>>(),
        )
        .f64(ca::LOGGED_TRACKING_RMS_M, c.tracking.rms_m.clone())
        .f64(ca::LOGGED_TRACKING_MAX_M, c.tracking.peak_m.clone())
        .opt_f64(
            ca::LAG_S,
            c.tracking
                .lag_per_actuator_s
                .iter()
                .map(|v| finite(*v))
                .collect(),
        )
        .opt_f64(
            ca::NOISE_STD_M,
            c.tracking
                .noise_per_actuator_m
                .iter()
                .map(|v| finite(*v))
                .collect(),
        )
        .f64(
            ca::REHEARSAL_TRACKING_RMS_M,
            rehearsal.tracking_rms_m.clone(),
        )
        .f64(
            ca::REHEARSAL_TRACKING_MAX_M,
            rehearsal.tracking_peak_m.clone(),
        )
        .opt_f64(
            ca::UPDATED_TRACKING_RMS_M,
            (0..m)
                .map(|a| updated.map(|u| u.tracking_rms_m[a]))
                .collect(),
        )
        .opt_f64(
            ca::UPDATED_TRACKING_MAX_M,
            (0..m)
                .map(|a| updated.map(|u| u.tracking_peak_m[a]))
                .collect(),
        )
        .build()?;
    let per_path = out_dir.join(COMPARE_TEST_ACTUATORS.file);
    write_parquet(&per_path, &[per], &meta)?;

    // Histories: one row per (step, actuator), steps in order.
    let n = log.steps();
    let idx: Vec<(usize, usize)> = (0..n).flat_map(|k| (0..m).map(move |a| (k, a))).collect();
    let col = |v: &[Vec<f64>]| -> Vec<f64> { idx.iter().map(|&(k, a)| v[a][k]).collect() };
    let opt = |v: Option<&Vec<Vec<f64>>>| -> Vec<Option<f64>> {
        idx.iter()
            .map(|&(k, a)| v.and_then(|v| v[a].get(k).copied()))
            .collect()
    };
    let (h, u) = (&c.rehearsal, c.updated.as_ref());
    let reference: Vec<Option<f64>> = idx
        .iter()
        .map(|&(k, a)| {
            (k % c.substeps == 0)
                .then(|| c.model.reference[a].get(k / c.substeps).copied())
                .flatten()
        })
        .collect();
    let batch = TableBuilder::new(&COMPARE_TEST)
        .u32(ct::STEP, idx.iter().map(|&(k, _)| k as u32).collect())
        .f64(
            ct::TIME_S,
            idx.iter().map(|&(k, _)| log.time_s[k]).collect(),
        )
        .u32(
            ct::ACTUATOR,
            idx.iter().map(|&(_, a)| acts[a].actuator as u32).collect(),
        )
        .f64(ct::COMMAND_M, col(&log.command_m))
        .f64(ct::MEASURED_M, col(&log.measured_m))
        .f64(ct::FORCE_N, col(&log.force_n))
        .opt_f64(ct::RESPONSE_M, opt(log.response_m.as_ref()))
        .opt_f64(ct::REHEARSAL_COMMAND_M, opt(Some(&h.command)))
        .opt_f64(ct::REHEARSAL_MEASURED_M, opt(Some(&h.achieved)))
        .opt_f64(ct::REHEARSAL_FORCE_N, opt(Some(&h.force)))
        .opt_f64(ct::REHEARSAL_RESPONSE_M, opt(Some(&h.response)))
        .opt_f64(ct::UPDATED_COMMAND_M, opt(u.map(|u| &u.command)))
        .opt_f64(ct::UPDATED_MEASURED_M, opt(u.map(|u| &u.achieved)))
        .opt_f64(ct::UPDATED_FORCE_N, opt(u.map(|u| &u.force)))
        .opt_f64(ct::REFERENCE_M, reference)
        .build()?;
    let path = out_dir.join(COMPARE_TEST.file);
    write_parquet(&path, &[batch], &meta)?;
    Ok(vec![summary_path, per_path, path])
}
