//! The backbone's Parquet tables (schemas in docs/formats.md):
//! `channels.parquet` (metadata, QA, metrics — one row per channel),
//! `samples.parquet` (acceleration, velocity, displacement per channel and
//! time — long format), `spectra.parquet` (response spectra, long format),
//! `drift.parquet` (peak inter-storey drift ratios).  `samples.parquet` also
//! carries the channels and the processing history as JSON metadata so a
//! later stage can load the conditioned event back without re-running.

use std::path::Path;

use arrow_array::{Array, Float64Array, StringArray};

use super::parquet::{write_parquet, ReadTable, TableBuilder};
use crate::conditioning::Motion;
use crate::error::{Error, Result};
use crate::metrics::{DriftRow, StrongMotionMetrics};
use crate::vocab::{Channel, Direction, Event, ProcessingHistory, Record};

pub const SCHEMA_KEY: &str = "quaketwin.schema";
pub const HISTORY_KEY: &str = "quaketwin.history";
pub const CHANNELS_KEY: &str = "quaketwin.channels";
pub const EVENT_KEY: &str = "quaketwin.event";

fn direction_text(d: &Option<Direction>) -> Option<String> {
    d.map(|d| d.to_string())
}

fn azimuth(d: &Option<Direction>) -> Option<f64> {
    match d {
        Some(Direction::Azimuth(a)) => Some(*a),
        _ => None,
    }
}

/// Event-level metadata stored in every table's key/value metadata.
fn event_metadata(event: &Event) -> Vec<(String, String)> {
    let doc = serde_json::json!({
        "name": event.name,
        "origin_time": event.origin_ns.map(crate::vocab::format_epoch_ns),
        "magnitude": event.magnitude,
        "structure": event.structure,
        "notes": event.notes,
    });
    vec![
        (EVENT_KEY.to_string(), doc.to_string()),
        (HISTORY_KEY.to_string(), event.history.to_json()),
    ]
}

/// `channels.parquet`: one row per channel, metadata + QA + metrics.
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
        .map(|r| crate::conditioning::qa::snr_db(&r.samples, r.channel.dt(), noise_window_s))
        .collect();
    let batch = TableBuilder::new()
        .str(
            "channel_id",
            &ch.iter().map(|c| c.id.clone()).collect::<Vec<_>>(),
        )
        .opt_str(
            "network",
            &ch.iter().map(|c| c.network.clone()).collect::<Vec<_>>(),
        )
        .opt_str(
            "station",
            &ch.iter().map(|c| c.station.clone()).collect::<Vec<_>>(),
        )
        .opt_str(
            "location_code",
            &ch.iter()
                .map(|c| c.location_code.clone())
                .collect::<Vec<_>>(),
        )
        .opt_str(
            "channel_code",
            &ch.iter()
                .map(|c| c.channel_code.clone())
                .collect::<Vec<_>>(),
        )
        .opt_str(
            "location_text",
            &ch.iter()
                .map(|c| c.location_text.clone())
                .collect::<Vec<_>>(),
        )
        .opt_i32("level", ch.iter().map(|c| c.level).collect())
        .opt_str(
            "node",
            &ch.iter().map(|c| c.node.clone()).collect::<Vec<_>>(),
        )
        .opt_f64("elevation_m", ch.iter().map(|c| c.elevation_m).collect())
        .opt_str(
            "direction",
            &ch.iter()
                .map(|c| direction_text(&c.direction))
                .collect::<Vec<_>>(),
        )
        .opt_f64(
            "azimuth_deg",
            ch.iter().map(|c| azimuth(&c.direction)).collect(),
        )
        .opt_f64("dip_deg", ch.iter().map(|c| c.dip_deg).collect())
        .str(
            "role",
            &ch.iter().map(|c| c.role.name()).collect::<Vec<_>>(),
        )
        .str(
            "units",
            &ch.iter().map(|c| c.units.name()).collect::<Vec<_>>(),
        )
        .f64(
            "sampling_rate_hz",
            ch.iter().map(|c| c.sampling_rate_hz).collect(),
        )
        .i64(
            "npts",
            recs.iter().map(|r| r.samples.len() as i64).collect(),
        )
        .opt_timestamp_ns("start_time", ch.iter().map(|c| c.start_ns).collect())
        .str(
            "source_file",
            &ch.iter().map(|c| c.source.file.clone()).collect::<Vec<_>>(),
        )
        .opt_str(
            "source_member",
            &ch.iter()
                .map(|c| c.source.member.clone())
                .collect::<Vec<_>>(),
        )
        .opt_str(
            "source_column",
            &ch.iter()
                .map(|c| c.source.column.clone())
                .collect::<Vec<_>>(),
        )
        .str(
            "format",
            &ch.iter()
                .map(|c| c.source.format.clone())
                .collect::<Vec<_>>(),
        )
        .list_str(
            "qa_flags",
            &ch.iter()
                .map(|c| c.qa.iter().map(|q| q.code().to_string()).collect())
                .collect::<Vec<_>>(),
        )
        .str(
            "qa_details",
            &ch.iter()
                .map(|c| serde_json::to_string(&c.qa).unwrap_or_default())
                .collect::<Vec<_>>(),
        )
        .list_str(
            "inferred",
            &ch.iter().map(|c| c.inferred.clone()).collect::<Vec<_>>(),
        )
        .list_str(
            "missing",
            &ch.iter().map(|c| c.missing.clone()).collect::<Vec<_>>(),
        )
        .opt_f64("snr_db", snr)
        .opt_f64("pga_m_s2", metric(|m| m.pga_m_per_s2))
        .opt_f64("pgv_m_s", metric(|m| m.pgv_m_per_s))
        .opt_f64("pgd_m", metric(|m| m.pgd_m))
        .opt_f64("arias_m_s", metric(|m| m.arias_m_per_s))
        .opt_f64("d5_95_s", metric(|m| m.d5_95_s))
        .opt_f64("cav_m_s", metric(|m| m.cav_m_per_s))
        .build()?;
    let mut meta = event_metadata(event);
    meta.push((SCHEMA_KEY.into(), "channels".into()));
    write_parquet(path, &[batch], &meta)
}

/// `samples.parquet`: long format, one row per channel and sample.
/// `motions` give velocity/displacement (matched by channel id); channels
/// without a motion carry their samples as acceleration and null vel/disp.
pub fn write_samples(path: &Path, event: &Event, motions: &[Motion]) -> Result<()> {
    let mut batches = Vec::new();
    for r in &event.records {
        let c = &r.channel;
        let n = r.samples.len();
        let dt = c.dt();
        let motion = motions
            .iter()
            .find(|m| m.channel_id == c.id && m.acceleration.len() == n);
        let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
        let abs_time: Vec<Option<i64>> = (0..n)
            .map(|i| c.start_ns.map(|s| s + (i as f64 * dt * 1e9).round() as i64))
            .collect();
        let acc = motion
            .map(|m| m.acceleration.clone())
            .unwrap_or_else(|| r.samples.clone());
        let vel: Vec<Option<f64>> = match motion {
            Some(m) => m.velocity.iter().map(|v| Some(*v)).collect(),
            None => vec![None; n],
        };
        let disp: Vec<Option<f64>> = match motion {
            Some(m) => m.displacement.iter().map(|v| Some(*v)).collect(),
            None => vec![None; n],
        };
        batches.push(
            TableBuilder::new()
                .str("channel_id", &vec![c.id.as_str(); n])
                .i64("sample", (0..n as i64).collect())
                .f64("t_s", t)
                .opt_timestamp_ns("time", abs_time)
                .f64("acc_m_s2", acc)
                .opt_f64("vel_m_s", vel)
                .opt_f64("disp_m", disp)
                .build()?,
        );
    }
    let channels: Vec<&Channel> = event.records.iter().map(|r| &r.channel).collect();
    let mut meta = event_metadata(event);
    meta.push((SCHEMA_KEY.into(), "samples".into()));
    meta.push((
        CHANNELS_KEY.into(),
        serde_json::to_string(&channels).map_err(|e| Error::output(path, e.to_string()))?,
    ));
    write_parquet(path, &batches, &meta)
}

/// `spectra.parquet`: one row per channel and period.
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
    let batch = TableBuilder::new()
        .str("channel_id", &id)
        .f64("damping", damping)
        .f64("period_s", period)
        .f64("sd_m", sd)
        .f64("psv_m_s", psv)
        .f64("psa_m_s2", psa)
        .f64("sa_abs_m_s2", sa)
        .build()?;
    let mut meta = event_metadata(event);
    meta.push((SCHEMA_KEY.into(), "spectra".into()));
    write_parquet(path, &[batch], &meta)
}

/// `drift.parquet`.
pub fn write_drift(path: &Path, event: &Event, rows: &[DriftRow]) -> Result<()> {
    let batch = TableBuilder::new()
        .str(
            "direction",
            &rows.iter().map(|r| r.direction.clone()).collect::<Vec<_>>(),
        )
        .i32("storey", rows.iter().map(|r| r.storey).collect())
        .str(
            "lower_channel",
            &rows
                .iter()
                .map(|r| r.lower_channel.clone())
                .collect::<Vec<_>>(),
        )
        .str(
            "upper_channel",
            &rows
                .iter()
                .map(|r| r.upper_channel.clone())
                .collect::<Vec<_>>(),
        )
        .f64(
            "storey_height_m",
            rows.iter().map(|r| r.storey_height_m).collect(),
        )
        .f64(
            "peak_drift_ratio",
            rows.iter().map(|r| r.peak_drift_ratio).collect(),
        )
        .build()?;
    let mut meta = event_metadata(event);
    meta.push((SCHEMA_KEY.into(), "drift".into()));
    write_parquet(path, &[batch], &meta)
}

/// Loads a conditioned event back from `samples.parquet` (channels and
/// history from its metadata, samples from its columns).
pub fn read_samples(path: &Path) -> Result<(Event, Vec<Motion>)> {
    let table = ReadTable::open(path)?;
    let loc = || table.location();
    let get = |k: &str| table.metadata(k).map(String::from);
    if get(SCHEMA_KEY).as_deref() != Some("samples") {
        return Err(Error::input(
            loc(),
            "not a quaketwin samples.parquet (schema key missing)",
        ));
    }
    let channels: Vec<Channel> = serde_json::from_str(&get(CHANNELS_KEY).unwrap_or_default())
        .map_err(|e| Error::input(loc(), format!("channel metadata unreadable: {e}")))?;
    let history: ProcessingHistory =
        serde_json::from_str(&get(HISTORY_KEY).unwrap_or_default()).unwrap_or_default();
    let ev: serde_json::Value =
        serde_json::from_str(&get(EVENT_KEY).unwrap_or_default()).unwrap_or_default();
    let mut cols: std::collections::BTreeMap<String, (Vec<f64>, Vec<f64>, Vec<f64>)> =
        Default::default();
    for batch in &table.batches {
        let ids: StringArray = table.column(batch, "channel_id")?;
        let acc: Float64Array = table.column(batch, "acc_m_s2")?;
        let vel: Float64Array = table.column(batch, "vel_m_s")?;
        let disp: Float64Array = table.column(batch, "disp_m")?;
        for i in 0..batch.num_rows() {
            let e = cols.entry(ids.value(i).to_string()).or_default();
            e.0.push(acc.value(i));
            e.1.push(if vel.is_null(i) {
                f64::NAN
            } else {
                vel.value(i)
            });
            e.2.push(if disp.is_null(i) {
                f64::NAN
            } else {
                disp.value(i)
            });
        }
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
        let Some((acc, vel, disp)) = cols.remove(&c.id) else {
            return Err(Error::input(
                loc().with_channel(c.id.clone()),
                "channel listed in metadata has no samples",
            ));
        };
        if vel.iter().all(|v| v.is_finite()) && disp.iter().all(|v| v.is_finite()) {
            motions.push(Motion {
                channel_id: c.id.clone(),
                dt: c.dt(),
                acceleration: acc.clone(),
                velocity: vel,
                displacement: disp,
            });
        }
        event.records.push(Record::new(c, acc));
    }
    Ok((event, motions))
}
