//! `quaketwin history DATASET [--structure ID] --out DIR` (issue 35 item 1):
//! the edges of [`crate::history`].  Reads a many-event dataset (the layout
//! of `quaketwin run … EV1 EV2 …` and of the Python fleet: docs/cli.md,
//! "Many events"), groups its events by structure, runs the history of each
//! structure and writes `history_modes.parquet`, `history_events.parquet`
//! and `history.html` (docs/history.md).
//!
//! [`write_history`] is the library call (what `watch` runs after each
//! event); the tables are read back with [`crate::sinks::history_tables`].
//!
//! Structure ids: the dataset's `structure=<S>` partition, except for
//! `structure=unknown` (events whose `event.toml` names no structure, e.g.
//! network zips as published): those are told apart by the recording
//! station of their channels (`NETWORK.STATION` of channels.parquet, the
//! most frequent one), so the zips of four CSMIP bridges make four
//! histories, not one.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::error::{Error, Location, Result};
use crate::history::prediction::{self, IoRecord, ModalModel, ModalTerm};
use crate::history::{analyse, EventModes, HistorySettings, StructureHistory};
use crate::modal::Mode;
use crate::report::history::StructurePage;
use crate::sinks::dataset;
use crate::sinks::history_tables::{self, HistoryEventRow, HistoryModeRow};
use crate::sinks::provenance::Provenance;
use crate::vocab::tables::{self, HISTORY_EVENTS, HISTORY_MODES};
use crate::vocab::Role;

mod rows;
mod source;

pub use source::EventSource;

pub const MODES_FILE: &str = HISTORY_MODES.file;
pub const EVENTS_FILE: &str = HISTORY_EVENTS.file;
pub const REPORT_FILE: &str = "history.html";

/// The intensity the amplitude dependence is fitted on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Intensity {
    /// Largest horizontal peak acceleration of the response (output)
    /// channels: the roof of a building, the deck of a bridge.
    Response,
    /// Largest horizontal peak acceleration of the base (input) channels.
    Base,
}

impl Intensity {
    pub fn name(self) -> &'static str {
        match self {
            Intensity::Response => "response",
            Intensity::Base => "base",
        }
    }
    pub fn from_name(s: &str) -> Option<Intensity> {
        match s {
            "response" => Some(Intensity::Response),
            "base" => Some(Intensity::Base),
            _ => None,
        }
    }
}

/// The command's options.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct HistoryOptions {
    pub dataset: PathBuf,
    /// Only this structure (its id: docs/history.md); all when None.
    pub structure: Option<String>,
    pub out: PathBuf,
    pub intensity: Intensity,
    /// Event-to-event prediction (reads every event's samples).
    pub predict: bool,
    pub settings: HistorySettings,
}

impl HistoryOptions {
    /// The defaults for `dataset` → `out`.
    pub fn new(dataset: &Path, out: &Path) -> Self {
        HistoryOptions {
            dataset: dataset.to_path_buf(),
            structure: None,
            out: out.to_path_buf(),
            intensity: Intensity::Response,
            predict: true,
            settings: HistorySettings::default(),
        }
    }
}

/// One followed mode in the summary.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ModeSummary {
    pub mode: usize,
    pub direction: String,
    pub events: usize,
    /// Median frequency over its events, Hz.
    pub median_frequency_hz: f64,
    /// b of Eq. H1 (null without a band).
    pub slope: Option<f64>,
    pub fitted_events: usize,
    /// `event: status` of each event outside the band.
    pub flagged: Vec<String>,
    /// First event of a permanent shift and its size, %.
    pub step_event: Option<String>,
    pub step_percent: Option<f64>,
    /// Why there is no band.
    pub note: Option<String>,
}

/// One structure in the summary.
#[derive(Debug, Clone, serde::Serialize)]
pub struct StructureSummary {
    pub structure: String,
    pub name: Option<String>,
    pub events: usize,
    pub modes: Vec<ModeSummary>,
}

/// What `quaketwin history` did (`--json`).
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct HistorySummary {
    pub ok: bool,
    pub error: Option<String>,
    pub dataset: PathBuf,
    pub out: PathBuf,
    pub structures: Vec<StructureSummary>,
    pub files: Vec<PathBuf>,
    pub seconds: f64,
}

impl HistorySummary {
    /// The summary of a run that failed with `error`.
    pub fn failed(opts: &HistoryOptions, error: &Error) -> HistorySummary {
        HistorySummary {
            ok: false,
            error: Some(crate::error::printable(
                &error.to_string(),
                crate::error::MAX_PRINTED_ERROR_CHARS,
            )),
            dataset: opts.dataset.clone(),
            out: opts.out.clone(),
            ..Default::default()
        }
    }
}

/// One structure's history and the sources of its events (same order as
/// `history.events`), with each event's prediction.
pub struct Analysed {
    pub structure: String,
    pub history: StructureHistory,
    pub sources: Vec<EventSource>,
    pub predictions: Vec<Prediction>,
    /// Index of its first row in history_events.parquet.
    pub first_row: usize,
}

/// The prediction of one event (Eqs. H7–H9).
#[derive(Debug, Clone, Default)]
pub struct Prediction {
    pub from: Option<String>,
    pub errors: Vec<prediction::ChannelError>,
    /// Median ε of the event's own model on its own records.
    pub model_error_median: Option<f64>,
    pub notes: Vec<String>,
}

/// The library call: the history of `dataset` (every structure, or only
/// `structure`) written into `out` with the defaults.
pub fn write_history(
    dataset: &Path,
    structure: Option<&str>,
    out: &Path,
) -> Result<HistorySummary> {
    let mut opts = HistoryOptions::new(dataset, out);
    opts.structure = structure.map(String::from);
    run(&opts)
}

/// The events of `dataset` grouped by structure id (docs/history.md), each
/// group in date order; a dataset path that is no dataset, or one without
/// events, is an input error naming it.
pub fn structures(root: &Path) -> Result<BTreeMap<String, Vec<EventSource>>> {
    let loc = || Location::file(root.display().to_string());
    if !root.is_dir() {
        return Err(Error::input(loc(), "not a directory: give the output directory of `quaketwin run PIPELINE EV1 EV2 … --out DIR` (docs/cli.md, \"Many events\")"));
    }
    let events = dataset::list_events(root)?.ok_or_else(|| {
        Error::input(
            loc(),
            "not a quaketwin dataset: no table folder with structure=…/event=… partitions and no runs/ folder (docs/cli.md, \"Many events\")",
        )
    })?;
    if events.is_empty() {
        return Err(Error::input(
            loc(),
            "the dataset holds no event (no table published under tables/<table>/structure=…/event=…/part-0.parquet)",
        ));
    }
    let sources: Vec<EventSource> = events
        .par_iter()
        .map(|e| EventSource::read(root, e))
        .collect::<Result<_>>()?;
    let mut groups: BTreeMap<String, Vec<EventSource>> = BTreeMap::new();
    for s in sources {
        groups.entry(s.structure.clone()).or_default().push(s);
    }
    for g in groups.values_mut() {
        g.sort_by(|a, b| {
            a.time_ns
                .is_none()
                .cmp(&b.time_ns.is_none())
                .then(a.time_ns.cmp(&b.time_ns))
                .then(a.event.event.cmp(&b.event.event))
        });
    }
    Ok(groups)
}

/// Runs `quaketwin history` (module doc).
pub fn run(opts: &HistoryOptions) -> Result<HistorySummary> {
    let clock = std::time::Instant::now();
    crate::fixed_order_reductions();
    check_out(opts)?;
    let mut groups = structures(&opts.dataset)?;
    if let Some(id) = &opts.structure {
        // A structure id, or a partition name (`watch` refreshes the
        // structures of the partition an event went to).
        let known: Vec<String> = groups.keys().cloned().collect();
        let partitions: std::collections::BTreeSet<String> = groups
            .values()
            .flatten()
            .map(|s| s.event.structure.clone())
            .collect();
        groups.retain(|k, sources| k == id || sources.iter().any(|s| s.event.structure == *id));
        if groups.is_empty() {
            return Err(Error::usage(format!(
                "--structure {id:?}: no such structure in {}; it holds {} (partitions structure={})",
                opts.dataset.display(),
                known.join(", "),
                partitions.into_iter().collect::<Vec<_>>().join(", structure=")
            )));
        }
    }
    let mut analysed: Vec<Analysed> = groups
        .into_iter()
        .map(|(structure, sources)| analyse_structure(&opts.dataset, structure, sources, opts))
        .collect();
    let mut first_row = 0;
    for a in &mut analysed {
        a.first_row = first_row;
        first_row += a.history.events.len();
    }
    let provenance = Provenance::of_source(serde_json::json!({
        "name": format!("dataset {}", opts.dataset.display()),
        "dataset": opts.dataset,
        "structures": analysed.iter().map(|a| &a.structure).collect::<Vec<_>>(),
    }))
    .then_step(
        "history",
        serde_json::json!({
            "intensity": opts.intensity,
            "predict": opts.predict,
            "settings": opts.settings,
            "structure": opts.structure,
        }),
    );
    let mode_rows: Vec<HistoryModeRow> = analysed.iter().flat_map(rows::mode_rows).collect();
    let event_rows: Vec<HistoryEventRow> = analysed.iter().flat_map(rows::event_rows).collect();
    let mut metadata = provenance.metadata();
    metadata.push((
        history_tables::MODELS_KEY.to_string(),
        rows::models_json(&analysed, &opts.settings).to_string(),
    ));
    let out = &opts.out;
    crate::pipeline::run_one_shot(
        out,
        "history",
        &opts.dataset,
        &[MODES_FILE, EVENTS_FILE, REPORT_FILE],
        || {
            history_tables::write_modes(&out.join(MODES_FILE), &mode_rows, &metadata)?;
            history_tables::write_events(
                &out.join(EVENTS_FILE),
                &event_rows,
                &provenance.metadata(),
            )?;
            let pages: Vec<StructurePage> = analysed
                .iter()
                .map(|a| StructurePage {
                    structure: &a.structure,
                    name: a
                        .sources
                        .iter()
                        .rev()
                        .find_map(|s| s.structure_name.as_deref()),
                    history: &a.history,
                    events: &event_rows[a.first_row..a.first_row + a.history.events.len()],
                })
                .collect();
            let html = crate::report::history::page(
                &pages,
                &opts.dataset.display().to_string(),
                opts.intensity.name(),
                opts.settings.band.confidence,
            );
            crate::sinks::atomic::write_bytes_atomically(&out.join(REPORT_FILE), html.as_bytes())
        },
    )?;
    Ok(HistorySummary {
        ok: true,
        error: None,
        dataset: opts.dataset.clone(),
        out: out.clone(),
        structures: analysed.iter().map(rows::summary).collect(),
        files: [MODES_FILE, EVENTS_FILE, REPORT_FILE]
            .iter()
            .map(|f| out.join(f))
            .collect(),
        seconds: clock.elapsed().as_secs_f64(),
    })
}

/// `--out` must not be the dataset itself nor one of its table folders.
fn check_out(opts: &HistoryOptions) -> Result<()> {
    let Some(root) = std::fs::canonicalize(&opts.dataset).ok() else {
        return Ok(());
    };
    // `--out` need not exist yet: its nearest existing ancestor, resolved,
    // with the rest of the path.
    let out = {
        let mut existing = opts.out.as_path();
        let mut rest = Vec::new();
        loop {
            if let Ok(p) = std::fs::canonicalize(existing) {
                break rest.iter().rev().fold(p, |p: PathBuf, c| p.join(c));
            }
            match (existing.parent(), existing.file_name()) {
                (Some(parent), Some(name)) => {
                    rest.push(name.to_os_string());
                    existing = if parent.as_os_str().is_empty() {
                        Path::new(".")
                    } else {
                        parent
                    };
                }
                _ => return Ok(()),
            }
        }
    };
    let inside_table = out
        .strip_prefix(&root)
        .ok()
        .and_then(|rel| rel.components().next())
        .is_some_and(|c| {
            let name = c.as_os_str().to_string_lossy();
            // The table tree, the run folders (and a table folder of the
            // layout before issue 34, `DIR/<table>/`).
            tables::by_name(&name).is_some()
                || name == dataset::RUNS_DIR
                || name == dataset::TABLES_DIR
        });
    if out == root || inside_table {
        return Err(Error::usage(format!(
            "--out {}: the dataset itself or one of its table or run folders; give a directory of its own (e.g. {}/history)",
            opts.out.display(),
            opts.dataset.display()
        )));
    }
    Ok(())
}

/// The history of one structure and its predictions.
fn analyse_structure(
    root: &Path,
    structure: String,
    sources: Vec<EventSource>,
    opts: &HistoryOptions,
) -> Analysed {
    let events: Vec<EventModes> = sources
        .iter()
        .map(|s| EventModes {
            event: s.event.event.clone(),
            time_ns: s.time_ns,
            intensity_m_s2: match opts.intensity {
                Intensity::Response => s.peak_response_m_s2,
                Intensity::Base => s.peak_base_m_s2,
            },
            modes: s.modes.clone(),
            channels: s.shape_channels.clone(),
        })
        .collect();
    // `analyse` sorts by date as `structures` did: the same order.
    let history = analyse(events, &opts.settings);
    let predictions = if opts.predict {
        predict_events(root, &history, &sources)
    } else {
        vec![Prediction::default(); sources.len()]
    };
    Analysed {
        structure,
        history,
        sources,
        predictions,
        first_row: 0,
    }
}

/// The conditioned records of one event as inputs and outputs (roles of
/// channels.parquet), from the dataset's `samples` table.
fn io_record(root: &Path, source: &EventSource) -> std::result::Result<IoRecord, String> {
    let file = source.event.table_file(root, tables::SAMPLES.name);
    if !source.event.tables.contains(&tables::SAMPLES.name) {
        return Err("the dataset holds no samples table for it".into());
    }
    let (event, _) = crate::sinks::event_tables::read_samples(&file).map_err(|e| e.to_string())?;
    let mut record = IoRecord {
        dt: f64::NAN,
        input_ids: Vec::new(),
        inputs: Vec::new(),
        output_ids: Vec::new(),
        outputs: Vec::new(),
    };
    for r in event.records {
        let dt = r.channel.dt();
        if record.dt.is_nan() {
            record.dt = dt;
        } else if (dt - record.dt).abs() > 1e-9 * record.dt {
            return Err(format!(
                "channels at different sampling intervals ({} s, {} s)",
                record.dt, dt
            ));
        }
        let samples = r.samples.take().map_err(|e| e.to_string())?;
        match r.channel.role {
            Role::Input => {
                record.input_ids.push(r.channel.id);
                record.inputs.push(samples);
            }
            Role::Output => {
                record.output_ids.push(r.channel.id);
                record.outputs.push(samples);
            }
            _ => {}
        }
    }
    Ok(record)
}

fn terms(modes: &[Mode]) -> Vec<ModalTerm> {
    modes
        .iter()
        .map(|m| ModalTerm {
            frequency_hz: m.frequency_hz,
            damping_ratio: m.damping_ratio,
            shape: m.shape.clone(),
        })
        .collect()
}

fn median(values: &[f64]) -> Option<f64> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    (!v.is_empty()).then(|| crate::stats::median_in_place(&mut v))
}

/// Eqs. H7–H9 over a structure's events (date order): every event with
/// modes gets its model (fitted on its own records), then every event is
/// predicted by the model of the latest earlier event that has one and
/// whose input and output channels the event recorded.  Each
/// event's samples are read in its own task, at most twice (to fit, to be
/// predicted), so memory holds a few events at a time.
fn predict_events(
    root: &Path,
    history: &StructureHistory,
    sources: &[EventSource],
) -> Vec<Prediction> {
    let models: Vec<std::result::Result<(ModalModel, f64), String>> = history
        .events
        .par_iter()
        .zip(sources)
        .map(|(e, s)| {
            if e.modes.is_empty() {
                return Err("no mode identified: no model".into());
            }
            let record = io_record(root, s)?;
            let model = prediction::fit(&terms(&e.modes), &e.channels, &record)?;
            let own = prediction::predict(&model, &record)?;
            let errors: Vec<f64> = own.iter().map(|c| c.normalised_error).collect();
            Ok((model, median(&errors).unwrap_or(f64::NAN)))
        })
        .collect();
    (0..sources.len())
        .into_par_iter()
        .map(|k| {
            let mut p = Prediction::default();
            match &models[k] {
                Ok((_, own)) => p.model_error_median = own.is_finite().then_some(*own),
                Err(why) => p.notes.push(format!("no model of this event: {why}")),
            }
            let earlier: Vec<usize> = (0..k).rev().filter(|&j| models[j].is_ok()).collect();
            if earlier.is_empty() {
                p.notes
                    .push("no prediction: no earlier event with a model".into());
                return p;
            }
            let record = match io_record(root, &sources[k]) {
                Ok(r) => r,
                Err(why) => {
                    p.notes.push(format!("no prediction: {why}"));
                    return p;
                }
            };
            // The latest earlier model whose inputs and outputs this event
            // recorded (a channel added or removed between two events
            // leaves the model before it to predict).
            let mut refused = Vec::new();
            for j in earlier {
                let Ok((model, _)) = &models[j] else { continue };
                let from = &history.events[j].event;
                match prediction::predict(model, &record) {
                    Ok(errors) => {
                        p.errors = errors;
                        p.from = Some(from.clone());
                        break;
                    }
                    Err(why) => refused.push(format!("{from}: {why}")),
                }
            }
            if p.from.is_none() {
                p.notes.push(format!(
                    "no prediction: no earlier model applies ({})",
                    refused.join("; ")
                ));
            }
            p
        })
        .collect()
}
