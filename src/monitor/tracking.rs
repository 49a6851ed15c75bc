//! Mode tracking: every window's modes paired with one set of reference
//! modes, so that a mode keeps its id (the reference mode's rank) across
//! windows.
//!
//! Pairing is the pre/post comparison's ([`crate::modal::compare_events`]):
//! shapes restricted to the shared channels, candidates with MAC ≥ `min_mac`
//! and |f − f_ref|/f_ref ≤ `frequency_window`, taken greedily by decreasing
//! MAC.  Tracking uses a narrower frequency window than a pre/post
//! comparison (10 % instead of 20 %): between two windows an hour apart a
//! frequency moves by a few per cent at most, and the narrower window keeps
//! a neighbouring mode of similar shape (the same direction's next mode
//! differs by far more) from being taken for the tracked one.
//!
//! Reference modes: those of a `modes/modes.parquet` given by the user, or by
//! default the *confirmed* modes of one of the first N =
//! [`TrackSettings::reference_windows`] identified windows.  A mode of window
//! i is confirmed when it pairs (same rule as the tracking) with a mode of
//! at least half of the other N − 1 windows: a pole column that one window
//! promoted from noise is not tracked for days.  The window with the most
//! confirmed modes gives the reference (ties: the earliest).  A mode absent
//! from the reference cannot be tracked; the reference's own window pairs
//! with itself (MAC 1).

use super::WindowModes;
use crate::modal::{compare_events, Mode, ModeSet, PairingSettings};

/// Settings of the tracking.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct TrackSettings {
    pub pairing: PairingSettings,
    /// Windows (identified ones, in time order) among which the default
    /// reference is chosen.
    pub reference_windows: usize,
}

impl Default for TrackSettings {
    fn default() -> Self {
        TrackSettings {
            pairing: PairingSettings {
                frequency_window: 0.1,
                ..PairingSettings::default()
            },
            reference_windows: 6,
        }
    }
}

/// The modes every window is paired with.
#[derive(Debug, Clone, PartialEq)]
pub struct Reference {
    pub modes: Vec<Mode>,
    /// Channel ids of the shapes.
    pub channels: Vec<String>,
    /// Where they came from (`window 2026-01-01T03:00:00Z`, or a file).
    pub source: String,
}

/// The default reference (module doc): the index into `windows` of the
/// chosen window and the indices of its confirmed modes.
pub fn default_reference(
    windows: &[WindowModes],
    settings: &TrackSettings,
) -> Option<(usize, Vec<usize>)> {
    let first: Vec<usize> = windows
        .iter()
        .enumerate()
        .filter(|(_, w)| !w.modes.is_empty())
        .map(|(i, _)| i)
        .take(settings.reference_windows.max(1))
        .collect();
    let mut best: Option<(usize, Vec<usize>)> = None;
    for &i in &first {
        let candidate = Reference {
            modes: windows[i].modes.clone(),
            channels: windows[i].channels.clone(),
            source: String::new(),
        };
        let mut paired = vec![0usize; candidate.modes.len()];
        for &j in first.iter().filter(|&&j| j != i) {
            let others = &windows[j..=j];
            for row in track(&candidate, others, settings) {
                paired[row.mode_id - 1] += 1;
            }
        }
        let needed = (first.len() - 1).div_ceil(2);
        let confirmed: Vec<usize> = (0..paired.len()).filter(|&k| paired[k] >= needed).collect();
        if best.as_ref().is_none_or(|(_, b)| confirmed.len() > b.len()) {
            best = Some((i, confirmed));
        }
    }
    best.filter(|(_, c)| !c.is_empty())
}

/// One tracked mode in one window.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackedMode {
    /// Index into the windows.
    pub window: usize,
    /// Id of the mode: 1-based rank of its reference mode.
    pub mode_id: usize,
    pub frequency_hz: f64,
    /// Scatter of the frequency over the model orders, Hz.
    pub frequency_std_hz: f64,
    pub damping_ratio: f64,
    /// MAC to the reference shape on the shared channels.
    pub mac: f64,
    pub mpc: f64,
    pub pole_count: usize,
    pub direction: String,
}

/// Pairs every window's modes with the reference (module doc); windows
/// without modes give no rows.  Rows by window, then mode id.
pub fn track(
    reference: &Reference,
    windows: &[WindowModes],
    settings: &TrackSettings,
) -> Vec<TrackedMode> {
    let mut rows = Vec::new();
    for (w, win) in windows.iter().enumerate() {
        if win.modes.is_empty() {
            continue;
        }
        let c = compare_events(
            ModeSet {
                modes: &reference.modes,
                channels: &reference.channels,
            },
            ModeSet {
                modes: &win.modes,
                channels: &win.channels,
            },
            &settings.pairing,
        );
        let mut found: Vec<TrackedMode> = c
            .shifts
            .iter()
            .map(|s| {
                let m = &win.modes[s.current_mode];
                TrackedMode {
                    window: w,
                    mode_id: s.reference_mode + 1,
                    frequency_hz: m.frequency_hz,
                    frequency_std_hz: m.frequency_std_hz,
                    damping_ratio: m.damping_ratio,
                    mac: s.mac.unwrap_or(f64::NAN),
                    mpc: m.mpc,
                    pole_count: m.pole_count,
                    direction: m.direction.clone(),
                }
            })
            .collect();
        found.sort_by_key(|t| t.mode_id);
        rows.extend(found);
    }
    rows
}
