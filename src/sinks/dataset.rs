//! The many-event dataset layout (docs/cli.md, "Many events"): one folder per
//! table under `tables/`, Hive-partitioned by structure id and event id, so
//! that one table across a network's events is one query for pyarrow, DuckDB
//! and polars, and a glob over the table tree meets each table once:
//!
//! ```text
//! DIR/tables/<table>/structure=<S>/event=<E>/part-0.parquet   one file per table and event
//! DIR/runs/structure=<S>/event=<E>/          the event's run: run.json, event.json,
//!                                            report.html, twin_updated.toml, tables
//! DIR/history/structure=<S>/                 the structure's history (quaketwin history)
//! DIR/_watch/                                quaketwin watch's journal and outbox
//! ```
//!
//! `<S>` and `<E>` are ids ([`partition_value`]): the manifest's
//! `structure.id` / `event.id` when stated, else the structure's name / the
//! event folder's name in a canonical form; the free text is in the
//! `event` table (`structure_name`, `event_name`).  The run directories hold
//! the same tables again under `runs/`, a sibling of `tables/`, so that no
//! glob under `tables/` counts them twice (issue 34).
//!
//! Each event runs into its own run directory (locked, with its run manifest,
//! re-run stage by stage like any single-event run); its tables are then
//! *published* into the table folders as hard links to the run's files (no
//! copy; a copy where the file system refuses links).  The writers replace
//! a file by renaming a new one over it, never by writing into it, so a
//! published link keeps the bytes of the run that published it until the
//! next publication replaces it.  JSON, HTML and TOML never enter a table
//! folder, so a glob over a table folder meets one schema only.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::vocab::tables;

/// Folder of the per-event run directories, beside the table tree.
pub const RUNS_DIR: &str = "runs";
/// Folder of the table folders (the table tree): `DIR/tables/<table>/…`.
pub const TABLES_DIR: &str = "tables";
/// The one file of a table in an event's partition.
pub const PART_FILE: &str = "part-0.parquet";
/// Folder of the structure histories (`quaketwin history`, refreshed by
/// `quaketwin watch`), beside the table folders.
pub const HISTORY_DIR: &str = "history";

/// Where the history of the structure whose partition value is `structure`
/// lives in the dataset `root`: `root/history/structure=<S>/` (its
/// `history_*.parquet` and `history.html`; read by the dashboard).
pub fn history_dir(root: &Path, structure: &str) -> PathBuf {
    root.join(HISTORY_DIR)
        .join(format!("structure={}", partition_value(structure)))
}

/// The folder of `table` in the dataset `root`: `root/tables/<table>`.
pub fn table_dir(root: &Path, table: &str) -> PathBuf {
    root.join(TABLES_DIR).join(table)
}

/// A Hive partition value: the id of a structure or an event in a canonical
/// form — ASCII letters lower-cased, digits, `_` and `.` kept, every run of
/// anything else (spaces, `/`, `=`, `-`, accents) one `-`, no `-` at either
/// end — so that a name can neither leave its folder nor break the
/// `key=value` form, two spellings of one name ("Building A", "building-a")
/// are one partition, and the value is the same on a case-insensitive file
/// system.  Idempotent: a value maps to itself.
pub fn partition_value(s: &str) -> String {
    let mut v = String::with_capacity(s.len());
    for c in s.trim().chars() {
        if c.is_ascii_alphanumeric() || c == '_' || c == '.' {
            v.push(c.to_ascii_lowercase());
        } else if !v.is_empty() && !v.ends_with('-') {
            v.push('-');
        }
    }
    let v = v.trim_end_matches('-').to_string();
    match v.as_str() {
        "" => "unnamed".into(),
        // `.` and `..` are path components, not names.
        "." | ".." => v.replace('.', "_"),
        _ => v,
    }
}

/// The `structure=` value of events whose structure nothing names (no
/// manifest name, no station in the headers).
pub const UNKNOWN_STRUCTURE: &str = "unknown";

/// The partition path `structure=<S>/event=<E>` (relative).
pub fn partition(structure: &str, event: &str) -> PathBuf {
    Path::new(&format!("structure={}", partition_value(structure)))
        .join(format!("event={}", partition_value(event)))
}

/// The run directory of the event at `partition` under the dataset `root`.
pub fn run_dir(root: &Path, partition: &Path) -> PathBuf {
    root.join(RUNS_DIR).join(partition)
}

/// Publishes the tables of the run at `run_dir` into the table folders of
/// `root` for `partition`, and withdraws this partition's files of tables the
/// run no longer has (a stage that no longer applies): after it, the table
/// folders hold exactly this run's tables for this event.  Only files named
/// after a declared table are published.  Returns the published paths.
pub fn publish_tables(root: &Path, partition: &Path, run_dir: &Path) -> Result<Vec<PathBuf>> {
    let produced: Vec<&'static str> = produced_tables(run_dir)?;
    let mut published = Vec::with_capacity(produced.len());
    for name in &produced {
        let from = run_dir.join(tables::table_file_of(name));
        let dir = table_dir(root, name).join(partition);
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        let to = dir.join(PART_FILE);
        link_or_copy_atomically(&from, &to)?;
        published.push(to);
    }
    // Withdraw what an earlier run of this event published and this one
    // did not produce.
    for t in tables::ALL_TABLES {
        if produced.contains(&t.name) {
            continue;
        }
        let dir = table_dir(root, t.name).join(partition);
        let stale = dir.join(PART_FILE);
        match std::fs::symlink_metadata(&stale) {
            Ok(m) if m.is_file() => {
                std::fs::remove_file(&stale).map_err(|e| Error::io(&stale, e))?;
                // Empty folders go too (best effort: another event may share the structure folder).
                let _ = std::fs::remove_dir(&dir);
                if let Some(parent) = dir.parent() {
                    let _ = std::fs::remove_dir(parent);
                }
            }
            Ok(_) => {
                return Err(Error::output(
                    &stale,
                    "not a regular file: refusing to remove it from the dataset",
                ))
            }
            Err(_) => {}
        }
    }
    Ok(published)
}

/// The declared tables a run directory holds (regular files at their
/// declared path, `<table>/<table>.parquet`), sorted by table name.
fn produced_tables(run_dir: &Path) -> Result<Vec<&'static str>> {
    std::fs::metadata(run_dir).map_err(|e| Error::io(run_dir, e))?;
    let mut produced: Vec<&'static str> = tables::ALL_TABLES
        .iter()
        .filter(|t| std::fs::symlink_metadata(run_dir.join(t.file)).is_ok_and(|m| m.is_file()))
        .map(|t| t.name)
        .collect();
    produced.sort_unstable();
    Ok(produced)
}

/// The tables of a run directory as (file, table) pairs, for a publisher
/// other than [`publish_tables`] (the Python fleet writes them to any
/// fsspec file system): the run's `DIR/<file>` goes to
/// `ROOT/tables/<table>/<partition>/part-0.parquet`.
pub fn run_tables(run_dir: &Path) -> Result<Vec<(String, String)>> {
    Ok(produced_tables(run_dir)?
        .into_iter()
        .map(|t| (tables::table_file_of(t), t.to_string()))
        .collect())
}

/// Puts a hard link to `from` (a copy where linking fails) at `to` (its
/// folder created): made
/// under a temporary name beside `to`, then renamed over it, so a reader of
/// the dataset sees the old file or the new one, never a missing or half
/// file.  Anything but a regular file at `to` is an error, never replaced.
pub fn link_or_copy_atomically(from: &Path, to: &Path) -> Result<()> {
    if let Some(dir) = to.parent() {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    }
    if let Ok(m) = std::fs::symlink_metadata(to) {
        if !m.is_file() {
            return Err(Error::output(
                to,
                "not a regular file: refusing to replace it with a table",
            ));
        }
    }
    // Temporary files a killed publication left are swept first.
    let name = to
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let prefix = format!(".{name}.quaketwin-");
    if let Some(Ok(entries)) = to.parent().map(std::fs::read_dir) {
        for e in entries.flatten() {
            let name = e.file_name();
            let name = name.to_string_lossy();
            if name.starts_with(&prefix) && name.ends_with(".tmp") {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
    // Already published (a re-run whose stage was up to date kept the file):
    // nothing to do.  Linking anew would be worse than useless: rename(a, b)
    // of two links to one inode is a no-op that leaves `a`, so every re-run
    // left a temporary file behind.
    if same_file(from, to) {
        return Ok(());
    }
    let tmp = to.with_file_name(format!("{prefix}{}.tmp", std::process::id()));
    if std::fs::hard_link(from, &tmp).is_err() {
        std::fs::copy(from, &tmp).map_err(|e| Error::io(&tmp, e))?;
    }
    let renamed = std::fs::rename(&tmp, to).map_err(|e| Error::io(to, e));
    // Gone after a rename, unless `to` became a link to the same inode in
    // between (the no-op above); gone after a failure too.
    if std::fs::symlink_metadata(&tmp).is_ok() {
        let _ = std::fs::remove_file(&tmp);
    }
    renamed
}

/// Whether `a` and `b` are the same file (device and inode; never
/// following a link at `b`).
fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (std::fs::metadata(a), std::fs::symlink_metadata(b)) {
            (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        let _ = (a, b);
        false
    }
}

/// The values of the `key=` sub-folders of `dir`, sorted (none when `dir`
/// is absent).
pub fn partition_values(dir: &Path, key: &str) -> Result<Vec<String>> {
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(Error::io(dir, e)),
    };
    let prefix = format!("{key}=");
    let mut out: Vec<String> = entries
        .flatten()
        .filter(|e| e.path().is_dir())
        .filter_map(|e| {
            e.file_name()
                .to_str()
                .and_then(|n| n.strip_prefix(&prefix).map(str::to_string))
        })
        .collect();
    out.sort();
    Ok(out)
}

/// The (structure, event) partitions under `root` (`runs/` or a table
/// folder, [`table_dir`]), sorted.
pub fn partitions_under(root: &Path) -> Result<Vec<(String, String)>> {
    let mut out = Vec::new();
    for s in partition_values(root, "structure")? {
        for e in partition_values(&root.join(format!("structure={s}")), "event")? {
            out.push((s.clone(), e));
        }
    }
    Ok(out)
}

/// One event of a dataset: its partition values and the tables it published.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DatasetEvent {
    /// The `structure=` value.
    pub structure: String,
    /// The `event=` value.
    pub event: String,
    /// `structure=<S>/event=<E>` (relative).
    pub partition: PathBuf,
    /// Declared tables with a `part-0.parquet` in this partition, in the
    /// order of [`tables::ALL_TABLES`].
    pub tables: Vec<&'static str>,
}

impl DatasetEvent {
    /// The file of `table` for this event under `root`.
    pub fn table_file(&self, root: &Path, table: &str) -> PathBuf {
        table_dir(root, table).join(&self.partition).join(PART_FILE)
    }

    /// The event's run directory under `root`.
    pub fn run_dir(&self, root: &Path) -> PathBuf {
        run_dir(root, &self.partition)
    }
}

/// What a directory holds as a dataset: `Ok(None)` when it is no dataset
/// at all (neither a table folder with `structure=` partitions nor a
/// `runs/` folder), else its events, sorted by structure then event (an
/// empty list for a dataset every event of which was withdrawn).  Read from
/// the table folders (`tables/<table>/structure=<S>/event=<E>/part-0.parquet`) of
/// the declared tables only; an event that published no table (its run
/// failed) is not listed.
pub fn list_events(root: &Path) -> Result<Option<Vec<DatasetEvent>>> {
    let mut is_dataset = root.join(RUNS_DIR).is_dir();
    let mut events: std::collections::BTreeMap<(String, String), Vec<&'static str>> =
        Default::default();
    for table in tables::ALL_TABLES {
        let folder = table_dir(root, table.name);
        if !partition_values(&folder, "structure")?.is_empty() {
            is_dataset = true;
        }
        for (structure, event) in partitions_under(&folder)? {
            let part = folder
                .join(format!("structure={structure}"))
                .join(format!("event={event}"))
                .join(PART_FILE);
            if std::fs::symlink_metadata(&part).is_ok_and(|m| m.is_file()) {
                events
                    .entry((structure, event))
                    .or_default()
                    .push(table.name);
            }
        }
    }
    if !is_dataset {
        return Ok(None);
    }
    Ok(Some(
        events
            .into_iter()
            .map(|((structure, event), tables)| DatasetEvent {
                partition: Path::new(&format!("structure={structure}"))
                    .join(format!("event={event}")),
                structure,
                event,
                tables,
            })
            .collect(),
    ))
}
