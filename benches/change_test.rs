//! Issue 36 benchmark: the χ² change test of one one-hour window (target
//! ≤ 50 ms): the 5-storey shear building of tests/it/modal.rs, ambient
//! floor forces, 5 floor channels at 100 Hz with 20 dB noise, against a
//! reference of three healthy hours.  Timed: what a monitoring window
//! costs — its covariances in 60 blocks (`covariance_blocks`) and the test
//! (`ChangeReference::test`); the reference is built once (also timed,
//! separately).  Data generation is outside the timed loops.

use criterion::{criterion_group, criterion_main, Criterion};
use quaketwin::modal::change_test::{
    covariance_blocks, reference_from, ChangeTestSettings, CovarianceBlocks, HankelShape,
};
use quaketwin::synth::five_storey::{five_storey_building, noisy_ambient};
use std::hint::black_box;

/// One seeded hour of the 5-storey building's noisy floor accelerations.
fn hour(seed: u64) -> Vec<Vec<f64>> {
    noisy_ambient(&five_storey_building(), 360_000, 0.01, seed).unwrap()
}

fn blocks(record: &[Vec<f64>], shape: HankelShape) -> CovarianceBlocks {
    let views: Vec<&[f64]> = record.iter().map(|s| s.as_slice()).collect();
    covariance_blocks(
        &views,
        shape.max_lag(),
        3,
        ChangeTestSettings::default().blocks_per_record,
    )
    .unwrap()
}

fn bench_change_test(c: &mut Criterion) {
    let shape = HankelShape::for_order(10, 5);
    let refs: Vec<CovarianceBlocks> = (1..=3).map(|s| blocks(&hour(s), shape)).collect();
    let window = hour(99);
    let reference = reference_from(&refs, shape).unwrap();
    let mut group = c.benchmark_group("change_test");
    group.sample_size(20);
    group.bench_function("one_hour_window_5ch_100Hz", |b| {
        b.iter(|| {
            let w = blocks(black_box(&window), shape);
            reference.test(&w, 0.01).unwrap()
        })
    });
    group.bench_function("reference_of_three_hours", |b| {
        b.iter(|| reference_from(black_box(&refs), shape).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench_change_test);
criterion_main!(benches);
