//! quaketwin: from a monitored building's earthquake records to decisions.
//!
//! Data flows one way: **readers** (file formats) → **event folder**
//! (manifest, channel metadata) → **conditioning** → **metrics** →
//! identification stages (modal, hysteresis, damage) → **twin** updating →
//! **test design** → **sinks** (Parquet, MCAP, report).  The `vocab` module
//! holds the types every stage speaks.

pub mod commands;
pub mod conditioning;
pub mod design;
pub mod error;
pub mod event_folder;
pub mod geometry;
pub mod hysteresis;
pub mod metrics;
pub mod modal;
pub mod numeric;
pub mod pipeline;
pub mod readers;
pub mod report;
pub mod rng;
pub mod sinks;
pub mod stages;
pub mod stats;
pub mod synth;
pub mod twin;
pub mod vocab;

pub use error::{Error, Location, Result};
