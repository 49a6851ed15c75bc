//! Lumped storey masses and the reduced-mass targets of Eq. 35–36 taken from
//! the digital twin (METHODS.md §4: "masses from the manifest (or the twin
//! when it exists)"). I/O free: the caller loads the twin.
//!
//! Choices (docs/pipelines.md, `hysteresis` stage):
//! - **Storey mass** of level L along a horizontal axis = Σ over the free
//!   translational DoFs along that axis of the nodes assigned to level L of
//!   (M̃ r̃)_i, the twin's mass times a unit rigid translation along the axis
//!   (the row sums of the mass matrix, including the coupling of consistent
//!   mass to supported DoFs). The masses are evaluated at the parameters'
//!   start values (the twin as it stands). Rigid-link slaves count through
//!   their master. Mass on nodes nearest the base level (level 0) moves with
//!   the ground and is dropped.
//! - **Levels of nodes**: level elevations are z₀ + Σ storey heights (from the
//!   manifest's `structure.storey_heights_m`), z₀ = the lowest node elevation
//!   of the twin; a node belongs to the nearest level (ties: the lower one).
//!   The vertical axis is y in 2D twins and z in 3D twins.
//! - **Reduced stiffness** of Eq. 35–36: Guyan condensation of K onto the two
//!   instrumented floors' sensor DoFs (the twin's `[[sensors]]` entries of the
//!   channels), which for a shear chain is the exact static condensation.
//! - **ω_FE along an axis**: the lowest of the twin's first modes (up to 12)
//!   whose modal participation Γ = φᵀ M̃ r̃ is largest along that axis among
//!   the twin's translational axes.

use crate::error::{Error, Location, Result};
use crate::twin::guyan::guyan_reduce;
use crate::twin::{Dimension, Model, TwinSystem};

use super::reduced_mass::ReducedMassTarget;

/// Global axis index (0 = x, 1 = y, 2 = z) of a horizontal direction label.
pub fn horizontal_axis(dimension: Dimension, direction: &str) -> Option<usize> {
    match (dimension, direction.trim().to_ascii_uppercase().as_str()) {
        (_, "X") => Some(0),
        (Dimension::Three, "Y") => Some(1),
        _ => None,
    }
}

fn vertical_axis(dimension: Dimension) -> usize {
    match dimension {
        Dimension::Two => 1,
        Dimension::Three => 2,
    }
}

fn twin_error(system: &TwinSystem, message: String) -> Error {
    Error::input(Location::file(system.source.clone()), message)
}

/// Lumped storey masses of levels 1..=heights.len() along `axis` (kg).
pub fn twin_storey_masses(
    system: &TwinSystem,
    model: &Model,
    axis: usize,
    storey_heights_m: &[f64],
) -> Result<Vec<f64>> {
    let Some(map) = &system.dofs else {
        return Err(twin_error(
            system,
            "storey masses need a mesh twin (node coordinates); a Matrix Market twin has none: give structure.masses_kg"
                .into(),
        ));
    };
    let pattern = system.mass_influence.get(axis).ok_or_else(|| {
        twin_error(
            system,
            format!("the twin has no mass pattern along axis {axis}"),
        )
    })?;
    let translation = model.dimension.translation_dof(axis).ok_or_else(|| {
        twin_error(
            system,
            format!(
                "a {:?} twin has no translation along axis {axis}",
                model.dimension
            ),
        )
    })?;
    if storey_heights_m.is_empty() || storey_heights_m.iter().any(|h| !(*h > 0.0)) {
        return Err(Error::usage(
            "storey masses from the twin need positive structure.storey_heights_m in event.toml (to assign twin nodes to levels)",
        ));
    }
    let vertical = vertical_axis(model.dimension);
    let base = model
        .nodes
        .iter()
        .map(|n| n.coords[vertical])
        .fold(f64::INFINITY, f64::min);
    let mut elevations = vec![base];
    for h in storey_heights_m {
        let last = elevations[elevations.len() - 1];
        elevations.push(last + h);
    }
    let level_of = |z: f64| -> usize {
        let mut best = 0;
        for (l, e) in elevations.iter().enumerate() {
            if (z - e).abs() < (z - elevations[best]).abs() {
                best = l;
            }
        }
        best
    };
    let theta = system.start_values();
    let row_sums = pattern.at(&theta);
    let mut masses = vec![0.0; storey_heights_m.len()];
    for (i, &(node, dof)) in map.free_labels.iter().enumerate() {
        if dof != translation {
            continue;
        }
        let Some(n) = model.nodes.get(node) else {
            continue;
        };
        let level = level_of(n.coords[vertical]);
        if level > 0 {
            masses[level - 1] += row_sums.get(i).copied().unwrap_or(0.0);
        }
    }
    Ok(masses)
}

/// The free DoF a sensor channel reads, when it reads exactly one free DoF.
fn sensor_free_dof(system: &TwinSystem, channel: &str) -> Result<usize> {
    let sensor = system
        .sensors
        .iter()
        .find(|s| s.channel == channel)
        .ok_or_else(|| {
            Error::input(
                Location::file(system.source.clone()).with_channel(channel.to_string()),
                format!(
                    "channel {channel} has no [[sensors]] entry in the twin: reduced masses (Eq. 35–36) need the twin DoF of every instrumented floor"
                ),
            )
        })?;
    match sensor.combination.as_slice() {
        [(i, c)] if *c == 1.0 => Ok(*i),
        _ => Err(Error::input(
            Location::file(system.source.clone()).with_channel(channel.to_string()),
            format!("channel {channel} does not read a single free twin DoF (rigid-link slave or support)"),
        )),
    }
}

/// Eq. 35–36 target of one direction: Guyan-condensed 2×2 stiffness on the
/// sensor DoFs of the two instrumented floors (lower first) and ω_FE along `axis`.
pub fn twin_reduced_target(
    system: &TwinSystem,
    channels: [&str; 2],
    axis: usize,
) -> Result<ReducedMassTarget> {
    let masters = [
        sensor_free_dof(system, channels[0])?,
        sensor_free_dof(system, channels[1])?,
    ];
    let theta = system.start_values();
    let k = system.stiffness_at(&theta);
    let m = system.mass_at(&theta);
    let reduction = guyan_reduce(&k, &m, &masters)?;
    let s = &reduction.stiffness;
    let stiffness = [[s[(0, 0)], s[(0, 1)]], [s[(1, 0)], s[(1, 1)]]];
    Ok(ReducedMassTarget {
        stiffness,
        omega_fe: first_pulsation_along(system, axis)?,
    })
}

/// ω (rad/s) of the lowest twin mode whose participation is largest along `axis`.
pub fn first_pulsation_along(system: &TwinSystem, axis: usize) -> Result<f64> {
    let theta = system.start_values();
    let count = system.n.min(12);
    let modes = system.modes(&theta, count)?;
    let patterns: Vec<Vec<f64>> = system.mass_influence.iter().map(|p| p.at(&theta)).collect();
    if axis >= patterns.len() {
        return Err(twin_error(
            system,
            format!("the twin has no mass pattern along axis {axis}"),
        ));
    }
    for j in 0..modes.count() {
        let phi = modes.shape(j);
        let gamma: Vec<f64> = patterns
            .iter()
            .map(|p| phi.iter().zip(p).map(|(a, b)| a * b).sum::<f64>().abs())
            .collect();
        let along = gamma[axis];
        if along > 0.0 && gamma.iter().all(|g| *g <= along) && modes.omega2[j] > 0.0 {
            return Ok(modes.omega2[j].sqrt());
        }
    }
    Err(twin_error(
        system,
        format!("none of the twin's lowest {count} modes moves mainly along axis {axis}"),
    ))
}
