//! `metrics`: strong-motion metrics and response spectra per channel, drift
//! ratios per storey → `channels.parquet`, `spectra.parquet`, `drift.parquet`.

use rayon::prelude::*;

use crate::error::Result;
use crate::metrics::{strong_motion_metrics, MetricsSettings};
use crate::pipeline::{params, RunContext, StageDecl};
use crate::sinks::event_tables;

pub fn run(stage: &StageDecl, ctx: &mut RunContext) -> Result<()> {
    let settings: MetricsSettings = params(stage)?;
    let out = ctx.out_dir.clone();
    let (event, motions) = ctx.conditioned_event()?;
    let metrics = motions
        .par_iter()
        .map(|m| strong_motion_metrics(m, &settings))
        .collect::<Result<Vec<_>>>()?;
    let drift = event_tables::drift_rows(event, motions)?;
    event_tables::write_channels(&out.join("channels.parquet"), event, &metrics)?;
    event_tables::write_spectra(&out.join("spectra.parquet"), event, &metrics)?;
    event_tables::write_drift(&out.join("drift.parquet"), event, &drift)?;
    Ok(())
}
