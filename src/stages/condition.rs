//! `condition`: units, QA, resampling/alignment, orientation, detrend,
//! taper, zero-phase band-pass, integration (METHODS §1) → `samples.parquet`.

use crate::conditioning::{condition_event_with_motion, ConditioningSettings};
use crate::error::Result;
use crate::pipeline::{params, RunContext, StageDecl};
use crate::sinks::event_tables;

pub fn run(stage: &StageDecl, ctx: &mut RunContext) -> Result<()> {
    let settings: ConditioningSettings = params(stage)?;
    let mut event = ctx.loaded_event()?.event.clone();
    let motions = condition_event_with_motion(&mut event, &settings)?;
    event_tables::write_samples(&ctx.out_dir.join("samples.parquet"), &event, &motions)?;
    ctx.conditioned = Some((event, motions));
    Ok(())
}
