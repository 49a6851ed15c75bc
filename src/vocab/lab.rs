//! Laboratory records (issue 37): channels of quantities beyond acceleration
//! — displacement, force, strain, actuator command — with their units and
//! roles, and the time base of a test protocol (a uniform rate, stamped
//! times, or only the step index of a quasi-static protocol). No I/O.

use serde::Serialize;
use std::fmt;

use super::SourceRef;

/// What a lab channel measures (or commands).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Quantity {
    Acceleration,
    Velocity,
    Displacement,
    Force,
    Strain,
}

impl Quantity {
    pub fn name(&self) -> &'static str {
        match self {
            Quantity::Acceleration => "acceleration",
            Quantity::Velocity => "velocity",
            Quantity::Displacement => "displacement",
            Quantity::Force => "force",
            Quantity::Strain => "strain",
        }
    }
    pub fn parse(s: &str) -> Option<Quantity> {
        Some(match s.trim().to_ascii_lowercase().as_str() {
            "acceleration" => Quantity::Acceleration,
            "velocity" => Quantity::Velocity,
            "displacement" => Quantity::Displacement,
            "force" => Quantity::Force,
            "strain" => Quantity::Strain,
            _ => return None,
        })
    }
    /// The SI unit values are converted to.
    pub fn si_unit(&self) -> &'static str {
        match self {
            Quantity::Acceleration => "m/s2",
            Quantity::Velocity => "m/s",
            Quantity::Displacement => "m",
            Quantity::Force => "N",
            Quantity::Strain => "1",
        }
    }
}

impl fmt::Display for Quantity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The units a lab channel may be stated in: the quantity they measure and
/// the factor to SI. Spellings are case-sensitive where case matters
/// (`mm` vs `Mm` is not accepted: `MN` is the only mega).
pub fn lab_units(s: &str) -> Option<(Quantity, f64)> {
    use Quantity::*;
    const INCH: f64 = 0.0254;
    const POUND_FORCE: f64 = 4.448_221_615_260_5;
    let k = s.trim();
    Some(match k {
        "m" => (Displacement, 1.0),
        "cm" => (Displacement, 0.01),
        "mm" => (Displacement, 1e-3),
        "um" | "µm" => (Displacement, 1e-6),
        "in" | "inch" | "inches" => (Displacement, INCH),
        "ft" => (Displacement, 0.3048),
        "N" => (Force, 1.0),
        "kN" | "KN" | "kn" => (Force, 1e3),
        "MN" => (Force, 1e6),
        "lb" | "lbf" | "lbs" => (Force, POUND_FORCE),
        "kip" | "kips" | "kipf" => (Force, 1e3 * POUND_FORCE),
        "strain" | "m/m" | "mm/mm" | "1" => (Strain, 1.0),
        "microstrain" | "ustrain" | "µε" | "ue" => (Strain, 1e-6),
        "m/s" => (Velocity, 1.0),
        "mm/s" => (Velocity, 1e-3),
        "in/s" => (Velocity, INCH),
        "m/s2" | "m/s^2" => (Acceleration, 1.0),
        "g" => (Acceleration, super::STANDARD_GRAVITY),
        _ => return None,
    })
}

/// Command (what the controller asked for) or measured (what the sensor saw).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum LabRole {
    Command,
    #[default]
    Measured,
}

impl LabRole {
    pub fn name(&self) -> &'static str {
        match self {
            LabRole::Command => "command",
            LabRole::Measured => "measured",
        }
    }
    pub fn parse(s: &str) -> Option<LabRole> {
        match s {
            "command" => Some(LabRole::Command),
            "measured" => Some(LabRole::Measured),
            _ => None,
        }
    }
}

/// One lab channel; its values (in SI) are in [`LabRecord::values`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LabChannel {
    pub id: String,
    pub quantity: Quantity,
    pub role: LabRole,
    /// The units as stated (or inferred), and the factor applied to SI.
    pub units: String,
    pub to_si: f64,
    /// The actuator (or load cell) it belongs to, when several.
    pub actuator: Option<String>,
    pub source: SourceRef,
}

/// How the samples of a lab record are ordered in time.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum TimeBase {
    /// Uniform sampling at `dt_s`.
    Uniform { dt_s: f64 },
    /// Each sample has its own time (s), strictly increasing.
    Stamped,
    /// No time: a quasi-static protocol, the step index orders the samples.
    StepIndex,
}

/// A laboratory record: channels of equal length in SI units.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LabRecord {
    pub name: String,
    pub channels: Vec<LabChannel>,
    #[serde(skip)]
    pub values: Vec<Vec<f64>>,
    pub time_base: TimeBase,
    /// Times (s) of a uniform or stamped record; None for a step index.
    #[serde(skip)]
    pub time_s: Option<Vec<f64>>,
    /// What was inferred rather than stated, and how.
    pub inferred: Vec<String>,
}

impl LabRecord {
    pub fn len(&self) -> usize {
        self.values.first().map_or(0, Vec::len)
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The first channel of `quantity` and `role` (and `actuator` when given).
    pub fn find(&self, quantity: Quantity, role: LabRole, actuator: Option<&str>) -> Option<usize> {
        self.channels.iter().position(|c| {
            c.quantity == quantity
                && c.role == role
                && actuator.is_none_or(|a| c.actuator.as_deref() == Some(a))
        })
    }
}
