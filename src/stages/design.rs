//! `design`: hybrid-test design from recorded response (thesis ch. 5–7, METHODS §5–6;
//! numerical work in `crate::design::plan`). Reads a design file (`crate::design::file`),
//! builds the base motion (`crate::design::motion`) — the conditioned event of the stage's
//! `condition` input, or a ground-motion file — and writes the design tables
//! (`crate::sinks::design_tables`) and the rehearsal model (`rehearsal_model.json`,
//! `crate::rehearse::model`), which is also its product for a `rehearse` stage.
//!
//! Which channels drive which twin axis: `crate::design::motion`.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::condition::Conditioned;
use crate::conditioning::{condition_event_with_motion, ConditioningSettings};
use crate::design::file::{load_design, settings_json, LoadedDesign, MotionSource};
use crate::design::motion::design_inputs;
use crate::design::plan::{design_hybrid_test_with, BaseMotion, TestDesign};
use crate::design::recorded::RecordedResponse;
use crate::error::Result;
use crate::hash::Hash64;
use crate::pipeline::fingerprint::path_fingerprint;
use crate::pipeline::{Product, ProductKind, RunContext, Stage, StageKind, StageSource};
use crate::rehearse::RehearsalModel;
use crate::sinks::design_tables::{write_design, DesignProvenance, DESIGN_FILES};
use crate::sinks::rehearsal_tables::{
    read_rehearsal_model, write_rehearsal_model, REHEARSAL_MODEL_FILE,
};
use crate::vocab::Role;

pub const KIND: StageKind = StageKind {
    kind: "design",
    needs: &[ProductKind::ConditionedEvent],
    provides: Some(ProductKind::TestDesign),
    reads_all_earlier: false,
    build,
};

/// Parameters of the `design` stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignParams {
    /// Design file (docs/test-design.md), relative to the event folder (to the directory of
    /// an event zip), or absolute.
    pub design: String,
}

/// What a design run produced (also what `quaketwin design` prints).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DesignSummary {
    pub design_file: String,
    pub twin: String,
    pub motion: String,
    pub ps_nodes: usize,
    pub ps_dofs: usize,
    pub interface_dofs: usize,
    pub rigid_body_modes: usize,
    pub retained_poms: usize,
    pub retained_energy: f64,
    pub control_nodes: usize,
    /// Steps of the interface refinement (rows of interface_refinement/interface_refinement.parquet).
    pub refinement_steps: usize,
    pub actuators: usize,
    pub force_controlled: usize,
    pub wnrmse: f64,
    pub wnrmse_total: f64,
    pub ns_modes: usize,
    pub time_scale: f64,
    pub bandwidth_hz: f64,
    pub outputs: Vec<PathBuf>,
}

/// The design's base motion when run on its own (`quaketwin design`): the event folder of the
/// design file, loaded and conditioned with the METHODS §1 chain (`ConditioningSettings::default()`,
/// the chain pipelines/test-design.toml states), or the file.
pub fn load_motion(design: &LoadedDesign) -> Result<BaseMotion> {
    Ok(load_inputs(design)?.0)
}

/// The base motion and, with `[snapshots] source = "records"`, the recorded response; an
/// event-sourced motion reads the design file's event folder, conditioned with the
/// METHODS §1 chain.
pub fn load_inputs(design: &LoadedDesign) -> Result<(BaseMotion, Option<RecordedResponse>)> {
    match &design.motion.source {
        MotionSource::Event { folder, .. } => {
            let mut event = crate::event_folder::load(folder)?.event;
            condition_event_with_motion(&mut event, &ConditioningSettings::default())?;
            design_inputs(design, Some((&event, &folder.display().to_string())))
        }
        MotionSource::File { .. } => design_inputs(design, None),
    }
}

/// Run the design and write its outputs into `out_dir`; `recorded` is the snapshot source (b)
/// when the design file asks for it.
pub fn run_design(
    design: &LoadedDesign,
    motion: &BaseMotion,
    recorded: Option<&RecordedResponse>,
    out_dir: &Path,
) -> Result<DesignSummary> {
    Ok(design_and_rehearsal_model(design, motion, recorded, out_dir)?.0)
}

/// As [`run_design`], also writing and returning the rehearsal model
/// (`rehearsal_model.json`: what the `rehearse` stage and `quaketwin rehearse` run).
pub fn design_and_rehearsal_model(
    design: &LoadedDesign,
    motion: &BaseMotion,
    recorded: Option<&RecordedResponse>,
    out_dir: &Path,
) -> Result<(DesignSummary, RehearsalModel)> {
    let model = design.model()?;
    let d: TestDesign = design_hybrid_test_with(
        &design.twin,
        &design.ps_node_ids,
        motion,
        recorded,
        &design.settings,
        &design.source,
    )?;
    let provenance = DesignProvenance {
        design_file: design.source.clone(),
        twin: design.twin_path.display().to_string(),
        motion_source: motion.source.clone(),
        settings_json: settings_json(&design.settings),
    };
    let mut outputs = write_design(out_dir, model, &d, &provenance)?;
    let rehearsal = RehearsalModel::from_design(&design.twin, &d, motion, &design.settings.hybrid)?;
    let path = out_dir.join(REHEARSAL_MODEL_FILE);
    write_rehearsal_model(&path, &rehearsal)?;
    outputs.push(path);
    let retained = d.pod_curve.retained;
    let summary = DesignSummary {
        design_file: design.source.clone(),
        twin: provenance.twin,
        motion: motion.source.clone(),
        ps_nodes: design.ps_node_ids.len(),
        ps_dofs: d.partition.n_ps(),
        interface_dofs: d.partition.interface.len(),
        rigid_body_modes: d.rigid.count(),
        retained_poms: retained,
        retained_energy: retained
            .checked_sub(1)
            .and_then(|i| d.pod.cumulative_energy.get(i))
            .copied()
            .unwrap_or(0.0),
        control_nodes: d.interface.control_nodes.len(),
        refinement_steps: d.refinement.len(),
        actuators: d.actuators.len(),
        force_controlled: d
            .actuators
            .iter()
            .filter(|a| a.control == crate::design::layout::ControlMode::Force)
            .count(),
        wnrmse: d.validation.wnrmse,
        wnrmse_total: d.validation.wnrmse_total,
        ns_modes: d.hybrid.prototype.ns_modes,
        time_scale: d.hybrid.time_scale,
        bandwidth_hz: d.hybrid.bandwidth_hz,
        outputs,
    };
    Ok((summary, rehearsal))
}

/// `quaketwin design DESIGN --out DIR`: load, build the motion (and the records, snapshot
/// source (b)), design, write.
pub fn design_from_file(design_path: &Path, out_dir: &Path) -> Result<DesignSummary> {
    crate::fixed_order_reductions();
    let design = load_design(design_path)?;
    let (motion, recorded) = load_inputs(&design)?;
    run_design(&design, &motion, recorded.as_ref(), out_dir)
}

fn build(src: &StageSource) -> Result<Box<dyn Stage>> {
    Ok(Box::new(Design {
        params: src.params()?,
    }))
}

struct Design {
    params: DesignParams,
}

impl Design {
    /// The design file: relative to the event folder; for a zipped event a member of the
    /// zip, else a file beside the zip.
    fn design_path(&self, ctx: &mut RunContext) -> Result<PathBuf> {
        let given = Path::new(&self.params.design);
        if given.is_absolute() {
            return Ok(given.to_path_buf());
        }
        if ctx.referenced.contains(&self.params.design)? {
            return ctx.referenced.resolve(&self.params.design, "design file");
        }
        let base = if ctx.event_path.is_dir() {
            ctx.event_path.clone()
        } else {
            ctx.event_path
                .parent()
                .map(Path::to_path_buf)
                .unwrap_or_default()
        };
        Ok(base.join(given))
    }
}

impl Stage for Design {
    fn outputs(&self) -> Vec<String> {
        DESIGN_FILES
            .iter()
            .chain([&REHEARSAL_MODEL_FILE])
            .map(|s| s.to_string())
            .collect()
    }
    /// The rehearsal model, read back from `rehearsal_model.json`.
    fn restore(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        let model = read_rehearsal_model(&ctx.out_dir.join(REHEARSAL_MODEL_FILE))?;
        Ok(Some(Box::new(model)))
    }
    /// The design file, its twin and (for a file source) the ground-motion file: inputs
    /// outside the event folder that the pipeline would not see.
    fn extra_fingerprint(&self, ctx: &mut RunContext) -> Result<String> {
        let path = self.design_path(ctx)?;
        let design = load_design(&path)?;
        let mut h = Hash64::default();
        h.write_str(&path_fingerprint(&path)?)
            .write_str(&path_fingerprint(&design.twin_path)?);
        if let MotionSource::File { path: f, .. } = &design.motion.source {
            h.write_str(&path_fingerprint(f)?);
        }
        Ok(h.finish_hex())
    }
    /// Not applicable when the design takes its motion from the event, the event has no
    /// base channel (level 0, role input) and the design file lists none.
    fn not_applicable(&self, ctx: &mut RunContext) -> Result<Option<String>> {
        let design = load_design(&self.design_path(ctx)?)?;
        let MotionSource::Event { channels, .. } = &design.motion.source else {
            return Ok(None);
        };
        if !channels.is_empty() {
            return Ok(None);
        }
        let has_base = ctx
            .loaded_event()?
            .event
            .records
            .iter()
            .any(|r| r.channel.level == Some(0) && r.channel.role == Role::Input);
        Ok((!has_base).then(|| {
            "the event has no base channel (level 0, role input) to drive the design".to_string()
        }))
    }
    /// An event-sourced motion is the conditioned event of the stage's input (the design
    /// file's `event` path is replaced by the run's event; its `channels`, `axis`, `scale`
    /// and `duration_s` apply); a file-sourced motion is the file.
    fn run(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        let design = load_design(&self.design_path(ctx)?)?;
        let (motion, recorded) = match &design.motion.source {
            MotionSource::Event { .. } => {
                let origin = ctx.event_path.display().to_string();
                let Conditioned { event, .. } = ctx.input(ProductKind::ConditionedEvent)?;
                design_inputs(&design, Some((event, &origin)))?
            }
            MotionSource::File { .. } => design_inputs(&design, None)?,
        };
        let (summary, model) =
            design_and_rehearsal_model(&design, &motion, recorded.as_ref(), &ctx.out_dir)?;
        ctx.info(format!(
                "design: {} actuators ({} force-controlled), {} POMs retained, WNRMSE {:.2e}, {} NS modes, λ = {}, bandwidth {:.3} Hz",
                summary.actuators,
                summary.force_controlled,
                summary.retained_poms,
                summary.wnrmse,
                summary.ns_modes,
                summary.time_scale,
                summary.bandwidth_hz
        ));
        Ok(Some(Box::new(model)))
    }
}
