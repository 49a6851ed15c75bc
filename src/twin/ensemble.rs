//! Ensemble model updating with Plackett–Luce rank aggregation (thesis Table 1, METHODS §3).
//!
//! Round r: every candidate solver minimises J from the current point (seeded: start point
//! of pattern search and annealing, one GA individual, one PSO particle); the candidates'
//! predictions z_i give scatters β (Eq. 3) and scores w (Eq. 4); the most likely ranking
//! (Eq. 1–2) selects the new point (first-ranked candidate, or the mean-reciprocal-rank
//! mean); stop when the variance across candidates of every parameter — measured in the
//! unit cube of the bounds, so parameters of different units compare — is below the
//! tolerance (Table 1, B), or after `max_rounds`.

use rayon::prelude::*;

use super::objective::{normalised_scatter, ModalObjective};
use super::optimisers::{Bounds, Optimiser};
use super::plackett_luce::{best_ranking, scores, RankingMethod};
use crate::error::Error;
use crate::rng::Rng;
use crate::Result;

/// What the ensemble needs from a calibration problem.
pub trait UpdateProblem: Sync {
    /// Measured quantities z_e (the voters' targets).
    fn measured(&self) -> Vec<f64>;
    /// J and the model quantities z at x (J = +∞ when the model cannot be solved).
    fn evaluate(&self, x: &[f64]) -> (f64, Vec<f64>);
    fn voter_names(&self) -> Vec<String> {
        (1..=self.measured().len())
            .map(|k| format!("z{k}"))
            .collect()
    }
}

impl UpdateProblem for ModalObjective<'_> {
    fn measured(&self) -> Vec<f64> {
        self.measured_z()
    }
    fn evaluate(&self, x: &[f64]) -> (f64, Vec<f64>) {
        let e = ModalObjective::evaluate(self, x);
        (e.objective, e.z)
    }
    fn voter_names(&self) -> Vec<String> {
        ModalObjective::voter_names(self)
    }
}

/// How the new parameter values are formed from the selected ranking
/// (settings files: `first`, `mrr`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Selection {
    /// The parameters of the first-ranked candidate.
    #[serde(rename = "first")]
    FirstRanked,
    /// Σ_r (1/r) x_(r) / Σ_r (1/r) over the ranking positions r.
    #[serde(rename = "mrr")]
    MeanReciprocalRank,
}

#[derive(Debug, Clone)]
pub struct EnsembleOptions {
    pub max_rounds: usize,
    /// Tolerance on the variance across candidates of each parameter in the unit cube.
    pub variance_tolerance: f64,
    pub selection: Selection,
    pub seed: u64,
}

impl Default for EnsembleOptions {
    fn default() -> Self {
        EnsembleOptions {
            max_rounds: 8,
            variance_tolerance: 1e-4,
            selection: Selection::FirstRanked,
            seed: 1,
        }
    }
}

/// Most ensemble rounds (`max_rounds`; default 8): each runs every solver
/// to its budget.
pub const MAX_ROUNDS: usize = 1000;

impl EnsembleOptions {
    /// Options an update can run with, else a usage error naming the key.
    pub fn validate(&self) -> crate::Result<()> {
        if !(1..=MAX_ROUNDS).contains(&self.max_rounds) {
            return Err(crate::Error::usage(format!(
                "update: max_rounds = {}: must be 1..={MAX_ROUNDS}",
                self.max_rounds
            )));
        }
        if !(self.variance_tolerance.is_finite() && self.variance_tolerance > 0.0) {
            return Err(crate::Error::usage(
                "update: tolerance must be a positive number",
            ));
        }
        Ok(())
    }
}

/// One candidate in one round (a row of twin_update/twin_update.parquet).
#[derive(Debug, Clone, PartialEq)]
pub struct CandidateRecord {
    pub round: usize,
    pub candidate: usize,
    pub solver: String,
    pub parameters: Vec<f64>,
    pub objective: f64,
    /// Model quantities z_i (voter order).
    pub z: Vec<f64>,
    /// β_k,i per voter (Eq. 3).
    pub scatters: Vec<f64>,
    /// w_k,i per voter (Eq. 4).
    pub scores: Vec<f64>,
    /// 1-based position in the selected ranking.
    pub rank: usize,
    /// Weight of this candidate in the new parameters (1 for the first-ranked candidate
    /// under `FirstRanked`; normalised 1/rank under `MeanReciprocalRank`).
    pub selection_weight: f64,
    pub selected: bool,
    pub evaluations: usize,
}

#[derive(Debug, Clone, PartialEq)]
pub struct RoundRecord {
    pub round: usize,
    /// Seed point of this round.
    pub start: Vec<f64>,
    pub candidates: Vec<CandidateRecord>,
    /// Candidate indices, best first.
    pub ranking: Vec<usize>,
    pub log_probability: f64,
    pub method: RankingMethod,
    pub selected_parameters: Vec<f64>,
    pub selected_objective: f64,
    /// Variance across candidates of each parameter (unit cube).
    pub variance: Vec<f64>,
    pub converged: bool,
}

#[derive(Debug, Clone, PartialEq)]
pub struct EnsembleResult {
    pub voter_names: Vec<String>,
    pub measured: Vec<f64>,
    pub rounds: Vec<RoundRecord>,
    /// Final (selected) parameters.
    pub parameters: Vec<f64>,
    pub objective: f64,
    pub z: Vec<f64>,
    pub converged: bool,
    pub evaluations: usize,
}

fn population_variance(values: &[f64]) -> f64 {
    let n = values.len().max(1) as f64;
    let mean = values.iter().sum::<f64>() / n;
    values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n
}

/// Run the ensemble loop of Table 1.
pub fn run_ensemble(
    problem: &dyn UpdateProblem,
    bounds: &Bounds,
    start: &[f64],
    solvers: &[Box<dyn Optimiser>],
    options: &EnsembleOptions,
) -> Result<EnsembleResult> {
    let q = bounds.dim();
    if start.len() != q || bounds.upper.len() != q {
        return Err(Error::usage(format!(
            "ensemble: start has {} values, bounds {q}",
            start.len()
        )));
    }
    for (i, v) in start.iter().enumerate() {
        if !(v.is_finite() && *v >= bounds.lower[i] && *v <= bounds.upper[i]) {
            return Err(Error::usage(format!(
                "ensemble: start value {v} of parameter {} is outside [{}, {}]",
                i + 1,
                bounds.lower[i],
                bounds.upper[i]
            )));
        }
    }
    if solvers.is_empty() {
        return Err(Error::usage("ensemble: no candidate solvers"));
    }
    let measured = problem.measured();
    let objective = |x: &[f64]| problem.evaluate(x).0;
    let mut point = start.to_vec();
    let mut rounds = Vec::new();
    let mut evaluations = 0;
    let mut converged = false;
    for round in 0..options.max_rounds.max(1) {
        let results: Vec<_> = solvers
            .par_iter()
            .enumerate()
            .map(|(i, s)| {
                let seed = Rng::derived(options.seed, (round as u64) << 16 | i as u64).next_u64();
                s.minimise(&objective, bounds, Some(&point), seed)
            })
            .collect();
        let predictions: Vec<(f64, Vec<f64>)> =
            results.par_iter().map(|r| problem.evaluate(&r.x)).collect();
        evaluations += results.iter().map(|r| r.evaluations).sum::<usize>() + results.len();
        // β[k][i] (Eq. 3) and w[k][i] (Eq. 4).
        let scatters: Vec<Vec<f64>> = (0..measured.len())
            .map(|k| {
                predictions
                    .iter()
                    .map(|(_, z)| {
                        let b =
                            normalised_scatter(measured[k], z.get(k).copied().unwrap_or(f64::NAN));
                        if b.is_finite() {
                            b
                        } else {
                            f64::INFINITY
                        }
                    })
                    .collect()
            })
            .collect();
        let weights = scores(&scatters);
        let ranking = best_ranking(&weights);
        let positions = ranking.positions();
        let n = solvers.len();
        let mut selection_weight = vec![0.0; n];
        match options.selection {
            Selection::FirstRanked => selection_weight[ranking.order[0]] = 1.0,
            Selection::MeanReciprocalRank => {
                let total: f64 = (1..=n).map(|r| 1.0 / r as f64).sum();
                for i in 0..n {
                    selection_weight[i] = (1.0 / positions[i] as f64) / total;
                }
            }
        }
        let mut selected = vec![0.0; q];
        for (i, r) in results.iter().enumerate() {
            for d in 0..q {
                selected[d] += selection_weight[i] * r.x[d];
            }
        }
        for d in 0..q {
            selected[d] = selected[d].clamp(bounds.lower[d], bounds.upper[d]);
        }
        let (selected_objective, _) = problem.evaluate(&selected);
        let units: Vec<Vec<f64>> = results.iter().map(|r| bounds.to_u(&r.x)).collect();
        let variance: Vec<f64> = (0..q)
            .map(|d| population_variance(&units.iter().map(|u| u[d]).collect::<Vec<_>>()))
            .collect();
        let round_converged = variance.iter().all(|v| *v < options.variance_tolerance);
        let candidates = results
            .iter()
            .zip(predictions.iter())
            .enumerate()
            .map(|(i, (r, (j, z)))| CandidateRecord {
                round,
                candidate: i,
                solver: solvers[i].name().to_string(),
                parameters: r.x.clone(),
                objective: *j,
                z: z.clone(),
                scatters: scatters.iter().map(|b| b[i]).collect(),
                scores: weights.iter().map(|w| w[i]).collect(),
                rank: positions[i],
                selection_weight: selection_weight[i],
                selected: selection_weight[i] > 0.0,
                evaluations: r.evaluations,
            })
            .collect();
        rounds.push(RoundRecord {
            round,
            start: point.clone(),
            candidates,
            ranking: ranking.order.clone(),
            log_probability: ranking.log_probability,
            method: ranking.method,
            selected_parameters: selected.clone(),
            selected_objective,
            variance,
            converged: round_converged,
        });
        point = selected;
        if round_converged {
            converged = true;
            break;
        }
    }
    let (objective_value, z) = problem.evaluate(&point);
    Ok(EnsembleResult {
        voter_names: problem.voter_names(),
        measured,
        rounds,
        parameters: point,
        objective: objective_value,
        z,
        converged,
        evaluations,
    })
}
