//! The design file (TOML) of the hybrid-test design: which twin, which part of it is the
//! physical substructure (PS), which base motion drives it, and every setting of
//! [`DesignSettings`]. A user contract documented in docs/test-design.md: unknown keys are
//! errors, and every error names the design file and, where it can, the line.
//!
//! ```toml
//! [design]
//! twin = "facade.toml"          # relative to this file
//! [ps]
//! nodes = [57, 58]              # node ids, and/or
//! boxes = [{ x = [2.0, 6.0], y = [1.5, 5.5] }]
//! [motion]
//! event = "."                   # an event folder (relative to this file) …
//! # file = "elCentro.AT2"       # … or a ground-motion file, with axis = "x"
//! ```

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Spanned;

use crate::design::plan::DesignSettings;
use crate::error::{Error, Location, Result};
use crate::twin::model::Model;
use crate::twin::{load_twin, Twin};

/// Default box tolerance (m): a node lies in a box when each coordinate is within the
/// interval widened by this much on both sides (node coordinates written with a few decimals
/// must not fall out by round-off).
pub const DEFAULT_BOX_TOLERANCE_M: f64 = 1e-6;

// ------------------------------------------------------------------ serde image

/// The design file as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignDoc {
    pub design: Spanned<DesignSection>,
    pub ps: Spanned<PsSection>,
    pub motion: Spanned<MotionSection>,
    #[serde(default)]
    pub pod: Option<Spanned<PodSection>>,
    #[serde(default)]
    pub interface: Option<Spanned<InterfaceSection>>,
    #[serde(default)]
    pub damping: Option<Spanned<DampingSection>>,
    #[serde(default)]
    pub actuators: Option<Spanned<ActuatorSection>>,
    #[serde(default)]
    pub hybrid: Option<Spanned<HybridSection>>,
    #[serde(default)]
    pub snapshots: Option<Spanned<SnapshotsSection>>,
}

/// Where the POD snapshots come from: the twin's response to the motion ("twin", default) or
/// the event's records at PS nodes ("records": channels mapped to twin DoFs by the twin's
/// `[[sensors]]`, made relative to the base, integrated with polynomial drift control and
/// expanded statically to the PS; see `design::recorded`).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SnapshotsSection {
    pub source: Option<String>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignSection {
    /// Free text naming the design (metadata only).
    #[serde(default)]
    pub name: Option<String>,
    /// Twin file (docs/twin.md), relative to the design file.
    pub twin: Spanned<String>,
    /// Include the gravity state (nominal actuator forces, static offsets). Default true.
    #[serde(default)]
    pub gravity: Option<bool>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PsSection {
    /// Node ids of the PS.
    #[serde(default)]
    pub nodes: Vec<Spanned<i64>>,
    /// Boxes of node coordinates; a node in any box belongs to the PS.
    #[serde(default)]
    pub boxes: Vec<Spanned<NodeBox>>,
    /// Box tolerance, m (default [`DEFAULT_BOX_TOLERANCE_M`]).
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// Element ids of the PS: their nodes belong to the PS node set.
    #[serde(default)]
    pub elements: Vec<Spanned<i64>>,
    /// Element groups of the twin (`group` of `[[elements]]`): the nodes of their elements.
    #[serde(default)]
    pub groups: Vec<Spanned<String>>,
}

/// Inclusive coordinate intervals; an absent axis is unbounded.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeBox {
    #[serde(default)]
    pub x: Option<[f64; 2]>,
    #[serde(default)]
    pub y: Option<[f64; 2]>,
    #[serde(default)]
    pub z: Option<[f64; 2]>,
}

/// `axis = "x"` (one component) or `axis = { "B-X" = "x", … }` (per channel id).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum AxisSpec {
    One(String),
    PerChannel(BTreeMap<String, String>),
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotionSection {
    /// Event folder (or zip), relative to the design file.
    #[serde(default)]
    pub event: Option<String>,
    /// Event channels to use (default: every level-0 input acceleration channel).
    #[serde(default)]
    pub channels: Vec<Spanned<String>>,
    /// Ground-motion file (AT2, CSV, … any format quaketwin reads), relative to the design file.
    #[serde(default)]
    pub file: Option<String>,
    /// Format name of `file` (default: sniffed from its name and content).
    #[serde(default)]
    pub format: Option<String>,
    /// Column of a multi-column `file` (name or 0-based index as text).
    #[serde(default)]
    pub column: Option<String>,
    /// Time column of a CSV `file`.
    #[serde(default)]
    pub time_column: Option<String>,
    /// Sampling rate of a CSV `file` without time column, Hz.
    #[serde(default)]
    pub sampling_rate_hz: Option<f64>,
    /// Twin axis of the motion: required for `file`; per channel id overrides for `event`.
    #[serde(default)]
    pub axis: Option<AxisSpec>,
    /// Factor applied to the accelerations (default 1).
    #[serde(default)]
    pub scale: Option<f64>,
    /// Use only the first `duration_s` seconds (default: all).
    #[serde(default)]
    pub duration_s: Option<f64>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PodSection {
    pub energy_target: Option<f64>,
    pub max_poms: Option<usize>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConstrainedDof {
    pub node: i64,
    pub dof: String,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InterfaceSection {
    pub wnrmse_target: Option<f64>,
    pub max_control_nodes: Option<usize>,
    pub refinement_candidates: Option<usize>,
    #[serde(default)]
    pub control_nodes: Vec<Spanned<i64>>,
    /// Constrained set override, one entry per rigid-body mode.
    pub constrained: Option<Vec<Spanned<ConstrainedDof>>>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DampingSection {
    pub ratio: Option<f64>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActuatorSection {
    pub static_ratio: Option<f64>,
    pub min_force: Option<f64>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HybridSection {
    pub actuator_band_hz: Option<f64>,
    pub band_of_interest_hz: Option<f64>,
    pub accuracy: Option<f64>,
    pub max_ns_modes: Option<usize>,
    pub time_scales: Option<Vec<f64>>,
}

// ------------------------------------------------------------------ resolved design

/// A twin axis (0 = x, 1 = y, 2 = z) from its name.
pub fn parse_axis(name: &str) -> Option<usize> {
    match name.trim().to_ascii_lowercase().as_str() {
        "x" => Some(0),
        "y" => Some(1),
        "z" => Some(2),
        _ => None,
    }
}

/// Where the base motion comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum MotionSource {
    /// An event folder: its base channels, conditioned like the post-earthquake pipeline.
    Event {
        folder: PathBuf,
        /// Selected channel ids (empty = every level-0 input acceleration channel).
        channels: Vec<String>,
        /// Twin axis per channel id, overriding the direction mapping.
        axes: BTreeMap<String, usize>,
    },
    /// A ground-motion file, used as recorded (converted to m/s²).
    File {
        path: PathBuf,
        format: Option<String>,
        column: Option<String>,
        time_column: Option<String>,
        sampling_rate_hz: Option<f64>,
        axis: usize,
    },
}

/// The base motion as the design file states it.
#[derive(Debug, Clone, PartialEq)]
pub struct MotionSpec {
    pub source: MotionSource,
    pub scale: f64,
    pub duration_s: Option<f64>,
    /// Line of the `[motion]` table (for errors found while reading the motion).
    pub line: usize,
}

/// A design file read, checked and resolved against its twin.
#[derive(Debug, Clone)]
pub struct LoadedDesign {
    /// The design file as given (errors and metadata name it).
    pub path: PathBuf,
    pub source: String,
    pub name: Option<String>,
    pub twin_path: PathBuf,
    pub twin: Twin,
    /// PS node ids in the twin's node order.
    pub ps_node_ids: Vec<i64>,
    pub motion: MotionSpec,
    pub settings: DesignSettings,
    /// POD snapshots from the event's records (`[snapshots] source = "records"`).
    pub snapshots_from_records: bool,
}

impl LoadedDesign {
    /// The mesh model (a loaded design always has one).
    pub fn model(&self) -> Result<&Model> {
        self.twin.model.as_ref().ok_or_else(|| {
            Error::input(
                Location::file(self.source.clone()),
                "the twin is given by matrices, not a mesh: the design needs nodes and elements",
            )
        })
    }
}

pub(super) fn line_of(text: &str, offset: usize) -> usize {
    text.get(..offset.min(text.len()))
        .map(|s| s.matches('\n').count() + 1)
        .unwrap_or(1)
}

/// Parse design-file text; syntax errors and unknown keys name `source` and the line.
pub fn parse_design(text: &str, source: &str) -> Result<DesignDoc> {
    toml::from_str(text).map_err(|e| {
        let mut loc = Location::file(source.to_string());
        if let Some(span) = e.span() {
            loc = loc.at_line(line_of(text, span.start));
        }
        Error::input(loc, format!("invalid design file: {}", e.message()))
    })
}

/// Largest design file read, bytes (checked before it is read or parsed; a
/// design file is a few kB of settings).
pub const MAX_DESIGN_FILE_BYTES: u64 = 1 << 20;

/// The text of the design file at `path`, its size checked against
/// [`MAX_DESIGN_FILE_BYTES`] before it is read.
fn read_design_text(path: &Path) -> Result<String> {
    crate::input_file::read_to_string_or(path, MAX_DESIGN_FILE_BYTES, |size| {
        Error::input(
            Location::file(path.display().to_string()),
            format!(
                "design file of {size} bytes: larger than the limit of {MAX_DESIGN_FILE_BYTES} bytes"
            ),
        )
    })
}

/// Read the design file at `path`, load its twin and resolve it (see
/// [`super::resolve::resolve_design`]).
pub fn load_design(path: &Path) -> Result<LoadedDesign> {
    let text = read_design_text(path)?;
    let source = path.display().to_string();
    let doc = parse_design(&text, &source)?;
    let base = path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."));
    let at =
        |span: Range<usize>| Location::file(source.clone()).at_line(line_of(&text, span.start));
    let twin_rel = doc.design.get_ref().twin.get_ref();
    let twin_path = base.join(twin_rel);
    if !twin_path.is_file() {
        return Err(Error::input(
            at(doc.design.get_ref().twin.span()),
            format!(
                "twin file {twin_rel:?} not found (looked for {})",
                twin_path.display()
            ),
        ));
    }
    let twin = load_twin(&twin_path)?;
    super::resolve::resolve_design(doc, &text, path, &base, twin_path, twin)
}

pub(super) fn resolve_motion(
    m: &Spanned<MotionSection>,
    text: &str,
    source: &str,
    base: &Path,
) -> Result<MotionSpec> {
    let line = line_of(text, m.span().start);
    let loc = || Location::file(source.to_string()).at_line(line);
    let s = m.get_ref();
    let scale = s.scale.unwrap_or(1.0);
    if !(scale.is_finite() && scale != 0.0) {
        return Err(Error::input(
            loc(),
            format!("[motion] scale {scale} must be a non-zero number"),
        ));
    }
    if let Some(d) = s.duration_s {
        if !(d.is_finite() && d > 0.0) {
            return Err(Error::input(
                loc(),
                format!("[motion] duration_s {d} must be positive"),
            ));
        }
    }
    let bad_axis = |name: &str| {
        Error::input(
            loc(),
            format!("[motion] axis {name:?} must be \"x\", \"y\" or \"z\""),
        )
    };
    let source_kind = match (&s.event, &s.file) {
        (Some(_), Some(_)) => {
            return Err(Error::input(
                loc(),
                "[motion] give either `event` or `file`, not both",
            ))
        }
        (None, None) => {
            return Err(Error::input(
                loc(),
                "[motion] names no source: give `event` (an event folder) or `file` (a ground-motion file)",
            ))
        }
        (Some(event), None) => {
            for (key, set) in [
                ("format", s.format.is_some()),
                ("column", s.column.is_some()),
                ("time_column", s.time_column.is_some()),
                ("sampling_rate_hz", s.sampling_rate_hz.is_some()),
            ] {
                if set {
                    return Err(Error::input(
                        loc(),
                        format!("[motion] `{key}` applies to a `file` source, not to an event"),
                    ));
                }
            }
            let channels: Vec<String> = s.channels.iter().map(|c| c.get_ref().clone()).collect();
            let mut axes = BTreeMap::new();
            match &s.axis {
                None => {}
                Some(AxisSpec::PerChannel(map)) => {
                    for (id, a) in map {
                        axes.insert(id.clone(), parse_axis(a).ok_or_else(|| bad_axis(a))?);
                    }
                }
                Some(AxisSpec::One(a)) => {
                    if channels.len() != 1 {
                        return Err(Error::input(
                            loc(),
                            "[motion] a single `axis` for an event needs exactly one entry in `channels`; otherwise give axis = { CHANNEL = \"x\", … }",
                        ));
                    }
                    axes.insert(
                        channels[0].clone(),
                        parse_axis(a).ok_or_else(|| bad_axis(a))?,
                    );
                }
            }
            MotionSource::Event {
                folder: base.join(event),
                channels,
                axes,
            }
        }
        (None, Some(file)) => {
            if !s.channels.is_empty() {
                return Err(Error::input(
                    loc(),
                    "[motion] `channels` selects event channels; for a file use `column`",
                ));
            }
            let axis = match &s.axis {
                Some(AxisSpec::One(a)) => parse_axis(a).ok_or_else(|| bad_axis(a))?,
                _ => {
                    return Err(Error::input(
                        loc(),
                        "[motion] a ground-motion `file` needs `axis = \"x\"` (or \"y\", \"z\"): the twin axis it acts along",
                    ))
                }
            };
            if let Some(r) = s.sampling_rate_hz {
                if !(r.is_finite() && r > 0.0) {
                    return Err(Error::input(
                        loc(),
                        format!("[motion] sampling_rate_hz {r} must be positive"),
                    ));
                }
            }
            MotionSource::File {
                path: base.join(file),
                format: s.format.clone(),
                column: s.column.clone(),
                time_column: s.time_column.clone(),
                sampling_rate_hz: s.sampling_rate_hz,
                axis,
            }
        }
    };
    Ok(MotionSpec {
        source: source_kind,
        scale,
        duration_s: s.duration_s,
        line,
    })
}

/// The settings as JSON (the `quaketwin.settings` metadata of the output tables).
pub fn settings_json(s: &DesignSettings) -> String {
    serde_json::json!({
        "pod": { "energy_target": s.energy_target, "max_poms": s.max_poms },
        "interface": {
            "wnrmse_target": s.wnrmse_target,
            "max_control_nodes": s.max_control_nodes,
            "control_nodes": s.control_nodes,
            "constrained": s.constrained.as_ref().map(|c| c.iter().map(|(n, d)| serde_json::json!({ "node": n, "dof": d })).collect::<Vec<_>>()),
        },
        "damping": { "ratio": s.damping_ratio },
        "gravity": s.gravity,
        "actuators": { "static_ratio": s.actuators.static_ratio, "min_force": s.actuators.min_force },
        "hybrid": {
            "actuator_band_hz": s.hybrid.actuator_band_hz,
            "band_of_interest_hz": s.hybrid.band_of_interest_hz,
            "accuracy": s.hybrid.accuracy,
            "max_ns_modes": s.hybrid.max_ns_modes,
            "time_scales": s.hybrid.time_scales,
        },
    })
    .to_string()
}
