//! A shear building whose ground storey yields and loses stiffness: the
//! storeys above stay linear, storey 1 is a bilinear spring with linear
//! kinematic hardening (return mapping of 1-D rate-independent plasticity,
//! Simo & Hughes, *Computational Inelasticity*, 1998, Box 1.5) whose elastic
//! stiffness degrades with the largest drift reached, as Clough–Johnston's
//! and Takeda's unloading stiffness does:
//!   k_e = k₀ (δ_y / δ_max)^ρ once δ_max > δ_y = F_y / k₀, else k₀.
//! When k_e drops, the plastic drift is shifted so that the storey force is
//! continuous (the back force is kept).  After the event, at rest inside the
//! elastic range, the storey's tangent stiffness is the final k_e.
//!
//! Damping: Rayleigh, C = a₀ M + a₁ K₀ on the initial stiffness, giving the
//! stated ratio at the first and third initial modes (Chopra, *Dynamics of
//! Structures*, §11.4).
//!
//! Integrator: the explicit central-difference method (Chopra Table 5.2.1):
//! (M/h² + C/2h) u_{i+1} = p_i − f_s(u_i) + (2M/h²) u_i − (M/h² − C/2h) u_{i−1},
//! p_i = −M 1 a_g(t_i), starting at rest (u_{−1} = u_0 = 0), with `substeps`
//! steps h per record sample (the base acceleration linear in between); the
//! absolute floor acceleration is (u_{i+1} − 2u_i + u_{i−1})/h² + a_g(t_i).
//! Stable for h < T_min/π; the caller's h is far below it.  I/O free.

use super::{check_dt, ShearBuilding};
use crate::error::{Error, Result};

/// A shear building with a yielding, degrading ground storey (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct YieldingShearBuilding {
    /// Masses of levels 1..n, kg.
    pub masses_kg: Vec<f64>,
    /// Initial storey stiffnesses k₀ of storeys 1..n, N/m.
    pub storey_stiffness_n_per_m: Vec<f64>,
    /// Yield force of storey 1, N.
    pub yield_force_n: f64,
    /// Post-yield stiffness of storey 1 as a fraction of k₀ (kinematic hardening).
    pub hardening_ratio: f64,
    /// Degradation exponent ρ of storey 1's elastic stiffness.
    pub degradation_exponent: f64,
    /// Rayleigh damping ratio at the first and third initial modes.
    pub damping_ratio: f64,
}

/// Response sampled at the record instants.
#[derive(Debug, Clone, PartialEq)]
pub struct YieldingResponse {
    /// Absolute floor accelerations, m/s², `[level − 1][sample]`.
    pub absolute_acceleration: Vec<Vec<f64>>,
    /// Floor displacements relative to the base, m.
    pub relative_displacement: Vec<Vec<f64>>,
    /// Storey 1 force, N.
    pub storey1_force_n: Vec<f64>,
    /// Storey 1 elastic (tangent, unloading) stiffness at the end, N/m.
    pub final_storey1_stiffness_n_per_m: f64,
    /// Largest |drift| of storey 1 reached, m.
    pub storey1_max_drift_m: f64,
    /// Storey 1's plastic drift at the end: its drift at rest (zero storey
    /// force), the true residual drift, m.
    pub final_storey1_plastic_drift_m: f64,
    /// Storey 1's elastic (unloading) stiffness k_e at each record sample t_k
    /// (after the spring's update at t_k), N/m: piecewise constant, it only
    /// drops when the largest drift grows.
    pub storey1_elastic_stiffness_n_per_m: Vec<f64>,
    /// Whether storey 1 took a plastic step (return mapping with f > 0) or
    /// lost stiffness at any integration step in (t_k, t_{k+1}]: where this is
    /// false over a span the building is linear with constant stiffness.
    pub storey1_plastic_step: Vec<bool>,
}

impl YieldingResponse {
    /// Whether the building is linear with one stiffness over the record
    /// samples `first..=last` (no plastic step in (t_first, t_last]), i.e.
    /// where its instantaneous tangent frequency is *defined over the window*.
    /// False for an empty or out-of-range span.
    pub fn is_linear_over(&self, first: usize, last: usize) -> bool {
        last >= first
            && last < self.storey1_plastic_step.len()
            && !self.storey1_plastic_step[first..last].iter().any(|&p| p)
    }
}

/// State of the degrading bilinear spring.
struct Spring {
    k0: f64,
    k: f64,
    yield_force: f64,
    hardening: f64,
    exponent: f64,
    plastic: f64,
    back: f64,
    max_drift: f64,
    force: f64,
    /// Set when a plastic step or a stiffness drop happens (read and cleared per sample).
    stepped: bool,
}

impl Spring {
    /// Storey force at drift `d` (return mapping, module doc).
    fn update(&mut self, d: f64) -> f64 {
        let yield_drift = self.yield_force / self.k0;
        if d.abs() > self.max_drift {
            self.max_drift = d.abs();
            if self.max_drift > yield_drift {
                let k_new = self.k0 * (yield_drift / self.max_drift).powf(self.exponent);
                if k_new < self.k {
                    // Keep the force continuous: F = k (d_prev − δ_p) = k_new (d_prev − δ_p').
                    self.plastic += self.force / self.k - self.force / k_new;
                    self.k = k_new;
                    self.stepped = true;
                }
            }
        }
        let trial = self.k * (d - self.plastic);
        let relative = trial - self.back;
        let excess = relative.abs() - self.yield_force;
        self.force = if excess > 0.0 {
            let step = excess / (self.k + self.hardening) * relative.signum();
            self.plastic += step;
            self.back += self.hardening * step;
            self.stepped = true;
            trial - self.k * step
        } else {
            trial
        };
        self.force
    }
}

impl YieldingShearBuilding {
    /// The linear building of the initial stiffnesses.
    pub fn initial(&self) -> ShearBuilding {
        ShearBuilding {
            masses_kg: self.masses_kg.clone(),
            storey_stiffness_n_per_m: self.storey_stiffness_n_per_m.clone(),
            damping_ratios: vec![self.damping_ratio],
        }
    }

    /// The linear building with storey 1 at stiffness `k1` (e.g. the final tangent).
    pub fn with_storey1_stiffness(&self, k1: f64) -> ShearBuilding {
        let mut b = self.initial();
        b.storey_stiffness_n_per_m[0] = k1;
        b
    }

    /// The true instantaneous tangent first-mode frequency at each record
    /// sample, Hz: f₁ of [`Self::with_storey1_stiffness`]`(k_e(t_k))`, the
    /// undamped fundamental of the linear building the structure is while it
    /// stays elastic.  Where storey 1 is on its plastic branch the tangent is
    /// the hardening stiffness instead: use [`YieldingResponse::is_linear_over`]
    /// to keep the spans where this value is defined.  One eigenproblem per
    /// distinct k_e (k_e is piecewise constant).
    pub fn tangent_first_frequency_hz(&self, response: &YieldingResponse) -> Result<Vec<f64>> {
        let mut out = Vec::with_capacity(response.storey1_elastic_stiffness_n_per_m.len());
        let mut cached: Option<(f64, f64)> = None;
        for &k in &response.storey1_elastic_stiffness_n_per_m {
            let f = match cached {
                Some((kc, f)) if kc == k => f,
                _ => {
                    let f = self.with_storey1_stiffness(k).modes()?.frequencies_hz[0];
                    cached = Some((k, f));
                    f
                }
            };
            out.push(f);
        }
        Ok(out)
    }

    /// Response to `base_acceleration` (m/s², sampled at `dt`), `substeps`
    /// central-difference steps per sample (module doc).
    pub fn simulate(
        &self,
        base_acceleration: &[f64],
        dt: f64,
        substeps: usize,
    ) -> Result<YieldingResponse> {
        check_dt(dt)?;
        let initial = self.initial();
        let modes = initial.modes()?;
        let n = initial.levels();
        let ok = |v: f64| v.is_finite() && v > 0.0;
        if !(ok(self.yield_force_n)
            && (0.0..1.0).contains(&self.hardening_ratio)
            && self.degradation_exponent >= 0.0
            && substeps > 0
            && n >= 3)
        {
            return Err(Error::usage(
                "yielding building: yield force > 0, hardening ratio in [0, 1), degradation exponent ≥ 0, substeps ≥ 1, at least 3 levels",
            ));
        }
        // Rayleigh coefficients from modes 1 and 3 (Chopra Eq. 11.4.9).
        let (w1, w3) = (modes.circular_frequencies[0], modes.circular_frequencies[2]);
        let a0 = self.damping_ratio * 2.0 * w1 * w3 / (w1 + w3);
        let a1 = self.damping_ratio * 2.0 / (w1 + w3);
        let k0 = initial.stiffness_matrix();
        let h = dt / substeps as f64;
        let m = &self.masses_kg;
        let c = |i: usize, j: usize| a0 * if i == j { m[i] } else { 0.0 } + a1 * k0[i][j];
        let lhs: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| if i == j { m[i] / (h * h) } else { 0.0 } + c(i, j) / (2.0 * h))
                    .collect()
            })
            .collect();
        let lhs_inv = invert(&lhs)?;
        let k1 = self.storey_stiffness_n_per_m[0];
        let mut spring = Spring {
            k0: k1,
            k: k1,
            yield_force: self.yield_force_n,
            hardening: self.hardening_ratio * k1 / (1.0 - self.hardening_ratio),
            exponent: self.degradation_exponent,
            plastic: 0.0,
            back: 0.0,
            max_drift: 0.0,
            force: 0.0,
            stepped: false,
        };
        let samples = base_acceleration.len();
        let mut out = YieldingResponse {
            absolute_acceleration: vec![Vec::with_capacity(samples); n],
            relative_displacement: vec![Vec::with_capacity(samples); n],
            storey1_force_n: Vec::with_capacity(samples),
            final_storey1_stiffness_n_per_m: k1,
            storey1_max_drift_m: 0.0,
            final_storey1_plastic_drift_m: 0.0,
            storey1_elastic_stiffness_n_per_m: Vec::with_capacity(samples),
            storey1_plastic_step: Vec::with_capacity(samples),
        };
        let (mut prev, mut now) = (vec![0.0; n], vec![0.0; n]);
        let mut rhs = vec![0.0; n];
        let mut shear = vec![0.0; n];
        let total = samples * substeps;
        for step in 0..total {
            let (k, frac) = (step / substeps, (step % substeps) as f64 / substeps as f64);
            let ag = match base_acceleration.get(k + 1) {
                Some(next) => base_acceleration[k] + (next - base_acceleration[k]) * frac,
                None => base_acceleration[k],
            };
            // Storey shears: storey 1 from the spring, the others linear.
            shear[0] = spring.update(now[0]);
            if step % substeps == 0 {
                // The flag collected over (t_{k−1}, t_k] belongs to sample k − 1.
                if step > 0 {
                    out.storey1_plastic_step.push(spring.stepped);
                }
                spring.stepped = false;
                out.storey1_elastic_stiffness_n_per_m.push(spring.k);
            }
            for s in 1..n {
                shear[s] = self.storey_stiffness_n_per_m[s] * (now[s] - now[s - 1]);
            }
            for i in 0..n {
                let restoring = shear[i] - shear.get(i + 1).copied().unwrap_or(0.0);
                let damping_prev: f64 = (0..n).map(|j| c(i, j) * prev[j]).sum::<f64>() / (2.0 * h);
                rhs[i] = -m[i] * ag - restoring + 2.0 * m[i] / (h * h) * now[i]
                    - (m[i] / (h * h) * prev[i] - damping_prev);
            }
            let next: Vec<f64> = (0..n)
                .map(|i| (0..n).map(|j| lhs_inv[i][j] * rhs[j]).sum())
                .collect();
            if next.iter().any(|v| !v.is_finite()) {
                return Err(Error::numerical(format!(
                    "yielding building: central differences diverged at t = {:.3} s",
                    step as f64 * h
                )));
            }
            if step % substeps == 0 {
                for i in 0..n {
                    out.relative_displacement[i].push(now[i]);
                    out.absolute_acceleration[i]
                        .push((next[i] - 2.0 * now[i] + prev[i]) / (h * h) + ag);
                }
                out.storey1_force_n.push(shear[0]);
            }
            prev = std::mem::replace(&mut now, next);
        }
        if samples > 0 {
            out.storey1_plastic_step.push(spring.stepped);
        }
        out.final_storey1_stiffness_n_per_m = spring.k;
        out.storey1_max_drift_m = spring.max_drift;
        out.final_storey1_plastic_drift_m = spring.plastic;
        Ok(out)
    }
}

/// Inverse of a small dense matrix by Gauss–Jordan elimination with partial pivoting.
fn invert(a: &[Vec<f64>]) -> Result<Vec<Vec<f64>>> {
    let n = a.len();
    let mut w: Vec<Vec<f64>> = a
        .iter()
        .enumerate()
        .map(|(i, row)| {
            let mut r = row.clone();
            r.extend((0..n).map(|j| if i == j { 1.0 } else { 0.0 }));
            r
        })
        .collect();
    for col in 0..n {
        let pivot = (col..n)
            .max_by(|&x, &y| w[x][col].abs().total_cmp(&w[y][col].abs()))
            .unwrap_or(col);
        if w[pivot][col].abs() < f64::MIN_POSITIVE {
            return Err(Error::numerical("yielding building: singular step matrix"));
        }
        w.swap(col, pivot);
        let p = w[col][col];
        w[col].iter_mut().for_each(|v| *v /= p);
        for r in 0..n {
            if r != col {
                let f = w[r][col];
                if f != 0.0 {
                    for j in 0..2 * n {
                        w[r][j] -= f * w[col][j];
                    }
                }
            }
        }
    }
    Ok(w.into_iter().map(|r| r[n..].to_vec()).collect())
}
