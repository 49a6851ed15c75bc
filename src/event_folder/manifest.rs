//! `event.toml`: the user's statement of what the files are.  It is a user
//! contract documented in docs/event-folder.md; unknown keys are errors so a
//! typo never silently drops a setting.

use serde::Deserialize;

use crate::error::{Error, Location, Result};
use crate::readers::Format;
use crate::vocab::{Direction, Role, Structure, Units};

/// Smallest storey height accepted, metres (a smaller one is a unit slip or
/// nonsense that would give absurd drift ratios).
pub const MIN_STOREY_HEIGHT_M: f64 = 0.5;

/// Origin times accepted (years), so a typo never wraps into another century.
pub const ORIGIN_YEARS: std::ops::RangeInclusive<i64> = 1900..=2100;

/// Largest `event.toml` read, bytes: checked before it is read or parsed (a
/// manifest of a 100-channel building is tens of kB; `init` writes about
/// 400 bytes per channel, so [`MAX_CHANNELS`] fit with room).
pub const MAX_MANIFEST_BYTES: u64 = 4 << 20;

/// Most `[[channel]]` entries a manifest may list (a large instrumented
/// structure has a few hundred channels).
pub const MAX_CHANNELS: usize = 4096;

/// Storey heights accepted, metres (a smaller one is a unit slip or
/// nonsense that would give absurd drift ratios; no storey is 100 m tall).
pub const STOREY_HEIGHT_M: std::ops::RangeInclusive<f64> = MIN_STOREY_HEIGHT_M..=100.0;

/// Mass of one level accepted, kg (a light timber floor is a few tonnes, the
/// heaviest building floors or bridge segments ~10⁸ kg).
pub const LEVEL_MASS_KG: std::ops::RangeInclusive<f64> = 1.0..=1e10;

/// Sampling rates accepted, Hz (no strong-motion or structural record is
/// sampled below 0.1 Hz or above 100 kHz).
pub const SAMPLING_RATE_HZ: std::ops::RangeInclusive<f64> = 0.1..=100_000.0;

/// Magnitude of a sensitivity accepted, counts per m/s² (a 1 V/g analog
/// channel is ~0.1, a 24-bit digitiser ~10⁶; a sign states the polarity).
/// Outside, one count would be more than 100 g, or less than 10⁻¹² m/s².
pub const SENSITIVITY_COUNTS_PER_MS2: std::ops::RangeInclusive<f64> = 1e-3..=1e12;

/// Highest level accepted (levels run 0 = base to the top floor; a
/// structure has at most 300 storeys, as `structure.storeys`).
pub const MAX_LEVEL: i32 = 300;

/// Elevations accepted, metres (the deepest trench to above the highest peak).
pub const ELEVATION_M: std::ops::RangeInclusive<f64> = -12_000.0..=9_000.0;

/// Largest plan coordinate accepted (`position_m`, `centre_of_mass_m`), metres.
pub const MAX_PLAN_COORDINATE_M: f64 = 100_000.0;

/// Magnitudes accepted.
pub const MAGNITUDE: std::ops::RangeInclusive<f64> = -3.0..=10.0;

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    #[serde(default)]
    pub event: EventSection,
    pub structure: Option<StructureSection>,
    #[serde(default, rename = "channel")]
    pub channels: Vec<ChannelEntry>,
    /// A laboratory record (docs/lab-tests.md).
    pub lab: Option<super::lab::LabSection>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EventSection {
    /// A stable id of the event (a network's event id): its `event=`
    /// partition in a many-event dataset, instead of the folder's name.
    pub id: Option<String>,
    pub name: Option<String>,
    /// ISO-8601 UTC origin time.
    pub origin_time: Option<String>,
    pub magnitude: Option<f64>,
    /// Free text.
    pub description: Option<String>,
    /// Epicentre (WGS 84 degrees, north and east positive): with the
    /// structure's position, the report's epicentral distance.
    pub latitude_deg: Option<f64>,
    pub longitude_deg: Option<f64>,
    /// Depth of the hypocentre, km.
    pub depth_km: Option<f64>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StructureSection {
    /// A stable id of the structure (the owner's asset number, a station
    /// code): its `structure=` partition in a many-event dataset instead of
    /// its name, and the report's title block.
    pub id: Option<String>,
    pub name: Option<String>,
    /// Postal address or place: the report's title block.
    pub address: Option<String>,
    #[serde(default)]
    pub storey_heights_m: Vec<f64>,
    #[serde(default)]
    pub masses_kg: Vec<f64>,
    /// Digital-twin file relative to the event folder.
    pub twin: Option<String>,
    /// Azimuth (degrees clockwise from north) of the building X axis; used to
    /// rotate azimuth-labelled sensors to building axes.
    pub x_axis_azimuth_deg: Option<f64>,
    /// Plan position (X, Y, metres) of the floors' centre of mass: the
    /// reference point of the rigid-floor combination.
    pub centre_of_mass_m: Option<[f64; 2]>,
    /// Number of storeys above the base (the roof is level `storeys`).
    pub storeys: Option<u32>,
    /// Total height above the base, metres.
    pub height_m: Option<f64>,
    /// Model building type (HAZUS code: "C1", "S1", "W1", "URM", …).
    #[serde(rename = "type")]
    pub building_type: Option<String>,
    /// HAZUS seismic design level: "high", "moderate", "low" or "pre".
    pub design_level: Option<String>,
    /// "building", "bridge", …
    pub kind: Option<String>,
    /// Geographic position of the structure (WGS 84 degrees, north and
    /// east positive): the fleet dashboard's map.
    pub latitude_deg: Option<f64>,
    pub longitude_deg: Option<f64>,
}

impl StructureSection {
    pub fn to_structure(&self) -> Structure {
        Structure {
            name: self.name.clone(),
            id: self.id.clone(),
            address: self.address.clone(),
            storey_heights_m: self.storey_heights_m.clone(),
            masses_kg: self.masses_kg.clone(),
            twin: self.twin.clone(),
            x_axis_azimuth_deg: self.x_axis_azimuth_deg,
            centre_of_mass_m: self.centre_of_mass_m,
            storeys: self.storeys,
            height_m: self.height_m.or_else(|| {
                (!self.storey_heights_m.is_empty()).then(|| self.storey_heights_m.iter().sum())
            }),
            building_type: self.building_type.clone(),
            design_level: self.design_level.clone(),
            kind: self.kind.clone(),
            latitude_deg: self.latitude_deg,
            longitude_deg: self.longitude_deg,
            inferred: Vec::new(),
        }
    }
}

/// A column may be named or given as a 0-based index.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum ColumnRef {
    Index(usize),
    Name(String),
}

impl ColumnRef {
    pub fn as_string(&self) -> String {
        match self {
            ColumnRef::Index(i) => i.to_string(),
            ColumnRef::Name(s) => s.clone(),
        }
    }
}

/// Direction as the manifest writes it: `"X"`, `"Y"`, `"Z"`, `"UP"` or an azimuth number.
#[derive(Deserialize)]
#[serde(untagged)]
enum DirectionValue {
    Azimuth(f64),
    Label(String),
}

/// A channel direction, parsed when the manifest is read.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(try_from = "DirectionValue")]
pub struct DirectionEntry(pub Direction);

impl TryFrom<DirectionValue> for DirectionEntry {
    type Error = String;
    fn try_from(v: DirectionValue) -> std::result::Result<Self, String> {
        match v {
            DirectionValue::Azimuth(a) if a.is_finite() => {
                Ok(DirectionEntry(Direction::Azimuth(a.rem_euclid(360.0))))
            }
            DirectionValue::Azimuth(a) => Err(format!("direction {a} is not a finite azimuth")),
            DirectionValue::Label(d) => Direction::parse(&d)
                .map(DirectionEntry)
                .ok_or_else(|| format!("direction {d:?} is not X, Y, Z, UP or an azimuth")),
        }
    }
}

/// Units as the manifest writes them, parsed when it is read (the spelling
/// is kept for the inventory's "inferred" note).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(try_from = "String")]
pub struct UnitsEntry {
    pub units: Units,
    pub written: String,
}

impl TryFrom<String> for UnitsEntry {
    type Error = String;
    fn try_from(written: String) -> std::result::Result<Self, String> {
        Ok(UnitsEntry {
            units: written.parse::<Units>()?,
            written,
        })
    }
}

/// A reader named by the manifest, checked when it is read.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(try_from = "String")]
pub struct FormatEntry(pub Format);

impl TryFrom<String> for FormatEntry {
    type Error = String;
    fn try_from(f: String) -> std::result::Result<Self, String> {
        Format::from_name(&f)
            .map(FormatEntry)
            .ok_or_else(|| format!("unknown format {f:?}"))
    }
}

/// A channel's role as the manifest may state it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(try_from = "String")]
pub enum RoleEntry {
    Input,
    Output,
}

impl TryFrom<String> for RoleEntry {
    type Error = String;
    fn try_from(r: String) -> std::result::Result<Self, String> {
        match r.as_str() {
            "input" => Ok(RoleEntry::Input),
            "output" => Ok(RoleEntry::Output),
            _ => Err(format!("role {r:?} must be \"input\" or \"output\"")),
        }
    }
}

impl RoleEntry {
    pub fn role(self) -> Role {
        match self {
            RoleEntry::Input => Role::Input,
            RoleEntry::Output => Role::Output,
        }
    }
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelEntry {
    /// Relative path; zip members as `bundle.zip:member`.
    pub file: String,
    /// Column name/index (CSV), or the channel to pick in a multi-channel file
    /// (its id, channel code, or 0-based index).
    pub column: Option<ColumnRef>,
    pub id: Option<String>,
    pub level: Option<i32>,
    pub direction: Option<DirectionEntry>,
    pub role: Option<RoleEntry>,
    pub units: Option<UnitsEntry>,
    /// Counts per m/s² when `units = "counts"`.
    pub sensitivity: Option<f64>,
    pub sampling_rate_hz: Option<f64>,
    /// Time column for CSV files.
    pub time_column: Option<String>,
    /// Force a reader (`cosmos`, `dmg`, `smc`, `at2`, `mseed`, `sac`, `geonet`, `csv`, `mcap`).
    pub format: Option<FormatEntry>,
    /// FE node of the twin.
    pub node: Option<String>,
    pub elevation_m: Option<f64>,
    /// Dip in degrees (StationXML convention: −90 = up, +90 = down, 0 =
    /// horizontal); with `direction` as an azimuth it says the sensor is
    /// horizontal, alone ±90 makes it vertical.
    pub dip_deg: Option<f64>,
    /// Position on the floor plan in building axes (X, Y), metres: lets the
    /// rigid-floor combination resolve the floor's rotation.
    pub position_m: Option<[f64; 2]>,
    /// Multiply samples by −1 (sensor mounted reversed).
    #[serde(default)]
    pub reversed: bool,
}

/// The `id` of the `[[channel]]` entry that holds byte `at` of the manifest
/// text, if it has one (so an error in a channel's values names the channel).
fn channel_id_at(text: &str, at: usize) -> Option<String> {
    let before = &text[..at.min(text.len())];
    let index = before
        .lines()
        .filter(|l| l.trim().replace(' ', "") == "[[channel]]")
        .count()
        .checked_sub(1)?;
    let root = toml::de::DeTable::parse(text).ok()?;
    let toml::de::DeValue::Array(channels) = root.get_ref().get("channel")?.get_ref() else {
        return None;
    };
    let toml::de::DeValue::Table(entry) = channels.get(index)?.get_ref() else {
        return None;
    };
    match entry.get("id")?.get_ref() {
        toml::de::DeValue::String(id) => Some(id.to_string()),
        _ => None,
    }
}

impl Manifest {
    /// Parses manifest text; errors name the manifest file and line.
    pub fn parse(text: &str, file: &str) -> Result<Manifest> {
        // Sizes first, before the parser holds the text many times over.
        if text.len() as u64 > MAX_MANIFEST_BYTES {
            return Err(Error::input(
                Location::file(file),
                format!(
                    "event manifest of {} bytes: larger than the limit of {MAX_MANIFEST_BYTES} bytes",
                    text.len()
                ),
            ));
        }
        let headers = text
            .lines()
            .filter(|l| l.trim().replace(' ', "") == "[[channel]]")
            .count();
        if headers > MAX_CHANNELS {
            return Err(too_many_channels(file, headers));
        }
        let m: Manifest = toml::from_str(text).map_err(|e| {
            let line = e
                .span()
                .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
            let mut loc = Location::file(file);
            loc.line = line;
            if let Some(id) = e.span().and_then(|s| channel_id_at(text, s.start)) {
                loc = loc.with_channel(id);
            }
            Error::input(loc, format!("invalid event manifest: {}", e.message()))
        })?;
        m.validate(file)?;
        if let Some(lab) = &m.lab {
            lab.validate(file)?;
        }
        Ok(m)
    }

    fn validate(&self, file: &str) -> Result<()> {
        let loc = || Location::file(file);
        if self.channels.len() > MAX_CHANNELS {
            return Err(too_many_channels(file, self.channels.len()));
        }
        if let Some(mag) = self.event.magnitude {
            if !MAGNITUDE.contains(&mag) {
                return Err(Error::input(
                    loc(),
                    format!(
                        "event.magnitude = {mag}: not a magnitude ({} to {})",
                        MAGNITUDE.start(),
                        MAGNITUDE.end()
                    ),
                ));
            }
        }
        match (self.event.latitude_deg, self.event.longitude_deg) {
            (None, None) => {}
            (Some(lat), Some(lon))
                if (-90.0..=90.0).contains(&lat) && (-180.0..=180.0).contains(&lon) => {}
            (Some(_), Some(_)) => {
                return Err(Error::input(
                    loc(),
                    "event.latitude_deg must be within ±90 and event.longitude_deg within ±180 degrees",
                ))
            }
            _ => {
                return Err(Error::input(
                    loc(),
                    "event.latitude_deg and event.longitude_deg (the epicentre) go together: state both or neither",
                ))
            }
        }
        if let Some(d) = self.event.depth_km {
            if !(-10.0..=800.0).contains(&d) {
                return Err(Error::input(
                    loc(),
                    format!("event.depth_km = {d}: not a hypocentre depth (−10 to 800 km)"),
                ));
            }
        }
        if let Some(s) = &self.structure {
            if let Some(h) = s
                .storey_heights_m
                .iter()
                .find(|h| !STOREY_HEIGHT_M.contains(*h))
            {
                return Err(Error::input(
                    loc(),
                    format!(
                        "structure.storey_heights_m: {h} m is not a storey height ({} to {} m)",
                        STOREY_HEIGHT_M.start(),
                        STOREY_HEIGHT_M.end()
                    ),
                ));
            }
            if !s.storey_heights_m.is_empty()
                && !s.masses_kg.is_empty()
                && s.storey_heights_m.len() != s.masses_kg.len()
            {
                return Err(Error::input(
                    loc(),
                    format!(
                        "structure.masses_kg lists {} levels and structure.storey_heights_m {}: one entry per level 1..n in both",
                        s.masses_kg.len(),
                        s.storey_heights_m.len()
                    ),
                ));
            }
            if let Some(n) = s.storeys {
                if n == 0 || n > 300 {
                    return Err(Error::input(
                        loc(),
                        format!("structure.storeys = {n}: a structure has 1 to 300 storeys"),
                    ));
                }
                if !s.storey_heights_m.is_empty() && s.storey_heights_m.len() != n as usize {
                    return Err(Error::input(
                        loc(),
                        format!(
                            "structure.storeys = {n} but structure.storey_heights_m lists {} storeys",
                            s.storey_heights_m.len()
                        ),
                    ));
                }
            }
            if let Some(h) = s.height_m {
                if !(MIN_STOREY_HEIGHT_M..=1000.0).contains(&h) {
                    return Err(Error::input(
                        loc(),
                        format!("structure.height_m = {h}: not a structure's height in metres"),
                    ));
                }
            }
            if let Some(m) = s.masses_kg.iter().find(|m| !LEVEL_MASS_KG.contains(*m)) {
                return Err(Error::input(
                    loc(),
                    format!(
                        "structure.masses_kg: {m} kg is not the mass of a level (masses_kg must be positive numbers from {:e} to {:e} kg)",
                        LEVEL_MASS_KG.start(),
                        LEVEL_MASS_KG.end()
                    ),
                ));
            }
            if let Some(az) = s.x_axis_azimuth_deg {
                // Within one turn either way: beyond ±2⁵³ an f64 has no
                // fraction of a degree left, and X − 90° would equal X
                // (found by the structured fuzz run: 1e300 made the axes
                // "not orthogonal", an error naming no file).
                if !(az.is_finite() && az.abs() <= 360.0) {
                    return Err(Error::input(
                        loc(),
                        format!(
                            "structure.x_axis_azimuth_deg {az} must be an angle in degrees, from -360 to 360 (clockwise from north)"
                        ),
                    ));
                }
            }
            if let Some(c) = s.centre_of_mass_m {
                if !c.iter().all(|v| v.abs() <= MAX_PLAN_COORDINATE_M) {
                    return Err(Error::input(
                        loc(),
                        format!("structure.centre_of_mass_m must be two numbers [x, y] in metres, each within ±{MAX_PLAN_COORDINATE_M} m"),
                    ));
                }
            }
            match (s.latitude_deg, s.longitude_deg) {
                (None, None) => {}
                (Some(lat), Some(lon))
                    if (-90.0..=90.0).contains(&lat) && (-180.0..=180.0).contains(&lon) => {}
                (Some(_), Some(_)) => {
                    return Err(Error::input(
                        loc(),
                        "structure.latitude_deg must be within ±90 and structure.longitude_deg within ±180 degrees",
                    ))
                }
                _ => {
                    return Err(Error::input(
                        loc(),
                        "structure.latitude_deg and structure.longitude_deg go together: state both or neither",
                    ))
                }
            }
        }
        let mut ids = std::collections::HashSet::new();
        for (i, c) in self.channels.iter().enumerate() {
            let at = |msg: String| {
                Error::input(
                    loc().with_channel(c.id.clone().unwrap_or_else(|| format!("#{i}"))),
                    msg,
                )
            };
            if c.file.trim().is_empty() {
                return Err(at("channel entry without `file`".into()));
            }
            if let Some(id) = &c.id {
                if !ids.insert(id.clone()) {
                    return Err(at(format!("channel id {id:?} is used twice")));
                }
            }
            if let Some(fs) = c.sampling_rate_hz {
                if !SAMPLING_RATE_HZ.contains(&fs) {
                    return Err(at(format!(
                        "sampling_rate_hz {fs} must be positive, from {} to {} Hz",
                        SAMPLING_RATE_HZ.start(),
                        SAMPLING_RATE_HZ.end()
                    )));
                }
            }
            if let Some(s) = c.sensitivity {
                if !SENSITIVITY_COUNTS_PER_MS2.contains(&s.abs()) {
                    return Err(at(format!(
                        "sensitivity {s:e} must be a non-zero number of counts per m/s² of magnitude {:e} to {:e} (one count is then at most 1000 m/s²)",
                        SENSITIVITY_COUNTS_PER_MS2.start(),
                        SENSITIVITY_COUNTS_PER_MS2.end()
                    )));
                }
            }
            if let Some(level) = c.level {
                if !(0..=MAX_LEVEL).contains(&level) {
                    return Err(at(format!(
                        "level {level}: levels are 0 (base/ground) to n (top floor), at most {MAX_LEVEL}"
                    )));
                }
            }
            if let Some(e) = c.elevation_m {
                if !ELEVATION_M.contains(&e) {
                    return Err(at(format!(
                        "elevation_m {e} must lie in [{}, {}] metres",
                        ELEVATION_M.start(),
                        ELEVATION_M.end()
                    )));
                }
            }
            if let Some(dip) = c.dip_deg {
                if !(dip.is_finite() && (-90.0..=90.0).contains(&dip)) {
                    return Err(at(format!("dip_deg {dip} must lie in [-90, 90] degrees")));
                }
            }
            if let Some(p) = c.position_m {
                if !p.iter().all(|v| v.abs() <= MAX_PLAN_COORDINATE_M) {
                    return Err(at(format!(
                        "position_m must be two numbers [x, y] in metres, each within ±{MAX_PLAN_COORDINATE_M} m"
                    )));
                }
            }
        }
        Ok(())
    }
}

fn too_many_channels(file: &str, n: usize) -> Error {
    Error::input(
        Location::file(file),
        format!("event manifest lists {n} channels: more than the limit of {MAX_CHANNELS}"),
    )
}
