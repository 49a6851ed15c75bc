//! Models shared by several benchmarks (each bench target includes this
//! module: `mod shared;`).

use quaketwin::synth::PlanBuilding;

/// The issue-13 building: 7 storeys, 30 m × 20 m in plan, 500 t per floor,
/// ≈ 1.05 Hz (X), 1.27 Hz (Y), 1.6 Hz (torsion), centre of mass 5 % off.
pub fn seven_storey_plan_building() -> PlanBuilding {
    let n = 7;
    let m = 5.0e5;
    let inertia = m * (30.0f64.powi(2) + 20.0f64.powi(2)) / 12.0;
    PlanBuilding {
        masses_kg: vec![m; n],
        rotational_inertia_kg_m2: vec![inertia; n],
        mass_eccentricity_m: [1.5, 1.0],
        storey_stiffness_x_n_per_m: vec![4.98e8; n],
        storey_stiffness_y_n_per_m: vec![7.29e8; n],
        storey_torsional_stiffness_n_m_per_rad: vec![2314.0 * inertia; n],
        damping_ratios: vec![0.02],
    }
}
