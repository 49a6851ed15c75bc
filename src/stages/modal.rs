//! `modal`: subspace identification of the conditioned records (METHODS §2)
//! → `stabilization/stabilization.parquet`, `modes/modes.parquet`, `mode_shapes/mode_shapes.parquet`,
//! `modal_spectrum/modal_spectrum.parquet`,
//! and `frequency_shifts/frequency_shifts.parquet` against an earlier run's modes
//! ([`super::prepost`]).

use std::path::{Path, PathBuf};

use super::condition::Conditioned;
use super::prepost::{self, ReferenceParams, ReferenceRun};
use crate::error::Result;
pub use crate::modal::params::{MethodChoice, ModalParams};
use crate::modal::{output_spectral_overlay, ModalResult};
use crate::pipeline::{Product, ProductKind, RunContext, Stage, StageKind, StageSource};
use crate::sinks::modal_tables as tables;
use crate::sinks::provenance::Provenance;
use crate::vocab::{Event, Role};

pub const KIND: StageKind = StageKind {
    kind: "modal",
    needs: &[ProductKind::ConditionedEvent],
    provides: Some(ProductKind::Modes),
    reads_all_earlier: false,
    build,
};

pub const STABILIZATION_FILE: &str = crate::vocab::tables::STABILIZATION.file;
pub const MODES_FILE: &str = crate::vocab::tables::MODES.file;
pub const MODE_SHAPES_FILE: &str = crate::vocab::tables::MODE_SHAPES.file;
pub const SPECTRUM_FILE: &str = crate::vocab::tables::MODAL_SPECTRUM.file;

/// The product: where the identified modes are (a later stage reads the file).
pub struct ModesFile {
    pub path: PathBuf,
}

/// Identifies `event` and writes the modal tables into `out`; with a
/// reference, also `frequency_shifts/frequency_shifts.parquet` (read before identifying, so
/// a bad reference fails first).
pub fn identify_and_write(
    event: &Event,
    p: &ModalParams,
    reference: Option<&ReferenceRun>,
    out: &Path,
) -> Result<ModalResult> {
    p.validate()?;
    let reference = reference.map(|r| r.read(out)).transpose()?;
    let (result, settings) = p.identify(event)?;
    let settings_json = serde_json::to_string(&settings).unwrap_or_default();
    for w in &result.warnings {
        crate::console::warn(format!("modal ({}): {w}", event.name));
    }
    let (json, provenance) = (settings_json.as_str(), Provenance::of_event(event));
    tables::write_stabilization(&out.join(STABILIZATION_FILE), &result, json, &provenance)?;
    tables::write_modes(&out.join(MODES_FILE), &result, json, &provenance)?;
    let level = |id: &String| {
        let r = event.records.iter().find(|r| &r.channel.id == id);
        r.and_then(|r| r.channel.level)
    };
    let levels: Vec<Option<i32>> = result.output_ids.iter().map(level).collect();
    let shapes = out.join(MODE_SHAPES_FILE);
    tables::write_mode_shapes(&shapes, &result, &levels, json, &provenance)?;
    let overlay = output_spectral_overlay(event, &result, p.psd_segment)?;
    let spectrum = out.join(SPECTRUM_FILE);
    tables::write_spectrum(&spectrum, &result, overlay.as_ref(), json, &provenance)?;
    if let Some(reference) = &reference {
        let provenance = provenance
            .clone()
            .then(result.preprocessing.iter().cloned());
        prepost::compare_and_write(reference, &result, out, &event.name, &provenance)?;
    }
    let against = reference
        .as_ref()
        .map(|r| (r.run.file.as_path(), r.modes.len()));
    let alpha = reference
        .as_ref()
        .map_or(0.01, |r| r.run.change_false_alarm_rate);
    super::change::write(event, &result, against, alpha, out, &provenance)?;
    Ok(result)
}

fn build(src: &StageSource) -> Result<Box<dyn Stage>> {
    let (params, reference): (ModalParams, ReferenceParams) = src.params_split(prepost::KEYS)?;
    params.validate().map_err(|e| src.invalid(e))?;
    let reference = reference.check().map_err(|e| src.invalid(e))?;
    Ok(Box::new(Modal { params, reference }))
}

struct Modal {
    params: ModalParams,
    /// The earlier run to compare with (checked when the pipeline was read).
    reference: Option<ReferenceRun>,
}

impl Stage for Modal {
    fn outputs(&self) -> Vec<String> {
        let mut v = vec![
            STABILIZATION_FILE.to_string(),
            MODES_FILE.into(),
            MODE_SHAPES_FILE.into(),
            SPECTRUM_FILE.into(),
            super::change::REFERENCE_FILE.into(),
        ];
        if self.reference.is_some() {
            v.push(prepost::SHIFTS_FILE.into());
            v.push(super::change::TEST_FILE.into());
        }
        v
    }
    fn not_applicable(&self, ctx: &mut RunContext) -> Result<Option<String>> {
        Ok(not_applicable(&ctx.loaded_event()?.event))
    }
    fn extra_fingerprint(&self, _ctx: &mut RunContext) -> Result<String> {
        self.reference
            .as_ref()
            .map_or(Ok(String::new()), |r| r.fingerprint())
    }
    fn run(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        let out = ctx.out_dir.clone();
        let Conditioned { event, .. } = ctx.input(ProductKind::ConditionedEvent)?;
        identify_and_write(event, &self.params, self.reference.as_ref(), &out)?;
        self.restore(ctx)
    }
    fn restore(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        Ok(Some(Box::new(ModesFile {
            path: ctx.out_dir.join(MODES_FILE),
        })))
    }
}

/// Why modal identification cannot run on `event`: no sensor channel is a
/// structural response (role output) — e.g. a folder without event.toml
/// whose headers name only the ground sensors.
pub fn not_applicable(event: &Event) -> Option<String> {
    let has_output = event
        .records
        .iter()
        .any(|r| !r.channel.is_floor_motion() && r.channel.role == Role::Output);
    (!has_output).then(|| {
        "no channel is known to be a structural response (role output; input = base/ground), and no header location text names one (deck, roof, floor, level…): state `role` or `level` per channel in event.toml (docs/event-folder.md)".to_string()
    })
}
