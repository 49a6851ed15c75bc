//! End-to-end benchmark (issue 7): an event of 20 channels × 60 s at 200 Hz
//! (a 9-storey shear building in X and Y plus two base channels, CSV +
//! manifest) through the whole post-earthquake pipeline, report included.
//! Target: ≤ 10 s on the 2-core reference machine.

use std::fmt::Write as _;
use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};
use quaketwin::rng::Rng;
use quaketwin::synth::{
    add_measurement_noise, synthetic_ground_motion, GroundMotionSpec, Sampling, ShearBuilding,
};

fn write_event(dir: &Path) {
    let dt = 1.0 / 200.0;
    let mut rng = Rng::new(11);
    let mut cols: Vec<(String, Vec<f64>)> = Vec::new();
    let mut manifest =
        String::from("[event]\nname = \"bench 20 channels\"\n[structure]\nname = \"bench\"\n");
    let _ = writeln!(
        manifest,
        "storey_heights_m = {:?}\nmasses_kg = {:?}",
        vec![3.5; 9],
        vec![4e5; 9]
    );
    for (i, dir_name) in ["X", "Y"].iter().enumerate() {
        let b = ShearBuilding::uniform(9, 4e5, 1.2e9 + 2e8 * i as f64, 0.02);
        let gm = GroundMotionSpec {
            duration_s: 60.0,
            sampling: Sampling::IntervalS(dt),
            seed: 3 + i as u64,
            ..Default::default()
        };
        let ag = synthetic_ground_motion(&gm).unwrap();
        let r = b.simulate_base_motion(&ag, dt).unwrap();
        cols.push((
            format!("B_{dir_name}"),
            add_measurement_noise(&ag, 40.0, &mut rng),
        ));
        let _ = writeln!(manifest, "[[channel]]\nfile = \"rec.csv\"\ncolumn = \"B_{dir_name}\"\nid = \"B-{dir_name}\"\nlevel = 0\ndirection = \"{dir_name}\"\nrole = \"input\"\nunits = \"m/s2\"\ntime_column = \"t\"");
        for (l, a) in r.absolute_acceleration.iter().enumerate() {
            cols.push((
                format!("F{}_{dir_name}", l + 1),
                add_measurement_noise(a, 40.0, &mut rng),
            ));
            let _ = writeln!(manifest, "[[channel]]\nfile = \"rec.csv\"\ncolumn = \"F{}_{dir_name}\"\nid = \"F{}-{dir_name}\"\nlevel = {}\ndirection = \"{dir_name}\"\nrole = \"output\"\nunits = \"m/s2\"\ntime_column = \"t\"", l + 1, l + 1, l + 1);
        }
    }
    assert_eq!(cols.len(), 20);
    let n = cols[0].1.len();
    let mut csv = String::from("t");
    for (c, _) in &cols {
        let _ = write!(csv, ",{c}");
    }
    csv.push('\n');
    for k in 0..n {
        let _ = write!(csv, "{:.4}", k as f64 * dt);
        for (_, v) in &cols {
            let _ = write!(csv, ",{:.8e}", v[k]);
        }
        csv.push('\n');
    }
    std::fs::write(dir.join("rec.csv"), csv).unwrap();
    std::fs::write(dir.join("event.toml"), manifest).unwrap();
}

fn bench(c: &mut Criterion) {
    let event = tempfile::tempdir().unwrap();
    write_event(event.path());
    let pipeline = Path::new(env!("CARGO_MANIFEST_DIR")).join("../pipelines/post-earthquake.toml");
    let mut g = c.benchmark_group("post_earthquake");
    g.sample_size(10);
    g.bench_function("20ch_60s_200Hz_full_pipeline_with_report", |b| {
        b.iter_batched(
            || tempfile::tempdir().unwrap(),
            |out| {
                quaketwin::commands::run_pipeline(&pipeline, event.path(), out.path(), true)
                    .unwrap();
                assert!(out.path().join("report.html").exists());
                out
            },
            criterion::BatchSize::PerIteration,
        )
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
