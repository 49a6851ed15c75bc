//! Gravity pre-load of a rehearsal (issue 16; thesis ch. 6–7): the static gravity state the
//! dynamic test starts from. No I/O.
//!
//! The prototype's gravity load is f̂_g = ψᵀ f_g, f_g = Σ_axis g_axis M̃ r̃_axis the twin's
//! gravity load (`SystemMatrices::gravity_load`: the twin's own gravity vector defines the
//! vertical). The static state solves
//!
//!   K̂ x_g = f̂_g,   K̂ = K̂_N + L K_P Lᵀ,                                  (G1)
//!
//! with the specimen's initial stiffness (a hysteretic specimen is assumed elastic under its
//! own weight). The specimen then sits at d_g = Lᵀ x_g and carries
//!
//!   r_g = K_P d_g,                                                           (G2)
//!
//! its share of the weight, held by the actuators: the force-controlled ones apply r_g as a
//! constant force command, the displacement-controlled ones hold d_g. The dynamic test starts
//! from (x_g, r_g) with the constant load f̂_g added to −Σ_d ψᵀ b_d a_d(t). For the linear
//! specimen the response is x_g + the seismic increment (superposition): the response error
//! against the reference is unchanged. A Bouc–Wen specimen is driven from 0 to d_g before the
//! run, so its hysteretic state starts shifted and its response changes.

use faer::linalg::solvers::Solve;

use super::model::{mat, RehearsalModel};
use crate::error::{Error, Result};

/// The static gravity state of the hybrid system.
#[derive(Debug, Clone, PartialEq)]
pub struct Preload {
    /// x_g over the prototype's coordinates (Eq. G1).
    pub x: Vec<f64>,
    /// d_g = Lᵀ x_g and r_g = K_P d_g at the actuators (Eq. G2).
    pub displacement: Vec<f64>,
    pub force: Vec<f64>,
    /// Σ r_g over the vertical force-controlled actuators: the weight they apply (N), and
    /// over all vertical actuators: the PS's share of the weight (vertical: the model's
    /// `gravity_direction`; every actuator when it is unknown).
    pub force_controlled_n: f64,
    pub vertical_n: f64,
}

/// The static gravity state of `model` (Eq. G1–G2); an error when the model has no gravity
/// load or K̂ is singular.
pub fn static_state(model: &RehearsalModel) -> Result<Preload> {
    let n = model.n_coordinates();
    if model.gravity_load.len() != n {
        return Err(Error::usage(
            "rehearsal: gravity pre-load requested but the rehearsal model has no gravity load (design with gravity = true)",
        ));
    }
    let k = mat(&model.stiffness);
    let f = faer::Mat::from_fn(n, 1, |i, _| model.gravity_load[i]);
    let x = k.partial_piv_lu().solve(&f);
    let x: Vec<f64> = (0..n).map(|i| x[(i, 0)]).collect();
    // Residual check: K̂ must be regular (a supported prototype).
    let kx = &k * faer::Mat::from_fn(n, 1, |i, _| x[i]);
    let scale = model
        .gravity_load
        .iter()
        .fold(0.0_f64, |a, v| a.max(v.abs()));
    let res = (0..n).fold(0.0_f64, |a, i| a.max((kx[(i, 0)] - f[(i, 0)]).abs()));
    if !x.iter().all(|v| v.is_finite()) || res > 1e-6 * scale.max(f64::MIN_POSITIVE) {
        return Err(Error::numerical(
            "rehearsal: the prototype's stiffness is singular, no static gravity state",
        ));
    }
    let (o, m) = (model.ns_modes, model.actuators.len());
    let displacement: Vec<f64> = x[o..o + m].to_vec();
    let force: Vec<f64> = (0..m)
        .map(|i| {
            (0..m)
                .map(|j| model.ps_stiffness[i][j] * displacement[j])
                .sum()
        })
        .collect();
    let vertical = |d: &str| model.gravity_direction.is_empty() || d == model.gravity_direction;
    let sum = |force_only: bool| -> f64 {
        model
            .actuators
            .iter()
            .zip(&force)
            .filter(|(a, _)| vertical(&a.direction) && (!force_only || a.control_mode == "force"))
            .map(|(_, r)| r)
            .sum()
    };
    let (force_controlled_n, vertical_n) = (sum(true), sum(false));
    Ok(Preload {
        x,
        displacement,
        force,
        force_controlled_n,
        vertical_n,
    })
}
