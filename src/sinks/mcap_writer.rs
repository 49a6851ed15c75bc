//! Writes a conditioned `Event` to MCAP for replay (Foxglove and friends) and
//! for reading back with `readers::mcap`.
//!
//! Layout: one MCAP channel per record on topic `/accel/<channel id>`, JSON
//! encoding, schema `quaketwin.AccelBlock` (JSON Schema in
//! `readers::mcap::ACCEL_BLOCK_JSON_SCHEMA`); each message holds one block of
//! `block_s` seconds (default 1 s) with `t0_ns` of its first sample, and
//! log_time = t0_ns (0 when negative).  Messages of all channels are
//! interleaved by time.  The channel metadata holds the record's
//! `vocab::Channel` as JSON (`quaketwin.channel`), its units, and
//! `start_known = "false"` when the record has no absolute start time (t0 is
//! then counted from 0).  A metadata record `quaketwin.processing_history`
//! holds the processing history JSON, the event name and notes.  Chunks are
//! zstd-compressed by default, compressed single-threaded so the same event
//! gives the same bytes.
//!
//! [`write_event`] writes atomically (`sinks::atomic`): a temporary file in
//! the target's directory, then a rename.

use std::collections::BTreeMap;
use std::io::{BufWriter, Seek, Write};
use std::path::Path;

use crate::error::{Error, Result};
use crate::readers::mcap::{
    AccelBlock, ACCEL_BLOCK_JSON_SCHEMA, ACCEL_BLOCK_SCHEMA, CHANNEL_METADATA_KEY,
};
use crate::vocab::Event;

/// Settings of the MCAP writer.
#[derive(Debug, Clone)]
pub struct McapWriteOptions {
    /// Seconds of samples per message (> 0).
    pub block_s: f64,
    /// Chunk compression (`None` = uncompressed chunks).
    pub compression: Option<mcap::Compression>,
    /// Target uncompressed chunk size in bytes.
    pub chunk_size: u64,
}

impl Default for McapWriteOptions {
    fn default() -> Self {
        McapWriteOptions {
            block_s: 1.0,
            compression: Some(mcap::Compression::Zstd),
            chunk_size: 1 << 20,
        }
    }
}

/// Name of the metadata record holding the processing history.
pub const HISTORY_METADATA_NAME: &str = "quaketwin.processing_history";

/// Writes `event` to `path` atomically through [`super::atomic`]: a
/// temporary file in the same directory, then a rename; anything but a
/// regular file at `path` (symbolic link, device, FIFO, directory) is refused.
pub fn write_event(event: &Event, path: &Path, opts: &McapWriteOptions) -> Result<()> {
    super::atomic::write_atomically(path, |file| {
        let w = write_event_to(event, BufWriter::new(file), opts, path)?;
        w.into_inner()
            .map_err(|e| Error::io(path, e.into_error()))?;
        Ok(())
    })
}

/// Writes `event` as MCAP into `w` and returns it; `path` names the target in errors.
pub fn write_event_to<W: Write + Seek>(
    event: &Event,
    w: W,
    opts: &McapWriteOptions,
    path: &Path,
) -> Result<W> {
    let fail = |m: String| Error::output(path, m);
    if !(opts.block_s.is_finite() && opts.block_s > 0.0) {
        return Err(Error::usage(format!(
            "MCAP block length {} s must be positive",
            opts.block_s
        )));
    }
    let mut writer = mcap::WriteOptions::new()
        .compression(opts.compression)
        .chunk_size(Some(opts.chunk_size))
        .compression_threads(0)
        .profile("")
        .create(w)
        .map_err(|e| fail(e.to_string()))?;
    let schema_id = writer
        .add_schema(
            ACCEL_BLOCK_SCHEMA,
            "jsonschema",
            ACCEL_BLOCK_JSON_SCHEMA.as_bytes(),
        )
        .map_err(|e| fail(e.to_string()))?;

    // (log_time, record index, block index, channel id, payload)
    let mut messages: Vec<(u64, usize, u32, u16, Vec<u8>)> = Vec::new();
    for (ri, rec) in event.records.iter().enumerate() {
        let ch = &rec.channel;
        let rate = ch.sampling_rate_hz;
        if !(rate.is_finite() && rate > 0.0) {
            return Err(fail(format!(
                "channel {}: sampling rate {rate} Hz is not positive",
                ch.id
            )));
        }
        let mut meta = BTreeMap::new();
        let json =
            serde_json::to_string(ch).map_err(|e| fail(format!("channel {}: {e}", ch.id)))?;
        meta.insert(CHANNEL_METADATA_KEY.to_string(), json);
        meta.insert("units".to_string(), ch.units.name().to_string());
        meta.insert("start_known".to_string(), ch.start_ns.is_some().to_string());
        let channel_id = writer
            .add_channel(schema_id, &format!("/accel/{}", ch.id), "json", &meta)
            .map_err(|e| fail(e.to_string()))?;
        let start = ch.start_ns.unwrap_or(0);
        let block_len = ((opts.block_s * rate).round() as usize).max(1);
        for (bi, chunk) in rec.samples.chunks(block_len).enumerate() {
            let first = bi * block_len;
            let t0 = start.saturating_add((first as f64 * 1e9 / rate).round() as i64);
            let block = AccelBlock {
                channel: ch.id.clone(),
                t0_ns: t0,
                rate_hz: rate,
                units: Some(ch.units.name().to_string()),
                samples: chunk.to_vec(),
            };
            let payload =
                serde_json::to_vec(&block).map_err(|e| fail(format!("channel {}: {e}", ch.id)))?;
            messages.push((t0.max(0) as u64, ri, bi as u32, channel_id, payload));
        }
    }
    messages.sort_by_key(|m| (m.0, m.1, m.2));
    for (log_time, _, seq, channel_id, payload) in &messages {
        let header = mcap::records::MessageHeader {
            channel_id: *channel_id,
            sequence: *seq,
            log_time: *log_time,
            publish_time: *log_time,
        };
        writer
            .write_to_known_channel(&header, payload)
            .map_err(|e| fail(e.to_string()))?;
    }
    let mut meta = BTreeMap::new();
    meta.insert("history".to_string(), event.history.to_json());
    meta.insert("event".to_string(), event.name.clone());
    meta.insert(
        "notes".to_string(),
        serde_json::to_string(&event.notes).unwrap_or_else(|_| "[]".into()),
    );
    if let Some(o) = event.origin_ns {
        meta.insert("origin_ns".to_string(), o.to_string());
    }
    writer
        .write_metadata(&mcap::records::Metadata {
            name: HISTORY_METADATA_NAME.to_string(),
            metadata: meta,
        })
        .map_err(|e| fail(e.to_string()))?;
    writer.finish().map_err(|e| fail(e.to_string()))?;
    Ok(writer.into_inner())
}
