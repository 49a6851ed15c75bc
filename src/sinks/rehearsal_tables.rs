//! Files of the hybrid-test rehearsal (docs/test-design.md, docs/formats.md):
//! `rehearsal_model.json` (written by the design stage: what a rehearsal needs, read back by
//! `quaketwin rehearse` and by a skipped design stage's restore), `rehearsal_summary/rehearsal_summary.parquet`
//! and `rehearsal/rehearsal.parquet`. Every file is written atomically.

use std::path::{Path, PathBuf};

use super::atomic::write_bytes_atomically;
use super::parquet::{write_parquet, TableBuilder};
use crate::error::{Error, Location, Result};
use crate::rehearse::{Rehearsal, RehearsalModel, RehearseSettings};
use crate::vocab::tables::{rehearsal, rehearsal_summary, REHEARSAL, REHEARSAL_SUMMARY};

pub const REHEARSAL_MODEL_FILE: &str = "rehearsal_model.json";
pub const REHEARSAL_FILE: &str = REHEARSAL.file;
pub const REHEARSAL_SUMMARY_FILE: &str = REHEARSAL_SUMMARY.file;

/// Every file `write_rehearsal` writes, in order.
pub const REHEARSAL_FILES: &[&str] = &[REHEARSAL_SUMMARY_FILE, REHEARSAL_FILE];

/// `rehearsal_model.json` (pretty JSON, floats round-trip exactly).
pub fn write_rehearsal_model(path: &Path, model: &RehearsalModel) -> Result<()> {
    let text = serde_json::to_string(model)
        .map_err(|e| Error::numerical(format!("rehearsal model: {e}")))?;
    write_bytes_atomically(path, text.as_bytes())
}

/// Reads and checks `rehearsal_model.json`; errors name the file.
pub fn read_rehearsal_model(path: &Path) -> Result<RehearsalModel> {
    let text = crate::input_file::read_to_string(path, crate::input_file::MAX_INPUT_BYTES)?;
    let model: RehearsalModel = serde_json::from_str(&text).map_err(|e| {
        Error::input(
            Location::file(path.display().to_string()),
            format!("not a rehearsal model: {e}"),
        )
    })?;
    model.validate(&path.display().to_string())?;
    Ok(model)
}

/// `rehearsal_summary/rehearsal_summary.parquet` and `rehearsal/rehearsal.parquet` into `out_dir`.
pub fn write_rehearsal(
    out_dir: &Path,
    model: &RehearsalModel,
    r: &Rehearsal,
    settings: &RehearseSettings,
    source: &str,
) -> Result<Vec<PathBuf>> {
    let runs = &r.runs;
    let meta = vec![
        ("quaketwin.design".to_string(), source.to_string()),
        ("quaketwin.motion".into(), model.motion_source.clone()),
        (
            "quaketwin.settings".into(),
            serde_json::to_string(settings).unwrap_or_default(),
        ),
        (
            "quaketwin.actuator".into(),
            serde_json::json!({
                "servo": r.actuator.servo.name(),
                "bandwidth_hz": r.actuator.bandwidth_hz,
                "damping": r.actuator.damping,
                "delay_s": r.actuator.delay_s,
            })
            .to_string(),
        ),
        (
            "quaketwin.recommendation".into(),
            serde_json::json!({
                "ns_modes": r.ns_modes,
                "time_scale": r.recommended.map(|i| runs[i].time_scale),
                "bandwidth_hz": r.recommended.map(|i| runs[i].bandwidth_hz),
                "design_time_scale": model.time_scale,
                "scheme": settings.scheme.name(),
                "dt_s": r.dt_s,
                "substeps": r.substeps,
            })
            .to_string(),
        ),
        (
            "quaketwin.gravity".into(),
            match &r.preload {
                Some(p) => serde_json::json!({
                    "preload": true,
                    "force_controlled_n": p.force_controlled_n,
                    "vertical_force_n": p.vertical_n,
                    "direction": model.gravity_direction,
                    "method": "static state K x_g = f_g (prototype, specimen's initial stiffness); force-controlled actuators apply r_g = K_P d_g, displacement-controlled hold d_g; the dynamic run starts there, responses are increments about it",
                })
                .to_string(),
                None => serde_json::json!({
                    "preload": false,
                    "reason": if model.gravity { "switched off (settings gravity = false, or no force-controlled actuator)" } else { "the design has no gravity state" },
                })
                .to_string(),
            },
        ),
    ];
    let summary = TableBuilder::new(&REHEARSAL_SUMMARY)
        .u32(
            rehearsal_summary::NS_MODES,
            runs.iter().map(|x| x.ns_modes as u32).collect(),
        )
        .f64(
            rehearsal_summary::TIME_SCALE,
            runs.iter().map(|x| x.time_scale).collect(),
        )
        .f64(
            rehearsal_summary::TOP_FREQUENCY_HZ,
            runs.iter().map(|x| x.top_frequency_hz).collect(),
        )
        .f64(
            rehearsal_summary::BANDWIDTH_HZ,
            runs.iter().map(|x| x.bandwidth_hz).collect(),
        )
        .bool(
            rehearsal_summary::STABLE,
            runs.iter().map(|x| x.stable).collect(),
        )
        .opt_f64(
            rehearsal_summary::DIVERGENCE_TIME_S,
            runs.iter().map(|x| x.divergence_time_s).collect(),
        )
        .f64(
            rehearsal_summary::ENERGY_ERROR,
            runs.iter().map(|x| x.energy_error).collect(),
        )
        .opt_f64(
            rehearsal_summary::RESPONSE_WNRMSE,
            runs.iter().map(|x| x.response_wnrmse).collect(),
        )
        .f64(
            rehearsal_summary::MAX_TRACKING_ERROR_M,
            runs.iter()
                .map(|x| x.tracking_max_m.iter().copied().fold(0.0, f64::max))
                .collect(),
        )
        .list_f64(
            rehearsal_summary::TRACKING_RMS_M,
            &runs
                .iter()
                .map(|x| x.tracking_rms_m.clone())
                .collect::<Vec<_>>(),
        )
        .list_f64(
            rehearsal_summary::TRACKING_MAX_M,
            &runs
                .iter()
                .map(|x| x.tracking_max_m.clone())
                .collect::<Vec<_>>(),
        )
        .bool(
            rehearsal_summary::SAFE,
            runs.iter().map(|x| x.safe).collect(),
        )
        .bool(
            rehearsal_summary::RECOMMENDED,
            (0..runs.len()).map(|i| r.recommended == Some(i)).collect(),
        )
        .build()?;
    let summary_path = out_dir.join(REHEARSAL_SUMMARY_FILE);
    write_parquet(&summary_path, &[summary], &meta)?;

    // Histories: one row per (sample, actuator), samples in time order.
    let h = &r.histories;
    let run = &runs[r.history_run];
    let (steps, m) = (h.time_s.len(), model.actuators.len());
    let idx: Vec<(usize, usize)> = (0..steps)
        .flat_map(|k| (0..m).map(move |a| (k, a)))
        .collect();
    let col = |v: &[Vec<f64>]| -> Vec<f64> { idx.iter().map(|&(k, a)| v[a][k]).collect() };
    let acts = &model.actuators;
    let batch = TableBuilder::new(&REHEARSAL)
        .f64(
            rehearsal::TIME_S,
            idx.iter().map(|&(k, _)| h.time_s[k]).collect(),
        )
        .u32(
            rehearsal::ACTUATOR,
            idx.iter().map(|&(_, a)| acts[a].actuator as u32).collect(),
        )
        .i64(
            rehearsal::NODE_ID,
            idx.iter().map(|&(_, a)| acts[a].node_id).collect(),
        )
        .str(
            rehearsal::DIRECTION,
            &idx.iter()
                .map(|&(_, a)| acts[a].direction.as_str())
                .collect::<Vec<_>>(),
        )
        .f64(rehearsal::COMMAND_M, col(&h.command))
        .f64(rehearsal::ACHIEVED_M, col(&h.achieved))
        .f64(rehearsal::FORCE_N, col(&h.force))
        .f64(rehearsal::RESPONSE_M, col(&h.response))
        .f64(rehearsal::REFERENCE_M, col(&model.reference))
        .f64(rehearsal::TIME_SCALE, vec![run.time_scale; idx.len()])
        .u32(rehearsal::NS_MODES, vec![run.ns_modes as u32; idx.len()])
        .build()?;
    let path = out_dir.join(REHEARSAL_FILE);
    let mut meta = meta;
    meta.push((
        "quaketwin.run".into(),
        serde_json::json!({
            "time_scale": run.time_scale,
            "ns_modes": run.ns_modes,
            "stable": run.stable,
            "divergence_time_s": run.divergence_time_s,
        })
        .to_string(),
    ));
    write_parquet(&path, &[batch], &meta)?;
    Ok(vec![summary_path, path])
}
