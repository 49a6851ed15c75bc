//! All tests in one binary (one link instead of one per area: linking was
//! most of CI's time), the unit tests of the library's pieces included: the
//! library has no `#[cfg(test)]` modules and `[lib] test = false`, so
//! `cargo test` compiles it once.  One module per area; shared helpers in
//! `common`.  Tests that read the real records of `../shared/records` have
//! `shared_` in their name or live in a module that says so, and fail with a
//! clear message when the folder is missing.
//!
//! Slow statistical studies are `#[ignore]`d; run them with
//! `cargo test --release --test it -- --ignored`.

mod common;

mod architecture;

mod apparent_frequency;
mod assessment;
mod assessment_change;
mod assessment_pipeline;

mod big_input;
mod bridge_consistency;
mod budgets;
mod buildings;
mod change_test;
mod child;
mod cli_output;
mod compare_test;
mod conditioning;
mod dashboard;
mod dataset;
mod design;
mod design_io;
mod determinism;
mod end_to_end;
mod environment;
mod event_folder;
mod event_window;
mod exit_codes;
mod fuzz;
mod fuzz_structured;
mod geometry;
mod history;
mod hysteresis;
mod hysteresis_masses;
mod hysteresis_partial;
mod hysteresis_real;
mod hysteresis_verdict;
mod hysteresis_window;
mod lab;
mod metrics;
mod modal;
mod modal_buildings;
mod modal_synthetic;
mod outdir;
mod param_bounds;
mod path_policy;
mod pipeline;
mod plackett_luce;
mod prepost;
mod readers_binary;
mod readers_csv;
mod readers_text;
mod rehearse;
mod rehearse_gravity;
mod report;
mod report_browser;
mod schemas;
mod snr_corners;
mod stage_params;
mod structure_inference;
mod synth;
mod synth_benchmarks;
mod track_compensation;
mod track_damaged;
mod tracking;
mod twin;
mod twin_update_io;
mod uncertainty;
mod vocab;
mod watch;
