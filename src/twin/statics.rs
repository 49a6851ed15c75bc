//! Linear static analysis K(θ) u = f, in particular under gravity (f = M g on the free
//! translational DoFs), by faer's sparse Cholesky.

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};

use super::assembly::{check_stiffness_diagonal, TwinSystem};
use super::eigen::EigenFailure;
use super::sparse::CscMatrix;
use crate::Result;

/// Solve K u = f for several right-hand sides with one sparse Cholesky factorisation.
/// Returns `NotPositiveDefinite` when K is singular (unrestrained model).
pub fn solve_spd(
    k: &CscMatrix,
    loads: &[Vec<f64>],
) -> std::result::Result<Vec<Vec<f64>>, EigenFailure> {
    let n = k.n;
    let lower = k
        .to_faer_lower()
        .map_err(|e| EigenFailure::Other(e.to_string()))?;
    let llt = lower.sp_cholesky(Side::Lower).map_err(|e| match e {
        faer::sparse::linalg::LltError::Numeric(_) => EigenFailure::NotPositiveDefinite(None),
        other => EigenFailure::Other(format!("{other:?}")),
    })?;
    let mut rhs = Mat::<f64>::zeros(n, loads.len());
    for (j, f) in loads.iter().enumerate() {
        for i in 0..n.min(f.len()) {
            rhs[(i, j)] = f[i];
        }
    }
    llt.solve_in_place(rhs.as_mut());
    Ok((0..loads.len())
        .map(|j| (0..n).map(|i| rhs[(i, j)]).collect())
        .collect())
}

/// Result of a static analysis.
#[derive(Debug, Clone)]
pub struct StaticResult {
    pub load: Vec<f64>,
    pub displacement: Vec<f64>,
}

impl TwinSystem {
    /// Static response to a load vector on the free DoFs.
    pub fn static_response(&self, theta: &[f64], load: &[f64]) -> Result<StaticResult> {
        self.check_parameters(theta)?;
        if load.len() != self.n {
            return Err(crate::Error::usage(format!(
                "{}: load has {} entries, the twin has {} DoFs",
                self.source,
                load.len(),
                self.n
            )));
        }
        let k = self.stiffness_at(theta);
        check_stiffness_diagonal(self, &k)?;
        let mut u = solve_spd(&k, &[load.to_vec()]).map_err(|f| self.eigen_error(f))?;
        Ok(StaticResult {
            load: load.to_vec(),
            displacement: u.pop().unwrap_or_default(),
        })
    }

    /// Static response under self-weight and lumped masses (gravity vector of the twin).
    pub fn gravity_response(&self, theta: &[f64]) -> Result<StaticResult> {
        let load = self.gravity_load(theta);
        self.static_response(theta, &load)
    }
}
