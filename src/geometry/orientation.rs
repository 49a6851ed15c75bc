//! Orientation normalisation (METHODS §0): horizontal channels recorded
//! along azimuths are brought to the building axes. A sensor along an axis
//! (within tolerance) is relabelled; one 180° off (e.g. 351° vs 171°) is
//! sign-flipped; an orthogonal pair at one location that is off-axis is
//! rotated. Vertical channels are the caller's (`geometry::apply_building_geometry`).
//!
//! Axis convention: the building X axis points to azimuth `x_azimuth_deg`
//! (clockwise from north); Y defaults to X − 90°, so that X, Y, Z(up) is
//! right-handed (X = east, Y = north for `x_azimuth_deg` = 90).

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::vocab::{Axis, Direction, Record};

/// Building axes and tolerance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OrientationSettings {
    /// Azimuth of the building X axis, degrees clockwise from north.
    pub x_azimuth_deg: f64,
    /// Azimuth of the Y axis; default X − 90° (right-handed with Z up).
    #[serde(default)]
    pub y_azimuth_deg: Option<f64>,
    /// Angular tolerance for "along an axis" and "reversed", degrees.
    #[serde(default = "default_tolerance")]
    pub tolerance_deg: f64,
}

fn default_tolerance() -> f64 {
    5.0
}

/// What was done to one channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OrientationAction {
    pub channel: String,
    /// `relabel`, `flip`, `rotate`, `flip_vertical`, `unresolved`.
    pub action: String,
    pub from: String,
    pub to: String,
    /// Rotation partner, for `rotate`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub partner: Option<String>,
}

/// Signed angle difference a − b wrapped to (−180, 180].
fn angle_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(360.0);
    if d > 180.0 {
        d - 360.0
    } else {
        d
    }
}

/// Component along azimuth `target` of the horizontal vector measured by
/// two orthogonal sensors (azimuths `az1`, `az2`), sample by sample:
/// a_θ = a1 cos(θ − α1) + a2 cos(θ − α2).
pub fn rotate_pair(a1: &[f64], az1: f64, a2: &[f64], az2: f64, target: f64) -> Vec<f64> {
    let c1 = (target - az1).to_radians().cos();
    let c2 = (target - az2).to_radians().cos();
    a1.iter().zip(a2).map(|(x, y)| c1 * x + c2 * y).collect()
}

/// Which axis (and sign) an azimuth matches within the tolerance.
fn match_axis(az: f64, x_az: f64, y_az: f64, tol: f64) -> Option<(Axis, f64)> {
    for (axis, axis_az) in [(Axis::X, x_az), (Axis::Y, y_az)] {
        let d = angle_diff(az, axis_az);
        if d.abs() <= tol {
            return Some((axis, 1.0));
        }
        if (180.0 - d.abs()) <= tol {
            return Some((axis, -1.0));
        }
    }
    None
}

/// Location key grouping channels of one sensor package.
fn location_key(
    r: &Record,
) -> (
    Option<String>,
    Option<String>,
    Option<i32>,
    Option<String>,
    Option<String>,
) {
    let c = &r.channel;
    (
        c.station.clone(),
        c.location_code.clone(),
        c.level,
        c.node.clone(),
        c.location_text.clone(),
    )
}

/// Normalises orientation in place (see module doc); returns what was done.
/// Channels already on an axis, without a direction, or off-axis without an
/// orthogonal partner at their location are left as they are (the last are
/// reported `unresolved`). Paired channels must have equal lengths.
pub fn normalise_orientation(
    records: &mut [Record],
    settings: &OrientationSettings,
) -> Result<Vec<OrientationAction>> {
    let x_az = settings.x_azimuth_deg;
    let y_az = settings.y_azimuth_deg.unwrap_or(x_az - 90.0);
    let tol = settings.tolerance_deg;
    if !(x_az.is_finite() && y_az.is_finite() && tol.is_finite() && (0.0..45.0).contains(&tol)) {
        return Err(Error::usage(
            "orientation: axis azimuths must be finite and tolerance within [0, 45) degrees",
        ));
    }
    if (angle_diff(x_az, y_az).abs() - 90.0).abs() > 1e-9 {
        return Err(Error::usage(format!(
            "orientation: X ({x_az}°) and Y ({y_az}°) axes must be orthogonal"
        )));
    }
    let mut actions = Vec::new();
    let mut off_axis: Vec<usize> = Vec::new();
    for (i, r) in records.iter_mut().enumerate() {
        match r.channel.direction {
            Some(Direction::Azimuth(az)) => match match_axis(az, x_az, y_az, tol) {
                Some((axis, sign)) => {
                    if sign < 0.0 {
                        r.samples.negate();
                    }
                    actions.push(OrientationAction {
                        channel: r.channel.id.clone(),
                        action: if sign < 0.0 {
                            "flip".into()
                        } else {
                            "relabel".into()
                        },
                        from: format!("{az}deg"),
                        to: format!("{axis:?}"),
                        partner: None,
                    });
                    r.channel.direction = Some(Direction::Axis(axis));
                }
                None => off_axis.push(i),
            },
            _ => {}
        }
    }
    // Pair off-axis horizontals at the same location that are orthogonal.
    let mut used = vec![false; off_axis.len()];
    for a in 0..off_axis.len() {
        if used[a] {
            continue;
        }
        let ia = off_axis[a];
        let partner = (a + 1..off_axis.len()).find(|&b| {
            let ib = off_axis[b];
            !used[b]
                && location_key(&records[ia]) == location_key(&records[ib])
                && records[ia].samples.len() == records[ib].samples.len()
                && records[ia].channel.units == records[ib].channel.units
                && match (records[ia].channel.direction, records[ib].channel.direction) {
                    (Some(Direction::Azimuth(p)), Some(Direction::Azimuth(q))) => {
                        (angle_diff(p, q).abs() - 90.0).abs() <= tol
                    }
                    _ => false,
                }
        });
        let Some(b) = partner else {
            let r = &records[ia];
            actions.push(OrientationAction {
                channel: r.channel.id.clone(),
                action: "unresolved".into(),
                from: r
                    .channel
                    .direction
                    .map(|d| d.to_string())
                    .unwrap_or_default(),
                to: String::new(),
                partner: None,
            });
            continue;
        };
        used[a] = true;
        used[b] = true;
        let ib = off_axis[b];
        let (Some(Direction::Azimuth(az_a)), Some(Direction::Azimuth(az_b))) =
            (records[ia].channel.direction, records[ib].channel.direction)
        else {
            continue;
        };
        // The channel closer to X becomes X, the other Y.
        let (ix, iy) = if angle_diff(az_a, x_az)
            .abs()
            .min(180.0 - angle_diff(az_a, x_az).abs())
            <= angle_diff(az_b, x_az)
                .abs()
                .min(180.0 - angle_diff(az_b, x_az).abs())
        {
            (ia, ib)
        } else {
            (ib, ia)
        };
        let along_x = rotate_pair(&records[ia].samples, az_a, &records[ib].samples, az_b, x_az);
        let along_y = rotate_pair(&records[ia].samples, az_a, &records[ib].samples, az_b, y_az);
        for (idx, axis, data, other) in [(ix, Axis::X, along_x, iy), (iy, Axis::Y, along_y, ix)] {
            let from = records[idx]
                .channel
                .direction
                .map(|d| d.to_string())
                .unwrap_or_default();
            let partner = records[other].channel.id.clone();
            let r = &mut records[idx];
            r.samples = data.into();
            r.channel.direction = Some(Direction::Axis(axis));
            actions.push(OrientationAction {
                channel: r.channel.id.clone(),
                action: "rotate".into(),
                from,
                to: format!("{axis:?}"),
                partner: Some(partner),
            });
        }
    }
    Ok(actions)
}
