//! Correlation and block-Hankel Gram matrices computed from the signals
//! directly, without ever forming the (rows × samples) Hankel matrices.
//!
//! Why: the LQ factor of a block-Hankel matrix H (the first step of SSI-DATA
//! and of the input–output subspace methods) equals the Cholesky factor of
//! its Gram matrix H Hᵀ, and H Hᵀ has shift structure:
//! G(s₁+1, s₂+1) = G(s₁, s₂) + x₁[j+s₁] x₂[j+s₂] − x₁[s₁] x₂[s₂].
//! Only the first row/column of every block needs full dot products, so a
//! record of N samples costs O(channels² · shifts · N) instead of the
//! O(rows² · N) of a Householder LQ on the 60 000-column matrix.

use rayon::prelude::*;

/// Dot product with four independent accumulators, so the compiler can keep
/// the reduction in SIMD registers (floating-point sums are not reassociated
/// automatically).
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f64; 4];
    let chunks = n / 4;
    for c in 0..chunks {
        let i = 4 * c;
        acc[0] += a[i] * b[i];
        acc[1] += a[i + 1] * b[i + 1];
        acc[2] += a[i + 2] * b[i + 2];
        acc[3] += a[i + 3] * b[i + 3];
    }
    let mut tail = 0.0;
    for i in 4 * chunks..n {
        tail += a[i] * b[i];
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// Dot products formed together by [`dots_sharing`].
const DOTS: usize = 4;

/// `dot(shared, others[k])` for each of up to [`DOTS`] slices no longer than
/// `shared`, in one pass: each sum has `dot`'s four accumulators, terms and
/// order (a product `x·y` is `y·x` exactly), so each result is `dot`'s bit
/// for bit; the passes over `shared` and the chains of additions of the
/// different sums overlap.  (The Gram products were the modal stage's time
/// on an hour of 64 channels; the covariances of SSI-COV, whose lags differ
/// in length, were 15 % of a 5-channel `modal`.)  Slices of different
/// lengths run together over their common whole chunks of four, then each
/// finishes alone in the same order.  Unused entries of the result are 0.
fn dots_sharing(shared: &[f64], others: &[&[f64]]) -> [f64; DOTS] {
    let mut out = [0.0; DOTS];
    if others.len() != DOTS || others.iter().any(|o| o.len() > shared.len()) {
        for (v, o) in out.iter_mut().zip(others) {
            *v = dot(shared, o);
        }
        return out;
    }
    let common = others.iter().map(|o| o.len() / 4).min().unwrap_or(0);
    let n = 4 * common;
    let (x, y0, y1, y2, y3) = (
        &shared[..n],
        &others[0][..n],
        &others[1][..n],
        &others[2][..n],
        &others[3][..n],
    );
    let mut acc = [[0.0f64; 4]; DOTS];
    for c in 0..common {
        let i = 4 * c;
        for j in 0..4 {
            let x = x[i + j];
            acc[0][j] += x * y0[i + j];
            acc[1][j] += x * y1[i + j];
            acc[2][j] += x * y2[i + j];
            acc[3][j] += x * y3[i + j];
        }
    }
    for ((v, a), y) in out.iter_mut().zip(&mut acc).zip(others) {
        // The chunks and tail `dot` would still add for this slice.
        let len = y.len();
        let chunks = len / 4;
        for c in common..chunks {
            let i = 4 * c;
            for j in 0..4 {
                a[j] += shared[i + j] * y[i + j];
            }
        }
        let mut tail = 0.0;
        for i in 4 * chunks..len {
            tail += shared[i] * y[i];
        }
        *v = (a[0] + a[1]) + (a[2] + a[3]) + tail;
    }
    out
}

/// One row of a block-Hankel matrix: `signal[k + shift]` for k = 0..columns.
#[derive(Debug, Clone, Copy)]
pub struct HankelRow {
    pub signal: usize,
    pub shift: usize,
}

/// Gram matrix G = H Hᵀ / columns of the block-Hankel matrix whose rows are
/// `rows` (row r holds `signals[rows[r].signal][k + rows[r].shift]`,
/// k = 0..columns).  Requires `shift + columns ≤ len` for every row.
/// Returned row-major, size rows.len()².
pub fn hankel_gram(signals: &[&[f64]], rows: &[HankelRow], columns: usize) -> Vec<f64> {
    let nr = rows.len();
    let n_sig = signals.len();
    let max_shift = rows.iter().map(|r| r.shift).max().unwrap_or(0);
    // base[(a, b, d)] for d = s_b − s_a ∈ [−max_shift, max_shift]:
    // Σ_k x_a[k + s_a] x_b[k + s_b] with min(s_a, s_b) = 0.
    let span = 2 * max_shift + 1;
    let mut base = vec![0.0; n_sig * n_sig * span];
    // Which (a, b, d) are needed; computing only those keeps the cost down.
    let mut needed = vec![false; n_sig * n_sig * span];
    for ra in rows {
        for rb in rows {
            let d = rb.shift as isize - ra.shift as isize + max_shift as isize;
            needed[(ra.signal * n_sig + rb.signal) * span + d as usize] = true;
        }
    }
    // Each needed product is one dot product, computed in parallel (each the
    // same sum whatever the threads).  (a, b, d) and (b, a, −d) multiply the
    // same pairs of samples in the same order: the second is copied from the
    // first, bit for bit.
    let split = |idx: usize| (idx / span / n_sig, idx / span % n_sig, idx % span);
    let mirror = |(a, b, d): (usize, usize, usize)| (b * n_sig + a) * span + (span - 1 - d);
    let canonical = |(a, b, d): (usize, usize, usize)| a < b || (a == b && d <= max_shift);
    // The products of one pair (a, b) at lags of one sign share a factor that
    // starts at sample 0 (x_a for lags ≥ 0, x_b for lags < 0): they are
    // computed [`DOTS`] at a time ([`dots_sharing`]), which reads the shared
    // factor once for all of them and overlaps their sums.  Each is still the
    // sum `dot` forms, bit for bit.
    let todo: Vec<usize> = (0..base.len())
        .filter(|&idx| {
            let abd = split(idx);
            canonical(abd) && (needed[idx] || needed[mirror(abd)])
        })
        .collect();
    let mut groups: Vec<&[usize]> = Vec::new();
    for same_pair in todo.chunk_by(|&i, &j| {
        let ((a, b, d), (a2, b2, d2)) = (split(i), split(j));
        (a, b) == (a2, b2) && (d >= max_shift) == (d2 >= max_shift)
    }) {
        groups.extend(same_pair.chunks(DOTS));
    }
    let values: Vec<[f64; DOTS]> = groups
        .par_iter()
        .map(|group| {
            let (a, b, _) = split(group[0]);
            let lags = group
                .iter()
                .map(|&idx| split(idx).2 as isize - max_shift as isize);
            let mut others = [&signals[a][..0]; DOTS];
            let shared = if split(group[0]).2 >= max_shift {
                for (o, lag) in others.iter_mut().zip(lags) {
                    *o = &signals[b][lag as usize..lag as usize + columns];
                }
                &signals[a][..columns]
            } else {
                for (o, lag) in others.iter_mut().zip(lags) {
                    *o = &signals[a][(-lag) as usize..(-lag) as usize + columns];
                }
                &signals[b][..columns]
            };
            dots_sharing(shared, &others[..group.len()])
        })
        .collect();
    for (group, values) in groups.iter().zip(&values) {
        for (&idx, &v) in group.iter().zip(values) {
            base[idx] = v;
        }
    }
    for idx in 0..base.len() {
        let abd = split(idx);
        if needed[idx] && !canonical(abd) {
            base[idx] = base[mirror(abd)];
        }
    }
    let mut g = vec![0.0; nr * nr];
    for (i, ra) in rows.iter().enumerate() {
        for (k, rb) in rows.iter().enumerate().skip(i) {
            let lag = rb.shift as isize - ra.shift as isize;
            let d = (lag + max_shift as isize) as usize;
            let mut value = base[(ra.signal * n_sig + rb.signal) * span + d];
            // Walk along the diagonal from the base position (min shift 0) to (s_a, s_b).
            let steps = ra.shift.min(rb.shift);
            let (xa, xb) = (signals[ra.signal], signals[rb.signal]);
            let (mut sa, mut sb) = (ra.shift - steps, rb.shift - steps);
            for _ in 0..steps {
                value += xa[columns + sa] * xb[columns + sb] - xa[sa] * xb[sb];
                sa += 1;
                sb += 1;
            }
            let v = value / columns as f64;
            g[i * nr + k] = v;
            g[k * nr + i] = v;
        }
    }
    g
}

/// Output cross-covariances R_k = (1/(N−k)) Σ_t y[t+k] y_ref[t]ᵀ for lags
/// k = 0..=max_lag; `result[k][o * refs.len() + r]`.
pub fn cross_covariances(outputs: &[&[f64]], refs: &[&[f64]], max_lag: usize) -> Vec<Vec<f64>> {
    let n = outputs
        .iter()
        .chain(refs)
        .map(|s| s.len())
        .min()
        .unwrap_or(0);
    let pairs = outputs.len() * refs.len();
    // One dot product per entry, `dot(y[k..], x)`; the lags of one pair
    // (o, r) share the factor x = refs[r] from sample 0, so they are formed
    // [`DOTS`] lags at a time ([`dots_sharing`]), each still `dot`'s sum bit
    // for bit.  Groups run in parallel (each the same sum whatever the threads).
    let lags: Vec<usize> = (0..=max_lag).collect();
    let groups: Vec<(usize, &[usize])> = (0..pairs)
        .flat_map(|i| lags.chunks(DOTS).map(move |ks| (i, ks)))
        .collect();
    let values: Vec<[f64; DOTS]> = groups
        .par_iter()
        .map(|&(i, ks)| {
            let (y, x) = (outputs[i / refs.len()], refs[i % refs.len()]);
            let mut others = [&y[..0]; DOTS];
            for (o, &k) in others.iter_mut().zip(ks) {
                let count = n.saturating_sub(k);
                *o = &y[k.min(n)..k.min(n) + count];
            }
            dots_sharing(&x[..n], &others[..ks.len()])
        })
        .collect();
    let mut result = vec![vec![0.0; pairs]; max_lag + 1];
    for (&(i, ks), values) in groups.iter().zip(&values) {
        for (&k, &v) in ks.iter().zip(values) {
            let count = n.saturating_sub(k);
            result[k][i] = if count == 0 { 0.0 } else { v / count as f64 };
        }
    }
    result
}
