//! The run's sample store (issue 14 item 5): a temporary file in the output
//! directory where the samples of a big event are parked while no stage
//! needs them (`vocab::Samples`), so that a run holds a few channels in
//! memory at a time instead of the whole event several times over.
//!
//! The file is named like every temporary file of ours
//! (`.samples.quaketwin-<pid>-<n>.tmp`, `sinks::atomic`) and, on Unix,
//! removed from the directory as soon as it is open: the disk space is
//! returned when the run ends, however it ends.  Elsewhere it is removed when
//! the run drops it, and a leftover is swept by the next run in the directory.
//!
//! Values are stored as little-endian f64 bits — or, when every value of a
//! series is exactly an f32 (records of float32 or integer-count sources, as
//! read), as f32 bits, half the disk (issue 33 item 6: a day's spill no
//! larger than its input) — so what is read back is exactly what was parked.

use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use crate::error::{Error, Result};
use crate::vocab::SampleStore;

/// Events with more samples than this (over all channels) are parked by a
/// pipeline run: 2²⁴ samples, 128 MiB of f64 — a few minutes of a dense
/// array.  The bundled sample events stay far below it.
pub const PARK_ABOVE_SAMPLES: usize = 1 << 24;

/// Values moved per read or write call (1 MiB of f64).
const CHUNK: usize = 1 << 17;

/// The top bit of a position: the series is stored as f32 (positions are
/// byte offsets in a file, far below 2⁶³).
const F32_TAG: u64 = 1 << 63;

/// Whether `v` is exactly an f32 (its bits come back unchanged through
/// f32; NaN payloads included).
fn is_exact_f32(v: f64) -> bool {
    ((v as f32) as f64).to_bits() == v.to_bits()
}

/// The spill file (see the module doc).
pub struct SpillFile {
    path: PathBuf,
    file: File,
    /// The end of what was reserved: a put takes its range with one atomic
    /// addition and writes it at its own offset, so channels conditioned in
    /// parallel park and read back at once, never waiting on each other.
    end: AtomicU64,
}

impl SpillFile {
    /// Creates the spill file in `dir`.
    pub fn create(dir: &Path) -> Result<Arc<dyn SampleStore>> {
        let path = crate::sinks::atomic::temp_path(&dir.join("samples"));
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create_new(true)
            .open(&path)
            .map_err(|e| Error::io(&path, e))?;
        // Unix keeps an open file's data after its name is gone.
        #[cfg(unix)]
        std::fs::remove_file(&path).map_err(|e| Error::io(&path, e))?;
        Ok(Arc::new(SpillFile {
            path,
            file,
            end: AtomicU64::new(0),
        }))
    }
}

/// Positional writes and reads (`pwrite`/`pread` on Unix, `seek_write`/
/// `seek_read` on Windows): the file has no shared cursor to lock.
#[cfg(unix)]
fn write_at(file: &File, bytes: &[u8], at: u64) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::write_all_at(file, bytes, at)
}
#[cfg(unix)]
fn read_at(file: &File, bytes: &mut [u8], at: u64) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::read_exact_at(file, bytes, at)
}
#[cfg(windows)]
fn write_at(file: &File, mut bytes: &[u8], mut at: u64) -> std::io::Result<()> {
    while !bytes.is_empty() {
        let n = std::os::windows::fs::FileExt::seek_write(file, bytes, at)?;
        if n == 0 {
            return Err(std::io::ErrorKind::WriteZero.into());
        }
        bytes = &bytes[n..];
        at += n as u64;
    }
    Ok(())
}
#[cfg(windows)]
fn read_at(file: &File, mut bytes: &mut [u8], mut at: u64) -> std::io::Result<()> {
    while !bytes.is_empty() {
        let n = std::os::windows::fs::FileExt::seek_read(file, bytes, at)?;
        if n == 0 {
            return Err(std::io::ErrorKind::UnexpectedEof.into());
        }
        bytes = &mut bytes[n..];
        at += n as u64;
    }
    Ok(())
}

impl SampleStore for SpillFile {
    fn put(&self, values: &[f64]) -> std::io::Result<u64> {
        if values.iter().all(|&v| is_exact_f32(v)) {
            let position = self
                .end
                .fetch_add(4 * values.len() as u64, Ordering::Relaxed);
            let mut at = position;
            let mut bytes = Vec::with_capacity(4 * values.len().min(CHUNK));
            for chunk in values.chunks(CHUNK) {
                bytes.clear();
                for &v in chunk {
                    bytes.extend_from_slice(&(v as f32).to_le_bytes());
                }
                write_at(&self.file, &bytes, at)?;
                at += bytes.len() as u64;
            }
            return Ok(position | F32_TAG);
        }
        let position = self
            .end
            .fetch_add(8 * values.len() as u64, Ordering::Relaxed);
        let mut at = position;
        if cfg!(target_endian = "little") {
            // The f64s' own bytes are their little-endian bits: written as
            // they lie in memory, without a converted copy.
            for chunk in values.chunks(CHUNK) {
                write_at(&self.file, bytemuck::cast_slice(chunk), at)?;
                at += 8 * chunk.len() as u64;
            }
        } else {
            let mut bytes = Vec::with_capacity(8 * values.len().min(CHUNK));
            for chunk in values.chunks(CHUNK) {
                bytes.clear();
                for v in chunk {
                    bytes.extend_from_slice(&v.to_le_bytes());
                }
                write_at(&self.file, &bytes, at)?;
                at += bytes.len() as u64;
            }
        }
        Ok(position)
    }

    fn get(&self, position: u64, offset: usize, out: &mut [f64]) -> std::io::Result<()> {
        if position & F32_TAG != 0 {
            let mut at = (position & !F32_TAG) + 4 * offset as u64;
            let mut bytes = vec![0u8; 4 * out.len().min(CHUNK)];
            for chunk in out.chunks_mut(CHUNK) {
                let b = &mut bytes[..4 * chunk.len()];
                read_at(&self.file, b, at)?;
                at += b.len() as u64;
                for (v, raw) in chunk.iter_mut().zip(b.chunks_exact(4)) {
                    *v = f32::from_le_bytes([raw[0], raw[1], raw[2], raw[3]]) as f64;
                }
            }
            return Ok(());
        }
        let mut at = position + 8 * offset as u64;
        if cfg!(target_endian = "little") {
            // Read straight into the values (every bit pattern is an f64).
            for chunk in out.chunks_mut(CHUNK) {
                read_at(&self.file, bytemuck::cast_slice_mut(chunk), at)?;
                at += 8 * chunk.len() as u64;
            }
        } else {
            let mut bytes = vec![0u8; 8 * out.len().min(CHUNK)];
            for chunk in out.chunks_mut(CHUNK) {
                let b = &mut bytes[..8 * chunk.len()];
                read_at(&self.file, b, at)?;
                at += b.len() as u64;
                for (v, raw) in chunk.iter_mut().zip(b.chunks_exact(8)) {
                    let mut le = [0u8; 8];
                    le.copy_from_slice(raw);
                    *v = f64::from_le_bytes(le);
                }
            }
        }
        Ok(())
    }

    fn describe(&self) -> String {
        format!("the run's spill file {}", self.path.display())
    }
}

impl Drop for SpillFile {
    fn drop(&mut self) {
        #[cfg(not(unix))]
        let _ = std::fs::remove_file(&self.path);
    }
}
