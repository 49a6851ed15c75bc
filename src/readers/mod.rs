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
pub mod dmg;
pub mod geonet;
pub mod mcap;
pub mod mseed;
pub mod sac;
pub mod smc;
pub mod stationxml;
mod textfmt;

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

/// Guesses a file's format from its name and first bytes.  `None` means "not
/// a record file" (README, event.json, V3 spectra…), which the event folder
/// lists as skipped rather than failing.
pub fn sniff(name: &str, head: &[u8]) -> Option<Format> {
    let lower = name.to_ascii_lowercase();
    let ext = lower.rsplit('.').next().unwrap_or("");
    if head.starts_with(b"\x89MCAP") {
        return Some(Format::Mcap);
    }
    let text_head = String::from_utf8_lossy(&head[..head.len().min(4096)]);
    if ext == "xml" || text_head.contains("<FDSNStationXML") {
        return text_head
            .contains("<FDSNStationXML")
            .then_some(Format::StationXml);
    }
    match ext {
        "at2" => return Some(Format::At2),
        "smc" => return Some(Format::Smc),
        "sac" => return Some(Format::Sac),
        "mseed" | "miniseed" => return Some(Format::MiniSeed),
        "csv" | "tsv" => return Some(Format::Csv),
        "v1a" | "v2a" => return Some(Format::GeoNet),
        "v0c" | "v1c" | "v2c" => return Some(Format::Cosmos),
        "mcap" => return Some(Format::Mcap),
        _ => {}
    }
    // Text strong-motion formats recognised by their first line (COSMOS
    // "(Format v01.20 with 13 text lines)", GeoNet "… GNS Science", SMC
    // "2 CORRECTED ACCELEROGRAM", CSMIP "CORRECTED ACCELEROGRAM …"); CSMIP V3
    // spectra ("RESPONSE AND FOURIER …") stay unrecognised: they hold no records.
    let first_line = text_head
        .lines()
        .next()
        .unwrap_or("")
        .trim()
        .to_ascii_lowercase();
    if first_line.contains("(format v") {
        return Some(Format::Cosmos);
    }
    if first_line.contains("gns science") && first_line.contains("accelerogram") {
        return Some(Format::GeoNet);
    }
    if first_line == "1 uncorrected accelerogram" || first_line == "2 corrected accelerogram" {
        return Some(Format::Smc);
    }
    if ext == "v1" || ext == "v2" {
        return Some(if text_head.contains("COSMOS") {
            Format::Cosmos
        } else {
            Format::Dmg
        });
    }
    if first_line.starts_with("corrected accelerogram")
        || first_line.starts_with("uncorrected accelerogram")
    {
        return Some(Format::Dmg);
    }
    if text_head.contains("NPTS=") && text_head.contains("DT=") {
        return Some(Format::At2);
    }
    if mseed::looks_like(head) {
        return Some(Format::MiniSeed);
    }
    if sac::looks_like(head) {
        return Some(Format::Sac);
    }
    None
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
