//! Guyan (static) condensation onto master DoFs (METHODS §5, Eq. 85–86):
//! u = T_d u_m with T_d = [I; −K_ss⁻¹ K_sm] (rows in the original DoF order),
//! K_r = T_dᵀ K T_d (the Schur complement K_mm − K_ms K_ss⁻¹ K_sm), M_r = T_dᵀ M T_d.
//! K_ss is factored by sparse Cholesky, so large slave sets are fine; T_d is dense (n × m).

use faer::Mat;

use super::sparse::CscMatrix;
use super::statics::solve_spd;
use crate::error::Error;
use crate::Result;

#[derive(Debug, Clone)]
pub struct GuyanReduction {
    pub masters: Vec<usize>,
    pub slaves: Vec<usize>,
    /// n × m: full displacement = T · master displacement.
    pub transformation: Mat<f64>,
    pub stiffness: Mat<f64>,
    pub mass: Mat<f64>,
}

/// Condense K and M onto `masters` (free-DoF indices). Errors: a master index out of range
/// or repeated (`Usage`), a singular slave block (`Numerical`: the slaves alone form a
/// mechanism — add masters or supports).
pub fn guyan_reduce(k: &CscMatrix, m: &CscMatrix, masters: &[usize]) -> Result<GuyanReduction> {
    let n = k.n;
    let mut is_master = vec![false; n];
    for &i in masters {
        if i >= n {
            return Err(Error::usage(format!(
                "Guyan: master DoF {i} outside 0..{n}"
            )));
        }
        if is_master[i] {
            return Err(Error::usage(format!("Guyan: master DoF {i} listed twice")));
        }
        is_master[i] = true;
    }
    let slaves: Vec<usize> = (0..n).filter(|&i| !is_master[i]).collect();
    let nm = masters.len();
    let mut t = Mat::<f64>::zeros(n, nm);
    for (j, &i) in masters.iter().enumerate() {
        t[(i, j)] = 1.0;
    }
    if !slaves.is_empty() && nm > 0 {
        let kss = k.principal_submatrix(&slaves);
        let ksm = k.dense_block(&slaves, masters);
        let rhs: Vec<Vec<f64>> = (0..nm)
            .map(|j| (0..slaves.len()).map(|i| -ksm[(i, j)]).collect())
            .collect();
        let sol = solve_spd(&kss, &rhs).map_err(|f| {
            Error::numerical(format!("Guyan: the slave stiffness block is singular ({f:?}); the slave DoFs form a mechanism"))
        })?;
        for (j, col) in sol.iter().enumerate() {
            for (r, &i) in slaves.iter().enumerate() {
                t[(i, j)] = col[r];
            }
        }
    }
    let project = |a: &CscMatrix| -> Mat<f64> {
        // A T column by column (sparse × dense), then Tᵀ (A T).
        let mut at = Mat::<f64>::zeros(n, nm);
        let mut x = vec![0.0; n];
        let mut y = vec![0.0; n];
        for j in 0..nm {
            for i in 0..n {
                x[i] = t[(i, j)];
            }
            a.mul_vec(&x, &mut y);
            for i in 0..n {
                at[(i, j)] = y[i];
            }
        }
        let mut r = t.transpose() * &at;
        // Symmetrise round-off.
        for i in 0..nm {
            for j in 0..i {
                let s = 0.5 * (r[(i, j)] + r[(j, i)]);
                r[(i, j)] = s;
                r[(j, i)] = s;
            }
        }
        r
    };
    let stiffness = project(k);
    let mass = project(m);
    Ok(GuyanReduction {
        masters: masters.to_vec(),
        slaves,
        transformation: t,
        stiffness,
        mass,
    })
}
