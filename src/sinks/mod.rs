//! Sinks: where results leave the pipeline (Parquet tables, MCAP replays).
//! I/O lives here, at the edge; stages hand over plain data.

pub mod assessment_tables;
pub mod atomic;
pub mod change_tables;
pub mod compare_test_tables;
pub mod dataset;
pub mod design_tables;
pub mod event_tables;
pub mod fourier_tables;
pub mod history_tables;
pub mod hysteresis_tables;
pub mod lab_tables;
pub mod matrix_market;
pub mod mcap_writer;
pub mod modal_tables;
pub mod mseed_writer;
pub mod parquet;
pub mod provenance;
pub mod rehearsal_tables;
pub mod twin_tables;
