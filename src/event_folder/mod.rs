//! Event folder → `Event`: finds the files (directory or zip, nested zips),
//! reads the optional `event.toml` manifest, dispatches each file to its
//! reader, applies StationXML and manifest metadata, and says what was
//! inferred and what later stages will miss.  See docs/event-folder.md.

mod archive;
pub mod init;
pub mod lab;
pub mod lengths;
pub mod manifest;
mod referenced;
pub mod structure;

use std::collections::BTreeMap;
use std::path::Path;

pub use archive::{
    collect, zip_is_whole, ArchiveLimits, EventFile, HEAD_BYTES, RATIO_GRACE_BYTES,
    READ_LATER_ABOVE, RELATIVE_FLOOR_BYTES,
};
pub use manifest::{
    ChannelEntry, ColumnRef, DirectionEntry, FormatEntry, Manifest, RoleEntry, UnitsEntry,
};
pub use referenced::{ReferencedFiles, MAX_REFERENCED_BYTES};

use crate::error::{Error, Location, Result};
use crate::readers::{self, FileContents, FileSpectrum, Format, ReadOptions};
use crate::vocab::{Direction, Event, Record, Role, SourceRef, Units};

/// Name of the manifest at the root of an event folder or zip.
pub const MANIFEST_NAME: &str = "event.toml";

/// What happened to one file of the folder.
#[derive(Debug, Clone)]
pub struct FileReport {
    pub name: String,
    pub format: Option<&'static str>,
    /// Number of channels read from it.
    pub channels: usize,
    /// Why it was skipped, when it was.
    pub skipped: Option<String>,
}

/// An ingested event plus the account of how it was read.
#[derive(Debug, Clone)]
pub struct LoadedEvent {
    pub event: Event,
    pub files: Vec<FileReport>,
    /// Spectra stated by the files (V3), for cross-checks.
    pub file_spectra: Vec<FileSpectrum>,
    pub manifest: Option<Manifest>,
    /// The building geometry applied (axes, rotations, floor combinations).
    pub geometry: crate::geometry::GeometryReport,
}

/// The lock file of a run's output directory (`pipeline::lock` creates it).
/// Named here, below the pipeline, because the event folder's reader must
/// recognise an output directory (see [`is_run_directory`]).
pub const RUN_LOCK_FILE: &str = ".quaketwin.lock";
/// The run manifest of an output directory (`pipeline::manifest` writes it).
pub const RUN_MANIFEST_FILE: &str = "run.json";

/// Whether `dir` is a quaketwin output directory — it holds a run's lock
/// file or its run manifest.  Such a folder inside an event folder (`--out`
/// placed there) is not part of the event: neither read as records nor
/// counted in the event's fingerprint, so a re-run finds the event unchanged.
pub fn is_run_directory(dir: &Path) -> bool {
    [RUN_LOCK_FILE, RUN_MANIFEST_FILE]
        .iter()
        .any(|marker| std::fs::symlink_metadata(dir.join(marker)).is_ok_and(|m| m.is_file()))
}

/// Loads the event at `path` (directory or zip).
pub fn load(path: &Path) -> Result<LoadedEvent> {
    load_with_limits(path, &ArchiveLimits::default())
}

pub fn load_with_limits(path: &Path, limits: &ArchiveLimits) -> Result<LoadedEvent> {
    load_parking(path, limits, &mut |_| Ok(()))
}

/// Loads the event at `path` for **listing** it (`quaketwin inspect`): every
/// file is read and checked as for a run, but each record's samples are let
/// go as soon as its file is read, so listing an event holds one file at a
/// time, never the event (issue 14 item 3: a day of 64 channels is 8.8 GB of
/// samples).  What the listing reports — counts, rates, times, units, QA
/// flags the readers set, the geometry decided — does not depend on sample
/// values; rotations and floor combinations still run on the let-go samples
/// (which read as zeros) so the records keep their shapes.  Never use the
/// returned records' values.
pub fn load_listing(path: &Path) -> Result<LoadedEvent> {
    let store: std::sync::Arc<dyn crate::vocab::SampleStore> = std::sync::Arc::new(LetGo);
    let mut loaded = load_parking(path, &ArchiveLimits::default(), &mut |rec| {
        rec.samples
            .park(&store)
            .map_err(|e| Error::io(store.describe(), e))
    })?;
    // Records the geometry made (rotated pairs, floor combinations) are in
    // memory: let them go too.
    for rec in &mut loaded.event.records {
        rec.samples
            .park(&store)
            .map_err(|e| Error::io(store.describe(), e))?;
    }
    Ok(loaded)
}

/// The sample store of [`load_listing`]: keeps nothing, reads back zeros.
struct LetGo;

impl crate::vocab::SampleStore for LetGo {
    fn put(&self, _values: &[f64]) -> std::io::Result<u64> {
        Ok(0)
    }
    fn get(&self, _position: u64, _offset: usize, out: &mut [f64]) -> std::io::Result<()> {
        out.fill(0.0);
        Ok(())
    }
    fn describe(&self) -> String {
        "nowhere (the event is being listed: samples are not kept)".into()
    }
}

/// As [`load_with_limits`], handing each record to `park` as soon as its
/// file is read (a pipeline run parks a big event's samples there, so the
/// files are read in the memory of one: issue 14 item 5).
pub fn load_parking(
    path: &Path,
    limits: &ArchiveLimits,
    park: &mut dyn FnMut(&mut Record) -> Result<()>,
) -> Result<LoadedEvent> {
    let mut loaded = load_as_stated(path, limits, park)?;
    loaded.geometry = crate::geometry::apply_building_geometry(&mut loaded.event)?;
    Ok(loaded)
}

/// The event as the files and the manifest state it, with what was
/// inferred from the headers (levels, roles, structure) but **before** the
/// building geometry: channels keep the directions their headers give
/// (what `quaketwin init` writes).  Samples are let go as in
/// [`load_listing`].
pub fn load_headers(path: &Path) -> Result<LoadedEvent> {
    let store: std::sync::Arc<dyn crate::vocab::SampleStore> = std::sync::Arc::new(LetGo);
    load_as_stated(path, &ArchiveLimits::default(), &mut |rec| {
        rec.samples
            .park(&store)
            .map_err(|e| Error::io(store.describe(), e))
    })
}

fn load_as_stated(
    path: &Path,
    limits: &ArchiveLimits,
    park: &mut dyn FnMut(&mut Record) -> Result<()>,
) -> Result<LoadedEvent> {
    let files = collect(path, limits)?;
    let manifest_file = files.iter().find(|f| is_manifest(f));
    let manifest = manifest_file.map(parse_manifest).transpose()?;
    // Where the manifest is, as errors name it (the zip's name included).
    let manifest_name = manifest_file
        .map(|f| f.display_name())
        .unwrap_or_else(|| MANIFEST_NAME.into());
    let default_name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "event".to_string());

    let mut reports = Vec::new();
    let mut spectra = Vec::new();
    let mut records: Vec<Record> = Vec::new();
    let mut hints = Vec::new();
    let mut history_notes = Vec::new();

    let listed_channels = manifest
        .as_ref()
        .map(|m| !m.channels.is_empty())
        .unwrap_or(false);
    if listed_channels {
        let m = manifest.as_ref().expect("checked above"); // ok: listed_channels implies Some
                                                           // Group entries by file, keeping manifest order within a file.
                                                           // With each entry its place in the manifest (records keep that order).
        let mut by_file: BTreeMap<String, Vec<(usize, &ChannelEntry)>> = BTreeMap::new();
        for (order, c) in m.channels.iter().enumerate() {
            by_file
                .entry(normalise_name(&c.file))
                .or_default()
                .push((order, c));
        }
        // The event's files by the names a manifest may use (one lookup per
        // file named, not a scan of the folder each).
        let mut by_name: std::collections::HashMap<String, &EventFile> =
            std::collections::HashMap::new();
        for f in files.iter().rev() {
            // Reversed: the first file under a name wins, as a scan would.
            by_name.insert(strip_root(f), f);
            by_name.insert(normalise_name(&f.display_name()), f);
        }
        let mut picked: Vec<(usize, Record)> = Vec::new();
        for (name, placed) in &by_file {
            let entries: Vec<&ChannelEntry> = placed.iter().map(|p| p.1).collect();
            let Some(&file) = by_name.get(name) else {
                let first = entries[0];
                return Err(Error::input(
                    Location::file(&manifest_name)
                        .with_channel(first.id.clone().unwrap_or_default()),
                    format!(
                        "file {:?} named by the manifest is not in the event folder",
                        first.file
                    ),
                ));
            };
            let format = match entries.iter().find_map(|e| e.format) {
                Some(f) => f.0,
                None => match readers::classify(file.base_name(), &file.head) {
                    readers::Sniffed::Record(f) => f,
                    readers::Sniffed::Skip(reason) => {
                        return Err(Error::input(
                            file.location(),
                            format!("not read as a record: {reason}; set `format` in the manifest if it is one"),
                        ))
                    }
                },
            };
            let opts = ReadOptions {
                sampling_rate_hz: entries.iter().find_map(|e| e.sampling_rate_hz),
                columns: if format == Format::Csv && entries.iter().all(|e| e.column.is_some()) {
                    Some(
                        entries
                            .iter()
                            .filter_map(|e| e.column.as_ref().map(|c| c.as_string()))
                            .collect(),
                    )
                } else {
                    None
                },
                time_column: entries.iter().find_map(|e| e.time_column.clone()),
            };
            let contents = read_file(file, format, &opts)?;
            reports.push(FileReport {
                name: file.display_name(),
                format: Some(format.name()),
                channels: entries.len(),
                skipped: None,
            });
            spectra.extend(contents.spectra.iter().cloned());
            hints.push(contents.event.clone());
            // The CSV reader returns one record per requested column, in
            // the order asked: the k-th record is the k-th entry's.  Matching
            // by name instead fails for an index (`column = 2`) or a name
            // without its unit suffix (`acc_x` for `acc_x [g]`).
            let mut picks: Vec<Result<usize>> = entries
                .iter()
                .enumerate()
                .map(|(k, entry)| match &opts.columns {
                    Some(cols) if contents.records.len() == cols.len() => Ok(k),
                    _ => pick_record(&contents, entry, file),
                })
                .collect();
            let mut slots: Vec<Option<Record>> = contents.records.into_iter().map(Some).collect();
            // The last entry naming each record takes it; earlier ones copy it.
            let mut last_use = vec![usize::MAX; slots.len()];
            for (k, p) in picks.iter().enumerate() {
                if let Ok(i) = p {
                    last_use[*i] = k;
                }
            }
            for (k, (order, entry)) in placed.iter().enumerate() {
                let i = std::mem::replace(&mut picks[k], Ok(usize::MAX))?;
                let shared = last_use[i] != k;
                let rec = match (shared, slots[i].as_ref()) {
                    (true, Some(r)) => r.clone(),
                    _ => slots[i].take().ok_or_else(|| {
                        Error::input(file.location(), "record already taken (internal error)")
                    })?,
                };
                let order = *order;
                let mut rec = apply_entry(rec, entry, &mut history_notes, file)?;
                park(&mut rec)?;
                picked.push((order, rec));
            }
        }
        picked.sort_by_key(|(order, _)| *order);
        records = picked.into_iter().map(|(_, r)| r).collect();
    } else {
        // All names, so an uncorrected V1 beside its corrected V2 is skipped.
        let names: Vec<String> = files.iter().map(|f| f.display_name()).collect();
        let heads: Vec<(String, &[u8])> = files
            .iter()
            .map(|f| (f.display_name(), f.head.as_slice()))
            .collect();
        let smc_duplicates = readers::smc::uncorrected_duplicates(&heads);
        let mut unreadable_csv: Option<Error> = None;
        for file in &files {
            if is_manifest(file) {
                continue;
            }
            let verdict = match smc_duplicates.get(&file.display_name()) {
                Some(v2) => readers::Sniffed::Skip(format!(
                    "uncorrected SMC V1 duplicate of the corrected {v2} of the same channel (which is read)"
                )),
                None => readers::classify_in_folder(&file.display_name(), &file.head, &names),
            };
            let format = match verdict {
                readers::Sniffed::Record(f) => f,
                readers::Sniffed::Skip(reason) => {
                    reports.push(FileReport {
                        name: file.display_name(),
                        format: None,
                        channels: 0,
                        skipped: Some(reason),
                    });
                    continue;
                }
            };
            if format == Format::StationXml {
                reports.push(FileReport {
                    name: file.display_name(),
                    format: Some(format.name()),
                    channels: 0,
                    skipped: Some("metadata (applied to matching channels)".into()),
                });
                continue;
            }
            let contents = match read_file(file, format, &ReadOptions::default()) {
                // A CSV beside the records is often station information,
                // not a record: skipped with the reader's reason (fatal
                // only when the folder has no other record).
                Err(e) if format == Format::Csv => {
                    reports.push(FileReport {
                        name: file.display_name(),
                        format: None,
                        channels: 0,
                        skipped: Some(format!("CSV file that is not a record ({e})")),
                    });
                    unreadable_csv.get_or_insert(e);
                    continue;
                }
                other => other?,
            };
            reports.push(FileReport {
                name: file.display_name(),
                format: Some(format.name()),
                channels: contents.records.len(),
                skipped: None,
            });
            spectra.extend(contents.spectra.iter().cloned());
            hints.push(contents.event.clone());
            for mut rec in contents.records {
                park(&mut rec)?;
                records.push(rec);
            }
        }
        if let (true, Some(e)) = (records.is_empty(), unreadable_csv) {
            return Err(e);
        }
    }

    // StationXML metadata for SEED-named channels (MiniSEED).
    let mut station_meta = Vec::new();
    for f in files
        .iter()
        .filter(|f| readers::sniff(f.base_name(), &f.head) == Some(Format::StationXml))
    {
        let source = SourceRef {
            file: f.file.clone(),
            member: f.member.clone(),
            column: None,
            format: "stationxml".into(),
        };
        station_meta.extend(readers::stationxml::parse(&f.content()?, &source)?);
    }
    if !station_meta.is_empty() {
        readers::stationxml::apply(&mut records, &station_meta);
    }

    // Channels of one recorder a few samples apart: one common window.
    let (trimmed, trim_notes) = lengths::trim_near_equal_lengths(&mut records);
    for i in trimmed {
        park(&mut records[i])?;
    }
    let mut event = Event {
        name: default_name,
        ..Default::default()
    };
    if let Some(m) = &manifest {
        if let Some(n) = &m.event.name {
            event.name = n.clone();
        }
        if let Some(t) = &m.event.origin_time {
            let bad = || {
                Error::input(
                    Location::file(&manifest_name),
                    format!(
                        "event.origin_time {t:?} is not an ISO-8601 UTC time in the years {}–{}",
                        manifest::ORIGIN_YEARS.start(),
                        manifest::ORIGIN_YEARS.end()
                    ),
                )
            };
            let year = t
                .trim()
                .split('-')
                .next()
                .and_then(|y| y.parse::<i64>().ok());
            if !year.is_some_and(|y| manifest::ORIGIN_YEARS.contains(&y)) {
                return Err(bad());
            }
            event.origin_ns = Some(crate::vocab::parse_iso8601_ns(t).ok_or_else(bad)?);
        }
        event.magnitude = m.event.magnitude;
        event.hypocentre = m
            .event
            .latitude_deg
            .zip(m.event.longitude_deg)
            .map(|(lat, lon)| crate::vocab::Hypocentre {
                latitude_deg: lat,
                longitude_deg: lon,
                depth_km: m.event.depth_km,
            });
        event.structure = m.structure.as_ref().map(|s| s.to_structure());
    }
    if manifest
        .as_ref()
        .and_then(|m| m.event.name.as_ref())
        .is_none()
    {
        if let Some(n) = hints.iter().find_map(|h| h.name.clone()) {
            event.name = n;
        }
    }
    event.origin_ns = event
        .origin_ns
        .or_else(|| hints.iter().find_map(|h| h.origin_ns));
    event.magnitude = event
        .magnitude
        .or_else(|| hints.iter().find_map(|h| h.magnitude));
    for (step, params) in history_notes {
        event.history.push(step, params);
    }
    event.records = records;
    // Levels, ids with the location and the structure from the headers.
    let mut facts = structure::HeaderFacts::default();
    for h in &hints {
        if let Some(n) = h
            .station_name
            .as_ref()
            .filter(|n| !facts.station_names.contains(n))
        {
            facts.station_names.push(n.clone());
        }
        if let Some(k) = h
            .structure_kind
            .as_ref()
            .filter(|k| !facts.stated_kinds.contains(k))
        {
            facts.stated_kinds.push(k.clone());
        }
    }
    let structure_notes = structure::infer_structure(&mut event, &facts, !listed_channels);
    header_positions(&mut event, &hints);
    make_ids_unique(&mut event.records);
    event.notes.extend(trim_notes);
    event.notes.extend(structure_notes);
    infer_and_report_missing(&mut event, manifest.is_some());
    if event.records.is_empty() {
        return Err(Error::input(
            Location::file(path.display().to_string()),
            "no record files found in the event",
        ));
    }
    Ok(LoadedEvent {
        event,
        files: reports,
        file_spectra: spectra,
        manifest,
        geometry: Default::default(),
    })
}

/// The epicentre from the headers where the manifest states none, and the
/// recording station's position the headers state (the structure's own
/// position stays what the manifest states).
fn header_positions(event: &mut Event, hints: &[crate::readers::EventHints]) {
    if event.hypocentre.is_none() {
        event.hypocentre = hints.iter().find_map(|h| {
            let (lat, lon, depth) = h.hypocenter?;
            ((-90.0..=90.0).contains(&lat) && (-180.0..=180.0).contains(&lon)).then_some(
                crate::vocab::Hypocentre {
                    latitude_deg: lat,
                    longitude_deg: lon,
                    depth_km: Some(depth).filter(|d| d.is_finite()),
                },
            )
        });
    }
    event.station_position = hints
        .iter()
        .find_map(|h| h.station_position)
        .map(|(lat, lon)| [lat, lon]);
}

fn parse_manifest(f: &EventFile) -> Result<Manifest> {
    // Its size before its content: a 1 GiB `event.toml` is never read.
    if f.len() > manifest::MAX_MANIFEST_BYTES {
        return Err(Error::input(
            f.location(),
            format!(
                "event manifest of {} bytes: larger than the limit of {} bytes",
                f.len(),
                manifest::MAX_MANIFEST_BYTES
            ),
        ));
    }
    let bytes = f.content()?;
    let text = std::str::from_utf8(&bytes)
        .map_err(|e| Error::input(f.location(), format!("manifest is not UTF-8: {e}")))?;
    Manifest::parse(text, &f.display_name())
}

/// The manifest (`event.toml`) of the event at `path`, without reading its
/// records (big files are only listed): what naming an event needs — the
/// structure of the many-event layout's partition.
pub fn read_manifest(path: &Path) -> Result<Option<Manifest>> {
    let files = collect(path, &ArchiveLimits::default())?;
    files
        .iter()
        .find(|f| is_manifest(f))
        .map(parse_manifest)
        .transpose()
}

fn is_manifest(f: &EventFile) -> bool {
    match &f.member {
        None => f.file == MANIFEST_NAME,
        // A zip given as the event: the manifest sits at the zip's root.
        Some(m) => m == MANIFEST_NAME,
    }
}

fn normalise_name(s: &str) -> String {
    s.trim().trim_start_matches("./").replace('\\', "/")
}

/// For a zip given as the event, manifest paths are relative to the zip's root.
fn strip_root(f: &EventFile) -> String {
    f.member.clone().unwrap_or_else(|| f.file.clone())
}

fn read_file(file: &EventFile, format: Format, opts: &ReadOptions) -> Result<FileContents> {
    let source = SourceRef {
        file: file.file.clone(),
        member: file.member.clone(),
        column: None,
        format: format.name().into(),
    };
    // A size the format cannot hold is refused before the bytes are read or
    // inflated (a 1 GiB "AT2" member within the zip budgets held 1 GiB).
    if let Some(most) = format.max_file_bytes().filter(|&m| file.len() > m) {
        return Err(Error::input(
            file.location(),
            format!(
                "{} bytes: more than the {most} bytes a {} record can hold",
                file.len(),
                format.name()
            ),
        ));
    }
    let contents = readers::read(format, &file.content()?, &source, opts)?;
    for r in &contents.records {
        if !(r.channel.sampling_rate_hz.is_finite() && r.channel.sampling_rate_hz > 0.0) {
            return Err(Error::input(
                file.location().with_channel(r.channel.id.clone()),
                "no valid sampling rate (give `sampling_rate_hz` in the manifest)",
            ));
        }
        if r.samples.is_empty() {
            return Err(Error::input(
                file.location().with_channel(r.channel.id.clone()),
                "channel has no samples",
            ));
        }
    }
    Ok(contents)
}

/// The index of the record a manifest entry designates in a file.
fn pick_record(contents: &FileContents, entry: &ChannelEntry, file: &EventFile) -> Result<usize> {
    let recs = &contents.records;
    let err = |msg: String| {
        Error::input(
            file.location()
                .with_channel(entry.id.clone().unwrap_or_default()),
            msg,
        )
    };
    match &entry.column {
        None if recs.len() == 1 => Ok(0),
        None => Err(err(format!(
            "file holds {} channels ({}); say which with `column`",
            recs.len(),
            recs.iter()
                .map(|r| r.channel.id.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ))),
        Some(col) => {
            let by_name = |name: &str| {
                recs.iter().position(|r| {
                    r.channel.source.column.as_deref() == Some(name)
                        || r.channel.id == name
                        || r.channel.channel_code.as_deref() == Some(name)
                        || r.channel.location_code.as_deref() == Some(name)
                })
            };
            let found = match col {
                ColumnRef::Name(n) => by_name(n),
                ColumnRef::Index(i) => {
                    by_name(&i.to_string()).or_else(|| (*i < recs.len()).then_some(*i))
                }
            };
            found.ok_or_else(|| {
                err(format!(
                    "column {:?} not found; the file has {}",
                    col.as_string(),
                    recs.iter()
                        .map(|r| r
                            .channel
                            .source
                            .column
                            .clone()
                            .unwrap_or_else(|| r.channel.id.clone()))
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            })
        }
    }
}

/// Applies what the manifest states over what the header said.
fn apply_entry(
    mut rec: Record,
    entry: &ChannelEntry,
    history: &mut Vec<(String, serde_json::Value)>,
    file: &EventFile,
) -> Result<Record> {
    let ch = &mut rec.channel;
    if let Some(id) = &entry.id {
        ch.id = id.clone();
    }
    let err = |msg: String| {
        Error::input(
            file.location()
                .with_channel(entry.id.clone().unwrap_or_default()),
            msg,
        )
    };
    if let Some(level) = entry.level {
        ch.level = Some(level);
    }
    if let Some(d) = entry.direction {
        ch.direction = Some(d.0);
    }
    if let Some(dip) = entry.dip_deg {
        ch.dip_deg = Some(dip);
        if (dip + 90.0).abs() < 1e-6 {
            ch.direction = Some(Direction::Up);
        } else if (dip - 90.0).abs() < 1e-6 {
            ch.direction = Some(Direction::Down);
        } else if dip.abs() > 1e-6 {
            return Err(err(format!(
                "dip_deg {dip}: an inclined sensor is neither horizontal nor vertical; quaketwin reads horizontal (dip 0) and vertical (dip ±90) sensors"
            )));
        }
    }
    if let Some(p) = entry.position_m {
        ch.position_m = Some(p);
    }
    if let Some(r) = entry.role {
        ch.role = r.role();
    }
    if let Some(UnitsEntry { units, written: u }) = &entry.units {
        ch.units = *units;
        ch.missing.retain(|m| m != "units");
        // What the reader assumed about units no longer holds.
        ch.inferred
            .retain(|i| !i.starts_with("units=") && !i.starts_with("units "));
        ch.inferred.push(format!("units {u} from the manifest"));
    }
    if let Some(s) = entry.sensitivity {
        match &mut ch.units {
            Units::Counts { counts_per_si } => *counts_per_si = Some(s),
            _ => {
                return Err(err(
                    "`sensitivity` applies only to units = \"counts\"".into()
                ))
            }
        }
    }
    if let Some(fs) = entry.sampling_rate_hz {
        ch.sampling_rate_hz = fs;
    }
    if let Some(n) = &entry.node {
        ch.node = Some(n.clone());
    }
    if let Some(e) = entry.elevation_m {
        ch.elevation_m = Some(e);
    }
    if let Some(c) = &entry.column {
        ch.source.column = Some(c.as_string());
    }
    if entry.reversed {
        rec.samples.negate();
        history.push((
            "reverse_sign".into(),
            serde_json::json!({ "channel": rec.channel.id, "reason": "manifest: reversed = true" }),
        ));
    }
    Ok(rec)
}

fn make_ids_unique(records: &mut [Record]) {
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    for r in records.iter() {
        *seen.entry(r.channel.id.clone()).or_default() += 1;
    }
    let mut used: BTreeMap<String, usize> = BTreeMap::new();
    for r in records.iter_mut() {
        if seen.get(&r.channel.id).copied().unwrap_or(0) > 1 {
            let n = used.entry(r.channel.id.clone()).or_default();
            *n += 1;
            let new_id = format!("{}#{}", r.channel.id, n);
            r.channel.inferred.push(format!(
                "id {new_id} made unique (duplicate id {} in the folder)",
                r.channel.id
            ));
            r.channel.id = new_id;
        }
    }
}

/// Phrases in a sensor's location text (CSMIP/COSMOS `Location:`) that mark
/// ground or base sensors (role input), checked before the structural words
/// so that "Column at Grnd Level" or "Ground Floor" are base sensors.
const GROUND_WORDS: [&str; 12] = [
    "FREE FIELD",
    "FREEFIELD",
    "FREE-FIELD",
    "GROUND",
    "GRND",
    "BASEMENT",
    "BASE OF",
    "BOTTOM OF",
    "FOOTING",
    "EMBANKMENT",
    "FOUNDATION",
    "PILE CAP",
];

/// Words that mark a structural response sensor (role output): deck, roof,
/// floors and levels of buildings, column tops, girders, spans.
const STRUCTURE_WORDS: [&str; 11] = [
    "DECK",
    "ROOF",
    "FLOOR",
    "LEVEL",
    "STORY",
    "STOREY",
    "TOP OF",
    "GIRDER",
    "SPAN",
    "PENTHOUSE",
    "ATTIC",
];

/// Role read from a sensor's location text, with the word that decided it;
/// `None` when the text names neither ground nor structure.  Public so the
/// modal stage can tell free-field sensors from base sensors.
pub fn role_from_location_text(text: &str) -> Option<(Role, &'static str)> {
    let t = text.to_ascii_uppercase();
    if let Some(w) = GROUND_WORDS.iter().find(|w| t.contains(*w)) {
        return Some((Role::Input, w));
    }
    STRUCTURE_WORDS
        .iter()
        .find(|w| t.contains(*w))
        .map(|w| (Role::Output, *w))
}

/// Whether a location text names a free-field sensor (ground away from the structure).
pub fn is_free_field(text: &str) -> bool {
    let t = text.to_ascii_uppercase();
    GROUND_WORDS[..3].iter().any(|w| t.contains(*w))
}

/// Fills role from level, guesses base sensors from location text (saying
/// so), and lists what later stages will miss.
fn infer_and_report_missing(event: &mut Event, has_manifest: bool) {
    for r in &mut event.records {
        let ch = &mut r.channel;
        if ch.role == Role::Unknown {
            match ch.level {
                Some(0) => {
                    ch.role = Role::Input;
                    ch.inferred.push("role=input from level 0".into());
                }
                Some(l) if l > 0 => {
                    ch.role = Role::Output;
                    ch.inferred.push(format!("role=output from level {l}"));
                }
                _ => {
                    let text = ch.location_text.clone().unwrap_or_default();
                    if let Some((role, w)) = role_from_location_text(&text) {
                        ch.role = role;
                        let what = match role {
                            Role::Input if is_free_field(&text) => "free-field ground sensor",
                            Role::Input => "base/ground sensor",
                            _ => "structural response",
                        };
                        ch.inferred.push(format!(
                            "role={} ({what}) from location text {:?} containing {w:?}; state `role` in event.toml to override",
                            role.name(),
                            text.trim()
                        ));
                    }
                }
            }
        }
        // Drop what readers listed as missing but the manifest has since stated.
        ch.missing.retain(|m| match m.as_str() {
            "level" => ch.level.is_none(),
            "role" => ch.role == Role::Unknown,
            "direction" => ch.direction.is_none(),
            "sensitivity" => matches!(
                ch.units,
                Units::Counts {
                    counts_per_si: None
                }
            ),
            "start_time" => ch.start_ns.is_none(),
            _ => true,
        });
        let mut missing = Vec::new();
        if ch.level.is_none() {
            missing.push("level");
        }
        if ch.role == Role::Unknown {
            missing.push("role");
        }
        if ch.direction.is_none() {
            missing.push("direction");
        }
        if let Units::Counts {
            counts_per_si: None,
        } = ch.units
        {
            missing.push("sensitivity");
        }
        if ch.start_ns.is_none() {
            missing.push("start_time");
        }
        for m in missing {
            if !ch.missing.iter().any(|x| x == m) {
                ch.missing.push(m.to_string());
            }
        }
    }
    if !has_manifest {
        event
            .notes
            .push("no event.toml manifest: channel metadata comes from file headers only".into());
    }
    let has_input = event.records.iter().any(|r| r.channel.role == Role::Input);
    if !has_input {
        event.notes.push("no base (input) channel identified: input–output modal identification and Bouc-Wen identification need one".into());
    }
    match &event.structure {
        None => event.notes.push(
            "no [structure] section, and none inferred from the headers: storey heights (drift ratios) and masses (Bouc-Wen) unknown"
                .into(),
        ),
        Some(s) => {
            if s.storey_heights_m.is_empty() {
                event.notes.push(
                    "storey heights unknown: inter-storey drift ratios will not be computed".into(),
                );
            }
            if s.masses_kg.is_empty() {
                event
                    .notes
                    .push("masses unknown: Bouc-Wen identification needs them (or a twin)".into());
            }
        }
    }
}
