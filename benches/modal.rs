//! Issue 3 benchmarks: the 5-storey ambient case (5 channels × 60 000
//! samples, orders 2–42, automatic selection included; target ≤ 0.25 s) and
//! the 40-s earthquake input–output case at 200 Hz (target ≤ 0.2 s).
//! Issue 13: the modal stage on a 14-channel × 41 s × 200 Hz event (target
//! ≤ 0.1 s): a 7-storey building twisting in plan, X and Y at one corner of
//! floors 2–7 (12 outputs) and X and Y at the base (the inputs), with the
//! settings the stage derives (`ModalParams::settings_for`: `auto` → io),
//! with and without storey heights in the manifest (which set the band and
//! so the decimation); identification alone and the whole stage (tables
//! and PSD overlay written).  Issue 36: each of the last two also without
//! the data-driven σ (`uncertainty_blocks = 0`): the difference is what the
//! uncertainty costs (target ≤ 50 % of the stage).
//! The 14-channel event is `quaketwin::synth::fourteen_channel_event`.
//! Data generation is outside the timed loop.

use criterion::{criterion_group, criterion_main, Criterion};
use quaketwin::modal::{
    identify, identify_event, ChannelChoice, Method, ModalInput, ModalSettings,
};
use quaketwin::rng::Rng;
use quaketwin::stages::modal::{identify_and_write, ModalParams};
use quaketwin::synth::five_storey::{five_storey_building, noisy_ambient};
use quaketwin::synth::{
    add_measurement_noise, fourteen_channel_event, synthetic_ground_motion, GroundMotionSpec,
};
use std::hint::black_box;

fn ambient() -> ModalInput {
    ModalInput {
        dt: 0.01,
        output_ids: (1..=5).map(|i| format!("L{i}")).collect(),
        outputs: noisy_ambient(&five_storey_building(), 60_000, 0.01, 1).unwrap(),
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
    let r = five_storey_building()
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

fn bench_modal_stage(c: &mut Criterion) {
    let mut group = c.benchmark_group("modal_stage");
    group.sample_size(20);
    let params = ModalParams::default();
    for (heights, label) in [(false, "no_structure"), (true, "storey_heights")] {
        let event = fourteen_channel_event(heights).unwrap();
        let settings = params.settings_for(&event).unwrap();
        assert_eq!(settings.method, Method::Io);
        let choice = ChannelChoice::default();
        let result = identify_event(&event, &settings, &choice).unwrap();
        eprintln!(
            "{label}: decimation {}, block rows {}, orders ≤ {:?}, modes {:?}",
            result.decimation,
            result.block_rows,
            result.orders.last(),
            result
                .modes
                .iter()
                .map(|m| format!("{:.3} {}", m.frequency_hz, m.direction))
                .collect::<Vec<_>>()
        );
        group.bench_function(format!("14ch_41s_200Hz_identify_{label}"), |b| {
            b.iter(|| {
                let r = identify_event(black_box(&event), &settings, &choice).unwrap();
                assert!(!r.modes.is_empty());
                r
            })
        });
        // Issue 36: the same without the data-driven σ (uncertainty_blocks = 0),
        // the cost of the uncertainty being the difference.
        let without = ModalSettings {
            uncertainty_blocks: Some(0),
            ..settings.clone()
        };
        group.bench_function(
            format!("14ch_41s_200Hz_identify_{label}_no_uncertainty"),
            |b| {
                b.iter(|| {
                    let r = identify_event(black_box(&event), &without, &choice).unwrap();
                    assert!(!r.modes.is_empty());
                    r
                })
            },
        );
        let out = tempfile::tempdir().unwrap();
        group.bench_function(format!("14ch_41s_200Hz_stage_{label}"), |b| {
            b.iter(|| identify_and_write(black_box(&event), &params, None, out.path()).unwrap())
        });
        let params_without = ModalParams {
            uncertainty_blocks: Some(0),
            ..ModalParams::default()
        };
        group.bench_function(
            format!("14ch_41s_200Hz_stage_{label}_no_uncertainty"),
            |b| {
                b.iter(|| {
                    identify_and_write(black_box(&event), &params_without, None, out.path())
                        .unwrap()
                })
            },
        );
    }
    group.finish();
}

criterion_group!(benches, bench_modal, bench_modal_stage);
criterion_main!(benches);
