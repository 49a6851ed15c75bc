//! A synthetic laboratory specimen with known Bouc–Wen–Baber–Noori
//! parameters (numerical code, no I/O): a displacement-controlled cyclic
//! protocol (two cycles at each of increasing amplitudes, as in the ATC-24
//! and FEMA 461 quasi-static protocols) and the restoring force of Eq. L1–L6
//! of docs/lab-tests.md, integrated ten times finer than the identification
//! does (so a recovered parameter is not the integrator's echo), with seeded
//! Gaussian measurement noise on the force.

use crate::lab::model::{restoring_force, substep_for, BwbnParameters};
use crate::rng::Rng;

/// Two cycles at each amplitude (m), `points_per_cycle` samples per cycle,
/// starting and ending at zero (a sine at each amplitude).
pub fn cyclic_protocol(amplitudes_m: &[f64], points_per_cycle: usize) -> Vec<f64> {
    let ppc = points_per_cycle.max(4);
    let mut x = vec![0.0];
    for &a in amplitudes_m {
        for _ in 0..2 {
            for k in 1..=ppc {
                let phase = std::f64::consts::TAU * k as f64 / ppc as f64;
                x.push(a * phase.sin());
            }
        }
    }
    x
}

/// A specimen record: the protocol, the exact force and the measured one.
#[derive(Debug, Clone)]
pub struct SyntheticSpecimen {
    pub truth: BwbnParameters,
    pub displacement_m: Vec<f64>,
    pub exact_force_n: Vec<f64>,
    /// Exact force plus N(0, σ²), σ = `noise_fraction` × RMS of the exact force.
    pub measured_force_n: Vec<f64>,
    pub noise_std_n: f64,
}

/// The record of `truth` along `displacement_m`.
pub fn synthetic_specimen(
    truth: BwbnParameters,
    displacement_m: Vec<f64>,
    noise_fraction: f64,
    seed: u64,
) -> SyntheticSpecimen {
    let exact = restoring_force(&displacement_m, &truth, substep_for(&displacement_m) / 10.0);
    let rms = (exact.iter().map(|v| v * v).sum::<f64>() / exact.len().max(1) as f64).sqrt();
    let noise_std_n = noise_fraction * rms;
    let mut rng = Rng::new(seed);
    let measured = exact
        .iter()
        .map(|v| v + noise_std_n * rng.normal())
        .collect();
    SyntheticSpecimen {
        truth,
        displacement_m,
        exact_force_n: exact,
        measured_force_n: measured,
        noise_std_n,
    }
}

/// The specimen of the tests and docs: an RC-column-like spring
/// (k₀ = 20 kN/mm, u_y = 10 mm) with moderate degradation and pinching.
pub fn reference_bwbn() -> BwbnParameters {
    BwbnParameters {
        initial_stiffness_n_per_m: 2.0e7,
        post_yield_ratio: 0.05,
        yield_displacement_m: 0.010,
        beta: 0.6,
        n: 1.5,
        strength_degradation: 0.004,
        stiffness_degradation: 0.006,
        pinching_extent: 0.5,
        pinching_rate: 0.05,
        pinching_centre: 0.15,
        pinching_width: 0.3,
    }
}
