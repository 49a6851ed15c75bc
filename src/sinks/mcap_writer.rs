//! Writes a conditioned `Event` to MCAP for replay in Foxglove (and
//! friends) and for reading back with `readers::mcap`.
//!
//! Layout: one MCAP channel per record on topic `/accel/<channel id>`, JSON
//! encoding.  By default every sample is one message, schema
//! `quaketwin.AccelSample` (`{"t_ns": …, "value": …}`, JSON Schema
//! [`ACCEL_SAMPLE_JSON_SCHEMA`]), so that Foxglove's Plot panel draws a
//! channel from the path `/accel/<id>.value` with no adapter.  With
//! [`McapMessages::Blocks`] each message holds a block of samples instead
//! (schema `quaketwin.AccelBlock`, `readers::mcap::ACCEL_BLOCK_JSON_SCHEMA`):
//! a smaller file for replay by quaketwin, which Foxglove shows as arrays.
//!
//! Times: a message's log_time and publish_time are the time of its (first)
//! sample — from the record's start time; when the record has none, from the
//! event's origin time (so a record of known origin never plots in 1970);
//! from 0 when neither is known.  The channel metadata states which
//! (`time_base` = `record_start`, `origin_time` or `none`), holds the record's
//! `vocab::Channel` as JSON (`quaketwin.channel`) and its units, and
//! `start_known = "false"` when the record has no start time of its own.
//! Messages of all channels are interleaved by time, ties by record order.
//! A metadata record `quaketwin.processing_history` holds the processing
//! history JSON, the event name, notes and origin time.  Chunks are
//! zstd-compressed by default, single-threaded so the same event gives the
//! same bytes.
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

/// What one message holds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum McapMessages {
    /// One sample per message (`quaketwin.AccelSample`): plots in Foxglove.
    PerSample,
    /// `seconds` of samples per message (> 0; `quaketwin.AccelBlock`).
    Blocks { seconds: f64 },
}

/// Schema name of the per-sample messages.
pub const ACCEL_SAMPLE_SCHEMA: &str = "quaketwin.AccelSample";
/// JSON Schema of the per-sample messages (what `readers::mcap` reads as
/// per-sample messages).
pub const ACCEL_SAMPLE_JSON_SCHEMA: &str = r#"{"$schema":"https://json-schema.org/draft/2020-12/schema","title":"quaketwin.AccelSample","type":"object","required":["t_ns","value"],"properties":{"t_ns":{"type":"integer","description":"ns since the Unix epoch of the sample (see the channel's time_base)"},"value":{"type":["number","null"],"description":"the sample, in the channel's units; null = missing"}}}"#;

/// Settings of the MCAP writer.
#[derive(Debug, Clone)]
pub struct McapWriteOptions {
    /// One sample per message (default) or blocks.
    pub messages: McapMessages,
    /// Chunk compression (`None` = uncompressed chunks).
    pub compression: Option<mcap::Compression>,
    /// Target uncompressed chunk size in bytes.
    pub chunk_size: u64,
}

impl Default for McapWriteOptions {
    fn default() -> Self {
        McapWriteOptions {
            messages: McapMessages::PerSample,
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
    // Samples per message.
    let per_message = |rate: f64| -> usize {
        match opts.messages {
            McapMessages::PerSample => 1,
            McapMessages::Blocks { seconds } => ((seconds * rate).round() as usize).max(1),
        }
    };
    if let McapMessages::Blocks { seconds } = opts.messages {
        if !(seconds.is_finite() && seconds > 0.0) {
            return Err(Error::usage(format!(
                "MCAP block length {seconds} s must be positive"
            )));
        }
    }
    let mut writer = mcap::WriteOptions::new()
        .compression(opts.compression)
        .chunk_size(Some(opts.chunk_size))
        .compression_threads(0)
        .profile("")
        .create(w)
        .map_err(|e| fail(e.to_string()))?;
    let (schema_name, schema) = match opts.messages {
        McapMessages::PerSample => (ACCEL_SAMPLE_SCHEMA, ACCEL_SAMPLE_JSON_SCHEMA),
        McapMessages::Blocks { .. } => (ACCEL_BLOCK_SCHEMA, ACCEL_BLOCK_JSON_SCHEMA),
    };
    let schema_id = writer
        .add_schema(schema_name, "jsonschema", schema.as_bytes())
        .map_err(|e| fail(e.to_string()))?;

    // One stream of messages per record, merged by time below.
    struct Stream<'a> {
        channel_id: u16,
        id: &'a str,
        units: &'a str,
        rate: f64,
        t0_ns: i64,
        samples: std::borrow::Cow<'a, [f64]>,
        block_len: usize,
    }
    let mut streams = Vec::with_capacity(event.records.len());
    for rec in &event.records {
        let ch = &rec.channel;
        let rate = ch.sampling_rate_hz;
        if !(rate.is_finite() && rate > 0.0) {
            return Err(fail(format!(
                "channel {}: sampling rate {rate} Hz is not positive",
                ch.id
            )));
        }
        // The time base of samples/samples.parquet's `time` (one home); 1970 and
        // `none` (this file's contract) when neither start nor origin is known.
        let (t0_ns, time_base) = match super::event_tables::time_base(ch, event.origin_ns) {
            (Some(t0), base) => (t0, base),
            (None, _) => (0, "none"),
        };
        let mut meta = BTreeMap::new();
        let json =
            serde_json::to_string(ch).map_err(|e| fail(format!("channel {}: {e}", ch.id)))?;
        meta.insert(CHANNEL_METADATA_KEY.to_string(), json);
        meta.insert("units".to_string(), ch.units.name().to_string());
        meta.insert("start_known".to_string(), ch.start_ns.is_some().to_string());
        meta.insert("time_base".to_string(), time_base.to_string());
        let channel_id = writer
            .add_channel(schema_id, &format!("/accel/{}", ch.id), "json", &meta)
            .map_err(|e| fail(e.to_string()))?;
        streams.push(Stream {
            channel_id,
            id: &ch.id,
            units: ch.units.name(),
            rate,
            t0_ns,
            samples: rec.samples.get()?,
            block_len: per_message(rate),
        });
    }
    let time_of = |s: &Stream, first: usize| -> i64 {
        s.t0_ns
            .saturating_add((first as f64 * 1e9 / s.rate).round() as i64)
    };
    // k-way merge by (time, record, message): the messages are made as they
    // are written, so memory holds the samples, not a copy per message.
    let mut heap = std::collections::BinaryHeap::new();
    for (ri, s) in streams.iter().enumerate() {
        if !s.samples.is_empty() {
            heap.push(std::cmp::Reverse((time_of(s, 0), ri, 0usize)));
        }
    }
    while let Some(std::cmp::Reverse((t_ns, ri, mi))) = heap.pop() {
        let s = &streams[ri];
        let first = mi * s.block_len;
        let end = (first + s.block_len).min(s.samples.len());
        let payload = match opts.messages {
            McapMessages::PerSample => {
                serde_json::to_vec(&serde_json::json!({ "t_ns": t_ns, "value": s.samples[first] }))
            }
            McapMessages::Blocks { .. } => serde_json::to_vec(&AccelBlock {
                channel: s.id.to_string(),
                t0_ns: t_ns,
                rate_hz: s.rate,
                units: Some(s.units.to_string()),
                samples: s.samples[first..end].to_vec(),
            }),
        }
        .map_err(|e| fail(format!("channel {}: {e}", s.id)))?;
        let log_time = t_ns.max(0) as u64;
        let header = mcap::records::MessageHeader {
            channel_id: s.channel_id,
            sequence: mi as u32,
            log_time,
            publish_time: log_time,
        };
        writer
            .write_to_known_channel(&header, &payload)
            .map_err(|e| fail(e.to_string()))?;
        if end < s.samples.len() {
            heap.push(std::cmp::Reverse((time_of(s, end), ri, mi + 1)));
        }
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
