//! Bounded linear least squares for the Bouc-Wen identification (Eq. 19 of
//! METHODS.md §4 under the inequality constraints of Eq. 47).
//!
//! Eq. 47 (K0_dd ≥ 0, β ≥ 0, −β ≤ γ ≤ β) becomes plain non-negativity after the
//! change of variables β = s + t, γ = s − t (s, t ≥ 0): the identification
//! passes the columns n_β + n_γ and n_β − n_γ. The problem here is therefore
//! min ‖A p − y‖²_W subject to p_i ≥ 0 for a few indices (three per DoF).
//!
//! Solver: exhaustive active-set enumeration. For each subset Z of the
//! constrained indices held at zero, the unconstrained least-squares problem
//! on the remaining columns is solved; among the solutions that satisfy the
//! bounds the one of least cost is returned. For a convex quadratic this is the
//! exact constrained minimum (the optimum's own active set is one of the
//! subsets and its restricted solution is unique when the restricted matrix has
//! full rank). With three constrained variables that is 8 small solves, exact
//! and deterministic, with no tolerances to tune.
//!
//! Why no crate: general QP crates (e.g. interior-point or ADMM solvers) stop
//! at a tolerance (the solver check asks for 1e-8 relative) and bring large
//! dependency trees for a problem of ≤ 2D+2 unknowns; Lawson–Hanson NNLS crates
//! do not handle free variables nor the weighted Gram form needed for the
//! cumulative (instantaneous) estimates. The dense kernels (Householder QR,
//! Cholesky with dependent-column dropping) are a few lines each on matrices of
//! at most ~20 columns.
//!
//! Columns are equilibrated (scaled to unit weighted norm) before solving:
//! the |V|^N basis functions span dozens of orders of magnitude.

use crate::error::{Error, Result};

/// Relative pivot below which a column is treated as dependent on the previous
/// ones (its coefficient is set to zero) — after equilibration.
const DEPENDENT_PIVOT: f64 = 1e-13;
/// Same for the QR form, on |R_aa| of unit-norm columns (QR tolerates a
/// condition number up to ~1e10 with ~1e-6 relative error).
const DEPENDENT_DIAGONAL_QR: f64 = 1e-10;

/// Result of a bounded least-squares solve.
#[derive(Debug, Clone, PartialEq)]
pub struct BoundedSolution {
    /// Parameters in the caller's (unequilibrated) units.
    pub p: Vec<f64>,
    /// Weighted residual cost ‖A p − y‖²_W at `p`.
    pub cost: f64,
    /// Indices held at their bound (zero) in the solution.
    pub active: Vec<usize>,
}

fn check_constrained(constrained: &[usize], dim: usize) -> Result<()> {
    if constrained.len() > 12 {
        return Err(Error::usage(
            "bounded least squares: at most 12 constrained parameters (exhaustive active sets)",
        ));
    }
    if constrained.iter().any(|&i| i >= dim) {
        return Err(Error::usage(
            "bounded least squares: constrained index out of range",
        ));
    }
    Ok(())
}

/// Enumerates the active sets; `solve_free(mask_free)` returns the
/// unconstrained solution on the free columns (equilibrated units) and its cost.
fn enumerate_active_sets(
    dim: usize,
    constrained: &[usize],
    mut solve_free: impl FnMut(&[bool]) -> Option<(Vec<f64>, f64)>,
) -> Option<(Vec<f64>, f64, Vec<usize>)> {
    let mut best: Option<(Vec<f64>, f64, Vec<usize>)> = None;
    for mask in 0u32..(1u32 << constrained.len()) {
        let mut free = vec![true; dim];
        let mut active = Vec::new();
        for (bit, &index) in constrained.iter().enumerate() {
            if mask & (1 << bit) != 0 {
                free[index] = false;
                active.push(index);
            }
        }
        let Some((p, cost)) = solve_free(&free) else {
            continue;
        };
        if constrained.iter().any(|&i| p[i] < 0.0) || !cost.is_finite() {
            continue;
        }
        // Strict improvement keeps the first (fewest-active) subset on ties.
        if best.as_ref().is_none_or(|b| cost < b.1) {
            best = Some((p, cost, active));
        }
    }
    best
}

/// Bounded least squares on the normal equations (Gram form, Eq. 19):
/// minimise pᵀHp − 2pᵀb + yy subject to p_i ≥ 0 for i ∈ `constrained`.
/// `h` is I×I row-major and symmetric positive semi-definite.
pub fn bounded_lsq_gram(
    h: &[f64],
    b: &[f64],
    yy: f64,
    constrained: &[usize],
) -> Result<BoundedSolution> {
    let dim = b.len();
    if h.len() != dim * dim {
        return Err(Error::usage("bounded least squares: H must be I×I"));
    }
    check_constrained(constrained, dim)?;
    // Column equilibration: D_i = 1/sqrt(H_ii) (zero columns get coefficient 0).
    let scale: Vec<f64> = (0..dim)
        .map(|i| {
            if h[i * dim + i] > 0.0 {
                1.0 / h[i * dim + i].sqrt()
            } else {
                0.0
            }
        })
        .collect();
    let hs: Vec<f64> = (0..dim * dim)
        .map(|x| h[x] * scale[x / dim] * scale[x % dim])
        .collect();
    let bs: Vec<f64> = (0..dim).map(|i| b[i] * scale[i]).collect();
    let mut factor = vec![0.0; dim * dim];
    let mut rhs = vec![0.0; dim];
    let best = enumerate_active_sets(dim, constrained, |free| {
        let p = cholesky_solve_dropping(&hs, &bs, free, &scale, &mut factor, &mut rhs);
        // Cost evaluated as the quadratic form at p (accurate even when the
        // solve itself lost digits).
        let mut cost = yy;
        for i in 0..dim {
            if p[i] == 0.0 {
                continue;
            }
            cost -= 2.0 * p[i] * bs[i];
            for k in 0..dim {
                cost += p[i] * hs[i * dim + k] * p[k];
            }
        }
        Some((p, cost))
    });
    let (ps, cost, active) =
        best.ok_or_else(|| Error::numerical("bounded least squares: no feasible active set"))?;
    Ok(BoundedSolution {
        p: ps.iter().zip(&scale).map(|(p, s)| p * s).collect(),
        cost: cost.max(0.0),
        active,
    })
}

/// Cholesky solve of the free block of the equilibrated system; columns whose
/// pivot falls below `DEPENDENT_PIVOT` (or whose scale is zero) get 0.
fn cholesky_solve_dropping(
    hs: &[f64],
    bs: &[f64],
    free: &[bool],
    scale: &[f64],
    factor: &mut [f64],
    rhs: &mut [f64],
) -> Vec<f64> {
    let dim = bs.len();
    let mut used = vec![false; dim];
    factor.iter_mut().for_each(|x| *x = 0.0);
    // Lower-triangular L with L Lᵀ = H_FF, row by row.
    for i in 0..dim {
        if !free[i] || scale[i] == 0.0 {
            continue;
        }
        for k in 0..i {
            if !used[k] {
                continue;
            }
            let mut s = hs[i * dim + k];
            for m in 0..k {
                if used[m] {
                    s -= factor[i * dim + m] * factor[k * dim + m];
                }
            }
            factor[i * dim + k] = s / factor[k * dim + k];
        }
        let mut d = hs[i * dim + i];
        for m in 0..i {
            if used[m] {
                d -= factor[i * dim + m] * factor[i * dim + m];
            }
        }
        if d > DEPENDENT_PIVOT * hs[i * dim + i] && d > 0.0 {
            factor[i * dim + i] = d.sqrt();
            used[i] = true;
        } else {
            for m in 0..i {
                factor[i * dim + m] = 0.0;
            }
        }
    }
    // Forward then backward substitution on the used indices.
    for i in 0..dim {
        if !used[i] {
            rhs[i] = 0.0;
            continue;
        }
        let mut s = bs[i];
        for m in 0..i {
            if used[m] {
                s -= factor[i * dim + m] * rhs[m];
            }
        }
        rhs[i] = s / factor[i * dim + i];
    }
    let mut p = vec![0.0; dim];
    for i in (0..dim).rev() {
        if !used[i] {
            continue;
        }
        let mut s = rhs[i];
        for m in i + 1..dim {
            if used[m] {
                s -= factor[m * dim + i] * p[m];
            }
        }
        p[i] = s / factor[i * dim + i];
    }
    p
}

/// In-place Householder triangularisation of a column-major matrix
/// (`columns[j][i]` = row i of column j). On return the upper triangle of the
/// leading rows holds R; rows below hold garbage. Column norms are preserved
/// in the sense ‖A x‖ = ‖R x‖ for every x.
fn householder_triangularize(columns: &mut [Vec<f64>]) {
    let rows = columns.first().map_or(0, |c| c.len());
    let cols = columns.len();
    for j in 0..cols.min(rows) {
        let norm = columns[j][j..].iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm == 0.0 {
            continue;
        }
        let alpha = if columns[j][j] > 0.0 { -norm } else { norm };
        // v = x − alpha e1, stored in place; beta = vᵀv / 2 = norm² − alpha x_0.
        let x0 = columns[j][j];
        let vtv_half = norm * norm - alpha * x0;
        let mut v: Vec<f64> = columns[j][j..].to_vec();
        v[0] = x0 - alpha;
        columns[j][j] = alpha;
        for x in columns[j][j + 1..].iter_mut() {
            *x = 0.0;
        }
        for col in columns.iter_mut().skip(j + 1) {
            let dot: f64 = v.iter().zip(&col[j..]).map(|(a, b)| a * b).sum();
            let f = dot / vtv_half;
            for (x, vi) in col[j..].iter_mut().zip(&v) {
                *x -= f * vi;
            }
        }
    }
}

/// Bounded weighted least squares on the design matrix itself (QR form, more
/// accurate than the normal equations): minimise Σ_n W[n] (Σ_i p_i a_i[n] − y[n])²
/// subject to p_i ≥ 0 for i ∈ `constrained`. `weights = None` means W = 1.
pub fn bounded_lsq_columns(
    columns: &[&[f64]],
    target: &[f64],
    weights: Option<&[f64]>,
    constrained: &[usize],
) -> Result<BoundedSolution> {
    let dim = columns.len();
    let n = target.len();
    if columns.iter().any(|c| c.len() != n) || weights.is_some_and(|w| w.len() != n) {
        return Err(Error::usage(
            "bounded least squares: columns, target and weights must have equal length",
        ));
    }
    check_constrained(constrained, dim)?;
    let root_w: Vec<f64> = match weights {
        Some(w) => w.iter().map(|x| x.max(0.0).sqrt()).collect(),
        None => vec![1.0; n],
    };
    // Weighted, equilibrated columns plus the weighted target as last column.
    let mut scale = vec![0.0; dim];
    let mut work: Vec<Vec<f64>> = Vec::with_capacity(dim + 1);
    for (i, c) in columns.iter().enumerate() {
        let col: Vec<f64> = c.iter().zip(&root_w).map(|(a, w)| a * w).collect();
        let norm = col.iter().map(|x| x * x).sum::<f64>().sqrt();
        scale[i] = if norm > 0.0 && norm.is_finite() {
            1.0 / norm
        } else {
            0.0
        };
        work.push(col.iter().map(|x| x * scale[i]).collect());
    }
    work.push(target.iter().zip(&root_w).map(|(y, w)| y * w).collect());
    householder_triangularize(&mut work);
    // Compressed problem: rows 0..=dim of [R | c] carry everything.
    let reduced: Vec<Vec<f64>> = work
        .iter()
        .map(|c| c[..(dim + 1).min(n)].to_vec())
        .collect();
    let best = enumerate_active_sets(dim, constrained, |free| {
        let chosen: Vec<usize> = (0..dim).filter(|&i| free[i] && scale[i] > 0.0).collect();
        let mut sub: Vec<Vec<f64>> = chosen.iter().map(|&i| reduced[i].clone()).collect();
        sub.push(reduced[dim].clone());
        householder_triangularize(&mut sub);
        let m = chosen.len();
        // Back substitution, dropping dependent columns (tiny diagonal).
        let mut x = vec![0.0; m];
        for a in (0..m).rev() {
            let diag = sub[a][a];
            if diag.abs() <= DEPENDENT_DIAGONAL_QR {
                x[a] = 0.0;
                continue;
            }
            let mut s = sub[m][a];
            for c in a + 1..m {
                s -= sub[c][a] * x[c];
            }
            x[a] = s / diag;
        }
        let mut p = vec![0.0; dim];
        for (a, &i) in chosen.iter().enumerate() {
            p[i] = x[a];
        }
        // Cost = ‖R p − c‖² on the compressed rows (rows below are the
        // unexplained part common to every subset).
        let rows = reduced[dim].len();
        let mut cost = 0.0;
        for r in 0..rows {
            let mut s = -reduced[dim][r];
            for i in 0..dim {
                s += reduced[i][r] * p[i];
            }
            cost += s * s;
        }
        Some((p, cost))
    });
    let (ps, cost, active) =
        best.ok_or_else(|| Error::numerical("bounded least squares: no feasible active set"))?;
    Ok(BoundedSolution {
        p: ps.iter().zip(&scale).map(|(p, s)| p * s).collect(),
        cost,
        active,
    })
}
