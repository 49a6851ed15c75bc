//! MCAP reader for acceleration messages (chunked or not, zstd/lz4/uncompressed).
//!
//! # Accepted messages
//!
//! The container is read with the `mcap` crate; quaketwin decodes the payloads.
//! A message is an *acceleration message* when its topic starts with
//! `/accel/` or its schema is named `quaketwin.AccelBlock`.  Other topics are
//! skipped.  An acceleration message in any encoding other than `json` or
//! `protobuf` is an error (never silently dropped).
//!
//! 1. **Block messages**, JSON (`message_encoding = "json"`, schema name
//!    `quaketwin.AccelBlock`, schema encoding `jsonschema`), any topic:
//!    ```json
//!    {"channel": "F1-X", "t0_ns": 1543598939334500000, "rate_hz": 200.0,
//!     "units": "m/s2", "samples": [0.01, 0.02, null, ...]}
//!    ```
//!    `channel` (string; default: the topic without `/accel/`), `t0_ns` (i64,
//!    ns since the Unix epoch of the first sample; default: the message
//!    log_time), `rate_hz` (f64 > 0, required), `units` (optional: `m/s2`,
//!    `g`, `cm/s2`, `mm/s2`, `counts`…), `samples` (numbers; `null` = missing
//!    value, read as NaN and flagged).
//! 2. **Per-sample messages**, JSON, topic `/accel/<channel>`:
//!    `{"t_ns": 1543598939334500000, "value": 0.01}`; `t_ns` defaults to the
//!    message log_time; optional `units`.  The sampling interval is the median
//!    time step (snapped to a whole rate in Hz when within 1 ns of it).
//! 3. **Block messages**, protobuf (`message_encoding = "protobuf"`, schema
//!    name `quaketwin.AccelBlock`), with fixed field numbers:
//!    ```proto
//!    message AccelBlock {
//!      string channel = 1;
//!      int64  t0_ns   = 2;
//!      double rate_hz = 3;
//!      string units   = 4;
//!      repeated double samples = 5 [packed = true];
//!    }
//!    ```
//!    Unpacked `samples` and unknown fields are accepted as protobuf allows.
//!
//! Channel metadata key `quaketwin.channel` (written by
//! `sinks::mcap_writer`) may hold the JSON of a `vocab::Channel`; when present
//! it supplies everything but samples, rate and start time, so files written
//! by quaketwin read back with their ids, units, directions and roles.  A
//! channel metadata `start_known = "false"` means the start time is unknown.
//!
//! Messages of one channel are ordered by time and joined (blocks and single
//! samples alike): contiguous within half a sample, gaps filled linearly and
//! flagged `QaFlag::Gap`, overlaps keep the earlier samples (see
//! `readers::mseed::join_segments`).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::mseed::{join_segments, Segment};
use super::{FileContents, ReadOptions};
use crate::error::{Error, Result};
use crate::vocab::{Channel, QaFlag, Record, SourceRef, Units};

/// Schema name of block messages (JSON and protobuf).
pub const ACCEL_BLOCK_SCHEMA: &str = "quaketwin.AccelBlock";

/// JSON Schema of the JSON block message (stored in MCAP files quaketwin writes).
pub const ACCEL_BLOCK_JSON_SCHEMA: &str = r#"{"$schema":"https://json-schema.org/draft/2020-12/schema","title":"quaketwin.AccelBlock","type":"object","required":["channel","t0_ns","rate_hz","samples"],"properties":{"channel":{"type":"string"},"t0_ns":{"type":"integer","description":"ns since the Unix epoch of samples[0]"},"rate_hz":{"type":"number","exclusiveMinimum":0},"units":{"type":"string"},"samples":{"type":"array","items":{"type":["number","null"]}}}}"#;

/// Protobuf source of the protobuf block message (field numbers are fixed).
pub const ACCEL_BLOCK_PROTO: &str = "syntax = \"proto3\";\npackage quaketwin;\nmessage AccelBlock {\n  string channel = 1;\n  int64 t0_ns = 2;\n  double rate_hz = 3;\n  string units = 4;\n  repeated double samples = 5;\n}\n";

/// Metadata key of a channel holding the JSON of a `vocab::Channel`.
pub const CHANNEL_METADATA_KEY: &str = "quaketwin.channel";

/// One block of uniformly sampled values (the payload of schema `quaketwin.AccelBlock`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AccelBlock {
    pub channel: String,
    pub t0_ns: i64,
    pub rate_hz: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub units: Option<String>,
    /// NaN is written as JSON `null` and read back as NaN.
    #[serde(serialize_with = "ser_samples", deserialize_with = "de_samples")]
    pub samples: Vec<f64>,
}

fn ser_samples<S: serde::Serializer>(v: &[f64], s: S) -> std::result::Result<S::Ok, S::Error> {
    use serde::ser::SerializeSeq;
    let mut seq = s.serialize_seq(Some(v.len()))?;
    for x in v {
        if x.is_finite() {
            seq.serialize_element(x)?;
        } else {
            seq.serialize_element(&Option::<f64>::None)?;
        }
    }
    seq.end()
}

fn de_samples<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Vec<f64>, D::Error> {
    let v: Vec<Option<f64>> = Vec::deserialize(d)?;
    Ok(v.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect())
}

/// Decodes a protobuf `quaketwin.AccelBlock` (field numbers in the module doc).
///
/// A hand-written wire-format decoder: there is exactly one message type with
/// five scalar fields, so a protobuf code generator or reflection crate
/// (prost + build script, or protobuf descriptors) would add weight for about
/// sixty lines of varint and length handling.
pub fn decode_accel_block_protobuf(data: &[u8]) -> std::result::Result<AccelBlock, String> {
    fn varint(data: &[u8], pos: &mut usize) -> std::result::Result<u64, String> {
        let mut v: u64 = 0;
        for shift in (0..64).step_by(7) {
            let b = *data
                .get(*pos)
                .ok_or_else(|| format!("varint runs past the end at byte {}", *pos))?;
            *pos += 1;
            v |= ((b & 0x7f) as u64) << shift;
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        Err(format!("varint longer than 10 bytes before byte {}", *pos))
    }
    fn take<'a>(
        data: &'a [u8],
        pos: &mut usize,
        n: usize,
    ) -> std::result::Result<&'a [u8], String> {
        let end = pos
            .checked_add(n)
            .filter(|e| *e <= data.len())
            .ok_or_else(|| {
                format!(
                    "field of {n} bytes at byte {} runs past the end ({} bytes)",
                    *pos,
                    data.len()
                )
            })?;
        let s = &data[*pos..end];
        *pos = end;
        Ok(s)
    }
    let f64_of = |b: &[u8]| f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]);
    let mut block = AccelBlock {
        channel: String::new(),
        t0_ns: 0,
        rate_hz: 0.0,
        units: None,
        samples: Vec::new(),
    };
    let mut pos = 0usize;
    while pos < data.len() {
        let at = pos;
        let key = varint(data, &mut pos)?;
        let (field, wire) = (key >> 3, key & 7);
        match (field, wire) {
            (1, 2) | (4, 2) => {
                let len = varint(data, &mut pos)? as usize;
                let s = std::str::from_utf8(take(data, &mut pos, len)?)
                    .map_err(|_| format!("field {field} at byte {at} is not UTF-8"))?
                    .to_string();
                if field == 1 {
                    block.channel = s;
                } else {
                    block.units = Some(s);
                }
            }
            (2, 0) => block.t0_ns = varint(data, &mut pos)? as i64,
            (3, 1) => block.rate_hz = f64_of(take(data, &mut pos, 8)?),
            (5, 2) => {
                let len = varint(data, &mut pos)? as usize;
                let bytes = take(data, &mut pos, len)?;
                if !len.is_multiple_of(8) {
                    return Err(format!(
                        "packed samples at byte {at}: {len} bytes is not a multiple of 8"
                    ));
                }
                block.samples.extend(bytes.chunks_exact(8).map(f64_of));
            }
            (5, 1) => {
                let b = take(data, &mut pos, 8)?;
                block.samples.push(f64_of(b));
            }
            (1..=5, w) => {
                return Err(format!(
                    "field {field} at byte {at} has wire type {w}, not the schema's"
                ))
            }
            // Unknown fields: skip by wire type.
            (_, 0) => {
                varint(data, &mut pos)?;
            }
            (_, 1) => {
                take(data, &mut pos, 8)?;
            }
            (_, 2) => {
                let len = varint(data, &mut pos)? as usize;
                take(data, &mut pos, len)?;
            }
            (_, 5) => {
                take(data, &mut pos, 4)?;
            }
            (_, w) => return Err(format!("unsupported wire type {w} at byte {at}")),
        }
    }
    Ok(block)
}

/// Walks the top-level records (opcode u8, length u64 LE, body) from the
/// leading to the trailing magic, checking each length fits in the file.
/// Returns the byte offset and a message for the first inconsistency.
fn check_record_structure(bytes: &[u8]) -> std::result::Result<(), (u64, String)> {
    const MAGIC: &[u8] = mcap::MAGIC;
    const FOOTER: u8 = 0x02;
    const CHUNK: u8 = 0x06;
    const MAX_CHUNK_BYTES: u64 = 1 << 30; // = the largest record_length_limit
    if !bytes.starts_with(MAGIC) {
        return Err((0, "not an MCAP file (no leading magic bytes)".into()));
    }
    let mut pos = MAGIC.len();
    loop {
        let left = bytes.len() - pos;
        if left < 9 {
            return Err((pos as u64, format!("truncated MCAP file: {left} bytes left where a record or the end magic should be")));
        }
        let opcode = bytes[pos];
        let mut len_bytes = [0u8; 8];
        len_bytes.copy_from_slice(&bytes[pos + 1..pos + 9]);
        let len = u64::from_le_bytes(len_bytes);
        let end = (pos as u64 + 9).checked_add(len).filter(|e| *e <= bytes.len() as u64).ok_or_else(|| {
            (pos as u64, format!("record (opcode {opcode:#04x}) claims {len} bytes, only {} remain: truncated or corrupt MCAP file", left - 9))
        })? as usize;
        // Chunk body: start u64, end u64, uncompressed_size u64, crc u32, ... The
        // parser allocates the claimed size up front: refuse absurd claims.
        if opcode == CHUNK && len >= 24 {
            let mut size = [0u8; 8];
            size.copy_from_slice(&bytes[pos + 9 + 16..pos + 9 + 24]);
            let size = u64::from_le_bytes(size);
            if size > MAX_CHUNK_BYTES {
                return Err((
                    pos as u64,
                    format!("chunk claims {size} uncompressed bytes (limit {MAX_CHUNK_BYTES}): corrupt MCAP file"),
                ));
            }
        }
        pos = end;
        if opcode == FOOTER {
            return if &bytes[pos..] == MAGIC {
                Ok(())
            } else {
                Err((
                    pos as u64,
                    "MCAP footer is not followed by exactly the end magic bytes".into(),
                ))
            };
        }
    }
}

/// Largest record (or decompressed chunk) accepted: generous for acceleration
/// blocks, small enough that a corrupt length cannot exhaust memory.
fn record_length_limit(file_len: usize) -> usize {
    (64usize << 20)
        .max(file_len.saturating_mul(16))
        .min(1 << 30)
}

/// Checks the length-prefixed fields of a Schema, Channel or Message record
/// against its body before the mcap crate parses it: its parser (binrw)
/// reserves a string's claimed length up front, so one corrupt u32 inside a
/// 40-byte Channel record asked for 4 GB (found by the long fuzz run,
/// docs/robustness.md).  Field layouts: MCAP specification, "Records".
fn check_record_fields(opcode: u8, body: &[u8]) -> std::result::Result<(), String> {
    struct Fields<'a> {
        body: &'a [u8],
        pos: usize,
    }
    impl Fields<'_> {
        fn skip(&mut self, n: u64, what: &str) -> std::result::Result<(), String> {
            let left = (self.body.len() - self.pos) as u64;
            if n > left {
                return Err(format!(
                    "{what} claims {n} bytes, only {left} remain in its record"
                ));
            }
            self.pos += n as usize;
            Ok(())
        }
        fn length(&mut self, what: &str) -> std::result::Result<u64, String> {
            let at = self.pos;
            self.skip(4, what)?;
            let mut b = [0u8; 4];
            b.copy_from_slice(&self.body[at..at + 4]);
            Ok(u32::from_le_bytes(b) as u64)
        }
        /// A string or byte array with a u32 length prefix.
        fn prefixed(&mut self, what: &str) -> std::result::Result<(), String> {
            let n = self.length(what)?;
            self.skip(n, what)
        }
        /// A map<string, string>: u32 byte length, then key/value strings.
        fn string_map(&mut self, what: &str) -> std::result::Result<(), String> {
            let n = self.length(what)?;
            let start = self.pos;
            self.skip(n, what)?;
            let mut inner = Fields {
                body: &self.body[start..self.pos],
                pos: 0,
            };
            while inner.pos < inner.body.len() {
                inner.prefixed(what)?;
                inner.prefixed(what)?;
            }
            Ok(())
        }
    }
    let mut f = Fields { body, pos: 0 };
    match opcode {
        SCHEMA => {
            f.skip(2, "schema id")?;
            f.prefixed("schema name")?;
            f.prefixed("schema encoding")?;
            f.prefixed("schema data")
        }
        CHANNEL => {
            f.skip(4, "channel and schema ids")?;
            f.prefixed("channel topic")?;
            f.prefixed("channel message encoding")?;
            f.string_map("channel metadata")
        }
        MESSAGE => f.skip(22, "message header"),
        _ => Ok(()),
    }
}

const SCHEMA: u8 = 0x03;
const CHANNEL: u8 = 0x04;
const MESSAGE: u8 = 0x05;
const DATA_END: u8 = 0x0F;

/// All messages of an in-memory MCAP file's data section, in file order.
/// The crate's linear reader frames the records and decompresses chunks
/// (with a record-length limit and chunk CRCs checked first); only the
/// records messages need (schemas, channels, messages) are parsed, each
/// after [`check_record_fields`]; the summary section after Data End is not
/// read (a reader of messages needs nothing from it).
fn read_messages(bytes: &[u8]) -> std::result::Result<Vec<mcap::Message<'static>>, String> {
    use mcap::records::Record;
    use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
    use std::borrow::Cow;
    use std::collections::HashMap;
    use std::sync::Arc;
    let options = LinearReaderOptions::default()
        .with_record_length_limit(record_length_limit(bytes.len()))
        .with_validate_chunk_crcs(true)
        .with_prevalidate_chunk_crcs(true)
        .with_emit_chunks(false);
    let mut reader = LinearReader::new_with_options(options);
    let mut rest = bytes;
    let mut schemas: HashMap<u16, Arc<mcap::Schema<'static>>> = HashMap::new();
    let mut channels: HashMap<u16, Arc<mcap::Channel<'static>>> = HashMap::new();
    let mut out = Vec::new();
    while let Some(event) = reader.next_event() {
        let (opcode, data) = match event.map_err(|e| e.to_string())? {
            LinearReadEvent::ReadRequest(need) => {
                let n = need.min(rest.len());
                reader.insert(n).copy_from_slice(&rest[..n]);
                reader.notify_read(n);
                rest = &rest[n..];
                continue;
            }
            LinearReadEvent::Record { opcode, data } => (opcode, data),
        };
        match opcode {
            DATA_END => break,
            SCHEMA | CHANNEL | MESSAGE => {}
            _ => continue,
        }
        check_record_fields(opcode, data)?;
        match mcap::parse_record(opcode, data).map_err(|e| e.to_string())? {
            Record::Schema { header, data } => {
                let schema = mcap::Schema {
                    id: header.id,
                    name: header.name,
                    encoding: header.encoding,
                    data: Cow::Owned(data.into_owned()),
                };
                schemas.insert(header.id, Arc::new(schema));
            }
            Record::Channel(c) => {
                let schema = match c.schema_id {
                    0 => None,
                    id => Some(schemas.get(&id).cloned().ok_or_else(|| {
                        format!(
                            "channel {} refers to schema {id}, which is not defined before it",
                            c.id
                        )
                    })?),
                };
                let channel = mcap::Channel {
                    id: c.id,
                    topic: c.topic,
                    schema,
                    message_encoding: c.message_encoding,
                    metadata: c.metadata,
                };
                channels.insert(c.id, Arc::new(channel));
            }
            Record::Message { header, data } => {
                let channel = channels.get(&header.channel_id).cloned().ok_or_else(|| {
                    format!(
                        "message {} refers to channel {}, which is not defined before it",
                        header.sequence, header.channel_id
                    )
                })?;
                out.push(mcap::Message {
                    channel,
                    sequence: header.sequence,
                    log_time: header.log_time,
                    publish_time: header.publish_time,
                    data: Cow::Owned(data.into_owned()),
                });
            }
            _ => {}
        }
    }
    Ok(out)
}

/// What was collected for one channel.
#[derive(Default)]
struct ChannelAcc {
    segments: Vec<Segment>,
    /// Per-sample messages (t_ns, value).
    points: Vec<(i64, f64)>,
    units: Vec<String>,
    channel_json: Option<String>,
    start_unknown: bool,
    topic: String,
}

/// Reads every acceleration channel of an MCAP file.
pub fn read(bytes: &[u8], source: &SourceRef, _opts: &ReadOptions) -> Result<FileContents> {
    let mut src = source.clone();
    src.format = "mcap".into();
    let loc = || super::location(&src);
    check_record_structure(bytes).map_err(|(at, m)| Error::input(loc().at_byte(at), m))?;
    // The mcap 0.26 `MessageStream` sets no record-length limit: a corrupt
    // length inside a chunk makes it overflow or allocate exabytes (found by
    // the corruption test).  So the sans-io reader is driven here with a
    // record-length limit, chunk CRCs checked before any chunk record is
    // parsed and every parsed record's fields checked (`read_messages`); the
    // panic guard is a last line of defence for parser bugs.
    let messages = std::panic::catch_unwind(|| read_messages(bytes))
        .map_err(|_| {
            Error::input(
                loc(),
                "malformed MCAP file: the MCAP parser failed on its records",
            )
        })?
        .map_err(|e| Error::input(loc(), format!("not a readable MCAP file: {e}")))?;
    let mut order: Vec<String> = Vec::new();
    let mut chans: BTreeMap<String, ChannelAcc> = BTreeMap::new();
    let mut topics_seen: Vec<String> = Vec::new();
    for (index, msg) in messages.into_iter().enumerate() {
        let topic = msg.channel.topic.clone();
        if !topics_seen.contains(&topic) {
            topics_seen.push(topic.clone());
        }
        let schema_name = msg
            .channel
            .schema
            .as_ref()
            .map(|s| s.name.as_str())
            .unwrap_or("");
        let is_accel = topic.starts_with("/accel/") || schema_name == ACCEL_BLOCK_SCHEMA;
        let here = |m: String| {
            Error::input(
                loc().with_channel(topic.clone()),
                format!("message {index} (log_time {}): {m}", msg.log_time),
            )
        };
        let topic_channel = topic.strip_prefix("/accel/").unwrap_or(&topic).to_string();
        enum Payload {
            Block(AccelBlock),
            Point {
                channel: String,
                t_ns: i64,
                value: f64,
                units: Option<String>,
            },
        }
        let payload = match msg.channel.message_encoding.as_str() {
            "json" => {
                let v: serde_json::Value = match serde_json::from_slice(&msg.data) {
                    Ok(v) => v,
                    Err(e) if is_accel => return Err(here(format!("invalid JSON: {e}"))),
                    Err(_) => continue,
                };
                if v.get("samples").is_some() {
                    let mut obj = v.clone();
                    if let Some(o) = obj.as_object_mut() {
                        o.entry("channel")
                            .or_insert_with(|| serde_json::Value::String(topic_channel.clone()));
                        o.entry("t0_ns")
                            .or_insert_with(|| serde_json::Value::from(msg.log_time as i64));
                    }
                    let block: AccelBlock = serde_json::from_value(obj)
                        .map_err(|e| here(format!("does not match {ACCEL_BLOCK_SCHEMA}: {e}")))?;
                    Payload::Block(block)
                } else if is_accel {
                    let value = match v.get("value") {
                        Some(serde_json::Value::Null) => f64::NAN,
                        Some(x) => x.as_f64().ok_or_else(|| here(format!("\"value\" is {x}, not a number")))?,
                        None => {
                            return Err(here(format!(
                                "JSON message has neither \"samples\" ({ACCEL_BLOCK_SCHEMA}) nor \"value\" (per-sample)"
                            )))
                        }
                    };
                    let t_ns = match v.get("t_ns") {
                        Some(t) => t
                            .as_i64()
                            .ok_or_else(|| here(format!("\"t_ns\" is {t}, not an integer")))?,
                        None => msg.log_time as i64,
                    };
                    let units = v.get("units").and_then(|u| u.as_str()).map(String::from);
                    Payload::Point {
                        channel: topic_channel.clone(),
                        t_ns,
                        value,
                        units,
                    }
                } else {
                    continue;
                }
            }
            "protobuf" => {
                if schema_name != ACCEL_BLOCK_SCHEMA {
                    if is_accel {
                        return Err(here(format!(
                            "protobuf schema {schema_name:?} is not {ACCEL_BLOCK_SCHEMA}"
                        )));
                    }
                    continue;
                }
                let mut b = decode_accel_block_protobuf(&msg.data)
                    .map_err(|m| here(format!("protobuf {ACCEL_BLOCK_SCHEMA}: {m}")))?;
                if b.channel.is_empty() {
                    b.channel = topic_channel.clone();
                }
                Payload::Block(b)
            }
            other => {
                if is_accel {
                    return Err(here(format!(
                        "unknown message encoding {other:?}: quaketwin reads acceleration messages encoded as json or protobuf"
                    )));
                }
                continue;
            }
        };
        let (id, units) = match &payload {
            Payload::Block(b) => (b.channel.clone(), b.units.clone()),
            Payload::Point { channel, units, .. } => (channel.clone(), units.clone()),
        };
        if !chans.contains_key(&id) {
            order.push(id.clone());
        }
        let acc = chans.entry(id.clone()).or_default();
        if acc.topic.is_empty() {
            acc.topic = topic.clone();
            acc.channel_json = msg.channel.metadata.get(CHANNEL_METADATA_KEY).cloned();
            acc.start_unknown = msg
                .channel
                .metadata
                .get("start_known")
                .map(|s| s == "false")
                .unwrap_or(false);
        }
        if let Some(u) = units.or_else(|| msg.channel.metadata.get("units").cloned()) {
            if !acc.units.contains(&u) {
                acc.units.push(u);
            }
        }
        match payload {
            Payload::Block(b) => {
                if !(b.rate_hz.is_finite() && b.rate_hz > 0.0) {
                    return Err(here(format!("rate_hz {} is not positive", b.rate_hz)));
                }
                acc.segments.push(Segment {
                    start_ns: b.t0_ns,
                    rate_hz: b.rate_hz,
                    samples: b.samples,
                    origin: format!("message {index} on {topic}"),
                });
            }
            Payload::Point { t_ns, value, .. } => acc.points.push((t_ns, value)),
        }
    }

    let mut records = Vec::new();
    for id in order {
        let Some(mut acc) = chans.remove(&id) else {
            continue;
        };
        let cloc = || loc().with_channel(id.clone());
        if !acc.points.is_empty() {
            acc.points.sort_by_key(|p| p.0);
            let rate = if let Some(s) = acc.segments.first() {
                s.rate_hz
            } else {
                let mut steps: Vec<i64> = acc
                    .points
                    .windows(2)
                    .map(|w| w[1].0.saturating_sub(w[0].0))
                    .filter(|d| *d > 0)
                    .collect();
                steps.sort_unstable();
                let Some(&dt) = steps.get(steps.len() / 2) else {
                    return Err(Error::input(cloc(), "per-sample messages need at least two distinct times to give a sampling rate"));
                };
                let whole = (1e9 / dt as f64).round();
                if whole >= 1.0 && (1e9 / whole - dt as f64).abs() <= 1.0 {
                    whole
                } else {
                    1e9 / dt as f64
                }
            };
            for (t, v) in acc.points.drain(..) {
                acc.segments.push(Segment {
                    start_ns: t,
                    rate_hz: rate,
                    samples: vec![v],
                    origin: format!("sample at {t} ns"),
                });
            }
        }
        let joined = join_segments(acc.segments).map_err(|m| Error::input(cloc(), m))?;
        let mut ch = match acc
            .channel_json
            .as_deref()
            .map(serde_json::from_str::<Channel>)
        {
            Some(Ok(mut c)) => {
                c.source = src.clone();
                c.source.column = Some(acc.topic.clone());
                c
            }
            Some(Err(e)) => {
                return Err(Error::input(
                    cloc(),
                    format!(
                        "channel metadata {CHANNEL_METADATA_KEY} is not a quaketwin channel: {e}"
                    ),
                ))
            }
            None => {
                let mut s = src.clone();
                s.column = Some(acc.topic.clone());
                let mut c = Channel::new(id.clone(), Units::MPerS2, joined.rate_hz, s);
                match acc.units.as_slice() {
                    [] => {
                        c.missing.push("units".into());
                        c.inferred
                            .push("units=m/s2 assumed: the messages state none".into());
                    }
                    [u] => {
                        c.units = u.parse::<Units>().map_err(|e| Error::input(cloc(), e))?;
                    }
                    many => {
                        return Err(Error::input(
                            cloc(),
                            format!("messages disagree on units: {many:?}"),
                        ))
                    }
                }
                c
            }
        };
        ch.sampling_rate_hz = joined.rate_hz;
        ch.start_ns = (!acc.start_unknown).then_some(joined.start_ns);
        ch.qa.extend(joined.qa);
        let nonfinite = joined.samples.iter().filter(|v| !v.is_finite()).count();
        if nonfinite > 0 && !ch.qa.iter().any(|q| matches!(q, QaFlag::NonFinite { .. })) {
            ch.qa.push(QaFlag::NonFinite { count: nonfinite });
        }
        records.push(Record::new(ch, joined.samples));
    }
    if records.is_empty() {
        return Err(Error::input(
            loc(),
            format!("no acceleration messages (topics /accel/… or schema {ACCEL_BLOCK_SCHEMA}); topics seen: {topics_seen:?}"),
        ));
    }
    Ok(FileContents {
        records,
        ..Default::default()
    })
}
