//! MiniSEED 2 reader (SEED 2.4 data-only records).
//!
//! Written by hand: the `mseed` crate binds libmseed through bindgen and needs
//! libclang, which build machines lack, and `miniseed` downloads C sources at
//! build time.  The format is small: a fixed 48-byte header, a chain of
//! blockettes (1000: encoding, word order, record length; 1001: extra
//! microseconds, frame count; 100: exact sampling rate) and a data section.
//!
//! What is read:
//! - both byte orders (header order detected from the BTIME year/day; data
//!   order from blockette 1000);
//! - encodings INT16 (1), INT32 (3), FLOAT32 (4), FLOAT64 (5), Steim-1 (10),
//!   Steim-2 (11).  Steim integration constants are verified: the first
//!   decoded sample must equal X0 (forward constant) and the last must equal
//!   Xn (reverse constant); a mismatch is an `Error::Input` naming the byte
//!   offset of the record;
//! - ASCII log records (encoding 0) and records without samples are skipped;
//! - several channels per file, keyed `NET.STA.LOC.CHA`; the records of one
//!   channel are ordered by start time and concatenated.
//!
//! Record joins (shared with the MCAP reader through [`join_segments`]): a
//! record that starts within half a sample of where the previous one ended
//! continues it.  A later start is a gap: the missing samples are filled by
//! linear interpolation between the bordering samples and flagged
//! `QaFlag::Gap { at_s, duration_s }` plus a `QaFlag::Note` saying how many
//! samples were filled.  An earlier start is an overlap: samples already
//! present are kept, the overlapping ones dropped; if they differ from what is
//! kept the overlap is flagged `QaFlag::Gap` with a *negative* duration and a
//! note (identical duplicates, common in archives, are dropped silently).
//!
//! Values are raw counts: `Units::Counts { counts_per_si: None }` until the
//! StationXML of the folder (see `stationxml::apply`) gives the sensitivity.

use std::collections::BTreeMap;

use super::{FileContents, ReadOptions};
use crate::error::{Error, Result};
use crate::vocab::{epoch_ns_from_ordinal, Channel, QaFlag, Record, SourceRef, Units};

const FIXED_HEADER_LEN: usize = 48;
const NS_PER_S: f64 = 1e9;
/// Largest gap (in samples) filled by interpolation; beyond it the join fails.
const MAX_GAP_FILL: usize = 10_000_000;

/// One decoded data record.
#[derive(Debug, Clone)]
struct DataRecord {
    id: String,
    network: String,
    station: String,
    location: String,
    channel: String,
    start_ns: i64,
    rate_hz: f64,
    samples: Vec<f64>,
    /// Samples the header announces (`samples` is empty when not decoded).
    nsamples: usize,
    /// `nsamples`, or fewer when the data section could not hold them (a
    /// header is not trusted before it is checked against the bytes: room
    /// reserved for a channel's records is at most what they can decode to).
    nsamples_bound: usize,
    /// Byte offset of the record in the file (for error messages).
    offset: usize,
}

/// A run of samples on a uniform grid, to be joined with others of the same channel.
#[derive(Debug, Clone)]
pub struct Segment {
    pub start_ns: i64,
    pub rate_hz: f64,
    pub samples: Vec<f64>,
    /// Where the segment came from (byte offset, message index), for messages.
    pub origin: String,
}

/// The result of joining segments: one uniform series and its quality flags.
#[derive(Debug, Clone, PartialEq)]
pub struct Joined {
    pub start_ns: i64,
    pub rate_hz: f64,
    pub samples: Vec<f64>,
    pub qa: Vec<QaFlag>,
}

/// Joins segments of one channel (sorted here by start time, stable) into one
/// series on the grid of the first segment.  Contiguity tolerance: half a
/// sample.  Gaps are filled by linear interpolation and flagged; overlaps keep
/// the samples already present (see the module documentation).  All segments
/// must share the sampling rate (relative difference below 1e-6).
pub fn join_segments(mut segments: Vec<Segment>) -> std::result::Result<Joined, String> {
    segments.retain(|s| !s.samples.is_empty());
    segments.sort_by_key(|s| s.start_ns);
    let Some(first) = segments.first() else {
        return Err("no samples".into());
    };
    let capacity = segments.iter().map(|s| s.samples.len()).sum();
    let mut joiner = Joiner::new(first.start_ns, first.rate_hz, &first.origin, capacity)?;
    // Each segment is freed as soon as it is appended.
    for seg in segments {
        joiner.push(seg)?;
    }
    Ok(joiner.finish())
}

/// [`join_segments`] a segment at a time, the segments coming in order of
/// start time: a reader decodes a record, pushes it and drops it, so a
/// channel is held once (the joined series), not twice.
pub struct Joiner {
    start_ns: i64,
    rate_hz: f64,
    dt_ns: f64,
    samples: Vec<f64>,
    qa: Vec<QaFlag>,
    filled_total: usize,
}

impl Joiner {
    /// A series starting at `start_ns` on the grid of `rate_hz` (of the
    /// segment `origin`, for messages), with room for `capacity` samples
    /// (exact for contiguous segments: a vector grown by doubling would
    /// reach twice a day-long channel).
    pub fn new(
        start_ns: i64,
        rate_hz: f64,
        origin: &str,
        capacity: usize,
    ) -> std::result::Result<Self, String> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(format!("invalid sampling rate {rate_hz} Hz ({origin})"));
        }
        Ok(Joiner {
            start_ns,
            rate_hz,
            dt_ns: NS_PER_S / rate_hz,
            samples: Vec::with_capacity(capacity),
            qa: Vec::new(),
            filled_total: 0,
        })
    }

    /// Appends the next segment (an empty one is ignored).
    pub fn push(&mut self, seg: Segment) -> std::result::Result<(), String> {
        if seg.samples.is_empty() {
            return Ok(());
        }
        let (rate, start_ns, dt_ns) = (self.rate_hz, self.start_ns, self.dt_ns);
        if ((seg.rate_hz - rate) / rate).abs() > 1e-6 {
            return Err(format!(
                "sampling rate changes from {rate} Hz to {} Hz ({})",
                seg.rate_hz, seg.origin
            ));
        }
        // Position of this segment's first sample on the grid of the first segment.
        let offset_samples = (seg.start_ns as i128 - start_ns as i128) as f64 / dt_ns;
        let expected = self.samples.len() as f64;
        let shift = offset_samples - expected;
        if self.samples.is_empty() || shift.abs() <= 0.5 {
            self.samples.extend_from_slice(&seg.samples);
        } else if shift > 0.5 {
            // Gap: fill with a straight line between the bordering samples.
            // A corrupt time stamp must not make us allocate years of samples.
            if shift > MAX_GAP_FILL as f64 {
                return Err(format!(
                    "gap of {:.0} samples ({:.1} s) before {} is implausible for one record (limit {MAX_GAP_FILL} samples)",
                    shift,
                    shift / rate,
                    seg.origin
                ));
            }
            let missing = shift.round() as usize;
            let left = self.samples.last().copied().unwrap_or(0.0);
            let right = seg.samples[0];
            for k in 1..=missing {
                let w = k as f64 / (missing + 1) as f64;
                self.samples.push(left + (right - left) * w);
            }
            self.filled_total += missing;
            self.qa.push(QaFlag::Gap {
                at_s: expected / rate,
                duration_s: shift / rate,
            });
            self.samples.extend_from_slice(&seg.samples);
        } else {
            // Overlap of `overlap` samples: keep what we have.
            let overlap = (-shift).round() as usize;
            let begin = self.samples.len().saturating_sub(overlap);
            let kept = &self.samples[begin..];
            let differs = kept
                .iter()
                .zip(seg.samples.iter())
                .any(|(a, b)| a != b && !(a.is_nan() && b.is_nan()));
            if differs {
                self.qa.push(QaFlag::Gap {
                    at_s: begin as f64 / rate,
                    duration_s: shift / rate,
                });
                self.qa.push(QaFlag::Note {
                    text: format!(
                        "overlap of {overlap} samples at {:.6} s ({}) with different values: the earlier samples were kept",
                        begin as f64 / rate,
                        seg.origin
                    ),
                });
            }
            if overlap < seg.samples.len() {
                self.samples.extend_from_slice(&seg.samples[overlap..]);
            }
        }
        Ok(())
    }

    /// The joined series and its flags.
    pub fn finish(mut self) -> Joined {
        if self.filled_total > 0 {
            self.qa.push(QaFlag::Note {
                text: format!(
                    "{} missing samples filled by linear interpolation across gaps",
                    self.filled_total
                ),
            });
        }
        Joined {
            start_ns: self.start_ns,
            rate_hz: self.rate_hz,
            samples: self.samples,
            qa: self.qa,
        }
    }
}

/// Reads a whole MiniSEED file: one record per `NET.STA.LOC.CHA`, in order of
/// first appearance.
pub fn read(bytes: &[u8], source: &SourceRef, _opts: &ReadOptions) -> Result<FileContents> {
    let mut src = source.clone();
    src.format = "mseed".into();
    // Headers first (every record checked, no sample decoded), then each
    // channel's records decoded one at a time into its joined series: a
    // day-long channel is held once, not as thousands of record vectors
    // beside the series they are copied into.
    let (data_records, skipped) = parse_records(bytes, &src, false)?;
    // Group by channel, keeping the order of first appearance (stable output).
    let mut order: Vec<String> = Vec::new();
    let mut groups: BTreeMap<String, Vec<DataRecord>> = BTreeMap::new();
    for r in data_records {
        if !groups.contains_key(&r.id) {
            order.push(r.id.clone());
        }
        groups.entry(r.id.clone()).or_default().push(r);
    }
    let mut records = Vec::new();
    for id in order {
        let Some(mut group) = groups.remove(&id) else {
            continue;
        };
        group.sort_by_key(|r| r.start_ns);
        let first = group[0].clone();
        let in_channel = |offset: usize, m: String| {
            Error::input(
                super::location(&src)
                    .with_channel(&id)
                    .at_byte(offset as u64),
                m,
            )
        };
        let capacity = group.iter().map(|r| r.nsamples_bound).sum();
        let origin = |r: &DataRecord| format!("record at byte {}", r.offset);
        let mut joiner = Joiner::new(first.start_ns, first.rate_hz, &origin(&first), capacity)
            .map_err(|m| in_channel(first.offset, m))?;
        for r in &group {
            let decoded = match parse_record(&bytes[r.offset..], r.offset, &src, true)? {
                Some((Parsed::Data(d), _)) => d.samples,
                // The same bytes parsed a moment ago as a data record.
                _ => {
                    return Err(in_channel(
                        r.offset,
                        "MiniSEED record changed while read".into(),
                    ))
                }
            };
            joiner
                .push(Segment {
                    start_ns: r.start_ns,
                    rate_hz: r.rate_hz,
                    samples: decoded,
                    origin: origin(r),
                })
                .map_err(|m| in_channel(first.offset, m))?;
        }
        let joined = joiner.finish();
        let mut ch = Channel::new(
            id.clone(),
            Units::Counts {
                counts_per_si: None,
            },
            joined.rate_hz,
            src.clone(),
        );
        ch.network = non_empty(&first.network);
        ch.station = non_empty(&first.station);
        ch.location_code = non_empty(&first.location);
        ch.channel_code = non_empty(&first.channel);
        ch.start_ns = Some(joined.start_ns);
        ch.qa = joined.qa;
        // Records of this channel that carried no usable samples: never
        // dropped silently (their time span shows as a gap or a late start).
        let mine: Vec<&SkippedRecord> = skipped.iter().filter(|k| k.id == id).collect();
        if !mine.is_empty() {
            let shown: Vec<String> = mine
                .iter()
                .take(5)
                .map(|k| format!("byte {} ({})", k.offset, k.why))
                .collect();
            ch.qa.push(QaFlag::Note {
                text: format!(
                    "{} record(s) of this channel skipped without samples: {}{}",
                    mine.len(),
                    shown.join(", "),
                    if mine.len() > 5 { ", …" } else { "" }
                ),
            });
        }
        ch.missing.push("sensitivity".into());
        records.push(Record::new(ch, joined.samples));
    }
    if records.is_empty() {
        return Err(Error::input(
            super::location(&src),
            "no data records with samples in this MiniSEED file",
        ));
    }
    Ok(FileContents {
        records,
        ..Default::default()
    })
}

/// `NET.STA.LOC.CHA` codes of a stream (at most 2, 5, 2 and 3 characters;
/// the location code may be empty).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct StreamCodes {
    pub network: String,
    pub station: String,
    pub location: String,
    pub channel: String,
}

impl StreamCodes {
    /// `NET.STA.LOC.CHA`, the id of the records of this stream.
    pub fn id(&self) -> String {
        format!(
            "{}.{}.{}.{}",
            self.network, self.station, self.location, self.channel
        )
    }
}

/// Where one data record of a file lies and what its header says: an
/// entry of a day file's index ([`super::dayfile`]), from which a reader
/// decodes only the records a time window needs ([`decode_record`]).  No
/// stream id: the records of a day file are of its stream (checked when
/// indexed), and an index holds up to a million of these.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordSpan {
    /// Byte offset of the record in the file, and its length.
    pub offset: u64,
    pub len: u32,
    /// Time of the first sample, ns since the Unix epoch (time correction applied).
    pub start_ns: i64,
    pub rate_hz: f64,
    pub samples: u32,
}

impl RecordSpan {
    /// Time just after the last sample: start + samples / rate.
    pub fn end_ns(&self) -> i64 {
        // Saturating: a corrupt rate must not overflow the time (the cast saturates too).
        self.start_ns
            .saturating_add((self.samples as f64 * NS_PER_S / self.rate_hz).round() as i64)
    }
}

/// What the bytes at one offset of a file are, headers checked but no
/// sample decoded ([`scan_header`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Scanned {
    /// A data record: its `NET.STA.LOC.CHA`, where it lies and its time,
    /// and `room`: the header's sample count capped at what the data
    /// section can hold (below `span.samples` when that count is damaged
    /// or the record incomplete).
    Data {
        id: String,
        span: RecordSpan,
        room: usize,
    },
    /// A record without samples (log, detection, empty) of `len` bytes.
    NoSamples { len: usize },
    /// Zeros or spaces up to the end of the bytes given.
    Padding,
}

/// The record at the start of `rest`, which lies at byte `offset` of the
/// file `source`: its header parsed and checked against the bytes present
/// (the record's full length must be in `rest`), no sample decoded.  An
/// error is a record that cannot be read (its message names the offset).
pub fn scan_header(rest: &[u8], offset: u64, source: &SourceRef) -> Result<Scanned> {
    let mut src = source.clone();
    src.format = "mseed".into();
    Ok(match parse_record(rest, offset as usize, &src, false)? {
        None => Scanned::Padding,
        Some((Parsed::Skipped(_), len)) => Scanned::NoSamples { len },
        Some((Parsed::Data(r), len)) => Scanned::Data {
            room: r.nsamples_bound,
            span: RecordSpan {
                offset,
                len: len as u32,
                start_ns: r.start_ns,
                rate_hz: r.rate_hz,
                samples: r.nsamples as u32,
            },
            id: r.id,
        },
    })
}

/// Decodes one record, `bytes` being exactly the record that lies at
/// `span.offset` of the file `source` (errors name that file and offset).
/// The header is parsed again and must agree with the index entry and be
/// of stream `id`.
pub fn decode_record(
    bytes: &[u8],
    span: &RecordSpan,
    id: &str,
    source: &SourceRef,
) -> Result<Segment> {
    let mut src = source.clone();
    src.format = "mseed".into();
    let at = span.offset as usize;
    match parse_record(bytes, at, &src, true)? {
        Some((Parsed::Data(r), _)) if r.id == id && r.start_ns == span.start_ns => Ok(Segment {
            start_ns: r.start_ns,
            rate_hz: r.rate_hz,
            samples: r.samples,
            origin: format!("{} record at byte {at}", src.file),
        }),
        _ => Err(Error::input(
            super::location(&src).at_byte(at as u64),
            "MiniSEED record changed since the file was indexed (the file is being rewritten?)",
        )),
    }
}

/// Whether `head` starts like a MiniSEED 2 record (sequence number, quality
/// indicator, plausible BTIME in either byte order), for format sniffing.
pub fn looks_like(head: &[u8]) -> bool {
    if head.len() < FIXED_HEADER_LEN {
        return false;
    }
    let seq = head[..6].iter().all(|c| c.is_ascii_digit() || *c == b' ');
    let quality = matches!(head[6], b'D' | b'R' | b'Q' | b'M') && matches!(head[7], b' ' | 0);
    let btime = [ByteOrder::Big, ByteOrder::Little].into_iter().any(|o| {
        let y = u16_at(head, 20, o).unwrap_or(0);
        let d = u16_at(head, 22, o).unwrap_or(0);
        (1900..=2500).contains(&y)
            && (1..=366).contains(&d)
            && head[24] < 24
            && head[25] < 60
            && head[26] <= 60
    });
    seq && quality && btime
}

fn non_empty(s: &str) -> Option<String> {
    (!s.is_empty()).then(|| s.to_string())
}

/// Byte order of a record's header or data words.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum ByteOrder {
    Big,
    Little,
}

fn u16_at(b: &[u8], at: usize, o: ByteOrder) -> Option<u16> {
    let s: [u8; 2] = b.get(at..at + 2)?.try_into().ok()?;
    Some(match o {
        ByteOrder::Big => u16::from_be_bytes(s),
        ByteOrder::Little => u16::from_le_bytes(s),
    })
}
fn i16_at(b: &[u8], at: usize, o: ByteOrder) -> Option<i16> {
    u16_at(b, at, o).map(|v| v as i16)
}
fn u32_at(b: &[u8], at: usize, o: ByteOrder) -> Option<u32> {
    let s: [u8; 4] = b.get(at..at + 4)?.try_into().ok()?;
    Some(match o {
        ByteOrder::Big => u32::from_be_bytes(s),
        ByteOrder::Little => u32::from_le_bytes(s),
    })
}
fn u64_at(b: &[u8], at: usize, o: ByteOrder) -> Option<u64> {
    let s: [u8; 8] = b.get(at..at + 8)?.try_into().ok()?;
    Some(match o {
        ByteOrder::Big => u64::from_be_bytes(s),
        ByteOrder::Little => u64::from_le_bytes(s),
    })
}

fn ascii_field(b: &[u8]) -> String {
    String::from_utf8_lossy(b)
        .trim_matches(|c: char| c == ' ' || c == '\0')
        .to_string()
}

/// Nominal sampling rate from the SEED rate factor and multiplier (SEED 2.4 manual, fixed header field 10/11).
pub fn rate_from_factor(factor: i16, multiplier: i16) -> f64 {
    let (f, m) = (factor as f64, multiplier as f64);
    match (factor, multiplier) {
        (0, _) | (_, 0) => 0.0,
        (f_, m_) if f_ > 0 && m_ > 0 => f * m,
        (f_, _) if f_ > 0 => -f / m,
        (_, m_) if m_ > 0 => -m / f,
        _ => 1.0 / (f * m),
    }
}

/// A record read past without samples, and why.
struct SkippedRecord {
    id: String,
    offset: usize,
    why: &'static str,
}

/// Every record of a file (decoded when `decode_samples`) and those skipped.
fn parse_records(
    bytes: &[u8],
    src: &SourceRef,
    decode_samples: bool,
) -> Result<(Vec<DataRecord>, Vec<SkippedRecord>)> {
    let (mut out, mut skipped) = (Vec::new(), Vec::new());
    let mut offset = 0usize;
    while offset < bytes.len() {
        match parse_record(&bytes[offset..], offset, src, decode_samples)? {
            None => break,
            Some((Parsed::Data(r), len)) => {
                out.push(r);
                offset += len;
            }
            Some((Parsed::Skipped(k), len)) => {
                skipped.push(k);
                offset += len;
            }
        }
    }
    Ok((out, skipped))
}

/// What one record holds: samples, or nothing usable (and why).
enum Parsed {
    Data(DataRecord),
    Skipped(SkippedRecord),
}

/// Parses the record at the start of `rest`, which lies at byte `offset`
/// of the file (for messages): what it holds and its length in bytes;
/// `None` for trailing padding.  Samples are decoded only when
/// `decode_samples` (an index of a file needs the headers alone).  Every
/// header field is checked against the bytes present before it is used.
fn parse_record(
    rest: &[u8],
    offset: usize,
    src: &SourceRef,
    decode_samples: bool,
) -> Result<Option<(Parsed, usize)>> {
    let err =
        |offset: usize, msg: String| Error::input(super::location(src).at_byte(offset as u64), msg);
    // Trailing padding (zeros or spaces) after the last record is tolerated.
    if rest.iter().all(|&b| b == 0 || b == b' ') {
        return Ok(None);
    }
    if rest.len() < FIXED_HEADER_LEN {
        return Err(err(
            offset,
            format!(
                "truncated MiniSEED record: {} bytes left, a fixed header needs {FIXED_HEADER_LEN}",
                rest.len()
            ),
        ));
    }
    if rest.starts_with(b"MS") && rest.get(2) == Some(&3) {
        return Err(err(
            offset,
            "MiniSEED 3 records are not supported (only MiniSEED 2)".into(),
        ));
    }
    let seq_ok = rest[..6]
        .iter()
        .all(|c| c.is_ascii_digit() || *c == b' ' || *c == 0);
    let quality = rest[6];
    if !seq_ok || !matches!(quality, b'D' | b'R' | b'Q' | b'M') {
        return Err(err(
            offset,
            "not a MiniSEED 2 record header (sequence number / quality indicator invalid)".into(),
        ));
    }
    // Header byte order: the BTIME year and day must be plausible.
    let order = [ByteOrder::Big, ByteOrder::Little]
        .into_iter()
        .find(|&o| {
            let y = u16_at(rest, 20, o).unwrap_or(0);
            let d = u16_at(rest, 22, o).unwrap_or(0);
            (1900..=2500).contains(&y) && (1..=366).contains(&d)
        })
        .ok_or_else(|| {
            err(
                offset,
                "record start time (BTIME) is invalid in either byte order".into(),
            )
        })?;
    let h = |at: usize| u16_at(rest, at, order).unwrap_or(0);
    let station = ascii_field(&rest[8..13]);
    let location = ascii_field(&rest[13..15]);
    let channel = ascii_field(&rest[15..18]);
    let network = ascii_field(&rest[18..20]);
    let (year, day) = (h(20), h(22));
    let (hour, minute, second) = (rest[24], rest[25], rest[26]);
    let fract_100us = h(28);
    let nsamples = h(30) as usize;
    let factor = i16_at(rest, 32, order).unwrap_or(0);
    let multiplier = i16_at(rest, 34, order).unwrap_or(0);
    let activity = rest[36];
    let nblockettes = rest[39];
    let time_correction = u32_at(rest, 40, order).unwrap_or(0) as i32;
    let data_offset = h(44) as usize;
    let first_blockette = h(46) as usize;

    // Blockette chain.
    let mut encoding: Option<u8> = None;
    let mut data_order = order;
    let mut record_len: Option<usize> = None;
    let mut microseconds: i64 = 0;
    let mut frame_count: usize = 0;
    let mut exact_rate: Option<f64> = None;
    let mut at = first_blockette;
    let mut seen = 0usize;
    while at != 0 {
        if at < FIXED_HEADER_LEN || seen > nblockettes.max(8) as usize + 8 {
            return Err(err(
                offset,
                format!("blockette chain is broken (next blockette at {at})"),
            ));
        }
        let btype = u16_at(rest, at, order).ok_or_else(|| {
            err(
                offset + at,
                "truncated MiniSEED record inside a blockette".into(),
            )
        })?;
        let next = u16_at(rest, at + 2, order).unwrap_or(0) as usize;
        match btype {
            1000 => {
                let b = rest.get(at + 4..at + 7).ok_or_else(|| {
                    err(
                        offset + at,
                        "truncated MiniSEED record inside blockette 1000".into(),
                    )
                })?;
                encoding = Some(b[0]);
                data_order = if b[1] == 0 {
                    ByteOrder::Little
                } else {
                    ByteOrder::Big
                };
                if !(7..=20).contains(&b[2]) {
                    return Err(err(
                        offset + at,
                        format!(
                            "blockette 1000 record length exponent {} is out of range",
                            b[2]
                        ),
                    ));
                }
                record_len = Some(1usize << b[2]);
            }
            1001 => {
                let b = rest.get(at + 4..at + 8).ok_or_else(|| {
                    err(
                        offset + at,
                        "truncated MiniSEED record inside blockette 1001".into(),
                    )
                })?;
                microseconds = b[1] as i8 as i64;
                frame_count = b[3] as usize;
            }
            100 => {
                let v = u32_at(rest, at + 4, order).ok_or_else(|| {
                    err(
                        offset + at,
                        "truncated MiniSEED record inside blockette 100".into(),
                    )
                })?;
                let r = f32::from_bits(v) as f64;
                if r.is_finite() && r > 0.0 {
                    exact_rate = Some(r);
                }
            }
            _ => {}
        }
        if next != 0 && next <= at {
            return Err(err(
                offset + at,
                format!("blockette chain loops back (next blockette at {next})"),
            ));
        }
        at = next;
        seen += 1;
    }
    let record_len = record_len.ok_or_else(|| {
        err(
            offset,
            "MiniSEED record without blockette 1000 (record length and encoding unknown)".into(),
        )
    })?;
    if rest.len() < record_len {
        return Err(err(
            offset,
            format!(
                "truncated MiniSEED record: blockette 1000 says {record_len} bytes, only {} remain in the file",
                rest.len()
            ),
        ));
    }
    let record = &rest[..record_len];
    let encoding = encoding.unwrap_or(0);
    let rate = exact_rate.unwrap_or_else(|| rate_from_factor(factor, multiplier));
    let id = format!("{network}.{station}.{location}.{channel}");
    if nsamples == 0 || rate <= 0.0 || encoding == 0 {
        // Log, detection or empty record: no samples. Noted on the
        // channel of the same id, if it has data records.
        let skipped = SkippedRecord {
            id: id.clone(),
            offset,
            why: if encoding == 0 {
                "encoding 0 (ASCII log)"
            } else if nsamples == 0 {
                "0 samples"
            } else {
                "sample rate 0"
            },
        };
        return Ok(Some((Parsed::Skipped(skipped), record_len)));
    }
    if data_offset < FIXED_HEADER_LEN || data_offset > record_len {
        return Err(err(
            offset,
            format!("data offset {data_offset} outside the {record_len}-byte record"),
        ));
    }
    let data = &record[data_offset..];
    let room = match encoding {
        1 => data.len() / 2,
        3 | 4 => data.len() / 4,
        5 => data.len() / 8,
        // A 64-byte frame: 15 words of at most 4 (Steim-1) or 7 (Steim-2) differences.
        10 => data.len() / 64 * 60,
        11 => data.len() / 64 * 105,
        _ => 0,
    };
    let decoded = if decode_samples {
        decode(data, encoding, data_order, nsamples, frame_count)
            .map_err(|m| err(offset, format!("{id}: {m}")))?
    } else {
        Vec::new()
    };

    let mut start_ns = epoch_ns_from_ordinal(
        year as i64,
        day as u32,
        hour as u32,
        minute as u32,
        second as f64,
    )
    .ok_or_else(|| {
        err(
            offset,
            format!("invalid record start time {year},{day} {hour}:{minute}:{second}"),
        )
    })?;
    let mut shift = fract_100us as i64 * 100_000 + microseconds * 1_000;
    // Activity flag bit 1: time correction already applied to BTIME.
    if activity & 0x02 == 0 {
        shift += time_correction as i64 * 100_000;
    }
    start_ns = start_ns.checked_add(shift).ok_or_else(|| {
        err(
            offset,
            format!("record start time {year},{day} {hour}:{minute}:{second} is out of range"),
        )
    })?;
    let record = DataRecord {
        id,
        network,
        station,
        location,
        channel,
        start_ns,
        rate_hz: rate,
        samples: decoded,
        nsamples,
        nsamples_bound: nsamples.min(room),
        offset,
    };
    Ok(Some((Parsed::Data(record), record_len)))
}

/// Decodes a record's data section.
fn decode(
    data: &[u8],
    encoding: u8,
    order: ByteOrder,
    n: usize,
    frame_count: usize,
) -> std::result::Result<Vec<f64>, String> {
    let need = |width: usize| -> std::result::Result<(), String> {
        if data.len() < n * width {
            Err(format!(
                "data section holds {} bytes, {n} samples of {width} bytes need {}",
                data.len(),
                n * width
            ))
        } else {
            Ok(())
        }
    };
    match encoding {
        1 => {
            need(2)?;
            Ok((0..n).map(|i| i16_at(data, 2 * i, order).unwrap_or(0) as f64).collect())
        }
        3 => {
            need(4)?;
            Ok((0..n).map(|i| u32_at(data, 4 * i, order).unwrap_or(0) as i32 as f64).collect())
        }
        4 => {
            need(4)?;
            Ok((0..n).map(|i| f32::from_bits(u32_at(data, 4 * i, order).unwrap_or(0)) as f64).collect())
        }
        5 => {
            need(8)?;
            Ok((0..n).map(|i| f64::from_bits(u64_at(data, 8 * i, order).unwrap_or(0))).collect())
        }
        10 | 11 => {
            let frames = if frame_count > 0 { frame_count.min(data.len() / 64) } else { data.len() / 64 };
            decode_steim(&data[..frames * 64], encoding == 11, order, n).map(|v| v.into_iter().map(|x| x as f64).collect())
        }
        other => Err(format!(
            "unsupported MiniSEED data encoding {other} (read: 1 INT16, 3 INT32, 4 FLOAT32, 5 FLOAT64, 10 Steim-1, 11 Steim-2)"
        )),
    }
}

/// Sign-extends the low `bits` bits of `v`.
fn sign_extend(v: u32, bits: u32) -> i32 {
    let shift = 32 - bits;
    ((v << shift) as i32) >> shift
}

/// Steim-1/2 decompression (SEED 2.4 manual, appendix B): 64-byte frames of
/// sixteen 32-bit words; word 0 holds 2-bit nibbles describing words 1..15.
/// Frame 0 words 1 and 2 hold the forward (X0) and reverse (Xn) integration
/// constants.  The first difference refers to the previous record and is not
/// used: x0 = X0, x_i = x_{i−1} + d_i.  Checks x_{n−1} = Xn.
pub fn decode_steim(
    frames: &[u8],
    steim2: bool,
    order: ByteOrder,
    n: usize,
) -> std::result::Result<Vec<i32>, String> {
    let name = if steim2 { "Steim-2" } else { "Steim-1" };
    if frames.len() < 64 {
        return Err(format!(
            "{name} data section holds no complete 64-byte frame"
        ));
    }
    let word = |f: usize, w: usize| u32_at(frames, f * 64 + w * 4, order).unwrap_or(0);
    let x0 = word(0, 1) as i32;
    let xn = word(0, 2) as i32;
    let mut diffs: Vec<i32> = Vec::with_capacity(n + 8);
    'frames: for f in 0..frames.len() / 64 {
        let nibbles = word(f, 0);
        for w in 1..16 {
            if diffs.len() >= n {
                break 'frames;
            }
            let nib = (nibbles >> (30 - 2 * w)) & 0b11;
            let v = word(f, w);
            if f == 0 && (w == 1 || w == 2) {
                continue; // integration constants
            }
            match (nib, steim2) {
                (0, _) => {}
                (1, _) => {
                    for k in 0..4 {
                        diffs.push(sign_extend(v >> (24 - 8 * k), 8));
                    }
                }
                (2, false) => {
                    diffs.push(sign_extend(v >> 16, 16));
                    diffs.push(sign_extend(v, 16));
                }
                (3, false) => diffs.push(v as i32),
                (2, true) => match v >> 30 {
                    1 => diffs.push(sign_extend(v, 30)),
                    2 => {
                        diffs.push(sign_extend(v >> 15, 15));
                        diffs.push(sign_extend(v, 15));
                    }
                    3 => {
                        for k in 0..3 {
                            diffs.push(sign_extend(v >> (20 - 10 * k), 10));
                        }
                    }
                    d => {
                        return Err(format!(
                            "{name} frame {f} word {w}: invalid sub-code {d} for nibble 2"
                        ))
                    }
                },
                (3, true) => match v >> 30 {
                    0 => {
                        for k in 0..5 {
                            diffs.push(sign_extend(v >> (24 - 6 * k), 6));
                        }
                    }
                    1 => {
                        for k in 0..6 {
                            diffs.push(sign_extend(v >> (25 - 5 * k), 5));
                        }
                    }
                    2 => {
                        for k in 0..7 {
                            diffs.push(sign_extend(v >> (24 - 4 * k), 4));
                        }
                    }
                    d => {
                        return Err(format!(
                            "{name} frame {f} word {w}: invalid sub-code {d} for nibble 3"
                        ))
                    }
                },
                _ => unreachable!("a 2-bit nibble is 0..=3"),
            }
        }
    }
    if diffs.len() < n {
        return Err(format!(
            "{name} data ends after {} of {n} samples",
            diffs.len()
        ));
    }
    let mut out = Vec::with_capacity(n);
    let mut x = x0;
    out.push(x);
    for d in &diffs[1..n] {
        x = x.wrapping_add(*d);
        out.push(x);
    }
    if x != xn {
        return Err(format!(
            "{name} integration constants do not match: last decoded sample {x} differs from the reverse constant Xn = {xn} (X0 = {x0})"
        ));
    }
    Ok(out)
}
