//! Signal conditioning (METHODS §1): units to m/s², quality checks,
//! resampling and alignment, detrending, cosine
//! taper, Butterworth filtering (zero-phase, scipy-identical), and
//! integration to velocity and displacement with drift control. Each step
//! is a pure function on slices; `condition_event` applies the configured
//! chain to every record and records every step in `event.history`.

pub mod baseline;
pub mod butterworth;
pub mod event_window;
pub mod integrate;
pub mod qa;
pub mod resample;
pub mod sosfilt;

pub use baseline::{cosine_taper, remove_linear_trend, remove_mean, remove_polynomial};
pub use butterworth::{butter_sos, BandType, Section};
pub use integrate::{
    integrate_motion, integrate_motion_of, integrate_motion_parking, DriftControl, Motion,
};
pub use qa::{quality_flags, QaSettings};
pub use resample::{align_records, resample_to_rate, Alignment};
pub use sosfilt::{sosfilt, sosfilt_zi, sosfiltfilt, sosfiltfilt_channels, sosfiltfilt_padlen};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::json;

use crate::error::{Error, Location, Result};
use crate::vocab::{Event, QaFlag, Record, Samples, Units};

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

/// Most conditioning steps of a `condition` stage (the default has four).
pub const MAX_STEPS: usize = 32;
/// Highest resampling rate, Hz: strong-motion and structural sensors
/// record at most a few kHz.  Resampling never grows a record more than
/// `resample::MAX_UPSAMPLING` times.
pub const MAX_RATE_HZ: f64 = 20_000.0;

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
        self.qa.validate()?;
        if self.steps.len() > MAX_STEPS {
            return Err(Error::usage(format!(
                "steps lists {} conditioning steps: at most {MAX_STEPS} (each is a pass over every record)",
                self.steps.len()
            )));
        }
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
                Step::Resample { rate_hz } if !(*rate_hz > 0.0 && *rate_hz <= MAX_RATE_HZ) => {
                    return Err(at(format!(
                        "rate_hz = {rate_hz:?}: must be a positive rate, at most {MAX_RATE_HZ} Hz"
                    )))
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
    condition_event_each(event, settings, None, &|_, _| Ok(()))
}

/// What `done` receives: a conditioned record and, for an acceleration
/// channel when integration is configured, its motion.
pub type ChannelDone<'a> = dyn Fn(&mut Record, Option<&mut Motion>) -> Result<()> + Sync + 'a;

/// Where a motion's series go as soon as each is final (the condition
/// stage's spill file: `integrate::integrate_motion_parking`); without one
/// they stay in memory.
pub type ParkSeries<'a> = dyn Fn(Vec<f64>) -> Result<Samples> + Sync + 'a;

/// As [`condition_event_with_motion`], a channel at a time (issue 14 item 5):
/// each record goes through every step — the checks, QA, units, then the
/// declared steps — in one task, channels in parallel, and `done` is called
/// on it (and its motion) as soon as it is conditioned; the condition stage
/// parks them there, so only the channels in flight are in memory.  The
/// records, motions, history and the error reported (the earliest step
/// that failed, and in it the first channel) are those of running each step
/// over all records before the next.  An `align` step needs every record at
/// once: with one, the steps run one after the other over all records, and
/// `done` is called at the end.  `park`, when given, takes each series of a
/// motion as soon as it is final ([`ParkSeries`]).
pub fn condition_event_each(
    event: &mut Event,
    settings: &ConditioningSettings,
    park: Option<&ParkSeries<'_>>,
    done: &ChannelDone<'_>,
) -> Result<Vec<Motion>> {
    let channels = if settings.step("align").is_some() {
        condition_step_by_step(&mut event.records, settings, park, done)?
    } else {
        let records = std::mem::take(&mut event.records);
        // Channels of more than LONG_CHANNEL samples (a day at 200 Hz) are
        // conditioned one at a time: two in flight would double the memory.
        let long = records.iter().any(|r| r.samples.len() > LONG_CHANNEL);
        let one = |r: Record| -> std::result::Result<Channel1, Failed> {
            let mut c = condition_channel(r, settings, park)?;
            if let Err(e) = done(&mut c.record, c.motion.as_mut()) {
                return Err((usize::MAX, e, c.record));
            }
            share_acceleration(&mut c.record, c.motion.as_ref());
            Ok(c)
        };
        let results: Vec<std::result::Result<Channel1, Failed>> = if long {
            records.into_iter().map(one).collect()
        } else {
            records.into_par_iter().map(one).collect()
        };
        match earliest_failure(results) {
            Ok(c) => c,
            // The records go back to the event, as conditioned so far.
            Err((e, records)) => {
                event.records = records;
                return Err(e);
            }
        }
    };
    let alignment = channels.alignment;
    let mut motions = Vec::new();
    let mut traces = Vec::with_capacity(channels.list.len());
    for c in channels.list {
        event.records.push(c.record);
        motions.extend(c.motion);
        traces.push(c.trace);
    }
    push_history(event, settings, &traces, alignment);
    Ok(motions)
}

/// Channels longer than this (samples) are conditioned one at a time: 2²³,
/// 64 MiB of f64, about 12 h at 200 Hz.
pub const LONG_CHANNEL: usize = 1 << 23;

/// After integration the record's samples are the motion's acceleration
/// (moved into the motion): shared back (a parked motion's without a copy).
fn share_acceleration(record: &mut Record, motion: Option<&Motion>) {
    if let Some(m) = motion {
        if record.samples.is_empty() && !m.acceleration.is_empty() {
            record.samples = m.acceleration.clone();
        }
    }
}

/// A failure: the phase it happened in (0 the checks, 1 units, 2 + i the
/// declared step i; `usize::MAX` after conditioning) and the error.
type Failure = (usize, Error);

/// A channel's failure, with its record (as conditioned so far).
type Failed = (usize, Error, Record);

/// One conditioned channel.
struct Channel1 {
    record: Record,
    motion: Option<Motion>,
    trace: Trace,
}

/// What a channel's conditioning leaves for the history.
struct Trace {
    /// QA codes of the channel after the checks (empty: not listed).
    qa_codes: Vec<&'static str>,
    units_from: &'static str,
    factor: f64,
    /// Indices of the resample steps that changed the record.
    resampled: Vec<usize>,
}

/// The conditioned channels, in record order, and the alignment when there was one.
struct Conditioned1 {
    list: Vec<Channel1>,
    alignment: Option<serde_json::Value>,
}

/// The channels, or the error of the earliest phase and, in it, of the
/// first channel, with every record.
fn earliest_failure(
    results: Vec<std::result::Result<Channel1, Failed>>,
) -> std::result::Result<Conditioned1, (Error, Vec<Record>)> {
    if results.iter().all(|r| r.is_ok()) {
        return Ok(Conditioned1 {
            list: results.into_iter().flatten().collect(),
            alignment: None,
        });
    }
    let mut records = Vec::with_capacity(results.len());
    let mut first: Option<Failure> = None;
    for r in results {
        match r {
            Ok(c) => records.push(c.record),
            Err((phase, e, record)) => {
                records.push(record);
                if first.as_ref().is_none_or(|(p, _)| phase < *p) {
                    first = Some((phase, e));
                }
            }
        }
    }
    let e = first.map(|(_, e)| e);
    Err((
        e.unwrap_or_else(|| Error::numerical("conditioning failed")),
        records,
    ))
}

/// Every step of one channel (no `align`: see [`condition_event_each`]).
fn condition_channel(
    mut record: Record,
    settings: &ConditioningSettings,
    park: Option<&ParkSeries<'_>>,
) -> std::result::Result<Channel1, Failed> {
    let mut trace = match check_qa_units(&mut record, settings) {
        Ok(t) => t,
        Err((phase, e)) => return Err((phase, e, record)),
    };
    let mut motion = None;
    for (i, step) in settings.steps.iter().enumerate() {
        match apply_step(&mut record, i, step, &mut trace, park) {
            Ok(Some(m)) => motion = Some(m),
            Ok(None) => {}
            Err(e) => return Err((2 + i, e, record)),
        }
    }
    Ok(Channel1 {
        record,
        motion,
        trace,
    })
}

/// The steps one after the other over all records (for `align`), in place.
fn condition_step_by_step(
    records: &mut Vec<Record>,
    settings: &ConditioningSettings,
    park: Option<&ParkSeries<'_>>,
    done: &ChannelDone<'_>,
) -> Result<Conditioned1> {
    // The checks and units of every record; the earliest failure, as above.
    let mut traces = Vec::with_capacity(records.len());
    let mut first: Option<Failure> = None;
    for r in records.iter_mut() {
        match check_qa_units(r, settings) {
            Ok(t) => traces.push(t),
            Err((phase, e)) => {
                if first.as_ref().is_none_or(|(p, _)| phase < *p) {
                    first = Some((phase, e));
                }
            }
        }
    }
    if let Some((_, e)) = first {
        return Err(e);
    }
    let mut motions: Vec<Option<Motion>> = (0..records.len()).map(|_| None).collect();
    let mut alignment = None;
    for (i, step) in settings.steps.iter().enumerate() {
        if let Step::Align = step {
            let a = align_records(records)?;
            alignment = Some(serde_json::to_value(&a).unwrap_or_default());
            continue;
        }
        let results: Vec<Result<Option<Motion>>> = records
            .par_iter_mut()
            .zip(traces.par_iter_mut())
            .map(|(r, t)| apply_step(r, i, step, t, park))
            .collect();
        for (k, m) in results.into_iter().enumerate() {
            if let Some(m) = m? {
                motions[k] = Some(m);
            }
        }
    }
    let mut list = Vec::with_capacity(records.len());
    let records = std::mem::take(records);
    for ((mut record, mut motion), trace) in records.into_iter().zip(motions).zip(traces) {
        done(&mut record, motion.as_mut())?;
        share_acceleration(&mut record, motion.as_ref());
        list.push(Channel1 {
            record,
            motion,
            trace,
        });
    }
    Ok(Conditioned1 { list, alignment })
}

/// The checks (finite samples, a positive rate), QA flags on the data as
/// recorded (clipping is best seen in raw values) and the conversion to SI.
fn check_qa_units(
    r: &mut Record,
    settings: &ConditioningSettings,
) -> std::result::Result<Trace, Failure> {
    let (count, first) = qa::count_non_finite(&r.samples);
    if count > 0 {
        let flag = QaFlag::NonFinite { count };
        if !r.channel.qa.contains(&flag) {
            r.channel.qa.push(flag);
        }
        return Err((
            0,
            Error::input(
                record_location(r),
                format!(
                    "{count} non-finite sample(s), first at index {}: refusing to condition",
                    first.unwrap_or(0)
                ),
            ),
        ));
    }
    if !(r.channel.sampling_rate_hz.is_finite() && r.channel.sampling_rate_hz > 0.0) {
        return Err((
            0,
            Error::input(
                record_location(r),
                format!(
                    "sampling rate must be positive, got {}",
                    r.channel.sampling_rate_hz
                ),
            ),
        ));
    }
    for f in quality_flags(&r.samples, r.channel.dt(), &settings.qa) {
        if !r.channel.qa.contains(&f) {
            r.channel.qa.push(f);
        }
    }
    let units_from = r.channel.units.name();
    let factor = units_to_si(r).map_err(|e| (1, e))?;
    if r.channel.units == Units::MPerS2 {
        if let Some(f) = qa::implausible_acceleration(&r.samples) {
            r.channel.qa.push(f);
        }
    }
    let qa_codes = r.channel.qa.iter().map(|f| f.code()).collect();
    Ok(Trace {
        qa_codes,
        units_from,
        factor,
        resampled: Vec::new(),
    })
}

/// Declared step `index` on one record; the motion when it integrates.
fn apply_step(
    r: &mut Record,
    index: usize,
    step: &Step,
    trace: &mut Trace,
    park: Option<&ParkSeries<'_>>,
) -> Result<Option<Motion>> {
    match step {
        Step::Resample { rate_hz } => {
            let target = *rate_hz;
            if r.channel.sampling_rate_hz != target {
                let from = r.channel.sampling_rate_hz;
                r.samples = resample_to_rate(&r.samples, from, target)
                    .map_err(|e| in_record(r, e))?
                    .into();
                r.channel.sampling_rate_hz = target;
                r.channel.qa.push(QaFlag::Resampled {
                    from: format!("{from} Hz"),
                });
                trace.resampled.push(index);
            }
        }
        // Needs every record: `condition_step_by_step`.
        Step::Align => {}
        _ if !is_acceleration(r) => {}
        Step::Detrend(method) => {
            let result = match method {
                Detrend::None => Ok(()),
                Detrend::Mean => {
                    remove_mean(&mut r.samples);
                    Ok(())
                }
                Detrend::Linear => remove_linear_trend(&mut r.samples).map(|_| ()),
                Detrend::Polynomial { order } => {
                    remove_polynomial(&mut r.samples, *order).map(|_| ())
                }
            };
            result.map_err(|e| in_record(r, e))?;
        }
        Step::Taper { fraction } => {
            cosine_taper(&mut r.samples, *fraction)?;
        }
        Step::Filter(f) => {
            let sos = butter_sos(f.order, f.band, &f.corners_hz, r.channel.sampling_rate_hz)
                .map_err(|e| in_record(r, e))?;
            r.samples = if f.zero_phase {
                sosfiltfilt(&sos, &r.samples)
            } else {
                sosfilt(&sos, &r.samples)
            }
            .map_err(|e| in_record(r, e))?
            .into();
        }
        Step::Integrate(integration) => {
            // The record's samples become the motion's acceleration: moved in,
            // given back by `share_acceleration` once the channel is done.
            let dt = r.channel.dt();
            let acc = std::mem::take(r.samples.as_mut_vec());
            let in_memory = |v: Vec<f64>| Ok(Samples::new(v));
            let m = integrate_motion_parking(
                &r.channel.id,
                acc,
                dt,
                &integration.drift,
                park.unwrap_or(&in_memory),
            )
            .map_err(|e| in_record(r, e))?;
            return Ok(Some(m));
        }
    }
    Ok(None)
}

fn is_acceleration(r: &Record) -> bool {
    r.channel.units.is_acceleration()
}

/// The history of the conditioning: QA, units, then each declared step.
fn push_history(
    event: &mut Event,
    settings: &ConditioningSettings,
    traces: &[Trace],
    alignment: Option<serde_json::Value>,
) {
    let mut qa_summary = serde_json::Map::new();
    let mut factors = serde_json::Map::new();
    for (r, t) in event.records.iter().zip(traces) {
        if !t.qa_codes.is_empty() {
            qa_summary.insert(r.channel.id.clone(), json!(t.qa_codes));
        }
        factors.insert(
            r.channel.id.clone(),
            json!({ "from": t.units_from, "factor": t.factor }),
        );
    }
    event.history.push(
        "qa",
        json!({ "settings": settings.qa, "flags": qa_summary }),
    );
    event
        .history
        .push("units_to_si", json!({ "channels": factors }));
    let ids: Vec<String> = event
        .records
        .iter()
        .filter(|r| is_acceleration(r))
        .map(|r| r.channel.id.clone())
        .collect();
    for (i, step) in settings.steps.iter().enumerate() {
        match step {
            Step::Resample { rate_hz } => {
                let changed = event
                    .records
                    .iter()
                    .zip(traces)
                    .filter(|(_, t)| t.resampled.contains(&i))
                    .map(|(r, _)| r.channel.id.clone())
                    .collect();
                event.history.push_for(
                    "resample",
                    changed,
                    json!({ "target_hz": rate_hz, "method": "rational polyphase, Kaiser-windowed sinc (beta 5, 20*max(up,down)+1 taps), cut-off at the lower Nyquist" }),
                );
            }
            Step::Align => event
                .history
                .push("align", alignment.clone().unwrap_or_default()),
            Step::Detrend(Detrend::None) => {}
            Step::Detrend(method) => event.history.push_for(
                "detrend",
                ids.clone(),
                serde_json::to_value(method).unwrap_or_default(),
            ),
            Step::Taper { fraction } => event.history.push_for(
                "taper",
                ids.clone(),
                json!({ "window": "cosine (Tukey)", "fraction_each_end": fraction }),
            ),
            Step::Filter(f) => event.history.push_for(
                "filter",
                ids.clone(),
                json!({
                    "design": "butterworth (scipy.signal.butter, output='sos')",
                    "order": f.order,
                    "band": f.band,
                    "corners_hz": f.corners_hz,
                    "zero_phase": f.zero_phase,
                    "edge_handling": if f.zero_phase { "odd extension, padlen = 3*(2*n_sections+1), sosfilt_zi initial conditions (scipy sosfiltfilt)" } else { "causal, zero initial state" },
                }),
            ),
            Step::Integrate(integration) => event.history.push_for(
                "integrate",
                ids.clone(),
                json!({ "rule": "cumulative trapezoid from rest", "drift_control": integration.drift }),
            ),
        }
    }
}
