//! Laboratory records in an event folder (issue 37; docs/lab-tests.md):
//! the manifest's `[lab]` section, or — without one — inference from the
//! files (names and the units they state), turned into [`LabRecord`]s in SI.
//! A lab folder holds no acceleration records; `ingest` is not run on it
//! (the `lab_hysteresis` stage reads it through [`load_lab`]).

use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;

use super::manifest::ColumnRef;
use super::{collect, is_manifest, parse_manifest, ArchiveLimits, EventFile};
use crate::error::{Error, Location, Result};
use crate::readers::lab::{read_json, read_mat, read_text, LabTable, MAX_LAB_FILE_BYTES};
use crate::vocab::{lab_units, LabChannel, LabRecord, LabRole, Quantity, SourceRef, TimeBase};

/// Most `[[lab.channel]]` entries.
pub const MAX_LAB_CHANNELS: usize = 256;
/// Time steps accepted, seconds (10 µs to 1 h between samples).
pub const LAB_DT_S: std::ops::RangeInclusive<f64> = 1e-5..=3600.0;
/// Scale factors accepted (a polarity or a gain; beyond, a unit slip).
pub const LAB_SCALE: std::ops::RangeInclusive<f64> = 1e-9..=1e9;

/// `[lab]` of event.toml.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LabSection {
    /// The specimen's name (the record's name in outputs).
    pub specimen: Option<String>,
    /// `quasi-static` (the step index orders the samples) or `dynamic`.
    pub protocol: Option<String>,
    /// The time column (name or index) of the first channel's file.
    pub time_column: Option<ColumnRef>,
    /// Uniform time step, when no time column states the times.
    pub dt_s: Option<f64>,
    #[serde(default, rename = "channel")]
    pub channels: Vec<LabChannelEntry>,
}

/// `[[lab.channel]]`.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LabChannelEntry {
    pub file: String,
    /// Column name or 0-based index; default the file's only column.
    pub column: Option<ColumnRef>,
    pub id: Option<String>,
    /// displacement | force | strain | velocity | acceleration (default from the units).
    pub quantity: Option<String>,
    /// command | measured (default measured).
    pub role: Option<String>,
    /// mm, m, in, kN, N, kip, lb, microstrain, … (docs/lab-tests.md).
    pub units: String,
    /// Actuator or load cell the channel belongs to.
    pub actuator: Option<String>,
    /// Multiplier applied before the unit conversion (−1: reversed polarity).
    pub scale: Option<f64>,
}

impl LabSection {
    /// Checks the section where it is parsed (errors name event.toml and the key).
    pub fn validate(&self, file: &str) -> Result<()> {
        let fail = |msg: String| Err(Error::input(Location::file(file), msg));
        if self.channels.len() > MAX_LAB_CHANNELS {
            return fail(format!(
                "[lab] lists {} channels; at most {MAX_LAB_CHANNELS}",
                self.channels.len()
            ));
        }
        if let Some(p) = &self.protocol {
            if p != "quasi-static" && p != "dynamic" {
                return fail(format!(
                    "lab.protocol = {p:?}: must be \"quasi-static\" or \"dynamic\""
                ));
            }
        }
        if let Some(dt) = self.dt_s {
            if !LAB_DT_S.contains(&dt) {
                return fail(format!(
                    "lab.dt_s = {dt}: must be within {} to {} s",
                    LAB_DT_S.start(),
                    LAB_DT_S.end()
                ));
            }
        }
        for (i, c) in self.channels.iter().enumerate() {
            let name = c.id.clone().unwrap_or_else(|| format!("lab.channel[{i}]"));
            let Some((q, _)) = lab_units(&c.units) else {
                return fail(format!("{name}: units = {:?} unknown (mm, cm, m, in, N, kN, MN, lb, kip, strain, microstrain, mm/s, m/s, in/s, m/s2, g)", c.units));
            };
            if let Some(qs) = &c.quantity {
                match Quantity::parse(qs) {
                    None => {
                        return fail(format!(
                            "{name}: quantity = {qs:?}: must be displacement, force, strain, velocity or acceleration"
                        ))
                    }
                    Some(stated) if stated != q => {
                        return fail(format!(
                            "{name}: units {:?} measure {q}, not the stated quantity {stated}",
                            c.units
                        ))
                    }
                    _ => {}
                }
            }
            if let Some(r) = &c.role {
                if LabRole::parse(r).is_none() {
                    return fail(format!(
                        "{name}: role = {r:?}: must be \"command\" or \"measured\""
                    ));
                }
            }
            if let Some(s) = c.scale {
                if !LAB_SCALE.contains(&s.abs()) {
                    return fail(format!(
                        "{name}: scale = {s}: its magnitude must be within 1e-9 to 1e9"
                    ));
                }
            }
        }
        Ok(())
    }
}

fn read_table(file: &EventFile) -> Result<LabTable> {
    if file.len() > MAX_LAB_FILE_BYTES {
        return Err(Error::input(
            file.location(),
            format!(
                "lab file of {} bytes: larger than the limit of {MAX_LAB_FILE_BYTES} bytes",
                file.len()
            ),
        ));
    }
    let bytes = file.content()?;
    let name = file.base_name().to_ascii_lowercase();
    let stem = file
        .base_name()
        .rsplit_once('.')
        .map_or(file.base_name(), |(s, _)| s)
        .to_string();
    if name.ends_with(".mat") || crate::readers::mat5::looks_like_mat(&bytes) {
        read_mat(&bytes, &file.location())
    } else if name.ends_with(".json") {
        read_json(&bytes, &file.location())
    } else {
        read_text(&bytes, &file.location(), &stem)
    }
}

fn pick<'t>(
    table: &'t LabTable,
    column: Option<&ColumnRef>,
    file: &EventFile,
) -> Result<&'t crate::readers::lab::LabColumn> {
    match column {
        None if table.columns.len() == 1 => Ok(&table.columns[0]),
        None => Err(Error::input(
            file.location(),
            format!(
                "the file has {} columns ({}); name one with `column`",
                table.columns.len(),
                names(table)
            ),
        )),
        Some(ColumnRef::Index(i)) => table.columns.get(*i).ok_or_else(|| {
            Error::input(
                file.location(),
                format!("column {i}: the file has {} columns", table.columns.len()),
            )
        }),
        Some(ColumnRef::Name(n)) => table.column(n).ok_or_else(|| {
            Error::input(
                file.location(),
                format!("no column {n:?} (columns: {})", names(table)),
            )
        }),
    }
}

fn names(t: &LabTable) -> String {
    t.columns
        .iter()
        .map(|c| c.name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

fn source(file: &EventFile, column: &str, format: &str) -> SourceRef {
    SourceRef {
        file: file.file.clone(),
        member: file.member.clone(),
        column: Some(column.to_string()),
        format: format.into(),
    }
}

/// The time base from a time column or a stated step.
fn time_base(
    times: Option<Vec<f64>>,
    dt: Option<f64>,
    n: usize,
    what: &str,
) -> Result<(TimeBase, Option<Vec<f64>>)> {
    if let Some(t) = times {
        if t.len() != n {
            return Err(Error::usage(format!(
                "{what}: the time column has {} values, the channels {n}",
                t.len()
            )));
        }
        if let Some(i) = (1..n).find(|&i| !(t[i] > t[i - 1])) {
            return Err(Error::usage(format!(
                "{what}: time does not increase at sample {i} ({} after {})",
                t[i],
                t[i - 1]
            )));
        }
        let dt0 = if n > 1 {
            (t[n - 1] - t[0]) / (n - 1) as f64
        } else {
            0.0
        };
        let uniform = n > 1
            && t.windows(2)
                .all(|w| ((w[1] - w[0]) - dt0).abs() <= 1e-6 * dt0.abs().max(1e-12));
        return Ok((
            if uniform {
                TimeBase::Uniform { dt_s: dt0 }
            } else {
                TimeBase::Stamped
            },
            Some(t),
        ));
    }
    Ok(match dt {
        Some(dt) => (
            TimeBase::Uniform { dt_s: dt },
            Some((0..n).map(|i| i as f64 * dt).collect()),
        ),
        None => (TimeBase::StepIndex, None),
    })
}

/// The lab records of the event at `path`: one from the manifest's `[lab]`
/// section; without one, inferred from the files (docs/lab-tests.md).
pub fn load_lab(path: &Path) -> Result<Vec<LabRecord>> {
    let files = collect(path, &ArchiveLimits::default())?;
    let manifest = files
        .iter()
        .find(|f| is_manifest(f))
        .map(parse_manifest)
        .transpose()?;
    let folder_name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "lab".into());
    match manifest.as_ref().and_then(|m| m.lab.as_ref()) {
        Some(lab) if !lab.channels.is_empty() => {
            let name = manifest
                .as_ref()
                .and_then(|m| lab.specimen.clone().or_else(|| m.event.name.clone()))
                .unwrap_or(folder_name);
            Ok(vec![from_manifest(&files, lab, name)?])
        }
        _ => infer(&files, &folder_name),
    }
}

fn from_manifest(files: &[EventFile], lab: &LabSection, name: String) -> Result<LabRecord> {
    let mut by_name: BTreeMap<String, &EventFile> = BTreeMap::new();
    for f in files.iter().rev() {
        by_name.insert(f.member.clone().unwrap_or_else(|| f.file.clone()), f);
        by_name.insert(f.display_name(), f);
    }
    let mut tables: BTreeMap<String, LabTable> = BTreeMap::new();
    let mut channels = Vec::new();
    let mut values = Vec::new();
    for (i, c) in lab.channels.iter().enumerate() {
        let key = c.file.trim().trim_start_matches("./").replace('\\', "/");
        let id = c.id.clone().unwrap_or_else(|| format!("lab{i}"));
        let file = *by_name.get(&key).ok_or_else(|| {
            Error::input(
                Location::file(super::MANIFEST_NAME).with_channel(id.clone()),
                format!(
                    "file {:?} named by [[lab.channel]] is not in the event folder",
                    c.file
                ),
            )
        })?;
        if !tables.contains_key(&key) {
            tables.insert(key.clone(), read_table(file)?);
        }
        let table = &tables[&key];
        let col = pick(table, c.column.as_ref(), file)?;
        let (quantity, to_si) =
            lab_units(&c.units).ok_or_else(|| Error::usage("units checked when parsed"))?;
        let scale = c.scale.unwrap_or(1.0);
        values.push(
            col.values
                .iter()
                .map(|v| v * scale * to_si)
                .collect::<Vec<f64>>(),
        );
        channels.push(LabChannel {
            id,
            quantity,
            role: c
                .role
                .as_deref()
                .and_then(LabRole::parse)
                .unwrap_or_default(),
            units: c.units.clone(),
            to_si: scale * to_si,
            actuator: c.actuator.clone(),
            source: source(file, &col.name, &table.layout),
        });
    }
    let n = values[0].len();
    if let Some(k) = values.iter().position(|v| v.len() != n) {
        return Err(Error::usage(format!(
            "[lab] channels {:?} and {:?} have {n} and {} samples: lab channels must be of equal length",
            channels[0].id,
            channels[k].id,
            values[k].len()
        )));
    }
    let first_key = lab.channels[0]
        .file
        .trim()
        .trim_start_matches("./")
        .replace('\\', "/");
    let times = match &lab.time_column {
        Some(tc) => Some(
            pick(&tables[&first_key], Some(tc), by_name[&first_key])?
                .values
                .clone(),
        ),
        None => None,
    };
    let dt = lab.dt_s.or(tables[&first_key].dt_s);
    let mut inferred = Vec::new();
    let (mut time_base, mut time_s) = time_base(times, dt, n, &name)?;
    if lab.protocol.as_deref() == Some("quasi-static") && time_base != TimeBase::StepIndex {
        inferred.push("protocol = quasi-static: the time column is kept but the step index orders the samples".into());
        time_base = TimeBase::StepIndex;
        time_s = None;
    }
    Ok(LabRecord {
        name,
        channels,
        values,
        time_base,
        time_s,
        inferred,
    })
}

/// What a column's name says it holds.
fn quantity_from_name(name: &str) -> Option<(Quantity, LabRole)> {
    let n = name.to_ascii_lowercase();
    let role = if ["cmd", "command", "target", "setpoint"]
        .iter()
        .any(|w| n.contains(w))
    {
        LabRole::Command
    } else {
        LabRole::Measured
    };
    let q = if n.contains("disp") || n.contains("stroke") || n == "x" || n == "u" {
        Quantity::Displacement
    } else if n.contains("force") || n.contains("load") || n == "f" {
        Quantity::Force
    } else if n.contains("strain") {
        Quantity::Strain
    } else if n.contains("vel") {
        Quantity::Velocity
    } else if n.contains("acc") {
        Quantity::Acceleration
    } else {
        return None;
    };
    Some((q, role))
}

fn is_time_name(name: &str) -> bool {
    matches!(
        name.to_ascii_lowercase().as_str(),
        "time" | "t" | "time_s" | "time (s)"
    )
}

/// Inference without a `[lab]` section: every data file (`.csv`, `.tsv`,
/// `.txt`, `.dat`, `.json`, `.mat`) is read; columns are classified by their
/// names (the file's stem for a single-column file); a file holding both a
/// displacement and a force is a record of its own, single-quantity files of
/// equal length form one record together.
fn infer(files: &[EventFile], folder_name: &str) -> Result<Vec<LabRecord>> {
    let data_ext = [".csv", ".tsv", ".txt", ".dat", ".json", ".mat"];
    let mut singles: Vec<(LabChannel, Vec<f64>, Vec<String>)> = Vec::new();
    let mut records = Vec::new();
    for file in files {
        let lower = file.base_name().to_ascii_lowercase();
        if is_manifest(file) || !data_ext.iter().any(|e| lower.ends_with(e)) {
            continue;
        }
        let table = match read_table(file) {
            Ok(t) => t,
            // A data-looking file that is not a table (notes) is not a lab record.
            Err(_) if lower.ends_with(".txt") => continue,
            Err(e) => return Err(e),
        };
        let mut channels = Vec::new();
        let mut values = Vec::new();
        let mut inferred = vec![format!("{}: {}", file.display_name(), table.layout)];
        let mut times = None;
        for col in &table.columns {
            if is_time_name(&col.name) {
                let f = col
                    .units
                    .as_deref()
                    .map_or(1.0, |u| if u == "ms" { 1e-3 } else { 1.0 });
                times = Some(col.values.iter().map(|v| v * f).collect::<Vec<f64>>());
                continue;
            }
            let Some((quantity, role)) = quantity_from_name(&col.name) else {
                continue;
            };
            let peak = col.values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let units = match &col.units {
                Some(u) if lab_units(u).is_some_and(|(q, _)| q == quantity) => u.clone(),
                Some(u) => {
                    return Err(Error::input(
                        file.location().with_channel(col.name.clone()),
                        format!("units {u:?} stated for a {quantity} column are not lab units of it; state them in event.toml [[lab.channel]]"),
                    ))
                }
                None => {
                    let (u, why) = default_units(quantity, peak);
                    inferred.push(format!("{}: units {u} inferred ({why}); state `units` in event.toml [[lab.channel]] to override", col.name));
                    u.to_string()
                }
            };
            let (_, to_si) =
                lab_units(&units).ok_or_else(|| Error::usage("units checked above"))?;
            let n = col.name.to_ascii_lowercase();
            let actuator = n.strip_prefix("actuator_force_").map(str::to_string);
            inferred.push(format!(
                "{}: {quantity} ({}) from its name",
                col.name,
                role.name()
            ));
            channels.push(LabChannel {
                id: col.name.clone(),
                quantity,
                role,
                units,
                to_si,
                actuator,
                source: source(file, &col.name, &table.layout),
            });
            values.push(col.values.iter().map(|v| v * to_si).collect::<Vec<f64>>());
        }
        let has = |q| channels.iter().any(|c: &LabChannel| c.quantity == q);
        if has(Quantity::Displacement) && has(Quantity::Force) {
            let n = values[0].len();
            let stem = file
                .base_name()
                .rsplit_once('.')
                .map_or(file.base_name(), |(s, _)| s);
            let (time_base, time_s) = time_base(times, table.dt_s, n, &file.display_name())?;
            records.push(LabRecord {
                name: stem.to_string(),
                channels,
                values,
                time_base,
                time_s,
                inferred,
            });
        } else {
            for (c, v) in channels.into_iter().zip(values) {
                singles.push((c, v, inferred.clone()));
            }
        }
    }
    if !singles.is_empty() {
        let n = singles[0].1.len();
        if let Some(k) = singles.iter().position(|s| s.1.len() != n) {
            return Err(Error::usage(format!(
                "lab record of single-quantity files: {} has {n} samples, {} has {}; state the channels in event.toml [lab]",
                singles[0].0.source, singles[k].0.source, singles[k].1.len()
            )));
        }
        let mut inferred: Vec<String> = Vec::new();
        for s in &singles {
            for i in &s.2 {
                if !inferred.contains(i) {
                    inferred.push(i.clone());
                }
            }
        }
        inferred.push(
            "no time column: the step index orders the samples (a quasi-static protocol)".into(),
        );
        records.push(LabRecord {
            name: folder_name.to_string(),
            channels: singles.iter().map(|s| s.0.clone()).collect(),
            values: singles.into_iter().map(|s| s.1).collect(),
            time_base: TimeBase::StepIndex,
            time_s: None,
            inferred,
        });
    }
    if records.is_empty() {
        return Err(Error::usage(
            "no lab record found: no file holds a column named like a displacement or a force, and event.toml has no [lab] section (docs/lab-tests.md)",
        ));
    }
    Ok(records)
}

/// Units of a column that states none: displacement in m when its peak is
/// at most 1 (a specimen moving more than a metre is rare; millimetres
/// otherwise), force in kN (the PEER structural performance database's unit),
/// strain dimensionless.
fn default_units(q: Quantity, peak: f64) -> (&'static str, String) {
    match q {
        Quantity::Displacement if peak <= 1.0 => ("m", format!("peak {peak:.4} ≤ 1: metres")),
        Quantity::Displacement => ("mm", format!("peak {peak:.4} > 1: millimetres")),
        Quantity::Force => (
            "kN",
            "the PEER structural performance database's unit".into(),
        ),
        Quantity::Strain => ("strain", "dimensionless".into()),
        Quantity::Velocity => ("m/s", "SI".into()),
        Quantity::Acceleration => ("m/s2", "SI".into()),
    }
}
