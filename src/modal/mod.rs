//! Subspace modal identification with automatic mode selection
//! (METHODS §2; issue 3).
//!
//! Flow: [`ModalInput`] (plain signals, outputs and optional inputs) →
//! explicit pre-processing ([`Preprocessing`], recorded) → ONE factorisation
//! of the record ([`ssi`]: SSI-COV, SSI-DATA or PO-MOESP input–output) →
//! for every model order (default 2..=42 step 2) a realisation by truncation
//! of that factorisation → poles (f, ζ, complex shape, MPC, MPD) →
//! stabilisation flags against the previous order → physical filters →
//! clustering → modes with mean and standard deviation ([`selection`]).
//! Numerical code only; no I/O.  [`identify_event`] maps an ingested
//! [`Event`] onto a [`ModalInput`] by channel role.
//!
//! Suggested Parquet layouts (written by the sinks, not here):
//! - `stabilization.parquet`, one row per pole: `order` u32, `frequency_hz` f64,
//!   `damping_ratio` f64, `mpc` f64, `mpd_deg` f64, `complexity` f64,
//!   `stable_frequency` bool, `stable_damping` bool, `stable_shape` bool,
//!   `physical` bool, `mode` i32 (−1 = none), `shape_re` list<f64>,
//!   `shape_im` list<f64>; file metadata: method, block_rows, dt_s,
//!   output channel ids, settings JSON, preprocessing JSON, singular values.
//!   A second table (or a metadata entry) `singular_values`: `index` u32, `value` f64,
//!   and the PSD overlay ([`spectral_overlay`]): `frequency_hz` f64, `sv1` … `svL` f64.
//! - `modes.parquet`, one row per mode: `mode` u32, `frequency_hz`, `frequency_std_hz`,
//!   `damping_ratio`, `damping_std`, `mpc`, `mpd_deg`, `mean_mac`, `pole_count` u32,
//!   `order_min` u32, `order_max` u32, `manual` bool, and per output channel
//!   either list columns `shape_re`, `shape_im`, `shape_std` plus a metadata entry
//!   with the channel ids, or long format (`mode`, `channel_id`, `shape_re`, `shape_im`, `shape_std`).
//! - `mode_pairs.parquet` / `frequency_shifts.parquet` (from [`compare`]):
//!   `reference_mode` u32, `other_mode` u32, `mac` f64, `frequency_reference_hz`,
//!   `frequency_other_hz`, `relative_shift`, `shift_in_std`, `damping_reference`,
//!   `damping_other`; metadata: the two event names.

pub mod compare;
pub mod hankel;
pub mod poles;
pub mod preprocess;
pub mod selection;
pub mod spectrum;
pub mod ssi;

pub use compare::{frequency_shifts, mac_matrix, pair_modes, FrequencyShift, ModePair};
pub use poles::{mac, mpc_mpd, Pole, StabilityTolerances};
pub use preprocess::Preprocessing;
pub use selection::{ClusterSettings, Mode, PhysicalFilters};
pub use spectrum::{spectral_overlay, SpectralOverlay};

use crate::error::{Error, Location, Result};
use crate::vocab::{Event, ProcessingStep, Record, Role};

/// Subspace identification method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Covariance-driven stochastic subspace identification (output-only).
    SsiCov,
    /// Data-driven stochastic subspace identification, UPC (output-only).
    SsiData,
    /// Input–output combined deterministic–stochastic (PO-MOESP).
    Io,
}

impl Method {
    pub fn name(&self) -> &'static str {
        match self {
            Method::SsiCov => "ssi-cov",
            Method::SsiData => "ssi-data",
            Method::Io => "io",
        }
    }
    pub fn from_name(s: &str) -> Option<Method> {
        match s.to_ascii_lowercase().as_str() {
            "ssi-cov" | "cov" => Some(Method::SsiCov),
            "ssi-data" | "data" => Some(Method::SsiData),
            "io" | "n4sid" | "moesp" => Some(Method::Io),
            _ => None,
        }
    }
}

/// All settings of the modal stage (serialisable into the output metadata).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ModalSettings {
    pub method: Method,
    /// Block rows p (past = future horizon).  `None` = automatic:
    /// max(30, ⌈n_max / min(l, r)⌉ + 2).
    pub block_rows: Option<usize>,
    /// Model orders to sweep (default 2, 4, …, 42).
    pub orders: Vec<usize>,
    /// Reference output channels (indices into the outputs) for SSI-COV/DATA;
    /// `None` = all outputs.
    pub reference_channels: Option<Vec<usize>>,
    pub preprocessing: Preprocessing,
    pub stability: StabilityTolerances,
    pub filters: PhysicalFilters,
    pub clustering: ClusterSettings,
    /// Manual override: pick these frequencies (Hz) instead of clustering.
    pub manual_frequencies_hz: Option<Vec<f64>>,
    /// Relative half-width of the manual pick window (default 5 %).
    pub manual_band: f64,
}

impl Default for ModalSettings {
    fn default() -> Self {
        ModalSettings {
            method: Method::SsiCov,
            block_rows: None,
            orders: (2..=42).step_by(2).collect(),
            reference_channels: None,
            preprocessing: Preprocessing::default(),
            stability: StabilityTolerances::default(),
            filters: PhysicalFilters::default(),
            clustering: ClusterSettings::default(),
            manual_frequencies_hz: None,
            manual_band: 0.05,
        }
    }
}

/// Signals to identify: equal-length channels sampled at `dt`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ModalInput {
    pub dt: f64,
    pub output_ids: Vec<String>,
    /// Response channels (mode shapes are given at these).
    pub outputs: Vec<Vec<f64>>,
    pub input_ids: Vec<String>,
    /// Excitation channels (base motion), used by [`Method::Io`] only.
    pub inputs: Vec<Vec<f64>>,
    /// Where each channel came from (same order as ids: outputs then inputs),
    /// used to name channels in errors; may be empty.
    pub locations: Vec<Location>,
}

/// Everything the modal stage found.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalResult {
    pub method: Method,
    pub block_rows: usize,
    /// Sampling interval after pre-processing, s.
    pub dt: f64,
    pub output_ids: Vec<String>,
    pub input_ids: Vec<String>,
    /// Orders actually realised (those above the subspace dimension are skipped).
    pub orders: Vec<usize>,
    /// Singular values of the factorised matrix (order-selection plot).
    pub singular_values: Vec<f64>,
    /// Every pole of every order (stabilisation diagram), by order then frequency.
    pub poles: Vec<Pole>,
    /// Selected modes, ascending frequency.
    pub modes: Vec<Mode>,
    /// Pre-processing applied, in order.
    pub preprocessing: Vec<ProcessingStep>,
    pub notes: Vec<String>,
}

fn channel_location(input: &ModalInput, index: usize, id: &str) -> Location {
    input
        .locations
        .get(index)
        .cloned()
        .unwrap_or_else(|| Location::file("modal input"))
        .with_channel(id)
}

/// Checks the signals: enough channels, equal lengths, finite and non-constant.
fn validate(input: &ModalInput, method: Method) -> Result<()> {
    if !(input.dt.is_finite() && input.dt > 0.0) {
        return Err(Error::usage(format!(
            "modal: sampling interval must be positive, got {}",
            input.dt
        )));
    }
    if input.output_ids.len() != input.outputs.len() || input.input_ids.len() != input.inputs.len()
    {
        return Err(Error::usage(
            "modal: channel ids and signals differ in number",
        ));
    }
    match method {
        Method::Io => {
            if input.inputs.is_empty() {
                return Err(Error::usage(
                    "modal: input–output identification needs at least one base channel (role = input); none found — use ssi-cov or ssi-data, or mark the base channels as inputs",
                ));
            }
            if input.outputs.is_empty() {
                return Err(Error::usage("modal: no response channel (role = output)"));
            }
        }
        _ => {
            if input.outputs.len() < 2 {
                return Err(Error::usage(format!(
                    "modal: output-only identification needs at least two response channels (got {}); a single channel gives no mode shape",
                    input.outputs.len()
                )));
            }
        }
    }
    let all = input
        .outputs
        .iter()
        .zip(&input.output_ids)
        .chain(input.inputs.iter().zip(&input.input_ids));
    let n0 = input.outputs.first().map(|s| s.len()).unwrap_or(0);
    for (index, (signal, id)) in all.enumerate() {
        let loc = || channel_location(input, index, id);
        if signal.len() != n0 {
            return Err(Error::input(
                loc(),
                format!(
                    "has {} samples, other channels {n0}: trim or align first",
                    signal.len()
                ),
            ));
        }
        if let Some(pos) = signal.iter().position(|v| !v.is_finite()) {
            return Err(Error::input(
                loc(),
                format!("non-finite sample at index {pos}"),
            ));
        }
        let first = signal.first().copied().unwrap_or(0.0);
        if signal.iter().all(|&v| v == first) {
            return Err(Error::input(loc(), "is constant: carries no response"));
        }
    }
    Ok(())
}

/// Runs the identification on plain signals.
pub fn identify(input: &ModalInput, settings: &ModalSettings) -> Result<ModalResult> {
    validate(input, settings.method)?;
    // Pre-processing on outputs and inputs together (same filter for both).
    let mut all: Vec<Vec<f64>> = input.outputs.clone();
    let use_inputs = settings.method == Method::Io;
    if use_inputs {
        all.extend(input.inputs.iter().cloned());
    }
    let (processed, dt, steps) = preprocess::apply(&all, input.dt, &settings.preprocessing);
    let l = input.outputs.len();
    let outputs: Vec<&[f64]> = processed[..l].iter().map(|v| v.as_slice()).collect();
    let inputs: Vec<&[f64]> = processed[l..].iter().map(|v| v.as_slice()).collect();
    let n_samples = outputs[0].len();

    let refs: Vec<usize> = match &settings.reference_channels {
        Some(r) => {
            if r.is_empty() || r.iter().any(|&i| i >= l) {
                return Err(Error::usage(format!(
                    "modal: reference channels {r:?} must be indices below {l}"
                )));
            }
            r.clone()
        }
        None => (0..l).collect(),
    };
    let mut orders: Vec<usize> = settings.orders.iter().copied().filter(|&n| n > 0).collect();
    orders.sort_unstable();
    orders.dedup();
    let max_order = *orders
        .last()
        .ok_or_else(|| Error::usage("modal: no model order to sweep"))?;
    let columns_per_block = match settings.method {
        Method::Io => l,
        _ => l.min(refs.len()),
    };
    let block_rows = settings
        .block_rows
        .unwrap_or_else(|| 30.max(max_order.div_ceil(columns_per_block) + 2));
    if block_rows < 2 {
        return Err(Error::usage("modal: block rows must be at least 2"));
    }
    // Hankel rows of the largest factorisation, and the columns they need.
    let hankel_rows = match settings.method {
        Method::SsiCov => 0,
        Method::SsiData => block_rows * (refs.len() + l),
        Method::Io => 2 * block_rows * (inputs.len() + l),
    };
    let needed = 2 * block_rows + (2 * hankel_rows).max(10 * block_rows);
    if n_samples < needed {
        return Err(Error::input(
            channel_location(input, 0, &input.output_ids[0]),
            format!(
                "too few samples for {block_rows} block rows: {n_samples} after pre-processing, need at least {needed}; reduce block_rows or decimation"
            ),
        ));
    }
    let subspace = match settings.method {
        Method::SsiCov => ssi::ssi_cov(&outputs, &refs, block_rows)?,
        Method::SsiData => ssi::ssi_data(&outputs, &refs, block_rows)?,
        Method::Io => ssi::po_moesp(&outputs, &inputs, block_rows)?,
    };
    let mut notes = Vec::new();
    let nyquist = 0.5 / dt;
    let mut poles: Vec<Pole> = Vec::new();
    let mut realised = Vec::new();
    let mut previous_range: Option<(usize, usize)> = None;
    for &n in &orders {
        if n > subspace.max_order() {
            notes.push(format!(
                "order {n} skipped: above the subspace dimension {}",
                subspace.max_order()
            ));
            continue;
        }
        let (a, c) = subspace.realise(n)?;
        let eig = ssi::eigen_structure(a.as_ref(), c.as_ref())?;
        let mut current = poles::poles_of_order(n, eig, dt);
        for p in current.iter_mut() {
            p.physical = settings.filters.passes(p, nyquist);
        }
        if let Some((start, end)) = previous_range {
            poles::flag_stability(&mut current, &poles[start..end], &settings.stability);
        }
        let start = poles.len();
        poles.extend(current);
        previous_range = Some((start, poles.len()));
        realised.push(n);
    }
    let modes = match &settings.manual_frequencies_hz {
        Some(f) => selection::select_manual(&mut poles, f, settings.manual_band)?,
        None => selection::select_automatic(&mut poles, realised.len(), &settings.clustering),
    };
    let mut preprocessing = steps;
    preprocessing.push(ProcessingStep {
        step: "band_limits".into(),
        channels: Vec::new(),
        params: serde_json::json!({
            "frequency_min_hz": settings.filters.frequency_min_hz.unwrap_or(0.0),
            "frequency_max_hz": settings.filters.frequency_max_hz.unwrap_or(0.95 * nyquist),
            "applies_to": "identified poles",
        }),
    });
    Ok(ModalResult {
        method: settings.method,
        block_rows,
        dt,
        output_ids: input.output_ids.clone(),
        input_ids: if use_inputs {
            input.input_ids.clone()
        } else {
            Vec::new()
        },
        orders: realised,
        singular_values: subspace.singular_values.clone(),
        poles,
        modes,
        preprocessing,
        notes,
    })
}

fn location_of(record: &Record) -> Location {
    let mut l = Location::file(&record.channel.source.file);
    l.member = record.channel.source.member.clone();
    l
}

/// Builds the identification input from an event by channel role: `output`
/// channels are responses, `input` channels the base motion.  Channels of
/// unknown role are left out (listed in the returned notes).  All channels
/// used must share one sampling rate; they are cut to the shortest length
/// (noted).  Values are used as stored: convert units and normalise
/// orientation beforehand (METHODS §0).  Floor motions formed by the
/// rigid-floor combination are left out: they are linear combinations of
/// the sensor channels, which carry the shapes (torsion included).
pub fn input_from_event(event: &Event) -> Result<(ModalInput, Vec<String>)> {
    let mut notes = Vec::new();
    let sensors = || {
        event
            .records
            .iter()
            .filter(|r| !r.channel.is_floor_motion())
    };
    let outputs: Vec<&Record> = sensors()
        .filter(|r| r.channel.role == Role::Output)
        .collect();
    let inputs: Vec<&Record> = sensors()
        .filter(|r| r.channel.role == Role::Input)
        .collect();
    for r in event
        .records
        .iter()
        .filter(|r| r.channel.role == Role::Unknown)
    {
        notes.push(format!("channel {} left out: role unknown", r.channel.id));
    }
    let first = outputs.first().or(inputs.first()).ok_or_else(|| {
        Error::usage(format!(
            "modal: event {} has no channel with role input or output",
            event.name
        ))
    })?;
    let rate = first.channel.sampling_rate_hz;
    for r in outputs.iter().chain(&inputs) {
        if (r.channel.sampling_rate_hz - rate).abs() > 1e-9 * rate {
            return Err(Error::input(
                location_of(r).with_channel(&r.channel.id),
                format!(
                    "sampled at {} Hz, channel {} at {rate} Hz: resample first",
                    r.channel.sampling_rate_hz, first.channel.id
                ),
            ));
        }
    }
    let n = outputs
        .iter()
        .chain(&inputs)
        .map(|r| r.samples.len())
        .min()
        .unwrap_or(0);
    if outputs.iter().chain(&inputs).any(|r| r.samples.len() != n) {
        notes.push(format!("channels cut to the shortest length, {n} samples"));
    }
    let mut locations: Vec<Location> = outputs.iter().map(|r| location_of(r)).collect();
    locations.extend(inputs.iter().map(|r| location_of(r)));
    Ok((
        ModalInput {
            dt: 1.0 / rate,
            output_ids: outputs.iter().map(|r| r.channel.id.clone()).collect(),
            outputs: outputs.iter().map(|r| r.samples[..n].to_vec()).collect(),
            input_ids: inputs.iter().map(|r| r.channel.id.clone()).collect(),
            inputs: inputs.iter().map(|r| r.samples[..n].to_vec()).collect(),
            locations,
        },
        notes,
    ))
}

/// Identifies an event: input–output when `settings.method` is `Io`,
/// output-only otherwise (the pipeline picks `Io` when the event has base channels).
pub fn identify_event(event: &Event, settings: &ModalSettings) -> Result<ModalResult> {
    let (input, notes) = input_from_event(event)?;
    let mut result = identify(&input, settings)?;
    result.notes.splice(0..0, notes);
    Ok(result)
}
