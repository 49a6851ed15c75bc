//! The specimen emulated behind its actuators (numerical code, no I/O): linear elastic, its
//! stiffness K_P condensed onto the actuated DoFs (`model`), optionally with a Bouc–Wen
//! hysteretic spring on each actuated DoF (Bouc 1967; Wen 1976) — a nonlinear rehearsal:
//!
//!   r = K_P (d − d_p),  d_p = (1 − α)(d − u_y z)  (so r = K_P (α d + (1 − α) u_y z)),
//!   dz/dd_a = [1 − |z_a|ⁿ (β sgn(Δd_a z_a) + γ)] / u_y   (A = 1):
//!
//! a Bouc–Wen hinge in series with the elastic specimen at every actuated DoF, d_p its plastic
//! slip. Small motions (|d| ≪ u_y, z ≈ d/u_y) give r = K_P d; beyond u_y the whole specimen tends
//! to α K_P and z to ±(β + γ)^(−1/n); one DoF is Eq. L1 of docs/lab-tests.md. The tangent
//! K_P diag(α + (1 − α) u_y ∂z/∂d) is similar to K_P^½ diag(·) K_P^½: positive definite while the
//! diagonal is positive, and no stiffer than K_P while it is ≤ 1 (β ≥ γ), so α-OS (whose
//! implicit part uses K_P) stays stable. (The first form, r = K_P d − (1 − α) diag(K_P)(d − u_y z),
//! took the hysteresis off the diagonal only: its post-yield tangent K_P − (1 − α) diag(K_P) is
//! indefinite for a condensed K_P with strong coupling, and the facade's rehearsal diverged
//! statically once its DoFs yielded — u_y = 5·10⁻⁵ and 2·10⁻⁴ m.) z is integrated over each
//! displacement increment by forward Euler on sub-increments of at most u_y / 20.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Parameters of the Bouc–Wen spring added on every actuated DoF.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoucWenSpring {
    /// u_y (m): displacement scale of the hysteretic variable.
    pub yield_displacement_m: f64,
    /// α: post-yield stiffness ratio, in [0, 1).
    #[serde(default = "default_post_yield")]
    pub post_yield_ratio: f64,
    #[serde(default = "default_half")]
    pub beta: f64,
    #[serde(default = "default_half")]
    pub gamma: f64,
    #[serde(default = "default_n")]
    pub n: f64,
}

fn default_post_yield() -> f64 {
    0.1
}
fn default_half() -> f64 {
    0.5
}
fn default_n() -> f64 {
    2.0
}

impl BoucWenSpring {
    pub fn check(&self) -> Result<()> {
        let ok = self.yield_displacement_m > 0.0
            && self.yield_displacement_m.is_finite()
            && (0.0..1.0).contains(&self.post_yield_ratio)
            && self.beta + self.gamma > 0.0
            && self.beta.is_finite()
            && self.gamma.is_finite()
            && self.n >= 1.0
            && self.n.is_finite();
        if ok {
            Ok(())
        } else {
            Err(Error::usage(format!(
                "bouc_wen: yield_displacement_m > 0, post_yield_ratio in [0, 1), beta + gamma > 0 and n ≥ 1 are required; got {self:?}"
            )))
        }
    }
}

/// The specimen's state: hysteretic variables and the last displacement.
#[derive(Debug, Clone)]
pub struct SpecimenModel {
    kp: Vec<f64>,
    m: usize,
    bouc_wen: Option<(BoucWenSpring, Vec<f64>, Vec<f64>)>,
}

impl SpecimenModel {
    /// `kp`: K_P row-major (m × m).
    pub fn new(kp: Vec<f64>, m: usize, bouc_wen: Option<BoucWenSpring>) -> Self {
        SpecimenModel {
            kp,
            m,
            bouc_wen: bouc_wen.map(|b| (b, vec![0.0; m], vec![0.0; m])),
        }
    }

    /// The restoring force at displacement `d` (after the previous call's displacement).
    pub fn force(&mut self, d: &[f64], r: &mut [f64]) {
        let m = self.m;
        let Some((bw, z, last)) = self.bouc_wen.as_mut() else {
            for (i, ri) in r.iter_mut().enumerate().take(m) {
                *ri = (0..m).map(|j| self.kp[i * m + j] * d[j]).sum();
            }
            return;
        };
        let uy = bw.yield_displacement_m;
        for a in 0..m {
            let delta = d[a] - last[a];
            let steps = ((delta.abs() / (uy / 20.0)).ceil() as usize).clamp(1, 10_000);
            let h = delta / steps as f64;
            for _ in 0..steps {
                let zn = z[a].abs().powf(bw.n);
                let s = (h * z[a]).signum();
                z[a] += h / uy * (1.0 - zn * (bw.beta * s + bw.gamma));
            }
            last[a] = d[a];
        }
        // The elastic deformation d − d_p = α d + (1 − α) u_y z through K_P.
        let alpha = bw.post_yield_ratio;
        let elastic: Vec<f64> = (0..m)
            .map(|a| alpha * d[a] + (1.0 - alpha) * uy * z[a])
            .collect();
        for (i, ri) in r.iter_mut().enumerate().take(m) {
            *ri = (0..m).map(|j| self.kp[i * m + j] * elastic[j]).sum();
        }
    }
}
