//! Bounded quasi-Newton descent (BFGS, Nocedal & Wright 2006, ch. 6) with central
//! finite-difference gradients and a projected backtracking (Armijo) line search, in the
//! unit cube. An extra, gradient-based candidate for the ensemble (METHODS §3 allows more
//! candidates): the stochastic solvers locate the basin, this one follows narrow curved
//! valleys to their floor, which compass and population moves do very slowly. The 2Q
//! gradient evaluations of one iteration run in parallel. Deterministic (no randomness).

use super::{evaluate_batch, Bounds, Objective, OptimResult, Optimiser};

#[derive(Debug, Clone)]
pub struct QuasiNewton {
    /// Finite-difference step in the unit cube.
    pub gradient_step: f64,
    pub max_iterations: usize,
    pub max_evaluations: usize,
    /// Stop when the projected step is shorter than this (unit cube).
    pub step_tolerance: f64,
}

impl Default for QuasiNewton {
    fn default() -> Self {
        QuasiNewton {
            gradient_step: 1e-7,
            max_iterations: 300,
            max_evaluations: 3000,
            step_tolerance: 1e-12,
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl Optimiser for QuasiNewton {
    fn name(&self) -> &str {
        "QN"
    }

    fn minimise(
        &self,
        f: &Objective<'_>,
        bounds: &Bounds,
        seed_point: Option<&[f64]>,
        _seed: u64,
    ) -> OptimResult {
        let q = bounds.dim();
        let mut x = match seed_point {
            Some(s) => bounds.to_u(s),
            None => vec![0.5; q],
        };
        let mut fx = evaluate_batch(f, bounds, std::slice::from_ref(&x))[0];
        let mut evaluations = 1;
        let h = self.gradient_step;
        let gradient = |x: &[f64], evaluations: &mut usize| -> Vec<f64> {
            let mut pts = Vec::with_capacity(2 * q);
            let mut widths = Vec::with_capacity(q);
            for d in 0..q {
                let mut p = x.to_vec();
                let mut m = x.to_vec();
                p[d] = (x[d] + h).min(1.0);
                m[d] = (x[d] - h).max(0.0);
                widths.push(p[d] - m[d]);
                pts.push(p);
                pts.push(m);
            }
            let v = evaluate_batch(f, bounds, &pts);
            *evaluations += pts.len();
            (0..q)
                .map(|d| {
                    if widths[d] > 0.0 {
                        (v[2 * d] - v[2 * d + 1]) / widths[d]
                    } else {
                        0.0
                    }
                })
                .collect()
        };
        let mut g = gradient(&x, &mut evaluations);
        // Inverse Hessian approximation, row-major.
        let mut hinv = vec![0.0; q * q];
        for d in 0..q {
            hinv[d * q + d] = 1.0;
        }
        let mut iterations = 0;
        while iterations < self.max_iterations
            && evaluations < self.max_evaluations
            && fx.is_finite()
        {
            iterations += 1;
            let mut dir: Vec<f64> = (0..q)
                .map(|i| -(0..q).map(|j| hinv[i * q + j] * g[j]).sum::<f64>())
                .collect();
            if dot(&dir, &g) >= 0.0 {
                // Not a descent direction: reset to steepest descent.
                hinv.iter_mut()
                    .enumerate()
                    .for_each(|(k, v)| *v = if k % (q + 1) == 0 { 1.0 } else { 0.0 });
                dir = g.iter().map(|v| -v).collect();
            }
            // Projected backtracking line search.
            let mut t = 1.0;
            let mut accepted = None;
            for _ in 0..40 {
                let trial: Vec<f64> = x
                    .iter()
                    .zip(&dir)
                    .map(|(a, b)| (a + t * b).clamp(0.0, 1.0))
                    .collect();
                let step: Vec<f64> = trial.iter().zip(&x).map(|(a, b)| a - b).collect();
                if dot(&step, &step).sqrt() < self.step_tolerance {
                    break;
                }
                let ft = evaluate_batch(f, bounds, std::slice::from_ref(&trial))[0];
                evaluations += 1;
                if ft <= fx + 1e-4 * dot(&g, &step) && ft < fx {
                    accepted = Some((trial, ft, step));
                    break;
                }
                t *= 0.5;
            }
            let Some((xn, fnew, s)) = accepted else { break };
            let gn = gradient(&xn, &mut evaluations);
            let y: Vec<f64> = gn.iter().zip(&g).map(|(a, b)| a - b).collect();
            let sy = dot(&s, &y);
            if sy > 1e-300 {
                // BFGS update of the inverse Hessian: H ← (I − ρ s yᵀ) H (I − ρ y sᵀ) + ρ s sᵀ.
                let rho = 1.0 / sy;
                let hy: Vec<f64> = (0..q)
                    .map(|i| (0..q).map(|j| hinv[i * q + j] * y[j]).sum())
                    .collect();
                let yhy = dot(&y, &hy);
                for i in 0..q {
                    for j in 0..q {
                        hinv[i * q + j] += -rho * (hy[i] * s[j] + s[i] * hy[j])
                            + (rho * rho * yhy + rho) * s[i] * s[j];
                    }
                }
            }
            x = xn;
            fx = fnew;
            g = gn;
        }
        OptimResult {
            x: bounds.to_x(&x),
            value: fx,
            evaluations,
            iterations,
        }
    }
}
