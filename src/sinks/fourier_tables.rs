//! `fourier/fourier.parquet` (docs/formats.md): each record's smoothed Fourier
//! amplitude spectra of the signal and noise windows, their ratio and the
//! filter corners chosen from it (`conditioning::snr`) — long format, one row
//! per channel and frequency, the channel's corners and windows on each row.

use std::path::Path;

use super::parquet::{write_parquet, TableBuilder};
use crate::conditioning::RecordFourier;
use crate::error::Result;
use crate::vocab::tables::{fourier, FOURIER};
use crate::vocab::Event;

/// The note of a channel: why each corner is where it is.
fn note(r: &RecordFourier) -> String {
    let hz = crate::conditioning::snr::hz_text;
    let mut parts = Vec::new();
    if let Some(h) = &r.choice.high_pass {
        parts.push(format!("high-pass {}: {}", hz(h.hz), h.why));
    }
    if let Some(l) = &r.choice.low_pass {
        parts.push(format!("low-pass {}: {}", hz(l.hz), l.why));
    }
    // This record's own corners, when the event's differ from them.
    let own = |c: &crate::conditioning::CornerChoice| {
        (
            c.high_pass.as_ref().map(|h| h.hz),
            c.low_pass.as_ref().map(|l| l.hz),
        )
    };
    if r.own.from_snr && own(&r.own) != own(&r.choice) {
        let mut mine = Vec::new();
        if let Some(h) = &r.own.high_pass {
            mine.push(format!("high-pass {}", hz(h.hz)));
        }
        if let Some(l) = &r.own.low_pass {
            mine.push(format!("low-pass {}", hz(l.hz)));
        }
        parts.push(format!(
            "this record's own spectra alone give {}",
            mine.join(" and ")
        ));
    }
    parts.join("; ")
}

/// Writes `fourier/fourier.parquet` for the records of `list` that have spectra.
pub fn write_fourier(path: &Path, event: &Event, list: &[RecordFourier]) -> Result<()> {
    let mut id = Vec::new();
    let (mut freq, mut signal, mut noise, mut snr) = (vec![], vec![], vec![], vec![]);
    let (mut high, mut low, mut from, mut notes) = (vec![], vec![], vec![], vec![]);
    let (mut s0, mut s1, mut n0, mut n1) = (vec![], vec![], vec![], vec![]);
    for r in list {
        let Some(s) = &r.spectra else { continue };
        let ratio = s.snr();
        let text = note(r);
        for (i, &f) in s.frequencies_hz.iter().enumerate() {
            id.push(r.channel_id.clone());
            freq.push(f);
            signal.push(s.signal[i]);
            noise.push(s.noise.get(i).copied().flatten());
            snr.push(ratio[i]);
            high.push(r.choice.high_pass.as_ref().map(|c| c.hz));
            low.push(r.choice.low_pass.as_ref().map(|c| c.hz));
            from.push(if r.choice.from_snr { "snr" } else { "stated" });
            notes.push(text.clone());
            s0.push(s.signal_window_s[0]);
            s1.push(s.signal_window_s[1]);
            n0.push(s.noise_window_s.map(|w| w[0]));
            n1.push(s.noise_window_s.map(|w| w[1]));
        }
    }
    let batch = TableBuilder::new(&FOURIER)
        .str(fourier::CHANNEL_ID, &id)
        .f64(fourier::FREQUENCY_HZ, freq)
        .f64(fourier::SIGNAL_FAS, signal)
        .opt_f64(fourier::NOISE_FAS, noise)
        .opt_f64(fourier::SNR, snr)
        .opt_f64(fourier::HIGH_PASS_HZ, high)
        .opt_f64(fourier::LOW_PASS_HZ, low)
        .str(fourier::CORNERS_FROM, &from)
        .str(fourier::NOTE, &notes)
        .f64(fourier::SIGNAL_START_S, s0)
        .f64(fourier::SIGNAL_END_S, s1)
        .opt_f64(fourier::NOISE_START_S, n0)
        .opt_f64(fourier::NOISE_END_S, n1)
        .build()?;
    let metadata = super::provenance::Provenance::of_event(event).metadata();
    write_parquet(path, &[batch], &metadata)
}
