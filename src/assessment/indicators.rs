//! Each indicator's verdict from its evidence (module doc of
//! `crate::assessment`; thresholds and sources in docs/assessment.md).
//! The evidence is what the other stages tabled, gathered by the `assess`
//! stage; nothing here reads a file.

use super::fragility::{DamageState, DriftFragility};
use super::{Indicator, IndicatorKind, FREQUENCY_DROP_THRESHOLDS, RESIDUAL_DRIFT_THRESHOLDS};

/// One row of drift/drift.parquet, as the assessment needs it.
#[derive(Debug, Clone, PartialEq)]
pub struct DriftEvidence {
    pub direction: String,
    pub lower_level: i32,
    pub upper_level: i32,
    /// `measured`, `segment` or `estimate`.
    pub kind: String,
    pub peak_ratio: f64,
    /// `stated`, `from total height`, `assumed`, `unknown: roof level assumed`.
    pub height_source: String,
    pub residual_ratio: Option<f64>,
    /// `resolved`, `unresolved`, `artefact`.
    pub residual_status: Option<String>,
}

impl DriftEvidence {
    fn subject(&self) -> String {
        format!(
            "levels {}–{}, {}",
            self.lower_level, self.upper_level, self.direction
        )
    }
    fn rateable(&self) -> bool {
        (self.kind == "measured" || self.kind == "segment")
            && !self.height_source.starts_with("unknown")
            && self.peak_ratio.is_finite()
    }
}

/// The building's drift fragility and how it was chosen.
#[derive(Debug, Clone, PartialEq)]
pub struct FragilityChoice {
    /// `None` for a structure no drift fragility applies to (a bridge).
    pub fragility: Option<DriftFragility>,
    /// The type was not stated (or not recognised): the default was used.
    pub default_used: bool,
    /// Why no fragility applies, when none does.
    pub why_none: Option<String>,
}

/// The drift indicator and the damage-state probabilities at its driving
/// drift (P(none) … P(complete)).
pub fn drift_indicator(
    rows: &[DriftEvidence],
    choice: &FragilityChoice,
) -> (Indicator, Option<[f64; 5]>) {
    let kind = IndicatorKind::Drift;
    let Some(fragility) = &choice.fragility else {
        let why = choice
            .why_none
            .clone()
            .unwrap_or_else(|| "no drift fragility applies to this structure".into());
        return (Indicator::not_rated(kind, None, String::new(), why), None);
    };
    let driver = rows
        .iter()
        .filter(|r| r.rateable())
        .max_by(|a, b| a.peak_ratio.total_cmp(&b.peak_ratio));
    let Some(d) = driver else {
        let why = if rows.is_empty() {
            "no storey or segment drift (drift/drift.parquet has no rows: no direction has records at two levels)".to_string()
        } else if rows.iter().any(|r| r.height_source.starts_with("unknown")) {
            "the only drifts run to a roof whose level was assumed (storey count unknown): state structure.storeys"
                .to_string()
        } else {
            "only interpolated storey estimates, which are never rated".to_string()
        };
        return (Indicator::not_rated(kind, None, String::new(), why), None);
    };
    let probabilities = fragility.probabilities(d.peak_ratio);
    let state = fragility.most_likely(d.peak_ratio);
    let p_state = match (probabilities, state) {
        (Some(p), Some(s)) => p[s as usize],
        _ => f64::NAN,
    };
    let mut verdict = format!(
        "{} (P = {:.2}) at {:.3} % drift, {} {} code",
        state.map(|s| s.name()).unwrap_or("—"),
        p_state,
        100.0 * d.peak_ratio,
        fragility.building_type,
        fragility.design_level.name()
    );
    if d.kind == "segment" {
        verdict.push_str(" (a segment of several storeys: its average, a lower bound of its largest storey drift)");
    }
    let indicator = Indicator {
        kind,
        value: Some(d.peak_ratio),
        subject: d.subject(),
        state,
        verdict,
        provisional: d.height_source == "assumed" || choice.default_used,
    };
    (indicator, probabilities)
}

/// The residual-drift indicator: the largest resolved residual drift ratio
/// on [`RESIDUAL_DRIFT_THRESHOLDS`]; unresolved values and artefacts are
/// never rated.
pub fn residual_indicator(rows: &[DriftEvidence]) -> Indicator {
    let kind = IndicatorKind::ResidualDrift;
    let resolved = rows
        .iter()
        .filter(|r| r.rateable() && r.residual_status.as_deref() == Some("resolved"))
        .filter_map(|r| r.residual_ratio.map(|v| (r, v.abs())))
        .filter(|(_, v)| v.is_finite())
        .max_by(|a, b| a.1.total_cmp(&b.1));
    match resolved {
        Some((r, v)) => {
            let state = DamageState::reached(v, RESIDUAL_DRIFT_THRESHOLDS);
            Indicator {
                kind,
                value: Some(v),
                subject: r.subject(),
                state: Some(state),
                verdict: format!("{} at {:.3} % residual drift", state.name(), 100.0 * v),
                provisional: r.height_source == "assumed",
            }
        }
        None => {
            let unresolved = rows
                .iter()
                .filter(|r| r.residual_status.as_deref() == Some("unresolved"))
                .count();
            let artefacts = rows
                .iter()
                .filter(|r| r.residual_status.as_deref() == Some("artefact"))
                .count();
            let why = if unresolved + artefacts == 0 {
                "no residual drift measured (no unfiltered records of two levels on a common time base)".to_string()
            } else {
                format!(
                    "no resolved residual drift ({unresolved} below 2σ of the integrated noise, {artefacts} baseline artefacts)"
                )
            };
            Indicator::not_rated(kind, None, String::new(), why)
        }
    }
}

/// The apparent-frequency evidence of one direction.
#[derive(Debug, Clone, PartialEq)]
pub struct FrequencyEvidence {
    pub direction: String,
    /// Output channel tracked (and the input, when input–output).
    pub channels: String,
    /// Before the event: the pre-event windows, else the reference event.
    pub before_hz: Option<f64>,
    /// Where `before_hz` comes from: `pre-event windows` or `reference event`.
    pub before_source: String,
    pub min_during_hz: Option<f64>,
    pub after_hz: Option<f64>,
    /// Relative scatter (standard deviation over mean) of the estimates
    /// behind `before_hz` and `after_hz`, combined in quadrature.
    pub scatter: f64,
    /// Why `before_hz` or `after_hz` is missing, when one is.
    pub why_missing: Option<String>,
}

impl FrequencyEvidence {
    /// 1 − f_after / f_before.
    pub fn permanent_drop(&self) -> Option<f64> {
        match (self.before_hz, self.after_hz) {
            (Some(b), Some(a)) if b > 0.0 && a.is_finite() => Some(1.0 - a / b),
            _ => None,
        }
    }
    /// 1 − f_min,during / f_before.
    pub fn drop_during(&self) -> Option<f64> {
        match (self.before_hz, self.min_during_hz) {
            (Some(b), Some(m)) if b > 0.0 && m.is_finite() => Some(1.0 - m / b),
            _ => None,
        }
    }
}

/// The frequency indicator: the direction with the largest permanent drop,
/// on [`FREQUENCY_DROP_THRESHOLDS`]; a drop within twice the track's scatter
/// counts as none.
pub fn frequency_indicator(evidence: &[FrequencyEvidence]) -> Indicator {
    let kind = IndicatorKind::Frequency;
    let worst = evidence
        .iter()
        .filter_map(|e| e.permanent_drop().map(|d| (e, d)))
        .max_by(|a, b| a.1.total_cmp(&b.1));
    let Some((e, drop)) = worst else {
        let why = if evidence.is_empty() {
            "no direction has a base and an upper-level record to track".to_string()
        } else {
            evidence
                .iter()
                .map(|e| {
                    format!(
                        "{}: {}",
                        e.direction,
                        e.why_missing.as_deref().unwrap_or("no estimate")
                    )
                })
                .collect::<Vec<_>>()
                .join("; ")
        };
        return Indicator::not_rated(kind, None, String::new(), why);
    };
    // The drop must stand out of the track's scatter to count; a drop
    // within it is "none" only when the scatter itself lies below the
    // slight threshold (it could have seen a slight softening), else the
    // comparison is unresolved and not rated.
    let resolution = 2.0 * e.scatter;
    let significant = drop > resolution;
    if !significant && resolution >= FREQUENCY_DROP_THRESHOLDS[0] {
        return Indicator::not_rated(
            kind,
            Some(drop),
            format!("{} ({})", e.direction, e.channels),
            format!(
                "unresolved: the permanent drop {:.1} % ({:.3} → {:.3} Hz) lies within twice the track's scatter ({:.1} %), \
                 wider than the {:.0} % of slight damage",
                100.0 * drop,
                e.before_hz.unwrap_or(f64::NAN),
                e.after_hz.unwrap_or(f64::NAN),
                100.0 * e.scatter,
                100.0 * FREQUENCY_DROP_THRESHOLDS[0]
            ),
        );
    }
    let state = if significant {
        DamageState::reached(drop, FREQUENCY_DROP_THRESHOLDS)
    } else {
        DamageState::None
    };
    let during = e
        .drop_during()
        .map(|d| format!("; {:.1} % lowest during the shaking", 100.0 * d))
        .unwrap_or_default();
    let verdict = format!(
        "{} — permanent drop {:.1} % ({:.3} → {:.3} Hz, before from the {}{}){}",
        state.name(),
        100.0 * drop,
        e.before_hz.unwrap_or(f64::NAN),
        e.after_hz.unwrap_or(f64::NAN),
        e.before_source,
        during,
        if significant {
            String::new()
        } else {
            format!(
                ", within twice the track's scatter ({:.1} %)",
                100.0 * e.scatter
            )
        }
    );
    Indicator {
        kind,
        value: Some(drop),
        subject: format!("{} ({})", e.direction, e.channels),
        state: Some(state),
        verdict,
        provisional: false,
    }
}

/// What the Bouc-Wen identification of one direction concluded.
#[derive(Debug, Clone, PartialEq)]
pub enum HysteresisOutcome {
    /// Significant hysteresis identified; the final (and peak) ι and the
    /// dissipated hysteretic energy where tabled.
    Nonlinear {
        final_iota: Option<f64>,
        peak_iota: Option<f64>,
        energy_j: Option<f64>,
    },
    /// The F-test (or the hysteretic share) found no significant hysteresis.
    NoSignificantHysteresis { reason: String },
    /// The identification could not run or decide (masses missing, …).
    NotIdentifiable { reason: String },
}

#[derive(Debug, Clone, PartialEq)]
pub struct HysteresisEvidence {
    pub direction: String,
    pub outcome: HysteresisOutcome,
}

/// The hysteresis indicator: the largest final ι of the directions where
/// significant hysteresis was identified, on [`FREQUENCY_DROP_THRESHOLDS`]
/// (ι is a participation-weighted frequency loss).  "No significant
/// hysteresis" is a verdict of none only when the apparent frequency did not
/// drop for good: a permanent softening that the F-test does not see is
/// outside what the test can see (docs/hysteresis.md), and the indicator is
/// then not rated rather than "linear".
pub fn hysteresis_indicator(evidence: &[HysteresisEvidence], frequency: &Indicator) -> Indicator {
    let kind = IndicatorKind::Hysteresis;
    let nonlinear = evidence
        .iter()
        .filter_map(|e| match &e.outcome {
            HysteresisOutcome::Nonlinear {
                final_iota,
                energy_j,
                ..
            } => Some((e, *final_iota, *energy_j)),
            _ => None,
        })
        .max_by(|a, b| {
            a.1.unwrap_or(f64::NEG_INFINITY)
                .total_cmp(&b.1.unwrap_or(f64::NEG_INFINITY))
        });
    if let Some((e, iota, energy)) = nonlinear {
        let energy_text = energy
            .map(|v| format!(", dissipated hysteretic energy {v:.3e} J"))
            .unwrap_or_default();
        return match iota.filter(|v| v.is_finite()) {
            Some(iota) => {
                let state = DamageState::reached(iota, FREQUENCY_DROP_THRESHOLDS);
                Indicator {
                    kind,
                    value: Some(iota),
                    subject: e.direction.clone(),
                    state: Some(state),
                    verdict: format!(
                        "{} — significant hysteresis, final ι = {:.3}{}",
                        state.name(),
                        iota,
                        energy_text
                    ),
                    provisional: false,
                }
            }
            None => Indicator::not_rated(
                kind,
                None,
                e.direction.clone(),
                format!("significant hysteresis identified{energy_text}, but no damage index ι (stage damage not run)"),
            ),
        };
    }
    let quiet: Vec<&HysteresisEvidence> = evidence
        .iter()
        .filter(|e| matches!(e.outcome, HysteresisOutcome::NoSignificantHysteresis { .. }))
        .collect();
    if !quiet.is_empty() {
        let directions = quiet
            .iter()
            .map(|e| e.direction.as_str())
            .collect::<Vec<_>>()
            .join(", ");
        return match frequency.state {
            Some(DamageState::None) => Indicator {
                kind,
                value: None,
                subject: directions,
                state: Some(DamageState::None),
                verdict: "none — no significant hysteresis (F-test), and the apparent frequency came back".into(),
                provisional: false,
            },
            Some(_) => Indicator::not_rated(
                kind,
                None,
                directions,
                format!(
                    "the F-test finds no significant hysteresis, yet the apparent frequency fell for good ({}): \
                     a softening outside what the Bouc-Wen test can see (docs/hysteresis.md), so no verdict of \"linear\"",
                    frequency.verdict
                ),
            ),
            None => Indicator::not_rated(
                kind,
                None,
                directions,
                "the F-test finds no significant hysteresis, which is not a finding of a linear response (docs/hysteresis.md), \
                 and no before/after apparent frequency confirms one"
                    .into(),
            ),
        };
    }
    let why = if evidence.is_empty() {
        "no Bouc-Wen identification (stage hysteresis not run or not applicable)".to_string()
    } else {
        evidence
            .iter()
            .map(|e| match &e.outcome {
                HysteresisOutcome::NotIdentifiable { reason } => {
                    format!("{}: {}", e.direction, reason)
                }
                _ => String::new(),
            })
            .collect::<Vec<_>>()
            .join("; ")
    };
    Indicator::not_rated(kind, None, String::new(), why)
}
