//! `ingest`: read the event folder and write `event.json`, the inventory of
//! what was read, inferred and missing, and `event/event.parquet`, the event's
//! ids and names as a table.

use serde::{Deserialize, Serialize};

use crate::conditioning::event_window::EventWindow;
use crate::error::{Error, Result};
use crate::event_folder::LoadedEvent;
use crate::pipeline::{Product, ProductKind, RunContext, Stage, StageKind, StageSource};
use crate::vocab::{format_epoch_ns, Channel, Structure};

pub const KIND: StageKind = StageKind {
    kind: "ingest",
    needs: &[],
    provides: Some(ProductKind::Inventory),
    reads_all_earlier: false,
    build,
};

/// The inventory file.
pub const EVENT_JSON: &str = "event.json";
/// The event's row (ids and names).
pub const EVENT_TABLE: &str = crate::vocab::tables::EVENT.file;

/// The stage takes no parameters: channel metadata belongs in event.toml.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct IngestParams {}

fn build(src: &StageSource) -> Result<Box<dyn Stage>> {
    src.params::<IngestParams>().map_err(|e| {
        Error::usage(format!(
            "{e} (the ingest stage takes no params: set channel metadata in event.toml)"
        ))
    })?;
    Ok(Box::new(Ingest))
}

struct Ingest;

impl Stage for Ingest {
    fn outputs(&self) -> Vec<String> {
        vec![EVENT_JSON.into(), EVENT_TABLE.into()]
    }
    fn run(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        let path = ctx.out_dir.join(EVENT_JSON);
        let window = ctx.event_window()?;
        if let Some(w) = &window {
            crate::console::note(format!("ingest: {}", w.describe()));
        }
        let ids = crate::pipeline::dataset::event_ids(&ctx.event_path)?;
        let json = inventory_json_with(ctx.loaded_event()?, window.as_ref())?;
        crate::sinks::parquet::write_bytes_atomically(&path, &json)?;
        let table = ctx.out_dir.join(EVENT_TABLE);
        let event = &ctx.loaded_event()?.event;
        crate::sinks::event_tables::write_event(&table, event, (&ids.0, &ids.1))?;
        Ok(None)
    }
}

#[derive(Serialize)]
struct FileJson<'a> {
    name: &'a str,
    format: Option<&'a str>,
    channels: usize,
    skipped: Option<&'a str>,
}

#[derive(Serialize)]
struct ChannelJson<'a> {
    #[serde(flatten)]
    channel: &'a Channel,
    npts: usize,
    start_time: Option<String>,
}

#[derive(Serialize)]
struct EventJson<'a> {
    name: &'a str,
    origin_time: Option<String>,
    magnitude: Option<f64>,
    /// Epicentre and depth, when stated or given by a header.
    #[serde(skip_serializing_if = "Option::is_none")]
    hypocentre: Option<&'a crate::vocab::Hypocentre>,
    /// The recording station's [latitude, longitude] from the headers.
    #[serde(skip_serializing_if = "Option::is_none")]
    station_position: Option<[f64; 2]>,
    structure: Option<&'a Structure>,
    notes: &'a [String],
    files: Vec<FileJson<'a>>,
    channels: Vec<ChannelJson<'a>>,
    history: &'a crate::vocab::ProcessingHistory,
    /// The building geometry applied at ingest (axes, rotations, floors).
    geometry: &'a crate::geometry::GeometryReport,
    /// A continuous record's event window (`conditioning::event_window`).
    #[serde(skip_serializing_if = "Option::is_none")]
    event_window: Option<serde_json::Value>,
}

/// The inventory of a loaded event as pretty JSON.
pub fn inventory_json(loaded: &LoadedEvent) -> Result<Vec<u8>> {
    inventory_json_with(loaded, None)
}

/// As [`inventory_json`], with the event window of a continuous record.
fn inventory_json_with(loaded: &LoadedEvent, window: Option<&EventWindow>) -> Result<Vec<u8>> {
    let e = &loaded.event;
    let mut notes = e.notes.clone();
    notes.extend(window.map(EventWindow::describe));
    let doc = EventJson {
        name: &e.name,
        origin_time: e.origin_ns.map(format_epoch_ns),
        magnitude: e.magnitude,
        hypocentre: e.hypocentre.as_ref(),
        station_position: e.station_position,
        structure: e.structure.as_ref(),
        notes: &notes,
        files: loaded
            .files
            .iter()
            .map(|f| FileJson {
                name: &f.name,
                format: f.format,
                channels: f.channels,
                skipped: f.skipped.as_deref(),
            })
            .collect(),
        channels: e
            .records
            .iter()
            .map(|r| ChannelJson {
                channel: &r.channel,
                npts: r.samples.len(),
                start_time: r.channel.start_ns.map(format_epoch_ns),
            })
            .collect(),
        history: &e.history,
        geometry: &loaded.geometry,
        event_window: window.map(EventWindow::history),
    };
    serde_json::to_vec_pretty(&doc)
        .map_err(|err| Error::numerical(format!("serialising the inventory: {err}")))
}
