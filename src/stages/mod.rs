//! The stage catalog: one thin typed component per stage kind, glue between
//! the pipeline's run context, the numerical modules and the sinks.
//! Numerical work lives in its module; nothing here does mathematics.
//!
//! `CATALOG` is the one list of stage kinds; the CLI hands it to the
//! pipeline (`parse_pipeline`), which knows stages only through the
//! `pipeline::Stage` trait.

pub mod condition;
pub mod design;
pub mod hysteresis;
pub mod ingest;
pub mod metrics;
pub mod modal;
pub mod report;
pub mod update;

use std::path::Path;

use crate::error::Result;
use crate::pipeline::{Pipeline, StageKind};

/// Every stage kind of this build, in pipeline order.
pub const CATALOG: &[StageKind] = &[
    ingest::KIND,
    condition::KIND,
    metrics::KIND,
    modal::KIND,
    hysteresis::KIND,
    hysteresis::DAMAGE_KIND,
    update::KIND,
    design::KIND,
    report::KIND,
];

/// Reads and builds a pipeline from its text with this build's stage kinds.
pub fn parse_pipeline(text: &str, file: &str) -> Result<Pipeline> {
    Pipeline::parse(text, file, CATALOG)
}

/// Reads and builds the pipeline file at `path`.
pub fn load_pipeline(path: &Path) -> Result<Pipeline> {
    Pipeline::load(path, CATALOG)
}
