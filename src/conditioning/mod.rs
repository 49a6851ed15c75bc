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
#[serde(tag = "method", rename_all = "snake_case", deny_unknown_fields)]
pub enum Detrend {
    None,
    Mean,
    Linear,
    Polynomial { order: usize },
}

/// Butterworth filter of the chain.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
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

impl FilterSettings {
    /// Order 1..=64, the number of corners the band needs, each positive and
    /// finite, two corners increasing (as `butter_sos` requires).
    pub fn validate(&self) -> Result<()> {
        if self.order == 0 || self.order > 64 {
            return Err(Error::usage(format!(
                "filter order {}: must be 1..=64",
                self.order
            )));
        }
        let expected = match self.band {
            BandType::Lowpass | BandType::Highpass => 1,
            BandType::Bandpass | BandType::Bandstop => 2,
        };
        if self.corners_hz.len() != expected {
            return Err(Error::usage(format!(
                "filter corners_hz: a {} filter needs {expected} corner frequency(ies), got {}",
                self.band.name(),
                self.corners_hz.len()
            )));
        }
        if let Some(c) = self
            .corners_hz
            .iter()
            .find(|c| !(c.is_finite() && **c > 0.0))
        {
            return Err(Error::usage(format!(
                "filter corners_hz: {c} Hz is not a positive frequency"
            )));
        }
        if expected == 2 && self.corners_hz[0] >= self.corners_hz[1] {
            return Err(Error::usage(format!(
                "filter corners_hz: {} corners must be increasing, got {:?}",
                self.band.name(),
                self.corners_hz
            )));
        }
        Ok(())
    }
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
#[serde(deny_unknown_fields)]
pub struct IntegrationSettings {
    #[serde(default)]
    pub drift: DriftControl,
}

/// One conditioning step, as declared in a `steps` list (the way gmprocess
/// and ObsPy declare processing): applied in the order listed, after the
/// QA checks and the conversion to SI units that always come first.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "step", rename_all = "snake_case", deny_unknown_fields)]
pub enum Step {
    /// Resample every record to a common rate, Hz (anti-aliased, polyphase).
    Resample { rate_hz: f64 },
    /// Trim records to their common time window (needs equal rates).
    Align,
    /// Baseline removal: `method = "mean" | "linear" | "polynomial"` (+ `order`).
    Detrend(Detrend),
    /// Cosine (Tukey) taper of `fraction` of the record at each end.
    Taper { fraction: f64 },
    /// Butterworth filter (zero-phase `sosfiltfilt` by default).
    Filter(FilterSettings),
    /// Integration to velocity and displacement with drift control (last step).
    Integrate(IntegrationSettings),
}

impl Step {
    pub fn name(&self) -> &'static str {
        match self {
            Step::Resample { .. } => "resample",
            Step::Align => "align",
            Step::Detrend(_) => "detrend",
            Step::Taper { .. } => "taper",
            Step::Filter(_) => "filter",
            Step::Integrate(_) => "integrate",
        }
    }
}

/// The conditioning of a `condition` stage: QA thresholds and the ordered
/// steps.  Defaults are METHODS §1: mean removal, 5 % cosine taper at each
/// end, 4th-order Butterworth band-pass 0.5–20 Hz zero-phase, integration
/// with polynomial drift control.  Orientation is not a conditioning step:
/// the building geometry is applied once at ingest (`geometry`).
///
/// Written either as `steps = [ { step = "detrend", method = "mean" }, … ]`
/// or, as before the step list, with the keys `detrend`, `taper_fraction`,
/// `filter`, `integration`, `resample_hz`, `align` (each absent key taking
/// its default); both read into the same list.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ConditioningFile")]
pub struct ConditioningSettings {
    pub qa: QaSettings,
    pub steps: Vec<Step>,
}

/// The `condition` params as written (both forms).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ConditioningFile {
    #[serde(default)]
    qa: QaSettings,
    steps: Option<Vec<Step>>,
    resample_hz: Option<f64>,
    align: Option<bool>,
    /// Refused with a message saying where the building axes are stated now.
    #[serde(default, deserialize_with = "orientation_moved")]
    #[allow(dead_code)] // only its error is used
    orientation: Option<()>,
    detrend: Option<Detrend>,
    taper_fraction: Option<f64>,
    filter: Option<FilterSettings>,
    integration: Option<IntegrationSettings>,
}

impl TryFrom<ConditioningFile> for ConditioningSettings {
    type Error = String;
    fn try_from(f: ConditioningFile) -> std::result::Result<Self, String> {
        let keyed = f.resample_hz.is_some()
            || f.align.is_some()
            || f.detrend.is_some()
            || f.taper_fraction.is_some()
            || f.filter.is_some()
            || f.integration.is_some();
        if let Some(steps) = f.steps {
            if keyed {
                return Err("give the conditioning either as `steps` or with the keys detrend/taper_fraction/filter/integration/resample_hz/align, not both".into());
            }
            return Ok(ConditioningSettings { qa: f.qa, steps });
        }
        let d = ConditioningSettings::default();
        let default_step = |name: &str| d.steps.iter().find(|s| s.name() == name).cloned();
        let mut steps = Vec::new();
        if let Some(rate_hz) = f.resample_hz {
            steps.push(Step::Resample { rate_hz });
        }
        if f.align == Some(true) {
            steps.push(Step::Align);
        }
        match f.detrend {
            Some(Detrend::None) => {}
            Some(m) => steps.push(Step::Detrend(m)),
            None => steps.extend(default_step("detrend")),
        }
        match f.taper_fraction {
            Some(fraction) => steps.push(Step::Taper { fraction }),
            None => steps.extend(default_step("taper")),
        }
        match f.filter {
            Some(filter) => steps.push(Step::Filter(filter)),
            None => steps.extend(default_step("filter")),
        }
        match f.integration {
            Some(i) => steps.push(Step::Integrate(i)),
            None => steps.extend(default_step("integrate")),
        }
        Ok(ConditioningSettings { qa: f.qa, steps })
    }
}

impl Default for ConditioningSettings {
    fn default() -> Self {
        ConditioningSettings {
            qa: QaSettings::default(),
            steps: vec![
                Step::Detrend(Detrend::Mean),
                Step::Taper { fraction: 0.05 },
                Step::Filter(FilterSettings {
                    order: 4,
                    band: BandType::Bandpass,
                    corners_hz: vec![0.5, 20.0],
                    zero_phase: true,
                }),
                Step::Integrate(IntegrationSettings::default()),
            ],
        }
    }
}

impl ConditioningSettings {
    /// Checks what can be checked before any record is read (a corner
    /// against a record's Nyquist frequency is checked per record): usage
    /// errors, so bad settings never pass for bad data.
    pub fn validate(&self) -> Result<()> {
        let last = self.steps.len().saturating_sub(1);
        for (i, step) in self.steps.iter().enumerate() {
            let at = |m: String| {
                Error::usage(format!(
                    "conditioning step {} ({}): {m}",
                    i + 1,
                    step.name()
                ))
            };
            match step {
                Step::Resample { rate_hz } if !(rate_hz.is_finite() && *rate_hz > 0.0) => {
                    return Err(at(format!("rate_hz = {rate_hz}: must be a positive rate")))
                }
                Step::Taper { fraction } if !(0.0..=0.5).contains(fraction) => {
                    return Err(at(format!(
                        "fraction = {fraction}: must be within [0, 0.5] of the record at each end"
                    )))
                }
                Step::Detrend(Detrend::Polynomial { order }) if *order > 10 => {
                    return Err(at(format!(
                        "polynomial order {order}: at most 10 (higher orders fit the signal, not the baseline)"
                    )))
                }
                Step::Filter(f) => f.validate().map_err(|e| at(e.to_string()))?,
                Step::Integrate(integration) => {
                    integration.drift.validate().map_err(|e| at(e.to_string()))?;
                    if i != last {
                        return Err(at("integration must be the last step".into()));
                    }
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// Minimal processing for the nonlinear (Bouc-Wen) stage, METHODS §1:
    /// SI units, mean removal and drift-controlled integration only (no
    /// taper, no band-pass: they distort hysteresis loops).
    pub fn minimal() -> Self {
        ConditioningSettings {
            qa: QaSettings::default(),
            steps: vec![
                Step::Detrend(Detrend::Mean),
                Step::Integrate(IntegrationSettings {
                    drift: DriftControl::Polynomial {
                        velocity_order: 1,
                        displacement_order: 2,
                    },
                }),
            ],
        }
    }

    /// The first step named `name`, if declared.
    pub fn step(&self, name: &str) -> Option<&Step> {
        self.steps.iter().find(|s| s.name() == name)
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
    // 4. The declared steps, in order.
    let mut motions = Vec::new();
    for step in &settings.steps {
        match step {
            Step::Resample { rate_hz } => resample_step(event, *rate_hz)?,
            Step::Align => {
                let a = align_records(&mut event.records)?;
                event
                    .history
                    .push("align", serde_json::to_value(&a).unwrap_or_default());
            }
            Step::Detrend(method) => detrend_step(event, method)?,
            Step::Taper { fraction } => {
                for r in event.records.iter_mut().filter(|r| is_acceleration(r)) {
                    cosine_taper(&mut r.samples, *fraction)?;
                }
                let ids = acceleration_ids(event);
                event.history.push_for(
                    "taper",
                    ids,
                    json!({ "window": "cosine (Tukey)", "fraction_each_end": fraction }),
                );
            }
            Step::Filter(f) => filter_step(event, f)?,
            Step::Integrate(integration) => motions = integrate_step(event, integration)?,
        }
    }
    Ok(motions)
}

fn is_acceleration(r: &Record) -> bool {
    r.channel.units.is_acceleration()
}

fn acceleration_ids(event: &Event) -> Vec<String> {
    event
        .records
        .iter()
        .filter(|r| is_acceleration(r))
        .map(|r| r.channel.id.clone())
        .collect()
}

/// Every record (all units) to `target` Hz; records already there are left alone.
fn resample_step(event: &mut Event, target: f64) -> Result<()> {
    let mut changed = Vec::new();
    for r in event.records.iter_mut() {
        if r.channel.sampling_rate_hz != target {
            let from = r.channel.sampling_rate_hz;
            r.samples = resample_to_rate(&r.samples, from, target)
                .map_err(|e| in_record(r, e))?
                .into();
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
    Ok(())
}

fn detrend_step(event: &mut Event, method: &Detrend) -> Result<()> {
    if *method == Detrend::None {
        return Ok(());
    }
    for r in event.records.iter_mut().filter(|r| is_acceleration(r)) {
        let result = match method {
            Detrend::None => Ok(()),
            Detrend::Mean => {
                remove_mean(&mut r.samples);
                Ok(())
            }
            Detrend::Linear => remove_linear_trend(&mut r.samples).map(|_| ()),
            Detrend::Polynomial { order } => remove_polynomial(&mut r.samples, *order).map(|_| ()),
        };
        result.map_err(|e| in_record(r, e))?;
    }
    let ids = acceleration_ids(event);
    event.history.push_for(
        "detrend",
        ids,
        serde_json::to_value(method).unwrap_or_default(),
    );
    Ok(())
}

/// Butterworth filter of every acceleration record (channels in parallel).
fn filter_step(event: &mut Event, f: &FilterSettings) -> Result<()> {
    let results: Vec<Result<()>> = event
        .records
        .par_iter_mut()
        .filter(|r| is_acceleration(r))
        .map(|r| {
            let sos = butter_sos(f.order, f.band, &f.corners_hz, r.channel.sampling_rate_hz)
                .map_err(|e| in_record(r, e))?;
            r.samples = if f.zero_phase {
                sosfiltfilt(&sos, &r.samples)
            } else {
                sosfilt(&sos, &r.samples)
            }
            .map_err(|e| in_record(r, e))?
            .into();
            Ok(())
        })
        .collect();
    results.into_iter().collect::<Result<Vec<()>>>()?;
    let ids = acceleration_ids(event);
    event.history.push_for(
        "filter",
        ids,
        json!({
            "design": "butterworth (scipy.signal.butter, output='sos')",
            "order": f.order,
            "band": f.band,
            "corners_hz": f.corners_hz,
            "zero_phase": f.zero_phase,
            "edge_handling": if f.zero_phase { "odd extension, padlen = 3*(2*n_sections+1), sosfilt_zi initial conditions (scipy sosfiltfilt)" } else { "causal, zero initial state" },
        }),
    );
    Ok(())
}

/// Acceleration, velocity and displacement of every acceleration record
/// (with polynomial drift control the records take the consistently
/// corrected acceleration).
fn integrate_step(event: &mut Event, integration: &IntegrationSettings) -> Result<Vec<Motion>> {
    let results: Vec<Result<Motion>> = event
        .records
        .par_iter_mut()
        .filter(|r| is_acceleration(r))
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
    let motions = results.into_iter().collect::<Result<Vec<Motion>>>()?;
    let ids = acceleration_ids(event);
    event.history.push_for(
        "integrate",
        ids,
        json!({ "rule": "cumulative trapezoid from rest", "drift_control": integration.drift }),
    );
    Ok(motions)
}
