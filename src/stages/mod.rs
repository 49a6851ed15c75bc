//! The stage catalog: one thin typed component per stage kind, glue between
//! the pipeline's run context, the numerical modules and the sinks.
//! Numerical work lives in its module; nothing here does mathematics.
//!
//! `CATALOG` is the one list of stage kinds; the CLI hands it to the
//! pipeline (`parse_pipeline`), which knows stages only through the
//! `pipeline::Stage` trait.

pub mod assess;
pub mod assess_evidence;
pub mod change;
pub mod compare_test;
pub mod condition;
pub mod design;
pub mod hysteresis;
pub mod ingest;
pub mod lab;
pub mod metrics;
pub mod modal;
pub mod prepost;
pub mod rehearse;
pub mod report;
pub mod update;

use std::path::Path;

use crate::error::{Error, Result};
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
    assess::KIND,
    design::KIND,
    rehearse::KIND,
    lab::KIND,
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

/// Reads and builds the pipeline file at `path` with `reference_modes =
/// reference` in every `modal` stage (`quaketwin run … --reference`):
/// the file as written is built first (its errors name its lines), then the
/// file with the reference.  A usage error when it has no `modal` stage.
pub fn load_pipeline_with_reference(path: &Path, reference: &str) -> Result<Pipeline> {
    let text = Pipeline::read_text(path)?;
    let file = path.display().to_string();
    Pipeline::parse(&text, &file, CATALOG)?;
    let mut doc: toml::Table = toml::from_str(&text)
        .map_err(|e| Error::usage(format!("{file}: invalid pipeline file: {e}")))?;
    if prepost::set_reference(&mut doc, reference) == 0 {
        return Err(Error::usage(format!(
            "--reference {reference}: pipeline {file} has no `{}` stage to compare modes (nor an `{}` stage)",
            modal::KIND.kind,
            assess::KIND.kind
        )));
    }
    let text = toml::to_string(&doc)
        .map_err(|e| Error::usage(format!("{file}: rewriting with --reference: {e}")))?;
    Pipeline::parse(&text, &format!("{file} (with --reference)"), CATALOG)
}
