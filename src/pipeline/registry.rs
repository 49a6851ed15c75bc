//! The stage kinds this build knows, what files each writes, and the run
//! context through which stages hand products to later stages.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use super::config::StageDecl;
use crate::conditioning::Motion;
use crate::error::{Error, Result};
use crate::event_folder::LoadedEvent;
use crate::sinks::hysteresis_tables::DirectionOutcome;
use crate::stages;
use crate::stages::hysteresis::HysteresisParams;
use crate::vocab::Event;

/// Stage kinds available in this build, in pipeline order.
pub const KINDS: &[&str] = &[
    "ingest",
    "condition",
    "metrics",
    "modal",
    "hysteresis",
    "damage",
    "update",
    "design",
    "report",
];

/// Output files (relative to the output directory) a stage declares.
pub fn outputs(stage: &StageDecl) -> Result<Vec<String>> {
    Ok(match stage.kind.as_str() {
        "ingest" => vec!["event.json".into()],
        "condition" => vec!["samples.parquet".into()],
        "metrics" => vec![
            "channels.parquet".into(),
            "spectra.parquet".into(),
            "drift.parquet".into(),
        ],
        "modal" => stages::modal::outputs(&super::params(stage)?),
        "hysteresis" => vec![
            "bouc_wen.parquet".into(),
            "bouc_wen_instantaneous.parquet".into(),
            "hysteresis_fit.parquet".into(),
        ],
        "damage" => vec!["damage.parquet".into()],
        "report" => vec!["report.html".into()],
        "update" => vec![
            stages::update::TWIN_UPDATE_FILE.into(),
            stages::update::TWIN_MODES_FILE.into(),
            stages::update::UPDATED_TWIN_FILE.into(),
        ],
        "design" => stages::design::outputs(),
        other => return Err(Error::usage(format!("unknown stage kind {other:?}"))),
    })
}

/// Whether a stage of `kind` reads the outputs of every earlier stage (not
/// only its `inputs`): its fingerprint then covers them all.
pub fn reads_all_earlier(kind: &str) -> bool {
    kind == "report"
}

/// Inputs of a stage outside the event folder (files named by its params), as a fingerprint
/// the pipeline adds to the stage's own; empty for stages that read only the event and
/// earlier stages.
pub fn extra_fingerprint(stage: &StageDecl, ctx: &mut RunContext) -> Result<String> {
    match stage.kind.as_str() {
        "design" => stages::design::fingerprint(stage, ctx),
        _ => Ok(String::new()),
    }
}

/// Why a declared stage does not apply to this event (None = it applies).
pub fn not_applicable(stage: &StageDecl, ctx: &mut RunContext) -> Result<Option<String>> {
    Ok(match stage.kind.as_str() {
        "update" => {
            let names_twin = ctx
                .loaded_event()?
                .event
                .structure
                .as_ref()
                .and_then(|s| s.twin.as_ref())
                .is_some();
            (!names_twin)
                .then(|| "the event names no twin (structure.twin in event.toml)".to_string())
        }
        "design" => stages::design::not_applicable(stage, ctx)?,
        "modal" => stages::modal::not_applicable(&ctx.loaded_event()?.event),
        _ => None,
    })
}

/// Runs one stage.
pub fn run_stage(stage: &StageDecl, ctx: &mut RunContext) -> Result<()> {
    match stage.kind.as_str() {
        "ingest" => stages::ingest::run(stage, ctx),
        "condition" => stages::condition::run(stage, ctx),
        "metrics" => stages::metrics::run(stage, ctx),
        "modal" => stages::modal::run(stage, ctx),
        "hysteresis" => stages::hysteresis::run(stage, ctx),
        "damage" => stages::hysteresis::run_damage(stage, ctx),
        "report" => stages::report::run(stage, ctx),
        "update" => stages::update::run(stage, ctx),
        "design" => stages::design::run(stage, ctx),
        other => Err(Error::usage(format!("unknown stage kind {other:?}"))),
    }
}

/// Products of the stages of one run.  A product is computed by its stage,
/// or — when that stage was skipped as up to date — loaded back from the
/// stage's output files on first use.
pub struct RunContext {
    pub event_path: PathBuf,
    pub out_dir: PathBuf,
    pub quiet: bool,
    skipped: BTreeSet<String>,
    pub loaded: Option<LoadedEvent>,
    /// Conditioned event and its acceleration/velocity/displacement.
    pub conditioned: Option<(Event, Vec<Motion>)>,
    /// Bouc-Wen identification per direction, with the params it used.
    pub hysteresis: Option<(Vec<DirectionOutcome>, HysteresisParams)>,
    /// The declarations of the pipeline's stages (a stage may need another's params).
    pub stage_decls: Vec<StageDecl>,
    /// Files the event refers to (twin, design file), read from a zipped event too.
    pub referenced: crate::event_folder::ReferencedFiles,
}

impl RunContext {
    pub fn new(event_path: &Path, out_dir: &Path, quiet: bool) -> Self {
        RunContext {
            event_path: event_path.to_path_buf(),
            out_dir: out_dir.to_path_buf(),
            quiet,
            skipped: BTreeSet::new(),
            loaded: None,
            conditioned: None,
            hysteresis: None,
            stage_decls: Vec::new(),
            referenced: crate::event_folder::ReferencedFiles::new(event_path),
        }
    }
    /// The first stage of `kind` in the pipeline.
    pub fn stage_decl_of_kind(&self, kind: &str) -> Option<StageDecl> {
        self.stage_decls.iter().find(|s| s.kind == kind).cloned()
    }
    pub fn mark_skipped(&mut self, stage: &str) {
        self.skipped.insert(stage.to_string());
    }
    pub fn was_skipped(&self, stage: &str) -> bool {
        self.skipped.contains(stage)
    }
    /// The ingested (raw) event; read from the event folder on first use.
    pub fn loaded_event(&mut self) -> Result<&LoadedEvent> {
        if self.loaded.is_none() {
            self.loaded = Some(crate::event_folder::load(&self.event_path)?);
        }
        Ok(self.loaded.as_ref().expect("just set")) // ok: set above
    }

    /// The conditioned event; loaded back from `samples.parquet` when the
    /// `condition` stage was skipped as up to date.
    pub fn conditioned_event(&mut self) -> Result<(&Event, &Vec<Motion>)> {
        if self.conditioned.is_none() {
            let path = self.out_dir.join("samples.parquet");
            if !path.exists() {
                return Err(Error::usage(
                    "this stage needs a `condition` stage before it",
                ));
            }
            self.conditioned = Some(crate::sinks::event_tables::read_samples(&path)?);
        }
        let (e, m) = self.conditioned.as_ref().expect("just set"); // ok: set above
        Ok((e, m))
    }
}
