//! Actuator placement, the Guyan + rigid-body reduction basis and its validation
//! (METHODS §5, Eq. 85–87; thesis ch. 7).
//!
//! Master selection: QR with column pivoting on U_kᵀ (k retained POMs × n_r retained DoFs).
//! The first k pivots are the DoFs whose rows of U_k are the most linearly independent
//! (greedy maximisation of |det U_k[m, :]|), so the retained POMs are spanned by, and
//! recoverable from, the master displacements (U_k[m, :] is invertible and well conditioned).
//! Effective independence would rank by the same projector; QR is deterministic and one
//! factorisation.

use faer::{Mat, MatRef};

use super::partition::Partition;
use super::pod::{wnrmse, Pod};
use super::rigid::{ConstrainedSet, RigidBodyModes};
use crate::error::Error;
use crate::twin::guyan::guyan_reduce;
use crate::twin::model::Model;
use crate::twin::sparse::CscMatrix;
use crate::Result;

/// Master DoFs (PS positions) spanning the first `k` POMs: QR with column pivoting on U_kᵀ.
/// POM rows follow `set.retained`.
pub fn select_masters(pod: &Pod, k: usize, set: &ConstrainedSet) -> Result<Vec<usize>> {
    let n = pod.modes.nrows();
    if k == 0 || k > pod.modes.ncols() || n != set.retained.len() {
        return Err(Error::usage(format!(
            "actuator placement: {k} POMs requested of {} (POM length {n}, retained DoFs {})",
            pod.modes.ncols(),
            set.retained.len()
        )));
    }
    let ukt = Mat::from_fn(k, n, |i, j| pod.modes[(j, i)]);
    let qr = ukt.col_piv_qr();
    let (forward, _) = qr.P().arrays();
    Ok(forward.iter().take(k).map(|&j| set.retained[j]).collect())
}

/// T_d on the retained DoFs and T over the PS (Eq. 85–87).
#[derive(Debug, Clone)]
pub struct ReductionBasis {
    /// Master DoFs (PS positions) in actuator order.
    pub masters: Vec<usize>,
    /// Masters as rows of the retained set r.
    pub masters_in_retained: Vec<usize>,
    /// T_d (n_r × n_m) = [I; −K_ss⁻¹K_sm] on the retained DoFs with c fixed (Eq. 85–86).
    pub guyan: Mat<f64>,
    /// T (n_PS × (n_m + n_rb)) = [[T_d, R^r], [0, R^c]] in PS DoF order (Eq. 87):
    /// u_PS = T [u_m; α].
    pub transformation: Mat<f64>,
    /// K̂ = Tᵀ K_P T, M̂ = Tᵀ M_P T.
    pub stiffness: Mat<f64>,
    pub mass: Mat<f64>,
}

/// Build T (Eq. 85–87): Guyan condensation of the PS with the constrained set c fixed onto the
/// masters, plus the rigid-body modes. Errors: a master in c or repeated, a mechanism among the
/// slaves.
pub fn reduction_basis(
    partition: &Partition,
    rigid: &RigidBodyModes,
    set: &ConstrainedSet,
    masters: &[usize],
) -> Result<ReductionBasis> {
    let nr = set.retained.len();
    let mut masters_in_retained = Vec::with_capacity(masters.len());
    for &m in masters {
        match set.retained.binary_search(&m) {
            Ok(i) => masters_in_retained.push(i),
            Err(_) => {
                return Err(Error::usage(format!(
                    "master PS DoF {m} is constrained or outside the PS"
                )))
            }
        }
    }
    let k_rr = Mat::from_fn(nr, nr, |i, j| {
        partition.ps_stiffness[(set.retained[i], set.retained[j])]
    });
    let m_rr = Mat::from_fn(nr, nr, |i, j| {
        partition.ps_mass[(set.retained[i], set.retained[j])]
    });
    let g = guyan_reduce(
        &CscMatrix::from_dense(k_rr.as_ref()),
        &CscMatrix::from_dense(m_rr.as_ref()),
        &masters_in_retained,
    )?;
    let (nm, nrb, np) = (masters.len(), rigid.count(), partition.n_ps());
    let mut t = Mat::<f64>::zeros(np, nm + nrb);
    for (row, &p) in set.retained.iter().enumerate() {
        for j in 0..nm {
            t[(p, j)] = g.transformation[(row, j)];
        }
    }
    for p in 0..np {
        for j in 0..nrb {
            t[(p, nm + j)] = rigid.modes[(p, j)];
        }
    }
    let stiffness = congruence(partition.ps_stiffness.as_ref(), t.as_ref());
    let mass = congruence(partition.ps_mass.as_ref(), t.as_ref());
    Ok(ReductionBasis {
        masters: masters.to_vec(),
        masters_in_retained,
        guyan: g.transformation,
        transformation: t,
        stiffness,
        mass,
    })
}

/// Tᵀ A T, symmetrised.
pub fn congruence(a: MatRef<'_, f64>, t: MatRef<'_, f64>) -> Mat<f64> {
    let mut r = t.transpose() * (a * t);
    let n = r.nrows();
    for i in 0..n {
        for j in 0..i {
            let s = 0.5 * (r[(i, j)] + r[(j, i)]);
            r[(i, j)] = s;
            r[(j, i)] = s;
        }
    }
    r
}

/// Displacement or force control of an actuator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ControlMode {
    Displacement,
    Force,
}

impl ControlMode {
    pub fn name(self) -> &'static str {
        match self {
            ControlMode::Displacement => "displacement",
            ControlMode::Force => "force",
        }
    }
}

#[derive(Debug, Clone)]
pub struct ActuatorSettings {
    /// A master DoF whose deformation history has std ≤ `static_ratio` · max|ū| moves
    /// negligibly about its (gravity) mean: with a non-zero nominal force it is force-controlled
    /// (thesis ch. 7: vertical actuators carrying the gravity load).
    pub static_ratio: f64,
    /// Nominal forces below this magnitude (N) count as zero.
    pub min_force: f64,
}

impl Default for ActuatorSettings {
    fn default() -> Self {
        ActuatorSettings {
            static_ratio: 0.05,
            min_force: 1.0,
        }
    }
}

/// One actuator: the columns of `actuator_layout.parquet`.
#[derive(Debug, Clone)]
pub struct Actuator {
    pub actuator: usize,
    /// PS position, node index, node id and DoF name.
    pub ps_position: usize,
    pub node: usize,
    pub node_id: i64,
    pub direction: String,
    pub control: ControlMode,
    /// Nominal (gravity) force, N (or N·m).
    pub nominal_force: f64,
    /// Component of each retained POM at this DoF.
    pub participation: Vec<f64>,
}

/// Forces the NS exerts on the PS in the static gravity state: f_int = K_P u_P − f_g,P (PS
/// order), with u_P the twin's gravity displacement restricted to the PS. Interior PS DoFs are
/// in equilibrium, so f_int vanishes there up to round-off.
pub fn interface_gravity_forces(
    partition: &Partition,
    u_ps: &[f64],
    ps_gravity_load: &[f64],
) -> Vec<f64> {
    let n = partition.n_ps();
    (0..n)
        .map(|i| {
            (0..n)
                .map(|j| partition.ps_stiffness[(i, j)] * u_ps.get(j).copied().unwrap_or(0.0))
                .sum::<f64>()
                - ps_gravity_load.get(i).copied().unwrap_or(0.0)
        })
        .collect()
}

/// Actuators at the masters of `basis`: nominal forces f_m = T_dᵀ f_int^r (the work-equivalent
/// master forces of the gravity interface actions), control mode from the deformation
/// snapshots (rows = retained DoFs) and the nominal force, participation from the first `k`
/// POMs.
pub fn place_actuators(
    model: &Model,
    partition: &Partition,
    set: &ConstrainedSet,
    basis: &ReductionBasis,
    pod: &Pod,
    k: usize,
    deformation: MatRef<'_, f64>,
    interface_force: &[f64],
    settings: &ActuatorSettings,
) -> Result<Vec<Actuator>> {
    let f_r: Vec<f64> = set
        .retained
        .iter()
        .map(|&p| interface_force.get(p).copied().unwrap_or(0.0))
        .collect();
    let nr = set.retained.len();
    if deformation.nrows() != nr || pod.modes.nrows() != nr || k > pod.modes.ncols() {
        return Err(Error::usage(
            "actuator placement: snapshots, POMs and retained DoFs disagree in size",
        ));
    }
    let mut out = Vec::with_capacity(basis.masters.len());
    for (a, (&p, &row)) in basis
        .masters
        .iter()
        .zip(&basis.masters_in_retained)
        .enumerate()
    {
        let nominal_force: f64 = (0..nr).map(|i| basis.guyan[(i, a)] * f_r[i]).sum();
        let x: Vec<f64> = (0..deformation.ncols())
            .map(|t| deformation[(row, t)])
            .collect();
        let mean = x.iter().sum::<f64>() / x.len().max(1) as f64;
        let std =
            (x.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / x.len().max(1) as f64).sqrt();
        let peak = x.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        let control =
            if std <= settings.static_ratio * peak && nominal_force.abs() > settings.min_force {
                ControlMode::Force
            } else {
                ControlMode::Displacement
            };
        let (node, dof) = partition.ps_dofs[p];
        out.push(Actuator {
            actuator: a + 1,
            ps_position: p,
            node,
            node_id: model.nodes.get(node).map(|n| n.id).unwrap_or(-1),
            direction: model
                .dimension
                .dof_names()
                .get(dof)
                .copied()
                .unwrap_or("?")
                .to_string(),
            control,
            nominal_force,
            participation: (0..k).map(|j| pod.modes[(row, j)]).collect(),
        });
    }
    Ok(out)
}

/// Reduced vs full PS response: the columns of `reduction_validation.parquet`.
#[derive(Debug, Clone)]
pub struct ReductionValidation {
    /// Retained PS positions, one row each.
    pub positions: Vec<usize>,
    pub nrmse: Vec<f64>,
    pub weight: Vec<f64>,
    pub is_master: Vec<bool>,
    pub wnrmse: f64,
    /// Max over steps of |u − T[u_m; α]| / max|u| on all PS DoFs (rigid motion included).
    pub relative_max_error_total: f64,
}

/// Validation of T: for each step, the full PS response u_k gives the deformation ū_k (Eq. 51)
/// and the reduced model's response T_d ū_k^m (the PS moved by its actuators only). NRMSE per
/// retained DoF and WNRMSE compare the deformations (the rigid part is reproduced exactly by
/// construction and would only dilute the error); the total-displacement error is reported too.
pub fn validate_reduction(
    rigid: &RigidBodyModes,
    set: &ConstrainedSet,
    basis: &ReductionBasis,
    history: &[Vec<f64>],
) -> ReductionValidation {
    let nr = set.retained.len();
    let nm = basis.masters.len();
    let nt = history.len();
    let mut full = Mat::<f64>::zeros(nr, nt);
    let mut reduced = Mat::<f64>::zeros(nr, nt);
    let (mut max_err, mut max_u) = (0.0_f64, 0.0_f64);
    for (t, u) in history.iter().enumerate() {
        let (bar, lambda) = set.remove(rigid, u);
        let um: Vec<f64> = basis.masters.iter().map(|&p| bar[p]).collect();
        for i in 0..nr {
            full[(i, t)] = bar[set.retained[i]];
            reduced[(i, t)] = (0..nm).map(|j| basis.guyan[(i, j)] * um[j]).sum();
        }
        // u = ū − R λ: reduced coordinates [u_m; α = −λ].
        let mut q = um.clone();
        q.extend(lambda.iter().map(|l| -l));
        for (p, &up) in u.iter().enumerate().take(basis.transformation.nrows()) {
            let ur: f64 = (0..q.len())
                .map(|j| basis.transformation[(p, j)] * q[j])
                .sum();
            max_err = max_err.max((up - ur).abs());
            max_u = max_u.max(up.abs());
        }
    }
    let (w, per, weights) = wnrmse(full.as_ref(), reduced.as_ref());
    let is_master = set
        .retained
        .iter()
        .map(|p| basis.masters.contains(p))
        .collect();
    ReductionValidation {
        positions: set.retained.clone(),
        nrmse: per,
        weight: weights,
        is_master,
        wnrmse: w,
        relative_max_error_total: if max_u > 0.0 { max_err / max_u } else { 0.0 },
    }
}

/// The fewest masters whose Guyan + rigid-body basis reproduces the PS deformation history
/// within `target_wnrmse`: for n_m = `min_masters`, `min_masters` + 1, … ≤ `max_masters`, the
/// masters are the QR pivots of the first n_m POMs (`select_masters`), T is built (Eq. 85–87)
/// and validated (`validate_reduction`). Errors when no count up to `max_masters` meets it.
pub fn fewest_masters(
    partition: &Partition,
    rigid: &RigidBodyModes,
    set: &ConstrainedSet,
    pod: &Pod,
    history: &[Vec<f64>],
    min_masters: usize,
    max_masters: usize,
    target_wnrmse: f64,
) -> Result<(ReductionBasis, ReductionValidation)> {
    let mut best = f64::INFINITY;
    for nm in min_masters.max(1)..=max_masters.min(pod.modes.ncols()) {
        let masters = select_masters(pod, nm, set)?;
        let Ok(basis) = reduction_basis(partition, rigid, set, &masters) else {
            continue;
        };
        let validation = validate_reduction(rigid, set, &basis, history);
        if validation.wnrmse <= target_wnrmse {
            return Ok((basis, validation));
        }
        best = best.min(validation.wnrmse);
    }
    Err(Error::numerical(format!(
        "actuator layout: up to {max_masters} masters the Guyan + rigid-body model reproduces the PS response with WNRMSE {best:.3e} at best (target {target_wnrmse:.1e})"
    )))
}
