//! `assess`: the post-earthquake assessment (`crate::assessment`) →
//! `assessment/assessment.parquet` (one row: colour, priority, damage-state
//! probabilities, every indicator's value and verdict, the assumptions) and
//! `frequency_track/frequency_track.parquet` (the apparent fundamental frequency through the
//! event, `modal::apparent`).
//!
//! Glue only: the evidence is read from the tables the earlier stages wrote
//! (drift, Bouc-Wen, damage index, modes, frequency shifts, the change test
//! — those the run manifest lists: `assess_evidence`), the frequency is tracked on the conditioned records,
//! and `crate::assessment` gives the verdicts.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::assess_evidence::{
    change_test_evidence, drift_evidence, hysteresis_evidence, modes_per_direction, read,
};
use super::condition::Conditioned;
use crate::assessment::frequency::{frequency_evidence, KnownFundamentals};
use crate::assessment::verdict::assess;
use crate::error::{Error, Result};
use crate::modal::apparent::ApparentSettings;
use crate::pipeline::{Product, ProductKind, RunContext, Stage, StageKind, StageSource};
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
        let change = change_test_evidence(&out)?;
        let row = assess(
            event,
            &drift,
            &hysteresis_evidence(&out),
            &frequency,
            change.as_ref(),
        );
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
