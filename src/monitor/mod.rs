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
pub mod change;
pub mod compensation;
pub mod environment;
pub mod tracking;
pub mod window;

use crate::error::{Error, Result};
use crate::modal::{identify, ModalInput, ModalSettings, Mode};
use crate::vocab::format_epoch_ns;
use anomaly::{BandModel, BandSettings, Observation};
use tracking::{Reference, TrackSettings, TrackedMode};

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
    /// Normalised output covariances for the change test ([`change`]);
    /// not handed between processes ([`windows_to_json`]).
    pub covariances: Option<crate::modal::change_test::CovarianceBlocks>,
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
            covariances: None,
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
            covariances: change::window_covariances(
                &input.outputs,
                result.decimation,
                &Default::default(),
            ),
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

/// Everything a tracking run computed: the windows, the tracked rows and their bands.
#[derive(Debug, Clone)]
pub struct Tracking {
    pub windows: Vec<WindowModes>,
    pub reference: Reference,
    pub rows: Vec<TrackedMode>,
    /// Per row: band (None = no model for that mode).
    pub bands: Vec<Option<anomaly::Band>>,
    /// Per window: Eq. M5's anomalous flag.
    pub anomalous: Vec<bool>,
    pub models: Vec<Option<BandModel>>,
    pub band_settings: BandSettings,
    pub anomaly_from: Option<usize>,
    /// Per window: the χ² change test against the training windows ([`change`]).
    pub change_tests: Vec<Option<crate::modal::change_test::ChangeTestResult>>,
    /// Why no window was tested, if so.
    pub change_note: Option<String>,
    /// Environmental compensation and its control chart
    /// ([`compensation::compensate`]; empty until a caller runs it).
    pub compensation: compensation::RunCompensation,
}

/// Tracking, bands and anomalies of identified windows (module doc).
pub fn analyse(
    windows: Vec<WindowModes>,
    reference: Option<Reference>,
    track_settings: &TrackSettings,
    band_settings: BandSettings,
) -> Result<Tracking> {
    let reference = match reference {
        Some(r) => r,
        None => {
            let (i, confirmed) = tracking::default_reference(&windows, track_settings)
                .ok_or_else(|| {
                    Error::numerical(
                        "track: no mode was found in half of the first identified windows, so there is no reference to track (see the skipped windows, or give --reference)",
                    )
                })?;
            Reference {
                modes: confirmed
                    .iter()
                    .map(|&k| windows[i].modes[k].clone())
                    .collect(),
                channels: windows[i].channels.clone(),
                source: format!(
                    "window {} ({} of its {} modes confirmed in the first windows)",
                    format_epoch_ns(windows[i].start_ns),
                    confirmed.len(),
                    windows[i].modes.len()
                ),
            }
        }
    };
    let rows = tracking::track(&reference, &windows, track_settings);
    let observation = |r: &TrackedMode| Observation {
        start_ns: windows[r.window].start_ns,
        end_ns: windows[r.window].end_ns,
        rms: windows[r.window].rms,
        frequency_hz: r.frequency_hz,
    };
    let models: Vec<Option<BandModel>> = (1..=reference.modes.len())
        .map(|id| {
            let obs: Vec<Observation> = rows
                .iter()
                .filter(|r| r.mode_id == id)
                .map(observation)
                .collect();
            anomaly::fit(&obs, &band_settings)
        })
        .collect();
    let bands: Vec<Option<anomaly::Band>> = rows
        .iter()
        .map(|r| {
            models[r.mode_id - 1]
                .as_ref()
                .map(|m| m.band(&observation(r)))
        })
        .collect();
    // Eq. M5: per window, at least half of the banded modes flagged.
    let mut counts = vec![(0usize, 0usize); windows.len()];
    for (r, b) in rows.iter().zip(&bands) {
        if let Some(b) = b {
            counts[r.window].0 += 1;
            counts[r.window].1 += usize::from(b.flagged);
        }
    }
    let per_window: Vec<Option<bool>> = counts
        .iter()
        .map(|&(n, f)| (n > 0).then_some(2 * f >= n))
        .collect();
    let eligible: Vec<bool> = windows
        .iter()
        .map(|w| w.start_ns >= band_settings.training_end_ns)
        .collect();
    let anomaly_from = anomaly::anomaly_onset(&per_window, &eligible, band_settings.min_run);
    let covariances: Vec<_> = windows.iter().map(|w| w.covariances.as_ref()).collect();
    let training: Vec<bool> = eligible.iter().map(|e| !e).collect();
    let (change_tests, change_note) = change::test_windows(
        &covariances,
        &training,
        reference.modes.len(),
        &Default::default(),
    );
    Ok(Tracking {
        compensation: Default::default(),
        change_tests,
        change_note,
        anomalous: per_window.iter().map(|a| a.unwrap_or(false)).collect(),
        windows,
        reference,
        rows,
        bands,
        models,
        band_settings,
        anomaly_from,
    })
}

/// A window as JSON (NaN RMS as null).
#[derive(serde::Serialize, serde::Deserialize)]
struct WindowRecord {
    start_ns: i64,
    end_ns: i64,
    channels: Vec<String>,
    modes: Vec<Mode>,
    rms: Option<f64>,
    present_fraction: f64,
    skipped: Option<String>,
    notes: Vec<String>,
}

/// Identified windows as JSON text, to be handed between processes (the
/// Dask workers of `quaketwin.fleet.track`); exact: floats round-trip.
pub fn windows_to_json(windows: &[WindowModes]) -> Result<String> {
    let records: Vec<WindowRecord> = windows
        .iter()
        .map(|w| WindowRecord {
            start_ns: w.start_ns,
            end_ns: w.end_ns,
            channels: w.channels.clone(),
            modes: w.modes.clone(),
            rms: w.rms.is_finite().then_some(w.rms),
            present_fraction: w.present_fraction,
            skipped: w.skipped.clone(),
            notes: w.notes.clone(),
        })
        .collect();
    serde_json::to_string(&records).map_err(|e| Error::numerical(format!("windows as JSON: {e}")))
}

/// The windows of [`windows_to_json`] back.
pub fn windows_from_json(text: &str) -> Result<Vec<WindowModes>> {
    let records: Vec<WindowRecord> = serde_json::from_str(text)
        .map_err(|e| Error::usage(format!("identified windows (JSON): {e}")))?;
    Ok(records
        .into_iter()
        .map(|w| WindowModes {
            start_ns: w.start_ns,
            end_ns: w.end_ns,
            channels: w.channels,
            modes: w.modes,
            rms: w.rms.unwrap_or(f64::NAN),
            present_fraction: w.present_fraction,
            skipped: w.skipped,
            notes: w.notes,
            covariances: None,
        })
        .collect())
}
