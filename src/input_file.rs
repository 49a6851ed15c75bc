//! The one way quaketwin opens a file the user named (a CLI argument, a
//! pipeline, settings, twin or design file, a reference run's table, a file
//! of an event folder): regular files only, and never an open that can block.
//!
//! - What sits at the path is checked first (following symbolic links: the
//!   user named the path): a FIFO, device, socket or directory is an input
//!   error naming the path and what it is, before any `open` — a FIFO would
//!   block the open forever, `/dev/zero` would be read without end.
//! - The file is then opened with `O_NONBLOCK` and checked again on the open
//!   descriptor (`fstat`), so a FIFO swapped in between the check and the
//!   open neither blocks the open nor is read.  (On a regular file
//!   `O_NONBLOCK` changes nothing.)
//! - [`read`] and [`read_to_string`] take a size cap: the size is checked
//!   before reading and the read is bounded by it, so a file that grows
//!   while it is read cannot exceed it either.
//!
//! Inside a folder quaketwin lists itself (an event folder), a symbolic link
//! is followed only to a regular file inside that folder ([`follow_link_inside`]).
//! docs/robustness.md, "Paths", states the policy.

use std::fs::{File, Metadata};
use std::io::Read;
use std::path::Path;

use crate::error::{Error, Location, Result};

/// Largest user-named file read whole (a pipeline, settings, twin, design or
/// Matrix Market file, a StationXML, an event's referenced files), bytes:
/// far above any real one, far below what would exhaust memory.  The event
/// folder's `MAX_REFERENCED_BYTES` is this value.
pub const MAX_INPUT_BYTES: u64 = 1 << 30;

/// Largest settings file (`--settings` of `update`, `rehearse`, `report`),
/// bytes: a hand-written TOML of a few keys is under a kilobyte; parsing a
/// document costs several times its size, so a gigabyte of it (a mistaken
/// path, a sparse file) is refused before it is read.
pub const MAX_SETTINGS_BYTES: u64 = 1 << 20;

/// What kind of file sits at a path, in words (for a file that is not a
/// regular file).
pub fn kind_of(meta: &Metadata) -> &'static str {
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

fn not_regular(path: &Path, meta: &Metadata) -> Error {
    Error::input(
        Location::file(path.display().to_string()),
        format!(
            "is {}, not a regular file: quaketwin reads only regular files",
            kind_of(meta)
        ),
    )
}

/// The metadata of the regular file at `path` (links followed); anything
/// else is an input error naming the path and what it is.
pub fn check_regular(path: &Path) -> Result<Metadata> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(not_regular(path, &meta));
    }
    Ok(meta)
}

/// Opens the regular file at `path` for reading (see the module doc): never
/// blocks, never opens a FIFO or device.
pub fn open(path: &Path) -> Result<File> {
    check_regular(path)?;
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(|e| Error::io(path, e))?;
    // Checked again on the descriptor: the path may have been swapped.
    let meta = file.metadata().map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(not_regular(path, &meta));
    }
    Ok(file)
}

/// The whole content of the regular file at `path`, refused (an input error
/// naming the path and the limit) above `max_bytes`.
pub fn read(path: &Path, max_bytes: u64) -> Result<Vec<u8>> {
    read_or(path, max_bytes, |n| {
        Error::input(
            Location::file(path.display().to_string()),
            format!("has {n} bytes; the limit is {max_bytes} bytes"),
        )
    })
}

/// [`read`] with the caller's error for a file above `max_bytes` (which
/// limit, which exit code: a pipeline file too big is a usage error).  The
/// size is taken from the open file before reading, and the read stops one
/// byte past the cap should the file grow meanwhile.
pub fn read_or(path: &Path, max_bytes: u64, too_big: impl Fn(u64) -> Error) -> Result<Vec<u8>> {
    let file = open(path)?;
    let len = file.metadata().map_err(|e| Error::io(path, e))?.len();
    if len > max_bytes {
        return Err(too_big(len));
    }
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > max_bytes {
        return Err(too_big(bytes.len() as u64));
    }
    Ok(bytes)
}

/// [`read`] as UTF-8 text; text that is not UTF-8 is an input error naming
/// the path and the byte offset.
pub fn read_to_string(path: &Path, max_bytes: u64) -> Result<String> {
    utf8(path, read(path, max_bytes)?)
}

/// [`read_or`] as UTF-8 text.
pub fn read_to_string_or(
    path: &Path,
    max_bytes: u64,
    too_big: impl Fn(u64) -> Error,
) -> Result<String> {
    utf8(path, read_or(path, max_bytes, too_big)?)
}

fn utf8(path: &Path, bytes: Vec<u8>) -> Result<String> {
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to() as u64;
        Error::input(
            Location::file(path.display().to_string()).at_byte(at),
            "not UTF-8 text",
        )
    })
}

/// What an entry of a folder quaketwin lists (an event folder) is, under
/// the one policy of such folders: a directory, or a regular file — itself
/// or through symbolic links that stay inside `root` ([`follow_links_inside`]).
/// A FIFO, device or socket is an input error naming it, never opened.
pub enum FolderEntry {
    Dir,
    /// The file's metadata (a link's: its target's).
    File(Metadata),
}

/// Classifies `path`, an entry found under the folder `root` (see [`FolderEntry`]).
pub fn folder_entry(root: &Path, path: &Path) -> Result<FolderEntry> {
    let meta = std::fs::symlink_metadata(path).map_err(|e| Error::io(path, e))?;
    let ft = meta.file_type();
    if ft.is_dir() {
        Ok(FolderEntry::Dir)
    } else if ft.is_file() {
        Ok(FolderEntry::File(meta))
    } else if ft.is_symlink() {
        follow_links_inside(root, path).map(FolderEntry::File)
    } else {
        Err(not_regular(path, &meta))
    }
}

/// The metadata of the file `path` (under the folder `root`) leads to,
/// under the one link policy of folders quaketwin lists: symbolic links
/// (the path's own or its directories') are followed when they lead to a
/// regular file inside `root`; a link that dangles, leads to anything but
/// a regular file (a directory, FIFO, device) or leaves `root` is an input
/// error naming the path — the same error wherever the folder is read
/// (`inspect`, `ingest`, `run`, the fingerprint of a run's inputs, the
/// files an event refers to).
pub fn follow_links_inside(root: &Path, path: &Path) -> Result<Metadata> {
    let link = std::fs::read_link(path).ok();
    let what = match &link {
        Some(t) => format!("symbolic link to {:?}", t.display().to_string()),
        None => "path".into(),
    };
    let refuse = |why: String, about_links: bool| {
        let hint = if about_links {
            ": a link in a folder is followed only to a regular file inside that folder \
             (replace the link by the file, or by a link that stays inside)"
        } else {
            ""
        };
        Error::input(
            Location::file(path.display().to_string()),
            format!("{what} {why}{hint}"),
        )
    };
    let resolved = match std::fs::canonicalize(path) {
        Ok(r) => r,
        Err(e) if std::fs::symlink_metadata(path).is_ok() => {
            return Err(refuse(format!("leads nowhere ({e})"), true))
        }
        Err(e) => return Err(Error::io(path, e)),
    };
    let meta = std::fs::metadata(&resolved).map_err(|e| Error::io(&resolved, e))?;
    if !meta.is_file() && link.is_none() {
        return Err(not_regular(path, &meta));
    }
    if !meta.is_file() {
        return Err(refuse(
            format!("leads to {}, not a regular file", kind_of(&meta)),
            true,
        ));
    }
    let root = std::fs::canonicalize(root).map_err(|e| Error::io(root, e))?;
    if !resolved.starts_with(&root) {
        return Err(refuse(
            format!(
                "leads outside the folder {}{}",
                root.display(),
                if link.is_some() {
                    ""
                } else {
                    " (through a linked directory)"
                }
            ),
            true,
        ));
    }
    Ok(meta)
}
