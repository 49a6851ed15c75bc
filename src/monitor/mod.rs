//! Continuous monitoring (issue 17 item 3): ambient modal identification of
//! consecutive windows of a continuous record, mode tracking against
//! reference shapes, and an anomaly band from a regression on the window's
//! operational and environmental variables.  Numerical code only, no I/O:
//! `crate::track` reads the SDS archive and writes the table and report.
//!
//! Flow per window: signals in physical units → [`identify_window`] (the
//! modal stage's identification, `ssi-cov` with its shipped defaults) →
//! [`tracking::track`] pairs its modes with the reference modes (the pre/post
//! comparison's pairing, MAC and frequency window) → [`anomaly`] fits the
//! frequency of each tracked mode on the training windows and flags the
//! windows outside the 99 % prediction band (docs/monitoring.md, Eqs. M1–M5).

pub mod anomaly;
pub mod tracking;
pub mod window;

use crate::modal::{identify, ModalInput, ModalSettings, Mode};

/// Signals of one window, in physical units (m/s², or counts when the
/// archive came without StationXML).
#[derive(Debug, Clone, PartialEq)]
pub struct WindowSignals {
    pub start_ns: i64,
    pub end_ns: i64,
    pub rate_hz: f64,
    pub ids: Vec<String>,
    /// Direction label per channel (`X`, `Y`, `90deg`…; empty = unknown).
    pub directions: Vec<String>,
    /// Location group per channel (for the torsion label).
    pub groups: Vec<String>,
    pub signals: Vec<Vec<f64>>,
    /// Share of the window's samples that were recorded (0..1).
    pub present_fraction: f64,
}

/// What the identification of one window gave.
#[derive(Debug, Clone, PartialEq)]
pub struct WindowModes {
    pub start_ns: i64,
    pub end_ns: i64,
    /// Channel ids the shapes are given at.
    pub channels: Vec<String>,
    /// Selected modes, ascending frequency (empty when skipped or failed).
    pub modes: Vec<Mode>,
    /// RMS level of the window: √(mean over channels of the variance of
    /// each channel), in the signals' units.
    pub rms: f64,
    pub present_fraction: f64,
    /// Why the window gave no modes (skipped, or the identification failed), if so.
    pub skipped: Option<String>,
    /// The identification's warnings and the reader's notes.
    pub notes: Vec<String>,
}

impl WindowModes {
    /// A window without identification, and why.
    pub fn skipped(start_ns: i64, end_ns: i64, present_fraction: f64, why: String) -> Self {
        WindowModes {
            start_ns,
            end_ns,
            channels: Vec::new(),
            modes: Vec::new(),
            rms: f64::NAN,
            present_fraction,
            skipped: Some(why),
            notes: Vec::new(),
        }
    }
}

/// RMS level of a window: √(mean over channels of each channel's variance).
pub fn rms_level(signals: &[Vec<f64>]) -> f64 {
    let per_channel = signals.iter().map(|s| {
        let n = s.len().max(1) as f64;
        let mean = s.iter().sum::<f64>() / n;
        s.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n
    });
    (per_channel.sum::<f64>() / signals.len().max(1) as f64).sqrt()
}

/// Ambient identification of one window with `settings` (the modal
/// stage's, `ssi-cov`); a failure is recorded on the window, not raised:
/// one bad window must not stop a year of monitoring.
pub fn identify_window(w: WindowSignals, settings: &ModalSettings) -> WindowModes {
    let rms = rms_level(&w.signals);
    let input = ModalInput {
        dt: 1.0 / w.rate_hz,
        output_ids: w.ids.clone(),
        outputs: w.signals,
        output_directions: w.directions,
        output_groups: w.groups,
        ..Default::default()
    };
    match identify(&input, settings) {
        Ok(result) => WindowModes {
            start_ns: w.start_ns,
            end_ns: w.end_ns,
            channels: w.ids,
            modes: result.modes,
            rms,
            present_fraction: w.present_fraction,
            skipped: None,
            notes: result.warnings,
        },
        Err(e) => {
            let mut m = WindowModes::skipped(
                w.start_ns,
                w.end_ns,
                w.present_fraction,
                format!("identification failed: {e}"),
            );
            m.rms = rms;
            m
        }
    }
}
