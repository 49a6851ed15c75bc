//! Benchmark of the hybrid-test design (issue 6): the whole `design_hybrid_test` on the
//! masonry facade sample twin (408 free DoFs, PS of 144 DoFs around the window) under the
//! first 10 s of El Centro 1940 NS: reference Newmark response, POD, the greedy interface
//! refinement (one reduced-twin simulation and eigen solve per step), actuators and the
//! Craig–Bampton recommendation.

use criterion::{criterion_group, criterion_main, Criterion};
use std::path::Path;

use quaketwin::design::plan::{design_hybrid_test, BaseComponent, BaseMotion, DesignSettings};
use quaketwin::readers::{at2, ReadOptions};
use quaketwin::synth::facade::{facade_node_id, facade_twin_toml};
use quaketwin::twin::parse_twin;
use quaketwin::vocab::SourceRef;

fn el_centro_10s() -> (f64, Vec<f64>) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/records/peer-at2-records/elCentro.AT2"
    );
    let bytes = std::fs::read(path).expect("El Centro record in ../shared/records");
    let source = SourceRef {
        file: path.into(),
        member: None,
        column: None,
        format: "at2".into(),
    };
    let contents = at2::read(&bytes, &source, &ReadOptions::default()).expect("AT2");
    let rec = &contents.records[0];
    let to_si = rec.channel.units.to_si_factor().expect("units");
    let dt = 1.0 / rec.channel.sampling_rate_hz;
    let n = ((10.0 / dt).round() as usize).min(rec.samples.len());
    (dt, rec.samples[..n].iter().map(|a| a * to_si).collect())
}

fn facade_design(c: &mut Criterion) {
    let twin = parse_twin(&facade_twin_toml(), "facade.toml", Path::new(".")).expect("twin");
    let ps: Vec<i64> = (4..=12)
        .flat_map(|i| (3..=11).map(move |j| facade_node_id(i, j)))
        .collect();
    let (dt, acceleration) = el_centro_10s();
    let motion = BaseMotion {
        dt,
        components: vec![BaseComponent {
            axis: 0,
            acceleration,
        }],
        source: "elCentro.AT2".into(),
    };
    let mut settings = DesignSettings::default();
    settings.hybrid.band_of_interest_hz = 40.0;
    let design = design_hybrid_test(&twin, &ps, &motion, &settings, "bench").expect("design");
    println!(
        "facade design: {} refinement steps, {} actuators, WNRMSE {:.2e}",
        design.refinement.len(),
        design.actuators.len(),
        design.validation.wnrmse
    );
    let mut group = c.benchmark_group("design");
    group.sample_size(10);
    group.bench_function("facade_el_centro_10s", |b| {
        b.iter(|| design_hybrid_test(&twin, &ps, &motion, &settings, "bench").expect("design"))
    });
    group.finish();
}

criterion_group!(benches, facade_design);
criterion_main!(benches);
