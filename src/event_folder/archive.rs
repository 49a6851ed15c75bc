//! The files of an event folder: a directory tree or a zip, with zips inside
//! zips expanded up to a depth limit.  Every member name is checked before
//! use (no `..`, no absolute paths) and every claimed size against the
//! archive, so a hostile or damaged archive gives a clear error instead of
//! writing outside the folder or exhausting memory.

use std::io::{Cursor, Read};
use std::path::{Component, Path};

use crate::error::{Error, Location, Result};
use crate::input_file::FolderEntry;

/// Safety limits for archives.
#[derive(Debug, Clone)]
pub struct ArchiveLimits {
    /// Zip nesting allowed: 1 = a zip of files; 2 = zips inside that zip…
    pub max_zip_depth: usize,
    /// Largest uncompressed member accepted, bytes.
    pub max_member_bytes: u64,
    /// Largest total uncompressed size of one event, bytes.
    pub max_total_bytes: u64,
}

impl Default for ArchiveLimits {
    fn default() -> Self {
        ArchiveLimits {
            max_zip_depth: 3,
            max_member_bytes: 2 << 30,
            max_total_bytes: 8 << 30,
        }
    }
}

/// Files of a directory above this size are read when their records are
/// (one at a time), not when the folder is listed: only their head is kept
/// for recognising the format (issue 14 item 5).
pub const READ_LATER_ABOVE: u64 = 1 << 20;

/// Bytes of a file's head kept for recognising its format (one more than
/// `readers` looks at, which tells it that the head was cut).
pub const HEAD_BYTES: usize = crate::readers::SNIFF_BYTES + 1;

/// One file of the event, with where it came from.
#[derive(Debug, Clone)]
pub struct EventFile {
    /// Path relative to the event root (for a zip given as the event: the zip's file name).
    pub file: String,
    /// Member path inside the zip(s), nested zips joined with `:`.
    pub member: Option<String>,
    /// The file's content — or, for a big file of a directory (read later,
    /// [`EventFile::content`]), its first [`HEAD_BYTES`]: enough to recognise the format.
    pub head: Vec<u8>,
    /// A big file of a directory, read when its content is asked for.
    on_disk: Option<std::path::PathBuf>,
}

impl EventFile {
    /// The whole content (a big file of a directory is read now).
    pub fn content(&self) -> Result<std::borrow::Cow<'_, [u8]>> {
        match &self.on_disk {
            None => Ok(std::borrow::Cow::Borrowed(&self.head)),
            // Its size was checked when the folder was listed.
            Some(path) => crate::input_file::read(path, u64::MAX).map(std::borrow::Cow::Owned),
        }
    }

    /// Name the manifest uses: `file` or `file:member`.
    pub fn display_name(&self) -> String {
        match &self.member {
            Some(m) => format!("{}:{}", self.file, m),
            None => self.file.clone(),
        }
    }
    /// Last path component (for sniffing by extension).
    pub fn base_name(&self) -> &str {
        let full = self.member.as_deref().unwrap_or(&self.file);
        let last = full.rsplit(':').next().unwrap_or(full);
        last.rsplit(['/', '\\']).next().unwrap_or(last)
    }
    pub fn location(&self) -> Location {
        let mut l = Location::file(&self.file);
        l.member = self.member.clone();
        l
    }
}

fn is_zip(name: &str, bytes: &[u8]) -> bool {
    bytes.starts_with(b"PK\x03\x04")
        || (name.to_ascii_lowercase().ends_with(".zip") && bytes.starts_with(b"PK"))
}

/// Collects every file of the event at `root` (directory or zip), sorted by
/// name so processing order is stable.
pub fn collect(root: &Path, limits: &ArchiveLimits) -> Result<Vec<EventFile>> {
    let meta = std::fs::metadata(root).map_err(|e| Error::io(root, e))?;
    let mut out = Vec::new();
    let mut total = 0u64;
    if meta.is_dir() {
        let mut paths = Vec::new();
        walk(root, root, &mut paths)?;
        paths.sort();
        for rel in paths {
            let full = root.join(&rel);
            let name = rel.to_string_lossy().replace('\\', "/");
            let (bytes, whole) = read_head_bounded(&full, limits)?;
            if whole || is_zip(&name, &bytes) {
                let bytes = if whole {
                    bytes
                } else {
                    read_bounded(&full, limits)?
                };
                push_file(name, None, bytes, 0, limits, &mut total, &mut out)?;
            } else {
                out.push(EventFile {
                    file: name,
                    member: None,
                    head: bytes,
                    on_disk: Some(full),
                });
            }
        }
    } else if meta.is_file() {
        let bytes = read_bounded(root, limits)?;
        let name = root
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        if !is_zip(&name, &bytes) {
            return Err(Error::input(
                Location::file(root.display().to_string()),
                "an event must be a directory or a .zip archive",
            ));
        }
        push_file(name, None, bytes, 0, limits, &mut total, &mut out)?;
    } else {
        // A FIFO would block the read forever, a device such as /dev/zero
        // would grow without bound: only directories and regular files.
        return Err(Error::input(
            Location::file(root.display().to_string()),
            "an event must be a directory or a .zip archive (this is neither a directory nor a regular file: a FIFO, socket or device is refused)",
        ));
    }
    Ok(out)
}

/// The content of a regular file up to [`READ_LATER_ABOVE`] bytes, else its
/// head (whether it is the whole file is the flag); the size is checked
/// first against the member limit.
fn read_head_bounded(path: &Path, limits: &ArchiveLimits) -> Result<(Vec<u8>, bool)> {
    let size = checked_size(path, limits)?;
    if size <= READ_LATER_ABOVE {
        return crate::input_file::read(path, limits.max_member_bytes).map(|b| (b, true));
    }
    let mut head = Vec::with_capacity(HEAD_BYTES);
    crate::input_file::open(path)?
        .take(HEAD_BYTES as u64)
        .read_to_end(&mut head)
        .map_err(|e| Error::io(path, e))?;
    Ok((head, false))
}

/// Reads a regular file whose size is checked first against the member limit.
fn read_bounded(path: &Path, limits: &ArchiveLimits) -> Result<Vec<u8>> {
    checked_size(path, limits)?;
    crate::input_file::read(path, limits.max_member_bytes)
}

/// The size of a regular file, refused above the member limit.
fn checked_size(path: &Path, limits: &ArchiveLimits) -> Result<u64> {
    let meta = crate::input_file::check_regular(path)?;
    if meta.len() > limits.max_member_bytes {
        return Err(Error::input(
            Location::file(path.display().to_string()),
            format!(
                "{} bytes: larger than the {}-byte limit for one file of an event",
                meta.len(),
                limits.max_member_bytes
            ),
        ));
    }
    Ok(meta.len())
}

fn walk(root: &Path, dir: &Path, out: &mut Vec<std::path::PathBuf>) -> Result<()> {
    let entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    for entry in entries {
        let entry = entry.map_err(|e| Error::io(dir, e))?;
        let path = entry.path();
        let name = entry.file_name();
        if name.to_string_lossy().starts_with('.') {
            continue; // hidden files (.DS_Store, editor swap files)
        }
        // The one policy of folders (src/input_file.rs): links followed
        // only to regular files inside the event; a FIFO or device refused.
        match crate::input_file::folder_entry(root, &path)? {
            FolderEntry::Dir => {
                if super::is_run_directory(&path) {
                    continue; // quaketwin's own outputs (`--out` inside the event folder)
                }
                walk(root, &path, out)?;
            }
            FolderEntry::File(_) => {
                out.push(path.strip_prefix(root).unwrap_or(&path).to_path_buf());
            }
        }
    }
    Ok(())
}

/// Adds a file; if it is a zip, expands its members instead (recursively).
fn push_file(
    file: String,
    member: Option<String>,
    bytes: Vec<u8>,
    depth: usize,
    limits: &ArchiveLimits,
    total: &mut u64,
    out: &mut Vec<EventFile>,
) -> Result<()> {
    let name = member.as_deref().unwrap_or(&file).to_string();
    if !is_zip(&name, &bytes) {
        out.push(EventFile {
            file,
            member,
            head: bytes,
            on_disk: None,
        });
        return Ok(());
    }
    let loc = || {
        let mut l = Location::file(&file);
        l.member = member.clone();
        l
    };
    if depth + 1 > limits.max_zip_depth {
        return Err(Error::input(
            loc(),
            format!(
                "zip nested deeper than the limit of {} levels",
                limits.max_zip_depth
            ),
        ));
    }
    let archive_len = bytes.len() as u64;
    let mut zip = zip::ZipArchive::new(Cursor::new(bytes))
        .map_err(|e| Error::input(loc(), format!("not a readable zip archive: {e}")))?;
    let mut members = Vec::new();
    for i in 0..zip.len() {
        let mut entry = zip
            .by_index(i)
            .map_err(|e| Error::input(loc(), format!("zip entry {i} unreadable: {e}")))?;
        let raw_name = entry
            .name()
            .map_err(|e| Error::input(loc(), format!("zip entry {i} has an unreadable name: {e}")))?
            .into_owned();
        let member_loc = || {
            let inner = match &member {
                Some(m) => format!("{m}:{raw_name}"),
                None => raw_name.clone(),
            };
            Location::file(&file).with_member(inner)
        };
        check_member_name(&raw_name).map_err(|why| Error::input(member_loc(), why))?;
        if entry.is_dir() {
            continue;
        }
        if entry.compressed_size() > archive_len {
            return Err(Error::input(
                member_loc(),
                format!(
                    "claims {} compressed bytes but the archive has only {archive_len}",
                    entry.compressed_size()
                ),
            ));
        }
        if entry.size() > limits.max_member_bytes {
            return Err(Error::input(
                member_loc(),
                format!(
                    "claims {} bytes, above the limit of {}",
                    entry.size(),
                    limits.max_member_bytes
                ),
            ));
        }
        *total += entry.size();
        if *total > limits.max_total_bytes {
            return Err(Error::input(
                member_loc(),
                format!(
                    "event exceeds {} bytes uncompressed",
                    limits.max_total_bytes
                ),
            ));
        }
        let base = raw_name.rsplit('/').next().unwrap_or(&raw_name);
        if base.starts_with('.') || raw_name.starts_with("__MACOSX/") {
            continue;
        }
        let claimed = entry.size();
        let mut data = Vec::with_capacity(claimed as usize);
        // Read one byte past the claim so a member larger than it says is caught.
        (&mut entry)
            .take(claimed + 1)
            .read_to_end(&mut data)
            .map_err(|e| Error::input(member_loc(), format!("cannot decompress: {e}")))?;
        if data.len() as u64 != claimed {
            return Err(Error::input(
                member_loc(),
                format!("holds {} bytes but claims {claimed}", data.len()),
            ));
        }
        let inner = match &member {
            Some(m) => format!("{m}:{raw_name}"),
            None => raw_name.clone(),
        };
        members.push((inner, data));
    }
    members.sort_by(|a, b| a.0.cmp(&b.0));
    for (inner, data) in members {
        push_file(
            file.clone(),
            Some(inner),
            data,
            depth + 1,
            limits,
            total,
            out,
        )?;
    }
    Ok(())
}

/// Rejects member names that could escape the folder: absolute paths, drive
/// prefixes, `..` components.
fn check_member_name(name: &str) -> std::result::Result<(), String> {
    if name.starts_with('/') || name.starts_with('\\') || name.as_bytes().get(1) == Some(&b':') {
        return Err(format!("member name {name:?} is an absolute path"));
    }
    let normalised = name.replace('\\', "/");
    for c in Path::new(&normalised).components() {
        match c {
            Component::ParentDir => return Err(format!("member name {name:?} contains '..'")),
            Component::RootDir | Component::Prefix(_) => {
                return Err(format!("member name {name:?} is an absolute path"))
            }
            _ => {}
        }
    }
    Ok(())
}
