//! Benchmark of the hybrid-test rehearsal (issue 16) on the facade sample's prototype
//! (`sample-records/synthetic-facade/design.toml`: PS around the window, band of interest
//! 45 Hz) driven by the first 20 s of El Centro 1940 NS: one rehearsal at λ = 200, and the
//! sweep over the design's 10 candidate λ (α-OS, first-order servo at the design's 2 Hz actuator
//! band, 5 ms delay). The design itself is computed once, outside the measurement.

use criterion::{criterion_group, criterion_main, Criterion};
use std::path::Path;

use quaketwin::design::file::load_design;
use quaketwin::design::plan::{design_hybrid_test, BaseComponent, BaseMotion};
use quaketwin::readers::{at2, ReadOptions};
use quaketwin::rehearse::{rehearse, RehearsalModel, RehearseSettings};
use quaketwin::vocab::SourceRef;

fn el_centro(seconds: f64) -> (f64, Vec<f64>) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared/records/peer-at2-records/elCentro.AT2"
    );
    let path = if Path::new(path).exists() {
        path.to_string()
    } else {
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../shared/records/peer-at2-records/elCentro.AT2"
        )
        .to_string()
    };
    let bytes = std::fs::read(&path).expect("El Centro record in shared/records");
    let source = SourceRef {
        file: path.clone(),
        member: None,
        column: None,
        format: "at2".into(),
    };
    let contents = at2::read(&bytes, &source, &ReadOptions::default()).expect("AT2");
    let rec = &contents.records[0];
    let to_si = rec.channel.units.to_si_factor().expect("units");
    let dt = 1.0 / rec.channel.sampling_rate_hz;
    let n = ((seconds / dt).round() as usize).min(rec.samples.len());
    (dt, rec.samples[..n].iter().map(|a| a * to_si).collect())
}

fn facade_rehearsal(c: &mut Criterion) {
    let file = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../sample-records/synthetic-facade/design.toml");
    let design = load_design(&file).expect("facade design file");
    let (dt, acceleration) = el_centro(20.0);
    let motion = BaseMotion {
        dt,
        components: vec![BaseComponent {
            axis: 0,
            acceleration,
        }],
        source: "elCentro.AT2 (20 s)".into(),
    };
    let d = design_hybrid_test(
        &design.twin,
        &design.ps_node_ids,
        &motion,
        &design.settings,
        "bench",
    )
    .expect("design");
    let model = RehearsalModel::from_design(&design.twin, &d, &motion, &design.settings.hybrid)
        .expect("rehearsal model");
    let single = RehearseSettings {
        time_scales: vec![200.0],
        ..RehearseSettings::default()
    };
    let sweep = RehearseSettings::default();
    let r = rehearse(&model, &sweep).expect("sweep");
    println!(
        "facade rehearsal: {} actuators, {} NS modes, top {:.1} Hz, {} steps × {} substeps; smallest safe λ {:?}",
        model.actuators.len(),
        model.ns_modes,
        model.top_frequency_hz(),
        model.steps(),
        r.substeps,
        r.recommended.map(|i| r.runs[i].time_scale)
    );
    for run in &r.runs {
        println!(
            "  λ {:>6}: stable {} (diverged at {:?} s), WNRMSE {:?}, energy error {:.3e}",
            run.time_scale,
            run.stable,
            run.divergence_time_s,
            run.response_wnrmse,
            run.energy_error
        );
    }
    let mut group = c.benchmark_group("rehearse");
    group.sample_size(10);
    group.bench_function("facade_el_centro_20s_lambda_200", |b| {
        b.iter(|| rehearse(&model, &single).expect("rehearsal"))
    });
    group.bench_function("facade_el_centro_20s_sweep_10_lambda", |b| {
        b.iter(|| rehearse(&model, &sweep).expect("sweep"))
    });
    group.finish();
}

criterion_group!(benches, facade_rehearsal);
criterion_main!(benches);
