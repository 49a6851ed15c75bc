//! What a stage is to the pipeline (the model: vector's components): a kind
//! with typed parameters, built when the pipeline file is read; the products
//! it needs from its declared inputs and the one it provides; its output
//! files; and `run`.  The pipeline knows stages only through this trait and
//! the catalog of kinds the caller hands it (`crate::stages::CATALOG`), so
//! it depends on no stage.

use std::any::Any;

use super::config::StageSource;
use super::context::RunContext;
use crate::error::Result;

/// What one stage hands to the stages that list it among their `inputs`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProductKind {
    /// The conditioned event and its acceleration, velocity and displacement.
    ConditionedEvent,
    /// Strong-motion metrics, spectra and drift tables.
    Metrics,
    /// Identified modes (`modes/modes.parquet`).
    Modes,
    /// Bouc-Wen identification per direction.
    Hysteresis,
    /// Damage index tables.
    Damage,
    /// Updated digital twin.
    UpdatedTwin,
    /// Hybrid-test design tables.
    TestDesign,
    /// The event's inventory (`event.json`).
    Inventory,
}

impl ProductKind {
    /// What the product is, for messages.
    pub fn describe(self) -> &'static str {
        match self {
            ProductKind::ConditionedEvent => "the conditioned records",
            ProductKind::Metrics => "the strong-motion metrics",
            ProductKind::Modes => "the identified modes",
            ProductKind::Hysteresis => "the Bouc-Wen identification",
            ProductKind::Damage => "the damage index",
            ProductKind::UpdatedTwin => "the updated twin",
            ProductKind::TestDesign => "the test design",
            ProductKind::Inventory => "the event inventory",
        }
    }
    /// The stage kind that provides it, for messages.
    pub fn provider_kind(self) -> &'static str {
        match self {
            ProductKind::ConditionedEvent => "condition",
            ProductKind::Metrics => "metrics",
            ProductKind::Modes => "modal",
            ProductKind::Hysteresis => "hysteresis",
            ProductKind::Damage => "damage",
            ProductKind::UpdatedTwin => "update",
            ProductKind::TestDesign => "design",
            ProductKind::Inventory => "ingest",
        }
    }
}

/// A product in memory (its type is the providing stage's own; consumers
/// ask for it by that type).
pub type Product = Box<dyn Any>;

/// A stage built from its declaration (parameters already typed and checked).
pub trait Stage: Send + Sync {
    /// Output files, relative to the output directory (names owned by the stage).
    fn outputs(&self) -> Vec<String>;
    /// Why the stage does not apply to this event (None = it applies).
    fn not_applicable(&self, _ctx: &mut RunContext) -> Result<Option<String>> {
        Ok(None)
    }
    /// Fingerprint of inputs outside the event folder (files named by the
    /// params), added to the stage's own; empty when there are none.
    fn extra_fingerprint(&self, _ctx: &mut RunContext) -> Result<String> {
        Ok(String::new())
    }
    /// Runs the stage: writes its outputs, returns its product (None when
    /// later stages read only its files).
    fn run(&self, ctx: &mut RunContext) -> Result<Option<Product>>;
    /// The product of a stage skipped as up to date: loaded back from its
    /// outputs, or recomputed without writing.
    fn restore(&self, _ctx: &mut RunContext) -> Result<Option<Product>> {
        Ok(None)
    }
}

/// One entry of the stage catalog.
pub struct StageKind {
    pub kind: &'static str,
    /// Products the stage needs, each from one of its declared inputs.
    pub needs: &'static [ProductKind],
    /// The product it provides.
    pub provides: Option<ProductKind>,
    /// The stage reads the outputs of every earlier stage (the report): its
    /// fingerprint then covers them all.
    pub reads_all_earlier: bool,
    /// Builds the stage from its declaration (typed params; usage errors
    /// name the file, line and key).
    pub build: fn(&StageSource) -> Result<Box<dyn Stage>>,
}
