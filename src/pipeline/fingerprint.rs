//! Stable fingerprints for deciding whether a stage is up to date, with the
//! one hash of [`crate::hash`].

use std::path::Path;

use crate::error::{Error, Result};
use crate::hash::Hash64;

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
    let meta = std::fs::metadata(p).map_err(|e| Error::io(p, e))?;
    if meta.is_dir() {
        // An output directory inside the event folder is not part of the
        // event (the event folder's reader skips it too).
        if p != root && crate::event_folder::is_run_directory(p) {
            return Ok(());
        }
        for entry in std::fs::read_dir(p).map_err(|e| Error::io(p, e))? {
            let entry = entry.map_err(|e| Error::io(p, e))?;
            collect(root, &entry.path(), out)?;
        }
    } else {
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
    Ok(())
}
