//! Data-driven uncertainty of the modal estimates (issue 36): the
//! first-order propagation of the statistical error of the factorised
//! matrix to frequency, damping ratio and mode shape (Reynders, Pintelon &
//! De Roeck 2008, MSSP 22; in the fast form of Döhler & Mevel 2013, MSSP 38;
//! the input–output case after Mellinger, Döhler & Mevel 2016, JSV 379).
//! docs/statistics.md gives the equations and the validation.
//!
//! 1. **Covariance of the factorised matrix H** from the data: the record
//!    is cut into n_b blocks, H_k formed from each block exactly as H from
//!    the record (SSI-COV: the block Toeplitz matrix of output-to-reference
//!    covariances; input–output: the Gram matrix of PO-MOESP's block Hankel
//!    matrix, then L₃₂ through its Cholesky factor); Σ_H = T Tᵀ with
//!    T = [vec(H_1 − H̄), …, vec(H_{n_b} − H̄)] / √(n_b (n_b − 1)), the
//!    covariance of the mean of the blocks.  Σ_H is never formed: every
//!    sensitivity is applied to the n_b columns of T (the "J·T column by
//!    column" of Döhler & Mevel), and σ_θ² = Σ_t (J_θ T_t)².
//! 2. **SVD → observability matrix.**  Γ = U₁ S₁^{1/2}.  A perturbation of
//!    Γ inside its own column space, Γ → Γ(I + X), is a change of state
//!    basis: A → (I + X)⁻¹ A (I + X), C → C (I + X), so the eigenvalues and
//!    the shapes C ψ do not move.  Only the part of ΔU₁ outside span U₁
//!    matters; first-order SVD perturbation gives it column by column
//!    (i ≤ n < j):
//!    ΔU₁_⊥ = U₂ K + (I − U Uᵀ) ΔH V₁ S₁⁻¹,
//!    K_{ji} = (σ_i u_jᵀ ΔH v_i + σ_j u_iᵀ ΔH v_j) / (σ_i² − σ_j²),
//!    and ΔΓ = ΔU₁_⊥ S₁^{1/2}.  This is the analytical Jacobian through
//!    the SVD (Eq. S3 of docs/statistics.md); the same for both methods.
//! 3. **(A, C)**: C = Γ↑ rows 1..l, A = Γ↑⁺ Γ↓ (least squares):
//!    ΔA = (Γ↑ᵀΓ↑)⁻¹ [Γ↑ᵀ (ΔΓ↓ − ΔΓ↑ A) + ΔΓ↑ᵀ (Γ↓ − Γ↑ A)], ΔC = ΔΓ rows 1..l.
//! 4. **Eigenstructure**, A = Ψ M Ψ⁻¹: Δμ_i = (Ψ⁻¹ ΔA ψ_i)_i,
//!    Δψ_i = Σ_{j≠i} ψ_j (Ψ⁻¹ ΔA ψ_i)_j / (μ_i − μ_j) (the part along ψ_i
//!    drops out of the normalised shape), Δφ = ΔC ψ + C Δψ.
//! 5. **Modal parameters**: λ = ln μ / Δt, Δλ = Δμ / (μ Δt);
//!    f = |λ|/2π, Δf = Re(λ̄ Δλ) / (2π |λ|);
//!    ζ = −Re λ / |λ|, Δζ = −Re Δλ / |λ| + Re λ · Re(λ̄ Δλ) / |λ|³;
//!    shape normalised at component c: φ̃ = φ / φ_c,
//!    Δφ̃ = (Δφ − φ̃ Δφ_c) / φ_c, Δ|φ̃_j| = Re(φ̃_j* Δφ̃_j) / |φ̃_j|.
//!
//! A mode's estimate is the mean over the poles of the best-converged part
//! of its column ([`super::selection`]); its σ is the median of the σ of
//! the mode's poles at the (up to [`MAX_POLES_PER_MODE`]) highest orders
//! where the first order holds (Eq. S6: the truncation's rotation
//! [`Sensitivity::cut_rotation`] at most [`MAX_CUT_ROTATION`]; [`mode_std`]
//! says why), combined in quadrature with the spread of the averaged poles
//! over the orders (Eq. S7, [`with_order_spread`]) for frequency and
//! damping — and, where that valid-order pole disagrees with the
//! reported estimate beyond its own interval, with their difference
//! (Eq. S9, [`StdBasis`]).  The σ's degrees
//! of freedom are the blocks' effective count by power (Eq. S8',
//! [`effective_dof`]), and the 95 % interval is θ̂ ± t_{0.975, ν} σ
//! ([`interval_factor`]).
//!
//! Input–output: the factorised matrix L₃₂ is a smooth function of the Gram
//! matrix G of [U_f; U_p; Y_p; Y_f] (G = L Lᵀ); with dG_t the centred block
//! Grams, dL = L Φ(L⁻¹ dG L⁻ᵀ) (Φ: the lower triangle, diagonal halved;
//! the derivative of the Cholesky factor), and dL₃₂ = L₃₂ Φ₂₂ + L₃₃ Φ₃₂.
//! Analytical, like SSI-COV; [`finite_difference_pole`] checks both
//! (tests/it/uncertainty.rs).  The modal stage uses the fast form
//! [`io_sensitivity`] (Eq. S1'' of docs/statistics.md: step 2 needs dL₃₂
//! only through d(L₃₂L₃₂ᵀ), where Φ drops out; a block's Gram is
//! H_k H_kᵀ / c with c ≪ R columns, L⁻¹ G_k L⁻ᵀ = W Wᵀ / c, W = L⁻¹ H_k,
//! applied straight to the singular vectors); [`l32_perturbations`] is the
//! dense reference it is tested against.
//!
//! Numerical code only; no I/O.

use super::hankel::hankel_gram;
use super::poles::Pole;
use super::selection::Mode;
use super::ssi::{
    cholesky_lower, covariance_toeplitz, eigen_structure, po_moesp_rows, thin_svd_subspace,
    Subspace,
};
use super::Method;
use crate::error::{Error, Result};
use crate::stats::median_in_place;
use faer::linalg::matmul::matmul;
use faer::linalg::solvers::DenseSolveCore;
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::{c64, Accum, Mat, MatRef, Par};

/// Fewest blocks for a data-driven σ: with n_b blocks the σ itself carries
/// a relative error of about 1/√(2 (n_b − 1)) (24 % at 10).  Below, the
/// σ is left null with a warning, never a number.
pub const MIN_BLOCKS: usize = 10;
/// Most blocks chosen automatically: 30 puts the σ's own error near 13 %
/// and keeps the cost (linear in n_b) within half the modal stage's
/// (docs/performance.md).
pub const MAX_AUTO_BLOCKS: usize = 30;
/// Most blocks a user may ask for (`uncertainty_blocks`).
pub const MAX_BLOCKS: usize = 200;
/// SSI-COV: each automatic block lasts at least this many periods of the
/// lowest selected mode: the blocks' covariance estimates must be nearly
/// independent, i.e. a block long against the memory of the ambient
/// response (1/(2π ζ f): 5 periods at ζ = 3 %).
pub const BLOCK_PERIODS: f64 = 10.0;
/// Input–output: the measured input carries the dynamics, and what is
/// random is the measurement noise, white: blocks need not outlast the
/// response's memory, only hold a few cycles of the lowest mode (a 40-s
/// earthquake record of a 1.3-Hz building gives 10 blocks).
pub const BLOCK_PERIODS_IO: f64 = 3.0;
/// … and at least this many times the Hankel matrix's span of 2p samples
/// (the fewest any block may have: fewer, and the σ is refused).  2, not
/// more: the 14-channel × 41 s event of `benches/modal.rs` (io, p = 28 at
/// 40 Hz, 1640 samples) gets 14 blocks of 3 periods of its 1.05 Hz
/// fundamental; 4 spans left it 7 blocks and no σ.
pub const BLOCK_SPANS: usize = 2;
/// Below this many degrees of freedom (Eq. S8') the σ is still given, with
/// its wide Student-t interval, but the modal stage warns: the σ is then
/// itself uncertain by more than a third (1/√(2ν)).  4, as the change
/// test's least (Eq. C4').
pub const FEW_DEGREES_OF_FREEDOM: f64 = 4.0;
/// Poles (orders) of a mode whose σ enter its median ([`mode_std`]): at
/// the orders where the first order holds their σ agree within a few per
/// cent, and each costs an eigen-decomposition and products over the n_b
/// columns (3, not 6: the io σ's cost, docs/performance.md).
pub const MAX_POLES_PER_MODE: usize = 3;

/// Data-driven standard deviations of one mode's estimates.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ModeStd {
    /// σ of the frequency, Hz.
    pub frequency_hz: f64,
    /// σ of the damping ratio.
    pub damping: f64,
    /// σ of each shape component's modulus (shape normalised to its largest
    /// component, whose σ is 0 by construction).
    pub shape_modulus: Vec<f64>,
    /// Blocks the covariance was estimated from.
    pub blocks: usize,
    /// Degrees of freedom of the estimated σ (Eq. S8' of
    /// docs/statistics.md): Kish's effective number of blocks − 1, which
    /// is `blocks` − 1 for a steady record and fewer where the record's
    /// power lies in a few blocks (an earthquake's strong phase).
    #[serde(default = "unknown_dof")]
    pub dof: f64,
    /// How the frequency's and damping's σ were formed (Eqs. S7, S9 of
    /// docs/statistics.md).
    #[serde(default)]
    pub basis: StdBasis,
}

fn unknown_dof() -> f64 {
    f64::NAN
}

/// How a mode's σ of frequency and damping was obtained (Eq. S9 of
/// docs/statistics.md; the `uncertainty_basis` column of modes.parquet).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StdBasis {
    /// √(σ_valid² + s²) (Eq. S7): the pole at the valid orders agrees with
    /// the reported estimate, so its σ stands for it.
    #[default]
    ValidOrders,
    /// √(σ_valid² + s² + d²) (Eq. S9): the valid-order pole lies outside
    /// its own 95 % interval of the reported estimate, so the two differ
    /// by more than σ_valid sees, and the measured difference d is added.
    Discrepancy,
}

impl StdBasis {
    /// The name in modes.parquet's `uncertainty_basis`.
    pub fn name(self) -> &'static str {
        match self {
            StdBasis::ValidOrders => "valid_orders",
            StdBasis::Discrepancy => "discrepancy",
        }
    }

    /// The basis named `name` (as [`Self::name`] writes it).
    pub fn from_name(name: &str) -> Option<StdBasis> {
        [StdBasis::ValidOrders, StdBasis::Discrepancy]
            .into_iter()
            .find(|b| b.name() == name)
    }
}

/// The automatic number of blocks for `samples` samples at `dt`, block rows
/// `p` and the lowest selected mode `lowest_hz`: as many as fit blocks of
/// max([`BLOCK_PERIODS`] periods ([`BLOCK_PERIODS_IO`] for `io`),
/// [`BLOCK_SPANS`] × 2p samples), at most
/// [`MAX_AUTO_BLOCKS`].  May be below [`MIN_BLOCKS`] (the caller refuses).
pub fn auto_blocks(
    method: Method,
    samples: usize,
    dt: f64,
    block_rows: usize,
    lowest_hz: f64,
) -> usize {
    let cycles = match method {
        Method::Io => BLOCK_PERIODS_IO,
        _ => BLOCK_PERIODS,
    };
    let periods = (cycles / (lowest_hz * dt)).ceil();
    let periods = if periods.is_finite() && periods > 0.0 {
        periods as usize
    } else {
        samples
    };
    let least = periods.max(BLOCK_SPANS * 2 * block_rows).max(1);
    (samples / least).min(MAX_AUTO_BLOCKS)
}

/// (H_k − H̄) / √(n_b (n_b − 1)) for each block matrix H_k, and H̄.
fn centre(mats: Vec<Mat<f64>>) -> (Mat<f64>, Vec<Mat<f64>>) {
    let nb = mats.len();
    centre_scaled(mats, 1.0 / ((nb * (nb - 1)) as f64).sqrt())
}

/// (H_k − H̄) · `scale` for each matrix H_k, and H̄.
fn centre_scaled(mats: Vec<Mat<f64>>, scale: f64) -> (Mat<f64>, Vec<Mat<f64>>) {
    let nb = mats.len();
    let (r, c) = (mats[0].nrows(), mats[0].ncols());
    let mut mean = Mat::<f64>::zeros(r, c);
    for m in &mats {
        mean += m;
    }
    mean *= faer::Scale(1.0 / nb as f64);
    let deltas = mats
        .into_iter()
        .map(|m| {
            let mut d = m - &mean;
            d *= faer::Scale(scale);
            d
        })
        .collect();
    (mean, deltas)
}

/// SSI-COV: the block Toeplitz covariance matrix of each of `blocks`
/// equal blocks of the record; returns H̄ and the columns of T.
pub fn ssi_cov_blocks(
    outputs: &[&[f64]],
    refs: &[usize],
    block_rows: usize,
    blocks: usize,
) -> (Mat<f64>, Vec<Mat<f64>>) {
    let n = outputs.iter().map(|s| s.len()).min().unwrap_or(0);
    let len = n / blocks;
    let mats = (0..blocks)
        .map(|k| {
            let cut: Vec<&[f64]> = outputs.iter().map(|s| &s[k * len..(k + 1) * len]).collect();
            covariance_toeplitz(&cut, refs, block_rows)
        })
        .collect();
    centre(mats)
}

/// Columns of PO-MOESP's block Hankel matrix in each of `blocks` equal
/// runs (the input–output blocks of Eq. S1): the record's n + 1 − 2p
/// columns shared out, n the shortest signal.
fn io_block_columns(
    outputs: &[&[f64]],
    inputs: &[&[f64]],
    block_rows: usize,
    blocks: usize,
) -> usize {
    let n = inputs
        .iter()
        .chain(outputs)
        .map(|s| s.len())
        .min()
        .unwrap_or(0);
    (n + 1).saturating_sub(2 * block_rows) / blocks
}

/// Input–output: the Gram matrix of PO-MOESP's block Hankel matrix over
/// each of `blocks` equal runs of its columns; returns Ḡ and the columns
/// of T (the centred block Grams).
pub fn po_moesp_blocks(
    outputs: &[&[f64]],
    inputs: &[&[f64]],
    block_rows: usize,
    blocks: usize,
) -> (Mat<f64>, Vec<Mat<f64>>) {
    let (l, m, p) = (outputs.len(), inputs.len(), block_rows);
    let signals: Vec<&[f64]> = inputs.iter().chain(outputs).copied().collect();
    let per_block = io_block_columns(outputs, inputs, p, blocks);
    let rows = po_moesp_rows(m, l, p);
    let r = rows.len();
    let mats = (0..blocks)
        .map(|k| {
            let start = k * per_block;
            let cut: Vec<&[f64]> = signals
                .iter()
                .map(|s| &s[start..start + per_block + 2 * p - 1])
                .collect();
            let g = hankel_gram(&cut, &rows, per_block);
            Mat::<f64>::from_fn(r, r, |i, j| g[i * r + j])
        })
        .collect();
    centre(mats)
}

/// Row blocks of PO-MOESP's Gram matrix: U_f (p·m), past (p·(m+l)), Y_f (p·l).
fn io_blocks(m: usize, l: usize, p: usize) -> (usize, usize, usize) {
    (p * m, p * (m + l), p * l)
}

/// Lower Cholesky factor of a Gram matrix given as a matrix.
fn cholesky_of(gram: MatRef<'_, f64>) -> Result<Mat<f64>> {
    let r = gram.nrows();
    let flat: Vec<f64> = (0..r * r).map(|k| gram[(k / r, k % r)]).collect();
    cholesky_lower(&flat, r)
}

/// L₃₂ of the Cholesky factor of a PO-MOESP Gram matrix: the matrix
/// `ssi::po_moesp` factorises.
pub fn po_moesp_l32(gram: MatRef<'_, f64>, m: usize, l: usize, p: usize) -> Result<Mat<f64>> {
    let big_l = cholesky_of(gram)?;
    let (r1, r2, r3) = io_blocks(m, l, p);
    Ok(big_l.as_ref().submatrix(r1 + r2, r1, r3, r2).to_owned())
}

/// dL₃₂ for each Gram perturbation dG_t (module doc): the derivative of
/// the Cholesky factor, dL = L Φ(L⁻¹ dG L⁻ᵀ), restricted to the blocks L₃₂
/// needs, dL₃₂ = L₃₂ Φ₂₂ + L₃₃ Φ₃₂ with M_{B,2} = L⁻¹[B, :] dG L⁻¹[2, ≤2]ᵀ.
pub fn l32_perturbations(
    gram: MatRef<'_, f64>,
    deltas: &[Mat<f64>],
    m: usize,
    l: usize,
    p: usize,
) -> Result<Vec<Mat<f64>>> {
    let big_l = cholesky_of(gram)?;
    let r = big_l.nrows();
    let (r1, r2, r3) = io_blocks(m, l, p);
    let mut linv = Mat::<f64>::identity(r, r);
    solve_lower_triangular_in_place(big_l.as_ref(), linv.as_mut(), Par::rayon(0));
    // L⁻¹ is lower triangular: the rows of block 2 vanish beyond column r1 + r2.
    let linv2t = linv
        .as_ref()
        .submatrix(r1, 0, r2, r1 + r2)
        .transpose()
        .to_owned();
    let linv23 = linv.as_ref().submatrix(r1, 0, r2 + r3, r).to_owned();
    let l32 = big_l.as_ref().submatrix(r1 + r2, r1, r3, r2);
    let l33 = big_l.as_ref().submatrix(r1 + r2, r1 + r2, r3, r3);
    Ok(deltas
        .iter()
        .map(|dg| {
            let q = dg.as_ref().subcols(0, r1 + r2) * &linv2t;
            let mm = &linv23 * &q;
            let phi22 = Mat::<f64>::from_fn(r2, r2, |i, j| match i.cmp(&j) {
                std::cmp::Ordering::Greater => mm[(i, j)],
                std::cmp::Ordering::Equal => 0.5 * mm[(i, j)],
                std::cmp::Ordering::Less => 0.0,
            });
            let phi32 = mm.as_ref().subrows(r2, r3);
            l32 * &phi22 + l33 * phi32
        })
        .collect())
}

/// `a b` without thread hand-offs: the small products of one block or one
/// pole run inside a rayon loop over blocks or modes, and faer's own
/// parallel kernels nested there cost more in hand-offs than they gain.
fn mul_seq(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> Mat<f64> {
    let mut out = Mat::<f64>::zeros(a.nrows(), b.ncols());
    matmul(out.as_mut(), Accum::Replace, a, b, 1.0, Par::Seq);
    out
}

/// Input–output, the fast form of Eqs. S1'–S2 (docs/statistics.md,
/// docs/performance.md): the products N_t = Uᵀ d(L₃₂L₃₂ᵀ)_t U₁ that K of
/// Eq. S2 needs (K_ji = N_ji / (σ_i² − σ_j²)), for every block straight
/// from its c Hankel columns H_k (R × c), never forming dG_t, M, Φ or dL₃₂.
/// With dL₃₂ = L₃₂ Φ(M₂₂) + L₃₃ M₃₂ (Eq. S1') and M symmetric,
/// d(L₃₂L₃₂ᵀ) = L₃₂ M₂₂ L₃₂ᵀ + L₃₃ M₃₂ L₃₂ᵀ + L₃₂ M₂₃ L₃₃ᵀ: the halved
/// diagonal and the triangle of Φ drop out.  A block's Gram is
/// H_k H_kᵀ / c, so M = W Wᵀ / c with W = L⁻¹ H_k, and with A = L₃₂ W₂,
/// B = L₃₃ W₃ and P = A + B = H₃ − L₃₁ W₁ (block row 3 of L W = H_k):
///   c · d(L₃₂L₃₂ᵀ) = A Aᵀ + B Aᵀ + A Bᵀ = P Aᵀ + A Bᵀ.
/// With Uᵀ L₃₂ = S Vᵀ, Uᵀ A = Â E where E = H₂ − L₂₁ W₁ = L₂₂ W₂ and
/// Â = S Vᵀ L₂₂⁻¹ (once per record), so W₂ is never formed either:
///   c · N = Uᵀ P (Â₁ E)ᵀ + Â E (U₁ᵀ P − Â₁ E)ᵀ.
/// The map G_k ↦ N is linear, so the centring of Eq. S1 is done on N:
/// Σ_t (G_k − Ḡ) = 0 makes that exact whatever Ḡ the factor L came from.
/// `cholesky` must be the L whose L₃₂ `subspace` is the SVD of
/// (`Subspace::gram_cholesky`).  Cost per block ≈ r₁² c / 2 + (r₂ + r₃)
/// r₁ c + 2 (r₂ + r₃) c n + k (r₂ + r₃) n, against 2 R² r₂ for
/// [`l32_perturbations`] (R = 784, c = 117, n = 42: ≈ 22 M against 480 M
/// multiply–adds).  `None` when U is not square (the part of ΔH outside
/// span U would be needed: [`l32_perturbations`] then).
pub fn io_sensitivity<'a>(
    subspace: &'a Subspace,
    cholesky: MatRef<'_, f64>,
    outputs: &[&[f64]],
    inputs: &[&[f64]],
    blocks: usize,
    n_max: usize,
) -> Option<Sensitivity<'a>> {
    use rayon::prelude::*;
    let (l, m, p) = (outputs.len(), inputs.len(), subspace.block_rows);
    let (r1, r2, r3) = io_blocks(m, l, p);
    let u = subspace.u.as_ref();
    let k = subspace.singular_values.len();
    if u.nrows() != k || u.nrows() != r3 || cholesky.nrows() != r1 + r2 + r3 || blocks < 2 {
        return None;
    }
    let n_max = n_max.min(k);
    let signals: Vec<&[f64]> = inputs.iter().chain(outputs).copied().collect();
    let per_block = io_block_columns(outputs, inputs, p, blocks);
    let rows = po_moesp_rows(m, l, p);
    let c = per_block as f64;
    let v = subspace.v.as_ref();
    let s = &subspace.singular_values;
    let u1t = u.subcols(0, n_max).transpose();
    let l11 = cholesky.submatrix(0, 0, r1, r1);
    let l22 = cholesky.submatrix(r1, r1, r2, r2);
    // [L₂₁; L₃₁]: block rows 2 and 3 of L W = H_k, minus their W₁ part.
    let l_23_1 = cholesky.submatrix(r1, 0, r2 + r3, r1);
    // Âᵀ = L₂₂⁻ᵀ V S (r₂ × k), then [Uᵀ  Â] (k × (r₃ + r₂)) for the one
    // product that gives N.
    let mut a_hat_t = Mat::<f64>::from_fn(r2, k, |i, j| v[(i, j)] * s[j]);
    solve_upper_triangular_in_place(
        l22.transpose(),
        a_hat_t.as_mut(),
        faer::get_global_parallelism(),
    );
    let a_hat1 = a_hat_t.as_ref().subcols(0, n_max).transpose();
    let ut_a_hat = Mat::<f64>::from_fn(k, r3 + r2, |i, j| {
        if j < r3 {
            u[(j, i)]
        } else {
            a_hat_t[(j - r3, i)]
        }
    });
    let raw: Vec<Mat<f64>> = (0..blocks)
        .into_par_iter()
        .map(|b| {
            let start = b * per_block;
            let h = Mat::<f64>::from_fn(r1 + r2 + r3, per_block, |r, j| {
                signals[rows[r].signal][start + j + rows[r].shift]
            });
            let mut w1 = h.as_ref().subrows(0, r1).to_owned();
            solve_lower_triangular_in_place(l11, w1.as_mut(), Par::Seq);
            // [E; P] = [H₂; H₃] − [L₂₁; L₃₁] W₁.
            let mut ep = h.as_ref().subrows(r1, r2 + r3).to_owned();
            matmul(ep.as_mut(), Accum::Add, l_23_1, w1.as_ref(), -1.0, Par::Seq);
            let (e, pp) = (ep.as_ref().subrows(0, r2), ep.as_ref().subrows(r2, r3));
            // F = Â₁ E = U₁ᵀ A; U₁ᵀ B = U₁ᵀ P − F.
            let f = mul_seq(a_hat1, e);
            let mut u1t_b = mul_seq(u1t, pp);
            u1t_b -= &f;
            // [P Fᵀ; E (U₁ᵀB)ᵀ] / c, then N = [Uᵀ  Â] times it.
            let mut x = Mat::<f64>::zeros(r3 + r2, n_max);
            matmul(
                x.as_mut().subrows_mut(0, r3),
                Accum::Replace,
                pp,
                f.transpose(),
                1.0 / c,
                Par::Seq,
            );
            matmul(
                x.as_mut().subrows_mut(r3, r2),
                Accum::Replace,
                e,
                u1t_b.transpose(),
                1.0 / c,
                Par::Seq,
            );
            mul_seq(ut_a_hat.as_ref(), x.as_ref())
        })
        .collect();
    let scale = 1.0 / ((blocks * (blocks - 1)) as f64).sqrt();
    let (_, products) = centre_scaled(raw, scale);
    Some(Sensitivity::with_products(
        subspace,
        n_max,
        products,
        Vec::new(),
    ))
}
/// A pole's value and its first-order perturbation along each column of T.
#[derive(Debug, Clone)]
pub struct PoleSensitivity {
    pub frequency_hz: f64,
    pub damping_ratio: f64,
    /// φ = C ψ, not normalised.
    pub shape: Vec<c64>,
    /// J_f T_t, Hz, per column t.
    pub d_frequency: Vec<f64>,
    /// J_ζ T_t per column t.
    pub d_damping: Vec<f64>,
    /// J_φ T_t per column t (not normalised; [`normalised_modulus_deltas`]).
    pub d_shape: Vec<Vec<c64>>,
}

impl PoleSensitivity {
    /// √Σ_t d_t² of the frequency and the damping.
    pub fn std(&self) -> (f64, f64) {
        let rss = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        (rss(&self.d_frequency), rss(&self.d_damping))
    }
}

/// Continuous-time pole of a discrete eigenvalue: (λ, f, ζ) as
/// `poles::poles_of_order` computes them.
fn continuous(mu: c64, dt: f64) -> (c64, f64, f64) {
    let lambda = c64::new(mu.norm().ln(), mu.arg()) / dt;
    let omega = lambda.norm();
    (lambda, omega / std::f64::consts::TAU, -lambda.re / omega)
}

/// The eigenvalue (Im μ > 0) of `eig` nearest the pole (f, ζ).
fn matching_eigenvalue(eig: &[c64], frequency_hz: f64, damping: f64, dt: f64) -> Option<usize> {
    (0..eig.len())
        .filter(|&i| eig[i].im > 0.0)
        .min_by(|&a, &b| {
            let d = |i: usize| {
                let (_, f, z) = continuous(eig[i], dt);
                (f - frequency_hz).abs() / frequency_hz + (z - damping).abs()
            };
            d(a).total_cmp(&d(b))
        })
}

/// (df, dζ) of a perturbation dμ of the eigenvalue μ (module doc, step 5).
fn modal_deltas(mu: c64, d_mu: c64, dt: f64) -> (f64, f64) {
    let (lambda, _, _) = continuous(mu, dt);
    let d_lambda = d_mu / (mu * dt);
    let modulus = lambda.norm();
    let radial = (lambda.conj() * d_lambda).re;
    (
        radial / (modulus * std::f64::consts::TAU),
        -d_lambda.re / modulus + lambda.re * radial / modulus.powi(3),
    )
}

/// The SVD-level products of every column of T, shared by all poles of
/// orders up to `n_max` (module doc, step 2): N_t = Uᵀ d(HHᵀ)_t U₁
/// (k × n_max), of which K_{ji} of Eq. S2 is N_ji / (σ_i² − σ_j²)
/// (σ_i u_jᵀ ΔH v_i + σ_j u_iᵀ ΔH v_j = u_jᵀ (ΔH Hᵀ + H ΔHᵀ) u_i), and
/// (I − UUᵀ) ΔH_t V₁ when U is not square.
pub struct Sensitivity<'a> {
    subspace: &'a Subspace,
    n_max: usize,
    products: Vec<Mat<f64>>,
    outside: Vec<Mat<f64>>,
    /// [`Self::cut_rotation`] per order 0..=n_max.
    cut_rotations: Vec<f64>,
    /// What every pole of one order shares (realisation, eigenvectors),
    /// computed once for all the modes that use the order.
    orders: Vec<std::sync::OnceLock<Result<OrderWork>>>,
}

/// The realisation of one order and what its poles' sensitivities share.
struct OrderWork {
    a_rows: usize,
    c: Mat<f64>,
    /// Γ↑ and Γ↓ − Γ↑ A (Eq. S3).
    up: Mat<f64>,
    residual: Mat<f64>,
    /// (Γ↑ᵀΓ↑)⁻¹.
    gram_inv: Mat<f64>,
    mus: Vec<c64>,
    psi_all: Mat<c64>,
    psi_inv: Mat<c64>,
    /// S^{1/2} of the kept singular values.
    sh: Vec<f64>,
    /// 1 / (σ_q² − σ_{n+j}²), column q, row j (Eq. S2).
    inv_gap: Mat<f64>,
}

/// (m re, m im) of a complex matrix.
fn split(x: MatRef<'_, c64>) -> (Mat<f64>, Mat<f64>) {
    (
        Mat::<f64>::from_fn(x.nrows(), x.ncols(), |i, j| x[(i, j)].re),
        Mat::<f64>::from_fn(x.nrows(), x.ncols(), |i, j| x[(i, j)].im),
    )
}

/// m (re + i im) for a real m.
fn real_times(m: MatRef<'_, f64>, re: MatRef<'_, f64>, im: MatRef<'_, f64>) -> Mat<c64> {
    let (a, b) = (mul_seq(m, re), mul_seq(m, im));
    Mat::<c64>::from_fn(a.nrows(), a.ncols(), |i, j| c64::new(a[(i, j)], b[(i, j)]))
}

impl<'a> Sensitivity<'a> {
    fn with_products(
        subspace: &'a Subspace,
        n_max: usize,
        products: Vec<Mat<f64>>,
        outside: Vec<Mat<f64>>,
    ) -> Sensitivity<'a> {
        let mut s = Sensitivity {
            subspace,
            n_max,
            products,
            outside,
            cut_rotations: Vec::new(),
            orders: (0..=n_max).map(|_| std::sync::OnceLock::new()).collect(),
        };
        s.cut_rotations = s.all_cut_rotations();
        s
    }

    /// `deltas`: the columns of T as matrices of the factorised matrix's shape.
    pub fn new(subspace: &'a Subspace, deltas: &[Mat<f64>], n_max: usize) -> Sensitivity<'a> {
        let k = subspace.singular_values.len();
        let s = &subspace.singular_values;
        let n_max = n_max.min(k);
        let u = subspace.u.as_ref();
        let v = subspace.v.as_ref();
        let v1 = v.subcols(0, n_max);
        let u1t = u.subcols(0, n_max).transpose();
        let square = u.nrows() == k;
        let (mut products, mut outside) = (Vec::new(), Vec::new());
        for d in deltas {
            let x = d * v1;
            let y = u.transpose() * &x;
            let z = (u1t * d) * v;
            if !square {
                outside.push(&x - u * &y);
            }
            // N_ji = σ_i Y_ji + σ_j Z_ij.
            products.push(Mat::<f64>::from_fn(k, n_max, |j, i| {
                s[i] * y[(j, i)] + s[j] * z[(i, j)]
            }));
        }
        Sensitivity::with_products(subspace, n_max, products, outside)
    }

    /// How far the first-order expansion of Eq. S2 can be trusted at
    /// order `n`: the largest rms rotation angle between a kept and a
    /// dropped singular vector, max_{i<n≤j} √Σ_t K_ji,t² (radians; Eq. S6
    /// of docs/statistics.md).  Small where the truncation falls in a clear
    /// gap of the singular values; of order 1 where it cuts between two
    /// nearly equal ones (the noise floor above the system order), where
    /// the linearised K overstates what a finite perturbation does.
    pub fn cut_rotation(&self, n: usize) -> f64 {
        self.cut_rotations.get(n).copied().unwrap_or(f64::INFINITY)
    }

    /// [`Self::cut_rotation`] for every order 0..=n_max at once: the rms
    /// angles of all pairs (i < n_max, j > i) once, then the running
    /// maxima over the pairs each truncation separates.
    fn all_cut_rotations(&self) -> Vec<f64> {
        let s = &self.subspace.singular_values;
        let k = s.len();
        let n_max = self.n_max.min(k.saturating_sub(1));
        // angle[i][j] for i < n_max, j in i+1..k.
        let mut angle = vec![vec![0.0f64; k]; n_max];
        for products in &self.products {
            for (i, row) in angle.iter_mut().enumerate() {
                let col = products.col_as_slice(i);
                for (j, a) in row.iter_mut().enumerate().skip(i + 1) {
                    let kv = col[j] / (s[i] * s[i] - s[j] * s[j]);
                    *a += kv * kv;
                }
            }
        }
        let mut out = vec![f64::INFINITY; self.n_max + 1];
        for (n, o) in out.iter_mut().enumerate().take(n_max + 1).skip(1) {
            let worst = (0..n)
                .flat_map(|i| angle[i][n..].iter().copied())
                .fold(0.0f64, f64::max)
                .sqrt();
            *o = if worst.is_finite() {
                worst
            } else {
                f64::INFINITY
            };
        }
        out
    }

    /// The realisation of order `n` and what its poles share, once.
    fn order_work(&self, n: usize) -> Result<&OrderWork> {
        self.orders[n]
            .get_or_init(|| {
                let sub = self.subspace;
                let l = sub.outputs;
                let a_rows = sub.u.nrows();
                let k = sub.singular_values.len();
                let s = &sub.singular_values;
                let (a, c) = sub.realise(n)?;
                let sh: Vec<f64> = s[..n].iter().map(|x| x.sqrt()).collect();
                let gamma = Mat::<f64>::from_fn(a_rows, n, |i, j| sub.u[(i, j)] * sh[j]);
                let up = gamma.as_ref().subrows(0, a_rows - l).to_owned();
                let down = gamma.as_ref().subrows(l, a_rows - l);
                let residual = down - mul_seq(up.as_ref(), a.as_ref());
                let gram_inv = mul_seq(up.transpose(), up.as_ref())
                    .partial_piv_lu()
                    .inverse();
                let eig = a.eigen().map_err(|e| {
                    Error::numerical(format!("eigenvalues of the state matrix: {e:?}"))
                })?;
                let mus: Vec<c64> = eig.S().column_vector().iter().copied().collect();
                let psi_all = eig.U().to_owned();
                let psi_inv = psi_all.partial_piv_lu().inverse();
                let inv_gap = Mat::<f64>::from_fn(k - n, n, |j, q| {
                    let sj = s[n + j];
                    1.0 / (s[q] * s[q] - sj * sj)
                });
                Ok(OrderWork {
                    a_rows,
                    c,
                    up,
                    residual,
                    gram_inv,
                    mus,
                    psi_all,
                    psi_inv,
                    sh,
                    inv_gap,
                })
            })
            .as_ref()
            .map_err(Error::duplicate)
    }

    /// The pole of order `order` nearest (f, ζ), with its perturbation
    /// along each column of T (module doc, steps 2–5).
    pub fn pole(
        &self,
        order: usize,
        frequency_hz: f64,
        damping: f64,
        dt: f64,
    ) -> Result<PoleSensitivity> {
        let sub = self.subspace;
        let n = order;
        if n == 0 || n > self.n_max {
            return Err(Error::numerical(format!(
                "uncertainty: order {n} above the prepared {}",
                self.n_max
            )));
        }
        let w = self.order_work(n)?;
        let l = sub.outputs;
        let a_rows = w.a_rows;
        let k = sub.singular_values.len();
        let sh = &w.sh;
        let mus = &w.mus;
        let i = matching_eigenvalue(mus, frequency_hz, damping, dt).ok_or_else(|| {
            Error::numerical(format!("uncertainty: no oscillating pole at order {n}"))
        })?;
        let mu = mus[i];
        let (_, f, z) = continuous(mu, dt);
        let psi: Vec<c64> = (0..n).map(|j| w.psi_all[(j, i)]).collect();
        let times = |m: MatRef<'_, f64>, x: &[c64]| -> Vec<c64> {
            (0..m.nrows())
                .map(|r| (0..m.ncols()).map(|q| x[q] * m[(r, q)]).sum())
                .collect()
        };
        let times_t = |m: MatRef<'_, f64>, x: &[c64]| -> Vec<c64> {
            (0..m.ncols())
                .map(|q| (0..m.nrows()).map(|r| x[r] * m[(r, q)]).sum())
                .collect()
        };
        let shape = times(w.c.as_ref(), &psi);
        let rho = times(w.residual.as_ref(), &psi);
        let u2 = sub.u.as_ref().subcols(n, k - n);
        let u2_rho = times_t(u2.subrows(0, a_rows - l), &rho);
        let s_psi: Vec<c64> = psi.iter().zip(sh).map(|(x, h)| x * *h).collect();
        let is_psi: Vec<c64> = psi.iter().zip(sh).map(|(x, h)| x / *h).collect();
        let nb = self.products.len();
        // Column t of `ks`: K_t S^{1/2} ψ (real and imaginary parts); of
        // `kr`: S^{1/2} K_tᵀ U₂↑ᵀ ρ.
        let mut ks_re = Mat::<f64>::zeros(k - n, nb);
        let mut ks_im = Mat::<f64>::zeros(k - n, nb);
        let mut kr = Mat::<c64>::zeros(n, nb);
        for t in 0..nb {
            let products = &self.products[t];
            let re = ks_re.col_as_slice_mut(t);
            let im = ks_im.col_as_slice_mut(t);
            for q in 0..n {
                let dropped = &products.col_as_slice(q)[n..];
                let gap = w.inv_gap.col_as_slice(q);
                let (sp, mut acc) = (s_psi[q], c64::new(0.0, 0.0));
                for j in 0..k - n {
                    let kv = dropped[j] * gap[j];
                    re[j] += sp.re * kv;
                    im[j] += sp.im * kv;
                    acc += u2_rho[j] * kv;
                }
                kr[(q, t)] = acc * sh[q];
            }
        }
        // ΔΓ ψ per column: U₂ K S^{1/2} ψ (+ the part outside span U).
        // Real products on the real and imaginary parts: U₂ is real, and a
        // complex copy of it per pole cost more than the product.
        let mut dgamma_psi = real_times(u2, ks_re.as_ref(), ks_im.as_ref());
        if !self.outside.is_empty() {
            for t in 0..nb {
                let o = self.outside[t].as_ref().subcols(0, n);
                let extra = times(o, &is_psi);
                let extra_t = times_t(o.subrows(0, a_rows - l), &rho);
                for r in 0..a_rows {
                    dgamma_psi[(r, t)] += extra[r];
                }
                for q in 0..n {
                    kr[(q, t)] += extra_t[q] / sh[q];
                }
            }
        }
        // Γ↑ᵀ (ΔΓ↓ψ − μ ΔΓ↑ψ) + ΔΓ↑ᵀ R ψ, then ΔA ψ.
        let shifted = Mat::<c64>::from_fn(a_rows - l, nb, |r, t| {
            dgamma_psi[(r + l, t)] - mu * dgamma_psi[(r, t)]
        });
        let (sr, si) = split(shifted.as_ref());
        let rhs = real_times(w.up.transpose(), sr.as_ref(), si.as_ref()) + &kr;
        let (rr, ri) = split(rhs.as_ref());
        let da_psi = real_times(w.gram_inv.as_ref(), rr.as_ref(), ri.as_ref());
        let mut e = Mat::<c64>::zeros(n, nb);
        matmul(
            e.as_mut(),
            Accum::Replace,
            w.psi_inv.as_ref(),
            da_psi.as_ref(),
            c64::new(1.0, 0.0),
            Par::Seq,
        );
        // Δψ = Σ_{j≠i} ψ_j e_j / (μ_i − μ_j) for all columns at once, then C Δψ.
        let coeff = Mat::<c64>::from_fn(n, nb, |j, t| {
            if j == i {
                c64::new(0.0, 0.0)
            } else {
                e[(j, t)] / (mu - mus[j])
            }
        });
        let mut d_psi = Mat::<c64>::zeros(n, nb);
        matmul(
            d_psi.as_mut(),
            Accum::Replace,
            w.psi_all.as_ref(),
            coeff.as_ref(),
            c64::new(1.0, 0.0),
            Par::Seq,
        );
        let (dr, di) = split(d_psi.as_ref());
        let c_dpsi = real_times(w.c.as_ref(), dr.as_ref(), di.as_ref());
        let mut d_frequency = Vec::with_capacity(nb);
        let mut d_damping = Vec::with_capacity(nb);
        let mut d_shape = Vec::with_capacity(nb);
        for t in 0..nb {
            let (df, dz) = modal_deltas(mu, e[(i, t)], dt);
            d_frequency.push(df);
            d_damping.push(dz);
            d_shape.push(
                (0..l)
                    .map(|r| dgamma_psi[(r, t)] + c_dpsi[(r, t)])
                    .collect(),
            );
        }
        Ok(PoleSensitivity {
            frequency_hz: f,
            damping_ratio: z,
            shape,
            d_frequency,
            d_damping,
            d_shape,
        })
    }
}

/// Δ|φ̃_j| per column of T of the shape normalised at component `c`
/// (module doc, step 5).
pub fn normalised_modulus_deltas(p: &PoleSensitivity, c: usize) -> Vec<Vec<f64>> {
    let pc = p.shape[c];
    let norm: Vec<c64> = p.shape.iter().map(|x| x / pc).collect();
    p.d_shape
        .iter()
        .map(|d| {
            norm.iter()
                .zip(d)
                .map(|(phi, dphi)| {
                    let dn = (dphi - phi * d[c]) / pc;
                    let modulus = phi.norm();
                    if modulus > 0.0 {
                        (phi.conj() * dn).re / modulus
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect()
}

/// Largest rms rotation at the truncation ([`Sensitivity::cut_rotation`])
/// at which a pole's first-order σ is used: 0.1 rad.  With a larger
/// rotation the linearised K of Eq. S2 overstates the finite
/// perturbation's effect, the σ of a mode whose truncation falls in the
/// noise floor comes out 2–4 × its seed-to-seed scatter
/// (docs/statistics.md, "The mode's σ").
pub const MAX_CUT_ROTATION: f64 = 0.1;
/// A pole of another order than the mode's own stands for the mode when
/// its frequency is within this fraction of the mode's and its shape's MAC
/// with the mode's at least [`SAME_MODE_MAC`].
pub const SAME_MODE_FREQUENCY: f64 = 0.01;
/// See [`SAME_MODE_FREQUENCY`].
pub const SAME_MODE_MAC: f64 = 0.9;

/// The σ of one mode (Eq. S6 of docs/statistics.md): the first-order σ
/// is evaluated only at orders where it is valid, i.e. whose truncation
/// rotates the kept singular vectors by at most [`MAX_CUT_ROTATION`]
/// (the mode's own poles `members` and, below them, the physical poles of
/// the same mode at lower orders); per quantity the median over the
/// (up to [`MAX_POLES_PER_MODE`]) highest such orders.  When no order
/// qualifies, the one with the smallest rotation.  Why not the mode's own
/// poles alone: they lie in the upper half of its column's orders, far
/// above the system order, where the truncation cuts between nearly equal
/// noise singular values; K of Eq. S2 then has tiny denominators and the
/// linearised σ of a weak mode came out 2–4 × its seed-to-seed scatter
/// (at single orders 10–100 ×: the 8.3 Hz mode of the 600-s ambient
/// 5-storey record, seed 2: 0.03–0.09 Hz at five orders, 2.3 Hz at order
/// 30) while the poles themselves stay put — the first order fails there.
/// That σ is the statistical error at the valid orders; the reported
/// estimate is the mean over the column's upper orders, whose scatter
/// over the orders is added in quadrature ([`with_order_spread`], Eq. S7):
/// with it the weak SSI-COV modes 3–5 of the 5-storey record go from
/// 79–86 % coverage to 89–95 % (docs/statistics.md, 100 seeds).  Where
/// the valid-order pole disagrees with the reported estimate (outside the
/// interval ± k σ_valid, k of `dof`), their difference is added too
/// (Eq. S9, [`StdBasis::Discrepancy`]).
pub fn mode_std(
    sensitivity: &Sensitivity<'_>,
    poles: &[Pole],
    members: &[usize],
    mode: &Mode,
    dt: f64,
    dof: f64,
) -> Result<ModeStd> {
    // One pole per order: the mode's own, else the nearest physical pole
    // of the same mode.
    let mut by_order: std::collections::BTreeMap<usize, (f64, usize)> = Default::default();
    for (i, p) in poles.iter().enumerate() {
        let own = members.contains(&i);
        let distance = (p.frequency_hz / mode.frequency_hz - 1.0).abs();
        let same = own
            || (p.physical
                && distance <= SAME_MODE_FREQUENCY
                && super::poles::mac(&p.shape, &mode.shape) >= SAME_MODE_MAC);
        if !same || p.order > sensitivity.n_max {
            continue;
        }
        let rank = if own { distance - 1.0 } else { distance };
        let e = by_order.entry(p.order).or_insert((rank, i));
        if rank < e.0 {
            *e = (rank, i);
        }
    }
    if by_order.is_empty() {
        return Err(Error::numerical("uncertainty: no pole of the mode"));
    }
    let rotation: Vec<(usize, usize, f64)> = by_order
        .iter()
        .map(|(&n, &(_, i))| (n, i, sensitivity.cut_rotation(n)))
        .collect();
    let valid: Vec<usize> = rotation
        .iter()
        .filter(|r| r.2 <= MAX_CUT_ROTATION)
        .map(|r| r.1)
        .collect();
    let chosen: Vec<usize> = if valid.is_empty() {
        rotation
            .iter()
            .min_by(|a, b| a.2.total_cmp(&b.2))
            .map(|r| r.1)
            .into_iter()
            .collect()
    } else {
        valid[valid.len().saturating_sub(MAX_POLES_PER_MODE)..].to_vec()
    };
    let c = (0..mode.shape.len())
        .max_by(|&a, &b| mode.shape[a].norm().total_cmp(&mode.shape[b].norm()))
        .unwrap_or(0);
    let l = mode.shape.len();
    let rss = |v: &mut dyn Iterator<Item = f64>| v.map(|x| x * x).sum::<f64>().sqrt();
    let (mut sf, mut sz) = (Vec::new(), Vec::new());
    let (mut pf, mut pz) = (Vec::new(), Vec::new());
    let mut sm = vec![Vec::new(); l];
    for &i in &chosen {
        let p = &poles[i];
        let s = sensitivity.pole(p.order, p.frequency_hz, p.damping_ratio, dt)?;
        let moduli = normalised_modulus_deltas(&s, c);
        let (f, z) = s.std();
        sf.push(f);
        sz.push(z);
        pf.push(s.frequency_hz);
        pz.push(s.damping_ratio);
        for (j, acc) in sm.iter_mut().enumerate() {
            acc.push(rss(&mut moduli.iter().map(|d| d[j])));
        }
    }
    let blocks = sensitivity.products.len();
    let valid = ValidOrderPole {
        frequency_hz: median_in_place(&mut pf),
        damping: median_in_place(&mut pz),
        frequency_std_hz: median_in_place(&mut sf),
        damping_std: median_in_place(&mut sz),
    };
    let (f, z) = (
        with_order_spread(valid.frequency_std_hz, mode.frequency_std_hz),
        with_order_spread(valid.damping_std, mode.damping_std),
    );
    let (frequency_hz, damping, basis) = if valid.stands_for(mode, interval_factor(dof)) {
        (f, z, StdBasis::ValidOrders)
    } else {
        // Eq. S9: the measured discrepancy joins the budget.
        (
            f.hypot(mode.frequency_hz - valid.frequency_hz),
            z.hypot(mode.damping_ratio - valid.damping),
            StdBasis::Discrepancy,
        )
    };
    Ok(ModeStd {
        frequency_hz,
        damping,
        shape_modulus: sm.iter_mut().map(|v| median_in_place(v)).collect(),
        blocks,
        dof,
        basis,
    })
}

/// A mode at its valid orders (Eq. S6): the median frequency and damping
/// of the chosen poles and the median of their first-order σ.
struct ValidOrderPole {
    frequency_hz: f64,
    damping: f64,
    frequency_std_hz: f64,
    damping_std: f64,
}

impl ValidOrderPole {
    /// Does this pole stand for the mode's reported estimate (Eq. S9)?
    /// Yes when the estimate lies inside the pole's own interval ± k σ
    /// (k of Eq. S8') in frequency and in damping: then the two differ by
    /// no more than the pole's statistical error, and σ_valid ⊕ s is the
    /// reported estimate's σ.  No when they differ by more: either the
    /// low-order pole has not converged to the mode the upper orders
    /// report (io modes 3–4 of the 5-storey building), or the upper
    /// orders' mean has drifted from a right low-order pole (the sample
    /// 4-storey quake's first Y mode: valid-order pole 2.74691 Hz, ζ 3.00 %,
    /// the truth 2.74695 Hz, 3 %; the reported mean 2.74767 Hz, 3.17 %).
    /// Which of the two is not known from one record, so the difference
    /// itself enters the σ.  13–22 % of 200 seeds for io modes 3–4,
    /// 11–26 % for SSI-COV's weak modes 3–5, never for modes 1–2.
    fn stands_for(&self, mode: &Mode, k: f64) -> bool {
        (mode.frequency_hz - self.frequency_hz).abs() <= k * self.frequency_std_hz
            && (mode.damping_ratio - self.damping).abs() <= k * self.damping_std
    }
}

/// The total σ of a mode's reported estimate (Eq. S7 of
/// docs/statistics.md): √(σ_valid² + s²), the first-order σ at the valid
/// orders plus the order spread s of the poles whose mean is reported
/// ([`Mode::frequency_std_hz`], [`Mode::damping_std`]).  The estimate is
/// the mean over the upper orders of the column, which move with the
/// record's noise in a way the valid-order σ does not see; s measures that
/// part.  s², not s²/n: the column's poles come from one record and are
/// strongly correlated, averaging them does not average their errors away.
/// A well-identified mode has s ≪ σ_valid and keeps its σ.
pub fn with_order_spread(valid_std: f64, order_spread: f64) -> f64 {
    if order_spread.is_finite() {
        valid_std.hypot(order_spread)
    } else {
        valid_std
    }
}

/// Confidence of the intervals reported with the data-driven σ.
pub const INTERVAL_CONFIDENCE: f64 = 0.95;

/// The factor k of the 95 % interval θ̂ ± k σ of a data-driven σ with
/// `dof` degrees of freedom ([`ModeStd::dof`]; Eqs. S8–S8' of
/// docs/statistics.md): Student's t_{0.975, dof}, not the normal 1.96.
/// σ² is estimated from the n_b block matrices (Eq. S1), so
/// (θ̂ − θ)/σ̂ is t-distributed, not normal: with 30 equal blocks (29
/// degrees of freedom) ±1.96 σ̂ covers 94.0 % instead of 95 %, with 20
/// blocks 93.5 %; the factor is 2.045 and 2.093 there.  NaN below 1
/// degree of freedom.
pub fn interval_factor(dof: f64) -> f64 {
    if !(dof >= 1.0) {
        return f64::NAN;
    }
    crate::stats::student_t_upper_quantile(0.5 * (1.0 - INTERVAL_CONFIDENCE), dof)
}

/// The degrees of freedom of a σ estimated from blocks of these powers
/// (Eq. S8' of docs/statistics.md; Satterthwaite): σ̂² is a sum of the
/// blocks' squared deviations, each with a variance that grows with its
/// block's power P_k, so its degrees of freedom are Kish's effective count
/// of the weights w_k minus one (the centring).  w_k = P_k² for SSI-COV
/// (output-only: the response itself is the random part, and a
/// covariance's error grows with the power), w_k = P_k for input–output
/// (the measured input drives the response; what is random is the
/// measurement noise, and its products with the signal grow with the
/// signal's power).  n_b − 1 for equal powers.
pub fn effective_dof(method: Method, powers: &[f64]) -> f64 {
    let weights: Vec<f64> = match method {
        Method::Io => powers.to_vec(),
        _ => powers.iter().map(|p| p * p).collect(),
    };
    crate::stats::kish_effective_count(&weights) - 1.0
}

/// The outputs' power in each of `blocks` consecutive runs of `len`
/// samples (the blocks of Eq. S1: [`ssi_cov_blocks`] cuts the record so,
/// [`po_moesp_blocks`] runs of Hankel columns starting there).
pub fn block_powers(outputs: &[&[f64]], blocks: usize, len: usize) -> Vec<f64> {
    (0..blocks)
        .map(|k| {
            outputs
                .iter()
                .map(|s| {
                    s.get(k * len..(k + 1) * len)
                        .map_or(0.0, |b| b.iter().map(|x| x * x).sum::<f64>())
                })
                .sum()
        })
        .collect()
}

/// Central finite differences of a pole along each column of T, for the
/// validation of the analytical sensitivities (tests/it/uncertainty.rs):
/// `factorised(t, ε)` returns the factorised matrix perturbed by ε along
/// column t (ε = 0: unperturbed); the pole of order `order` nearest (f, ζ)
/// is followed through ±`step`.  Returns (J_f T_t, J_ζ T_t) per column.
pub fn finite_difference_pole(
    factorised: impl Fn(usize, f64) -> Result<Mat<f64>>,
    columns: usize,
    outputs: usize,
    block_rows: usize,
    order: usize,
    (frequency_hz, damping): (f64, f64),
    dt: f64,
    step: f64,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let pole_at = |t: usize, eps: f64| -> Result<(f64, f64)> {
        let m = factorised(t, eps)?;
        let sub = thin_svd_subspace(m.as_ref(), outputs, block_rows)?;
        let (a, c) = sub.realise(order)?;
        let eig: Vec<c64> = eigen_structure(a.as_ref(), c.as_ref())?
            .into_iter()
            .map(|(mu, _)| mu)
            .collect();
        let i = matching_eigenvalue(&eig, frequency_hz, damping, dt)
            .ok_or_else(|| Error::numerical("finite difference: pole lost"))?;
        let (_, f, z) = continuous(eig[i], dt);
        Ok((f, z))
    };
    let (mut df, mut dz) = (Vec::new(), Vec::new());
    for t in 0..columns {
        let (fp, zp) = pole_at(t, step)?;
        let (fm, zm) = pole_at(t, -step)?;
        df.push((fp - fm) / (2.0 * step));
        dz.push((zp - zm) / (2.0 * step));
    }
    Ok((df, dz))
}

/// What [`of_modes`] needs from the identification.
pub struct Identified<'a> {
    pub method: Method,
    /// Pre-processed (decimated) outputs and, for `io`, inputs.
    pub outputs: &'a [&'a [f64]],
    pub inputs: &'a [&'a [f64]],
    pub refs: &'a [usize],
    pub block_rows: usize,
    pub subspace: &'a Subspace,
    pub dt: f64,
}

/// The data-driven σ of every mode, or why not.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DataUncertainty {
    /// Per mode (same order as the modes); `None` = not computed.
    pub modes: Vec<Option<ModeStd>>,
    pub notes: Vec<String>,
    pub warnings: Vec<String>,
}

/// The data-driven σ of `modes` (their member poles: `Pole::mode`), with
/// `blocks` blocks (`None` = [`auto_blocks`]).  SSI-DATA is not covered
/// (a note says so); too few blocks leave every σ null with a warning.
pub fn of_modes(
    id: &Identified<'_>,
    poles: &[Pole],
    modes: &[Mode],
    blocks: Option<usize>,
) -> DataUncertainty {
    let mut out = DataUncertainty {
        modes: vec![None; modes.len()],
        ..Default::default()
    };
    if modes.is_empty() {
        return out;
    }
    if id.method == Method::SsiData {
        out.notes.push(
            "data-driven σ (frequency_std_data_hz, damping_std_data): not computed for ssi-data (ssi-cov and io only)"
                .into(),
        );
        return out;
    }
    let samples = id.outputs.iter().map(|s| s.len()).min().unwrap_or(0);
    let lowest = modes
        .iter()
        .map(|m| m.frequency_hz)
        .fold(f64::INFINITY, f64::min);
    let (nb, rule) = match blocks {
        Some(b) => (b, "stated (uncertainty_blocks)".to_string()),
        None => (
            auto_blocks(id.method, samples, id.dt, id.block_rows, lowest),
            format!(
                "automatic: blocks of at least {} periods of the lowest mode {lowest:.3} Hz and {BLOCK_SPANS} × 2p = {} samples, at most {MAX_AUTO_BLOCKS}",
                if id.method == Method::Io { BLOCK_PERIODS_IO } else { BLOCK_PERIODS },
                BLOCK_SPANS * 2 * id.block_rows
            ),
        ),
    };
    let span = 2 * id.block_rows;
    if nb < MIN_BLOCKS || samples / nb.max(1) < BLOCK_SPANS * span {
        out.warnings.push(format!(
            "data-driven σ not computed: the record ({samples} samples after decimation, {:.1} s) gives {nb} block(s) ({rule}); at least {MIN_BLOCKS} blocks of {BLOCK_SPANS} × the Hankel span of {span} samples are needed — frequency_std_data_hz and damping_std_data are null, the order-spread σ alone is reported",
            samples as f64 * id.dt
        ));
        return out;
    }
    // Eq. S8': the blocks' powers give the σ's degrees of freedom.
    let block_len = match id.method {
        Method::Io => io_block_columns(id.outputs, id.inputs, id.block_rows, nb),
        _ => samples / nb,
    };
    let powers = block_powers(id.outputs, nb, block_len);
    let dof = effective_dof(id.method, &powers);
    if !(dof >= 1.0) {
        out.warnings.push(format!(
            "data-driven σ not computed: the record's power lies in one of its {nb} blocks (they count as {:.1}, Eq. S8'), no degree of freedom is left to estimate it — frequency_std_data_hz and damping_std_data are null",
            dof + 1.0
        ));
        return out;
    }
    if dof < FEW_DEGREES_OF_FREEDOM {
        out.warnings.push(format!(
            "data-driven σ from few effective blocks: the record's {nb} blocks count as {:.1} by their power (Eq. S8': its strong phase fills few of them), {dof:.1} degrees of freedom — the σ is itself uncertain by about {:.0} % and its 95 % intervals are ± {:.2} σ; an ambient record or a longer strong phase gives a σ to rely on",
            dof + 1.0,
            100.0 / (2.0 * dof).sqrt(),
            interval_factor(dof)
        ));
    }
    let members: Vec<Vec<usize>> = (0..modes.len())
        .map(|m| {
            (0..poles.len())
                .filter(|&i| poles[i].mode == Some(m))
                .collect()
        })
        .collect();
    let n_max = poles.iter().map(|p| p.order).max().unwrap_or(0);
    let fast = match (id.method, &id.subspace.gram_cholesky) {
        (Method::Io, Some(l)) => {
            io_sensitivity(id.subspace, l.as_ref(), id.outputs, id.inputs, nb, n_max)
        }
        _ => None,
    };
    let sensitivity = match fast {
        Some(s) => s,
        None => {
            let deltas = match id.method {
                Method::SsiCov => ssi_cov_blocks(id.outputs, id.refs, id.block_rows, nb).1,
                _ => {
                    let (gram, dg) = po_moesp_blocks(id.outputs, id.inputs, id.block_rows, nb);
                    match l32_perturbations(
                        gram.as_ref(),
                        &dg,
                        id.inputs.len(),
                        id.outputs.len(),
                        id.block_rows,
                    ) {
                        Ok(d) => d,
                        Err(e) => {
                            out.warnings
                                .push(format!("data-driven σ not computed: {e}"));
                            return out;
                        }
                    }
                }
            };
            Sensitivity::new(id.subspace, &deltas, n_max)
        }
    };
    // The modes in parallel (each mode's σ is the same whatever the thread;
    // the orders they share are realised once, `Sensitivity::order_work`).
    let stds: Vec<Option<Result<ModeStd>>> = {
        use rayon::prelude::*;
        modes
            .par_iter()
            .enumerate()
            .map(|(m, mode)| {
                (!members[m].is_empty())
                    .then(|| mode_std(&sensitivity, poles, &members[m], mode, id.dt, dof))
            })
            .collect()
    };
    for (m, (mode, std)) in modes.iter().zip(stds).enumerate() {
        let Some(std) = std else {
            continue;
        };
        match std {
            Ok(s) if s.frequency_hz.is_finite() && s.damping.is_finite() => out.modes[m] = Some(s),
            Ok(_) => out.warnings.push(format!(
                "data-driven σ of the {:.3} Hz mode not computed: not finite (coinciding singular values)",
                mode.frequency_hz
            )),
            Err(e) => out.warnings.push(format!(
                "data-driven σ of the {:.3} Hz mode not computed: {e}",
                mode.frequency_hz
            )),
        }
    }
    let switched = out
        .modes
        .iter()
        .flatten()
        .filter(|s| s.basis == StdBasis::Discrepancy)
        .count();
    out.notes.push(format!(
        "data-driven σ from {nb} blocks of {} samples ({rule}), counting as {:.1} by their power (Eq. S8': {:.1} degrees of freedom, 95 % interval ± {:.3} σ); first-order propagation (Reynders et al. 2008, Döhler & Mevel 2013){}",
        samples / nb,
        dof + 1.0,
        dof,
        interval_factor(dof),
        if switched > 0 {
            format!("; {switched} mode(s) with the discrepancy between the valid-order pole and the estimate added (Eq. S9)")
        } else {
            String::new()
        }
    ));
    out
}
