//! Channels of one recorder whose lengths differ by a few samples (real
//! CSMIP/NSMP sets: the processing cuts each channel on its own, ±4
//! samples) are trimmed to their common window at load, so drift,
//! the rigid-floor combination and Bouc-Wen — which need equal lengths —
//! see one window.  Larger differences are real and left alone.

use crate::vocab::{QaFlag, Record};

/// Largest length difference trimmed, as a fraction of the longest channel.
pub const TRIM_MAX_FRACTION: f64 = 0.01;
/// Largest length difference trimmed, seconds.
pub const TRIM_MAX_SECONDS: f64 = 0.5;

/// Trims channels of the same sampling rate that start within one sample
/// of each other and whose lengths differ by at most [`TRIM_MAX_FRACTION`]
/// of the longest **and** at most [`TRIM_MAX_SECONDS`] to the shortest
/// length (their common window), with a QA note per trimmed channel.
/// Returns the indices of the trimmed records and the event notes.
pub fn trim_near_equal_lengths(records: &mut [Record]) -> (Vec<usize>, Vec<String>) {
    // Groups: same rate (to 1e-9 relative), start within one sample (or both unknown).
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (i, r) in records.iter().enumerate() {
        let c = &r.channel;
        let same = |j: usize| {
            let o = &records[j].channel;
            let rate_ok = (o.sampling_rate_hz - c.sampling_rate_hz).abs()
                <= 1e-9 * c.sampling_rate_hz.abs().max(1.0);
            let dt_ns = 1e9 / c.sampling_rate_hz;
            let start_ok = match (o.start_ns, c.start_ns) {
                (Some(a), Some(b)) => ((a - b) as f64).abs() < dt_ns,
                (None, None) => true,
                _ => false,
            };
            rate_ok && start_ok
        };
        match groups.iter_mut().find(|g| same(g[0])) {
            Some(g) => g.push(i),
            None => groups.push(vec![i]),
        }
    }
    let mut trimmed = Vec::new();
    let mut notes = Vec::new();
    for g in groups.iter().filter(|g| g.len() > 1) {
        let lens: Vec<usize> = g.iter().map(|&i| records[i].samples.len()).collect();
        let (min, max) = (
            *lens.iter().min().expect("non-empty group"), // ok: groups have ≥ 2 members
            *lens.iter().max().expect("non-empty group"), // ok: as above
        );
        if min == max || min == 0 {
            continue;
        }
        let rate = records[g[0]].channel.sampling_rate_hz;
        let diff = max - min;
        let small =
            diff as f64 <= TRIM_MAX_FRACTION * max as f64 && diff as f64 / rate <= TRIM_MAX_SECONDS;
        let ids: Vec<String> = g.iter().map(|&i| records[i].channel.id.clone()).collect();
        if !small {
            notes.push(format!(
                "channels {} have the same rate and start but lengths {min}–{max} samples: a difference above {} % or {TRIM_MAX_SECONDS} s is left alone (stages needing equal lengths say so)",
                ids.join(", "),
                TRIM_MAX_FRACTION * 100.0
            ));
            continue;
        }
        for &i in g {
            let n = records[i].samples.len();
            if n > min {
                records[i].samples.as_mut_vec().truncate(min);
                records[i].channel.qa.push(QaFlag::Note {
                    text: format!(
                        "trimmed from {n} to {min} samples: the common window of the channels of the same rate and start (lengths differed by {diff} samples, {:.3} s)",
                        diff as f64 / rate
                    ),
                });
                trimmed.push(i);
            }
        }
        notes.push(format!(
            "{} channels ({}) differed in length by {diff} samples ({:.3} s) at the same rate and start: trimmed to their common {min} samples (rule: at most {} % of the length and at most {TRIM_MAX_SECONDS} s)",
            g.len(),
            ids.join(", "),
            diff as f64 / rate,
            TRIM_MAX_FRACTION * 100.0
        ));
    }
    (trimmed, notes)
}
