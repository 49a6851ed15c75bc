//! Structure history (issue 35 item 1): the events a structure has recorded,
//! its modes followed across them, each mode's frequency against the
//! event's intensity with an amplitude-dependence band, the events outside
//! the band, a permanent shift, and event-to-event prediction.  Numerical
//! code only, no I/O: `crate::dataset_history` reads a many-event dataset
//! and writes `history_modes/history_modes.parquet`, `history_events/history_events.parquet` and
//! `history.html` (docs/history.md).
//!
//! Flow per structure: its events in date order → the modes of every event
//! paired across the events ([`crate::modal::track_across_events`]: the
//! pre/post pairing generalised to N events, one id and one direction label
//! per followed mode) → per mode, frequency against intensity
//! ([`amplitude`]: log-linear band with its prediction interval, outliers,
//! a permanent shift dated) → per event, the prediction of its response by
//! the model of the event before ([`prediction`]).

pub mod amplitude;
pub mod prediction;

use crate::modal::{track_across_events, Mode, ModeSet, ModeTrack, PairingSettings};
pub use amplitude::{BandSettings, ModeAssessment, ModeBand, Point, Status, Step, G};

/// Settings of a history.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HistorySettings {
    /// The pairing across events (`modal::compare`).
    pub pairing: PairingSettings,
    pub band: BandSettings,
}

impl Default for HistorySettings {
    fn default() -> Self {
        HistorySettings {
            // The pre/post pairing's MAC threshold with a wider frequency
            // window: across a structure's events the frequency of one mode
            // moves with the shaking (the Painter St. overpass: 4.39 Hz in
            // small events, 2.45 Hz at 1 g in 1992, −44 %), and the event a
            // history must flag is the one that moved most.  MAC ≥ 0.8 on
            // the shared channels still tells the mode from its neighbours;
            // below two shared channels the direction label must agree.
            pairing: PairingSettings {
                frequency_window: 0.5,
                min_mac_same_direction: Some(0.5),
                ..PairingSettings::default()
            },
            band: BandSettings::default(),
        }
    }
}

/// What the history needs of one event.
#[derive(Debug, Clone, PartialEq)]
pub struct EventModes {
    /// The event's name (its partition value).
    pub event: String,
    /// Its time (origin time, else the records' start), ns since the epoch.
    pub time_ns: Option<i64>,
    /// The intensity the band is fitted on, m/s² (None: unknown).
    pub intensity_m_s2: Option<f64>,
    /// Its identified modes and the channels of their shapes.
    pub modes: Vec<Mode>,
    pub channels: Vec<String>,
}

/// One mode followed across the events.
#[derive(Debug, Clone, PartialEq)]
pub struct ModeHistory {
    /// 1-based, in the order the modes first appear (date order).
    pub id: usize,
    /// The pairing's track: members in event order (`event` indexes
    /// [`StructureHistory::events`]).
    pub track: ModeTrack,
    /// The band and one verdict per member.
    pub assessment: ModeAssessment,
}

/// The history of one structure.
#[derive(Debug, Clone, PartialEq)]
pub struct StructureHistory {
    /// Its events, in date order (unknown dates last, then by name).
    pub events: Vec<EventModes>,
    pub modes: Vec<ModeHistory>,
}

impl StructureHistory {
    /// The mode of `mode` in event `event` (indices into `modes`, `events`).
    pub fn member_mode(&self, mode: usize, member: usize) -> &Mode {
        let m = &self.modes[mode].track.members[member];
        &self.events[m.event].modes[m.mode]
    }
}

/// Date order: known times first, ascending; then by name.
pub fn sort_by_date(events: &mut [EventModes]) {
    events.sort_by(|a, b| {
        a.time_ns
            .is_none()
            .cmp(&b.time_ns.is_none())
            .then(a.time_ns.cmp(&b.time_ns))
            .then(a.event.cmp(&b.event))
    });
}

/// The history of one structure from its events (module doc).
pub fn analyse(mut events: Vec<EventModes>, settings: &HistorySettings) -> StructureHistory {
    sort_by_date(&mut events);
    let sets: Vec<ModeSet> = events
        .iter()
        .map(|e| ModeSet {
            modes: &e.modes,
            channels: &e.channels,
        })
        .collect();
    let tracks = track_across_events(&sets, &settings.pairing);
    let modes = tracks
        .into_iter()
        .enumerate()
        .map(|(k, track)| {
            let points: Vec<Point> = track
                .members
                .iter()
                .map(|m| Point {
                    frequency_hz: events[m.event].modes[m.mode].frequency_hz,
                    intensity_m_s2: events[m.event].intensity_m_s2.unwrap_or(f64::NAN),
                })
                .collect();
            ModeHistory {
                id: k + 1,
                assessment: amplitude::assess(&points, &settings.band),
                track,
            }
        })
        .collect();
    StructureHistory { events, modes }
}
