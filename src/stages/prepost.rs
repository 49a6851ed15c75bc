//! The pre/post part of the `modal` stage (issue 13): its params
//! (`reference_modes`, `reference_min_mac`, `reference_frequency_window`),
//! the modes of an earlier run read back, and `frequency_shifts/frequency_shifts.parquet`
//! (pairing and shifts: `modal::compare`).

use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::error::{Error, Result};
use crate::modal::{compare_events, Comparison, ModalResult, Mode, ModeSet, PairingSettings};
use crate::sinks::modal_tables as tables;
use crate::sinks::provenance::Provenance;

pub const SHIFTS_FILE: &str = crate::vocab::tables::FREQUENCY_SHIFTS.file;

/// The param `quaketwin run … --reference` and `quaketwin modal …
/// --reference` set.
pub const REFERENCE_KEY: &str = "reference_modes";

/// The keys of the `modal` stage's params that [`ReferenceParams`] takes.
pub const KEYS: &[&str] = &[
    REFERENCE_KEY,
    "reference_min_mac",
    "reference_frequency_window",
    "reference_frequency_std_floor",
    "change_false_alarm_rate",
];

/// Pre/post params of the `modal` stage (docs/pipelines.md).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReferenceParams {
    /// An earlier run of the same structure: its output directory or its
    /// `modes/modes.parquet` (relative to the working directory) →
    /// `frequency_shifts/frequency_shifts.parquet`.
    pub reference_modes: Option<PathBuf>,
    /// Least MAC of a pair on the shared channels.
    pub reference_min_mac: f64,
    /// Largest |f − f_ref|/f_ref of a pair.
    pub reference_frequency_window: f64,
    /// Least relative standard deviation of each frequency in the shift's
    /// uncertainty (`modal::compare`).
    pub reference_frequency_std_floor: f64,
    /// False-alarm rate of the change test against the reference
    /// (`change_test/change_test.parquet`, docs/statistics.md).
    pub change_false_alarm_rate: f64,
}

impl Default for ReferenceParams {
    fn default() -> Self {
        let d = PairingSettings::default();
        ReferenceParams {
            reference_modes: None,
            reference_min_mac: d.min_mac,
            reference_frequency_window: d.frequency_window,
            reference_frequency_std_floor: d.frequency_std_floor,
            change_false_alarm_rate: 0.01,
        }
    }
}

impl ReferenceParams {
    /// Checks the values and the reference file (before any record is
    /// read); the reference run, if any.
    pub fn check(&self) -> Result<Option<ReferenceRun>> {
        if !(self.reference_min_mac > 0.0 && self.reference_min_mac <= 1.0) {
            return Err(Error::usage(format!(
                "reference_min_mac {} must lie in (0, 1]",
                self.reference_min_mac
            )));
        }
        if !(self.reference_frequency_window > 0.0 && self.reference_frequency_window < 1.0) {
            return Err(Error::usage(format!(
                "reference_frequency_window {} must lie in (0, 1) (a fraction: 0.2 = 20 %)",
                self.reference_frequency_window
            )));
        }
        if !(self.reference_frequency_std_floor >= 0.0 && self.reference_frequency_std_floor < 0.5)
        {
            return Err(Error::usage(format!(
                "reference_frequency_std_floor {} must lie in [0, 0.5) (a fraction: 0.002 = 0.2 %)",
                self.reference_frequency_std_floor
            )));
        }
        if !(self.change_false_alarm_rate > 0.0 && self.change_false_alarm_rate < 0.5) {
            return Err(Error::usage(format!(
                "change_false_alarm_rate {} must lie in (0, 0.5) (a fraction: 0.01 = 1 %)",
                self.change_false_alarm_rate
            )));
        }
        let pairing = PairingSettings {
            min_mac: self.reference_min_mac,
            frequency_window: self.reference_frequency_window,
            frequency_std_floor: self.reference_frequency_std_floor,
            min_mac_same_direction: None,
        };
        self.reference_modes
            .as_deref()
            .map(|p| {
                let file = tables::locate_modes(p).map_err(|e| e.usage_about(REFERENCE_KEY))?;
                Ok(ReferenceRun {
                    file,
                    pairing,
                    change_false_alarm_rate: self.change_false_alarm_rate,
                })
            })
            .transpose()
    }
}

/// A checked reference: its `modes/modes.parquet` and the pairing settings.
#[derive(Debug, Clone)]
pub struct ReferenceRun {
    pub file: PathBuf,
    pub pairing: PairingSettings,
    /// α of the change test (`change_test/change_test.parquet`).
    pub change_false_alarm_rate: f64,
}

/// The modes of the reference run, read back.
pub struct Reference {
    pub run: ReferenceRun,
    pub modes: Vec<Mode>,
    pub channels: Vec<String>,
}

impl ReferenceRun {
    /// Reads the reference modes; refuses this run's own `modes/modes.parquet`
    /// in `out` (it is about to be replaced).
    pub fn read(&self, out: &Path) -> Result<Reference> {
        let own = out.join(crate::vocab::tables::MODES.file);
        if let (Ok(a), Ok(b)) = (
            std::fs::canonicalize(&self.file),
            std::fs::canonicalize(&own),
        ) {
            if a == b {
                return Err(Error::usage(format!(
                    "{REFERENCE_KEY}: {} is this run's own output: give the output directory of an earlier run",
                    self.file.display()
                )));
            }
        }
        let (modes, channels) = tables::read_modes(&self.file)?;
        Ok(Reference {
            run: self.clone(),
            modes,
            channels,
        })
    }

    /// Fingerprint of the reference file (outside the event folder): a new
    /// reference run re-runs the stage.
    pub fn fingerprint(&self) -> Result<String> {
        crate::pipeline::fingerprint::path_fingerprint(&self.file)
    }
}

/// Pairs the modes of `result` with the reference's and writes
/// `frequency_shifts/frequency_shifts.parquet` into `out`; a warning on stderr when no mode
/// pairs.
pub fn compare_and_write(
    reference: &Reference,
    result: &ModalResult,
    out: &Path,
    event_name: &str,
    provenance: &Provenance,
) -> Result<Comparison> {
    let (file, pairing) = (&reference.run.file, &reference.run.pairing);
    let c = compare_events(
        ModeSet {
            modes: &reference.modes,
            channels: &reference.channels,
        },
        ModeSet {
            modes: &result.modes,
            channels: &result.output_ids,
        },
        pairing,
    );
    if c.shifts.is_empty() {
        crate::console::warn(format!(
            "modal ({event_name}): no mode pairs with the reference {}: {}",
            file.display(),
            c.notes.join("; ")
        ));
    }
    tables::write_shifts(&out.join(SHIFTS_FILE), &c, pairing, file, provenance)?;
    Ok(c)
}

/// Sets `reference_modes = reference` in every `modal` and `assess` stage
/// of a pipeline document; returns how many stages it set.
pub fn set_reference(doc: &mut toml::Table, reference: &str) -> usize {
    let Some(toml::Value::Array(stages)) = doc.get_mut("stage") else {
        return 0;
    };
    let mut n = 0;
    for s in stages.iter_mut() {
        let Some(t) = s.as_table_mut() else { continue };
        let kind = t.get("kind").and_then(|k| k.as_str());
        if kind != Some(super::modal::KIND.kind) && kind != Some(super::assess::KIND.kind) {
            continue;
        }
        let params = t
            .entry("params")
            .or_insert_with(|| toml::Value::Table(Default::default()));
        if let Some(p) = params.as_table_mut() {
            p.insert(REFERENCE_KEY.into(), toml::Value::String(reference.into()));
            n += 1;
        }
    }
    n
}
