//! `condition`: QA and units, then the declared conditioning steps
//! (resampling/alignment, detrend, taper, zero-phase band-pass, integration;
//! METHODS §1) → `samples.parquet`.

use crate::conditioning::{condition_event_with_motion, ConditioningSettings, Motion};
use crate::error::Result;
use crate::pipeline::{Product, ProductKind, RunContext, Stage, StageKind, StageSource};
use crate::sinks::event_tables;
use crate::vocab::Event;

pub const KIND: StageKind = StageKind {
    kind: "condition",
    needs: &[],
    provides: Some(ProductKind::ConditionedEvent),
    reads_all_earlier: false,
    build,
};

/// The conditioned records file.
pub const SAMPLES_FILE: &str = "samples.parquet";

/// The product: the conditioned event and, per acceleration channel, its
/// acceleration, velocity and displacement.
pub struct Conditioned {
    pub event: Event,
    pub motions: Vec<Motion>,
}

fn build(src: &StageSource) -> Result<Box<dyn Stage>> {
    let settings: ConditioningSettings = src.params()?;
    settings.validate().map_err(|e| src.invalid(e))?;
    Ok(Box::new(Condition { settings }))
}

struct Condition {
    settings: ConditioningSettings,
}

impl Stage for Condition {
    fn outputs(&self) -> Vec<String> {
        vec![SAMPLES_FILE.into()]
    }
    fn run(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        let mut event = ctx.loaded_event()?.event.clone();
        let motions = condition_event_with_motion(&mut event, &self.settings)?;
        event_tables::write_samples(&ctx.out_dir.join(SAMPLES_FILE), &event, &motions)?;
        Ok(Some(Box::new(Conditioned { event, motions })))
    }
    fn restore(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        let (event, motions) = event_tables::read_samples(&ctx.out_dir.join(SAMPLES_FILE))?;
        Ok(Some(Box::new(Conditioned { event, motions })))
    }
}
