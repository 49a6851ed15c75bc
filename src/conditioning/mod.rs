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
pub mod snr;
pub mod sosfilt;

pub use baseline::{cosine_taper, remove_linear_trend, remove_mean, remove_polynomial};
pub use butterworth::{butter_sos, BandType, Section};
pub use integrate::{
    integrate_motion, integrate_motion_of, integrate_motion_parking, DriftControl, Motion,
};
pub use qa::{quality_flags, QaSettings};
pub use resample::{align_records, resample_to_rate, Alignment};
pub use snr::{CornerBounds, CornerChoice, FourierSpectra};
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
    /// `"stated"`: `corners_hz` as written; `"snr"`: chosen per record from
    /// its signal-to-noise ratio (`snr`), `corners_hz` then the bounds — the
    /// lowest high-pass and the highest low-pass.
    #[serde(default, skip_serializing_if = "CornersFrom::is_stated")]
    pub corners_from: CornersFrom,
    /// `"snr"`: the SNR the pass band must reach (gmprocess's 3).
    #[serde(default = "default_snr_min")]
    pub snr_min: f64,
    /// `"snr"`: the highest high-pass corner (METHODS §1's 0.5 Hz; the larger
    /// of it and the stated corner; lowered to the band of interest by the
    /// condition stage's `high_pass = "auto"`).
    #[serde(default = "default_high_pass_max_hz")]
    pub high_pass_max_hz: f64,
    /// `"snr"`: the lowest low-pass corner (the smaller of it and the stated corner).
    #[serde(default = "default_low_pass_min_hz")]
    pub low_pass_min_hz: f64,
    /// `"snr"`: the shortest pre-event noise window, s.
    #[serde(default = "default_noise_min_s")]
    pub noise_min_s: f64,
}

fn yes() -> bool {
    true
}

/// Where a filter's corners come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CornersFrom {
    /// `corners_hz` as written.
    #[default]
    Stated,
    /// Per record from its signal-to-noise ratio (`conditioning::snr`).
    Snr,
}

impl CornersFrom {
    fn is_stated(&self) -> bool {
        *self == CornersFrom::Stated
    }
}

/// gmprocess's threshold (`snr_check`, `get_corner_frequencies`).
pub const DEFAULT_SNR_MIN: f64 = 3.0;
/// METHODS §1's high-pass corner, the highest the SNR may choose by default.
pub const DEFAULT_HIGH_PASS_MAX_HZ: f64 = 0.5;
/// The lowest low-pass the SNR may choose by default: a structure's modes and
/// its peak acceleration lie below 10 Hz.
pub const DEFAULT_LOW_PASS_MIN_HZ: f64 = 10.0;
/// The shortest noise window by default, s (see `snr`).
pub const DEFAULT_NOISE_MIN_S: f64 = 4.0;

fn default_snr_min() -> f64 {
    DEFAULT_SNR_MIN
}
fn default_high_pass_max_hz() -> f64 {
    DEFAULT_HIGH_PASS_MAX_HZ
}
fn default_low_pass_min_hz() -> f64 {
    DEFAULT_LOW_PASS_MIN_HZ
}
fn default_noise_min_s() -> f64 {
    DEFAULT_NOISE_MIN_S
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
        if self.corners_from == CornersFrom::Snr {
            self.validate_snr()?;
        }
        Ok(())
    }

    fn validate_snr(&self) -> Result<()> {
        if self.band == BandType::Bandstop {
            return Err(Error::usage(
                "filter corners_from = \"snr\" chooses a high-pass and a low-pass corner: not for a bandstop filter",
            ));
        }
        if !(self.snr_min.is_finite() && self.snr_min >= 1.0) {
            return Err(Error::usage(format!(
                "filter snr_min = {}: must be a ratio of at least 1 (noise alone gives 1)",
                self.snr_min
            )));
        }
        for (key, v) in [
            ("high_pass_max_hz", self.high_pass_max_hz),
            ("low_pass_min_hz", self.low_pass_min_hz),
            ("noise_min_s", self.noise_min_s),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::usage(format!(
                    "filter {key} = {v}: must be positive and finite"
                )));
            }
        }
        let b = self.corner_bounds();
        if let (Some([_, hp]), Some([lp, _])) = (b.high_pass, b.low_pass) {
            if hp >= lp {
                return Err(Error::usage(format!(
                    "filter corners_from = \"snr\": the highest high-pass ({hp} Hz, high_pass_max_hz or the stated corner) must lie below the lowest low-pass ({lp} Hz, low_pass_min_hz or the stated corner)"
                )));
            }
        }
        Ok(())
    }

    /// The range each corner may take when chosen from the SNR: the
    /// high-pass from the stated corner up to `high_pass_max_hz` (or the
    /// stated corner when higher), the low-pass from `low_pass_min_hz` (or
    /// the stated corner when lower) up to the stated corner.
    pub fn corner_bounds(&self) -> snr::CornerBounds {
        let c = &self.corners_hz;
        let (hp, lp) = match (self.band, c.len()) {
            (BandType::Highpass, 1) => (Some(c[0]), None),
            (BandType::Lowpass, 1) => (None, Some(c[0])),
            (BandType::Bandpass, 2) => (Some(c[0]), Some(c[1])),
            _ => (None, None),
        };
        snr::CornerBounds {
            high_pass: hp.map(|f| [f, f.max(self.high_pass_max_hz)]),
            low_pass: lp.map(|f| [f.min(self.low_pass_min_hz), f]),
        }
    }

    /// The corners to design the filter with: `corners_hz`, or the chosen
    /// ones of a record (in the same layout).
    fn corners_for(&self, chosen: Option<&snr::CornerChoice>) -> Vec<f64> {
        let Some(c) = chosen else {
            return self.corners_hz.clone();
        };
        let mut out = self.corners_hz.clone();
        match self.band {
            BandType::Highpass => {
                if let Some(h) = &c.high_pass {
                    out[0] = h.hz;
                }
            }
            BandType::Lowpass => {
                if let Some(l) = &c.low_pass {
                    out[0] = l.hz;
                }
            }
            BandType::Bandpass => {
                if let Some(h) = &c.high_pass {
                    out[0] = h.hz;
                }
                if let Some(l) = &c.low_pass {
                    out[1] = l.hz;
                }
            }
            BandType::Bandstop => {}
        }
        out
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
                    corners_from: CornersFrom::Stated,
                    snr_min: DEFAULT_SNR_MIN,
                    high_pass_max_hz: DEFAULT_HIGH_PASS_MAX_HZ,
                    low_pass_min_hz: DEFAULT_LOW_PASS_MIN_HZ,
                    noise_min_s: DEFAULT_NOISE_MIN_S,
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
        let snr_filters = self
            .steps
            .iter()
            .filter(|s| matches!(s, Step::Filter(f) if f.corners_from == CornersFrom::Snr))
            .count();
        if snr_filters > 1 {
            return Err(Error::usage(format!(
                "{snr_filters} filter steps choose their corners from the signal-to-noise ratio (corners_from = \"snr\"): at most one may (its spectra are the stage's fourier table)"
            )));
        }
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

    /// The filter step whose corners come from the SNR, if any.
    pub fn snr_filter(&self) -> Option<&FilterSettings> {
        self.snr_filter_step().map(|(_, f)| f)
    }

    /// [`Self::snr_filter`] with its index in `steps`.
    fn snr_filter_step(&self) -> Option<(usize, &FilterSettings)> {
        self.steps.iter().enumerate().find_map(|(i, s)| match s {
            Step::Filter(f) if f.corners_from == CornersFrom::Snr => Some((i, f)),
            _ => None,
        })
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
    condition_event_each(event, settings, None, &|_, _| Ok(())).map(|o| o.motions)
}

/// What conditioning an event gives besides the records it changes in place.
#[derive(Debug, Default)]
pub struct ConditioningOutput {
    /// Acceleration, velocity and displacement of every acceleration channel
    /// when integration is configured (empty otherwise).
    pub motions: Vec<Motion>,
    /// With a filter whose corners come from the SNR: each acceleration
    /// record's spectra and chosen corners, in record order (empty otherwise).
    pub fourier: Vec<RecordFourier>,
}

/// One record's Fourier spectra (signal and noise windows) and the corners
/// chosen from them for the filter step with `corners_from = "snr"`.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordFourier {
    pub channel_id: String,
    /// None when the record has no signal window to analyse.
    pub spectra: Option<snr::FourierSpectra>,
    /// The corners of this record's own spectra.
    pub own: snr::CornerChoice,
    /// The corners applied: common to the event's records of its group
    /// (`snr::common_corners`).
    pub choice: snr::CornerChoice,
}

/// The spectra and corners of record `r` (before any step; the spectra in SI
/// units: the file's values times `factor` — windows and ratios do not
/// depend on the scale) for filter `f`.
fn fourier_of(r: &Record, f: &FilterSettings, factor: f64) -> Result<RecordFourier> {
    let bounds = f.corner_bounds();
    let x = r.samples.get()?;
    let dt = r.channel.dt();
    let mut spectra = snr::fourier_spectra(&x, dt, f.noise_min_s).map_err(|e| in_record(r, e))?;
    if let Some(s) = spectra.as_mut() {
        s.signal.iter_mut().for_each(|v| *v *= factor);
        s.noise.iter_mut().flatten().for_each(|v| *v *= factor);
    }
    let own = match &spectra {
        Some(s) => snr::choose_corners(s, &bounds, f.snr_min),
        None => snr::CornerChoice::stated(
            &bounds,
            "the pipeline's corner: the record has no signal window to analyse (too short or silent, or a continuous record of more than 30 min without an event window)",
        ),
    };
    Ok(RecordFourier {
        channel_id: r.channel.id.clone(),
        spectra,
        choice: own.clone(),
        own,
    })
}

/// With a filter whose corners come from the SNR: every acceleration
/// record's spectra and own corners (before any step: records in counts
/// without a sensitivity, or with non-finite samples, are left to the checks
/// that refuse them), then the corners common to the event's horizontal
/// records and to its vertical ones (`snr::common_corners`).  In record
/// order; `None` for a record not analysed.
fn analyse_event(
    records: &[Record],
    settings: &ConditioningSettings,
) -> Result<Vec<Option<RecordFourier>>> {
    let Some(f) = settings.snr_filter() else {
        return Ok(vec![None; records.len()]);
    };
    let one = |r: &Record| -> Result<Option<RecordFourier>> {
        match r.channel.units.to_si_factor() {
            Some(factor) if is_acceleration(r) => fourier_of(r, f, factor).map(Some),
            _ => Ok(None),
        }
    };
    // Long channels one at a time (as their conditioning).
    let mut list: Vec<Option<RecordFourier>> =
        if records.iter().any(|r| r.samples.len() > LONG_CHANNEL) {
            records.iter().map(one).collect::<Result<_>>()?
        } else {
            records.par_iter().map(one).collect::<Result<_>>()?
        };
    let bounds = f.corner_bounds();
    let vertical = |r: &Record| r.channel.direction.is_some_and(|d| d.is_vertical());
    for (is_vertical, group) in [(false, "horizontal"), (true, "vertical")] {
        let members: Vec<usize> = (0..records.len())
            .filter(|&i| list[i].is_some() && vertical(&records[i]) == is_vertical)
            .collect();
        let own: Vec<(&str, &snr::CornerChoice)> = members
            .iter()
            .filter_map(|&i| list[i].as_ref().map(|c| (c.channel_id.as_str(), &c.own)))
            .collect();
        let common = snr::common_corners(&own, &bounds, group);
        for (&i, c) in members.iter().zip(common) {
            if let Some(rf) = list[i].as_mut() {
                rf.choice = c;
            }
        }
    }
    Ok(list)
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
) -> Result<ConditioningOutput> {
    let analyses = analyse_event(&event.records, settings)?;
    let channels = if settings.step("align").is_some() {
        condition_step_by_step(&mut event.records, settings, analyses, park, done)?
    } else {
        let records = std::mem::take(&mut event.records);
        // Channels of more than LONG_CHANNEL samples (a day at 200 Hz) are
        // conditioned one at a time: two in flight would double the memory.
        let long = records.iter().any(|r| r.samples.len() > LONG_CHANNEL);
        let one = |(r, fourier): (Record, Option<RecordFourier>)| -> std::result::Result<Channel1, Failed> {
            let mut c = condition_channel(r, fourier, settings, park)?;
            if let Err(e) = done(&mut c.record, c.motion.as_mut()) {
                return Err((usize::MAX, e, c.record));
            }
            share_acceleration(&mut c.record, c.motion.as_ref());
            Ok(c)
        };
        let results: Vec<std::result::Result<Channel1, Failed>> = if long {
            records.into_iter().zip(analyses).map(one).collect()
        } else {
            records.into_par_iter().zip(analyses).map(one).collect()
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
    let fourier = traces.into_iter().filter_map(|t| t.fourier).collect();
    Ok(ConditioningOutput { motions, fourier })
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
    /// The spectra and corners of a filter with `corners_from = "snr"`.
    fourier: Option<RecordFourier>,
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
    fourier: Option<RecordFourier>,
    settings: &ConditioningSettings,
    park: Option<&ParkSeries<'_>>,
) -> std::result::Result<Channel1, Failed> {
    let mut trace = match check_qa_units(&mut record, settings) {
        Ok(t) => t,
        Err((phase, e)) => return Err((phase, e, record)),
    };
    trace.fourier = fourier;
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
    analyses: Vec<Option<RecordFourier>>,
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
    for (t, fourier) in traces.iter_mut().zip(analyses) {
        t.fourier = fourier;
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
        fourier: None,
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
            let corners = match f.corners_from {
                CornersFrom::Stated => f.corners_hz.clone(),
                CornersFrom::Snr => f.corners_for(trace.fourier.as_ref().map(|c| &c.choice)),
            };
            let sos = butter_sos(f.order, f.band, &corners, r.channel.sampling_rate_hz)
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

/// The corners of a filter with `corners_from = "snr"` in its history
/// entry: the method, the bounds and, per channel, the corners applied and why.
fn snr_history(
    params: &mut serde_json::Value,
    f: &FilterSettings,
    records: &[Record],
    traces: &[Trace],
) {
    let b = f.corner_bounds();
    let mut per_channel = serde_json::Map::new();
    for (r, t) in records.iter().zip(traces) {
        let Some(c) = &t.fourier else { continue };
        let spectra = c.spectra.as_ref();
        per_channel.insert(
            r.channel.id.clone(),
            json!({
                "corners_hz": f.corners_for(Some(&c.choice)),
                "from": if c.choice.from_snr { "snr" } else { "stated" },
                "own_corners_hz": f.corners_for(Some(&c.own)),
                "high_pass": c.choice.high_pass.as_ref().map(|h| &h.why),
                "low_pass": c.choice.low_pass.as_ref().map(|l| &l.why),
                "noise_window_s": spectra.and_then(|s| s.noise_window_s),
                "signal_window_s": spectra.map(|s| s.signal_window_s),
            }),
        );
    }
    // The stated corners are bounds here; each channel's applied corners follow.
    if let Some(o) = params.as_object_mut() {
        o.remove("corners_hz");
    }
    params["corners_from"] = json!("snr");
    params["snr_min"] = json!(f.snr_min);
    params["bounds_hz"] = json!({ "high_pass": b.high_pass, "low_pass": b.low_pass });
    params["noise_min_s"] = json!(f.noise_min_s);
    params["method"] = json!("noise window before the AIC onset (Maeda 1985), signal window to 95 % of the energy; Hann-tapered windows, Konno-Ohmachi (b = 20) smoothed |FFT|·dt divided by sqrt(window duration); high-pass: lowest frequency above which SNR >= snr_min up to its upper bound; low-pass: highest frequency below which SNR >= snr_min from its lower bound; applied: the highest high-pass and lowest low-pass of the event's horizontal (vertical) records with a noise window, to all of them; the pipeline's corners when half or more have none (docs/pipelines.md)");
    params["per_channel"] = serde_json::Value::Object(per_channel);
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
            Step::Filter(f) => {
                let mut params = json!({
                    "design": "butterworth (scipy.signal.butter, output='sos')",
                    "order": f.order,
                    "band": f.band,
                    "corners_hz": f.corners_hz,
                    "zero_phase": f.zero_phase,
                    "edge_handling": if f.zero_phase { "odd extension, padlen = 3*(2*n_sections+1), sosfilt_zi initial conditions (scipy sosfiltfilt)" } else { "causal, zero initial state" },
                });
                if f.corners_from == CornersFrom::Snr {
                    snr_history(&mut params, f, &event.records, traces);
                }
                event.history.push_for("filter", ids.clone(), params)
            }
            Step::Integrate(integration) => event.history.push_for(
                "integrate",
                ids.clone(),
                json!({ "rule": "cumulative trapezoid from rest", "drift_control": integration.drift }),
            ),
        }
    }
}
