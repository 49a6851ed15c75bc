//! Generalised symmetric eigenproblem K φ = ω² M φ.
//!
//! - Dense (small models): Cholesky of the *stiffness* K = L Lᵀ, then the standard problem
//!   C y = μ y with C = L⁻¹ M L⁻ᵀ and μ = 1/ω² (faer `self_adjoint_eigen`); φ = L⁻ᵀ y.
//!   Factoring K instead of M keeps massless DoFs (μ = 0, ω = ∞) harmless, and a failed
//!   factorisation names the first DoF where K is not positive definite (unrestrained model).
//! - Sparse (large models): shift-invert Lanczos on A = (K − σM)⁻¹ M, which is self-adjoint
//!   in the K_σ = K − σM inner product, with full re-orthogonalisation; K_σ factored once by
//!   faer's sparse Cholesky. Ritz values ν give ω² = σ + 1/ν. Convergence: residual
//!   estimate |β_m s_m,i| ≤ tol · |ν_i| for the wanted modes.
//! Mode shapes are mass-normalised (φᵀMφ = 1) with the largest-magnitude entry positive.

use faer::linalg::solvers::Solve;
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::{Mat, MatRef, Par, Side};

use super::sparse::CscMatrix;
use crate::rng::Rng;

/// Eigen-pairs, ascending in ω².
#[derive(Debug, Clone)]
pub struct Modes {
    /// ω² (rad²/s²).
    pub omega2: Vec<f64>,
    /// Mass-normalised shapes, one column per mode (n × count).
    pub shapes: Mat<f64>,
}

impl Modes {
    pub fn count(&self) -> usize {
        self.omega2.len()
    }
    pub fn frequencies_hz(&self) -> Vec<f64> {
        self.omega2
            .iter()
            .map(|w2| w2.max(0.0).sqrt() / (2.0 * std::f64::consts::PI))
            .collect()
    }
    pub fn shape(&self, mode: usize) -> Vec<f64> {
        (0..self.shapes.nrows())
            .map(|i| self.shapes[(i, mode)])
            .collect()
    }
}

/// Why an eigen solve failed.
#[derive(Debug, Clone, PartialEq)]
pub enum EigenFailure {
    /// K (or K − σM) is not positive definite; the index is the offending DoF when known.
    NotPositiveDefinite(Option<usize>),
    Other(String),
}

fn normalise_columns(shapes: &mut Mat<f64>, m: MatMulFn<'_>) {
    let n = shapes.nrows();
    let mut mx = vec![0.0; n];
    for j in 0..shapes.ncols() {
        let x: Vec<f64> = (0..n).map(|i| shapes[(i, j)]).collect();
        m(&x, &mut mx);
        let mass: f64 = x.iter().zip(&mx).map(|(a, b)| a * b).sum();
        let mut scale = if mass > 0.0 { 1.0 / mass.sqrt() } else { 1.0 };
        let mut biggest = 0.0f64;
        let mut sign = 1.0;
        for v in &x {
            if v.abs() > biggest {
                biggest = v.abs();
                sign = v.signum();
            }
        }
        scale *= sign;
        for i in 0..n {
            shapes[(i, j)] *= scale;
        }
    }
}

type MatMulFn<'a> = &'a dyn Fn(&[f64], &mut [f64]);

/// The `count` lowest modes by the dense K-Cholesky method.
pub fn dense_modes(
    k: MatRef<'_, f64>,
    m: MatRef<'_, f64>,
    count: usize,
) -> Result<Modes, EigenFailure> {
    let n = k.nrows();
    let llt = k.llt(Side::Lower).map_err(|e| match e {
        faer::linalg::cholesky::llt::factor::LltError::NonPositivePivot { index } => {
            EigenFailure::NotPositiveDefinite(Some(index))
        }
    })?;
    let l = llt.L();
    // X = L⁻¹ M, then C = L⁻¹ Xᵀ = L⁻¹ M L⁻ᵀ.
    let mut x = m.to_owned();
    solve_lower_triangular_in_place(l, x.as_mut(), Par::Seq);
    let mut c = x.transpose().to_owned();
    solve_lower_triangular_in_place(l, c.as_mut(), Par::Seq);
    for i in 0..n {
        for j in 0..i {
            let s = 0.5 * (c[(i, j)] + c[(j, i)]);
            c[(i, j)] = s;
            c[(j, i)] = s;
        }
    }
    let evd = c
        .self_adjoint_eigen(Side::Lower)
        .map_err(|e| EigenFailure::Other(format!("{e:?}")))?;
    let mu = evd.S().column_vector();
    let u = evd.U();
    let mu_max = (0..n).map(|i| mu[i]).fold(0.0f64, f64::max);
    // Largest μ first = lowest ω²; μ ≤ tiny means a massless (infinite-frequency) direction.
    let mut picked = Vec::new();
    for i in (0..n).rev() {
        if picked.len() == count {
            break;
        }
        if mu[i] > 1e-13 * mu_max {
            picked.push(i);
        }
    }
    let mut shapes = Mat::<f64>::zeros(n, picked.len());
    for (j, &i) in picked.iter().enumerate() {
        for r in 0..n {
            shapes[(r, j)] = u[(r, i)];
        }
    }
    solve_upper_triangular_in_place(l.transpose(), shapes.as_mut(), Par::Seq);
    let omega2: Vec<f64> = picked.iter().map(|&i| 1.0 / mu[i]).collect();
    let mult = |x: &[f64], y: &mut [f64]| {
        for r in 0..n {
            y[r] = (0..n).map(|c| m[(r, c)] * x[c]).sum();
        }
    };
    normalise_columns(&mut shapes, &mult);
    Ok(Modes { omega2, shapes })
}

/// Settings of the shift-invert Lanczos solver.
#[derive(Debug, Clone)]
pub struct LanczosOptions {
    /// Shift σ (rad²/s²); 0 finds the lowest modes of a restrained structure.
    pub shift: f64,
    /// Relative residual tolerance on the Ritz values.
    pub tolerance: f64,
    /// Maximum Krylov dimension (default max(20·count, 200), capped at n).
    pub max_steps: Option<usize>,
    /// Seed of the start vector.
    pub seed: u64,
}

impl Default for LanczosOptions {
    fn default() -> Self {
        LanczosOptions {
            shift: 0.0,
            tolerance: 1e-10,
            max_steps: None,
            seed: 0x5EED,
        }
    }
}

/// A sparse Cholesky factorisation of K_σ = K − σM, reusable across Lanczos runs.
pub struct ShiftInvertFactor {
    pub shift: f64,
    pub shifted: CscMatrix,
    pub llt: faer::sparse::linalg::solvers::Llt<usize, f64>,
}

/// The symbolic Cholesky analysis of a matrix's lower-triangle pattern (reusable for every
/// matrix with the same pattern, e.g. K(θ) for all θ).
pub fn symbolic_cholesky(
    k: &CscMatrix,
) -> Result<faer::sparse::linalg::solvers::SymbolicLlt<usize>, EigenFailure> {
    let lower = k
        .to_faer_lower()
        .map_err(|e| EigenFailure::Other(e.to_string()))?;
    faer::sparse::linalg::solvers::SymbolicLlt::try_new(lower.symbolic(), Side::Lower)
        .map_err(|e| EigenFailure::Other(format!("{e:?}")))
}

/// Factor K − σM (σ = `shift`), reusing a symbolic analysis of the same pattern when given.
pub fn factor_shifted(
    k: &CscMatrix,
    m: &CscMatrix,
    shift: f64,
    symbolic: Option<&faer::sparse::linalg::solvers::SymbolicLlt<usize>>,
) -> Result<ShiftInvertFactor, EigenFailure> {
    let shifted = if shift == 0.0 {
        k.clone()
    } else {
        super::sparse::AffineMatrix::from_matrices(k, &[m.clone()]).at(&[-shift])
    };
    let lower = shifted
        .to_faer_lower()
        .map_err(|e| EigenFailure::Other(e.to_string()))?;
    let symbolic = match symbolic {
        Some(s) if shift == 0.0 => s.clone(),
        _ => faer::sparse::linalg::solvers::SymbolicLlt::try_new(lower.symbolic(), Side::Lower)
            .map_err(|e| EigenFailure::Other(format!("{e:?}")))?,
    };
    let llt = faer::sparse::linalg::solvers::Llt::try_new_with_symbolic(
        symbolic,
        lower.as_ref(),
        Side::Lower,
    )
    .map_err(|e| match e {
        faer::sparse::linalg::LltError::Numeric(_) => EigenFailure::NotPositiveDefinite(None),
        other => EigenFailure::Other(format!("{other:?}")),
    })?;
    Ok(ShiftInvertFactor {
        shift,
        shifted,
        llt,
    })
}

/// The `count` modes nearest above the shift by shift-invert Lanczos.
pub fn lanczos_modes(
    k: &CscMatrix,
    m: &CscMatrix,
    count: usize,
    opts: &LanczosOptions,
) -> Result<Modes, EigenFailure> {
    let factor = factor_shifted(k, m, opts.shift, None)?;
    lanczos_with_factor(&factor, m, count, opts)
}

/// Shift-invert Lanczos with a prepared factorisation of K − σM.
pub fn lanczos_with_factor(
    factor: &ShiftInvertFactor,
    m: &CscMatrix,
    count: usize,
    opts: &LanczosOptions,
) -> Result<Modes, EigenFailure> {
    let ks = &factor.shifted;
    let n = ks.n;
    if count == 0 || n == 0 {
        return Ok(Modes {
            omega2: vec![],
            shapes: Mat::zeros(n, 0),
        });
    }
    let max_steps = opts.max_steps.unwrap_or((20 * count).max(200)).min(n);
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let mut rhs = Mat::<f64>::zeros(n, 1);
    let mut tmp = vec![0.0; n];
    // y = (K − σM)⁻¹ M x.
    let apply = |x: &[f64], out: &mut [f64], rhs: &mut Mat<f64>, tmp: &mut [f64]| {
        m.mul_vec(x, tmp);
        for i in 0..n {
            rhs[(i, 0)] = tmp[i];
        }
        factor.llt.solve_in_place(rhs.as_mut());
        for i in 0..n {
            out[i] = rhs[(i, 0)];
        }
    };
    // Lanczos vectors q_j and p_j = K_σ q_j (for K_σ inner products without re-multiplying).
    let mut q: Vec<Vec<f64>> = Vec::new();
    let mut p: Vec<Vec<f64>> = Vec::new();
    let mut alpha: Vec<f64> = Vec::new();
    let mut beta: Vec<f64> = Vec::new();
    let mut rng = Rng::new(opts.seed);
    let start: Vec<f64> = (0..n).map(|_| rng.uniform() - 0.5).collect();
    // Start in the range of the operator (drops massless directions).
    let mut w = vec![0.0; n];
    apply(&start, &mut w, &mut rhs, &mut tmp);
    let mut kw = vec![0.0; n];
    ks.mul_vec(&w, &mut kw);
    let mut norm = dot(&w, &kw).max(0.0).sqrt();
    if !(norm > 0.0) {
        return Err(EigenFailure::Other("the mass matrix is zero".into()));
    }
    let mut aw = vec![0.0; n];
    let mut ritz: Option<(Vec<f64>, Vec<Vec<f64>>, Vec<usize>)> = None;
    for step in 0..max_steps {
        let qj: Vec<f64> = w.iter().map(|v| v / norm).collect();
        let pj: Vec<f64> = kw.iter().map(|v| v / norm).collect();
        apply(&qj, &mut aw, &mut rhs, &mut tmp);
        // α_j = ⟨A q_j, q_j⟩_Kσ = q_jᵀ M q_j.
        m.mul_vec(&qj, &mut tmp);
        let a = dot(&qj, &tmp);
        q.push(qj);
        p.push(pj);
        alpha.push(a);
        // Full re-orthogonalisation (twice) in the K_σ inner product.
        for _ in 0..2 {
            for (qi, pi) in q.iter().zip(p.iter()) {
                let c = dot(pi, &aw);
                for (x, y) in aw.iter_mut().zip(qi) {
                    *x -= c * y;
                }
            }
        }
        ks.mul_vec(&aw, &mut kw);
        let b = dot(&aw, &kw).max(0.0).sqrt();
        let steps = step + 1;
        let breakdown = b <= 1e-13 * a.abs().max(f64::MIN_POSITIVE);
        if steps >= count.min(n) || breakdown || steps == max_steps {
            let (nu, s) = super::tridiagonal::tridiagonal_eigen_rows(&alpha, &beta, false)
                .ok_or_else(|| {
                    EigenFailure::Other("tridiagonal eigen-solve did not converge".into())
                })?;
            // Largest ν = nearest above the shift.
            let idx: Vec<usize> = (0..steps)
                .rev()
                .filter(|&i| nu[i] > 0.0)
                .take(count)
                .collect();
            let converged = idx.len() == count.min(steps)
                && idx
                    .iter()
                    .all(|&i| (b * s[i][0]).abs() <= opts.tolerance * nu[i].abs());
            if converged || breakdown || steps == max_steps {
                if !converged && !breakdown && idx.len() < count {
                    return Err(EigenFailure::Other(format!(
                        "Lanczos did not converge in {steps} steps for {count} modes"
                    )));
                }
                let (nu, s) =
                    super::tridiagonal::tridiagonal_eigen(&alpha, &beta).ok_or_else(|| {
                        EigenFailure::Other("tridiagonal eigen-solve did not converge".into())
                    })?;
                let idx: Vec<usize> = (0..steps)
                    .rev()
                    .filter(|&i| nu[i] > 0.0)
                    .take(count)
                    .collect();
                ritz = Some((nu, s, idx));
                break;
            }
        }
        beta.push(b);
        w.clone_from(&aw);
        norm = b;
    }
    let (nu, s, idx) =
        ritz.ok_or_else(|| EigenFailure::Other("Lanczos produced no Ritz pairs".into()))?;
    // Ascending ω² = σ + 1/ν: ν descending.
    let mut shapes = Mat::<f64>::zeros(n, idx.len());
    let mut omega2 = Vec::with_capacity(idx.len());
    for (j, &i) in idx.iter().enumerate() {
        omega2.push(factor.shift + 1.0 / nu[i]);
        for (r, qr) in q.iter().enumerate() {
            let c = s[i][r];
            if c == 0.0 {
                continue;
            }
            for row in 0..n {
                shapes[(row, j)] += c * qr[row];
            }
        }
    }
    let mult = |x: &[f64], y: &mut [f64]| m.mul_vec(x, y);
    normalise_columns(&mut shapes, &mult);
    Ok(Modes { omega2, shapes })
}

/// Largest model solved with the dense method by `TwinSystem::modes`.
pub const DENSE_LIMIT: usize = 1500;

/// Most modes asked of a twin (`quaketwin twin modes --count`): the Lanczos
/// basis holds a few vectors per mode of every DoF.
pub const MAX_MODES: usize = 1000;

impl super::assembly::TwinSystem {
    /// Turn a solver failure into a user-facing error naming the twin file and DoF.
    pub fn eigen_error(&self, failure: EigenFailure) -> crate::Error {
        match failure {
            EigenFailure::NotPositiveDefinite(index) => crate::Error::input(
                crate::Location::file(self.source.clone()),
                match index.and_then(|i| self.labels.get(i)) {
                    Some(label) => format!(
                        "stiffness matrix is singular (not positive definite) at {label}: the model is unrestrained or has a mechanism"
                    ),
                    None => "stiffness matrix is singular (not positive definite): the model is unrestrained or has a mechanism".to_string(),
                },
            ),
            EigenFailure::Other(message) => crate::Error::numerical(format!("{}: eigen solve: {message}", self.source)),
        }
    }

    /// The `count` lowest modes at parameters θ (dense up to `DENSE_LIMIT` DoFs, else
    /// shift-invert Lanczos).
    pub fn modes(&self, theta: &[f64], count: usize) -> crate::Result<Modes> {
        if count > MAX_MODES {
            return Err(crate::Error::usage(format!(
                "{}: mode count {count}: at most {MAX_MODES}",
                self.source
            )));
        }
        self.check_parameters(theta)?;
        let k = self.stiffness_at(theta);
        super::assembly::check_stiffness_diagonal(self, &k)?;
        if self.n <= DENSE_LIMIT {
            let kd = k.to_dense();
            let md = self.mass.dense_at(theta);
            dense_modes(kd.as_ref(), md.as_ref(), count).map_err(|f| self.eigen_error(f))
        } else {
            self.modes_lanczos_cached(theta, count)
                .map_err(|f| self.eigen_error(f))
        }
    }

    /// The `count` lowest modes by Lanczos, reusing the cached symbolic factorisation of the
    /// stiffness pattern (no bounds check; for repeated evaluations inside optimisers).
    pub fn modes_lanczos_cached(&self, theta: &[f64], count: usize) -> Result<Modes, EigenFailure> {
        let k = self.stiffness_at(theta);
        let m = self.mass_at(theta);
        let symbolic = match self.symbolic_cache.get() {
            Some(s) => s.clone(),
            None => {
                let s = symbolic_cholesky(&k)?;
                let _ = self.symbolic_cache.set(s.clone());
                s
            }
        };
        let factor = factor_shifted(&k, &m, 0.0, Some(&symbolic))?;
        lanczos_with_factor(&factor, &m, count, &LanczosOptions::default())
    }

    /// Dense modes without the bounds check (for optimisers that already clamp θ).
    pub fn modes_unchecked_dense(
        &self,
        theta: &[f64],
        count: usize,
    ) -> Result<Modes, EigenFailure> {
        let kd = self.stiffness.dense_at(theta);
        let md = self.mass.dense_at(theta);
        dense_modes(kd.as_ref(), md.as_ref(), count)
    }
}
