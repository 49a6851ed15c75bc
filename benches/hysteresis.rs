//! Benchmark of the Bouc-Wen identification (issue 4 target: ≤ 5 s).
//! Case: the 2-DoF shear chain of tests/hysteresis.rs (m = [1e5, 1e5] kg,
//! storey stiffness [6e7, 4e7] N/m, δ11 = 4e-7, δ21 = −1e-6, δ22 = 4e-7 1/J,
//! β = [0.4, 2e-5], γ = [0.2, 1e-5], N = [1.4, 2.2]) in two directions (X:
//! ground-motion seed 7, Y: seed 11; 50 s, PGA 3.5 m/s², `strong_50s`),
//! simulated at 1000 Hz and recorded at 250 Hz; identification with the
//! default settings: N on [1, 10] at 0.001 (coarse 0.05 grid + refinement),
//! scalar and instantaneous estimates, damage index at every sample.

use criterion::{criterion_group, criterion_main, Criterion};
use quaketwin::hysteresis::*;
use quaketwin::synth::{synthetic_ground_motion, GroundMotionSpec};
use quaketwin::vocab::ProcessingHistory;

fn direction(label: &str, seed: u64) -> DirectionRecords {
    let chain = BoucWenChain::shear(
        vec![1e5, 1e5],
        &[6e7, 4e7],
        &[vec![4e-7], vec![-1e-6, 4e-7]],
        vec![0.4, 2e-5],
        vec![0.2, 1e-5],
        vec![1.4, 2.2],
    )
    .expect("valid chain");
    let ground = synthetic_ground_motion(&GroundMotionSpec::strong_50s(seed, 1000.0, 3.5))
        .expect("ground motion");
    let response = chain
        .simulate(&ground, 1000.0, 4)
        .expect("simulation")
        .subsample(4);
    DirectionRecords {
        direction: label.into(),
        source: "bench".into(),
        sampling_rate_hz: 250.0,
        base: Some(BaseRecord {
            channel: format!("base-{label}"),
            acceleration: ground.iter().step_by(4).copied().collect(),
        }),
        floors: (0..2)
            .map(|d| FloorRecord {
                channel: format!("floor{}-{label}", d + 1),
                absolute_acceleration: response.absolute_acceleration[d].clone(),
                mass_kg: Some(chain.masses[d]),
                relative_velocity: None,
                relative_displacement: None,
            })
            .collect(),
        declared_processing: ProcessingHistory::default(),
    }
}

fn bench(c: &mut Criterion) {
    let records = [direction("X", 7), direction("Y", 11)];
    let settings = IdentifySettings::default();
    let mut group = c.benchmark_group("hysteresis");
    group.sample_size(10);
    group.bench_function("two_dof_two_directions_50s_250hz_n_res_0.001", |b| {
        b.iter(|| identify_directions(&records, &settings).expect("identification"))
    });
    let no_instantaneous = IdentifySettings {
        instantaneous: false,
        ..IdentifySettings::default()
    };
    group.bench_function("two_dof_two_directions_scalar_only", |b| {
        b.iter(|| identify_directions(&records, &no_instantaneous).expect("identification"))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
