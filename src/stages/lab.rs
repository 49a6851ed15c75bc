//! `lab_hysteresis`: the hysteresis of a laboratory specimen identified
//! from its measured displacement and force (issue 37; numerical work in
//! `crate::lab`, records read by `crate::event_folder::lab`). Writes
//! `lab_identification/lab_identification.parquet`, `lab_fit/lab_fit.parquet` and `lab_cycles/lab_cycles.parquet`
//! (`crate::sinks::lab_tables`); the report's lab section reads them.

use std::path::Path;

use crate::error::{Error, Result};
use crate::event_folder::lab::load_lab;
use crate::lab::instantaneous::{identify_instantaneous, InstantaneousFit};
use crate::lab::{history_of, identify_specimen, LabIdentifySettings, SpecimenIdentification};
use crate::pipeline::{Product, RunContext, Stage, StageKind, StageSource};
use crate::sinks::lab_tables::{
    lab_provenance, write_lab_cycles, write_lab_fit, write_lab_identification, LabOutcome,
};
use crate::vocab::tables::{LAB_CYCLES, LAB_FIT, LAB_IDENTIFICATION};
use crate::vocab::{LabRecord, TimeBase};

pub const KIND: StageKind = StageKind {
    kind: "lab_hysteresis",
    needs: &[],
    provides: None,
    reads_all_earlier: false,
    build,
};

/// The stage's output files.
pub const LAB_FILES: [&str; 3] = [LAB_IDENTIFICATION.file, LAB_FIT.file, LAB_CYCLES.file];

fn build(src: &StageSource) -> Result<Box<dyn Stage>> {
    let settings: LabIdentifySettings = src.params()?;
    settings.check().map_err(|e| {
        Error::usage(format!(
            "{}: stage {:?} (lab_hysteresis): params: {e}",
            src.file(),
            src.decl.name
        ))
    })?;
    Ok(Box::new(LabHysteresis { settings }))
}

struct LabHysteresis {
    settings: LabIdentifySettings,
}

/// One lab record identified: the whole-history fit and, for a uniformly
/// sampled (dynamic) record, the thesis's time–frequency identification or
/// why it identified nothing.
pub struct LabDone {
    pub record: LabRecord,
    pub identification: SpecimenIdentification,
    pub instantaneous: Option<std::result::Result<InstantaneousFit, String>>,
}

/// Identifies every lab record of the event at `event` and writes the three
/// tables into `out_dir`; returns the records and their identifications.
pub fn identify_lab_event(
    event: &Path,
    settings: &LabIdentifySettings,
    out_dir: &Path,
) -> Result<Vec<LabDone>> {
    let records = load_lab(event)?;
    let mut done = Vec::with_capacity(records.len());
    for record in records {
        let history = history_of(&record)?;
        let id = identify_specimen(&history, settings)
            .map_err(|e| Error::usage(format!("lab record {:?}: {e}", record.name)))?;
        let instantaneous = match record.time_base {
            TimeBase::Uniform { dt_s } if settings.instantaneous => Some(
                identify_instantaneous(
                    history.displacement_m,
                    history.force_n,
                    1.0 / dt_s,
                    settings.cycle_band,
                )
                .map_err(|e| e.to_string()),
            ),
            _ => None,
        };
        done.push(LabDone {
            record,
            identification: id,
            instantaneous,
        });
    }
    let histories: Vec<_> = done
        .iter()
        .map(|d| history_of(&d.record))
        .collect::<Result<Vec<_>>>()?;
    let outcomes: Vec<LabOutcome<'_>> = done
        .iter()
        .zip(&histories)
        .map(|(d, h)| LabOutcome {
            record: &d.record.name,
            displacement_m: h.displacement_m,
            force_n: h.force_n,
            time_s: h.time_s,
            identification: &d.identification,
            instantaneous: d
                .instantaneous
                .as_ref()
                .map(|r| r.as_ref().map_err(String::as_str)),
        })
        .collect();
    let names: Vec<&str> = done.iter().map(|d| d.record.name.as_str()).collect();
    let provenance = lab_provenance(&event.display().to_string(), &names, settings);
    write_lab_identification(
        &out_dir.join(LAB_IDENTIFICATION.file),
        &outcomes,
        settings,
        &provenance,
    )?;
    write_lab_fit(&out_dir.join(LAB_FIT.file), &outcomes, &provenance)?;
    write_lab_cycles(&out_dir.join(LAB_CYCLES.file), &outcomes, &provenance)?;
    Ok(done)
}

impl Stage for LabHysteresis {
    fn outputs(&self) -> Vec<String> {
        LAB_FILES.iter().map(|s| s.to_string()).collect()
    }
    fn run(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        let done = identify_lab_event(&ctx.event_path.clone(), &self.settings, &ctx.out_dir)?;
        for d in &done {
            let id = &d.identification;
            ctx.info(format!(
                "lab_hysteresis: {}: {} form, force NRMSE {:.4} ({})",
                d.record.name,
                id.form.name(),
                id.force_nrmse,
                id.form_reason
            ));
            match &d.instantaneous {
                Some(Ok(fit)) => ctx.info(format!(
                    "lab_hysteresis: {}: thesis's STFT identification: force NRMSE {:.4} ({})",
                    d.record.name, fit.force_nrmse, fit.verdict
                )),
                Some(Err(e)) => ctx.info(format!(
                    "lab_hysteresis: {}: thesis's STFT identification: nothing identified ({e})",
                    d.record.name
                )),
                None => {}
            }
        }
        Ok(None)
    }
}
