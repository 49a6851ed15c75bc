//! Interface super-element (thesis ch. 5, METHODS §5 last item): a distributed PS–NS
//! interface is driven through a few control nodes; every other interface node follows the
//! piecewise-affine field between the control nodes on its boundary chain. In the laboratory
//! this is the steel frame, anchors and rods of the PS super-element; in the twin it is the
//! constraint u_PS = G g, where g holds the PS interior DoFs and the control-node DoFs.
//!
//! Chains: the PS boundary edges (element edges used by one PS element only) whose nodes are
//! both interface nodes, linked into paths and split where the path turns by more than
//! `CORNER_ANGLE_DEG` or branches; chain ends are always control nodes. An interface node on
//! no chain (e.g. a beam end) is a control node by itself.

use std::collections::{BTreeMap, BTreeSet};

use faer::Mat;

use super::partition::Partition;
use crate::twin::model::Model;

/// A chain turning by more than this (degrees) at a node is split there (a corner).
pub const CORNER_ANGLE_DEG: f64 = 10.0;

#[derive(Debug, Clone)]
pub struct InterfaceKinematics {
    /// Chains of interface nodes (node indices), each ordered along the PS boundary.
    pub chains: Vec<Vec<usize>>,
    /// Control nodes (node indices), ascending.
    pub control_nodes: Vec<usize>,
    /// PS positions (into `Partition::ps_dofs`) kept as independent coordinates g: the PS DoFs
    /// of interior nodes and of control nodes, ascending.
    pub coordinates: Vec<usize>,
    /// Positions in `coordinates` of the control-node interface DoFs: the coupled DoFs.
    pub coupled: Vec<usize>,
    /// G (n_PS × n_g): u_PS = G g (identity rows for coordinates, two-point affine weights for
    /// the followers).
    pub map: Mat<f64>,
}

/// Interface nodes (node indices, ascending) of a partition.
pub fn interface_nodes(partition: &Partition) -> Vec<usize> {
    let mut nodes: Vec<usize> = partition
        .interface
        .iter()
        .map(|&p| partition.ps_dofs[p].0)
        .collect();
    nodes.sort_unstable();
    nodes.dedup();
    nodes
}

/// Boundary chains of the PS through its interface nodes (see the module notes).
pub fn interface_chains(model: &Model, partition: &Partition) -> Vec<Vec<usize>> {
    let on_interface: BTreeSet<usize> = interface_nodes(partition).into_iter().collect();
    // Element edges of PS area elements (3+ nodes, taken cyclically) used by one PS element.
    let mut edge_count: BTreeMap<(usize, usize), usize> = BTreeMap::new();
    for &e in &partition.ps_elements {
        let nodes = &model.elements[e].nodes;
        if nodes.len() < 3 {
            continue;
        }
        for i in 0..nodes.len() {
            let (a, b) = (nodes[i], nodes[(i + 1) % nodes.len()]);
            *edge_count.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    let mut adjacency: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for (&(a, b), &count) in &edge_count {
        if count == 1 && on_interface.contains(&a) && on_interface.contains(&b) {
            adjacency.entry(a).or_default().push(b);
            adjacency.entry(b).or_default().push(a);
        }
    }
    let coords = |n: usize| model.nodes[n].coords;
    let is_break = |n: usize| -> bool {
        let nb = &adjacency[&n];
        if nb.len() != 2 {
            return true;
        }
        let (p, c, q) = (coords(nb[0]), coords(n), coords(nb[1]));
        let u: Vec<f64> = (0..3).map(|i| c[i] - p[i]).collect();
        let v: Vec<f64> = (0..3).map(|i| q[i] - c[i]).collect();
        let dot: f64 = (0..3).map(|i| u[i] * v[i]).sum();
        let nu = u.iter().map(|x| x * x).sum::<f64>().sqrt();
        let nv = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if nu == 0.0 || nv == 0.0 {
            return true;
        }
        (dot / (nu * nv)).clamp(-1.0, 1.0).acos() > CORNER_ANGLE_DEG.to_radians()
    };
    let mut breaks: BTreeSet<usize> = adjacency.keys().copied().filter(|&n| is_break(n)).collect();
    let mut visited: BTreeSet<(usize, usize)> = BTreeSet::new();
    let mut chains = Vec::new();
    // A closed loop without corners (e.g. round an opening) breaks at its smallest node.
    loop {
        for &start in &breaks {
            for &next in &adjacency[&start] {
                if visited.contains(&(start.min(next), start.max(next))) {
                    continue;
                }
                let mut chain = vec![start];
                let (mut prev, mut cur) = (start, next);
                loop {
                    visited.insert((prev.min(cur), prev.max(cur)));
                    chain.push(cur);
                    if breaks.contains(&cur) {
                        break;
                    }
                    let Some(&nxt) = adjacency[&cur].iter().find(|&&x| x != prev) else {
                        break;
                    };
                    prev = cur;
                    cur = nxt;
                }
                chains.push(chain);
            }
        }
        let left = adjacency
            .iter()
            .find(|(&a, nb)| nb.iter().any(|&b| !visited.contains(&(a.min(b), a.max(b)))))
            .map(|(&a, _)| a);
        match left {
            Some(a) => {
                breaks.insert(a);
            }
            None => break,
        }
    }
    chains
}

impl InterfaceKinematics {
    /// The kinematics with the given control nodes (node indices; chain ends and interface
    /// nodes on no chain are added).
    pub fn new(
        model: &Model,
        partition: &Partition,
        chains: &[Vec<usize>],
        control: &BTreeSet<usize>,
    ) -> Self {
        let mut control: BTreeSet<usize> = control.clone();
        let mut on_chain = BTreeSet::new();
        for chain in chains {
            if let (Some(&a), Some(&b)) = (chain.first(), chain.last()) {
                control.insert(a);
                control.insert(b);
            }
            on_chain.extend(chain.iter().copied());
        }
        for n in interface_nodes(partition) {
            if !on_chain.contains(&n) {
                control.insert(n);
            }
        }
        // Followers: node → ((control a, weight), (control b, weight)) by arc length.
        let mut follows: BTreeMap<usize, [(usize, f64); 2]> = BTreeMap::new();
        let dist = |a: usize, b: usize| -> f64 {
            let (p, q) = (model.nodes[a].coords, model.nodes[b].coords);
            (0..3).map(|i| (p[i] - q[i]).powi(2)).sum::<f64>().sqrt()
        };
        for chain in chains {
            let mut arc = vec![0.0; chain.len()];
            for i in 1..chain.len() {
                arc[i] = arc[i - 1] + dist(chain[i - 1], chain[i]);
            }
            let knots: Vec<usize> = (0..chain.len())
                .filter(|&i| control.contains(&chain[i]))
                .collect();
            for w in knots.windows(2) {
                let (a, b) = (w[0], w[1]);
                let span = arc[b] - arc[a];
                for i in a + 1..b {
                    if control.contains(&chain[i]) || follows.contains_key(&chain[i]) {
                        continue;
                    }
                    let s = if span > 0.0 {
                        (arc[i] - arc[a]) / span
                    } else {
                        0.5
                    };
                    follows.insert(chain[i], [(chain[a], 1.0 - s), (chain[b], s)]);
                }
            }
        }
        // A follower needs each of its DoFs at both control nodes; otherwise it is a control node.
        let n_ps = partition.n_ps();
        let follows: BTreeMap<usize, [(usize, f64); 2]> = follows
            .into_iter()
            .filter(|(n, pair)| {
                partition
                    .ps_dofs
                    .iter()
                    .filter(|(node, _)| node == n)
                    .all(|&(_, d)| {
                        pair.iter()
                            .all(|&(c, _)| partition.position(c, d).is_some())
                    })
            })
            .collect();
        let control_nodes: Vec<usize> = interface_nodes(partition)
            .into_iter()
            .filter(|n| !follows.contains_key(n))
            .collect();
        let coordinates: Vec<usize> = (0..n_ps)
            .filter(|&p| !follows.contains_key(&partition.ps_dofs[p].0))
            .collect();
        let interface: BTreeSet<usize> = partition.interface.iter().copied().collect();
        let coupled: Vec<usize> = coordinates
            .iter()
            .enumerate()
            .filter(|(_, p)| interface.contains(p))
            .map(|(i, _)| i)
            .collect();
        let mut map = Mat::<f64>::zeros(n_ps, coordinates.len());
        for (j, &p) in coordinates.iter().enumerate() {
            map[(p, j)] = 1.0;
        }
        for (p, &(node, d)) in partition.ps_dofs.iter().enumerate() {
            if let Some(pair) = follows.get(&node) {
                for &(c, w) in pair {
                    if let Some(q) = partition.position(c, d) {
                        if let Ok(j) = coordinates.binary_search(&q) {
                            map[(p, j)] += w;
                        }
                    }
                }
            }
        }
        InterfaceKinematics {
            chains: chains.to_vec(),
            control_nodes,
            coordinates,
            coupled,
            map,
        }
    }

    pub fn n_coordinates(&self) -> usize {
        self.coordinates.len()
    }

    /// Interface nodes that follow (not control nodes), with their chain, for refinement.
    pub fn followers(&self) -> Vec<usize> {
        let mut out: Vec<usize> = self
            .chains
            .iter()
            .flatten()
            .copied()
            .filter(|n| self.control_nodes.binary_search(n).is_err())
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }
}
