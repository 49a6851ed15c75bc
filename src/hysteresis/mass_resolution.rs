//! Lumped masses of each identified direction (Eq. 46 needs m_d): from the
//! stage's params, else from the level masses of the building (the event
//! manifest's `structure.masses_kg`, or the digital twin's storey masses).
//! When every level 1..n has a channel they are used as they are; when some
//! level has none (below, between or above the instrumented ones) the chain
//! is reduced to the instrumented levels (`mass_lumping`):
//! - the thesis's reduced masses of Eq. 35–36 (σ search against the twin,
//!   one σ shared by the directions of the same instrumented levels) when
//!   exactly two floors are instrumented and the twin has a `[[sensors]]`
//!   entry for both (`auto`, `eq35_36`);
//! - otherwise (`auto`, `tributary`) Eq. 35–36 generalised to any set of
//!   instrumented levels: the tributary lumping of [`super::lumping`].

use std::path::Path;

use serde::Serialize;

use super::event::DirectionSpec;
use super::lumping::{segment_label, tributary_masses, LumpedMasses};
use super::storey_masses::{horizontal_axis, twin_reduced_target, twin_storey_masses};
use super::{reduced_lumped_masses, ReducedMassTarget};
use crate::error::{Error, Location, Result};
use crate::vocab::Event;

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
/// `quaketwin.masses` metadata of bouc_wen/bouc_wen.parquet and logged by the stage).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MassResolution {
    pub direction: String,
    /// Floor channels, DoF 1..D.
    pub channels: Vec<String>,
    /// Their levels (1-based; gaps = non-instrumented floors).
    pub levels: Vec<i32>,
    /// Lumped mass per DoF used in Eq. 46, kg.
    pub masses_kg: Vec<f64>,
    /// `stage params`, `event.toml structure.masses_kg`, `twin FILE`,
    /// `reduced (Eq. 35–36)` or `tributary lumping (Eq. 35–36 generalised) of …`.
    pub source: String,
    pub reduced: Option<ReducedMassRecord>,
    /// The tributary lumping, when the masses come from it.
    pub lumping: Option<LumpedMasses>,
}

/// How the masses of uninstrumented levels enter the chain (docs/pipelines.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MassLumping {
    /// Eq. 35–36 when two floors are instrumented and the twin has sensors
    /// for both; tributary lumping otherwise.
    #[default]
    Auto,
    /// Tributary lumping (`lumping` module) for every partly instrumented chain.
    Tributary,
    /// The thesis's Eq. 35–36 only: two instrumented floors and the twin.
    Eq35_36,
}

impl MassResolution {
    /// Segment names of the DoFs: `L0-L1`, `L1-L3`, … (DoF d spans from the
    /// level below it to its own).
    pub fn segments(&self) -> Vec<String> {
        (0..self.levels.len())
            .map(|d| segment_label(&self.levels, d))
            .collect()
    }
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
        if let Some(l) = &self.lumping {
            s.push_str(&format!(
                "; segments {}: uninstrumented levels lumped linearly by elevation ({}), {:.6e} kg onto the base",
                self.segments().join(", "),
                l.elevation_source,
                l.dropped_to_base_kg
            ));
        }
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

/// Masses of every level 1..n of the building (n ≥ top) from the manifest
/// (when it lists enough) or the twin. `channel` names the first floor
/// channel in errors.
fn storey_masses(
    event: &Event,
    twins: &mut TwinSource,
    direction: &str,
    top: usize,
    channel: &str,
) -> Result<(Vec<f64>, String)> {
    let structure = event.structure.as_ref();
    if let Some(s) = structure.filter(|s| s.masses_kg.len() >= top) {
        return Ok((s.masses_kg.clone(), "event.toml structure.masses_kg".into()));
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
            Ok((masses, format!("twin {}", twin.source)))
        }
        Some(Err(e)) => Err(e.duplicate()),
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
pub fn resolve_masses(
    event: &Event,
    event_dir: Option<&Path>,
    specs: &[DirectionSpec],
    step: f64,
    lumping: MassLumping,
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
            lumping: None,
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
        let top = levels.iter().copied().max().unwrap_or(0).max(0) as usize;
        let (masses, source) = match storey_masses(event, &mut twins, &spec.direction, top, &first)
        {
            Ok(m) => m,
            Err(e) => {
                out.push(Err(e));
                continue;
            }
        };
        let every_level = levels.len() == masses.len()
            && levels.iter().enumerate().all(|(d, l)| *l == d as i32 + 1);
        if every_level {
            out.push(Ok(MassResolution {
                levels,
                masses_kg: masses,
                source,
                ..base
            }));
            continue;
        }
        match eq35_applies(lumping, &levels, &spec.floors, &mut twins) {
            Ok(true) => {
                out.push(Ok(base));
                pending.push((i, masses, source, levels));
            }
            Ok(false) => out.push(tributary(event, masses, source, levels, base)),
            Err(message) => out.push(Err(Error::input(
                manifest_location(event_dir).with_channel(first.clone()),
                format!("direction {}: {message}", spec.direction),
            ))),
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
                    Some(Err(e)) => return Err(e.duplicate()),
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
            .map(|t| t.as_ref().map(|t| *t).map_err(Error::duplicate))
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
                    lumping: None,
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
                Err(e) => Err(e.duplicate()),
            };
        }
    }
    out
}

/// Whether the thesis's Eq. 35–36 gives the masses of a partly instrumented
/// chain (module doc); `Err` when `eq35_36` is asked for and cannot apply.
fn eq35_applies(
    lumping: MassLumping,
    levels: &[i32],
    channels: &[String],
    twins: &mut TwinSource,
) -> std::result::Result<bool, String> {
    if lumping == MassLumping::Tributary {
        return Ok(false);
    }
    let why_not = if levels.len() != 2 {
        Some(format!(
            "floor channels at levels {levels:?}; the reduced masses of Eq. 35–36 are defined for two instrumented floors (use mass_lumping = \"tributary\")"
        ))
    } else {
        match twins.twin() {
            None => Some(format!(
                "floor channels at levels {levels:?} leave floors uninstrumented; reduced lumped masses (Eq. 35–36) need the digital twin's \
                 reduced stiffness and first frequency: name it in structure.twin (or use mass_lumping = \"tributary\")"
            )),
            Some(Err(e)) => Some(e.to_string()),
            Some(Ok(t)) => channels
                .iter()
                .find(|c| !t.system.sensors.iter().any(|s| &s.channel == *c))
                .map(|c| format!("channel {c} has no [[sensors]] entry in the twin {}: Eq. 35–36 needs the twin DoF of both instrumented floors", t.source)),
        }
    };
    match (why_not, lumping) {
        (None, _) => Ok(true),
        (Some(m), MassLumping::Eq35_36) => Err(m),
        (Some(_), _) => Ok(false),
    }
}

/// Tributary lumping (Eq. 35–36 generalised, `lumping` module) of the level
/// masses onto the instrumented `levels`.
fn tributary(
    event: &Event,
    level_masses: Vec<f64>,
    source: String,
    levels: Vec<i32>,
    base: MassResolution,
) -> Result<MassResolution> {
    let heights = event
        .structure
        .as_ref()
        .map(|s| s.storey_heights_m.clone())
        .unwrap_or_default();
    let lumped = tributary_masses(&level_masses, &heights, &levels)?;
    Ok(MassResolution {
        levels,
        masses_kg: lumped.masses_kg.clone(),
        source: format!("tributary lumping (Eq. 35–36 generalised) of {source}"),
        lumping: Some(lumped),
        ..base
    })
}
