//! The identification window of a direction: the part of the record the
//! Bouc-Wen identification runs on (METHODS.md §4).
//!
//! The method identifies the hysteresis of an earthquake *record*: its STFT
//! layout takes as many frames as frequency bins of the record it is given
//! (w = 220 for the thesis's 12 500 samples), and the structure starts the
//! record at rest (the stage integrates from rest).  A triggered strong-motion
//! record is that already: the shaking with some seconds of pre-event and
//! post-event motion.  A continuous monitoring record is not: an hour of 64
//! channels at 200 Hz holds a minute of earthquake in an hour of microtremor.
//! Identified whole, its layout has 8.5 s windows; its measurement noise,
//! which the jerk form differentiates, accumulates over sixty times the
//! shaking; and the energy terms ε_dr of a 31-storey building alone are
//! 496 series of the record's length (2.9 GB for the hour, per direction).
//!
//! So the rule (default `strong_motion`): the **strong motion** of a
//! direction runs from the first to the last sample at which any of its
//! channels (the base and every floor the stage uses) reaches `threshold`
//! (5 %) of that channel's own peak absolute acceleration — the bracketed
//! duration of Bolt (1973) with a threshold relative to each channel's peak,
//! so that it does not depend on the size of the event, and taken over the
//! floors as well as the base, so that it holds the structure's free
//! vibration after the shaking down to 5 % of its peak.  The window is the
//! strong motion widened by `margin_s` (10 s) on each side, within the
//! record: quiet motion before the shaking (the structure at rest, as the
//! integration from rest assumes) and after it (the end of the free decay).
//! A triggered record — the bundled sample events, with 5 s of pre-event
//! motion — is its own window: identified whole, as before.  `record` takes
//! the whole record.  Either way the window is at most `max_s` long
//! (memory grows with the window and with the square of the storeys): a
//! longer one is an error naming the setting.
//!
//! The window is recorded in the processing history (`hysteresis_window`),
//! and the stage's times (`t_s` of its tables) count from the record's start.

use std::ops::Range;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::vocab::Record;

/// Which part of the record is identified.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WindowRule {
    /// The strong motion, widened by the margin (see the module doc).
    #[default]
    StrongMotion,
    /// The whole record.
    Record,
}

/// Settings of the identification window (stage parameter `window`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WindowSettings {
    pub rule: WindowRule,
    /// Fraction of each channel's peak absolute acceleration that bounds the strong motion.
    pub threshold: f64,
    /// Seconds kept before and after the strong motion.
    pub margin_s: f64,
    /// Longest window identified, s.
    pub max_s: f64,
}

impl Default for WindowSettings {
    fn default() -> Self {
        WindowSettings {
            rule: WindowRule::StrongMotion,
            threshold: 0.05,
            margin_s: 10.0,
            max_s: 600.0,
        }
    }
}

impl WindowSettings {
    /// Settings the window can be formed with, else `Error::Usage`.
    pub fn validate(&self) -> Result<()> {
        if !(self.threshold > 0.0 && self.threshold < 1.0) {
            return Err(Error::usage(format!(
                "window.threshold must be in (0, 1), got {}",
                self.threshold
            )));
        }
        if !(self.margin_s >= 0.0 && self.margin_s.is_finite()) {
            return Err(Error::usage(format!(
                "window.margin_s must be ≥ 0 s, got {}",
                self.margin_s
            )));
        }
        if !(self.max_s > 0.0) {
            return Err(Error::usage(format!(
                "window.max_s must be positive, got {}",
                self.max_s
            )));
        }
        Ok(())
    }
}

/// The identification window of one direction.
#[derive(Debug, Clone, PartialEq)]
pub struct IdentificationWindow {
    /// Samples of the record identified.
    pub samples: Range<usize>,
    /// The strong motion (samples), when the rule found one.
    pub strong_motion: Option<Range<usize>>,
    /// Samples of the record.
    pub record_samples: usize,
    pub sampling_rate_hz: f64,
}

impl IdentificationWindow {
    /// Time of the window's first sample from the record's start, s.
    pub fn start_s(&self) -> f64 {
        self.samples.start as f64 / self.sampling_rate_hz
    }
    /// What the processing history records of the window.
    pub fn history(&self, settings: &WindowSettings) -> serde_json::Value {
        let fs = self.sampling_rate_hz;
        let seconds = |r: &Range<usize>| [r.start as f64 / fs, r.end as f64 / fs];
        serde_json::json!({
            "rule": settings.rule,
            "threshold": settings.threshold,
            "margin_s": settings.margin_s,
            "strong_motion_s": self.strong_motion.as_ref().map(seconds),
            "window_s": seconds(&self.samples),
            "whole_record": self.samples == (0..self.record_samples),
        })
    }
}

/// First and last sample at which `x` reaches `threshold` of its peak
/// absolute value (non-finite values ignored); `None` for a record without
/// motion.
fn bracket(x: &[f64], threshold: f64) -> Option<Range<usize>> {
    let peak = x
        .iter()
        .filter(|v| v.is_finite())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    if !(peak > 0.0) {
        return None;
    }
    let level = threshold * peak;
    let strong = |v: &f64| v.abs() >= level;
    let first = x.iter().position(strong)?;
    let last = x.iter().rposition(strong)?;
    Some(first..last + 1)
}

/// The window of the direction whose channels are `records` (base first), a
/// channel read at a time (parked samples are not kept).  The record's
/// length is the base's.
pub fn identification_window(
    direction: &str,
    records: &[&Record],
    settings: &WindowSettings,
) -> Result<IdentificationWindow> {
    settings.validate()?;
    let Some(base) = records.first() else {
        return Err(Error::usage(format!(
            "direction {direction}: no channel to form an identification window from"
        )));
    };
    let n = base.samples.len();
    let fs = base.channel.sampling_rate_hz;
    let mut strong_motion: Option<Range<usize>> = None;
    if settings.rule == WindowRule::StrongMotion {
        for r in records {
            let x = r.samples.get_range(0, n)?;
            if let Some(b) = bracket(&x, settings.threshold) {
                strong_motion = Some(match strong_motion {
                    Some(s) => s.start.min(b.start)..s.end.max(b.end),
                    None => b,
                });
            }
        }
    }
    let samples = match (&strong_motion, fs > 0.0 && fs.is_finite()) {
        (Some(s), true) => {
            let margin = (settings.margin_s * fs).round() as usize;
            s.start.saturating_sub(margin)..s.end.saturating_add(margin).min(n)
        }
        // No motion, or no usable rate (reported by the identification): all of it.
        _ => 0..n,
    };
    let window = IdentificationWindow {
        samples,
        strong_motion,
        record_samples: n,
        sampling_rate_hz: fs,
    };
    let length_s = window.samples.len() as f64 / fs;
    if length_s > settings.max_s {
        let what = match &window.strong_motion {
            Some(s) => format!(
                "strong motion from {:.1} s to {:.1} s, widened by {} s",
                s.start as f64 / fs,
                s.end as f64 / fs,
                settings.margin_s
            ),
            None => "the whole record".to_string(),
        };
        return Err(Error::NotIdentifiable {
            stage: "hysteresis".into(),
            message: format!(
                "direction {direction}: the identification window is {length_s:.1} s ({what}), longer than \
                 window.max_s = {} s; the stage's memory grows with the window (and with the square of the \
                 storeys): raise window.max_s, or lower window.threshold / window.margin_s",
                settings.max_s
            ),
            f_test: None,
        });
    }
    Ok(window)
}
