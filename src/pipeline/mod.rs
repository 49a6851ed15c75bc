//! The stage mechanism: a pipeline file lists named stages; each stage has
//! a kind (what it computes), parameters, the earlier stages it reads, and
//! output files.  A stage is skipped when a stamp shows its outputs were made
//! from the same inputs, parameters and program version and the outputs are
//! still there and newer than its inputs.  Data flows one way: stages hand
//! their products to later stages through the `RunContext` (in memory) and
//! through their output files (when a stage was skipped, later stages load
//! its products back from them).

pub mod config;
pub mod fingerprint;
pub mod registry;

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::{Deserialize, Serialize};

pub use config::{params, PipelineFile, StageDecl};
pub use registry::RunContext;

use crate::error::{Error, Result};
use fingerprint::Fnv64;

/// What happened to one stage in a run.
#[derive(Debug, Clone, PartialEq)]
pub enum StageOutcome {
    Ran {
        seconds: f64,
    },
    Skipped,
    Disabled,
    /// The stage does not apply to this event (the reason says why).
    NotApplicable(String),
}

/// Stamp written after a stage succeeds.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct Stamp {
    stage: String,
    kind: String,
    fingerprint: String,
    outputs: Vec<String>,
    version: String,
}

fn stamp_path(out: &Path, stage: &str) -> PathBuf {
    out.join(".quaketwin").join(format!("{stage}.stamp.json"))
}

/// Runs `pipeline` on the event at `event_path`, writing into `out`.
/// Returns the outcome of every stage, in order.
pub fn run(
    pipeline: &PipelineFile,
    event_path: &Path,
    out: &Path,
    quiet: bool,
) -> Result<Vec<(String, StageOutcome)>> {
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let event_fp = fingerprint::path_fingerprint(event_path)?;
    let mut ctx = RunContext::new(event_path, out, quiet);
    ctx.stage_decls = pipeline.stages.clone();
    let mut fingerprints: std::collections::BTreeMap<String, String> = Default::default();
    let mut outcomes = Vec::new();
    // One bar over the stages; indicatif hides it when stderr is not a terminal.
    let bar = if quiet {
        indicatif::ProgressBar::hidden()
    } else {
        let b = indicatif::ProgressBar::new(pipeline.stages.len() as u64);
        if let Ok(style) = indicatif::ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} stages: {msg}",
        ) {
            b.set_style(style);
        }
        b.enable_steady_tick(std::time::Duration::from_millis(200));
        b
    };
    let log = |line: String| {
        if !quiet {
            bar.suspend(|| eprintln!("{line}"));
        }
    };
    for stage in &pipeline.stages {
        bar.set_message(stage.name.clone());
        if !stage.enabled {
            bar.inc(1);
            outcomes.push((stage.name.clone(), StageOutcome::Disabled));
            continue;
        }
        if let Some(why) = registry::not_applicable(stage, &mut ctx)? {
            log(format!(
                "[{}] {:<12} not applicable: {why}",
                pipeline.pipeline.name, stage.name
            ));
            bar.inc(1);
            outcomes.push((stage.name.clone(), StageOutcome::NotApplicable(why)));
            continue;
        }
        let mut h = Fnv64::default();
        h.write_str(env!("CARGO_PKG_VERSION"))
            .write_str(&stage.kind)
            .write_str(&stage.name);
        h.write_str(&toml::to_string(&stage.params).unwrap_or_default());
        h.write_str(&event_fp);
        h.write_str(&registry::extra_fingerprint(stage, &mut ctx)?);
        for i in &stage.inputs {
            h.write_str(fingerprints.get(i).map(|s| s.as_str()).unwrap_or(""));
        }
        let fp = h.finish_hex();
        fingerprints.insert(stage.name.clone(), fp.clone());
        let outputs = registry::outputs(stage)?;
        if is_up_to_date(out, stage, &fp, &outputs, event_path) {
            log(format!(
                "[{}] {:<12} up to date, skipped",
                pipeline.pipeline.name, stage.name
            ));
            bar.inc(1);
            ctx.mark_skipped(&stage.name);
            outcomes.push((stage.name.clone(), StageOutcome::Skipped));
            continue;
        }
        let t0 = Instant::now();
        log(format!(
            "[{}] {:<12} running ({})",
            pipeline.pipeline.name, stage.name, stage.kind
        ));
        registry::run_stage(stage, &mut ctx).map_err(|e| {
            bar.finish_and_clear();
            match e {
                Error::Usage(m) => Error::Usage(format!("stage {:?}: {m}", stage.name)),
                Error::Numerical(m) => Error::Numerical(format!("stage {:?}: {m}", stage.name)),
                other => other,
            }
        })?;
        for o in &outputs {
            if !out.join(o).exists() {
                return Err(Error::output(
                    out.join(o),
                    format!("stage {:?} did not write this declared output", stage.name),
                ));
            }
        }
        let stamp = Stamp {
            stage: stage.name.clone(),
            kind: stage.kind.clone(),
            fingerprint: fp,
            outputs: outputs.clone(),
            version: env!("CARGO_PKG_VERSION").into(),
        };
        let sp = stamp_path(out, &stage.name);
        let json =
            serde_json::to_vec_pretty(&stamp).map_err(|e| Error::output(&sp, e.to_string()))?;
        crate::sinks::parquet::write_bytes_atomically(&sp, &json)?;
        let secs = t0.elapsed().as_secs_f64();
        log(format!(
            "[{}] {:<12} done in {:.2} s -> {}",
            pipeline.pipeline.name,
            stage.name,
            secs,
            outputs.join(", ")
        ));
        bar.inc(1);
        outcomes.push((stage.name.clone(), StageOutcome::Ran { seconds: secs }));
    }
    bar.finish_and_clear();
    Ok(outcomes)
}

fn mtime(p: &Path) -> Option<std::time::SystemTime> {
    std::fs::metadata(p).and_then(|m| m.modified()).ok()
}

fn newest_input_mtime(p: &Path) -> Option<std::time::SystemTime> {
    let meta = std::fs::metadata(p).ok()?;
    if meta.is_dir() {
        let mut newest = meta.modified().ok();
        for e in std::fs::read_dir(p).ok()?.flatten() {
            if let Some(t) = newest_input_mtime(&e.path()) {
                newest = Some(newest.map_or(t, |n| n.max(t)));
            }
        }
        newest
    } else {
        meta.modified().ok()
    }
}

fn is_up_to_date(
    out: &Path,
    stage: &StageDecl,
    fp: &str,
    outputs: &[String],
    event_path: &Path,
) -> bool {
    let Ok(text) = std::fs::read(stamp_path(out, &stage.name)) else {
        return false;
    };
    let Ok(stamp) = serde_json::from_slice::<Stamp>(&text) else {
        return false;
    };
    if stamp.fingerprint != fp || stamp.outputs != outputs {
        return false;
    }
    let input_time = newest_input_mtime(event_path);
    outputs
        .iter()
        .all(|o| match (mtime(&out.join(o)), input_time) {
            (Some(t_out), Some(t_in)) => t_out >= t_in,
            (Some(_), None) => true,
            _ => false,
        })
}
