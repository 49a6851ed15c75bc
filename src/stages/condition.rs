//! `condition`: QA and units, then the declared conditioning steps
//! (resampling/alignment, detrend, taper, zero-phase band-pass, integration;
//! METHODS §1) → `samples.parquet`.

use crate::conditioning::{condition_event_each, ConditioningSettings, Motion, ParkSeries};
use crate::pipeline::context::park;
use serde::Deserialize;

use crate::error::Result;
use crate::pipeline::{Product, ProductKind, RunContext, Stage, StageKind, StageSource};
use crate::sinks::event_tables;
use crate::vocab::{Event, Samples};

pub const KIND: StageKind = StageKind {
    kind: "condition",
    needs: &[],
    provides: Some(ProductKind::ConditionedEvent),
    reads_all_earlier: false,
    build,
};

/// The conditioned records file (default; `samples_file` names another, so
/// that two condition stages — e.g. the band-passed records for modal
/// identification and the records as recorded for Bouc-Wen — can coexist).
pub const SAMPLES_FILE: &str = crate::vocab::tables::SAMPLES.file;

/// The stage's own params beside the conditioning settings.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct OutputParams {
    samples_file: Option<String>,
}

/// The product: the conditioned event and, per acceleration channel, its
/// acceleration, velocity and displacement — parked in the run's spill file
/// when the event is (`RunContext::parked`).
pub struct Conditioned {
    pub event: Event,
    pub motions: Vec<Motion>,
}

fn build(src: &StageSource) -> Result<Box<dyn Stage>> {
    let (settings, output): (ConditioningSettings, OutputParams) =
        src.params_split(&["samples_file"])?;
    settings.validate().map_err(|e| src.invalid(e))?;
    let samples_file = output.samples_file.unwrap_or_else(|| SAMPLES_FILE.into());
    if !samples_file.ends_with(".parquet") {
        return Err(src.invalid(format!(
            "samples_file {samples_file:?} must be a .parquet file name"
        )));
    }
    Ok(Box::new(Condition {
        settings,
        samples_file,
    }))
}

struct Condition {
    settings: ConditioningSettings,
    samples_file: String,
}

impl Stage for Condition {
    fn outputs(&self) -> Vec<String> {
        vec![self.samples_file.clone()]
    }
    /// A channel at a time: a parked event's channels are read back, conditioned
    /// and parked again one by one (issue 14 item 5).
    fn run(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        // Cloning a parked event copies its channels' descriptions, not their samples.
        let mut event = ctx.loaded_event()?.event.clone();
        let spill = ctx.parked();
        // A parked event's motions are parked series by series as each is
        // final (two series of a day-long channel in memory, not three).
        let park_series = |values: Vec<f64>| -> Result<Samples> {
            let mut samples = Samples::new(values);
            if let Some(spill) = &spill {
                park(&mut samples, spill)?;
            }
            Ok(samples)
        };
        let parking: Option<&ParkSeries> = spill.as_ref().map(|_| &park_series as &ParkSeries);
        let motions =
            condition_event_each(&mut event, &self.settings, parking, &|record, motion| {
                let Some(spill) = &spill else {
                    return Ok(());
                };
                // An integrated record's samples are its motion's acceleration
                // (shared once parked, `conditioning::condition_event_each`).
                if let Some(m) = motion {
                    park(&mut m.acceleration, spill)?;
                    park(&mut m.velocity, spill)?;
                    park(&mut m.displacement, spill)?;
                }
                park(&mut record.samples, spill)
            })?;
        event_tables::write_samples(&ctx.out_dir.join(&self.samples_file), &event, &motions)?;
        Ok(Some(Box::new(Conditioned { event, motions })))
    }
    fn restore(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        let path = ctx.out_dir.join(&self.samples_file);
        // Samples read back are parked as the event's would be (by their number).
        let (event, motions) =
            event_tables::read_samples_parked(&path, |rows| ctx.spill_above(rows))?;
        Ok(Some(Box::new(Conditioned { event, motions })))
    }
}
