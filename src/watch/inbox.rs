//! The inbox of `quaketwin watch`: which of its entries are events, and when
//! an upload is complete.
//!
//! An entry is a folder or a `.zip` file directly inside the inbox.  Names
//! that uploaders use while a transfer runs are not entries: hidden names
//! (`.name…`, rsync's and many clients' temporary files), `*.part`,
//! `*.partial`, `*.tmp`, `*.crdownload`, `*.filepart`; nor is a `.done`
//! marker.  The inbox is only read: nothing in it is written, moved or
//! removed (the journal in the dataset says what was processed).
//!
//! Complete means ([`Settling::judge`]):
//! - a marker says so — `NAME.done` beside the entry, or `NAME/.done` inside
//!   a folder — and, for a zip, its central directory reads
//!   ([`crate::event_folder::zip_is_whole`]); or
//! - without `--require-done`: the entry's fingerprint (every file's name,
//!   size and modification time) has not changed for the settle period, and,
//!   for a zip, its central directory reads.  A zip is written front to
//!   back with its directory last, so a truncated zip never passes, however
//!   long it rests; a folder has no such structure, so an uploader that
//!   pauses longer than the settle period between two files should write a
//!   marker (docs/monitoring-network.md).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::error::{Error, Result};

/// Suffix of a completion marker (`NAME.done`, or `.done` inside a folder).
pub const DONE_SUFFIX: &str = ".done";

/// Suffixes of files an upload is still writing.
const IN_TRANSIT_SUFFIXES: [&str; 5] = [".part", ".partial", ".tmp", ".crdownload", ".filepart"];

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EntryKind {
    Folder,
    Zip,
}

/// One event in the inbox.
#[derive(Debug, Clone)]
pub struct Entry {
    /// Its name in the inbox (the journal's key).
    pub name: String,
    pub path: PathBuf,
    pub kind: EntryKind,
    /// Whether a completion marker exists for it.
    pub marked_done: bool,
}

/// What a scan of the inbox found.
#[derive(Debug, Default)]
pub struct Scan {
    /// The entries, sorted by name.
    pub entries: Vec<Entry>,
    /// Names that are neither a folder nor a zip (nor in transit, nor a marker).
    pub ignored: Vec<String>,
}

/// Whether `name` is a file an upload is still writing, or a marker.
fn in_transit_or_marker(name: &str) -> bool {
    let lower = name.to_ascii_lowercase();
    name.starts_with('.')
        || lower.ends_with(DONE_SUFFIX)
        || IN_TRANSIT_SUFFIXES.iter().any(|s| lower.ends_with(s))
}

/// The entries of `inbox` (see the module doc).
pub fn scan(inbox: &Path) -> Result<Scan> {
    let mut found = Scan::default();
    for item in std::fs::read_dir(inbox).map_err(|e| Error::io(inbox, e))? {
        let item = item.map_err(|e| Error::io(inbox, e))?;
        let Some(name) = item.file_name().to_str().map(str::to_string) else {
            found
                .ignored
                .push(item.file_name().to_string_lossy().into_owned());
            continue;
        };
        if in_transit_or_marker(&name) {
            continue;
        }
        let path = item.path();
        // Followed: a link in the inbox is the user's way of naming an event.
        let kind = match std::fs::metadata(&path) {
            Ok(m) if m.is_dir() => EntryKind::Folder,
            Ok(m) if m.is_file() && name.to_ascii_lowercase().ends_with(".zip") => EntryKind::Zip,
            _ => {
                found.ignored.push(name);
                continue;
            }
        };
        let marked_done = inbox.join(format!("{name}{DONE_SUFFIX}")).is_file()
            || (kind == EntryKind::Folder && path.join(DONE_SUFFIX).is_file());
        found.entries.push(Entry {
            name,
            path,
            kind,
            marked_done,
        });
    }
    found.entries.sort_by(|a, b| a.name.cmp(&b.name));
    found.ignored.sort();
    Ok(found)
}

/// Whether an entry can be processed now.
#[derive(Debug, Clone, PartialEq)]
pub enum Judgement {
    Complete,
    /// Still changing, or not yet at rest for the settle period (or
    /// waiting for its marker): looked at again at the next poll.
    Waiting(String),
    /// No marker, and only a marker completes an entry (`--require-done`):
    /// nothing but the uploader can change that (`--once` does not wait for it).
    Unmarked(String),
    /// At rest for the settle period but not whole (a zip whose directory
    /// does not read): never processed as it is; looked at again when it
    /// changes.
    Incomplete(String),
}

/// The settle clock of each entry: its fingerprint and since when it has
/// not changed (in this process: a restarted watch observes again, except
/// for an entry the journal says it had begun, [`Settling::judge`]).
#[derive(Debug, Default)]
pub struct Settling {
    seen: HashMap<String, (String, Instant)>,
}

/// How completeness is decided (the command's flags).
#[derive(Debug, Clone, Copy)]
pub struct CompletionRule {
    /// How long an entry must rest unchanged.
    pub settle: Duration,
    /// Only a marker completes an entry.
    pub require_done: bool,
}

impl Settling {
    /// Judges `entry`, whose fingerprint is now `fingerprint`.  `begun`: the
    /// journal holds this entry with this fingerprint as begun by an earlier
    /// run (judged complete then; killed while processing it).
    pub fn judge(
        &mut self,
        entry: &Entry,
        fingerprint: &str,
        begun: bool,
        rule: CompletionRule,
        now: Instant,
    ) -> Judgement {
        let since = match self.seen.get(&entry.name) {
            Some((fp, since)) if fp == fingerprint => *since,
            _ => {
                self.seen
                    .insert(entry.name.clone(), (fingerprint.to_string(), now));
                now
            }
        };
        let at_rest = now.duration_since(since) >= rule.settle;
        let whole = || match entry.kind {
            EntryKind::Folder => Ok(()),
            EntryKind::Zip => crate::event_folder::zip_is_whole(&entry.path).map(|_| ()),
        };
        if begun {
            return Judgement::Complete;
        }
        if entry.marked_done {
            return match whole() {
                Ok(()) => Judgement::Complete,
                // Marked done yet not whole: processed once at rest, so that
                // the failure is reported (a marker written before the last
                // bytes landed gets the settle period to catch up).
                Err(_) if at_rest => Judgement::Complete,
                Err(why) => Judgement::Waiting(format!("marked done, zip not whole yet: {why}")),
            };
        }
        if rule.require_done {
            return Judgement::Unmarked(format!("no {}{DONE_SUFFIX} marker yet", entry.name));
        }
        if !at_rest {
            return Judgement::Waiting(format!(
                "changed {:.1} s ago (settle period {:.1} s)",
                now.duration_since(since).as_secs_f64(),
                rule.settle.as_secs_f64()
            ));
        }
        match whole() {
            Ok(()) => Judgement::Complete,
            Err(why) => Judgement::Incomplete(format!("zip not whole: {why}")),
        }
    }

    /// Forgets entries no longer in the inbox.
    pub fn retain(&mut self, names: &[&str]) {
        self.seen.retain(|n, _| names.contains(&n.as_str()));
    }
}
