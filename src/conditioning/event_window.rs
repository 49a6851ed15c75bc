//! The **event window** of a continuous record (issue 33 item 6).
//!
//! A triggered strong-motion record is the earthquake with some pre- and
//! post-event motion; a continuous monitoring record (a day of 64 channels at
//! 200 Hz) is hours of microtremor holding a minute of earthquake.  The
//! event's analyses are those of the earthquake: conditioned whole, a day's
//! 5 % cosine taper would span 72 minutes at each end (an earthquake twenty
//! minutes in would be scaled by ≈ 0.2), its Arias intensity and significant
//! duration would be those of the day's noise, its velocity and
//! displacement 26 GB of series nobody reads, and its modal identification
//! would mix a day of ambient vibration with the earthquake's softened
//! modes.  So a record longer than [`CONTINUOUS_ABOVE_S`] is analysed on its
//! event window: the stages that condition records (with steps) and the
//! residual drift take the window; the records as recorded (a condition
//! stage without steps) are written whole, once.
//!
//! The window, from the records as read (no units, no filter needed):
//! - each record's **envelope**: the largest absolute first difference
//!   |x[i] − x[i−1]| in each second (differencing removes the offset and a
//!   slow drift, which dominate a raw day), divided by the record's largest;
//! - the event's envelope E(t): the sum of the records' envelopes on a
//!   common time base (the records' start times) — an earthquake moves every
//!   channel at once, a glitch on one channel adds at most 1 of N;
//! - the **strong motion**: the first to the last second at which E reaches
//!   `max(THRESHOLD · max E, NOISE_FACTOR · median E)` — the bracketed
//!   duration of Bolt (1973) on E, relative to its peak (5 %, as the Bouc-Wen
//!   stage's window: `hysteresis::window`) and kept above the noise floor
//!   (the median second is microtremor);
//! - the window: the strong motion widened by [`MARGIN_S`] on each side,
//!   within the record — pre-event motion for the taper, the noise window of
//!   the QA's signal-to-noise ratio and the structure at rest, post-event
//!   motion for the free decay and the filter's transient.
//!
//! When E has no second above the level (a day of ambient vibration), there
//! is no event window and the records are analysed whole.

use std::ops::Range;

use serde_json::json;

use crate::vocab::{Event, ProcessingHistory, Record};

/// Records longer than this are continuous, s (half an hour: triggered
/// strong-motion records last minutes — five for the longest shaking, the
/// 2011 Tohoku records; monitoring systems store hours or days).
pub const CONTINUOUS_ABOVE_S: f64 = 1800.0;
/// Envelope bin, s.
const BIN_S: f64 = 1.0;
/// The strong motion's level relative to the peak of E (Bolt's bracket).
const THRESHOLD: f64 = 0.05;
/// The strong motion's level relative to the median of E (the noise floor).
const NOISE_FACTOR: f64 = 4.0;
/// Motion kept before and after the strong motion, s.
pub const MARGIN_S: f64 = 120.0;

/// One record's envelope (see the module doc).
#[derive(Debug, Clone)]
pub struct Envelope {
    /// Start of the record, ns since the epoch (None: the event's start).
    start_ns: Option<i64>,
    /// Length of the record, s.
    duration_s: f64,
    /// Largest |first difference| of each second, divided by the largest of all.
    bins: Vec<f32>,
}

/// The envelope of `values` sampled at `rate_hz`; `None` for a record too
/// short or too flat to have one, or of unusable rate.
pub fn envelope(values: &[f64], rate_hz: f64, start_ns: Option<i64>) -> Option<Envelope> {
    if !(rate_hz > 0.0 && rate_hz.is_finite()) || values.len() < 2 {
        return None;
    }
    let per_bin = ((BIN_S * rate_hz).round() as usize).max(1);
    let mut bins = Vec::with_capacity(values.len() / per_bin + 1);
    let mut peak = 0.0f64;
    for (b, chunk) in values.chunks(per_bin).enumerate() {
        // A bin's first difference reaches back to the previous bin's last sample.
        let before = if b == 0 {
            chunk[0]
        } else {
            values[b * per_bin - 1]
        };
        let mut largest = 0.0f64;
        let mut previous = before;
        for &v in chunk {
            let d = (v - previous).abs();
            if d.is_finite() && d > largest {
                largest = d;
            }
            previous = v;
        }
        peak = peak.max(largest);
        bins.push(largest as f32);
    }
    if !(peak > 0.0) {
        return None;
    }
    let scale = (1.0 / peak) as f32;
    bins.iter_mut().for_each(|b| *b *= scale);
    Some(Envelope {
        start_ns,
        duration_s: values.len() as f64 / rate_hz,
        bins,
    })
}

/// The event window, s from the event's start (the earliest record start).
#[derive(Debug, Clone, PartialEq)]
pub struct EventWindow {
    /// Start of the event's time base, ns since the epoch, when the records have one.
    pub origin_ns: Option<i64>,
    /// The strong motion found, s.
    pub strong_motion_s: [f64; 2],
    /// The window analysed, s.
    pub window_s: [f64; 2],
    /// The longest record, s.
    pub record_s: f64,
}

impl EventWindow {
    /// The samples of `record` inside the window.
    pub fn samples_of(&self, record: &Record) -> Range<usize> {
        let fs = record.channel.sampling_rate_hz;
        let offset_s = match (self.origin_ns, record.channel.start_ns) {
            (Some(o), Some(s)) => (s - o) as f64 * 1e-9,
            _ => 0.0,
        };
        let n = record.samples.len();
        let at = |t: f64| (((t - offset_s) * fs).round().max(0.0) as usize).min(n);
        at(self.window_s[0])..at(self.window_s[1])
    }

    /// The window in a sentence.
    pub fn describe(&self) -> String {
        format!(
            "continuous record of {:.1} h: analysed on its event window, {:.0} s to {:.0} s (strong motion {:.0} s to {:.0} s, widened by {} s)",
            self.record_s / 3600.0,
            self.window_s[0],
            self.window_s[1],
            self.strong_motion_s[0],
            self.strong_motion_s[1],
            MARGIN_S
        )
    }

    /// The window a run recorded in `history` (the last `event_window` step).
    pub fn from_history(history: &ProcessingHistory) -> Option<EventWindow> {
        let step = history
            .steps
            .iter()
            .rev()
            .find(|s| s.step == "event_window")?;
        let pair = |key: &str| -> Option<[f64; 2]> {
            let v = step.params.get(key)?.as_array()?;
            Some([v.first()?.as_f64()?, v.get(1)?.as_f64()?])
        };
        Some(EventWindow {
            origin_ns: step.params.get("origin_ns").and_then(|v| v.as_i64()),
            strong_motion_s: pair("strong_motion_s")?,
            window_s: pair("window_s")?,
            record_s: step.params.get("record_s")?.as_f64()?,
        })
    }

    /// What the processing history records of the window.
    pub fn history(&self) -> serde_json::Value {
        json!({
            "rule": "continuous records: the strong motion of the event's envelope, widened",
            "continuous_above_s": CONTINUOUS_ABOVE_S,
            "threshold": THRESHOLD,
            "noise_factor": NOISE_FACTOR,
            "margin_s": MARGIN_S,
            "origin_ns": self.origin_ns,
            "strong_motion_s": self.strong_motion_s,
            "window_s": self.window_s,
            "record_s": self.record_s,
        })
    }
}

/// The event window of records whose envelopes are `envelopes`, or `None`
/// when they are not continuous (no record longer than
/// [`CONTINUOUS_ABOVE_S`]) or no strong motion stands out.
pub fn event_window(envelopes: &[Envelope]) -> Option<EventWindow> {
    let record_s = envelopes.iter().map(|e| e.duration_s).fold(0.0, f64::max);
    if !(record_s > CONTINUOUS_ABOVE_S) {
        return None;
    }
    let origin_ns = envelopes.iter().filter_map(|e| e.start_ns).min();
    let offset_bins = |e: &Envelope| match (origin_ns, e.start_ns) {
        (Some(o), Some(s)) => ((s - o) as f64 * 1e-9 / BIN_S).round() as usize,
        _ => 0,
    };
    let total = envelopes
        .iter()
        .map(|e| offset_bins(e) + e.bins.len())
        .max()
        .unwrap_or(0);
    // A start a year away from the others is not a time base to sum on.
    if total > 64 * (record_s / BIN_S) as usize + 64 {
        return None;
    }
    let mut sum = vec![0.0f64; total];
    for e in envelopes {
        let o = offset_bins(e);
        for (s, &b) in sum[o..].iter_mut().zip(&e.bins) {
            *s += b as f64;
        }
    }
    let peak = sum.iter().copied().fold(0.0, f64::max);
    let mut sorted = sum.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    let level = (THRESHOLD * peak).max(NOISE_FACTOR * median);
    if !(peak > level) {
        return None;
    }
    let first = sum.iter().position(|&s| s >= level)?;
    let last = sum.iter().rposition(|&s| s >= level)?;
    let strong = [first as f64 * BIN_S, (last + 1) as f64 * BIN_S];
    let window_s = [
        (strong[0] - MARGIN_S).max(0.0),
        (strong[1] + MARGIN_S).min(total as f64 * BIN_S),
    ];
    Some(EventWindow {
        origin_ns,
        strong_motion_s: strong,
        window_s,
        record_s,
    })
}

/// `event` cut to `window`: each record's samples inside it (parked samples
/// as a view, nothing read), its start time moved to the window's; the
/// window recorded in the history and the notes.
pub fn cut_to_window(event: &Event, window: &EventWindow) -> Event {
    let mut cut = event.clone();
    for r in cut.records.iter_mut() {
        let range = window.samples_of(r);
        if let Some(start) = r.channel.start_ns.as_mut() {
            *start += (range.start as f64 / r.channel.sampling_rate_hz * 1e9).round() as i64;
        }
        r.samples = r.samples.window(range);
    }
    cut.history.push("event_window", window.history());
    cut.notes.push(window.describe());
    cut
}
