//! The stage mechanism: a pipeline file lists named stages; each stage has
//! a kind (what it computes), parameters, the earlier stages it reads, and
//! output files.  Data flows one way: stages hand their products to later
//! stages through the `RunContext` (in memory) and through their output
//! files (when a stage was skipped, later stages load its products back from
//! them).
//!
//! An output directory holds the results of one run of one event:
//! - a run takes the directory's lock (`lock`, `DIR/.quaketwin.lock`) for
//!   its whole length, so two runs never write into one directory;
//! - the run manifest (`manifest`, `DIR/run.json`) records the event and,
//!   per stage, the fingerprint of its inputs and settings and the size and
//!   hash of each output.  Before anything runs, outputs of another event,
//!   of stages that no longer apply and of stages that did not finish are
//!   removed, with a note on stderr; temporary files of interrupted runs
//!   are swept;
//! - a stage is skipped as up to date only when its fingerprint matches and
//!   every output still has its recorded size and hash; a damaged output is
//!   removed and rebuilt.

pub mod config;
pub mod context;
pub mod dataset;
pub mod fingerprint;
pub mod lock;
pub mod manifest;
pub mod spill;
pub mod stage;

use std::path::Path;
use std::time::Instant;

pub use config::{Pipeline, PlannedStage, StageDecl, StageSource};
pub use context::RunContext;
pub use stage::{Product, ProductKind, Stage, StageKind};

use crate::error::{Error, Result};
use crate::hash::Hash64;
use manifest::{EventIdentity, OutputRecord, RunManifest, StageRecord, StageState};

/// What happened to one stage in a run.
#[derive(Debug, Clone, PartialEq)]
pub enum StageOutcome {
    Ran {
        seconds: f64,
    },
    Skipped,
    Disabled,
    /// The stage does not apply to this event (the reason says why).
    NotApplicable(String),
}

/// Notes for the user about what a run removes or takes over, on stderr
/// (shown even with `--quiet`: they say why files disappeared).
fn note(msg: &str) {
    crate::console::note(msg);
}

/// How a run shows its progress on stderr ([`crate::console`]).
#[derive(Debug, Clone, Default)]
pub struct Progress {
    /// No bar and no stage lines for this run (warnings and notes still show).
    pub quiet: bool,
    /// The event's label in a many-event run: its bar is prefixed with it,
    /// and its stage lines (prefixed too) are shown with `-v` only, so that
    /// parallel events do not interleave their lines.
    pub label: Option<String>,
}

impl Progress {
    /// A progress line: shown by default for a one-event run, with `-v`
    /// (labelled) in a many-event run, never when the run is quiet.
    pub fn line(&self, line: impl std::fmt::Display) {
        match (&self.label, self.quiet) {
            (_, true) => {}
            (None, false) => crate::console::info(line),
            (Some(label), false) => crate::console::detail(format!("{label}: {line}")),
        }
    }
}

/// The stamp directory of quaketwin versions before the run manifest.
const LEGACY_STAMP_DIR: &str = ".quaketwin";

/// Whether `name` is an output file's name relative to the output
/// directory: a plain file name directly inside it (`report.html`) or inside
/// one folder of its own (a table: `modes/modes.parquet`) — no other
/// separator, no `.`/`..`, nothing hidden (hidden names are quaketwin's own
/// lock and temporary files), not the run manifest.
pub(crate) fn is_plain_name(name: &str) -> bool {
    let parts: Vec<_> = Path::new(name).components().collect();
    let normal = |c: &std::path::Component| {
        matches!(c, std::path::Component::Normal(n)
            if !n.to_string_lossy().starts_with('.'))
    };
    (1..=2).contains(&parts.len())
        && parts.iter().all(normal)
        && !name.ends_with('/')
        && name != manifest::MANIFEST_FILE
}

/// Creates the output directory, or checks that the existing path is one
/// (a symbolic link to a directory is fine).
fn prepare_out_dir(out: &Path) -> Result<()> {
    match std::fs::metadata(out) {
        Ok(m) if m.is_dir() => Ok(()),
        Ok(_) => Err(Error::usage(format!(
            "{}: the output path exists and is not a directory",
            out.display()
        ))),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))
        }
        Err(e) => Err(Error::io(out, e)),
    }
}

/// The event's path as recorded in the manifest: absolute, links resolved.
fn event_path_string(p: &Path) -> String {
    std::fs::canonicalize(p)
        .unwrap_or_else(|_| p.to_path_buf())
        .display()
        .to_string()
}

/// Removes the regular files among `names` in `out` (a link, directory or
/// other non-regular file is left alone: writing there is refused later),
/// and a table's folder when that leaves it empty; returns the names
/// removed, sorted.  Names that are not output names ([`is_plain_name`]: a
/// hand-edited manifest) are ignored.
fn remove_files(out: &Path, names: impl IntoIterator<Item = String>) -> Result<Vec<String>> {
    let mut removed = std::collections::BTreeSet::new();
    for n in names {
        if !is_plain_name(&n) {
            continue;
        }
        let p = out.join(&n);
        if let Ok(m) = std::fs::symlink_metadata(&p) {
            if m.file_type().is_file() {
                std::fs::remove_file(&p).map_err(|e| Error::io(&p, e))?;
                if let Some((folder, _)) = n.split_once('/') {
                    // Only an empty real folder goes (remove_dir refuses the rest).
                    let _ = std::fs::remove_dir(out.join(folder));
                }
                removed.insert(n);
            }
        }
    }
    Ok(removed.into_iter().collect())
}

/// Names of the files quaketwin's stages write by default: every table of
/// `vocab::tables` (and the raw samples beside the conditioned ones), the
/// run's JSON and HTML, the updated twin, the design's matrices.  Kept here
/// as the one list the output directory's cleaning needs; a stage that
/// writes a new default file name adds it to its table or to this list.
pub fn known_output_names() -> impl Iterator<Item = String> {
    known_output_names_static().map(str::to_string)
}

fn known_output_names_static() -> impl Iterator<Item = &'static str> {
    const OTHER_OUTPUTS: &[&str] = &[
        "samples_as_recorded/samples_as_recorded.parquet",
        "samples_as_recorded.parquet",
        "event.json",
        "report.html",
        "tracking.html",
        "twin_updated.toml",
        "rehearsal_model.json",
        "prototype_stiffness.mtx",
        "prototype_mass.mtx",
        "ps_basis.mtx",
    ];
    // A table's flat file name (`modes.parquet`) is where quaketwin versions
    // before the per-table folders wrote it: such a file is not of this run.
    crate::vocab::tables::ALL_TABLES
        .iter()
        .flat_map(|t| [t.file, t.flat_file()])
        .chain(OTHER_OUTPUTS.iter().copied())
}

/// Outputs listed by the stamps of quaketwin versions before the run
/// manifest (`DIR/.quaketwin/<stage>.stamp.json`); the stamps are removed.
fn take_legacy_stamps(out: &Path) -> Result<Vec<String>> {
    let dir = out.join(LEGACY_STAMP_DIR);
    match std::fs::symlink_metadata(&dir) {
        Ok(m) if m.is_dir() => {}
        _ => return Ok(Vec::new()),
    }
    let mut files = Vec::new();
    for entry in std::fs::read_dir(&dir).map_err(|e| Error::io(&dir, e))? {
        let entry = entry.map_err(|e| Error::io(&dir, e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        let p = entry.path();
        if !entry.file_type().map(|t| t.is_file()).unwrap_or(false) {
            continue;
        }
        if name.ends_with(".stamp.json") {
            if let Ok(v) = serde_json::from_slice::<serde_json::Value>(
                &crate::input_file::read(&p, crate::input_file::MAX_INPUT_BYTES)
                    .unwrap_or_default(),
            ) {
                if let Some(list) = v.get("outputs").and_then(|o| o.as_array()) {
                    files.extend(list.iter().filter_map(|s| s.as_str().map(String::from)));
                }
            }
            std::fs::remove_file(&p).map_err(|e| Error::io(&p, e))?;
        } else if crate::sinks::atomic::is_temp_name(&name) {
            std::fs::remove_file(&p).map_err(|e| Error::io(&p, e))?;
        }
    }
    let _ = std::fs::remove_dir(&dir); // only when nothing else is in it
    Ok(files)
}

/// Puts `rec` into the manifest in place of the record of the same stage,
/// keeping the records in pipeline order.
fn set_record(m: &mut RunManifest, rec: StageRecord, pipeline: &Pipeline) {
    m.stages.retain(|r| r.name != rec.name);
    m.stages.push(rec);
    let pos = |name: &str| {
        pipeline
            .stages
            .iter()
            .position(|s| s.decl.name == name)
            .unwrap_or(usize::MAX)
    };
    m.stages.sort_by_key(|r| pos(&r.name));
}

fn hash_record(h: &mut Hash64, r: Option<&StageRecord>) {
    match r {
        None => {
            h.write_str("absent");
        }
        Some(r) => {
            h.write_str(&r.name)
                .write_str(&format!("{:?}", r.state))
                .write_str(&r.fingerprint);
            for o in &r.outputs {
                h.write_str(&o.file)
                    .write_str(o.xxh64.as_deref().unwrap_or(""));
            }
        }
    }
}

/// Fingerprint of a stage: version, kind, name, params, the event, inputs
/// outside the event folder, and the fingerprints and output hashes of the
/// stages it reads (for the report: of every earlier stage).
fn stage_fingerprint(
    planned: &PlannedStage,
    index: usize,
    event_fp: &str,
    ctx: &mut RunContext,
    current: &RunManifest,
    pipeline: &Pipeline,
) -> Result<String> {
    let stage = &planned.decl;
    let mut h = Hash64::default();
    h.write_str(env!("CARGO_PKG_VERSION"))
        .write_str(&stage.kind)
        .write_str(&stage.name);
    h.write_str(&toml::to_string(&stage.params).unwrap_or_default());
    h.write_str(event_fp);
    h.write_str(&planned.stage.extra_fingerprint(ctx)?);
    if planned.kind.reads_all_earlier {
        for s in &pipeline.stages[..index] {
            hash_record(&mut h, current.stage(&s.decl.name));
        }
    } else {
        for i in &stage.inputs {
            hash_record(&mut h, current.stage(i));
        }
    }
    Ok(h.finish_hex())
}

/// Runs `pipeline` on the event at `event_path`, writing into `out`.
/// Returns the outcome of every stage, in order.  Holds the directory's
/// lock for the whole run; keeps the run manifest `out/run.json`.
pub fn run(
    pipeline: &Pipeline,
    event_path: &Path,
    out: &Path,
    quiet: bool,
) -> Result<Vec<(String, StageOutcome)>> {
    let progress = Progress { quiet, label: None };
    run_showing(pipeline, event_path, out, &progress)
}

/// [`run`], showing its progress as `progress` says.
pub fn run_showing(
    pipeline: &Pipeline,
    event_path: &Path,
    out: &Path,
    progress: &Progress,
) -> Result<Vec<(String, StageOutcome)>> {
    crate::fixed_order_reductions();
    prepare_out_dir(out)?;
    let event_fp = fingerprint::path_fingerprint(event_path)?;
    let event = EventIdentity {
        path: event_path_string(event_path),
        fingerprint: event_fp,
    };
    let lock = lock::DirLock::acquire(
        out,
        &format!("pipeline {} on {}", pipeline.pipeline.name, event.path),
    )?;
    if let Some(said) = &lock.took_over {
        note(said);
    }
    let result = run_locked(pipeline, event_path, &event, out, progress);
    drop(lock);
    result
}

/// Removes the temporary files an interrupted run left in `out`, saying so.
fn sweep_interrupted(out: &Path) -> Result<()> {
    let mut swept = crate::sinks::atomic::sweep_temp_files(out)?;
    // And in the tables' folders (real folders only, never through a link).
    let folders: std::collections::BTreeSet<&str> = known_output_names_static()
        .filter_map(|n| n.split_once('/').map(|(folder, _)| folder))
        .collect();
    for folder in folders {
        let dir = out.join(folder);
        if std::fs::symlink_metadata(&dir).is_ok_and(|m| m.is_dir()) {
            swept.extend(
                crate::sinks::atomic::sweep_temp_files(&dir)?
                    .into_iter()
                    .map(|n| format!("{folder}/{n}")),
            );
        }
    }
    if !swept.is_empty() {
        note(&format!(
            "{}: removed temporary files of an interrupted run: {}",
            out.display(),
            swept.join(", ")
        ));
    }
    Ok(())
}

/// A run manifest of this quaketwin for `pipeline` on `event`, no stage yet.
fn empty_manifest(pipeline: &str, event: EventIdentity) -> RunManifest {
    RunManifest {
        format: manifest::FORMAT,
        quaketwin_version: env!("CARGO_PKG_VERSION").into(),
        pipeline: pipeline.into(),
        event,
        stages: Vec::new(),
    }
}

/// Brings the directory to a state holding only trusted results of this
/// event (see the module doc) and returns the manifest to continue from.
fn clean_out_dir(out: &Path, pipeline: &Pipeline, event: &EventIdentity) -> Result<RunManifest> {
    sweep_interrupted(out)?;
    let mut current = empty_manifest(&pipeline.pipeline.name, event.clone());
    // (reason, files) groups to remove, said per group.
    let mut groups: Vec<(String, Vec<String>)> = Vec::new();
    let legacy = take_legacy_stamps(out)?;
    if !legacy.is_empty() {
        groups.push((
            "results of an earlier quaketwin version (no run manifest)".into(),
            legacy,
        ));
    }
    match manifest::read(out) {
        Err(why) => {
            let files = pipeline
                .stages
                .iter()
                .flat_map(|s| s.stage.outputs())
                .collect();
            groups.push((
                format!(
                    "results of unknown origin ({} is not a valid run manifest: {why})",
                    manifest::MANIFEST_FILE
                ),
                files,
            ));
        }
        Ok(None) => {}
        Ok(Some(old)) if old.event != *event => {
            let what = if old.event.path == event.path {
                format!("results of {} before its files changed", old.event.path)
            } else {
                format!("results of another event ({})", old.event.path)
            };
            groups.push((what, old.all_files()));
        }
        Ok(Some(old)) => {
            for r in old.stages {
                if pipeline.stages.iter().any(|s| s.decl.name == r.name) {
                    current.stages.push(r);
                } else {
                    let what = if r.kind == "extra" {
                        format!("files written by {}", r.name)
                    } else {
                        format!(
                            "outputs of stage {:?}, which is no longer in the pipeline",
                            r.name
                        )
                    };
                    groups.push((what, r.outputs.into_iter().map(|o| o.file).collect()));
                }
            }
        }
    }
    let kept = current.all_files();
    // A file bearing the name of a quaketwin output that no manifest lists
    // (another run's table dropped in, a directory of unknown origin) is
    // not a result of this run: it goes too, so the directory never shows
    // another event's file beside this one's.
    let stray: Vec<String> = known_output_names()
        .filter(|n| !kept.contains(n) && out.join(n).is_file())
        .collect();
    if !stray.is_empty() {
        groups.push((
            format!(
                "files named as quaketwin outputs that no run manifest lists ({})",
                manifest::MANIFEST_FILE
            ),
            stray,
        ));
    }
    for (what, files) in groups {
        let removed = remove_files(out, files.into_iter().filter(|f| !kept.contains(f)))?;
        if !removed.is_empty() {
            note(&format!(
                "{}: removing {what}: {}",
                out.display(),
                removed.join(", ")
            ));
        }
    }
    manifest::write(out, &current)?;
    Ok(current)
}

/// Marks a stage that does not run (disabled, not applicable) and removes
/// its outputs of an earlier run.
fn retire(
    out: &Path,
    current: &mut RunManifest,
    pipeline: &Pipeline,
    stage: &StageDecl,
    state: StageState,
    reason: Option<String>,
) -> Result<()> {
    let files = current
        .stage(&stage.name)
        .map(|r| r.outputs.iter().map(|o| o.file.clone()).collect::<Vec<_>>())
        .unwrap_or_default();
    let removed = remove_files(out, files)?;
    if !removed.is_empty() {
        let what = match state {
            StageState::Disabled => "is disabled",
            _ => "does not apply to this event",
        };
        note(&format!(
            "{}: stage {:?} {what}; removing its outputs of an earlier run: {}",
            out.display(),
            stage.name,
            removed.join(", ")
        ));
    }
    set_record(
        current,
        StageRecord {
            name: stage.name.clone(),
            kind: stage.kind.clone(),
            state,
            reason,
            fingerprint: String::new(),
            outputs: Vec::new(),
        },
        pipeline,
    );
    manifest::write(out, current)
}

fn run_locked(
    pipeline: &Pipeline,
    event_path: &Path,
    event: &EventIdentity,
    out: &Path,
    progress: &Progress,
) -> Result<Vec<(String, StageOutcome)>> {
    let mut current = clean_out_dir(out, pipeline, event)?;
    let mut ctx = RunContext::new(pipeline, event_path, out, progress.quiet);
    ctx.progress = progress.clone();
    let mut outcomes = Vec::new();
    // One bar over the stages (indicatif hides it when stderr is not a terminal).
    let bar = crate::console::bar(
        pipeline.stages.len() as u64,
        progress.label.as_deref().unwrap_or(""),
        "stages",
        progress.quiet,
    );
    let result = run_stages(
        pipeline,
        event,
        out,
        progress,
        &bar,
        &mut ctx,
        &mut current,
        &mut outcomes,
    );
    bar.finish_and_clear();
    result.map(|()| outcomes)
}

/// Why a stage cannot run because a product it needs comes from a stage
/// that did not run (disabled or not applicable).
fn missing_input(
    planned: &PlannedStage,
    pipeline: &Pipeline,
    outcomes: &[(String, StageOutcome)],
) -> Option<String> {
    planned.routes.iter().find_map(|&(product, from)| {
        let provider = &pipeline.stages[from].decl.name;
        match &outcomes.get(from)?.1 {
            StageOutcome::Disabled => Some(format!(
                "it needs {} from stage {provider:?}, which is disabled",
                product.describe()
            )),
            StageOutcome::NotApplicable(why) => Some(format!(
                "it needs {} from stage {provider:?}, which does not apply ({why})",
                product.describe()
            )),
            _ => None,
        }
    })
}

#[allow(clippy::too_many_arguments)]
fn run_stages(
    pipeline: &Pipeline,
    event: &EventIdentity,
    out: &Path,
    progress: &Progress,
    bar: &indicatif::ProgressBar,
    ctx: &mut RunContext,
    current: &mut RunManifest,
    outcomes: &mut Vec<(String, StageOutcome)>,
) -> Result<()> {
    // A stage line: shown by default for one event; with `-v` only (and
    // labelled) for one of many events running in parallel.
    let log = |line: String| progress.line(line);
    let name = &pipeline.pipeline.name;
    for (index, planned) in pipeline.stages.iter().enumerate() {
        let stage = &planned.decl;
        ctx.enter(index);
        bar.set_message(stage.name.clone());
        if !stage.enabled {
            retire(out, current, pipeline, stage, StageState::Disabled, None)?;
            bar.inc(1);
            outcomes.push((stage.name.clone(), StageOutcome::Disabled));
            continue;
        }
        let not_applicable = match missing_input(planned, pipeline, outcomes) {
            Some(why) => Some(why),
            None => planned.stage.not_applicable(ctx)?,
        };
        if let Some(why) = not_applicable {
            log(format!("[{name}] {:<12} not applicable: {why}", stage.name));
            retire(
                out,
                current,
                pipeline,
                stage,
                StageState::NotApplicable,
                Some(why.clone()),
            )?;
            bar.inc(1);
            outcomes.push((stage.name.clone(), StageOutcome::NotApplicable(why)));
            continue;
        }
        let outputs = planned.stage.outputs();
        for o in &outputs {
            if !is_plain_name(o) {
                return Err(Error::usage(format!(
                    "stage {:?}: output {o:?} is not a plain file name inside the output directory",
                    stage.name
                )));
            }
            // A link, directory, device or FIFO at an output path: refused before any work.
            crate::sinks::atomic::check_replaceable(&out.join(o))?;
        }
        let fp = stage_fingerprint(planned, index, &event.fingerprint, ctx, current, pipeline)?;
        let previous = current.stage(&stage.name).cloned();
        let mut damaged = Vec::new();
        let up_to_date = match &previous {
            Some(r)
                if r.state == StageState::Done
                    && r.kind == stage.kind
                    && r.fingerprint == fp
                    && r.outputs.iter().map(|o| &o.file).eq(outputs.iter()) =>
            {
                for o in &r.outputs {
                    if let Err(why) = manifest::verify_output(out, o)? {
                        damaged.push((o.file.clone(), why));
                    }
                }
                damaged.is_empty()
            }
            _ => false,
        };
        if up_to_date {
            log(format!("[{name}] {:<12} up to date, skipped", stage.name));
            bar.inc(1);
            outcomes.push((stage.name.clone(), StageOutcome::Skipped));
            continue;
        }
        // The stage runs: its earlier outputs go first, so a failure leaves
        // none of them behind as if they were current.
        if let Some(r) = &previous {
            remove_files(out, r.outputs.iter().map(|o| o.file.clone()))?;
            for (file, why) in &damaged {
                note(&format!(
                    "{}: not as {} recorded it ({why}); stage {:?} rebuilds it",
                    out.join(file).display(),
                    manifest::MANIFEST_FILE,
                    stage.name
                ));
            }
        }
        set_record(
            current,
            StageRecord {
                name: stage.name.clone(),
                kind: stage.kind.clone(),
                state: StageState::Started,
                reason: None,
                fingerprint: fp.clone(),
                outputs: outputs
                    .iter()
                    .map(|f| OutputRecord {
                        file: f.clone(),
                        bytes: None,
                        xxh64: None,
                    })
                    .collect(),
            },
            pipeline,
        );
        manifest::write(out, current)?;
        let t0 = Instant::now();
        let running = format!("[{name}] {:<12} running ({})", stage.name, stage.kind);
        if progress.label.is_none() && !progress.quiet {
            crate::console::detail(running);
        }
        let product = planned.stage.run(ctx).map_err(|e| match e {
            Error::Usage(m) => Error::Usage(format!("stage {:?}: {m}", stage.name)),
            Error::MissingPath { path, message } => Error::MissingPath {
                path,
                message: format!("stage {:?}: {message}", stage.name),
            },
            Error::Numerical(m) => Error::Numerical(format!("stage {:?}: {m}", stage.name)),
            other => other,
        })?;
        ctx.set_product(product);
        let records = outputs
            .iter()
            .map(|o| manifest::record_output(out, o))
            .collect::<Result<Vec<_>>>()?;
        set_record(
            current,
            StageRecord {
                name: stage.name.clone(),
                kind: stage.kind.clone(),
                state: StageState::Done,
                reason: None,
                fingerprint: fp,
                outputs: records,
            },
            pipeline,
        );
        manifest::write(out, current)?;
        let secs = t0.elapsed().as_secs_f64();
        // The files written are a detail (`-v`); the stage and its time are not.
        let files = if crate::console::verbosity() >= crate::console::Verbosity::Verbose {
            format!(" -> {}", outputs.join(", "))
        } else {
            String::new()
        };
        log(format!(
            "[{name}] {:<12} done in {:.2} s{files}",
            stage.name, secs
        ));
        bar.inc(1);
        outcomes.push((stage.name.clone(), StageOutcome::Ran { seconds: secs }));
    }
    Ok(())
}

/// Adds a file written into a pipeline output directory outside a stage
/// (`quaketwin report DIR`, `quaketwin ingest --mcap DIR/…`) to the run
/// manifest, under the lock: `write` writes it; the record `record` lists it.
/// Without a manifest in `dir` (not a pipeline output directory) the file is
/// written as is.  Returns what `write` returns.
pub fn write_extra_output<T>(
    dir: &Path,
    file: &str,
    record: &str,
    write: impl FnOnce() -> Result<T>,
) -> Result<T> {
    if !dir.join(manifest::MANIFEST_FILE).exists() || !is_plain_name(file) {
        return write();
    }
    let _lock = lock::DirLock::acquire(dir, &format!("writing {file}"))?;
    let value = write()?;
    let mut m = match manifest::read(dir) {
        Ok(Some(m)) => m,
        Ok(None) => return Ok(value),
        Err(why) => return Err(Error::output(dir.join(manifest::MANIFEST_FILE), why)),
    };
    let rec = manifest::record_output(dir, file)?;
    // The stage that wrote the file before (if any) now records it as it is,
    // with an empty fingerprint: the next run rebuilds it from its settings.
    let mut found = false;
    for s in m.stages.iter_mut() {
        if let Some(o) = s.outputs.iter_mut().find(|o| o.file == file) {
            *o = rec.clone();
            s.fingerprint.clear();
            found = true;
        }
    }
    if !found {
        m.stages.retain(|s| s.name != record);
        m.stages.push(StageRecord {
            name: record.into(),
            kind: "extra".into(),
            state: StageState::Done,
            reason: None,
            fingerprint: String::new(),
            outputs: vec![rec],
        });
    }
    manifest::write(dir, &m)?;
    Ok(value)
}

/// A command that writes its files into an output directory without a
/// pipeline (`quaketwin track`): the directory then holds the results of
/// this run only, as after `run`.  Under the directory's lock: temporary
/// files of an interrupted run are swept, every file the previous run
/// manifest lists is removed (said once), a manifest naming `input` and a
/// record `name` in state `started` is written, then `write` runs and the
/// record lists `outputs` (file names in `out`) as done.  A failed `write`
/// leaves the record `started`: nothing in the directory counts as a result.
pub fn run_one_shot<T>(
    out: &Path,
    name: &str,
    input: &Path,
    outputs: &[&str],
    write: impl FnOnce() -> Result<T>,
) -> Result<T> {
    prepare_out_dir(out)?;
    let event = EventIdentity {
        path: event_path_string(input),
        fingerprint: fingerprint::path_fingerprint(input)?,
    };
    let _lock = lock::DirLock::acquire(out, &format!("{name} on {}", event.path))?;
    sweep_interrupted(out)?;
    let mut stale = take_legacy_stamps(out)?;
    match manifest::read(out) {
        Ok(Some(old)) => stale.extend(old.all_files()),
        Ok(None) => {}
        Err(_) => stale.extend(outputs.iter().map(|f| f.to_string())),
    }
    let removed = remove_files(out, stale)?;
    if !removed.is_empty() {
        note(&format!(
            "{}: removing the results of the previous run: {}",
            out.display(),
            removed.join(", ")
        ));
    }
    let mut m = empty_manifest(name, event);
    m.stages.push(StageRecord {
        name: name.into(),
        kind: name.into(),
        state: StageState::Started,
        reason: None,
        fingerprint: String::new(),
        outputs: outputs
            .iter()
            .map(|f| manifest::OutputRecord {
                file: f.to_string(),
                bytes: None,
                xxh64: None,
            })
            .collect(),
    });
    manifest::write(out, &m)?;
    let value = write()?;
    let records = outputs
        .iter()
        .map(|f| manifest::record_output(out, f))
        .collect::<Result<Vec<_>>>()?;
    m.stages[0].outputs = records;
    m.stages[0].state = StageState::Done;
    manifest::write(out, &m)?;
    Ok(value)
}

/// Why the stage of kind `kind` did not apply in the run recorded in `dir`
/// (run.json), when it did not.
pub fn not_applicable_reason(dir: &Path, kind: &str) -> Option<String> {
    let m = manifest::read(dir).ok()??;
    m.stages
        .iter()
        .find(|s| s.kind == kind && s.state == manifest::StageState::NotApplicable)
        .and_then(|s| s.reason.clone())
}

/// The files a pipeline run lists as results of `dir` (the `done` stages of
/// its run manifest); `None` when `dir` has no run manifest (a directory
/// not written by `quaketwin run`: every file counts).
pub fn listed_results(dir: &Path) -> Option<Vec<String>> {
    match manifest::read(dir) {
        Ok(Some(m)) => Some(m.done_files()),
        Ok(None) => None,
        // An unreadable manifest lists nothing trustworthy.
        Err(_) => Some(Vec::new()),
    }
}
