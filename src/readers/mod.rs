//! Readers: one module per file format.  Each turns the bytes of one file (or
//! zip member) into records with everything its header says, in the units
//! the file stores.  Readers never convert units or guess roles: that is the
//! event folder's and conditioning's job, so what came from the file and what
//! was inferred stay distinguishable.
//!
//! Contract of every reader: `fn read(bytes: &[u8], source: &SourceRef, opts: &ReadOptions) -> Result<FileContents>`.
//! Errors are `Error::Input` with a `Location` naming the file, member and,
//! where it applies, the channel and the line (text) or byte offset (binary).

pub mod at2;
pub mod cosmos;
pub mod csv;
pub mod dayfile;
pub mod dmg;
pub mod geonet;
pub mod lab;
pub mod mat5;
pub mod mcap;
pub mod mseed;
pub mod resample;
pub mod sac;
pub mod sds;
pub mod smc;
pub mod stationxml;
pub mod textfmt;

use crate::error::{Error, Location, Result};
use crate::vocab::{Record, SourceRef};

/// Hints a caller (the event manifest) can give a reader.
#[derive(Debug, Clone, Default)]
pub struct ReadOptions {
    /// Sampling rate for files without a time column or header rate (CSV).
    pub sampling_rate_hz: Option<f64>,
    /// Columns to read (names or 0-based indices) for multi-column files;
    /// `None` = every numeric acceleration-like column.  The CSV reader
    /// returns one record per entry, in this order.
    pub columns: Option<Vec<String>>,
    /// Name (or index) of the time column in CSV files.
    pub time_column: Option<String>,
}

/// Event-level facts a header may state.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EventHints {
    pub name: Option<String>,
    pub origin_ns: Option<i64>,
    pub magnitude: Option<f64>,
    pub hypocenter: Option<(f64, f64, f64)>,
    /// The recording station's position (latitude, longitude, degrees),
    /// when the header states it: the structure's, for the report's
    /// epicentral distance.
    pub station_position: Option<(f64, f64)>,
    /// The station's name as the header gives it ("Van Nuys - 7-story
    /// Hotel", SMC `station = …`): the event folder reads the storey count
    /// and the kind of structure from it.
    pub station_name: Option<String>,
    /// Kind of structure a header field states (COSMOS integer 18, the
    /// station/structure type code): "building", "bridge", "dam", …, with
    /// the code, for `Structure.inferred`.
    pub structure_kind: Option<(String, String)>,
}

/// A response spectrum stated by a file (CSMIP V3, COSMOS spectra), kept for
/// cross-checking our own spectra.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FileSpectrum {
    /// Id of the channel it belongs to (same id as the channel's record).
    pub channel_id: String,
    /// Damping ratio (0.05 = 5 %).
    pub damping: f64,
    pub periods_s: Vec<f64>,
    /// Pseudo-spectral acceleration in `units`.
    pub psa: Vec<f64>,
    pub units: String,
}

/// What one file holds.
#[derive(Debug, Clone, Default)]
pub struct FileContents {
    /// Acceleration records (one per channel), values in the units the file stores.
    pub records: Vec<Record>,
    /// Spectra the file states (V3 files).
    pub spectra: Vec<FileSpectrum>,
    pub event: EventHints,
}

/// Formats quaketwin reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// COSMOS strong-motion format V0/V1/V2 (`.V0c`, `.V1c`, `.V2c`…).
    Cosmos,
    /// CSMIP/CDMG volume 1/2/3 (`.V1`, `.V2`, `.V3`), one or many channels per file.
    Dmg,
    /// USGS SMC.
    Smc,
    /// PEER NGA `.AT2` (and look-alikes with an `NPTS=…, DT=…` line).
    At2,
    /// MiniSEED 2 (Steim-1/2, integer and float encodings).
    MiniSeed,
    /// FDSN StationXML (metadata only: gains, orientation, elevation).
    StationXml,
    /// SAC binary (either endianness).
    Sac,
    /// GeoNet V1A/V2A.
    GeoNet,
    /// CSV/TSV, including the Xsens DOT export.
    Csv,
    /// MCAP with JSON-encoded acceleration messages (schema in docs/formats.md).
    Mcap,
}

impl Format {
    /// The most bytes a file of this format may have, when the format sets
    /// one: the fixed-format text readers ([`textfmt::MAX_TEXT_RECORD_BYTES`]),
    /// checked on a member's size before it is decompressed or read.
    pub fn max_file_bytes(&self) -> Option<u64> {
        match self {
            Format::Cosmos | Format::Dmg | Format::Smc | Format::At2 | Format::GeoNet => {
                Some(textfmt::MAX_TEXT_RECORD_BYTES as u64)
            }
            _ => None,
        }
    }
    pub fn name(&self) -> &'static str {
        match self {
            Format::Cosmos => "cosmos",
            Format::Dmg => "dmg",
            Format::Smc => "smc",
            Format::At2 => "at2",
            Format::MiniSeed => "mseed",
            Format::StationXml => "stationxml",
            Format::Sac => "sac",
            Format::GeoNet => "geonet",
            Format::Csv => "csv",
            Format::Mcap => "mcap",
        }
    }
    pub fn from_name(s: &str) -> Option<Format> {
        Some(match s.to_ascii_lowercase().as_str() {
            "cosmos" => Format::Cosmos,
            "dmg" | "csmip" | "cdmg" => Format::Dmg,
            "smc" => Format::Smc,
            "at2" | "peer" => Format::At2,
            "mseed" | "miniseed" => Format::MiniSeed,
            "stationxml" | "xml" => Format::StationXml,
            "sac" => Format::Sac,
            "geonet" | "v2a" | "v1a" => Format::GeoNet,
            "csv" | "tsv" => Format::Csv,
            "mcap" => Format::Mcap,
            _ => return None,
        })
    }
}

/// What sniffing decided about one file: a record file in a known format,
/// or a file that is skipped, with the reason shown to the user.
#[derive(Debug, Clone, PartialEq)]
pub enum Sniffed {
    Record(Format),
    Skip(String),
}

impl Sniffed {
    pub fn format(&self) -> Option<Format> {
        match self {
            Sniffed::Record(f) => Some(*f),
            Sniffed::Skip(_) => None,
        }
    }
}

/// Extensions of documentation and metadata files.  Such a file is a record
/// only when its content holds a complete record header (a README quoting
/// `NPTS=… DT=` must never abort the folder).
const DOC_EXTENSIONS: [&str; 16] = [
    "md", "txt", "rst", "pdf", "json", "geojson", "html", "htm", "doc", "docx", "xls", "xlsx",
    "png", "jpg", "jpeg", "toml",
];

/// Bytes of the head used for content sniffing (every header structure
/// checked fits: SMC 17 lines, COSMOS ~15, CSMIP ≤ 40, AT2 ≤ 12 + data).
pub const SNIFF_BYTES: usize = 16 * 1024;

/// Guesses a file's format from its name and first bytes.  `None` means "not
/// a record file" (README, event.json, V3 spectra…); [`classify`] says why.
pub fn sniff(name: &str, head: &[u8]) -> Option<Format> {
    classify(name, head).format()
}

/// Decides whether a file is a record file, and in which format, from its
/// name and first bytes.  The extension decides among record formats; a
/// file without a record extension is a record only when its content holds
/// the format's complete header structure (content sniffing decides between
/// record formats, it never makes a text file fatal).  Everything else is
/// skipped with its reason: velocity, displacement and spectra products,
/// documentation, unknown files.
pub fn classify(name: &str, head: &[u8]) -> Sniffed {
    let base = base_name(name);
    let lower = base.to_ascii_lowercase();
    let ext = if lower.contains('.') {
        lower.rsplit('.').next().unwrap_or("")
    } else {
        ""
    };
    let skip = |reason: &str| Sniffed::Skip(reason.to_string());
    if head.starts_with(b"\x89MCAP") {
        return Sniffed::Record(Format::Mcap);
    }
    let text = String::from_utf8_lossy(&head[..head.len().min(SNIFF_BYTES)]);
    // A head cut inside a line: that last partial line is not judged.
    let mut lines: Vec<&str> = text
        .split('\n')
        .map(|l| l.strip_suffix('\r').unwrap_or(l))
        .collect();
    if head.len() > SNIFF_BYTES || !text.ends_with('\n') {
        lines.pop();
    }
    let first_line = lines.first().map(|l| l.trim()).unwrap_or("");
    let first = first_line.to_ascii_lowercase();

    if ext == "xml" || text.contains("<FDSNStationXML") {
        return if text.contains("<FDSNStationXML") {
            Sniffed::Record(Format::StationXml)
        } else {
            skip("XML file that is not FDSN StationXML")
        };
    }
    // Spectra products by extension (USGS NSMP `_f.fs1`, `_r.rs2`; COSMOS V3).
    let digits_after = |p: &str| {
        ext.strip_prefix(p)
            .is_some_and(|d| !d.is_empty() && d.chars().all(|c| c.is_ascii_digit()))
    };
    if digits_after("fs") {
        return Sniffed::Skip(format!("Fourier amplitude spectrum (.{ext})"));
    }
    if digits_after("rs") {
        return Sniffed::Skip(format!("response spectrum (.{ext})"));
    }
    match ext {
        "at2" => return Sniffed::Record(Format::At2),
        "smc" => {
            // The first line names the product (`2 CORRECTED ACCELEROGRAM`,
            // `4 DISPLACEMENT`); a damaged `.smc` is an error from the
            // reader, not a silent skip.
            return smc_product(&first).map_or(Sniffed::Record(Format::Smc), smc_verdict);
        }
        "sac" => return Sniffed::Record(Format::Sac),
        "mseed" | "miniseed" => return Sniffed::Record(Format::MiniSeed),
        "csv" | "tsv" => return Sniffed::Record(Format::Csv),
        "v1a" | "v2a" => return Sniffed::Record(Format::GeoNet),
        "v0c" | "v1c" | "v2c" => {
            return cosmos_product_skip(&first).unwrap_or(Sniffed::Record(Format::Cosmos))
        }
        "v3c" => return skip("COSMOS V3 spectra (no acceleration series)"),
        "v3" => return skip(
            "CSMIP V3 spectra (response and Fourier spectra; the acceleration is read from the V2)",
        ),
        "mcap" => return Sniffed::Record(Format::Mcap),
        "v1" | "v2" => {
            if first.starts_with("response and fourier") {
                return skip("CSMIP V3 spectra (response and Fourier spectra; the acceleration is read from the V2)");
            }
            return if text.contains("COSMOS") || first.contains("(format v") {
                cosmos_product_skip(&first).unwrap_or(Sniffed::Record(Format::Cosmos))
            } else {
                Sniffed::Record(Format::Dmg)
            };
        }
        _ => {}
    }

    // Content sniffing: the first line names the format, and the rest of the
    // header must have that format's structure.
    if let Some(v) = smc_volume(&first) {
        if smc_int_header_complete(&lines) {
            return smc_verdict(v);
        }
    }
    if first.contains("(format v") && cosmos_header_complete(&lines) {
        return cosmos_product_skip(&first).unwrap_or(Sniffed::Record(Format::Cosmos));
    }
    if first.contains("gns science")
        && first.contains("accelerogram")
        && geonet::header_complete(&lines)
    {
        return Sniffed::Record(Format::GeoNet);
    }
    if first.starts_with("response and fourier") && dmg::header_complete(&lines) {
        return skip(
            "CSMIP V3 spectra (response and Fourier spectra; the acceleration is read from the V2)",
        );
    }
    if (first.starts_with("corrected accelerogram")
        || first.starts_with("uncorrected accelerogram"))
        && dmg::header_complete(&lines)
    {
        return Sniffed::Record(Format::Dmg);
    }
    if at2::header_complete(&lines) {
        return Sniffed::Record(Format::At2);
    }
    if DOC_EXTENSIONS.contains(&ext) {
        return Sniffed::Skip(format!(
            "documentation or metadata file (.{ext}) without a record header"
        ));
    }
    if mseed::looks_like(head) {
        return Sniffed::Record(Format::MiniSeed);
    }
    if sac::looks_like(head) {
        return Sniffed::Record(Format::Sac);
    }
    // Text: no control bytes other than tab, line ends, form feed and the
    // DOS end-of-file byte old CDMG files are padded with.
    let sample = &head[..head.len().min(SNIFF_BYTES)];
    let binary = sample
        .iter()
        .any(|&b| b < 0x09 || (0x0e..0x20).contains(&b) && b != 0x1a || b == 0x7f);
    if binary {
        skip("not a record file (unknown binary format)")
    } else {
        skip("text file without a record header")
    }
}

/// [`classify`] plus the one decision that needs the other files of the
/// folder: an uncorrected CSMIP V1 (`CHAN001.V1`) or COSMOS V1/V0
/// (`….V1c`, `….V0c`) beside the corrected V2 of the same name holds the
/// same channel, so it is skipped as a duplicate and the V2 is read.  A V1
/// without its V2 is read.  `path` and `folder` are full names (zip members
/// as `a.zip:dir/CHAN001.V1`), compared case-insensitively.
pub fn classify_in_folder(path: &str, head: &[u8], folder: &[String]) -> Sniffed {
    let verdict = classify(path, head);
    if !matches!(verdict, Sniffed::Record(Format::Dmg | Format::Cosmos)) {
        return verdict;
    }
    let lower = path.to_ascii_lowercase();
    let Some((stem, ext)) = lower.rsplit_once('.') else {
        return verdict;
    };
    let better: &[&str] = match ext {
        "v1" => &["v2"],
        "v1c" => &["v2c"],
        "v0c" => &["v2c", "v1c"],
        "v0" => &["v2", "v1"],
        _ => return verdict,
    };
    for b in better {
        let want = format!("{stem}.{b}");
        if let Some(other) = folder.iter().find(|n| n.to_ascii_lowercase() == want) {
            let what = if ext.starts_with("v0") {
                "raw V0"
            } else {
                "uncorrected V1"
            };
            return Sniffed::Skip(format!(
                "{what} duplicate of the corrected {} of the same channel (which is read)",
                base_name(other)
            ));
        }
    }
    verdict
}

/// Last component of a path or zip member name (`a.zip:dir/x.V2` → `x.V2`).
fn base_name(name: &str) -> &str {
    name.rsplit([':', '/', '\\']).next().unwrap_or(name)
}

/// SMC volume number from the first line (`2 CORRECTED ACCELEROGRAM`,
/// `3 VELOCITY`, `4 DISPLACEMENT`, `5 RESPONSE SPECTRA`): the digit and a
/// label that agrees with it.
fn smc_volume(first_lower: &str) -> Option<u8> {
    let (num, label) = first_lower.split_once(char::is_whitespace)?;
    let v: u8 = num.parse().ok()?;
    let label = label.trim();
    let ok = match v {
        1 => label.starts_with("uncorrected accelerogram"),
        2 => label.starts_with("corrected accelerogram"),
        3 => label.contains("velocity"),
        4 => label.contains("displacement"),
        5 => label.contains("spectr"),
        _ => false,
    };
    ok.then_some(v)
}

/// SMC product named by the first line of a `.smc` file, by its words
/// (the volume digit is not always present in NSMP products).
fn smc_product(first_lower: &str) -> Option<u8> {
    smc_volume(first_lower).or_else(|| {
        if first_lower.contains("velocity") {
            Some(3)
        } else if first_lower.contains("displacement") {
            Some(4)
        } else if first_lower.contains("spectr") {
            Some(5)
        } else {
            None
        }
    })
}

fn smc_verdict(volume: u8) -> Sniffed {
    match volume {
        1 | 2 => Sniffed::Record(Format::Smc),
        3 => Sniffed::Skip("SMC velocity series (only acceleration is read)".into()),
        4 => Sniffed::Skip("SMC displacement series (only acceleration is read)".into()),
        _ => Sniffed::Skip("SMC response spectra (no acceleration series)".into()),
    }
}

/// SMC structure after the first line: 11 text lines, then 6 lines of
/// 8I10 integers.
fn smc_int_header_complete(lines: &[&str]) -> bool {
    lines.len() > 17
        && lines[11..17].iter().all(|l| {
            let f = textfmt::fixed_fields(l, 10, 8);
            f.len() == 8 && f.iter().all(|x| textfmt::parse_int(x).is_some())
        })
}

/// COSMOS structure: `(Format v01.20 with 13 text lines)` and the
/// `… Integer-header values follow …` line right after those text lines.
fn cosmos_header_complete(lines: &[&str]) -> bool {
    let first = lines
        .first()
        .map(|l| l.to_ascii_lowercase())
        .unwrap_or_default();
    let Some(p) = first.find("(format v") else {
        return false;
    };
    let Some(n) = textfmt::number_after(&first[p..], "with").filter(|n| (3.0..=100.0).contains(n))
    else {
        return false;
    };
    lines.get(n as usize).is_some_and(|l| {
        l.to_ascii_lowercase()
            .contains("integer-header values follow")
    })
}

/// COSMOS products that are not acceleration series, from the first line
/// (`Corrected velocity (Format v01.20 …)`).
fn cosmos_product_skip(first_lower: &str) -> Option<Sniffed> {
    let label = first_lower.split("(format").next().unwrap_or(first_lower);
    let reason = if label.contains("velocity") {
        "COSMOS velocity series (only acceleration is read)"
    } else if label.contains("displacement") {
        "COSMOS displacement series (only acceleration is read)"
    } else if label.contains("spectr") {
        "COSMOS spectra (no acceleration series)"
    } else {
        return None;
    };
    Some(Sniffed::Skip(reason.into()))
}

/// Reads one file's bytes in the given format.
pub fn read(
    format: Format,
    bytes: &[u8],
    source: &SourceRef,
    opts: &ReadOptions,
) -> Result<FileContents> {
    match format {
        Format::Cosmos => cosmos::read(bytes, source, opts),
        Format::Dmg => dmg::read(bytes, source, opts),
        Format::Smc => smc::read(bytes, source, opts),
        Format::At2 => at2::read(bytes, source, opts),
        Format::MiniSeed => mseed::read(bytes, source, opts),
        Format::Sac => sac::read(bytes, source, opts),
        Format::GeoNet => geonet::read(bytes, source, opts),
        Format::Csv => csv::read(bytes, source, opts),
        Format::Mcap => mcap::read(bytes, source, opts),
        Format::StationXml => Err(Error::input(
            location(source),
            "StationXML holds metadata, not samples: it is applied to the MiniSEED channels of the same folder",
        )),
    }
}

/// Builds the `Location` of an error in `source`.
pub fn location(source: &SourceRef) -> Location {
    let mut l = Location::file(&source.file);
    l.member = source.member.clone();
    l
}
