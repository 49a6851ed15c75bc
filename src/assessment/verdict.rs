//! The assessment of one event from its evidence: the building's drift
//! fragility (stated type and design level, else the stated default), the
//! indicators and their combination (`combine`).  I/O free.

use super::change_test::{change_test_indicator, ChangeTestEvidence};
use super::fragility::{self, DesignLevel, DriftFragility};
use super::indicators::{
    drift_indicator, frequency_indicator, hysteresis_indicator, residual_indicator, DriftEvidence,
    FragilityChoice, FrequencyEvidence, HysteresisEvidence,
};
use super::{combine, Assessment};
use crate::vocab::{Event, Structure};

/// The assessment of `event` from its drift rows, Bouc-Wen outcomes and
/// apparent-frequency evidence, and the change test against the reference
/// run when there is one.
pub fn assess(
    event: &Event,
    drift_rows: &[DriftEvidence],
    hysteresis: &[HysteresisEvidence],
    frequency: &[FrequencyEvidence],
    change: Option<&ChangeTestEvidence>,
) -> Assessment {
    let structure = event.structure.as_ref();
    let mut assumptions = Vec::new();
    let choice = fragility_choice(structure, &mut assumptions);
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
    let (drift, probabilities) = drift_indicator(drift_rows, &choice);
    let frequency_verdict = frequency_indicator(frequency);
    let hysteresis = hysteresis_indicator(hysteresis, &frequency_verdict);
    let residual = residual_indicator(drift_rows);
    let mut indicators = vec![drift, frequency_verdict, hysteresis, residual];
    indicators.extend(change.map(change_test_indicator));
    let overall = combine(&indicators);
    // The direction whose drop is rated (else the first tracked).
    let driving = frequency
        .iter()
        .filter_map(|e| e.permanent_drop().map(|d| (e, d)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(e, _)| e)
        .or_else(|| {
            frequency
                .iter()
                .find(|e| e.after_hz.is_some() || e.min_during_hz.is_some())
        })
        .or_else(|| frequency.first())
        .cloned();
    Assessment {
        event: event.name.clone(),
        structure: structure.and_then(|s| s.name.clone()),
        structure_kind: structure_kind(structure),
        overall,
        building_type_source: if choice.fragility.is_none() {
            "not applicable".into()
        } else if choice.default_used {
            "default".into()
        } else {
            "stated".into()
        },
        fragility: choice.fragility,
        probabilities,
        indicators,
        frequency: driving,
        change_test: change.cloned(),
        assumptions,
    }
}

pub fn structure_kind(structure: Option<&Structure>) -> String {
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
pub fn fragility_choice(
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
