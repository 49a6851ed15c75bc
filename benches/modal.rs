//! Issue 3 benchmarks: the 5-storey ambient case (5 channels × 60 000
//! samples, orders 2–42, automatic selection included; target ≤ 0.25 s) and
//! the 40-s earthquake input–output case at 200 Hz (target ≤ 0.2 s).
//! Data generation is outside the timed loop.

use criterion::{criterion_group, criterion_main, Criterion};
use quaketwin::modal::{identify, Method, ModalInput, ModalSettings};
use quaketwin::rng::Rng;
use quaketwin::synth::{
    add_measurement_noise, synthetic_ground_motion, GroundMotionSpec, ShearBuilding,
};
use std::hint::black_box;

fn five_storey() -> ShearBuilding {
    ShearBuilding {
        masses_kg: vec![4.0e5, 3.8e5, 3.6e5, 3.4e5, 3.0e5],
        storey_stiffness_n_per_m: vec![7.2e8, 6.75e8, 6.3e8, 5.4e8, 4.5e8],
        damping_ratios: vec![0.015, 0.02, 0.025, 0.03, 0.04],
    }
}

fn ambient() -> ModalInput {
    let mut rng = Rng::new(1);
    let r = five_storey()
        .simulate_ambient(60_000, 0.01, 1.0e4, &mut rng)
        .unwrap();
    ModalInput {
        dt: 0.01,
        output_ids: (1..=5).map(|i| format!("L{i}")).collect(),
        outputs: r
            .absolute_acceleration
            .iter()
            .map(|a| add_measurement_noise(a, 20.0, &mut rng))
            .collect(),
        ..Default::default()
    }
}

fn earthquake() -> ModalInput {
    let params = GroundMotionSpec {
        seed: 7,
        ground_frequency_hz: 4.0,
        ..Default::default()
    };
    let ag = synthetic_ground_motion(&params).unwrap();
    let r = five_storey()
        .simulate_base_motion(&ag, params.dt())
        .unwrap();
    let mut rng = Rng::new(99);
    ModalInput {
        dt: params.dt(),
        output_ids: (1..=5).map(|i| format!("L{i}")).collect(),
        outputs: r
            .absolute_acceleration
            .iter()
            .map(|a| add_measurement_noise(a, 30.0, &mut rng))
            .collect(),
        input_ids: vec!["L0".into()],
        inputs: vec![add_measurement_noise(&r.base_acceleration, 30.0, &mut rng)],
        ..Default::default()
    }
}

fn bench_modal(c: &mut Criterion) {
    let ambient_input = ambient();
    let quake_input = earthquake();
    let mut group = c.benchmark_group("modal");
    group.sample_size(10);
    for method in [Method::SsiCov, Method::SsiData] {
        let mut settings = ModalSettings {
            method,
            ..Default::default()
        };
        settings.filters.damping_min = 0.005;
        settings.filters.damping_max = 0.06;
        group.bench_function(format!("ambient_5ch_60000_{}", method.name()), |b| {
            b.iter(|| {
                let r = identify(black_box(&ambient_input), &settings).unwrap();
                assert_eq!(r.modes.len(), 5);
                r
            })
        });
    }
    let settings = ModalSettings {
        method: Method::Io,
        ..Default::default()
    };
    group.bench_function("earthquake_io_6ch_8000", |b| {
        b.iter(|| {
            let r = identify(black_box(&quake_input), &settings).unwrap();
            assert_eq!(r.modes.len(), 5);
            r
        })
    });
    group.finish();
}

criterion_group!(benches, bench_modal);
criterion_main!(benches);
