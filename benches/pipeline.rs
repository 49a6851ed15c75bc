//! End-to-end benchmark (issue 7): an event of 20 channels × 60 s at 200 Hz
//! (a 9-storey shear building in X and Y plus two base channels, CSV +
//! manifest) through the whole post-earthquake pipeline, report included.
//! Target: ≤ 10 s on the 2-core reference machine.

use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};

#[path = "bench_events.rs"]
mod bench_events;
use bench_events::write_event;

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
