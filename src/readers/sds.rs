//! SDS archives: the SeisComP Data Structure seismic networks keep their
//! continuous MiniSEED in, one file per stream and UTC day:
//! `ROOT/YEAR/NET/STA/CHAN.D/NET.STA.LOC.CHAN.D.YEAR.DAY` (DAY: day of the
//! year, three digits).
//!
//! What is read, and how (issue 17 item 3):
//! - [`SdsArchive::open`] lists the streams of the archive (directory walk of
//!   four levels, file names parsed; nothing is decoded) and
//!   [`SdsArchive::select`] keeps those matching `NET.STA.LOC.CHAN` patterns
//!   (`*` and `?` wildcards per field);
//! - [`SdsArchive::read_window`] returns the samples of every selected
//!   stream in `[t0, t1)`.  Memory stays at about one window: a day file is
//!   scanned once, record by record from disk, to index its records
//!   (headers only, [`dayfile::scan`]: a chunk in memory, never the whole
//!   file; the index, a few hundred kB per day, is kept for the next
//!   windows), then only the records overlapping the window are read from
//!   disk and decoded.  The file of the day before is consulted too, so a
//!   record that starts before midnight and ends after it is found;
//! - damage costs only the windows it overlaps (issue 33 item 4): a
//!   stretch the scan could not read, or a record whose samples do not
//!   decode, is skipped and its time span left without samples (a gap, as
//!   below); every window it overlaps carries a note ([`damage_note`]:
//!   stream, file, byte offset, why, the time without samples), and a
//!   window where it leaves a stream with no sample at all is an input
//!   error naming the file and offset;
//! - the records of a stream are joined by [`mseed::join_segments`]: gaps
//!   up to its limit are filled by linear interpolation, overlaps keep the
//!   earlier samples.  Only recorded samples count as present: a window's
//!   `present_fraction` is the smallest share, over streams, of the window's
//!   samples that were recorded (filled gaps and missing ends do not
//!   count); the caller decides what to do with a window below a threshold;
//! - all selected streams must share one sampling rate (an input error
//!   naming them otherwise: resample the archive first); the streams are cut
//!   to their common span inside the window, on the grid of the first one;
//! - a record whose header disagrees with the bytes present is never
//!   trusted; a day file that is not a regular file, cannot be read or is
//!   beyond the scan's limits is an input error naming it (the windows
//!   that need it are skipped with that reason).
//!
//! Samples are as recorded (counts); the caller applies StationXML gains.

use std::collections::BTreeMap;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use super::dayfile::{self, Damage, DayScan};
use super::mseed::{self, RecordSpan, Segment, StreamCodes};
use crate::error::{Error, Location, Result};
use crate::vocab::{day_start_ns, format_epoch_ns, ordinal_from_epoch_ns, SourceRef};

const NS_PER_DAY: i64 = 86_400_000_000_000;

/// Path of the day file of `codes` for the UTC day holding `t_ns`.
pub fn day_file(root: &Path, codes: &StreamCodes, t_ns: i64) -> PathBuf {
    let t = ordinal_from_epoch_ns(t_ns);
    root.join(format!("{:04}", t.year))
        .join(&codes.network)
        .join(&codes.station)
        .join(format!("{}.D", codes.channel))
        .join(format!(
            "{}.D.{:04}.{:03}",
            codes.id(),
            t.year,
            t.day_of_year
        ))
}

/// The stream codes of an SDS file name `NET.STA.LOC.CHAN.D.YEAR.DAY`,
/// and the start of its day (ns).
fn codes_of_file_name(name: &str) -> Option<(StreamCodes, i64)> {
    let parts: Vec<&str> = name.split('.').collect();
    if parts.len() != 7 || parts[4] != "D" {
        return None;
    }
    let numeric = |s: &str, n: usize| s.len() == n && s.bytes().all(|b| b.is_ascii_digit());
    if !numeric(parts[5], 4) || !numeric(parts[6], 3) {
        return None;
    }
    let day = crate::vocab::epoch_ns_from_ordinal(
        parts[5].parse().ok()?,
        parts[6].parse().ok()?,
        0,
        0,
        0.0,
    )?;
    let codes = StreamCodes {
        network: parts[0].into(),
        station: parts[1].into(),
        location: parts[2].into(),
        channel: parts[3].into(),
    };
    Some((codes, day))
}

/// Whether `text` matches the glob `pattern` (`*` any run, `?` one character).
fn glob(pattern: &str, text: &str) -> bool {
    let (p, t): (Vec<char>, Vec<char>) = (pattern.chars().collect(), text.chars().collect());
    // Iterative matcher with backtracking to the last `*`.
    let (mut i, mut j, mut star, mut mark) = (0usize, 0usize, None, 0usize);
    while j < t.len() {
        if i < p.len() && (p[i] == '?' || p[i] == t[j]) {
            i += 1;
            j += 1;
        } else if i < p.len() && p[i] == '*' {
            star = Some(i);
            mark = j;
            i += 1;
        } else if let Some(s) = star {
            i = s + 1;
            mark += 1;
            j = mark;
        } else {
            return false;
        }
    }
    p[i..].iter().all(|&c| c == '*')
}

/// A channel selection `NET.STA.LOC.CHAN`, each field a glob (`*`, `?`); an
/// empty location field matches the empty location code only.
#[derive(Debug, Clone, PartialEq)]
pub struct StreamPattern {
    fields: [String; 4],
}

impl StreamPattern {
    /// Parses `NET.STA.LOC.CHAN`; anything else is a usage error.
    pub fn parse(text: &str) -> Result<StreamPattern> {
        let parts: Vec<&str> = text.trim().split('.').collect();
        if parts.len() != 4
            || parts
                .iter()
                .enumerate()
                .any(|(k, p)| p.is_empty() && k != 2)
        {
            return Err(Error::usage(format!(
                "channel pattern {text:?} must read NET.STA.LOC.CHAN (wildcards * and ?, e.g. QT.BLD.*.HN?)"
            )));
        }
        Ok(StreamPattern {
            fields: [0, 1, 2, 3].map(|k| parts[k].to_string()),
        })
    }

    pub fn matches(&self, c: &StreamCodes) -> bool {
        let values = [&c.network, &c.station, &c.location, &c.channel];
        self.fields.iter().zip(values).all(|(p, v)| glob(p, v))
    }
}

/// Samples of the selected streams in one window.
#[derive(Debug, Clone, PartialEq)]
pub struct WindowSamples {
    /// Time of the first sample, ns (the common start of the streams).
    pub start_ns: i64,
    pub rate_hz: f64,
    /// One signal per selected stream (archive order), equal lengths, counts.
    pub signals: Vec<Vec<f64>>,
    /// Smallest share over the streams of the window's samples that were
    /// recorded (0..1): filled gaps and missing stretches do not count.
    pub present_fraction: f64,
    /// Gaps, overlaps and missing ends, said once per stream.
    pub notes: Vec<String>,
}

/// Damaged stretches and records, each with its day file.
type Damaged = Vec<(PathBuf, Damage)>;

/// Index of one day file: its records and damaged stretches (empty when
/// the file does not exist).
type DayIndex = Arc<DayScan>;

/// An SDS archive and the streams selected in it.
#[derive(Debug)]
pub struct SdsArchive {
    root: PathBuf,
    streams: Vec<StreamCodes>,
    /// Day files found, by stream: the start of each file's day, ns.
    days: BTreeMap<StreamCodes, Vec<i64>>,
    /// Day-file indexes by (stream index, day start ns); the oldest days
    /// are dropped as windows move on ([`Self::forget_before`]).
    indexes: Mutex<BTreeMap<(usize, i64), DayIndex>>,
}

impl SdsArchive {
    /// Lists the streams under `root` (sorted by `NET.STA.LOC.CHAN`).  An
    /// archive without any SDS day file is an input error.
    pub fn open(root: &Path) -> Result<SdsArchive> {
        let meta = std::fs::metadata(root).map_err(|e| Error::io(root, e))?;
        if !meta.is_dir() {
            return Err(Error::usage(format!(
                "{}: an SDS archive is a directory (YEAR/NET/STA/CHAN.D/NET.STA.LOC.CHAN.D.YEAR.DAY)",
                root.display()
            )));
        }
        let mut found: BTreeMap<StreamCodes, Vec<i64>> = BTreeMap::new();
        let subdirs = |dir: &Path| -> Result<Vec<PathBuf>> {
            let mut v = Vec::new();
            for entry in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
                let entry = entry.map_err(|e| Error::io(dir, e))?;
                if entry.file_type().map(|t| t.is_dir()).unwrap_or(false) {
                    v.push(entry.path());
                }
            }
            v.sort();
            Ok(v)
        };
        let is_year = |p: &Path| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.len() == 4 && n.bytes().all(|b| b.is_ascii_digit()))
        };
        for year in subdirs(root)?.into_iter().filter(|p| is_year(p)) {
            for net in subdirs(&year)? {
                for sta in subdirs(&net)? {
                    for chan in subdirs(&sta)? {
                        for entry in std::fs::read_dir(&chan).map_err(|e| Error::io(&chan, e))? {
                            let entry = entry.map_err(|e| Error::io(&chan, e))?;
                            let name = entry.file_name();
                            let Some(name) = name.to_str() else { continue };
                            if let Some((c, day)) = codes_of_file_name(name) {
                                found.entry(c).or_default().push(day);
                            }
                        }
                    }
                }
            }
        }
        if found.is_empty() {
            return Err(Error::input(
                Location::file(root.display().to_string()),
                "no SDS day file found (expected YEAR/NET/STA/CHAN.D/NET.STA.LOC.CHAN.D.YEAR.DAY)",
            ));
        }
        found.values_mut().for_each(|d| d.sort());
        Ok(SdsArchive {
            root: root.to_path_buf(),
            streams: found.keys().cloned().collect(),
            days: found,
            indexes: Mutex::new(BTreeMap::new()),
        })
    }

    /// Keeps the streams matching any of `patterns` (all when empty); a
    /// selection matching nothing is an input error listing what exists.
    pub fn select(mut self, patterns: &[StreamPattern]) -> Result<SdsArchive> {
        if patterns.is_empty() {
            return Ok(self);
        }
        let all = self.streams.clone();
        self.streams
            .retain(|c| patterns.iter().any(|p| p.matches(c)));
        if self.streams.is_empty() {
            let ids: Vec<String> = all.iter().map(StreamCodes::id).collect();
            return Err(Error::input(
                Location::file(self.root.display().to_string()),
                format!(
                    "no stream matches the channel selection; the archive holds {}",
                    ids.join(", ")
                ),
            ));
        }
        Ok(self)
    }

    /// Drops the stream `id` (`NET.STA.LOC.CHAN`) from the selection, if
    /// selected: a channel that is not an accelerometer (temperature).
    pub fn without(mut self, id: &str) -> SdsArchive {
        self.streams.retain(|c| c.id() != id);
        self
    }

    pub fn root(&self) -> &Path {
        &self.root
    }

    /// The days the selected streams' files cover: the start of the first
    /// file's day and the end of the last's, ns.
    pub fn span(&self) -> (i64, i64) {
        let days = self
            .streams
            .iter()
            .filter_map(|c| self.days.get(c))
            .flatten();
        let first = days.clone().min().copied().unwrap_or(0);
        let last = days.max().copied().unwrap_or(0);
        (first, last + NS_PER_DAY)
    }

    /// The selected streams, sorted by id.
    pub fn streams(&self) -> &[StreamCodes] {
        &self.streams
    }

    /// The index of stream `k`'s day file for the day starting at `day_ns`
    /// (scanned once, then kept): its good records and damaged stretches.
    fn day_index(&self, k: usize, day_ns: i64) -> Result<DayIndex> {
        if let Some(ix) = self.lock().get(&(k, day_ns)) {
            return Ok(ix.clone());
        }
        let path = day_file(&self.root, &self.streams[k], day_ns);
        let scan = dayfile::scan(&path, &self.streams[k].id(), (day_ns, day_ns + NS_PER_DAY))?;
        let ix = Arc::new(scan);
        self.lock().insert((k, day_ns), ix.clone());
        Ok(ix)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, BTreeMap<(usize, i64), DayIndex>> {
        // A poisoned lock only means another window's thread panicked; the
        // map itself is always consistent (single inserts and removals).
        self.indexes.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Drops the indexes of days that end before `t_ns` minus one day (the
    /// day before is still needed for records spanning midnight).
    pub fn forget_before(&self, t_ns: i64) {
        let keep_from = day_start_ns(t_ns) - NS_PER_DAY;
        self.lock().retain(|&(_, day), _| day >= keep_from);
    }

    /// The recorded segments of stream `k` overlapping `[t0, t1)`, and the
    /// damage that leaves samples missing there: stretches of its day files
    /// skipped when indexed, and records whose samples do not decode (a
    /// Steim integrity check failed, a data section shorter than its
    /// count), each with its file.
    fn segments(&self, k: usize, t0: i64, t1: i64) -> Result<(Vec<Segment>, Damaged)> {
        let mut out = Vec::new();
        let mut damaged = Vec::new();
        let id = self.streams[k].id();
        let mut day = day_start_ns(t0) - NS_PER_DAY;
        while day < t1 {
            let ix = self.day_index(k, day)?;
            let path = day_file(&self.root, &self.streams[k], day);
            damaged.extend(
                ix.damage
                    .iter()
                    .filter(|d| overlaps(d.start_ns, d.end_ns, t0, t1))
                    .map(|d| (path.clone(), d.clone())),
            );
            let wanted: Vec<&RecordSpan> = ix
                .records
                .iter()
                .filter(|s| s.start_ns < t1 && s.end_ns() > t0)
                .collect();
            if !wanted.is_empty() {
                let src = source_of(&path);
                let mut file = crate::input_file::open(&path)?;
                let mut buf = Vec::new();
                for span in wanted {
                    buf.resize(span.len as usize, 0);
                    file.seek(SeekFrom::Start(span.offset))
                        .and_then(|_| file.read_exact(&mut buf))
                        .map_err(|e| Error::io(&path, e))?;
                    match mseed::decode_record(&buf, span, &id, &src) {
                        Ok(seg) => out.push(seg),
                        Err(e) => damaged.push((
                            path.clone(),
                            Damage {
                                offset: span.offset,
                                bytes: span.len as u64,
                                why: match e {
                                    Error::Input { message, .. } => message,
                                    other => other.to_string(),
                                },
                                start_ns: span.start_ns,
                                end_ns: span.end_ns(),
                            },
                        )),
                    }
                }
            }
            day += NS_PER_DAY;
        }
        Ok((out, damaged))
    }

    /// The samples of every selected stream in `[t0, t1)` (module doc);
    /// `Ok(None)` when some stream has no sample there at all.
    pub fn read_window(&self, t0: i64, t1: i64) -> Result<Option<WindowSamples>> {
        struct Cut {
            first_ns: i64,
            samples: Vec<f64>,
            present: usize,
        }
        let mut cuts = Vec::with_capacity(self.streams.len());
        let mut notes = Vec::new();
        let mut rate: Option<(f64, String)> = None;
        for k in 0..self.streams.len() {
            let id = self.streams[k].id();
            let (segments, damaged) = self.segments(k, t0, t1)?;
            if let (true, Some((path, d))) = (segments.is_empty(), damaged.first()) {
                return Err(Error::input(
                    Location::file(path.display().to_string())
                        .with_channel(&id)
                        .at_byte(d.offset),
                    format!(
                        "no samples of {id} in the window: {}",
                        damage_note(&id, path, d)
                    ),
                ));
            }
            if segments.is_empty() {
                return Ok(None);
            }
            notes.extend(damaged.iter().map(|(p, d)| damage_note(&id, p, d)));
            let r = segments[0].rate_hz;
            match &rate {
                None => rate = Some((r, id.clone())),
                Some((r0, id0)) if ((r - r0) / r0).abs() > 1e-6 => {
                    return Err(Error::input(
                        Location::file(self.root.display().to_string()).with_channel(&id),
                        format!(
                            "samples at {r} Hz, stream {id0} at {r0} Hz: the streams of one identification must share a sampling rate (select streams of one rate, or resample the archive)"
                        ),
                    ));
                }
                _ => {}
            }
            let dt_ns = 1e9 / r;
            // Recorded samples inside the window, counted before joining.
            let present: usize = segments
                .iter()
                .map(|s| {
                    let first = ((t0 - s.start_ns) as f64 / dt_ns).ceil().max(0.0) as usize;
                    let end = (((t1 - s.start_ns) as f64 / dt_ns).ceil().max(0.0) as usize)
                        .min(s.samples.len());
                    end.saturating_sub(first)
                })
                .sum();
            let joined = mseed::join_segments(segments).map_err(|m| {
                Error::input(
                    Location::file(self.root.display().to_string()).with_channel(&id),
                    m,
                )
            })?;
            let gaps = joined
                .qa
                .iter()
                .filter(|q| matches!(q, crate::vocab::QaFlag::Gap { .. }))
                .count();
            if gaps > 0 {
                notes.push(format!(
                    "{id}: {gaps} gap(s) or overlap(s) in the window, gaps filled by linear interpolation"
                ));
            }
            let first = ((t0 - joined.start_ns) as f64 / dt_ns).ceil().max(0.0) as usize;
            let end = (((t1 - joined.start_ns) as f64 / dt_ns).ceil().max(0.0) as usize)
                .min(joined.samples.len());
            if first >= end {
                return Ok(None);
            }
            cuts.push(Cut {
                first_ns: joined.start_ns + (first as f64 * dt_ns).round() as i64,
                samples: joined.samples[first..end].to_vec(),
                present,
            });
        }
        let Some((rate_hz, _)) = rate else {
            return Ok(None);
        };
        let dt_ns = 1e9 / rate_hz;
        let expected = ((t1 - t0) as f64 / dt_ns).round().max(1.0);
        // Common span: the latest first sample to the earliest last one.
        let start_ns = cuts.iter().map(|c| c.first_ns).max().unwrap_or(t0);
        let shifts: Vec<usize> = cuts
            .iter()
            .map(|c| ((start_ns - c.first_ns) as f64 / dt_ns).round() as usize)
            .collect();
        let len = cuts
            .iter()
            .zip(&shifts)
            .map(|(c, &s)| c.samples.len().saturating_sub(s))
            .min()
            .unwrap_or(0);
        if len < 2 {
            return Ok(None);
        }
        let present_fraction = cuts
            .iter()
            .map(|c| (c.present as f64 / expected).min(1.0))
            .fold(1.0, f64::min)
            .min(len as f64 / expected);
        if present_fraction < 1.0 - 1e-9 {
            notes.push(format!(
                "{:.2} % of the window's samples recorded (the least complete stream)",
                100.0 * present_fraction
            ));
        }
        let signals = cuts
            .into_iter()
            .zip(shifts)
            .map(|(c, s)| c.samples[s..s + len].to_vec())
            .collect();
        Ok(Some(WindowSamples {
            start_ns,
            rate_hz,
            signals,
            present_fraction,
            notes,
        }))
    }
}

/// Whether the time span `[a, b)` (an instant when `a == b`) meets `[t0, t1)`.
fn overlaps(a: i64, b: i64, t0: i64, t1: i64) -> bool {
    if a == b {
        (t0..t1).contains(&a)
    } else {
        a < t1 && b > t0
    }
}

/// How every window note about damage begins (`track` picks them out for
/// stderr and the report by it).
pub const DAMAGE_NOTE: &str = "damaged MiniSEED skipped";

/// The note of a damaged stretch: stream, file, byte offset and length,
/// why, and the time left without samples.
pub fn damage_note(id: &str, path: &Path, d: &Damage) -> String {
    format!(
        "{DAMAGE_NOTE}: {id}, {} byte {} ({} bytes): {}; no samples from {} to {}",
        path.display(),
        d.offset,
        d.bytes,
        d.why,
        format_epoch_ns(d.start_ns),
        format_epoch_ns(d.end_ns)
    )
}

fn source_of(path: &Path) -> SourceRef {
    SourceRef {
        file: path.display().to_string(),
        member: None,
        column: None,
        format: "mseed".into(),
    }
}
