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

/// When an optimiser stops before its evaluation budget (the `update` stage's `convergence`
/// param, docs/pipelines.md): the budget is set by convergence, not by a fixed count.
///
/// - Stall: the best objective J* has not improved by more than `tolerance`·|J*| (relative)
///   for `window` consecutive iterations — GA generations, PSO iterations, SA steps.
/// - Collapse (GA, PSO): every parameter's spread over the population (max − min, in the
///   unit cube of the bounds) is below `collapse`: the population sits on one point and can
///   only repeat it.
///
/// Pattern search and quasi-Newton keep their own convergence tests (mesh size, step length),
/// which already stop them at a point.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Convergence {
    /// Relative improvement of the best objective that counts as progress.
    pub tolerance: f64,
    /// Iterations without progress before the optimiser stops.
    pub window: usize,
    /// Population spread (unit cube) below which GA and PSO stop.
    pub collapse: f64,
}

impl Default for Convergence {
    fn default() -> Self {
        Convergence {
            tolerance: 1e-6,
            window: 10,
            collapse: 1e-6,
        }
    }
}

/// Most iterations without progress (`convergence.window`) before a solver
/// stops: beyond any solver's budget.
pub const MAX_CONVERGENCE_WINDOW: usize = 100_000;

impl Convergence {
    /// The rule itself, or a usage error naming the setting it cannot use.
    pub fn checked(self) -> crate::Result<Convergence> {
        let bad = |m: &str| {
            Err(crate::error::Error::usage(format!(
                "update: convergence.{m}"
            )))
        };
        if !(self.tolerance.is_finite() && self.tolerance >= 0.0) {
            return bad("tolerance must be a number ≥ 0");
        }
        if !(1..=MAX_CONVERGENCE_WINDOW).contains(&self.window) {
            return bad("window must be 1..=100000 iterations");
        }
        if !(self.collapse.is_finite() && self.collapse >= 0.0) {
            return bad("collapse must be a number ≥ 0");
        }
        Ok(self)
    }

    /// Whether `candidate` improves on `best` by more than the relative tolerance
    /// (any finite value improves on +∞).
    pub fn improves(&self, candidate: f64, best: f64) -> bool {
        if best.is_infinite() {
            return candidate < best;
        }
        candidate < best - self.tolerance * best.abs().max(1e-300)
    }

    /// Whether every coordinate of `points` (unit cube) spans less than `collapse`.
    pub fn collapsed(&self, points: &[Vec<f64>]) -> bool {
        let Some(first) = points.first() else {
            return true;
        };
        (0..first.len()).all(|d| {
            let (lo, hi) = points
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| {
                    (l.min(p[d]), h.max(p[d]))
                });
            hi - lo < self.collapse
        })
    }
}

/// The stall count of [`Convergence`]: iterations since the best value last improved by more
/// than the tolerance.
#[derive(Debug, Clone)]
pub struct Stall {
    rule: Convergence,
    /// Best value when progress was last counted.
    reference: f64,
    since: usize,
}

impl Stall {
    pub fn new(rule: Convergence, best: f64) -> Self {
        Stall {
            rule,
            reference: best,
            since: 0,
        }
    }
    /// Records the best value after one more iteration; true when the window has passed
    /// without progress.
    pub fn update(&mut self, best: f64) -> bool {
        if self.rule.improves(best, self.reference) {
            self.reference = best;
            self.since = 0;
        } else {
            self.since += 1;
        }
        self.since >= self.rule.window
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
        self.build_with(Convergence::default())
    }
    /// The solver with its default settings and the stopping rule `convergence`.
    pub fn build_with(self, convergence: Convergence) -> Box<dyn Optimiser> {
        match self {
            SolverName::GeneticAlgorithm => Box::new(GeneticAlgorithm {
                convergence,
                ..Default::default()
            }),
            SolverName::ParticleSwarm => Box::new(ParticleSwarm {
                convergence,
                ..Default::default()
            }),
            SolverName::SimulatedAnnealing => Box::new(SimulatedAnnealing {
                convergence,
                ..Default::default()
            }),
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
