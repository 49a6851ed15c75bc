//! The output directory's lock: one run at a time writes into a directory.
//!
//! The lock is the file `DIR/.quaketwin.lock`, holding an exclusive advisory
//! lock (`flock`) for as long as the run lasts, and a JSON line naming the
//! holder (pid, host, start time, event) so a refused run can say who holds
//! it.  The operating system releases the advisory lock when the holder
//! exits, however it exits; the file is removed at the end of a run.  A
//! lock file left by a run that was killed on this host is taken over (and
//! the run says so); one left by a run on another host is refused, since
//! that run may be alive (remove the file by hand when it is not).

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Name of the lock file inside the output directory.
pub const LOCK_FILE: &str = crate::event_folder::RUN_LOCK_FILE;

/// Who holds (or held) a lock.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Holder {
    pub pid: u32,
    pub host: String,
    /// Start of the run, UTC (ISO 8601).
    pub started: String,
    /// What the run does (e.g. the event path).
    pub what: String,
}

impl Holder {
    fn describe(&self) -> String {
        format!(
            "pid {} on host {}, started {} ({})",
            self.pid, self.host, self.started, self.what
        )
    }
}

/// An acquired lock; released (and the file removed) on drop.
#[derive(Debug)]
pub struct DirLock {
    path: PathBuf,
    file: Option<File>,
    /// Said when a stale lock was taken over.
    pub took_over: Option<String>,
}

/// This machine's host name (`/proc/sys/kernel/hostname`, `/etc/hostname`,
/// `$HOSTNAME`), or `unknown`.
pub fn host_name() -> String {
    for p in ["/proc/sys/kernel/hostname", "/etc/hostname"] {
        if let Ok(s) = std::fs::read_to_string(p) {
            let s = s.trim();
            if !s.is_empty() {
                return s.to_string();
            }
        }
    }
    std::env::var("HOSTNAME")
        .ok()
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".into())
}

/// Whether process `pid` runs on this host (None: cannot tell).
fn process_alive(pid: u32) -> Option<bool> {
    if Path::new("/proc/self").exists() {
        Some(Path::new(&format!("/proc/{pid}")).exists())
    } else {
        None
    }
}

fn now_utc() -> String {
    let ns = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as i64)
        .unwrap_or(0);
    crate::vocab::format_epoch_ns(ns - ns % 1_000_000_000)
}

#[cfg(unix)]
fn same_file(a: &std::fs::Metadata, b: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::MetadataExt;
    a.dev() == b.dev() && a.ino() == b.ino()
}
#[cfg(not(unix))]
fn same_file(_: &std::fs::Metadata, _: &std::fs::Metadata) -> bool {
    true
}

fn read_holder(file: &mut File) -> Option<Holder> {
    let mut text = String::new();
    file.rewind().ok()?;
    file.read_to_string(&mut text).ok()?;
    serde_json::from_str(text.trim()).ok()
}

impl DirLock {
    /// Takes the lock of directory `dir` for a run described by `what`.
    /// A lock held by a live run is a usage error naming the holder.
    pub fn acquire(dir: &Path, what: &str) -> Result<DirLock> {
        let path = dir.join(LOCK_FILE);
        // A few attempts: the holder may remove the file between our open
        // and our lock (then we hold a lock on a removed file, and retry).
        for _ in 0..20 {
            crate::sinks::atomic::check_replaceable(&path)?;
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .map_err(|e| Error::io(&path, e))?;
            match file.try_lock() {
                Ok(()) => {}
                Err(TryLockError::WouldBlock) => {
                    let holder = read_holder(&mut file)
                        .map(|h| h.describe())
                        .unwrap_or_else(|| "another process (no details yet)".into());
                    return Err(Error::usage(format!(
                        "{}: output directory {} is in use by another quaketwin run: {holder}; \
                         wait for it to finish or use another --out directory",
                        path.display(),
                        dir.display()
                    )));
                }
                Err(TryLockError::Error(e)) => return Err(Error::io(&path, e)),
            }
            // Still the file at `path`?  (The previous holder removes it when done.)
            let (Ok(mine), Ok(there)) = (file.metadata(), std::fs::symlink_metadata(&path)) else {
                continue;
            };
            if !same_file(&mine, &there) {
                continue;
            }
            let host = host_name();
            let mut took_over = None;
            if let Some(old) = read_holder(&mut file) {
                if old.host != host {
                    return Err(Error::usage(format!(
                        "{}: output directory {} is locked by a run on another host: {}; \
                         if that run is over, remove {}",
                        path.display(),
                        dir.display(),
                        old.describe(),
                        path.display()
                    )));
                }
                let state = match process_alive(old.pid) {
                    Some(false) => "that process is no longer running",
                    _ => "that process no longer holds the lock",
                };
                took_over = Some(format!(
                    "{}: taking over the stale lock of an interrupted run ({}): {state}",
                    path.display(),
                    old.describe()
                ));
            }
            let me = Holder {
                pid: std::process::id(),
                host,
                started: now_utc(),
                what: what.to_string(),
            };
            let line = serde_json::to_string(&me).unwrap_or_default() + "\n";
            file.set_len(0)
                .and_then(|_| file.rewind())
                .and_then(|_| file.write_all(line.as_bytes()))
                .and_then(|_| file.sync_all())
                .map_err(|e| Error::io(&path, e))?;
            return Ok(DirLock {
                path,
                file: Some(file),
                took_over,
            });
        }
        Err(Error::usage(format!(
            "{}: could not take the lock (it keeps changing hands)",
            path.display()
        )))
    }
}

impl Drop for DirLock {
    fn drop(&mut self) {
        if let Some(file) = self.file.take() {
            // Remove the file while still holding the lock, so nobody takes
            // over a file that is about to disappear (they re-check the inode).
            let _ = std::fs::remove_file(&self.path);
            let _ = file.unlock();
        }
    }
}
