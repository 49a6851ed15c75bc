//! Generalised pattern search (Audet & Dennis 2002) with a Hooke–Jeeves pattern move as the
//! search step. Each iteration evaluates, in parallel, the centre point c and its complete
//! compass poll c ± Δ e_q; if the best of them improves on the base point b, the new base is
//! that point, the mesh expands (×2, capped) and the next centre is the pattern point
//! b_new + (b_new − b_old) (which follows curved valleys much faster than compass steps
//! alone); otherwise the centre returns to the base, and if it already was the base the mesh
//! contracts (×½). Deterministic: it starts from the seed point (or the middle of the
//! bounds) and uses no randomness.

use super::{argmin, evaluate_batch, Bounds, Objective, OptimResult, Optimiser};

#[derive(Debug, Clone)]
pub struct PatternSearch {
    /// Initial mesh size in the unit cube.
    pub initial_mesh: f64,
    pub max_mesh: f64,
    /// Stop when the mesh is below this size.
    pub mesh_tolerance: f64,
    pub max_evaluations: usize,
}

impl Default for PatternSearch {
    fn default() -> Self {
        PatternSearch {
            initial_mesh: 0.125,
            max_mesh: 0.5,
            mesh_tolerance: 1e-8,
            max_evaluations: 4000,
        }
    }
}

impl Optimiser for PatternSearch {
    fn name(&self) -> &str {
        "PS"
    }

    fn minimise(
        &self,
        f: &Objective<'_>,
        bounds: &Bounds,
        seed_point: Option<&[f64]>,
        _seed: u64,
    ) -> OptimResult {
        let dim = bounds.dim();
        let mut base = match seed_point {
            Some(s) => bounds.to_u(s),
            None => vec![0.5; dim],
        };
        let mut base_v = evaluate_batch(f, bounds, std::slice::from_ref(&base))[0];
        let mut evaluations = 1;
        let mut centre = base.clone();
        let mut mesh = self.initial_mesh;
        let mut iterations = 0;
        while mesh >= self.mesh_tolerance && evaluations < self.max_evaluations {
            iterations += 1;
            let mut batch = Vec::with_capacity(2 * dim + 1);
            if centre != base {
                batch.push(centre.clone());
            }
            for d in 0..dim {
                for sign in [1.0, -1.0] {
                    let mut p = centre.clone();
                    p[d] = (p[d] + sign * mesh).clamp(0.0, 1.0);
                    if p[d] != centre[d] && p != base {
                        batch.push(p);
                    }
                }
            }
            if batch.is_empty() {
                mesh *= 0.5;
                continue;
            }
            let values = evaluate_batch(f, bounds, &batch);
            evaluations += batch.len();
            let b = argmin(&values);
            if values[b] < base_v {
                let new_base = batch[b].clone();
                centre = new_base
                    .iter()
                    .zip(&base)
                    .map(|(n, o)| (2.0 * n - o).clamp(0.0, 1.0))
                    .collect();
                base = new_base;
                base_v = values[b];
                mesh = (mesh * 2.0).min(self.max_mesh);
            } else if centre != base {
                centre = base.clone();
            } else {
                mesh *= 0.5;
            }
        }
        OptimResult {
            x: bounds.to_x(&base),
            value: base_v,
            evaluations,
            iterations,
        }
    }
}
