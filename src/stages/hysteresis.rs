//! `hysteresis` and `damage`: instantaneous Bouc-Wen identification per
//! horizontal direction (METHODS §4) and the damage index ι(t).
//!
//! Processing is explicit: by default the records go in as recorded (units
//! converted to SI only; the identification integrates velocities itself with
//! the configured drift control).  A `conditioning` table in the params
//! applies a conditioning chain first and is recorded in the outputs.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::conditioning::{condition_event, ConditioningSettings};
use crate::error::{Error, Location, Result};
use crate::hysteresis::storey_masses::{horizontal_axis, twin_reduced_target, twin_storey_masses};
use crate::hysteresis::{
    identify_direction, reduced_lumped_masses, BasisForm, DirectionRecords, FrequencyBand,
    IdentifySettings, ReducedMassTarget, VelocityDrift,
};
use crate::pipeline::{params, RunContext, StageDecl};
use crate::sinks::hysteresis_tables::{self as tables, DirectionOutcome};
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

/// Parameters of the `hysteresis` stage (docs/pipelines.md).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HysteresisParams {
    /// `jerk` (Eq. A7–A10, default) or `integral` (Eq. 27–30).
    pub form: String,
    /// Lower limit of the frequency integral of Eq. 20, Hz (0 = the thesis's full band).
    pub band_low_hz: f64,
    pub exponent_min: f64,
    pub exponent_max: f64,
    pub exponent_resolution: f64,
    pub instantaneous: bool,
    /// `none` (default: plain integration from rest) or `endpoint_ramp`
    /// (removes the velocity drift of a constant acceleration offset,
    /// estimated from a Hann-weighted mean over the last 10 % of the record;
    /// see `VelocityDrift::EndpointRamp`).
    pub velocity_drift: String,
    /// Grid step of σ in the reduced-mass search of Eq. 35–36 (≤ 0.001).
    pub reduced_mass_step: f64,
    /// Optional conditioning before identification (none by default: band-pass
    /// filtering biases N towards 1 and γ towards −β, METHODS §1).
    pub conditioning: Option<ConditioningSettings>,
    /// Explicit directions; default: one per horizontal direction that has a
    /// level-0 input channel and floors at levels 1..D.
    pub directions: Option<Vec<DirectionSpec>>,
    /// Keep every n-th sample in hysteresis_fit.parquet and damage.parquet.
    pub output_decimation: usize,
    /// Fail the stage when a direction cannot be identified (the CLI command
    /// does); in a pipeline the reason is written to bouc_wen.parquet instead.
    pub fail_on_error: bool,
}

impl Default for HysteresisParams {
    fn default() -> Self {
        let d = IdentifySettings::default();
        HysteresisParams {
            form: "jerk".into(),
            band_low_hz: 0.0,
            exponent_min: d.exponent_min,
            exponent_max: d.exponent_max,
            exponent_resolution: d.exponent_resolution,
            instantaneous: true,
            velocity_drift: "none".into(),
            reduced_mass_step: 0.001,
            conditioning: None,
            directions: None,
            output_decimation: 1,
            fail_on_error: false,
        }
    }
}

impl HysteresisParams {
    pub fn identify_settings(&self) -> Result<IdentifySettings> {
        let mut s = IdentifySettings {
            exponent_min: self.exponent_min,
            exponent_max: self.exponent_max,
            exponent_resolution: self.exponent_resolution,
            instantaneous: self.instantaneous,
            ..IdentifySettings::default()
        };
        s.form = match self.form.as_str() {
            "jerk" => BasisForm::Jerk,
            "integral" => BasisForm::Integral,
            f => {
                return Err(Error::usage(format!(
                    "form {f:?} must be \"jerk\" or \"integral\""
                )))
            }
        };
        s.velocity_drift = match self.velocity_drift.as_str() {
            "none" => VelocityDrift::None,
            "endpoint_ramp" => VelocityDrift::EndpointRamp,
            v => {
                return Err(Error::usage(format!(
                    "velocity_drift {v:?} must be \"none\" or \"endpoint_ramp\""
                )))
            }
        };
        if self.band_low_hz > 0.0 {
            s.band = FrequencyBand::above(self.band_low_hz);
            s.transform = crate::hysteresis::Transform::Fft;
        }
        if !(self.exponent_min >= 1.0
            && self.exponent_max > self.exponent_min
            && self.exponent_resolution > 0.0)
        {
            return Err(Error::usage(
                "exponent range must satisfy 1 ≤ exponent_min < exponent_max, resolution > 0",
            ));
        }
        Ok(s)
    }
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

/// Eq. 35–36 details of a direction identified on a reduced model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReducedMassRecord {
    /// Storey masses of levels 1..L (kg) the reduced masses were built from.
    pub storey_masses_kg: Vec<f64>,
    pub storey_masses_source: String,
    pub uninstrumented_levels: Vec<i32>,
    pub sigma1: f64,
    pub sigma2: f64,
    pub sigma_step: f64,
    /// J_m = Σ_directions |ω_red − ω_FE| at σ (rad/s).
    pub cost_rad_s: f64,
    /// Directions that shared σ (Eq. 36 sums over them).
    pub directions: Vec<String>,
    /// Twin target of this direction: condensed 2×2 stiffness (N/m) and ω_FE (rad/s).
    pub reduced_stiffness_n_per_m: [[f64; 2]; 2],
    pub omega_fe_rad_s: f64,
}

/// Which masses a direction used and where they came from (written to the
/// `quaketwin.masses` metadata of bouc_wen.parquet and logged by the stage).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MassResolution {
    pub direction: String,
    /// Floor channels, DoF 1..D.
    pub channels: Vec<String>,
    /// Their levels (1-based; gaps = non-instrumented floors).
    pub levels: Vec<i32>,
    /// Lumped mass per DoF used in Eq. 46, kg.
    pub masses_kg: Vec<f64>,
    /// `stage params`, `event.toml structure.masses_kg`, `twin FILE`, or
    /// `reduced (Eq. 35–36)`.
    pub source: String,
    pub reduced: Option<ReducedMassRecord>,
}

impl MassResolution {
    pub fn message(&self) -> String {
        let masses: Vec<String> = self.masses_kg.iter().map(|m| format!("{m:.6e}")).collect();
        let mut s = format!(
            "direction {}: masses [{}] kg at levels {:?} from {}",
            self.direction,
            masses.join(", "),
            self.levels,
            self.source
        );
        if let Some(r) = &self.reduced {
            s.push_str(&format!(
                "; levels {:?} not instrumented: σ1 = {:.3}, σ2 = {:.3} (step {}), storey masses from {}",
                r.uninstrumented_levels, r.sigma1, r.sigma2, r.sigma_step, r.storey_masses_source
            ));
        }
        s
    }
}

/// The twin named by the event, loaded on first use.
struct TwinSource<'a> {
    event: &'a Event,
    event_dir: Option<&'a Path>,
    loaded: Option<Result<crate::twin::Twin>>,
}

impl<'a> TwinSource<'a> {
    fn twin(&mut self) -> Option<&Result<crate::twin::Twin>> {
        let name = self.event.structure.as_ref()?.twin.as_ref()?;
        if self.loaded.is_none() {
            let path = match self.event_dir {
                Some(dir) => dir.join(name),
                None => Path::new(name).to_path_buf(),
            };
            self.loaded = Some(crate::twin::load_twin(&path));
        }
        self.loaded.as_ref()
    }
}

fn manifest_location(event_dir: Option<&Path>) -> Location {
    Location::file(match event_dir {
        Some(d) => d.join("event.toml").display().to_string(),
        None => "event.toml".to_string(),
    })
}

fn err_clone(e: &Error) -> Error {
    match e {
        Error::Input { location, message } => Error::input((**location).clone(), message.clone()),
        other => Error::usage(other.to_string()),
    }
}

/// Storey masses of levels 1..=top from the manifest (when it lists enough)
/// or the twin. `channel` names the first floor channel in errors.
fn storey_masses(
    event: &Event,
    twins: &mut TwinSource,
    direction: &str,
    top: usize,
    channel: &str,
) -> Result<(Vec<f64>, String)> {
    let structure = event.structure.as_ref();
    if let Some(s) = structure.filter(|s| s.masses_kg.len() >= top) {
        return Ok((
            s.masses_kg[..top].to_vec(),
            "event.toml structure.masses_kg".into(),
        ));
    }
    match twins.twin() {
        Some(Ok(twin)) => {
            let Some(model) = &twin.model else {
                return Err(Error::input(
                    Location::file(twin.source.clone()),
                    "storey masses need a mesh twin (node coordinates); give structure.masses_kg in event.toml",
                ));
            };
            let axis = horizontal_axis(model.dimension, direction).ok_or_else(|| {
                Error::input(
                    Location::file(twin.source.clone()),
                    format!("direction {direction} is not a horizontal axis (X, or Y in 3D) of the twin"),
                )
            })?;
            let heights = structure.map(|s| s.storey_heights_m.clone()).unwrap_or_default();
            if heights.len() < top {
                return Err(Error::input(
                    manifest_location(twins.event_dir).with_channel(channel.to_string()),
                    format!(
                        "direction {direction}: storey masses from the twin need structure.storey_heights_m for levels 1..{top} (to assign twin nodes to levels)"
                    ),
                ));
            }
            let masses = twin_storey_masses(&twin.system, model, axis, &heights)?;
            if let Some(l) = masses[..top].iter().position(|m| !(*m > 0.0)) {
                return Err(Error::input(
                    Location::file(twin.source.clone()),
                    format!("the twin has no mass at level {} along {direction}", l + 1),
                ));
            }
            Ok((masses[..top].to_vec(), format!("twin {}", twin.source)))
        }
        Some(Err(e)) => Err(err_clone(e)),
        None => Err(Error::input(
            manifest_location(twins.event_dir).with_channel(channel.to_string()),
            format!(
                "direction {direction}: lumped masses missing for levels 1..{top}: restoring forces f_d = −m_d (a + ü_d) (Eq. 46) need \
                 structure.masses_kg in event.toml, a twin (structure.twin), or masses_kg in the stage's directions"
            ),
        )),
    }
}

/// Resolves the masses of every direction (Eq. 35–36 shared σ per set of
/// instrumented levels).
fn resolve_masses(
    event: &Event,
    event_dir: Option<&Path>,
    specs: &[DirectionSpec],
    step: f64,
) -> Vec<Result<MassResolution>> {
    let mut twins = TwinSource {
        event,
        event_dir,
        loaded: None,
    };
    let mut out: Vec<Result<MassResolution>> = Vec::with_capacity(specs.len());
    // Directions needing reduced masses: (index, storey masses, source, top level).
    let mut pending: Vec<(usize, Vec<f64>, String, Vec<i32>)> = Vec::new();
    for (i, spec) in specs.iter().enumerate() {
        let first = spec.floors.first().cloned().unwrap_or_default();
        let levels: Result<Vec<i32>> = spec
            .floors
            .iter()
            .map(|id| {
                event
                    .record(id)
                    .and_then(|r| r.channel.level)
                    .ok_or_else(|| {
                        Error::input(
                            Location::file(event.name.clone()).with_channel(id.clone()),
                            format!(
                                "direction {}: floor channel {id} is missing or has no level",
                                spec.direction
                            ),
                        )
                    })
            })
            .collect();
        let base = MassResolution {
            direction: spec.direction.clone(),
            channels: spec.floors.clone(),
            levels: Vec::new(),
            masses_kg: Vec::new(),
            source: String::new(),
            reduced: None,
        };
        if let Some(m) = &spec.masses_kg {
            out.push(Ok(MassResolution {
                levels: levels.unwrap_or_default(),
                masses_kg: m.clone(),
                source: "stage params".into(),
                ..base
            }));
            continue;
        }
        let levels = match levels {
            Ok(l) => l,
            Err(e) => {
                out.push(Err(e));
                continue;
            }
        };
        let contiguous = levels.iter().enumerate().all(|(d, l)| *l == d as i32 + 1);
        let top = levels.iter().copied().max().unwrap_or(0).max(0) as usize;
        if contiguous {
            out.push(
                storey_masses(event, &mut twins, &spec.direction, top, &first).map(
                    |(masses, source)| MassResolution {
                        levels: levels.clone(),
                        masses_kg: masses,
                        source,
                        ..base
                    },
                ),
            );
            continue;
        }
        if levels.len() != 2 || levels.iter().any(|l| *l < 1) {
            out.push(Err(Error::input(
                manifest_location(event_dir).with_channel(first.clone()),
                format!(
                    "direction {}: floor channels at levels {levels:?}; reduced lumped masses (Eq. 35–36) are defined for two instrumented floors",
                    spec.direction
                ),
            )));
            continue;
        }
        if twins.twin().is_none() {
            out.push(Err(Error::input(
                manifest_location(event_dir).with_channel(first.clone()),
                format!(
                    "direction {}: floor channels at levels {levels:?} leave floors uninstrumented; reduced lumped masses (Eq. 35–36) \
                     need the digital twin's reduced stiffness and first frequency: name it in structure.twin",
                    spec.direction
                ),
            )));
            continue;
        }
        match storey_masses(event, &mut twins, &spec.direction, top, &first) {
            Ok((masses, source)) => {
                out.push(Ok(base));
                pending.push((i, masses, source, levels));
            }
            Err(e) => out.push(Err(e)),
        }
    }
    // Eq. 35–36: one σ per set of instrumented levels, over its directions.
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (k, p) in pending.iter().enumerate() {
        match groups.iter_mut().find(|g| pending[g[0]].3 == p.3) {
            Some(g) => g.push(k),
            None => groups.push(vec![k]),
        }
    }
    for group in groups {
        let (_, storey, source, levels) = &pending[group[0]];
        let la = levels[0] as usize;
        let lb = levels[1] as usize;
        let instrumented = [storey[la - 1], storey[lb - 1]];
        let uninstrumented_levels: Vec<i32> = (1..=storey.len() as i32)
            .filter(|l| !levels.contains(l))
            .collect();
        let m_u: f64 = uninstrumented_levels
            .iter()
            .map(|l| storey[*l as usize - 1])
            .sum();
        let targets: Vec<Result<ReducedMassTarget>> = group
            .iter()
            .map(|&k| {
                let spec = &specs[pending[k].0];
                let twin = match twins.twin() {
                    Some(Ok(t)) => t,
                    Some(Err(e)) => return Err(err_clone(e)),
                    None => return Err(Error::usage("twin vanished")),
                };
                let dimension = twin
                    .model
                    .as_ref()
                    .map(|m| m.dimension)
                    .unwrap_or(crate::twin::Dimension::Three);
                let axis = horizontal_axis(dimension, &spec.direction).ok_or_else(|| {
                    Error::input(
                        Location::file(twin.source.clone()),
                        format!(
                            "direction {} is not a horizontal axis of the twin",
                            spec.direction
                        ),
                    )
                })?;
                twin_reduced_target(
                    &twin.system,
                    [spec.floors[0].as_str(), spec.floors[1].as_str()],
                    axis,
                )
            })
            .collect();
        let result = targets
            .iter()
            .map(|t| t.as_ref().map(|t| *t).map_err(err_clone))
            .collect::<Result<Vec<_>>>()
            .and_then(|t| reduced_lumped_masses(instrumented, m_u, &t, step).map(|r| (r, t)));
        let directions: Vec<String> = group
            .iter()
            .map(|&k| specs[pending[k].0].direction.clone())
            .collect();
        for (j, &k) in group.iter().enumerate() {
            let index = pending[k].0;
            out[index] = match &result {
                Ok((r, t)) => Ok(MassResolution {
                    direction: specs[index].direction.clone(),
                    channels: specs[index].floors.clone(),
                    levels: levels.clone(),
                    masses_kg: vec![r.m1, r.m2],
                    source: "reduced (Eq. 35–36)".into(),
                    reduced: Some(ReducedMassRecord {
                        storey_masses_kg: storey.clone(),
                        storey_masses_source: source.clone(),
                        uninstrumented_levels: uninstrumented_levels.clone(),
                        sigma1: r.sigma1,
                        sigma2: r.sigma2,
                        sigma_step: step,
                        cost_rad_s: r.cost,
                        directions: directions.clone(),
                        reduced_stiffness_n_per_m: t[j].stiffness,
                        omega_fe_rad_s: t[j].omega_fe,
                    }),
                }),
                Err(e) => Err(err_clone(e)),
            };
        }
    }
    out
}

/// Runs the identification on `event` for every direction (no event folder:
/// a twin named by the manifest is resolved against the working directory).
pub fn identify_event(event: &Event, p: &HysteresisParams) -> Result<Vec<DirectionOutcome>> {
    identify_event_at(event, None, p).map(|(o, _)| o)
}

/// Runs the identification on `event` (loaded from `event_dir`, against which
/// the manifest's twin path is resolved) for every direction; returns the
/// outcomes and, per direction with resolvable masses, which masses were used.
pub fn identify_event_at(
    event: &Event,
    event_dir: Option<&Path>,
    p: &HysteresisParams,
) -> Result<(Vec<DirectionOutcome>, Vec<MassResolution>)> {
    let settings = p.identify_settings()?;
    if !(p.reduced_mass_step > 0.0 && p.reduced_mass_step <= 0.001) {
        return Err(Error::usage(
            "reduced_mass_step must be in (0, 0.001] (Eq. 35–36 search resolution)",
        ));
    }
    let mut event = event.clone();
    if let Some(c) = &p.conditioning {
        condition_event(&mut event, c)?;
    }
    let (specs, mut outcomes) = match &p.directions {
        Some(d) => (d.clone(), Vec::new()),
        None => auto_directions(&event),
    };
    let masses = resolve_masses(&event, event_dir, &specs, p.reduced_mass_step);
    let results: Vec<(String, Result<_>)> = {
        use rayon::prelude::*;
        specs
            .par_iter()
            .zip(masses.par_iter())
            .map(|(spec, mass)| {
                let floors: Vec<&str> = spec.floors.iter().map(|s| s.as_str()).collect();
                let r = mass.as_ref().map_err(err_clone).and_then(|mass| {
                    DirectionRecords::from_event(
                        &event,
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
                        identify_direction(&rec, &settings)
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

/// Writes the three identification tables.
pub fn write_identification(
    dir: &std::path::Path,
    outcomes: &[DirectionOutcome],
    masses: &[MassResolution],
    p: &HysteresisParams,
) -> Result<()> {
    let settings_json = serde_json::json!({
        "form": p.form, "band_low_hz": p.band_low_hz, "exponent_min": p.exponent_min,
        "exponent_max": p.exponent_max, "exponent_resolution": p.exponent_resolution,
        "velocity_drift": p.velocity_drift, "reduced_mass_step": p.reduced_mass_step,
        "conditioning": p.conditioning,
    });
    let processing: serde_json::Map<String, serde_json::Value> = outcomes
        .iter()
        .filter_map(|o| match o {
            DirectionOutcome::Identified(d) => Some((
                d.direction.clone(),
                serde_json::to_value(&d.processing).unwrap_or_default(),
            )),
            _ => None,
        })
        .collect();
    let meta = vec![
        ("quaketwin.settings".to_string(), settings_json.to_string()),
        (
            "quaketwin.history".to_string(),
            serde_json::Value::Object(processing).to_string(),
        ),
        (
            "quaketwin.masses".to_string(),
            serde_json::to_string(masses).unwrap_or_default(),
        ),
    ];
    tables::write_bouc_wen(&dir.join("bouc_wen.parquet"), outcomes, &meta)?;
    tables::write_instantaneous(&dir.join("bouc_wen_instantaneous.parquet"), outcomes)?;
    tables::write_fit(
        &dir.join("hysteresis_fit.parquet"),
        outcomes,
        p.output_decimation,
    )
}

pub fn run(stage: &StageDecl, ctx: &mut RunContext) -> Result<()> {
    let p: HysteresisParams = params(stage)?;
    let event_dir = ctx.event_path.clone();
    let quiet = ctx.quiet;
    let (outcomes, masses) = identify_event_at(&ctx.loaded_event()?.event, Some(&event_dir), &p)?;
    if !quiet {
        for m in &masses {
            eprintln!("[hysteresis] {}", m.message());
        }
    }
    write_identification(&ctx.out_dir, &outcomes, &masses, &p)?;
    ctx.hysteresis = Some((outcomes, p));
    Ok(())
}

/// Parameters of the `damage` stage.
#[derive(Debug, Clone, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct DamageParams {
    /// Keep every n-th time step in damage.parquet (the last is always kept).
    pub output_decimation: usize,
}

pub fn run_damage(stage: &StageDecl, ctx: &mut RunContext) -> Result<()> {
    let p: DamageParams = params(stage)?;
    if ctx.hysteresis.is_none() {
        // The identification is not stored in a form that can be loaded back
        // whole; when `hysteresis` was skipped it is recomputed in memory
        // (its outputs are not rewritten).
        let decl = ctx
            .stage_decl_of_kind("hysteresis")
            .ok_or_else(|| Error::usage("the damage stage needs a hysteresis stage before it"))?;
        let hp: HysteresisParams = params(&decl)?;
        let event_dir = ctx.event_path.clone();
        let (outcomes, _) = identify_event_at(&ctx.loaded_event()?.event, Some(&event_dir), &hp)?;
        ctx.hysteresis = Some((outcomes, hp));
    }
    let (outcomes, _) = ctx.hysteresis.as_ref().expect("set above"); // ok: set above
    tables::write_damage(
        &ctx.out_dir.join("damage.parquet"),
        outcomes,
        p.output_decimation.max(1),
    )
}
