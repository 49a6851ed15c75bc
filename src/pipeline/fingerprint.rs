//! Stable fingerprints for deciding whether a stage is up to date, with the
//! one hash of [`crate::hash`].

use std::path::Path;

use crate::error::{Error, Result};
use crate::hash::Hash64;
use crate::input_file::FolderEntry;

/// Fingerprint of an input path (file or directory tree): names, sizes and
/// modification times, in sorted order.
pub fn path_fingerprint(path: &Path) -> Result<String> {
    let mut h = Hash64::default();
    let mut entries = Vec::new();
    collect(path, path, &mut entries)?;
    entries.sort();
    for (name, len, mtime) in entries {
        h.write_str(&name)
            .write(&len.to_le_bytes())
            .write(&mtime.to_le_bytes());
    }
    Ok(h.finish_hex())
}

fn collect(root: &Path, p: &Path, out: &mut Vec<(String, u64, i128)>) -> Result<()> {
    // The path given (`root`) is followed wherever it leads (the user named
    // it); below it, entries follow the event folder's one policy
    // (src/input_file.rs): links only to regular files inside `root`, the
    // same error as `inspect` and `ingest` otherwise.
    let meta = if p == root {
        let meta = std::fs::metadata(p).map_err(|e| Error::io(p, e))?;
        if meta.is_dir() {
            FolderEntry::Dir
        } else {
            FolderEntry::File(meta)
        }
    } else {
        crate::input_file::folder_entry(root, p)?
    };
    match meta {
        FolderEntry::Dir => {
            // An output directory inside the event folder is not part of the
            // event (the event folder's reader skips it too).
            if p != root && crate::event_folder::is_run_directory(p) {
                return Ok(());
            }
            for entry in std::fs::read_dir(p).map_err(|e| Error::io(p, e))? {
                let entry = entry.map_err(|e| Error::io(p, e))?;
                // Hidden files are not the event's (its reader skips them too).
                if entry.file_name().to_string_lossy().starts_with('.') {
                    continue;
                }
                collect(root, &entry.path(), out)?;
            }
        }
        FolderEntry::File(meta) => {
            let mtime = meta
                .modified()
                .ok()
                .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
                .map(|d| d.as_nanos() as i128)
                .unwrap_or(0);
            let name = p
                .strip_prefix(root)
                .unwrap_or(p)
                .to_string_lossy()
                .into_owned();
            out.push((name, meta.len(), mtime));
        }
    }
    Ok(())
}
