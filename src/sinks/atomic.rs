//! The one way quaketwin writes a file: into a new temporary file beside the
//! target (same directory, so the rename is atomic), flushed to disk, then
//! renamed over the target.  A reader never sees half a file; on any error
//! the temporary file is removed and the target is untouched.
//!
//! What sits at the target path is checked first: only a regular file (or
//! nothing) is replaced.  A symbolic link, directory, device, FIFO or socket
//! is an error naming the path, never replaced.
//!
//! Temporary files are named `.<target name>.quaketwin-<pid>-<n>.tmp`
//! ([`is_temp_name`]); a killed run may leave one behind, and the next
//! pipeline run in that directory removes them ([`sweep_temp_files`]).

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Error, Result};

/// Marker in every temporary file name (see the module doc).
pub const TEMP_MARKER: &str = ".quaketwin-";
/// Suffix of every temporary file name.
pub const TEMP_SUFFIX: &str = ".tmp";

static COUNTER: AtomicU64 = AtomicU64::new(0);

/// Temporary path beside `path`: `.<name>.quaketwin-<pid>-<n>.tmp`.
pub fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    path.with_file_name(format!(
        ".{name}{TEMP_MARKER}{}-{n}{TEMP_SUFFIX}",
        std::process::id()
    ))
}

/// Whether a file name is one of quaketwin's temporary files: the current
/// pattern `.<name>.quaketwin-<pid>-<n>.tmp`, or the patterns of earlier
/// versions (`.<name>.<pid>.tmp`, `.<name>.tmp-<pid>`).
pub fn is_temp_name(name: &str) -> bool {
    if !name.starts_with('.') {
        return false;
    }
    if name.contains(TEMP_MARKER) && name.ends_with(TEMP_SUFFIX) {
        return true;
    }
    // Earlier versions: `.<name>.<pid>.tmp` and `.<name>.tmp-<pid>` (MCAP).
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    if let Some(stem) = name.strip_suffix(".tmp") {
        if let Some((_, pid)) = stem.rsplit_once('.') {
            return digits(pid);
        }
    }
    if let Some((_, pid)) = name.rsplit_once(".tmp-") {
        return digits(pid);
    }
    false
}

/// What kind of non-regular file sits at a path, in words.
fn kind_of(meta: &std::fs::Metadata) -> &'static str {
    let ft = meta.file_type();
    if ft.is_symlink() {
        return "a symbolic link";
    }
    if ft.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if ft.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if ft.is_char_device() || ft.is_block_device() {
            return "a device";
        }
        if ft.is_socket() {
            return "a socket";
        }
    }
    "not a regular file"
}

/// Checks that `path` is absent or a regular file (never following a
/// symbolic link).  Anything else is a usage error naming the path: the
/// user pointed an output at something quaketwin must not replace.
pub fn check_replaceable(path: &Path) -> Result<()> {
    match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(Error::io(path, e)),
        Ok(meta) if meta.file_type().is_file() => Ok(()),
        Ok(meta) => Err(Error::usage(format!(
            "{}: output path is {}; quaketwin writes only regular files and will not replace it \
             (remove it or choose another output path)",
            path.display(),
            kind_of(&meta)
        ))),
    }
}

/// Runs `write` on a new temporary file beside `path`, flushes it to disk,
/// then renames it over `path`.  On any error the temporary file is removed
/// and `path` is untouched.  Refuses to replace anything but a regular file
/// ([`check_replaceable`]).
pub fn write_atomically(path: &Path, write: impl FnOnce(&mut File) -> Result<()>) -> Result<()> {
    check_replaceable(path)?;
    if let Some(dir) = path.parent() {
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        }
    }
    let tmp = temp_path(path);
    // create_new: never open (or follow a link at) an existing path.
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&tmp)
        .map_err(|e| Error::io(&tmp, e))?;
    let result = write(&mut file)
        .and_then(|_| file.sync_all().map_err(|e| Error::io(&tmp, e)))
        .and_then(|_| {
            drop(file);
            // Checked again just before the rename: the target may have
            // changed while the file was written.
            check_replaceable(path)?;
            std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e))
        });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp); // best effort; swept by the next run otherwise
    }
    result
}

/// Writes bytes atomically (JSON, TOML, HTML, Matrix Market).
pub fn write_bytes_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomically(path, |f| f.write_all(bytes).map_err(|e| Error::io(path, e)))
}

/// Removes quaketwin's temporary files ([`is_temp_name`], regular files
/// only) directly inside `dir`; returns the names removed.  Only for a
/// directory this process owns (the pipeline holds the output directory's
/// lock), since another live writer's temporary file would be removed too.
pub fn sweep_temp_files(dir: &Path) -> Result<Vec<String>> {
    let mut removed = Vec::new();
    let entries = match std::fs::read_dir(dir) {
        Ok(rd) => rd,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(removed),
        Err(e) => return Err(Error::io(dir, e)),
    };
    for entry in entries {
        let entry = entry.map_err(|e| Error::io(dir, e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if !is_temp_name(&name) {
            continue;
        }
        let is_file = entry.file_type().map(|t| t.is_file()).unwrap_or(false);
        if is_file {
            let p = entry.path();
            std::fs::remove_file(&p).map_err(|e| Error::io(&p, e))?;
            removed.push(name);
        }
    }
    removed.sort();
    Ok(removed)
}
