//! The design file checked against its twin: the PS node set (ids, elements, groups,
//! boxes), control nodes and the constrained-set override, every setting's range, and the
//! snapshot source. Each `[section]` has its own routine; all errors name the design file
//! and the line of the offending entry (docs/test-design.md).

use std::ops::Range;
use std::path::{Path, PathBuf};

use toml::Spanned;

use super::craig_bampton::HybridSettings;
use super::file::{
    line_of, resolve_motion, ActuatorSection, DesignDoc, HybridSection, InterfaceSection,
    LoadedDesign, MotionSource, MotionSpec, NodeBox, PodSection, PsSection, SnapshotsSection,
    DEFAULT_BOX_TOLERANCE_M,
};
use super::layout::ActuatorSettings;
use super::plan::DesignSettings;
use crate::error::{Error, Location, Result};
use crate::twin::model::Model;
use crate::twin::Twin;

/// What every check needs: the twin's mesh and how to name a place in the design file.
struct Checker<'a> {
    model: &'a Model,
    twin_path: &'a Path,
    source: &'a str,
    text: &'a str,
}

impl Checker<'_> {
    fn at(&self, span: Range<usize>) -> Location {
        Location::file(self.source.to_string()).at_line(line_of(self.text, span.start))
    }

    fn error(&self, span: Range<usize>, message: impl Into<String>) -> Error {
        Error::input(self.at(span), message.into())
    }

    /// The twin's index of node `id`, or an error naming the entry (`what`) that gave it.
    fn node(&self, id: i64, span: Range<usize>, what: &str) -> Result<usize> {
        self.model.node_index(id).ok_or_else(|| {
            self.error(
                span,
                format!(
                    "{what}: node {id} does not exist in twin {}",
                    self.twin_path.display()
                ),
            )
        })
    }

    /// Like [`Self::node`], and the node must belong to the PS node set.
    fn ps_node(&self, id: i64, span: Range<usize>, what: &str, in_ps: &[bool]) -> Result<()> {
        if in_ps[self.node(id, span.clone(), what)?] {
            Ok(())
        } else {
            Err(self.error(span, format!("{what}: node {id} is not in the PS node set")))
        }
    }
}

/// Check the design against the twin: PS node set (ids and boxes), control nodes, the
/// constrained-set override (node ids, DoF names), settings ranges, the motion source.
/// `base` resolves the relative paths of the file.
pub fn resolve_design(
    doc: DesignDoc,
    text: &str,
    path: &Path,
    base: &Path,
    twin_path: PathBuf,
    twin: Twin,
) -> Result<LoadedDesign> {
    let source = path.display().to_string();
    let Some(model) = twin.model.as_ref() else {
        return Err(Error::input(
            Location::file(source.clone())
                .at_line(line_of(text, doc.design.get_ref().twin.span().start)),
            format!(
                "twin {} is given by matrices, not a mesh: the design needs nodes and elements",
                twin_path.display()
            ),
        ));
    };
    let check = Checker {
        model,
        twin_path: &twin_path,
        source: &source,
        text,
    };
    let in_ps = ps_node_set(&check, &doc.ps)?;
    let ps_node_ids: Vec<i64> = model
        .nodes
        .iter()
        .zip(&in_ps)
        .filter(|(_, &s)| s)
        .map(|(n, _)| n.id)
        .collect();
    if ps_node_ids.is_empty() {
        return Err(check.error(
            doc.ps.span(),
            "[ps] the PS node set is empty: give `nodes`, `boxes`, `elements` and/or `groups`",
        ));
    }

    let mut settings = DesignSettings::default();
    if let Some(g) = doc.design.get_ref().gravity {
        settings.gravity = g;
    }
    if let Some(p) = &doc.pod {
        apply_pod(&check, p, &mut settings)?;
    }
    if let Some(i) = &doc.interface {
        apply_interface(&check, i, &in_ps, &mut settings)?;
    }
    if let Some(d) = &doc.damping {
        if let Some(v) = d.get_ref().ratio {
            if !(v.is_finite() && (0.0..1.0).contains(&v)) {
                return Err(
                    check.error(d.span(), format!("[damping] ratio {v} must lie in [0, 1)"))
                );
            }
            settings.damping_ratio = v;
        }
    }
    if let Some(a) = &doc.actuators {
        settings.actuators = actuator_settings(&check, a)?;
    }
    if let Some(h) = &doc.hybrid {
        settings.hybrid = hybrid_settings(&check, h)?;
    }

    let motion = resolve_motion(&doc.motion, text, &source, base)?;
    let snapshots_from_records = match &doc.snapshots {
        None => false,
        Some(sn) => snapshots_from_records(&check, sn, &motion)?,
    };
    Ok(LoadedDesign {
        path: path.to_path_buf(),
        name: doc.design.get_ref().name.clone(),
        source,
        twin_path,
        twin,
        ps_node_ids,
        motion,
        settings,
        snapshots_from_records,
    })
}

fn unit_interval(v: f64) -> bool {
    v.is_finite() && v > 0.0 && v <= 1.0
}

fn positive(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

/// `[ps]`: which twin nodes belong to the PS (the union of nodes, elements, groups, boxes).
fn ps_node_set(check: &Checker, ps: &Spanned<PsSection>) -> Result<Vec<bool>> {
    let model = check.model;
    let twin = check.twin_path.display();
    let section = ps.get_ref();
    let tolerance = section.tolerance.unwrap_or(DEFAULT_BOX_TOLERANCE_M);
    if !(tolerance.is_finite() && tolerance >= 0.0) {
        return Err(check.error(
            ps.span(),
            format!("[ps] tolerance {tolerance} must be a non-negative number (m)"),
        ));
    }
    let mut in_ps = vec![false; model.nodes.len()];
    for id in &section.nodes {
        in_ps[check.node(*id.get_ref(), id.span(), "[ps] nodes")?] = true;
    }
    for id in &section.elements {
        let Some(el) = model.elements.iter().find(|e| e.id == *id.get_ref()) else {
            return Err(check.error(
                id.span(),
                format!(
                    "[ps] elements: element {} does not exist in twin {twin}",
                    id.get_ref()
                ),
            ));
        };
        for &n in &el.nodes {
            in_ps[n] = true;
        }
    }
    for g in &section.groups {
        let mut count = 0usize;
        for el in model.elements.iter().filter(|e| &e.group == g.get_ref()) {
            for &n in &el.nodes {
                in_ps[n] = true;
            }
            count += 1;
        }
        if count == 0 {
            return Err(check.error(
                g.span(),
                format!(
                    "[ps] groups: no element of twin {twin} is in group {:?}",
                    g.get_ref()
                ),
            ));
        }
    }
    for b in &section.boxes {
        let count = mark_box(check, b, tolerance, &mut in_ps)?;
        if count == 0 {
            return Err(check.error(
                b.span(),
                format!(
                    "[ps] box {} selects no node of twin {twin} (tolerance {tolerance} m)",
                    describe_box(b.get_ref()),
                ),
            ));
        }
    }
    Ok(in_ps)
}

/// Mark the nodes inside one `[ps]` box (each interval widened by `tolerance`); returns
/// how many it holds.
fn mark_box(
    check: &Checker,
    b: &Spanned<NodeBox>,
    tolerance: f64,
    in_ps: &mut [bool],
) -> Result<usize> {
    let intervals = [b.get_ref().x, b.get_ref().y, b.get_ref().z];
    for (axis, iv) in intervals.iter().enumerate() {
        if let Some([lo, hi]) = iv {
            if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                return Err(check.error(
                    b.span(),
                    format!(
                        "[ps] box: {} interval [{lo}, {hi}] must be finite and ascending",
                        ["x", "y", "z"][axis]
                    ),
                ));
            }
        }
    }
    let mut count = 0usize;
    for (i, node) in check.model.nodes.iter().enumerate() {
        let inside = intervals.iter().zip(node.coords).all(|(iv, c)| match iv {
            Some([lo, hi]) => c >= lo - tolerance && c <= hi + tolerance,
            None => true,
        });
        if inside {
            in_ps[i] = true;
            count += 1;
        }
    }
    Ok(count)
}

fn describe_box(b: &NodeBox) -> String {
    let parts: Vec<String> = [("x", b.x), ("y", b.y), ("z", b.z)]
        .iter()
        .filter_map(|(n, iv)| iv.map(|[lo, hi]| format!("{n} ∈ [{lo}, {hi}]")))
        .collect();
    if parts.is_empty() {
        "(unbounded)".into()
    } else {
        parts.join(", ")
    }
}

/// `[pod]`: energy target and the number of POMs.
fn apply_pod(
    check: &Checker,
    pod: &Spanned<PodSection>,
    settings: &mut DesignSettings,
) -> Result<()> {
    let s = pod.get_ref();
    if let Some(v) = s.energy_target {
        if !unit_interval(v) {
            return Err(check.error(
                pod.span(),
                format!("[pod] energy_target {v} must lie in (0, 1]"),
            ));
        }
        settings.energy_target = v;
    }
    if let Some(v) = s.max_poms {
        if v == 0 {
            return Err(check.error(pod.span(), "[pod] max_poms must be at least 1"));
        }
        settings.max_poms = v;
    }
    Ok(())
}

/// `[interface]`: refinement targets, control nodes and the constrained-set override, whose
/// nodes must lie in the PS.
fn apply_interface(
    check: &Checker,
    interface: &Spanned<InterfaceSection>,
    in_ps: &[bool],
    settings: &mut DesignSettings,
) -> Result<()> {
    let s = interface.get_ref();
    let span = || interface.span();
    if let Some(v) = s.wnrmse_target {
        if !positive(v) {
            return Err(check.error(
                span(),
                format!("[interface] wnrmse_target {v} must be positive"),
            ));
        }
        settings.wnrmse_target = v;
    }
    if let Some(v) = s.max_control_nodes {
        if v < 2 {
            return Err(check.error(span(), "[interface] max_control_nodes must be at least 2"));
        }
        settings.max_control_nodes = v;
    }
    if let Some(v) = s.refinement_candidates {
        if v == 0 {
            return Err(check.error(
                span(),
                "[interface] refinement_candidates must be at least 1",
            ));
        }
        settings.refinement_candidates = v;
    }
    for id in &s.control_nodes {
        check.ps_node(*id.get_ref(), id.span(), "[interface] control_nodes", in_ps)?;
        settings.control_nodes.push(*id.get_ref());
    }
    if let Some(list) = &s.constrained {
        let dimension = check.model.dimension;
        let mut out = Vec::with_capacity(list.len());
        for c in list {
            let d = c.get_ref();
            check.ps_node(d.node, c.span(), "[interface] constrained", in_ps)?;
            let Some(k) = dimension.dof_index(&d.dof) else {
                return Err(check.error(
                    c.span(),
                    format!(
                        "[interface] constrained: DoF {:?} is not one of {}",
                        d.dof,
                        dimension.dof_names().join(", ")
                    ),
                ));
            };
            out.push((d.node, dimension.dof_names()[k].to_string()));
        }
        settings.constrained = Some(out);
    }
    Ok(())
}

/// `[actuators]`: static force ratio and minimum force.
fn actuator_settings(check: &Checker, a: &Spanned<ActuatorSection>) -> Result<ActuatorSettings> {
    let s = a.get_ref();
    let mut act = ActuatorSettings::default();
    for (name, value, unit, slot) in [
        ("static_ratio", s.static_ratio, "", &mut act.static_ratio),
        ("min_force", s.min_force, " (N)", &mut act.min_force),
    ] {
        if let Some(v) = value {
            if !(v.is_finite() && v >= 0.0) {
                return Err(check.error(
                    a.span(),
                    format!("[actuators] {name} {v} must be non-negative{unit}"),
                ));
            }
            *slot = v;
        }
    }
    Ok(act)
}

/// `[hybrid]`: actuator band, band of interest, accuracy, NS mode count, time scales.
fn hybrid_settings(check: &Checker, h: &Spanned<HybridSection>) -> Result<HybridSettings> {
    let s = h.get_ref();
    let mut hy = HybridSettings::default();
    for (name, value, slot) in [
        (
            "actuator_band_hz",
            s.actuator_band_hz,
            &mut hy.actuator_band_hz,
        ),
        (
            "band_of_interest_hz",
            s.band_of_interest_hz,
            &mut hy.band_of_interest_hz,
        ),
        ("accuracy", s.accuracy, &mut hy.accuracy),
    ] {
        if let Some(v) = value {
            if !positive(v) {
                return Err(check.error(h.span(), format!("[hybrid] {name} {v} must be positive")));
            }
            *slot = v;
        }
    }
    if let Some(v) = s.max_ns_modes {
        hy.max_ns_modes = v;
    }
    if let Some(ts) = &s.time_scales {
        if ts.is_empty() || ts.iter().any(|&l| !positive(l)) || ts.windows(2).any(|w| w[1] <= w[0])
        {
            return Err(check.error(
                h.span(),
                format!("[hybrid] time_scales {ts:?} must be positive and strictly ascending"),
            ));
        }
        hy.time_scales = ts.clone();
    }
    Ok(hy)
}

/// `[snapshots] source`: "twin" (default) or "records", which needs an event as the motion.
fn snapshots_from_records(
    check: &Checker,
    sn: &Spanned<SnapshotsSection>,
    motion: &MotionSpec,
) -> Result<bool> {
    match sn.get_ref().source.as_deref() {
        None | Some("twin") => Ok(false),
        Some("records") => {
            if matches!(motion.source, MotionSource::File { .. }) {
                return Err(check.error(
                    sn.span(),
                    "[snapshots] source = \"records\" needs the motion from an event ([motion] event), whose channels at PS nodes are the records",
                ));
            }
            Ok(true)
        }
        Some(other) => Err(check.error(
            sn.span(),
            format!("[snapshots] source {other:?}: expected \"twin\" or \"records\""),
        )),
    }
}
