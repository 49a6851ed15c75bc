//! Every Parquet table quaketwin writes, declared once: name, file,
//! description and columns (type, nullability, unit, meaning).  The writers
//! build their batches from these declarations (`sinks::parquet::TableBuilder`
//! refuses a table that does not match), the readers of our own outputs look
//! columns up through them, and docs/formats.md is checked against them
//! (`tests/it/schemas.rs`).  Units: SI, `1` for a dimensionless quantity
//! (`%` where a column says percent), `varies` / `arbitrary` for a number
//! without one physical unit (`schema::UNIT_VARIES`, `schema::UNIT_ARBITRARY`),
//! empty for what is not a physical quantity (ids, labels, indices, counts,
//! flags, timestamps).  Every column's unit and meaning travel in its Arrow
//! field metadata (`unit`, `description`).
//!
//! Each table has a constant (`MODES`) and a module of its columns
//! (`modes::FREQUENCY_HZ`), so code names a column without a string literal.

use super::schema::{Rows, TableSchema};

/// `declare!([series] CONST, module, "name", "file", "doc", { COL: "col", Type, required|nullable, "unit", "doc"; … })`
/// (`series`: rows are samples of time series, [`Rows::Series`]).
macro_rules! declare {
    (series $konst:ident, $($rest:tt)*) => { declare!(@table Series, $konst, $($rest)*); };
    ($konst:ident, $($rest:tt)*) => { declare!(@table Results, $konst, $($rest)*); };
    (@table $rows:ident, $konst:ident, $module:ident, $name:literal, $file:literal, $doc:literal, {
        $($col:ident: $cname:literal, $ty:ident, $null:ident, $unit:literal, $cdoc:literal;)*
    }) => {
        #[doc = concat!("Columns of `", $file, "`.")]
        pub mod $module {
            use super::super::schema::{ColumnSpec, ColumnType::*};
            $(
                #[doc = $cdoc]
                pub const $col: ColumnSpec = ColumnSpec {
                    name: $cname,
                    ty: $ty,
                    nullable: declare!(@null $null),
                    unit: $unit,
                    doc: $cdoc,
                };
            )*
        }
        #[doc = concat!("`", $file, "`: ", $doc)]
        pub const $konst: TableSchema = TableSchema {
            name: $name,
            file: $file,
            doc: $doc,
            rows: Rows::$rows,
            columns: &[$($module::$col),*],
        };
    };
    (@null required) => { false };
    (@null nullable) => { true };
}

declare!(EVENT, event, "event", "event/event.parquet",
    "one row: the event and its structure, their ids (the partitions of a many-event dataset) beside the free-text names the manifest or the records give", {
    STRUCTURE_ID: "structure_id", Utf8, required, "", "the structure's id: `structure.id` of event.toml, else its `structure.name`, else `unknown`, in canonical form (lower case, runs of other characters one `-`): the `structure=` partition of a many-event dataset";
    STRUCTURE_NAME: "structure_name", Utf8, nullable, "", "the structure's name as given (free text; `structure.name`, else from the records' headers); null when none";
    EVENT_ID: "event_id", Utf8, required, "", "the event's id: `event.id` of event.toml, else the event folder's (zip's) name, in canonical form: the `event=` partition of a many-event dataset";
    EVENT_NAME: "event_name", Utf8, required, "", "the event's name as given (free text; `event.name`, else from the headers or the folder)";
    ORIGIN_TIME: "origin_time", TimestampNsUtc, nullable, "", "origin time (UTC), when stated";
    MAGNITUDE: "magnitude", F64, nullable, "1", "magnitude, when stated";
    RECORD_START: "record_start", TimestampNsUtc, nullable, "", "earliest start time of the records (UTC); null when no record states one";
    CHANNELS: "channels", U32, required, "", "channels read";
    STRUCTURE_KIND: "structure_kind", Utf8, nullable, "", "`building`, `bridge`, … when stated or inferred";
    LATITUDE_DEG: "latitude_deg", F64, nullable, "deg", "the structure's latitude (WGS 84, north positive), when stated";
    LONGITUDE_DEG: "longitude_deg", F64, nullable, "deg", "the structure's longitude (WGS 84, east positive), when stated";
});

declare!(CHANNELS, channels, "channels", "channels/channels.parquet",
    "one row per channel: metadata, QA and strong-motion metrics", {
    CHANNEL_ID: "channel_id", Utf8, required, "", "unique id within the event";
    NETWORK: "network", Utf8, nullable, "", "network code, as the file header or StationXML states";
    STATION: "station", Utf8, nullable, "", "station code, as the file header or StationXML states";
    LOCATION_CODE: "location_code", Utf8, nullable, "", "location code, as the file header or StationXML states";
    CHANNEL_CODE: "channel_code", Utf8, nullable, "", "channel code, as the file header or StationXML states";
    LOCATION_TEXT: "location_text", Utf8, nullable, "", "sensor location from the header";
    LEVEL: "level", I32, nullable, "", "0 = base/ground, 1..n floors";
    NODE: "node", Utf8, nullable, "", "digital-twin node";
    ELEVATION_M: "elevation_m", F64, nullable, "m", "sensor elevation";
    DIRECTION: "direction", Utf8, nullable, "", "`X`, `Y`, `Z`, `UP`, `DOWN` or `<azimuth>deg`";
    AZIMUTH_DEG: "azimuth_deg", F64, nullable, "deg", "azimuth of an `<azimuth>deg` direction";
    DIP_DEG: "dip_deg", F64, nullable, "deg", "dip of the sensor axis";
    ROLE: "role", Utf8, required, "", "`input`, `output` or `unknown`";
    UNITS: "units", Utf8, required, "", "units after conditioning (`m/s2`)";
    SAMPLING_RATE_HZ: "sampling_rate_hz", F64, required, "Hz", "after resampling, when configured";
    NPTS: "npts", I64, required, "", "number of samples";
    START_TIME: "start_time", TimestampNsUtc, nullable, "", "time of the first sample, as the record states it (null when the record has none)";
    TIME_SOURCE: "time_source", Utf8, required, "", "what the `time` column of samples/samples.parquet counts from: `record_start` (`start_time`), `origin_time` (the record has no start time: its first sample is taken at the event's origin time, so the times are late or early by the unknown trigger delay) or `unknown` (neither: `time` is null)";
    SOURCE_FILE: "source_file", Utf8, required, "", "file the samples came from; `(rigid-floor combination)` for a floor motion formed by the rigid-floor combination (its sensors are listed in `inferred`, and in `event.json` / the `quaketwin.channels` metadata as `combines`; each sensor's `combined_into` names the floor)";
    SOURCE_MEMBER: "source_member", Utf8, nullable, "", "zip member the samples came from";
    SOURCE_COLUMN: "source_column", Utf8, nullable, "", "column of the file the samples came from";
    FORMAT: "format", Utf8, required, "", "file format; `floor` for a rigid-floor combination";
    QA_FLAGS: "qa_flags", ListUtf8, required, "", "QA codes: `clipping`, `gap`, `flat`, `nan`, `spikes`, `low_snr`, `resampled`, `note`";
    QA_DETAILS: "qa_details", Utf8, required, "", "JSON list of the QA flags with their figures";
    INFERRED: "inferred", ListUtf8, required, "", "what was inferred, and how";
    MISSING: "missing", ListUtf8, required, "", "what later stages need and nobody stated";
    SNR_DB: "snr_db", F64, nullable, "dB", "signal-to-noise ratio of the conditioned record against its first 2 s (pre-event noise); null when too short";
    PGA_M_S2: "pga_m_s2", F64, nullable, "m/s^2", "peak ground/floor acceleration";
    PGV_M_S: "pgv_m_s", F64, nullable, "m/s", "peak ground/floor velocity";
    PGD_M: "pgd_m", F64, nullable, "m", "peak ground/floor displacement";
    ARIAS_M_S: "arias_m_s", F64, nullable, "m/s", "Arias intensity π/(2g) ∫a² dt";
    D5_95_S: "d5_95_s", F64, nullable, "s", "significant duration, 5–95 % of Arias intensity";
    CAV_M_S: "cav_m_s", F64, nullable, "m/s", "cumulative absolute velocity ∫|a| dt";
});

declare!(series SAMPLES, samples, "samples", "samples/samples.parquet",
    "one row per channel and sample: the conditioned records (long format)", {
    CHANNEL_ID: "channel_id", Utf8, required, "", "channel id (`channel_id` of channels/channels.parquet)";
    SAMPLE: "sample", I64, required, "", "index from 0";
    T_S: "t_s", F64, required, "s", "time from the channel's first sample";
    TIME: "time", TimestampNsUtc, nullable, "", "absolute time (UTC) of the sample: the record's start time + `t_s`; for a record without a start time of its own, the event's origin time + `t_s` (`time_source` of channels/channels.parquet says which); null when neither is known";
    ACC_M_S2: "acc_m_s2", F64, required, "m/s^2", "conditioned acceleration";
    VEL_M_S: "vel_m_s", F64, nullable, "m/s", "velocity (integration with drift control)";
    DISP_M: "disp_m", F64, nullable, "m", "displacement";
});

declare!(SPECTRA, spectra, "spectra", "spectra/spectra.parquet",
    "one row per channel and period: elastic response spectra", {
    CHANNEL_ID: "channel_id", Utf8, required, "", "channel id";
    DAMPING: "damping", F64, required, "1", "damping ratio (0.05)";
    PERIOD_S: "period_s", F64, required, "s", "oscillator period; the first row of each channel is T = 0";
    SD_M: "sd_m", F64, required, "m", "spectral displacement max|u|";
    PSV_M_S: "psv_m_s", F64, required, "m/s", "pseudo-velocity ω·SD";
    PSA_M_S2: "psa_m_s2", F64, required, "m/s^2", "pseudo-acceleration ω²·SD";
    SA_ABS_M_S2: "sa_abs_m_s2", F64, required, "m/s^2", "peak absolute acceleration of the oscillator";
});

declare!(FOURIER, fourier, "fourier", "fourier/fourier.parquet",
    "one row per channel and frequency: smoothed Fourier amplitude spectra of the signal and pre-event noise windows, their ratio, and the filter corners chosen from it (a `condition` stage whose filter has `corners_from = \"snr\"`)", {
    CHANNEL_ID: "channel_id", Utf8, required, "", "channel id (`channel_id` of channels/channels.parquet)";
    FREQUENCY_HZ: "frequency_hz", F64, required, "Hz", "centre frequency 10^(k/50), from 1/(signal window duration) to the Nyquist frequency";
    SIGNAL_FAS: "signal_fas", F64, required, "m/s^2/Hz^0.5", "Fourier amplitude |X(f)|·Δt of the signal window (demeaned, Hann taper 5 % at each end), Konno–Ohmachi smoothed (b = 20) and divided by √(window duration)";
    NOISE_FAS: "noise_fas", F64, nullable, "m/s^2/Hz^0.5", "the same for the noise window; null without a noise window and below 1/(noise window duration), which the window does not resolve";
    SNR: "snr", F64, nullable, "1", "signal_fas / noise_fas; null where noise_fas is null or zero";
    HIGH_PASS_HZ: "high_pass_hz", F64, nullable, "Hz", "the channel's high-pass corner as applied (the same on every row of the channel): common to the event's horizontal records, or vertical ones (docs/pipelines.md); null for a filter without one";
    LOW_PASS_HZ: "low_pass_hz", F64, nullable, "Hz", "the channel's low-pass corner as applied; null for a filter without one";
    CORNERS_FROM: "corners_from", Utf8, required, "", "`snr` (chosen from the ratios of the event's records of the channel's group) or `stated` (the pipeline's corners: no usable noise window, `note` says why)";
    NOTE: "note", Utf8, required, "", "why each corner is where it is, in words, and this record's own corners when they differ";
    SIGNAL_START_S: "signal_start_s", F64, required, "s", "signal window start (the onset when found), from the channel's first sample";
    SIGNAL_END_S: "signal_end_s", F64, required, "s", "signal window end (95 % of the record's energy Σa²)";
    NOISE_START_S: "noise_start_s", F64, nullable, "s", "noise window start (the first sample, or 30 minutes before the onset in a longer record); null without a noise window";
    NOISE_END_S: "noise_end_s", F64, nullable, "s", "noise window end (the onset); null without a noise window";
});

declare!(DRIFT, drift, "drift", "drift/drift.parquet",
    "one row per storey or instrumented segment and direction: peak drift ratios (measured, segment average, or per-storey estimate: `kind`)", {
    DIRECTION: "direction", Utf8, required, "", "`X`, `Y` or an azimuth";
    STOREY: "storey", I32, required, "", "upper level of the row: storey L joins levels L−1 and L; for a `segment` row its upper level (`lower_level`–`upper_level`)";
    LOWER_CHANNEL: "lower_channel", Utf8, required, "", "record at the lower level (an `estimate`: the lower record of its segment)";
    UPPER_CHANNEL: "upper_channel", Utf8, required, "", "record at the upper level (an `estimate`: the upper record of its segment)";
    STOREY_HEIGHT_M: "storey_height_m", F64, required, "m", "height of the storey, or of the segment (sum of its storeys); where from: `height_source`";
    PEAK_DRIFT_RATIO: "peak_drift_ratio", F64, required, "1", "max over time of |u_upper − u_lower| / h (band-passed displacements of the condition stage: the oscillation only); a `segment` row: the segment's average ratio; an `estimate`: from the interpolated profile (`method`)";
    RESIDUAL_DRIFT_M: "residual_drift_m", F64, nullable, "m", "permanent drift u_upper − u_lower after the event (signed), from the relative acceleration as recorded (no filter) integrated twice and baseline-corrected on the post-event window (docs/report.md); null for an `estimate` and when the two levels' records are not on a common time base";
    RESIDUAL_DRIFT_STD_M: "residual_drift_std_m", F64, nullable, "m", "uncertainty of `residual_drift_m`: sensor-noise random walk (white-noise estimate from 0.6–0.9 × Nyquist) and post-event window instability; a lower bound for non-white noise";
    RESIDUAL_DRIFT_RATIO: "residual_drift_ratio", F64, nullable, "1", "residual_drift_m / h";
    RESIDUAL_WINDOW_START_S: "residual_window_start_s", F64, nullable, "s", "start of the post-event window (95 % of the relative acceleration's Arias intensity, at most 90 % of the record)";
    KIND: "kind", Utf8, required, "", "`measured` (one storey between instrumented levels), `segment` (several storeys between instrumented levels: the average ratio, a lower bound of its largest storey drift), `estimate` (one storey inside a segment: interpolated, not measured; never rated)";
    LOWER_LEVEL: "lower_level", I32, required, "", "lower level of the row (level 0 = the base)";
    UPPER_LEVEL: "upper_level", I32, required, "", "upper level of the row";
    METHOD: "method", Utf8, required, "", "how the value was formed (an `estimate`: the interpolation of the displacement profile)";
    HEIGHT_SOURCE: "height_source", Utf8, required, "", "`stated` (`structure.storey_heights_m`), `from total height` (`height_m / storeys`), `assumed` (metrics param `assumed_storey_height_m`: the ratio and its rating are provisional), `unknown: roof level assumed` (storey count unknown: shown, never rated)";
    RESIDUAL_STATUS: "residual_status", Utf8, nullable, "", "`unresolved` (|D| < 2σ), else `artefact` (|D| more than twice the row's own peak drift: impossible for an offset reached during the motion, the band-pass taking at most about half of such an offset out of the peak — docs/report.md), else `resolved`; only `resolved` is rated; null without a residual";
});

declare!(STABILIZATION, stabilization, "stabilization", "stabilization/stabilization.parquet",
    "one row per pole of every model order (the stabilisation diagram)", {
    ORDER: "order", U32, required, "", "model order";
    FREQUENCY_HZ: "frequency_hz", F64, required, "Hz", "pole frequency";
    DAMPING_RATIO: "damping_ratio", F64, required, "1", "pole damping ratio";
    MPC: "mpc", F64, required, "1", "modal phase collinearity";
    MPD_DEG: "mpd_deg", F64, required, "deg", "mean phase deviation";
    STABLE_FREQUENCY: "stable_frequency", Bool, required, "", "frequency stable against the previous order (default tolerance 1 %)";
    STABLE_DAMPING: "stable_damping", Bool, required, "", "damping stable against the previous order (default tolerance 5 %)";
    STABLE_SHAPE: "stable_shape", Bool, required, "", "shape stable against the previous order (default MAC tolerance 2 %)";
    PHYSICAL: "physical", Bool, required, "", "passes the damping window, MPC/MPD and band filters";
    MODE: "mode", I32, required, "", "selected mode it belongs to (1-based), −1 = none";
});

declare!(MODES, modes, "modes", "modes/modes.parquet",
    "one row per selected mode, with statistics and shapes", {
    MODE: "mode", U32, required, "", "1-based, ascending frequency";
    FREQUENCY_HZ: "frequency_hz", F64, required, "Hz", "mean frequency over the best-converged part of the pole column (upper half of its orders, physical poles)";
    FREQUENCY_STD_HZ: "frequency_std_hz", F64, required, "Hz", "order spread: standard deviation of the frequency over the poles of the cluster (a quality figure of the pole column, not the statistical error of the estimate: that is `frequency_std_data_hz`)";
    DAMPING_RATIO: "damping_ratio", F64, required, "1", "mean damping ratio over the cluster";
    DAMPING_STD: "damping_std", F64, required, "1", "order spread: standard deviation of the damping ratio over the poles of the cluster";
    FREQUENCY_STD_DATA_HZ: "frequency_std_data_hz", F64, nullable, "Hz", "data-driven standard deviation of `frequency_hz`, the first-order propagation of the covariance of the factorised matrix (estimated from `uncertainty_blocks` blocks of the record): √(σ² + s²), σ at the orders where the first order holds, s the order spread `frequency_std_hz` of the poles whose mean is reported (docs/statistics.md, Eqs. S6–S7), plus their difference where the valid-order pole disagrees with the estimate (Eq. S9; `uncertainty_basis` says which); null when not computed (record too short for enough blocks, ssi-data, `uncertainty_blocks = 0`)";
    DAMPING_STD_DATA: "damping_std_data", F64, nullable, "1", "data-driven standard deviation of `damping_ratio` (as `frequency_std_data_hz`, with the order spread `damping_std`); null when not computed";
    UNCERTAINTY_BASIS: "uncertainty_basis", Utf8, nullable, "", "how `frequency_std_data_hz` and `damping_std_data` were formed (docs/statistics.md, Eqs. S7, S9): `valid_orders` = √(σ² + s²) of Eq. S7, the mode's pole at the orders where the first order holds agreeing with the reported estimate within its 95 % interval; `discrepancy` = √(σ² + s² + d²), where that pole does not agree: d the difference between the reported estimate and that pole, which σ does not see; null when they were not computed";
    UNCERTAINTY_BLOCKS: "uncertainty_blocks", U32, nullable, "", "blocks the record was cut into for the data-driven standard deviations; null when they were not computed";
    UNCERTAINTY_DOF: "uncertainty_dof", F64, nullable, "1", "degrees of freedom of the data-driven standard deviations (docs/statistics.md, Eqs. S8–S8'): Kish's effective number of the blocks weighted by their power, minus one — `uncertainty_blocks` − 1 for a steady record, fewer where its power lies in a few blocks; the 95 % interval is value ± t × std, t = Student's t_{0.975, uncertainty_dof} (2.045 for 29, 2.262 for 9); null when they were not computed";
    MPC: "mpc", F64, required, "1", "modal phase collinearity of the shape";
    MPD_DEG: "mpd_deg", F64, required, "deg", "mean phase deviation of the shape";
    MEAN_MAC: "mean_mac", F64, required, "1", "mean MAC of the cluster's poles to the mean shape";
    POLE_COUNT: "pole_count", U32, required, "", "poles behind the statistics";
    ORDER_MIN: "order_min", U32, required, "", "lowest model order of the cluster";
    ORDER_MAX: "order_max", U32, required, "", "highest model order of the cluster";
    MANUAL: "manual", Bool, required, "", "picked by the manual override";
    DIRECTION: "direction", Utf8, required, "", "label of the shape from the channels' directions: `X`, `Y`, `vertical`, `torsion` (components of one horizontal direction at one level in opposite senses), `mixed`, an azimuth `<deg>deg` (folded onto 0–180) for channels not on building axes, empty when the directions are unknown";
    SHAPE_RE: "shape_re", ListF64, required, "1", "real part of the complex mode shape at `quaketwin.output_channels` (largest component 1)";
    SHAPE_IM: "shape_im", ListF64, required, "1", "imaginary part of the mode shape";
    SHAPE_STD: "shape_std", ListF64, required, "1", "standard deviation of each component's modulus";
});

declare!(MODE_SHAPES, mode_shapes, "mode_shapes", "mode_shapes/mode_shapes.parquet",
    "one row per selected mode and output channel: the mode shapes of modes/modes.parquet in long form, each component beside its channel, level and direction", {
    MODE: "mode", U32, required, "", "mode (`mode` of modes/modes.parquet)";
    FREQUENCY_HZ: "frequency_hz", F64, required, "Hz", "the mode's frequency (`frequency_hz` of modes/modes.parquet)";
    CHANNEL_ID: "channel_id", Utf8, required, "", "output channel of this component (`channel_id` of channels/channels.parquet; the k-th entry of `quaketwin.output_channels`)";
    LEVEL: "level", I32, nullable, "", "the channel's level (0 = base/ground); null when unknown";
    DIRECTION: "direction", Utf8, required, "", "the channel's direction label (`X`, `Y`, `Z`, an azimuth `<deg>deg`; empty when unknown)";
    REAL: "real", F64, required, "1", "real part of the shape component (`shape_re[k]` of modes/modes.parquet; largest component of the mode 1)";
    IMAG: "imag", F64, required, "1", "imaginary part (`shape_im[k]`)";
    MODULUS_STD: "modulus_std", F64, required, "1", "order spread: standard deviation of the component's modulus over the cluster (`shape_std[k]`)";
    MODULUS_STD_DATA: "modulus_std_data", F64, nullable, "1", "data-driven standard deviation of the component's modulus, the shape normalised to its largest component (0 there by construction; docs/statistics.md); null when not computed";
});

declare!(MODAL_SPECTRUM, modal_spectrum, "modal_spectrum", "modal_spectrum/modal_spectrum.parquet",
    "singular values of the factorisation and of the PSD matrix (long format)", {
    KIND: "kind", Utf8, required, "", "`subspace` (singular values of the factorised matrix) or `psd` (singular values of the Welch PSD matrix)";
    INDEX: "index", I32, required, "", "singular value number (1 = largest)";
    FREQUENCY_HZ: "frequency_hz", F64, nullable, "Hz", "PSD bin (null for `subspace`)";
    VALUE: "value", F64, required, "arbitrary", "singular value, on the scale of the factorised matrix (compare values of one `kind` with each other)";
});

declare!(FREQUENCY_SHIFTS, frequency_shifts, "frequency_shifts", "frequency_shifts/frequency_shifts.parquet",
    "one row per mode of a reference (earlier) event paired with a mode of this event on the channels both share", {
    REFERENCE_MODE: "reference_mode", U32, required, "", "mode of the reference event (`mode` of its modes/modes.parquet)";
    CURRENT_MODE: "current_mode", U32, required, "", "mode of this event (`mode` of modes/modes.parquet)";
    DIRECTION_REFERENCE: "direction_reference", Utf8, required, "", "direction label of the reference mode (`direction` of its modes/modes.parquet)";
    DIRECTION_CURRENT: "direction_current", Utf8, required, "", "direction label of this event's mode";
    FREQUENCY_REFERENCE_HZ: "frequency_reference_hz", F64, required, "Hz", "reference frequency";
    FREQUENCY_REFERENCE_STD_HZ: "frequency_reference_std_hz", F64, required, "Hz", "its standard deviation (`frequency_std_hz` of the reference)";
    FREQUENCY_CURRENT_HZ: "frequency_current_hz", F64, required, "Hz", "frequency of this event";
    FREQUENCY_CURRENT_STD_HZ: "frequency_current_std_hz", F64, required, "Hz", "its standard deviation";
    SHIFT_PERCENT: "shift_percent", F64, required, "%", "100 (f_current − f_reference)/f_reference: negative = softening";
    SHIFT_STD_PERCENT: "shift_std_percent", F64, required, "%", "standard deviation of the shift from the two frequency standard deviations (independent, first order): 100 √((σ_cur/f_ref)² + (f_cur σ_ref/f_ref²)²), each σ the mode's data-driven `frequency_std_data_hz` when known, else its order spread `frequency_std_hz` taken at least `reference_frequency_std_floor` × f (the order spread understates the error of one record); `shift_std_basis` says which";
    FREQUENCY_REFERENCE_STD_DATA_HZ: "frequency_reference_std_data_hz", F64, nullable, "Hz", "data-driven standard deviation of the reference frequency (`frequency_std_data_hz` of the reference); null when not computed";
    FREQUENCY_CURRENT_STD_DATA_HZ: "frequency_current_std_data_hz", F64, nullable, "Hz", "data-driven standard deviation of this event's frequency; null when not computed";
    SHIFT_STD_BASIS: "shift_std_basis", Utf8, required, "", "the σ behind `shift_std_percent`: `data` (both data-driven), `order_spread` (both from the order spread with the floor), `mixed` (one of each)";
    SHIFT_DOF: "shift_dof", F64, nullable, "1", "Welch–Satterthwaite degrees of freedom of `shift_std_percent` from the data-driven σ's `uncertainty_dof` (an order-spread σ counts as exact): (a² + b²)² / (a⁴/ν_ref + b⁴/ν_cur) (docs/statistics.md, Pre/post shifts); null when neither σ is data-driven";
    SIGNIFICANT: "significant", Bool, nullable, "", "|shift| > t_{0.975, shift_dof} × `shift_std_percent` (2 × when `shift_dof` is null); null when that is zero (no uncertainty known)";
    DAMPING_REFERENCE: "damping_reference", F64, required, "1", "reference damping ratio";
    DAMPING_CURRENT: "damping_current", F64, required, "1", "damping ratio of this event";
    MAC: "mac", F64, nullable, "1", "MAC of the two shapes restricted to the shared channels (renormalised); null when paired by frequency and direction";
    SHARED_CHANNELS: "shared_channels", U32, required, "", "output channels (same id) both events have; the same on every row";
    PAIRING: "pairing", Utf8, required, "", "what the pairing was based on: `mac_and_frequency` (MAC ≥ `reference_min_mac` on the shared channels and |Δf|/f_ref ≤ `reference_frequency_window`) or `frequency_and_direction` (fewer than 2 shared channels: the frequency window and the same direction label only)";
});

declare!(BOUC_WEN, bouc_wen, "bouc_wen", "bouc_wen/bouc_wen.parquet",
    "one row per direction, DoF and Bouc-Wen parameter", {
    DIRECTION: "direction", Utf8, required, "", "`X`, `Y`, …";
    DOF: "dof", I32, required, "", "DoF (instrumented floor) from the base up, 1-based; −1 on a not-identifiable row";
    SEGMENT: "segment", Utf8, nullable, "", "levels the DoF's storey spans, `L<a>-L<b>` (ASCII hyphen; a segment of several storeys where levels between are not instrumented); null on a not-identifiable row";
    PARAMETER: "parameter", Utf8, required, "", "`K0`, `K0_delta`, `delta`, `beta`, `gamma`, `N` (`none` on a not-identifiable row)";
    COUPLED_DOF: "coupled_dof", I32, nullable, "", "r of K0_dr-type rows";
    VALUE: "value", F64, required, "varies", "parameter value, in the row's `unit`";
    UNIT: "unit", Utf8, required, "", "unit of `value`: `N/m`, `1/J`, `N^(1-N)/m`, `-`";
    STABILITY_STD: "stability_std", F64, nullable, "1", "relative std over the informative instantaneous estimates (N: absolute)";
    STABLE: "stable", Bool, required, "", "parameter stability over time (model-adequacy indicator)";
    COST_J: "cost_j", F64, required, "arbitrary", "J(N) at the optimum (Eq. 31; a weighted STFT residual on the scale of the basis form: compare the rows of one direction; `cost_relative` is the dimensionless figure)";
    COST_RELATIVE: "cost_relative", F64, required, "1", "J(N) relative to the target";
    HYSTERETIC_SHARE: "hysteretic_share", F64, required, "1", "share of the record explained by the hysteretic terms";
    STATUS: "status", Utf8, required, "", "`identified` (hysteretic terms significant at this DoF), `identified_unstable` (significant, estimates unstable over time), `no_significant_hysteresis` (this DoF's hysteretic terms failed the share, F-test, N-range or J(N)-contrast check: its rows are the nested model's K0, K0_delta, delta, with beta = gamma = 0 and N NaN; the DoFs below were still identified), `not_identifiable` (one row per direction: `dof` −1, `parameter` `none`, `value` NaN)";
    REASON: "reason", Utf8, required, "", "empty on `identified` rows: why not (no base or floor channel, a level whose channels could not be combined, masses missing, too few windows, the F-test and its numbers …), naming level, channel or file; a `no_significant_hysteresis` reason also says what the test cannot see (docs/hysteresis.md)";
    VERDICT: "verdict", Utf8, required, "", "the direction's outcome, on every row of the direction: `nonlinear_identified` (hysteretic terms significant at one DoF at least), `no_significant_hysteresis` (every DoF tested, none significant: status `not_identifiable` with the reason — not a finding of a linear, undamaged response), `not_identifiable` (nothing could be tested: masses or channels missing, too few windows, …)";
    F_STATISTIC: "f_statistic", F64, nullable, "1", "F-test of the hysteretic terms (β, γ, N) against the nested model (the same K0, K0·δ columns) at this DoF: [(J_lin − J)/3] / [J/(n_eff − p)], n_eff = non-overlapping STFT windows; on a not-identifiable row with verdict `no_significant_hysteresis`: the test of the DoF with the smallest p-value (null when another check decided)";
    P_VALUE: "p_value", F64, nullable, "1", "its p-value; a DoF is identifiable when p < `significance_level` (default 1e-3)";
    ENERGY_RECORD_J: "energy_record_j", F64, nullable, "J", "E_rec = ∫ V_d dΔu_d: work of the recorded storey (segment) shear along its drift over the identified window — the energy the measured loops enclose (hysteretic and viscous dissipation plus the elastic energy stored at the end); on a not-identifiable row the sum over the direction's segments (null when the kinematics could not be formed)";
    ENERGY_HYSTERETIC_J: "energy_hysteretic_j", F64, nullable, "J", "E_h = ∫ h_d dΔu_d, h_d = ∫ BW_d dτ (Eq. 23c): work of the identified Bouc-Wen hysteretic storey force along the recorded drift, the hysteretic energy dissipated; 0 on `no_significant_hysteresis` rows, null on not-identifiable rows";
});

declare!(BOUC_WEN_INSTANTANEOUS, bouc_wen_instantaneous, "bouc_wen_instantaneous",
    "bouc_wen_instantaneous/bouc_wen_instantaneous.parquet",
    "cumulative (t_e → t) Bouc-Wen estimates per frame", {
    DIRECTION: "direction", Utf8, required, "", "`X`, `Y`, …";
    DOF: "dof", I32, required, "", "DoF (storey), 1-based";
    T_S: "t_s", F64, required, "s", "end of the cumulative window";
    INFORMATIVE: "informative", Bool, required, "", "after the hysteretic onset";
    N_EXPONENT: "n_exponent", F64, required, "1", "exponent N";
    COST_J: "cost_j", F64, required, "arbitrary", "J(N) over the window (Eq. 31, on the scale of the basis form: compare the rows of one DoF)";
    K0_OWN_N_M: "k0_own_n_m", F64, required, "N/m", "K0_dd (own storey)";
    BETA: "beta", F64, required, "N^(1-N)/m", "β";
    GAMMA: "gamma", F64, required, "N^(1-N)/m", "γ";
});

declare!(series HYSTERESIS_FIT, hysteresis_fit, "hysteresis_fit", "hysteresis_fit/hysteresis_fit.parquet",
    "recorded vs model storey shear and drift per storey (segment): the force–drift loops", {
    DIRECTION: "direction", Utf8, required, "", "`X`, `Y`, …";
    DOF: "dof", I32, required, "", "DoF (instrumented floor), 1-based";
    SEGMENT: "segment", Utf8, required, "", "levels the storey spans, `L<a>-L<b>` (ASCII hyphen)";
    T_S: "t_s", F64, required, "s", "time";
    DRIFT_M: "drift_m", F64, required, "m", "storey (segment) drift u_d − u_{d−1}, from the stage's own integration of the as-recorded accelerations (no band-pass: permanent drift kept)";
    FORCE_RECORD_N: "force_record_n", F64, required, "N", "storey shear from the records, V_d = Σ_{r ≥ d} f_r, f_r = −m_r (a + ü_r) (Eq. 46)";
    FORCE_MODEL_N: "force_model_n", F64, nullable, "N", "storey shear of the identified model along the recorded kinematics; null where the direction is not identified (measured loop only)";
    ENERGY_RECORD_J: "energy_record_j", F64, required, "J", "cumulative work of the recorded storey shear along the drift, E_rec(t) = ∫₀ᵗ V_d dΔu_d (trapezoid on the drift increments of every sample, also where rows are decimated)";
});

declare!(series DAMAGE, damage, "damage", "damage/damage.parquet",
    "one row per direction, time and mode: the damage index", {
    DIRECTION: "direction", Utf8, required, "", "`X`, `Y`, …";
    T_S: "t_s", F64, required, "s", "time";
    IOTA: "iota", F64, required, "1", "ι(t), Eq. 34 (repeated on the mode rows of one time)";
    MODE: "mode", I32, required, "", "mode, 1-based";
    OMEGA_RAD_S: "omega_rad_s", F64, required, "rad/s", "ω_s(t)";
    OMEGA_RATIO: "omega_ratio", F64, required, "1", "ω_s(t)/ω_s(0)";
    PARTICIPATION: "participation", F64, required, "1", "c_s(t), Eq. 33";
});

declare!(TWIN_UPDATE, twin_update, "twin_update", "twin_update/twin_update.parquet",
    "one row per ensemble round and candidate of the twin update", {
    ROUND: "round", U32, required, "", "0-based ensemble round (thesis Table 1)";
    CANDIDATE: "candidate", U32, required, "", "0-based candidate index (order of the `solvers` setting)";
    SOLVER: "solver", Utf8, required, "", "`GA`, `PSO`, `SA`, `PS`, `QN`";
    PARAM: "param_<name>", F64, required, "varies", "one column per twin parameter (twin file order): the candidate's value, in the parameter's own unit (the `unit` of each column's field metadata: `Pa`, `kg/m^3`, `N/m`…, as in `quaketwin.parameter_bounds`)";
    OBJECTIVE_J: "objective_j", F64, required, "arbitrary", "J at the candidate (Eq. 5; mixes squared frequency differences in Hz² and squared MAC differences: compare the rows of one update)";
    Z: "z", ListF64, required, "varies", "model quantities per voter (`quaketwin.voters`): paired frequencies in Hz, then MAC values (1)";
    SCATTER: "scatter", ListF64, required, "1", "normalised scatter β per voter (Eq. 3)";
    SCORE: "score", ListF64, required, "1", "score w per voter (Eq. 4)";
    RANK: "rank", U32, required, "", "1-based position in the round's most likely Plackett–Luce ranking";
    SELECTION_WEIGHT: "selection_weight", F64, required, "1", "weight in the round's new point (1 for the first-ranked under `first`; normalised 1/rank under `mrr`)";
    SELECTED: "selected", Bool, required, "", "selection_weight > 0 (exactly one row per round under `first`; every row under `mrr`)";
    EVALUATIONS: "evaluations", I64, required, "", "objective evaluations the solver used";
});

declare!(TWIN_MODES, twin_modes, "twin_modes", "twin_modes/twin_modes.parquet",
    "one row per measured mode, before and after updating", {
    STAGE: "stage", Utf8, required, "", "`initial` (twin start values) or `updated`";
    MODE: "mode", U32, required, "", "measured mode number (`mode` of modes/modes.parquet)";
    MODEL_MODE: "model_mode", I32, nullable, "", "1-based model mode paired by MAC; null when no model mode was left";
    F_EXP_HZ: "f_exp_hz", F64, required, "Hz", "measured frequency";
    F_NUM_HZ: "f_num_hz", F64, nullable, "Hz", "paired model frequency";
    REL_ERROR: "rel_error", F64, nullable, "1", "|f_exp − f_num| / f_exp";
    MAC: "mac", F64, required, "1", "MAC at the sensor DoFs (0 when unpaired)";
});

declare!(ACTUATOR_LAYOUT, actuator_layout, "actuator_layout", "actuator_layout/actuator_layout.parquet",
    "one row per actuator of the hybrid-test design", {
    ACTUATOR: "actuator", U32, required, "", "1-based actuator number (column order of `ps_basis.mtx`)";
    NODE_ID: "node_id", I64, required, "", "twin node id";
    DIRECTION: "direction", Utf8, required, "", "DoF name (`ux`, `uy`, …)";
    CONTROL_MODE: "control_mode", Utf8, required, "", "`displacement` or `force`";
    NOMINAL_FORCE_N: "nominal_force_n", F64, required, "N", "nominal (gravity) force (N·m for rotations); 0 without gravity";
    POM: "pom_<j>", F64, required, "1", "component of each retained POM at this DoF (`pom_1` … `pom_k`, k = retained POMs)";
});

declare!(POD, pod, "pod", "pod/pod.parquet",
    "one row per listed proper orthogonal mode (POM)", {
    POM: "pom", U32, required, "", "1-based";
    SINGULAR_VALUE: "singular_value", F64, required, "m", "σ_i (m·√step)";
    ENERGY_FRACTION: "energy_fraction", F64, required, "1", "E_i = σ_i² / Σ σ²";
    CUMULATIVE_ENERGY: "cumulative_energy", F64, required, "1", "Σ_{j ≤ i} E_j";
    WNRMSE: "wnrmse", F64, required, "1", "WNRMSE of the reconstruction with POMs 1..i (Eq. 83–84)";
    RETAINED: "retained", Bool, required, "", "among the retained POMs";
});

declare!(REDUCTION_VALIDATION, reduction_validation, "reduction_validation",
    "reduction_validation/reduction_validation.parquet",
    "one row per retained PS DoF (outside c): reduced vs full response", {
    NODE_ID: "node_id", I64, required, "", "twin node id";
    DIRECTION: "direction", Utf8, required, "", "DoF name";
    NRMSE: "nrmse", F64, required, "1", "NRMSE of the reduced vs full deformation history (Eq. 83)";
    WEIGHT: "weight", F64, required, "m", "WNRMSE weight max|x − μ| of the full history";
    IS_MASTER: "is_master", Bool, required, "", "actuated DoF";
});

declare!(INTERFACE_REFINEMENT, interface_refinement, "interface_refinement",
    "interface_refinement/interface_refinement.parquet",
    "one row per step of the interface refinement", {
    STEP: "step", U32, required, "", "1-based";
    CONTROL_NODES: "control_nodes", U32, required, "", "interface control nodes";
    COUPLED_DOFS: "coupled_dofs", U32, required, "", "control-node interface DoFs";
    ACTUATORS: "actuators", U32, required, "", "coupled DoFs outside the constrained set";
    WNRMSE_TOTAL: "wnrmse_total", F64, required, "1", "WNRMSE of the reduced twin's total PS displacement";
    WNRMSE_DEFORMATION: "wnrmse_deformation", F64, required, "1", "WNRMSE of its PS deformation";
    FIRST_FREQUENCY_ERROR: "first_frequency_error", F64, required, "1", "relative error of the reduced model's first frequency";
});

declare!(HYBRID_PROTOTYPE, hybrid_prototype, "hybrid_prototype", "hybrid_prototype/hybrid_prototype.parquet",
    "one row per prototype eigenfrequency, paired in ascending order with the full model's", {
    MODE: "mode", U32, required, "", "1-based";
    PROTOTYPE_FREQUENCY_HZ: "prototype_frequency_hz", F64, required, "Hz", "Craig–Bampton prototype frequency";
    FULL_FREQUENCY_HZ: "full_frequency_hz", F64, nullable, "Hz", "full twin frequency of the same rank (null beyond those computed)";
    RELATIVE_ERROR: "relative_error", F64, nullable, "1", "|f_proto − f_full| / f_full";
    IN_BAND: "in_band", Bool, required, "", "inside the band of interest (checked against `accuracy`)";
    TEST_FREQUENCY_HZ: "test_frequency_hz", F64, required, "Hz", "f_proto / λ: the frequency in laboratory time";
    NS_MODES: "ns_modes", U32, required, "", "recommended NS fixed-interface modes (same on every row)";
    TIME_SCALE: "time_scale", F64, required, "1", "recommended λ";
    BANDWIDTH_HZ: "bandwidth_hz", F64, required, "Hz", "highest prototype frequency / λ";
});

declare!(REHEARSAL, rehearsal, "rehearsal", "rehearsal/rehearsal.parquet",
    "time histories of one rehearsed hybrid test (the recommended λ), one row per base-motion step and actuator, in simulation time", {
    TIME_S: "time_s", F64, required, "s", "simulation time (laboratory time = λ × this)";
    ACTUATOR: "actuator", U32, required, "", "1-based actuator number (as in `actuator_layout/actuator_layout.parquet`)";
    NODE_ID: "node_id", I64, required, "", "twin node id of the actuated DoF";
    DIRECTION: "direction", Utf8, required, "", "DoF name";
    COMMAND_M: "command_m", F64, required, "m", "commanded actuator displacement (actuated coordinate q_m: deformation relative to the constrained set)";
    ACHIEVED_M: "achieved_m", F64, required, "m", "measured achieved displacement (with measurement noise)";
    FORCE_N: "force_n", F64, required, "N", "measured restoring force of the specimen (with load-cell noise; N·m for rotations)";
    RESPONSE_M: "response_m", F64, required, "m", "total displacement of the actuated DoF relative to the base in the hybrid simulation";
    REFERENCE_M: "reference_m", F64, required, "m", "the full twin's displacement there (the rehearsal's reference: sub-stepped Newmark, `reference` of `rehearsal_model.json`)";
    TIME_SCALE: "time_scale", F64, required, "1", "λ of this run (same on every row)";
    NS_MODES: "ns_modes", U32, required, "", "NS fixed-interface modes of this run (same on every row)";
});

declare!(REHEARSAL_SUMMARY, rehearsal_summary, "rehearsal_summary", "rehearsal_summary/rehearsal_summary.parquet",
    "one row per rehearsal run of the sweep (NS modes × time scale λ)", {
    NS_MODES: "ns_modes", U32, required, "", "NS fixed-interface modes of the prototype";
    TIME_SCALE: "time_scale", F64, required, "1", "time scale λ (laboratory time / simulation time)";
    TOP_FREQUENCY_HZ: "top_frequency_hz", F64, required, "Hz", "highest prototype frequency with these NS modes";
    BANDWIDTH_HZ: "bandwidth_hz", F64, required, "Hz", "top frequency / λ: the highest frequency in laboratory time";
    STABLE: "stable", Bool, required, "", "the run did not diverge";
    DIVERGENCE_TIME_S: "divergence_time_s", F64, nullable, "s", "simulation time when the response left `divergence_factor` × the reference peak (null when stable)";
    ENERGY_ERROR: "energy_error", F64, required, "1", "max |spurious energy| / max |input energy| (Mosqueda energy balance)";
    RESPONSE_WNRMSE: "response_wnrmse", F64, nullable, "1", "WNRMSE (Eq. 84) of the actuated DoFs' total displacement against the full twin (null when diverged)";
    MAX_TRACKING_ERROR_M: "max_tracking_error_m", F64, required, "m", "largest |command − achieved| over actuators and steps";
    TRACKING_RMS_M: "tracking_rms_m", ListF64, required, "m", "RMS of command − achieved per actuator (actuator order)";
    TRACKING_MAX_M: "tracking_max_m", ListF64, required, "m", "max |command − achieved| per actuator (actuator order)";
    SAFE: "safe", Bool, required, "", "stable, response WNRMSE ≤ `response_tolerance` and energy error ≤ `energy_tolerance`";
    RECOMMENDED: "recommended", Bool, required, "", "the smallest safe λ at the design's NS mode count";
});

declare!(COMPARE_TEST_SUMMARY, compare_test_summary, "compare_test_summary", "compare_test_summary/compare_test_summary.parquet",
    "a logged hybrid test against its rehearsal and its twin (`quaketwin compare-test`): one row for the log, one for the design's rehearsal, one for the rehearsal updated from the log", {
    SOURCE: "source", Utf8, required, "", "`logged`, `rehearsal` (the design's rehearsal settings at the log's λ and step) or `updated rehearsal` (identified actuator and specimen)";
    TIME_SCALE: "time_scale", F64, required, "1", "time scale λ (laboratory time / simulation time), the log's";
    LAG_S: "lag_s", F64, nullable, "s", "actuator lag in laboratory time: identified from the log (equivalent pure delay), or the model's low-frequency group delay (delay + servo lag)";
    NOISE_STD_M: "noise_std_m", F64, required, "m", "displacement measurement noise: identified (residual after the lag model), or the model's";
    POOLED_TRACKING_RMS_M: "pooled_tracking_rms_m", F64, required, "m", "RMS of command − measured over steps and actuators (√ of the mean of the per-actuator mean squares)";
    MAX_TRACKING_ERROR_M: "max_tracking_error_m", F64, required, "m", "largest |command − measured| over actuators and steps";
    ENERGY_ERROR: "energy_error", F64, required, "1", "max |spurious energy| / max |input energy| (Mosqueda energy balance; the input energy of the rehearsal of the same motion)";
    COMMAND_WNRMSE: "command_wnrmse", F64, nullable, "1", "WNRMSE (Eq. 84) of the commanded displacements against the log's (null for the log itself or a diverged run)";
    FORCE_WNRMSE: "force_wnrmse", F64, nullable, "1", "WNRMSE of the restoring forces against the log's";
    RESPONSE_WNRMSE: "response_wnrmse", F64, nullable, "1", "WNRMSE of the actuated DoFs' response against the log's `response_m` (null when not logged)";
    TWIN_WNRMSE: "twin_wnrmse", F64, nullable, "1", "WNRMSE of the actuated DoFs' response against the twin (the full model, `reference` of the rehearsal model) at the motion's steps";
    STABLE: "stable", Bool, required, "", "the run did not diverge (the log: true)";
    DIVERGENCE_TIME_S: "divergence_time_s", F64, nullable, "s", "simulation time of a rehearsal's divergence";
});

declare!(COMPARE_TEST_ACTUATORS, compare_test_actuators, "compare_test_actuators", "compare_test_actuators/compare_test_actuators.parquet",
    "one row per actuator of a compared hybrid test: tracking error logged and predicted, identified lag and noise", {
    ACTUATOR: "actuator", U32, required, "", "1-based actuator number (as in `actuator_layout/actuator_layout.parquet`)";
    NODE_ID: "node_id", I64, required, "", "twin node id of the actuated DoF";
    DIRECTION: "direction", Utf8, required, "", "DoF name";
    LOGGED_TRACKING_RMS_M: "logged_tracking_rms_m", F64, required, "m", "RMS of the log's command − measured";
    LOGGED_TRACKING_MAX_M: "logged_tracking_max_m", F64, required, "m", "peak |command − measured| in the log";
    LAG_S: "lag_s", F64, nullable, "s", "this actuator's lag identified alone (null when its command does not move)";
    NOISE_STD_M: "noise_std_m", F64, nullable, "m", "this actuator's noise identified alone";
    REHEARSAL_TRACKING_RMS_M: "rehearsal_tracking_rms_m", F64, required, "m", "RMS of command − measured predicted by the rehearsal";
    REHEARSAL_TRACKING_MAX_M: "rehearsal_tracking_max_m", F64, required, "m", "peak |command − measured| predicted by the rehearsal";
    UPDATED_TRACKING_RMS_M: "updated_tracking_rms_m", F64, nullable, "m", "the same from the updated rehearsal (null when not run)";
    UPDATED_TRACKING_MAX_M: "updated_tracking_max_m", F64, nullable, "m", "peak from the updated rehearsal";
});

declare!(series COMPARE_TEST, compare_test, "compare_test", "compare_test/compare_test.parquet",
    "time histories of a compared hybrid test, one row per logged step and actuator: logged, rehearsed, updated, and the twin", {
    STEP: "step", U32, required, "", "integration step of the log (0: the state the test starts from)";
    TIME_S: "time_s", F64, required, "s", "simulation time (laboratory time = λ × this)";
    ACTUATOR: "actuator", U32, required, "", "1-based actuator number";
    COMMAND_M: "command_m", F64, required, "m", "logged commanded displacement";
    MEASURED_M: "measured_m", F64, required, "m", "logged measured displacement";
    FORCE_N: "force_n", F64, required, "N", "logged restoring force";
    RESPONSE_M: "response_m", F64, nullable, "m", "logged response of the actuated DoF relative to the base (null when not logged)";
    REHEARSAL_COMMAND_M: "rehearsal_command_m", F64, nullable, "m", "the rehearsal's command (null after a divergence)";
    REHEARSAL_MEASURED_M: "rehearsal_measured_m", F64, nullable, "m", "the rehearsal's measured displacement";
    REHEARSAL_FORCE_N: "rehearsal_force_n", F64, nullable, "N", "the rehearsal's restoring force";
    REHEARSAL_RESPONSE_M: "rehearsal_response_m", F64, nullable, "m", "the rehearsal's response";
    UPDATED_COMMAND_M: "updated_command_m", F64, nullable, "m", "the updated rehearsal's command (null when not run)";
    UPDATED_MEASURED_M: "updated_measured_m", F64, nullable, "m", "the updated rehearsal's measured displacement";
    UPDATED_FORCE_N: "updated_force_n", F64, nullable, "N", "the updated rehearsal's restoring force";
    REFERENCE_M: "reference_m", F64, nullable, "m", "the twin's response there (at the motion's steps; null between them)";
});

declare!(MODAL_TRACKING, modal_tracking, "modal_tracking", "modal_tracking/modal_tracking.parquet",
    "one row per window of a continuous record and tracked mode: frequency, damping, MAC to the reference shape, quality and the anomaly band (`quaketwin track`, docs/monitoring.md)", {
    WINDOW_START: "window_start", TimestampNsUtc, required, "", "start of the window (UTC)";
    WINDOW_END: "window_end", TimestampNsUtc, required, "", "end of the window (UTC, exclusive)";
    MODE: "mode", U32, required, "", "id of the tracked mode: 1-based rank of its reference mode, the same in every window";
    DIRECTION: "direction", Utf8, required, "", "direction label of this window's shape (`X`, `Y`, `torsion`, an azimuth such as `90deg`, `mixed`; empty when the channels' orientations are unknown)";
    FREQUENCY_HZ: "frequency_hz", F64, required, "Hz", "identified natural frequency in this window";
    FREQUENCY_STD_HZ: "frequency_std_hz", F64, required, "Hz", "scatter of the frequency over the model orders of the mode's pole column (`frequency_std_hz` of modes/modes.parquet): a quality figure, large when the column is split";
    DAMPING_RATIO: "damping_ratio", F64, required, "1", "identified modal damping ratio";
    MAC_TO_REFERENCE: "mac_to_reference", F64, nullable, "1", "MAC between this window's shape and the reference shape on the shared channels (null when paired by frequency and direction: fewer than two shared channels)";
    REFERENCE_FREQUENCY_HZ: "reference_frequency_hz", F64, required, "Hz", "frequency of the reference mode";
    MPC: "mpc", F64, required, "1", "modal phase collinearity of the shape (1 = real mode)";
    POLE_COUNT: "pole_count", U32, required, "", "stable poles (model orders) behind the mode";
    PRESENT_FRACTION: "present_fraction", F64, required, "1", "share of the window's samples that were recorded (the least complete channel; gaps filled by interpolation do not count)";
    RMS_LEVEL: "rms_level", F64, required, "m/s^2", "RMS level of the window: √(mean over channels of each channel's variance); in counts when the archive came without StationXML (`quaketwin.units`)";
    TRAINING: "training", Bool, required, "", "the window lies in the training period of the anomaly band";
    PREDICTED_FREQUENCY_HZ: "predicted_frequency_hz", F64, nullable, "Hz", "frequency the regression on RMS level and time of day predicts (docs/monitoring.md Eq. M1); null without a band";
    BAND_LOW_HZ: "band_low_hz", F64, nullable, "Hz", "lower end of the 99 % prediction interval (Eq. M3)";
    BAND_HIGH_HZ: "band_high_hz", F64, nullable, "Hz", "upper end of the 99 % prediction interval (Eq. M3)";
    DEVIATION_PERCENT: "deviation_percent", F64, nullable, "%", "100 (f − predicted) / predicted";
    FLAGGED: "flagged", Bool, nullable, "", "the frequency lies outside the band (Eq. M4); null without a band";
    ANOMALOUS_WINDOW: "anomalous_window", Bool, required, "", "at least half of this window's modes with a band are flagged (Eq. M5; the same on every row of the window)";
    CHANGE_STATISTIC: "change_statistic", F64, nullable, "1", "χ² statistic of the subspace change test of the window against the training windows (docs/statistics.md Eq. C6; the same on every row of the window); null when the window kept no covariances (more than 16 channels, or identified by another process)";
    CHANGE_THRESHOLD: "change_threshold", F64, nullable, "1", "the statistic's threshold at a 1 % false-alarm rate (Hotelling's T² quantile, Eq. C6)";
    CHANGE_P_VALUE: "change_p_value", F64, nullable, "1", "probability of a statistic at least this large in the training state";
    CHANGE_DOF: "change_dof", I32, nullable, "", "degrees of freedom of the statistic (rank kept of the residual covariance)";
    CHANGE_DETECTED: "change_detected", Bool, nullable, "", "the statistic exceeds the threshold";
    ENVIRONMENT_VALUE: "environment_value", F64, nullable, "varies", "the measured environmental series (`--temperature` or `--temperature-channel`) over the window: its samples' mean (docs/statistics.md Eq. E1); the series' unit (counts for a channel); null when none was given or it does not cover the window";
    COMPENSATED_RESIDUAL: "compensated_residual", F64, nullable, "1", "the mode's relative frequency residual after environmental compensation (Eq. E1 with a measured series, else the latent model E2); null when the window is not charted (some reference mode missing) or there is no chart";
    RESIDUAL_FLAGGED: "residual_flagged", Bool, nullable, "", "the residual lies outside the mode's 99 % band of the training residuals (Eq. E6); null with the residual";
});

declare!(CONTROL_CHART, control_chart, "control_chart", "control_chart/control_chart.parquet",
    "one row per subgroup of consecutive windows (a `--cycle`'s worth) of a `quaketwin track` run: Hotelling's T² of the environmentally compensated frequency residuals against the training period, its threshold and the alarm (docs/statistics.md Eqs. E1–E5); no rows when the training period was too short for a chart", {
    SUBGROUP_START: "subgroup_start", TimestampNsUtc, required, "", "start of the subgroup's first window (UTC)";
    SUBGROUP_END: "subgroup_end", TimestampNsUtc, required, "", "end of its last window (UTC, exclusive)";
    WINDOWS: "windows", U32, required, "", "windows of the run's grid in the subgroup";
    CHARTED_WINDOWS: "charted_windows", U32, required, "", "of those, windows with every reference mode tracked (and a measured value): the ones the statistic averages";
    TRAINING: "training", Bool, required, "", "the subgroup lies in the training period (no out-of-control decision)";
    MODEL: "model", Utf8, required, "", "`measured` (regression on the measured series, Eq. E1) or `latent` (principal directions of the training frequencies, Eq. E2)";
    STATISTIC: "statistic", F64, nullable, "1", "T²_g of Eq. E3 (w dᵀS⁺d rescaled by the threshold over the subgroup's own: the α quantile of the non-central T² with the training error's bounded non-centrality); null when no window of the subgroup is charted";
    THRESHOLD: "threshold", F64, required, "1", "upper α quantile of T²(k, n − 1 − p) (Eq. E3; α = 0.1 % per subgroup): every subgroup's statistic is rescaled onto it";
    P_VALUE: "p_value", F64, nullable, "1", "probability of a statistic at least this large in the training state (an upper bound, for all but 1 % of trainings: Eq. E3)";
    DOF: "dof", I32, required, "", "k of Eq. E3: the rank of the residual covariance";
    OUT_OF_CONTROL: "out_of_control", Bool, nullable, "", "the statistic exceeds the threshold (Eq. E4); null for training or uncharted subgroups";
    ALARM: "alarm", Bool, required, "", "this subgroup starts the first alarm (Eq. E5)";
});

declare!(CHANGE_REFERENCE, change_reference, "change_reference", "change_reference/change_reference.parquet",
    "one row per block of the identified record: its normalised output covariances, what a later run's change test (`reference_modes`) builds the reference state from (docs/statistics.md Eqs. C1, C4); written by every `modal` run with 2–16 output channels, empty otherwise", {
    BLOCK: "block", U32, required, "", "0-based block of the record (consecutive, equal length)";
    BLOCK_SAMPLES: "block_samples", U32, required, "", "samples of the block";
    BLOCK_POWER: "block_power", F64, nullable, "1", "the block's mean channel variance over the record's (1 for a stationary record): the weight of the block in the covariance of Eq. C4' (null in tables written before it was kept: read as 1)";
    COVARIANCES: "covariances", ListF64, required, "1", "R_k / (tr R₀ / l) of the block for k = 1…max_lag, entry (k − 1)·l² + o·l + c for output channel o and reference channel c (channel order: `quaketwin.output_channels`; max_lag: `quaketwin.max_lag`)";
});

declare!(CHANGE_TEST, change_test, "change_test", "change_test/change_test.parquet",
    "one row per output channel: the subspace χ² change test of this run's record against the reference run's (`reference_modes`), the test's figures repeated on every row, and the channel's share of the statistic (docs/statistics.md Eqs. C1–C7)", {
    CHANNEL: "channel", Utf8, required, "", "output channel id";
    CONTRIBUTION: "contribution", F64, required, "1", "the channel's share of the statistic (Eq. C7; the shares sum to the statistic, one may be negative)";
    STATISTIC: "statistic", F64, required, "1", "χ² (Hotelling T²) statistic of the residual (Eq. C6)";
    THRESHOLD: "threshold", F64, required, "1", "the statistic's threshold at the false-alarm rate";
    P_VALUE: "p_value", F64, required, "1", "probability of a statistic at least this large in the reference state";
    DOF: "dof", I32, required, "", "degrees of freedom (rank kept of the residual covariance)";
    COVARIANCE_DOF: "covariance_dof", I32, required, "", "degrees of freedom of the reference's residual covariance (blocks − 1 per record)";
    FALSE_ALARM_RATE: "false_alarm_rate", F64, required, "1", "false-alarm rate the threshold holds (`change_false_alarm_rate`)";
    CHANGED: "changed", Bool, required, "", "the statistic exceeds the threshold: the structure's dynamics differ from the reference's";
});

declare!(FREQUENCY_TRACK, frequency_track, "frequency_track", "frequency_track/frequency_track.parquet",
    "one row per moving window and tracked direction: the apparent fundamental frequency during the event (`assess` stage, docs/assessment.md)", {
    DIRECTION: "direction", Utf8, required, "", "building direction tracked (`X`, `Y`)";
    OUTPUT_CHANNEL: "output_channel", Utf8, required, "", "channel whose response is tracked (the highest level of the direction)";
    INPUT_CHANNEL: "input_channel", Utf8, nullable, "", "the base channel of the direction (input–output identification); null for output-only";
    METHOD: "method", Utf8, required, "", "`arx` (input–output) or `ar` (output-only), see docs/assessment.md";
    WINDOW_S: "window_s", F64, required, "s", "length of the moving window";
    TIME_S: "time_s", F64, required, "s", "window centre, from the start of the common window of the two records";
    FREQUENCY_HZ: "frequency_hz", F64, nullable, "Hz", "apparent frequency of the pole nearest the expected fundamental; null when the window has none";
    DAMPING_RATIO: "damping_ratio", F64, nullable, "1", "damping ratio of that pole";
    OUTPUT_RMS: "output_rms", F64, required, "m/s^2", "RMS of the output record over the window";
    PHASE: "phase", Utf8, required, "", "`pre` (window wholly before 5 % of the base's Arias intensity), `strong` (overlapping the 5–95 % span), `post` (wholly after 95 %)";
    TRUE_FREQUENCY_HZ: "true_frequency_hz", F64, nullable, "Hz", "a synthetic event's true tangent f₁ over the window (its `truth_frequency.csv`, written by `quaketwin synth`) where the frame stays linear across the window; null for real records";
});

declare!(ASSESSMENT, assessment, "assessment", "assessment/assessment.parquet",
    "one row per event: the overall colour and inspection priority, the damage-state probabilities and every indicator's value and verdict (`assess` stage, docs/assessment.md)", {
    EVENT: "event", Utf8, required, "", "event name";
    STRUCTURE: "structure", Utf8, nullable, "", "structure name";
    STRUCTURE_KIND: "structure_kind", Utf8, required, "", "`building`, `bridge`, or `unknown`";
    RATING: "rating", Utf8, required, "", "`GREEN`, `YELLOW`, `ORANGE`, `RED`, or `NOT RATED`";
    PRIORITY: "priority", Utf8, nullable, "", "inspection priority: `low`, `medium`, `medium-high`, `high` (null when not rated)";
    DAMAGE_STATE: "damage_state", Utf8, nullable, "", "the damage state behind the rating (`none` … `complete`)";
    CONFIDENCE: "confidence", Utf8, required, "", "`agreeing`, `corroborated by N indicators`, `single indicator`, `only one indicator rated`, `not rated`";
    PROVISIONAL: "provisional", Bool, required, "", "an indicator behind the rating rests on an assumption (listed in `assumptions`)";
    DRIVERS: "drivers", ListUtf8, required, "", "the indicators behind the rating, as sentences";
    NOT_RATED_REASON: "not_rated_reason", Utf8, nullable, "", "why no indicator could be rated";
    BUILDING_TYPE: "building_type", Utf8, nullable, "", "HAZUS model building type of the drift fragility (null: none applies)";
    DESIGN_LEVEL: "design_level", Utf8, nullable, "", "HAZUS seismic design level: `high`, `moderate`, `low`, `pre`";
    BUILDING_TYPE_SOURCE: "building_type_source", Utf8, required, "", "`stated` (structure.type), `default` (not stated or not recognised), `not applicable`";
    P_NONE: "p_none", F64, nullable, "1", "probability of no structural damage at the driving peak drift";
    P_SLIGHT: "p_slight", F64, nullable, "1", "probability of slight damage";
    P_MODERATE: "p_moderate", F64, nullable, "1", "probability of moderate damage";
    P_EXTENSIVE: "p_extensive", F64, nullable, "1", "probability of extensive damage";
    P_COMPLETE: "p_complete", F64, nullable, "1", "probability of complete damage";
    EMS98_GRADE: "ems98_grade", Utf8, nullable, "", "EMS-98 grade of the most likely drift damage state (`0`, `1`, `2`, `3`, `4–5`)";
    DRIFT_RATIO: "drift_ratio", F64, nullable, "1", "driving peak drift ratio (largest rated storey or segment drift)";
    DRIFT_STATE: "drift_state", Utf8, nullable, "", "most likely damage state at that drift; null when not rated";
    DRIFT_VERDICT: "drift_verdict", Utf8, required, "", "the drift indicator's verdict, or `not rated: <reason>`";
    FREQUENCY_BEFORE_HZ: "frequency_before_hz", F64, nullable, "Hz", "apparent fundamental frequency before the strong shaking (pre-event windows or the reference event) of the driving direction";
    FREQUENCY_MIN_DURING_HZ: "frequency_min_during_hz", F64, nullable, "Hz", "lowest apparent frequency during the strong shaking";
    FREQUENCY_AFTER_HZ: "frequency_after_hz", F64, nullable, "Hz", "apparent frequency after the strong shaking";
    FREQUENCY_DROP_DURING: "frequency_drop_during", F64, nullable, "1", "1 − min during / before: temporary softening, reported, never rated";
    FREQUENCY_DROP_PERMANENT: "frequency_drop_permanent", F64, nullable, "1", "1 − after / before: the rated permanent softening";
    FREQUENCY_STATE: "frequency_state", Utf8, nullable, "", "damage state of the permanent drop; null when not rated";
    FREQUENCY_VERDICT: "frequency_verdict", Utf8, required, "", "the frequency indicator's verdict, or `not rated: <reason>`";
    IOTA_FINAL: "iota_final", F64, nullable, "1", "final damage index ι of the driving direction, where significant hysteresis was identified";
    HYSTERESIS_STATE: "hysteresis_state", Utf8, nullable, "", "damage state of ι; `none` for no significant hysteresis and no lasting softening; null when not rated";
    HYSTERESIS_VERDICT: "hysteresis_verdict", Utf8, required, "", "the hysteresis indicator's verdict, or `not rated: <reason>`";
    RESIDUAL_DRIFT_RATIO: "residual_drift_ratio", F64, nullable, "1", "largest resolved residual drift ratio (absolute)";
    RESIDUAL_STATE: "residual_state", Utf8, nullable, "", "its damage state; null when not rated";
    RESIDUAL_VERDICT: "residual_verdict", Utf8, required, "", "the residual-drift indicator's verdict, or `not rated: <reason>`";
    CHANGE_TEST_RATIO: "change_test_ratio", F64, nullable, "1", "χ² statistic / threshold of the subspace change test against the reference run (change_test/change_test.parquet, docs/statistics.md Eq. C6): > 1 is a detected change; null without a reference or when no test could be made";
    CHANGE_TEST_P_VALUE: "change_test_p_value", F64, nullable, "1", "the test's p-value: probability of a statistic at least this large in the reference state";
    CHANGE_TEST_STATE: "change_test_state", Utf8, nullable, "", "`slight` when the change is detected at the test's false-alarm rate (at most slight: a reason to inspect), `none` when not; null when not rated";
    CHANGE_TEST_VERDICT: "change_test_verdict", Utf8, nullable, "", "the change-test indicator's verdict, or `not rated: <reason>`; null when the run had no reference";
    ASSUMPTIONS: "assumptions", ListUtf8, required, "", "what the assessment assumed: a default building type, an assumed storey height, a roof level…";
});

declare!(HISTORY_MODES, history_modes, "history_modes", "history_modes/history_modes.parquet",
    "one row per structure, followed mode and event holding it: the mode's frequency against the event's intensity, the amplitude-dependence band, the flags and a permanent shift (`quaketwin history`, docs/history.md)", {
    STRUCTURE: "structure", Utf8, required, "", "structure id: the dataset's `structure=` partition, or for events whose manifest names no structure (`structure=unknown`) the recording station `NETWORK.STATION` of their channels";
    EVENT: "event", Utf8, required, "", "event (the dataset's `event=` partition)";
    EVENT_TIME: "event_time", TimestampNsUtc, nullable, "", "origin time, else the start of the event's records (`time_source` of history_events/history_events.parquet)";
    MODE: "mode", U32, required, "", "id of the followed mode: 1-based, in the order the modes first appear in date order; the same in every event";
    DIRECTION: "direction", Utf8, required, "", "direction label of the followed mode: the label most of its events give it (`X`, `Y`, `torsion`, `vertical`, `mixed`, an azimuth; empty when unknown)";
    EVENT_MODE: "event_mode", U32, required, "", "the mode's number in this event's modes/modes.parquet (`mode`)";
    EVENT_DIRECTION: "event_direction", Utf8, required, "", "direction label of the mode in this event (`direction` of its modes/modes.parquet)";
    FREQUENCY_HZ: "frequency_hz", F64, required, "Hz", "identified frequency in this event";
    FREQUENCY_STD_HZ: "frequency_std_hz", F64, required, "Hz", "its scatter over the model orders (`frequency_std_hz` of modes/modes.parquet)";
    DAMPING_RATIO: "damping_ratio", F64, required, "1", "identified damping ratio in this event";
    PAIRED_WITH_EVENT: "paired_with_event", Utf8, nullable, "", "the earlier event whose mode this one was paired with (null for the event where the mode first appears)";
    MAC: "mac", F64, nullable, "1", "MAC to that event's mode on the channels the two events share (null when first, or when paired by frequency and direction: fewer than two shared channels)";
    INTENSITY_M_S2: "intensity_m_s2", F64, nullable, "m/s^2", "the event's intensity the band is fitted on (`--intensity`: the largest horizontal peak acceleration of the response channels, or of the base channels); null when unknown";
    PREDICTED_FREQUENCY_HZ: "predicted_frequency_hz", F64, nullable, "Hz", "frequency the amplitude dependence predicts at this intensity (Eq. H1); null without a band";
    BAND_LOW_HZ: "band_low_hz", F64, nullable, "Hz", "lower end of the prediction interval (Eq. H3)";
    BAND_HIGH_HZ: "band_high_hz", F64, nullable, "Hz", "upper end of the prediction interval (Eq. H3)";
    DEVIATION_PERCENT: "deviation_percent", F64, nullable, "%", "100 (f − predicted) / predicted";
    STATUS: "status", Utf8, required, "", "`in_band`, `amplitude_softened` (below the band at an intensity above every fitted event's, a later event back inside), `below_band`, `above_band` (Eq. H6), `no_band` (too few events or no intensity spread), `no_intensity`";
    FITTED: "fitted", Bool, required, "", "the event is among those the band was fitted on (not taken out as an outlier, Eq. H4)";
    AFTER_STEP: "after_step", Bool, required, "", "the event is on or after the mode's permanent shift (Eq. H5)";
    STEP_EVENT: "step_event", Utf8, nullable, "", "first event of the mode's permanent shift (Eq. H5): the shift happened between the event before it and this one; null when none (same on every row of the mode)";
    STEP_TIME: "step_time", TimestampNsUtc, nullable, "", "time of `step_event`";
    STEP_PERCENT: "step_percent", F64, nullable, "%", "100 (e^c − 1): the shift at equal intensity (negative = softening); null when none";
    STEP_P_VALUE: "step_p_value", F64, nullable, "1", "Bonferroni-adjusted p-value of the shift's F test; null when none";
});

declare!(HISTORY_EVENTS, history_events, "history_events", "history_events/history_events.parquet",
    "one row per structure and event: its date, intensity, rating, the flags of its modes, and the prediction of its response by the model of the event before (`quaketwin history`, docs/history.md)", {
    STRUCTURE: "structure", Utf8, required, "", "structure id (as in history_modes/history_modes.parquet)";
    STRUCTURE_NAME: "structure_name", Utf8, nullable, "", "the structure's name as the event's manifest or headers give it (`structure.name` of event.json)";
    EVENT: "event", Utf8, required, "", "event (the dataset's `event=` partition)";
    PARTITION: "partition", Utf8, required, "", "the event's partition `structure=<S>/event=<E>`: its tables are `DATASET/tables/<table>/<partition>/part-0.parquet`, its run directory (report.html) `DATASET/runs/<partition>/`";
    EVENT_TIME: "event_time", TimestampNsUtc, nullable, "", "origin time (event.json), else the earliest start of its channels";
    TIME_SOURCE: "time_source", Utf8, required, "", "`origin_time`, `record_start` or `unknown`";
    PEAK_BASE_M_S2: "peak_base_m_s2", F64, nullable, "m/s^2", "largest horizontal peak acceleration of the input (base, ground) channels (`pga_m_s2` of channels/channels.parquet)";
    PEAK_RESPONSE_M_S2: "peak_response_m_s2", F64, nullable, "m/s^2", "largest horizontal peak acceleration of the response (output) channels: the roof of a building, the deck of a bridge";
    INTENSITY_M_S2: "intensity_m_s2", F64, nullable, "m/s^2", "the one of the two the bands are fitted on (`--intensity`)";
    RATING: "rating", Utf8, nullable, "", "the event's colour (`rating` of assessment/assessment.parquet); null when the run had no `assess` stage";
    MODES: "modes", U32, required, "", "modes identified in the event";
    STATUS: "status", Utf8, required, "", "the event's most severe mode status: `step` (a permanent shift starts here), `below_band`, `amplitude_softened`, `above_band`, `in_band`, `no_band`, `no_modes`";
    FLAGS: "flags", ListUtf8, required, "", "one sentence per mode outside its band or starting a shift";
    PREDICTED_FROM: "predicted_from", Utf8, nullable, "", "the event whose model predicted this one's response: the latest earlier event with a model whose input and output channels this event recorded (Eqs. H7–H9); null when none";
    PREDICTION_CHANNELS: "prediction_channels", ListUtf8, required, "", "output channels of the prediction";
    PREDICTION_ERRORS: "prediction_errors", ListF64, required, "1", "normalised error ‖y − ŷ‖/‖y‖ per channel of `prediction_channels` (Eq. H9)";
    PREDICTION_ERROR_MEDIAN: "prediction_error_median", F64, nullable, "1", "median of `prediction_errors`";
    MODEL_ERROR_MEDIAN: "model_error_median", F64, nullable, "1", "median normalised error of this event's own model on its own records (Eq. H9 with the model event itself): what the model leaves out";
    NOTES: "notes", ListUtf8, required, "", "why a value is missing: no modes, no prediction and why";
});

declare!(LAB_IDENTIFICATION, lab_identification, "lab_identification", "lab_identification/lab_identification.parquet",
    "one row per lab record and model parameter: the hysteresis identified from measured displacement and force (docs/lab-tests.md), with the record's fit figures, form test and damage repeated on its rows", {
    RECORD: "record", Utf8, required, "", "the lab record (the specimen's name, or the file it was read from)";
    METHOD: "method", Utf8, required, "", "`whole_history` (the least-squares fit of Eq. L1–L9) or `stft_instantaneous` (the thesis's time–frequency identification of Eq. 15–31 on the measured force, dynamic records with a uniform time base only; its rows carry its own parameters and fit figures, docs/lab-tests.md)";
    FORM: "form", Utf8, required, "", "`plain` (Bouc–Wen) or `degrading_pinching` (Bouc–Wen–Baber–Noori, Eq. L1–L6); on `stft_instantaneous` rows `thesis_bouc_wen` (Eq. 21–23, one DoF), or `not_identified` (one row, parameter `none`, the reason in `form_reason`)";
    PARAMETER: "parameter", Utf8, required, "", "`initial_stiffness_n_per_m`, `post_yield_ratio`, `yield_displacement_m`, `beta` (γ = 1 − β), `n`, `strength_degradation` (δ_ν), `stiffness_degradation` (δ_η), `pinching_extent` (ζ_s), `pinching_rate` (p), `pinching_centre` (q), `pinching_width` (ψ); on `stft_instantaneous` rows `initial_stiffness_n_per_m` (K0), `stiffness_degradation_per_j` (δ), `beta`, `gamma` (N^(1−N)/m), `n` (N)";
    VALUE: "value", F64, required, "varies", "the identified value, in the row's `unit`";
    STD: "std", F64, required, "varies", "its standard deviation from s²(JᵀJ)⁻¹ at the optimum inflated by N/N_eff of the chosen model's residuals (Eq. L8, L8a); 0 on a fixed row, NaN when JᵀJ is singular; on `stft_instantaneous` rows the spread (standard deviation) of the instantaneous estimates over the informative frames — a measure of time variation, not a standard error";
    UNIT: "unit", Utf8, required, "", "`N/m`, `m`, `1`, `1/J` or `N^(1-N)/m`";
    FIXED: "fixed", Bool, required, "", "not fitted in this form (the plain form's degradation and pinching, held at 0)";
    FORCE_NRMSE: "force_nrmse", F64, required, "1", "NRMSE of the fitted force against the measured one (Eq. 83: RMS error over the measured force range)";
    PLAIN_NRMSE: "plain_nrmse", F64, required, "1", "the plain model's NRMSE (equal to `force_nrmse` when plain is chosen)";
    ENERGY_ERROR_MEAN: "energy_error_mean", F64, nullable, "1", "mean of |fitted − measured| / |measured| dissipated energy over the record's cycles (per cycle in lab_cycles/lab_cycles.parquet); null without a complete cycle";
    CYCLES: "cycles", U32, required, "", "displacement cycles counted (maximum to maximum, dead band `cycle_band` of the range)";
    F_STATISTIC: "f_statistic", F64, nullable, "1", "F-test of the plain model nested in the degrading/pinching one, [(S_plain − S_deg)/6] / [S_deg/(N_eff − 11)] (Eq. L9); null when only one form was fitted; on `stft_instantaneous` rows the thesis's test of the hysteretic terms against the nested linear model";
    P_VALUE: "p_value", F64, nullable, "1", "its p-value: the degrading/pinching form is chosen when p < `significance`";
    EFFECTIVE_SAMPLES: "effective_samples", U32, nullable, "", "N_eff of the F-test: N / (1 + 2 Σ_k (1 − k/N) ρ_k) over the lags before the autocorrelation ρ_k of the degrading/pinching model's residuals first drops to ≤ 0 (Eq. L8a); on `stft_instantaneous` rows the non-overlapping STFT windows";
    FORM_REASON: "form_reason", Utf8, required, "", "why this form, in words (the F-test's numbers)";
    YIELD_FORCE_N: "yield_force_n", F64, required, "N", "F_y = k₀ u_y; on `stft_instantaneous` rows the saturation force (K0/(β + γ))^(1/N) (NaN when β + γ ≤ 0)";
    DUCTILITY: "ductility", F64, required, "1", "max |x| / u_y (`stft_instantaneous`: u_y = saturation force / K0)";
    HYSTERETIC_ENERGY_J: "hysteretic_energy_j", F64, required, "J", "∫ F dx of the measured record";
    PARK_ANG: "park_ang", F64, nullable, "1", "Park–Ang index δ_max/δ_u + β_PA E_h/(F_y δ_u) (null without `ultimate_displacement_m`)";
    STIFFNESS_INDEX: "stiffness_index", F64, required, "1", "1 − sqrt(k_end/k₀), k_end = k₀ (α + (1 − α)/η_end): the single-DoF form of Eq. 34 (0 for the plain model); on `stft_instantaneous` rows ι at the end of the record, 1 − sqrt(1 − δ ε_end) (Eq. 34, negative when δ < 0: stiffening)";
    SAMPLES: "samples", U32, required, "", "samples of the record";
    SAMPLES_FITTED: "samples_fitted", U32, required, "", "samples the fit used (every k-th beyond `max_samples`)";
    QUASI_STATIC: "quasi_static", Bool, required, "", "no time base: the step index orders the samples";
});

declare!(series LAB_FIT, lab_fit, "lab_fit", "lab_fit/lab_fit.parquet",
    "one row per lab record and sample: measured and fitted force along the measured displacement (the loops)", {
    RECORD: "record", Utf8, required, "", "the lab record";
    STEP: "step", U32, required, "", "sample index (the time of a quasi-static protocol)";
    T_S: "t_s", F64, nullable, "s", "time; null for a quasi-static record";
    DISPLACEMENT_M: "displacement_m", F64, required, "m", "measured displacement";
    FORCE_MEASURED_N: "force_measured_n", F64, required, "N", "measured restoring force";
    FORCE_FITTED_N: "force_fitted_n", F64, required, "N", "force of the identified model (the chosen form) along the measured displacement";
    FORCE_PLAIN_N: "force_plain_n", F64, required, "N", "force of the plain Bouc–Wen fit (equal to `force_fitted_n` when plain is chosen)";
    FORCE_INSTANTANEOUS_N: "force_instantaneous_n", F64, nullable, "N", "force of the thesis's time–frequency identification (`stft_instantaneous`) along the measured displacement; null when it was not run or identified nothing";
});

declare!(LAB_CYCLES, lab_cycles, "lab_cycles", "lab_cycles/lab_cycles.parquet",
    "one row per lab record and displacement cycle: dissipated energy measured and fitted", {
    RECORD: "record", Utf8, required, "", "the lab record";
    CYCLE: "cycle", U32, required, "", "cycle, 1-based (displacement maximum to the next)";
    START_STEP: "start_step", U32, required, "", "first sample of the cycle";
    END_STEP: "end_step", U32, required, "", "last sample of the cycle";
    AMPLITUDE_M: "amplitude_m", F64, required, "m", "peak-to-peak displacement within the cycle";
    ENERGY_MEASURED_J: "energy_measured_j", F64, required, "J", "∮ F dx of the measured force over the cycle";
    ENERGY_FITTED_J: "energy_fitted_j", F64, required, "J", "∮ F dx of the fitted force over the cycle";
    ENERGY_ERROR: "energy_error", F64, required, "1", "(fitted − measured) / |measured|";
    ENERGY_INSTANTANEOUS_J: "energy_instantaneous_j", F64, nullable, "J", "∮ F dx of the `stft_instantaneous` model's force over the cycle; null when it was not run";
});

/// Every table quaketwin writes, in pipeline order.
pub const ALL_TABLES: &[&TableSchema] = &[
    &EVENT,
    &SAMPLES,
    &CHANNELS,
    &SPECTRA,
    &FOURIER,
    &DRIFT,
    &STABILIZATION,
    &MODES,
    &MODE_SHAPES,
    &MODAL_SPECTRUM,
    &FREQUENCY_SHIFTS,
    &BOUC_WEN,
    &BOUC_WEN_INSTANTANEOUS,
    &HYSTERESIS_FIT,
    &DAMAGE,
    &LAB_IDENTIFICATION,
    &LAB_FIT,
    &LAB_CYCLES,
    &TWIN_UPDATE,
    &TWIN_MODES,
    &ACTUATOR_LAYOUT,
    &POD,
    &REDUCTION_VALIDATION,
    &INTERFACE_REFINEMENT,
    &HYBRID_PROTOTYPE,
    &REHEARSAL_SUMMARY,
    &REHEARSAL,
    &COMPARE_TEST_SUMMARY,
    &COMPARE_TEST_ACTUATORS,
    &COMPARE_TEST,
    &FREQUENCY_TRACK,
    &ASSESSMENT,
    &MODAL_TRACKING,
    &CONTROL_CHART,
    &CHANGE_REFERENCE,
    &CHANGE_TEST,
    &HISTORY_MODES,
    &HISTORY_EVENTS,
];

/// The declared table of a `quaketwin.schema` name.
pub fn by_name(name: &str) -> Option<&'static TableSchema> {
    ALL_TABLES.iter().copied().find(|t| t.name == name)
}

/// The file, relative to a run's output directory, of the declared table
/// `name` (`modes` → `modes/modes.parquet`; an undeclared name gets the same
/// folder-of-its-own form).
pub fn table_file_of(name: &str) -> String {
    by_name(name)
        .map(|t| t.file.to_string())
        .unwrap_or_else(|| super::schema::table_file(&format!("{name}.parquet")))
}
