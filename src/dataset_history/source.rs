//! What the history reads of one event of a dataset: its channels (roles,
//! directions, peak accelerations, station, start), modes, rating and
//! event.json (origin time, structure name).  A table that cannot be read
//! is a note on the event and a warning, not the end of the history: one
//! damaged event must not hide a network's other events.

use std::path::Path;

use arrow_array::{Array, Float64Array, StringArray, TimestampNanosecondArray};

use crate::error::Result;
use crate::modal::Mode;
use crate::sinks::dataset::DatasetEvent;
use crate::sinks::parquet::ReadTable;
use crate::vocab::tables::{self, assessment, channels};

use crate::sinks::dataset::UNKNOWN_STRUCTURE;

/// Largest event.json read, bytes.
const MAX_EVENT_JSON: u64 = 64 << 20;

/// One event as the history sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct EventSource {
    pub event: DatasetEvent,
    /// Structure id (module doc of `dataset_history`).
    pub structure: String,
    pub structure_name: Option<String>,
    pub time_ns: Option<i64>,
    /// `origin_time`, `record_start` or `unknown`.
    pub time_source: &'static str,
    pub peak_base_m_s2: Option<f64>,
    pub peak_response_m_s2: Option<f64>,
    pub rating: Option<String>,
    pub modes: Vec<Mode>,
    /// Channel ids of the mode shapes.
    pub shape_channels: Vec<String>,
    pub notes: Vec<String>,
}

/// One channel's row as needed here.
struct ChannelRow {
    station: Option<String>,
    role: String,
    direction: Option<String>,
    pga: Option<f64>,
    start_ns: Option<i64>,
}

fn read_channels(path: &Path) -> Result<Vec<ChannelRow>> {
    let t = ReadTable::open(path)?;
    let mut rows = Vec::new();
    for b in &t.batches {
        let text = |c| -> Result<StringArray> { t.declared(b, c) };
        let (net, sta, role, dir) = (
            text(&channels::NETWORK)?,
            text(&channels::STATION)?,
            text(&channels::ROLE)?,
            text(&channels::DIRECTION)?,
        );
        let pga: Float64Array = t.declared(b, &channels::PGA_M_S2)?;
        let start: TimestampNanosecondArray = t.declared(b, &channels::START_TIME)?;
        let opt = |a: &StringArray, i: usize| a.is_valid(i).then(|| a.value(i).to_string());
        for i in 0..b.num_rows() {
            rows.push(ChannelRow {
                station: match (opt(&net, i), opt(&sta, i)) {
                    (Some(n), Some(s)) => Some(format!("{n}.{s}")),
                    (None, Some(s)) => Some(s),
                    _ => None,
                },
                role: role.value(i).to_string(),
                direction: opt(&dir, i),
                pga: (pga.is_valid(i) && pga.value(i).is_finite()).then(|| pga.value(i)),
                start_ns: start.is_valid(i).then(|| start.value(i)),
            });
        }
    }
    Ok(rows)
}

/// A horizontal direction label: `X`, `Y` or an azimuth `<deg>deg`.
fn horizontal(direction: Option<&str>) -> bool {
    direction.is_some_and(|d| d == "X" || d == "Y" || d.ends_with("deg"))
}

/// Largest horizontal peak acceleration of the channels of `role`.
fn peak(rows: &[ChannelRow], role: &str) -> Option<f64> {
    rows.iter()
        .filter(|r| r.role == role && horizontal(r.direction.as_deref()))
        .filter_map(|r| r.pga)
        .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))))
}

/// The station most of the channels give (datasets written before events
/// without a manifest were partitioned by station).
fn station(rows: &[ChannelRow]) -> Option<String> {
    crate::vocab::most_common_station(rows.iter().map(|r| (None, r.station.as_deref())))
}

fn rating(path: &Path) -> Result<Option<String>> {
    let t = ReadTable::open(path)?;
    for b in &t.batches {
        let r: StringArray = t.declared(b, &assessment::RATING)?;
        if r.len() > 0 && r.is_valid(0) {
            return Ok(Some(r.value(0).to_string()));
        }
    }
    Ok(None)
}

impl EventSource {
    /// Reads what the history needs of `event` under the dataset `root`.
    pub fn read(root: &Path, event: &DatasetEvent) -> Result<EventSource> {
        let mut notes = Vec::new();
        let has = |t: &str| event.tables.contains(&t);
        let mut note = |what: String| {
            crate::console::warn(format!("history: {what}"));
            notes.push(what);
        };
        let channel_rows = if has(tables::CHANNELS.name) {
            let file = event.table_file(root, tables::CHANNELS.name);
            match read_channels(&file) {
                Ok(rows) => rows,
                Err(e) => {
                    note(format!("{}: {e}", file.display()));
                    Vec::new()
                }
            }
        } else {
            note("no channels table: intensity unknown".into());
            Vec::new()
        };
        let (modes, shape_channels) = if has(tables::MODES.name) {
            let file = event.table_file(root, tables::MODES.name);
            match crate::sinks::modal_tables::read_modes(&file) {
                Ok(m) => m,
                Err(e) => {
                    note(format!("{}: {e}", file.display()));
                    (Vec::new(), Vec::new())
                }
            }
        } else {
            (Vec::new(), Vec::new())
        };
        let rating = if has(tables::ASSESSMENT.name) {
            let file = event.table_file(root, tables::ASSESSMENT.name);
            rating(&file).unwrap_or_else(|e| {
                note(format!("{}: {e}", file.display()));
                None
            })
        } else {
            None
        };
        let json_file = event.run_dir(root).join("event.json");
        let json: Option<serde_json::Value> = json_file
            .is_file()
            .then(|| crate::input_file::read_to_string(&json_file, MAX_EVENT_JSON))
            .and_then(|r| r.ok())
            .and_then(|t| serde_json::from_str(&t).ok());
        let origin = json
            .as_ref()
            .and_then(|j| j.get("origin_time")?.as_str().map(String::from))
            .and_then(|t| crate::vocab::parse_iso8601_ns(&t));
        let start = channel_rows.iter().filter_map(|r| r.start_ns).min();
        let (time_ns, time_source) = match (origin, start) {
            (Some(t), _) => (Some(t), "origin_time"),
            (None, Some(t)) => (Some(t), "record_start"),
            (None, None) => (None, "unknown"),
        };
        let structure_name = json
            .as_ref()
            .and_then(|j| {
                j.get("structure")?
                    .get("name")?
                    .as_str()
                    .map(|s| s.trim().to_string())
            })
            .filter(|s| !s.is_empty());
        let structure = if event.structure == UNKNOWN_STRUCTURE {
            station(&channel_rows).unwrap_or_else(|| UNKNOWN_STRUCTURE.into())
        } else {
            event.structure.clone()
        };
        if !has(tables::MODES.name) {
            notes.push("no modes table: the modal stage did not run or did not apply".into());
        }
        Ok(EventSource {
            event: event.clone(),
            structure,
            structure_name,
            time_ns,
            time_source,
            peak_base_m_s2: peak(&channel_rows, "input"),
            peak_response_m_s2: peak(&channel_rows, "output"),
            rating,
            modes,
            shape_channels,
            notes,
        })
    }
}
