//! `design`: hybrid-test design from recorded response (thesis ch. 5–7, METHODS §5–6;
//! numerical work in `crate::design::plan`). Reads a design file (`crate::design_file`),
//! builds the base motion — the run's conditioned event, or a ground-motion file — and writes
//! the design tables (`crate::sinks::design_tables`).
//!
//! Base channels → twin axes. A base channel is a level-0, role-input acceleration channel
//! (as for the hysteresis stage), or any channel the design file lists in `[motion] channels`.
//! Its direction maps to a twin axis:
//! - the twin's vertical axis is the axis of its gravity vector (y for plane twins, z for
//!   spatial ones by default); `Z` / `UP` channels act along it, `DOWN` channels along it with
//!   the sign reversed;
//! - the horizontal twin axes, in order x, y, z without the vertical one, take building `X`
//!   then `Y`: a spatial twin maps X → x, Y → y; a plane (x–y) twin maps X → x and has no
//!   axis for Y (out of plane);
//! - azimuth-labelled channels have no building axis: normalise them in the condition stage
//!   (event.toml `structure.x_axis_azimuth_deg`) or name their axis in the design file;
//! - `[motion] axis = { CHANNEL = "x" }` overrides the mapping of a channel (sign +).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::conditioning::integrate::{integrate_motion, DriftControl};
use crate::conditioning::{condition_event_with_motion, ConditioningSettings};
use crate::design::plan::{design_hybrid_test_with, BaseComponent, BaseMotion, TestDesign};
use crate::design::recorded::RecordedResponse;
use crate::design_file::{load_design, settings_json, LoadedDesign, MotionSource, MotionSpec};
use crate::error::{Error, Location, Result};
use crate::pipeline::fingerprint::{path_fingerprint, Fnv64};
use crate::pipeline::{params, PipelineFile, RunContext, StageDecl};
use crate::readers::{self, Format, ReadOptions};
use crate::sinks::design_tables::{write_design, DesignProvenance, DESIGN_FILES};
use crate::twin::model::{Dimension, Model};
use crate::vocab::{Axis, Direction, Event, Role, SourceRef};

/// The test-design pipeline (ingest → condition → design), embedded so that
/// `quaketwin design` conditions an event exactly as `pipelines/test-design.toml` does.
pub const TEST_DESIGN_PIPELINE: &str = include_str!("../../pipelines/test-design.toml");

/// Parameters of the `design` stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignParams {
    /// Design file (docs/test-design.md), relative to the event folder (to the directory of
    /// an event zip), or absolute.
    pub design: String,
}

/// What a design run produced (also what `quaketwin design` prints).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DesignSummary {
    pub design_file: String,
    pub twin: String,
    pub motion: String,
    pub ps_nodes: usize,
    pub ps_dofs: usize,
    pub interface_dofs: usize,
    pub rigid_body_modes: usize,
    pub retained_poms: usize,
    pub retained_energy: f64,
    pub control_nodes: usize,
    /// Steps of the interface refinement (rows of interface_refinement.parquet).
    pub refinement_steps: usize,
    pub actuators: usize,
    pub force_controlled: usize,
    pub wnrmse: f64,
    pub wnrmse_total: f64,
    pub ns_modes: usize,
    pub time_scale: f64,
    pub bandwidth_hz: f64,
    pub outputs: Vec<PathBuf>,
}

/// Conditioning settings of the condition stage of the embedded test-design pipeline (the
/// same chain as pipelines/post-earthquake.toml).
pub fn event_conditioning_settings() -> Result<ConditioningSettings> {
    let p = PipelineFile::parse(TEST_DESIGN_PIPELINE, "built-in test-design pipeline")?;
    let stage = p
        .stages
        .iter()
        .find(|s| s.kind == "condition")
        .ok_or_else(|| Error::usage("built-in test-design pipeline has no condition stage"))?;
    params(stage)
}

/// Twin axis (0 = x, 1 = y, 2 = z) of gravity: the component of largest magnitude; a twin
/// without gravity takes y (plane) or z (spatial).
pub fn vertical_axis(model: &Model) -> usize {
    let g = model.gravity;
    let best = (0..3).fold(0usize, |b, i| if g[i].abs() > g[b].abs() { i } else { b });
    if g[best] != 0.0 {
        best
    } else if model.dimension == Dimension::Two {
        1
    } else {
        2
    }
}

/// Twin axis and sign of a channel direction (see the module notes), or why there is none.
pub fn twin_axis_of(
    direction: Option<Direction>,
    model: &Model,
) -> std::result::Result<(usize, f64), String> {
    let vertical = vertical_axis(model);
    let plane = model.dimension == Dimension::Two;
    let horizontal: Vec<usize> = (0..3)
        .filter(|&a| a != vertical && (!plane || a < 2))
        .collect();
    match direction {
        None => Err("the channel has no direction".into()),
        Some(Direction::Up) | Some(Direction::Axis(Axis::Z)) => Ok((vertical, 1.0)),
        Some(Direction::Down) => Ok((vertical, -1.0)),
        Some(Direction::Axis(Axis::X)) => horizontal
            .first()
            .map(|&a| (a, 1.0))
            .ok_or_else(|| "the twin has no horizontal axis for X".into()),
        Some(Direction::Axis(Axis::Y)) => horizontal.get(1).map(|&a| (a, 1.0)).ok_or_else(|| {
            "building Y is out of the plane of this plane twin (it has one horizontal axis, x)"
                .into()
        }),
        Some(Direction::Azimuth(az)) => Err(format!(
            "the channel points at azimuth {az}°, not along a building axis: state the building axes in event.toml (structure.x_axis_azimuth_deg) or name its axis in [motion] axis"
        )),
    }
}

fn axis_name(axis: usize) -> &'static str {
    ["x", "y", "z"].get(axis).copied().unwrap_or("?")
}

/// One component per twin axis from channels (id, direction, dt, samples); checks common
/// sampling, distinct axes and axes the twin has; applies scale and duration.
fn assemble_motion(
    parts: Vec<(String, usize, f64, f64, Vec<f64>)>,
    spec: &MotionSpec,
    model: &Model,
    design_source: &str,
    origin: &str,
) -> Result<BaseMotion> {
    let loc = || Location::file(design_source.to_string()).at_line(spec.line);
    let Some(first) = parts.first() else {
        return Err(Error::input(
            loc(),
            format!("{origin}: no base motion channel"),
        ));
    };
    let dt = first.3;
    let mut used: Vec<(usize, String)> = Vec::new();
    for (id, axis, _, step, _) in &parts {
        if (step - dt).abs() > 1e-9 * dt {
            return Err(Error::input(
                loc().with_channel(id.clone()),
                format!(
                    "{origin}: channel {id} is sampled every {step} s, channel {} every {dt} s; resample them to a common rate (condition stage `resample_hz`)",
                    first.0
                ),
            ));
        }
        if model.dimension.translation_dof(*axis).is_none() {
            return Err(Error::input(
                loc().with_channel(id.clone()),
                format!(
                    "{origin}: channel {id} acts along twin axis {}, which this plane twin does not have",
                    axis_name(*axis)
                ),
            ));
        }
        if let Some((_, other)) = used.iter().find(|(a, _)| a == axis) {
            return Err(Error::input(
                loc().with_channel(id.clone()),
                format!(
                    "{origin}: channels {other} and {id} both act along twin axis {}; select one with [motion] channels",
                    axis_name(*axis)
                ),
            ));
        }
        used.push((*axis, id.clone()));
    }
    let mut n = parts.iter().map(|p| p.4.len()).min().unwrap_or(0);
    if let Some(d) = spec.duration_s {
        n = n.min((d / dt).round() as usize + 1);
    }
    if n < 2 {
        return Err(Error::input(
            loc(),
            format!("{origin}: fewer than two samples of base motion"),
        ));
    }
    let mut desc = Vec::new();
    let components = parts
        .into_iter()
        .map(|(id, axis, sign, _, samples)| {
            desc.push(format!("{id}→{}", axis_name(axis)));
            BaseComponent {
                axis,
                acceleration: samples[..n].iter().map(|v| v * sign * spec.scale).collect(),
            }
        })
        .collect();
    let mut source = format!("{origin} [{}]", desc.join(", "));
    if spec.scale != 1.0 {
        source.push_str(&format!(" × {}", spec.scale));
    }
    source.push_str(&format!(", {n} samples at {dt} s"));
    Ok(BaseMotion {
        dt,
        components,
        source,
    })
}

/// Base motion from a conditioned event (see the module notes for channel selection and the
/// axis mapping). `channels` / `axes` come from the design file's `[motion]` table.
pub fn base_motion_from_event(
    event: &Event,
    origin: &str,
    channels: &[String],
    axes: &std::collections::BTreeMap<String, usize>,
    spec: &MotionSpec,
    model: &Model,
    design_source: &str,
) -> Result<BaseMotion> {
    let loc = || Location::file(design_source.to_string()).at_line(spec.line);
    let records: Vec<&crate::vocab::Record> = if channels.is_empty() {
        event
            .records
            .iter()
            .filter(|r| {
                r.channel.level == Some(0)
                    && r.channel.role == Role::Input
                    && r.channel.units.is_acceleration()
            })
            .collect()
    } else {
        let mut out = Vec::new();
        for id in channels {
            let Some(r) = event.records.iter().find(|r| &r.channel.id == id) else {
                return Err(Error::input(
                    loc().with_channel(id.clone()),
                    format!("[motion] channels: event {origin} has no channel {id:?}"),
                ));
            };
            if !r.channel.units.is_acceleration() {
                return Err(Error::input(
                    loc().with_channel(id.clone()),
                    format!(
                        "[motion] channels: channel {id} is in {}, not an acceleration",
                        r.channel.units.name()
                    ),
                ));
            }
            out.push(r);
        }
        out
    };
    if records.is_empty() {
        return Err(Error::input(
            loc(),
            format!(
                "event {origin} has no base channel (level 0, role input, acceleration); list the channels to use in [motion] channels"
            ),
        ));
    }
    for id in axes.keys() {
        if !records.iter().any(|r| &r.channel.id == id) {
            return Err(Error::input(
                loc().with_channel(id.clone()),
                format!("[motion] axis names channel {id:?}, which is not a base motion channel of event {origin}"),
            ));
        }
    }
    let mut parts = Vec::with_capacity(records.len());
    for r in records {
        let id = r.channel.id.clone();
        let (axis, sign) = match axes.get(&id) {
            Some(&a) => (a, 1.0),
            None => twin_axis_of(r.channel.direction, model).map_err(|why| {
                Error::input(
                    loc().with_channel(id.clone()),
                    format!("channel {id}: {why}"),
                )
            })?,
        };
        parts.push((id, axis, sign, r.channel.dt(), r.samples.clone()));
    }
    parts.sort_by_key(|p| p.1);
    assemble_motion(
        parts,
        spec,
        model,
        design_source,
        &format!("event {origin}"),
    )
}

/// Base motion from a ground-motion file (any format quaketwin reads), converted to m/s² and
/// used as recorded (no filtering: such files are usually processed records already).
pub fn base_motion_from_file(
    spec: &MotionSpec,
    model: &Model,
    design_source: &str,
) -> Result<BaseMotion> {
    let MotionSource::File {
        path,
        format,
        column,
        time_column,
        sampling_rate_hz,
        axis,
    } = &spec.source
    else {
        return Err(Error::usage(
            "base_motion_from_file: the motion is not a file",
        ));
    };
    let loc = || Location::file(design_source.to_string()).at_line(spec.line);
    let name = path.display().to_string();
    let bytes = std::fs::read(path)
        .map_err(|e| Error::input(loc(), format!("[motion] file {name}: {e}")))?;
    let fmt = match format {
        Some(f) => Format::from_name(f).ok_or_else(|| {
            Error::input(
                loc(),
                format!("[motion] format {f:?} is not a format quaketwin reads"),
            )
        })?,
        None => readers::sniff(&name, &bytes[..bytes.len().min(8192)]).ok_or_else(|| {
            Error::input(
                loc(),
                format!("[motion] file {name}: format not recognised; give `format`"),
            )
        })?,
    };
    let source = SourceRef {
        file: name.clone(),
        member: None,
        column: column.clone(),
        format: fmt.name().into(),
    };
    let opts = ReadOptions {
        sampling_rate_hz: *sampling_rate_hz,
        columns: column.as_ref().map(|c| vec![c.clone()]),
        time_column: time_column.clone(),
    };
    let contents = readers::read(fmt, &bytes, &source, &opts)?;
    let record = match contents.records.len() {
        1 => &contents.records[0],
        0 => {
            return Err(Error::input(
                Location::file(name),
                "no acceleration record in this file",
            ))
        }
        k => {
            return Err(Error::input(
                loc(),
                format!("[motion] file {name} holds {k} channels; choose one with `column`"),
            ))
        }
    };
    let units = record.channel.units;
    if !units.is_acceleration() {
        return Err(Error::input(
            Location::file(name),
            format!("the record is in {}, not an acceleration", units.name()),
        ));
    }
    let factor = units.to_si_factor().ok_or_else(|| {
        Error::input(
            Location::file(name.clone()),
            "the record is in counts without a sensitivity",
        )
    })?;
    let samples: Vec<f64> = record.samples.iter().map(|v| v * factor).collect();
    if let Some(i) = samples.iter().position(|v| !v.is_finite()) {
        return Err(Error::input(
            Location::file(name),
            format!("non-finite sample at index {i}"),
        ));
    }
    let dt = record.channel.dt();
    if !(dt.is_finite() && dt > 0.0) {
        return Err(Error::input(
            Location::file(name),
            "the record states no positive sampling rate",
        ));
    }
    assemble_motion(
        vec![(record.channel.id.clone(), *axis, 1.0, dt, samples)],
        spec,
        model,
        design_source,
        &format!("file {name}"),
    )
}

/// The design's base motion when run on its own (`quaketwin design`): the event folder of the
/// design file, loaded and conditioned like the pipeline's condition stage, or the file.
pub fn load_motion(design: &LoadedDesign) -> Result<BaseMotion> {
    Ok(load_inputs(design)?.0)
}

/// The base motion and, with `[snapshots] source = "records"`, the recorded response.
pub fn load_inputs(design: &LoadedDesign) -> Result<(BaseMotion, Option<RecordedResponse>)> {
    let model = design.model()?;
    match &design.motion.source {
        MotionSource::Event {
            folder,
            channels,
            axes,
        } => {
            let loaded = crate::event_folder::load(folder)?;
            let mut event = loaded.event;
            condition_event_with_motion(&mut event, &event_conditioning_settings()?)?;
            let origin = folder.display().to_string();
            let motion = base_motion_from_event(
                &event,
                &origin,
                channels,
                axes,
                &design.motion,
                model,
                &design.source,
            )?;
            let recorded = if design.snapshots_from_records {
                Some(recorded_response_from_event(
                    &event, &origin, design, &motion,
                )?)
            } else {
                None
            };
            Ok((motion, recorded))
        }
        MotionSource::File { .. } => Ok((
            base_motion_from_file(&design.motion, model, &design.source)?,
            None,
        )),
    }
}

/// Snapshot source (b): the event's records at PS nodes. Channels are mapped to twin DoFs by
/// the twin's `[[sensors]]` (node and DoF); each PS translation DoF's absolute acceleration
/// minus the base motion along the same axis is integrated twice with polynomial drift
/// control (`DriftControl::default()`), over the motion's samples. Errors name the channel
/// whose step differs from the motion's or whose sensor DoF is a rotation.
pub fn recorded_response_from_event(
    event: &Event,
    origin: &str,
    design: &LoadedDesign,
    motion: &BaseMotion,
) -> Result<RecordedResponse> {
    let model = design.model()?;
    let in_ps: std::collections::BTreeSet<i64> = design.ps_node_ids.iter().copied().collect();
    let mut dofs = Vec::new();
    let mut displacement = Vec::new();
    let mut used = Vec::new();
    let steps = motion
        .components
        .iter()
        .map(|c| c.acceleration.len())
        .min()
        .unwrap_or(0);
    for sensor in &design.twin.file.sensors {
        let (Some(node), Some(dof)) = (sensor.node, sensor.dof.as_ref()) else {
            continue;
        };
        if !in_ps.contains(&node) {
            continue;
        }
        let Some(record) = event
            .records
            .iter()
            .find(|r| r.channel.id == sensor.channel)
        else {
            continue;
        };
        let loc = || Location::file(design.source.clone()).with_channel(sensor.channel.clone());
        let d = model.dimension.dof_names().iter().position(|n| n == dof);
        let axis = d.and_then(|d| (0..3).find(|&a| model.dimension.translation_dof(a) == Some(d)));
        let Some(axis) = axis else {
            return Err(Error::input(
                loc(),
                format!(
                    "[snapshots] records: sensor {} measures {dof}, not a translation",
                    sensor.channel
                ),
            ));
        };
        if !record.channel.units.is_acceleration() {
            return Err(Error::input(
                loc(),
                format!(
                    "[snapshots] records: channel {} is in {}, not an acceleration",
                    sensor.channel,
                    record.channel.units.name()
                ),
            ));
        }
        let dt = record.channel.dt();
        if (dt - motion.dt).abs() > 1e-9 * motion.dt {
            return Err(Error::input(
                loc(),
                format!("[snapshots] records: channel {} is sampled every {dt} s, the base motion every {} s; resample in the condition stage", sensor.channel, motion.dt),
            ));
        }
        if record.samples.len() < steps {
            return Err(Error::input(
                loc(),
                format!(
                    "[snapshots] records: channel {} has {} samples, the base motion {steps}",
                    sensor.channel,
                    record.samples.len()
                ),
            ));
        }
        let Some(to_si) = record.channel.units.to_si_factor() else {
            return Err(Error::input(
                loc(),
                format!(
                    "[snapshots] records: channel {} has units {} with no SI factor",
                    sensor.channel,
                    record.channel.units.name()
                ),
            ));
        };
        let base = motion.components.iter().find(|c| c.axis == axis);
        let relative: Vec<f64> = (0..steps)
            .map(|k| record.samples[k] * to_si - base.map(|b| b.acceleration[k]).unwrap_or(0.0))
            .collect();
        let integrated =
            integrate_motion(&sensor.channel, &relative, dt, &DriftControl::default())?;
        dofs.push((node, dof.clone()));
        displacement.push(integrated.displacement);
        used.push(sensor.channel.clone());
    }
    Ok(RecordedResponse {
        dofs,
        displacement,
        source: format!("event {origin}, channels {}", used.join(", ")),
    })
}

/// Run the design and write its outputs into `out_dir`; `recorded` is the snapshot source (b)
/// when the design file asks for it.
pub fn run_design(
    design: &LoadedDesign,
    motion: &BaseMotion,
    recorded: Option<&RecordedResponse>,
    out_dir: &Path,
) -> Result<DesignSummary> {
    let model = design.model()?;
    let d: TestDesign = design_hybrid_test_with(
        &design.twin,
        &design.ps_node_ids,
        motion,
        recorded,
        &design.settings,
        &design.source,
    )?;
    let provenance = DesignProvenance {
        design_file: design.source.clone(),
        twin: design.twin_path.display().to_string(),
        motion_source: motion.source.clone(),
        settings_json: settings_json(&design.settings),
    };
    let outputs = write_design(out_dir, model, &d, &provenance)?;
    let retained = d.pod_curve.retained;
    Ok(DesignSummary {
        design_file: design.source.clone(),
        twin: provenance.twin,
        motion: motion.source.clone(),
        ps_nodes: design.ps_node_ids.len(),
        ps_dofs: d.partition.n_ps(),
        interface_dofs: d.partition.interface.len(),
        rigid_body_modes: d.rigid.count(),
        retained_poms: retained,
        retained_energy: retained
            .checked_sub(1)
            .and_then(|i| d.pod.cumulative_energy.get(i))
            .copied()
            .unwrap_or(0.0),
        control_nodes: d.interface.control_nodes.len(),
        refinement_steps: d.refinement.len(),
        actuators: d.actuators.len(),
        force_controlled: d
            .actuators
            .iter()
            .filter(|a| a.control == crate::design::layout::ControlMode::Force)
            .count(),
        wnrmse: d.validation.wnrmse,
        wnrmse_total: d.validation.wnrmse_total,
        ns_modes: d.hybrid.prototype.ns_modes,
        time_scale: d.hybrid.time_scale,
        bandwidth_hz: d.hybrid.bandwidth_hz,
        outputs,
    })
}

/// `quaketwin design DESIGN --out DIR`: load, build the motion (and the records, snapshot
/// source (b)), design, write.
pub fn design_from_file(design_path: &Path, out_dir: &Path) -> Result<DesignSummary> {
    let design = load_design(design_path)?;
    let (motion, recorded) = load_inputs(&design)?;
    run_design(&design, &motion, recorded.as_ref(), out_dir)
}

/// Output files of the stage.
pub fn outputs() -> Vec<String> {
    DESIGN_FILES.iter().map(|s| s.to_string()).collect()
}

/// The design file of a stage: relative to the event folder; for a zipped event a member
/// of the zip, else a file beside the zip.
fn design_path(stage: &StageDecl, ctx: &mut RunContext) -> Result<PathBuf> {
    let p: DesignParams = params(stage)?;
    let given = Path::new(&p.design);
    if given.is_absolute() {
        return Ok(given.to_path_buf());
    }
    if ctx.referenced.contains(&p.design)? {
        return ctx.referenced.resolve(&p.design, "design file");
    }
    let base = if ctx.event_path.is_dir() {
        ctx.event_path.clone()
    } else {
        ctx.event_path
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default()
    };
    Ok(base.join(given))
}

/// Extra fingerprint of the stage: the design file, its twin and (for a file source) the
/// ground-motion file — inputs outside the event folder that the pipeline would not see.
pub fn fingerprint(stage: &StageDecl, ctx: &mut RunContext) -> Result<String> {
    let path = design_path(stage, ctx)?;
    let design = load_design(&path)?;
    let mut h = Fnv64::default();
    h.write_str(&path_fingerprint(&path)?)
        .write_str(&path_fingerprint(&design.twin_path)?);
    if let MotionSource::File { path: f, .. } = &design.motion.source {
        h.write_str(&path_fingerprint(f)?);
    }
    Ok(h.finish_hex())
}

/// The stage does not apply when the design takes its motion from the event and the event
/// has no base channel (level 0, role input) and the design file lists none.
pub fn not_applicable(stage: &StageDecl, ctx: &mut RunContext) -> Result<Option<String>> {
    let path = design_path(stage, ctx)?;
    let design = load_design(&path)?;
    let MotionSource::Event { channels, .. } = &design.motion.source else {
        return Ok(None);
    };
    if !channels.is_empty() {
        return Ok(None);
    }
    let has_base = ctx
        .loaded_event()?
        .event
        .records
        .iter()
        .any(|r| r.channel.level == Some(0) && r.channel.role == Role::Input);
    Ok((!has_base).then(|| {
        "the event has no base channel (level 0, role input) to drive the design".to_string()
    }))
}

/// Pipeline stage: the design file named by `design`; an event-sourced motion is the run's
/// conditioned event (the design file's `event` path is replaced by the run's event, its
/// `channels`, `axis`, `scale` and `duration_s` apply); a file-sourced motion is the file.
pub fn run(stage: &StageDecl, ctx: &mut RunContext) -> Result<()> {
    let path = design_path(stage, ctx)?;
    let design = load_design(&path)?;
    let model = design.model()?;
    let (motion, recorded) = match &design.motion.source {
        MotionSource::Event { channels, axes, .. } => {
            let origin = ctx.event_path.display().to_string();
            let (event, _) = ctx.conditioned_event()?;
            let motion = base_motion_from_event(
                event,
                &origin,
                channels,
                axes,
                &design.motion,
                model,
                &design.source,
            )?;
            let recorded = if design.snapshots_from_records {
                Some(recorded_response_from_event(
                    event, &origin, &design, &motion,
                )?)
            } else {
                None
            };
            (motion, recorded)
        }
        MotionSource::File { .. } => (
            base_motion_from_file(&design.motion, model, &design.source)?,
            None,
        ),
    };
    let summary = run_design(&design, &motion, recorded.as_ref(), &ctx.out_dir)?;
    if !ctx.quiet {
        eprintln!(
            "design: {} actuators ({} force-controlled), {} POMs retained, WNRMSE {:.2e}, {} NS modes, λ = {}, bandwidth {:.3} Hz",
            summary.actuators,
            summary.force_controlled,
            summary.retained_poms,
            summary.wnrmse,
            summary.ns_modes,
            summary.time_scale,
            summary.bandwidth_hz
        );
    }
    Ok(())
}
