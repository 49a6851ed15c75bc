//! Reduced lumped masses when a floor is not instrumented (Eq. 35–36 of
//! METHODS.md §4, thesis Ch. 4.3.1).
//!
//! Two instrumented floors (masses m_a, m_b, e.g. first floor and under-roof
//! floor) carry the whole mass plus a share σ1 of the non-instrumented floor
//! m_u (e.g. the raised floor), split σ2 : (1 − σ2):
//!   m1 = σ2 [(m_a + m_b) + σ1 m_u],  m2 = (1 − σ2) [(m_a + m_b) + σ1 m_u].
//! σ ∈ [0, 1]² is found by exhaustive grid search minimising
//!   J_m(σ) = Σ_directions |ω_red,1(σ) − ω_FE|
//! with ω_red,1 the first pulsation of the 2-DoF system (K_red, diag(m1, m2)).
//! Ties keep the first minimum in (σ1, σ2) lexicographic order.

use crate::error::{Error, Result};

/// One direction's data: reduced 2×2 stiffness of the twin and its first
/// pulsation ω_FE (rad/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReducedMassTarget {
    pub stiffness: [[f64; 2]; 2],
    pub omega_fe: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReducedMasses {
    pub sigma1: f64,
    pub sigma2: f64,
    /// Lower reduced mass m1, kg.
    pub m1: f64,
    /// Upper reduced mass m2, kg.
    pub m2: f64,
    /// J_m at the optimum, rad/s.
    pub cost: f64,
}

/// First (lowest) pulsation of [[k11, k12], [k12, k22]] with diag(m1, m2),
/// from m1 m2 λ² − (k11 m2 + k22 m1) λ + det K = 0 (one mass may be zero).
pub fn first_pulsation_2dof(k: &[[f64; 2]; 2], m1: f64, m2: f64) -> Option<f64> {
    let a = m1 * m2;
    let b = -(k[0][0] * m2 + k[1][1] * m1);
    let c = k[0][0] * k[1][1] - k[0][1] * k[1][0];
    let lambda = if a == 0.0 {
        if b == 0.0 {
            return None;
        }
        -c / b
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return None;
        }
        // Stable form of the smaller root: 2c / (−b + √disc).
        let q = -b + disc.sqrt();
        if q == 0.0 {
            return None;
        }
        2.0 * c / q
    };
    (lambda > 0.0).then(|| lambda.sqrt())
}

/// Eq. 35–36 grid search with step `step` (≤ 0.001 in the thesis).
pub fn reduced_lumped_masses(
    instrumented_masses: [f64; 2],
    uninstrumented_mass: f64,
    targets: &[ReducedMassTarget],
    step: f64,
) -> Result<ReducedMasses> {
    if !(step > 0.0 && step <= 0.5) {
        return Err(Error::usage("reduced masses: step must be in (0, 0.5]"));
    }
    if instrumented_masses
        .iter()
        .chain([&uninstrumented_mass])
        .any(|m| !(*m >= 0.0 && m.is_finite()))
        || instrumented_masses[0] + instrumented_masses[1] <= 0.0
    {
        return Err(Error::usage(
            "reduced masses: masses must be non-negative with a positive instrumented total",
        ));
    }
    if targets.is_empty() || targets.iter().any(|t| !(t.omega_fe > 0.0)) {
        return Err(Error::usage(
            "reduced masses: need at least one direction with a positive FE pulsation",
        ));
    }
    let steps = (1.0 / step).round() as usize;
    let sigma = |i: usize| (i as f64 * step).min(1.0);
    let base = instrumented_masses[0] + instrumented_masses[1];
    let mut best: Option<ReducedMasses> = None;
    for i in 0..=steps {
        let total = base + sigma(i) * uninstrumented_mass;
        for j in 0..=steps {
            let (m1, m2) = (sigma(j) * total, (1.0 - sigma(j)) * total);
            let mut cost = 0.0;
            for t in targets {
                match first_pulsation_2dof(&t.stiffness, m1, m2) {
                    Some(w) => cost += (w - t.omega_fe).abs(),
                    None => cost = f64::INFINITY,
                }
            }
            if cost.is_finite() && best.is_none_or(|b| cost < b.cost) {
                best = Some(ReducedMasses {
                    sigma1: sigma(i),
                    sigma2: sigma(j),
                    m1,
                    m2,
                    cost,
                });
            }
        }
    }
    best.ok_or_else(|| Error::numerical("reduced masses: no σ gives a positive first pulsation"))
}
