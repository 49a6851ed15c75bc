//! Partition of a mesh twin into the numerical substructure (NS) and the physical substructure
//! (PS, the laboratory specimen) by a node set (METHODS §5). An element belongs to the PS when
//! all its nodes are in the set; the PS DoFs are the node DoFs its elements couple; interface
//! DoFs are PS DoFs that an NS element also couples. The PS matrices are assembled from the PS
//! elements alone, without supports, springs or lumped masses: they describe the floating
//! specimen, whose kernel is its rigid-body motion.

use faer::Mat;

use crate::error::{Error, Location};
use crate::twin::assembly::{element_matrices, DofMap};
use crate::twin::model::Model;
use crate::Result;

#[derive(Debug, Clone)]
pub struct Partition {
    /// Element indices of the PS and of the NS (ascending).
    pub ps_elements: Vec<usize>,
    pub ns_elements: Vec<usize>,
    /// PS DoFs as (node index, node DoF), ascending; every matrix below uses this order.
    pub ps_dofs: Vec<(usize, usize)>,
    /// Free-DoF index in the twin of each PS DoF.
    pub ps_free: Vec<usize>,
    /// Positions in `ps_dofs` of the interface DoFs (also coupled by an NS element).
    pub interface: Vec<usize>,
    /// Stiffness and mass of the floating PS (its elements only), `ps_dofs` order.
    pub ps_stiffness: Mat<f64>,
    pub ps_mass: Mat<f64>,
}

impl Partition {
    pub fn n_ps(&self) -> usize {
        self.ps_dofs.len()
    }
    /// Position in `ps_dofs` of (node index, DoF).
    pub fn position(&self, node: usize, dof: usize) -> Option<usize> {
        self.ps_dofs.binary_search(&(node, dof)).ok()
    }
    /// Free-DoF indices of the interface DoFs.
    pub fn interface_free(&self) -> Vec<usize> {
        self.interface.iter().map(|&p| self.ps_free[p]).collect()
    }
    /// Restrict a full free-DoF vector of the twin to the PS DoFs.
    pub fn restrict(&self, u_free: &[f64]) -> Vec<f64> {
        self.ps_free
            .iter()
            .map(|&i| u_free.get(i).copied().unwrap_or(0.0))
            .collect()
    }
    /// Gravity load on the floating PS: f = M_P r_g, r_g the rigid translation of every PS
    /// node by the gravity vector (consistent mass: the weight of the PS elements).
    pub fn ps_gravity_load(
        &self,
        gravity: [f64; 3],
        dimension_translation: impl Fn(usize) -> Option<usize>,
    ) -> Vec<f64> {
        let n = self.n_ps();
        let r: Vec<f64> = self
            .ps_dofs
            .iter()
            .map(|&(_, d)| {
                (0..3)
                    .filter(|&axis| dimension_translation(axis) == Some(d))
                    .map(|axis| gravity[axis])
                    .sum()
            })
            .collect();
        (0..n)
            .map(|i| (0..n).map(|j| self.ps_mass[(i, j)] * r[j]).sum())
            .collect()
    }
}

/// Partition by user node ids (the design file's form). Errors name the unknown id.
pub fn partition_by_node_ids(
    model: &Model,
    dofs: &DofMap,
    ps_node_ids: &[i64],
    source: &str,
) -> Result<Partition> {
    let mut nodes = Vec::with_capacity(ps_node_ids.len());
    for &id in ps_node_ids {
        let Some(i) = model.node_index(id) else {
            return Err(Error::input(
                Location::file(source.to_string()),
                format!(
                    "PS node set: node {id} does not exist in twin {}",
                    model.source
                ),
            ));
        };
        nodes.push(i);
    }
    partition_by_nodes(model, dofs, &nodes, source)
}

/// Partition by node indices. Errors (`Input`, naming `source`): empty PS, a PS that is the
/// whole model, a PS without interface, a PS DoF that is supported or a rigid-link slave in the
/// twin (the PS must be floating: its rigid-body motion is then free in the assembled twin).
pub fn partition_by_nodes(
    model: &Model,
    dofs: &DofMap,
    ps_nodes: &[usize],
    source: &str,
) -> Result<Partition> {
    let loc = || Location::file(source.to_string());
    let mut in_set = vec![false; model.nodes.len()];
    for &n in ps_nodes {
        match in_set.get_mut(n) {
            Some(s) => *s = true,
            None => {
                return Err(Error::input(
                    loc(),
                    format!("PS node set: node index {n} out of range"),
                ))
            }
        }
    }
    let (mut ps_elements, mut ns_elements) = (Vec::new(), Vec::new());
    for (e, el) in model.elements.iter().enumerate() {
        if el
            .nodes
            .iter()
            .all(|&n| in_set.get(n).copied().unwrap_or(false))
        {
            ps_elements.push(e);
        } else {
            ns_elements.push(e);
        }
    }
    if ps_elements.is_empty() {
        return Err(Error::input(
            loc(),
            "PS node set contains no complete element: the physical substructure is empty",
        ));
    }
    if ns_elements.is_empty() {
        return Err(Error::input(
            loc(),
            "PS node set covers every element: no numerical substructure is left",
        ));
    }
    let element_dofs = |e: usize| -> Vec<(usize, usize)> {
        let el = &model.elements[e];
        el.nodes
            .iter()
            .flat_map(|&n| el.kind.dofs().iter().map(move |&d| (n, d)))
            .collect()
    };
    let mut ps_dofs: Vec<(usize, usize)> =
        ps_elements.iter().flat_map(|&e| element_dofs(e)).collect();
    ps_dofs.sort_unstable();
    ps_dofs.dedup();
    let mut ns_dofs: Vec<(usize, usize)> =
        ns_elements.iter().flat_map(|&e| element_dofs(e)).collect();
    ns_dofs.sort_unstable();
    ns_dofs.dedup();
    let interface: Vec<usize> = ps_dofs
        .iter()
        .enumerate()
        .filter(|(_, d)| ns_dofs.binary_search(d).is_ok())
        .map(|(p, _)| p)
        .collect();
    if interface.is_empty() {
        return Err(Error::input(loc(), "the PS shares no DoF with the NS: a PS without interface cannot be tested in a hybrid loop"));
    }
    let mut ps_free = Vec::with_capacity(ps_dofs.len());
    for &(n, d) in &ps_dofs {
        match dofs.free_index(n, d) {
            Some(i) => ps_free.push(i),
            None => {
                return Err(Error::input(
                    loc(),
                    format!("PS DoF {} is supported or a rigid-link slave in the twin; the PS must be floating", model.dof_label(n, d)),
                ))
            }
        }
    }
    let n = ps_dofs.len();
    let mut k = Mat::<f64>::zeros(n, n);
    let mut m = Mat::<f64>::zeros(n, n);
    for &e in &ps_elements {
        let (ke, me) = element_matrices(model, e)?;
        let pos: Vec<usize> = element_dofs(e)
            .iter()
            .map(|d| ps_dofs.binary_search(d).unwrap_or(usize::MAX))
            .collect();
        for (a, &pa) in pos.iter().enumerate() {
            for (b, &pb) in pos.iter().enumerate() {
                if pa < n && pb < n {
                    k[(pa, pb)] += ke[(a, b)];
                    m[(pa, pb)] += me[(a, b)];
                }
            }
        }
    }
    Ok(Partition {
        ps_elements,
        ns_elements,
        ps_dofs,
        ps_free,
        interface,
        ps_stiffness: k,
        ps_mass: m,
    })
}
