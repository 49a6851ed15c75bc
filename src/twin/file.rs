//! The twin file (TOML): reading, validation into a `Model`, and writing the updated twin.
//! The format is documented in docs/twin.md.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::assembly::{assemble, ParameterInfo, SensorDof, TwinSystem};
use super::matrix_market::read_matrix_market;
use super::model::*;
use super::sparse::AffineMatrix;
use crate::error::{Error, Location};
use crate::Result;

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TwinHeader {
    pub name: String,
    /// 2 (plane x–y) or 3 (space).
    pub dimension: u8,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gravity: Option<Vec<f64>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MaterialDef {
    pub name: String,
    #[serde(rename = "E")]
    pub youngs_modulus: f64,
    pub nu: f64,
    pub rho: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SectionDef {
    pub name: String,
    #[serde(rename = "A", default, skip_serializing_if = "Option::is_none")]
    pub area: Option<f64>,
    #[serde(rename = "Iy", default, skip_serializing_if = "Option::is_none")]
    pub iy: Option<f64>,
    #[serde(rename = "Iz", default, skip_serializing_if = "Option::is_none")]
    pub iz: Option<f64>,
    #[serde(rename = "J", default, skip_serializing_if = "Option::is_none")]
    pub torsion: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shear_factor: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thickness: Option<f64>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct MeshDef {
    /// `[id, x, y]` (2D) or `[id, x, y, z]` (3D).
    pub nodes: Vec<Vec<f64>>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ElementBlockDef {
    #[serde(rename = "type")]
    pub kind: String,
    pub material: String,
    pub section: String,
    pub group: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub orientation: Option<[f64; 3]>,
    /// `[element id, node ids…]`.
    pub connectivity: Vec<Vec<i64>>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SupportDef {
    pub nodes: Vec<i64>,
    /// DoF names or `"all"`.
    pub dofs: Vec<String>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MassDef {
    pub node: i64,
    pub mass: f64,
    /// Rotational inertias (rz in 2D; rx, ry, rz in 3D).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inertia: Option<Vec<f64>>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpringDef {
    pub set: String,
    pub dof: String,
    pub k: f64,
    /// Grounded springs, one per listed node.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub nodes: Vec<i64>,
    /// Two-node springs.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub pairs: Vec<[i64; 2]>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RigidLinkDef {
    pub master: i64,
    pub slaves: Vec<i64>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ParameterDef {
    pub name: String,
    pub kind: ParameterKind,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub groups: Vec<String>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sets: Vec<String>,
    pub lower: f64,
    pub upper: f64,
    pub start: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SensorDef {
    pub channel: String,
    /// Node id (mesh twins).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node: Option<i64>,
    /// DoF name (mesh twins).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dof: Option<String>,
    /// 1-based row of the imported matrices (Matrix Market twins).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub index: Option<usize>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MatrixTermDef {
    pub parameter: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiffness: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mass: Option<String>,
}

/// Externally assembled matrices (paths relative to the twin file).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MatricesDef {
    pub stiffness: String,
    pub mass: String,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub terms: Vec<MatrixTermDef>,
}

/// The twin file as written (serde image of the TOML).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TwinFile {
    pub twin: TwinHeader,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub materials: Vec<MaterialDef>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sections: Vec<SectionDef>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mesh: Option<MeshDef>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub elements: Vec<ElementBlockDef>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub supports: Vec<SupportDef>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub masses: Vec<MassDef>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub springs: Vec<SpringDef>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rigid_links: Vec<RigidLinkDef>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub parameters: Vec<ParameterDef>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sensors: Vec<SensorDef>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub matrices: Option<MatricesDef>,
}

/// A loaded twin: the file image, the mesh model (absent for Matrix Market twins) and the
/// assembled system.
#[derive(Debug, Clone)]
pub struct Twin {
    pub file: TwinFile,
    pub source: String,
    pub model: Option<Model>,
    pub system: TwinSystem,
}

fn line_of(text: &str, offset: usize) -> usize {
    text.get(..offset.min(text.len()))
        .map(|s| s.matches('\n').count() + 1)
        .unwrap_or(1)
}

/// Largest twin file read, bytes (checked before it is read or parsed: the
/// TOML parser holds a text tens of times over).  A model of thousands of
/// nodes and elements is a few MB; larger systems come as Matrix Market
/// files (`[matrices]`), which are read on their own.
pub const MAX_TWIN_FILE_BYTES: u64 = 8 << 20;

/// The text of the twin file at `path`, its size checked against
/// [`MAX_TWIN_FILE_BYTES`] before it is read.
fn read_twin_text(path: &Path) -> Result<String> {
    crate::input_file::read_to_string_or(path, MAX_TWIN_FILE_BYTES, |size| {
        Error::input(
            Location::file(path.display().to_string()),
            format!(
                "twin file of {size} bytes: larger than the limit of {MAX_TWIN_FILE_BYTES} bytes (give a large model's matrices as Matrix Market files)"
            ),
        )
    })
}

/// Read and validate a twin file from disk.
pub fn load_twin(path: &Path) -> Result<Twin> {
    let text = read_twin_text(path)?;
    let base = path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."));
    parse_twin(&text, &path.display().to_string(), &base)
}

/// Parse twin TOML text; `source` names it in errors; `base_dir` resolves matrix paths.
pub fn parse_twin(text: &str, source: &str, base_dir: &Path) -> Result<Twin> {
    let file: TwinFile = toml::from_str(text).map_err(|e| {
        let mut loc = Location::file(source.to_string());
        if let Some(span) = e.span() {
            loc = loc.at_line(line_of(text, span.start));
        }
        Error::input(loc, format!("invalid twin file: {}", e.message()))
    })?;
    build_twin(file, source, base_dir)
}

/// Validate a parsed twin file and assemble it.
pub fn build_twin(file: TwinFile, source: &str, base_dir: &Path) -> Result<Twin> {
    if file.matrices.is_some() {
        let system = build_matrix_market_system(&file, source, base_dir)?;
        return Ok(Twin {
            file,
            source: source.to_string(),
            model: None,
            system,
        });
    }
    let model = build_model(&file, source)?;
    let system = assemble(&model)?;
    Ok(Twin {
        file,
        source: source.to_string(),
        model: Some(model),
        system,
    })
}

fn err(source: &str, message: String) -> Error {
    Error::input(Location::file(source.to_string()), message)
}

fn check_positive(source: &str, what: &str, v: f64) -> Result<()> {
    if v > 0.0 && v.is_finite() {
        Ok(())
    } else {
        Err(err(
            source,
            format!("{what} must be positive and finite, is {v}"),
        ))
    }
}

fn validate_parameters(source: &str, defs: &[ParameterDef]) -> Result<()> {
    let mut seen = HashSet::new();
    for p in defs {
        if !seen.insert(p.name.as_str()) {
            return Err(err(source, format!("parameter {}: defined twice", p.name)));
        }
        if !(p.lower.is_finite() && p.upper.is_finite() && p.lower < p.upper) {
            return Err(err(
                source,
                format!(
                    "parameter {}: bounds [{}, {}] must be finite with lower < upper",
                    p.name, p.lower, p.upper
                ),
            ));
        }
        if !(p.lower > 0.0) && p.kind != ParameterKind::Density {
            return Err(err(
                source,
                format!(
                    "parameter {}: lower bound must be positive, is {}",
                    p.name, p.lower
                ),
            ));
        }
        if !(p.start.is_finite() && p.start >= p.lower && p.start <= p.upper) {
            return Err(err(
                source,
                format!(
                    "parameter {}: start {} is outside its bounds [{}, {}]",
                    p.name, p.start, p.lower, p.upper
                ),
            ));
        }
    }
    Ok(())
}

/// Validate every cross-reference and build the model (checked in file order: dimension,
/// materials, sections, nodes, elements, supports, masses, springs, rigid links,
/// parameters, sensors, gravity).
pub fn build_model(file: &TwinFile, source: &str) -> Result<Model> {
    let dimension = match file.twin.dimension {
        2 => Dimension::Two,
        3 => Dimension::Three,
        d => {
            return Err(err(
                source,
                format!("[twin] dimension must be 2 or 3, is {d}"),
            ))
        }
    };
    let (materials, material_index) = build_materials(file, source)?;
    let (sections, section_index) = build_sections(file, source)?;
    let (nodes, refs) = build_nodes(file, dimension, source)?;
    let (elements, groups) =
        build_elements(file, &refs, &material_index, &section_index, &sections)?;
    let supports = build_supports(file, &refs)?;
    let masses = build_masses(file, &refs)?;
    let (springs, sets) = build_springs(file, &refs)?;
    let rigid_links = build_rigid_links(file, &refs)?;
    let parameters = build_parameters(file, source, &groups, &sets)?;
    let sensors = build_sensors(file, &refs)?;
    let gravity = gravity_of(file, dimension, source)?;
    Ok(Model {
        name: file.twin.name.clone(),
        source: source.to_string(),
        dimension,
        nodes,
        materials,
        sections,
        elements,
        supports,
        masses,
        springs,
        rigid_links,
        parameters,
        sensors,
        gravity,
    })
}

/// What the node and DoF references of a twin file resolve against.
struct Refs<'a> {
    source: &'a str,
    dimension: Dimension,
    node_index: HashMap<i64, usize>,
}

impl Refs<'_> {
    /// Index of node `id`; `what` names the referring item in the error.
    fn node(&self, id: i64, what: &str) -> Result<usize> {
        self.node_index
            .get(&id)
            .copied()
            .ok_or_else(|| err(self.source, format!("{what}: node {id} does not exist")))
    }

    /// Index of the DoF called `name` (ux, uy, …) in this dimension.
    fn dof(&self, name: &str, what: &str) -> Result<usize> {
        self.dimension.dof_index(name).ok_or_else(|| {
            err(
                self.source,
                format!(
                    "{what}: DoF '{name}' is not one of {:?}",
                    self.dimension.dof_names()
                ),
            )
        })
    }
}

/// `[[materials]]`: unique names, E > 0, ρ ≥ 0, ν in (−1, 0.5); with the name → index map.
fn build_materials(
    file: &TwinFile,
    source: &str,
) -> Result<(Vec<Material>, HashMap<String, usize>)> {
    let mut materials = Vec::new();
    let mut material_index = HashMap::new();
    for m in &file.materials {
        if material_index
            .insert(m.name.clone(), materials.len())
            .is_some()
        {
            return Err(err(source, format!("material {}: defined twice", m.name)));
        }
        check_positive(source, &format!("material {}: E", m.name), m.youngs_modulus)?;
        if !(m.rho >= 0.0 && m.rho.is_finite()) {
            return Err(err(
                source,
                format!("material {}: rho must be ≥ 0, is {}", m.name, m.rho),
            ));
        }
        if !(m.nu > -1.0 && m.nu < 0.5) {
            return Err(err(
                source,
                format!("material {}: nu must be in (−1, 0.5), is {}", m.name, m.nu),
            ));
        }
        materials.push(Material {
            name: m.name.clone(),
            youngs_modulus: m.youngs_modulus,
            poisson: m.nu,
            density: m.rho,
        });
    }
    Ok((materials, material_index))
}

/// `[[sections]]`: unique names, shear factor (default 5/6) > 0; with the name → index map.
fn build_sections(file: &TwinFile, source: &str) -> Result<(Vec<Section>, HashMap<String, usize>)> {
    let mut sections = Vec::new();
    let mut section_index = HashMap::new();
    for s in &file.sections {
        if section_index
            .insert(s.name.clone(), sections.len())
            .is_some()
        {
            return Err(err(source, format!("section {}: defined twice", s.name)));
        }
        let shear_factor = s.shear_factor.unwrap_or(5.0 / 6.0);
        check_positive(
            source,
            &format!("section {}: shear_factor", s.name),
            shear_factor,
        )?;
        sections.push(Section {
            name: s.name.clone(),
            area: s.area.unwrap_or(0.0),
            iy: s.iy.unwrap_or(0.0),
            iz: s.iz.unwrap_or(0.0),
            torsion: s.torsion.unwrap_or(0.0),
            shear_factor,
            thickness: s.thickness.unwrap_or(0.0),
        });
    }
    Ok((sections, section_index))
}

/// `[mesh] nodes`: rows [id, x, y(, z)] with integer, unique ids and finite coordinates;
/// with the references that resolve node ids and DoF names.
fn build_nodes<'a>(
    file: &TwinFile,
    dimension: Dimension,
    source: &'a str,
) -> Result<(Vec<Node>, Refs<'a>)> {
    let mesh = file
        .mesh
        .as_ref()
        .ok_or_else(|| err(source, "missing [mesh] with nodes (or [matrices])".into()))?;
    let mut nodes = Vec::with_capacity(mesh.nodes.len());
    let mut node_index: HashMap<i64, usize> = HashMap::new();
    let want = if dimension == Dimension::Two { 3 } else { 4 };
    for (i, row) in mesh.nodes.iter().enumerate() {
        if row.len() != want {
            return Err(err(
                source,
                format!(
                    "mesh.nodes[{i}]: expected [id, {}], got {} numbers",
                    if want == 3 { "x, y" } else { "x, y, z" },
                    row.len()
                ),
            ));
        }
        let id = row[0];
        if !(id.fract() == 0.0 && id.abs() < 9.0e15) {
            return Err(err(
                source,
                format!("mesh.nodes[{i}]: node id {id} is not an integer"),
            ));
        }
        let id = id as i64;
        if row.iter().any(|v| !v.is_finite()) {
            return Err(err(source, format!("node {id}: non-finite coordinate")));
        }
        if node_index.insert(id, nodes.len()).is_some() {
            return Err(err(source, format!("node {id}: defined twice")));
        }
        let z = if want == 4 { row[3] } else { 0.0 };
        nodes.push(Node {
            id,
            coords: [row[1], row[2], z],
        });
    }
    Ok((
        nodes,
        Refs {
            source,
            dimension,
            node_index,
        },
    ))
}

/// `[[elements]]` blocks: known type of the twin's dimension, existing material and section
/// (with the properties the type needs), connectivity of existing nodes, unique element ids;
/// with the element groups.
fn build_elements(
    file: &TwinFile,
    refs: &Refs,
    material_index: &HashMap<String, usize>,
    section_index: &HashMap<String, usize>,
    sections: &[Section],
) -> Result<(Vec<Element>, HashSet<String>)> {
    let source = refs.source;
    let mut elements = Vec::new();
    let mut element_ids = HashSet::new();
    let mut groups = HashSet::new();
    for (b, block) in file.elements.iter().enumerate() {
        let what = format!("elements[{b}] (group {})", block.group);
        let kind = element_kind(file, block, &what, refs)?;
        let material = *material_index.get(&block.material).ok_or_else(|| {
            err(
                source,
                format!("{what}: material '{}' does not exist", block.material),
            )
        })?;
        let section = *section_index.get(&block.section).ok_or_else(|| {
            err(
                source,
                format!("{what}: section '{}' does not exist", block.section),
            )
        })?;
        check_section_for(kind, &sections[section], source)?;
        groups.insert(block.group.clone());
        for row in &block.connectivity {
            if row.len() != kind.node_count() + 1 {
                return Err(err(
                    source,
                    format!(
                        "{what}: connectivity {:?} must be [id, {} node ids]",
                        row,
                        kind.node_count()
                    ),
                ));
            }
            let id = row[0];
            if !element_ids.insert(id) {
                return Err(err(source, format!("element {id}: defined twice")));
            }
            let mut en = Vec::with_capacity(kind.node_count());
            for &nid in &row[1..] {
                en.push(refs.node(nid, &format!("element {id}"))?);
            }
            elements.push(Element {
                id,
                kind,
                nodes: en,
                material,
                section,
                group: block.group.clone(),
                orientation: block.orientation,
            });
        }
    }
    Ok((elements, groups))
}

/// Element type of a block: known, and of the twin's dimension.
fn element_kind(
    file: &TwinFile,
    block: &ElementBlockDef,
    what: &str,
    refs: &Refs,
) -> Result<ElementKind> {
    let (source, dimension) = (refs.source, refs.dimension);
    let kind = ElementKind::parse(&block.kind).ok_or_else(|| {
        err(
            source,
            format!(
                "{what}: unknown element type '{}' (known: beam2d, beam3d, q4, shell4)",
                block.kind
            ),
        )
    })?;
    if kind.dimension() != dimension {
        return Err(err(
            source,
            format!(
                "{what}: element type {} needs a {}D model, the twin is {}D",
                kind.name(),
                if kind.dimension() == Dimension::Two {
                    2
                } else {
                    3
                },
                file.twin.dimension
            ),
        ));
    }
    Ok(kind)
}

/// The section properties an element type needs must be positive.
fn check_section_for(kind: ElementKind, sec: &Section, source: &str) -> Result<()> {
    match kind {
        ElementKind::Beam2d => {
            check_positive(source, &format!("section {}: A", sec.name), sec.area)?;
            check_positive(source, &format!("section {}: Iz", sec.name), sec.iz)?;
        }
        ElementKind::Beam3d => {
            for (n, v) in [
                ("A", sec.area),
                ("Iy", sec.iy),
                ("Iz", sec.iz),
                ("J", sec.torsion),
            ] {
                check_positive(source, &format!("section {}: {n}", sec.name), v)?;
            }
        }
        ElementKind::Q4 | ElementKind::Shell4 => {
            check_positive(
                source,
                &format!("section {}: thickness", sec.name),
                sec.thickness,
            )?;
        }
    }
    Ok(())
}

/// `[[supports]]`: (node, DoF) pairs fixed to zero ("all" = every DoF of the node).
fn build_supports(file: &TwinFile, refs: &Refs) -> Result<Vec<(usize, usize)>> {
    let nd = refs.dimension.dofs_per_node();
    let mut supports = Vec::new();
    for (i, s) in file.supports.iter().enumerate() {
        for &nid in &s.nodes {
            let node = refs.node(nid, &format!("supports[{i}]"))?;
            for d in &s.dofs {
                if d.eq_ignore_ascii_case("all") {
                    supports.extend((0..nd).map(|k| (node, k)));
                } else {
                    supports.push((node, refs.dof(d, &format!("supports[{i}]"))?));
                }
            }
        }
    }
    Ok(supports)
}

/// `[[masses]]`: lumped mass on the translations, optional rotational inertias, all ≥ 0.
fn build_masses(file: &TwinFile, refs: &Refs) -> Result<Vec<LumpedMass>> {
    let (source, dimension) = (refs.source, refs.dimension);
    let nd = dimension.dofs_per_node();
    let mut masses = Vec::new();
    for (i, m) in file.masses.iter().enumerate() {
        let node = refs.node(m.node, &format!("masses[{i}]"))?;
        let mut values = vec![0.0; nd];
        let trans = if dimension == Dimension::Two { 2 } else { 3 };
        let inertia = m.inertia.clone().unwrap_or_default();
        if inertia.len() > nd - trans {
            return Err(err(
                source,
                format!("masses[{i}]: at most {} inertia values", nd - trans),
            ));
        }
        for v in values.iter_mut().take(trans) {
            *v = m.mass;
        }
        for (k, v) in inertia.iter().enumerate() {
            values[trans + k] = *v;
        }
        if values.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(err(
                source,
                format!(
                    "masses[{i}] (node {}): masses and inertias must be ≥ 0",
                    m.node
                ),
            ));
        }
        masses.push(LumpedMass { node, values });
    }
    Ok(masses)
}

/// `[[springs]]`: grounded (`nodes`) and two-node (`pairs`) springs, k ≥ 0, numbered in
/// file order; with the spring sets.
fn build_springs(file: &TwinFile, refs: &Refs) -> Result<(Vec<Spring>, HashSet<String>)> {
    let source = refs.source;
    let mut springs = Vec::new();
    let mut sets = HashSet::new();
    let mut spring_id = 0i64;
    for (i, s) in file.springs.iter().enumerate() {
        let what = format!("springs[{i}] (set {})", s.set);
        let dof = refs.dof(&s.dof, &what)?;
        if !(s.k.is_finite() && s.k >= 0.0) {
            return Err(err(source, format!("{what}: k must be ≥ 0, is {}", s.k)));
        }
        sets.insert(s.set.clone());
        for &nid in &s.nodes {
            spring_id += 1;
            springs.push(Spring {
                id: spring_id,
                node: refs.node(nid, &what)?,
                node2: None,
                dof,
                stiffness: s.k,
                set: s.set.clone(),
            });
        }
        for &[a, b] in &s.pairs {
            spring_id += 1;
            springs.push(Spring {
                id: spring_id,
                node: refs.node(a, &what)?,
                node2: Some(refs.node(b, &what)?),
                dof,
                stiffness: s.k,
                set: s.set.clone(),
            });
        }
    }
    Ok((springs, sets))
}

/// `[[rigid_links]]`: existing master and slave nodes, no node its own master.
fn build_rigid_links(file: &TwinFile, refs: &Refs) -> Result<Vec<RigidLink>> {
    let source = refs.source;
    let mut rigid_links = Vec::new();
    for (i, r) in file.rigid_links.iter().enumerate() {
        let what = format!("rigid_links[{i}]");
        let master = refs.node(r.master, &what)?;
        let mut slaves = Vec::new();
        for &s in &r.slaves {
            let idx = refs.node(s, &what)?;
            if idx == master {
                return Err(err(source, format!("{what}: node {s} is its own master")));
            }
            slaves.push(idx);
        }
        rigid_links.push(RigidLink { master, slaves });
    }
    Ok(rigid_links)
}

/// `[[parameters]]`: valid bounds and start, targets (element groups, or spring sets for
/// spring stiffness) that exist, no target set by two parameters.
fn build_parameters(
    file: &TwinFile,
    source: &str,
    groups: &HashSet<String>,
    sets: &HashSet<String>,
) -> Result<Vec<Parameter>> {
    validate_parameters(source, &file.parameters)?;
    let mut claimed: HashMap<(ParameterKind, String), String> = HashMap::new();
    let mut parameters = Vec::new();
    for p in &file.parameters {
        let targets: &Vec<String> = match p.kind {
            ParameterKind::SpringStiffness => &p.sets,
            _ => &p.groups,
        };
        if targets.is_empty() {
            return Err(err(
                source,
                format!(
                    "parameter {}: lists no {}",
                    p.name,
                    if p.kind == ParameterKind::SpringStiffness {
                        "spring sets"
                    } else {
                        "element groups"
                    }
                ),
            ));
        }
        for t in targets {
            let exists = if p.kind == ParameterKind::SpringStiffness {
                sets.contains(t)
            } else {
                groups.contains(t)
            };
            if !exists {
                return Err(err(
                    source,
                    format!(
                        "parameter {}: {} '{t}' does not exist",
                        p.name,
                        if p.kind == ParameterKind::SpringStiffness {
                            "spring set"
                        } else {
                            "element group"
                        }
                    ),
                ));
            }
            if let Some(other) = claimed.insert((p.kind, t.clone()), p.name.clone()) {
                return Err(err(
                    source,
                    format!(
                        "parameters {other} and {} both set {:?} of '{t}'",
                        p.name, p.kind
                    ),
                ));
            }
        }
        parameters.push(Parameter {
            name: p.name.clone(),
            kind: p.kind,
            groups: p.groups.clone(),
            sets: p.sets.clone(),
            lower: p.lower,
            upper: p.upper,
            start: p.start,
        });
    }
    Ok(parameters)
}

/// `[[sensors]]`: each channel mapped once, to an existing node and DoF.
fn build_sensors(file: &TwinFile, refs: &Refs) -> Result<Vec<Sensor>> {
    let source = refs.source;
    let mut sensors = Vec::new();
    let mut channels = HashSet::new();
    for s in &file.sensors {
        let what = format!("sensor {}", s.channel);
        if !channels.insert(s.channel.clone()) {
            return Err(err(source, format!("{what}: channel mapped twice")));
        }
        let (Some(nid), Some(dof)) = (s.node, s.dof.as_ref()) else {
            return Err(err(
                source,
                format!("{what}: a mesh twin needs node and dof"),
            ));
        };
        let node = refs.node(nid, &what)?;
        sensors.push(Sensor {
            channel: s.channel.clone(),
            node,
            dof: refs.dof(dof, &what)?,
        });
    }
    Ok(sensors)
}

/// `[twin] gravity` (2 or 3 components), default −9.81 m/s² along y (2D) or z (3D).
fn gravity_of(file: &TwinFile, dimension: Dimension, source: &str) -> Result<[f64; 3]> {
    let gravity = match &file.twin.gravity {
        None => {
            if dimension == Dimension::Two {
                [0.0, -9.81, 0.0]
            } else {
                [0.0, 0.0, -9.81]
            }
        }
        Some(g) if g.len() == 2 || g.len() == 3 => [g[0], g[1], g.get(2).copied().unwrap_or(0.0)],
        Some(g) => {
            return Err(err(
                source,
                format!(
                    "[twin] gravity must have 2 or 3 components, has {}",
                    g.len()
                ),
            ))
        }
    };
    Ok(gravity)
}

/// Matrix Market twin: K(θ) = K0 + Σ θ_g K_g, M(θ) = M0 + Σ θ_g M_g.
fn build_matrix_market_system(
    file: &TwinFile,
    source: &str,
    base_dir: &Path,
) -> Result<TwinSystem> {
    let Some(mx) = &file.matrices else {
        return Err(err(source, "missing [matrices]".into()));
    };
    if file.mesh.is_some() || !file.elements.is_empty() {
        return Err(err(
            source,
            "a twin has either [mesh]/[[elements]] or [matrices], not both".into(),
        ));
    }
    validate_parameters(source, &file.parameters)?;
    let k0 = read_matrix_market(&base_dir.join(&mx.stiffness))?;
    let m0 = read_matrix_market(&base_dir.join(&mx.mass))?;
    let n = k0.n;
    if m0.n != n {
        return Err(err(
            source,
            format!("mass matrix is {}×{}, stiffness {}×{}", m0.n, m0.n, n, n),
        ));
    }
    let zero = super::sparse::CscMatrix::from_triplets(n, &[]);
    let mut kt = vec![zero.clone(); file.parameters.len()];
    let mut mt = vec![zero.clone(); file.parameters.len()];
    for t in &mx.terms {
        let g = file
            .parameters
            .iter()
            .position(|p| p.name == t.parameter)
            .ok_or_else(|| {
                err(
                    source,
                    format!("matrices.terms: parameter '{}' is not defined", t.parameter),
                )
            })?;
        for (path, slot) in [(&t.stiffness, &mut kt[g]), (&t.mass, &mut mt[g])] {
            if let Some(p) = path {
                let a = read_matrix_market(&base_dir.join(p))?;
                if a.n != n {
                    return Err(err(
                        source,
                        format!(
                            "matrices.terms {}: {p} is {}×{}, expected {n}×{n}",
                            t.parameter, a.n, a.n
                        ),
                    ));
                }
                *slot = a;
            }
        }
    }
    let mut sensors = Vec::new();
    for s in &file.sensors {
        let idx = s.index.ok_or_else(|| {
            err(
                source,
                format!(
                    "sensor {}: a Matrix Market twin maps sensors by 'index'",
                    s.channel
                ),
            )
        })?;
        if idx == 0 || idx > n {
            return Err(err(
                source,
                format!("sensor {}: index {idx} outside 1..={n}", s.channel),
            ));
        }
        sensors.push(SensorDof {
            channel: s.channel.clone(),
            combination: vec![(idx - 1, 1.0)],
        });
    }
    Ok(TwinSystem {
        source: source.to_string(),
        dofs: None,
        n,
        stiffness: AffineMatrix::from_matrices(&k0, &kt),
        mass: AffineMatrix::from_matrices(&m0, &mt),
        parameters: file
            .parameters
            .iter()
            .map(|p| ParameterInfo {
                name: p.name.clone(),
                lower: p.lower,
                upper: p.upper,
                start: p.start,
            })
            .collect(),
        sensors,
        gravity: [0.0; 3],
        labels: (0..n).map(|i| format!("matrix row {}", i + 1)).collect(),
        mass_influence: Vec::new(),
        symbolic_cache: Default::default(),
    })
}

/// The twin file with each parameter's `start` replaced by its updated value (TOML text).
pub fn updated_twin_toml(file: &TwinFile, values: &[(String, f64)]) -> Result<String> {
    let mut out = file.clone();
    for (name, v) in values {
        let p = out
            .parameters
            .iter_mut()
            .find(|p| &p.name == name)
            .ok_or_else(|| Error::usage(format!("updated parameter {name} is not in the twin")))?;
        if !(v.is_finite() && *v >= p.lower && *v <= p.upper) {
            return Err(Error::usage(format!(
                "updated parameter {name} = {v} is outside [{}, {}]",
                p.lower, p.upper
            )));
        }
        p.start = *v;
    }
    toml::to_string(&out).map_err(|e| Error::usage(format!("serialising the updated twin: {e}")))
}
