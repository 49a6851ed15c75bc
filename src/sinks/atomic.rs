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
//!
//! The bytes are hashed as they are written ([`HashingWriter`]), so that the
//! run manifest can record a big output's size and hash without reading it
//! back (issue 14 item 5: reading back the 1.7 GB of an hour of 64 channels
//! cost seconds).  [`written_digest`] gives them for a file this process
//! wrote, as long as the file is still the one it wrote.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

use crate::error::{Error, Result};
use crate::hash::Hash64;
use crate::input_file::kind_of;

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

/// A writer that hashes ([`Hash64`]) and counts the bytes it passes on.  A
/// seek anywhere but to the end of what was written (a writer that patches
/// a header, as MCAP's does) leaves it without a digest: the bytes it saw
/// are then not the file's.
pub struct HashingWriter<W> {
    inner: W,
    hash: Hash64,
    bytes: u64,
    sequential: bool,
}

impl<W> HashingWriter<W> {
    pub fn new(inner: W) -> Self {
        HashingWriter {
            inner,
            hash: Hash64::default(),
            bytes: 0,
            sequential: true,
        }
    }
    /// Size and hash of the bytes written, when they were written in order.
    pub fn digest(&self) -> Option<(u64, String)> {
        self.sequential
            .then(|| (self.bytes, self.hash.finish_hex()))
    }
}

impl<W: Write> Write for HashingWriter<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hash.write_raw(&buf[..n]);
        self.bytes += n as u64;
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

impl<W: Seek> Seek for HashingWriter<W> {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        let to = self.inner.seek(pos)?;
        if to != self.bytes {
            self.sequential = false;
        }
        Ok(to)
    }
}

/// What identifies a file as the one written: size, modification time and,
/// on Unix, device and inode (a rename keeps them).
#[derive(Debug, Clone, PartialEq, Eq)]
struct FileId {
    len: u64,
    modified: Option<std::time::SystemTime>,
    #[cfg(unix)]
    dev_ino: (u64, u64),
}

impl FileId {
    fn of(meta: &std::fs::Metadata) -> Self {
        #[cfg(unix)]
        use std::os::unix::fs::MetadataExt;
        FileId {
            len: meta.len(),
            modified: meta.modified().ok(),
            #[cfg(unix)]
            dev_ino: (meta.dev(), meta.ino()),
        }
    }
}

/// Size and hash of the files this process wrote, by canonical path, with
/// the identity of each file as it was closed.
static WRITTEN: Mutex<BTreeMap<PathBuf, (FileId, u64, String)>> = Mutex::new(BTreeMap::new());

/// Size and hash of `path` as this process last wrote it with
/// [`write_atomically`], taken from the record (once: the record is
/// removed); `None` when this process did not write it, or the file at
/// `path` is no longer the one written (another size, modification time or
/// inode) — the caller then reads it.
pub fn written_digest(path: &Path) -> Option<(u64, String)> {
    let key = std::fs::canonicalize(path).ok()?;
    let (id, bytes, hash) = WRITTEN.lock().ok()?.remove(&key)?;
    let now = std::fs::symlink_metadata(&key).ok()?;
    (now.file_type().is_file() && FileId::of(&now) == id).then_some((bytes, hash))
}

/// Runs `write` on a new temporary file beside `path`, flushes it to disk,
/// then renames it over `path`.  On any error the temporary file is removed
/// and `path` is untouched.  Refuses to replace anything but a regular file
/// ([`check_replaceable`]).  The bytes are hashed on their way
/// ([`written_digest`]).
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut HashingWriter<&mut File>) -> Result<()>,
) -> Result<()> {
    let (tmp, mut file) = begin(path)?;
    let mut out = HashingWriter::new(&mut file);
    let result = write(&mut out);
    let digest = out.digest();
    match result {
        Ok(()) => commit(path, &tmp, file, digest),
        Err(e) => {
            drop(file);
            let _ = std::fs::remove_file(&tmp); // best effort; swept by the next run otherwise
            Err(e)
        }
    }
}

/// The temporary file of a write to `path`, created new (see [`write_atomically`]).
fn begin(path: &Path) -> Result<(PathBuf, File)> {
    check_replaceable(path)?;
    if let Some(dir) = path.parent() {
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        }
    }
    let tmp = temp_path(path);
    // create_new: never open (or follow a link at) an existing path.
    let file = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&tmp)
        .map_err(|e| Error::io(&tmp, e))?;
    Ok((tmp, file))
}

/// Flushes `file` (written at `tmp`) to disk and renames it over `path`,
/// recording `digest` ([`written_digest`]); on any error `tmp` is removed.
fn commit(path: &Path, tmp: &Path, file: File, digest: Option<(u64, String)>) -> Result<()> {
    let result = file
        .sync_all()
        .map_err(|e| Error::io(tmp, e))
        .and_then(|_| file.metadata().map_err(|e| Error::io(tmp, e)))
        .and_then(|meta| {
            drop(file);
            // Checked again just before the rename: the target may have
            // changed while the file was written.
            check_replaceable(path)?;
            std::fs::rename(tmp, path).map_err(|e| Error::io(path, e))?;
            Ok(meta)
        });
    match result {
        Ok(meta) => {
            let digest = digest.filter(|(bytes, _)| *bytes == meta.len());
            if let (Some((bytes, hash)), Ok(key)) = (digest, std::fs::canonicalize(path)) {
                if let Ok(mut written) = WRITTEN.lock() {
                    written.insert(key, (FileId::of(&meta), bytes, hash));
                }
            }
            Ok(())
        }
        Err(e) => {
            let _ = std::fs::remove_file(tmp); // best effort; swept by the next run otherwise
            Err(e)
        }
    }
}

/// [`write_atomically`] for a writer that must stay open while others are
/// written (one day file per stream, written as the records come): the
/// bytes go to a temporary file beside `path`, [`AtomicFile::commit`]
/// renames it over `path`; dropped without a commit (an error on the way),
/// the temporary file is removed and `path` is untouched.
pub struct AtomicFile {
    path: PathBuf,
    tmp: PathBuf,
    out: Option<HashingWriter<std::io::BufWriter<File>>>,
}

impl AtomicFile {
    /// Starts the write of `path` (refused as [`write_atomically`] refuses).
    pub fn create(path: &Path) -> Result<AtomicFile> {
        let (tmp, file) = begin(path)?;
        Ok(AtomicFile {
            path: path.to_path_buf(),
            tmp,
            out: Some(HashingWriter::new(std::io::BufWriter::with_capacity(
                1 << 20,
                file,
            ))),
        })
    }

    /// The target path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Flushes and renames the file over its target.
    pub fn commit(mut self) -> Result<()> {
        let out = self.out.take().expect("taken only here and on drop"); // ok: commit consumes self
        let digest = out.digest();
        let file = out.inner.into_inner().map_err(|e| {
            let _ = std::fs::remove_file(&self.tmp);
            Error::io(&self.tmp, e.into_error())
        })?;
        commit(&self.path, &self.tmp, file, digest)
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self.out.as_mut() {
            Some(out) => out.write(buf),
            None => Err(std::io::Error::other("atomic file already committed")),
        }
    }
    fn flush(&mut self) -> std::io::Result<()> {
        match self.out.as_mut() {
            Some(out) => out.flush(),
            None => Ok(()),
        }
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if let Some(out) = self.out.take() {
            drop(out);
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
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
