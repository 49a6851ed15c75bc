//! Simulated annealing (Kirkpatrick et al. 1983; schedule in the spirit of Ingber 2000):
//! Gaussian moves whose length shrinks with the temperature, Metropolis acceptance on the
//! relative increase Δ/|f_current|, geometric cooling. Each step draws a fixed batch of
//! proposals evaluated in parallel and scans them in order, moving at the first accepted one
//! (the batch size is fixed, so the result does not depend on the thread count). Stops after
//! `max_evaluations` or earlier by `convergence` (stall of the
//! best value over a window of steps).

use super::{evaluate_batch, Bounds, Convergence, Objective, OptimResult, Optimiser, Stall};
use crate::rng::Rng;

#[derive(Debug, Clone)]
pub struct SimulatedAnnealing {
    pub initial_temperature: f64,
    pub cooling: f64,
    /// Move standard deviation at T = T0 in the unit cube.
    pub initial_step: f64,
    pub min_step: f64,
    pub batch: usize,
    pub max_evaluations: usize,
    /// Stop earlier: stall of the best value over a window of steps.
    pub convergence: Convergence,
}

impl Default for SimulatedAnnealing {
    fn default() -> Self {
        SimulatedAnnealing {
            initial_temperature: 1.0,
            cooling: 0.97,
            initial_step: 0.2,
            min_step: 1e-4,
            batch: 4,
            max_evaluations: 2500,
            convergence: Convergence::default(),
        }
    }
}

impl Optimiser for SimulatedAnnealing {
    fn name(&self) -> &str {
        "SA"
    }

    fn minimise(
        &self,
        f: &Objective<'_>,
        bounds: &Bounds,
        seed_point: Option<&[f64]>,
        seed: u64,
    ) -> OptimResult {
        let dim = bounds.dim();
        let mut rng = Rng::new(seed);
        let mut cur = match seed_point {
            Some(s) => bounds.to_u(s),
            None => (0..dim).map(|_| rng.uniform()).collect(),
        };
        let mut cur_v = evaluate_batch(f, bounds, std::slice::from_ref(&cur))[0];
        let mut evaluations = 1;
        let (mut best_u, mut best_v) = (cur.clone(), cur_v);
        let mut stall = Stall::new(self.convergence, best_v);
        let mut converged = false;
        let mut temperature = self.initial_temperature;
        let mut steps = 0;
        while evaluations < self.max_evaluations && !converged {
            steps += 1;
            let step =
                (self.initial_step * temperature / self.initial_temperature).max(self.min_step);
            let proposals: Vec<Vec<f64>> = (0..self.batch.max(1))
                .map(|_| {
                    cur.iter()
                        .map(|c| (c + step * rng.normal_uncached()).clamp(0.0, 1.0))
                        .collect()
                })
                .collect();
            let values = evaluate_batch(f, bounds, &proposals);
            evaluations += proposals.len();
            // Acceptance draws are taken for every proposal so the stream does not depend on
            // which one is accepted.
            let draws: Vec<f64> = (0..proposals.len()).map(|_| rng.uniform()).collect();
            for (k, (&v, p)) in values.iter().zip(proposals.iter()).enumerate() {
                if v < best_v {
                    best_v = v;
                    best_u = p.clone();
                }
                let delta = (v - cur_v) / cur_v.abs().max(1e-300);
                let accept =
                    v <= cur_v || (v.is_finite() && draws[k] < (-delta / temperature).exp());
                if accept {
                    cur = p.clone();
                    cur_v = v;
                    break;
                }
            }
            temperature *= self.cooling;
            converged = stall.update(best_v);
        }
        OptimResult {
            x: bounds.to_x(&best_u),
            value: best_v,
            evaluations,
            iterations: steps,
        }
    }
}
