//! `modal`: subspace identification of the conditioned records (METHODS §2)
//! → `stabilization.parquet`, `modes.parquet`, `modal_spectrum.parquet`,
//! and `frequency_shifts.parquet` against a previous event's modes.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::error::{Error, Result};
use crate::modal::{
    frequency_shifts, identify_event, spectral_overlay, Method, ModalResult, ModalSettings,
};
use crate::pipeline::{params, RunContext, StageDecl};
use crate::sinks::modal_tables as tables;
use crate::vocab::{Event, Role};

/// Parameters of the `modal` stage (docs/pipelines.md).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ModalParams {
    /// `auto` (input–output when the event has base channels, else SSI-COV),
    /// `ssi-cov`, `ssi-data` or `io`.
    pub method: String,
    /// Model orders swept: [first, last, step] (thesis: 2 to 42 step 2).
    pub orders: [usize; 3],
    /// Block rows; none = automatic.
    pub block_rows: Option<usize>,
    /// Physical damping window (METHODS §2: 0.9–5.5 %).
    pub damping_min: f64,
    pub damping_max: f64,
    pub frequency_min_hz: Option<f64>,
    pub frequency_max_hz: Option<f64>,
    /// Decimation factor applied before identification (anti-aliased).
    pub decimation: usize,
    /// Manual override: pick these frequencies instead of clustering.
    pub manual_frequencies_hz: Option<Vec<f64>>,
    /// `modes.parquet` of an earlier event of the same structure (path
    /// relative to the working directory) → `frequency_shifts.parquet`.
    pub reference_modes: Option<PathBuf>,
    /// Welch segment length for the PSD singular values.
    pub psd_segment: usize,
}

impl Default for ModalParams {
    fn default() -> Self {
        let f = crate::modal::PhysicalFilters::default();
        ModalParams {
            method: "auto".into(),
            orders: [2, 42, 2],
            block_rows: None,
            damping_min: f.damping_min,
            damping_max: f.damping_max,
            frequency_min_hz: None,
            frequency_max_hz: None,
            decimation: 1,
            manual_frequencies_hz: None,
            reference_modes: None,
            psd_segment: 1024,
        }
    }
}

impl ModalParams {
    /// The modal settings for `event` (method `auto` resolved from its channels).
    pub fn settings_for(&self, event: &Event) -> Result<ModalSettings> {
        let method = match self.method.as_str() {
            "auto" => {
                if event.records.iter().any(|r| r.channel.role == Role::Input) {
                    Method::Io
                } else {
                    Method::SsiCov
                }
            }
            m => Method::from_name(m).ok_or_else(|| {
                Error::usage(format!("method {m:?}: use auto, ssi-cov, ssi-data or io"))
            })?,
        };
        let [first, last, step] = self.orders;
        if first == 0 || step == 0 || last < first {
            return Err(Error::usage(
                "orders must be [first, last, step] with 0 < first ≤ last and step > 0",
            ));
        }
        let mut s = ModalSettings {
            method,
            block_rows: self.block_rows,
            orders: (first..=last).step_by(step).collect(),
            ..Default::default()
        };
        s.filters.damping_min = self.damping_min;
        s.filters.damping_max = self.damping_max;
        s.filters.frequency_min_hz = self.frequency_min_hz;
        s.filters.frequency_max_hz = self.frequency_max_hz;
        s.preprocessing.decimation = self.decimation.max(1);
        s.manual_frequencies_hz = self.manual_frequencies_hz.clone();
        Ok(s)
    }
}

/// Identifies `event` and writes the modal tables into `out`.
pub fn identify_and_write(event: &Event, p: &ModalParams, out: &Path) -> Result<ModalResult> {
    let settings = p.settings_for(event)?;
    let settings_json = serde_json::to_string(&settings).unwrap_or_default();
    let result = identify_event(event, &settings)?;
    tables::write_stabilization(&out.join("stabilization.parquet"), &result, &settings_json)?;
    tables::write_modes(&out.join("modes.parquet"), &result, &settings_json)?;
    let outputs: Vec<Vec<f64>> = result
        .output_ids
        .iter()
        .filter_map(|id| event.record(id).map(|r| r.samples.clone()))
        .collect();
    let dt = event
        .record(&result.output_ids[0])
        .map(|r| r.channel.dt())
        .unwrap_or(result.dt);
    let overlay = spectral_overlay(&outputs, dt, p.psd_segment).ok();
    tables::write_spectrum(
        &out.join("modal_spectrum.parquet"),
        &result,
        overlay.as_ref(),
        &settings_json,
    )?;
    if let Some(reference) = &p.reference_modes {
        let (ref_modes, ref_channels) = tables::read_modes(reference)?;
        if ref_channels != result.output_ids {
            return Err(Error::input(
                crate::error::Location::file(reference.display().to_string()),
                format!(
                    "reference modes are given at channels {ref_channels:?}, this event at {:?}",
                    result.output_ids
                ),
            ));
        }
        let shifts = frequency_shifts(&ref_modes, &result.modes, 0.8);
        tables::write_shifts(
            &out.join("frequency_shifts.parquet"),
            &shifts,
            &reference.display().to_string(),
            &event.name,
        )?;
    }
    Ok(result)
}

pub fn run(stage: &StageDecl, ctx: &mut RunContext) -> Result<()> {
    let p: ModalParams = params(stage)?;
    let out = ctx.out_dir.clone();
    let (event, _) = ctx.conditioned_event()?;
    identify_and_write(event, &p, &out)?;
    Ok(())
}

/// Output files of the stage (the shifts file only with `reference_modes`).
/// Why modal identification cannot run on `event`: no sensor channel is a
/// structural response (role output) — e.g. a folder without event.toml
/// whose headers name only the ground sensors.
pub fn not_applicable(event: &Event) -> Option<String> {
    let has_output = event
        .records
        .iter()
        .any(|r| !r.channel.is_floor_motion() && r.channel.role == Role::Output);
    (!has_output).then(|| {
        "no channel is known to be a structural response (role output; input = base/ground): state `role` or `level` per channel in event.toml (docs/event-folder.md)".to_string()
    })
}

pub fn outputs(p: &ModalParams) -> Vec<String> {
    let mut v = vec![
        "stabilization.parquet".to_string(),
        "modes.parquet".into(),
        "modal_spectrum.parquet".into(),
    ];
    if p.reference_modes.is_some() {
        v.push("frequency_shifts.parquet".into());
    }
    v
}
