//! `history_modes/history_modes.parquet` and `history_events/history_events.parquet` (`quaketwin
//! history`, docs/history.md): one row type per table, written from the
//! declarations and read back the same way, so that `watch` and the
//! dashboard read a structure's history as the rows `history` wrote.

use std::path::Path;

use arrow_array::{
    Array, BooleanArray, Float64Array, ListArray, StringArray, TimestampNanosecondArray,
    UInt32Array,
};

use super::parquet::{write_parquet, ReadTable, TableBuilder};
use crate::error::{Error, Result};
use crate::vocab::schema::{ColumnSpec, TableSchema, SCHEMA_KEY};
use crate::vocab::tables::{
    history_events as ev, history_modes as md, HISTORY_EVENTS, HISTORY_MODES,
};

/// Metadata key of the fitted bands (JSON list, one entry per structure
/// and mode: docs/formats.md).
pub const MODELS_KEY: &str = "quaketwin.history_models";

/// One row of `history_modes/history_modes.parquet` (columns: docs/formats.md).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct HistoryModeRow {
    pub structure: String,
    pub event: String,
    pub event_time_ns: Option<i64>,
    pub mode: u32,
    pub direction: String,
    pub event_mode: u32,
    pub event_direction: String,
    pub frequency_hz: f64,
    pub frequency_std_hz: f64,
    pub damping_ratio: f64,
    pub paired_with_event: Option<String>,
    pub mac: Option<f64>,
    pub intensity_m_s2: Option<f64>,
    pub predicted_frequency_hz: Option<f64>,
    pub band_low_hz: Option<f64>,
    pub band_high_hz: Option<f64>,
    pub deviation_percent: Option<f64>,
    pub status: String,
    pub fitted: bool,
    pub after_step: bool,
    pub step_event: Option<String>,
    pub step_time_ns: Option<i64>,
    pub step_percent: Option<f64>,
    pub step_p_value: Option<f64>,
}

/// One row of `history_events/history_events.parquet` (columns: docs/formats.md).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct HistoryEventRow {
    pub structure: String,
    pub structure_name: Option<String>,
    pub event: String,
    pub partition: String,
    pub event_time_ns: Option<i64>,
    pub time_source: String,
    pub peak_base_m_s2: Option<f64>,
    pub peak_response_m_s2: Option<f64>,
    pub intensity_m_s2: Option<f64>,
    pub rating: Option<String>,
    pub modes: u32,
    pub status: String,
    pub flags: Vec<String>,
    pub predicted_from: Option<String>,
    pub prediction_channels: Vec<String>,
    pub prediction_errors: Vec<f64>,
    pub prediction_error_median: Option<f64>,
    pub model_error_median: Option<f64>,
    pub notes: Vec<String>,
}

/// Writes `history_modes/history_modes.parquet` with `metadata` (provenance, models).
pub fn write_modes(
    path: &Path,
    rows: &[HistoryModeRow],
    metadata: &[(String, String)],
) -> Result<()> {
    let s = |f: fn(&HistoryModeRow) -> &str| rows.iter().map(f).collect::<Vec<&str>>();
    let os = |f: fn(&HistoryModeRow) -> Option<&str>| rows.iter().map(f).collect::<Vec<_>>();
    let f = |f: fn(&HistoryModeRow) -> f64| rows.iter().map(f).collect::<Vec<f64>>();
    let of = |f: fn(&HistoryModeRow) -> Option<f64>| rows.iter().map(f).collect::<Vec<_>>();
    let batch = TableBuilder::new(&HISTORY_MODES)
        .str(md::STRUCTURE.name, &s(|r| &r.structure))
        .str(md::EVENT.name, &s(|r| &r.event))
        .opt_timestamp_ns(
            md::EVENT_TIME.name,
            rows.iter().map(|r| r.event_time_ns).collect(),
        )
        .u32(md::MODE.name, rows.iter().map(|r| r.mode).collect())
        .str(md::DIRECTION.name, &s(|r| &r.direction))
        .u32(
            md::EVENT_MODE.name,
            rows.iter().map(|r| r.event_mode).collect(),
        )
        .str(md::EVENT_DIRECTION.name, &s(|r| &r.event_direction))
        .f64(md::FREQUENCY_HZ.name, f(|r| r.frequency_hz))
        .f64(md::FREQUENCY_STD_HZ.name, f(|r| r.frequency_std_hz))
        .f64(md::DAMPING_RATIO.name, f(|r| r.damping_ratio))
        .opt_str(
            md::PAIRED_WITH_EVENT.name,
            &os(|r| r.paired_with_event.as_deref()),
        )
        .opt_f64(md::MAC.name, of(|r| r.mac))
        .opt_f64(md::INTENSITY_M_S2.name, of(|r| r.intensity_m_s2))
        .opt_f64(
            md::PREDICTED_FREQUENCY_HZ.name,
            of(|r| r.predicted_frequency_hz),
        )
        .opt_f64(md::BAND_LOW_HZ.name, of(|r| r.band_low_hz))
        .opt_f64(md::BAND_HIGH_HZ.name, of(|r| r.band_high_hz))
        .opt_f64(md::DEVIATION_PERCENT.name, of(|r| r.deviation_percent))
        .str(md::STATUS.name, &s(|r| &r.status))
        .bool(md::FITTED.name, rows.iter().map(|r| r.fitted).collect())
        .bool(
            md::AFTER_STEP.name,
            rows.iter().map(|r| r.after_step).collect(),
        )
        .opt_str(md::STEP_EVENT.name, &os(|r| r.step_event.as_deref()))
        .opt_timestamp_ns(
            md::STEP_TIME.name,
            rows.iter().map(|r| r.step_time_ns).collect(),
        )
        .opt_f64(md::STEP_PERCENT.name, of(|r| r.step_percent))
        .opt_f64(md::STEP_P_VALUE.name, of(|r| r.step_p_value))
        .build()?;
    write_parquet(path, &[batch], metadata)
}

/// Writes `history_events/history_events.parquet` with `metadata` (provenance).
pub fn write_events(
    path: &Path,
    rows: &[HistoryEventRow],
    metadata: &[(String, String)],
) -> Result<()> {
    let s = |f: fn(&HistoryEventRow) -> &str| rows.iter().map(f).collect::<Vec<&str>>();
    let os = |f: fn(&HistoryEventRow) -> Option<&str>| rows.iter().map(f).collect::<Vec<_>>();
    let of = |f: fn(&HistoryEventRow) -> Option<f64>| rows.iter().map(f).collect::<Vec<_>>();
    let batch = TableBuilder::new(&HISTORY_EVENTS)
        .str(ev::STRUCTURE.name, &s(|r| &r.structure))
        .opt_str(
            ev::STRUCTURE_NAME.name,
            &os(|r| r.structure_name.as_deref()),
        )
        .str(ev::EVENT.name, &s(|r| &r.event))
        .str(ev::PARTITION.name, &s(|r| &r.partition))
        .opt_timestamp_ns(
            ev::EVENT_TIME.name,
            rows.iter().map(|r| r.event_time_ns).collect(),
        )
        .str(ev::TIME_SOURCE.name, &s(|r| &r.time_source))
        .opt_f64(ev::PEAK_BASE_M_S2.name, of(|r| r.peak_base_m_s2))
        .opt_f64(ev::PEAK_RESPONSE_M_S2.name, of(|r| r.peak_response_m_s2))
        .opt_f64(ev::INTENSITY_M_S2.name, of(|r| r.intensity_m_s2))
        .opt_str(ev::RATING.name, &os(|r| r.rating.as_deref()))
        .u32(ev::MODES.name, rows.iter().map(|r| r.modes).collect())
        .str(ev::STATUS.name, &s(|r| &r.status))
        .list_str(
            ev::FLAGS.name,
            &rows.iter().map(|r| r.flags.clone()).collect::<Vec<_>>(),
        )
        .opt_str(
            ev::PREDICTED_FROM.name,
            &os(|r| r.predicted_from.as_deref()),
        )
        .list_str(
            ev::PREDICTION_CHANNELS.name,
            &rows
                .iter()
                .map(|r| r.prediction_channels.clone())
                .collect::<Vec<_>>(),
        )
        .list_f64(
            ev::PREDICTION_ERRORS.name,
            &rows
                .iter()
                .map(|r| r.prediction_errors.clone())
                .collect::<Vec<_>>(),
        )
        .opt_f64(
            ev::PREDICTION_ERROR_MEDIAN.name,
            of(|r| r.prediction_error_median),
        )
        .opt_f64(ev::MODEL_ERROR_MEDIAN.name, of(|r| r.model_error_median))
        .list_str(
            ev::NOTES.name,
            &rows.iter().map(|r| r.notes.clone()).collect::<Vec<_>>(),
        )
        .build()?;
    write_parquet(path, &[batch], metadata)
}

/// Opens a table and checks that it is the declared `schema`.
fn open(path: &Path, schema: &TableSchema) -> Result<ReadTable> {
    let table = ReadTable::open(path)?;
    match table.metadata(SCHEMA_KEY) {
        Some(name) if name == schema.name => Ok(table),
        other => Err(Error::input(
            table.location(),
            format!(
                "not a quaketwin {} (schema {})",
                schema.file,
                other.unwrap_or("not stated")
            ),
        )),
    }
}

/// Typed column access of one batch, nulls as `None`.
struct Columns<'a> {
    table: &'a ReadTable,
    batch: &'a arrow_array::RecordBatch,
}

impl Columns<'_> {
    fn text(&self, c: &ColumnSpec) -> Result<Vec<Option<String>>> {
        let a: StringArray = self.table.declared(self.batch, c)?;
        Ok((0..a.len())
            .map(|i| a.is_valid(i).then(|| a.value(i).to_string()))
            .collect())
    }
    fn number(&self, c: &ColumnSpec) -> Result<Vec<Option<f64>>> {
        let a: Float64Array = self.table.declared(self.batch, c)?;
        Ok((0..a.len())
            .map(|i| a.is_valid(i).then(|| a.value(i)))
            .collect())
    }
    fn count(&self, c: &ColumnSpec) -> Result<Vec<u32>> {
        let a: UInt32Array = self.table.declared(self.batch, c)?;
        Ok(a.values().to_vec())
    }
    fn flag(&self, c: &ColumnSpec) -> Result<Vec<bool>> {
        let a: BooleanArray = self.table.declared(self.batch, c)?;
        Ok((0..a.len()).map(|i| a.value(i)).collect())
    }
    fn time(&self, c: &ColumnSpec) -> Result<Vec<Option<i64>>> {
        let a: TimestampNanosecondArray = self.table.declared(self.batch, c)?;
        Ok((0..a.len())
            .map(|i| a.is_valid(i).then(|| a.value(i)))
            .collect())
    }
    fn texts(&self, c: &ColumnSpec) -> Result<Vec<Vec<String>>> {
        let a: ListArray = self.table.declared(self.batch, c)?;
        Ok((0..a.len())
            .map(|i| {
                let v = a.value(i);
                v.as_any()
                    .downcast_ref::<StringArray>()
                    .map(|s| (0..s.len()).map(|k| s.value(k).to_string()).collect())
                    .unwrap_or_default()
            })
            .collect())
    }
    fn numbers(&self, c: &ColumnSpec) -> Result<Vec<Vec<f64>>> {
        let a: ListArray = self.table.declared(self.batch, c)?;
        Ok((0..a.len())
            .map(|i| {
                let v = a.value(i);
                v.as_any()
                    .downcast_ref::<Float64Array>()
                    .map(|s| s.values().to_vec())
                    .unwrap_or_default()
            })
            .collect())
    }
}

fn required(v: Option<String>) -> String {
    v.unwrap_or_default()
}

/// Reads `history_modes/history_modes.parquet` back, in file order.
pub fn read_modes(path: &Path) -> Result<Vec<HistoryModeRow>> {
    let table = open(path, &HISTORY_MODES)?;
    let mut rows = Vec::new();
    for batch in &table.batches {
        let c = Columns {
            table: &table,
            batch,
        };
        let (structure, event, direction, event_direction, status) = (
            c.text(&md::STRUCTURE)?,
            c.text(&md::EVENT)?,
            c.text(&md::DIRECTION)?,
            c.text(&md::EVENT_DIRECTION)?,
            c.text(&md::STATUS)?,
        );
        let (paired, step_event) = (c.text(&md::PAIRED_WITH_EVENT)?, c.text(&md::STEP_EVENT)?);
        let (time, step_time) = (c.time(&md::EVENT_TIME)?, c.time(&md::STEP_TIME)?);
        let (mode, event_mode) = (c.count(&md::MODE)?, c.count(&md::EVENT_MODE)?);
        let (fitted, after_step) = (c.flag(&md::FITTED)?, c.flag(&md::AFTER_STEP)?);
        let n = |s: &ColumnSpec| c.number(s);
        let (f, fs, z, mac, a) = (
            n(&md::FREQUENCY_HZ)?,
            n(&md::FREQUENCY_STD_HZ)?,
            n(&md::DAMPING_RATIO)?,
            n(&md::MAC)?,
            n(&md::INTENSITY_M_S2)?,
        );
        let (pred, lo, hi, dev) = (
            n(&md::PREDICTED_FREQUENCY_HZ)?,
            n(&md::BAND_LOW_HZ)?,
            n(&md::BAND_HIGH_HZ)?,
            n(&md::DEVIATION_PERCENT)?,
        );
        let (sp, spv) = (n(&md::STEP_PERCENT)?, n(&md::STEP_P_VALUE)?);
        for i in 0..batch.num_rows() {
            rows.push(HistoryModeRow {
                structure: required(structure[i].clone()),
                event: required(event[i].clone()),
                event_time_ns: time[i],
                mode: mode[i],
                direction: required(direction[i].clone()),
                event_mode: event_mode[i],
                event_direction: required(event_direction[i].clone()),
                frequency_hz: f[i].unwrap_or(f64::NAN),
                frequency_std_hz: fs[i].unwrap_or(f64::NAN),
                damping_ratio: z[i].unwrap_or(f64::NAN),
                paired_with_event: paired[i].clone(),
                mac: mac[i],
                intensity_m_s2: a[i],
                predicted_frequency_hz: pred[i],
                band_low_hz: lo[i],
                band_high_hz: hi[i],
                deviation_percent: dev[i],
                status: required(status[i].clone()),
                fitted: fitted[i],
                after_step: after_step[i],
                step_event: step_event[i].clone(),
                step_time_ns: step_time[i],
                step_percent: sp[i],
                step_p_value: spv[i],
            });
        }
    }
    Ok(rows)
}

/// Reads `history_events/history_events.parquet` back, in file order.
pub fn read_events(path: &Path) -> Result<Vec<HistoryEventRow>> {
    let table = open(path, &HISTORY_EVENTS)?;
    let mut rows = Vec::new();
    for batch in &table.batches {
        let c = Columns {
            table: &table,
            batch,
        };
        let (structure, name, event, partition, source, rating, status, from) = (
            c.text(&ev::STRUCTURE)?,
            c.text(&ev::STRUCTURE_NAME)?,
            c.text(&ev::EVENT)?,
            c.text(&ev::PARTITION)?,
            c.text(&ev::TIME_SOURCE)?,
            c.text(&ev::RATING)?,
            c.text(&ev::STATUS)?,
            c.text(&ev::PREDICTED_FROM)?,
        );
        let time = c.time(&ev::EVENT_TIME)?;
        let n = |s: &ColumnSpec| c.number(s);
        let (base, response, intensity, pmed, mmed) = (
            n(&ev::PEAK_BASE_M_S2)?,
            n(&ev::PEAK_RESPONSE_M_S2)?,
            n(&ev::INTENSITY_M_S2)?,
            n(&ev::PREDICTION_ERROR_MEDIAN)?,
            n(&ev::MODEL_ERROR_MEDIAN)?,
        );
        let modes = c.count(&ev::MODES)?;
        let (flags, channels, notes) = (
            c.texts(&ev::FLAGS)?,
            c.texts(&ev::PREDICTION_CHANNELS)?,
            c.texts(&ev::NOTES)?,
        );
        let errors = c.numbers(&ev::PREDICTION_ERRORS)?;
        for i in 0..batch.num_rows() {
            rows.push(HistoryEventRow {
                structure: required(structure[i].clone()),
                structure_name: name[i].clone(),
                event: required(event[i].clone()),
                partition: required(partition[i].clone()),
                event_time_ns: time[i],
                time_source: required(source[i].clone()),
                peak_base_m_s2: base[i],
                peak_response_m_s2: response[i],
                intensity_m_s2: intensity[i],
                rating: rating[i].clone(),
                modes: modes[i],
                status: required(status[i].clone()),
                flags: flags[i].clone(),
                predicted_from: from[i].clone(),
                prediction_channels: channels[i].clone(),
                prediction_errors: errors[i].clone(),
                prediction_error_median: pmed[i],
                model_error_median: mmed[i],
                notes: notes[i].clone(),
            });
        }
    }
    Ok(rows)
}
