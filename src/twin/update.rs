//! One call for the `update` command: ensemble-update a twin against measured modes and
//! gather what the outputs need (twin_update/twin_update.parquet rows are in `ensemble.rounds`,
//! twin_modes/twin_modes.parquet rows in `modes`, the updated twin file text in `updated_twin_toml`).

use super::ensemble::{run_ensemble, EnsembleOptions, EnsembleResult};
use super::file::{updated_twin_toml, Twin};
use super::objective::{
    compare_modes, MeasuredModes, ModalObjective, ModeComparison, ObjectiveOptions,
};
use super::optimisers::{default_solvers, Bounds, Optimiser};
use crate::error::Error;
use crate::Result;

#[derive(Debug, Clone)]
pub struct UpdateOutcome {
    pub parameter_names: Vec<String>,
    /// The start point of the search.
    pub start_values: Vec<f64>,
    pub objective_initial: f64,
    pub objective_updated: f64,
    pub ensemble: EnsembleResult,
    /// Paired modes at the updated parameters, with the frequency and shape errors.
    pub modes: ModeComparison,
    /// Paired modes at the start values (before updating), for comparison.
    pub modes_before: ModeComparison,
    pub updated_twin_toml: String,
}

/// Where the search starts (settings files: `twin`, `mid`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StartPoint {
    /// Each parameter's `start` in the twin file.
    #[default]
    Twin,
    /// The middle of each parameter's bounds.
    Mid,
}

/// Update `twin` against `measured` from the twin's start values with the default candidates.
pub fn update_twin(
    twin: &Twin,
    measured: MeasuredModes,
    objective_options: ObjectiveOptions,
    options: &EnsembleOptions,
) -> Result<UpdateOutcome> {
    update_twin_with(
        twin,
        measured,
        objective_options,
        options,
        &default_solvers(),
        StartPoint::Twin,
    )
}

/// Update `twin` against `measured` from `start` with the candidate `solvers`
/// (METHODS §3: ensemble rounds, Plackett–Luce rank aggregation).
pub fn update_twin_with(
    twin: &Twin,
    measured: MeasuredModes,
    objective_options: ObjectiveOptions,
    options: &EnsembleOptions,
    solvers: &[Box<dyn Optimiser>],
    start: StartPoint,
) -> Result<UpdateOutcome> {
    let system = &twin.system;
    if system.parameters.is_empty() {
        return Err(Error::input(
            crate::error::Location::file(twin.source.clone()),
            "the twin has no [[parameters]] to update",
        ));
    }
    let objective = ModalObjective::new(system, measured, objective_options)?;
    let bounds = Bounds::new(system.lower_bounds(), system.upper_bounds());
    let start = match start {
        StartPoint::Twin => system.start_values(),
        StartPoint::Mid => system.mid_bounds(),
    };
    system.check_parameters(&start)?;
    let before = objective.evaluate(&start);
    if !before.objective.is_finite() {
        return Err(Error::numerical(format!(
            "{}: the model's modes could not be computed at the start values",
            twin.source
        )));
    }
    let ensemble = run_ensemble(&objective, &bounds, &start, solvers, options)?;
    let after = objective.evaluate(&ensemble.parameters);
    let names: Vec<String> = system.parameters.iter().map(|p| p.name.clone()).collect();
    let values: Vec<(String, f64)> = names
        .iter()
        .cloned()
        .zip(ensemble.parameters.iter().copied())
        .collect();
    Ok(UpdateOutcome {
        parameter_names: names,
        start_values: start,
        objective_initial: before.objective,
        objective_updated: after.objective,
        modes: compare_modes(&after.pairs),
        modes_before: compare_modes(&before.pairs),
        updated_twin_toml: updated_twin_toml(&twin.file, &values)?,
        ensemble,
    })
}
