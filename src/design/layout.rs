//! The Guyan + rigid-body reduction basis of the PS (METHODS §5, Eq. 85–87; thesis ch. 7),
//! actuators and their control modes, and the validation of the reduced twin against the full
//! twin under the same base motion.
//!
//! The masters are the coupled DoFs of the interface super-element (see `interface`): the
//! actuators drive them, and the NS is coupled to the PS through them only. The reduced twin
//! keeps every NS DoF and represents the PS by u_PS = B q, B = G T; its response at the PS is
//! compared with the full twin's, DoF by DoF (NRMSE, Eq. 84) and overall (WNRMSE, Eq. 83).

use faer::{Mat, MatRef};

use super::partition::Partition;
use super::pod::wnrmse;
use super::rigid::{ConstrainedSet, RigidBodyModes};
use crate::error::Error;
use crate::twin::eigen::{dense_modes, lanczos_modes, LanczosOptions};
use crate::twin::guyan::guyan_reduce;
use crate::twin::newmark::{newmark_base_excitation, BaseExcitation, NewmarkSettings};
use crate::twin::sparse::CscMatrix;
use crate::twin::statics::solve_spd;
use crate::Result;

/// T_d on the retained DoFs and T over the PS coordinates (Eq. 85–87).
#[derive(Debug, Clone)]
pub struct ReductionBasis {
    /// Master DoFs (positions in the PS coordinates) in actuator order.
    pub masters: Vec<usize>,
    /// Masters as rows of the retained set r.
    pub masters_in_retained: Vec<usize>,
    /// T_d (n_r × n_m) = [I; −K_ss⁻¹K_sm] on the retained DoFs with c fixed (Eq. 85–86).
    pub guyan: Mat<f64>,
    /// T (n × (n_m + n_rb)) = [[T_d, R^r], [0, R^c]] in PS coordinate order (Eq. 87):
    /// u = T [u_m; α].
    pub transformation: Mat<f64>,
    /// K̂ = Tᵀ K_P T, M̂ = Tᵀ M_P T.
    pub stiffness: Mat<f64>,
    pub mass: Mat<f64>,
}

/// Build T (Eq. 85–87) for the floating PS with stiffness `k_ps` and mass `m_ps` (in the
/// coordinates `rigid` and `set` refer to): Guyan condensation with the constrained set c
/// fixed onto the masters, plus the rigid-body modes. Errors: a master in c or repeated, a
/// mechanism among the slaves.
pub fn reduction_basis(
    k_ps: MatRef<'_, f64>,
    m_ps: MatRef<'_, f64>,
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
    if k_ps.nrows() != rigid.modes.nrows() || m_ps.nrows() != k_ps.nrows() {
        return Err(Error::usage(
            "reduction basis: PS matrices and rigid-body modes disagree in size",
        ));
    }
    let k_rr = Mat::from_fn(nr, nr, |i, j| k_ps[(set.retained[i], set.retained[j])]);
    let m_rr = Mat::from_fn(nr, nr, |i, j| m_ps[(set.retained[i], set.retained[j])]);
    let g = guyan_reduce(
        &CscMatrix::from_dense(k_rr.as_ref()),
        &CscMatrix::from_dense(m_rr.as_ref()),
        &masters_in_retained,
    )?;
    let (nm, nrb, np) = (masters.len(), rigid.count(), k_ps.nrows());
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
    let stiffness = congruence(k_ps, t.as_ref());
    let mass = congruence(m_ps, t.as_ref());
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

/// One actuator: the columns of `actuator_layout/actuator_layout.parquet`.
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

/// Reduced vs full PS response: the columns of `reduction_validation/reduction_validation.parquet`.
#[derive(Debug, Clone)]
pub struct ReductionValidation {
    /// Retained PS positions (rigid-body removal's r set), one row each.
    pub positions: Vec<usize>,
    /// NRMSE of the deformation history per retained DoF (Eq. 84) and its WNRMSE weight.
    pub nrmse: Vec<f64>,
    pub weight: Vec<f64>,
    /// The DoF is an actuated (master) DoF.
    pub is_master: Vec<bool>,
    /// WNRMSE of the deformation ū (Eq. 83, after Eq. 51 on both responses): what the
    /// specimen is made to undergo.
    pub wnrmse: f64,
    /// WNRMSE of the total PS displacement (rigid motion included), as thesis ch. 7 compares.
    pub wnrmse_total: f64,
    /// Max over steps and PS DoFs of |u − u_red| / max|u|.
    pub relative_max_error_total: f64,
}

/// The reduced twin: every NS DoF kept, the PS represented by u_PS = B q (`ps_basis`,
/// n_PS × n_q), i.e. the transformation Φ = [[I, 0], [0, B]] (rows: NS-only free DoFs, PS
/// DoFs) applied to K and M (K_r = Φᵀ K Φ, M_r = Φᵀ M Φ).
#[derive(Debug, Clone)]
pub struct ReducedTwin {
    pub stiffness: CscMatrix,
    pub mass: CscMatrix,
    /// Free DoFs of the twin kept as they are (not in the PS), ascending.
    pub ns_only: Vec<usize>,
    /// B (n_PS × n_q).
    pub ps_basis: Mat<f64>,
    ps_free: Vec<usize>,
}

impl ReducedTwin {
    pub fn new(
        k: &CscMatrix,
        m: &CscMatrix,
        partition: &Partition,
        ps_basis: MatRef<'_, f64>,
    ) -> Result<Self> {
        let n = k.n;
        let (np, nq) = (partition.n_ps(), ps_basis.ncols());
        if ps_basis.nrows() != np || partition.ps_free.iter().any(|&f| f >= n) {
            return Err(Error::usage(
                "reduced twin: the PS basis does not match the PS DoFs",
            ));
        }
        let mut ps_index = vec![usize::MAX; n];
        for (p, &f) in partition.ps_free.iter().enumerate() {
            ps_index[f] = p;
        }
        let ns_only: Vec<usize> = (0..n).filter(|&i| ps_index[i] == usize::MAX).collect();
        let mut reduced_index = vec![usize::MAX; n];
        for (r, &i) in ns_only.iter().enumerate() {
            reduced_index[i] = r;
        }
        let ni = ns_only.len();
        let nr = ni + nq;
        // Φᵀ A Φ: the NS–NS block copied, then A Φ_q column by column for the PS coordinates.
        let project = |a: &CscMatrix| -> CscMatrix {
            let mut triplets = Vec::with_capacity(a.nnz());
            for c in 0..n {
                let rc = reduced_index[c];
                if rc == usize::MAX {
                    continue;
                }
                for idx in a.col_ptr[c]..a.col_ptr[c + 1] {
                    let rr = reduced_index[a.row_idx[idx]];
                    if rr != usize::MAX {
                        triplets.push((rr, rc, a.values[idx]));
                    }
                }
            }
            let mut x = vec![0.0; n];
            let mut y = vec![0.0; n];
            let mut qq = Mat::<f64>::zeros(nq, nq);
            for j in 0..nq {
                x.iter_mut().for_each(|v| *v = 0.0);
                for (p, &f) in partition.ps_free.iter().enumerate() {
                    x[f] = ps_basis[(p, j)];
                }
                a.mul_vec(&x, &mut y);
                for (i, &yi) in y.iter().enumerate() {
                    if yi == 0.0 {
                        continue;
                    }
                    let rr = reduced_index[i];
                    if rr != usize::MAX {
                        triplets.push((rr, ni + j, yi));
                        triplets.push((ni + j, rr, yi));
                    } else {
                        let p = ps_index[i];
                        for l in 0..nq {
                            qq[(l, j)] += ps_basis[(p, l)] * yi;
                        }
                    }
                }
            }
            for j in 0..nq {
                for l in 0..nq {
                    triplets.push((ni + l, ni + j, 0.5 * (qq[(l, j)] + qq[(j, l)])));
                }
            }
            CscMatrix::from_triplets(nr, &triplets)
        };
        Ok(ReducedTwin {
            stiffness: project(k),
            mass: project(m),
            ns_only,
            ps_basis: ps_basis.to_owned(),
            ps_free: partition.ps_free.clone(),
        })
    }

    pub fn n(&self) -> usize {
        self.stiffness.n
    }

    /// The `count` lowest eigenfrequencies (Hz): dense up to 3000 DoFs, else shift-invert
    /// Lanczos.
    pub fn frequencies_hz(&self, count: usize) -> Result<Vec<f64>> {
        let count = count.min(self.n());
        let modes = if self.n() <= 3000 {
            dense_modes(
                self.stiffness.to_dense().as_ref(),
                self.mass.to_dense().as_ref(),
                count,
            )
        } else {
            lanczos_modes(
                &self.stiffness,
                &self.mass,
                count,
                &LanczosOptions::default(),
            )
        }
        .map_err(|f| Error::numerical(format!("reduced twin: eigen solve failed ({f:?})")))?;
        Ok(modes.frequencies_hz())
    }

    /// Response from rest to the base excitations (Rayleigh damping with the same
    /// coefficients, loads Φᵀ b, kinematic influence by least squares Φ r̂ = r). Returns the PS
    /// histories `out[step][PS position]` of the relative displacement.
    pub fn response(
        &self,
        excitations: &[BaseExcitation],
        settings: &NewmarkSettings,
    ) -> Result<Vec<Vec<f64>>> {
        let b = &self.ps_basis;
        let (np, nq, ni) = (b.nrows(), b.ncols(), self.ns_only.len());
        let n_full = self.ns_only.len() + np;
        let btb = b.transpose() * b;
        let btb = CscMatrix::from_dense(btb.as_ref());
        let mut reduced_exc = Vec::with_capacity(excitations.len());
        for e in excitations {
            if e.influence.len() != n_full || e.load.len() != n_full {
                return Err(Error::usage("reduced twin: excitation size mismatch"));
            }
            let restrict = |v: &[f64]| -> Vec<f64> {
                let mut out: Vec<f64> = self.ns_only.iter().map(|&i| v[i]).collect();
                out.extend((0..nq).map(|j| {
                    self.ps_free
                        .iter()
                        .enumerate()
                        .map(|(p, &f)| b[(p, j)] * v[f])
                        .sum::<f64>()
                }));
                out
            };
            let load = restrict(&e.load);
            let projected = restrict(&e.influence);
            let q_r = solve_spd(&btb, &[projected[ni..].to_vec()]).map_err(|f| {
                Error::numerical(format!(
                    "reduced twin: the PS basis is rank deficient ({f:?})"
                ))
            })?;
            let mut influence: Vec<f64> = self.ns_only.iter().map(|&i| e.influence[i]).collect();
            influence.extend(q_r.into_iter().flatten());
            reduced_exc.push(BaseExcitation {
                influence,
                load,
                acceleration: e.acceleration.clone(),
            });
        }
        let resp = newmark_base_excitation(
            &self.stiffness,
            &self.mass,
            &reduced_exc,
            &NewmarkSettings {
                dt: settings.dt,
                rayleigh: settings.rayleigh,
                record: Some((ni..ni + nq).collect()),
            },
        )?;
        let steps = resp.displacement.first().map(|d| d.len()).unwrap_or(0);
        Ok((0..steps)
            .map(|t| {
                (0..np)
                    .map(|p| (0..nq).map(|j| b[(p, j)] * resp.displacement[j][t]).sum())
                    .collect()
            })
            .collect())
    }
}

/// Compare reduced and full PS histories (`[step][PS position]`): deformations after
/// rigid-body removal (Eq. 50–51) per retained DoF and overall, and the total displacements.
pub fn compare_responses(
    rigid: &RigidBodyModes,
    set: &ConstrainedSet,
    reference: &[Vec<f64>],
    reduced: &[Vec<f64>],
    master_positions: &[usize],
) -> ReductionValidation {
    let (full_bar, _) = set.deformation_snapshots(rigid, reference);
    let (red_bar, _) = set.deformation_snapshots(rigid, reduced);
    let (w, per, weights) = wnrmse(full_bar.as_ref(), red_bar.as_ref());
    let np = reference.first().map(|u| u.len()).unwrap_or(0);
    let nt = reference.len().min(reduced.len());
    let total_full = Mat::from_fn(np, nt, |p, t| reference[t][p]);
    let total_red = Mat::from_fn(np, nt, |p, t| reduced[t].get(p).copied().unwrap_or(0.0));
    let (w_total, _, _) = wnrmse(total_full.as_ref(), total_red.as_ref());
    let (mut max_err, mut max_u) = (0.0_f64, 0.0_f64);
    for t in 0..nt {
        for p in 0..np {
            max_err = max_err.max((total_full[(p, t)] - total_red[(p, t)]).abs());
            max_u = max_u.max(total_full[(p, t)].abs());
        }
    }
    ReductionValidation {
        positions: set.retained.clone(),
        nrmse: per,
        weight: weights,
        is_master: set
            .retained
            .iter()
            .map(|p| master_positions.contains(p))
            .collect(),
        wnrmse: w,
        wnrmse_total: w_total,
        relative_max_error_total: if max_u > 0.0 { max_err / max_u } else { 0.0 },
    }
}
