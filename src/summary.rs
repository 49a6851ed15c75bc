//! Machine-readable summaries of what a command did (`--json`, on stdout):
//! for a pipeline run, the stages and their outcomes, the files the run
//! lists, and the headline results read back from those files — the modes,
//! the frequency shifts, the Bouc-Wen status per direction and the rating
//! the report opens with.  Field reference: docs/cli.md ("--json").
//!
//! Everything here is read from the output directory after the run (the
//! files the run manifest lists), so a summary says what the files say.

use std::path::Path;

use serde::Serialize;

use crate::pipeline::StageOutcome;
use crate::report::table::{self, Table};
use crate::report::{ReportSettings, Verdict};
use crate::vocab::tables::{self as t, bouc_wen, frequency_shifts as shifts, modes};

/// Version of the summary's layout (bumped when a field changes meaning).
pub const SUMMARY_VERSION: u32 = 2;

/// One event run through a pipeline.
#[derive(Debug, Clone, Serialize)]
pub struct RunSummary {
    pub summary_version: u32,
    pub pipeline: String,
    /// The event folder or zip as given.
    pub event: String,
    /// The run's output directory.
    pub out: String,
    pub ok: bool,
    /// Why the run failed, when it did.
    pub error: Option<String>,
    pub stages: Vec<StageSummary>,
    /// The result files the run manifest lists, sorted.
    pub outputs: Vec<String>,
    pub modes: Vec<ModeSummary>,
    pub frequency_shifts: Vec<ShiftSummary>,
    pub bouc_wen: Vec<DirectionSummary>,
    /// The assessment (`assessment.parquet`, the `assess` stage): colour,
    /// priority, probabilities, indicators; absent when the pipeline has no
    /// `assess` stage.
    pub assessment: Option<crate::report::AssessmentView>,
    /// The screening of tabled values against fixed thresholds (drift, ι;
    /// default thresholds); `rating: null` inside when no value could be rated.
    pub screening: Option<Verdict>,
}

#[derive(Debug, Clone, Serialize)]
pub struct StageSummary {
    pub name: String,
    /// `ran`, `skipped` (up to date), `disabled` or `not_applicable`.
    pub outcome: &'static str,
    pub seconds: Option<f64>,
    pub reason: Option<String>,
}

#[derive(Debug, Clone, Serialize)]
pub struct ModeSummary {
    pub mode: u32,
    pub frequency_hz: f64,
    pub damping_ratio: Option<f64>,
    pub direction: Option<String>,
}

#[derive(Debug, Clone, Serialize)]
pub struct ShiftSummary {
    pub reference_mode: u32,
    pub current_mode: u32,
    pub frequency_reference_hz: Option<f64>,
    pub frequency_current_hz: Option<f64>,
    pub shift_percent: Option<f64>,
    pub significant: Option<bool>,
}

/// The Bouc-Wen outcome of one direction.
#[derive(Debug, Clone, Serialize)]
pub struct DirectionSummary {
    pub direction: String,
    /// `identified`, `identified_unstable`, `no_significant_hysteresis` or
    /// `not_identifiable` (the least favourable of the direction's DoFs).
    pub status: String,
    /// The direction's verdict (bouc_wen.parquet `verdict`):
    /// `nonlinear_identified`, `no_significant_hysteresis` or
    /// `not_identifiable`; None in tables written before the column.
    pub verdict: Option<String>,
    /// Why, when not identifiable.
    pub reason: Option<String>,
}

fn outcome_fields(o: &StageOutcome) -> (&'static str, Option<f64>, Option<String>) {
    match o {
        StageOutcome::Ran { seconds } => ("ran", Some(*seconds), None),
        StageOutcome::Skipped => ("skipped", None, None),
        StageOutcome::Disabled => ("disabled", None, None),
        StageOutcome::NotApplicable(why) => ("not_applicable", None, Some(why.clone())),
    }
}

impl RunSummary {
    /// The summary of a run of `pipeline` on `event` into `out` that ended
    /// with `result`.
    pub fn of_run(
        pipeline: &str,
        event: &Path,
        out: &Path,
        result: &crate::error::Result<Vec<(String, StageOutcome)>>,
    ) -> RunSummary {
        let (ok, error, stages) = match result {
            Ok(outcomes) => (
                true,
                None,
                outcomes
                    .iter()
                    .map(|(name, o)| {
                        let (outcome, seconds, reason) = outcome_fields(o);
                        StageSummary {
                            name: name.clone(),
                            outcome,
                            seconds,
                            reason,
                        }
                    })
                    .collect(),
            ),
            Err(e) => (false, Some(e.to_string()), Vec::new()),
        };
        let mut outputs = crate::pipeline::listed_results(out).unwrap_or_default();
        outputs.sort();
        let read = |schema: &crate::vocab::schema::TableSchema| -> Option<Table> {
            outputs
                .iter()
                .any(|f| f == schema.file)
                .then(|| table::load(&out.join(schema.file), None).ok())
                .flatten()
        };
        let modes = read(&t::MODES).map(|m| mode_rows(&m)).unwrap_or_default();
        let frequency_shifts = read(&t::FREQUENCY_SHIFTS)
            .map(|s| shift_rows(&s))
            .unwrap_or_default();
        let bouc_wen = read(&t::BOUC_WEN)
            .map(|b| direction_rows(&b))
            .unwrap_or_default();
        let rated = outputs
            .iter()
            .any(|f| f == t::DRIFT.file || f == t::DAMAGE.file);
        let screening = rated
            .then(|| crate::report::verdict(out, &ReportSettings::default()).ok())
            .flatten();
        let assessment = crate::report::read_assessment(out);
        RunSummary {
            summary_version: SUMMARY_VERSION,
            pipeline: pipeline.to_string(),
            event: event.display().to_string(),
            out: out.display().to_string(),
            ok,
            error,
            stages,
            outputs,
            modes,
            frequency_shifts,
            bouc_wen,
            assessment,
            screening,
        }
    }
}

fn number(t: &Table, column: &str, row: usize) -> Option<f64> {
    t.number(column)?.get(row).copied().flatten()
}

fn text(t: &Table, column: &str, row: usize) -> Option<String> {
    t.text(column)?.get(row).cloned().flatten()
}

fn mode_rows(t: &Table) -> Vec<ModeSummary> {
    (0..t.rows)
        .filter_map(|r| {
            Some(ModeSummary {
                mode: number(t, modes::MODE.name, r)? as u32,
                frequency_hz: number(t, modes::FREQUENCY_HZ.name, r)?,
                damping_ratio: number(t, modes::DAMPING_RATIO.name, r),
                direction: text(t, modes::DIRECTION.name, r),
            })
        })
        .collect()
}

fn shift_rows(t: &Table) -> Vec<ShiftSummary> {
    (0..t.rows)
        .filter_map(|r| {
            Some(ShiftSummary {
                reference_mode: number(t, shifts::REFERENCE_MODE.name, r)? as u32,
                current_mode: number(t, shifts::CURRENT_MODE.name, r)? as u32,
                frequency_reference_hz: number(t, shifts::FREQUENCY_REFERENCE_HZ.name, r),
                frequency_current_hz: number(t, shifts::FREQUENCY_CURRENT_HZ.name, r),
                shift_percent: number(t, shifts::SHIFT_PERCENT.name, r),
                significant: t
                    .boolean(shifts::SIGNIFICANT.name)
                    .and_then(|b| b.get(r).copied().flatten()),
            })
        })
        .collect()
}

/// One row per direction (file order), with its least favourable status.
fn direction_rows(t: &Table) -> Vec<DirectionSummary> {
    fn rank(status: &str) -> u8 {
        match status {
            "identified" => 0,
            "identified_unstable" => 1,
            "no_significant_hysteresis" => 2,
            _ => 3,
        }
    }
    let mut out: Vec<DirectionSummary> = Vec::new();
    for r in 0..t.rows {
        let (Some(direction), Some(status)) = (
            text(t, bouc_wen::DIRECTION.name, r),
            text(t, bouc_wen::STATUS.name, r),
        ) else {
            continue;
        };
        let reason = text(t, bouc_wen::REASON.name, r).filter(|s| !s.is_empty());
        let verdict = text(t, bouc_wen::VERDICT.name, r);
        match out.iter_mut().find(|d| d.direction == direction) {
            Some(d) if rank(&status) > rank(&d.status) => {
                d.status = status;
                d.reason = reason;
            }
            Some(_) => {}
            None => out.push(DirectionSummary {
                direction,
                status,
                reason,
                verdict,
            }),
        }
    }
    out
}

/// `value` as pretty JSON with a final newline (what `--json` prints).
pub fn to_json<T: Serialize>(value: &T) -> crate::error::Result<String> {
    serde_json::to_string_pretty(value)
        .map(|s| s + "\n")
        .map_err(|e| crate::error::Error::numerical(format!("serialising the summary: {e}")))
}
