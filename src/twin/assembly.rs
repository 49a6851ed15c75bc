//! Sparse assembly of the twin: DoF numbering with supports and rigid links, element loops,
//! and the split K(θ) = K0 + Σ θ_g K_g, M(θ) = M0 + Σ θ_g M_g by parameter group.
//!
//! Every node DoF ("full" DoF) maps to a linear combination of free DoFs:
//! a free DoF to itself, a support to nothing, a rigid-link slave DoF to its master's
//! rigid-body motion (u_s = u_m + θ_m × (x_s − x_m), θ_s = θ_m). Element matrices are
//! scattered through this map, which is the congruence Tᵀ k T with T the constraint matrix.

use nalgebra::{DVector, Vector3};

use super::elements::beam2d::{beam2d_matrices, BeamSection2d};
use super::elements::beam3d::{beam3d_matrices, BeamSection3d};
use super::elements::q4::{q4_matrices, PlaneStress};
use super::elements::shell::{shell4_matrices, ShellSection};
use super::elements::{to_element_matrices, ElementMatrix};
use super::model::{Dimension, ElementKind, Model, ParameterKind};
use super::sparse::{AffineMatrix, AffineVector, CscMatrix};
use crate::error::Error;
use crate::Result;

/// Map from node DoFs to free (unknown) DoFs.
#[derive(Debug, Clone)]
pub struct DofMap {
    pub dimension: Dimension,
    pub dofs_per_node: usize,
    /// Per full DoF (node · dofs_per_node + dof): the free DoFs and coefficients it equals.
    pub full_to_free: Vec<Vec<(usize, f64)>>,
    /// Per free DoF: (node index, node DoF).
    pub free_labels: Vec<(usize, usize)>,
    /// Node ids, for labels.
    pub node_ids: Vec<i64>,
}

impl DofMap {
    pub fn n_free(&self) -> usize {
        self.free_labels.len()
    }
    /// The free DoF of (node index, dof) when it is itself free (not fixed, not a slave).
    pub fn free_index(&self, node: usize, dof: usize) -> Option<usize> {
        let combo = self.full_to_free.get(node * self.dofs_per_node + dof)?;
        match combo.as_slice() {
            [(i, c)] if *c == 1.0 && self.free_labels.get(*i) == Some(&(node, dof)) => Some(*i),
            _ => None,
        }
    }
    /// Label "node ID dof" of a free DoF.
    pub fn label(&self, free: usize) -> String {
        match self.free_labels.get(free) {
            Some(&(node, dof)) => format!(
                "node {} {}",
                self.node_ids.get(node).copied().unwrap_or(-1),
                self.dimension.dof_names().get(dof).copied().unwrap_or("?")
            ),
            None => format!("free DoF {free}"),
        }
    }
    /// Influence vector of a unit rigid translation of the base along global axis 0/1/2:
    /// 1 on free translational DoFs along that axis (rigid-link masters carry it through).
    pub fn influence_vector(&self, axis: usize) -> Vec<f64> {
        let mut r = vec![0.0; self.n_free()];
        if let Some(d) = self.dimension.translation_dof(axis) {
            for (i, &(_, dof)) in self.free_labels.iter().enumerate() {
                if dof == d {
                    r[i] = 1.0;
                }
            }
        }
        r
    }
}

/// A sensor channel read off the free DoFs: value = Σ coef · u[free].
#[derive(Debug, Clone)]
pub struct SensorDof {
    pub channel: String,
    pub combination: Vec<(usize, f64)>,
}

impl SensorDof {
    pub fn read(&self, u: &[f64]) -> f64 {
        self.combination
            .iter()
            .map(|&(i, c)| c * u.get(i).copied().unwrap_or(0.0))
            .sum()
    }
}

#[derive(Debug, Clone)]
pub struct ParameterInfo {
    pub name: String,
    pub lower: f64,
    pub upper: f64,
    pub start: f64,
}

/// The assembled twin: affine stiffness and mass, DoF map, parameters and sensors.
#[derive(Debug, Clone)]
pub struct TwinSystem {
    /// File the system came from, for messages.
    pub source: String,
    pub dofs: Option<DofMap>,
    pub n: usize,
    pub stiffness: AffineMatrix,
    pub mass: AffineMatrix,
    pub parameters: Vec<ParameterInfo>,
    pub sensors: Vec<SensorDof>,
    /// Gravity acceleration vector (m/s²).
    pub gravity: [f64; 3],
    /// Free-DoF labels for messages (same length as n).
    pub labels: Vec<String>,
    /// Effective earthquake/gravity force patterns per global axis x, y, z: M̃ r̃, the full
    /// mass (including the coupling to supported DoFs) times a unit rigid translation of all
    /// nodes along the axis, on the free DoFs. Empty for Matrix Market twins.
    pub mass_influence: Vec<AffineVector>,
    /// Symbolic sparse Cholesky of the K(θ) pattern, computed on first use.
    pub symbolic_cache: std::sync::OnceLock<faer::sparse::linalg::solvers::SymbolicLlt<usize>>,
}

impl TwinSystem {
    pub fn stiffness_at(&self, theta: &[f64]) -> CscMatrix {
        self.stiffness.at(theta)
    }
    pub fn mass_at(&self, theta: &[f64]) -> CscMatrix {
        self.mass.at(theta)
    }
    pub fn start_values(&self) -> Vec<f64> {
        self.parameters.iter().map(|p| p.start).collect()
    }
    pub fn lower_bounds(&self) -> Vec<f64> {
        self.parameters.iter().map(|p| p.lower).collect()
    }
    pub fn upper_bounds(&self) -> Vec<f64> {
        self.parameters.iter().map(|p| p.upper).collect()
    }
    /// Midpoint of the bounds (the thesis's start point).
    pub fn mid_bounds(&self) -> Vec<f64> {
        self.parameters
            .iter()
            .map(|p| 0.5 * (p.lower + p.upper))
            .collect()
    }
    /// Parameter vector within bounds, else `Error::Usage` naming the parameter.
    pub fn check_parameters(&self, theta: &[f64]) -> Result<()> {
        if theta.len() != self.parameters.len() {
            return Err(Error::usage(format!(
                "{}: {} parameter values given, the twin has {}",
                self.source,
                theta.len(),
                self.parameters.len()
            )));
        }
        for (p, v) in self.parameters.iter().zip(theta) {
            if !(v.is_finite() && *v >= p.lower && *v <= p.upper) {
                return Err(Error::usage(format!(
                    "{}: parameter {} = {v} is outside its bounds [{}, {}]",
                    self.source, p.name, p.lower, p.upper
                )));
            }
        }
        Ok(())
    }
    pub fn sensor_index(&self, channel: &str) -> Option<usize> {
        self.sensors.iter().position(|s| s.channel == channel)
    }
    /// Gravity load vector f = Σ_axis g_axis · M̃ r̃_axis (includes the mass at supports'
    /// neighbours that a free-DoF-only M r would miss with consistent mass).
    pub fn gravity_load(&self, theta: &[f64]) -> Vec<f64> {
        let mut f = vec![0.0; self.n];
        for (axis, pattern) in self.mass_influence.iter().enumerate().take(3) {
            let g = self.gravity[axis];
            if g != 0.0 {
                for (fi, p) in f.iter_mut().zip(pattern.at(theta)) {
                    *fi += g * p;
                }
            }
        }
        f
    }

    /// Base acceleration along global axis 0/1/2 as a Newmark excitation: effective force
    /// pattern M̃ r̃ and kinematic influence r (for absolute accelerations).
    pub fn base_excitation(
        &self,
        theta: &[f64],
        axis: usize,
        acceleration: Vec<f64>,
    ) -> Result<super::newmark::BaseExcitation> {
        let (Some(map), Some(pattern)) = (&self.dofs, self.mass_influence.get(axis)) else {
            return Err(Error::usage(format!(
                "{}: base excitation needs a mesh twin and an axis 0–2",
                self.source
            )));
        };
        Ok(super::newmark::BaseExcitation {
            influence: map.influence_vector(axis),
            load: pattern.at(theta),
            acceleration,
        })
    }
}

/// Build the DoF map: used DoFs (touched by an element, spring, mass or rigid link), minus
/// supports, minus rigid-link slaves.
pub fn build_dof_map(model: &Model) -> Result<DofMap> {
    let nd = model.dimension.dofs_per_node();
    let nn = model.nodes.len();
    let mut used = vec![false; nn * nd];
    for e in &model.elements {
        for &node in &e.nodes {
            for &d in e.kind.dofs() {
                if d < nd {
                    used[node * nd + d] = true;
                }
            }
        }
    }
    for s in &model.springs {
        used[s.node * nd + s.dof] = true;
        if let Some(n2) = s.node2 {
            used[n2 * nd + s.dof] = true;
        }
    }
    for m in &model.masses {
        for (d, v) in m.values.iter().enumerate() {
            if *v != 0.0 && d < nd {
                used[m.node * nd + d] = true;
            }
        }
    }
    let mut fixed = vec![false; nn * nd];
    for &(node, dof) in &model.supports {
        fixed[node * nd + dof] = true;
    }
    let mut slave_of = vec![None; nn];
    for link in &model.rigid_links {
        for &s in &link.slaves {
            if slave_of[s].is_some() {
                return Err(model.input_error(format!(
                    "rigid link: node {} is a slave of two rigid links",
                    model.nodes[s].id
                )));
            }
            slave_of[s] = Some(link.master);
        }
    }
    for link in &model.rigid_links {
        if slave_of[link.master].is_some() {
            return Err(model.input_error(format!(
                "rigid link: master node {} is itself a slave (chain the slaves to one master)",
                model.nodes[link.master].id
            )));
        }
        for &s in &link.slaves {
            for d in 0..nd {
                if fixed[s * nd + d] {
                    return Err(model.input_error(format!(
                        "rigid link: slave {} has a support; put the support on the master node {}",
                        model.dof_label(s, d),
                        model.nodes[link.master].id
                    )));
                }
            }
            // The slave's motion is carried by all the master's DoFs it depends on.
            if (0..nd).any(|d| used[s * nd + d]) {
                for d in 0..nd {
                    used[link.master * nd + d] = true;
                }
            }
        }
    }
    let mut full_to_free: Vec<Vec<(usize, f64)>> = vec![Vec::new(); nn * nd];
    let mut free_labels = Vec::new();
    for node in 0..nn {
        if slave_of[node].is_some() {
            continue;
        }
        for d in 0..nd {
            let k = node * nd + d;
            if used[k] && !fixed[k] {
                full_to_free[k] = vec![(free_labels.len(), 1.0)];
                free_labels.push((node, d));
            }
        }
    }
    for node in 0..nn {
        let Some(master) = slave_of[node] else {
            continue;
        };
        let r = [
            model.nodes[node].coords[0] - model.nodes[master].coords[0],
            model.nodes[node].coords[1] - model.nodes[master].coords[1],
            model.nodes[node].coords[2] - model.nodes[master].coords[2],
        ];
        // Rows of the rigid-body constraint: slave DoF d = Σ coef · master DoF.
        let rows: Vec<Vec<(usize, f64)>> = match model.dimension {
            Dimension::Two => vec![
                vec![(0, 1.0), (2, -r[1])],
                vec![(1, 1.0), (2, r[0])],
                vec![(2, 1.0)],
            ],
            Dimension::Three => vec![
                vec![(0, 1.0), (4, r[2]), (5, -r[1])],
                vec![(1, 1.0), (5, r[0]), (3, -r[2])],
                vec![(2, 1.0), (3, r[1]), (4, -r[0])],
                vec![(3, 1.0)],
                vec![(4, 1.0)],
                vec![(5, 1.0)],
            ],
        };
        for (d, row) in rows.iter().enumerate() {
            let mut combo: Vec<(usize, f64)> = Vec::new();
            for &(md, c) in row {
                if c == 0.0 {
                    continue;
                }
                for &(free, c2) in &full_to_free[master * nd + md] {
                    combo.push((free, c * c2));
                }
            }
            full_to_free[node * nd + d] = combo;
        }
    }
    Ok(DofMap {
        dimension: model.dimension,
        dofs_per_node: nd,
        full_to_free,
        free_labels,
        node_ids: model.nodes.iter().map(|n| n.id).collect(),
    })
}

/// Scatter an element matrix through the DoF map into a triplet list.
fn scatter(
    map: &DofMap,
    full_dofs: &[usize],
    k: &ElementMatrix,
    scale: f64,
    out: &mut Vec<(usize, usize, f64)>,
) {
    for (a, &fa) in full_dofs.iter().enumerate() {
        let Some(ra) = map.full_to_free.get(fa) else {
            continue;
        };
        if ra.is_empty() {
            continue;
        }
        for (b, &fb) in full_dofs.iter().enumerate() {
            let v = k[(a, b)] * scale;
            if v == 0.0 {
                continue;
            }
            let Some(rb) = map.full_to_free.get(fb) else {
                continue;
            };
            for &(ia, ca) in ra {
                for &(ib, cb) in rb {
                    out.push((ia, ib, ca * cb * v));
                }
            }
        }
    }
}

/// Element stiffness and mass in global coordinates (node DoFs in `ElementKind::dofs` order).
pub fn element_matrices(
    model: &Model,
    element_index: usize,
) -> Result<(ElementMatrix, ElementMatrix)> {
    let e = &model.elements[element_index];
    let mat = &model.materials[e.material];
    let sec = &model.sections[e.section];
    let xyz = |i: usize| Vector3::from(model.nodes[e.nodes[i]].coords);
    let result = match e.kind {
        ElementKind::Beam2d => {
            let s = BeamSection2d {
                youngs_modulus: mat.youngs_modulus,
                poisson: mat.poisson,
                density: mat.density,
                area: sec.area,
                inertia: sec.iz,
                shear_factor: sec.shear_factor,
            };
            let (a, b) = (xyz(0), xyz(1));
            beam2d_matrices(a.xy(), b.xy(), &s).map(to_element_matrices)
        }
        ElementKind::Beam3d => {
            let s = BeamSection3d {
                youngs_modulus: mat.youngs_modulus,
                poisson: mat.poisson,
                density: mat.density,
                area: sec.area,
                iy: sec.iy,
                iz: sec.iz,
                torsion: sec.torsion,
                shear_factor: sec.shear_factor,
            };
            beam3d_matrices(xyz(0), xyz(1), e.orientation.map(Vector3::from), &s)
                .map(to_element_matrices)
        }
        ElementKind::Q4 => {
            let p = PlaneStress {
                youngs_modulus: mat.youngs_modulus,
                poisson: mat.poisson,
                density: mat.density,
                thickness: sec.thickness,
            };
            let xy = [0, 1, 2, 3].map(|i| xyz(i).xy());
            q4_matrices(&xy, &p).map(to_element_matrices)
        }
        ElementKind::Shell4 => {
            let s = ShellSection {
                youngs_modulus: mat.youngs_modulus,
                poisson: mat.poisson,
                density: mat.density,
                thickness: sec.thickness,
                shear_factor: sec.shear_factor,
            };
            shell4_matrices(&[0, 1, 2, 3].map(xyz), &s).map(to_element_matrices)
        }
    };
    result.ok_or_else(|| {
        model.input_error(format!(
            "element {} ({}): degenerate geometry (zero length, inverted or collinear nodes, or orientation parallel to the axis)",
            e.id,
            e.kind.name()
        ))
    })
}

/// Assemble the twin: K(θ) and M(θ) affine in the parameters.
pub fn assemble(model: &Model) -> Result<TwinSystem> {
    let map = build_dof_map(model)?;
    let n = map.n_free();
    if n == 0 {
        return Err(model.input_error("the model has no free degree of freedom"));
    }
    let nd = map.dofs_per_node;
    let np = model.parameters.len();
    // Which parameter (if any) sets E / ρ of a group, k of a spring set.
    let param_for = |kind: ParameterKind, name: &str| -> Option<usize> {
        model.parameters.iter().position(|p| {
            p.kind == kind
                && match kind {
                    ParameterKind::SpringStiffness => p.sets.iter().any(|s| s == name),
                    _ => p.groups.iter().any(|g| g == name),
                }
        })
    };
    let mut k0 = Vec::new();
    let mut m0 = Vec::new();
    // Effective force patterns M̃ r̃ per axis: base and per density parameter.
    let mut infl: Vec<AffineVector> = (0..3)
        .map(|_| AffineVector {
            base: vec![0.0; n],
            terms: vec![vec![0.0; n]; np],
        })
        .collect();
    let add_influence = |infl: &mut Vec<AffineVector>,
                         full: &[usize],
                         me: &ElementMatrix,
                         local_dofs: &[usize],
                         scale: f64,
                         term: Option<usize>| {
        for axis in 0..3 {
            let Some(td) = map.dimension.translation_dof(axis) else {
                continue;
            };
            let r: Vec<f64> = full
                .iter()
                .enumerate()
                .map(|(a, _)| {
                    if local_dofs[a % local_dofs.len()] == td {
                        1.0
                    } else {
                        0.0
                    }
                })
                .collect();
            let f = me * DVector::from_vec(r);
            let target = match term {
                Some(g) => &mut infl[axis].terms[g],
                None => &mut infl[axis].base,
            };
            for (a, &fa) in full.iter().enumerate() {
                let v = f[a] * scale;
                if v == 0.0 {
                    continue;
                }
                if let Some(combo) = map.full_to_free.get(fa) {
                    for &(i, c) in combo {
                        target[i] += c * v;
                    }
                }
            }
        }
    };
    let mut kg: Vec<Vec<(usize, usize, f64)>> = vec![Vec::new(); np];
    let mut mg: Vec<Vec<(usize, usize, f64)>> = vec![Vec::new(); np];
    for (ei, e) in model.elements.iter().enumerate() {
        let (ke, me) = element_matrices(model, ei)?;
        let local = e.kind.dofs();
        let full: Vec<usize> = e
            .nodes
            .iter()
            .flat_map(|&node| local.iter().map(move |&d| node * nd + d))
            .collect();
        let mat = &model.materials[e.material];
        match param_for(ParameterKind::YoungsModulus, &e.group) {
            // Stiffness is linear in E (ν fixed): store it per unit E.
            Some(g) => scatter(&map, &full, &ke, 1.0 / mat.youngs_modulus, &mut kg[g]),
            None => scatter(&map, &full, &ke, 1.0, &mut k0),
        }
        match param_for(ParameterKind::Density, &e.group) {
            Some(g) => {
                scatter(&map, &full, &me, 1.0 / mat.density, &mut mg[g]);
                add_influence(&mut infl, &full, &me, local, 1.0 / mat.density, Some(g));
            }
            None => {
                scatter(&map, &full, &me, 1.0, &mut m0);
                add_influence(&mut infl, &full, &me, local, 1.0, None);
            }
        }
    }
    for s in &model.springs {
        let (full, ks) = match s.node2 {
            None => {
                let k = ElementMatrix::from_element(1, 1, 1.0);
                (vec![s.node * nd + s.dof], k)
            }
            Some(n2) => {
                let k = ElementMatrix::from_row_slice(2, 2, &[1.0, -1.0, -1.0, 1.0]);
                (vec![s.node * nd + s.dof, n2 * nd + s.dof], k)
            }
        };
        match param_for(ParameterKind::SpringStiffness, &s.set) {
            Some(g) => scatter(&map, &full, &ks, 1.0, &mut kg[g]),
            None => scatter(&map, &full, &ks, s.stiffness, &mut k0),
        }
    }
    for lm in &model.masses {
        let full: Vec<usize> = (0..nd).map(|d| lm.node * nd + d).collect();
        let mut m = ElementMatrix::zeros(nd, nd);
        for (d, v) in lm.values.iter().enumerate().take(nd) {
            m[(d, d)] = *v;
        }
        scatter(&map, &full, &m, 1.0, &mut m0);
        let local: Vec<usize> = (0..nd).collect();
        add_influence(&mut infl, &full, &m, &local, 1.0, None);
    }
    let stiffness = AffineMatrix::from_triplets(n, &k0, &kg);
    let mass = AffineMatrix::from_triplets(n, &m0, &mg);
    let mut sensors = Vec::with_capacity(model.sensors.len());
    for s in &model.sensors {
        let combination = map
            .full_to_free
            .get(s.node * nd + s.dof)
            .cloned()
            .unwrap_or_default();
        sensors.push(super::assembly::SensorDof {
            channel: s.channel.clone(),
            combination,
        });
    }
    let labels = (0..n).map(|i| map.label(i)).collect();
    Ok(TwinSystem {
        source: model.source.clone(),
        n,
        stiffness,
        mass,
        parameters: model
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
        gravity: model.gravity,
        labels,
        dofs: Some(map),
        mass_influence: infl,
        symbolic_cache: Default::default(),
    })
}

/// Check that no free DoF is left without stiffness (an unrestrained or unconnected DoF),
/// naming the first such DoF.
pub fn check_stiffness_diagonal(system: &TwinSystem, k: &CscMatrix) -> Result<()> {
    let d = k.diagonal();
    let scale = d.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    for (i, v) in d.iter().enumerate() {
        if !(*v > 1e-14 * scale) {
            return Err(Error::input(
                crate::error::Location::file(system.source.clone()),
                format!(
                    "stiffness matrix is singular: {} has no stiffness (unrestrained or unconnected DoF)",
                    system.labels.get(i).cloned().unwrap_or_else(|| format!("DoF {i}"))
                ),
            ));
        }
    }
    Ok(())
}
