//! Parameters of the `modal` stage (docs/pipelines.md), shared by the
//! pipeline stage, `quaketwin modal` and the Python `modal`: their bounds
//! live here, checked before any record is read.

use serde::Deserialize;

use super::{
    fundamental_estimate, identify_event, identify_event_or_output_only, ChannelChoice, Method,
    ModalResult, ModalSettings,
};
use crate::error::{Error, Result};
use crate::vocab::{Event, Role};

/// Identification method of the stage: `auto` picks input–output when the
/// event has base channels (output-only if that finds no mode), else SSI-COV.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MethodChoice {
    Auto,
    #[serde(alias = "cov")]
    SsiCov,
    #[serde(alias = "data")]
    SsiData,
    #[serde(alias = "n4sid", alias = "moesp")]
    Io,
}

/// Parameters of the `modal` stage (docs/pipelines.md) but the pre/post
/// ones ([`ReferenceParams`]).  Unset values adapt to the record (issue 13,
/// `modal::plan`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ModalParams {
    /// `auto`, `ssi-cov`, `ssi-data` or `io` ([`MethodChoice`]).
    pub method: MethodChoice,
    /// Band of interest [low, high] Hz; unset = around the structure's
    /// estimated fundamental (`modal::fundamental_estimate`), else from the
    /// records' spectra (`modal::band_from_spectra`).
    pub band_hz: Option<[f64; 2]>,
    /// Model orders swept: [first, last, step]; unset = 2, 4, … up to what
    /// the data support (at most 60).
    pub orders: Option<[usize; 3]>,
    /// Block rows; unset = automatic.
    pub block_rows: Option<usize>,
    /// Physical damping window (default 0.5–10 %; the thesis, METHODS §2, used 0.9–5.5 % for a masonry building).
    pub damping_min: f64,
    pub damping_max: f64,
    pub frequency_min_hz: Option<f64>,
    pub frequency_max_hz: Option<f64>,
    /// Decimation factor applied before identification (anti-aliased);
    /// unset = automatic (sampling rate ≈ 4 × the band's top).
    pub decimation: Option<usize>,
    /// Input channel ids for input–output identification; unset = the
    /// horizontal base channels.  Verticals enter only when listed here.
    pub inputs: Option<Vec<String>>,
    /// Vertical response channels enter as outputs (default: only when the
    /// event has no horizontal response channel).
    pub vertical_outputs: bool,
    /// Manual override: pick these frequencies instead of the automatic selection.
    pub manual_frequencies_hz: Option<Vec<f64>>,
    /// Welch segment length for the PSD singular values.
    pub psd_segment: usize,
    /// Blocks the record is cut into for the modes' data-driven σ
    /// (`modal::uncertainty`): unset = automatic, 0 = not computed, else
    /// `uncertainty::MIN_BLOCKS..=uncertainty::MAX_BLOCKS`.
    pub uncertainty_blocks: Option<usize>,
}

impl Default for ModalParams {
    fn default() -> Self {
        let f = crate::modal::PhysicalFilters::default();
        ModalParams {
            method: MethodChoice::Auto,
            band_hz: None,
            orders: None,
            block_rows: None,
            damping_min: f.damping_min,
            damping_max: f.damping_max,
            frequency_min_hz: None,
            frequency_max_hz: None,
            decimation: None,
            inputs: None,
            vertical_outputs: false,
            manual_frequencies_hz: None,
            psd_segment: 1024,
            uncertainty_blocks: None,
        }
    }
}

/// Highest model order of an explicit `orders` sweep: the widest block
/// (block rows × outputs) the automatic choice builds
/// ([`super::MAX_HORIZON_BLOCK_WIDTH`]), four times the automatic cap
/// ([`super::MAX_AUTO_ORDER_CAP`]).  Orders above the subspace a record
/// supports ((block rows − 1) × outputs) are skipped with a note.
pub const MAX_MODEL_ORDER: usize = super::MAX_HORIZON_BLOCK_WIDTH;
/// Most explicit block rows: with one output the automatic choice reaches
/// [`super::MAX_HORIZON_BLOCK_WIDTH`]; at run time block rows × the rows of
/// a block (outputs, plus inputs for `io`) are bounded by
/// [`super::MAX_HANKEL_ROWS`].
pub const MAX_BLOCK_ROWS: usize = super::MAX_HORIZON_BLOCK_WIDTH;
/// Largest explicit decimation factor: a 1 kHz record decimated 1000 times
/// is sampled at 1 Hz, below any structural mode's band.
pub const MAX_DECIMATION: usize = 1000;
/// Longest Welch segment of the PSD overlay, samples (a power of two of
/// 64 k samples: 11 min at 100 Hz).
pub const MAX_PSD_SEGMENT: usize = 65_536;
/// Most entries of `manual_frequencies_hz` and of `inputs`.
pub const MAX_LISTED: usize = 256;

impl ModalParams {
    /// Checks the parameters before any record is read (usage errors
    /// naming the key): the bounds above, bands positive and finite.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(Error::usage(m));
        if let Some([first, last, step]) = self.orders {
            if first == 0 || step == 0 || last < first || last > MAX_MODEL_ORDER {
                return bad(format!(
                    "orders = [{first}, {last}, {step}]: must be [first, last, step] with 0 < first ≤ last ≤ {MAX_MODEL_ORDER} and step > 0"
                ));
            }
        }
        if let Some([lo, hi]) = self.band_hz {
            if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi > lo) {
                return bad(format!("band_hz [{lo}, {hi}] must satisfy 0 < low < high"));
            }
        }
        if let Some(p) = self
            .block_rows
            .filter(|p| !(2..=MAX_BLOCK_ROWS).contains(p))
        {
            return bad(format!("block_rows = {p}: must be 2..={MAX_BLOCK_ROWS}"));
        }
        if let Some(d) = self
            .decimation
            .filter(|d| !(1..=MAX_DECIMATION).contains(d))
        {
            return bad(format!("decimation = {d}: must be 1..={MAX_DECIMATION}"));
        }
        if let Some(i) = &self.inputs {
            if i.is_empty() || i.len() > MAX_LISTED {
                return bad(format!(
                    "inputs lists {} channel ids: must be 1..={MAX_LISTED}",
                    i.len()
                ));
            }
        }
        if !(self.damping_min >= 0.0
            && self.damping_max > self.damping_min
            && self.damping_max <= 1.0)
        {
            return bad(format!(
                "damping window [{}, {}]: must satisfy 0 ≤ damping_min < damping_max ≤ 1",
                self.damping_min, self.damping_max
            ));
        }
        for (key, f) in [
            ("frequency_min_hz", self.frequency_min_hz),
            ("frequency_max_hz", self.frequency_max_hz),
        ] {
            if let Some(f) = f.filter(|f| !(f.is_finite() && *f >= 0.0)) {
                return bad(format!("{key} = {f}: must be a frequency ≥ 0 Hz"));
            }
        }
        if let Some(f) = &self.manual_frequencies_hz {
            if f.len() > MAX_LISTED || f.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
                return bad(format!(
                    "manual_frequencies_hz: at most {MAX_LISTED} positive finite frequencies (got {})",
                    f.len()
                ));
            }
        }
        if let Some(b) = self.uncertainty_blocks.filter(|&b| {
            b != 0
                && !(super::uncertainty::MIN_BLOCKS..=super::uncertainty::MAX_BLOCKS).contains(&b)
        }) {
            return bad(format!(
                "uncertainty_blocks = {b}: must be 0 (off) or {}..={}",
                super::uncertainty::MIN_BLOCKS,
                super::uncertainty::MAX_BLOCKS
            ));
        }
        if !(8..=MAX_PSD_SEGMENT).contains(&self.psd_segment) {
            return bad(format!(
                "psd_segment = {}: must be 8..={MAX_PSD_SEGMENT} samples",
                self.psd_segment
            ));
        }
        Ok(())
    }

    /// The modal settings for `event` (method `auto` resolved from its channels).
    pub fn settings_for(&self, event: &Event) -> Result<ModalSettings> {
        let has_input = match &self.inputs {
            Some(ids) => !ids.is_empty(),
            None => event.records.iter().any(|r| {
                r.channel.role == Role::Input
                    && !r.channel.direction.is_some_and(|d| d.is_vertical())
            }),
        };
        let method = match self.method {
            MethodChoice::Auto if has_input => Method::Io,
            MethodChoice::Auto | MethodChoice::SsiCov => Method::SsiCov,
            MethodChoice::SsiData => Method::SsiData,
            MethodChoice::Io => Method::Io,
        };
        self.validate()?;
        let estimate = event.structure.as_ref().and_then(fundamental_estimate);
        let (band_hz, band_basis) =
            crate::modal::band_of_structure(self.band_hz, event.structure.as_ref());
        let mut s = ModalSettings {
            method,
            band_hz,
            fundamental_estimate_hz: estimate.map(|(f1, _)| f1),
            band_basis,
            block_rows: self.block_rows,
            orders: self
                .orders
                .map(|[first, last, step]| (first..=last).step_by(step).collect()),
            ..Default::default()
        };
        s.filters.damping_min = self.damping_min;
        s.filters.damping_max = self.damping_max;
        s.filters.frequency_min_hz = self.frequency_min_hz;
        s.filters.frequency_max_hz = self.frequency_max_hz;
        s.preprocessing.decimation = self.decimation;
        s.manual_frequencies_hz = self.manual_frequencies_hz.clone();
        s.uncertainty_blocks = self.uncertainty_blocks;
        Ok(s)
    }

    /// Identifies `event` with these parameters; returns the result and the
    /// settings it was made with.  `auto` may fall back to output-only
    /// identification ([`identify_event_or_output_only`]); an explicit
    /// `method` never does.
    pub fn identify(&self, event: &Event) -> Result<(ModalResult, ModalSettings)> {
        let settings = self.settings_for(event)?;
        let choice = ChannelChoice {
            inputs: self.inputs.clone(),
            vertical_outputs: self.vertical_outputs,
        };
        if self.method == MethodChoice::Auto {
            identify_event_or_output_only(event, &settings, &choice)
        } else {
            Ok((identify_event(event, &settings, &choice)?, settings))
        }
    }
}
