//! Stable fingerprints for deciding whether a stage is up to date.  FNV-1a
//! 64 is written here (ten lines) because std's hasher is not guaranteed
//! stable across releases and the stamps outlive one binary.

use std::path::Path;

use crate::error::{Error, Result};

#[derive(Debug, Clone, Copy)]
pub struct Fnv64(u64);

impl Default for Fnv64 {
    fn default() -> Self {
        Fnv64(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv64 {
    pub fn write(&mut self, bytes: &[u8]) -> &mut Self {
        for b in bytes {
            self.0 ^= *b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
        // Separator so ("ab","c") and ("a","bc") differ.
        self.0 ^= 0xff;
        self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        self
    }
    /// Bytes without the separator (for hashing a file in chunks).
    pub fn write_raw(&mut self, bytes: &[u8]) -> &mut Self {
        for b in bytes {
            self.0 ^= *b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
        self
    }
    pub fn write_str(&mut self, s: &str) -> &mut Self {
        self.write(s.as_bytes())
    }
    pub fn finish_hex(&self) -> String {
        format!("{:016x}", self.0)
    }
}

/// Fingerprint of an input path (file or directory tree): names, sizes and
/// modification times, in sorted order.
pub fn path_fingerprint(path: &Path) -> Result<String> {
    let mut h = Fnv64::default();
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
