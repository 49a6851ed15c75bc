//! Drift fragility of model building types: the probability of each damage
//! state given a storey's peak drift ratio, from lognormal fragility curves
//!   P(DS ≥ ds | θ) = Φ( ln(θ / θ̂_ds) / β ),
//! P(none) = 1 − P(DS ≥ slight), P(ds) = P(DS ≥ ds) − P(DS ≥ ds+1),
//! P(complete) = P(DS ≥ complete).
//!
//! Medians θ̂_ds: the inter-storey drift ratios at the thresholds of the
//! slight, moderate, extensive and complete structural damage states of the
//! HAZUS-MH MR5 Earthquake Model Technical Manual (FEMA, 2010), Tables
//! 5.9a–d, per model building type and seismic design level (high, moderate,
//! low and pre-code), low-rise values, to three decimals as USGS ShakeCast's
//! Advanced Engineering Building Module tabulates them.  The low-rise values
//! are used for every height: HAZUS's smaller mid- and high-rise values are
//! drifts averaged over the building's height (the roof drift of its
//! pushover), which a measured storey drift is not.
//! β = 0.4: HAZUS's variability of the damage-state threshold (Technical
//! Manual §5.4.3.1, β_M(ds) = 0.4 for every structural damage state); the
//! demand variability of HAZUS's spectral fragilities does not apply to a
//! measured drift.
//!
//! EMS-98 (Grünthal, 1998) damage grades, for masonry and concrete: the
//! states map to grades 1 (slight), 2 (moderate), 3 (extensive, "substantial
//! to heavy") and 4–5 (complete: "very heavy" or destruction, which drift
//! alone does not tell apart).  I/O free.

use std::fmt;

use crate::stats::standard_normal_cdf;

/// Lognormal dispersion of every drift fragility (module doc).
pub const DRIFT_FRAGILITY_BETA: f64 = 0.4;

/// Structural damage state (HAZUS), from best to worst.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum DamageState {
    None,
    Slight,
    Moderate,
    Extensive,
    Complete,
}

impl DamageState {
    pub const ALL: [DamageState; 5] = [
        DamageState::None,
        DamageState::Slight,
        DamageState::Moderate,
        DamageState::Extensive,
        DamageState::Complete,
    ];
    pub fn name(self) -> &'static str {
        match self {
            DamageState::None => "none",
            DamageState::Slight => "slight",
            DamageState::Moderate => "moderate",
            DamageState::Extensive => "extensive",
            DamageState::Complete => "complete",
        }
    }
    /// EMS-98 damage grade (module doc): "0" for none, "4–5" for complete.
    pub fn ems98_grade(self) -> &'static str {
        match self {
            DamageState::None => "0",
            DamageState::Slight => "1",
            DamageState::Moderate => "2",
            DamageState::Extensive => "3",
            DamageState::Complete => "4–5",
        }
    }
    /// The state whose threshold `value` reaches, for ascending thresholds
    /// of slight, moderate, extensive and complete.
    pub fn reached(value: f64, thresholds: [f64; 4]) -> DamageState {
        let n = thresholds.iter().filter(|&&t| value >= t).count();
        DamageState::ALL[n]
    }
}

impl fmt::Display for DamageState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Seismic design level of HAZUS (the code the building was designed to).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DesignLevel {
    High,
    Moderate,
    Low,
    Pre,
}

impl DesignLevel {
    pub fn name(self) -> &'static str {
        match self {
            DesignLevel::High => "high",
            DesignLevel::Moderate => "moderate",
            DesignLevel::Low => "low",
            DesignLevel::Pre => "pre",
        }
    }
    /// "high", "moderate", "low", "pre" (also "pre-code", "high-code", …).
    pub fn parse(text: &str) -> Option<DesignLevel> {
        let t = text.trim().to_ascii_lowercase();
        let t = t
            .trim_end_matches("-code")
            .trim_end_matches(" code")
            .trim_end_matches("_code");
        match t {
            "high" => Some(DesignLevel::High),
            "moderate" => Some(DesignLevel::Moderate),
            "low" => Some(DesignLevel::Low),
            "pre" => Some(DesignLevel::Pre),
            _ => None,
        }
    }
}

/// HAZUS model building types with a drift fragility (W1A counts as W1).
pub const BUILDING_TYPES: &[(&str, &str)] = &[
    ("W1", "wood, light frame"),
    ("W2", "wood, commercial and industrial"),
    ("S1", "steel moment frame"),
    ("S2", "steel braced frame"),
    ("S3", "steel light frame"),
    ("S4", "steel frame with cast-in-place concrete shear walls"),
    ("S5", "steel frame with unreinforced masonry infill walls"),
    ("C1", "concrete moment frame"),
    ("C2", "concrete shear walls"),
    (
        "C3",
        "concrete frame with unreinforced masonry infill walls",
    ),
    ("PC1", "precast concrete tilt-up walls"),
    ("PC2", "precast concrete frames with concrete shear walls"),
    (
        "RM1",
        "reinforced masonry bearing walls with wood or metal deck diaphragms",
    ),
    (
        "RM2",
        "reinforced masonry bearing walls with precast concrete diaphragms",
    ),
    ("URM", "unreinforced masonry bearing walls"),
    ("MH", "mobile homes"),
];

/// The stated default when the building type is not stated (or unknown):
/// a concrete moment frame of moderate code, the commonest instrumented
/// building; the drift verdict is then provisional.
pub const DEFAULT_TYPE: &str = "C1";
pub const DEFAULT_DESIGN_LEVEL: DesignLevel = DesignLevel::Moderate;

/// One drift fragility: the building type and design level it is for, and
/// the median drift ratios of slight, moderate, extensive and complete.
#[derive(Debug, Clone, PartialEq)]
pub struct DriftFragility {
    pub building_type: &'static str,
    pub design_level: DesignLevel,
    pub medians: [f64; 4],
    pub beta: f64,
}

/// A type as written in event.toml, read: its HAZUS code, and what was
/// dropped (a height suffix) or not recognised.
#[derive(Debug, Clone, PartialEq)]
pub struct TypeReading {
    /// The recognised code, `None` when the text is not a HAZUS type.
    pub code: Option<&'static str>,
    pub note: Option<String>,
}

/// Reads a HAZUS code such as "C1", "C1M", "URML", "W1A" (case-insensitive).
/// A height-class suffix (L, M, H) is dropped with a note: the fragility is
/// per storey (module doc).
pub fn read_type(text: &str) -> TypeReading {
    let t = text.trim().to_ascii_uppercase();
    let exact = |s: &str| BUILDING_TYPES.iter().map(|(c, _)| *c).find(|c| *c == s);
    if let Some(code) = exact(&t) {
        return TypeReading {
            code: Some(code),
            note: None,
        };
    }
    if t == "W1A" {
        return TypeReading {
            code: Some("W1"),
            note: Some("type W1A read as W1 (same drift fragility)".into()),
        };
    }
    for suffix in ["L", "M", "H"] {
        if let Some(code) = t.strip_suffix(suffix).and_then(exact) {
            return TypeReading {
                code: Some(code),
                note: Some(format!(
                    "type {t} read as {code}: the height class does not change a storey's drift fragility (docs/assessment.md)"
                )),
            };
        }
    }
    TypeReading {
        code: None,
        note: Some(format!(
            "type {:?} is not a HAZUS model building type ({})",
            text.trim(),
            BUILDING_TYPES
                .iter()
                .map(|(c, _)| *c)
                .collect::<Vec<_>>()
                .join(", ")
        )),
    }
}

impl DriftFragility {
    /// The fragility of a recognised HAZUS `code` (see [`read_type`]) at `level`.
    pub fn of(code: &str, level: DesignLevel) -> Option<DriftFragility> {
        use DesignLevel::*;
        let code = BUILDING_TYPES
            .iter()
            .map(|(c, _)| *c)
            .find(|c| *c == code)?;
        // HAZUS-MH MR5 Tables 5.9a–d, low-rise (module doc).
        let medians = match (code, level) {
            ("C1", High) => [0.005, 0.010, 0.030, 0.080],
            ("C1", Moderate) => [0.005, 0.009, 0.023, 0.060],
            ("C1", Low) => [0.005, 0.008, 0.020, 0.050],
            ("C1", Pre) => [0.004, 0.006, 0.016, 0.040],
            ("C2", High) => [0.004, 0.010, 0.030, 0.080],
            ("C2", Moderate) => [0.004, 0.008, 0.023, 0.060],
            ("C2", Low) => [0.004, 0.008, 0.020, 0.050],
            ("C2", Pre) => [0.003, 0.006, 0.016, 0.040],
            ("S1", High) => [0.006, 0.012, 0.030, 0.080],
            ("S1", Moderate) => [0.006, 0.010, 0.024, 0.060],
            ("S1", Low) => [0.006, 0.010, 0.020, 0.050],
            ("S1", Pre) => [0.005, 0.008, 0.016, 0.040],
            ("S2", High) => [0.005, 0.010, 0.030, 0.080],
            ("S2", Moderate) => [0.005, 0.009, 0.023, 0.060],
            ("S2", Low) => [0.005, 0.008, 0.020, 0.050],
            ("S2", Pre) => [0.004, 0.006, 0.016, 0.040],
            ("S3" | "S4" | "PC1" | "PC2" | "RM1" | "RM2", High) => [0.004, 0.008, 0.024, 0.070],
            ("S3" | "S4" | "PC1" | "PC2" | "RM1" | "RM2", Moderate) => [0.004, 0.007, 0.019, 0.053],
            ("S3" | "S4" | "PC1" | "PC2" | "RM1" | "RM2", Low) => [0.004, 0.006, 0.016, 0.044],
            ("S3" | "S4" | "PC1" | "PC2" | "RM1" | "RM2", Pre) => [0.003, 0.005, 0.013, 0.035],
            ("C3" | "S5" | "URM", High | Moderate | Low) => [0.003, 0.006, 0.015, 0.035],
            ("C3" | "S5" | "URM", Pre) => [0.002, 0.005, 0.012, 0.028],
            ("W1" | "W2", High) => [0.004, 0.012, 0.040, 0.100],
            ("W1" | "W2", Moderate) => [0.004, 0.010, 0.031, 0.075],
            ("W1" | "W2", Low) => [0.004, 0.010, 0.025, 0.060],
            ("W1" | "W2", Pre) => [0.003, 0.008, 0.020, 0.050],
            ("MH", _) => [0.004, 0.012, 0.040, 0.100],
            _ => return None,
        };
        Some(DriftFragility {
            building_type: code,
            design_level: level,
            medians,
            beta: DRIFT_FRAGILITY_BETA,
        })
    }

    /// P(none), P(slight), P(moderate), P(extensive), P(complete) at the
    /// drift ratio `drift` (module doc); `None` for a negative or non-finite drift.
    pub fn probabilities(&self, drift: f64) -> Option<[f64; 5]> {
        if !(drift.is_finite() && drift >= 0.0) {
            return None;
        }
        let exceed = |median: f64| {
            if drift == 0.0 {
                0.0
            } else {
                standard_normal_cdf((drift / median).ln() / self.beta)
            }
        };
        let e: Vec<f64> = self.medians.iter().map(|&m| exceed(m)).collect();
        Some([1.0 - e[0], e[0] - e[1], e[1] - e[2], e[2] - e[3], e[3]])
    }

    /// The most probable damage state at `drift` (ties: the worse).
    pub fn most_likely(&self, drift: f64) -> Option<DamageState> {
        let p = self.probabilities(drift)?;
        let mut best = 0;
        for (i, v) in p.iter().enumerate() {
            if *v >= p[best] {
                best = i;
            }
        }
        Some(DamageState::ALL[best])
    }

    /// "C1, moderate code (HAZUS-MH Table 5.9)", for notes.
    pub fn describe(&self) -> String {
        format!(
            "{} ({}), {} code: medians {:.3} / {:.3} / {:.3} / {:.3}, β = {}",
            self.building_type,
            BUILDING_TYPES
                .iter()
                .find(|(c, _)| *c == self.building_type)
                .map(|(_, d)| *d)
                .unwrap_or(""),
            self.design_level.name(),
            self.medians[0],
            self.medians[1],
            self.medians[2],
            self.medians[3],
            self.beta
        )
    }
}
