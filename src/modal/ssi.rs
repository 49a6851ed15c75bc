//! The three subspace methods, each reduced to ONE factorisation per record
//! (an SVD giving the column space of the extended observability matrix
//! Γ_p = [C; CA; …; CA^{p−1}]), and the per-order realisation (A, C) obtained by
//! truncating that SVD (Van Overschee & De Moor 1996; METHODS §2).
//!
//! - SSI-COV: SVD of the block Toeplitz matrix of output-to-reference
//!   covariances T = Γ_p Δ_p (T_{ij} = R_{p+i−j}, R_k = E[y_{t+k} y_refᵀ_t]).
//! - SSI-DATA (UPC): LQ of the block Hankel matrix [Y_past,ref; Y_future];
//!   the projection of future outputs on past references is L₂₁ Q₁ᵀ, whose
//!   column space (SVD of L₂₁) is that of Γ_p.
//! - Input–output, PO-MOESP (Verhaegen 1994), the combined
//!   deterministic–stochastic family: LQ of [U_f; U_p; Y_p; Y_f]; the part of
//!   Y_f orthogonal to the future inputs and correlated with the past
//!   instruments (U_p, Y_p) is L₃₂, whose left singular vectors span Γ_p.
//!   Instrumenting with past data makes the estimate insensitive to white
//!   measurement noise on inputs and outputs.
//!
//! The LQ factors come from the Cholesky factor of the Hankel Gram matrix
//! (see `hankel.rs`); a tiny ridge is added only when the Gram matrix is
//! numerically singular (e.g. noise-free synthetic data).

use super::hankel::{cross_covariances, hankel_gram, HankelRow};
use crate::error::{Error, Result};
use faer::linalg::solvers::SolveLstsq;
use faer::{c64, Mat, MatRef, Side};

/// Column space of Γ_p from the one factorisation of a record.
#[derive(Debug, Clone)]
pub struct Subspace {
    /// Left singular vectors, (block_rows · outputs) × rank.
    pub u: Mat<f64>,
    /// Singular values, descending.
    pub singular_values: Vec<f64>,
    /// Right singular vectors, (columns of the factorised matrix) × rank:
    /// the data-driven uncertainty (`uncertainty.rs`) needs them for the
    /// first-order perturbation of the left ones.
    pub v: Mat<f64>,
    pub outputs: usize,
    pub block_rows: usize,
    /// PO-MOESP only: the Cholesky factor L of the Gram matrix whose block
    /// L₃₂ this is the SVD of; the input–output σ (`uncertainty.rs`, fast
    /// form of Eq. S1') reuses it instead of factorising again.
    pub gram_cholesky: Option<Mat<f64>>,
}

/// Largest model order the subspace supports (shift invariance needs
/// (p−1)·l ≥ n rows).
impl Subspace {
    pub fn max_order(&self) -> usize {
        self.singular_values
            .len()
            .min((self.block_rows - 1) * self.outputs)
    }

    /// Realisation (A, C) of order `n`: Γ_n = U_n S_n^{1/2}, C = first block
    /// row of Γ_n, A = Γ_n↑⁺ Γ_n↓ (shift invariance, least squares).
    pub fn realise(&self, n: usize) -> Result<(Mat<f64>, Mat<f64>)> {
        if n == 0 || n > self.max_order() {
            return Err(Error::numerical(format!(
                "model order {n} exceeds the subspace dimension {}",
                self.max_order()
            )));
        }
        let l = self.outputs;
        let p = self.block_rows;
        let sqrt_s: Vec<f64> = self.singular_values[..n].iter().map(|s| s.sqrt()).collect();
        let gamma = Mat::<f64>::from_fn(p * l, n, |i, j| self.u[(i, j)] * sqrt_s[j]);
        let upper = gamma.as_ref().subrows(0, (p - 1) * l);
        let lower = gamma.as_ref().subrows(l, (p - 1) * l);
        let a = upper.qr().solve_lstsq(lower);
        let c = gamma.as_ref().subrows(0, l).to_owned();
        if a.as_ref().has_nan() || c.as_ref().has_nan() {
            return Err(Error::numerical(format!(
                "order {n}: realisation produced non-finite values"
            )));
        }
        Ok((a, c))
    }
}

/// Discrete eigenvalues μ and output-space eigenvectors C ψ of a realisation.
pub fn eigen_structure(a: MatRef<'_, f64>, c: MatRef<'_, f64>) -> Result<Vec<(c64, Vec<c64>)>> {
    let eig = a
        .eigen()
        .map_err(|e| Error::numerical(format!("eigenvalues of the state matrix: {e:?}")))?;
    let values = eig.S().column_vector();
    let vectors = eig.U();
    let n = a.nrows();
    let l = c.nrows();
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        let mu = values[k];
        let shape: Vec<c64> = (0..l)
            .map(|i| {
                let mut acc = c64::new(0.0, 0.0);
                for j in 0..n {
                    acc += vectors[(j, k)] * c[(i, j)];
                }
                acc
            })
            .collect();
        out.push((mu, shape));
    }
    Ok(out)
}

/// The column space of Γ_p from a thin SVD of the factorised matrix `m`.
pub fn thin_svd_subspace(
    m: MatRef<'_, f64>,
    outputs: usize,
    block_rows: usize,
) -> Result<Subspace> {
    let svd = m
        .thin_svd()
        .map_err(|e| Error::numerical(format!("SVD of the subspace matrix: {e:?}")))?;
    let s: Vec<f64> = svd.S().column_vector().iter().copied().collect();
    Ok(Subspace {
        u: svd.U().to_owned(),
        singular_values: s,
        v: svd.V().to_owned(),
        outputs,
        block_rows,
        gram_cholesky: None,
    })
}

/// Lower Cholesky factor of a symmetric positive (semi-)definite row-major
/// matrix; adds a ridge of 1e-12·mean diagonal (then 1e-9) only if needed.
pub fn cholesky_lower(gram: &[f64], n: usize) -> Result<Mat<f64>> {
    let mean_diag = (0..n).map(|i| gram[i * n + i]).sum::<f64>() / n.max(1) as f64;
    for ridge in [0.0, 1e-12, 1e-9] {
        let g = Mat::<f64>::from_fn(n, n, |i, j| {
            gram[i * n + j] + if i == j { ridge * mean_diag } else { 0.0 }
        });
        if let Ok(llt) = g.llt(Side::Lower) {
            return Ok(llt.L().to_owned());
        }
    }
    Err(Error::numerical(
        "Hankel Gram matrix is not positive definite: channels are linearly dependent or constant",
    ))
}

/// SSI-COV: one SVD of the p·l × p·r block Toeplitz covariance matrix.
pub fn ssi_cov(outputs: &[&[f64]], refs: &[usize], block_rows: usize) -> Result<Subspace> {
    let t = covariance_toeplitz(outputs, refs, block_rows);
    thin_svd_subspace(t.as_ref(), outputs.len(), block_rows)
}

/// The p·l × p·r block Toeplitz matrix of output-to-reference covariances
/// SSI-COV factorises (T_{ij} = R_{p+i−j}); also formed per block of the
/// record by the data-driven uncertainty (`uncertainty.rs`).
pub fn covariance_toeplitz(outputs: &[&[f64]], refs: &[usize], block_rows: usize) -> Mat<f64> {
    let l = outputs.len();
    let r = refs.len();
    let p = block_rows;
    let ref_signals: Vec<&[f64]> = refs.iter().map(|&i| outputs[i]).collect();
    let cov = cross_covariances(outputs, &ref_signals, 2 * p - 1);
    Mat::<f64>::from_fn(p * l, p * r, |row, col| {
        let (i, o) = (row / l, row % l);
        let (j, c) = (col / r, col % r);
        cov[p + i - j][o * r + c]
    })
}

/// SSI-DATA (unweighted principal components): Cholesky of the Gram matrix
/// of [Y_past,ref (p·r rows); Y_future (p·l rows)], then SVD of L₂₁.
pub fn ssi_data(outputs: &[&[f64]], refs: &[usize], block_rows: usize) -> Result<Subspace> {
    let l = outputs.len();
    let r = refs.len();
    let p = block_rows;
    let n = outputs.iter().map(|s| s.len()).min().unwrap_or(0);
    let columns = n + 1 - 2 * p;
    let mut rows = Vec::with_capacity(p * (r + l));
    for shift in 0..p {
        for &c in refs {
            rows.push(HankelRow { signal: c, shift });
        }
    }
    for shift in p..2 * p {
        for c in 0..l {
            rows.push(HankelRow { signal: c, shift });
        }
    }
    let g = hankel_gram(outputs, &rows, columns);
    let big_l = cholesky_lower(&g, rows.len())?;
    let l21 = big_l.as_ref().submatrix(p * r, 0, p * l, p * r);
    thin_svd_subspace(l21, l, p)
}

/// PO-MOESP input–output subspace identification: Cholesky of the Gram
/// matrix of [U_f; U_p; Y_p; Y_f], SVD of L₃₂ (future outputs against the
/// past-data instruments, future inputs projected out).
pub fn po_moesp(outputs: &[&[f64]], inputs: &[&[f64]], block_rows: usize) -> Result<Subspace> {
    let l = outputs.len();
    let m = inputs.len();
    let p = block_rows;
    let n = outputs
        .iter()
        .chain(inputs)
        .map(|s| s.len())
        .min()
        .unwrap_or(0);
    let columns = n + 1 - 2 * p;
    // Signals: inputs first (0..m), then outputs (m..m+l).
    let signals: Vec<&[f64]> = inputs.iter().chain(outputs).copied().collect();
    let rows = po_moesp_rows(m, l, p);
    let g = hankel_gram(&signals, &rows, columns);
    let big_l = cholesky_lower(&g, rows.len())?;
    let l32 = big_l
        .as_ref()
        .submatrix(p * m + p * (m + l), p * m, p * l, p * (m + l));
    let mut subspace = thin_svd_subspace(l32, l, p)?;
    subspace.gram_cholesky = Some(big_l);
    Ok(subspace)
}

/// Rows of PO-MOESP's block Hankel matrix [U_f; U_p; Y_p; Y_f] over the
/// signals (inputs 0..m, then outputs m..m+l).
pub fn po_moesp_rows(m: usize, l: usize, p: usize) -> Vec<HankelRow> {
    let mut rows = Vec::with_capacity(2 * p * (m + l));
    for shift in p..2 * p {
        for c in 0..m {
            rows.push(HankelRow { signal: c, shift });
        }
    }
    for shift in 0..p {
        for c in 0..m {
            rows.push(HankelRow { signal: c, shift });
        }
    }
    for shift in 0..p {
        for c in 0..l {
            rows.push(HankelRow {
                signal: m + c,
                shift,
            });
        }
    }
    for shift in p..2 * p {
        for c in 0..l {
            rows.push(HankelRow {
                signal: m + c,
                shift,
            });
        }
    }
    rows
}
