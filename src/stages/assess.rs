//! `assess`: the post-earthquake assessment (`crate::assessment`) →
//! `assessment.parquet` (one row: colour, priority, damage-state
//! probabilities, every indicator's value and verdict, the assumptions) and
//! `frequency_track.parquet` (the apparent fundamental frequency through the
//! event, `modal::apparent`).
//!
//! Glue only: the evidence is read from the tables the earlier stages wrote
//! (drift, Bouc-Wen, damage index, modes, frequency shifts — listed by the
//! run manifest), the frequency track is computed from the conditioned
//! records, and the rules of `crate::assessment` give the verdicts.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::condition::Conditioned;
use crate::assessment::fragility::{self, DesignLevel, DriftFragility};
use crate::assessment::indicators::{
    drift_indicator, frequency_indicator, hysteresis_indicator, residual_indicator, DriftEvidence,
    FragilityChoice, FrequencyEvidence, HysteresisEvidence, HysteresisOutcome,
};
use crate::assessment::{combine, Assessment, Overall};
use crate::error::{Error, Result};
use crate::modal::apparent::{track_apparent_frequency, ApparentSettings, FrequencyTrack};
use crate::pipeline::{Product, ProductKind, RunContext, Stage, StageKind, StageSource};
use crate::report::table::{self, Table};
use crate::sinks::assessment_tables::{write_assessment, write_frequency_track, TrackRows};
use crate::vocab::tables as t;
use crate::vocab::{Axis, Event, Structure};

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
}

impl Default for AssessParams {
    fn default() -> Self {
        AssessParams {
            tracking: ApparentSettings::default(),
            strong_motion_arias: [0.05, 0.95],
        }
    }
}

fn build(src: &StageSource) -> Result<Box<dyn Stage>> {
    let params: AssessParams = src.params()?;
    params.tracking.validate().map_err(|e| src.invalid(e))?;
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
    fn run(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        let out = ctx.out_dir.clone();
        let Conditioned { event, motions } = ctx.input(ProductKind::ConditionedEvent)?;
        let modes = read(&out, &t::MODES);
        let shifts = read(&out, &t::FREQUENCY_SHIFTS);
        let (tracks, evidence) = frequency_tracks(event, motions, &modes, &shifts, &self.params)?;
        let row = assess(event, &out, &evidence);
        write_frequency_track(&out.join(t::FREQUENCY_TRACK.file), event, &tracks)?;
        write_assessment(&out.join(t::ASSESSMENT.file), event, &row)?;
        for note in &row.overall.drivers {
            ctx.info(format!("assess: {note}"));
        }
        ctx.info(format!(
            "assess: {}{}",
            row.overall.colour.map(|c| c.label()).unwrap_or("NOT RATED"),
            row.overall
                .reason
                .as_deref()
                .map(|r| format!(" — {r}"))
                .unwrap_or_default()
        ));
        Ok(None)
    }
}

/// A table of the run, when the run manifest lists it and it reads.
fn read(dir: &Path, schema: &crate::vocab::schema::TableSchema) -> Option<Table> {
    let listed = crate::pipeline::listed_results(dir)
        .map(|files| files.iter().any(|f| f == schema.file))
        .unwrap_or(true);
    (listed && dir.join(schema.file).exists())
        .then(|| table::load(&dir.join(schema.file), None).ok())
        .flatten()
}

fn number(t: &Table, column: &str, row: usize) -> Option<f64> {
    t.number(column)?.get(row).copied().flatten()
}

/// The assessment of `event` from the tables in `dir` and the frequency evidence.
pub fn assess(event: &Event, dir: &Path, frequency: &[FrequencyEvidence]) -> Assessment {
    let structure = event.structure.as_ref();
    let mut assumptions = Vec::new();
    let choice = fragility_choice(structure, &mut assumptions);
    let drift_rows = read(dir, &t::DRIFT)
        .map(|d| drift_evidence(&d))
        .unwrap_or_default();
    if drift_rows.iter().any(|r| r.height_source == "assumed") {
        assumptions.push(
            "storey height assumed (metrics param assumed_storey_height_m): drift ratios are provisional; state structure.storey_heights_m or height_m"
                .into(),
        );
    }
    if drift_rows
        .iter()
        .any(|r| r.height_source.starts_with("unknown"))
    {
        assumptions.push(
            "roof level assumed (storey count unknown): those drifts are shown, never rated".into(),
        );
    }
    let (drift, probabilities) = drift_indicator(&drift_rows, &choice);
    let frequency_indicator = frequency_indicator(frequency);
    let hysteresis = hysteresis_indicator(&hysteresis_evidence(dir), &frequency_indicator);
    let residual = residual_indicator(&drift_rows);
    let indicators = vec![drift, frequency_indicator, hysteresis, residual];
    let overall: Overall = combine(&indicators);
    let driving = frequency
        .iter()
        .filter(|e| e.permanent_drop().is_some())
        .max_by(|a, b| {
            a.permanent_drop()
                .unwrap_or(f64::NEG_INFINITY)
                .total_cmp(&b.permanent_drop().unwrap_or(f64::NEG_INFINITY))
        })
        .or_else(|| frequency.first())
        .cloned();
    Assessment {
        event: event.name.clone(),
        structure: structure.and_then(|s| s.name.clone()),
        structure_kind: structure_kind(structure),
        overall,
        fragility: choice.fragility.clone(),
        building_type_source: if choice.fragility.is_none() {
            "not applicable".into()
        } else if choice.default_used {
            "default".into()
        } else {
            "stated".into()
        },
        probabilities,
        indicators,
        frequency: driving,
        assumptions,
    }
}

fn structure_kind(structure: Option<&Structure>) -> String {
    if crate::modal::is_bridge(structure) {
        "bridge".into()
    } else if structure.is_some_and(|s| {
        s.kind
            .as_deref()
            .is_some_and(|k| k.eq_ignore_ascii_case("building"))
            || s.storeys.is_some()
    }) {
        "building".into()
    } else {
        "unknown".into()
    }
}

/// The drift fragility of the structure: its stated type and design level,
/// else the stated default (with an assumption); none for a bridge.
fn fragility_choice(
    structure: Option<&Structure>,
    assumptions: &mut Vec<String>,
) -> FragilityChoice {
    if crate::modal::is_bridge(structure) {
        return FragilityChoice {
            fragility: None,
            default_used: false,
            why_none: Some(
                "a bridge: published bridge fragilities (HAZUS bridge classes HWB1–28) are in spectral acceleration at the site, not in drift, and no drift-based set is shipped"
                    .into(),
            ),
        };
    }
    let level_text = structure.and_then(|s| s.design_level.clone());
    let level = match level_text.as_deref().map(DesignLevel::parse) {
        Some(Some(l)) => l,
        Some(None) => {
            assumptions.push(format!(
                "design level {:?} not one of high, moderate, low, pre: {} assumed",
                level_text.clone().unwrap_or_default(),
                fragility::DEFAULT_DESIGN_LEVEL.name()
            ));
            fragility::DEFAULT_DESIGN_LEVEL
        }
        None => fragility::DEFAULT_DESIGN_LEVEL,
    };
    let stated = structure.and_then(|s| s.building_type.clone());
    let reading = stated.as_deref().map(fragility::read_type);
    let (code, default_used) = match &reading {
        Some(r) => {
            if let Some(note) = &r.note {
                assumptions.push(note.clone());
            }
            match r.code {
                Some(c) => (c, false),
                None => (fragility::DEFAULT_TYPE, true),
            }
        }
        None => (fragility::DEFAULT_TYPE, true),
    };
    if default_used {
        assumptions.push(format!(
            "building type not stated: default {} ({} code) assumed — state structure.type (HAZUS code) and structure.design_level in event.toml",
            fragility::DEFAULT_TYPE,
            level.name()
        ));
    } else if level_text.is_none() {
        assumptions.push(format!(
            "design level not stated: {} assumed (structure.design_level)",
            level.name()
        ));
    }
    FragilityChoice {
        fragility: DriftFragility::of(code, level),
        default_used,
        why_none: None,
    }
}

fn drift_evidence(d: &Table) -> Vec<DriftEvidence> {
    use t::drift as c;
    (0..d.rows)
        .map(|r| DriftEvidence {
            direction: d.key(c::DIRECTION.name, r).unwrap_or_default(),
            lower_level: number(d, c::LOWER_LEVEL.name, r).unwrap_or(f64::NAN) as i32,
            upper_level: number(d, c::UPPER_LEVEL.name, r).unwrap_or(f64::NAN) as i32,
            kind: d.key(c::KIND.name, r).unwrap_or_default(),
            peak_ratio: number(d, c::PEAK_DRIFT_RATIO.name, r).unwrap_or(f64::NAN),
            height_source: d.key(c::HEIGHT_SOURCE.name, r).unwrap_or_default(),
            residual_ratio: number(d, c::RESIDUAL_DRIFT_RATIO.name, r),
            residual_status: d.key(c::RESIDUAL_STATUS.name, r),
        })
        .collect()
}

/// Per direction: the Bouc-Wen outcome (bouc_wen.parquet's status and
/// reason) and, where identified, ι from damage.parquet.
fn hysteresis_evidence(dir: &Path) -> Vec<HysteresisEvidence> {
    let Some(b) = read(dir, &t::BOUC_WEN) else {
        return Vec::new();
    };
    let damage = read(dir, &t::DAMAGE);
    let mut out: Vec<HysteresisEvidence> = Vec::new();
    for (keys, rows) in b.groups(&[t::bouc_wen::DIRECTION.name]) {
        let direction = keys.first().cloned().unwrap_or_default();
        let status = |r: usize| b.key(t::bouc_wen::STATUS.name, r).unwrap_or_default();
        let identified = rows.iter().any(|&r| status(r).starts_with("identified"));
        let outcome = if identified {
            let (final_iota, peak_iota) = damage
                .as_ref()
                .map(|d| iota_of(d, &direction))
                .unwrap_or((None, None));
            HysteresisOutcome::Nonlinear {
                final_iota,
                peak_iota,
                energy_j: None,
            }
        } else {
            let reason = rows
                .iter()
                .filter_map(|&r| b.key(t::bouc_wen::REASON.name, r))
                .find(|s| !s.is_empty())
                .unwrap_or_default();
            if rows
                .iter()
                .any(|&r| status(r) == "no_significant_hysteresis")
                || reason.contains("do not improve the linear fit significantly")
                || reason.contains("stays (nearly) linear")
            {
                HysteresisOutcome::NoSignificantHysteresis { reason }
            } else {
                HysteresisOutcome::NotIdentifiable { reason }
            }
        };
        out.push(HysteresisEvidence { direction, outcome });
    }
    out
}

/// (final, peak) ι of `direction` in damage.parquet (rows in time order).
fn iota_of(d: &Table, direction: &str) -> (Option<f64>, Option<f64>) {
    let Some(iota) = d.number(t::damage::IOTA.name) else {
        return (None, None);
    };
    let mut last: Option<(f64, f64)> = None;
    let mut peak: Option<f64> = None;
    for r in 0..d.rows {
        if d.key(t::damage::DIRECTION.name, r).as_deref() != Some(direction) {
            continue;
        }
        let (Some(v), Some(time)) = (iota[r], number(d, t::damage::T_S.name, r)) else {
            continue;
        };
        if last.is_none_or(|(lt, _)| time >= lt) {
            last = Some((time, v));
        }
        peak = Some(peak.map_or(v, |p: f64| p.max(v)));
    }
    (last.map(|(_, v)| v), peak)
}

/// The tracked records of one direction.
struct Pair<'a> {
    axis: Axis,
    output: &'a crate::vocab::Record,
    input: Option<&'a crate::vocab::Record>,
}

/// The apparent-frequency track per horizontal direction (the highest
/// level's record, with the base's as input), and the evidence each gives.
fn frequency_tracks(
    event: &Event,
    motions: &[crate::conditioning::Motion],
    modes: &Option<Table>,
    shifts: &Option<Table>,
    params: &AssessParams,
) -> Result<(Vec<TrackRows>, Vec<FrequencyEvidence>)> {
    let selection = crate::geometry::one_record_per_level(&event.records);
    let mut pairs: Vec<Pair> = Vec::new();
    let mut evidence: Vec<FrequencyEvidence> = Vec::new();
    for axis in [Axis::X, Axis::Y] {
        let levels: Vec<(i32, &crate::vocab::Record)> = selection
            .records
            .iter()
            .filter(|((a, _), _)| *a == axis)
            .map(|((_, l), r)| (*l, *r))
            .collect();
        let top = levels
            .iter()
            .filter(|(l, _)| *l > 0)
            .max_by_key(|(l, _)| *l);
        let base = levels.iter().find(|(l, _)| *l == 0).map(|(_, r)| *r);
        match top {
            Some((_, output)) => pairs.push(Pair {
                axis,
                output,
                input: base,
            }),
            None if !levels.is_empty() => evidence.push(FrequencyEvidence {
                direction: format!("{axis:?}"),
                channels: String::new(),
                before_hz: None,
                before_source: String::new(),
                min_during_hz: None,
                after_hz: None,
                scatter: 0.0,
                why_missing: Some("no record above the base in this direction".into()),
            }),
            None => {}
        }
    }
    let motion_of = |id: &str| motions.iter().find(|m| m.channel_id == id);
    let mut series: Vec<(Pair, Vec<f64>, Option<Vec<f64>>, f64, f64)> = Vec::new();
    for pair in pairs {
        let direction = format!("{:?}", pair.axis);
        let missing = |why: String| FrequencyEvidence {
            direction: direction.clone(),
            channels: pair.output.channel.id.clone(),
            before_hz: None,
            before_source: String::new(),
            min_during_hz: None,
            after_hz: None,
            scatter: 0.0,
            why_missing: Some(why),
        };
        let Some(out_motion) = motion_of(&pair.output.channel.id) else {
            evidence.push(missing("the output channel was not conditioned".into()));
            continue;
        };
        let output = out_motion.acceleration.get()?.to_vec();
        let input = match pair.input.and_then(|r| motion_of(&r.channel.id)) {
            Some(m) if (m.dt - out_motion.dt).abs() < 1e-12 => Some(m.acceleration.get()?.to_vec()),
            _ => None,
        };
        // One time base: the common window of the two records.
        let (output, input) = match (&input, pair.input) {
            (Some(inp), Some(rec)) => {
                match crate::metrics::drift::common_window(&[
                    (&rec.channel, inp.len()),
                    (&pair.output.channel, output.len()),
                ]) {
                    Ok(w) => (
                        output[w.offsets[1]..w.offsets[1] + w.len].to_vec(),
                        Some(inp[w.offsets[0]..w.offsets[0] + w.len].to_vec()),
                    ),
                    Err(why) => {
                        evidence.push(missing(format!(
                            "base and output records share no time base: {why}"
                        )));
                        continue;
                    }
                }
            }
            _ => (output, None),
        };
        let dt = out_motion.dt;
        let expected = expected_frequency(event, pair.axis, &output, dt, modes);
        let Some(expected) = expected else {
            evidence.push(missing("no expected fundamental (no mode in this direction, no spectral peak, no storey count or height)".into()));
            continue;
        };
        series.push((pair, output, input, dt, expected));
    }
    let mut rows = Vec::new();
    for (pair, output, input, dt, expected) in &series {
        let direction = format!("{:?}", pair.axis);
        let channels = match pair.input {
            Some(r) if input.is_some() => format!("{} / {}", pair.output.channel.id, r.channel.id),
            _ => pair.output.channel.id.clone(),
        };
        let result =
            track_apparent_frequency(input.as_deref(), output, *dt, *expected, &params.tracking);
        let track = match result {
            Ok(track) => track,
            Err(e) => {
                evidence.push(FrequencyEvidence {
                    direction,
                    channels,
                    before_hz: None,
                    before_source: String::new(),
                    min_during_hz: None,
                    after_hz: None,
                    scatter: 0.0,
                    why_missing: Some(format!("no track: {e}")),
                });
                continue;
            }
        };
        let base_for_arias = input.as_deref().unwrap_or(output);
        let [from, to] = params.strong_motion_arias;
        let (duration, start) =
            crate::metrics::significant_duration(base_for_arias, *dt, from, to)?;
        let (strong_start, strong_end) = (start, start + duration);
        let phases = track.phases(strong_start, strong_end);
        let reference = reference_frequency(shifts, &direction);
        let (before_hz, before_source) = match (phases.pre_hz, reference) {
            (Some(f), _) => (Some(f), "pre-event windows".to_string()),
            (None, Some(f)) => (Some(f), "reference event".to_string()),
            (None, None) => (None, String::new()),
        };
        let scatter = phase_scatter(&track, strong_start, strong_end);
        let why_missing = if before_hz.is_none() {
            Some(format!(
                "no pre-event window: the strong shaking starts {strong_start:.1} s into the record and a window is {:.1} s long; give --reference with an earlier event",
                track.window_s
            ))
        } else if phases.post_hz.is_none() {
            Some(format!(
                "no post-event window: the record ends {:.1} s after the strong shaking and a window is {:.1} s long",
                (output.len() as f64 * dt - strong_end).max(0.0),
                track.window_s
            ))
        } else {
            None
        };
        evidence.push(FrequencyEvidence {
            direction: direction.clone(),
            channels,
            before_hz,
            before_source,
            min_during_hz: phases.min_during_hz,
            after_hz: phases.post_hz,
            scatter,
            why_missing,
        });
        rows.push(TrackRows {
            direction,
            output_channel: pair.output.channel.id.clone(),
            input_channel: input.as_ref().and(pair.input).map(|r| r.channel.id.clone()),
            strong_start_s: strong_start,
            strong_end_s: strong_end,
            track,
        });
    }
    evidence.sort_by(|a, b| a.direction.cmp(&b.direction));
    Ok((rows, evidence))
}

/// Relative scatter of the pre- and post-event estimates (std / mean of
/// each, in quadrature): the noise a permanent drop must stand out of.
fn phase_scatter(track: &FrequencyTrack, strong_start: f64, strong_end: f64) -> f64 {
    let half = 0.5 * track.window_s;
    let rel_std = |values: Vec<f64>| -> f64 {
        if values.len() < 2 {
            return 0.0;
        }
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
        if mean > 0.0 {
            var.sqrt() / mean
        } else {
            0.0
        }
    };
    let pick = |f: &dyn Fn(f64) -> bool| -> Vec<f64> {
        track
            .points
            .iter()
            .filter(|p| p.frequency_hz.is_finite() && f(p.time_s))
            .map(|p| p.frequency_hz)
            .collect()
    };
    let pre = rel_std(pick(&|t| t + half <= strong_start));
    let post = rel_std(pick(&|t| t - half >= strong_end));
    pre.hypot(post)
}

/// The expected fundamental of a direction: the identified mode of that
/// direction, unless the record's lowest spectral peak lies well below it
/// (a fundamental that softened during the event, or was not selected);
/// else the structure's estimate.
fn expected_frequency(
    event: &Event,
    axis: Axis,
    output: &[f64],
    dt: f64,
    modes: &Option<Table>,
) -> Option<f64> {
    let label = format!("{axis:?}");
    let modal = modes.as_ref().and_then(|m| {
        let f = m.number(t::modes::FREQUENCY_HZ.name)?;
        (0..m.rows)
            .filter(|&r| m.key(t::modes::DIRECTION.name, r).as_deref() == Some(label.as_str()))
            .filter_map(|r| f[r])
            .filter(|v| v.is_finite() && *v > 0.0)
            .min_by(|a, b| a.total_cmp(b))
    });
    let estimate = event
        .structure
        .as_ref()
        .and_then(crate::modal::fundamental_estimate)
        .map(|(f, _)| f);
    let top = modal
        .or(estimate)
        .map(|f| 1.5 * f)
        .unwrap_or(crate::modal::DEFAULT_BAND_HZ[1])
        .min(0.4 / dt);
    let peak = crate::modal::lowest_peak_of_records(&[output], dt, top);
    match (modal, peak) {
        (Some(m), Some(p)) if p < 0.8 * m => Some(p),
        (Some(m), _) => Some(m),
        (None, Some(p)) => Some(p),
        (None, None) => estimate,
    }
}

/// The reference event's fundamental of `direction` (frequency_shifts.parquet
/// from `--reference`): the lowest reference mode labelled with it.
fn reference_frequency(shifts: &Option<Table>, direction: &str) -> Option<f64> {
    let s = shifts.as_ref()?;
    let f = s.number(t::frequency_shifts::FREQUENCY_REFERENCE_HZ.name)?;
    (0..s.rows)
        .filter(|&r| {
            s.key(t::frequency_shifts::DIRECTION_REFERENCE.name, r)
                .as_deref()
                == Some(direction)
        })
        .filter_map(|r| f[r])
        .filter(|v| v.is_finite() && *v > 0.0)
        .min_by(|a, b| a.total_cmp(b))
}
