//! Benchmarks of the twin (issue 5 targets): the 10 lowest modes of a ~100 000-DoF shell
//! model (≤ 30 s) and the ensemble update of the thesis benchmark beam (≤ 10 s).

use criterion::{criterion_group, criterion_main, Criterion};
use std::path::Path;

use quaketwin::twin::benchmark::{shell_plate_toml, thesis_cantilever_toml, TRUE_MODULI};
use quaketwin::twin::ensemble::{run_ensemble, EnsembleOptions};
use quaketwin::twin::objective::{MeasuredMode, MeasuredModes, ModalObjective, ObjectiveOptions};
use quaketwin::twin::optimisers::{default_solvers, Bounds};
use quaketwin::twin::parse_twin;

fn shell_100k_modes(c: &mut Criterion) {
    // 162 × 102 elements: 163·103 nodes · 6 − 103 · 6 clamped = 100 116 free DoFs.
    let twin = parse_twin(
        &shell_plate_toml(162, 102, 16.2, 10.2),
        "plate.toml",
        Path::new("."),
    )
    .expect("plate twin");
    println!("shell model: {} free DoFs", twin.system.n);
    let mut group = c.benchmark_group("twin");
    group.sample_size(10);
    group.bench_function("shell_100k_dof_10_modes", |b| {
        b.iter(|| {
            let modes = twin.system.modes(&[], 10).expect("modes");
            assert_eq!(modes.count(), 10);
            modes
        })
    });
    group.finish();
}

fn ensemble_beam(c: &mut Criterion) {
    let twin = parse_twin(
        &thesis_cantilever_toml([5.05e9; 3]),
        "beam.toml",
        Path::new("."),
    )
    .expect("beam twin");
    let sys = &twin.system;
    let truth = sys.modes(&TRUE_MODULI, 2).expect("modes");
    let f = truth.frequencies_hz();
    let modes = (0..2)
        .map(|j| {
            let s = truth.shape(j);
            MeasuredMode {
                frequency_hz: f[j],
                shape: vec![sys.sensors[0].read(&s), sys.sensors[1].read(&s)],
            }
        })
        .collect();
    let measured = MeasuredModes {
        source: "synthetic".into(),
        channels: vec!["h1".into(), "top".into()],
        modes,
    };
    let objective =
        ModalObjective::new(sys, measured, ObjectiveOptions::default()).expect("objective");
    let bounds = Bounds::new(sys.lower_bounds(), sys.upper_bounds());
    let solvers = default_solvers();
    let mut group = c.benchmark_group("twin");
    group.sample_size(10);
    group.bench_function("ensemble_update_benchmark_beam", |b| {
        b.iter(|| {
            run_ensemble(
                &objective,
                &bounds,
                &bounds.mid(),
                &solvers,
                &EnsembleOptions::default(),
            )
            .expect("ensemble")
        })
    });
    group.finish();
}

criterion_group!(benches, shell_100k_modes, ensemble_beam);
criterion_main!(benches);
