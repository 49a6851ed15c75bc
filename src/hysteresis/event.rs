//! Bouc-Wen identification of a whole event: which directions can be
//! identified (a base channel and floors of one building axis), their
//! masses (`mass_resolution`), and the identification of each direction in
//! parallel (METHODS §4).

use std::path::Path;

use serde::Deserialize;

use super::mass_resolution::{resolve_masses, MassResolution};
use super::{identify_direction, DirectionIdentification, DirectionRecords, IdentifySettings};
use crate::error::{Error, Result};
use crate::vocab::{Axis, Event, Role};

/// Explicit channels of one direction.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DirectionSpec {
    pub direction: String,
    pub base: String,
    /// Floor channels, DoF 1..D from the base up.
    pub floors: Vec<String>,
    /// Masses per floor (kg); default: `structure.masses_kg` at the channels'
    /// levels, else the twin's storey masses, and reduced masses (Eq. 35–36)
    /// when a level below the top instrumented one has no channel.
    pub masses_kg: Option<Vec<f64>>,
}

/// Outcome of one direction: identified, or why not.
pub enum DirectionOutcome {
    Identified(Box<DirectionIdentification>),
    NotIdentifiable { direction: String, reason: String },
}

impl DirectionOutcome {
    pub fn direction(&self) -> &str {
        match self {
            DirectionOutcome::Identified(d) => &d.direction,
            DirectionOutcome::NotIdentifiable { direction, .. } => direction,
        }
    }
}

/// Settings of the identification of an event.
#[derive(Debug, Clone)]
pub struct EventSettings {
    pub identify: IdentifySettings,
    /// Grid step of σ in the reduced-mass search of Eq. 35–36.
    pub reduced_mass_step: f64,
    /// Explicit directions; None = `auto_directions`.
    pub directions: Option<Vec<DirectionSpec>>,
    /// A direction that cannot be identified fails the whole identification.
    pub fail_on_error: bool,
}

/// Directions found automatically: a level-0 input channel and floor channels
/// (levels > 0) of the same horizontal direction. Levels may have gaps: a
/// non-instrumented floor is handled with reduced masses (Eq. 35–36).
pub fn auto_directions(event: &Event) -> (Vec<DirectionSpec>, Vec<DirectionOutcome>) {
    let mut specs = Vec::new();
    let mut skipped = Vec::new();
    // One motion per level and direction (the rigid-floor combination where
    // a level has several channels), in building axes.
    let selection = crate::geometry::one_record_per_level(&event.records);
    let mut axes: Vec<Axis> = selection.records.keys().map(|(a, _)| *a).collect();
    axes.extend(selection.ambiguous.iter().map(|(a, _, _)| *a));
    axes.sort();
    axes.dedup();
    for axis in axes {
        let dir = format!("{axis:?}");
        if let Some((_, level, ids)) = selection.ambiguous.iter().find(|(a, _, _)| *a == axis) {
            skipped.push(DirectionOutcome::NotIdentifiable {
                direction: dir,
                reason: format!(
                    "level {level} has channels {} in this direction that could not be combined into one floor motion (see the rigid_floor step of the history)",
                    ids.join(", ")
                ),
            });
            continue;
        }
        let base = selection
            .records
            .get(&(axis, 0))
            .filter(|r| r.channel.role == Role::Input);
        let floors: Vec<&crate::vocab::Record> = selection
            .records
            .iter()
            .filter(|((a, l), _)| *a == axis && *l > 0)
            .map(|(_, r)| *r)
            .collect();
        let Some(base) = base else {
            skipped.push(DirectionOutcome::NotIdentifiable {
                direction: dir,
                reason: "no base (level 0, role input) channel in this direction".into(),
            });
            continue;
        };
        if floors.is_empty() {
            skipped.push(DirectionOutcome::NotIdentifiable {
                direction: dir,
                reason: "no floor channel (level > 0) in this direction".into(),
            });
            continue;
        }
        specs.push(DirectionSpec {
            direction: dir,
            base: base.channel.id.clone(),
            floors: floors.iter().map(|r| r.channel.id.clone()).collect(),
            masses_kg: None,
        });
    }
    (specs, skipped)
}

/// Runs the identification on `event` (loaded from `event_dir`, against which
/// the manifest's twin path is resolved) for every direction; returns the
/// outcomes and, per direction with resolvable masses, which masses were used.
pub fn identify_event(
    event: &Event,
    event_dir: Option<&Path>,
    p: &EventSettings,
) -> Result<(Vec<DirectionOutcome>, Vec<MassResolution>)> {
    let settings = &p.identify;
    let (specs, mut outcomes) = match &p.directions {
        Some(d) => (d.clone(), Vec::new()),
        None => auto_directions(event),
    };
    let masses = resolve_masses(event, event_dir, &specs, p.reduced_mass_step);
    let results: Vec<(String, Result<_>)> = {
        use rayon::prelude::*;
        specs
            .par_iter()
            .zip(masses.par_iter())
            .map(|(spec, mass)| {
                let floors: Vec<&str> = spec.floors.iter().map(|s| s.as_str()).collect();
                let r = mass.as_ref().map_err(Error::duplicate).and_then(|mass| {
                    DirectionRecords::from_event(
                        event,
                        &spec.direction,
                        &spec.base,
                        &floors,
                        Some(&mass.masses_kg),
                    )
                    .and_then(|mut rec| {
                        rec.declared_processing = event.history.clone();
                        rec.declared_processing.push_for(
                            "hysteresis_masses",
                            spec.floors.clone(),
                            serde_json::to_value(mass).unwrap_or_default(),
                        );
                        identify_direction(&rec, settings)
                    })
                });
                (spec.direction.clone(), r)
            })
            .collect()
    };
    for (direction, r) in results {
        match r {
            Ok(d) => outcomes.push(DirectionOutcome::Identified(Box::new(d))),
            Err(e) if !p.fail_on_error => outcomes.push(DirectionOutcome::NotIdentifiable {
                direction,
                reason: e.to_string(),
            }),
            Err(e) => return Err(e),
        }
    }
    outcomes.sort_by(|a, b| a.direction().cmp(b.direction()));
    if p.fail_on_error
        && outcomes
            .iter()
            .any(|o| matches!(o, DirectionOutcome::NotIdentifiable { .. }))
    {
        let reasons: Vec<String> = outcomes
            .iter()
            .filter_map(|o| match o {
                DirectionOutcome::NotIdentifiable { direction, reason } => {
                    Some(format!("{direction}: {reason}"))
                }
                _ => None,
            })
            .collect();
        return Err(Error::NotIdentifiable {
            stage: "hysteresis".into(),
            message: reasons.join("; "),
        });
    }
    let resolved: Vec<MassResolution> = masses.into_iter().filter_map(|m| m.ok()).collect();
    Ok((outcomes, resolved))
}
