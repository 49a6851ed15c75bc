//! Zero-phase filtering throughput: 64 channels × 1 hour at 200 Hz
//! (46.08 M samples), 4th-order Butterworth band-pass 0.5–20 Hz
//! (4 second-order sections), `sosfiltfilt` on every channel in parallel.
//! Target ≤ 0.66 s on the 2-core machine (scipy: 1.33 s single-threaded).

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::time::Duration;

use quaketwin::conditioning::{butter_sos, sosfiltfilt_channels, BandType};

/// The allocator of the `quaketwin` binary (src/main.rs): mimalloc, keeping
/// freed memory for reuse (`keep_freed_memory` below).  Under the system
/// allocator each iteration's 368 MB of outputs came as fresh pages the
/// kernel zeroes — a fifth of the measured time was system time, which the
/// product does not pay.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// As `quaketwin`'s main: `mi_option_purge_delay` (15) set to −1, never.
fn keep_freed_memory() {
    // SAFETY: sets an option value; mimalloc reads options at each purge.
    unsafe { libmimalloc_sys::mi_option_set(15, -1) }
}

const CHANNELS: usize = 64;
const RATE_HZ: f64 = 200.0;
const SAMPLES: usize = 3600 * 200;

/// Deterministic test signals: a few sines plus SplitMix64 noise per channel.
fn channels() -> Vec<Vec<f64>> {
    (0..CHANNELS)
        .map(|c| {
            let mut state = 0x9e37_79b9_7f4a_7c15u64.wrapping_mul(c as u64 + 1);
            (0..SAMPLES)
                .map(|i| {
                    state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
                    let mut z = state;
                    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
                    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
                    let noise = (z ^ (z >> 31)) as f64 / u64::MAX as f64 - 0.5;
                    let t = i as f64 / RATE_HZ;
                    (2.0 * std::f64::consts::PI * (1.0 + 0.1 * c as f64) * t).sin()
                        + 0.3 * (2.0 * std::f64::consts::PI * 35.0 * t).sin()
                        + 0.1 * noise
                })
                .collect()
        })
        .collect()
}

fn bench_sosfiltfilt(c: &mut Criterion) {
    keep_freed_memory();
    let sos = butter_sos(4, BandType::Bandpass, &[0.5, 20.0], RATE_HZ).expect("valid design");
    assert_eq!(sos.len(), 4);
    let data = channels();
    let mut group = c.benchmark_group("sosfiltfilt");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(8));
    group.bench_function("64ch_1h_200Hz_bp4_0.5-20Hz", |b| {
        b.iter(|| black_box(sosfiltfilt_channels(&sos, black_box(&data)).expect("filtering")))
    });
    group.finish();
}

criterion_group!(benches, bench_sosfiltfilt);
criterion_main!(benches);
