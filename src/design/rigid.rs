//! Rigid-body modes of a floating PS and their removal (METHODS §5, Eq. 49–51 and 73–75).

use faer::{Mat, MatRef, Side};

use crate::error::Error;
use crate::Result;

/// Default relative tolerance of the kernel: eigenvalues of K_P up to `1e-9 · λ_max` are zero.
/// Round-off leaves rigid-body eigenvalues near 1e-16 · λ_max and the softest deformation of a
/// practical specimen stays far above 1e-9 · λ_max, so the gap is wide on both sides.
pub const KERNEL_RELATIVE_TOLERANCE: f64 = 1e-9;
/// Default bound on the condition number of R^c (2-norm) for a constrained set to be accepted.
pub const MAX_CONSTRAINT_CONDITION: f64 = 1e8;

/// Kernel of the PS stiffness: orthonormal columns R (n × number of rigid-body modes).
#[derive(Debug, Clone)]
pub struct RigidBodyModes {
    pub modes: Mat<f64>,
    /// Eigenvalues of K_P ascending (all of them), for reporting the gap.
    pub eigenvalues: Vec<f64>,
    /// The tolerance used, relative to the largest eigenvalue.
    pub relative_tolerance: f64,
}

impl RigidBodyModes {
    pub fn count(&self) -> usize {
        self.modes.ncols()
    }
    /// Ratio (largest kernel eigenvalue, smallest non-kernel eigenvalue) / λ_max: the gap.
    pub fn gap(&self) -> (f64, f64) {
        let max = self
            .eigenvalues
            .last()
            .copied()
            .unwrap_or(0.0)
            .abs()
            .max(f64::MIN_POSITIVE);
        let r = self.count();
        let last_zero = if r > 0 {
            self.eigenvalues[r - 1].abs() / max
        } else {
            0.0
        };
        let first_non_zero = self
            .eigenvalues
            .get(r)
            .map(|v| v / max)
            .unwrap_or(f64::INFINITY);
        (last_zero, first_non_zero)
    }
}

/// R = ker(K_P) (Eq. 49, 73) from the symmetric eigendecomposition of K_P: eigenvectors whose
/// eigenvalue is ≤ `relative_tolerance · λ_max`. Orthonormal columns.
pub fn rigid_body_modes(k: MatRef<'_, f64>, relative_tolerance: f64) -> Result<RigidBodyModes> {
    let n = k.nrows();
    if n == 0 || k.ncols() != n {
        return Err(Error::usage(
            "rigid-body modes: the PS stiffness must be square and non-empty",
        ));
    }
    if !(relative_tolerance > 0.0 && relative_tolerance < 1.0) {
        return Err(Error::usage(format!(
            "rigid-body modes: relative tolerance {relative_tolerance} must lie in (0, 1)"
        )));
    }
    let mut sym = Mat::<f64>::zeros(n, n);
    for j in 0..n {
        for i in 0..n {
            let v = 0.5 * (k[(i, j)] + k[(j, i)]);
            if !v.is_finite() {
                return Err(Error::numerical(
                    "rigid-body modes: the PS stiffness has a non-finite entry",
                ));
            }
            sym[(i, j)] = v;
        }
    }
    let evd = sym.self_adjoint_eigen(Side::Lower).map_err(|e| {
        Error::numerical(format!(
            "rigid-body modes: eigendecomposition of K_P failed ({e:?})"
        ))
    })?;
    let lambda: Vec<f64> = (0..n).map(|i| evd.S().column_vector()[i]).collect();
    let max = lambda.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    if max == 0.0 {
        return Err(Error::numerical(
            "rigid-body modes: the PS stiffness is zero",
        ));
    }
    let r = lambda
        .iter()
        .take_while(|v| v.abs() <= relative_tolerance * max)
        .count();
    let u = evd.U();
    let modes = Mat::from_fn(n, r, |i, j| u[(i, j)]);
    Ok(RigidBodyModes {
        modes,
        eigenvalues: lambda,
        relative_tolerance,
    })
}

/// A statically determined constrained set c (as many DoFs as rigid-body modes) and the
/// retained set r, with (R^c)⁻¹ for the per-step removal (Eq. 50–51, 74–75).
#[derive(Debug, Clone)]
pub struct ConstrainedSet {
    /// Positions (in the PS DoF order) of the constrained DoFs c, in the order chosen.
    pub constrained: Vec<usize>,
    /// The other positions r, ascending.
    pub retained: Vec<usize>,
    /// R^c = R[c, :] and its inverse.
    pub r_c: Mat<f64>,
    pub r_c_inverse: Mat<f64>,
    /// 2-norm condition number of R^c.
    pub condition: f64,
}

impl ConstrainedSet {
    /// Automatic proposal: QR with column pivoting on Rᵀ (n_rb × n). The first n_rb pivots are
    /// the DoFs whose rows of R are most linearly independent (greedy maximum volume of R^c),
    /// hence a statically determined and well-conditioned support set.
    pub fn propose(rigid: &RigidBodyModes, max_condition: f64) -> Result<Self> {
        let r = rigid.count();
        if r == 0 {
            return Self::validated(rigid, Vec::new(), max_condition);
        }
        let rt = rigid.modes.transpose().to_owned();
        let qr = rt.col_piv_qr();
        let (forward, _) = qr.P().arrays();
        let c: Vec<usize> = forward.iter().take(r).copied().collect();
        Self::validated(rigid, c, max_condition)
    }

    /// Proposal restricted to `candidates` (PS positions, e.g. the interface control DoFs that
    /// can be bolted to the reaction frame): QR with column pivoting on the candidate columns
    /// of Rᵀ.
    pub fn propose_among(
        rigid: &RigidBodyModes,
        candidates: &[usize],
        max_condition: f64,
    ) -> Result<Self> {
        let r = rigid.count();
        if r == 0 {
            return Self::validated(rigid, Vec::new(), max_condition);
        }
        let n = rigid.modes.nrows();
        if candidates.len() < r || candidates.iter().any(|&c| c >= n) {
            return Err(Error::usage(format!(
                "constrained set: {} candidate DoFs for {r} rigid-body modes",
                candidates.len()
            )));
        }
        let rt = Mat::from_fn(r, candidates.len(), |i, j| rigid.modes[(candidates[j], i)]);
        let qr = rt.col_piv_qr();
        let (forward, _) = qr.P().arrays();
        let c: Vec<usize> = forward.iter().take(r).map(|&j| candidates[j]).collect();
        Self::validated(rigid, c, max_condition)
    }

    /// User override: validate the given positions. Errors (`Usage`): wrong count, repeated or
    /// out-of-range positions, or R^c singular / worse conditioned than `max_condition` —
    /// then the set does not remove the rigid-body modes.
    pub fn validated(
        rigid: &RigidBodyModes,
        constrained: Vec<usize>,
        max_condition: f64,
    ) -> Result<Self> {
        let n = rigid.modes.nrows();
        let r = rigid.count();
        if constrained.len() != r {
            return Err(Error::usage(format!(
                "constrained set has {} DoFs but the PS has {r} rigid-body modes: a statically determined set constrains exactly one DoF per rigid-body mode",
                constrained.len()
            )));
        }
        let mut used = vec![false; n];
        for &c in &constrained {
            match used.get_mut(c) {
                Some(u) if !*u => *u = true,
                Some(_) => {
                    return Err(Error::usage(format!(
                        "constrained set lists PS DoF {c} twice"
                    )))
                }
                None => {
                    return Err(Error::usage(format!(
                        "constrained DoF {c} outside the PS (0..{n})"
                    )))
                }
            }
        }
        let retained: Vec<usize> = (0..n).filter(|&i| !used[i]).collect();
        let r_c = Mat::from_fn(r, r, |i, j| rigid.modes[(constrained[i], j)]);
        let (condition, r_c_inverse) = if r == 0 {
            (1.0, Mat::zeros(0, 0))
        } else {
            let svd = r_c.thin_svd().map_err(|e| {
                Error::numerical(format!("constrained set: SVD of R^c failed ({e:?})"))
            })?;
            let s = svd.S().column_vector();
            let (smax, smin) = (s[0], s[r - 1]);
            let condition = if smin > 0.0 {
                smax / smin
            } else {
                f64::INFINITY
            };
            if !(condition <= max_condition) {
                return Err(Error::usage(format!(
                    "constrained set {constrained:?} does not remove the rigid-body modes: R^c has condition number {condition:.3e} (limit {max_condition:.1e}); choose DoFs that restrain every rigid-body motion"
                )));
            }
            // (R^c)⁻¹ = V Σ⁻¹ Uᵀ.
            let (u, v) = (svd.U(), svd.V());
            let inv = Mat::from_fn(r, r, |i, j| {
                (0..r).map(|l| v[(i, l)] * u[(j, l)] / s[l]).sum()
            });
            (condition, inv)
        };
        Ok(ConstrainedSet {
            constrained,
            retained,
            r_c,
            r_c_inverse,
            condition,
        })
    }

    /// Rigid-body removal of one PS displacement vector (Eq. 50–51, 74–75):
    /// λ = −(R^c)⁻¹ u^c and ū = u + R λ, so that ū^c = 0. Returns (ū over all PS DoFs, λ).
    pub fn remove(&self, rigid: &RigidBodyModes, u: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let r = self.constrained.len();
        let uc: Vec<f64> = self
            .constrained
            .iter()
            .map(|&c| u.get(c).copied().unwrap_or(0.0))
            .collect();
        let lambda: Vec<f64> = (0..r)
            .map(|i| {
                -(0..r)
                    .map(|j| self.r_c_inverse[(i, j)] * uc[j])
                    .sum::<f64>()
            })
            .collect();
        let mut bar: Vec<f64> = u.to_vec();
        for (i, b) in bar.iter_mut().enumerate().take(rigid.modes.nrows()) {
            *b += (0..r).map(|j| rigid.modes[(i, j)] * lambda[j]).sum::<f64>();
        }
        for &c in &self.constrained {
            // Exactly zero by construction; clear the round-off.
            if let Some(b) = bar.get_mut(c) {
                *b = 0.0;
            }
        }
        (bar, lambda)
    }

    /// Snapshot matrix of deformations at the retained DoFs r: column k is ū_k^r (Eq. 51, 75),
    /// from PS displacement histories `history[k]` (one PS vector per time step).
    /// Also returns λ_k per step.
    pub fn deformation_snapshots(
        &self,
        rigid: &RigidBodyModes,
        history: &[Vec<f64>],
    ) -> (Mat<f64>, Vec<Vec<f64>>) {
        let mut x = Mat::<f64>::zeros(self.retained.len(), history.len());
        let mut lambdas = Vec::with_capacity(history.len());
        for (k, u) in history.iter().enumerate() {
            let (bar, lambda) = self.remove(rigid, u);
            for (row, &p) in self.retained.iter().enumerate() {
                x[(row, k)] = bar.get(p).copied().unwrap_or(0.0);
            }
            lambdas.push(lambda);
        }
        (x, lambdas)
    }
}
