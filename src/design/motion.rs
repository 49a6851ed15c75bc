//! The base motion of a hybrid-test design and the recorded response at PS
//! nodes (snapshot source (b)), assembled from a conditioned event or a
//! ground-motion file.
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

use std::collections::BTreeMap;

use super::file::{LoadedDesign, MotionSource, MotionSpec};
use super::plan::{BaseComponent, BaseMotion};
use super::recorded::RecordedResponse;
use crate::conditioning::integrate::{integrate_motion, DriftControl};
use crate::error::{Error, Location, Result};
use crate::readers::{self, Format, ReadOptions};
use crate::twin::model::{Dimension, Model};
use crate::vocab::{Axis, Direction, Event, Role, SourceRef};

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
        // As many samples as the duration covers; a duration longer than any
        // record (even 1e308 s) takes the whole record.
        n = n.min(((d / dt).round() as usize).saturating_add(1));
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
    axes: &BTreeMap<String, usize>,
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
        parts.push((id, axis, sign, r.channel.dt(), r.samples.to_vec()));
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
    let bytes = crate::input_file::read(path, crate::input_file::MAX_INPUT_BYTES)
        .map_err(|e| Error::input(loc(), format!("[motion] file {e}")))?;
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

/// The design's base motion and, with `[snapshots] source = "records"`, the recorded
/// response: from `event` (conditioned, with its name for messages) when the motion comes
/// from an event — its `channels`, `axis`, `scale` and `duration_s` apply — or from the
/// design's ground-motion file.
pub fn design_inputs(
    design: &LoadedDesign,
    event: Option<(&Event, &str)>,
) -> Result<(BaseMotion, Option<RecordedResponse>)> {
    let model = design.model()?;
    match (&design.motion.source, event) {
        (MotionSource::Event { channels, axes, .. }, Some((event, origin))) => {
            let motion = base_motion_from_event(
                event,
                origin,
                channels,
                axes,
                &design.motion,
                model,
                &design.source,
            )?;
            let recorded = if design.snapshots_from_records {
                Some(recorded_response_from_event(
                    event, origin, design, &motion,
                )?)
            } else {
                None
            };
            Ok((motion, recorded))
        }
        (MotionSource::Event { .. }, None) => Err(Error::usage(format!(
            "{}: the motion comes from an event and no event was given",
            design.source
        ))),
        (MotionSource::File { .. }, _) => Ok((
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
        displacement.push(integrated.displacement.to_vec());
        used.push(sensor.channel.clone());
    }
    Ok(RecordedResponse {
        dofs,
        displacement,
        source: format!("event {origin}, channels {}", used.join(", ")),
    })
}
