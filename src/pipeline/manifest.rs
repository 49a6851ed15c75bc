//! The run manifest `DIR/run.json`: which event the output directory holds,
//! and per stage the fingerprint of its inputs and settings and the size and
//! XXH64 hash ([`crate::hash`]) of every output file.  It is the directory's table of
//! contents: a file not listed here is not a result (the report shows only
//! listed files), a listed file that fails its size or hash is damaged and
//! rebuilt.  Schema: docs/pipelines.md ("The run manifest").

use std::io::Read;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::hash::Hash64;

/// File name of the manifest inside the output directory.
pub const MANIFEST_FILE: &str = crate::event_folder::RUN_MANIFEST_FILE;
/// Version of the manifest's layout (2: outputs hashed with XXH64, `xxh64`;
/// 1 had FNV-1a, `fnv1a64`).
pub const FORMAT: u32 = 2;

/// Contents of `run.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunManifest {
    /// Layout version ([`FORMAT`]).
    pub format: u32,
    pub quaketwin_version: String,
    /// Name of the pipeline of the last run.
    pub pipeline: String,
    pub event: EventIdentity,
    /// In pipeline order.
    pub stages: Vec<StageRecord>,
}

/// Which event the directory holds.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EventIdentity {
    /// The event folder or zip (absolute path).
    pub path: String,
    /// Fingerprint of its files: names, sizes and modification times.
    pub fingerprint: String,
}

/// State of a stage in the directory.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StageState {
    /// Ran (now or in an earlier run) and its outputs are as recorded.
    Done,
    /// Started but not finished (the run failed or was killed): its outputs
    /// are not trusted and are rebuilt or removed by the next run.
    Started,
    /// Does not apply to this event (`reason` says why): no outputs.
    NotApplicable,
    /// Switched off in the pipeline file: no outputs.
    Disabled,
}

/// One stage's record.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageRecord {
    pub name: String,
    pub kind: String,
    pub state: StageState,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// Fingerprint of the stage's inputs and settings (empty when it did not run).
    #[serde(default)]
    pub fingerprint: String,
    #[serde(default)]
    pub outputs: Vec<OutputRecord>,
}

/// One output file: its name in the directory, size and hash.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputRecord {
    pub file: String,
    /// Size in bytes (absent while the stage is `started`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bytes: Option<u64>,
    /// XXH64 of the file's bytes, 16 hex digits (absent while `started`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub xxh64: Option<String>,
}

impl RunManifest {
    /// The record of stage `name`.
    pub fn stage(&self, name: &str) -> Option<&StageRecord> {
        self.stages.iter().find(|s| s.name == name)
    }
    /// Files of the `done` stages: the directory's results.
    pub fn done_files(&self) -> Vec<String> {
        self.stages
            .iter()
            .filter(|s| s.state == StageState::Done)
            .flat_map(|s| s.outputs.iter().map(|o| o.file.clone()))
            .collect()
    }
    /// Every file any record names.
    pub fn all_files(&self) -> Vec<String> {
        self.stages
            .iter()
            .flat_map(|s| s.outputs.iter().map(|o| o.file.clone()))
            .collect()
    }
}

/// Reads `dir/run.json`: `Ok(None)` when absent, `Err` (with the reason)
/// when present but not a valid manifest.
pub fn read(dir: &Path) -> std::result::Result<Option<RunManifest>, String> {
    let path = dir.join(MANIFEST_FILE);
    match std::fs::symlink_metadata(&path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e.to_string()),
        Ok(m) if !m.file_type().is_file() => return Err("not a regular file".into()),
        Ok(_) => {}
    }
    let bytes = crate::input_file::read(&path, crate::input_file::MAX_INPUT_BYTES)
        .map_err(|e| e.to_string())?;
    // The layout version first: a manifest of another format is reported
    // as such, not by the first field this build does not know.
    #[derive(Deserialize)]
    struct Format {
        format: u32,
    }
    let format = serde_json::from_slice::<Format>(&bytes)
        .map_err(|e| e.to_string())?
        .format;
    if format != FORMAT {
        return Err(format!(
            "manifest format {format} (this build reads {FORMAT})"
        ));
    }
    let m: RunManifest = serde_json::from_slice(&bytes).map_err(|e| e.to_string())?;
    Ok(Some(m))
}

/// Writes `dir/run.json` atomically.
pub fn write(dir: &Path, m: &RunManifest) -> Result<()> {
    let path = dir.join(MANIFEST_FILE);
    let mut json = serde_json::to_vec_pretty(m).map_err(|e| Error::output(&path, e.to_string()))?;
    json.push(b'\n');
    crate::sinks::atomic::write_bytes_atomically(&path, &json)
}

/// Size and hash of a regular file (never following a link), read whole;
/// `None` when absent or not a regular file.
pub fn hash_file(path: &Path) -> Result<Option<(u64, String)>> {
    match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(Error::io(path, e)),
        Ok(m) if !m.file_type().is_file() => return Ok(None),
        Ok(_) => {}
    }
    let mut f = crate::input_file::open(path)?;
    let mut h = Hash64::default();
    let mut buf = vec![0u8; 1 << 20];
    let mut n_total = 0u64;
    loop {
        let n = f.read(&mut buf).map_err(|e| Error::io(path, e))?;
        if n == 0 {
            break;
        }
        h.write_raw(&buf[..n]);
        n_total += n as u64;
    }
    Ok(Some((n_total, h.finish_hex())))
}

/// Record of output `file` in `dir` as it is now: the size and hash taken
/// as this process wrote it ([`crate::sinks::atomic::written_digest`]) when
/// it is still that file, else read from the file.
pub fn record_output(dir: &Path, file: &str) -> Result<OutputRecord> {
    let path = dir.join(file);
    let digest = match crate::sinks::atomic::written_digest(&path) {
        Some(d) => Some(d),
        None => hash_file(&path)?,
    };
    let (bytes, hash) = digest
        .ok_or_else(|| Error::output(&path, "the stage did not write this declared output"))?;
    Ok(OutputRecord {
        file: file.to_string(),
        bytes: Some(bytes),
        xxh64: Some(hash),
    })
}

/// Whether `dir/o.file` is still exactly as recorded; `Err` holds what is
/// wrong, in words.
pub fn verify_output(dir: &Path, o: &OutputRecord) -> Result<std::result::Result<(), String>> {
    let (Some(bytes), Some(hash)) = (o.bytes, o.xxh64.as_deref()) else {
        return Ok(Err("no recorded size and hash".into()));
    };
    let path = dir.join(&o.file);
    if let Ok(m) = std::fs::symlink_metadata(&path) {
        if !m.file_type().is_file() {
            return Ok(Err("not a regular file".into()));
        }
        if m.len() != bytes {
            return Ok(Err(format!("{} bytes, recorded {bytes}", m.len())));
        }
    }
    Ok(match hash_file(&path)? {
        None => Err("missing".into()),
        Some((_, h)) if h != hash => Err(format!("hash {h}, recorded {hash}")),
        Some(_) => Ok(()),
    })
}
