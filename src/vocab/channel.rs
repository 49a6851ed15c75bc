use serde::{Deserialize, Serialize};
use std::fmt;

use super::Units;

/// Building axes after orientation normalisation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Axis {
    X,
    Y,
    Z,
}

/// Sensing direction as recorded: a building axis, or a horizontal azimuth in
/// degrees clockwise from north (0 = N, 90 = E), or vertical.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Direction {
    Axis(Axis),
    Azimuth(f64),
    /// Vertical, positive up.
    Up,
    /// Vertical, positive down (e.g. StationXML dip = +90).
    Down,
}

impl Direction {
    /// Parses `X`, `Y`, `Z`, `UP`, `DOWN`, `V`, `360`, `270 DEG`, `N`, `E`, `S16W`…
    pub fn parse(s: &str) -> Option<Direction> {
        let t = s.trim().to_ascii_uppercase();
        let t = t.trim_end_matches("DEG").trim_end_matches("DEGREES").trim();
        match t {
            "X" => return Some(Direction::Axis(Axis::X)),
            "Y" => return Some(Direction::Axis(Axis::Y)),
            "Z" => return Some(Direction::Axis(Axis::Z)),
            "UP" | "V" | "VERT" | "VERTICAL" => return Some(Direction::Up),
            "DOWN" => return Some(Direction::Down),
            "N" => return Some(Direction::Azimuth(0.0)),
            "E" => return Some(Direction::Azimuth(90.0)),
            "S" => return Some(Direction::Azimuth(180.0)),
            "W" => return Some(Direction::Azimuth(270.0)),
            _ => {}
        }
        if let Ok(a) = t.parse::<f64>() {
            if a.is_finite() {
                return Some(Direction::Azimuth(a.rem_euclid(360.0)));
            }
        }
        // Quadrant bearings such as S16W, N74E.
        let b = t.as_bytes();
        if b.len() >= 3 && matches!(b[0], b'N' | b'S') && matches!(b[b.len() - 1], b'E' | b'W') {
            if let Ok(angle) = t[1..t.len() - 1].parse::<f64>() {
                let az = match (b[0], b[b.len() - 1]) {
                    (b'N', b'E') => angle,
                    (b'N', b'W') => 360.0 - angle,
                    (b'S', b'E') => 180.0 - angle,
                    _ => 180.0 + angle, // S..W
                };
                return Some(Direction::Azimuth(az.rem_euclid(360.0)));
            }
        }
        None
    }
    pub fn is_vertical(&self) -> bool {
        matches!(
            self,
            Direction::Up | Direction::Down | Direction::Axis(Axis::Z)
        )
    }
}

impl fmt::Display for Direction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Direction::Axis(a) => write!(f, "{a:?}"),
            Direction::Azimuth(az) => write!(f, "{az}deg"),
            Direction::Up => f.write_str("UP"),
            Direction::Down => f.write_str("DOWN"),
        }
    }
}

/// Whether a channel is an excitation (base/ground motion) or a structural response.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    Input,
    Output,
    #[default]
    Unknown,
}

impl Role {
    pub fn name(&self) -> &'static str {
        match self {
            Role::Input => "input",
            Role::Output => "output",
            Role::Unknown => "unknown",
        }
    }
}

/// Quality flags raised by readers and conditioning.  Each carries enough to
/// act on it (where, how much).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "flag", rename_all = "snake_case")]
pub enum QaFlag {
    /// Samples at (or within a hair of) the extreme value for a run.
    Clipping { samples: usize, level: f64 },
    /// Missing time span (seconds) starting at `at_s`.
    Gap { at_s: f64, duration_s: f64 },
    /// Constant run of samples.
    FlatSegment { at_s: f64, duration_s: f64 },
    /// Non-finite values found (they are never passed downstream silently).
    NonFinite { count: usize },
    /// Isolated outliers against the local robust scale.
    Spikes { count: usize },
    /// Signal-to-noise ratio against pre-event noise, dB.
    LowSnr { snr_db: f64 },
    /// The reader resampled uneven (time, value) pairs onto a uniform grid.
    Resampled { from: String },
    /// Free-text warning from a reader (e.g. extra values after the declared count).
    Note { text: String },
}

impl QaFlag {
    /// Short code for tables.
    pub fn code(&self) -> &'static str {
        match self {
            QaFlag::Clipping { .. } => "clipping",
            QaFlag::Gap { .. } => "gap",
            QaFlag::FlatSegment { .. } => "flat",
            QaFlag::NonFinite { .. } => "nan",
            QaFlag::Spikes { .. } => "spikes",
            QaFlag::LowSnr { .. } => "low_snr",
            QaFlag::Resampled { .. } => "resampled",
            QaFlag::Note { .. } => "note",
        }
    }
}

/// Where a channel's samples came from: file, zip member path, column.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct SourceRef {
    /// Path of the file as given (relative to the event folder when inside it).
    pub file: String,
    /// Zip member path; nested zips joined with `:` (`Structure.zip:CHAN1.V2`).
    pub member: Option<String>,
    /// Column name or index for multi-column files; component index for
    /// multi-channel files.
    pub column: Option<String>,
    /// Format the reader recognised (`cosmos`, `dmg`, `smc`, `at2`, `mseed`, `sac`, `v2a`, `csv`, `mcap`).
    pub format: String,
}

impl fmt::Display for SourceRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if let Some(m) = &self.member {
            write!(f, ":{m}")?;
        }
        if let Some(c) = &self.column {
            write!(f, "[{c}]")?;
        }
        Ok(())
    }
}

/// One sensor axis and everything known about it.  Readers fill what the
/// file says; the manifest overrides; `inferred` lists what was guessed and
/// `missing` what later stages will lack.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Channel {
    /// Unique within the event (manifest id, or built from the header).
    pub id: String,
    pub network: Option<String>,
    pub station: Option<String>,
    /// SEED location code, or CSMIP station channel number.
    pub location_code: Option<String>,
    /// SEED channel code (HNE…) or the recorder channel label.
    pub channel_code: Option<String>,
    /// Free-text sensor location from the header ("DECK: MIDDLE OF BRIDGE").
    pub location_text: Option<String>,
    /// Level index: 0 = base/ground, 1..n floors.
    pub level: Option<i32>,
    /// FE node of the digital twin the sensor sits on.
    pub node: Option<String>,
    pub elevation_m: Option<f64>,
    pub direction: Option<Direction>,
    /// Dip in degrees (StationXML convention, −90 = up).
    pub dip_deg: Option<f64>,
    pub role: Role,
    /// Units of the values as read (before conditioning).
    pub units: Units,
    pub sampling_rate_hz: f64,
    /// Start time, nanoseconds since the Unix epoch (UTC), when known.
    pub start_ns: Option<i64>,
    /// Multiplier already applied or to apply (sensitivity, gain); informative.
    pub calibration: Option<f64>,
    pub source: SourceRef,
    /// Position on the floor plan in building axes (X, Y), metres, when
    /// stated: used by the rigid-floor combination (floor rotation).
    #[serde(default)]
    pub position_m: Option<[f64; 2]>,
    /// For a floor motion formed by the rigid-floor combination: the ids of
    /// the sensor channels it was formed from (empty for a sensor channel).
    #[serde(default)]
    pub combines: Vec<String>,
    /// For a sensor channel that entered a floor motion: that floor's id.
    #[serde(default)]
    pub combined_into: Option<String>,
    pub qa: Vec<QaFlag>,
    /// Fields that were inferred rather than read, with how ("role=input from level 0").
    pub inferred: Vec<String>,
    /// What later stages need and nobody said ("level", "role", "masses").
    pub missing: Vec<String>,
}

impl Channel {
    /// A channel with only the essentials; everything else unknown.
    pub fn new(
        id: impl Into<String>,
        units: Units,
        sampling_rate_hz: f64,
        source: SourceRef,
    ) -> Self {
        Channel {
            id: id.into(),
            network: None,
            station: None,
            location_code: None,
            channel_code: None,
            location_text: None,
            level: None,
            node: None,
            elevation_m: None,
            direction: None,
            dip_deg: None,
            role: Role::Unknown,
            units,
            sampling_rate_hz,
            start_ns: None,
            calibration: None,
            source,
            position_m: None,
            combines: Vec::new(),
            combined_into: None,
            qa: Vec::new(),
            inferred: Vec::new(),
            missing: Vec::new(),
        }
    }
    pub fn dt(&self) -> f64 {
        1.0 / self.sampling_rate_hz
    }
    /// A floor motion formed from several sensors (rigid-floor combination).
    pub fn is_floor_motion(&self) -> bool {
        !self.combines.is_empty()
    }
    /// The building axis the channel measures along, once the geometry has
    /// been applied (`Z` for vertical channels).
    pub fn axis(&self) -> Option<Axis> {
        match self.direction? {
            Direction::Axis(a) => Some(a),
            Direction::Up | Direction::Down => Some(Axis::Z),
            Direction::Azimuth(_) => None,
        }
    }
}

/// The recording station most of the channels give, `NETWORK.STATION` (or
/// `STATION` without a network code); ties go to the first in name order.
/// What names an instrumented structure when nothing else does (a network's
/// zip without `event.toml`): the dataset's partition and the history's
/// grouping both use it.
pub fn most_common_station<'a>(
    channels: impl Iterator<Item = (Option<&'a str>, Option<&'a str>)>,
) -> Option<String> {
    let mut counts: std::collections::BTreeMap<String, usize> = Default::default();
    for (network, station) in channels {
        let station = match (network.map(str::trim), station.map(str::trim)) {
            (_, None) | (_, Some("")) => continue,
            (Some(n), Some(s)) if !n.is_empty() => format!("{n}.{s}"),
            (_, Some(s)) => s.to_string(),
        };
        *counts.entry(station).or_default() += 1;
    }
    let most = counts.values().copied().max()?;
    counts.into_iter().find(|(_, n)| *n == most).map(|(s, _)| s)
}
