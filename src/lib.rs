//! quaketwin: from a monitored building's earthquake records to decisions.
//!
//! Data flows one way: **readers** (file formats) → **event folder**
//! (manifest, channel metadata) → **conditioning** → **metrics** →
//! identification stages (modal, hysteresis, damage) → **twin** updating →
//! **test design** → **sinks** (Parquet, MCAP, report).  The `vocab` module
//! holds the types every stage speaks.

pub mod assessment;
pub mod commands;
pub mod conditioning;
pub mod console;
pub mod dashboard;
pub mod dataset_history;
pub mod design;
pub mod error;
pub mod event_folder;
pub mod flags;
pub mod geometry;
pub mod hash;
pub mod history;
pub mod hybrid_test;
pub mod hysteresis;
pub mod in_memory;
pub mod input_file;
pub mod lab;
pub mod metrics;
pub mod modal;
pub mod monitor;
pub mod numeric;
pub mod pipeline;
pub mod readers;
pub mod rehearse;
pub mod report;
pub mod rng;
pub mod sinks;
pub mod stages;
pub mod stats;
pub mod summary;
pub mod synth;
pub mod track;
pub mod twin;
pub mod vocab;
pub mod watch;

pub use error::{Error, Location, Result};

/// Makes every result independent of the number of threads (issue 14, item 7):
/// faer's dense kernels (matrix products, QR, SVD, eigen-solvers) split their
/// sums into one part per thread of their `Par` setting and add the parts up,
/// so with the default `Par::rayon(0)` the 15th digit of modes, stabilization
/// diagrams and twin updates followed `RAYON_NUM_THREADS`.  This sets faer's
/// global parallelism to `Par::Seq` (a fixed summation order); the
/// parallelism stays where it never changes a result: rayon `par_iter`s over
/// channels, events, candidates, collected in index order.  Called by the
/// CLI and by `pipeline::run`; cheap and idempotent.
pub fn fixed_order_reductions() {
    faer::set_global_parallelism(faer::Par::Seq);
}
