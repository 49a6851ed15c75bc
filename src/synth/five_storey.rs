//! The 5-storey shear building of the modal, uncertainty, change-test and
//! environment studies (docs/statistics.md), and its seeded ambient records:
//! one definition for the tests and the benchmarks.

use super::{add_measurement_noise, ShearBuilding};
use crate::error::Result;
use crate::rng::Rng;

/// The 5-storey test building: f ≈ 2.0–12.4 Hz (T₁ ≈ 0.5 s, typical of five
/// storeys), damping 1.5–4 %.
pub fn five_storey_building() -> ShearBuilding {
    ShearBuilding {
        masses_kg: vec![4.0e5, 3.8e5, 3.6e5, 3.4e5, 3.0e5],
        storey_stiffness_n_per_m: vec![7.2e8, 6.75e8, 6.3e8, 5.4e8, 4.5e8],
        damping_ratios: vec![0.015, 0.02, 0.025, 0.03, 0.04],
    }
}

/// `samples` floor accelerations of `building` under independent white floor
/// forces (1e4 N), step `dt`, each with 20 dB measurement noise; one seeded
/// generator draws the forces, then the noise.
pub fn noisy_ambient(
    building: &ShearBuilding,
    samples: usize,
    dt: f64,
    seed: u64,
) -> Result<Vec<Vec<f64>>> {
    let mut rng = Rng::new(seed);
    let response = building.simulate_ambient(samples, dt, 1.0e4, &mut rng)?;
    Ok(response
        .absolute_acceleration
        .iter()
        .map(|a| add_measurement_noise(a, 20.0, &mut rng))
        .collect())
}
