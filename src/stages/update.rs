//! `update`: ensemble updating of the event's digital twin against the modes identified by
//! the modal stage (thesis ch. 3, METHODS §3; numerical work in `crate::twin`). Writes
//! `twin_update.parquet`, `twin_modes.parquet` and `twin_updated.toml`.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::pipeline::{params, RunContext, StageDecl};
use crate::sinks::parquet::write_bytes_atomically;
use crate::sinks::twin_tables::{read_measured_modes, write_twin_modes, write_twin_update};
use crate::twin::ensemble::{run_ensemble, EnsembleOptions, Selection};
use crate::twin::objective::{compare_modes, ModalObjective, ObjectiveOptions};
use crate::twin::optimisers::{
    Bounds, GeneticAlgorithm, Optimiser, ParticleSwarm, PatternSearch, QuasiNewton,
    SimulatedAnnealing,
};
use crate::twin::{load_twin, updated_twin_toml};

/// File names of the stage's outputs.
pub const TWIN_UPDATE_FILE: &str = "twin_update.parquet";
pub const TWIN_MODES_FILE: &str = "twin_modes.parquet";
pub const UPDATED_TWIN_FILE: &str = "twin_updated.toml";

/// Parameters of the `update` stage and of `quaketwin update`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct UpdateParams {
    /// Candidate solvers: `ga`, `pso`, `sa`, `ps` (pattern search), `qn` (quasi-Newton),
    /// each with its default settings. Default: all five (the thesis's four plus `qn`).
    pub solvers: Vec<String>,
    /// Seed of every random draw (same seed → same result).
    pub seed: u64,
    /// Upper limit on ensemble rounds (Table 1).
    pub max_rounds: usize,
    /// Stop when every parameter's variance across candidates, in units of its bound range
    /// squared, is below this.
    pub tolerance: f64,
    /// `first` (first-ranked candidate, default) or `mrr` (mean-reciprocal-rank mean).
    pub selection: String,
    /// Start point: `twin` (each parameter's `start`, default) or `mid` (middle of the bounds).
    pub start: String,
    /// Model modes computed beyond the number of measured modes, as pairing candidates.
    pub extra_model_modes: usize,
}

impl Default for UpdateParams {
    fn default() -> Self {
        let e = EnsembleOptions::default();
        UpdateParams {
            solvers: ["ga", "pso", "sa", "ps", "qn"]
                .into_iter()
                .map(String::from)
                .collect(),
            seed: e.seed,
            max_rounds: e.max_rounds,
            tolerance: e.variance_tolerance,
            selection: "first".into(),
            start: "twin".into(),
            extra_model_modes: ObjectiveOptions::default().extra_model_modes,
        }
    }
}

impl UpdateParams {
    /// The candidate solvers named in `solvers` (usage error for unknown or repeated names).
    pub fn build_solvers(&self) -> Result<Vec<Box<dyn Optimiser>>> {
        if self.solvers.is_empty() {
            return Err(Error::usage("update: `solvers` is empty"));
        }
        let mut out: Vec<Box<dyn Optimiser>> = Vec::new();
        let mut seen = Vec::new();
        for name in &self.solvers {
            let key = name.to_ascii_lowercase();
            let solver: Box<dyn Optimiser> = match key.as_str() {
                "ga" | "genetic_algorithm" => Box::new(GeneticAlgorithm::default()),
                "pso" | "particle_swarm" => Box::new(ParticleSwarm::default()),
                "sa" | "simulated_annealing" => Box::new(SimulatedAnnealing::default()),
                "ps" | "pattern_search" => Box::new(PatternSearch::default()),
                "qn" | "quasi_newton" => Box::new(QuasiNewton::default()),
                _ => {
                    return Err(Error::usage(format!(
                        "update: unknown solver {name:?} (ga, pso, sa, ps, qn)"
                    )))
                }
            };
            if seen.contains(&solver.name().to_string()) {
                return Err(Error::usage(format!(
                    "update: solver {name:?} is listed twice"
                )));
            }
            seen.push(solver.name().to_string());
            out.push(solver);
        }
        Ok(out)
    }

    pub fn ensemble_options(&self) -> Result<EnsembleOptions> {
        let selection = match self.selection.as_str() {
            "first" => Selection::FirstRanked,
            "mrr" => Selection::MeanReciprocalRank,
            s => {
                return Err(Error::usage(format!(
                    "update: selection {s:?} must be \"first\" or \"mrr\""
                )))
            }
        };
        if self.max_rounds == 0 {
            return Err(Error::usage("update: max_rounds must be at least 1"));
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(Error::usage("update: tolerance must be a positive number"));
        }
        Ok(EnsembleOptions {
            max_rounds: self.max_rounds,
            variance_tolerance: self.tolerance,
            selection,
            seed: self.seed,
        })
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
/// update and write `twin_update.parquet`, `twin_modes.parquet` and `twin_updated.toml`
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
    let system = &twin.system;
    if system.parameters.is_empty() {
        return Err(Error::input(
            crate::error::Location::file(twin.source.clone()),
            "the twin has no [[parameters]] to update",
        ));
    }
    let start = match params.start.as_str() {
        "twin" => system.start_values(),
        "mid" => system.mid_bounds(),
        s => {
            return Err(Error::usage(format!(
                "update: start {s:?} must be \"twin\" or \"mid\""
            )))
        }
    };
    system.check_parameters(&start)?;
    let objective = ModalObjective::new(
        system,
        modes_file.measured.clone(),
        ObjectiveOptions {
            extra_model_modes: params.extra_model_modes,
        },
    )?;
    let bounds = Bounds::new(system.lower_bounds(), system.upper_bounds());
    let before = objective.evaluate(&start);
    if !before.objective.is_finite() {
        return Err(Error::numerical(format!(
            "{}: the model's modes could not be computed at the start values",
            twin.source
        )));
    }
    let result = run_ensemble(&objective, &bounds, &start, &solvers, &options)?;
    let after = objective.evaluate(&result.parameters);
    let cmp_before = compare_modes(&before.pairs);
    let cmp_after = compare_modes(&after.pairs);
    let names: Vec<String> = system.parameters.iter().map(|p| p.name.clone()).collect();
    let values: Vec<(String, f64)> = names
        .iter()
        .cloned()
        .zip(result.parameters.iter().copied())
        .collect();
    let toml_text = updated_twin_toml(&twin.file, &values)?;

    let settings = serde_json::to_string(params).unwrap_or_default();
    let inputs = serde_json::json!({
        "twin": twin_path.display().to_string(),
        "modes": modes_path.display().to_string(),
    })
    .to_string();
    let meta = vec![
        ("quaketwin.settings".to_string(), settings),
        ("quaketwin.inputs".to_string(), inputs),
    ];
    let update_path = out_dir.join(TWIN_UPDATE_FILE);
    let modes_path_out = out_dir.join(TWIN_MODES_FILE);
    let twin_out = out_dir.join(UPDATED_TWIN_FILE);
    write_twin_update(&update_path, &names, &result, &meta)?;
    write_twin_modes(
        &modes_path_out,
        &modes_file.mode_numbers,
        &cmp_before,
        &cmp_after,
        &meta,
    )?;
    write_bytes_atomically(&twin_out, toml_text.as_bytes())?;
    Ok(UpdateSummary {
        parameter_names: names,
        start_values: start,
        updated_values: result.parameters.clone(),
        objective_initial: before.objective,
        objective_updated: after.objective,
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

/// Pipeline stage: the twin named by the event's `structure.twin` (relative to the event
/// folder, or a member of a zipped event) against `modes.parquet` in the output folder. An event without a twin is a usage
/// error; the registry decides whether to skip the stage instead.
pub fn run(stage: &StageDecl, ctx: &mut RunContext) -> Result<()> {
    let p: UpdateParams = params(stage)?;
    let twin = ctx
        .loaded_event()?
        .event
        .structure
        .as_ref()
        .and_then(|s| s.twin.clone())
        .ok_or_else(|| {
            Error::usage(format!(
                "stage {:?} (update): the event names no digital twin (structure.twin)",
                stage.name
            ))
        })?;
    let twin_path = ctx.referenced.resolve(&twin, "structure.twin")?;
    let modes_path = ctx.out_dir.join("modes.parquet");
    update_from_files(&twin_path, &modes_path, &ctx.out_dir, &p)?;
    Ok(())
}
