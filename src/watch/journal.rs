//! The journal of `quaketwin watch`: `DATASET/_watch/state.json`, what was
//! done with each inbox entry, rewritten whole through the atomic writer
//! after every change (a reader — or a restart after `kill -9` — sees the
//! state before or after a step, never half of one).  Fields:
//! docs/formats.md ("watch state").
//!
//! The order of the steps makes a restart safe ([`super`]): an entry is
//! marked `processing` before its run, its notifications are in the outbox
//! before it is marked `done` (or `failed`), and `followed_up` is set once
//! the history hook and the dashboard ran for it.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Location, Result};

/// The journal's file name inside the state folder.
pub const STATE_FILE: &str = "state.json";
/// Layout version of the journal.
pub const FORMAT: u32 = 1;
/// Largest journal read back (a million entries take ≈ 400 MB: far more
/// than any network's events).
const MAX_STATE_BYTES: u64 = 1 << 30;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Judged complete and begun; a restart finds it here when killed during the run.
    Processing,
    /// In the dataset; its notifications are in the outbox (or delivered).
    Done,
    /// The run failed; the failure notification is in the outbox (or delivered).
    Failed,
}

/// What was done with one inbox entry (the latest version of it).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Item {
    /// The fingerprint of the version processed (names, sizes, times).
    pub fingerprint: String,
    pub status: Status,
    /// `structure=…/event=…` in the dataset, once known.
    pub partition: Option<String>,
    /// The id of its notification (the same for every delivery of it).
    pub notification_id: Option<String>,
    /// When the upload was judged complete, UTC.
    pub complete_at: String,
    /// When processing began and ended, UTC.
    pub started_at: String,
    pub finished_at: Option<String>,
    pub seconds: Option<f64>,
    pub error: Option<String>,
    /// The history hook and the dashboard ran after it.
    pub followed_up: bool,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Journal {
    pub format: u32,
    /// By inbox entry name.
    pub items: BTreeMap<String, Item>,
}

impl Journal {
    /// The journal of the state folder `dir` (empty when there is none yet).
    /// An unreadable journal is an error naming the file: starting over would
    /// process and notify every event again.
    pub fn load(dir: &Path) -> Result<Journal> {
        let path = dir.join(STATE_FILE);
        if !path.exists() {
            return Ok(Journal {
                format: FORMAT,
                items: BTreeMap::new(),
            });
        }
        let text = crate::input_file::read_to_string(&path, MAX_STATE_BYTES)?;
        let j: Journal = serde_json::from_str(&text).map_err(|e| {
            Error::input(
                Location::file(path.display().to_string()),
                format!("not a quaketwin watch journal ({e}); move it away to start over (every event in the inbox is then processed and notified again)"),
            )
        })?;
        if j.format != FORMAT {
            return Err(Error::input(
                Location::file(path.display().to_string()),
                format!(
                    "journal format {} (this quaketwin reads {FORMAT})",
                    j.format
                ),
            ));
        }
        Ok(j)
    }

    /// Writes the journal into `dir` atomically.
    pub fn save(&self, dir: &Path) -> Result<()> {
        let path: PathBuf = dir.join(STATE_FILE);
        let text = serde_json::to_string_pretty(self)
            .map_err(|e| Error::output(&path, format!("serialising the journal: {e}")))?;
        crate::sinks::atomic::write_bytes_atomically(&path, (text + "\n").as_bytes())
    }

    /// Whether the entry `name` at `fingerprint` is finished (done or failed).
    pub fn finished(&self, name: &str, fingerprint: &str) -> bool {
        self.items.get(name).is_some_and(|i| {
            i.fingerprint == fingerprint && matches!(i.status, Status::Done | Status::Failed)
        })
    }

    /// Whether the entry `name` at `fingerprint` was begun by an earlier run
    /// and not finished (that run was killed).
    pub fn begun(&self, name: &str, fingerprint: &str) -> bool {
        self.items
            .get(name)
            .is_some_and(|i| i.fingerprint == fingerprint && i.status == Status::Processing)
    }
}
