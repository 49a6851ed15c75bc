//! The 14-channel event of the modal benchmarks (issue 13) and of the
//! uncertainty cost check (issue 36): a 7-storey building twisting in
//! plan, 41 s at 200 Hz of independent X and Y base motions, X and Y at one
//! corner of floors 2–7 (12 outputs) and at the base (the 2 inputs), 20 dB
//! of measurement noise.  One generator for `benches/modal.rs` and
//! `tests/it/uncertainty.rs`, so that the test's figures and the bench's
//! are of the same event.  Numerical code; no I/O.

use super::{
    add_measurement_noise, synthetic_ground_motion, GroundMotionSpec, PlanBuilding, Sampling,
    Sensor,
};
use crate::error::Result;
use crate::rng::Rng;
use crate::vocab::{Axis, Event, Structure};

/// The issue-13 building: 7 storeys of 3.5 m, 30 m × 20 m in plan, 500 t
/// per floor, ≈ 1.05 Hz (X), 1.27 Hz (Y), 1.6 Hz (torsion), centre of mass
/// 5 % off (1.5 m, 1.0 m), 2 % damping in every mode.
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

/// [`seven_storey_plan_building`] shaken for 41 s at 200 Hz by synthetic
/// ground motions of seeds 31 (X) and 32 (Y); channels `L{level}-{X|Y}` at
/// levels 0 and 2–7 (the base at the plan origin, the floors at the corner
/// (15 m, 10 m)), 20 dB of noise (seed 33).  `storey_heights`: the event's
/// structure carries the 3.5-m storey heights (which set the modal stage's
/// band and so its decimation), else no structure.
pub fn fourteen_channel_event(storey_heights: bool) -> Result<Event> {
    let building = seven_storey_plan_building();
    let n = building.masses_kg.len();
    let spec = |seed| GroundMotionSpec {
        seed,
        duration_s: 41.0,
        sampling: Sampling::RateHz(200.0),
        ..Default::default()
    };
    let gx = synthetic_ground_motion(&spec(31))?;
    let gy = synthetic_ground_motion(&spec(32))?;
    let response = building.simulate_base_motion(&gx, &gy, spec(31).dt())?;
    let mut sensors = Vec::new();
    for level in (0..=n).filter(|&l| l != 1) {
        for (axis, name) in [(Axis::X, "X"), (Axis::Y, "Y")] {
            sensors.push(Sensor {
                id: format!("L{level}-{name}"),
                level,
                position_m: if level == 0 { [0.0, 0.0] } else { [15.0, 10.0] },
                axis,
            });
        }
    }
    let mut records = response.to_records(&sensors)?;
    let mut rng = Rng::new(33);
    for r in records.iter_mut() {
        r.samples = add_measurement_noise(&r.samples, 20.0, &mut rng).into();
    }
    Ok(Event {
        name: "14 channels".into(),
        structure: storey_heights.then(|| Structure {
            storey_heights_m: vec![3.5; n],
            ..Default::default()
        }),
        records,
        ..Default::default()
    })
}
