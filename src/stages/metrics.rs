//! `metrics`: strong-motion metrics and response spectra per channel, drift
//! ratios per storey → `channels.parquet`, `spectra.parquet`, `drift.parquet`.

use rayon::prelude::*;

use super::condition::Conditioned;
use crate::error::Result;
use crate::metrics::{storey_drift, strong_motion_metrics, MetricsSettings};
use crate::pipeline::{Product, ProductKind, RunContext, Stage, StageKind, StageSource};
use crate::sinks::event_tables;

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
        let Conditioned { event, motions } = ctx.input(ProductKind::ConditionedEvent)?;
        // Parked motions are read back one channel at a time.
        let metrics = motions
            .par_iter()
            .map(|m| strong_motion_metrics(&*m.in_memory()?, &self.settings))
            .collect::<Result<Vec<_>>>()?;
        let drift = storey_drift(event, motions)?;
        event_tables::write_channels(&out.join(CHANNELS_FILE), event, &metrics)?;
        event_tables::write_spectra(&out.join(SPECTRA_FILE), event, &metrics)?;
        event_tables::write_drift(&out.join(DRIFT_FILE), event, &drift)?;
        Ok(None)
    }
}
