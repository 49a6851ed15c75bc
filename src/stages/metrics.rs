//! `metrics`: strong-motion metrics and response spectra per channel, drift
//! ratios per storey or instrumented segment (peak from the conditioned
//! records, residual from the records as recorded; `metrics::drift`) → `channels/channels.parquet`, `spectra/spectra.parquet`, `drift/drift.parquet`.

use rayon::prelude::*;

use super::condition::Conditioned;
use crate::conditioning::{Motion, LONG_CHANNEL};
use crate::error::Result;
use crate::metrics::{
    metrics_of_parts, peak_abs, storey_drift, storey_residual_drifts, MetricsSettings,
};
use crate::pipeline::{Product, ProductKind, RunContext, Stage, StageKind, StageSource};
use crate::sinks::event_tables;
use crate::vocab::Samples;

pub const KIND: StageKind = StageKind {
    kind: "metrics",
    needs: &[ProductKind::ConditionedEvent],
    provides: Some(ProductKind::Metrics),
    reads_all_earlier: false,
    build,
};

pub const CHANNELS_FILE: &str = crate::vocab::tables::CHANNELS.file;
pub const SPECTRA_FILE: &str = crate::vocab::tables::SPECTRA.file;
pub const DRIFT_FILE: &str = crate::vocab::tables::DRIFT.file;

fn build(src: &StageSource) -> Result<Box<dyn Stage>> {
    let settings: MetricsSettings = src.params()?;
    settings.validate().map_err(|e| src.invalid(e))?;
    Ok(Box::new(Metrics { settings }))
}

struct Metrics {
    settings: MetricsSettings,
}

impl Stage for Metrics {
    fn outputs(&self) -> Vec<String> {
        vec![CHANNELS_FILE.into(), SPECTRA_FILE.into(), DRIFT_FILE.into()]
    }
    fn run(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        let out = ctx.out_dir.clone();
        // Residual drift needs the records before any filter: the run's
        // source (on its event window, as the conditioned records).
        let residual = storey_residual_drifts(&ctx.analysis_event()?)?;
        let Conditioned { event, motions } = ctx.input(ProductKind::ConditionedEvent)?;
        // Parked motions are read back a channel — a series — at a time; long
        // channels one after the other (two in flight would double the memory).
        let one = |m: &Motion| {
            let peak = |s: &Samples| s.get().map(|v| peak_abs(&v));
            let (pgv, pgd) = (peak(&m.velocity)?, peak(&m.displacement)?);
            let a = m.acceleration.get()?;
            metrics_of_parts(&m.channel_id, m.dt, &a, pgv, pgd, &self.settings)
        };
        let long = motions.iter().any(|m| m.acceleration.len() > LONG_CHANNEL);
        let metrics = if long {
            motions.iter().map(one).collect::<Result<Vec<_>>>()?
        } else {
            motions.par_iter().map(one).collect::<Result<Vec<_>>>()?
        };
        let drift = storey_drift(
            event,
            motions,
            &residual,
            self.settings.assumed_storey_height_m,
        )?;
        for note in &drift.notes {
            crate::console::detail(format!("metrics: {note}"));
        }
        event_tables::write_channels(&out.join(CHANNELS_FILE), event, &metrics)?;
        event_tables::write_spectra(&out.join(SPECTRA_FILE), event, &metrics)?;
        event_tables::write_drift(&out.join(DRIFT_FILE), event, &drift)?;
        Ok(None)
    }
}
