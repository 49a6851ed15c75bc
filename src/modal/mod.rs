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
//! - `stabilization/stabilization.parquet`, one row per pole: `order` u32, `frequency_hz` f64,
//!   `damping_ratio` f64, `mpc` f64, `mpd_deg` f64, `complexity` f64,
//!   `stable_frequency` bool, `stable_damping` bool, `stable_shape` bool,
//!   `physical` bool, `mode` i32 (−1 = none), `shape_re` list<f64>,
//!   `shape_im` list<f64>; file metadata: method, block_rows, dt_s,
//!   output channel ids, settings JSON, preprocessing JSON, singular values.
//!   A second table (or a metadata entry) `singular_values`: `index` u32, `value` f64,
//!   and the PSD overlay ([`spectral_overlay`]): `frequency_hz` f64, `sv1` … `svL` f64.
//! - `modes/modes.parquet`, one row per mode: `mode` u32, `frequency_hz`, `frequency_std_hz`,
//!   `damping_ratio`, `damping_std`, `mpc`, `mpd_deg`, `mean_mac`, `pole_count` u32,
//!   `order_min` u32, `order_max` u32, `manual` bool, and per output channel
//!   either list columns `shape_re`, `shape_im`, `shape_std` plus a metadata entry
//!   with the channel ids, or long format (`mode`, `channel_id`, `shape_re`, `shape_im`, `shape_std`).
//! - `frequency_shifts/frequency_shifts.parquet` (from [`compare`]): the pre/post comparison
//!   against a reference event (docs/formats.md).

pub mod apparent;
pub mod change_test;
pub mod compare;
pub mod direction;
pub mod fallback;
pub mod global;
pub mod hankel;
pub mod params;
pub mod poles;
pub mod preprocess;
pub mod selection;
pub mod spectrum;
pub mod ssi;
pub mod uncertainty;

pub use compare::{
    compare_events, mac_matrix, pair_modes, track_across_events, Comparison, FrequencyShift,
    ModePair, ModeSet, ModeTrack, PairingBasis, PairingSettings, TrackMember,
};
pub use fallback::{identify_event_or_output_only, MIN_AMPLIFICATION};
pub use poles::{mac, mpc_mpd, Pole, StabilityTolerances};
pub use preprocess::Preprocessing;
pub use selection::{Mode, PhysicalFilters, RejectedColumn, Selection, SelectionSettings};
pub use spectrum::{spectral_overlay, structural_amplification, SpectralOverlay};

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

/// Default band of interest when neither the settings nor the structure
/// say otherwise, Hz (issue 13).
pub const DEFAULT_BAND_HZ: [f64; 2] = [0.2, 20.0];
/// Automatic decimation keeps the sampling rate at least this multiple of
/// the top of the band (issue 13: ≈ 4–5 ×).
pub const SAMPLES_PER_TOP_PERIOD: f64 = 4.0;
/// Automatic block rows: p · l ≤ this, l the output channels (the rows of
/// the extended observability matrix whose SVD fixes the order; inputs of
/// input–output identification only enter the projection and do not
/// count).  150 is the former default of 30 block rows on the 5-storey
/// output-only cases, where 36 already gave one persistent spurious column
/// (and 60 a sixth "mode" at 12.97 Hz next to the true 12.43 Hz on a seed).
/// Counting the inputs too (the former rule) left the CESMD bridges a
/// horizon of 0.10–0.15 s, below the 0.24 s period of the Painter St.
/// transverse mode; counting outputs only gives it 0.37 s.
pub const MAX_BLOCK_WIDTH: usize = 150;
/// SSI-COV's automatic block rows may exceed [`MAX_BLOCK_WIDTH`] to reach
/// half a period of the record's lowest clear spectral peak, up to p · l ≤
/// this: with 8 outputs the cost bound alone left a 1-Hz building a horizon
/// of 0.18 s at 100 Hz and no pole column for its first two modes (issue 13,
/// `modal_synthetic::weak_torsion_ambient`).  Output-only covariances need
/// the horizon (the lags must span the modes' periods) and stay cheap (an
/// SVD of p·l × p·l); the data-driven methods factorise a matrix of
/// 2 p (r + l) or 2 p (m + l) rows by the whole record, whose cost grows
/// with the square of p (40 block rows made the 14-channel event of
/// `benches/modal.rs` 12 × slower), and `io` takes the dynamics from the
/// measured input rather than from long output lags: they keep the cost
/// bound.
pub const MAX_HORIZON_BLOCK_WIDTH: usize = 480;
/// Automatic model orders: 2, 4, … up to this (thesis: 42), or what the
/// subspace supports …
pub const MAX_AUTO_ORDER: usize = 42;
/// … or, for SSI-COV with many outputs, up to this many per output
/// channel: a building recorded in plan has three modes per floor in its
/// band, and a mode's pole column only starts once the order can hold the
/// modes below it (the torsion of a 5-storey building in plan appears at
/// order 36).  Not for the data-driven methods: on the 14-channel event of
/// `benches/modal.rs`, `io` with orders to 96 took 5–7 × longer and found
/// no further mode …
pub const AUTO_ORDERS_PER_OUTPUT: usize = 8;
/// … and never above this.
pub const MAX_AUTO_ORDER_CAP: usize = 120;
/// Most rows of an explicit block rows' Hankel matrices (block rows × the
/// rows of one block: outputs for `ssi-cov`, references + outputs for
/// `ssi-data`, 2 × (inputs + outputs) for `io`): their Gram matrix, rows²
/// values, stays ≤ 128 MiB and its cost (rows² × samples) bounded.
pub const MAX_HANKEL_ROWS: usize = 4096;

/// All settings of the modal stage (serialisable into the output metadata).
/// `None` fields are resolved from the record by [`plan`] (issue 13).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ModalSettings {
    pub method: Method,
    /// Band of interest [lo, hi], Hz; `None` = [`DEFAULT_BAND_HZ`] (the modal
    /// stage derives it from the structure when the manifest gives storeys).
    /// Sets the automatic decimation, block rows and the poles' band filter.
    #[serde(default)]
    pub band_hz: Option<[f64; 2]>,
    /// The structure's estimated fundamental frequency, Hz
    /// ([`fundamental_estimate`]): the lowest frequency of interest of the
    /// block rows' horizon when the records show no clear spectral peak.
    #[serde(default)]
    pub fundamental_estimate_hz: Option<f64>,
    /// Why `band_hz` is what it is (stated, or the structure's estimate);
    /// goes into the notes.
    #[serde(default)]
    pub band_basis: Option<String>,
    /// Block rows p (past = future horizon).  `None` = automatic: half a
    /// period of the band's low end, bounded by the data (enough Hankel
    /// columns) and by [`MAX_BLOCK_WIDTH`], never below what the highest
    /// order needs when the data allow it.
    pub block_rows: Option<usize>,
    /// Model orders to sweep; `None` = 2, 4, … up to [`MAX_AUTO_ORDER`] or
    /// the subspace dimension.
    pub orders: Option<Vec<usize>>,
    /// Reference output channels (indices into the outputs) for SSI-COV/DATA;
    /// `None` = all outputs.
    pub reference_channels: Option<Vec<usize>>,
    pub preprocessing: Preprocessing,
    pub stability: StabilityTolerances,
    pub filters: PhysicalFilters,
    pub selection: SelectionSettings,
    /// Manual override: pick these frequencies (Hz) instead of the automatic selection.
    pub manual_frequencies_hz: Option<Vec<f64>>,
    /// Relative half-width of the manual pick window (default 5 %).
    pub manual_band: f64,
    /// Blocks the record is cut into for the data-driven σ of every mode
    /// ([`uncertainty`]); `None` = automatic ([`uncertainty::auto_blocks`]),
    /// `Some(0)` = not computed.
    #[serde(default)]
    pub uncertainty_blocks: Option<usize>,
}

impl Default for ModalSettings {
    fn default() -> Self {
        ModalSettings {
            method: Method::SsiCov,
            band_hz: None,
            fundamental_estimate_hz: None,
            band_basis: None,
            block_rows: None,
            orders: None,
            reference_channels: None,
            preprocessing: Preprocessing::default(),
            stability: StabilityTolerances::default(),
            filters: PhysicalFilters::default(),
            selection: SelectionSettings::default(),
            manual_frequencies_hz: None,
            manual_band: 0.05,
            uncertainty_blocks: None,
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
    /// Direction label of each output (`X`, `Y`, [`direction::VERTICAL`], an
    /// azimuth label, empty = unknown); may be empty.  Gives the modes' labels.
    pub output_directions: Vec<String>,
    /// Level (or location group) of each output, for the torsion label; may be empty.
    pub output_groups: Vec<String>,
}

/// Everything the modal stage found.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalResult {
    pub method: Method,
    pub block_rows: usize,
    /// Band of interest used, Hz.
    pub band_hz: [f64; 2],
    /// Decimation factor applied.
    pub decimation: usize,
    /// Sampling interval after pre-processing, s.
    pub dt: f64,
    pub output_ids: Vec<String>,
    pub input_ids: Vec<String>,
    /// Direction label per output channel (empty entries = unknown).
    pub output_directions: Vec<String>,
    /// Orders actually realised (those above the subspace dimension are skipped).
    pub orders: Vec<usize>,
    /// Singular values of the factorised matrix (order-selection plot).
    pub singular_values: Vec<f64>,
    /// Every pole of every order (stabilisation diagram), by order then frequency.
    pub poles: Vec<Pole>,
    /// Selected modes, ascending frequency.
    pub modes: Vec<Mode>,
    /// Pole columns that looked physical but were not promoted, and why
    /// (local modes and near-duplicates among them, [`global`]).
    pub rejected: Vec<RejectedColumn>,
    /// Modes whose shape lives on one channel ([`global`]): listed here,
    /// never among `modes`.
    pub local_modes: Vec<global::LocalMode>,
    /// Pre-processing applied, in order.
    pub preprocessing: Vec<ProcessingStep>,
    /// How the settings were resolved and what was left out.
    pub notes: Vec<String>,
    /// Why no mode, or fewer modes than the stable columns suggest, were
    /// selected (empty when nothing is wrong).
    pub warnings: Vec<String>,
}

impl ModalResult {
    /// Withdraws the modes with a reason in `reasons` (one entry per mode):
    /// each is reported as a rejected column with that reason, and the
    /// poles behind the modes kept are re-numbered.
    pub fn withdraw_modes(&mut self, reasons: &[Option<String>]) {
        let mut renumber = Vec::with_capacity(self.modes.len());
        let mut kept = Vec::new();
        for (mode, reason) in std::mem::take(&mut self.modes).into_iter().zip(reasons) {
            match reason {
                None => {
                    renumber.push(Some(kept.len()));
                    kept.push(mode);
                }
                Some(reason) => {
                    renumber.push(None);
                    self.rejected.push(selection::RejectedColumn {
                        frequency_hz: mode.frequency_hz,
                        damping_ratio: mode.damping_ratio,
                        poles: mode.pole_count,
                        order_min: mode.order_min,
                        order_max: mode.order_max,
                        reason: reason.clone(),
                    });
                }
            }
        }
        self.modes = kept;
        for pole in self.poles.iter_mut() {
            pole.mode = pole.mode.and_then(|m| renumber.get(m).copied().flatten());
        }
        self.rejected
            .sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
    }
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
    // The channels' own conditions are data problems (exit 1) naming the
    // file and channel; only a method the record cannot serve stays usage.
    let first = || match input.output_ids.first() {
        Some(id) => channel_location(input, 0, id),
        None => input
            .locations
            .first()
            .cloned()
            .unwrap_or_else(|| Location::file("modal input")),
    };
    if !(input.dt.is_finite() && input.dt > 0.0) {
        return Err(Error::input(
            first(),
            format!(
                "modal: sampling interval must be positive, got {}",
                input.dt
            ),
        ));
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
                return Err(Error::input(
                    first(),
                    "modal: no response channel (role = output)",
                ));
            }
        }
        _ => {
            if input.outputs.len() < 2 {
                return Err(Error::input(first(), format!(
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

/// Empirical fundamental frequency of a building, Hz, and how it was
/// estimated (issue 31), from what the structure states:
/// - a height H (`height_m`, else the sum of `storey_heights_m`): EN 1998-1
///   (Eurocode 8) §4.3.3.2.2 Eq. (4.6), T₁ = C_t · H^(3/4), H in m, with
///   C_t = 0.085 for steel moment frames (HAZUS S1 or a type naming steel),
///   0.075 for reinforced-concrete moment frames (C1, or naming concrete/RC)
///   and 0.050 for every other stated type; 0.075 when the type is unknown
///   (the band's margin of a factor 3 each way covers 0.050–0.085);
/// - else a storey count N: T₁ ≈ 0.1 · N s (the rule of thumb of ASCE 7-16
///   Eq. 12.8-8 for moment frames).
///
/// `None` without either (bridges, or a building that states neither).
pub fn fundamental_estimate(structure: &crate::vocab::Structure) -> Option<(f64, String)> {
    let summed: f64 = structure.storey_heights_m.iter().sum();
    let height = structure
        .height_m
        .filter(|h| h.is_finite() && *h > 0.0)
        .or((summed.is_finite() && summed > 0.0).then_some(summed));
    if let Some(h) = height {
        let kind = structure
            .building_type
            .as_deref()
            .unwrap_or("")
            .to_ascii_lowercase();
        let (ct, what) = if kind.is_empty() {
            (0.075, "type unknown: C_t = 0.075")
        } else if kind == "s1" || kind.contains("steel") {
            (0.085, "steel moment frame: C_t = 0.085")
        } else if kind == "c1" || kind.contains("concrete") || kind.starts_with("rc") {
            (0.075, "concrete moment frame: C_t = 0.075")
        } else {
            (0.05, "other type: C_t = 0.050")
        };
        let period = ct * h.powf(0.75);
        return Some((
            1.0 / period,
            format!("EC8 Eq. 4.6 T1 = C_t·H^0.75 = {period:.3} s (H = {h:.1} m, {what})"),
        ));
    }
    let storeys = structure.storeys.filter(|&n| n > 0)?;
    let period = 0.1 * storeys as f64;
    Some((
        1.0 / period,
        format!("T1 ≈ 0.1·N = {period:.2} s (N = {storeys} storeys, ASCE 7-16 Eq. 12.8-8)"),
    ))
}

/// Margin of the band of interest around an estimated fundamental f₁: from
/// f₁ / [`BAND_MARGIN_BELOW`] (the empirical periods scatter by a factor ≈ 2
/// about the measured ones) …
pub const BAND_MARGIN_BELOW: f64 = 3.0;
/// … to [`BAND_MARGIN_ABOVE`] · f₁ (the second and third modes of each
/// direction and torsion), never above the top of [`DEFAULT_BAND_HZ`] (the
/// shipped conditioning low-passes at 20 Hz).
pub const BAND_MARGIN_ABOVE: f64 = 10.0;

/// Band of interest from an estimated fundamental `f1_hz` (issue 31):
/// [f₁/3, min(10 f₁, 20 Hz)].
pub fn band_around(f1_hz: f64) -> [f64; 2] {
    let lo = f1_hz / BAND_MARGIN_BELOW;
    let hi = (BAND_MARGIN_ABOVE * f1_hz)
        .min(DEFAULT_BAND_HZ[1])
        .max(2.0 * lo);
    [lo, hi]
}

/// Band of interest from a structure's height or storey count
/// ([`fundamental_estimate`], [`band_around`]); `None` when neither is known.
pub fn band_for_structure(structure: &crate::vocab::Structure) -> Option<[f64; 2]> {
    fundamental_estimate(structure).map(|(f1, _)| band_around(f1))
}

/// Lowest frequency searched for a spectral peak when the structure says
/// nothing of its height, Hz: a 60-storey building's fundamental (≈ 0.15 Hz)
/// lies above it; below it an accelerogram's spectrum is baseline noise.
pub const SPECTRAL_SEARCH_LOW_HZ: f64 = 0.1;

/// The band of interest the modal stage hands to [`plan`], and why:
/// `stated` (the `band_hz` param); else around the structure's estimated
/// fundamental ([`fundamental_estimate`], [`band_around`]); else, for a
/// bridge ([`is_bridge`]), [`DEFAULT_BAND_HZ`]; else `None` (the plan takes
/// it from the records' spectra, [`band_from_spectra`]).
pub fn band_of_structure(
    stated: Option<[f64; 2]>,
    structure: Option<&crate::vocab::Structure>,
) -> (Option<[f64; 2]>, Option<String>) {
    if let Some(band) = stated {
        return (Some(band), Some("stated (band_hz)".to_string()));
    }
    if let Some((f1, why)) = structure.and_then(fundamental_estimate) {
        return (
            Some(band_around(f1)),
            Some(format!(
                "f1/3 … min(10·f1, 20 Hz) around the structure's estimated fundamental f1 = {f1:.3} Hz: {why}"
            )),
        );
    }
    if is_bridge(structure) {
        return (
            Some(DEFAULT_BAND_HZ),
            Some("default band: a bridge (structure.kind), whose records' spectra are not searched below it; state band_hz for a long-span bridge".to_string()),
        );
    }
    (None, None)
}

/// Whether the structure is stated or inferred to be a bridge: its band
/// stays [`DEFAULT_BAND_HZ`] (no spectral search below it).  A bridge's
/// records are short and their lowest spectral peaks below 0.5 Hz are the
/// ground motion's (Meloland 1979: 0.35 Hz); the long-span bridges whose
/// modes lie lower are stated with `band_hz`.
pub fn is_bridge(structure: Option<&crate::vocab::Structure>) -> bool {
    structure
        .and_then(|s| s.kind.as_deref())
        .is_some_and(|k| k.eq_ignore_ascii_case("bridge"))
}

/// Cycles of a spectral peak a segment must hold for the peak to count
/// ([`lowest_peak_of_records`]): 4 (a 40-s segment resolves 0.1 Hz).
pub const MIN_CYCLES_PER_SEGMENT: f64 = 4.0;

/// The lowest clear peak of the records' averaged output spectrum
/// ([`spectrum::lowest_spectral_peak_hz`]) between
/// [`SPECTRAL_SEARCH_LOW_HZ`] and the top of `band`: segments of 40 s (a
/// resolution of 0.025 Hz) or a quarter of the record.
pub fn lowest_peak_of_records<S: AsRef<[f64]>>(outputs: &[S], dt: f64, top_hz: f64) -> Option<f64> {
    let n = outputs.iter().map(|s| s.as_ref().len()).min().unwrap_or(0);
    let seg = ((40.0 / dt).ceil() as usize).min(n / 4);
    // A peak needs a few cycles in a segment to be told from the spectrum's
    // low-frequency end (its resolution is 1/T): a 22.8-s bridge record's
    // 5.7-s segments put a ground-motion "peak" at 0.35 Hz.
    let low = SPECTRAL_SEARCH_LOW_HZ.max(MIN_CYCLES_PER_SEGMENT / (seg as f64 * dt));
    if !(low < top_hz) {
        return None;
    }
    let owned: Vec<Vec<f64>> = outputs.iter().map(|s| s.as_ref().to_vec()).collect();
    spectrum::lowest_spectral_peak_hz(&owned, dt, seg, [low, top_hz])
}

/// The band of interest of a record whose structure states no height
/// (issue 31): [`DEFAULT_BAND_HZ`], its low end lowered to f_p / 3 when the
/// records' lowest clear spectral peak f_p ([`lowest_peak_of_records`]) lies
/// below 3 × 0.2 Hz (a tall building).  Returns the band and the peak.
pub fn band_from_spectra<S: AsRef<[f64]>>(outputs: &[S], dt: f64) -> ([f64; 2], Option<f64>) {
    let top = DEFAULT_BAND_HZ[1].min(0.4 / dt);
    let peak = lowest_peak_of_records(outputs, dt, top);
    let lo = peak.map_or(DEFAULT_BAND_HZ[0], |f| {
        (f / BAND_MARGIN_BELOW).min(DEFAULT_BAND_HZ[0])
    });
    ([lo, DEFAULT_BAND_HZ[1]], peak)
}

/// How far below a MEASURED spectral peak f_p the high-pass corner may sit:
/// f_p / 2.  The structure's estimate needs the wide margin of
/// [`BAND_MARGIN_BELOW`] (empirical periods scatter by a factor ≈ 2); a peak
/// read off the records does not, and the shipped 4th-order zero-phase
/// Butterworth high-pass at f_p / 2 passes f_p with gain 1/(1 + 2⁻⁸) = 0.996
/// (two passes).  A wider margin moved the corner of bridges whose lowest
/// peak is near 1 Hz (Trinidad 1980: 0.5 → 0.365 Hz) and let the ground
/// motion's long periods into their identification.
pub const FILTER_MARGIN_BELOW_PEAK: f64 = 2.0;

/// The low edge of the band of interest of `event` before any filtering
/// (issue 31), and why: around the structure's estimated fundamental
/// ([`fundamental_estimate`], [`band_around`]), else f_p / 2 with f_p the
/// lowest clear spectral peak ([`lowest_peak_of_records`]) of its horizontal
/// response channels (role output; those at the most common sampling rate,
/// cut to the shortest).  `None` when neither is known.  The condition
/// stage's `high_pass = "auto"` keeps its high-pass corner at or below it,
/// so that the conditioning never cuts inside the band identification uses.
pub fn band_low_edge_of_event(event: &Event) -> Result<Option<(f64, String)>> {
    if let Some((f1, why)) = event.structure.as_ref().and_then(fundamental_estimate) {
        let lo = band_around(f1)[0];
        return Ok(Some((
            lo,
            format!("f1/3 of the structure's estimated fundamental {f1:.3} Hz ({why})"),
        )));
    }
    if is_bridge(event.structure.as_ref()) {
        return Ok(None);
    }
    let outputs: Vec<&Record> = event
        .records
        .iter()
        .filter(|r| {
            !r.channel.is_floor_motion()
                && r.channel.role == Role::Output
                && !is_vertical(&r.channel)
        })
        .collect();
    let Some(rate) = outputs.first().map(|r| r.channel.sampling_rate_hz) else {
        return Ok(None);
    };
    let same: Vec<Vec<f64>> = outputs
        .iter()
        .filter(|r| r.channel.sampling_rate_hz == rate)
        .map(|r| Ok(r.samples.get()?.into_owned()))
        .collect::<Result<_>>()?;
    let n = same.iter().map(Vec::len).min().unwrap_or(0);
    let cut: Vec<&[f64]> = same.iter().map(|s| &s[..n]).collect();
    let peak = lowest_peak_of_records(&cut, 1.0 / rate, DEFAULT_BAND_HZ[1].min(0.4 * rate));
    Ok(peak.map(|f| {
        (
            f / FILTER_MARGIN_BELOW_PEAK,
            format!("f/2 of the records' lowest clear spectral peak {f:.3} Hz (no storey count or height stated)"),
        )
    }))
}

/// Hankel horizon of the automatic block rows: this many periods of the
/// lowest frequency of interest (issue 31: at least one — 1.5 biased the 600-s 5-storey ambient
/// records by 0.9 % and gave a sixth mode; the 7-storey
/// building's ≈ 1.04 Hz fundamental was missed with 0.18 s).
pub const HORIZON_PERIODS: f64 = 1.0;

/// SSI-COV keeps its issue-13 horizon of half a period of the lowest
/// frequency of interest: its covariance lags reach twice the horizon (the
/// future block rows), and one period biased the 600-s 5-storey ambient
/// records (`modal::ambient_*`) by 0.5 % and gave a sixth mode.
/// SSI-DATA keeps its cost bound alone (0): one period biased the same
/// records by 0.5 % — left open (issue 31).
fn horizon_periods(method: Method) -> f64 {
    match method {
        Method::SsiCov => 0.5,
        Method::SsiData => 0.0,
        Method::Io => HORIZON_PERIODS,
    }
}

/// The settings resolved for one record (issue 13): what [`identify`] will do.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// Band of interest, Hz (clipped to the anti-alias pass band).
    pub band_hz: [f64; 2],
    pub decimation: usize,
    pub block_rows: usize,
    pub orders: Vec<usize>,
    /// Samples per channel after decimation.
    pub samples: usize,
    /// How each value was chosen.
    pub notes: Vec<String>,
}

/// Rows of the factorised matrix per block row, and the fewest samples
/// `p` block rows need (enough Hankel columns for a well-posed LQ).
fn rows_and_samples_needed(
    method: Method,
    l: usize,
    r: usize,
    m: usize,
    p: usize,
) -> (usize, usize) {
    match method {
        Method::SsiCov => (l, 12 * p),
        Method::SsiData => (r + l, 2 * p + (2 * p * (r + l)).max(10 * p)),
        Method::Io => (2 * (m + l), 2 * p + (4 * p * (m + l)).max(10 * p)),
    }
}

/// Resolves band, decimation, block rows and orders for `input` (issue 13).
/// Bad explicit settings are usage errors; the automatic values never
/// refuse a record that a smaller value would accept.
pub fn plan(input: &ModalInput, settings: &ModalSettings) -> Result<Plan> {
    let mut notes = Vec::new();
    let fs0 = 1.0 / input.dt;
    let n0 = input.outputs.first().map_or(0, |s| s.len());
    let (band, spectral_peak) = match settings.band_hz {
        Some(band) => {
            notes.push(format!(
                "band of interest {:.3}–{:.3} Hz: {}",
                band[0],
                band[1],
                settings.band_basis.as_deref().unwrap_or("stated")
            ));
            (band, None)
        }
        None => {
            let (band, peak) = band_from_spectra(&input.outputs, input.dt);
            notes.push(match peak {
                Some(f) => format!(
                    "band of interest {:.3}–{:.3} Hz: no storey count or height stated; the records' lowest clear spectral peak is {f:.3} Hz (band low end min(0.2, f/3))",
                    band[0], band[1]
                ),
                None => format!(
                    "band of interest {:.3}–{:.3} Hz: no storey count or height stated and no clear spectral peak (default)",
                    band[0], band[1]
                ),
            });
            (band, peak)
        }
    };
    let [lo, hi] = band;
    if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi > lo) {
        return Err(Error::usage(format!(
            "modal: band [{lo}, {hi}] Hz must satisfy 0 < low < high"
        )));
    }
    // The anti-alias filter passes 80 % of the Nyquist frequency.
    let top = 0.4 * fs0;
    if lo >= top {
        return Err(Error::usage(format!(
            "modal: band low end {lo} Hz is above the usable band of a {fs0} Hz record (< {top} Hz)"
        )));
    }
    let hi = if hi > top {
        notes.push(format!(
            "band top {hi} Hz above 80 % of the record's Nyquist frequency: {top} Hz used"
        ));
        top
    } else {
        hi
    };
    let l = input.outputs.len();
    // The lowest frequency of interest: the lowest clear peak of the
    // records' spectrum in the band, or the structure's estimated
    // fundamental, whichever is lower (issue 31).
    let seg = ((2.0 * fs0 / lo).ceil() as usize).min(n0 / 4);
    let lowest_peak = spectrum::lowest_spectral_peak_hz(&input.outputs, input.dt, seg, [lo, hi])
        .or(spectral_peak.filter(|f| (lo..=hi).contains(f)));
    let lowest_of_interest = match (lowest_peak, settings.fundamental_estimate_hz) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    };
    let decimation = match settings.preprocessing.decimation {
        Some(0) => return Err(Error::usage("modal: decimation must be at least 1")),
        Some(d) => d,
        None => {
            let d = ((fs0 / (SAMPLES_PER_TOP_PERIOD * hi)).floor() as usize).max(1);
            notes.push(format!(
                "decimation {d} (automatic: sampling rate {:.4} Hz ≥ {SAMPLES_PER_TOP_PERIOD} × band top {hi} Hz)",
                fs0 / d as f64
            ));
            // The horizon of HORIZON_PERIODS periods of the lowest frequency
            // of interest must fit the cost bound p · l ≤
            // MAX_HORIZON_BLOCK_WIDTH: decimate more when it does not (the
            // band top follows, below), rather than cap the horizon.
            let fits = |d: usize| {
                lowest_of_interest.is_none_or(|f| {
                    horizon_periods(settings.method) == 0.0
                        || (horizon_periods(settings.method) * fs0 / d as f64 / f).ceil() as usize
                            * l.max(1)
                            <= MAX_HORIZON_BLOCK_WIDTH
                })
            };
            // Never so far that the band's low end reaches the usable top.
            let most = ((0.4 * fs0 / (2.0 * lo)).floor() as usize).max(d);
            match (d..=most).find(|&k| fits(k)) {
                Some(k) if k > d => {
                    notes.push(format!(
                        "decimation raised to {k}: a horizon of {} period(s) of {:.3} Hz with {l} outputs must fit p·l ≤ {MAX_HORIZON_BLOCK_WIDTH}",
                        horizon_periods(settings.method),
                        lowest_of_interest.unwrap_or(0.0)
                    ));
                    k
                }
                Some(_) => d,
                None => most,
            }
        }
    };
    let fs = fs0 / decimation as f64;
    let hi = if hi > 0.4 * fs {
        notes.push(format!(
            "band top lowered to {} Hz: 80 % of the Nyquist frequency after decimation by {decimation}",
            0.4 * fs
        ));
        0.4 * fs
    } else {
        hi
    };
    if lo >= hi {
        return Err(Error::usage(format!(
            "modal: decimation {decimation} leaves no band: low end {lo} Hz ≥ usable top {hi} Hz"
        )));
    }
    let n = n0.div_ceil(decimation);
    let m = if settings.method == Method::Io {
        input.inputs.len()
    } else {
        0
    };
    let r = settings
        .reference_channels
        .as_ref()
        .map_or(l, |refs| refs.len());
    let columns_per_block = match settings.method {
        Method::Io => l,
        _ => l.min(r),
    }
    .max(1);
    let explicit_orders = match &settings.orders {
        Some(o) => {
            let mut o: Vec<usize> = o.iter().copied().filter(|&k| k > 0).collect();
            o.sort_unstable();
            o.dedup();
            if o.is_empty() {
                return Err(Error::usage("modal: no model order to sweep"));
            }
            Some(o)
        }
        None => None,
    };
    let needed = |p: usize| rows_and_samples_needed(settings.method, l, r, m, p);
    let block_rows = match settings.block_rows {
        Some(p) if p < 2 => return Err(Error::usage("modal: block rows must be at least 2")),
        Some(p) => {
            // p alone first: `needed` multiplies it.
            let rows = if p > MAX_HANKEL_ROWS {
                p
            } else {
                needed(p).0 * p
            };
            if rows > MAX_HANKEL_ROWS {
                return Err(Error::usage(format!(
                    "modal: block_rows = {p} with {l} outputs builds Hankel matrices of {rows} rows, at most {MAX_HANKEL_ROWS}: give fewer block rows or leave them automatic"
                )));
            }
            let need = needed(p).1;
            if n < need {
                return Err(Error::input(
                    channel_location(input, 0, input.output_ids.first().map_or("", |s| s.as_str())),
                    format!(
                        "too few samples for {p} block rows: {n} after decimation by {decimation}, need at least {need}; give fewer block rows or leave them automatic"
                    ),
                ));
            }
            p
        }
        None => {
            // Half a period of the band's low end …
            let p_band = (fs / (2.0 * lo)).ceil() as usize;
            // … enough for the highest order asked …
            let want_order = explicit_orders
                .as_ref()
                .and_then(|o| o.last().copied())
                .unwrap_or(0);
            let p_order = want_order.div_ceil(columns_per_block).saturating_add(2);
            // … bounded by the cost, but at least HORIZON_PERIODS periods of
            // the lowest frequency of interest (up to a larger bound, which
            // the automatic decimation keeps it within) …
            let p_cost = (MAX_BLOCK_WIDTH / l.max(1)).max(3);
            let p_peak = lowest_of_interest
                .filter(|_| horizon_periods(settings.method) > 0.0)
                .map_or(0, |f| {
                    ((horizon_periods(settings.method) * fs / f).ceil() as usize)
                        .min(MAX_HORIZON_BLOCK_WIDTH / l.max(1))
                });
            // … and by the data.
            let p_data = (2..=p_band.max(p_order).max(p_peak).max(3))
                .take_while(|&p| needed(p).1 <= n)
                .last()
                .unwrap_or(0);
            if p_data < 2 {
                return Err(Error::input(
                    channel_location(input, 0, input.output_ids.first().map_or("", |s| s.as_str())),
                    format!(
                        "record too short for subspace identification: {n} samples after decimation by {decimation} ({} s)",
                        n as f64 / fs
                    ),
                ));
            }
            let p = p_band
                .max(p_order)
                .min(p_cost)
                .max(p_peak)
                .min(p_data)
                .max(2);
            let peak_note = lowest_of_interest.map_or(
                String::from("no lowest frequency of interest (no spectral peak, no estimate)"),
                |f| {
                    format!(
                        "{} period(s) of the lowest frequency of interest {f:.3} Hz = {p_peak} ({:.2} s)",
                        horizon_periods(settings.method),
                        p_peak as f64 / fs
                    )
                },
            );
            notes.push(format!(
                "block rows {p} (automatic: half a period of {lo} Hz = {p_band}, highest order needs {p_order}, cost bound {p_cost}, {peak_note}, data bound {p_data})"
            ));
            p
        }
    };
    let supported = (block_rows - 1) * columns_per_block;
    let orders = match explicit_orders {
        Some(o) => o,
        None => {
            let per_output = if settings.method == Method::SsiCov {
                AUTO_ORDERS_PER_OUTPUT * l
            } else {
                0
            };
            let most = MAX_AUTO_ORDER.max(per_output).min(MAX_AUTO_ORDER_CAP);
            let top = most.min(supported - supported % 2).max(2);
            notes.push(format!(
                "model orders 2–{top} step 2 (automatic: at most {most} = max({MAX_AUTO_ORDER}, {AUTO_ORDERS_PER_OUTPUT} per output for ssi-cov) ≤ {MAX_AUTO_ORDER_CAP}, subspace supports {supported})"
            ));
            (2..=top).step_by(2).collect()
        }
    };
    Ok(Plan {
        band_hz: [lo, hi],
        decimation,
        block_rows,
        orders,
        samples: n,
        notes,
    })
}

/// Why no mode, or fewer than the columns suggest, was selected.
fn selection_warnings(
    poles: &[Pole],
    selection: &Selection,
    filters: &PhysicalFilters,
    band: [f64; 2],
) -> Vec<String> {
    let mut warnings = Vec::new();
    let listed: Vec<String> = selection
        .rejected
        .iter()
        .filter(|c| c.poles >= 4)
        .take(6)
        .map(|c| {
            format!(
                "{:.3} Hz (ζ {:.1} %, orders {}–{}, {} poles): {}",
                c.frequency_hz,
                100.0 * c.damping_ratio,
                c.order_min,
                c.order_max,
                c.poles,
                c.reason
            )
        })
        .collect();
    if selection.modes.is_empty() {
        let in_band = poles
            .iter()
            .filter(|p| p.frequency_hz >= band[0] && p.frequency_hz <= band[1])
            .count();
        let physical = poles.iter().filter(|p| p.physical).count();
        let why = if in_band == 0 {
            format!("no pole in the band {:.3}–{:.3} Hz", band[0], band[1])
        } else if physical == 0 {
            let mut z: Vec<f64> = poles
                .iter()
                .filter(|p| p.frequency_hz >= band[0] && p.frequency_hz <= band[1])
                .map(|p| p.damping_ratio)
                .collect();
            z.sort_by(f64::total_cmp);
            format!(
                "none of the {in_band} poles in the band passes the physical filters (damping {:.1}–{:.1} %, MPC ≥ {}, MPD ≤ {}°; median damping of the poles {:.1} %)",
                100.0 * filters.damping_min,
                100.0 * filters.damping_max,
                filters.mpc_min,
                filters.mpd_max_deg,
                100.0 * z[z.len() / 2]
            )
        } else if listed.is_empty() {
            format!(
                "no pole column is stable over consecutive orders ({physical} physical poles scattered): the record may be too short or too weakly excited in {:.3}–{:.3} Hz",
                band[0], band[1]
            )
        } else {
            format!("stable columns were not promoted: {}", listed.join("; "))
        };
        warnings.push(format!("no mode selected: {why}"));
    } else if !listed.is_empty() {
        warnings.push(format!(
            "{} mode(s) selected; stable columns not promoted: {}",
            selection.modes.len(),
            listed.join("; ")
        ));
    }
    warnings
}

/// Runs the identification on plain signals.
pub fn identify(input: &ModalInput, settings: &ModalSettings) -> Result<ModalResult> {
    validate(input, settings.method)?;
    let plan = plan(input, settings)?;
    // Pre-processing on outputs and inputs together (same filter for both),
    // decimated to the band before any Hankel or covariance matrix is formed.
    let mut all: Vec<&[f64]> = input.outputs.iter().map(Vec::as_slice).collect();
    let use_inputs = settings.method == Method::Io;
    if use_inputs {
        all.extend(input.inputs.iter().map(Vec::as_slice));
    }
    let pre = Preprocessing {
        decimation: Some(plan.decimation),
        ..settings.preprocessing.clone()
    };
    let (processed, dt, steps) = preprocess::apply(&all, input.dt, &pre);
    let l = input.outputs.len();
    let outputs: Vec<&[f64]> = processed[..l].iter().map(|v| v.as_slice()).collect();
    let inputs: Vec<&[f64]> = processed[l..].iter().map(|v| v.as_slice()).collect();

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
    let block_rows = plan.block_rows;
    let subspace = match settings.method {
        Method::SsiCov => ssi::ssi_cov(&outputs, &refs, block_rows)?,
        Method::SsiData => ssi::ssi_data(&outputs, &refs, block_rows)?,
        Method::Io => ssi::po_moesp(&outputs, &inputs, block_rows)?,
    };
    let mut notes = plan.notes.clone();
    let nyquist = 0.5 / dt;
    let mut filters = settings.filters.clone();
    filters.frequency_min_hz = filters.frequency_min_hz.or(Some(plan.band_hz[0]));
    filters.frequency_max_hz = filters.frequency_max_hz.or(Some(plan.band_hz[1]));
    let mut poles: Vec<Pole> = Vec::new();
    let mut realised = Vec::new();
    let mut previous_range: Option<(usize, usize)> = None;
    let mut skipped = Vec::new();
    for &n in &plan.orders {
        if n > subspace.max_order() {
            skipped.push(n);
            continue;
        }
        let (a, c) = subspace.realise(n)?;
        let eig = ssi::eigen_structure(a.as_ref(), c.as_ref())?;
        let mut current = poles::poles_of_order(n, eig, dt);
        for p in current.iter_mut() {
            p.physical = filters.passes(p, nyquist);
        }
        if let Some((start, end)) = previous_range {
            poles::flag_stability(&mut current, &poles[start..end], &settings.stability);
        }
        let start = poles.len();
        poles.extend(current);
        previous_range = Some((start, poles.len()));
        realised.push(n);
    }
    if realised.is_empty() && settings.orders.is_some() {
        // Every explicit order lies above what the record supports: say so
        // (usage) rather than report an empty stabilisation diagram.
        return Err(Error::usage(format!(
            "modal: orders {:?} all exceed the subspace dimension {} this record supports with {block_rows} block rows ((block rows − 1) × outputs at most): give lower orders",
            plan.orders,
            subspace.max_order()
        )));
    }
    if !skipped.is_empty() {
        notes.push(format!(
            "orders {skipped:?} skipped: above the subspace dimension {}",
            subspace.max_order()
        ));
    }
    let band = [
        filters.frequency_min_hz.unwrap_or(0.0),
        filters.frequency_max_hz.unwrap_or(0.95 * nyquist),
    ];
    let (mut modes, rejected, warnings, promoted) = match &settings.manual_frequencies_hz {
        Some(f) => {
            let manual = selection::select_manual(&mut poles, f, settings.manual_band)?;
            let promoted = vec![false; manual.len()];
            (manual, Vec::new(), Vec::new(), promoted)
        }
        None => {
            let sel = selection::select_automatic(
                &mut poles,
                &realised,
                &filters,
                nyquist,
                &settings.selection,
            );
            let w = selection_warnings(&poles, &sel, &filters, band);
            (sel.modes, sel.rejected, w, sel.promoted)
        }
    };
    for m in modes.iter_mut() {
        m.direction = direction::label(&m.shape, &input.output_directions, &input.output_groups);
    }
    // Global modes only (issue 31): local modes and near-duplicates are
    // withdrawn from the structural modes (the manual override is the
    // user's choice and stays as picked).
    let (mut screen, local_modes) = if settings.manual_frequencies_hz.is_none() {
        global::screen(&modes, &input.output_ids)
    } else {
        (vec![None; modes.len()], Vec::new())
    };
    // A short column promoted by its shapes' coherence is a mode only when
    // its shape is a torsion (`selection::SelectionSettings::coherent_promotion_mac`).
    for ((m, why), promoted) in modes.iter().zip(screen.iter_mut()).zip(&promoted) {
        if *promoted && why.is_none() && m.direction != "torsion" {
            *why = Some(format!(
                "a short column ({} poles) promoted by its shapes' coherence, kept only for a torsion; its shape is {}",
                m.pole_count, m.direction
            ));
        }
    }
    for m in &local_modes {
        notes.push(format!(
            "local mode {:.3} Hz (ζ {:.1} %): {:.0} % of its shape's energy on channel {}: listed apart, not a structural mode",
            m.frequency_hz,
            100.0 * m.damping_ratio,
            100.0 * m.energy_share,
            m.channel
        ));
    }
    let structural: Vec<Mode> = modes
        .iter()
        .zip(&screen)
        .filter(|(_, why)| why.is_none())
        .map(|(m, _)| m.clone())
        .collect();
    notes.extend(lone_channel_directions(input, &structural));
    let mut preprocessing = steps;
    preprocessing.push(ProcessingStep {
        step: "band_limits".into(),
        channels: Vec::new(),
        params: serde_json::json!({
            "frequency_min_hz": band[0],
            "frequency_max_hz": band[1],
            "applies_to": "identified poles",
        }),
    });
    let mut result = ModalResult {
        method: settings.method,
        block_rows,
        band_hz: plan.band_hz,
        decimation: plan.decimation,
        dt,
        output_ids: input.output_ids.clone(),
        input_ids: if use_inputs {
            input.input_ids.clone()
        } else {
            Vec::new()
        },
        output_directions: input.output_directions.clone(),
        orders: realised,
        singular_values: subspace.singular_values.clone(),
        poles,
        modes,
        rejected,
        local_modes,
        preprocessing,
        notes,
        warnings,
    };
    result.withdraw_modes(&screen);
    if settings.uncertainty_blocks != Some(0) {
        let identified = uncertainty::Identified {
            method: settings.method,
            outputs: &outputs,
            inputs: &inputs,
            refs: &refs,
            block_rows,
            subspace: &subspace,
            dt,
        };
        let data = uncertainty::of_modes(
            &identified,
            &result.poles,
            &result.modes,
            settings.uncertainty_blocks,
        );
        for (mode, std) in result.modes.iter_mut().zip(data.modes) {
            mode.data_std = std;
        }
        result.notes.extend(data.notes);
        result.warnings.extend(data.warnings);
    }
    Ok(result)
}

/// A note per horizontal direction (X, Y) watched by one output channel
/// only, with no mode labelled in it.  A mode seen by one channel has a
/// one-component shape, whose coherence (MAC, MPC) is 1 by construction,
/// so stability cannot tell it from a noise pole: a bridge's single
/// longitudinal deck channel (CESMD corpus, docs/real-records) gives no
/// longitudinal mode, and the user should know why.
fn lone_channel_directions(input: &ModalInput, modes: &[Mode]) -> Vec<String> {
    ["X", "Y"]
        .into_iter()
        .filter_map(|axis| {
            let channels: Vec<&str> = input
                .output_directions
                .iter()
                .zip(&input.output_ids)
                .filter(|(d, _)| d.as_str() == axis)
                .map(|(_, id)| id.as_str())
                .collect();
            let found = modes.iter().any(|m| m.direction == axis);
            (channels.len() == 1 && input.output_ids.len() > 1 && !found).then(|| {
                format!(
                    "no mode labelled {axis}: one output channel ({}) watches {axis}, and a mode seen mainly by one channel \
                     cannot be told from a noise pole by the coherence of its shape; a second {axis} channel would",
                    channels[0]
                )
            })
        })
        .collect()
}

fn location_of(record: &Record) -> Location {
    let mut l = Location::file(&record.channel.source.file);
    l.member = record.channel.source.member.clone();
    l
}

/// Which channels of an event enter the identification.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ChannelChoice {
    /// Input (base) channel ids; `None` = the horizontal base channels
    /// (role input), structural base sensors preferred to free-field ones.
    /// Listing a vertical channel here is how verticals enter as inputs.
    pub inputs: Option<Vec<String>>,
    /// Vertical response channels enter as outputs.  Off by default when
    /// the event has horizontal outputs: vertical deck and floor channels
    /// add vertical modes that are not the lateral modes asked for and
    /// dominate the shapes of the lateral ones on bridges (CESMD corpus:
    /// Painter St. modes labelled vertical).
    pub vertical_outputs: bool,
}

/// Direction label of a channel for [`direction::label`]: building axis,
/// vertical, or an azimuth folded onto [0, 180) (a reversed sensor measures
/// the same axis), empty when unknown.
pub fn direction_label(channel: &crate::vocab::Channel) -> String {
    use crate::vocab::{Axis, Direction};
    match channel.direction {
        Some(Direction::Axis(Axis::X)) => "X".into(),
        Some(Direction::Axis(Axis::Y)) => "Y".into(),
        Some(Direction::Axis(Axis::Z)) | Some(Direction::Up) | Some(Direction::Down) => {
            direction::VERTICAL.into()
        }
        Some(Direction::Azimuth(a)) => format!("{:.0}deg", a.rem_euclid(180.0)),
        None => String::new(),
    }
}

fn is_vertical(channel: &crate::vocab::Channel) -> bool {
    channel.direction.is_some_and(|d| d.is_vertical())
}

/// Builds the identification input from an event by channel role: `output`
/// channels are responses; inputs are the horizontal `input` channels
/// (structural base sensors preferred; free-field ones only when there is
/// no other), or the ids of `choice.inputs`.  Channels of unknown role are
/// left out.  Channels at a higher sampling rate are decimated (anti-alias
/// FIR) to the lowest rate when the ratio is an integer, else left out.
/// When every channel states its start time, channels are aligned on
/// absolute time and cut to the common window (CSMIP zips hold several
/// recorders with different starts); otherwise they are cut to the
/// shortest length from their first sample.  Everything done is noted.
/// Values are used as stored: convert units and normalise orientation
/// beforehand (METHODS §0).  Floor motions formed by the rigid-floor
/// combination are left out: they are linear combinations of the sensor
/// channels, which carry the shapes (torsion included).
pub fn input_from_event(
    event: &Event,
    choice: &ChannelChoice,
) -> Result<(ModalInput, Vec<String>)> {
    let mut notes = Vec::new();
    let sensors: Vec<&Record> = event
        .records
        .iter()
        .filter(|r| !r.channel.is_floor_motion())
        .collect();
    let (outputs, inputs): (Vec<&Record>, Vec<&Record>) = match &choice.inputs {
        Some(ids) => {
            let mut inputs = Vec::new();
            for id in ids {
                let r = sensors
                    .iter()
                    .find(|r| r.channel.id == *id)
                    .ok_or_else(|| {
                        Error::usage(format!(
                            "modal: input channel {id:?} is not a sensor channel of event {} (channels: {})",
                            event.name,
                            sensors.iter().map(|r| r.channel.id.as_str()).collect::<Vec<_>>().join(", ")
                        ))
                    })?;
                inputs.push(*r);
            }
            let outputs = sensors
                .iter()
                .copied()
                .filter(|r| r.channel.role == Role::Output && !ids.contains(&r.channel.id))
                .collect();
            (outputs, inputs)
        }
        None => {
            let base: Vec<&Record> = sensors
                .iter()
                .copied()
                .filter(|r| r.channel.role == Role::Input)
                .collect();
            let vertical: Vec<&str> = base
                .iter()
                .filter(|r| is_vertical(&r.channel))
                .map(|r| r.channel.id.as_str())
                .collect();
            if !vertical.is_empty() {
                notes.push(format!(
                    "vertical base channels not used as inputs (list them in `inputs` to use them): {}",
                    vertical.join(", ")
                ));
            }
            let horizontal: Vec<&Record> = base
                .into_iter()
                .filter(|r| !is_vertical(&r.channel))
                .collect();
            let free = |r: &Record| {
                crate::event_folder::is_free_field(r.channel.location_text.as_deref().unwrap_or(""))
            };
            let structural: Vec<&Record> =
                horizontal.iter().copied().filter(|r| !free(r)).collect();
            let inputs = if !structural.is_empty() && structural.len() < horizontal.len() {
                notes.push(format!(
                    "free-field channels not used as inputs (base sensors of the structure are): {}",
                    horizontal
                        .iter()
                        .filter(|r| free(r))
                        .map(|r| r.channel.id.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
                structural
            } else {
                horizontal
            };
            let outputs = sensors
                .iter()
                .copied()
                .filter(|r| r.channel.role == Role::Output)
                .collect();
            (outputs, inputs)
        }
    };
    let outputs = if choice.vertical_outputs || outputs.iter().all(|r| is_vertical(&r.channel)) {
        outputs
    } else {
        let (vertical, lateral): (Vec<&Record>, Vec<&Record>) =
            outputs.into_iter().partition(|r| is_vertical(&r.channel));
        if !vertical.is_empty() {
            notes.push(format!(
                "vertical response channels not used as outputs (set `vertical_outputs = true` to use them): {}",
                vertical
                    .iter()
                    .map(|r| r.channel.id.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        lateral
    };
    let unknown: Vec<&str> = sensors
        .iter()
        .filter(|r| r.channel.role == Role::Unknown)
        .map(|r| r.channel.id.as_str())
        .collect();
    if !unknown.is_empty() {
        notes.push(format!(
            "channels left out, role unknown: {}",
            unknown.join(", ")
        ));
    }
    if outputs.is_empty() && inputs.is_empty() {
        return Err(Error::usage(format!(
            "modal: event {} has no channel with role input or output",
            event.name
        )));
    }
    // One sampling rate: the lowest; integer multiples are decimated.
    let rate = outputs
        .iter()
        .chain(&inputs)
        .map(|r| r.channel.sampling_rate_hz)
        .fold(f64::INFINITY, f64::min);
    let factor = |r: &Record| -> Option<usize> {
        let k = r.channel.sampling_rate_hz / rate;
        let kr = k.round();
        ((k - kr).abs() <= 1e-6 * k && kr >= 1.0).then_some(kr as usize)
    };
    let dropped: Vec<String> = outputs
        .iter()
        .chain(&inputs)
        .filter(|r| factor(r).is_none())
        .map(|r| r.channel.id.clone())
        .collect();
    let outputs: Vec<&Record> = outputs
        .into_iter()
        .filter(|r| factor(r).is_some())
        .collect();
    let inputs: Vec<&Record> = inputs.into_iter().filter(|r| factor(r).is_some()).collect();
    if !dropped.is_empty() {
        notes.push(format!(
            "channels left out: sampling rate not an integer multiple of {rate} Hz: {}",
            dropped.join(", ")
        ));
    }
    // A channel at a time (parked samples are read back, not kept).
    let resampled: Vec<(&Record, Vec<f64>)> = outputs
        .iter()
        .chain(&inputs)
        .map(|r| {
            let k = factor(r).unwrap_or(1);
            let data = r.samples.get()?;
            let samples = if k > 1 {
                preprocess::decimate(&data, k, &preprocess::antialias_taps(k))
            } else {
                data.into_owned()
            };
            Ok((*r, samples))
        })
        .collect::<Result<_>>()?;
    let decimated: Vec<&str> = resampled
        .iter()
        .filter(|(r, _)| factor(r).unwrap_or(1) > 1)
        .map(|(r, _)| r.channel.id.as_str())
        .collect();
    if !decimated.is_empty() {
        notes.push(format!(
            "decimated to the common {rate} Hz (anti-alias FIR): {}",
            decimated.join(", ")
        ));
    }
    // Common time window.
    let dt = 1.0 / rate;
    let offsets: Vec<usize> = if resampled.iter().all(|(r, _)| r.channel.start_ns.is_some()) {
        let start = |r: &Record| r.channel.start_ns.unwrap_or(0);
        let latest = resampled.iter().map(|(r, _)| start(r)).max().unwrap_or(0);
        let earliest = resampled.iter().map(|(r, _)| start(r)).min().unwrap_or(0);
        if latest != earliest {
            notes.push(format!(
                "channels start at different times (recorders up to {:.3} s apart): aligned on absolute time",
                (latest - earliest) as f64 / 1e9
            ));
        }
        resampled
            .iter()
            .map(|(r, _)| (((latest - start(r)) as f64 / 1e9) / dt).round() as usize)
            .collect()
    } else {
        if resampled.iter().any(|(r, _)| r.channel.start_ns.is_some()) {
            notes.push(
                "start times not stated for every channel: channels aligned at their first sample"
                    .into(),
            );
        }
        vec![0; resampled.len()]
    };
    let common = |offsets: &[usize]| {
        resampled
            .iter()
            .zip(offsets)
            .map(|((_, s), &o)| s.len().saturating_sub(o))
            .min()
            .unwrap_or(0)
    };
    let shortest = common(&vec![0; resampled.len()]);
    let mut offsets = offsets;
    if common(&offsets) < shortest / 2 {
        // Stated start times that leave less than half the record in common
        // are not trusted (a recorder clock off by minutes or a time zone).
        notes.push(format!(
            "stated start times leave {} of {shortest} samples in common: start times not trusted, channels aligned at their first sample",
            common(&offsets)
        ));
        offsets = vec![0; resampled.len()];
    }
    let n = common(&offsets);
    if n == 0 {
        return Err(Error::input(
            location_of(resampled[0].0),
            "the channels share no common time window (start times and lengths)",
        ));
    }
    if resampled
        .iter()
        .zip(&offsets)
        .any(|((_, s), &o)| s.len() != n + o || o > 0)
    {
        notes.push(format!(
            "channels cut to the common window: {n} samples ({:.2} s)",
            n as f64 * dt
        ));
    }
    let mut cut: Vec<Vec<f64>> = resampled
        .into_iter()
        .zip(&offsets)
        .map(|((_, mut s), &o)| {
            if o > 0 {
                s.drain(..o);
            }
            s.truncate(n);
            s
        })
        .collect();
    let lo = outputs.len();
    let cut_inputs = cut.split_off(lo);
    let locations: Vec<Location> = outputs
        .iter()
        .chain(&inputs)
        .map(|r| location_of(r))
        .collect();
    Ok((
        ModalInput {
            dt,
            output_ids: outputs.iter().map(|r| r.channel.id.clone()).collect(),
            outputs: cut,
            input_ids: inputs.iter().map(|r| r.channel.id.clone()).collect(),
            inputs: cut_inputs,
            locations,
            output_directions: outputs
                .iter()
                .map(|r| direction_label(&r.channel))
                .collect(),
            output_groups: outputs
                .iter()
                .map(|r| r.channel.level.map(|l| l.to_string()).unwrap_or_default())
                .collect(),
        },
        notes,
    ))
}

/// The PSD overlay ([`spectral_overlay`]) of `result`'s output channels in
/// `event`, at their recorded rate; `None` when the records are shorter than
/// a segment.  Read after the identification freed its signals (parked
/// samples are read back).
pub fn output_spectral_overlay(
    event: &Event,
    result: &ModalResult,
    segment_length: usize,
) -> Result<Option<SpectralOverlay>> {
    let outputs: Vec<Vec<f64>> = result
        .output_ids
        .iter()
        .filter_map(|id| {
            event
                .record(id)
                .map(|r| r.samples.get().map(|s| s.into_owned()))
        })
        .collect::<Result<_>>()?;
    let dt = event
        .record(&result.output_ids[0])
        .map(|r| r.channel.dt())
        .unwrap_or(result.dt);
    Ok(spectral_overlay(&outputs, dt, segment_length).ok())
}

/// Identifies an event: input–output when `settings.method` is `Io`,
/// output-only otherwise (the pipeline picks `Io` when the event has base channels).
pub fn identify_event(
    event: &Event,
    settings: &ModalSettings,
    choice: &ChannelChoice,
) -> Result<ModalResult> {
    let (input, notes) = input_from_event(event, choice)?;
    let mut result = identify(&input, settings)?;
    result.notes.splice(0..0, notes);
    Ok(result)
}
