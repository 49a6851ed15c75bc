//! One event added to a many-event dataset ([`crate::sinks::dataset`]): the
//! event's Hive partition, its run in `DIR/runs/<partition>/` (locked, with
//! its run manifest, stages skipped when up to date), then its tables
//! published table-first.  The one home of this sequence: `quaketwin run`
//! with several events and `quaketwin watch` both add events through it.

use std::path::{Path, PathBuf};

use super::{run_showing, Pipeline, Progress, StageOutcome};
use crate::error::Result;
use crate::sinks::dataset;

/// The ids of one event in a many-event dataset, (structure, event), in the
/// canonical form of [`dataset::partition_value`]: the manifest's
/// `structure.id`, else its `structure.name`, else (a network's zip as
/// published, no manifest) the recording station `NETWORK.STATION` most of
/// the records' headers give, so that the events of one instrumented
/// structure share a partition, else `unknown`; the manifest's `event.id`,
/// else the event folder's name (the zip's without its extension).  The
/// free-text names are columns of `event/event.parquet`.
pub fn event_ids(event: &Path) -> Result<(String, String)> {
    let manifest = crate::event_folder::read_manifest(event)?;
    let folder = event
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let stated = |s: &Option<String>| s.clone().filter(|v| !v.trim().is_empty());
    let structure = manifest
        .as_ref()
        .and_then(|m| m.structure.as_ref())
        .and_then(|s| stated(&s.id).or_else(|| stated(&s.name)))
        .or_else(|| recording_station(event))
        .unwrap_or_else(|| dataset::UNKNOWN_STRUCTURE.into());
    let event_id = manifest
        .as_ref()
        .and_then(|m| stated(&m.event.id))
        .unwrap_or(folder);
    Ok((
        dataset::partition_value(&structure),
        dataset::partition_value(&event_id),
    ))
}

/// The Hive partition of one event, `structure=<id>/event=<id>` ([`event_ids`]),
/// relative to the dataset root.
pub fn event_partition(event: &Path) -> Result<PathBuf> {
    let (structure, event) = event_ids(event)?;
    Ok(dataset::partition(&structure, &event))
}

/// The station of an event without a manifest's structure, from its
/// records' headers (samples are let go as they are read).  An event that
/// cannot be read is `None` here: its run says why, under
/// `structure=unknown`.
fn recording_station(event: &Path) -> Option<String> {
    let loaded = crate::event_folder::load_headers(event).ok()?;
    let channels = loaded.event.records.iter().map(|r| &r.channel);
    crate::vocab::most_common_station(
        channels.map(|c| (c.network.as_deref(), c.station.as_deref())),
    )
}

/// How adding one event to a dataset ended.
#[derive(Debug)]
pub struct DatasetRun {
    /// The event's partition (`None` when the event could not be read far
    /// enough to name it).
    pub partition: Option<PathBuf>,
    /// Its run directory `DIR/runs/<partition>/`.
    pub run_dir: Option<PathBuf>,
    pub result: Result<Vec<(String, StageOutcome)>>,
}

/// Runs `pipeline` on `event` into its run directory under the dataset
/// `root` and publishes its tables.  Idempotent: a second call on the same
/// event finds every stage up to date and publishes the same files again, so
/// the event is in the dataset once however often (or however interrupted)
/// it was added.  `progress.label` is set to the partition.
pub fn add_event(pipeline: &Pipeline, event: &Path, root: &Path, quiet: bool) -> DatasetRun {
    let mut run = DatasetRun {
        partition: None,
        run_dir: None,
        result: Ok(Vec::new()),
    };
    run.result = event_partition(event).and_then(|partition| {
        let dir = dataset::run_dir(root, &partition);
        run.partition = Some(partition.clone());
        run.run_dir = Some(dir.clone());
        let progress = Progress {
            quiet,
            label: Some(partition.display().to_string()),
        };
        let outcomes = run_showing(pipeline, event, &dir, &progress)?;
        dataset::publish_tables(root, &partition, &dir)?;
        Ok(outcomes)
    });
    run
}
