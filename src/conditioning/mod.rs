//! Signal conditioning (METHODS §1): units to m/s², quality checks,
//! resampling and alignment, detrending, cosine
//! taper, Butterworth filtering (zero-phase, scipy-identical), and
//! integration to velocity and displacement with drift control. Each step
//! is a pure function on slices; `condition_event` applies the configured
//! chain to every record and records every step in `event.history`.

pub mod baseline;
pub mod butterworth;
pub mod integrate;
pub mod qa;
pub mod resample;
pub mod sosfilt;

pub use baseline::{cosine_taper, remove_linear_trend, remove_mean, remove_polynomial};
pub use butterworth::{butter_sos, BandType, Section};
pub use integrate::{integrate_motion, DriftControl, Motion};
pub use qa::{quality_flags, QaSettings};
pub use resample::{align_records, resample_to_rate, Alignment};
pub use sosfilt::{sosfilt, sosfilt_zi, sosfiltfilt, sosfiltfilt_channels, sosfiltfilt_padlen};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::json;

use crate::error::{Error, Location, Result};
use crate::vocab::{Event, QaFlag, Record, Units};

/// Baseline removal before filtering.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "method", rename_all = "snake_case")]
pub enum Detrend {
    None,
    Mean,
    Linear,
    Polynomial { order: usize },
}

/// Butterworth filter of the chain.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FilterSettings {
    pub order: usize,
    pub band: BandType,
    /// One corner (low/high-pass) or two (band-pass/stop), Hz.
    pub corners_hz: Vec<f64>,
    /// Forward–backward (`sosfiltfilt`) when true, causal `sosfilt` otherwise.
    #[serde(default = "yes")]
    pub zero_phase: bool,
}

fn yes() -> bool {
    true
}

/// The condition stage's `orientation` moved to the event manifest, so that
/// every stage (not only those after conditioning) sees the same axes.
fn orientation_moved<'de, D: serde::Deserializer<'de>>(
    _: D,
) -> std::result::Result<Option<()>, D::Error> {
    Err(serde::de::Error::custom(
        "`orientation` is no longer a conditioning setting: state the building axes in event.toml (structure.x_axis_azimuth_deg); they are applied once at ingest so every stage sees the same X/Y",
    ))
}

/// Integration to velocity and displacement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct IntegrationSettings {
    #[serde(default)]
    pub drift: DriftControl,
}

/// The conditioning chain; defaults are METHODS §1: SI units, mean removal,
/// 5 % cosine taper (at each end), 4th-order Butterworth band-pass
/// 0.5–20 Hz zero-phase, integration with drift control. Resampling,
/// alignment are off unless configured. Orientation is not a conditioning
/// step: the building geometry is applied once at ingest (`geometry`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ConditioningSettings {
    pub qa: QaSettings,
    /// Common sampling rate, Hz (None = keep each record's rate).
    pub resample_hz: Option<f64>,
    /// Trim records to their common time window (needs equal rates).
    pub align: bool,
    /// Refused with a message saying where the building axes are stated now.
    #[serde(skip_serializing, deserialize_with = "orientation_moved")]
    pub orientation: Option<()>,
    pub detrend: Detrend,
    /// Fraction of the record tapered at each end (None = no taper).
    pub taper_fraction: Option<f64>,
    pub filter: Option<FilterSettings>,
    pub integration: Option<IntegrationSettings>,
}

impl Default for ConditioningSettings {
    fn default() -> Self {
        ConditioningSettings {
            qa: QaSettings::default(),
            resample_hz: None,
            align: false,
            orientation: None,
            detrend: Detrend::Mean,
            taper_fraction: Some(0.05),
            filter: Some(FilterSettings {
                order: 4,
                band: BandType::Bandpass,
                corners_hz: vec![0.5, 20.0],
                zero_phase: true,
            }),
            integration: Some(IntegrationSettings::default()),
        }
    }
}

impl ConditioningSettings {
    /// Minimal processing for the nonlinear (Bouc-Wen) stage, METHODS §1:
    /// SI units, mean removal and drift-controlled integration only (no
    /// taper, no band-pass: they distort hysteresis loops).
    pub fn minimal() -> Self {
        ConditioningSettings {
            taper_fraction: None,
            filter: None,
            integration: Some(IntegrationSettings {
                drift: DriftControl::Polynomial {
                    velocity_order: 1,
                    displacement_order: 2,
                },
            }),
            ..ConditioningSettings::default()
        }
    }
}

/// Location naming a record's file, member and channel for error messages.
pub fn record_location(record: &Record) -> Location {
    let mut loc =
        Location::file(record.channel.source.file.clone()).with_channel(record.channel.id.clone());
    if let Some(m) = &record.channel.source.member {
        loc = loc.with_member(m.clone());
    }
    loc
}

fn in_record(record: &Record, e: Error) -> Error {
    match e {
        Error::Numerical(m) | Error::Usage(m) => Error::input(record_location(record), m),
        other => other,
    }
}

/// Converts samples to SI (m/s², m/s or m) in place; errors naming the
/// channel when counts have no sensitivity. Returns the factor applied.
pub fn units_to_si(record: &mut Record) -> Result<f64> {
    let factor = record.channel.units.to_si_factor().ok_or_else(|| {
        Error::input(record_location(record), "values are in counts and no sensitivity (counts per m/s²) is known: set `sensitivity` in the manifest")
    })?;
    if factor != 1.0 {
        record.samples.iter_mut().for_each(|v| *v *= factor);
    }
    record.channel.units = match record.channel.units {
        Units::MPerS | Units::CmPerS => Units::MPerS,
        Units::M | Units::Cm => Units::M,
        _ => Units::MPerS2,
    };
    Ok(factor)
}

/// Applies the conditioning chain to every acceleration record of `event`
/// in place (records in other units are converted to SI and otherwise left
/// alone), adding QA flags to the channels and every step with its
/// parameters to `event.history`. Non-finite samples are refused.
pub fn condition_event(event: &mut Event, settings: &ConditioningSettings) -> Result<()> {
    condition_event_with_motion(event, settings).map(|_| ())
}

/// As `condition_event`, also returning acceleration, velocity and
/// displacement of every acceleration channel when integration is
/// configured (empty otherwise). With polynomial drift control the
/// acceleration records are updated with the consistent baseline correction.
pub fn condition_event_with_motion(
    event: &mut Event,
    settings: &ConditioningSettings,
) -> Result<Vec<Motion>> {
    // 1. Non-finite values: flag and refuse.
    for r in event.records.iter_mut() {
        let (count, first) = qa::count_non_finite(&r.samples);
        if count > 0 {
            let flag = QaFlag::NonFinite { count };
            if !r.channel.qa.contains(&flag) {
                r.channel.qa.push(flag);
            }
            return Err(Error::input(
                record_location(r),
                format!(
                    "{count} non-finite sample(s), first at index {}: refusing to condition",
                    first.unwrap_or(0)
                ),
            ));
        }
        if !(r.channel.sampling_rate_hz.is_finite() && r.channel.sampling_rate_hz > 0.0) {
            return Err(Error::input(
                record_location(r),
                format!(
                    "sampling rate must be positive, got {}",
                    r.channel.sampling_rate_hz
                ),
            ));
        }
    }
    // 2. Quality flags on the data as recorded (clipping is best seen in raw values).
    let mut qa_summary = serde_json::Map::new();
    for r in event.records.iter_mut() {
        let flags = quality_flags(&r.samples, r.channel.dt(), &settings.qa);
        for f in flags {
            if !r.channel.qa.contains(&f) {
                r.channel.qa.push(f);
            }
        }
        let codes: Vec<&str> = r.channel.qa.iter().map(|f| f.code()).collect();
        if !codes.is_empty() {
            qa_summary.insert(r.channel.id.clone(), json!(codes));
        }
    }
    event.history.push(
        "qa",
        json!({ "settings": settings.qa, "flags": qa_summary }),
    );
    // 3. Units.
    let mut factors = serde_json::Map::new();
    for r in event.records.iter_mut() {
        let from = r.channel.units.name();
        let factor = units_to_si(r)?;
        factors.insert(
            r.channel.id.clone(),
            json!({ "from": from, "factor": factor }),
        );
    }
    event
        .history
        .push("units_to_si", json!({ "channels": factors }));
    let is_acc = |r: &Record| r.channel.units.is_acceleration();
    // 4. Resampling.
    if let Some(target) = settings.resample_hz {
        let mut changed = Vec::new();
        for r in event.records.iter_mut() {
            if r.channel.sampling_rate_hz != target {
                let from = r.channel.sampling_rate_hz;
                r.samples =
                    resample_to_rate(&r.samples, from, target).map_err(|e| in_record(r, e))?;
                r.channel.sampling_rate_hz = target;
                r.channel.qa.push(QaFlag::Resampled {
                    from: format!("{from} Hz"),
                });
                changed.push(r.channel.id.clone());
            }
        }
        event.history.push_for(
            "resample",
            changed,
            json!({ "target_hz": target, "method": "rational polyphase, Kaiser-windowed sinc (beta 5, 20*max(up,down)+1 taps), cut-off at the lower Nyquist" }),
        );
    }
    // 5. Alignment.
    if settings.align {
        let a = align_records(&mut event.records)?;
        event
            .history
            .push("align", serde_json::to_value(&a).unwrap_or_default());
    }
    let acc_ids: Vec<String> = event
        .records
        .iter()
        .filter(|r| is_acc(r))
        .map(|r| r.channel.id.clone())
        .collect();
    // 7. Detrend.
    if settings.detrend != Detrend::None {
        for r in event.records.iter_mut().filter(|r| is_acc(r)) {
            let result = match settings.detrend {
                Detrend::None => Ok(()),
                Detrend::Mean => {
                    remove_mean(&mut r.samples);
                    Ok(())
                }
                Detrend::Linear => remove_linear_trend(&mut r.samples).map(|_| ()),
                Detrend::Polynomial { order } => {
                    remove_polynomial(&mut r.samples, order).map(|_| ())
                }
            };
            result.map_err(|e| in_record(r, e))?;
        }
        event.history.push_for(
            "detrend",
            acc_ids.clone(),
            serde_json::to_value(&settings.detrend).unwrap_or_default(),
        );
    }
    // 8. Taper.
    if let Some(fraction) = settings.taper_fraction {
        for r in event.records.iter_mut().filter(|r| is_acc(r)) {
            cosine_taper(&mut r.samples, fraction)?;
        }
        event.history.push_for(
            "taper",
            acc_ids.clone(),
            json!({ "window": "cosine (Tukey)", "fraction_each_end": fraction }),
        );
    }
    // 9. Filter (channels in parallel).
    if let Some(f) = &settings.filter {
        let results: Vec<Result<()>> = event
            .records
            .par_iter_mut()
            .filter(|r| is_acc(r))
            .map(|r| {
                let sos = butter_sos(f.order, f.band, &f.corners_hz, r.channel.sampling_rate_hz)
                    .map_err(|e| in_record(r, e))?;
                r.samples = if f.zero_phase {
                    sosfiltfilt(&sos, &r.samples)
                } else {
                    sosfilt(&sos, &r.samples)
                }
                .map_err(|e| in_record(r, e))?;
                Ok(())
            })
            .collect();
        results.into_iter().collect::<Result<Vec<()>>>()?;
        event.history.push_for(
            "filter",
            acc_ids.clone(),
            json!({
                "design": "butterworth (scipy.signal.butter, output='sos')",
                "order": f.order,
                "band": f.band,
                "corners_hz": f.corners_hz,
                "zero_phase": f.zero_phase,
                "edge_handling": if f.zero_phase { "odd extension, padlen = 3*(2*n_sections+1), sosfilt_zi initial conditions (scipy sosfiltfilt)" } else { "causal, zero initial state" },
            }),
        );
    }
    // 10. Integration.
    let mut motions = Vec::new();
    if let Some(integration) = &settings.integration {
        let results: Vec<Result<Motion>> = event
            .records
            .par_iter_mut()
            .filter(|r| is_acc(r))
            .map(|r| {
                let m = integrate_motion(
                    &r.channel.id,
                    &r.samples,
                    r.channel.dt(),
                    &integration.drift,
                )
                .map_err(|e| in_record(r, e))?;
                r.samples.clone_from(&m.acceleration);
                Ok(m)
            })
            .collect();
        motions = results.into_iter().collect::<Result<Vec<Motion>>>()?;
        event.history.push_for(
            "integrate",
            acc_ids,
            json!({ "rule": "cumulative trapezoid from rest", "drift_control": integration.drift }),
        );
    }
    Ok(motions)
}
