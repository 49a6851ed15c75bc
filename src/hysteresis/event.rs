//! Bouc-Wen identification of a whole event: which directions can be
//! identified (a base channel and floors of one building axis), their
//! masses (`mass_resolution`), and the identification of each direction in
//! parallel (METHODS §4).

use std::path::Path;

use serde::Deserialize;

use super::identify::{identify_kinematics_outcome, KinematicsOutcome};
use super::mass_resolution::{resolve_masses, MassLumping, MassResolution};
use super::window::{identification_window, WindowSettings};
use super::{DirectionIdentification, DirectionKinematics, DirectionRecords, IdentifySettings};
use crate::error::{Error, Result};
use crate::vocab::{Axis, Event, Record, Role};

/// Explicit channels of one direction.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DirectionSpec {
    pub direction: String,
    pub base: String,
    /// Floor channels, DoF 1..D from the base up.
    pub floors: Vec<String>,
    /// Masses per floor (kg); default: `structure.masses_kg` at the channels'
    /// levels, else the twin's storey masses, lumped onto the instrumented
    /// levels (`mass_resolution`) when some level has no channel.
    pub masses_kg: Option<Vec<f64>>,
}

/// The direction-level verdict a later stage reads (bouc_wen/bouc_wen.parquet `verdict`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// (a) Hysteretic terms significant at one DoF at least: nonlinear
    /// response identified.
    NonlinearIdentified,
    /// (b) Every DoF tested, none with significant hysteretic terms: the
    /// test saw no hysteresis beyond the nested model. Not "linear": see
    /// `crate::hysteresis::identify::F_TEST_BLIND_SPOTS`.
    NoSignificantHysteresis,
    /// (c) Not identifiable: masses or channels missing, too few windows, K0
    /// at its bound, unstable estimates…; nothing is known about hysteresis.
    NotIdentifiable,
}

impl Verdict {
    pub fn name(self) -> &'static str {
        match self {
            Verdict::NonlinearIdentified => "nonlinear_identified",
            Verdict::NoSignificantHysteresis => "no_significant_hysteresis",
            Verdict::NotIdentifiable => "not_identifiable",
        }
    }
}

/// Outcome of one direction: identified, or why not.
pub enum DirectionOutcome {
    Identified(Box<DirectionIdentification>),
    NotIdentifiable {
        direction: String,
        reason: String,
        /// The measured force–drift response, when the records and masses
        /// allow it (the identification itself failed).
        measured: Option<Box<MeasuredResponse>>,
        /// The F-test of the hysteretic terms (F, p) when it is what failed.
        f_test: Option<(f64, f64)>,
        /// `NoSignificantHysteresis` or `NotIdentifiable`.
        verdict: Verdict,
    },
}

/// The measured response of a direction's segments: what the force–drift
/// loops are drawn from when the model is not identified.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredResponse {
    pub sampling_rate_hz: f64,
    /// Time of the first sample from the record's start, s (as
    /// `DirectionIdentification::start_s`).
    pub start_s: f64,
    /// Segment of each DoF (`L0-L4`…).
    pub segments: Vec<String>,
    /// Inter-storey (segment) drift u_d − u_{d−1}, m, per DoF.
    pub storey_drift: Vec<Vec<f64>>,
    /// f_d = −m_d (a + ü_d) (Eq. 46), N, per DoF.
    pub restoring_force: Vec<Vec<f64>>,
}

impl MeasuredResponse {
    /// E_rec = ∫ V_d dΔu_d per DoF (segment), J: the work of the recorded
    /// storey shear along the segment drift (`super::energy`).
    pub fn segment_work(&self) -> Vec<f64> {
        let mut shear = self.restoring_force.clone();
        for d in (0..shear.len().saturating_sub(1)).rev() {
            let (lower, upper) = shear.split_at_mut(d + 1);
            for (v, above) in lower[d].iter_mut().zip(&upper[0]) {
                *v += above;
            }
        }
        shear
            .iter()
            .zip(&self.storey_drift)
            .map(|(v, u)| super::energy::work(v, u))
            .collect()
    }

    pub fn from_kinematics(kin: &DirectionKinematics, segments: Vec<String>) -> Self {
        let storey_drift = (0..kin.dofs()).map(|d| kin.storey_drift(d)).collect();
        MeasuredResponse {
            sampling_rate_hz: kin.sampling_rate_hz,
            start_s: kin.start_s,
            segments,
            storey_drift,
            restoring_force: kin.restoring_force.clone(),
        }
    }
}

impl DirectionOutcome {
    pub fn direction(&self) -> &str {
        match self {
            DirectionOutcome::Identified(d) => &d.direction,
            DirectionOutcome::NotIdentifiable { direction, .. } => direction,
        }
    }
    pub fn verdict(&self) -> Verdict {
        match self {
            DirectionOutcome::Identified(_) => Verdict::NonlinearIdentified,
            DirectionOutcome::NotIdentifiable { verdict, .. } => *verdict,
        }
    }
}

/// Settings of the identification of an event.
#[derive(Debug, Clone)]
pub struct EventSettings {
    pub identify: IdentifySettings,
    /// Grid step of σ in the reduced-mass search of Eq. 35–36.
    pub reduced_mass_step: f64,
    /// Masses of uninstrumented levels (Eq. 35–36 or tributary lumping).
    pub mass_lumping: MassLumping,
    /// Explicit directions; None = `auto_directions`.
    pub directions: Option<Vec<DirectionSpec>>,
    /// The part of the record identified (`super::window`).
    pub window: WindowSettings,
    /// A direction that cannot be identified fails the whole identification.
    pub fail_on_error: bool,
}

/// Most explicit `directions` of the hysteresis stage: a building has two
/// horizontal axes (and torsion); listing more is a typo.
pub const MAX_DIRECTIONS: usize = 8;
/// Most floors (DoFs) of one direction: each adds columns to every frame's
/// least-squares problem; instrumented buildings have far fewer floors.
pub const MAX_FLOORS_PER_DIRECTION: usize = 100;

impl EventSettings {
    /// Settings an identification can run with, else `Error::Usage` naming
    /// the key (pipeline `hysteresis` params and library callers alike).
    pub fn validate(&self) -> Result<()> {
        super::settings::validate_settings(&self.identify)?;
        if !(self.reduced_mass_step > 0.0 && self.reduced_mass_step <= 0.001) {
            return Err(Error::usage(format!(
                "reduced_mass_step = {}: must be in (0, 0.001] (Eq. 35–36 search resolution)",
                self.reduced_mass_step
            )));
        }
        if let Some(d) = &self.directions {
            if d.is_empty() || d.len() > MAX_DIRECTIONS {
                return Err(Error::usage(format!(
                    "directions: {} listed, must be 1..={MAX_DIRECTIONS}",
                    d.len()
                )));
            }
            for spec in d {
                let floors = spec.floors.len();
                if floors == 0 || floors > MAX_FLOORS_PER_DIRECTION {
                    return Err(Error::usage(format!(
                        "directions: direction {:?} lists {floors} floors, must be 1..={MAX_FLOORS_PER_DIRECTION}",
                        spec.direction
                    )));
                }
                if let Some(m) = &spec.masses_kg {
                    if m.len() != floors || m.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
                        return Err(Error::usage(format!(
                            "directions: direction {:?}: masses_kg must give one positive finite mass per floor ({floors})",
                            spec.direction
                        )));
                    }
                }
            }
        }
        self.window.validate()
    }
}

/// Directions found automatically: a level-0 input channel and floor channels
/// (levels > 0) of the same horizontal direction, one record per level (the
/// rigid-floor combination where a level has several channels). Levels may
/// have gaps: uninstrumented floors are lumped onto the instrumented ones
/// (`mass_resolution`). A level whose channels could not be combined makes
/// the direction not identifiable, with the reason.
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
                reason: not_combined_reason(event, *level, ids),
                measured: None,
                f_test: None,
                verdict: Verdict::NotIdentifiable,
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
                measured: None,
                f_test: None,
                verdict: Verdict::NotIdentifiable,
            });
            continue;
        };
        if floors.is_empty() {
            skipped.push(DirectionOutcome::NotIdentifiable {
                direction: dir,
                reason: "no floor channel (level > 0) in this direction".into(),
                measured: None,
                f_test: None,
                verdict: Verdict::NotIdentifiable,
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
    p.validate()?;
    let settings = &p.identify;
    let (specs, mut outcomes) = match &p.directions {
        Some(d) => (d.clone(), Vec::new()),
        None => auto_directions(event),
    };
    let masses = resolve_masses(
        event,
        event_dir,
        &specs,
        p.reduced_mass_step,
        p.mass_lumping,
    );
    let results: Vec<(String, Result<KinematicsOutcome>, Option<MeasuredResponse>)> = {
        use rayon::prelude::*;
        specs
            .par_iter()
            .zip(masses.par_iter())
            .map(|(spec, mass)| {
                let (r, measured) = match mass {
                    Ok(mass) => identify_spec(event, spec, mass, settings, &p.window),
                    Err(e) => (Err(e.duplicate()), None),
                };
                (spec.direction.clone(), r, measured)
            })
            .collect()
    };
    for (direction, r, measured) in results {
        match r {
            Ok(KinematicsOutcome::Identified(d)) => outcomes.push(DirectionOutcome::Identified(d)),
            Ok(KinematicsOutcome::NoSignificantHysteresis { reason, f_test, .. }) => {
                outcomes.push(DirectionOutcome::NotIdentifiable {
                    direction,
                    reason: format!("hysteresis: {reason}"),
                    measured: measured.map(Box::new),
                    f_test,
                    verdict: Verdict::NoSignificantHysteresis,
                })
            }
            Err(e) if !p.fail_on_error => outcomes.push(DirectionOutcome::NotIdentifiable {
                direction,
                f_test: match &e {
                    Error::NotIdentifiable { f_test, .. } => *f_test,
                    _ => None,
                },
                reason: e.to_string(),
                measured: measured.map(Box::new),
                verdict: Verdict::NotIdentifiable,
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
                DirectionOutcome::NotIdentifiable {
                    direction, reason, ..
                } => Some(format!("{direction}: {reason}")),
                _ => None,
            })
            .collect();
        return Err(Error::NotIdentifiable {
            stage: "hysteresis".into(),
            message: reasons.join("; "),
            f_test: None,
        });
    }
    let resolved: Vec<MassResolution> = masses.into_iter().filter_map(|m| m.ok()).collect();
    Ok((outcomes, resolved))
}

/// Identifies one direction with its resolved masses, on its identification
/// window (`super::window`); when the kinematics could be formed, also
/// returns the measured response (for the loops of a direction whose model
/// is not identified).
fn identify_spec(
    event: &Event,
    spec: &DirectionSpec,
    mass: &MassResolution,
    settings: &IdentifySettings,
    window: &WindowSettings,
) -> (Result<KinematicsOutcome>, Option<MeasuredResponse>) {
    let floors: Vec<&str> = spec.floors.iter().map(|s| s.as_str()).collect();
    let channels: Vec<&Record> = std::iter::once(spec.base.as_str())
        .chain(floors.iter().copied())
        .filter_map(|id| event.record(id))
        .collect();
    // A missing channel is reported by `from_event_window`, naming it.
    let span = if channels.len() == floors.len() + 1 {
        match identification_window(&spec.direction, &channels, window) {
            Ok(w) => Some(w),
            Err(e) => return (Err(e), None),
        }
    } else {
        None
    };
    let records = DirectionRecords::from_event_window(
        event,
        &spec.direction,
        &spec.base,
        &floors,
        Some(&mass.masses_kg),
        span.as_ref().map(|w| w.samples.clone()),
    );
    let mut records = match records {
        Ok(r) => r,
        Err(e) => return (Err(e), None),
    };
    records.declared_processing = event.history.clone();
    records.declared_processing.push_for(
        "hysteresis_masses",
        spec.floors.clone(),
        serde_json::to_value(mass).unwrap_or_default(),
    );
    if let Some(w) = &span {
        records.declared_processing.push_for(
            "hysteresis_window",
            std::iter::once(spec.base.clone())
                .chain(spec.floors.iter().cloned())
                .collect(),
            w.history(window),
        );
    }
    let mut kin = match DirectionKinematics::from_records(
        &records,
        settings.min_samples,
        settings.velocity_drift,
    ) {
        Ok(k) => k,
        Err(e) => return (Err(e), None),
    };
    drop(records);
    kin.start_s = span.as_ref().map_or(0.0, |w| w.start_s());
    let segments = if mass.levels.len() == kin.dofs() {
        mass.segments()
    } else {
        (1..=kin.dofs() as i32)
            .map(|l| format!("L{}-L{l}", l - 1))
            .collect()
    };
    match identify_kinematics_outcome(&kin, &spec.direction, settings) {
        Ok(KinematicsOutcome::Identified(mut d)) => {
            d.segments = segments;
            (Ok(KinematicsOutcome::Identified(d)), None)
        }
        Ok(other) => (
            Ok(other),
            Some(MeasuredResponse::from_kinematics(&kin, segments)),
        ),
        Err(e) => (
            Err(e),
            Some(MeasuredResponse::from_kinematics(&kin, segments)),
        ),
    }
}

/// Why the channels of one level could not be combined into one floor
/// motion: which channels, and how they differ.
fn not_combined_reason(event: &Event, level: i32, ids: &[String]) -> String {
    let records: Vec<&Record> = ids.iter().filter_map(|id| event.record(id)).collect();
    let differ = |f: &dyn Fn(&Record) -> String| -> Option<String> {
        let values: Vec<String> = records.iter().map(|r| f(r)).collect();
        (values.iter().any(|v| *v != values[0])).then(|| {
            ids.iter()
                .zip(&values)
                .map(|(id, v)| format!("{id} {v}"))
                .collect::<Vec<_>>()
                .join(", ")
        })
    };
    let why = [
        (
            "sampling rate",
            differ(&|r| format!("{} Hz", r.channel.sampling_rate_hz)),
        ),
        (
            "length",
            differ(&|r| format!("{} samples", r.samples.len())),
        ),
        (
            "start time",
            differ(&|r| format!("start {:?} ns", r.channel.start_ns)),
        ),
    ]
    .into_iter()
    .filter_map(|(what, d)| d.map(|d| format!("they differ in {what} ({d})")))
    .collect::<Vec<_>>();
    format!(
        "level {level}: channels {} in this direction could not be combined into one floor motion (rigid-floor assumption): {}; \
         one record per level is needed, so the chain cannot be formed",
        ids.join(", "),
        if why.is_empty() {
            "see the rigid_floor step of the history".to_string()
        } else {
            why.join("; ")
        }
    )
}
