use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// Physical units of a channel's stored values.  Everything downstream of
/// conditioning is in SI (m/s², m/s, m).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Units {
    MPerS2,
    CmPerS2,
    MmPerS2,
    G,
    /// Raw digitiser counts; `counts_per_si` converts to m/s² (StationXML
    /// InstrumentSensitivity, or the manifest's `sensitivity`).
    Counts {
        counts_per_si: Option<f64>,
    },
    /// Velocity and displacement (readers of V2/V3 files may carry them).
    MPerS,
    CmPerS,
    M,
    Cm,
}

impl Units {
    /// Factor that converts a value in these units to SI (m/s², m/s or m).
    /// `None` for counts without a known sensitivity.
    pub fn to_si_factor(&self) -> Option<f64> {
        Some(match self {
            Units::MPerS2 | Units::MPerS | Units::M => 1.0,
            Units::CmPerS2 | Units::CmPerS | Units::Cm => 0.01,
            Units::MmPerS2 => 0.001,
            Units::G => super::STANDARD_GRAVITY,
            Units::Counts { counts_per_si } => return counts_per_si.map(|s| 1.0 / s),
        })
    }
    pub fn is_acceleration(&self) -> bool {
        matches!(
            self,
            Units::MPerS2 | Units::CmPerS2 | Units::MmPerS2 | Units::G | Units::Counts { .. }
        )
    }
    /// Canonical short name, used in Parquet and manifests.
    pub fn name(&self) -> &'static str {
        match self {
            Units::MPerS2 => "m/s2",
            Units::CmPerS2 => "cm/s2",
            Units::MmPerS2 => "mm/s2",
            Units::G => "g",
            Units::Counts { .. } => "counts",
            Units::MPerS => "m/s",
            Units::CmPerS => "cm/s",
            Units::M => "m",
            Units::Cm => "cm",
        }
    }
}

impl fmt::Display for Units {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Units {
    type Err = String;
    /// Accepts the spellings seen in manifests and file headers
    /// (`m/s2`, `m/s^2`, `m/s/s`, `cm/sec2`, `CM/SEC/SEC`, `gal`, `mm/s/s`, `g`, `counts`…).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let k: String = s
            .trim()
            .to_ascii_lowercase()
            .chars()
            .filter(|c| !c.is_whitespace() && *c != '^' && *c != '*' && *c != '²')
            .collect();
        let k = k.replace("sec", "s").replace("/s/s", "/s2");
        Ok(match k.as_str() {
            "m/s2" | "ms-2" | "mps2" => Units::MPerS2,
            "cm/s2" | "gal" | "cms-2" => Units::CmPerS2,
            "mm/s2" | "mms-2" => Units::MmPerS2,
            "g" | "gs" => Units::G,
            "counts" | "count" | "counts(raw)" | "raw" => Units::Counts {
                counts_per_si: None,
            },
            "m/s" => Units::MPerS,
            "cm/s" => Units::CmPerS,
            "m" => Units::M,
            "cm" => Units::Cm,
            _ => {
                return Err(format!(
                    "unknown units {s:?} (expected m/s2, g, cm/s2, mm/s2 or counts)"
                ))
            }
        })
    }
}
