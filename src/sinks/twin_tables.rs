//! Twin-updating tables: `twin_update/twin_update.parquet` (one row per round and candidate of the
//! ensemble, thesis Table 1), `twin_modes/twin_modes.parquet` (paired modes before and after updating)
//! and the reader of the measured modes in `modes/modes.parquet` (written by the modal stage).
//! Schemas are documented in docs/formats.md.

use std::collections::BTreeSet;
use std::path::Path;

use arrow_array::cast::AsArray;
use arrow_array::types::{Float64Type, Int32Type, Int64Type, UInt32Type};
use arrow_array::{Array, ArrayRef, RecordBatch};
use arrow_schema::DataType;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

use super::parquet::{write_parquet, TableBuilder};
use super::provenance::Provenance;
use crate::error::{Error, Location, Result};
use crate::twin::ensemble::EnsembleResult;
use crate::twin::objective::{MeasuredMode, MeasuredModes, ModeComparison};
use crate::vocab::tables::{modes, twin_modes, twin_update, TWIN_MODES, TWIN_UPDATE};

/// File metadata key of the output channel ids (JSON list) in modes/modes.parquet.
pub use super::modal_tables::OUTPUT_CHANNELS_KEY;
/// File metadata key of the schema name.
pub use crate::vocab::schema::SCHEMA_KEY;
/// File metadata key of the error summary (JSON) in twin_modes/twin_modes.parquet.
pub const SUMMARY_KEY: &str = "quaketwin.summary";

/// Measured modes as read from modes/modes.parquet, with the file's mode numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct ModesFile {
    pub measured: MeasuredModes,
    /// `mode` column value of each measured mode (same order as `measured.modes`).
    pub mode_numbers: Vec<u32>,
    /// The event and processing history the modes come from (`None` for a
    /// table without quaketwin's provenance keys).
    pub provenance: Option<Provenance>,
}

/// Read measured modes from `modes/modes.parquet` (columns named by the declaration
/// [`crate::vocab::tables::MODES`], but tolerant of the types other tools write): `mode` (UInt32/Int32/Int64), `frequency_hz`
/// (Float64), `shape_re` (list<f64>, one entry per output channel), optional `shape_im`,
/// and the channel ids as a JSON list in the `quaketwin.output_channels` metadata entry.
/// Modes come out sorted by mode number.
pub fn read_measured_modes(path: &Path) -> Result<ModesFile> {
    let source = path.display().to_string();
    let loc = || Location::file(source.clone());
    let file = crate::input_file::open(path)?;
    let builder = ParquetRecordBatchReaderBuilder::try_new(file)
        .map_err(|e| Error::input(loc(), format!("not a readable Parquet file: {e}")))?;
    let kv = builder
        .metadata()
        .file_metadata()
        .key_value_metadata()
        .cloned()
        .unwrap_or_default();
    let channels_json = kv
        .iter()
        .find(|e| e.key == OUTPUT_CHANNELS_KEY)
        .and_then(|e| e.value.clone())
        .ok_or_else(|| {
            Error::input(
                loc(),
                format!("metadata entry {OUTPUT_CHANNELS_KEY} (output channel ids) missing"),
            )
        })?;
    let channels: Vec<String> = serde_json::from_str(&channels_json).map_err(|e| {
        Error::input(
            loc(),
            format!("metadata entry {OUTPUT_CHANNELS_KEY} is not a JSON list of strings: {e}"),
        )
    })?;
    let mut seen = BTreeSet::new();
    for c in &channels {
        if !seen.insert(c.as_str()) {
            return Err(Error::input(
                loc().with_channel(c.clone()),
                format!("channel listed twice in {OUTPUT_CHANNELS_KEY}"),
            ));
        }
    }
    let schema = builder.schema().clone();
    let missing: Vec<&str> = [modes::MODE, modes::FREQUENCY_HZ, modes::SHAPE_RE]
        .into_iter()
        .map(|c| c.name)
        .filter(|c| schema.field_with_name(c).is_err())
        .collect();
    if !missing.is_empty() {
        return Err(Error::input(
            loc(),
            format!("modes table lacks column(s): {}", missing.join(", ")),
        ));
    }
    let reader = builder
        .build()
        .map_err(|e| Error::input(loc(), e.to_string()))?;
    let mut rows: Vec<(u32, MeasuredMode)> = Vec::new();
    for batch in reader {
        let batch: RecordBatch = batch.map_err(|e| Error::input(loc(), e.to_string()))?;
        let col = |name: &str| -> Result<&ArrayRef> {
            batch
                .column_by_name(name)
                .ok_or_else(|| Error::input(loc(), format!("column {name} missing")))
        };
        let numbers = mode_numbers(col(modes::MODE.name)?, &loc)?;
        // The declared type, nullability aside (nulls are refused per row).
        let freq_field = batch
            .schema_ref()
            .field_with_name(modes::FREQUENCY_HZ.name)
            .cloned();
        if let Some(m) = freq_field
            .ok()
            .and_then(|f| modes::FREQUENCY_HZ.type_mismatch(&f))
        {
            return Err(Error::input(loc(), m));
        }
        let freq = col(modes::FREQUENCY_HZ.name)?.as_primitive::<Float64Type>();
        let shape_re = col(modes::SHAPE_RE.name)?;
        let shape_im = batch.column_by_name(modes::SHAPE_IM.name);
        for (i, number) in numbers.iter().enumerate() {
            let row_err = |m: String| Error::input(loc(), format!("mode {number}: {m}"));
            if freq.is_null(i) {
                return Err(row_err("frequency_hz is null".into()));
            }
            let re = list_row(shape_re, i, modes::SHAPE_RE.name).map_err(row_err)?;
            let im = match shape_im {
                Some(a) => Some(list_row(a, i, modes::SHAPE_IM.name).map_err(row_err)?),
                None => None,
            };
            if re.len() != channels.len() || im.as_ref().is_some_and(|v| v.len() != re.len()) {
                return Err(row_err(format!(
                    "{} shape components for {} output channels",
                    re.len(),
                    channels.len()
                )));
            }
            let shape = match im {
                Some(im) => real_shape(&re, &im),
                None => re,
            };
            rows.push((
                *number,
                MeasuredMode {
                    frequency_hz: freq.value(i),
                    shape,
                },
            ));
        }
    }
    rows.sort_by_key(|(n, _)| *n);
    if let Some(w) = rows.windows(2).find(|w| w[0].0 == w[1].0) {
        return Err(Error::input(
            loc(),
            format!("mode number {} appears twice", w[0].0),
        ));
    }
    let provenance =
        Provenance::from_metadata(kv.iter().map(|e| (e.key.as_str(), e.value.as_deref())));
    Ok(ModesFile {
        provenance,
        mode_numbers: rows.iter().map(|(n, _)| *n).collect(),
        measured: MeasuredModes {
            source,
            channels,
            modes: rows.into_iter().map(|(_, m)| m).collect(),
        },
    })
}

/// The `mode` column as u32 (UInt32, Int32 or Int64; negative or null values are errors).
fn mode_numbers(a: &ArrayRef, loc: &dyn Fn() -> Location) -> Result<Vec<u32>> {
    if a.null_count() > 0 {
        return Err(Error::input(loc(), "column mode has null values"));
    }
    let bad = |v: i64| Error::input(loc(), format!("mode number {v} is not a valid mode number"));
    match a.data_type() {
        DataType::UInt32 => Ok(a.as_primitive::<UInt32Type>().values().to_vec()),
        DataType::Int32 => a
            .as_primitive::<Int32Type>()
            .values()
            .iter()
            .map(|v| u32::try_from(*v).map_err(|_| bad(*v as i64)))
            .collect(),
        DataType::Int64 => a
            .as_primitive::<Int64Type>()
            .values()
            .iter()
            .map(|v| u32::try_from(*v).map_err(|_| bad(*v)))
            .collect(),
        t => Err(Error::input(
            loc(),
            format!("column mode has type {t}, expected UInt32 or Int64"),
        )),
    }
}

/// Row `i` of a list<f64> column (List or LargeList), nulls rejected.
fn list_row(a: &ArrayRef, i: usize, name: &str) -> std::result::Result<Vec<f64>, String> {
    if a.is_null(i) {
        return Err(format!("{name} is null"));
    }
    let values = match a.data_type() {
        DataType::List(_) => a.as_list::<i32>().value(i),
        DataType::LargeList(_) => a.as_list::<i64>().value(i),
        t => return Err(format!("column {name} has type {t}, expected list<f64>")),
    };
    let values = values
        .as_primitive_opt::<Float64Type>()
        .ok_or_else(|| format!("column {name} is not a list of Float64"))?;
    if values.null_count() > 0 {
        return Err(format!("{name} has null entries"));
    }
    Ok(values.values().to_vec())
}

/// Real mode shape of a complex shape φ = a + i b: the real part after the rotation
/// e^{−iθ} that maximises Σ Re(e^{−iθ} φ_k)², i.e. the projection on the best-fitting real
/// line, θ = ½·atan2(2 Σ a_k b_k, Σ (a_k² − b_k²)). For a real (monophase) shape up to a
/// common phase this returns the shape exactly, up to sign; the twin's MAC ignores the sign.
pub fn real_shape(re: &[f64], im: &[f64]) -> Vec<f64> {
    let ab: f64 = re.iter().zip(im).map(|(a, b)| a * b).sum();
    let aa_bb: f64 = re.iter().zip(im).map(|(a, b)| a * a - b * b).sum();
    let theta = 0.5 * (2.0 * ab).atan2(aa_bb);
    let (s, c) = theta.sin_cos();
    re.iter().zip(im).map(|(a, b)| a * c + b * s).collect()
}

/// Each parameter's unit (`Pa`, `kg/m^3`, `N/m`…), from the
/// `quaketwin.parameter_bounds` entry of `metadata` (`name`, `unit`): the
/// unit of its `param_<name>` column.
fn parameter_units(metadata: &[(String, String)]) -> std::collections::HashMap<String, String> {
    metadata
        .iter()
        .filter(|(k, _)| k == "quaketwin.parameter_bounds")
        .filter_map(|(_, v)| serde_json::from_str::<Vec<serde_json::Value>>(v).ok())
        .flatten()
        .filter_map(|b| {
            let name = b["name"].as_str()?.to_string();
            Some((name, b["unit"].as_str()?.to_string()))
        })
        .collect()
}

/// Write `twin_update/twin_update.parquet`: one row per round and candidate. `parameter_names` name the
/// `param_<name>` columns (ensemble parameter order); `metadata` is appended to the file's
/// key/value metadata (e.g. settings).
pub fn write_twin_update(
    path: &Path,
    parameter_names: &[String],
    result: &EnsembleResult,
    metadata: &[(String, String)],
) -> Result<()> {
    let rows: Vec<_> = result
        .rounds
        .iter()
        .flat_map(|r| r.candidates.iter())
        .collect();
    let units = parameter_units(metadata);
    let mut t = TableBuilder::new(&TWIN_UPDATE)
        .u32(
            twin_update::ROUND,
            rows.iter().map(|c| c.round as u32).collect(),
        )
        .u32(
            twin_update::CANDIDATE,
            rows.iter().map(|c| c.candidate as u32).collect(),
        )
        .str(
            twin_update::SOLVER,
            &rows.iter().map(|c| c.solver.as_str()).collect::<Vec<_>>(),
        );
    for (q, name) in parameter_names.iter().enumerate() {
        let mut values = Vec::with_capacity(rows.len());
        for c in &rows {
            let v = c.parameters.get(q).copied().ok_or_else(|| {
                Error::output(path, format!("candidate has no value for parameter {name}"))
            })?;
            values.push(v);
        }
        t = t.f64(twin_update::PARAM.member(name), values);
        // Without bounds (a caller other than the update stage) the column
        // keeps the family's `varies`.
        if let Some(unit) = units.get(name.as_str()) {
            t = t.with_unit(unit);
        }
    }
    let batch = t
        .f64(
            twin_update::OBJECTIVE_J,
            rows.iter().map(|c| c.objective).collect(),
        )
        .list_f64(
            twin_update::Z,
            &rows.iter().map(|c| c.z.clone()).collect::<Vec<_>>(),
        )
        .list_f64(
            twin_update::SCATTER,
            &rows.iter().map(|c| c.scatters.clone()).collect::<Vec<_>>(),
        )
        .list_f64(
            twin_update::SCORE,
            &rows.iter().map(|c| c.scores.clone()).collect::<Vec<_>>(),
        )
        .u32(
            twin_update::RANK,
            rows.iter().map(|c| c.rank as u32).collect(),
        )
        .f64(
            twin_update::SELECTION_WEIGHT,
            rows.iter().map(|c| c.selection_weight).collect(),
        )
        .bool(
            twin_update::SELECTED,
            rows.iter().map(|c| c.selected).collect(),
        )
        .i64(
            twin_update::EVALUATIONS,
            rows.iter().map(|c| c.evaluations as i64).collect(),
        )
        .build()?;
    let rounds: Vec<serde_json::Value> = result
        .rounds
        .iter()
        .map(|r| {
            serde_json::json!({
                "round": r.round,
                "start": r.start,
                "ranking": r.ranking,
                "log_probability": r.log_probability,
                "ranking_method": format!("{:?}", r.method),
                "selected_parameters": r.selected_parameters,
                "selected_objective": r.selected_objective,
                "variance": r.variance,
                "converged": r.converged,
            })
        })
        .collect();
    let mut meta = vec![
        (
            "quaketwin.parameters".to_string(),
            serde_json::json!(parameter_names).to_string(),
        ),
        (
            "quaketwin.voters".to_string(),
            serde_json::json!({"names": result.voter_names, "measured": result.measured})
                .to_string(),
        ),
        (
            "quaketwin.rounds".to_string(),
            serde_json::Value::Array(rounds).to_string(),
        ),
        (
            "quaketwin.result".to_string(),
            serde_json::json!({
                "parameters": result.parameters,
                "objective_j": result.objective,
                "converged": result.converged,
                "evaluations": result.evaluations,
            })
            .to_string(),
        ),
    ];
    meta.extend(metadata.iter().cloned());
    write_parquet(path, &[batch], &meta)
}

/// Write `twin_modes/twin_modes.parquet`: the paired modes at the start values (`stage` "initial") and
/// at the updated values ("updated"). `mode_numbers` are the measured modes' numbers (from
/// modes/modes.parquet); the mean errors of `ModeComparison` go into `quaketwin.summary`.
pub fn write_twin_modes(
    path: &Path,
    mode_numbers: &[u32],
    initial: &ModeComparison,
    updated: &ModeComparison,
    metadata: &[(String, String)],
) -> Result<()> {
    let mut stage = Vec::new();
    let mut mode = Vec::new();
    let mut model_mode = Vec::new();
    let mut f_exp = Vec::new();
    let mut f_num = Vec::new();
    let mut rel_error = Vec::new();
    let mut mac = Vec::new();
    for (name, cmp) in [("initial", initial), ("updated", updated)] {
        for p in &cmp.pairs {
            stage.push(name);
            mode.push(
                mode_numbers
                    .get(p.measured)
                    .copied()
                    .unwrap_or(p.measured as u32 + 1),
            );
            // Unpaired measured mode (the model had fewer modes): no model frequency.
            let paired = p.model.is_some();
            model_mode.push(p.model.map(|j| j as i32 + 1));
            f_exp.push(p.f_exp);
            f_num.push(paired.then_some(p.f_num));
            rel_error.push(paired.then(|| (p.f_exp - p.f_num).abs() / p.f_exp));
            mac.push(p.mac);
        }
    }
    let batch = TableBuilder::new(&TWIN_MODES)
        .str(twin_modes::STAGE, &stage)
        .u32(twin_modes::MODE, mode)
        .opt_i32(twin_modes::MODEL_MODE, model_mode)
        .f64(twin_modes::F_EXP_HZ, f_exp)
        .opt_f64(twin_modes::F_NUM_HZ, f_num)
        .opt_f64(twin_modes::REL_ERROR, rel_error)
        .f64(twin_modes::MAC, mac)
        .build()?;
    let summary = serde_json::json!({
        "initial": {"frequency_error": initial.frequency_error, "shape_error": initial.shape_error},
        "updated": {"frequency_error": updated.frequency_error, "shape_error": updated.shape_error},
        "frequency_error": "mean over measured modes of |f_exp - f_num| / f_exp (unpaired modes count 1)",
        "shape_error": "mean over measured modes of (1 - MAC)",
    });
    let mut meta = vec![(SUMMARY_KEY.to_string(), summary.to_string())];
    meta.extend(metadata.iter().cloned());
    write_parquet(path, &[batch], &meta)
}
