//! Issue 18: Parquet write throughput of `samples/samples.parquet` for 64 channels
//! × 1 h × 200 Hz (46.08 M rows: channel id, sample, t, absolute time,
//! acceleration, velocity, displacement), through the product's writer
//! (`sinks::event_tables::write_samples`: zstd level 3, series encodings,
//! columns encoded in parallel, temporary file renamed into place).
//!
//! Criterion reports the throughput over the **Arrow bytes** written (the
//! in-memory columns: 48 bytes per row of numbers plus the channel id
//! string and offsets); the file's own size is printed once, so the
//! throughput over file bytes follows.  Target (issue 18): ≥ 300 MB/s.
//! Data generation is outside the timed loop; the page cache absorbs the
//! file (the bench measures encoding and compression, not the disk).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use quaketwin::conditioning::Motion;
use quaketwin::rng::Rng;
use quaketwin::sinks::event_tables::write_samples;
use quaketwin::vocab::{Channel, Event, Record, Samples, SourceRef, Units};

const CHANNELS: usize = 64;
const RATE_HZ: f64 = 200.0;
const SAMPLES: usize = 3600 * 200;

fn event() -> (Event, Vec<Motion>) {
    let mut rng = Rng::new(5);
    let mut event = Event {
        name: "bench parquet 64 channels".into(),
        origin_ns: Some(1_700_000_000_000_000_000),
        ..Default::default()
    };
    let mut motions = Vec::new();
    for c in 0..CHANNELS {
        let id = format!("CH{c:02}");
        let source = SourceRef {
            file: "bench.csv".into(),
            member: None,
            column: Some(id.clone()),
            format: "csv".into(),
        };
        let mut channel = Channel::new(id.clone(), Units::MPerS2, RATE_HZ, source);
        channel.start_ns = event.origin_ns;
        // A damped oscillation in noise: realistic mantissas for the codecs.
        let omega = std::f64::consts::TAU * (1.0 + 0.05 * c as f64);
        let acc: Vec<f64> = (0..SAMPLES)
            .map(|i| {
                let t = i as f64 / RATE_HZ;
                0.3 * (omega * t).sin() * (-0.001 * t).exp() + 0.01 * rng.normal()
            })
            .collect();
        let dt = 1.0 / RATE_HZ;
        let vel = quaketwin::numeric::cumulative_trapezoid(&acc, dt);
        let disp = quaketwin::numeric::cumulative_trapezoid(&vel, dt);
        motions.push(Motion {
            channel_id: id,
            dt,
            acceleration: Samples::new(acc.clone()),
            velocity: Samples::new(vel),
            displacement: Samples::new(disp),
        });
        event.records.push(Record::new(channel, acc));
    }
    (event, motions)
}

fn bench_parquet(c: &mut Criterion) {
    let (event, motions) = event();
    let dir = tempfile::tempdir().expect("temporary directory");
    let path = dir.path().join("samples/samples.parquet");
    let id_bytes: usize = event
        .records
        .iter()
        .map(|r| r.channel.id.len() + 4)
        .sum::<usize>()
        * SAMPLES;
    let arrow_bytes = (CHANNELS * SAMPLES * 6 * 8 + id_bytes) as u64;
    write_samples(&path, &event, &motions).expect("write");
    let file_bytes = std::fs::metadata(&path).expect("file").len();
    eprintln!(
        "samples/samples.parquet: {} rows, {:.0} MB of Arrow data, {:.0} MB file",
        CHANNELS * SAMPLES,
        arrow_bytes as f64 / 1e6,
        file_bytes as f64 / 1e6
    );
    let mut group = c.benchmark_group("parquet_write");
    group.sample_size(10);
    group.throughput(Throughput::Bytes(arrow_bytes));
    group.bench_function("samples_64ch_1h_200Hz", |b| {
        b.iter(|| write_samples(&path, &event, &motions).expect("write"))
    });
    group.finish();
}

criterion_group!(benches, bench_parquet);
criterion_main!(benches);
