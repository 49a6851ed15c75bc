//! Files an event refers to besides its records — the digital twin named by
//! `structure.twin`, a design file, the Matrix Market files they name — as
//! paths a loader can open, whether the event is a directory or a zip.
//!
//! For a directory the path is checked to stay inside the event (symbolic
//! links followed only inside it, as when the folder is listed) and to be a
//! regular file of bounded size (a FIFO would hang a run, `/dev/zero` would
//! grow without bound). For a zip the top-level members are extracted once
//! into a private temporary directory (removed when the resolver is dropped),
//! so relative references between the files (a twin's matrices) resolve as
//! they would in a folder. The member names were checked by `collect` (no
//! `..`, no absolute paths) and each member is inflated within the zip's
//! budget ([`ArchiveLimits`]); one past it is not extracted, and is an error
//! only when it is referenced.

use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use super::archive::{collect, ArchiveLimits};
use crate::error::{Error, Location, Result};

/// Largest referenced file accepted (twin, design, matrices), bytes.
pub const MAX_REFERENCED_BYTES: u64 = crate::input_file::MAX_INPUT_BYTES;

/// Resolves paths relative to an event (see module doc).
#[derive(Debug)]
pub struct ReferencedFiles {
    root: PathBuf,
    extracted: Option<TempTree>,
    /// Members of a zipped event not extracted, with why (above a limit of
    /// the zip's budget): an error only if one of them is referenced.
    unreadable: Vec<(String, String)>,
}

impl ReferencedFiles {
    pub fn new(event_path: &Path) -> Self {
        ReferencedFiles {
            root: event_path.to_path_buf(),
            extracted: None,
            unreadable: Vec::new(),
        }
    }

    /// Whether the event is a zip archive (rather than a directory).
    pub fn is_zip(&self) -> bool {
        self.root.is_file()
    }

    /// Whether `rel` names a file of the event (for a zip: a top-level member).
    pub fn contains(&mut self, rel: &str) -> Result<bool> {
        if !is_relative_inside(rel) {
            return Ok(false);
        }
        let base = self.base()?;
        Ok(base.join(rel).is_file())
    }

    /// The path of the event's file `rel` (see module doc); an error naming
    /// the event and `rel` when it is missing, escapes the event, is not a
    /// regular file, or is larger than [`MAX_REFERENCED_BYTES`].
    pub fn resolve(&mut self, rel: &str, what: &str) -> Result<PathBuf> {
        let shown = format!("{}:{rel}", self.root.display());
        let here = || Location::file(shown.clone());
        if !is_relative_inside(rel) {
            return Err(Error::input(
                here(),
                format!("{what} {rel:?} must be a relative path inside the event (no `..`, not absolute)"),
            ));
        }
        let base = self.base()?;
        if let Some((_, why)) = self.unreadable.iter().find(|(m, _)| m == rel) {
            return Err(Error::input(here(), format!("{what} {rel:?}: {why}")));
        }
        let path = base.join(rel);
        std::fs::symlink_metadata(&path)
            .map_err(|_| Error::input(here(), format!("{what} {rel:?} is not in the event")))?;
        // The one link policy of the event folder (src/input_file.rs): links
        // followed only to a regular file inside the event.
        let meta = crate::input_file::follow_links_inside(&base, &path)
            .map_err(|e| Error::input(here(), format!("{what} {rel:?}: {e}")))?;
        if meta.len() > MAX_REFERENCED_BYTES {
            return Err(Error::input(
                here(),
                format!(
                    "{what} {rel:?} has {} bytes; the limit is {MAX_REFERENCED_BYTES}",
                    meta.len()
                ),
            ));
        }
        Ok(path)
    }

    /// The directory relative paths resolve against.
    fn base(&mut self) -> Result<PathBuf> {
        if !self.is_zip() {
            return Ok(self.root.clone());
        }
        if self.extracted.is_none() {
            let tree = TempTree::new()?;
            for f in collect(&self.root, &ArchiveLimits::default())? {
                // Top-level members only: nested zips are named `a.zip:b`.
                let Some(member) = f.member.as_deref().filter(|m| !m.contains(':')) else {
                    continue;
                };
                if !is_relative_inside(member) {
                    continue;
                }
                let dest = tree.path.join(member);
                if let Some(parent) = dest.parent() {
                    std::fs::create_dir_all(parent).map_err(|e| Error::io(parent, e))?;
                }
                // One member at a time, within the zip's budget; a member
                // past it (a bomb beside the twin) matters only if named.
                let content = match f.content() {
                    Ok(c) => c,
                    Err(e) => {
                        self.unreadable.push((member.to_string(), e.to_string()));
                        continue;
                    }
                };
                std::fs::write(&dest, &*content).map_err(|e| Error::io(&dest, e))?;
            }
            self.extracted = Some(tree);
        }
        Ok(self.extracted.as_ref().expect("set above").path.clone()) // ok: set above
    }
}

fn is_relative_inside(rel: &str) -> bool {
    let p = Path::new(rel);
    !rel.is_empty()
        && p.components()
            .all(|c| matches!(c, Component::Normal(_) | Component::CurDir))
}

/// A private temporary directory, removed on drop.
#[derive(Debug)]
struct TempTree {
    path: PathBuf,
}

impl TempTree {
    fn new() -> Result<Self> {
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let path = std::env::temp_dir().join(format!("quaketwin-event-{}-{n}", std::process::id()));
        // A leftover of an earlier process with the same pid is stale.
        let _ = std::fs::remove_dir_all(&path);
        std::fs::create_dir_all(&path).map_err(|e| Error::io(&path, e))?;
        Ok(TempTree { path })
    }
}

impl Drop for TempTree {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.path);
    }
}
