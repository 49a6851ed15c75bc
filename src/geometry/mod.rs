//! The building geometry, applied once when an event is read (METHODS §0):
//! every channel leaves ingest expressed in building axes X, Y (horizontal,
//! right-handed with Z up) and Z (vertical, positive up), with the rotations
//! and sign flips recorded in the history, so conditioning, metrics and
//! drift, modal, hysteresis, design and the report all see the same axes.
//!
//! - The building axes are stated (`structure.x_axis_azimuth_deg` in
//!   event.toml) or, failing that, inferred from the sensors' azimuths (the
//!   sensor line carrying most horizontal channels becomes X; stated as
//!   inferred in the history and the event notes).
//! - Channels are relabelled, sign-flipped or rotated onto the axes
//!   ([`orientation`]); vertical channels become Z, positive up.
//! - Several channels in one direction at one level are combined under the
//!   rigid-floor assumption into the floor's motion ([`floor`]).
//!
//! Numerical code only: no I/O.

pub mod floor;
pub mod orientation;

use serde::Serialize;
use serde_json::json;

pub use floor::{combine_floors, one_record_per_level, FloorSettings, LevelSelection};
pub use orientation::{normalise_orientation, rotate_pair, OrientationAction, OrientationSettings};

use crate::error::Result;
use crate::vocab::{Axis, Direction, Event};

/// Angular tolerance for "along an axis", "reversed" and "orthogonal", degrees.
pub const AXIS_TOLERANCE_DEG: f64 = 5.0;

/// Where the building axes came from.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum AxesSource {
    /// `structure.x_axis_azimuth_deg` in the manifest.
    Stated,
    /// From the sensors' azimuths (see [`infer_x_axis`]).
    Inferred,
}

/// The building axes applied to an event.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BuildingAxes {
    /// Azimuth of X, degrees clockwise from north.
    pub x_azimuth_deg: f64,
    /// Azimuth of Y = X − 90° (X, Y, Z up right-handed).
    pub y_azimuth_deg: f64,
    pub source: AxesSource,
}

/// What applying the geometry did, for `inspect`, the history and the report.
#[derive(Debug, Clone, Default, Serialize)]
pub struct GeometryReport {
    /// `None` when no channel carries an azimuth (all already in building axes).
    pub axes: Option<BuildingAxes>,
    pub actions: Vec<OrientationAction>,
    pub floors: Vec<floor::FloorCombination>,
}

/// Infers the X axis from the horizontal sensors' azimuths: the azimuths are
/// folded onto sensor lines (mod 180°); the line carrying most channels is X
/// (ties: the smaller line azimuth in [0°, 180°)), pointing to that line's
/// azimuth in [0°, 180°). `None` without azimuth-labelled channels.
pub fn infer_x_axis(azimuths: &[f64], tolerance_deg: f64) -> Option<f64> {
    let mut lines: Vec<(f64, usize)> = Vec::new();
    let mut folded: Vec<f64> = azimuths.iter().map(|a| a.rem_euclid(180.0)).collect();
    folded.sort_by(f64::total_cmp);
    for a in folded {
        let near = |l: f64| {
            let d = (a - l).rem_euclid(180.0);
            d.min(180.0 - d) <= tolerance_deg
        };
        match lines.iter_mut().find(|(l, _)| near(*l)) {
            Some((_, n)) => *n += 1,
            None => lines.push((a, 1)),
        }
    }
    // Most channels first; on a tie, the line of smaller azimuth (lines were
    // created in increasing azimuth order, and the sort is stable).
    lines.sort_by(|a, b| b.1.cmp(&a.1));
    lines.first().map(|(l, _)| *l)
}

/// The X axis of a building recorded at azimuths only, from its geometry
/// alone (issue 31: one structure's direction labels are the same in every
/// event, whichever channels an event lacks): the sensor lines (azimuths
/// folded mod 180°, merged within `tolerance_deg`) that have a perpendicular
/// partner line are the building's axis pairs; X is the one of smallest
/// azimuth in [0°, 180°).  Counting channels per line ([`infer_x_axis`]) can
/// swap X and Y between two events of one building when a channel is dead
/// in one of them.  `None` when no two lines are perpendicular.
pub fn building_x_axis(azimuths: &[f64], tolerance_deg: f64) -> Option<f64> {
    let mut folded: Vec<f64> = azimuths.iter().map(|a| a.rem_euclid(180.0)).collect();
    folded.sort_by(f64::total_cmp);
    let apart = |a: f64, b: f64| {
        let d = (a - b).rem_euclid(180.0);
        d.min(180.0 - d)
    };
    let mut lines: Vec<f64> = Vec::new();
    for a in folded {
        if !lines.iter().any(|l| apart(a, *l) <= tolerance_deg) {
            lines.push(a);
        }
    }
    lines
        .iter()
        .copied()
        .filter(|l| {
            lines
                .iter()
                .any(|m| (apart(*l, *m) - 90.0).abs() <= tolerance_deg)
        })
        .min_by(f64::total_cmp)
}

/// The line of a bridge's deck, from where its abutments are: location texts
/// that name an east or west abutment (CSMIP: "Deck: Near East Abutment",
/// "On Ground Near West Abutment") place the abutments at the two ends of an
/// east–west deck (line 90°), north or south ones a north–south deck (0°).
/// `None` when no text names an abutment, or when both pairs are named.
pub fn bridge_line_from_abutments<'a>(
    location_texts: impl Iterator<Item = &'a str>,
) -> Option<f64> {
    let (mut east_west, mut north_south) = (false, false);
    for text in location_texts {
        let text = text.to_ascii_uppercase();
        if !text.contains("ABUTMENT") {
            continue;
        }
        let words: Vec<&str> = text
            .split(|c: char| !c.is_ascii_alphabetic())
            .filter(|w| !w.is_empty())
            .collect();
        east_west |= words.iter().any(|w| matches!(*w, "EAST" | "WEST"));
        north_south |= words.iter().any(|w| matches!(*w, "NORTH" | "SOUTH"));
    }
    match (east_west, north_south) {
        (true, false) => Some(90.0),
        (false, true) => Some(0.0),
        _ => None,
    }
}

/// The X axis of a bridge recorded at azimuths only: its longitudinal axis
/// (CSMIP's convention for bridges, Long = X and Tran = Y, so the modes of
/// records that give only azimuths carry the labels of those that say
/// Long/Tran), taken as the sensor line nearest the deck's line
/// ([`bridge_line_from_abutments`]) when it is within 45° of it; the line's
/// azimuth in [0°, 180°), as [`infer_x_axis`].
pub fn bridge_x_axis(azimuths: &[f64], deck_line_deg: f64, tolerance_deg: f64) -> Option<f64> {
    let separation = |a: f64| {
        let d = (a - deck_line_deg).rem_euclid(180.0);
        d.min(180.0 - d)
    };
    let nearest = azimuths
        .iter()
        .map(|a| a.rem_euclid(180.0))
        .min_by(|a, b| separation(*a).total_cmp(&separation(*b)))?;
    if separation(nearest) >= 45.0 {
        return None;
    }
    // The line's azimuth as the first sensor within tolerance of it gives it.
    azimuths
        .iter()
        .map(|a| a.rem_euclid(180.0))
        .filter(|a| {
            let d = (a - nearest).rem_euclid(180.0);
            d.min(180.0 - d) <= tolerance_deg
        })
        .min_by(f64::total_cmp)
}

/// Applies the building geometry to `event` in place (see module doc) and
/// records it in `event.history` (steps `building_axes` and, when floors were
/// combined, `rigid_floor`) and `event.notes`.
pub fn apply_building_geometry(event: &mut Event) -> Result<GeometryReport> {
    let mut report = GeometryReport::default();
    let stated = event.structure.as_ref().and_then(|s| s.x_axis_azimuth_deg);
    let azimuths: Vec<f64> = event
        .records
        .iter()
        .filter_map(|r| match r.channel.direction {
            Some(Direction::Azimuth(a)) => Some(a),
            _ => None,
        })
        .collect();
    // The deck line the axes were taken from, when a bridge's abutments gave them.
    let mut axes_from_deck_line: Option<f64> = None;
    let axes = match stated {
        Some(x) => Some(BuildingAxes {
            x_azimuth_deg: x.rem_euclid(360.0),
            y_azimuth_deg: (x.rem_euclid(360.0) - 90.0).rem_euclid(360.0),
            source: AxesSource::Stated,
        }),
        // Channels already in structure axes (a bridge's Long/Tran, a
        // manifest's X/Y) beside azimuth-labelled ones: how the two relate is
        // unknown, so no axes are inferred from the azimuths alone.
        None if mixes_axes_and_azimuths(event) => None,
        None => {
            let deck_line = bridge_line_from_abutments(
                event
                    .records
                    .iter()
                    .filter_map(|r| r.channel.location_text.as_deref()),
            );
            let bridge =
                deck_line.and_then(|line| bridge_x_axis(&azimuths, line, AXIS_TOLERANCE_DEG));
            axes_from_deck_line = deck_line.filter(|_| bridge.is_some());
            let building = event
                .structure
                .as_ref()
                .and_then(|s| s.kind.as_deref())
                .is_some_and(|k| k.eq_ignore_ascii_case("building"));
            bridge
                .or_else(|| {
                    building
                        .then(|| building_x_axis(&azimuths, AXIS_TOLERANCE_DEG))
                        .flatten()
                })
                .or_else(|| infer_x_axis(&azimuths, AXIS_TOLERANCE_DEG))
                .map(|x| BuildingAxes {
                    x_azimuth_deg: x,
                    y_azimuth_deg: (x - 90.0).rem_euclid(360.0),
                    source: AxesSource::Inferred,
                })
        }
    };
    if axes.is_none() {
        for r in &event.records {
            if let Some(Direction::Azimuth(az)) = r.channel.direction {
                report.actions.push(OrientationAction {
                    channel: r.channel.id.clone(),
                    action: "unresolved".into(),
                    from: format!("{az}deg"),
                    to: String::new(),
                    partner: None,
                });
            }
        }
    }
    if let Some(axes) = &axes {
        report.actions = normalise_orientation(
            &mut event.records,
            &OrientationSettings {
                x_azimuth_deg: axes.x_azimuth_deg,
                y_azimuth_deg: Some(axes.y_azimuth_deg),
                tolerance_deg: AXIS_TOLERANCE_DEG,
            },
        )?;
        if let Some(deck_line) = axes_from_deck_line {
            event.notes.push(format!(
                "building axes inferred from the abutments named in the location texts: a deck along the {} line, so X = longitudinal = {}°, Y = transverse = {}° (CSMIP's Long = X, Tran = Y; state structure.x_axis_azimuth_deg in event.toml to fix them)",
                if deck_line == 90.0 { "east–west" } else { "north–south" },
                axes.x_azimuth_deg,
                axes.y_azimuth_deg
            ));
        } else if axes.source == AxesSource::Inferred {
            event.notes.push(format!(
                "building axes inferred from the sensor azimuths: X = {}°, Y = {}° (state structure.x_axis_azimuth_deg in event.toml to fix them)",
                axes.x_azimuth_deg, axes.y_azimuth_deg
            ));
        }
    }
    // Vertical channels: Z, positive up.
    for r in &mut event.records {
        match r.channel.direction {
            Some(Direction::Down) => {
                r.samples.negate();
                r.channel.direction = Some(Direction::Axis(Axis::Z));
                report
                    .actions
                    .push(vertical_action(&r.channel.id, "flip_vertical", "DOWN"));
            }
            Some(Direction::Up) => {
                r.channel.direction = Some(Direction::Axis(Axis::Z));
                report
                    .actions
                    .push(vertical_action(&r.channel.id, "relabel", "UP"));
            }
            _ => {}
        }
    }
    for a in report.actions.iter().filter(|a| a.action == "unresolved") {
        event.notes.push(if axes.is_some() {
            format!(
                "channel {} at {} is neither along a building axis nor paired with an orthogonal sensor at its location: stages working in X/Y leave it out",
                a.channel, a.from
            )
        } else {
            format!(
                "channel {} at {}: other channels are labelled in the structure's own axes, so its relation to X/Y is unknown; state structure.x_axis_azimuth_deg in event.toml (stages working in X/Y leave it out)",
                a.channel, a.from
            )
        });
    }
    report.axes = axes;
    if report.axes.is_some() || !report.actions.is_empty() {
        event.history.push(
            "building_axes",
            json!({
                "axes": report.axes,
                "tolerance_deg": AXIS_TOLERANCE_DEG,
                "actions": report.actions,
            }),
        );
    }
    report.floors = combine_floors(event, &FloorSettings::default())?;
    Ok(report)
}

/// Whether some horizontal channels are in building axes and others at azimuths.
fn mixes_axes_and_azimuths(event: &Event) -> bool {
    let dirs = || event.records.iter().filter_map(|r| r.channel.direction);
    dirs().any(|d| matches!(d, Direction::Axis(Axis::X) | Direction::Axis(Axis::Y)))
        && dirs().any(|d| matches!(d, Direction::Azimuth(_)))
}

fn vertical_action(channel: &str, action: &str, from: &str) -> OrientationAction {
    OrientationAction {
        channel: channel.to_string(),
        action: action.into(),
        from: from.into(),
        to: "Z".into(),
        partner: None,
    }
}

/// Mean Earth radius (IUGG), km: the sphere the epicentral distance is
/// measured on.
pub const EARTH_RADIUS_KM: f64 = 6371.0088;

/// Great-circle distance between two points (degrees), km: the haversine
/// formula on a sphere of [`EARTH_RADIUS_KM`] (within 0.5 % of the WGS 84
/// geodesic — a report figure, not a survey).
pub fn great_circle_km(lat1: f64, lon1: f64, lat2: f64, lon2: f64) -> f64 {
    let (p1, p2) = (lat1.to_radians(), lat2.to_radians());
    let dp = p2 - p1;
    let dl = (lon2 - lon1).to_radians();
    let a = (dp / 2.0).sin().powi(2) + p1.cos() * p2.cos() * (dl / 2.0).sin().powi(2);
    2.0 * EARTH_RADIUS_KM * a.sqrt().min(1.0).asin()
}
