//! Stage implementations: thin glue between the pipeline's run context, the
//! numerical modules and the sinks.  Numerical work lives in its module;
//! nothing here does mathematics.

pub mod condition;
pub mod design;
pub mod hysteresis;
pub mod ingest;
pub mod metrics;
pub mod modal;
pub mod report;
pub mod update;
