//! One SDS day file indexed record by record, within a memory bound and
//! with damage kept to the records it hits (issue 33 item 4).
//!
//! [`scan`] reads the file from disk in chunks of [`CHUNK`] bytes (never
//! the whole file: a 4 GiB day file costs the chunk, not 4 GiB) and
//! indexes its data records (headers checked, no sample decoded).  A
//! damaged stretch — a header that does not parse, a record of another
//! stream, a sample count its data section cannot hold, a start outside
//! the file's day, a record length or sampling rate that disagrees with
//! the records around it, zeros where records should be, a truncated or
//! incomplete last record — is
//! skipped and kept as a [`Damage`]: byte offset, length, the reason, and
//! the time span without samples it leaves (from the end of the last good
//! record before it to the start of the next good one after it).  Reading
//! resynchronises on the next plausible header: records are fixed-length
//! but a truncated record shifts every later one, so candidates are looked
//! for at every byte whose quality indicator (`D`, `R`, `Q`, `M` at
//! offset 6) fits, and runs of zero bytes (a zeroed block, a sparse file)
//! are passed over eight bytes at a time.
//!
//! The time cost is one pass over the file's bytes; the memory is the
//! chunk plus the index, at most [`MAX_DAY_RECORDS`] records (32 bytes
//! each) and [`MAX_DAMAGED_STRETCHES`] stretches, a file beyond either is
//! an input error (its windows are skipped with that reason).

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

use super::mseed::{self, RecordSpan, Scanned};
use crate::error::{Error, Location, Result};
use crate::vocab::SourceRef;

/// Bytes read from disk at once (the scan's only buffer).
pub const CHUNK: usize = 4 << 20;
/// Longest record MiniSEED 2 allows (blockette 1000 exponent ≤ 20).
const MAX_RECORD_LEN: usize = 1 << 20;
/// Data records indexed per day file (32 MiB of index): a 1000 Hz stream
/// in 512-byte INT32 records (112 samples each) needs 771 429 a day.
pub const MAX_DAY_RECORDS: usize = 1 << 20;
/// Damaged stretches per day file (each separated from the next by a good
/// record); beyond it the file is refused rather than noted stretch by stretch.
pub const MAX_DAMAGED_STRETCHES: usize = 4096;
/// How far outside its day a record of a day file may lie (archivers file
/// a record spanning midnight under either day).
const DAY_MARGIN_NS: i64 = 3_600_000_000_000;

/// A stretch of a day file skipped as damaged.
#[derive(Debug, Clone, PartialEq)]
pub struct Damage {
    /// Byte offset of the stretch in the file, and its length.
    pub offset: u64,
    pub bytes: u64,
    /// Why its first record could not be read.
    pub why: String,
    /// The time without samples it leaves: the end of the last good record
    /// before it (the day's start if none) to the start of the next good
    /// one (the day's end if none); for a record whose header was read but
    /// whose samples could not be decoded, the record's own span.
    pub start_ns: i64,
    pub end_ns: i64,
}

/// The index of a day file: its good data records in file order and its
/// damaged stretches.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DayScan {
    pub records: Vec<RecordSpan>,
    pub damage: Vec<Damage>,
}

/// A file read through one buffer of at least [`CHUNK`] bytes.
struct Chunked {
    file: File,
    len: u64,
    buf: Vec<u8>,
    /// File offset of `buf[0]`.
    at: u64,
}

impl Chunked {
    /// Up to `n` bytes from `from` (fewer at the end of the file).
    fn bytes(&mut self, from: u64, n: usize) -> std::io::Result<&[u8]> {
        if from >= self.len {
            return Ok(&[]);
        }
        let end = from.saturating_add(n as u64).min(self.len);
        if from < self.at || end > self.at + self.buf.len() as u64 {
            let want = (self.len - from).min(CHUNK.max(n) as u64) as usize;
            self.buf.resize(want, 0);
            self.file.seek(SeekFrom::Start(from))?;
            // A file that shrank under us fails here: an I/O error for the day.
            self.file.read_exact(&mut self.buf)?;
            self.at = from;
        }
        let s = (from - self.at) as usize;
        Ok(&self.buf[s..s + (end - from) as usize])
    }

    /// The first offset ≥ `from` that may start a record: its byte 6 (the
    /// quality indicator) is `D`, `R`, `Q` or `M`.  Zero bytes are passed
    /// over a word at a time.
    fn next_candidate(&mut self, from: u64) -> std::io::Result<Option<u64>> {
        let mut q = from + 6;
        while q < self.len {
            let block = self.bytes(q, 1 << 16)?;
            let n = block.len();
            let words = block.chunks_exact(8);
            let tail = words.remainder();
            let zero = words.fold(0u64, |a, w| {
                a | u64::from_ne_bytes(w.try_into().unwrap_or([1; 8]))
            }) == 0
                && tail.iter().all(|&b| b == 0);
            if zero {
                // A hole of a sparse file reads as zeros at the cost of
                // zero-filling the page cache (15 s for 3 GiB here): jump
                // to the next byte the file system holds instead.
                q = match next_data(&self.file, q) {
                    Some(d) => d.max(q + n as u64),
                    None => q + n as u64,
                };
                continue;
            }
            if let Some(i) = block
                .iter()
                .position(|b| matches!(b, b'D' | b'R' | b'Q' | b'M'))
            {
                return Ok(Some(q + i as u64 - 6));
            }
            q += n as u64;
        }
        Ok(None)
    }
}

/// The first offset ≥ `from` that is not in a hole of the file (its length
/// when only holes follow); `None` when the file system cannot say.
#[cfg(target_os = "linux")]
fn next_data(file: &File, from: u64) -> Option<u64> {
    use std::os::fd::AsRawFd;
    let from = libc::off_t::try_from(from).ok()?;
    // SAFETY: lseek reads no memory of ours; it moves the offset of a
    // descriptor this scan owns, and every read seeks before reading.
    let at = unsafe { libc::lseek(file.as_raw_fd(), from, libc::SEEK_DATA) };
    if at >= 0 {
        return u64::try_from(at).ok();
    }
    match std::io::Error::last_os_error().raw_os_error() {
        // ENXIO: no data after `from`.
        Some(libc::ENXIO) => file.metadata().ok().map(|m| m.len()),
        _ => None,
    }
}

#[cfg(not(target_os = "linux"))]
fn next_data(_file: &File, _from: u64) -> Option<u64> {
    None
}

/// What one offset of the file holds, for the scan.
enum Found {
    Good(RecordSpan),
    /// Bytes to pass over without samples and without damage (log records).
    Quiet(u64),
    /// A record whose header was read (so its length is known) but that
    /// cannot be used, and why.
    Bad(u64, String),
    /// No record starts here.
    NotRecord(String),
    Padding,
}

/// The message of an input error without its location (the note gives
/// the file and offset), with the byte when it is not the record's own.
fn reason(e: Error, record_at: u64) -> String {
    match e {
        Error::Input { location, message } => match location.byte_offset {
            Some(b) if b != record_at => format!("{message} (byte {b})"),
            _ => message,
        },
        other => other.to_string(),
    }
}

/// Indexes the day file `path` of stream `id` for the day `[day.0, day.1)`
/// (module doc).  A file that does not exist is an empty index; one that is
/// not a regular file, cannot be read, or exceeds the limits is an error
/// naming it.
pub fn scan(path: &Path, id: &str, day: (i64, i64)) -> Result<DayScan> {
    let io = |e| Error::io(path, e);
    // The one path policy (`input_file`): regular files only, checked
    // before opening (a FIFO would block the open, a device never end),
    // opened without blocking; a link is followed to what it names (a
    // dangling one is an error, a day file that is not there an empty day).
    if let Err(e) = std::fs::symlink_metadata(path) {
        if e.kind() == std::io::ErrorKind::NotFound {
            return Ok(DayScan::default());
        }
    }
    let file = crate::input_file::open(path)?;
    let len = file.metadata().map_err(io)?.len();
    let src = SourceRef {
        file: path.display().to_string(),
        member: None,
        column: None,
        format: "mseed".into(),
    };
    let mut r = Chunked {
        file,
        len,
        buf: Vec::new(),
        at: 0,
    };
    let mut out = DayScan::default();
    // The open damaged stretch: its first byte and reason.
    let mut open: Option<(u64, String)> = None;
    // Index into `out.records` of the good record after each stretch.
    let mut next_good: Vec<usize> = Vec::new();
    // Length and sampling rate of the last good record.
    let mut last_len: Option<u64> = None;
    let mut last_rate: Option<f64> = None;
    let mut prev_good: Option<(u64, u64)> = None;
    let mut at = 0u64;
    let too_many = |what: String| Error::input(Location::file(src.file.clone()), what);
    let mut close = |open: &mut Option<(u64, String)>,
                     end: u64,
                     records: usize,
                     damage: &mut Vec<Damage>|
     -> Result<()> {
        if let Some((from, why)) = open.take() {
            if damage.len() >= MAX_DAMAGED_STRETCHES {
                return Err(too_many(format!(
                    "more than {MAX_DAMAGED_STRETCHES} damaged stretches in one day file: too damaged to read record by record"
                )));
            }
            damage.push(Damage {
                offset: from,
                bytes: end - from,
                why,
                start_ns: 0,
                end_ns: 0,
            });
            next_good.push(records);
        }
        Ok(())
    };
    while at < len {
        let found = {
            let rest = r.bytes(at, MAX_RECORD_LEN).map_err(io)?;
            classify(rest, at, &src, id, day)
        };
        let found = match found {
            // The record length disagrees with the file's records and one
            // of those starts where this one should have ended (a damaged
            // blockette 1000 would otherwise swallow the records after it).
            Found::Good(span) if last_len.is_some_and(|l| span.len as u64 > l) => {
                let l = last_len.unwrap_or(0);
                let next = r.bytes(at + l, MAX_RECORD_LEN).map_err(io)?;
                if matches!(
                    classify(next, at + l, &src, id, day),
                    Found::Good(_) | Found::Bad(..) | Found::Quiet(_)
                ) {
                    Found::Bad(
                        l,
                        format!(
                            "blockette 1000 says {} bytes, the file's records have {l} and the next starts at byte {}",
                            span.len,
                            at + l
                        ),
                    )
                } else {
                    Found::Good(span)
                }
            }
            // The sampling rate disagrees with the record before and the
            // record after agrees with that one: a damaged rate field (the
            // join would refuse the window over it), not a change of rate.
            Found::Good(span)
                if last_rate.is_some_and(|r0| ((span.rate_hz - r0) / r0).abs() > 1e-6) =>
            {
                let r0 = last_rate.unwrap_or(0.0);
                let after = at + span.len as u64;
                let next = r.bytes(after, MAX_RECORD_LEN).map_err(io)?;
                match classify(next, after, &src, id, day) {
                    Found::Good(n) if ((n.rate_hz - r0) / r0).abs() <= 1e-6 => Found::Bad(
                        span.len as u64,
                        format!(
                            "sampling rate {} Hz between records of {r0} Hz (rate field damaged?)",
                            span.rate_hz
                        ),
                    ),
                    _ => Found::Good(span),
                }
            }
            f => f,
        };
        // The good record just before `at`, if the last step read one:
        // (its offset, its length).
        let mut prev_now = None;
        match found {
            Found::Good(span) => {
                prev_now = Some((at, span.len as u64));
                close(&mut open, at, out.records.len(), &mut out.damage)?;
                if out.records.len() >= MAX_DAY_RECORDS {
                    return Err(too_many(format!(
                        "more than {MAX_DAY_RECORDS} records in one day file (the index limit)"
                    )));
                }
                at += span.len as u64;
                last_len = Some(span.len as u64);
                last_rate = Some(span.rate_hz);
                out.records.push(span);
            }
            Found::Quiet(n) => {
                close(&mut open, at, out.records.len(), &mut out.damage)?;
                at += n;
            }
            Found::Bad(n, why) => {
                open.get_or_insert((at, why));
                at += n;
            }
            Found::Padding if open.is_none() && len - at < last_len.unwrap_or(0) => {
                // Zeros or spaces after the last record, shorter than a
                // record: padding, as archivers leave it.
                break;
            }
            Found::Padding => {
                open.get_or_insert((
                    at,
                    "zero bytes where a record should start (a zeroed block or an unwritten region)"
                        .into(),
                ));
                at = resync(&mut r, at, &src).map_err(io)?;
            }
            Found::NotRecord(why) => {
                // No record where the previous one said it ends: if a
                // record starts inside that one, it was truncated (and the
                // bytes it took of the next are no samples of its own).
                let inside = match prev_good {
                    Some((from, _)) => {
                        Some(resync(&mut r, from, &src).map_err(io)?).filter(|&p| p < at)
                    }
                    None => None,
                };
                match (inside, prev_good) {
                    (Some(p), Some((from, l))) => {
                        out.records.pop();
                        open = Some((
                            from,
                            format!(
                                "truncated record: blockette 1000 says {l} bytes, the next record starts {} bytes in, at byte {p}",
                                p - from
                            ),
                        ));
                        at = p;
                    }
                    _ => {
                        open.get_or_insert((at, why));
                        at = resync(&mut r, at, &src).map_err(io)?;
                    }
                }
            }
        }
        prev_good = prev_now;
    }
    if let Some((from, why)) = &mut open {
        if len - *from < last_len.unwrap_or(MAX_RECORD_LEN as u64) {
            why.push_str(
                "; the file ends inside this record (the last record of a live archive, still being written?): skipped, a later run reads it",
            );
        }
    }
    close(&mut open, len, out.records.len(), &mut out.damage)?;
    for (d, &k) in out.damage.iter_mut().zip(&next_good) {
        d.start_ns = match k {
            0 => day.0,
            k => out.records[k - 1].end_ns(),
        };
        d.end_ns = out.records.get(k).map_or(day.1, |s| s.start_ns);
        if d.end_ns < d.start_ns {
            // Records out of time order around the damage: the span
            // between them still holds the missing samples.
            std::mem::swap(&mut d.start_ns, &mut d.end_ns);
        }
    }
    Ok(out)
}

/// The offset where reading goes on after a record that could not be read
/// at `at`: the next plausible record header, or the end of the file.
fn resync(r: &mut Chunked, at: u64, src: &SourceRef) -> std::io::Result<u64> {
    let mut from = at + 1;
    while let Some(p) = r.next_candidate(from)? {
        let rest = r.bytes(p, MAX_RECORD_LEN)?;
        if mseed::looks_like(rest) && mseed::scan_header(rest, p, src).is_ok() {
            return Ok(p);
        }
        from = p + 1;
    }
    Ok(r.len)
}

/// What the bytes `rest` at offset `at` of the day file of `id` hold.
fn classify(rest: &[u8], at: u64, src: &SourceRef, id: &str, day: (i64, i64)) -> Found {
    match mseed::scan_header(rest, at, src) {
        Err(_) if rest.len() >= 48 && rest[..48].iter().all(|&b| b == 0) => Found::NotRecord(
            "zero bytes where a record should start (a zeroed block or an unwritten region)".into(),
        ),
        Err(e) => Found::NotRecord(reason(e, at)),
        Ok(Scanned::Padding) => Found::Padding,
        Ok(Scanned::NoSamples { len }) => Found::Quiet(len as u64),
        Ok(Scanned::Data {
            id: found,
            span,
            room,
        }) => {
            let len = span.len as u64;
            if found != id {
                Found::Bad(
                    len,
                    format!("a record of stream {found} in the day file of {id}"),
                )
            } else if (span.samples as usize) > room {
                Found::Bad(
                    len,
                    format!(
                        "the header announces {} samples, the data section holds at most {room}",
                        span.samples
                    ),
                )
            } else if span.start_ns >= day.1 + DAY_MARGIN_NS
                || span.end_ns() <= day.0 - DAY_MARGIN_NS
            {
                Found::Bad(
                    len,
                    format!(
                        "the record starts at {}, outside the file's day (time fields damaged?)",
                        crate::vocab::format_epoch_ns(span.start_ns)
                    ),
                )
            } else {
                Found::Good(span)
            }
        }
    }
}
