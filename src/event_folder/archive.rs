//! The files of an event folder: a directory tree or a zip, with zips inside
//! zips expanded up to a depth limit.  Every member name is checked before
//! use (no `..`, no absolute paths) and every claimed size against the
//! archive, so a hostile or damaged archive gives a clear error instead of
//! writing outside the folder or exhausting memory.
//!
//! A zip is untrusted: its members are decompressed as a stream under a
//! budget (issue 33 item 2) — an absolute total for the event
//! ([`ArchiveLimits::max_total_bytes`]), a total relative to the bytes of
//! the event's zip files ([`ArchiveLimits::max_total_ratio`]) and a
//! compression ratio per member ([`ArchiveLimits::max_member_ratio`]) —
//! checked on the claimed sizes before a byte is inflated and again on the
//! bytes as they come, so a member that lies about its size is stopped at
//! the limit, not after.  A member above [`READ_LATER_ABOVE`] is only
//! inflated up to its head ([`HEAD_BYTES`]) when the event is listed, and
//! in full when its content is asked for: a member the loader skips (not a
//! record, not named by the manifest) is never decompressed beyond its head.

use std::io::{Cursor, Read};
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use crate::error::{Error, Location, Result};
use crate::input_file::FolderEntry;

/// Safety limits for archives (docs/robustness.md, Limits).
#[derive(Debug, Clone)]
pub struct ArchiveLimits {
    /// Zip nesting allowed: 1 = a zip of files; 2 = zips inside that zip…
    pub max_zip_depth: usize,
    /// Largest uncompressed member (or file of a directory) accepted, bytes.
    pub max_member_bytes: u64,
    /// Largest total of bytes decompressed from the zips of one event
    /// (nested zips and their members both count): the absolute budget.
    pub max_total_bytes: u64,
    /// The relative budget: bytes decompressed from the zips of one event at
    /// most this many times the bytes of its zip files on disk (beyond
    /// [`RELATIVE_FLOOR_BYTES`]; every level of nesting multiplies, so a
    /// zip of zips cannot pass where each member alone would).
    pub max_total_ratio: u64,
    /// Largest decompressed : compressed ratio of one member (beyond its
    /// first [`RATIO_GRACE_BYTES`]).  Real records deflate 1.1× (MiniSEED)
    /// to about 10× (text columns); a deflate bomb reaches 1000×.
    pub max_member_ratio: u64,
}

/// A member's first bytes are never refused for their ratio (a small text
/// file of repeated blanks may deflate 100× and is harmless).
pub const RATIO_GRACE_BYTES: u64 = 1 << 20;

/// The relative budget of an event is never below this (small zips of
/// small, very compressible files are harmless).
pub const RELATIVE_FLOOR_BYTES: u64 = 16 << 20;

impl Default for ArchiveLimits {
    fn default() -> Self {
        ArchiveLimits {
            max_zip_depth: 3,
            // A record is parsed from one buffer holding its file: 768 MiB
            // keeps a file refused by its reader (or read) under a 1 GB peak
            // (a 1 GiB CSV member, inflated whole, peaked at 1.09–1.13 GB;
            // the 64-channel hour of CSV is 582 MB).
            max_member_bytes: 768 << 20,
            max_total_bytes: 2 << 30,
            max_total_ratio: 100,
            max_member_ratio: 100,
        }
    }
}

/// Files of a directory above this size are read when their records are
/// (one at a time), not when the folder is listed: only their head is kept
/// for recognising the format (issue 14 item 5).  Zip members above it are
/// likewise inflated only up to their head until their content is asked for.
pub const READ_LATER_ABOVE: u64 = 1 << 20;

/// Bytes of a file's head kept for recognising its format (one more than
/// `readers` looks at, which tells it that the head was cut).
pub const HEAD_BYTES: usize = crate::readers::SNIFF_BYTES + 1;

/// Bytes inflated at a time, so every budget is checked within this much.
const INFLATE_CHUNK: usize = 64 << 10;

/// What the zips of one event have decompressed, against its budget.
#[derive(Debug)]
struct Budget {
    limits: ArchiveLimits,
    /// Bytes of the event's zip files as read from disk.
    compressed: AtomicU64,
    /// Bytes decompressed so far.
    used: AtomicU64,
}

impl Budget {
    fn new(limits: &ArchiveLimits) -> Arc<Budget> {
        Arc::new(Budget {
            limits: limits.clone(),
            compressed: AtomicU64::new(0),
            used: AtomicU64::new(0),
        })
    }

    /// The relative budget: `max_total_ratio` × the zip files' bytes.
    fn relative(&self) -> u64 {
        self.compressed
            .load(Ordering::Relaxed)
            .saturating_mul(self.limits.max_total_ratio)
            .max(RELATIVE_FLOOR_BYTES)
    }

    /// Whether `more` bytes fit; the refusal names the limit.
    fn check(&self, more: u64) -> std::result::Result<(), String> {
        let total = self.used.load(Ordering::Relaxed).saturating_add(more);
        let l = &self.limits;
        if total > l.max_total_bytes {
            return Err(format!(
                "decompressing it would take the event's zips past {total} bytes, above the limit of {} bytes decompressed per event",
                l.max_total_bytes
            ));
        }
        let relative = self.relative();
        if total > relative {
            return Err(format!(
                "decompressing it would take the event's zips past {total} bytes, above the limit of {} × the {} bytes of the event's zip files ({relative} bytes)",
                l.max_total_ratio,
                self.compressed.load(Ordering::Relaxed)
            ));
        }
        Ok(())
    }

    fn spend(&self, n: u64) -> std::result::Result<(), String> {
        self.check(n)?;
        self.used.fetch_add(n, Ordering::Relaxed);
        Ok(())
    }
}

/// Where a file's content is, beyond its head.
#[derive(Clone)]
enum Body {
    /// `head` is the whole content.
    Whole,
    /// A big file of a directory, read when its content is asked for.
    OnDisk { path: PathBuf, len: u64 },
    /// A big zip member, inflated when its content is asked for.
    Member(ZipMember),
}

impl std::fmt::Debug for Body {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Body::Whole => write!(f, "Whole"),
            Body::OnDisk { path, len } => write!(f, "OnDisk({}, {len} bytes)", path.display()),
            Body::Member(m) => write!(
                f,
                "Member(#{}, {} bytes claimed, {} compressed)",
                m.index, m.claimed, m.compressed
            ),
        }
    }
}

/// A member of a zip held in memory (the outer zip's bytes, or a nested
/// zip's inflated bytes), with the event's budget.
#[derive(Clone)]
struct ZipMember {
    archive: zip::ZipArchive<Cursor<Arc<[u8]>>>,
    index: usize,
    claimed: u64,
    compressed: u64,
    budget: Arc<Budget>,
}

/// One file of the event, with where it came from.
#[derive(Debug, Clone)]
pub struct EventFile {
    /// Path relative to the event root (for a zip given as the event: the zip's file name).
    pub file: String,
    /// Member path inside the zip(s), nested zips joined with `:`.
    pub member: Option<String>,
    /// The file's content — or, for a big file of a directory or a big zip
    /// member (read later, [`EventFile::content`]), its first
    /// [`HEAD_BYTES`]: enough to recognise the format.
    pub head: Vec<u8>,
    body: Body,
}

impl EventFile {
    /// The whole content (a big file of a directory is read now, a big zip
    /// member inflated now, within the event's budget).
    pub fn content(&self) -> Result<std::borrow::Cow<'_, [u8]>> {
        match &self.body {
            Body::Whole => Ok(std::borrow::Cow::Borrowed(&self.head)),
            Body::OnDisk { path, len } => {
                // At most the size listed (and checked): a file grown since
                // is cut there, never read without bound.
                // Sized once: a vector doubling to 300 MB held 768 MB at
                // its last growth.
                let mut bytes = Vec::with_capacity(*len as usize);
                crate::input_file::open(path)?
                    .take(*len)
                    .read_to_end(&mut bytes)
                    .map_err(|e| Error::io(path, e))?;
                Ok(std::borrow::Cow::Owned(bytes))
            }
            Body::Member(m) => {
                let mut archive = m.archive.clone();
                let mut entry = archive.by_index(m.index).map_err(|e| {
                    Error::input(self.location(), format!("zip entry unreadable: {e}"))
                })?;
                inflate(&mut entry, m, u64::MAX, &|| self.location()).map(std::borrow::Cow::Owned)
            }
        }
    }

    /// The size of the whole content, bytes (for a zip member: the size its
    /// header claims, which [`EventFile::content`] holds it to).
    pub fn len(&self) -> u64 {
        match &self.body {
            Body::Whole => self.head.len() as u64,
            Body::OnDisk { len, .. } => *len,
            Body::Member(m) => m.claimed,
        }
    }

    /// Whether the file is empty.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
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

/// Whether the zip file at `path` is whole, as far as its structure tells
/// without decompressing: its end-of-central-directory record is found, its
/// central directory reads, and every member's data lies inside the file.
/// A zip is written front to back with its central directory last, so an
/// upload cut short (or still running) fails here.  `Err` says why (for a
/// log line); `Ok` is the number of members.
pub fn zip_is_whole(path: &Path) -> std::result::Result<usize, String> {
    let file = crate::input_file::open(path).map_err(|e| e.to_string())?;
    let len = file.metadata().map_err(|e| e.to_string())?.len();
    let mut zip = zip::ZipArchive::new(std::io::BufReader::new(file))
        .map_err(|e| format!("no readable central directory ({e})"))?;
    for i in 0..zip.len() {
        let entry = zip
            .by_index_raw(i)
            .map_err(|e| format!("member {i} unreadable ({e})"))?;
        // `by_index_raw` read the member's local header, which sets its data start.
        let end = entry
            .data_start()
            .unwrap_or(entry.header_start())
            .saturating_add(entry.compressed_size());
        if end > len {
            return Err(format!(
                "member {i} ends at byte {end}, past the file's {len} bytes"
            ));
        }
    }
    Ok(zip.len())
}

/// Collects every file of the event at `root` (directory or zip), sorted by
/// name so processing order is stable.
pub fn collect(root: &Path, limits: &ArchiveLimits) -> Result<Vec<EventFile>> {
    let meta = std::fs::metadata(root).map_err(|e| Error::io(root, e))?;
    let mut out = Vec::new();
    let budget = Budget::new(limits);
    if meta.is_dir() {
        let mut paths = Vec::new();
        walk(root, root, &mut paths)?;
        paths.sort();
        for rel in paths {
            let full = root.join(&rel);
            let name = rel.to_string_lossy().replace('\\', "/");
            let (bytes, len) = read_head_bounded(&full, limits)?;
            let whole = bytes.len() as u64 == len;
            if is_zip(&name, &bytes) {
                let bytes = if whole {
                    bytes
                } else {
                    read_bounded(&full, limits)?
                };
                expand_zip(name, None, bytes, 0, &budget, &mut out)?;
            } else if whole {
                out.push(EventFile {
                    file: name,
                    member: None,
                    head: bytes,
                    body: Body::Whole,
                });
            } else {
                out.push(EventFile {
                    file: name,
                    member: None,
                    head: bytes,
                    body: Body::OnDisk { path: full, len },
                });
            }
        }
    } else if meta.is_file() {
        let name = root
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        // The head decides: a gigabyte that is no zip is refused unread.
        let (head, len) = read_head_bounded(root, limits)?;
        if !is_zip(&name, &head) {
            return Err(Error::input(
                Location::file(root.display().to_string()),
                "an event must be a directory or a .zip archive",
            ));
        }
        let bytes = if head.len() as u64 == len {
            head
        } else {
            read_bounded(root, limits)?
        };
        expand_zip(name, None, bytes, 0, &budget, &mut out)?;
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
/// head, with the file's size (checked first against the member limit).
fn read_head_bounded(path: &Path, limits: &ArchiveLimits) -> Result<(Vec<u8>, u64)> {
    let size = checked_size(path, limits)?;
    let keep = if size <= READ_LATER_ABOVE {
        size
    } else {
        HEAD_BYTES as u64
    };
    let mut head = Vec::with_capacity(keep as usize);
    crate::input_file::open(path)?
        .take(keep)
        .read_to_end(&mut head)
        .map_err(|e| Error::io(path, e))?;
    // A file that shrank since its size was read is read as it is now.
    let len = if (head.len() as u64) < keep {
        head.len() as u64
    } else {
        size
    };
    Ok((head, len))
}

/// Reads a regular file whose size is checked first against the member
/// limit (and no more than that size, should it grow meanwhile).
fn read_bounded(path: &Path, limits: &ArchiveLimits) -> Result<Vec<u8>> {
    let size = checked_size(path, limits)?;
    let mut bytes = Vec::with_capacity(size as usize);
    crate::input_file::open(path)?
        .take(size)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    Ok(bytes)
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

/// Why a member may not be inflated (beyond its head) for what its header
/// claims: above the member limit, or a ratio no record has.
fn claim_refusal(m: &ZipMember) -> Option<String> {
    let l = &m.budget.limits;
    if m.claimed > l.max_member_bytes {
        return Some(format!(
            "claims {} bytes, above the limit of {} bytes for one member",
            m.claimed, l.max_member_bytes
        ));
    }
    let ratio_cap = ratio_cap(m.compressed, l.max_member_ratio);
    if m.claimed > ratio_cap {
        return Some(format!(
            "claims {} bytes from {} compressed bytes: more than the limit of {}:1 for one member (a deflate bomb, or not a record)",
            m.claimed, m.compressed, l.max_member_ratio
        ));
    }
    None
}

/// The most bytes a member of `compressed` bytes may inflate to.
fn ratio_cap(compressed: u64, ratio: u64) -> u64 {
    compressed.saturating_mul(ratio).max(RATIO_GRACE_BYTES)
}

/// Inflates at most `want` bytes of a member (its head, or `u64::MAX` for
/// all of it) in chunks, checking each against the member's claim and
/// ratio and the event's budget before it is kept.  Reading it all, the
/// member must hold exactly what it claims.
fn inflate(
    entry: &mut dyn Read,
    m: &ZipMember,
    want: u64,
    loc: &dyn Fn() -> Location,
) -> Result<Vec<u8>> {
    let all = want == u64::MAX;
    if all {
        if let Some(why) = claim_refusal(m) {
            return Err(Error::input(loc(), why));
        }
        m.budget
            .check(m.claimed)
            .map_err(|why| Error::input(loc(), why))?;
    }
    let l = &m.budget.limits;
    let cap = ratio_cap(m.compressed, l.max_member_ratio);
    let limit = want.min(m.claimed.saturating_add(1));
    // A whole member's claim has passed the budget above: sized once to it
    // (untouched capacity costs no memory; a vector doubling to 300 MB
    // held 768 MB at its last growth).  A head is small.
    let first = if all {
        m.claimed
    } else {
        limit.min(READ_LATER_ABOVE)
    };
    let mut data = Vec::with_capacity(first as usize);
    let mut chunk = vec![0u8; INFLATE_CHUNK];
    while (data.len() as u64) < limit {
        let room = (limit - data.len() as u64).min(INFLATE_CHUNK as u64) as usize;
        let n = entry
            .read(&mut chunk[..room])
            .map_err(|e| Error::input(loc(), format!("cannot decompress: {e}")))?;
        if n == 0 {
            break;
        }
        let after = data.len() as u64 + n as u64;
        if after > m.claimed {
            return Err(Error::input(
                loc(),
                format!("holds more than the {} bytes it claims", m.claimed),
            ));
        }
        if after > cap {
            return Err(Error::input(
                loc(),
                format!(
                    "inflates past {after} bytes from {} compressed bytes: more than the limit of {}:1 for one member",
                    m.compressed, l.max_member_ratio
                ),
            ));
        }
        m.budget
            .spend(n as u64)
            .map_err(|why| Error::input(loc(), why))?;
        data.extend_from_slice(&chunk[..n]);
    }
    if all && data.len() as u64 != m.claimed {
        return Err(Error::input(
            loc(),
            format!("holds {} bytes but claims {}", data.len(), m.claimed),
        ));
    }
    Ok(data)
}

/// Adds the members of the zip `bytes` (the event's zip, a zip file of its
/// folder, or a nested zip), expanding nested zips (recursively).  Members
/// above [`READ_LATER_ABOVE`] are inflated up to their head only.
fn expand_zip(
    file: String,
    member: Option<String>,
    bytes: Vec<u8>,
    depth: usize,
    budget: &Arc<Budget>,
    out: &mut Vec<EventFile>,
) -> Result<()> {
    let limits = &budget.limits;
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
    if depth == 0 {
        // Only the zips on disk set the relative budget: a nested zip's
        // bytes are themselves decompressed output.
        budget.compressed.fetch_add(archive_len, Ordering::Relaxed);
    }
    let bytes: Arc<[u8]> = bytes.into();
    let mut zip = zip::ZipArchive::new(Cursor::new(bytes))
        .map_err(|e| Error::input(loc(), format!("not a readable zip archive: {e}")))?;
    let mut members = Vec::new();
    for i in 0..zip.len() {
        let entry = zip
            .by_index(i)
            .map_err(|e| Error::input(loc(), format!("zip entry {i} unreadable: {e}")))?;
        let raw_name = entry
            .name()
            .map_err(|e| Error::input(loc(), format!("zip entry {i} has an unreadable name: {e}")))?
            .into_owned();
        let inner = match &member {
            Some(m) => format!("{m}:{raw_name}"),
            None => raw_name.clone(),
        };
        let member_loc = || Location::file(&file).with_member(inner.clone());
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
        let base = raw_name.rsplit('/').next().unwrap_or(&raw_name);
        if base.starts_with('.') || raw_name.starts_with("__MACOSX/") {
            continue;
        }
        let (claimed, compressed) = (entry.size(), entry.compressed_size());
        drop(entry);
        let m = ZipMember {
            archive: zip.clone(),
            index: i,
            claimed,
            compressed,
            budget: budget.clone(),
        };
        let mut entry = zip
            .by_index(i)
            .map_err(|e| Error::input(member_loc(), format!("zip entry unreadable: {e}")))?;
        // Small members whole; big ones up to their head, which decides
        // whether they are read at all (a nested zip always is).
        let small = m.claimed <= READ_LATER_ABOVE;
        let want = if small { u64::MAX } else { HEAD_BYTES as u64 };
        let head = inflate(&mut entry, &m, want, &member_loc)?;
        drop(entry);
        let nested = is_zip(&raw_name, &head);
        let data = if nested && !small {
            let mut entry = zip
                .by_index(i)
                .map_err(|e| Error::input(member_loc(), format!("zip entry unreadable: {e}")))?;
            inflate(&mut entry, &m, u64::MAX, &member_loc)?
        } else {
            head
        };
        members.push((inner, data, nested, small, m));
    }
    members.sort_by(|a, b| a.0.cmp(&b.0));
    for (inner, data, nested, small, m) in members {
        if nested {
            expand_zip(file.clone(), Some(inner), data, depth + 1, budget, out)?;
        } else {
            out.push(EventFile {
                file: file.clone(),
                member: Some(inner),
                head: data,
                body: if small { Body::Whole } else { Body::Member(m) },
            });
        }
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
