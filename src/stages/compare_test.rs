//! `quaketwin compare-test` and `quaketwin synth-hybrid-log`: the edge of the hybrid-test
//! comparison (numerical work in `crate::hybrid_test`, the generator in `crate::synth`) — read
//! the design run's rehearsal model and settings and the test's log, compare, write the tables
//! (`crate::sinks::compare_test_tables`) and the report (docs/lab-tests.md).

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::hybrid_test::log::LOG_FILE;
use crate::hybrid_test::{compare, CompareSettings, HybridLog};
use crate::rehearse::RehearseSettings;
use crate::sinks::compare_test_tables::{write_comparison, write_hybrid_log};
use crate::sinks::rehearsal_tables::{read_rehearsal_model, REHEARSAL_MODEL_FILE};
use crate::synth::hybrid_log::{synth_hybrid_log, HybridLogSettings, HybridLogTruth};

/// What `compare-test` found (what it prints; `--json`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CompareTestSummary {
    pub time_scale: f64,
    pub steps: usize,
    pub actuators: usize,
    /// Identified lag (s, laboratory time) and noise (m).
    pub lag_s: f64,
    pub noise_std_m: f64,
    /// Pooled RMS of command − measured: logged, predicted by the rehearsal, by the updated one.
    pub logged_tracking_rms_m: f64,
    pub rehearsal_tracking_rms_m: f64,
    pub updated_tracking_rms_m: Option<f64>,
    pub logged_energy_error: f64,
    pub rehearsal_energy_error: f64,
    pub updated_energy_error: Option<f64>,
    /// The specimen update: the fitted form, or why there is none.
    pub specimen_form: Option<String>,
    pub specimen_failure: Option<String>,
    pub outputs: Vec<PathBuf>,
}

/// The log of TEST_RECORDS: a CSV file, or a folder holding `hybrid_log.csv`.
pub fn read_log(test_records: &Path) -> Result<HybridLog> {
    let path = if test_records.is_dir() {
        test_records.join(LOG_FILE)
    } else {
        test_records.to_path_buf()
    };
    let text = crate::input_file::read_to_string(&path, crate::input_file::MAX_INPUT_BYTES)?;
    HybridLog::parse_csv(&text, &path.display().to_string())
}

/// The design run's rehearsal settings: `settings` (a TOML file of the `rehearse` stage's
/// params) if given, else those recorded in DESIGN_OUT's `rehearsal_summary/rehearsal_summary.parquet`, else
/// the defaults.
pub fn rehearsal_settings(design_out: &Path, settings: Option<&Path>) -> Result<RehearseSettings> {
    if let Some(p) = settings {
        let text = crate::input_file::read_to_string(p, crate::input_file::MAX_SETTINGS_BYTES)?;
        return toml::from_str(&text)
            .map_err(|e| Error::usage(format!("{}: bad rehearsal settings: {e}", p.display())));
    }
    let summary = crate::vocab::tables::REHEARSAL_SUMMARY.locate(design_out);
    if !summary.exists() {
        return Ok(RehearseSettings::default());
    }
    let table = crate::sinks::parquet::ReadTable::open(&summary)?;
    match table.metadata("quaketwin.settings") {
        Some(text) => serde_json::from_str(text).map_err(|e| {
            Error::usage(format!(
                "{}: metadata quaketwin.settings is not rehearsal settings: {e}",
                summary.display()
            ))
        }),
        None => Ok(RehearseSettings::default()),
    }
}

/// `quaketwin compare-test DESIGN_OUT TEST_RECORDS --out DIR`.
pub fn compare_test(
    design_out: &Path,
    test_records: &Path,
    out_dir: &Path,
    settings: CompareSettings,
) -> Result<CompareTestSummary> {
    let model_path = design_out.join(REHEARSAL_MODEL_FILE);
    let model = read_rehearsal_model(&model_path)?;
    let log = read_log(test_records)?;
    let c = compare(&log, &model, &settings)?;
    std::fs::create_dir_all(out_dir).map_err(|e| Error::io(out_dir, e))?;
    let mut outputs = write_comparison(out_dir, &c, &log, &model_path.display().to_string())?;
    outputs.push(crate::report::write_report(
        out_dir,
        &crate::report::ReportSettings::default(),
    )?);
    let run = |i: usize| c.runs.get(i);
    Ok(CompareTestSummary {
        time_scale: c.time_scale,
        steps: log.steps(),
        actuators: log.actuators.len(),
        lag_s: c.tracking.lag_s,
        noise_std_m: c.tracking.noise_std_m,
        logged_tracking_rms_m: c.runs[0].pooled_tracking_rms_m(),
        rehearsal_tracking_rms_m: c.runs[1].pooled_tracking_rms_m(),
        updated_tracking_rms_m: run(2).map(|r| r.pooled_tracking_rms_m()),
        logged_energy_error: c.runs[0].energy_error,
        rehearsal_energy_error: c.runs[1].energy_error,
        updated_energy_error: run(2).map(|r| r.energy_error),
        specimen_form: c
            .specimen
            .as_ref()
            .and_then(|s| s.fit.as_ref())
            .map(|f| f.form.clone()),
        specimen_failure: c.specimen.as_ref().and_then(|s| s.failure.clone()),
        outputs,
    })
}

/// `quaketwin synth-hybrid-log DESIGN_OUT --out DIR`: the log and its truth.
pub fn write_synth_hybrid_log(
    design_out: &Path,
    out_dir: &Path,
    settings: &HybridLogSettings,
) -> Result<(HybridLogTruth, Vec<PathBuf>)> {
    let model = read_rehearsal_model(&design_out.join(REHEARSAL_MODEL_FILE))?;
    let source = out_dir.join(LOG_FILE).display().to_string();
    let (log, truth) = synth_hybrid_log(&model, settings, &source)?;
    std::fs::create_dir_all(out_dir).map_err(|e| Error::io(out_dir, e))?;
    let files = write_hybrid_log(out_dir, &log, &truth)?;
    Ok((truth, files))
}
