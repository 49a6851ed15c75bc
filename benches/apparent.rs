//! Issue 32 benchmark: the apparent-frequency track (`modal::apparent::
//! track_many`, moving-window ARX, default settings) on a 14-channel ×
//! 60 s × 200 Hz event (target ≤ 0.2 s): the 7-storey building twisting in
//! plan of benches/modal.rs (≈ 1.05 Hz in X, 1.27 Hz in Y), X and Y at one
//! corner of floors 2–7 (12 outputs, each with its direction's base
//! channel as input) and X and Y at the base, 20 dB noise.
//! Data generation is outside the timed loop.

use criterion::{criterion_group, criterion_main, Criterion};
use quaketwin::modal::apparent::{track_many, ApparentSettings, TrackRequest};
use quaketwin::rng::Rng;
use quaketwin::synth::{
    add_measurement_noise, synthetic_ground_motion, GroundMotionSpec, Sampling, Sensor,
};
use quaketwin::vocab::Axis;
use std::hint::black_box;

/// (base X, base Y, outputs with their axis), 60 s at 200 Hz.
fn fourteen_channels() -> (Vec<f64>, Vec<f64>, Vec<(Axis, Vec<f64>)>, [f64; 2]) {
    let building = quaketwin::synth::seven_storey_plan_building();
    let n = building.masses_kg.len();
    let spec = |seed| GroundMotionSpec {
        seed,
        duration_s: 60.0,
        sampling: Sampling::RateHz(200.0),
        ..Default::default()
    };
    let gx = synthetic_ground_motion(&spec(31)).unwrap();
    let gy = synthetic_ground_motion(&spec(32)).unwrap();
    let response = building
        .simulate_base_motion(&gx, &gy, spec(31).dt())
        .unwrap();
    let mut sensors = Vec::new();
    for level in (0..=n).filter(|&l| l != 1) {
        for axis in [Axis::X, Axis::Y] {
            sensors.push(Sensor {
                id: format!("L{level}-{axis:?}"),
                level,
                position_m: if level == 0 { [0.0, 0.0] } else { [15.0, 10.0] },
                axis,
            });
        }
    }
    let records = response.to_records(&sensors).unwrap();
    assert_eq!(records.len(), 14);
    let mut rng = Rng::new(33);
    let mut noisy: Vec<Vec<f64>> = records
        .iter()
        .map(|r| add_measurement_noise(&r.samples, 20.0, &mut rng))
        .collect();
    let outputs = noisy
        .split_off(2)
        .into_iter()
        .zip(sensors[2..].iter().map(|s| s.axis))
        .map(|(v, a)| (a, v))
        .collect();
    let [bx, by]: [Vec<f64>; 2] = noisy.try_into().unwrap();
    (bx, by, outputs, [1.05, 1.27])
}

fn bench_apparent(c: &mut Criterion) {
    let (bx, by, outputs, expected) = fourteen_channels();
    let requests: Vec<TrackRequest> = outputs
        .iter()
        .map(|(axis, y)| {
            let x = *axis == Axis::X;
            TrackRequest {
                input: Some(if x { &bx } else { &by }),
                output: y,
                expected_hz: expected[usize::from(!x)],
            }
        })
        .collect();
    assert_eq!(requests.len(), 12);
    let settings = ApparentSettings::default();
    for (r, t) in requests.iter().zip(track_many(&requests, 0.005, &settings)) {
        let t = t.unwrap();
        let mut f: Vec<f64> = t
            .points
            .iter()
            .map(|p| p.frequency_hz)
            .filter(|f| f.is_finite())
            .collect();
        f.sort_by(f64::total_cmp);
        eprintln!(
            "expected {:.2} Hz: {} windows of {:.2} s, {} with a pole, median {:.3} Hz",
            r.expected_hz,
            t.points.len(),
            t.window_s,
            f.len(),
            f.get(f.len() / 2).copied().unwrap_or(f64::NAN)
        );
    }
    let mut group = c.benchmark_group("apparent");
    group.sample_size(20);
    group.bench_function("track_many_12_outputs_60s_200Hz", |b| {
        b.iter(|| {
            let tracks = track_many(black_box(&requests), 0.005, &settings);
            assert!(tracks.iter().all(|t| t.is_ok()));
            tracks
        })
    });
    group.finish();
}

criterion_group!(benches, bench_apparent);
criterion_main!(benches);
