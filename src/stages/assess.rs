//! `assess`: the post-earthquake assessment (`crate::assessment`) →
//! `assessment/assessment.parquet` (one row: colour, priority, damage-state
//! probabilities, every indicator's value and verdict, the assumptions) and
//! `frequency_track/frequency_track.parquet` (the apparent fundamental frequency through the
//! event, `modal::apparent`).
//!
//! Glue only: the evidence is read from the tables the earlier stages wrote
//! (drift, Bouc-Wen, damage index, modes, frequency shifts — those the run
//! manifest lists), the frequency is tracked on the conditioned records,
//! and `crate::assessment` gives the verdicts.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::condition::Conditioned;
use crate::assessment::frequency::{frequency_evidence, KnownFundamentals};
use crate::assessment::indicators::{DriftEvidence, HysteresisEvidence, HysteresisOutcome};
use crate::assessment::verdict::assess;
use crate::error::{Error, Result};
use crate::modal::apparent::ApparentSettings;
use crate::pipeline::{Product, ProductKind, RunContext, Stage, StageKind, StageSource};
use crate::report::table::{self, Table};
use crate::sinks::assessment_tables::{write_assessment, write_frequency_track};
use crate::synth::realistic::degrading::{TruthFrequency, TRUTH_FREQUENCY_FILE};
use crate::vocab::tables as t;

pub const KIND: StageKind = StageKind {
    kind: "assess",
    needs: &[ProductKind::ConditionedEvent],
    provides: None,
    reads_all_earlier: true,
    build,
};

/// Parameters of the `assess` stage (docs/pipelines.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AssessParams {
    /// The moving-window identification of the apparent frequency.
    pub tracking: ApparentSettings,
    /// Fractions of the base record's Arias intensity that bound the strong
    /// shaking (Trifunac & Brady's significant duration): windows wholly
    /// before the first are pre-event, wholly after the second post-event.
    pub strong_motion_arias: [f64; 2],
    /// Windows using samples within this many periods of the expected
    /// fundamental of the record's start or end are dropped (processing
    /// edges: `assessment::frequency::without_edges`).
    pub edge_guard_periods: f64,
    /// An earlier run of the structure (its output directory or its
    /// `modes/modes.parquet`; `quaketwin run … --reference` sets it): its lowest
    /// mode per direction is the frequency before the event where the
    /// record has no pre-event window.
    pub reference_modes: Option<PathBuf>,
}

impl Default for AssessParams {
    fn default() -> Self {
        AssessParams {
            tracking: ApparentSettings::default(),
            strong_motion_arias: [0.05, 0.95],
            edge_guard_periods: 2.0,
            reference_modes: None,
        }
    }
}

fn build(src: &StageSource) -> Result<Box<dyn Stage>> {
    let params: AssessParams = src.params()?;
    params.tracking.validate().map_err(|e| src.invalid(e))?;
    if !(params.edge_guard_periods.is_finite() && params.edge_guard_periods >= 0.0) {
        return Err(src.invalid(Error::usage("edge_guard_periods must be ≥ 0")));
    }
    let [a, b] = params.strong_motion_arias;
    if !(0.0 <= a && a < b && b <= 1.0) {
        return Err(src.invalid(Error::usage(format!(
            "strong_motion_arias must satisfy 0 ≤ from < to ≤ 1, got [{a}, {b}]"
        ))));
    }
    Ok(Box::new(Assess { params }))
}

struct Assess {
    params: AssessParams,
}

impl Stage for Assess {
    fn outputs(&self) -> Vec<String> {
        vec![t::ASSESSMENT.file.into(), t::FREQUENCY_TRACK.file.into()]
    }
    fn extra_fingerprint(&self, _ctx: &mut RunContext) -> Result<String> {
        match &self.params.reference_modes {
            Some(p) => crate::pipeline::fingerprint::path_fingerprint(&reference_file(p)?),
            None => Ok(String::new()),
        }
    }
    fn run(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        let out = ctx.out_dir.clone();
        let truth_file = ctx.event_path.join(TRUTH_FREQUENCY_FILE);
        let Conditioned { event, .. } = ctx.input(ProductKind::ConditionedEvent)?;
        let known = KnownFundamentals {
            identified: modes_per_direction(
                &read(&out, &t::MODES),
                t::modes::DIRECTION.name,
                t::modes::FREQUENCY_HZ.name,
            ),
            reference: match &self.params.reference_modes {
                Some(p) => {
                    let (modes, _) = crate::sinks::modal_tables::read_modes(&reference_file(p)?)?;
                    modes
                        .iter()
                        .map(|m| (m.direction.clone(), m.frequency_hz))
                        .collect()
                }
                // Without one: the reference of frequency_shifts/frequency_shifts.parquet, if any.
                None => modes_per_direction(
                    &read(&out, &t::FREQUENCY_SHIFTS),
                    t::frequency_shifts::DIRECTION_REFERENCE.name,
                    t::frequency_shifts::FREQUENCY_REFERENCE_HZ.name,
                ),
            },
        };
        let (mut tracks, frequency) = frequency_evidence(
            event,
            &known,
            &self.params.tracking,
            self.params.strong_motion_arias,
            self.params.edge_guard_periods,
        )?;
        // A synthetic event's truth, tabled beside the track (validation).
        if truth_file.is_file() {
            let truth = TruthFrequency::read(&truth_file)?;
            for r in tracks.iter_mut() {
                r.truth_hz = r
                    .track
                    .points
                    .iter()
                    .map(|p| truth.defined_over(&r.direction, p.start_s, p.end_s))
                    .collect();
            }
        }
        let drift = read(&out, &t::DRIFT)
            .map(|d| drift_evidence(&d))
            .unwrap_or_default();
        let row = assess(event, &drift, &hysteresis_evidence(&out), &frequency);
        write_frequency_track(&out.join(t::FREQUENCY_TRACK.file), event, &tracks)?;
        write_assessment(&out.join(t::ASSESSMENT.file), event, &row)?;
        let o = &row.overall;
        ctx.info(format!(
            "assess: {} ({}){}",
            o.colour.map(|c| c.label()).unwrap_or("NOT RATED"),
            o.confidence,
            o.reason
                .as_deref()
                .map(|r| format!(" — {r}"))
                .unwrap_or_default()
        ));
        for driver in &o.drivers {
            ctx.info(format!("assess: {driver}"));
        }
        Ok(None)
    }
}

/// The reference run's `modes/modes.parquet` (an output directory or the file).
fn reference_file(p: &Path) -> Result<PathBuf> {
    crate::sinks::modal_tables::locate_modes(p)
        .map_err(|e| e.usage_about("assess: reference_modes"))
}

/// A table of the run, when the run manifest lists it and it reads.
fn read(dir: &Path, schema: &crate::vocab::schema::TableSchema) -> Option<Table> {
    let listed = crate::pipeline::listed_results(dir)
        .map(|files| {
            files
                .iter()
                .any(|f| f == schema.file || f == schema.flat_file())
        })
        .unwrap_or(true);
    let path = schema.locate(dir);
    (listed && path.exists())
        .then(|| table::load(&path, None).ok())
        .flatten()
}

fn number(t: &Table, column: &str, row: usize) -> Option<f64> {
    t.number(column)?.get(row).copied().flatten()
}

/// (direction label, frequency) of every row of a modes-like table (the
/// lowest per direction is taken where it is used).
fn modes_per_direction(t: &Option<Table>, direction: &str, frequency: &str) -> Vec<(String, f64)> {
    let Some(t) = t else {
        return Vec::new();
    };
    (0..t.rows)
        .filter_map(|r| Some((t.key(direction, r)?, number(t, frequency, r)?)))
        .collect()
}

fn drift_evidence(d: &Table) -> Vec<DriftEvidence> {
    use t::drift as c;
    (0..d.rows)
        .map(|r| DriftEvidence {
            direction: d.key(c::DIRECTION.name, r).unwrap_or_default(),
            lower_level: number(d, c::LOWER_LEVEL.name, r).unwrap_or(-1.0) as i32,
            upper_level: number(d, c::UPPER_LEVEL.name, r).unwrap_or(-1.0) as i32,
            kind: d.key(c::KIND.name, r).unwrap_or_default(),
            peak_ratio: number(d, c::PEAK_DRIFT_RATIO.name, r).unwrap_or(f64::NAN),
            height_source: d.key(c::HEIGHT_SOURCE.name, r).unwrap_or_default(),
            residual_ratio: number(d, c::RESIDUAL_DRIFT_RATIO.name, r),
            residual_status: d.key(c::RESIDUAL_STATUS.name, r),
        })
        .collect()
}

/// Per direction: the Bouc-Wen verdict (bouc_wen/bouc_wen.parquet's `verdict`,
/// else its statuses), the energies of its DoFs and, where identified, ι
/// from damage/damage.parquet.
fn hysteresis_evidence(dir: &Path) -> Vec<HysteresisEvidence> {
    use t::bouc_wen as c;
    let Some(b) = read(dir, &t::BOUC_WEN) else {
        return Vec::new();
    };
    let damage = read(dir, &t::DAMAGE);
    let mut out = Vec::new();
    for (keys, rows) in b.groups(&[c::DIRECTION.name]) {
        let direction = keys.first().cloned().unwrap_or_default();
        let key = |col: &str, r: usize| b.key(col, r).unwrap_or_default();
        let reason = rows
            .iter()
            .map(|&r| key(c::REASON.name, r))
            .find(|s| !s.is_empty())
            .unwrap_or_default();
        let verdict = rows
            .iter()
            .map(|&r| key(c::VERDICT.name, r))
            .find(|s| !s.is_empty())
            .unwrap_or_else(|| {
                // Tables written before the verdict column: from the statuses.
                if rows
                    .iter()
                    .any(|&r| key(c::STATUS.name, r).starts_with("identified"))
                {
                    "nonlinear_identified".into()
                } else {
                    "not_identifiable".into()
                }
            });
        // One energy per DoF (repeated on its parameter rows).
        let mut seen = std::collections::BTreeSet::new();
        let energies: Vec<f64> = rows
            .iter()
            .filter(|&&r| seen.insert(key(c::DOF.name, r)))
            .filter_map(|&r| number(&b, c::ENERGY_HYSTERETIC_J.name, r))
            .collect();
        let energy_j = (!energies.is_empty()).then(|| energies.iter().sum());
        let outcome = match verdict.as_str() {
            "nonlinear_identified" => {
                let (final_iota, peak_iota) = damage
                    .as_ref()
                    .map(|d| iota_of(d, &direction))
                    .unwrap_or((None, None));
                HysteresisOutcome::Nonlinear {
                    final_iota,
                    peak_iota,
                    energy_j,
                }
            }
            "no_significant_hysteresis" => HysteresisOutcome::NoSignificantHysteresis { reason },
            _ => HysteresisOutcome::NotIdentifiable { reason },
        };
        out.push(HysteresisEvidence { direction, outcome });
    }
    out
}

/// (final, peak) ι of `direction` in damage/damage.parquet.
fn iota_of(d: &Table, direction: &str) -> (Option<f64>, Option<f64>) {
    let (Some(iota), Some(time)) = (
        d.number(t::damage::IOTA.name),
        d.number(t::damage::T_S.name),
    ) else {
        return (None, None);
    };
    let mut last: Option<(f64, f64)> = None;
    let mut peak: Option<f64> = None;
    for r in 0..d.rows {
        if d.key(t::damage::DIRECTION.name, r).as_deref() != Some(direction) {
            continue;
        }
        let (Some(v), Some(at)) = (iota[r], time[r]) else {
            continue;
        };
        if last.is_none_or(|(lt, _)| at >= lt) {
            last = Some((at, v));
        }
        peak = Some(peak.map_or(v, |p| p.max(v)));
    }
    (last.map(|(_, v)| v), peak)
}
