//! What the dashboard shows, read from a many-event dataset
//! ([`crate::sinks::dataset`]): the events are the partitions
//! `structure=S/event=E` of the run folders and of the `assessment` table
//! (a fleet dataset written by the Python package has both); per event its
//! assessment row, its modes, its `event.json` (name, origin time,
//! magnitude, the structure's name, kind and position) and its report.
//! Everything shown is read from these files; nothing is recomputed.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::report::table::{self, Table};
use crate::report::AssessmentView;
use crate::sinks::dataset::{self, PART_FILE, RUNS_DIR};
use crate::vocab::tables as t;

/// Largest `event.json` read (a network event of 500 channels is ≈ 2 MB).
const MAX_EVENT_JSON_BYTES: u64 = 64 << 20;

/// One mode of an event's `modes` table.
#[derive(Debug, Clone, PartialEq)]
pub struct ModeView {
    pub frequency_hz: f64,
    pub direction: Option<String>,
}

/// One event of a structure.
#[derive(Debug, Clone)]
pub struct EventView {
    /// Partition values.
    pub structure: String,
    pub event: String,
    /// From event.json.
    pub name: Option<String>,
    pub origin_ns: Option<i64>,
    pub magnitude: Option<f64>,
    pub structure_name: Option<String>,
    pub kind: Option<String>,
    pub position: Option<(f64, f64)>,
    pub assessment: Option<AssessmentView>,
    /// Why the assessment table could not be read, when it exists.
    pub assessment_error: Option<String>,
    pub modes: Vec<ModeView>,
    /// The event's report in the dataset, when there is one.
    pub report: Option<PathBuf>,
    /// When its run was last written (`run.json`'s modification time), ns.
    pub processed_ns: Option<i64>,
}

impl EventView {
    /// The order of events in time: origin time, else when processed, then name.
    pub fn time_key(&self) -> (i64, &str) {
        (
            self.origin_ns.or(self.processed_ns).unwrap_or(i64::MIN),
            &self.event,
        )
    }
    pub fn rating(&self) -> &str {
        self.assessment
            .as_ref()
            .map(|a| a.rating.as_str())
            .unwrap_or("NOT RATED")
    }
}

/// One structure and its events, oldest first.
#[derive(Debug, Clone)]
pub struct StructureView {
    /// The partition value `S` (the page's name).
    pub key: String,
    pub events: Vec<EventView>,
}

impl StructureView {
    /// The latest event (by [`EventView::time_key`]).
    pub fn latest(&self) -> &EventView {
        self.events
            .last()
            .expect("a structure has at least one event") // ok: built from its events
    }
    /// The name to show: the latest event.json's, else the partition value.
    pub fn display_name(&self) -> String {
        self.events
            .iter()
            .rev()
            .find_map(|e| e.structure_name.clone())
            .unwrap_or_else(|| self.key.clone())
    }
    pub fn kind(&self) -> Option<String> {
        self.events.iter().rev().find_map(|e| e.kind.clone())
    }
    /// The latest stated position.
    pub fn position(&self) -> Option<(f64, f64)> {
        self.events.iter().rev().find_map(|e| e.position)
    }
}

/// Reads every structure of the dataset at `root`, sorted by key; each
/// structure's events oldest first.
pub fn scan(root: &Path) -> Result<Vec<StructureView>> {
    if !root.is_dir() {
        return Err(Error::usage(format!(
            "{}: not a dataset folder (quaketwin run … --out DIR, quaketwin watch … --out DIR)",
            root.display()
        )));
    }
    let mut keys: Vec<(String, String)> = dataset::partitions_under(&root.join(RUNS_DIR))?;
    keys.extend(dataset::partitions_under(&dataset::table_dir(
        root,
        t::ASSESSMENT.name,
    ))?);
    keys.sort();
    keys.dedup();
    let mut by_structure: BTreeMap<String, Vec<EventView>> = BTreeMap::new();
    for (s, e) in keys {
        let view = read_event(root, &s, &e);
        by_structure.entry(s).or_default().push(view);
    }
    Ok(by_structure
        .into_iter()
        .map(|(key, mut events)| {
            events.sort_by(|a, b| a.time_key().cmp(&b.time_key()));
            StructureView { key, events }
        })
        .collect())
}

fn read_event(root: &Path, structure: &str, event: &str) -> EventView {
    let partition = dataset::partition(structure, event);
    let run_dir = dataset::run_dir(root, &partition);
    let table_file = |name: &str| {
        dataset::table_dir(root, name)
            .join(&partition)
            .join(PART_FILE)
    };
    let mut v = EventView {
        structure: structure.to_string(),
        event: event.to_string(),
        name: None,
        origin_ns: None,
        magnitude: None,
        structure_name: None,
        kind: None,
        position: None,
        assessment: None,
        assessment_error: None,
        modes: Vec::new(),
        report: Some(run_dir.join("report.html")).filter(|p| p.is_file()),
        processed_ns: std::fs::metadata(run_dir.join(crate::pipeline::manifest::MANIFEST_FILE))
            .and_then(|m| m.modified())
            .ok()
            .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
            .map(|d| d.as_nanos() as i64),
    };
    read_event_json(&run_dir.join("event.json"), &mut v);
    let assessment = table_file(t::ASSESSMENT.name);
    if assessment.is_file() {
        match table::load(&assessment, None) {
            Ok(tb) => v.assessment = AssessmentView::of(&tb),
            Err(e) => v.assessment_error = Some(e.to_string()),
        }
    }
    if let Ok(m) = table::load(&table_file(t::MODES.name), None) {
        v.modes = modes_of(&m);
    }
    v
}

fn modes_of(m: &Table) -> Vec<ModeView> {
    let freq = m.number(t::modes::FREQUENCY_HZ.name).unwrap_or(&[]);
    let dir = m.text(t::modes::DIRECTION.name);
    freq.iter()
        .enumerate()
        .filter_map(|(r, f)| {
            Some(ModeView {
                frequency_hz: (*f)?,
                direction: dir.and_then(|d| d.get(r).cloned().flatten()),
            })
        })
        .collect()
}

/// Fills what `event.json` (the ingest stage's inventory) says.
fn read_event_json(path: &Path, v: &mut EventView) {
    let Ok(text) = crate::input_file::read_to_string(path, MAX_EVENT_JSON_BYTES) else {
        return;
    };
    let Ok(doc) = serde_json::from_str::<serde_json::Value>(&text) else {
        return;
    };
    let text_of = |x: &serde_json::Value| x.as_str().map(str::to_string);
    v.name = text_of(&doc["name"]);
    v.origin_ns = doc["origin_time"]
        .as_str()
        .and_then(crate::vocab::parse_iso8601_ns);
    v.magnitude = doc["magnitude"].as_f64();
    let s = &doc["structure"];
    v.structure_name = text_of(&s["name"]).map(|n| n.trim().to_string());
    v.kind = text_of(&s["kind"]);
    v.position = match (s["latitude_deg"].as_f64(), s["longitude_deg"].as_f64()) {
        (Some(lat), Some(lon)) if lat.abs() <= 90.0 && lon.abs() <= 180.0 => Some((lat, lon)),
        _ => None,
    };
}
