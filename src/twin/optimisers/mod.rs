//! Bounded derivative-free optimisers: genetic algorithm, particle swarm, simulated
//! annealing, pattern search.
//!
//! Written here rather than taken from argmin 0.11: argmin has no genetic algorithm and no
//! pattern search, its PSO/annealing draw from `rand` generators whose streams are not
//! guaranteed stable across versions, and the ensemble needs each solver to accept a seed
//! point (one GA individual, one PSO particle, the SA/PS start) and to evaluate populations
//! in parallel with an evaluation order that does not depend on thread scheduling.
//!
//! All solvers work in the unit cube u ∈ [0,1]^Q mapped affinely onto the bounds, and
//! evaluate batches with rayon (`evaluate_batch`), so results repeat exactly for a seed.

pub mod ga;
pub mod pattern;
pub mod pso;
pub mod quasi_newton;
pub mod sa;

use rayon::prelude::*;

pub use ga::GeneticAlgorithm;
pub use pattern::PatternSearch;
pub use pso::ParticleSwarm;
pub use quasi_newton::QuasiNewton;
pub use sa::SimulatedAnnealing;

/// Box bounds.
#[derive(Debug, Clone, PartialEq)]
pub struct Bounds {
    pub lower: Vec<f64>,
    pub upper: Vec<f64>,
}

impl Bounds {
    pub fn new(lower: Vec<f64>, upper: Vec<f64>) -> Self {
        Bounds { lower, upper }
    }
    pub fn dim(&self) -> usize {
        self.lower.len()
    }
    /// Unit-cube coordinates → parameters.
    pub fn to_x(&self, u: &[f64]) -> Vec<f64> {
        u.iter()
            .enumerate()
            .map(|(i, v)| self.lower[i] + v.clamp(0.0, 1.0) * (self.upper[i] - self.lower[i]))
            .collect()
    }
    /// Parameters → unit-cube coordinates (clamped).
    pub fn to_u(&self, x: &[f64]) -> Vec<f64> {
        x.iter()
            .enumerate()
            .map(|(i, v)| {
                let r = self.upper[i] - self.lower[i];
                if r > 0.0 {
                    ((v - self.lower[i]) / r).clamp(0.0, 1.0)
                } else {
                    0.0
                }
            })
            .collect()
    }
    pub fn mid(&self) -> Vec<f64> {
        self.lower
            .iter()
            .zip(&self.upper)
            .map(|(l, u)| 0.5 * (l + u))
            .collect()
    }
}

/// Outcome of one optimisation.
#[derive(Debug, Clone, PartialEq)]
pub struct OptimResult {
    pub x: Vec<f64>,
    pub value: f64,
    pub evaluations: usize,
    /// Iterations/generations performed.
    pub iterations: usize,
}

/// The objective as the optimisers see it.
pub type Objective<'a> = dyn Fn(&[f64]) -> f64 + Sync + 'a;

/// A seedable bounded minimiser.
pub trait Optimiser: Sync + Send {
    fn name(&self) -> &str;
    /// Minimise `f` over `bounds`, starting from / including `seed_point` when given, with
    /// all randomness drawn from `seed`.
    fn minimise(
        &self,
        f: &Objective<'_>,
        bounds: &Bounds,
        seed_point: Option<&[f64]>,
        seed: u64,
    ) -> OptimResult;
}

/// Evaluate f at unit-cube points in parallel; the output order is the input order. NaN is
/// treated as +∞ so comparisons stay total.
pub fn evaluate_batch(f: &Objective<'_>, bounds: &Bounds, points: &[Vec<f64>]) -> Vec<f64> {
    points
        .par_iter()
        .map(|u| {
            let v = f(&bounds.to_x(u));
            if v.is_nan() {
                f64::INFINITY
            } else {
                v
            }
        })
        .collect()
}

/// Index of the smallest value (first on ties).
pub fn argmin(values: &[f64]) -> usize {
    let mut best = 0;
    for (i, v) in values.iter().enumerate() {
        if *v < values[best] {
            best = i;
        }
    }
    best
}

/// The four solvers of the thesis with their default settings.
pub fn thesis_solvers() -> Vec<Box<dyn Optimiser>> {
    vec![
        Box::new(GeneticAlgorithm::default()),
        Box::new(ParticleSwarm::default()),
        Box::new(SimulatedAnnealing::default()),
        Box::new(PatternSearch::default()),
    ]
}

/// The default ensemble: the thesis's four solvers plus the quasi-Newton refiner.
/// A candidate solver of the ensemble by name (settings files), each with its default settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum SolverName {
    #[serde(rename = "ga", alias = "genetic_algorithm")]
    GeneticAlgorithm,
    #[serde(rename = "pso", alias = "particle_swarm")]
    ParticleSwarm,
    #[serde(rename = "sa", alias = "simulated_annealing")]
    SimulatedAnnealing,
    #[serde(rename = "ps", alias = "pattern_search")]
    PatternSearch,
    #[serde(rename = "qn", alias = "quasi_newton")]
    QuasiNewton,
}

impl SolverName {
    /// The thesis's four solvers and quasi-Newton, in `default_solvers` order.
    pub const ALL: [SolverName; 5] = [
        SolverName::GeneticAlgorithm,
        SolverName::ParticleSwarm,
        SolverName::SimulatedAnnealing,
        SolverName::PatternSearch,
        SolverName::QuasiNewton,
    ];
    /// The solver with its default settings.
    pub fn build(self) -> Box<dyn Optimiser> {
        match self {
            SolverName::GeneticAlgorithm => Box::new(GeneticAlgorithm::default()),
            SolverName::ParticleSwarm => Box::new(ParticleSwarm::default()),
            SolverName::SimulatedAnnealing => Box::new(SimulatedAnnealing::default()),
            SolverName::PatternSearch => Box::new(PatternSearch::default()),
            SolverName::QuasiNewton => Box::new(QuasiNewton::default()),
        }
    }
}

pub fn default_solvers() -> Vec<Box<dyn Optimiser>> {
    let mut s = thesis_solvers();
    s.push(Box::new(QuasiNewton::default()));
    s
}
