//! CSV / TSV reader, including the Xsens (Movella) DOT export.
//!
//! Field splitting (quotes, `""` escapes, a delimiter inside a quoted field
//! such as `"a, b"`) is done by the `csv` crate.  What is ours is finding
//! where the table starts after a free-form preamble, guessing the delimiter,
//! and turning a time column into a sampling rate and a start time — none of
//! which a CSV crate does.
//!
//! Layout understood:
//! - an optional `sep=X` first line (Excel hint) fixes the delimiter; otherwise
//!   comma, tab, semicolon and whitespace are tried and the one giving the
//!   widest consistent table wins.  Whitespace-separated files (runs of spaces
//!   or tabs used for alignment) are split by hand: the `csv` crate takes one
//!   delimiter byte and would turn every extra space into an empty field;
//! - preamble lines before the header row (`Key:,value` or `Key: value`):
//!   `DeviceTag` → station, `StartTime` (`2025-03-06_12:26:07_000 PST`, or ISO
//!   8601 UTC) → start time, `SampleRate`/`Sampling rate` → rate;
//! - the table: the first row, with at least 3 rows after it of the same field
//!   count (or up to the end of the file), in which more than half of the
//!   fields, or the first field, are numbers or ISO 8601 date-times, and whose
//!   first field does not end in `:` (a `Key:` preamble line).  Other fields may
//!   be text (a station name, a quoted comment): text columns are never read
//!   unless named, so they are not an error;
//! - a header row (optional; without it columns are named by their 0-based index);
//! - a time column (`ReadOptions.time_column`, else `time`, `t`, `timestamp`,
//!   `seconds`, `SampleTimeFine`…, else the first column holding ISO 8601
//!   date-times).  Its cells are either
//!   - numbers, in seconds unless the header says `[ms]`, `(us)`, `time_ms`…;
//!     `SampleTimeFine` is the Xsens microsecond counter, which wraps at 2³².
//!     A first value of at least 10⁹ seconds (2001-09-09) is Unix epoch time
//!     and gives the start time.  Without a stated unit the magnitude of the
//!     first value tells the epoch unit: below 10¹¹ seconds, below 10¹⁴
//!     milliseconds, below 10¹⁷ microseconds, else nanoseconds (each covers
//!     the years 1973 to 5138);
//!   - ISO 8601 date-times, `2024-03-01T12:00:00.005Z`, with `T` or a space,
//!     with a `Z`, an offset (`+01:00`, `-0500`) or no zone (taken as UTC,
//!     noted in `inferred`); they give the start time.
//!
//!   Without a time column the rate comes from `ReadOptions.sampling_rate_hz` or the preamble;
//! - columns from `ReadOptions.columns` (names or 0-based indices), else every
//!   acceleration-like column (`Acc_*`, `acc*`, `a_*`, `ax`…) whose first cell
//!   is a number.
//!
//! The sampling interval is the median time step.  When it is within the time
//! resolution of a whole rate in Hz (Xsens: 8333 µs = 1/120 s truncated to
//! whole µs) the whole rate is used and noted in `inferred`.  Steps further
//! than max(1 % of the interval, 1.5 × resolution) from it make the column
//! uneven: the samples are resampled linearly onto a uniform grid and flagged
//! `QaFlag::Resampled` (steps longer than 1.5 intervals are also flagged `QaFlag::Gap`).
//! The grid is bounded before it is allocated: at most
//! [`MAX_RESAMPLE_GROWTH`] times the rows of the file and at most
//! [`MAX_RESAMPLED_SAMPLES`] samples over all channels read; beyond that the
//! file is refused, naming the line where the largest time jump ends.
//!
//! Units come from the column header (`acc_x[m/s2]`, `Acc_X (g)`).  When the
//! header states none, m/s² is assumed, noted in `inferred`, and `"units"`
//! is listed in `missing` (a manifest `units` per column overrides both).

use chrono::{DateTime, NaiveDateTime};

use super::{FileContents, ReadOptions};
use crate::error::{Error, Result};
use crate::vocab::{
    epoch_ns_from_civil, parse_iso8601_ns, Channel, QaFlag, Record, SourceRef, Units,
};

/// Most samples, summed over the channels read, that resampling an uneven
/// time column may produce: 2²⁸ (2 GiB of f64).  Checked before allocating.
pub const MAX_RESAMPLED_SAMPLES: usize = 1 << 28;

/// Most samples per channel that resampling may produce per row of the file
/// (shared by every reader): a longer grid would be mostly interpolation
/// across gaps (a time column jumping to 10⁶ s after 200 rows at 100 Hz asks
/// for 10⁸ samples), which is a broken time column rather than a record.
pub use super::resample::MAX_RESAMPLE_GROWTH;
use super::resample::{grid_len, resample_linear};

/// Unix epoch time starts here: 10⁹ s is 2001-09-09, far beyond any
/// elapsed-time column of a sensor export.
const EPOCH_MIN_S: f64 = 1e9;

/// How fields are separated.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Delim {
    Byte(u8),
    Whitespace,
}

/// One row of the file: its 0-based line index in the text, its byte
/// offset (rows split by a delimiter byte) and its fields.
struct Row {
    line: usize,
    byte: Option<usize>,
    fields: csv::StringRecord,
}

/// The rows of `text` (which starts at line `first_line`), blank lines skipped.
fn rows<'a>(
    text: &'a str,
    first_line: usize,
    delim: Delim,
) -> Box<dyn Iterator<Item = std::result::Result<Row, csv::Error>> + 'a> {
    match delim {
        Delim::Byte(b) => {
            let rdr = csv::ReaderBuilder::new()
                .has_headers(false)
                // Preamble lines have their own field counts; ragged data rows
                // are reported by us with the expected count.
                .flexible(true)
                .trim(csv::Trim::All)
                .delimiter(b)
                .from_reader(text.as_bytes());
            // Where a record starts, and its line: the csv crate's position of
            // a record is taken before the line ends that precede it (the `\n`
            // of a `\r\n`, empty lines), so its line number lagged by one in
            // CRLF files and after empty lines.  Counted here from the bytes.
            let bytes = text.as_bytes();
            let mut counted = (0usize, 0usize); // (byte, line ends before it)
            Box::new(rdr.into_records().filter_map(move |r| match r {
                Ok(fields) => {
                    let raw = fields
                        .position()
                        .map_or(0, |p| p.byte() as usize)
                        .min(bytes.len());
                    let start = raw
                        + bytes[raw..]
                            .iter()
                            .take_while(|&&b| b == b'\n' || b == b'\r')
                            .count();
                    let (from, before) = counted;
                    let line = before
                        + bytes[from.min(start)..start]
                            .iter()
                            .filter(|&&b| b == b'\n')
                            .count();
                    counted = (start, line);
                    // The csv crate skips empty lines but not lines of spaces.
                    if fields.len() == 1 && fields[0].is_empty() {
                        return None;
                    }
                    Some(Ok(Row {
                        line: first_line + line,
                        byte: Some(start),
                        fields,
                    }))
                }
                Err(e) => Some(Err(e)),
            }))
        }
        Delim::Whitespace => Box::new(text.split('\n').enumerate().filter_map(move |(i, l)| {
            let fields: csv::StringRecord =
                l.split_whitespace().map(|s| s.trim_matches('"')).collect();
            (!fields.is_empty()).then(|| {
                Ok(Row {
                    line: first_line + i,
                    byte: None,
                    fields,
                })
            })
        })),
    }
}

fn is_number(s: &str) -> bool {
    !s.is_empty() && s.parse::<f64>().is_ok()
}

/// Cheap shape test for `YYYY-MM-DD[T ]HH:…` (the full parse comes later).
fn looks_like_datetime(s: &str) -> bool {
    let b = s.as_bytes();
    let digits = |r: std::ops::Range<usize>| r.into_iter().all(|i| b[i].is_ascii_digit());
    b.len() >= 16
        && digits(0..4)
        && b[4] == b'-'
        && digits(5..7)
        && b[7] == b'-'
        && digits(8..10)
        && matches!(b[10], b'T' | b't' | b' ')
        && digits(11..13)
        && b[13] == b':'
}

/// A number or a date-time: what a data row holds.
fn is_value(s: &str) -> bool {
    is_number(s) || looks_like_datetime(s)
}

fn count_values(fields: &csv::StringRecord) -> usize {
    fields.iter().filter(|f| is_value(f)).count()
}

/// Could be a row of the table (see the module doc).
// Public only for the tests in tests/it/readers_csv.rs (the library's tests
// live there, so the library is compiled once); not part of the API: it
// takes the `csv` crate's record type.
#[doc(hidden)]
pub fn data_like(fields: &csv::StringRecord) -> bool {
    let first = fields.get(0).unwrap_or("");
    if first.ends_with(':') {
        return false;
    }
    let v = count_values(fields);
    v >= 1 && (2 * v > fields.len() || is_value(first))
}

/// How an ISO 8601 cell stated its zone.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Zone {
    Z,
    Offset(i32),
    Naive,
}

impl Zone {
    fn describe(self) -> String {
        match self {
            Zone::Z => "Z = UTC".into(),
            Zone::Offset(s) => format!(
                "offset UTC{}{:02}:{:02} converted to UTC",
                if s < 0 { '-' } else { '+' },
                s.abs() / 3600,
                s.abs() % 3600 / 60
            ),
            Zone::Naive => "no zone stated: taken as UTC".into(),
        }
    }
}

/// Parses an ISO 8601 date-time cell into ns since the epoch (UTC).
pub fn parse_datetime_cell(s: &str) -> Option<(i64, Zone)> {
    if !looks_like_datetime(s) {
        return None;
    }
    if let Ok(dt) = DateTime::parse_from_rfc3339(s) {
        let zone = if s.ends_with(['Z', 'z']) {
            Zone::Z
        } else {
            Zone::Offset(dt.offset().local_minus_utc())
        };
        return Some((dt.timestamp_nanos_opt()?, zone));
    }
    // chrono's formats want the `T`; RFC 3339 above already took the space.
    let norm = format!("{}T{}", &s[..10], &s[11..]);
    if let Ok(dt) = DateTime::parse_from_str(&norm, "%Y-%m-%dT%H:%M:%S%.f%z") {
        return Some((
            dt.timestamp_nanos_opt()?,
            Zone::Offset(dt.offset().local_minus_utc()),
        ));
    }
    let naive = NaiveDateTime::parse_from_str(&norm, "%Y-%m-%dT%H:%M:%S%.f").ok()?;
    Some((naive.and_utc().timestamp_nanos_opt()?, Zone::Naive))
}

/// Digits after the decimal point of a number or of the seconds of a date-time.
fn fraction_digits(s: &str) -> usize {
    s.split_once('.')
        .map(|(_, d)| d.bytes().take_while(u8::is_ascii_digit).count())
        .unwrap_or(0)
}

/// A plain decimal `[-]123.456` times `ns_per_unit`, exactly (f64 cannot hold
/// epoch nanoseconds: 1.7e18 is past 2⁵³).  `None` for exponent forms.
pub fn decimal_to_ns(s: &str, ns_per_unit: i128) -> Option<i64> {
    let (neg, digits) = match s.strip_prefix('-') {
        Some(d) => (true, d),
        None => (false, s.strip_prefix('+').unwrap_or(s)),
    };
    let (int, frac) = digits.split_once('.').unwrap_or((digits, ""));
    if int.is_empty() && frac.is_empty()
        || !int.bytes().chain(frac.bytes()).all(|b| b.is_ascii_digit())
        || int.len() > 20
    {
        return None;
    }
    let frac = &frac[..frac.len().min(18)];
    let int_v: i128 = if int.is_empty() { 0 } else { int.parse().ok()? };
    let frac_v: i128 = if frac.is_empty() {
        0
    } else {
        frac.parse().ok()?
    };
    let scale = 10i128.pow(frac.len() as u32);
    let ns = int_v.checked_mul(ns_per_unit)? + (frac_v * ns_per_unit + scale / 2) / scale;
    i64::try_from(if neg { -ns } else { ns }).ok()
}

/// The most fields any row of `text` can have when split by `delim` — a
/// bound, exact when no field is quoted; `None` for text with quotes (a
/// quoted field may hold delimiters and line ends).
fn most_fields(text: &str, delim: Delim) -> Option<usize> {
    use rayon::prelude::*;
    let per_line = |l: &[u8]| match delim {
        Delim::Byte(d) => l.iter().filter(|&&b| b == d).count() + 1,
        // A line without whitespace or non-ASCII bytes (where Unicode
        // whitespace could hide) is one field, or none when empty: only
        // other lines are split (a comma file has none of them).
        Delim::Whitespace => {
            let plain = |b: &u8| b.is_ascii() && !(b.is_ascii_whitespace() || *b == 0x0b);
            // A CRLF line's final CR splits nothing.
            let l = l.strip_suffix(b"\r").unwrap_or(l);
            if l.iter().all(plain) {
                usize::from(!l.is_empty())
            } else {
                std::str::from_utf8(l).map_or(0, |s| s.split_whitespace().count())
            }
        }
    };
    // In parallel over chunks of whole lines (a 582 MB file is scanned once
    // per candidate delimiter); chunks end after a newline, so their lines
    // are the file's.
    //
    // Most candidates split nothing (a comma file has no tab, semicolon or
    // space): a chunk without the delimiter has one field per line, and a
    // chunk of plain bytes and newlines one per non-empty line — both found
    // by a scan of the bytes instead of the lines one by one (these scans
    // were 7 % of a 5 MB comma file's `modal`).
    let whole_chunk = |c: &[u8]| match delim {
        Delim::Byte(d) => (!c.contains(&d)).then_some(1),
        Delim::Whitespace => {
            // A fold without early exit, so that the byte tests vectorise.
            let odd =
                |b: u8| !(b == b'\n' || (b.is_ascii() && !(b.is_ascii_whitespace() || b == 0x0b)));
            (!c.iter().fold(false, |any, &b| any | odd(b)))
                .then(|| usize::from(c.iter().any(|&b| b != b'\n')))
        }
    };
    let per_chunk: Vec<Option<usize>> = line_chunks(text.as_bytes())
        .par_iter()
        .map(|c| match delim {
            Delim::Byte(_) if c.contains(&b'"') => None,
            _ => Some(
                whole_chunk(c)
                    .unwrap_or_else(|| c.split(|&b| b == b'\n').map(per_line).max().unwrap_or(0)),
            ),
        })
        .collect();
    per_chunk
        .into_iter()
        .try_fold(0, |m, c| c.map(|c| m.max(c)))
}

/// [`most_fields`] by delimiter byte (`None`: runs of whitespace), for
/// checking it against a line-by-line count (tests/it/readers_csv.rs).
pub fn most_fields_by(text: &str, delimiter: Option<u8>) -> Option<usize> {
    most_fields(text, delimiter.map_or(Delim::Whitespace, Delim::Byte))
}

/// `data` cut into chunks of whole lines (each but the last ends with a
/// newline), several per thread, for parsing or scanning in parallel.
fn line_chunks(data: &[u8]) -> Vec<&[u8]> {
    let pieces = 8 * rayon::current_num_threads().max(1);
    let mut bounds = vec![0usize];
    for k in 1..pieces {
        let at = (data.len() * k / pieces).max(*bounds.last().unwrap_or(&0));
        let end = data[at..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(data.len(), |p| at + p + 1);
        bounds.push(end);
    }
    bounds.push(data.len());
    bounds.dedup();
    bounds.windows(2).map(|w| &data[w[0]..w[1]]).collect()
}

/// Where the table is: header row (index into the sniffed rows), first data
/// row (index in the row sequence), field count.
#[derive(Debug, Clone, Copy)]
struct Layout {
    delim: Delim,
    header: Option<usize>,
    data_start: usize,
    fields: usize,
}

/// The table of `delim`, and the rows up to the end of its first 4 data rows
/// (the preamble, header and the first data row are read from them).
fn find_layout(
    text: &str,
    first_line: usize,
    delim: Delim,
) -> std::result::Result<Option<(Layout, Vec<Row>)>, csv::Error> {
    let mut it = rows(text, first_line, delim);
    let mut seen: Vec<Row> = Vec::new();
    let mut done = false;
    let mut k = 0;
    loop {
        // Row k qualifies when it and the (up to) 3 rows after it are data-like
        // with the same field count: read ahead until those rows are in.
        while !done && seen.len() < k + 4 {
            match it.next() {
                Some(r) => seen.push(r?),
                None => done = true,
            }
        }
        if k >= seen.len() {
            return Ok(None);
        }
        let f = &seen[k].fields;
        let n = f.len();
        if data_like(f)
            && seen[k + 1..]
                .iter()
                .all(|r| r.fields.len() == n && data_like(&r.fields))
        {
            // Walk back over data rows with a bad cell (still data-like) so they are parsed and reported.
            let mut start = k;
            while start > 0 {
                let g = &seen[start - 1].fields;
                if g.len() != n || !data_like(g) {
                    break;
                }
                start -= 1;
            }
            let header = start.checked_sub(1).filter(|&h| {
                let g = &seen[h].fields;
                g.len() == n && 2 * count_values(g) < n.max(1)
            });
            let layout = Layout {
                delim,
                header,
                data_start: start,
                fields: n,
            };
            return Ok(Some((layout, seen)));
        }
        k += 1;
    }
}

/// Column name without a trailing unit in brackets or parentheses, lower case.
fn base_name(name: &str) -> String {
    let cut = name.find(['[', '(']).unwrap_or(name.len());
    name[..cut].trim().to_ascii_lowercase()
}

/// Unit text in brackets or parentheses of a column name (`acc_x[m/s2]` → `m/s2`).
fn unit_text(name: &str) -> Option<String> {
    let open = name.find(['[', '('])?;
    let close = name[open + 1..].find([']', ')'])? + open + 1;
    Some(name[open + 1..close].trim().to_string())
}

fn is_acceleration_like(name: &str) -> bool {
    let b = base_name(name);
    b.contains("acc") || b.starts_with("a_") || matches!(b.as_str(), "ax" | "ay" | "az" | "a")
}

/// Time zone abbreviations seen in sensor exports → offset from UTC in hours.
fn zone_offset_hours(zone: &str) -> Option<i64> {
    Some(match zone.to_ascii_uppercase().as_str() {
        "UTC" | "GMT" | "Z" => 0,
        "PST" => -8,
        "PDT" | "MST" => -7,
        "MDT" | "CST" => -6,
        "CDT" | "EST" => -5,
        "EDT" => -4,
        "CET" => 1,
        "CEST" | "EET" => 2,
        "JST" => 9,
        "NZST" => 12,
        "NZDT" => 13,
        _ => return None,
    })
}

/// Parses `2025-03-06_12:26:07_000 PST` (Xsens) or ISO 8601 UTC.
/// Returns (ns since epoch UTC, description of the zone used).
pub fn parse_start_time(s: &str) -> Option<(i64, String)> {
    let s = s.trim();
    let (stamp, zone) = match s.rsplit_once(' ') {
        Some((a, z)) if z.chars().all(|c| c.is_ascii_alphabetic()) => (a.trim(), Some(z)),
        _ => (s, None),
    };
    let offset_h = match zone {
        Some(z) => zone_offset_hours(z)?,
        None => 0,
    };
    let parts: Vec<&str> = stamp.split('_').collect();
    let local = if parts.len() >= 2 {
        let mut d = parts[0].split('-');
        let y: i64 = d.next()?.parse().ok()?;
        let m: u32 = d.next()?.parse().ok()?;
        let day: u32 = d.next()?.parse().ok()?;
        let mut t = parts[1].split(':');
        let hh: u32 = t.next()?.parse().ok()?;
        let mm: u32 = t.next()?.parse().ok()?;
        let ss: f64 = t.next()?.parse().ok()?;
        let ms: f64 = parts.get(2).map(|x| x.parse().ok()).unwrap_or(Some(0.0))?;
        let ms_ns = (ms * 1e6).round();
        if !(0.0..1e12).contains(&ms_ns) {
            return None;
        }
        epoch_ns_from_civil(y, m, day, hh, mm, ss)?.checked_add(ms_ns as i64)?
    } else {
        parse_iso8601_ns(stamp)?
    };
    let desc = match zone {
        Some(z) => format!("{z} = UTC{offset_h:+}"),
        None => "UTC".into(),
    };
    Some((local.checked_sub(offset_h * 3_600_000_000_000)?, desc))
}

/// How the time column counts.
#[derive(Debug, Clone, Copy, PartialEq)]
enum TimeKind {
    /// Value × factor = seconds; `stated` when the header gave the unit.
    Seconds { factor: f64, stated: bool },
    /// Xsens SampleTimeFine: µs, unsigned 32-bit counter that wraps.
    XsensFine,
}

fn time_kind(name: &str) -> Option<TimeKind> {
    let b = base_name(name);
    if b == "sampletimefine" {
        return Some(TimeKind::XsensFine);
    }
    let from_unit = |u: &str| -> Option<f64> {
        Some(match u.trim().to_ascii_lowercase().as_str() {
            "s" | "sec" | "seconds" => 1.0,
            "ms" => 1e-3,
            "us" | "µs" | "μs" => 1e-6,
            "ns" => 1e-9,
            "min" => 60.0,
            _ => return None,
        })
    };
    let named = matches!(
        b.as_str(),
        "time" | "t" | "times" | "timestamp" | "seconds" | "sec" | "time_s" | "elapsed"
    );
    let suffixed = ["time_ms", "time_us", "time_ns", "t_ms", "t_us", "t_s"].contains(&b.as_str());
    if !named && !suffixed {
        return None;
    }
    if let Some(u) = unit_text(name) {
        return from_unit(&u).map(|factor| TimeKind::Seconds {
            factor,
            stated: true,
        });
    }
    let factor = match b.rsplit('_').next() {
        Some("ms") if suffixed => 1e-3,
        Some("us") if suffixed => 1e-6,
        Some("ns") if suffixed => 1e-9,
        _ => 1.0,
    };
    let stated = suffixed || matches!(b.as_str(), "seconds" | "sec" | "time_s");
    Some(TimeKind::Seconds { factor, stated })
}

/// Unit of a unitless epoch time column from the magnitude of its first value
/// (see the module doc): (seconds per unit, name).
// Public only for the tests in tests/it/readers_csv.rs (the library's tests
// live there, so the library is compiled once); not part of the API.
#[doc(hidden)]
pub fn epoch_unit(first: f64) -> (f64, &'static str) {
    let a = first.abs();
    if a < 1e11 {
        (1.0, "seconds")
    } else if a < 1e14 {
        (1e-3, "milliseconds")
    } else if a < 1e17 {
        (1e-6, "microseconds")
    } else {
        (1e-9, "nanoseconds")
    }
}

/// The time column as read: raw numbers, or date-times as epoch ns.
enum TimeCells {
    Numbers(Vec<f64>),
    DateTimes(Vec<i64>, Zone),
}

/// Reads the selected columns of a CSV/TSV file, one record per column.
pub fn read(bytes: &[u8], source: &SourceRef, opts: &ReadOptions) -> Result<FileContents> {
    let mut src = source.clone();
    src.format = "csv".into();
    // Valid UTF-8 (nearly every file) is checked by `from_utf8`, whose ASCII
    // fast path is several times quicker than the lossy conversion's scan.
    let text = match std::str::from_utf8(bytes) {
        Ok(text) => std::borrow::Cow::Borrowed(text),
        Err(_) => String::from_utf8_lossy(bytes),
    };
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let loc = |line: usize| super::location(&src).at_line(line + 1);
    let csv_err = |e: csv::Error| {
        let line = e.position().map_or(0, |p| p.line() as usize);
        Error::input(
            super::location(&src).at_line(line.max(1)),
            format!("CSV: {e}"),
        )
    };

    // Optional `sep=X` first line.
    let first_line_text = text.split('\n').next().unwrap_or("");
    let (body, first) = match first_line_text.trim().strip_prefix("sep=") {
        Some(_) => (text.get(first_line_text.len() + 1..).unwrap_or(""), 1usize),
        None => (text, 0usize),
    };
    let candidates = match first_line_text.trim().strip_prefix("sep=") {
        Some(rest) => vec![match rest {
            "\\t" | "\t" | "" => Delim::Byte(b'\t'),
            r if r.len() == 1 && r.is_ascii() => Delim::Byte(r.as_bytes()[0]),
            r => {
                return Err(Error::input(
                    loc(0),
                    format!("sep={r:?}: the delimiter must be one ASCII character"),
                ))
            }
        }],
        None => vec![
            Delim::Byte(b','),
            Delim::Byte(b'\t'),
            Delim::Byte(b';'),
            Delim::Whitespace,
        ],
    };
    let mut found: Option<(Layout, Vec<Row>)> = None;
    for d in candidates {
        // A delimiter can only win with a wider table than the best so far:
        // one that splits no line into more fields is not searched (without
        // this, a 582 MB comma file was read three more times to find that
        // tabs, semicolons and spaces make no table of it).
        if let Some((best, _)) = &found {
            if most_fields(body, d).is_some_and(|m| m <= best.fields) {
                continue;
            }
        }
        if let Some((l, r)) = find_layout(body, first, d).map_err(csv_err)? {
            if found
                .as_ref()
                .is_none_or(|(best, _)| l.fields > best.fields)
            {
                found = Some((l, r));
            }
        }
    }
    let (layout, sniffed) = found.ok_or_else(|| {
        Error::input(
            super::location(&src),
            "no table of numbers found in this CSV file",
        )
    })?;
    let names: Vec<String> = match layout.header {
        Some(h) => sniffed[h].fields.iter().map(str::to_string).collect(),
        None => (0..layout.fields).map(|i| i.to_string()).collect(),
    };
    let first_data = &sniffed[layout.data_start];
    let header_line = layout.header.map_or(first_data.line, |h| sniffed[h].line);

    // Preamble key/value rows: `Key:,value` (key and value in separate fields)
    // or `Key: value` (one field, or several when split on whitespace).
    let preamble_end = layout.header.unwrap_or(layout.data_start);
    let mut station: Option<String> = None;
    let mut start: Option<(i64, String, usize)> = None;
    let mut preamble_rate: Option<f64> = None;
    let mut is_xsens = false;
    for row in &sniffed[..preamble_end] {
        if row
            .fields
            .iter()
            .any(|f| f.contains("Xsens") || f.contains("Movella"))
        {
            is_xsens = true;
        }
        let Some((key, rest)) = row.fields.get(0).and_then(|f| f.split_once(':')) else {
            continue;
        };
        let key = key.trim().to_ascii_lowercase();
        let value = std::iter::once(rest.trim())
            .chain(row.fields.iter().skip(1))
            .filter(|s| !s.is_empty())
            .collect::<Vec<_>>()
            .join(" ");
        match key.as_str() {
            "devicetag" => {
                is_xsens = true;
                if !value.is_empty() {
                    station = Some(value.to_string());
                }
            }
            "starttime" | "start time" | "start_time" => match parse_start_time(&value) {
                Some((ns, zone)) => start = Some((ns, zone, row.line)),
                None => {
                    return Err(Error::input(
                        loc(row.line),
                        format!("StartTime {value:?} is not a date and time this reader knows"),
                    ))
                }
            },
            "samplerate" | "sample rate" | "sampling rate" | "sampling_rate" | "fs" => {
                let num = value.trim_end_matches("Hz").trim_end_matches("hz").trim();
                preamble_rate = num.parse::<f64>().ok().filter(|r| *r > 0.0);
            }
            _ => {}
        }
    }

    let resolve = |spec: &str| -> Option<usize> {
        let s = spec.trim();
        names
            .iter()
            .position(|n| n.eq_ignore_ascii_case(s))
            .or_else(|| {
                names
                    .iter()
                    .position(|n| base_name(n) == s.to_ascii_lowercase())
            })
            .or_else(|| s.parse::<usize>().ok().filter(|&i| i < names.len()))
    };
    let first_cell = |c: usize| first_data.fields.get(c).unwrap_or("");
    let default_kind = TimeKind::Seconds {
        factor: 1.0,
        stated: false,
    };
    let time_col: Option<(usize, TimeKind)> = match &opts.time_column {
        Some(t) => {
            let i = resolve(t).ok_or_else(|| {
                Error::input(
                    loc(header_line),
                    format!("time column {t:?} not found; columns are {names:?}"),
                )
            })?;
            Some((i, time_kind(&names[i]).unwrap_or(default_kind)))
        }
        None => names
            .iter()
            .enumerate()
            .find_map(|(i, n)| time_kind(n).map(|k| (i, k)))
            // A date-time column under another name (`Date/Time`, `UTC`…).
            .or_else(|| {
                (0..names.len())
                    .find(|&i| looks_like_datetime(first_cell(i)))
                    .map(|i| (i, default_kind))
            }),
    };
    let mut skipped_text: Vec<&str> = Vec::new();
    let selected: Vec<usize> = match &opts.columns {
        Some(cols) => cols
            .iter()
            .map(|c| {
                resolve(c).ok_or_else(|| {
                    Error::input(
                        loc(header_line),
                        format!("column {c:?} not found; columns are {names:?}"),
                    )
                })
            })
            .collect::<Result<_>>()?,
        None => (0..names.len())
            .filter(|&i| Some(i) != time_col.map(|t| t.0) && is_acceleration_like(&names[i]))
            // A text column whose name looks like acceleration (`accelerometer`
            // holding a serial number) is not data; a number column with a bad
            // cell further down still is, and that cell is reported.
            .filter(|&i| {
                let cell = first_cell(i);
                let text = !cell.is_empty() && !is_number(cell);
                if text {
                    skipped_text.push(&names[i]);
                }
                !text
            })
            .collect(),
    };
    if selected.is_empty() {
        return Err(Error::input(
            loc(header_line),
            format!("no acceleration-like column (Acc_*, acc*, a_*) of numbers; name the columns to read in the manifest. Columns are {names:?}"),
        ));
    }

    // Parse the cells we need, row by row (the whole file again, now that the
    // delimiter is known; only the selected columns are kept).
    let mut values: Vec<Vec<f64>> = vec![Vec::new(); selected.len()];
    let mut time_cells: Option<TimeCells> = None;
    let mut time_decimals = 0usize;
    let mut time_first_text = String::new();
    let mut time_lines: Vec<usize> = Vec::new();
    // A simple table (numbers in the time column) is parsed in parallel.
    let simple = match time_col {
        Some((tc, _)) if !is_number(first_cell(tc)) => None,
        _ => first_data.byte.and_then(|offset| {
            let cells = Cells {
                time: time_col.map(|(tc, _)| tc),
                selected: &selected,
                names: &names,
                fields: layout.fields,
                loc: &loc,
            };
            parse_simple(body, offset, first_data.line, layout.delim, &cells)
        }),
    };
    let slow_rows = match simple {
        Some(parsed) => {
            let parsed = parsed?;
            values = parsed.values;
            if let Some((tc, _)) = time_col {
                time_first_text = first_cell(tc).to_string();
                time_cells = Some(TimeCells::Numbers(parsed.times));
                time_decimals = parsed.time_decimals;
                time_lines = parsed.lines;
            }
            None
        }
        None => Some(rows(body, first, layout.delim).skip(layout.data_start)),
    };
    for row in slow_rows.into_iter().flatten() {
        let row = row.map_err(csv_err)?;
        let fields = &row.fields;
        let i = row.line;
        if fields.len() != layout.fields {
            return Err(width_error(loc(i), layout.fields, fields.len()));
        }
        let cell = |c: usize| number_cell(&fields[c], c, &names[c], || loc(i));
        if let Some((tc, _)) = time_col {
            let tcell = &fields[tc];
            let cells = time_cells.get_or_insert_with(|| {
                time_first_text = tcell.to_string();
                match parse_datetime_cell(tcell) {
                    Some((_, zone)) if !is_number(tcell) => TimeCells::DateTimes(Vec::new(), zone),
                    _ => TimeCells::Numbers(Vec::new()),
                }
            });
            match cells {
                TimeCells::Numbers(v) => v.push(cell(tc)?),
                TimeCells::DateTimes(v, _) => {
                    v.push(parse_datetime_cell(tcell).map(|(ns, _)| ns).ok_or_else(|| {
                        Error::input(
                            loc(i).with_channel(names[tc].clone()),
                            format!(
                                "cell {tcell:?} in time column {} is not an ISO 8601 date-time like the first one ({time_first_text:?})",
                                names[tc]
                            ),
                        )
                    })?)
                }
            }
            time_decimals = time_decimals.max(fraction_digits(tcell));
            time_lines.push(i);
        }
        for (k, &c) in selected.iter().enumerate() {
            values[k].push(cell(c)?);
        }
    }
    let n = values[0].len();
    if n < 2 {
        return Err(Error::input(
            loc(first_data.line),
            "fewer than two data rows",
        ));
    }

    // Sampling rate and grid.
    let mut inferred_common: Vec<String> = Vec::new();
    let mut qa_common: Vec<QaFlag> = Vec::new();
    // Start time stated by the time column itself (epoch numbers, date-times).
    let mut column_start: Option<(i64, String)> = None;
    let rate_hz: f64;
    if let (Some((tc, kind)), Some(cells)) = (time_col, &time_cells) {
        let tname = &names[tc];
        // Times in seconds since the first row (differences first: epoch
        // values are too large for f64 to keep their fractions otherwise).
        let (times, resolution): (Vec<f64>, f64) = match (cells, kind) {
            (TimeCells::DateTimes(ns, zone), _) => {
                column_start = Some((
                    ns[0],
                    format!(
                        "start time from the first cell of date-time column {tname} ({time_first_text}; {})",
                        zone.describe()
                    ),
                ));
                (
                    ns.iter().map(|t| (t - ns[0]) as f64 * 1e-9).collect(),
                    10f64.powi(-(time_decimals as i32)),
                )
            }
            (TimeCells::Numbers(raw), TimeKind::XsensFine) => {
                let mut wraps = 0.0;
                let mut out = Vec::with_capacity(n);
                for (k, &t) in raw.iter().enumerate() {
                    if k > 0 && t < raw[k - 1] {
                        wraps += 4_294_967_296.0; // 2^32 µs counter wrapped
                    }
                    out.push((t + wraps - raw[0]) * 1e-6);
                }
                (out, 1e-6)
            }
            (TimeCells::Numbers(raw), TimeKind::Seconds { factor, stated }) => {
                let mut f = factor;
                if !stated && raw[0].abs() >= EPOCH_MIN_S {
                    let (unit_s, unit) = epoch_unit(raw[0]);
                    f = unit_s;
                    inferred_common.push(format!(
                        "time column {tname} read as Unix epoch {unit}: no unit stated and its first value {} is at least 1e9",
                        raw[0]
                    ));
                }
                if (raw[0] * f).abs() >= EPOCH_MIN_S {
                    let ns_per_unit = (f * 1e9).round() as i128;
                    let ns = decimal_to_ns(&time_first_text, ns_per_unit)
                        .or_else(|| {
                            let v = raw[0] * f * 1e9;
                            (v.abs() < 9.2e18).then(|| v.round() as i64)
                        })
                        .ok_or_else(|| {
                            Error::input(
                                loc(time_lines[0]).with_channel(tname.clone()),
                                format!("epoch time {} is out of range", raw[0]),
                            )
                        })?;
                    column_start = Some((
                        ns,
                        format!("start time from the first value of epoch time column {tname} ({time_first_text})"),
                    ));
                }
                (
                    raw.iter().map(|t| (t - raw[0]) * f).collect(),
                    10f64.powi(-(time_decimals as i32)) * f,
                )
            }
        };
        let raw_text = |k: usize| -> String {
            match cells {
                TimeCells::Numbers(raw) => raw[k].to_string(),
                TimeCells::DateTimes(ns, _) => crate::vocab::format_epoch_ns(ns[k]),
            }
        };
        let mut steps: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
        if let Some(k) = steps.iter().position(|s| *s <= 0.0 || !s.is_finite()) {
            return Err(Error::input(
                loc(time_lines[k + 1]).with_channel(tname.clone()),
                format!(
                    "time column {tname} does not increase ({} after {})",
                    raw_text(k + 1),
                    raw_text(k)
                ),
            ));
        }
        let raw_steps = steps.clone();
        steps.sort_by(|a, b| a.total_cmp(b));
        let dt = steps[steps.len() / 2];
        let whole = (1.0 / dt).round();
        rate_hz = if whole >= 1.0 && (1.0 / whole - dt).abs() <= resolution {
            inferred_common.push(format!(
                "sampling rate {whole} Hz: median step {:.9} s of column {tname} is 1/{whole} s within its resolution {resolution:e} s",
                dt
            ));
            whole
        } else {
            1.0 / dt
        };
        let tol = (0.01 * dt).max(1.5 * resolution);
        let uneven = raw_steps.iter().any(|s| (s - dt).abs() > tol);
        if uneven {
            // Bound the grid before allocating it (module doc).
            let span = times[n - 1] - times[0];
            let grid = grid_len(span, 1.0 / rate_hz);
            let per_row = (MAX_RESAMPLE_GROWTH * n) as f64;
            let total = (MAX_RESAMPLED_SAMPLES / selected.len()) as f64;
            if !(grid <= per_row && grid <= total) {
                let (k, jump) = raw_steps
                    .iter()
                    .enumerate()
                    .max_by(|a, b| a.1.total_cmp(b.1))
                    .map(|(k, s)| (k, *s))
                    .unwrap_or((0, 0.0));
                return Err(Error::input(
                    loc(time_lines[k + 1]).with_channel(tname.clone()),
                    format!(
                        "time column {tname} spans {span:e} s over {n} rows at a median step of {dt:e} s: resampling onto a uniform {rate_hz} Hz grid would need {grid:e} samples per channel, more than {MAX_RESAMPLE_GROWTH} × the rows and at most {MAX_RESAMPLED_SAMPLES} samples over the {} channels read; the largest jump, {jump:e} s, ends at this line",
                        selected.len()
                    ),
                ));
            }
            for (k, s) in raw_steps.iter().enumerate() {
                if *s > 1.5 * dt {
                    qa_common.push(QaFlag::Gap {
                        at_s: times[k] - times[0],
                        duration_s: s - dt,
                    });
                }
            }
            let (lo, hi) = (steps[0], steps[steps.len() - 1]);
            qa_common.push(QaFlag::Resampled {
                from: format!("uneven time column {tname} (steps {lo:.6}–{hi:.6} s), linear interpolation onto {rate_hz} Hz"),
            });
            for v in values.iter_mut() {
                *v = resample_linear(&times, v, 1.0 / rate_hz);
            }
        }
        if let Some(r) = opts.sampling_rate_hz {
            if ((r - rate_hz) / rate_hz).abs() > 0.01 {
                qa_common.push(QaFlag::Note {
                    text: format!("manifest sampling rate {r} Hz disagrees with the time column ({rate_hz} Hz); the time column was used"),
                });
            }
        }
    } else if let Some(r) = opts.sampling_rate_hz.or(preamble_rate) {
        if !(r.is_finite() && r > 0.0) {
            return Err(Error::usage(format!(
                "sampling rate {r} Hz is not positive"
            )));
        }
        rate_hz = r;
    } else {
        return Err(Error::input(
            loc(header_line),
            "no time column and no sampling rate: give `sampling_rate_hz` (or `time_column`) in the manifest",
        ));
    }
    if !skipped_text.is_empty() {
        qa_common.push(QaFlag::Note {
            text: format!(
                "columns {skipped_text:?} look like acceleration by name but hold text; not read"
            ),
        });
    }
    // The time column states the instant of each row; a preamble StartTime is
    // only the recorder's note of when it started.
    let start: Option<(i64, String)> = column_start.or(start.map(|(ns, zone, line)| {
        (
            ns,
            format!("start time from the StartTime line {} ({zone})", line + 1),
        )
    }));

    let prefix = station.clone().unwrap_or_else(|| {
        std::path::Path::new(&src.file)
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_default()
    });
    let mut records = Vec::new();
    for (k, &c) in selected.iter().enumerate() {
        let name = &names[c];
        let mut s = src.clone();
        s.column = Some(name.clone());
        let mut missing = Vec::new();
        let mut inferred = inferred_common.clone();
        let mut qa = qa_common.clone();
        let units = match unit_text(name) {
            Some(u) => match u.parse::<Units>() {
                Ok(units) => units,
                Err(e) => {
                    qa.push(QaFlag::Note {
                        text: format!("column {name}: {e}"),
                    });
                    missing.push("units".to_string());
                    inferred.push(format!(
                        "units=m/s2 assumed: unit {u:?} of column {name} is not understood"
                    ));
                    Units::MPerS2
                }
            },
            None => {
                missing.push("units".to_string());
                inferred.push(if is_xsens && base_name(name).starts_with("acc") {
                    format!("units=m/s2 assumed: column {name} states none; Xsens DOT exports Acc_* in m/s² (including gravity)")
                } else {
                    format!("units=m/s2 assumed: column {name} states none")
                });
                Units::MPerS2
            }
        };
        let mut ch = Channel::new(format!("{prefix}.{name}"), units, rate_hz, s);
        ch.station = station.clone();
        if let Some((ns, why)) = &start {
            ch.start_ns = Some(*ns);
            inferred.push(why.clone());
        }
        let nonfinite = values[k].iter().filter(|v| !v.is_finite()).count();
        if nonfinite > 0 {
            qa.push(QaFlag::NonFinite { count: nonfinite });
        }
        ch.missing = missing;
        ch.inferred = inferred;
        ch.qa = qa;
        records.push(Record::new(ch, std::mem::take(&mut values[k])));
    }
    Ok(FileContents {
        records,
        ..Default::default()
    })
}

/// What the data rows are read for: the time column (if any), the selected
/// columns, and how errors name the place.
struct Cells<'a> {
    time: Option<usize>,
    selected: &'a [usize],
    names: &'a [String],
    /// Fields of every row.
    fields: usize,
    loc: &'a (dyn Fn(usize) -> crate::error::Location + Sync),
}

/// The data rows as read by [`parse_simple`].
struct Parsed {
    values: Vec<Vec<f64>>,
    times: Vec<f64>,
    time_decimals: usize,
    /// Line (0-based, in the file) of each row.
    lines: Vec<usize>,
}

/// Whitespace as `str::trim` sees it, in ASCII text.
fn is_trim_space(b: u8) -> bool {
    matches!(b, b'\t' | b'\n' | 0x0B | 0x0C | b'\r' | b' ')
}

fn trim_space(mut s: &[u8]) -> &[u8] {
    while let [first, rest @ ..] = s {
        if !is_trim_space(*first) {
            break;
        }
        s = rest;
    }
    while let [rest @ .., last] = s {
        if !is_trim_space(*last) {
            break;
        }
        s = rest;
    }
    s
}

/// The data rows of a *simple* table — split by a delimiter byte; ASCII
/// text without quotes and without a carriage return that does not end a
/// line — from byte `offset` of `body` (line `line` of the file) to the end,
/// parsed in parallel in chunks of whole lines (issue 14 item 5: a 582 MB
/// CSV).  What the `csv` crate would make of such rows is plain: lines are
/// rows, fields split at the delimiter and trimmed, blank lines skipped.  So
/// the cells, values and errors (the first in file order) are those of
/// reading it row by row.  `None` when the table is not simple.
fn parse_simple(
    body: &str,
    offset: usize,
    line: usize,
    delim: Delim,
    cells: &Cells,
) -> Option<Result<Parsed>> {
    use rayon::prelude::*;
    let Delim::Byte(d) = delim else {
        return None;
    };
    if d == b'"' || !d.is_ascii() {
        return None;
    }
    let data = body.as_bytes().get(offset..)?;
    let chunks = line_chunks(data);
    // Pass 1: is every chunk simple, and how many lines and rows does it hold?
    let blank = |l: &[u8]| !l.contains(&d) && trim_space(l).is_empty();
    let counts: Vec<Option<(usize, usize)>> = chunks
        .par_iter()
        .map(|c| {
            let simple = c.iter().enumerate().all(|(i, &b)| {
                b.is_ascii() && b != b'"' && (b != b'\r' || c.get(i + 1) == Some(&b'\n'))
            });
            simple.then(|| {
                let lines = c.iter().filter(|&&b| b == b'\n').count();
                let rows = c.split(|&b| b == b'\n').filter(|l| !blank(l)).count();
                (lines, rows)
            })
        })
        .collect();
    let counts: Vec<(usize, usize)> = counts.into_iter().collect::<Option<_>>()?;
    let rows: usize = counts.iter().map(|c| c.1).sum();
    // Pass 2: each chunk fills its rows of every column.
    let mut values: Vec<Vec<f64>> = vec![vec![0.0; rows]; cells.selected.len()];
    let (mut times, mut lines) = match cells.time {
        Some(_) => (vec![0.0; rows], vec![0usize; rows]),
        None => (Vec::new(), Vec::new()),
    };
    let mut work = Vec::with_capacity(chunks.len());
    {
        let mut columns: Vec<&mut [f64]> = values.iter_mut().map(|v| v.as_mut_slice()).collect();
        let (mut t, mut l) = (times.as_mut_slice(), lines.as_mut_slice());
        let mut first_line = line;
        for (chunk, &(n_lines, n_rows)) in chunks.iter().zip(&counts) {
            let mut mine = Vec::with_capacity(columns.len());
            for c in columns.iter_mut() {
                let (head, rest) = std::mem::take(c).split_at_mut(n_rows);
                mine.push(head);
                *c = rest;
            }
            let k = if cells.time.is_some() { n_rows } else { 0 };
            let (th, tr) = std::mem::take(&mut t).split_at_mut(k);
            let (lh, lr) = std::mem::take(&mut l).split_at_mut(k);
            (t, l) = (tr, lr);
            work.push((*chunk, first_line, mine, th, lh));
            first_line += n_lines;
        }
        let results: Vec<Result<usize>> = work
            .into_par_iter()
            .map(|(chunk, first_line, mut cols, t, l)| {
                parse_chunk(chunk, first_line, d, cells, &mut cols, t, l)
            })
            .collect();
        let mut decimals = 0usize;
        for r in results {
            decimals = decimals.max(match r {
                Ok(dec) => dec,
                Err(e) => return Some(Err(e)),
            });
        }
        return Some(Ok(Parsed {
            values,
            times,
            time_decimals: decimals,
            lines,
        }));
    }
}

/// Parses the rows of one chunk (first line `first_line` of the file) into
/// the chunk's slices; returns the most decimals of its time cells.
fn parse_chunk(
    chunk: &[u8],
    first_line: usize,
    d: u8,
    cells: &Cells,
    columns: &mut [&mut [f64]],
    times: &mut [f64],
    lines: &mut [usize],
) -> Result<usize> {
    let mut fields: Vec<&str> = Vec::with_capacity(cells.fields);
    let mut row = 0usize;
    let mut decimals = 0usize;
    for (i, raw) in chunk.split(|&b| b == b'\n').enumerate() {
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        if !raw.contains(&d) && trim_space(raw).is_empty() {
            continue;
        }
        let at = first_line + i;
        fields.clear();
        // ASCII text: every piece is valid UTF-8.
        fields.extend(
            raw.split(|&b| b == d)
                .map(|f| std::str::from_utf8(trim_space(f)).unwrap_or("")),
        );
        if fields.len() != cells.fields {
            return Err(width_error((cells.loc)(at), cells.fields, fields.len()));
        }
        let cell = |c: usize| number_cell(fields[c], c, &cells.names[c], || (cells.loc)(at));
        if let Some(tc) = cells.time {
            times[row] = cell(tc)?;
            decimals = decimals.max(fraction_digits(fields[tc]));
            lines[row] = at;
        }
        for (k, &c) in cells.selected.iter().enumerate() {
            columns[k][row] = cell(c)?;
        }
        row += 1;
    }
    Ok(decimals)
}

/// A data row of another width than the table's.
fn width_error(at: crate::error::Location, expected: usize, found: usize) -> Error {
    Error::input(
        at,
        format!("expected {expected} fields as in the header, found {found}"),
    )
}

/// Cell `cell` of column `c` (named `name`) as a number; the error names
/// the line (`at`), the column and the cell.
fn number_cell(
    cell: &str,
    c: usize,
    name: &str,
    at: impl FnOnce() -> crate::error::Location,
) -> Result<f64> {
    cell.parse::<f64>().map_err(|_| {
        Error::input(
            at().with_channel(name.to_string()),
            format!("cell {cell:?} in column {c} ({name}) is not a number"),
        )
    })
}
