//! The one hash of quaketwin: XXH64 (seed 0), for the fingerprints that
//! decide whether a stage is up to date and for the output hashes of the run
//! manifest (`run.json`).
//!
//! Why XXH64: the values must be stable across releases and builds (they
//! outlive one binary; std's hasher promises neither), and output files are
//! hashed whole — `samples.parquet` of an hour of 64 channels is over a GB, and
//! every re-run verifies every output.  FNV-1a, used before, runs a byte at a
//! time (about 0.2–1 GB/s here); XXH64 runs 8 bytes a lane over four lanes
//! (about 15× faster here) and is a published specification, so a file's hash
//! in `run.json` is what `xxhsum -H1 FILE` prints.  The crate (twox-hash) is
//! already in the build through parquet, with the same feature.

use std::hash::Hasher as _;

/// Streaming XXH64 with seed 0.
#[derive(Debug, Clone, Default)]
pub struct Hash64(twox_hash::XxHash64);

impl Hash64 {
    /// One field: its length, then its bytes, so that ("ab", "c") and
    /// ("a", "bc") differ.
    pub fn write(&mut self, bytes: &[u8]) -> &mut Self {
        self.0.write(&(bytes.len() as u64).to_le_bytes());
        self.0.write(bytes);
        self
    }
    /// Bytes as they come (a file in chunks): the hash of the concatenation.
    pub fn write_raw(&mut self, bytes: &[u8]) -> &mut Self {
        self.0.write(bytes);
        self
    }
    pub fn write_str(&mut self, s: &str) -> &mut Self {
        self.write(s.as_bytes())
    }
    /// The hash, 16 lowercase hex digits (XXH64's canonical big-endian form).
    pub fn finish_hex(&self) -> String {
        format!("{:016x}", self.0.finish())
    }
}
