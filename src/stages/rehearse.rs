//! `rehearse`: the hybrid test run virtually before the specimen is loaded (issue 16; numerical
//! work in `crate::rehearse`). Takes the design stage's product — the rehearsal model, in
//! memory, or read back from `rehearsal_model.json` when the design was up to date — sweeps
//! the time scales (and NS mode counts) and writes `rehearsal_summary/rehearsal_summary.parquet` and
//! `rehearsal/rehearsal.parquet` (`crate::sinks::rehearsal_tables`).

use std::path::{Path, PathBuf};

use crate::error::Result;
use crate::pipeline::{Product, ProductKind, RunContext, Stage, StageKind, StageSource};
use crate::rehearse::{rehearse, RehearsalModel, RehearseSettings};
use crate::sinks::rehearsal_tables::{
    read_rehearsal_model, write_rehearsal, REHEARSAL_FILES, REHEARSAL_MODEL_FILE,
};

pub const KIND: StageKind = StageKind {
    kind: "rehearse",
    needs: &[ProductKind::TestDesign],
    provides: None,
    reads_all_earlier: false,
    build,
};

/// What a rehearsal found (also what `quaketwin rehearse` prints).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RehearsalSummary {
    pub runs: usize,
    pub stable_runs: usize,
    pub ns_modes: usize,
    pub design_time_scale: f64,
    /// The smallest safe λ at the design's NS modes (None: none is safe).
    pub recommended_time_scale: Option<f64>,
    pub recommended_bandwidth_hz: Option<f64>,
    pub recommended_wnrmse: Option<f64>,
    pub outputs: Vec<PathBuf>,
}

/// Rehearse `model` and write the tables into `out_dir`; `source` names the design.
pub fn run_rehearsal(
    model: &RehearsalModel,
    settings: &RehearseSettings,
    out_dir: &Path,
    source: &str,
) -> Result<RehearsalSummary> {
    let r = rehearse(model, settings)?;
    let outputs = write_rehearsal(out_dir, model, &r, settings, source)?;
    let best = r.recommended.map(|i| &r.runs[i]);
    Ok(RehearsalSummary {
        runs: r.runs.len(),
        stable_runs: r.runs.iter().filter(|x| x.stable).count(),
        ns_modes: r.ns_modes,
        design_time_scale: model.time_scale,
        recommended_time_scale: best.map(|b| b.time_scale),
        recommended_bandwidth_hz: best.map(|b| b.bandwidth_hz),
        recommended_wnrmse: best.and_then(|b| b.response_wnrmse),
        outputs,
    })
}

/// `quaketwin rehearse DESIGN_OUT --out DIR`: the rehearsal model of a design run's output
/// directory, rehearsed with `settings`.
pub fn rehearse_design_output(
    design_out: &Path,
    settings: &RehearseSettings,
    out_dir: &Path,
) -> Result<RehearsalSummary> {
    settings.check("rehearsal settings")?;
    let path = design_out.join(REHEARSAL_MODEL_FILE);
    let model = read_rehearsal_model(&path)?;
    std::fs::create_dir_all(out_dir).map_err(|e| crate::error::Error::io(out_dir, e))?;
    run_rehearsal(&model, settings, out_dir, &path.display().to_string())
}

fn build(src: &StageSource) -> Result<Box<dyn Stage>> {
    let settings: RehearseSettings = src.params()?;
    settings.check(&format!(
        "{}: stage {:?} (rehearse): params",
        src.file(),
        src.decl.name
    ))?;
    Ok(Box::new(Rehearse { settings }))
}

struct Rehearse {
    settings: RehearseSettings,
}

impl Stage for Rehearse {
    fn outputs(&self) -> Vec<String> {
        REHEARSAL_FILES.iter().map(|s| s.to_string()).collect()
    }
    fn run(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        let model: RehearsalModel = ctx
            .input::<RehearsalModel>(ProductKind::TestDesign)?
            .clone();
        let source = ctx.out_dir.join(REHEARSAL_MODEL_FILE).display().to_string();
        let s = run_rehearsal(&model, &self.settings, &ctx.out_dir, &source)?;
        ctx.info(match s.recommended_time_scale {
            Some(l) => format!(
                "rehearse: {} runs, {} stable; smallest safe λ = {l} ({} NS modes, bandwidth {:.3} Hz, WNRMSE {:.2e}; design λ = {})",
                s.runs,
                s.stable_runs,
                s.ns_modes,
                s.recommended_bandwidth_hz.unwrap_or(0.0),
                s.recommended_wnrmse.unwrap_or(0.0),
                s.design_time_scale
            ),
            None => format!(
                "rehearse: {} runs, {} stable; no swept λ is safe with {} NS modes",
                s.runs, s.stable_runs, s.ns_modes
            ),
        });
        Ok(None)
    }
}
