//! The subspace-based change test (Basseville, Abdelghani & Benveniste 2000,
//! *Subspace-based fault detection algorithms for vibration monitoring*,
//! Automatica 36; Döhler, Mevel & Hille 2014, *Subspace-based damage
//! detection under changes in the ambient excitation statistics*, MSSP 45):
//! is a record's output covariance structure that of a reference state?
//! docs/statistics.md, section "Change test", Eqs. C1–C7.
//!
//! (C1) H = [R_{i+j+1}]_{i<p, j<q}, the p·l × q·l block Hankel matrix of
//!      output covariances R_k = E[y_{t+k} y_tᵀ] (every channel a
//!      reference; lags from 1: the lag-0 covariance carries the measurement
//!      noise), divided by the record's mean channel variance tr R₀ / l:
//!      a change of the excitation's amplitude, the change Döhler, Mevel &
//!      Hille found to matter most, leaves the normalised H unchanged.
//! (C2) H₀ = O C of the reference (the mean of its records' H, weighted by
//!      their samples) has rank n, the model order (2 × the modes); its left
//!      null space S (the p·l − n eigenvectors of H₀H₀ᵀ with the smallest
//!      eigenvalues) satisfies Sᵀ O = 0 for the reference system whatever
//!      the excitation (which enters C only).
//! (C3) residual ζ = √N vec(Sᵀ (H − H₀)): zero-mean in the reference state,
//!      shifted when the eigenstructure (O) changed.  Centring on H₀ (the
//!      classical residual is √N vec(Sᵀ H)) removes Sᵀ H₀, which is not zero
//!      when the order n is below the system's (a mode the reference did not
//!      confirm), and makes the reference's own estimation error exact to
//!      first order: ζ/√N = Sᵀ (E − E₀), E, E₀ the estimation errors of H
//!      and H₀ (the perturbation of Ŝ cancels).
//! (C4) Σ, the covariance per sample of vec(Sᵀ E), from the reference's data
//!      blocks: each record is cut into blocks, each block's
//!      ζ_b = √N_b vec(Sᵀ H_b) is centred on its record's mean;
//!      Σ = Σ_b ζ_b ζ_bᵀ / m with m = Σ_records (blocks − 1) degrees of
//!      freedom.  From the reference rather than from the test: a long
//!      reference (the training day of `track`) gives a full-rank,
//!      well-estimated Σ that the blocks of one test window cannot (tens of
//!      blocks for ≥ 50 entries of ζ), and (C1)'s normalisation removes the
//!      excitation's level.
//! (C5) Cov ζ = (1 + N/N_ref) Σ (C3: test and reference errors independent).
//! (C6) χ² = ζᵀ Cov(ζ)⁺ ζ with the pseudo-inverse truncated to the k largest
//!      eigenvalues (k ≤ m/2, λ > 10⁻¹⁰ λ_max): degrees of freedom k.  Σ is
//!      estimated, so the statistic is Hotelling's T²: its p-value and the
//!      threshold of a false-alarm rate α come from (m − k + 1)/(m k) · T² ~
//!      F(k, m − k + 1) (→ χ²(k) for a long reference).
//! (C7) contributions: χ² = Σ_i ζ_i (Cov(ζ)⁺ζ)_i; the terms of the columns of
//!      H that belong to one channel (all its lags) add up to that channel's
//!      share (the shares sum to χ²; a share may be negative).
//! (C8) mode contributions: H₀ = O C with O = U_n Λ^{1/2}, C = Λ^{-1/2} U_nᵀ H₀
//!      (U_n, Λ the n leading eigenvectors and eigenvalues of H₀H₀ᵀ); the
//!      state matrix A = O↑⁺ O↓ (shift invariance) = Ψ M Ψ⁻¹, the modal row
//!      factors C_m = Ψ⁻¹ C (row j: mode j's c_j).  A change of mode j
//!      moves H by Δo_j c_jᵀ + o_j Δc_jᵀ, and Sᵀ o_j = 0: the residual
//!      Z = Sᵀ(H − H₀) of that change lies along c_j.  So Z's part in the
//!      row space of C, Z Cᵀ(CCᵀ)⁻¹ C = G C_m with G = Z Cᵀ(CCᵀ)⁻¹ Ψ, splits
//!      into the modes' terms Z_j = g_j c_jᵀ (a conjugate pair's two terms
//!      summed: 2 Re), and mode j's share of χ² is vec(Z_j)ᵀ Cov(ζ)⁺ ζ (as
//!      C7; the rest, Z's part outside the row space, is `unexplained`).
//!      Each mode is reported with its discrete eigenvalue μ_j: frequency
//!      arg μ_j / (2π lag_step) cycles per sample, damping −ln|μ_j| / |ln μ_j|.

use crate::error::{Error, Result};
use crate::modal::hankel::dot;
use crate::stats::{hotelling_survival, hotelling_upper_quantile};
use faer::linalg::solvers::DenseSolveCore;
use faer::{c64, Mat, Side};

/// The shape of the Hankel matrix (C1) and the model order (C2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct HankelShape {
    /// Block rows p (future lags).
    pub block_rows: usize,
    /// Block columns q (past lags).
    pub block_columns: usize,
    /// Model order n (2 × modes).
    pub order: usize,
}

impl HankelShape {
    /// The smallest square shape for a model of order `order` from
    /// `channels` channels: p = q = ⌈n/l⌉ + 1 (≥ 2) block rows, so that the
    /// null space has at least l dimensions.
    pub fn for_order(order: usize, channels: usize) -> HankelShape {
        let p = (order.div_ceil(channels.max(1)) + 1).max(2);
        HankelShape {
            block_rows: p,
            block_columns: p,
            order,
        }
    }
    /// Largest lag of (C1), p + q − 1.
    pub fn max_lag(&self) -> usize {
        self.block_rows + self.block_columns - 1
    }
}

/// Largest order a record's covariances are kept for by default
/// ([`max_lag_for`]): ten modes.
pub const DEFAULT_MAX_ORDER: usize = 20;

/// The lags a record must keep for orders up to `max_order` from `channels`.
pub fn max_lag_for(max_order: usize, channels: usize) -> usize {
    HankelShape::for_order(max_order, channels).max_lag()
}

/// Most channels whose covariances a record keeps for the test: l² entries
/// per lag and block (a year of hourly monitoring windows of 16 channels
/// holds about 100 MB of them); beyond, no change test.
pub const MAX_CHANNELS: usize = 16;

/// Settings of the test.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ChangeTestSettings {
    /// Blocks each record is cut into for Σ (C4).
    pub blocks_per_record: usize,
    /// False-alarm rate α of the threshold (C6).
    pub false_alarm_rate: f64,
}

impl Default for ChangeTestSettings {
    fn default() -> Self {
        ChangeTestSettings {
            blocks_per_record: 60,
            false_alarm_rate: 0.01,
        }
    }
}

/// What a record contributes to a test or to a reference: its normalised
/// output covariances at lags 1..=max_lag (C1), of the whole record and of
/// each block (C4).  A reference run stores these
/// (`change_reference/change_reference.parquet`), not S and Σ: the null space depends on
/// the union of the reference records and on the order chosen.
#[derive(Debug, Clone, PartialEq)]
pub struct CovarianceBlocks {
    pub channels: usize,
    pub max_lag: usize,
    /// Samples between consecutive lags.
    pub lag_step: usize,
    /// Samples of the record (the sum of the blocks').
    pub samples: usize,
    /// R_k / (tr R₀ / l) for k = 1..=max_lag, entry (k − 1)·l² + o·l + c.
    pub mean: Vec<f64>,
    /// Samples of each block.
    pub block_samples: Vec<usize>,
    /// Each block's mean channel variance over the record's (tr R₀,b / tr R₀;
    /// 1 for a stationary record): the weights of (C4') — an earthquake
    /// record's strong phase holds most of it in a few blocks.
    pub block_power: Vec<f64>,
    /// The same per block (empty once [`CovarianceBlocks::without_blocks`]).
    pub blocks: Vec<Vec<f64>>,
}

impl CovarianceBlocks {
    /// The same covariances at lags in steps of `lag_step` samples, a
    /// multiple of the record's own (lag i at the new step is lag
    /// i·lag_step/own of the record's); `None` when `lag_step` is not a
    /// multiple or no lag is left.  Two runs of one structure may decimate
    /// differently (each event's rate is chosen from its own content): a
    /// test between them uses the least common multiple of their steps.
    pub fn at_lag_step(&self, lag_step: usize) -> Option<CovarianceBlocks> {
        if lag_step == 0 || lag_step % self.lag_step != 0 {
            return None;
        }
        let factor = lag_step / self.lag_step;
        let max_lag = self.max_lag / factor;
        if max_lag == 0 {
            return None;
        }
        let l2 = self.channels * self.channels;
        let pick = |v: &[f64]| -> Vec<f64> {
            (1..=max_lag)
                .flat_map(|i| v[(i * factor - 1) * l2..i * factor * l2].iter().copied())
                .collect()
        };
        Some(CovarianceBlocks {
            channels: self.channels,
            max_lag,
            lag_step,
            samples: self.samples,
            mean: pick(&self.mean),
            block_samples: self.block_samples.clone(),
            block_power: self.block_power.clone(),
            blocks: self.blocks.iter().map(|b| pick(b)).collect(),
        })
    }

    /// The blocks' relative powers P_b (all 1 when not kept: a table
    /// written before they were).
    pub fn powers(&self) -> Vec<f64> {
        if self.block_power.len() == self.block_samples.len() && !self.block_power.is_empty() {
            self.block_power.clone()
        } else {
            vec![1.0; self.block_samples.len().max(1)]
        }
    }

    /// The record without its blocks (their powers kept, for C5'): enough
    /// to be tested, not to be a reference.
    pub fn without_blocks(mut self) -> Self {
        self.blocks = Vec::new();
        self
    }

    /// H of (C1) for `shape` from the covariances `lagged` (the record's
    /// mean or one block's), row-major (p·l) × (q·l).
    fn hankel(&self, lagged: &[f64], shape: HankelShape) -> Vec<f64> {
        let l = self.channels;
        let (rows, cols) = (shape.block_rows * l, shape.block_columns * l);
        (0..rows * cols)
            .map(|idx| {
                let (row, col) = (idx / cols, idx % cols);
                let (i, o) = (row / l, row % l);
                let (j, c) = (col / l, col % l);
                lagged[(i + j) * l * l + o * l + c]
            })
            .collect()
    }
}

/// (C1) of `signals` (channels of one record) at lags k·`lag_step` for
/// k = 1..=`max_lag`, whole and in `blocks` consecutive blocks (each
/// centred: a drifting offset is not structure); the record's H is the
/// samples-weighted mean of its blocks' (products across block boundaries
/// are left out alike in every record, reference or test).  A lag step s
/// gives the covariances of the record sampled every s samples (without
/// anti-aliasing, which covariances do not need as long as no two modes
/// alias onto each other): the identification's decimation factor, so the
/// lags span the periods of the modes of interest instead of the first
/// milliseconds.
pub fn covariance_blocks(
    signals: &[&[f64]],
    max_lag: usize,
    lag_step: usize,
    blocks: usize,
) -> Result<CovarianceBlocks> {
    let l = signals.len();
    let n = signals.iter().map(|s| s.len()).min().unwrap_or(0);
    let blocks = blocks.max(1);
    let lag_step = lag_step.max(1);
    let block_len = n / blocks;
    let longest = max_lag * lag_step;
    if l == 0 || max_lag == 0 || block_len < 20 * (longest + 1) {
        return Err(Error::numerical(format!(
            "change test: {n} samples in {blocks} blocks are too few for lags up to {longest} samples (each block needs at least {})",
            20 * (longest + 1)
        )));
    }
    let mut raw = Vec::with_capacity(blocks);
    let mut powers = Vec::with_capacity(blocks);
    let mut variance = 0.0;
    for b in 0..blocks {
        let centred: Vec<Vec<f64>> = signals
            .iter()
            .map(|s| {
                let part = &s[b * block_len..(b + 1) * block_len];
                let m = part.iter().sum::<f64>() / part.len() as f64;
                part.iter().map(|v| v - m).collect()
            })
            .collect();
        let block_variance = centred
            .iter()
            .map(|x| dot(x, x) / block_len as f64)
            .sum::<f64>()
            / l as f64;
        variance += block_variance / blocks as f64;
        // R_k[o, c] = Σ_t y_o[t + k] y_c[t] / (N − k), lag k = i·lag_step.
        let mut r = vec![0.0; max_lag * l * l];
        for i in 1..=max_lag {
            let k = i * lag_step;
            for o in 0..l {
                for c in 0..l {
                    r[(i - 1) * l * l + o * l + c] =
                        dot(&centred[o][k..], &centred[c][..block_len - k])
                            / (block_len - k) as f64;
                }
            }
        }
        powers.push(block_variance);
        raw.push(r);
    }
    if !(variance > 0.0 && variance.is_finite()) {
        return Err(Error::numerical(
            "change test: the record's channels have no variance",
        ));
    }
    for r in &mut raw {
        for v in r.iter_mut() {
            *v /= variance;
        }
    }
    let mut mean = vec![0.0; max_lag * l * l];
    for r in &raw {
        for (acc, v) in mean.iter_mut().zip(r) {
            *acc += v / blocks as f64;
        }
    }
    Ok(CovarianceBlocks {
        channels: l,
        max_lag,
        lag_step,
        samples: block_len * blocks,
        mean,
        block_samples: vec![block_len; blocks],
        block_power: powers.iter().map(|p| p / variance).collect(),
        blocks: raw,
    })
}

/// The reference state (C2, C4): H₀, its null space, and the residual
/// covariance's truncated inverse square root.
#[derive(Debug, Clone)]
pub struct ChangeReference {
    pub shape: HankelShape,
    pub channels: usize,
    pub lag_step: usize,
    /// H₀, row-major.
    reference_hankel: Vec<f64>,
    /// S, (p·l) × s.
    pub null_space: Mat<f64>,
    /// W (k × d) with Σ⁺ = WᵀW, Σ of (C4) truncated as in (C6).
    whitening: Mat<f64>,
    /// k of (C6).
    pub dof: usize,
    /// m of (C4).
    pub covariance_dof: usize,
    /// N_ref.
    pub samples: usize,
    /// κ of (C4'): the mean power² of the blocks Σ is estimated from.
    scatter_power: f64,
    /// κ of H₀'s estimation error: the records' κ weighted by their samples.
    reference_power: f64,
    /// (C8): per mode (one per conjugate pair), μ_j and the real
    /// `cols`-vectors Re c_j, Im c_j, and the row-space map Cᵀ(CCᵀ)⁻¹Ψ
    /// (cols × n, complex) restricted to the pair's column.
    modes: Vec<ModeFactor>,
}

/// One reference mode's pieces for (C8).
#[derive(Debug, Clone)]
struct ModeFactor {
    mu: c64,
    /// c_j (cols), complex.
    row: Vec<c64>,
    /// Column j of Cᵀ(CCᵀ)⁻¹Ψ (cols), complex: g_j = Z · this.
    map: Vec<c64>,
    /// A real eigenvalue: its term counts once, not as 2 Re.
    real: bool,
}

/// One mode's share of the statistic (C8).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ModeContribution {
    /// arg μ / (2π lag_step): cycles per sample of the record.
    pub frequency_per_sample: f64,
    pub damping_ratio: f64,
    pub contribution: f64,
}

/// (C8): the modal pieces of H₀ of order n (`evd` of H₀H₀ᵀ, ascending).
fn mode_factors(
    h0: &[f64],
    rows: usize,
    cols: usize,
    l: usize,
    n: usize,
    u: faer::MatRef<'_, f64>,
    lambda: &[f64],
) -> Vec<ModeFactor> {
    let lead: Vec<usize> = (rows - n..rows).rev().collect();
    if lead.iter().any(|&i| !(lambda[i] > 0.0)) {
        return Vec::new();
    }
    let o = Mat::<f64>::from_fn(rows, n, |r, k| u[(r, lead[k])] * lambda[lead[k]].powf(0.25));
    let c = Mat::<f64>::from_fn(n, cols, |k, j| {
        (0..rows)
            .map(|r| u[(r, lead[k])] * h0[r * cols + j])
            .sum::<f64>()
            / lambda[lead[k]].powf(0.25)
    });
    let up = o.subrows(0, rows - l).to_owned();
    let down = o.subrows(l, rows - l).to_owned();
    let a = match up.thin_svd() {
        Ok(svd) => {
            let sv = svd.S().column_vector();
            let smax = sv.iter().fold(0.0f64, |m, &v| m.max(v));
            let inv = Mat::<f64>::from_fn(n, n, |i, j| {
                if i == j && sv[i] > 1e-12 * smax {
                    1.0 / sv[i]
                } else {
                    0.0
                }
            });
            svd.V() * inv * svd.U().transpose() * &down
        }
        Err(_) => return Vec::new(),
    };
    let Ok(eig) = a.eigen() else {
        return Vec::new();
    };
    let mu = eig.S().column_vector();
    let psi = eig.U();
    let psi_inv = psi.partial_piv_lu().inverse();
    let cc = &c * c.transpose();
    let cc_inv = cc.partial_piv_lu().inverse();
    let finite = |v: f64| v.is_finite();
    if !(0..n).all(|i| (0..n).all(|j| finite(cc_inv[(i, j)]) && finite(psi_inv[(i, j)].re))) {
        return Vec::new();
    }
    let ct_cc = c.transpose() * cc_inv; // cols × n, real
    let mut out = Vec::new();
    for j in 0..n {
        let m = mu[j];
        if m.im < -1e-12 {
            continue; // the pair's other half
        }
        let row: Vec<c64> = (0..cols)
            .map(|x| {
                let mut acc = c64::new(0.0, 0.0);
                for k in 0..n {
                    acc += psi_inv[(j, k)] * c64::new(c[(k, x)], 0.0);
                }
                acc
            })
            .collect();
        let map: Vec<c64> = (0..cols)
            .map(|x| {
                let mut acc = c64::new(0.0, 0.0);
                for k in 0..n {
                    acc += c64::new(ct_cc[(x, k)], 0.0) * psi[(k, j)];
                }
                acc
            })
            .collect();
        out.push(ModeFactor {
            mu: m,
            row,
            map,
            real: m.im.abs() <= 1e-12,
        });
    }
    out
}

/// vec(Sᵀ X), column-major (index = column · s + null vector), of a row-major
/// `rows` × `cols` matrix.
fn residual(null_space: &Mat<f64>, x: &[f64], rows: usize, cols: usize) -> Vec<f64> {
    let s = null_space.ncols();
    let mut z = vec![0.0; s * cols];
    for c in 0..cols {
        for k in 0..s {
            z[c * s + k] = (0..rows)
                .map(|r| null_space[(r, k)] * x[r * cols + c])
                .sum();
        }
    }
    z
}

/// Builds the reference of order `shape.order` from one or several
/// records' blocks (of the same channels).
pub fn reference_from(records: &[CovarianceBlocks], shape: HankelShape) -> Result<ChangeReference> {
    let first = records
        .first()
        .ok_or_else(|| Error::usage("change test: the reference holds no record"))?;
    let l = first.channels;
    if records
        .iter()
        .any(|r| r.channels != l || r.lag_step != first.lag_step)
    {
        return Err(Error::usage(
            "change test: the reference records differ in their channels or lag step",
        ));
    }
    if let Some(r) = records.iter().find(|r| r.max_lag < shape.max_lag()) {
        return Err(Error::usage(format!(
            "change test: a reference record keeps lags up to {}, the Hankel shape needs {}",
            r.max_lag,
            shape.max_lag()
        )));
    }
    let (rows, cols) = (shape.block_rows * l, shape.block_columns * l);
    let n = shape.order;
    if n == 0 || n >= rows || n > cols {
        return Err(Error::usage(format!(
            "change test: model order {n} does not fit a {rows} × {cols} Hankel matrix"
        )));
    }
    let total: usize = records.iter().map(|r| r.samples).sum();
    let mut h0 = vec![0.0; rows * cols];
    for r in records {
        let w = r.samples as f64 / total.max(1) as f64;
        for (acc, v) in h0.iter_mut().zip(r.hankel(&r.mean, shape)) {
            *acc += w * v;
        }
    }
    let h0m = Mat::<f64>::from_fn(rows, cols, |i, j| h0[i * cols + j]);
    let gram = &h0m * h0m.transpose();
    let evd = gram
        .self_adjoint_eigen(Side::Lower)
        .map_err(|e| Error::numerical(format!("change test: eigenvectors of H₀H₀ᵀ: {e:?}")))?;
    // Eigenvalues ascending: the first rows − n eigenvectors span the null space.
    let s_dim = rows - n;
    let u = evd.U();
    let null_space = Mat::<f64>::from_fn(rows, s_dim, |i, j| u[(i, j)]);
    let gram_lambda: Vec<f64> = evd.S().column_vector().iter().copied().collect();
    let modes = mode_factors(&h0, rows, cols, l, n, u, &gram_lambda);
    let d = s_dim * cols;
    // Streamed, one block at a time: a long `track` training holds tens of
    // thousands of blocks.
    let s_ref = &null_space;
    let centred_blocks = records
        .iter()
        .filter(|r| r.blocks.len() >= 2)
        .flat_map(|r| {
            let mean = residual(s_ref, &r.hankel(&r.mean, shape), rows, cols);
            r.blocks.iter().zip(&r.block_samples).map(move |(b, &nb)| {
                let z = residual(s_ref, &r.hankel(b, shape), rows, cols);
                z.iter()
                    .zip(&mean)
                    .map(|(a, m)| (a - m) * (nb as f64).sqrt())
                    .collect()
            })
        });
    // (C4'): the blocks' scatter weighs each block by its power², so its
    // degrees of freedom are Kish's effective count, not blocks − 1.
    // Per record with a scatter: its blocks' powers and effective count.
    let scattered: Vec<(&CovarianceBlocks, Vec<f64>)> = records
        .iter()
        .filter(|r| r.blocks.len() >= 2)
        .map(|r| (r, r.powers()))
        .collect();
    let effective: f64 = scattered.iter().map(|(_, p)| effective_blocks(p)).sum();
    let dof = (effective - scattered.len() as f64).max(0.0).floor() as usize;
    if dof < 4 {
        let blocks: usize = records.iter().map(|r| r.blocks.len()).sum();
        return Err(Error::usage(format!(
            "change test: the reference's {blocks} blocks count as {effective:.1} (Eq. C4': their power² weights — an earthquake's strong phase fills few of them), {dof} degrees of freedom for the residual covariance where at least 4 are needed; the subspace test needs a long, steady excitation (ambient records, monitoring windows)"
        )));
    }
    let whitening = truncated_whitening(centred_blocks, d, dof)?;
    // κ of Σ (the mean power² of its blocks) and of H₀'s error.
    let all_powers: Vec<f64> = scattered
        .iter()
        .flat_map(|(_, p)| p.iter().copied())
        .collect();
    let scatter_power = mean_square(&all_powers);
    let reference_power = records
        .iter()
        .map(|r| r.samples as f64 / total.max(1) as f64 * mean_square(&r.powers()))
        .sum();
    Ok(ChangeReference {
        shape,
        channels: l,
        lag_step: first.lag_step,
        reference_hankel: h0,
        null_space,
        dof: whitening.nrows(),
        whitening,
        covariance_dof: dof,
        samples: total,
        scatter_power,
        reference_power,
        modes,
    })
}

/// Kish's effective number of blocks of a scatter whose terms are weighted
/// by power²: (Σ w)² / Σ w², w = P_b² (C4').
fn effective_blocks(powers: &[f64]) -> f64 {
    let weights: Vec<f64> = powers.iter().map(|p| p * p).collect();
    crate::stats::kish_effective_count(&weights)
}

/// κ = the mean of P_b² (1 for a stationary record; C4').
fn mean_square(powers: &[f64]) -> f64 {
    if powers.is_empty() {
        1.0
    } else {
        powers.iter().map(|p| p * p).sum::<f64>() / powers.len() as f64
    }
}

/// (C4, C6): from `centred` vectors of length `d` (a block's √N_b-scaled
/// deviation from its record's mean) with `dof` (≥ 4, the caller checks)
/// degrees of freedom, the covariance per sample Σ's W (k × d) with
/// Σ⁺ = WᵀW, truncated to the k largest eigenvalues (k ≤ dof/2,
/// λ > 10⁻¹⁰ λ_max).
fn truncated_whitening(
    centred: impl Iterator<Item = Vec<f64>>,
    d: usize,
    dof: usize,
) -> Result<Mat<f64>> {
    let mut covariance = Mat::<f64>::zeros(d, d);
    for y in centred {
        for j in 0..d {
            let yj = y[j];
            let col = covariance.col_mut(j);
            for (c, yi) in col.iter_mut().zip(&y) {
                *c += yi * yj;
            }
        }
    }
    let covariance = covariance * faer::Scale(1.0 / dof as f64);
    let evd = covariance
        .self_adjoint_eigen(Side::Lower)
        .map_err(|e| Error::numerical(format!("change test: eigenvalues of Σ: {e:?}")))?;
    let lambda: Vec<f64> = evd.S().column_vector().iter().copied().collect();
    let max = lambda.iter().fold(0.0f64, |a, &v| a.max(v));
    let keep: Vec<usize> = (0..d)
        .rev()
        .filter(|&i| lambda[i] > 1e-10 * max)
        .take(dof / 2)
        .collect();
    if keep.is_empty() {
        return Err(Error::numerical(
            "change test: the residual covariance is zero",
        ));
    }
    let u = evd.U();
    let whitening = Mat::<f64>::from_fn(keep.len(), d, |r, c| {
        u[(c, keep[r])] / lambda[keep[r]].sqrt()
    });
    Ok(whitening)
}

/// The outcome of one test (C6, C7).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ChangeTestResult {
    pub statistic: f64,
    pub threshold: f64,
    pub p_value: f64,
    pub dof: usize,
    pub covariance_dof: usize,
    pub false_alarm_rate: f64,
    /// statistic > threshold.
    pub changed: bool,
    /// Per channel (in the record's order): its share of the statistic (C7).
    pub channel_contributions: Vec<f64>,
    /// Per reference mode (ascending frequency): its share (C8).
    pub mode_contributions: Vec<ModeContribution>,
    /// The statistic less the modes' shares (C8): what no mode explains.
    pub unexplained_contribution: f64,
}

impl ChangeReference {
    /// The threshold of (C6) for the false-alarm rate `alpha`.
    pub fn threshold(&self, alpha: f64) -> Result<f64> {
        if !(alpha > 0.0 && alpha < 0.5) {
            return Err(Error::usage(format!(
                "change test: false-alarm rate {alpha} must lie in (0, 0.5)"
            )));
        }
        Ok(hotelling_upper_quantile(
            alpha,
            self.dof as f64,
            self.covariance_dof as f64,
        ))
    }

    /// Tests one record (C3, C5–C7) at the false-alarm rate `alpha`.
    pub fn test(&self, record: &CovarianceBlocks, alpha: f64) -> Result<ChangeTestResult> {
        if record.channels != self.channels
            || record.max_lag < self.shape.max_lag()
            || record.lag_step != self.lag_step
        {
            return Err(Error::usage(format!(
                "change test: the record has {} channels and lags up to {} (step {}), the reference {} channels and lags up to {} (step {})",
                record.channels,
                record.max_lag,
                record.lag_step,
                self.channels,
                self.shape.max_lag(),
                self.lag_step
            )));
        }
        let threshold = self.threshold(alpha)?;
        let l = self.channels;
        let (rows, cols) = (self.shape.block_rows * l, self.shape.block_columns * l);
        let h = record.hankel(&record.mean, self.shape);
        let centred: Vec<f64> = h
            .iter()
            .zip(&self.reference_hankel)
            .map(|(a, b)| a - b)
            .collect();
        let n = record.samples as f64;
        // (C5'): Cov ζ = (κ_test + κ_ref N/N_ref) / κ_Σ · Σ.
        let scale = (n * self.scatter_power
            / (mean_square(&record.powers()) + self.reference_power * n / self.samples as f64))
            .sqrt();
        let zeta: Vec<f64> = residual(&self.null_space, &centred, rows, cols)
            .into_iter()
            .map(|v| v * scale)
            .collect();
        let (k, d) = (self.dof, zeta.len());
        let w: Vec<f64> = (0..k)
            .map(|r| (0..d).map(|c| self.whitening[(r, c)] * zeta[c]).sum())
            .collect();
        let statistic: f64 = w.iter().map(|v| v * v).sum();
        let s = self.null_space.ncols();
        let mut channel_contributions = vec![0.0; l];
        // (Σ⁺ζ)_i = (Wᵀ W ζ)_i; column of H: i / s, its channel: column mod l.
        let pinv: Vec<f64> = (0..d)
            .map(|i| (0..k).map(|r| self.whitening[(r, i)] * w[r]).sum())
            .collect();
        for (i, z) in zeta.iter().enumerate() {
            channel_contributions[(i / s) % l] += z * pinv[i];
        }
        // (C8): Z = ζ as an s × cols matrix (index column · s + row).
        let mut mode_contributions: Vec<ModeContribution> = self
            .modes
            .iter()
            .map(|m| {
                let g: Vec<c64> = (0..s)
                    .map(|row| {
                        let mut acc = c64::new(0.0, 0.0);
                        for (x, mx) in m.map.iter().enumerate() {
                            acc += *mx * zeta[x * s + row];
                        }
                        acc
                    })
                    .collect();
                let factor = if m.real { 1.0 } else { 2.0 };
                let mut share = 0.0;
                for (x, cx) in m.row.iter().enumerate() {
                    for (row, gr) in g.iter().enumerate() {
                        share += factor * (*gr * *cx).re * pinv[x * s + row];
                    }
                }
                let ln = m.mu.ln();
                ModeContribution {
                    frequency_per_sample: ln.im.abs()
                        / (std::f64::consts::TAU * self.lag_step as f64),
                    damping_ratio: -ln.re / (ln.re * ln.re + ln.im * ln.im).sqrt(),
                    contribution: share,
                }
            })
            .collect();
        mode_contributions
            .sort_by(|a, b| a.frequency_per_sample.total_cmp(&b.frequency_per_sample));
        let explained: f64 = mode_contributions.iter().map(|m| m.contribution).sum();
        Ok(ChangeTestResult {
            statistic,
            threshold,
            p_value: hotelling_survival(statistic, k as f64, self.covariance_dof as f64),
            dof: k,
            covariance_dof: self.covariance_dof,
            false_alarm_rate: alpha,
            changed: statistic > threshold,
            channel_contributions,
            unexplained_contribution: statistic - explained,
            mode_contributions,
        })
    }
}
