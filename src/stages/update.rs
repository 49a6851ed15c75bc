//! `update`: ensemble updating of the event's digital twin against the modes identified by
//! the modal stage (thesis ch. 3, METHODS §3; numerical work in `crate::twin`). Writes
//! `twin_update/twin_update.parquet`, `twin_modes/twin_modes.parquet` and `twin_updated.toml`.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::modal::ModesFile;
use crate::error::{Error, Result};
use crate::pipeline::{Product, ProductKind, RunContext, Stage, StageKind, StageSource};
use crate::sinks::parquet::write_bytes_atomically;
use crate::sinks::twin_tables::{read_measured_modes, write_twin_modes, write_twin_update};
use crate::twin::ensemble::{EnsembleOptions, Selection};
use crate::twin::load_twin;
use crate::twin::objective::ObjectiveOptions;
use crate::twin::optimisers::{Convergence, Optimiser, SolverName};
use crate::twin::update::{update_twin_with, StartPoint};

pub const KIND: StageKind = StageKind {
    kind: "update",
    needs: &[ProductKind::Modes],
    provides: Some(ProductKind::UpdatedTwin),
    reads_all_earlier: false,
    build,
};

/// File names of the stage's outputs.
pub const TWIN_UPDATE_FILE: &str = crate::vocab::tables::TWIN_UPDATE.file;
pub const TWIN_MODES_FILE: &str = crate::vocab::tables::TWIN_MODES.file;
pub const UPDATED_TWIN_FILE: &str = "twin_updated.toml";

/// Parameters of the `update` stage and of `quaketwin update`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct UpdateParams {
    /// Candidate solvers: `ga`, `pso`, `sa`, `ps` (pattern search), `qn` (quasi-Newton),
    /// each with its default settings. Default: all five (the thesis's four plus `qn`).
    pub solvers: Vec<SolverName>,
    /// Seed of every random draw (same seed → same result).
    pub seed: u64,
    /// Upper limit on ensemble rounds (Table 1).
    pub max_rounds: usize,
    /// Stop when every parameter's variance across candidates, in units of its bound range
    /// squared, is below this.
    pub tolerance: f64,
    /// `first` (first-ranked candidate, default) or `mrr` (mean-reciprocal-rank mean).
    pub selection: Selection,
    /// Start point: `twin` (each parameter's `start`, default) or `mid` (middle of the bounds).
    pub start: StartPoint,
    /// Model modes computed beyond the number of measured modes, as pairing candidates.
    pub extra_model_modes: usize,
    /// When GA, PSO and SA stop before their budget (`twin::optimisers::Convergence`).
    pub convergence: Convergence,
}

impl Default for UpdateParams {
    fn default() -> Self {
        let e = EnsembleOptions::default();
        UpdateParams {
            solvers: SolverName::ALL.to_vec(),
            seed: e.seed,
            max_rounds: e.max_rounds,
            tolerance: e.variance_tolerance,
            selection: Selection::FirstRanked,
            start: StartPoint::Twin,
            extra_model_modes: ObjectiveOptions::default().extra_model_modes,
            convergence: Convergence::default(),
        }
    }
}

impl UpdateParams {
    /// Reads a settings file of `quaketwin update` (the stage's params as a
    /// TOML document); errors name the file and line.
    pub fn from_toml(text: &str, file: &str) -> Result<UpdateParams> {
        let params: UpdateParams = toml::from_str(text).map_err(|e| {
            let line = e
                .span()
                .map(|s| format!(" line {}", text[..s.start].matches('\n').count() + 1))
                .unwrap_or_default();
            Error::usage(format!("{file}{line}: {}", e.message()))
        })?;
        params
            .validate()
            .map_err(|e| Error::usage(format!("{file}: {e}")))?;
        Ok(params)
    }

    /// Checks the parameters before any file is read: solvers listed once
    /// each and at least one, rounds and tolerance positive, a usable convergence rule.
    pub fn validate(&self) -> Result<()> {
        self.build_solvers()?;
        self.ensemble_options()?;
        let extra_model_modes = self.extra_model_modes;
        ObjectiveOptions { extra_model_modes }.validate()
    }

    /// The candidate solvers named in `solvers` (usage error for an empty list or repeated names).
    pub fn build_solvers(&self) -> Result<Vec<Box<dyn Optimiser>>> {
        if self.solvers.is_empty() {
            return Err(Error::usage("update: `solvers` is empty"));
        }
        for (i, name) in self.solvers.iter().enumerate() {
            if self.solvers[..i].contains(name) {
                return Err(Error::usage(format!(
                    "update: solver {name:?} is listed twice"
                )));
            }
        }
        let rule = self.convergence.checked()?;
        Ok(self.solvers.iter().map(|s| s.build_with(rule)).collect())
    }

    pub fn ensemble_options(&self) -> Result<EnsembleOptions> {
        let options = EnsembleOptions {
            max_rounds: self.max_rounds,
            variance_tolerance: self.tolerance,
            selection: self.selection,
            seed: self.seed,
        };
        options.validate().map(|()| options)
    }
}

/// What an update did (also what `quaketwin update` prints).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UpdateSummary {
    pub parameter_names: Vec<String>,
    pub start_values: Vec<f64>,
    pub updated_values: Vec<f64>,
    pub objective_initial: f64,
    pub objective_updated: f64,
    /// Mean |Δf|/f_exp before and after updating.
    pub frequency_error_initial: f64,
    pub frequency_error_updated: f64,
    /// Mean (1 − MAC) before and after updating.
    pub shape_error_initial: f64,
    pub shape_error_updated: f64,
    pub rounds: usize,
    pub converged: bool,
    pub evaluations: usize,
    pub twin_update_path: PathBuf,
    pub twin_modes_path: PathBuf,
    pub updated_twin_path: PathBuf,
}

/// Load the twin at `twin_path`, read the measured modes at `modes_path`, run the ensemble
/// update and write `twin_update/twin_update.parquet`, `twin_modes/twin_modes.parquet` and `twin_updated.toml`
/// (each atomically) into `out_dir`. The inputs are not modified.
pub fn update_from_files(
    twin_path: &Path,
    modes_path: &Path,
    out_dir: &Path,
    params: &UpdateParams,
) -> Result<UpdateSummary> {
    // Settings first: a usage error should not wait for the model.
    let solvers = params.build_solvers()?;
    let options = params.ensemble_options()?;
    let twin = load_twin(twin_path)?;
    let modes_file = read_measured_modes(modes_path)?;
    let outcome = update_twin_with(
        &twin,
        modes_file.measured.clone(),
        ObjectiveOptions {
            extra_model_modes: params.extra_model_modes,
        },
        &options,
        &solvers,
        params.start,
    )?;
    let (cmp_before, cmp_after, result) =
        (&outcome.modes_before, &outcome.modes, &outcome.ensemble);
    let names = outcome.parameter_names.clone();
    let settings = serde_json::to_string(params).unwrap_or_default();
    let inputs = serde_json::json!({
        "twin": twin_path.display().to_string(),
        "modes": modes_path.display().to_string(),
    })
    .to_string();
    // The parameters' start values (those the update started from) and bounds,
    // so that a reader (the report's before/after table) needs no twin file.
    let bounds: Vec<serde_json::Value> = twin
        .system
        .parameters
        .iter()
        .zip(&outcome.start_values)
        .map(|(p, start)| {
            use crate::twin::model::ParameterKind::*;
            let kind = twin
                .file
                .parameters
                .iter()
                .find(|d| d.name == p.name)
                .map(|d| match d.kind {
                    YoungsModulus => ("youngs_modulus", "Pa"),
                    Density => ("density", "kg/m^3"),
                    SpringStiffness => ("spring_stiffness", "N/m (N·m/rad for a rotation)"),
                });
            serde_json::json!({
                "name": p.name, "kind": kind.map(|k| k.0), "unit": kind.map(|k| k.1),
                "start": start, "lower": p.lower, "upper": p.upper,
            })
        })
        .collect();
    // The measured modes' provenance (event, conditioning, modal
    // pre-processing) followed by this update.
    let step = serde_json::json!({ "twin": twin_path.display().to_string() });
    let provenance = (modes_file.provenance.clone()).map(|p| p.then_step("twin_update", step));
    let mut meta = provenance.map(|p| p.metadata()).unwrap_or_default();
    meta.extend([
        ("quaketwin.settings".to_string(), settings),
        ("quaketwin.inputs".to_string(), inputs),
        (
            "quaketwin.parameter_bounds".to_string(),
            serde_json::Value::Array(bounds).to_string(),
        ),
    ]);
    let update_path = out_dir.join(TWIN_UPDATE_FILE);
    let modes_path_out = out_dir.join(TWIN_MODES_FILE);
    let twin_out = out_dir.join(UPDATED_TWIN_FILE);
    write_twin_update(&update_path, &names, result, &meta)?;
    write_twin_modes(
        &modes_path_out,
        &modes_file.mode_numbers,
        cmp_before,
        cmp_after,
        &meta,
    )?;
    write_bytes_atomically(&twin_out, outcome.updated_twin_toml.as_bytes())?;
    Ok(UpdateSummary {
        parameter_names: names,
        start_values: outcome.start_values.clone(),
        updated_values: result.parameters.clone(),
        objective_initial: outcome.objective_initial,
        objective_updated: outcome.objective_updated,
        frequency_error_initial: cmp_before.frequency_error,
        frequency_error_updated: cmp_after.frequency_error,
        shape_error_initial: cmp_before.shape_error,
        shape_error_updated: cmp_after.shape_error,
        rounds: result.rounds.len(),
        converged: result.converged,
        evaluations: result.evaluations,
        twin_update_path: update_path,
        twin_modes_path: modes_path_out,
        updated_twin_path: twin_out,
    })
}

fn build(src: &StageSource) -> Result<Box<dyn Stage>> {
    let params: UpdateParams = src.params()?;
    params.validate().map_err(|e| src.invalid(e))?;
    Ok(Box::new(Update { params }))
}

struct Update {
    params: UpdateParams,
}

/// The twin the event names (`structure.twin` in event.toml), if any.
fn event_twin(ctx: &mut RunContext) -> Result<Option<String>> {
    Ok(ctx
        .loaded_event()?
        .event
        .structure
        .as_ref()
        .and_then(|s| s.twin.clone()))
}

impl Stage for Update {
    fn outputs(&self) -> Vec<String> {
        vec![
            TWIN_UPDATE_FILE.into(),
            TWIN_MODES_FILE.into(),
            UPDATED_TWIN_FILE.into(),
        ]
    }
    fn not_applicable(&self, ctx: &mut RunContext) -> Result<Option<String>> {
        Ok(event_twin(ctx)?
            .is_none()
            .then(|| "the event names no twin (structure.twin in event.toml)".to_string()))
    }
    /// The twin named by the event's `structure.twin` (relative to the event folder, or a
    /// member of a zipped event) against the modes of the stage's modal input.
    fn run(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        let twin = event_twin(ctx)?
            .ok_or_else(|| Error::usage("the event names no digital twin (structure.twin)"))?;
        let twin_path = ctx.referenced.resolve(&twin, "structure.twin")?;
        let modes_path = ctx.input::<ModesFile>(ProductKind::Modes)?.path.clone();
        update_from_files(&twin_path, &modes_path, &ctx.out_dir, &self.params)?;
        Ok(None)
    }
}
