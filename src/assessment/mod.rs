//! The post-earthquake assessment: independent indicators of damage, each
//! with its own verdict (a damage state, or "not rated" and why), and the
//! overall colour and inspection priority they give together.
//!
//! Indicators (docs/assessment.md states every threshold and its source):
//! - **drift**: the largest rated peak drift ratio through the drift
//!   fragility of the building type ([`fragility`]) → damage-state
//!   probabilities and the most likely state;
//! - **frequency**: the permanent drop of the apparent fundamental frequency,
//!   pre-event (or the `--reference` event) against post-event
//!   (`modal::apparent`), Δ = 1 − f_post / f_pre, on the scale
//!   [`FREQUENCY_DROP_THRESHOLDS`] — a softening that does not come back;
//!   the drop during the strong shaking is reported, never rated (healthy
//!   buildings soften temporarily and recover);
//! - **hysteresis**: the final damage index ι (METHODS §4, a participation-
//!   weighted loss of modal frequency) on the same scale, where the Bouc-Wen
//!   identification found significant hysteresis;
//! - **residual drift**, where resolved: [`RESIDUAL_DRIFT_THRESHOLDS`];
//! - **change test**, when the run has a reference: the subspace χ² test of
//!   the record against the reference run's ([`change_test`]) — a detected
//!   change is at most slight: a reason to inspect, never alone a RED.
//!
//! The colour (ShakeCast's four: GREEN, YELLOW, ORANGE, RED, with inspection
//! priority low, medium, medium-high, high) follows [`combine`]: a damage
//! state that at least two indicators reach is *corroborated* and gives its
//! colour; a state that only one indicator reaches gives "inspect" (YELLOW)
//! at most.  I/O free: the `assess` stage gathers the evidence from the
//! other stages' tables and writes `assessment/assessment.parquet`.

pub mod change_test;
pub mod fragility;
pub mod frequency;
pub mod indicators;
pub mod verdict;

use serde::Serialize;

pub use fragility::{DamageState, DesignLevel, DriftFragility};

/// Permanent frequency drop Δ (and final ι) at the thresholds of slight,
/// moderate, extensive and complete damage: 5, 10, 20 and 35 % — stiffness
/// losses 1 − (1 − Δ)² of 10, 19, 36 and 58 %, DiPasquale & Çakmak's final
/// softening (1990).  Our decision (docs/assessment.md): below 5 % lies the
/// frequency wander of undamaged buildings between low-amplitude states
/// (Clinton et al., 2006); beyond 35 % the softening of their collapsed RC
/// frames.
pub const FREQUENCY_DROP_THRESHOLDS: [f64; 4] = [0.05, 0.10, 0.20, 0.35];

/// Residual drift ratio at the thresholds of slight, moderate, extensive and
/// complete damage: FEMA P-58-1 (2012) residual-drift damage states DS1–DS3
/// (0.2 %: doors and non-structural realignment; 0.5 %: structural
/// realignment and repair; 1 %: repair may not be feasible) and 2 % for DS4
/// (our choice; FEMA P-58 ties DS4 to the system's collapse).
pub const RESIDUAL_DRIFT_THRESHOLDS: [f64; 4] = [0.002, 0.005, 0.010, 0.020];

/// ShakeCast's colours, from best to worst.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum Colour {
    Green,
    Yellow,
    Orange,
    Red,
}

impl Colour {
    pub fn label(self) -> &'static str {
        match self {
            Colour::Green => "GREEN",
            Colour::Yellow => "YELLOW",
            Colour::Orange => "ORANGE",
            Colour::Red => "RED",
        }
    }
    /// The inspection priority of the colour (ShakeCast).
    pub fn priority(self) -> &'static str {
        match self {
            Colour::Green => "low",
            Colour::Yellow => "medium",
            Colour::Orange => "medium-high",
            Colour::Red => "high",
        }
    }
    /// What the colour asks of the owner (stated in the report).
    pub fn meaning(self) -> &'static str {
        match self {
            Colour::Green => "no indication of damage",
            Colour::Yellow => "inspect: a possible slight damage, or one indicator alone",
            Colour::Orange => "inspect soon: moderate damage indicated by independent indicators",
            Colour::Red => {
                "inspect urgently, restrict use until assessed: extensive damage indicated by independent indicators"
            }
        }
    }
    /// none → GREEN, slight → YELLOW, moderate → ORANGE, extensive and
    /// complete → RED.
    pub fn of_state(state: DamageState) -> Colour {
        match state {
            DamageState::None => Colour::Green,
            DamageState::Slight => Colour::Yellow,
            DamageState::Moderate => Colour::Orange,
            DamageState::Extensive | DamageState::Complete => Colour::Red,
        }
    }
}

/// The indicators, in the order the assessment lists them (the change test
/// only when the run has a reference).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum IndicatorKind {
    Drift,
    Frequency,
    Hysteresis,
    ResidualDrift,
    ChangeTest,
}

impl IndicatorKind {
    pub fn name(self) -> &'static str {
        match self {
            IndicatorKind::Drift => "drift",
            IndicatorKind::Frequency => "frequency",
            IndicatorKind::Hysteresis => "hysteresis",
            IndicatorKind::ResidualDrift => "residual_drift",
            IndicatorKind::ChangeTest => "change_test",
        }
    }
    /// For sentences: "peak drift", "apparent frequency", …
    pub fn title(self) -> &'static str {
        match self {
            IndicatorKind::Drift => "peak drift",
            IndicatorKind::Frequency => "apparent frequency",
            IndicatorKind::Hysteresis => "hysteresis",
            IndicatorKind::ResidualDrift => "residual drift",
            IndicatorKind::ChangeTest => "subspace change test",
        }
    }
}

/// One indicator's verdict.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Indicator {
    pub kind: IndicatorKind,
    /// The rated value (drift ratio, frequency drop, ι, residual drift
    /// ratio, χ² statistic / threshold), or the value measured but not rated; `None` when there is none.
    pub value: Option<f64>,
    /// Where it was measured ("levels 0–2, X").
    pub subject: String,
    /// The damage state it indicates; `None`: not rated (see `verdict`).
    #[serde(serialize_with = "state_name")]
    pub state: Option<DamageState>,
    /// The verdict as a sentence: the state and what gives it, or "not
    /// rated: <reason>".
    pub verdict: String,
    /// The verdict rests on an assumption (an assumed storey height, a
    /// default building type).
    pub provisional: bool,
}

fn state_name<S: serde::Serializer>(s: &Option<DamageState>, ser: S) -> Result<S::Ok, S::Error> {
    match s {
        Some(v) => ser.serialize_str(v.name()),
        None => ser.serialize_none(),
    }
}

impl Indicator {
    pub fn not_rated(
        kind: IndicatorKind,
        value: Option<f64>,
        subject: String,
        why: String,
    ) -> Self {
        Indicator {
            kind,
            value,
            subject,
            state: None,
            verdict: format!("not rated: {why}"),
            provisional: false,
        }
    }
}

/// The assessment of one event: what the `assess` stage writes as one row
/// of `assessment/assessment.parquet`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Assessment {
    pub event: String,
    pub structure: Option<String>,
    /// `building`, `bridge` or `unknown`.
    pub structure_kind: String,
    pub overall: Overall,
    /// The drift fragility used (None: none applies).
    #[serde(skip)]
    pub fragility: Option<DriftFragility>,
    /// `stated`, `default` or `not applicable`.
    pub building_type_source: String,
    /// P(none) … P(complete) at the driving drift.
    pub probabilities: Option<[f64; 5]>,
    /// Drift, frequency, hysteresis, residual drift, and the change test
    /// when the run has a reference — in that order.
    pub indicators: Vec<Indicator>,
    /// The frequency evidence of the driving direction.
    #[serde(skip)]
    pub frequency: Option<indicators::FrequencyEvidence>,
    /// The change test against the reference run (None: no reference).
    #[serde(skip)]
    pub change_test: Option<change_test::ChangeTestEvidence>,
    pub assumptions: Vec<String>,
}

impl Assessment {
    /// The indicator of `kind`.
    pub fn indicator(&self, kind: IndicatorKind) -> Option<&Indicator> {
        self.indicators.iter().find(|i| i.kind == kind)
    }
}

/// The colour of a set of indicators and how sure it is.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Overall {
    /// `None`: NOT RATED (no indicator could be rated; `reason` says why).
    pub colour: Option<Colour>,
    pub priority: Option<&'static str>,
    /// The damage state that gives the colour.
    #[serde(serialize_with = "state_name")]
    pub state: Option<DamageState>,
    /// `corroborated` (two or more indicators reach the state), `single
    /// indicator` (one indicator alone goes beyond the others: inspect),
    /// `agreeing` (every rated indicator says none), `only one indicator
    /// rated`, or `not rated`.
    pub confidence: String,
    /// The indicators behind the colour, as sentences.
    pub drivers: Vec<String>,
    /// A rated indicator behind the colour rests on an assumption.
    pub provisional: bool,
    /// Why not rated, when not rated.
    pub reason: Option<String>,
}

/// The overall colour of `indicators` (module doc; docs/assessment.md):
/// 1. s₂ = the worst state reached by at least two rated indicators
///    (corroborated), s₁ = the worst state of any rated indicator;
/// 2. every rated indicator says none: GREEN;
/// 3. s₂ ≥ slight: colour(s₂) (an indicator beyond s₂ is named in the
///    confidence, not followed);
/// 4. s₂ = none < s₁, or only one indicator rated and it indicates damage:
///    YELLOW — "inspect" — with the lone indicator as the driver;
/// 5. no rated indicator: NOT RATED, with every indicator's reason.
pub fn combine(indicators: &[Indicator]) -> Overall {
    let rated: Vec<&Indicator> = indicators.iter().filter(|i| i.state.is_some()).collect();
    if rated.is_empty() {
        let why = indicators
            .iter()
            .map(|i| {
                format!(
                    "{}: {}",
                    i.kind.title(),
                    i.verdict.trim_start_matches("not rated: ")
                )
            })
            .collect::<Vec<_>>()
            .join("; ");
        return Overall {
            colour: None,
            priority: None,
            state: None,
            confidence: "not rated".into(),
            drivers: Vec::new(),
            provisional: false,
            reason: Some(if why.is_empty() {
                "no indicator could be evaluated".into()
            } else {
                format!("no indicator could be rated — {why}")
            }),
        };
    }
    let mut states: Vec<DamageState> = rated.iter().filter_map(|i| i.state).collect();
    states.sort_unstable_by(|a, b| b.cmp(a));
    let worst = states[0];
    let corroborated = states.get(1).copied();
    let describe = |i: &Indicator| {
        format!(
            "{}: {}{}",
            i.kind.title(),
            i.verdict,
            if i.provisional { " (provisional)" } else { "" }
        )
    };
    let reaching = |s: DamageState| -> Vec<&Indicator> {
        rated
            .iter()
            .copied()
            .filter(|i| i.state.is_some_and(|x| x >= s))
            .collect()
    };
    let (colour, state, confidence, behind) = match corroborated {
        // Two or more rated: the state at least two reach.
        Some(s2) => {
            let behind = if worst == DamageState::None {
                rated.clone()
            } else {
                reaching(s2.max(DamageState::Slight))
            };
            let k = reaching(s2).len();
            if worst == DamageState::None {
                (
                    Colour::Green,
                    DamageState::None,
                    "agreeing".to_string(),
                    behind,
                )
            } else if s2 == worst {
                (
                    Colour::of_state(s2),
                    s2,
                    format!("corroborated by {k} indicators"),
                    behind,
                )
            } else if s2 > DamageState::None {
                (
                    Colour::of_state(s2),
                    s2,
                    format!(
                        "corroborated by {k} indicators up to {}; one indicator alone reaches {}",
                        s2.name(),
                        worst.name()
                    ),
                    behind,
                )
            } else {
                // One indicator alone indicates damage: inspect.
                (
                    Colour::Yellow,
                    DamageState::Slight,
                    "single indicator".to_string(),
                    behind,
                )
            }
        }
        // One rated indicator: its "none", or "inspect" at most.
        None => {
            if worst == DamageState::None {
                (
                    Colour::Green,
                    DamageState::None,
                    "only one indicator rated".to_string(),
                    rated.clone(),
                )
            } else {
                (
                    Colour::Yellow,
                    DamageState::Slight,
                    "only one indicator rated".to_string(),
                    rated.clone(),
                )
            }
        }
    };
    let drivers = behind.iter().map(|i| describe(i)).collect();
    let provisional = behind.iter().any(|i| i.provisional);
    Overall {
        colour: Some(colour),
        priority: Some(colour.priority()),
        state: Some(state),
        confidence,
        drivers,
        provisional,
        reason: None,
    }
}
