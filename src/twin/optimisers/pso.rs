//! Particle swarm optimisation (Kennedy & Eberhart 1995) with the constriction coefficients
//! of Clerc & Kennedy (w = 0.7298, c1 = c2 = 1.49618), global-best topology, velocity clamp,
//! absorbing walls. The seed point, when given, is particle 0 (at rest). Stops after
//! `max_iterations` or earlier by `convergence` (stall of the best value, or a collapsed swarm).

use super::{
    argmin, evaluate_batch, Bounds, Convergence, Objective, OptimResult, Optimiser, Stall,
};
use crate::rng::Rng;

#[derive(Debug, Clone)]
pub struct ParticleSwarm {
    pub particles: usize,
    pub max_iterations: usize,
    /// Stop earlier: stall over a window of iterations, or swarm collapse.
    pub convergence: Convergence,
    pub inertia: f64,
    pub cognitive: f64,
    pub social: f64,
    /// Largest velocity component in the unit cube.
    pub max_velocity: f64,
}

impl Default for ParticleSwarm {
    fn default() -> Self {
        ParticleSwarm {
            particles: 30,
            max_iterations: 100,
            convergence: Convergence::default(),
            inertia: 0.7298,
            cognitive: 1.49618,
            social: 1.49618,
            max_velocity: 0.3,
        }
    }
}

impl Optimiser for ParticleSwarm {
    fn name(&self) -> &str {
        "PSO"
    }

    fn minimise(
        &self,
        f: &Objective<'_>,
        bounds: &Bounds,
        seed_point: Option<&[f64]>,
        seed: u64,
    ) -> OptimResult {
        let dim = bounds.dim();
        let n = self.particles.max(2);
        let mut rng = Rng::new(seed);
        let mut x: Vec<Vec<f64>> = (0..n)
            .map(|_| (0..dim).map(|_| rng.uniform()).collect())
            .collect();
        let mut v: Vec<Vec<f64>> = (0..n)
            .map(|_| (0..dim).map(|_| rng.uniform_in(-0.1, 0.1)).collect())
            .collect();
        if let Some(s) = seed_point {
            x[0] = bounds.to_u(s);
            v[0] = vec![0.0; dim];
        }
        let values = evaluate_batch(f, bounds, &x);
        let mut evaluations = n;
        let mut personal = x.clone();
        let mut personal_v = values.clone();
        let g = argmin(&personal_v);
        let (mut best_u, mut best_v) = (personal[g].clone(), personal_v[g]);
        let mut stall = Stall::new(self.convergence, best_v);
        let mut iteration = 0;
        let mut converged = false;
        while iteration < self.max_iterations && !converged {
            iteration += 1;
            for i in 0..n {
                for d in 0..dim {
                    let r1 = rng.uniform();
                    let r2 = rng.uniform();
                    let vel = self.inertia * v[i][d]
                        + self.cognitive * r1 * (personal[i][d] - x[i][d])
                        + self.social * r2 * (best_u[d] - x[i][d]);
                    v[i][d] = vel.clamp(-self.max_velocity, self.max_velocity);
                    let pos = x[i][d] + v[i][d];
                    if !(0.0..=1.0).contains(&pos) {
                        v[i][d] = 0.0;
                    }
                    x[i][d] = pos.clamp(0.0, 1.0);
                }
            }
            let values = evaluate_batch(f, bounds, &x);
            evaluations += n;
            for i in 0..n {
                if values[i] < personal_v[i] {
                    personal_v[i] = values[i];
                    personal[i] = x[i].clone();
                }
            }
            let g = argmin(&personal_v);
            if personal_v[g] < best_v {
                best_v = personal_v[g];
                best_u = personal[g].clone();
            }
            converged = stall.update(best_v) || self.convergence.collapsed(&x);
        }
        OptimResult {
            x: bounds.to_x(&best_u),
            value: best_v,
            evaluations,
            iterations: iteration,
        }
    }
}
