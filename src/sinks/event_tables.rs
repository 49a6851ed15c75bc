//! The backbone's Parquet tables (schemas in docs/formats.md):
//! `channels/channels.parquet` (metadata, QA, metrics — one row per channel),
//! `samples/samples.parquet` (acceleration, velocity, displacement per channel and
//! time — long format), `spectra/spectra.parquet` (response spectra, long format),
//! `drift/drift.parquet` (peak inter-storey drift ratios).  `samples/samples.parquet` also
//! carries the channels and the processing history as JSON metadata so a
//! later stage can load the conditioned event back without re-running.

use std::path::Path;

use arrow_array::{Array, Float64Array, StringArray};

use super::parquet::{write_parquet, write_parquet_stream, ReadTable, TableBuilder};
use crate::conditioning::Motion;
use crate::error::{Error, Result};
use crate::metrics::{DriftRow, DriftTable, ResidualDrift, StrongMotionMetrics};
use crate::vocab::tables::{
    channels, drift, event as ev, samples, spectra, CHANNELS, DRIFT, EVENT, SAMPLES, SPECTRA,
};
use crate::vocab::{Channel, Direction, Event, ProcessingHistory, Record, SampleStore, Samples};
use std::sync::Arc;

pub use super::provenance::{EVENT_KEY, HISTORY_KEY};
pub use crate::vocab::schema::SCHEMA_KEY;
pub const CHANNELS_KEY: &str = "quaketwin.channels";

fn direction_text(d: &Option<Direction>) -> Option<String> {
    d.map(|d| d.to_string())
}

fn azimuth(d: &Option<Direction>) -> Option<f64> {
    match d {
        Some(Direction::Azimuth(a)) => Some(*a),
        _ => None,
    }
}

/// What the absolute times of a channel's samples count from (the `time`
/// column of samples/samples.parquet, `time_source` of channels/channels.parquet): the
/// record's own start, else the event's origin time (the first sample taken
/// at the origin: late or early by the record's unknown trigger delay, as
/// the MCAP writer does), else nothing.  The start in ns and its name.
pub fn time_base(channel: &Channel, origin_ns: Option<i64>) -> (Option<i64>, &'static str) {
    match (channel.start_ns, origin_ns) {
        (Some(s), _) => (Some(s), "record_start"),
        (None, Some(o)) => (Some(o), "origin_time"),
        (None, None) => (None, "unknown"),
    }
}

/// Event-level metadata stored in every table's key/value metadata.
fn event_metadata(event: &Event) -> Vec<(String, String)> {
    super::provenance::Provenance::of_event(event).metadata()
}

/// `event/event.parquet`: one row, the event and its structure — the ids
/// `(structure_id, event_id)` a many-event dataset partitions by
/// (`pipeline::dataset::event_ids`) beside the free-text names.
pub fn write_event(path: &Path, event: &Event, ids: (&str, &str)) -> Result<()> {
    let s = event.structure.as_ref();
    let record_start = event
        .records
        .iter()
        .filter_map(|r| r.channel.start_ns)
        .min();
    let batch = TableBuilder::new(&EVENT)
        .str(ev::STRUCTURE_ID, &[ids.0])
        .opt_str(ev::STRUCTURE_NAME, &[s.and_then(|s| s.name.clone())])
        .str(ev::EVENT_ID, &[ids.1])
        .str(ev::EVENT_NAME, &[event.name.as_str()])
        .opt_timestamp_ns(ev::ORIGIN_TIME, vec![event.origin_ns])
        .opt_f64(ev::MAGNITUDE, vec![event.magnitude])
        .opt_timestamp_ns(ev::RECORD_START, vec![record_start])
        .u32(ev::CHANNELS, vec![event.records.len() as u32])
        .opt_str(ev::STRUCTURE_KIND, &[s.and_then(|s| s.kind.clone())])
        .opt_f64(ev::LATITUDE_DEG, vec![s.and_then(|s| s.latitude_deg)])
        .opt_f64(ev::LONGITUDE_DEG, vec![s.and_then(|s| s.longitude_deg)])
        .build()?;
    write_parquet(path, &[batch], &event_metadata(event))
}

/// `channels/channels.parquet`: one row per channel, metadata + QA + metrics.
/// `metrics` are matched to channels by id (channels without metrics get nulls).
pub fn write_channels(path: &Path, event: &Event, metrics: &[StrongMotionMetrics]) -> Result<()> {
    let recs = &event.records;
    let ch: Vec<&Channel> = recs.iter().map(|r| &r.channel).collect();
    let m = |c: &Channel| metrics.iter().find(|m| m.channel_id == c.id);
    let metric =
        |f: fn(&StrongMotionMetrics) -> f64| ch.iter().map(|c| m(c).map(f)).collect::<Vec<_>>();
    // SNR of every channel against its pre-event window (the QA flag only
    // says when it is low; the figure is useful for all).
    let noise_window_s = crate::conditioning::QaSettings::default().snr_noise_window_s;
    let snr: Vec<Option<f64>> = recs
        .iter()
        .map(|r| {
            Ok(crate::conditioning::qa::snr_db(
                &r.samples.get()?,
                r.channel.dt(),
                noise_window_s,
            ))
        })
        .collect::<Result<_>>()?;
    let batch = TableBuilder::new(&CHANNELS)
        .str(
            channels::CHANNEL_ID,
            &ch.iter().map(|c| c.id.clone()).collect::<Vec<_>>(),
        )
        .opt_str(
            channels::NETWORK,
            &ch.iter().map(|c| c.network.clone()).collect::<Vec<_>>(),
        )
        .opt_str(
            channels::STATION,
            &ch.iter().map(|c| c.station.clone()).collect::<Vec<_>>(),
        )
        .opt_str(
            channels::LOCATION_CODE,
            &ch.iter()
                .map(|c| c.location_code.clone())
                .collect::<Vec<_>>(),
        )
        .opt_str(
            channels::CHANNEL_CODE,
            &ch.iter()
                .map(|c| c.channel_code.clone())
                .collect::<Vec<_>>(),
        )
        .opt_str(
            channels::LOCATION_TEXT,
            &ch.iter()
                .map(|c| c.location_text.clone())
                .collect::<Vec<_>>(),
        )
        .opt_i32(channels::LEVEL, ch.iter().map(|c| c.level).collect())
        .opt_str(
            channels::NODE,
            &ch.iter().map(|c| c.node.clone()).collect::<Vec<_>>(),
        )
        .opt_f64(
            channels::ELEVATION_M,
            ch.iter().map(|c| c.elevation_m).collect(),
        )
        .opt_str(
            channels::DIRECTION,
            &ch.iter()
                .map(|c| direction_text(&c.direction))
                .collect::<Vec<_>>(),
        )
        .opt_f64(
            channels::AZIMUTH_DEG,
            ch.iter().map(|c| azimuth(&c.direction)).collect(),
        )
        .opt_f64(channels::DIP_DEG, ch.iter().map(|c| c.dip_deg).collect())
        .str(
            channels::ROLE,
            &ch.iter().map(|c| c.role.name()).collect::<Vec<_>>(),
        )
        .str(
            channels::UNITS,
            &ch.iter().map(|c| c.units.name()).collect::<Vec<_>>(),
        )
        .f64(
            channels::SAMPLING_RATE_HZ,
            ch.iter().map(|c| c.sampling_rate_hz).collect(),
        )
        .i64(
            channels::NPTS,
            recs.iter().map(|r| r.samples.len() as i64).collect(),
        )
        .opt_timestamp_ns(
            channels::START_TIME,
            ch.iter().map(|c| c.start_ns).collect(),
        )
        .str(
            channels::TIME_SOURCE,
            &ch.iter()
                .map(|c| time_base(c, event.origin_ns).1)
                .collect::<Vec<_>>(),
        )
        .str(
            channels::SOURCE_FILE,
            &ch.iter().map(|c| c.source.file.clone()).collect::<Vec<_>>(),
        )
        .opt_str(
            channels::SOURCE_MEMBER,
            &ch.iter()
                .map(|c| c.source.member.clone())
                .collect::<Vec<_>>(),
        )
        .opt_str(
            channels::SOURCE_COLUMN,
            &ch.iter()
                .map(|c| c.source.column.clone())
                .collect::<Vec<_>>(),
        )
        .str(
            channels::FORMAT,
            &ch.iter()
                .map(|c| c.source.format.clone())
                .collect::<Vec<_>>(),
        )
        .list_str(
            channels::QA_FLAGS,
            &ch.iter()
                .map(|c| c.qa.iter().map(|q| q.code().to_string()).collect())
                .collect::<Vec<_>>(),
        )
        .str(
            channels::QA_DETAILS,
            &ch.iter()
                .map(|c| serde_json::to_string(&c.qa).unwrap_or_default())
                .collect::<Vec<_>>(),
        )
        .list_str(
            channels::INFERRED,
            &ch.iter().map(|c| c.inferred.clone()).collect::<Vec<_>>(),
        )
        .list_str(
            channels::MISSING,
            &ch.iter().map(|c| c.missing.clone()).collect::<Vec<_>>(),
        )
        .opt_f64(channels::SNR_DB, snr)
        .opt_f64(channels::PGA_M_S2, metric(|m| m.pga_m_per_s2))
        .opt_f64(channels::PGV_M_S, metric(|m| m.pgv_m_per_s))
        .opt_f64(channels::PGD_M, metric(|m| m.pgd_m))
        .opt_f64(channels::ARIAS_M_S, metric(|m| m.arias_m_per_s))
        .opt_f64(channels::D5_95_S, metric(|m| m.d5_95_s))
        .opt_f64(channels::CAV_M_S, metric(|m| m.cav_m_per_s))
        .build()?;
    write_parquet(path, &[batch], &event_metadata(event))
}

/// `samples/samples.parquet`: long format, one row per channel and sample.
/// `motions` give velocity/displacement (matched by channel id); channels
/// without a motion carry their samples as acceleration and null vel/disp.
/// Written a channel at a time (parked samples are read back one channel
/// at a time too).
pub fn write_samples(path: &Path, event: &Event, motions: &[Motion]) -> Result<()> {
    let meta = samples_metadata(event).map_err(|e| Error::output(path, e))?;
    write_parquet_stream(path, &meta, samples_batches(event, motions))
}

/// The metadata of `samples/samples.parquet`: the event's, and the channels.
fn samples_metadata(event: &Event) -> std::result::Result<Vec<(String, String)>, String> {
    let channels: Vec<&Channel> = event.records.iter().map(|r| &r.channel).collect();
    let mut meta = event_metadata(event);
    meta.push((
        CHANNELS_KEY.into(),
        serde_json::to_string(&channels).map_err(|e| e.to_string())?,
    ));
    Ok(meta)
}

/// The rows of `samples/samples.parquet`, a batch at a time.
fn samples_batches<'a>(
    event: &'a Event,
    motions: &'a [Motion],
) -> impl Iterator<Item = Result<arrow_array::RecordBatch>> + Send + 'a {
    event.records.iter().flat_map(move |r| {
        let n = r.samples.len();
        (0..n.div_ceil(SAMPLES_BATCH_ROWS).max(1))
            .map(move |k| samples_batch(r, motions, event.origin_ns, k * SAMPLES_BATCH_ROWS))
    })
}

/// The `samples` table in memory (the batches of [`write_samples`], with
/// the metadata a file would carry in its Arrow schema).
pub fn samples_table(event: &Event, motions: &[Motion]) -> Result<Vec<arrow_array::RecordBatch>> {
    let meta = samples_metadata(event).map_err(Error::numerical)?;
    let batches = samples_batches(event, motions).collect::<Result<Vec<_>>>()?;
    crate::sinks::parquet::with_table_metadata(batches, &meta)
}

/// Rows of `samples/samples.parquet` built at a time: a channel longer than this
/// (about 87 minutes at 200 Hz) is written in several batches, so that a day
/// of a channel is not built in memory as one table.
pub const SAMPLES_BATCH_ROWS: usize = 1 << 20;

/// The rows of one channel of `samples/samples.parquet`, from sample `from` on (at
/// most [`SAMPLES_BATCH_ROWS`]); absolute times from the channel's
/// [`time_base`] (its start, else `origin_ns`).
fn samples_batch(
    r: &Record,
    motions: &[Motion],
    origin_ns: Option<i64>,
    from: usize,
) -> Result<arrow_array::RecordBatch> {
    let c = &r.channel;
    let total = r.samples.len();
    let motion = motions
        .iter()
        .find(|m| m.channel_id == c.id && m.acceleration.len() == total);
    let n = SAMPLES_BATCH_ROWS.min(total - from.min(total));
    let rows = from..from + n;
    let dt = c.dt();
    let t: Vec<f64> = rows.clone().map(|i| i as f64 * dt).collect();
    let abs_time: Option<Vec<i64>> = time_base(c, origin_ns).0.map(|s| {
        rows.clone()
            .map(|i| s + (i as f64 * dt * 1e9).round() as i64)
            .collect()
    });
    // Each series is read (or borrowed) once and moved into its column.
    let acc = match motion {
        Some(m) => m.acceleration.get_range(from, n)?.into_owned(),
        None => r.samples.get_range(from, n)?.into_owned(),
    };
    let (vel, disp) = match motion {
        Some(m) => (
            Some(m.velocity.get_range(from, n)?.into_owned()),
            Some(m.displacement.get_range(from, n)?.into_owned()),
        ),
        None => (None, None),
    };
    TableBuilder::new(&SAMPLES)
        .repeated_str(samples::CHANNEL_ID, &c.id, n)
        .i64(samples::SAMPLE, rows.map(|i| i as i64).collect())
        .f64(samples::T_S, t)
        .opt_timestamp_ns_column(samples::TIME, abs_time, n)
        .f64(samples::ACC_M_S2, acc)
        .opt_f64_column(samples::VEL_M_S, vel, n)
        .opt_f64_column(samples::DISP_M, disp, n)
        .build()
}

/// `spectra/spectra.parquet`: one row per channel and period.
pub fn write_spectra(path: &Path, event: &Event, metrics: &[StrongMotionMetrics]) -> Result<()> {
    let mut id = Vec::new();
    let (mut damping, mut period, mut sd, mut psv, mut psa, mut sa) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    for m in metrics {
        let s = &m.spectrum;
        for i in 0..s.periods_s.len() {
            id.push(m.channel_id.clone());
            damping.push(s.damping);
            period.push(s.periods_s[i]);
            sd.push(s.sd_m[i]);
            psv.push(s.psv_m_per_s[i]);
            psa.push(s.psa_m_per_s2[i]);
            sa.push(s.sa_abs_m_per_s2[i]);
        }
    }
    let batch = TableBuilder::new(&SPECTRA)
        .str(spectra::CHANNEL_ID, &id)
        .f64(spectra::DAMPING, damping)
        .f64(spectra::PERIOD_S, period)
        .f64(spectra::SD_M, sd)
        .f64(spectra::PSV_M_S, psv)
        .f64(spectra::PSA_M_S2, psa)
        .f64(spectra::SA_ABS_M_S2, sa)
        .build()?;
    write_parquet(path, &[batch], &event_metadata(event))
}

/// `drift/drift.parquet`; the table's notes (why drift is missing, heights
/// assumed, records trimmed to a common window) in `quaketwin.notes`.
pub fn write_drift(path: &Path, event: &Event, table: &DriftTable) -> Result<()> {
    let rows = &table.rows;
    let text = |f: fn(&DriftRow) -> String| rows.iter().map(f).collect::<Vec<_>>();
    let number = |f: fn(&DriftRow) -> f64| rows.iter().map(f).collect::<Vec<_>>();
    let residual = |f: fn(&DriftRow, &ResidualDrift) -> f64| -> Vec<Option<f64>> {
        rows.iter()
            .map(|r| r.residual.as_ref().map(|x| f(r, x)))
            .collect()
    };
    let batch = TableBuilder::new(&DRIFT)
        .str(drift::DIRECTION, &text(|r| r.direction.clone()))
        .i32(drift::STOREY, rows.iter().map(|r| r.storey).collect())
        .str(drift::LOWER_CHANNEL, &text(|r| r.lower_channel.clone()))
        .str(drift::UPPER_CHANNEL, &text(|r| r.upper_channel.clone()))
        .f64(drift::STOREY_HEIGHT_M, number(|r| r.storey_height_m))
        .f64(drift::PEAK_DRIFT_RATIO, number(|r| r.peak_drift_ratio))
        .opt_f64(drift::RESIDUAL_DRIFT_M, residual(|_, x| x.drift_m))
        .opt_f64(drift::RESIDUAL_DRIFT_STD_M, residual(|_, x| x.std_m))
        .opt_f64(
            drift::RESIDUAL_DRIFT_RATIO,
            residual(|r, x| x.drift_m / r.storey_height_m),
        )
        .opt_f64(
            drift::RESIDUAL_WINDOW_START_S,
            residual(|_, x| x.window_start_s),
        )
        .str(drift::KIND, &text(|r| r.kind.name().into()))
        .i32(
            drift::LOWER_LEVEL,
            rows.iter().map(|r| r.lower_level).collect(),
        )
        .i32(
            drift::UPPER_LEVEL,
            rows.iter().map(|r| r.upper_level).collect(),
        )
        .str(drift::METHOD, &text(|r| r.method.into()))
        .str(
            drift::HEIGHT_SOURCE,
            &text(|r| r.height_source.name().into()),
        )
        .opt_str(
            drift::RESIDUAL_STATUS,
            &rows
                .iter()
                .map(|r| r.residual_status.map(|s| s.name()))
                .collect::<Vec<_>>(),
        )
        .build()?;
    let mut metadata = event_metadata(event);
    metadata.push((
        DRIFT_NOTES_KEY.into(),
        serde_json::to_string(&table.notes).unwrap_or_default(),
    ));
    write_parquet(path, &[batch], &metadata)
}

/// Metadata key of drift/drift.parquet's notes (JSON list of strings).
pub const DRIFT_NOTES_KEY: &str = "quaketwin.notes";

/// Loads a conditioned event back from `samples/samples.parquet` (channels and
/// history from its metadata, samples from its columns).
pub fn read_samples(path: &Path) -> Result<(Event, Vec<Motion>)> {
    read_samples_parked(path, |_| Ok(None))
}

/// One channel's columns as read so far.
#[derive(Default)]
struct ReadColumns {
    acc: Samples,
    vel: Samples,
    disp: Samples,
    /// Every velocity and displacement value is present (not null).
    complete: bool,
}

impl ReadColumns {
    fn park(&mut self, store: Option<&Arc<dyn SampleStore>>) -> std::io::Result<()> {
        if let Some(store) = store {
            self.acc.park(store)?;
            self.vel.park(store)?;
            self.disp.park(store)?;
        }
        Ok(())
    }
}

/// As [`read_samples`], a batch of rows at a time; when `store_for` (given
/// the file's number of rows) returns a sample store, the columns of each
/// channel are parked there as soon as its rows end, so a big file is read
/// back in the memory of a channel.
pub fn read_samples_parked(
    path: &Path,
    store_for: impl FnOnce(usize) -> Result<Option<Arc<dyn SampleStore>>>,
) -> Result<(Event, Vec<Motion>)> {
    let (table, reader) = ReadTable::open_stream(path, Some(1 << 16))?;
    let store = store_for(table.rows)?;
    samples_from(&table, reader, store.as_ref())
}

/// A `samples` table handed over in memory (its schema's metadata and its
/// batches; `label` names it in errors) as the event it holds.
pub fn samples_from_batches(
    label: &str,
    metadata: Vec<(String, String)>,
    batches: Vec<arrow_array::RecordBatch>,
) -> Result<(Event, Vec<Motion>)> {
    let table = ReadTable::in_memory(label, metadata, Vec::new());
    samples_from(&table, batches.into_iter().map(Ok), None)
}

/// The event of a `samples` table: `table` gives its metadata and names it
/// in errors; `reader` its batches.
fn samples_from(
    table: &ReadTable,
    reader: impl Iterator<
        Item = std::result::Result<arrow_array::RecordBatch, arrow_schema::ArrowError>,
    >,
    store: Option<&Arc<dyn SampleStore>>,
) -> Result<(Event, Vec<Motion>)> {
    let path = table.path.as_path();
    let loc = || table.location();
    let parking = |e: std::io::Error| Error::output(path, format!("parking samples: {e}"));
    let get = |k: &str| table.metadata(k).map(String::from);
    if get(SCHEMA_KEY).as_deref() != Some(SAMPLES.name) {
        return Err(Error::input(
            loc(),
            "not a quaketwin samples/samples.parquet (schema key missing)",
        ));
    }
    let channels: Vec<Channel> = serde_json::from_str(&get(CHANNELS_KEY).unwrap_or_default())
        .map_err(|e| Error::input(loc(), format!("channel metadata unreadable: {e}")))?;
    let history: ProcessingHistory =
        serde_json::from_str(&get(HISTORY_KEY).unwrap_or_default()).unwrap_or_default();
    let ev: serde_json::Value =
        serde_json::from_str(&get(EVENT_KEY).unwrap_or_default()).unwrap_or_default();
    // Rows of one channel are contiguous in our files; the channel being
    // read is `current`, the others are done (parked when there is a store).
    let mut cols: std::collections::BTreeMap<String, ReadColumns> = Default::default();
    let mut current: Option<(String, ReadColumns)> = None;
    for batch in reader {
        let batch = batch.map_err(|e| Error::input(loc(), e.to_string()))?;
        let ids: StringArray = table.declared(&batch, &samples::CHANNEL_ID)?;
        let acc: Float64Array = table.declared(&batch, &samples::ACC_M_S2)?;
        let vel: Float64Array = table.declared(&batch, &samples::VEL_M_S)?;
        let disp: Float64Array = table.declared(&batch, &samples::DISP_M)?;
        for i in 0..batch.num_rows() {
            let id = ids.value(i);
            if current.as_ref().is_none_or(|(c, _)| c != id) {
                if let Some((c, mut done)) = current.take() {
                    done.park(store).map_err(parking)?;
                    cols.insert(c, done);
                }
                let resumed = cols.remove(id).unwrap_or(ReadColumns {
                    complete: true,
                    ..Default::default()
                });
                current = Some((id.to_string(), resumed));
            }
            let Some((_, e)) = current.as_mut() else {
                continue;
            };
            e.acc.as_mut_vec().push(acc.value(i));
            let (v, d) = (vel.is_valid(i), disp.is_valid(i));
            e.complete &= v && d && vel.value(i).is_finite() && disp.value(i).is_finite();
            e.vel
                .as_mut_vec()
                .push(if v { vel.value(i) } else { f64::NAN });
            e.disp
                .as_mut_vec()
                .push(if d { disp.value(i) } else { f64::NAN });
        }
    }
    if let Some((c, mut done)) = current.take() {
        done.park(store).map_err(parking)?;
        cols.insert(c, done);
    }
    let mut event = Event {
        name: ev
            .get("name")
            .and_then(|v| v.as_str())
            .unwrap_or("event")
            .to_string(),
        origin_ns: ev
            .get("origin_time")
            .and_then(|v| v.as_str())
            .and_then(crate::vocab::parse_iso8601_ns),
        magnitude: ev.get("magnitude").and_then(|v| v.as_f64()),
        hypocentre: ev
            .get("hypocentre")
            .cloned()
            .and_then(|h| serde_json::from_value(h).ok()),
        station_position: ev
            .get("station_position")
            .cloned()
            .and_then(|p| serde_json::from_value(p).ok()),
        structure: ev
            .get("structure")
            .cloned()
            .and_then(|s| serde_json::from_value(s).ok()),
        notes: ev
            .get("notes")
            .and_then(|v| v.as_array())
            .map(|a| {
                a.iter()
                    .filter_map(|s| s.as_str().map(String::from))
                    .collect()
            })
            .unwrap_or_default(),
        history,
        records: Vec::new(),
    };
    let mut motions = Vec::new();
    for c in channels {
        let Some(cols) = cols.remove(&c.id) else {
            return Err(Error::input(
                loc().with_channel(c.id.clone()),
                "channel listed in metadata has no samples",
            ));
        };
        if cols.complete {
            motions.push(Motion {
                channel_id: c.id.clone(),
                dt: c.dt(),
                acceleration: cols.acc.clone(),
                velocity: cols.vel,
                displacement: cols.disp,
            });
        }
        event.records.push(Record::new(c, cols.acc));
    }
    Ok((event, motions))
}
