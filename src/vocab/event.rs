use serde::{Deserialize, Serialize};

use super::{Channel, ProcessingHistory, Samples};

/// One channel's samples on a uniform time grid (`channel.sampling_rate_hz`,
/// first sample at `channel.start_ns` when known).
#[derive(Debug, Clone, PartialEq)]
pub struct Record {
    pub channel: Channel,
    /// In memory, or parked in the run's sample store ([`Samples`]).
    pub samples: Samples,
}

impl Record {
    pub fn new(channel: Channel, samples: impl Into<Samples>) -> Self {
        Record {
            channel,
            samples: samples.into(),
        }
    }
    pub fn len(&self) -> usize {
        self.samples.len()
    }
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }
    pub fn duration_s(&self) -> f64 {
        self.samples.len() as f64 / self.channel.sampling_rate_hz
    }
}

/// What is known of the monitored structure (from the event manifest).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Structure {
    pub name: Option<String>,
    /// The owner's identifier of the structure (an asset number, a
    /// station code), when stated (`structure.id`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<String>,
    /// Postal address or place description, when stated (`structure.address`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub address: Option<String>,
    /// Storey heights in metres, level 1..n above the base.
    #[serde(default)]
    pub storey_heights_m: Vec<f64>,
    /// Lumped mass per level 1..n, kg.
    #[serde(default)]
    pub masses_kg: Vec<f64>,
    /// Path of a digital-twin file, relative to the event folder.
    pub twin: Option<String>,
    /// Azimuth of the building X axis (degrees clockwise from north), as
    /// stated in the manifest; the axes actually applied (stated or
    /// inferred) are in the history step `building_axes`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x_axis_azimuth_deg: Option<f64>,
    /// Plan position (X, Y, metres) of the floors' centre of mass, when
    /// stated: the reference point of the rigid-floor combination (default:
    /// the centroid of each floor's sensors).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub centre_of_mass_m: Option<[f64; 2]>,
    /// Number of storeys above the base (level 0): the roof is level
    /// `storeys`.  From the manifest (`structure.storeys`), else inferred from
    /// the headers (e.g. a CSMIP station name "Van Nuys - 7-story Hotel");
    /// how it was found is in `inferred`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub storeys: Option<u32>,
    /// Total height above the base, metres, when stated (or the sum of
    /// `storey_heights_m`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height_m: Option<f64>,
    /// Model building type (HAZUS code such as "C1", "S1", "URM"), when stated.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub building_type: Option<String>,
    /// HAZUS seismic design level ("high", "moderate", "low", "pre"), when stated.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub design_level: Option<String>,
    /// Kind of structure: "building", "bridge", … when stated or inferred.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kind: Option<String>,
    /// Geographic position (WGS 84 degrees, north and east positive), when
    /// stated (`structure.latitude_deg`, `structure.longitude_deg`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub latitude_deg: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub longitude_deg: Option<f64>,
    /// What of the structure was inferred rather than stated, with how
    /// ("storeys=7 from station name \"Van Nuys - 7-story Hotel\"").
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub inferred: Vec<String>,
}

/// Where the earthquake started: the epicentre (WGS 84 degrees, north and
/// east positive) and, when known, the depth of the hypocentre.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Hypocentre {
    pub latitude_deg: f64,
    pub longitude_deg: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth_km: Option<f64>,
}

/// An earthquake (or ambient) event as ingested: records of every channel,
/// event and structure metadata, and what was done to the data.
#[derive(Debug, Clone, Default)]
pub struct Event {
    pub name: String,
    /// Event origin time, ns since the Unix epoch, when known.
    pub origin_ns: Option<i64>,
    pub magnitude: Option<f64>,
    /// Epicentre (and depth), when stated (`event.latitude_deg`, …) or
    /// given by a record header.
    pub hypocentre: Option<Hypocentre>,
    /// The recording station's position [latitude, longitude] (degrees) as
    /// the record headers state it; the structure's stated position
    /// (`structure.latitude_deg`) takes precedence where both are known.
    pub station_position: Option<[f64; 2]>,
    pub structure: Option<Structure>,
    pub records: Vec<Record>,
    pub history: ProcessingHistory,
    /// Event-level notes: what was inferred, what is missing for later stages.
    pub notes: Vec<String>,
}

impl Event {
    pub fn channel_ids(&self) -> Vec<&str> {
        self.records.iter().map(|r| r.channel.id.as_str()).collect()
    }
    pub fn record(&self, id: &str) -> Option<&Record> {
        self.records.iter().find(|r| r.channel.id == id)
    }
}
