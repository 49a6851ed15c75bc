//! Least-squares fit of Eq. L1–L6 to a measured (x, F) history (numerical
//! code, no I/O): variable projection (Golub & Pereyra 1973) — k₀ and α enter
//! Eq. L1 linearly, so for given shape parameters they come from a two-column
//! least-squares problem, and only the shape parameters are searched — by a
//! seeded multistart (uniform draws in the bounds, the best few refined) and a
//! bound-projected Levenberg–Marquardt (Marquardt 1963) with forward-difference
//! Jacobians. Uncertainty: s² (JᵀJ)⁻¹ at the optimum (central differences, all
//! fitted parameters including k₀ and α), inflated by N / N_eff for residuals
//! correlated from sample to sample (AR(1): N_eff = N (1 − ρ₁)/(1 + ρ₁)).

use crate::rng::Rng;

use super::model::{hysteretic_state, BwbnParameters};

/// Bounds of the nine shape parameters ([`BwbnParameters::shape`]) for a
/// record of displacement range `range_m`.
pub fn shape_bounds(range_m: f64) -> ([f64; 9], [f64; 9]) {
    (
        [range_m * 2e-3, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.02],
        [range_m, 2.0, 8.0, 0.5, 0.5, 0.95, 5.0, 0.8, 1.0],
    )
}

/// One fitting problem: the record, which shape parameters are free, and
/// the values of the fixed ones.
pub struct Problem<'a> {
    pub x: &'a [f64],
    pub force: &'a [f64],
    pub substep_m: f64,
    pub free: Vec<usize>,
    pub lower: [f64; 9],
    pub upper: [f64; 9],
}

/// A fitted model: parameters, residual sum of squares, the model force.
#[derive(Debug, Clone)]
pub struct Fit {
    pub params: BwbnParameters,
    pub ssr: f64,
    pub model_force: Vec<f64>,
    pub iterations: usize,
}

impl Problem<'_> {
    /// The variable-projection model: the force for `shape` with the best
    /// non-negative (a = α k₀, b = (1 − α) k₀) of Eq. L1; None if the record
    /// cannot determine them.
    pub fn project(&self, shape: &[f64; 9]) -> Option<Fit> {
        let state = hysteretic_state(self.x, shape, self.substep_m);
        let uy = shape[0];
        let w: Vec<f64> = state.z.iter().map(|z| uy * z).collect();
        let (a, b) = nonnegative_two_column(self.x, &w, self.force)?;
        let k0 = a + b;
        if !(k0 > 0.0) || !k0.is_finite() {
            return None;
        }
        let model_force: Vec<f64> = self
            .x
            .iter()
            .zip(&w)
            .map(|(xi, wi)| a * xi + b * wi)
            .collect();
        let ssr = sum_sq_diff(self.force, &model_force);
        if !ssr.is_finite() {
            return None;
        }
        Some(Fit {
            params: BwbnParameters::with_shape(k0, a / k0, shape),
            ssr,
            model_force,
            iterations: 0,
        })
    }

    fn clamp(&self, shape: &mut [f64; 9]) {
        for &i in &self.free {
            shape[i] = shape[i].clamp(self.lower[i], self.upper[i]);
        }
    }

    /// Bound-projected Levenberg–Marquardt over the free shape parameters.
    pub fn refine(&self, start: &[f64; 9], max_iterations: usize) -> Option<Fit> {
        let mut shape = *start;
        self.clamp(&mut shape);
        let mut best = self.project(&shape)?;
        let p = self.free.len();
        let mut lambda = 1e-3;
        let mut iterations = 0;
        'outer: while iterations < max_iterations {
            iterations += 1;
            // Forward-difference Jacobian of the projected model.
            let mut columns = Vec::with_capacity(p);
            for &i in &self.free {
                let h = (self.upper[i] - self.lower[i]) * 1e-6;
                let mut s = shape;
                let h = if s[i] + h > self.upper[i] { -h } else { h };
                s[i] += h;
                let Some(f) = self.project(&s) else {
                    break 'outer;
                };
                columns.push(
                    f.model_force
                        .iter()
                        .zip(&best.model_force)
                        .map(|(a, b)| (a - b) / h)
                        .collect::<Vec<f64>>(),
                );
            }
            let residual: Vec<f64> = self
                .force
                .iter()
                .zip(&best.model_force)
                .map(|(f, m)| f - m)
                .collect();
            let (jtj, jtr) = normal_equations(&columns, &residual);
            let mut improved = false;
            for _ in 0..12 {
                let mut a = jtj.clone();
                for k in 0..p {
                    a[k * p + k] += lambda * jtj[k * p + k].max(1e-300);
                }
                let Some(delta) = solve_spd(&a, &jtr, p) else {
                    lambda *= 10.0;
                    continue;
                };
                let mut trial = shape;
                for (k, &i) in self.free.iter().enumerate() {
                    trial[i] += delta[k];
                }
                self.clamp(&mut trial);
                match self.project(&trial) {
                    Some(f) if f.ssr < best.ssr => {
                        let gain = (best.ssr - f.ssr) / best.ssr.max(f64::MIN_POSITIVE);
                        shape = trial;
                        best = f;
                        lambda = (lambda / 3.0).max(1e-12);
                        improved = true;
                        if gain < 1e-8 {
                            break 'outer;
                        }
                        break;
                    }
                    _ => lambda *= 4.0,
                }
            }
            if !improved {
                break;
            }
        }
        best.iterations = iterations;
        Some(best)
    }

    /// Seeded global search: `draws` uniform draws of the parameters
    /// `drawn` (a subset of the free ones; u_y log-uniform) in their bounds,
    /// the others as in `base`; the `refined` best of them (and `base`
    /// itself) refined over all free parameters by [`Problem::refine`].
    pub fn search(
        &self,
        base: &[f64; 9],
        drawn: &[usize],
        rng: &mut Rng,
        draws: usize,
        refined: usize,
        max_iterations: usize,
    ) -> Option<Fit> {
        let mut candidates: Vec<(f64, [f64; 9])> = Vec::with_capacity(draws + 1);
        if let Some(f) = self.project(base) {
            candidates.push((f.ssr, *base));
        }
        for _ in 0..draws {
            let mut s = *base;
            for &i in drawn {
                s[i] = if i == 0 {
                    (rng.uniform_in(self.lower[0].ln(), self.upper[0].ln())).exp()
                } else {
                    rng.uniform_in(self.lower[i], self.upper[i])
                };
            }
            if let Some(f) = self.project(&s) {
                candidates.push((f.ssr, s));
            }
        }
        candidates.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut best: Option<Fit> = None;
        let base_first = std::iter::once(*base).filter(|_| self.project(base).is_some());
        let starts: Vec<[f64; 9]> = base_first
            .chain(candidates.iter().map(|c| c.1))
            .take(refined.max(1) + 1)
            .collect();
        for s in starts {
            if let Some(f) = self.refine(&s, max_iterations) {
                if best.as_ref().is_none_or(|b| f.ssr < b.ssr) {
                    best = Some(f);
                }
            }
        }
        best
    }

    /// Standard deviations of (k₀, α, free shape parameters…) from
    /// s² (JᵀJ)⁻¹ with central differences of the full model, inflated by
    /// `inflation` (N / N_eff). NaN where JᵀJ is singular.
    pub fn standard_deviations(&self, fit: &Fit, inflation: f64) -> Vec<f64> {
        let p = 2 + self.free.len();
        let n = self.x.len();
        let nan = vec![f64::NAN; p];
        if n <= p {
            return nan;
        }
        let base = fit.params;
        let shape = base.shape();
        let model = |k0: f64, alpha: f64, s: &[f64; 9]| -> Vec<f64> {
            let st = hysteretic_state(self.x, s, self.substep_m);
            self.x
                .iter()
                .zip(&st.z)
                .map(|(xi, zi)| alpha * k0 * xi + (1.0 - alpha) * k0 * s[0] * zi)
                .collect()
        };
        let k0 = base.initial_stiffness_n_per_m;
        let alpha = base.post_yield_ratio;
        let diff = |plus: Vec<f64>, minus: Vec<f64>, h: f64| -> Vec<f64> {
            plus.iter().zip(&minus).map(|(a, b)| (a - b) / h).collect()
        };
        let mut columns = Vec::with_capacity(p);
        let hk = k0 * 1e-6;
        columns.push(diff(
            model(k0 + hk, alpha, &shape),
            model(k0 - hk, alpha, &shape),
            2.0 * hk,
        ));
        let ha = 1e-6;
        columns.push(diff(
            model(k0, alpha + ha, &shape),
            model(k0, alpha - ha, &shape),
            2.0 * ha,
        ));
        for &i in &self.free {
            let h = (self.upper[i] - self.lower[i]) * 1e-6;
            let (mut sp, mut sm) = (shape, shape);
            // One-sided at a bound.
            let lo = (shape[i] - h).max(self.lower[i]);
            let hi = (shape[i] + h).min(self.upper[i]);
            sp[i] = hi;
            sm[i] = lo;
            if hi - lo <= 0.0 {
                return nan;
            }
            columns.push(diff(model(k0, alpha, &sp), model(k0, alpha, &sm), hi - lo));
        }
        let zeros = vec![0.0; n];
        let (jtj, _) = normal_equations(&columns, &zeros);
        let s2 = fit.ssr / (n - p) as f64 * inflation.max(1.0);
        let mut out = Vec::with_capacity(p);
        for k in 0..p {
            let mut e = vec![0.0; p];
            e[k] = 1.0;
            match solve_spd(&jtj, &e, p) {
                Some(col) if col[k] >= 0.0 => out.push((s2 * col[k]).sqrt()),
                _ => return nan,
            }
        }
        out
    }
}

fn sum_sq_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// min ‖f − a x − b w‖² over a, b ≥ 0 (the active set of two columns).
fn nonnegative_two_column(x: &[f64], w: &[f64], f: &[f64]) -> Option<(f64, f64)> {
    let dot = |u: &[f64], v: &[f64]| -> f64 { u.iter().zip(v).map(|(a, b)| a * b).sum() };
    let (xx, ww, xw, xf, wf) = (dot(x, x), dot(w, w), dot(x, w), dot(x, f), dot(w, f));
    let det = xx * ww - xw * xw;
    if det > 1e-12 * xx * ww && det.is_finite() {
        let a = (ww * xf - xw * wf) / det;
        let b = (xx * wf - xw * xf) / det;
        if a >= 0.0 && b >= 0.0 {
            return Some((a, b));
        }
    }
    // One column only: the better of the two non-negative single fits.
    let a_only = if xx > 0.0 { (xf / xx).max(0.0) } else { 0.0 };
    let b_only = if ww > 0.0 { (wf / ww).max(0.0) } else { 0.0 };
    let cost_a = -2.0 * a_only * xf + a_only * a_only * xx;
    let cost_b = -2.0 * b_only * wf + b_only * b_only * ww;
    let pair = if cost_a <= cost_b {
        (a_only, 0.0)
    } else {
        (0.0, b_only)
    };
    (pair.0 + pair.1 > 0.0).then_some(pair)
}

/// JᵀJ (row-major p × p) and Jᵀr from the Jacobian's columns.
fn normal_equations(columns: &[Vec<f64>], r: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let p = columns.len();
    let mut jtj = vec![0.0; p * p];
    let mut jtr = vec![0.0; p];
    for a in 0..p {
        jtr[a] = columns[a].iter().zip(r).map(|(u, v)| u * v).sum();
        for b in a..p {
            let v: f64 = columns[a].iter().zip(&columns[b]).map(|(u, v)| u * v).sum();
            jtj[a * p + b] = v;
            jtj[b * p + a] = v;
        }
    }
    (jtj, jtr)
}

/// Solves A x = b for a symmetric positive definite A (row-major p × p) by
/// Cholesky after Jacobi scaling (the columns differ by many orders of
/// magnitude: k₀ in N/m, α dimensionless); None if A is not positive definite.
pub(crate) fn solve_spd(a: &[f64], b: &[f64], p: usize) -> Option<Vec<f64>> {
    let d: Vec<f64> = (0..p)
        .map(|i| {
            let v = a[i * p + i];
            if v > 0.0 {
                1.0 / v.sqrt()
            } else {
                1.0
            }
        })
        .collect();
    let mut l = vec![0.0; p * p];
    for i in 0..p {
        for j in 0..=i {
            let mut s = a[i * p + j] * d[i] * d[j];
            for k in 0..j {
                s -= l[i * p + k] * l[j * p + k];
            }
            if i == j {
                if !(s > 1e-14) {
                    return None;
                }
                l[i * p + i] = s.sqrt();
            } else {
                l[i * p + j] = s / l[j * p + j];
            }
        }
    }
    let mut y = vec![0.0; p];
    for i in 0..p {
        let mut s = b[i] * d[i];
        for k in 0..i {
            s -= l[i * p + k] * y[k];
        }
        y[i] = s / l[i * p + i];
    }
    let mut x = vec![0.0; p];
    for i in (0..p).rev() {
        let mut s = y[i];
        for k in i + 1..p {
            s -= l[k * p + i] * x[k];
        }
        x[i] = s / l[i * p + i];
    }
    Some(x.iter().zip(&d).map(|(v, s)| v * s).collect())
}

/// Sample autocorrelation of `r` at lags 0..=`max_lag` (mean removed,
/// biased normalisation by the lag-0 sum, so |ρ_k| ≤ 1).
pub fn autocorrelation(r: &[f64], max_lag: usize) -> Vec<f64> {
    let n = r.len();
    let mean = r.iter().sum::<f64>() / n.max(1) as f64;
    let var: f64 = r.iter().map(|v| (v - mean) * (v - mean)).sum();
    if n < 3 || !(var > 0.0) {
        return vec![1.0];
    }
    (0..=max_lag.min(n - 1))
        .map(|k| {
            (k..n)
                .map(|i| (r[i] - mean) * (r[i - k] - mean))
                .sum::<f64>()
                / var
        })
        .collect()
}

/// Effective number of independent residuals (Eq. L8a of docs/lab-tests.md):
/// N_eff = N / (1 + 2 Σ_{k=1}^{K} (1 − k/N) ρ_k), K the last lag before the
/// sample autocorrelation first drops to ≤ 0 (at most N/4) — the
/// integral-time-scale estimate of Thiébaux & Zwiers (1984, J. Climate Appl.
/// Meteor. 23, 800–811), truncated where the estimated correlation ends.
/// Unlike the AR(1) form N(1 − ρ₁)/(1 + ρ₁) it does not extrapolate ρ₁ to
/// every lag: a model-error residual that is smooth over a few samples but
/// uncorrelated beyond them (a real specimen's) keeps its N/(a few).
/// Returns N_eff in [1, N] and ρ₁.
pub fn effective_samples(r: &[f64]) -> (f64, f64) {
    let n = r.len();
    if n < 3 {
        return (n.max(1) as f64, 0.0);
    }
    let rho = autocorrelation(r, n / 4);
    let mut sum = 0.0;
    for (k, &rk) in rho.iter().enumerate().skip(1) {
        if !(rk > 0.0) {
            break;
        }
        sum += (1.0 - k as f64 / n as f64) * rk;
    }
    let n_eff = (n as f64 / (1.0 + 2.0 * sum)).clamp(1.0, n as f64);
    (n_eff, rho.get(1).copied().unwrap_or(0.0))
}
