//! `modal`: subspace identification of the conditioned records (METHODS §2)
//! → `stabilization.parquet`, `modes.parquet`, `modal_spectrum.parquet`,
//! and `frequency_shifts.parquet` against an earlier run's modes
//! ([`super::prepost`]).

use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::condition::Conditioned;
use super::prepost::{self, ReferenceParams, ReferenceRun};
use crate::error::{Error, Result};
use crate::modal::{
    fundamental_estimate, identify_event, identify_event_or_output_only, output_spectral_overlay,
    ChannelChoice, Method, ModalResult, ModalSettings,
};
use crate::pipeline::{Product, ProductKind, RunContext, Stage, StageKind, StageSource};
use crate::sinks::modal_tables as tables;
use crate::sinks::provenance::Provenance;
use crate::vocab::{Event, Role};

pub const KIND: StageKind = StageKind {
    kind: "modal",
    needs: &[ProductKind::ConditionedEvent],
    provides: Some(ProductKind::Modes),
    reads_all_earlier: false,
    build,
};

pub const STABILIZATION_FILE: &str = crate::vocab::tables::STABILIZATION.file;
pub const MODES_FILE: &str = crate::vocab::tables::MODES.file;
pub const SPECTRUM_FILE: &str = crate::vocab::tables::MODAL_SPECTRUM.file;

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

/// The product: where the identified modes are (a later stage reads the file).
pub struct ModesFile {
    pub path: PathBuf,
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
        }
    }
}

impl ModalParams {
    /// Checks the parameters before any record is read.
    pub fn validate(&self) -> Result<()> {
        if let Some([first, last, step]) = self.orders {
            if first == 0 || step == 0 || last < first {
                return Err(Error::usage(
                    "orders must be [first, last, step] with 0 < first ≤ last and step > 0",
                ));
            }
        }
        if let Some([lo, hi]) = self.band_hz {
            if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi > lo) {
                return Err(Error::usage(format!(
                    "band_hz [{lo}, {hi}] must satisfy 0 < low < high"
                )));
            }
        }
        if self.block_rows.is_some_and(|p| p < 2) {
            return Err(Error::usage("block_rows must be at least 2"));
        }
        if self.decimation == Some(0) {
            return Err(Error::usage("decimation must be at least 1"));
        }
        if self.inputs.as_ref().is_some_and(|i| i.is_empty()) {
            return Err(Error::usage("inputs must list at least one channel id"));
        }
        if !(self.damping_min >= 0.0 && self.damping_max > self.damping_min) {
            return Err(Error::usage(
                "damping window must satisfy 0 ≤ damping_min < damping_max",
            ));
        }
        if self.psd_segment < 8 {
            return Err(Error::usage("psd_segment must be at least 8 samples"));
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

/// Identifies `event` and writes the modal tables into `out`; with a
/// reference, also `frequency_shifts.parquet` (read before identifying, so
/// a bad reference fails first).
pub fn identify_and_write(
    event: &Event,
    p: &ModalParams,
    reference: Option<&ReferenceRun>,
    out: &Path,
) -> Result<ModalResult> {
    p.validate()?;
    let reference = reference.map(|r| r.read(out)).transpose()?;
    let (result, settings) = p.identify(event)?;
    let settings_json = serde_json::to_string(&settings).unwrap_or_default();
    for w in &result.warnings {
        crate::console::warn(format!("modal ({}): {w}", event.name));
    }
    let (json, provenance) = (settings_json.as_str(), Provenance::of_event(event));
    tables::write_stabilization(&out.join(STABILIZATION_FILE), &result, json, &provenance)?;
    tables::write_modes(&out.join(MODES_FILE), &result, json, &provenance)?;
    let overlay = output_spectral_overlay(event, &result, p.psd_segment)?;
    let spectrum = out.join(SPECTRUM_FILE);
    tables::write_spectrum(&spectrum, &result, overlay.as_ref(), json, &provenance)?;
    if let Some(reference) = &reference {
        let provenance = provenance.then(result.preprocessing.iter().cloned());
        prepost::compare_and_write(reference, &result, out, &event.name, &provenance)?;
    }
    Ok(result)
}

fn build(src: &StageSource) -> Result<Box<dyn Stage>> {
    let (params, reference): (ModalParams, ReferenceParams) = src.params_split(prepost::KEYS)?;
    params.validate().map_err(|e| src.invalid(e))?;
    let reference = reference.check().map_err(|e| src.invalid(e))?;
    Ok(Box::new(Modal { params, reference }))
}

struct Modal {
    params: ModalParams,
    /// The earlier run to compare with (checked when the pipeline was read).
    reference: Option<ReferenceRun>,
}

impl Stage for Modal {
    fn outputs(&self) -> Vec<String> {
        let mut v = vec![
            STABILIZATION_FILE.to_string(),
            MODES_FILE.into(),
            SPECTRUM_FILE.into(),
        ];
        if self.reference.is_some() {
            v.push(prepost::SHIFTS_FILE.into());
        }
        v
    }
    fn not_applicable(&self, ctx: &mut RunContext) -> Result<Option<String>> {
        Ok(not_applicable(&ctx.loaded_event()?.event))
    }
    fn extra_fingerprint(&self, _ctx: &mut RunContext) -> Result<String> {
        self.reference
            .as_ref()
            .map_or(Ok(String::new()), |r| r.fingerprint())
    }
    fn run(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        let out = ctx.out_dir.clone();
        let Conditioned { event, .. } = ctx.input(ProductKind::ConditionedEvent)?;
        identify_and_write(event, &self.params, self.reference.as_ref(), &out)?;
        self.restore(ctx)
    }
    fn restore(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        Ok(Some(Box::new(ModesFile {
            path: ctx.out_dir.join(MODES_FILE),
        })))
    }
}

/// Why modal identification cannot run on `event`: no sensor channel is a
/// structural response (role output) — e.g. a folder without event.toml
/// whose headers name only the ground sensors.
pub fn not_applicable(event: &Event) -> Option<String> {
    let has_output = event
        .records
        .iter()
        .any(|r| !r.channel.is_floor_motion() && r.channel.role == Role::Output);
    (!has_output).then(|| {
        "no channel is known to be a structural response (role output; input = base/ground), and no header location text names one (deck, roof, floor, level…): state `role` or `level` per channel in event.toml (docs/event-folder.md)".to_string()
    })
}
