//! Baseline operations on a uniformly sampled signal: mean removal, linear
//! and polynomial detrending by least squares, and the cosine (Tukey) taper
//! (METHODS §1: "mean (or linear) removal; cosine taper").

use crate::error::{Error, Result};

/// Subtracts the arithmetic mean in place; returns the mean removed.
pub fn remove_mean(data: &mut [f64]) -> f64 {
    if data.is_empty() {
        return 0.0;
    }
    let mean = data.iter().sum::<f64>() / data.len() as f64;
    data.iter_mut().for_each(|v| *v -= mean);
    mean
}

/// Legendre polynomials P_0..P_order at x ∈ [−1, 1] (Bonnet recurrence).
fn legendre_values(x: f64, order: usize, out: &mut [f64]) {
    out[0] = 1.0;
    if order >= 1 {
        out[1] = x;
    }
    for k in 1..order {
        let kf = k as f64;
        out[k + 1] = ((2.0 * kf + 1.0) * x * out[k] - kf * out[k - 1]) / (kf + 1.0);
    }
}

/// Samples whose Legendre values are computed side by side: the same
/// operations per sample, in vector registers (the recurrence's divisions,
/// one chain per sample, were most of the polynomial drift control's time).
const LANES: usize = 8;

/// [`legendre_values`] at the scaled times of samples `start..start + LANES`
/// of n (`out[k][l]`: P_k at sample start + l; lanes past the end repeat the
/// last sample).  Each lane's value is `legendre_values`'s, bit for bit.
fn legendre_block(start: usize, n: usize, order: usize, out: &mut [[f64; LANES]]) {
    let x: [f64; LANES] =
        std::array::from_fn(|l| scaled_time((start + l).min(n.saturating_sub(1)), n));
    out[0] = [1.0; LANES];
    if order >= 1 {
        out[1] = x;
    }
    for k in 1..order {
        let kf = k as f64;
        let (p, q) = (out[k], out[k - 1]);
        out[k + 1] =
            std::array::from_fn(|l| ((2.0 * kf + 1.0) * x[l] * p[l] - kf * q[l]) / (kf + 1.0));
    }
}

/// Maps sample index i of n to t ∈ [−1, 1].
fn scaled_time(i: usize, n: usize) -> f64 {
    if n <= 1 {
        0.0
    } else {
        2.0 * i as f64 / (n - 1) as f64 - 1.0
    }
}

/// Least-squares polynomial of degree `order` fitted to `data` against
/// scaled time t ∈ [−1, 1], in the Legendre basis (near-orthogonal on a
/// uniform grid, so the normal equations are well conditioned; solved by
/// Gaussian elimination with partial pivoting). Returns the Legendre
/// coefficients.
pub fn fit_polynomial(data: &[f64], order: usize) -> Result<Vec<f64>> {
    let mut fit = PolynomialFit::new(data.len(), order)?;
    for &y in data {
        fit.push(y);
    }
    fit.solve()
}

/// [`fit_polynomial`] a sample at a time (the same sums in the same order,
/// so the same coefficients): for a series formed as it goes by and never
/// held, such as the displacement whose drift polynomial the integration
/// needs before it forms the displacement (`integrate`).
pub struct PolynomialFit {
    n: usize,
    order: usize,
    gram: Vec<f64>,
    rhs: Vec<f64>,
    basis: Vec<f64>,
    /// Index of the next sample.
    next: usize,
}

impl PolynomialFit {
    /// A fit of degree `order` to `n` samples (at least `order + 1`).
    pub fn new(n: usize, order: usize) -> Result<Self> {
        let m = order + 1;
        if n < m {
            return Err(Error::numerical(format!(
                "polynomial of order {order} needs at least {m} samples, got {n}"
            )));
        }
        Ok(PolynomialFit {
            n,
            order,
            gram: vec![0.0; m * m],
            rhs: vec![0.0; m],
            basis: vec![0.0; m],
            next: 0,
        })
    }

    /// The next sample.
    #[inline]
    pub fn push(&mut self, y: f64) {
        let m = self.order + 1;
        legendre_values(scaled_time(self.next, self.n), self.order, &mut self.basis);
        for r in 0..m {
            self.rhs[r] += self.basis[r] * y;
            for c in 0..=r {
                self.gram[r * m + c] += self.basis[r] * self.basis[c];
            }
        }
        self.next += 1;
    }

    /// The Legendre coefficients (every one of the `n` samples pushed).
    pub fn solve(mut self) -> Result<Vec<f64>> {
        if self.next != self.n {
            return Err(Error::numerical(format!(
                "polynomial fit given {} of its {} samples",
                self.next, self.n
            )));
        }
        let m = self.order + 1;
        for r in 0..m {
            for c in r + 1..m {
                self.gram[r * m + c] = self.gram[c * m + r];
            }
        }
        solve_dense(&mut self.gram, &mut self.rhs, m)?;
        Ok(self.rhs)
    }
}

/// Values of a Legendre-basis polynomial (from `fit_polynomial`) on the n-sample grid.
pub fn evaluate_polynomial(coefficients: &[f64], n: usize) -> Vec<f64> {
    if coefficients.is_empty() {
        return vec![0.0; n];
    }
    let order = coefficients.len() - 1;
    let mut basis = vec![0.0; order + 1];
    (0..n)
        .map(|i| {
            legendre_values(scaled_time(i, n), order, &mut basis);
            basis.iter().zip(coefficients).map(|(b, c)| b * c).sum()
        })
        .collect()
}

/// Values and first and second derivatives with respect to the scaled time
/// t ∈ [−1, 1] of a Legendre-basis polynomial on the n-sample grid
/// (derivative recurrences P'_{k+1} = P'_{k−1} + (2k+1) P_k and
/// P''_{k+1} = P''_{k−1} + (2k+1) P'_k).
pub fn evaluate_polynomial_with_derivatives(coefficients: &[f64], n: usize) -> [Vec<f64>; 3] {
    let mut out = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    for_each_polynomial_value(coefficients, n, |i, v, d1, d2| {
        out[0][i] = v;
        out[1][i] = d1;
        out[2][i] = d2;
    });
    out
}

/// [`evaluate_polynomial_with_derivatives`] a sample at a time: `each(i,
/// value, first, second)` for i = 0..n, without arrays of n values (a day
/// at 200 Hz is 17 M samples).
pub fn for_each_polynomial_value(
    coefficients: &[f64],
    n: usize,
    mut each: impl FnMut(usize, f64, f64, f64),
) {
    if coefficients.is_empty() {
        for i in 0..n {
            each(i, 0.0, 0.0, 0.0);
        }
        return;
    }
    let order = coefficients.len() - 1;
    let mut p = vec![[0.0; LANES]; order + 1];
    let mut dp = vec![[0.0; LANES]; order + 1];
    let mut ddp = vec![[0.0; LANES]; order + 1];
    for start in (0..n).step_by(LANES) {
        legendre_block(start, n, order, &mut p);
        for k in 0..=order {
            let f = (2 * k).saturating_sub(1) as f64;
            dp[k] = std::array::from_fn(|l| match k {
                0 => 0.0,
                1 => 1.0,
                _ => dp[k - 2][l] + f * p[k - 1][l],
            });
            ddp[k] = std::array::from_fn(|l| match k {
                0 | 1 => 0.0,
                _ => ddp[k - 2][l] + f * dp[k - 1][l],
            });
        }
        // Each sum as `Iterator::sum` forms it, sample by sample in order.
        let sum = |b: &[[f64; LANES]], l: usize| -> f64 {
            b.iter().zip(coefficients).map(|(b, c)| b[l] * c).sum()
        };
        for l in 0..LANES.min(n - start) {
            each(start + l, sum(&p, l), sum(&dp, l), sum(&ddp, l));
        }
    }
}

/// Solves A x = b (A m×m row-major, overwritten; x returned in b).
fn solve_dense(a: &mut [f64], b: &mut [f64], m: usize) -> Result<()> {
    for col in 0..m {
        let pivot = (col..m)
            .max_by(|&i, &j| a[i * m + col].abs().total_cmp(&a[j * m + col].abs()))
            .unwrap_or(col);
        if a[pivot * m + col].abs() < 1e-300 {
            return Err(Error::numerical(
                "polynomial baseline: singular normal equations",
            ));
        }
        if pivot != col {
            for c in 0..m {
                a.swap(pivot * m + c, col * m + c);
            }
            b.swap(pivot, col);
        }
        for r in col + 1..m {
            let f = a[r * m + col] / a[col * m + col];
            for c in col..m {
                a[r * m + c] -= f * a[col * m + c];
            }
            b[r] -= f * b[col];
        }
    }
    for r in (0..m).rev() {
        let mut s = b[r];
        for c in r + 1..m {
            s -= a[r * m + c] * b[c];
        }
        b[r] = s / a[r * m + r];
    }
    Ok(())
}

/// Subtracts the least-squares polynomial of degree `order` (0 = mean,
/// 1 = linear trend) in place; returns the removed baseline's Legendre
/// coefficients.
pub fn remove_polynomial(data: &mut [f64], order: usize) -> Result<Vec<f64>> {
    let coefficients = fit_polynomial(data, order)?;
    let baseline = evaluate_polynomial(&coefficients, data.len());
    data.iter_mut().zip(&baseline).for_each(|(v, b)| *v -= b);
    Ok(coefficients)
}

/// Linear detrend (least-squares straight line removed).
pub fn remove_linear_trend(data: &mut [f64]) -> Result<Vec<f64>> {
    remove_polynomial(data, 1)
}

/// Cosine (Tukey) taper applied in place: the first and the last
/// `fraction · n` samples (each end) are multiplied by the half-cosine ramp
/// w = ½(1 − cos(π k / m)), k = 0..m−1, mirrored at the end; the middle is
/// untouched. `fraction` in [0, 0.5].
pub fn cosine_taper(data: &mut [f64], fraction: f64) -> Result<usize> {
    if !(0.0..=0.5).contains(&fraction) {
        return Err(Error::usage(format!(
            "taper fraction must be within [0, 0.5] of the record at each end, got {fraction}"
        )));
    }
    let n = data.len();
    let m = ((fraction * n as f64).round() as usize).min(n / 2);
    for k in 0..m {
        let w = 0.5 * (1.0 - (std::f64::consts::PI * k as f64 / m as f64).cos());
        data[k] *= w;
        data[n - 1 - k] *= w;
    }
    Ok(m)
}
