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
//! Values are stored as little-endian f64 bits, so what is read back is
//! exactly what was parked.

use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use crate::error::{Error, Result};
use crate::vocab::SampleStore;

/// Events with more samples than this (over all channels) are parked by a
/// pipeline run: 2²⁴ samples, 128 MiB of f64 — a few minutes of a dense
/// array.  The bundled sample events stay far below it.
pub const PARK_ABOVE_SAMPLES: usize = 1 << 24;

/// Values moved per read or write call (1 MiB).
const CHUNK: usize = 1 << 17;

/// The spill file (see the module doc).
pub struct SpillFile {
    path: PathBuf,
    /// The file and the end of what was written; one lock for both keeps a
    /// read from racing the seek of a write.
    inner: Mutex<(File, u64)>,
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
            inner: Mutex::new((file, 0)),
        }))
    }

    fn lock(&self) -> std::io::Result<std::sync::MutexGuard<'_, (File, u64)>> {
        self.inner
            .lock()
            .map_err(|_| std::io::Error::other("an earlier access to the spill file failed"))
    }
}

impl SampleStore for SpillFile {
    fn put(&self, values: &[f64]) -> std::io::Result<u64> {
        let mut bytes = Vec::with_capacity(8 * values.len().min(CHUNK));
        let mut guard = self.lock()?;
        let (file, end) = &mut *guard;
        let position = *end;
        file.seek(SeekFrom::Start(position))?;
        for chunk in values.chunks(CHUNK) {
            bytes.clear();
            for v in chunk {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
            file.write_all(&bytes)?;
        }
        *end += 8 * values.len() as u64;
        Ok(position)
    }

    fn get(&self, position: u64, offset: usize, out: &mut [f64]) -> std::io::Result<()> {
        let mut bytes = vec![0u8; 8 * out.len().min(CHUNK)];
        let mut guard = self.lock()?;
        let (file, _) = &mut *guard;
        file.seek(SeekFrom::Start(position + 8 * offset as u64))?;
        for chunk in out.chunks_mut(CHUNK) {
            let b = &mut bytes[..8 * chunk.len()];
            file.read_exact(b)?;
            for (v, raw) in chunk.iter_mut().zip(b.chunks_exact(8)) {
                let mut le = [0u8; 8];
                le.copy_from_slice(raw);
                *v = f64::from_le_bytes(le);
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
