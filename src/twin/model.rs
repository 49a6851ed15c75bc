//! The validated in-memory finite-element model (what a twin file describes).
//!
//! Indices here are positions in the vectors (nodes, materials, …); user ids only appear in
//! messages. `file::parse_twin` builds a `Model` and checks every cross-reference, so the
//! assembly can index without failing.

use crate::error::{Error, Location};

/// Plane (x–y, DoFs ux, uy, rz) or spatial (ux, uy, uz, rx, ry, rz) model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Dimension {
    Two,
    Three,
}

impl Dimension {
    pub fn dofs_per_node(self) -> usize {
        match self {
            Dimension::Two => 3,
            Dimension::Three => 6,
        }
    }
    /// DoF names in node order.
    pub fn dof_names(self) -> &'static [&'static str] {
        match self {
            Dimension::Two => &["ux", "uy", "rz"],
            Dimension::Three => &["ux", "uy", "uz", "rx", "ry", "rz"],
        }
    }
    pub fn dof_index(self, name: &str) -> Option<usize> {
        self.dof_names()
            .iter()
            .position(|n| n.eq_ignore_ascii_case(name))
    }
    /// Index of the translational DoF along global axis 0/1/2, if the model has it.
    pub fn translation_dof(self, axis: usize) -> Option<usize> {
        match (self, axis) {
            (Dimension::Two, 0 | 1) => Some(axis),
            (Dimension::Three, 0..=2) => Some(axis),
            _ => None,
        }
    }
}

#[derive(Debug, Clone)]
pub struct Node {
    pub id: i64,
    pub coords: [f64; 3],
}

/// Element types the twin understands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ElementKind {
    Beam2d,
    Beam3d,
    Q4,
    Shell4,
}

impl ElementKind {
    pub fn parse(name: &str) -> Option<Self> {
        match name.to_ascii_lowercase().as_str() {
            "beam2d" => Some(ElementKind::Beam2d),
            "beam3d" => Some(ElementKind::Beam3d),
            "q4" => Some(ElementKind::Q4),
            "shell4" | "mitc4" => Some(ElementKind::Shell4),
            _ => None,
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            ElementKind::Beam2d => "beam2d",
            ElementKind::Beam3d => "beam3d",
            ElementKind::Q4 => "q4",
            ElementKind::Shell4 => "shell4",
        }
    }
    pub fn node_count(self) -> usize {
        match self {
            ElementKind::Beam2d | ElementKind::Beam3d => 2,
            ElementKind::Q4 | ElementKind::Shell4 => 4,
        }
    }
    /// Node-local DoF indices the element couples, for the given model dimension.
    pub fn dofs(self) -> &'static [usize] {
        match self {
            ElementKind::Beam2d => &[0, 1, 2],
            ElementKind::Q4 => &[0, 1],
            ElementKind::Beam3d | ElementKind::Shell4 => &[0, 1, 2, 3, 4, 5],
        }
    }
    pub fn dimension(self) -> Dimension {
        match self {
            ElementKind::Beam2d | ElementKind::Q4 => Dimension::Two,
            ElementKind::Beam3d | ElementKind::Shell4 => Dimension::Three,
        }
    }
}

#[derive(Debug, Clone)]
pub struct Material {
    pub name: String,
    pub youngs_modulus: f64,
    pub poisson: f64,
    pub density: f64,
}

#[derive(Debug, Clone)]
pub struct Section {
    pub name: String,
    pub area: f64,
    pub iy: f64,
    pub iz: f64,
    pub torsion: f64,
    pub shear_factor: f64,
    pub thickness: f64,
}

#[derive(Debug, Clone)]
pub struct Element {
    pub id: i64,
    pub kind: ElementKind,
    pub nodes: Vec<usize>,
    pub material: usize,
    pub section: usize,
    pub group: String,
    /// Beam3d reference vector in the local x–z plane.
    pub orientation: Option<[f64; 3]>,
}

/// Linear spring on one DoF, to ground (`node2 = None`) or between two nodes.
#[derive(Debug, Clone)]
pub struct Spring {
    pub id: i64,
    pub node: usize,
    pub node2: Option<usize>,
    pub dof: usize,
    pub stiffness: f64,
    pub set: String,
}

/// Lumped mass: one value per node DoF (translations: mass, rotations: inertia).
#[derive(Debug, Clone)]
pub struct LumpedMass {
    pub node: usize,
    pub values: Vec<f64>,
}

/// Rigid link: the slave nodes follow the master's rigid-body motion.
#[derive(Debug, Clone)]
pub struct RigidLink {
    pub master: usize,
    pub slaves: Vec<usize>,
}

/// What an updatable parameter sets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ParameterKind {
    /// Young's modulus E of the elements in the listed groups (Pa).
    YoungsModulus,
    /// Density ρ of the elements in the listed groups (kg/m³).
    Density,
    /// Stiffness of the springs in the listed sets (N/m or N·m/rad).
    SpringStiffness,
}

#[derive(Debug, Clone)]
pub struct Parameter {
    pub name: String,
    pub kind: ParameterKind,
    pub groups: Vec<String>,
    pub sets: Vec<String>,
    pub lower: f64,
    pub upper: f64,
    pub start: f64,
}

#[derive(Debug, Clone)]
pub struct Sensor {
    pub channel: String,
    pub node: usize,
    pub dof: usize,
}

#[derive(Debug, Clone)]
pub struct Model {
    pub name: String,
    /// The twin file this model came from (used in error messages).
    pub source: String,
    pub dimension: Dimension,
    pub nodes: Vec<Node>,
    pub materials: Vec<Material>,
    pub sections: Vec<Section>,
    pub elements: Vec<Element>,
    /// (node, DoF) pairs fixed to zero.
    pub supports: Vec<(usize, usize)>,
    pub masses: Vec<LumpedMass>,
    pub springs: Vec<Spring>,
    pub rigid_links: Vec<RigidLink>,
    pub parameters: Vec<Parameter>,
    pub sensors: Vec<Sensor>,
    /// Gravity acceleration vector (m/s²), default (0, 0, −9.81) in 3D, (0, −9.81) in 2D.
    pub gravity: [f64; 3],
}

impl Model {
    pub fn location(&self) -> Location {
        Location::file(self.source.clone())
    }
    pub fn input_error(&self, message: impl Into<String>) -> Error {
        Error::input(self.location(), message)
    }
    /// Human label of a node DoF, e.g. "node 12 uy".
    pub fn dof_label(&self, node: usize, dof: usize) -> String {
        let id = self.nodes.get(node).map(|n| n.id).unwrap_or(-1);
        let name = self.dimension.dof_names().get(dof).copied().unwrap_or("?");
        format!("node {id} {name}")
    }
    pub fn node_index(&self, id: i64) -> Option<usize> {
        self.nodes.iter().position(|n| n.id == id)
    }
    pub fn parameter_index(&self, name: &str) -> Option<usize> {
        self.parameters.iter().position(|p| p.name == name)
    }
    /// Start values of the parameters.
    pub fn start_values(&self) -> Vec<f64> {
        self.parameters.iter().map(|p| p.start).collect()
    }
}
