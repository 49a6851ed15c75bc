//! Seismic damage index ι(t) of one direction (Eq. 32–34 of METHODS.md §4).
//!
//! K_dr(t) = K0_dr − (K0_dr δ_dr) ε_dr(t) (Eq. 23b) with the identified K0 and
//! K0·δ and the energy integrals ε(t) of the records; per time step the
//! eigenproblem (K(t) − ω_s² M) φ_s = 0 is solved with mass-normalised φ
//! (φᵀMφ = 1): with M diagonal, A = M^{-1/2} K M^{-1/2} = Ψ Λ Ψᵀ and
//! φ_s = M^{-1/2} ψ_s. Then Γ = Φᵀ M v (v = ones), c_s = Γ_s² / Σ Γ²,
//! α_s = 1 − ω_s(t)/ω_s(0), ι(t) = Σ_s c_s α_s. Modes are matched by order of
//! frequency (lowest first).

use crate::error::{Error, Result};
use faer::{Mat, Side};

use super::forward::{packed_upper_index, BoucWenChain, ChainResponse};

/// ι(t) and its ingredients, sampled every `stride` samples.
#[derive(Debug, Clone, PartialEq)]
pub struct DamageSeries {
    pub time_s: Vec<f64>,
    /// ι(t) = c(t)ᵀ α(t) (Eq. 34b).
    pub iota: Vec<f64>,
    /// ω_s(t), rad/s, `[mode][time]`, lowest mode first (NaN where K(t) lost
    /// positive definiteness).
    pub omega: Vec<Vec<f64>>,
    /// ω_s(t)/ω_s(0).
    pub omega_ratio: Vec<Vec<f64>>,
    /// c_s(t) = Γ_s²/ΣΓ² (Eq. 33).
    pub participation: Vec<Vec<f64>>,
    /// Number of time steps where K(t) had a non-positive eigenvalue.
    pub indefinite_steps: usize,
}

impl DamageSeries {
    pub fn final_iota(&self) -> Option<f64> {
        self.iota.last().copied()
    }
}

/// Computes ι(t) from full D×D matrices K0 and K0∘δ (`k0_delta[d][r]` =
/// K0_dr δ_dr; antisymmetric off the diagonal), the masses, and the packed
/// energy histories ε_ab(t) (a ≤ b).
pub fn damage_index(
    k0: &[Vec<f64>],
    k0_delta: &[Vec<f64>],
    masses: &[f64],
    energy_upper: &[Vec<f64>],
    sampling_rate_hz: f64,
    stride: usize,
) -> Result<DamageSeries> {
    let dofs = masses.len();
    if dofs == 0
        || k0.len() != dofs
        || k0_delta.len() != dofs
        || k0.iter().chain(k0_delta).any(|row| row.len() != dofs)
        || energy_upper.len() != dofs * (dofs + 1) / 2
    {
        return Err(Error::usage(
            "damage index: K0, K0·δ, masses and energies must agree on the number of DoFs",
        ));
    }
    if masses.iter().any(|m| !(*m > 0.0)) {
        return Err(Error::usage("damage index: masses must be positive"));
    }
    let samples = energy_upper[0].len();
    let stride = stride.max(1);
    let inv_sqrt_m: Vec<f64> = masses.iter().map(|m| 1.0 / m.sqrt()).collect();
    let sqrt_m: Vec<f64> = masses.iter().map(|m| m.sqrt()).collect();
    let mut series = DamageSeries {
        time_s: Vec::new(),
        iota: Vec::new(),
        omega: vec![Vec::new(); dofs],
        omega_ratio: vec![Vec::new(); dofs],
        participation: vec![Vec::new(); dofs],
        indefinite_steps: 0,
    };
    let mut omega0: Vec<f64> = Vec::new();
    let mut a = Mat::<f64>::zeros(dofs, dofs);
    for k in (0..samples).step_by(stride) {
        // K(t) (Eq. 23b), symmetric by the antisymmetry of δ and ε.
        for d in 0..dofs {
            for r in 0..dofs {
                let eps = if d <= r {
                    energy_upper[packed_upper_index(d, r, dofs)][k]
                } else {
                    -energy_upper[packed_upper_index(r, d, dofs)][k]
                };
                let stiffness = k0[d][r] - k0_delta[d][r] * eps;
                a[(d, r)] = inv_sqrt_m[d] * stiffness * inv_sqrt_m[r];
            }
        }
        let (lambda, psi) = symmetric_eigen(&a)?;
        let omega: Vec<f64> = lambda
            .iter()
            .map(|l| if *l > 0.0 { l.sqrt() } else { f64::NAN })
            .collect();
        if omega.iter().any(|w| w.is_nan()) {
            series.indefinite_steps += 1;
        }
        if omega0.is_empty() {
            omega0 = omega.clone();
        }
        // Γ_s = φ_sᵀ M 1 = ψ_sᵀ M^{1/2} 1.
        let gamma: Vec<f64> = (0..dofs)
            .map(|s| (0..dofs).map(|d| psi[(d, s)] * sqrt_m[d]).sum())
            .collect();
        let total: f64 = gamma.iter().map(|g| g * g).sum();
        let mut iota = 0.0;
        for s in 0..dofs {
            let c = if total > 0.0 {
                gamma[s] * gamma[s] / total
            } else {
                0.0
            };
            let ratio = omega[s] / omega0[s];
            iota += c * (1.0 - ratio);
            series.omega[s].push(omega[s]);
            series.omega_ratio[s].push(ratio);
            series.participation[s].push(c);
        }
        series.time_s.push(k as f64 / sampling_rate_hz);
        series.iota.push(iota);
    }
    Ok(series)
}

/// Eigenvalues (ascending) and orthonormal eigenvectors of a small symmetric matrix (faer).
fn symmetric_eigen(a: &Mat<f64>) -> Result<(Vec<f64>, Mat<f64>)> {
    let n = a.nrows();
    if n == 1 {
        return Ok((vec![a[(0, 0)]], Mat::from_fn(1, 1, |_, _| 1.0)));
    }
    let evd = a.self_adjoint_eigen(Side::Lower).map_err(|e| {
        Error::numerical(format!("damage index: eigen-decomposition failed: {e:?}"))
    })?;
    let values = evd.S().column_vector().iter().copied().collect();
    Ok((values, evd.U().to_owned()))
}

/// Reference ι(t) of a known chain from its exact simulated energies.
pub fn damage_index_of_chain(
    chain: &BoucWenChain,
    response: &ChainResponse,
    stride: usize,
) -> Result<DamageSeries> {
    let dofs = chain.dofs();
    let k0_delta: Vec<Vec<f64>> = (0..dofs)
        .map(|d| {
            (0..dofs)
                .map(|r| chain.k0[d][r] * chain.delta[d][r])
                .collect()
        })
        .collect();
    damage_index(
        &chain.k0,
        &k0_delta,
        &chain.masses,
        &response.energy_upper,
        response.sampling_rate_hz,
        stride,
    )
}
