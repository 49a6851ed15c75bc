//! Distribution functions of the statistical tests (generic special functions,
//! no crate in the tree provides them): the F distribution's survival function
//! through the regularised incomplete beta function (central and non-central
//! Hotelling's T², Eq. E3 of docs/statistics.md), and ln Γ; the
//! least-squares fit with its prediction interval ([`LinearFit`]).

// `!(x > 0.0)` checks deliberately reject NaN as well.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

/// P(F > f) for F ~ F(d1, d2): I_{d2/(d2 + d1 f)}(d2/2, d1/2).
pub fn f_survival(f: f64, d1: f64, d2: f64) -> f64 {
    if !(f > 0.0) {
        return 1.0;
    }
    if f.is_infinite() {
        return 0.0;
    }
    regularized_incomplete_beta(d2 / (d2 + d1 * f), 0.5 * d2, 0.5 * d1)
}

/// ln Γ(x), x > 0 (Lanczos approximation, g = 7, 9 terms; |rel. error| < 1e-14).
pub fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Γ(x)Γ(1 − x) = π / sin(πx).
        return (std::f64::consts::PI / (std::f64::consts::PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = G[0];
    let t = x + 7.5;
    for (i, g) in G.iter().enumerate().skip(1) {
        a += g / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised incomplete beta I_x(a, b) by its continued fraction (modified
/// Lentz), using the symmetry I_x(a, b) = 1 − I_{1−x}(b, a) for convergence.
/// A standard special function; no crate in the tree provides it.
pub fn regularized_incomplete_beta(x: f64, a: f64, b: f64) -> f64 {
    if !(x > 0.0) {
        return 0.0;
    }
    if !(x < 1.0) {
        return 1.0;
    }
    let ln_front = ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln();
    if x > (a + 1.0) / (a + b + 2.0) {
        return 1.0 - regularized_incomplete_beta(1.0 - x, b, a);
    }
    const TINY: f64 = 1e-300;
    let mut c = 1.0;
    let mut d = 1.0 - (a + b) * x / (a + 1.0);
    if d.abs() < TINY {
        d = TINY;
    }
    d = 1.0 / d;
    let mut h = d;
    for m in 1..500 {
        let m = m as f64;
        let even = m * (b - m) * x / ((a + 2.0 * m - 1.0) * (a + 2.0 * m));
        d = 1.0 + even * d;
        d = if d.abs() < TINY { TINY } else { d };
        c = 1.0 + even / c;
        c = if c.abs() < TINY { TINY } else { c };
        d = 1.0 / d;
        h *= d * c;
        let odd = -(a + m) * (a + b + m) * x / ((a + 2.0 * m) * (a + 2.0 * m + 1.0));
        d = 1.0 + odd * d;
        d = if d.abs() < TINY { TINY } else { d };
        c = 1.0 + odd / c;
        c = if c.abs() < TINY { TINY } else { c };
        d = 1.0 / d;
        let step = d * c;
        h *= step;
        if (step - 1.0).abs() < 1e-15 {
            break;
        }
    }
    (ln_front.exp() * h / a).clamp(0.0, 1.0)
}

/// Regularised upper incomplete gamma Q(a, x) = Γ(a, x)/Γ(a), a > 0, x ≥ 0:
/// the series of P = 1 − Q for x < a + 1, otherwise the continued fraction
/// of Q (modified Lentz) — the standard split (Press et al., *Numerical
/// Recipes*, 3rd ed., §6.2), each converging fast on its side.
pub fn regularized_upper_gamma(a: f64, x: f64) -> f64 {
    if !(a > 0.0) || x.is_nan() {
        return f64::NAN;
    }
    if !(x > 0.0) {
        return 1.0;
    }
    if x.is_infinite() {
        return 0.0;
    }
    let ln_front = a * x.ln() - x - ln_gamma(a);
    if x < a + 1.0 {
        // P(a, x) = e^{−x} x^a / Γ(a + 1) · Σ_n x^n / ((a+1)…(a+n)).
        let (mut term, mut sum, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..1000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        return (1.0 - sum * ln_front.exp()).clamp(0.0, 1.0);
    }
    const TINY: f64 = 1e-300;
    let mut b = x + 1.0 - a;
    let mut c = 1.0 / TINY;
    let mut d = 1.0 / b;
    let mut h = d;
    for i in 1..1000 {
        let an = -(i as f64) * (i as f64 - a);
        b += 2.0;
        d = an * d + b;
        d = if d.abs() < TINY { TINY } else { d };
        c = b + an / c;
        c = if c.abs() < TINY { TINY } else { c };
        d = 1.0 / d;
        let step = d * c;
        h *= step;
        if (step - 1.0).abs() < 1e-16 {
            break;
        }
    }
    (ln_front.exp() * h).clamp(0.0, 1.0)
}

/// P(X > x) for X ~ χ²(k): Q(k/2, x/2).
pub fn chi2_survival(x: f64, k: f64) -> f64 {
    regularized_upper_gamma(0.5 * k, 0.5 * x)
}

/// Upper quantile of χ²(k): the x with P(X > x) = `tail` (0 < tail < 1),
/// by bisection (the survival function is monotone).
pub fn chi2_upper_quantile(tail: f64, k: f64) -> f64 {
    if !(tail > 0.0 && tail < 1.0 && k > 0.0) {
        return f64::NAN;
    }
    upper_quantile_by_bisection(tail, |x| chi2_survival(x, k))
}

/// P(T² > t2) for Hotelling's T² of a k-dimensional mean whose covariance
/// was estimated with m degrees of freedom (Gaussian data, zero mean):
/// (m − k + 1)/(m k) · T² ~ F(k, m − k + 1) (Anderson, *An Introduction to
/// Multivariate Statistical Analysis*, 3rd ed., §5.2); tends to χ²(k) as
/// m → ∞.  NaN when m < k.
pub fn hotelling_survival(t2: f64, k: f64, m: f64) -> f64 {
    if !(k > 0.0 && m >= k) {
        return f64::NAN;
    }
    let d2 = m - k + 1.0;
    f_survival(t2 * d2 / (m * k), k, d2)
}

/// The T² with [`hotelling_survival`] = `tail`.
pub fn hotelling_upper_quantile(tail: f64, k: f64, m: f64) -> f64 {
    if !(tail > 0.0 && tail < 1.0 && k > 0.0 && m >= k) {
        return f64::NAN;
    }
    upper_quantile_by_bisection(tail, |t| hotelling_survival(t, k, m))
}

/// P(T² > t2) for a non-central Hotelling's T²: the k-dimensional mean has
/// non-centrality `lambda` (= μᵀΣ⁻¹μ scaled as T² is), the covariance
/// was estimated with m degrees of freedom: (m − k + 1)/(m k) · T² ~ the
/// non-central F(k, m − k + 1, λ), whose survival is the Poisson(λ/2)
/// mixture Σ_j P(j) P(F(k + 2j, m − k + 1) > f k/(k + 2j)) (Johnson, Kotz &
/// Balakrishnan, *Continuous Univariate Distributions* 2, ch. 30).  Equals
/// [`hotelling_survival`] at λ = 0.  NaN when m < k or λ < 0.
pub fn noncentral_hotelling_survival(t2: f64, k: f64, m: f64, lambda: f64) -> f64 {
    if !(k > 0.0 && m >= k && lambda >= 0.0) {
        return f64::NAN;
    }
    if lambda == 0.0 {
        return hotelling_survival(t2, k, m);
    }
    let d2 = m - k + 1.0;
    let f = t2 * d2 / (m * k);
    let half = 0.5 * lambda;
    // Sum the Poisson weights from j = 0 until the remaining mass < 1e-15.
    let (mut total, mut mass) = (0.0, 0.0);
    let mut weight = (-half).exp();
    let mut j = 0.0;
    while 1.0 - mass > 1e-13 && j < 10_000.0 {
        if weight > 0.0 {
            total += weight * f_survival(f * k / (k + 2.0 * j), k + 2.0 * j, d2);
        }
        mass += weight;
        j += 1.0;
        weight *= half / j;
        if weight == 0.0 && j > half {
            break;
        }
    }
    // Large λ: e^{−λ/2} underflows; the mixture from its mode (log weights).
    if mass < 0.5 {
        let mode = half.floor();
        let ln_w = |j: f64| j * half.ln() - half - ln_gamma(j + 1.0);
        let (mut total, mut mass) = (0.0, 0.0);
        let lo = (mode - 40.0 * half.sqrt() - 40.0).max(0.0);
        let hi = mode + 40.0 * half.sqrt() + 40.0;
        let mut j = lo.floor();
        while j <= hi {
            let w = ln_w(j).exp();
            total += w * f_survival(f * k / (k + 2.0 * j), k + 2.0 * j, d2);
            mass += w;
            j += 1.0;
        }
        return (total / mass).clamp(0.0, 1.0);
    }
    total.clamp(0.0, 1.0)
}

/// The T² with [`noncentral_hotelling_survival`] = `tail`: bracketed by
/// the central quantile c (below) and (√c + √λ)² (above, the triangle
/// inequality; doubled until it brackets), then the Illinois variant of
/// regula falsi on ln P(T² > t) − ln tail, nearly linear in the tail (a
/// few survival evaluations where bisection needs ~45), to a relative 10⁻¹⁰.
pub fn noncentral_hotelling_upper_quantile(tail: f64, k: f64, m: f64, lambda: f64) -> f64 {
    if !(tail > 0.0 && tail < 1.0 && k > 0.0 && m >= k && lambda >= 0.0) {
        return f64::NAN;
    }
    let central = hotelling_upper_quantile(tail, k, m);
    if lambda == 0.0 {
        return central;
    }
    let g = |t: f64| {
        noncentral_hotelling_survival(t, k, m, lambda)
            .max(1e-300)
            .ln()
            - tail.ln()
    };
    let (mut lo, mut hi) = (central, (central.sqrt() + lambda.sqrt()).powi(2));
    let (mut g_lo, mut g_hi) = (g(lo), g(hi));
    while g_hi > 0.0 && hi < 1e12 {
        lo = hi;
        g_lo = g_hi;
        hi *= 2.0;
        g_hi = g(hi);
    }
    if g_lo <= 0.0 {
        return lo;
    }
    let mut side = 0;
    for _ in 0..200 {
        let t = (lo * g_hi - hi * g_lo) / (g_hi - g_lo);
        let gt = g(t);
        if gt > 0.0 {
            lo = t;
            g_lo = gt;
            if side == -1 {
                g_hi *= 0.5;
            }
            side = -1;
        } else {
            hi = t;
            g_hi = gt;
            if side == 1 {
                g_lo *= 0.5;
            }
            side = 1;
        }
        if hi - lo < 1e-10 * hi || gt.abs() < 1e-12 {
            return t;
        }
    }
    0.5 * (lo + hi)
}

/// The x ≥ 0 with `survival(x)` = `tail`, for a decreasing `survival`: the
/// upper end doubled from 1 until it brackets (at most 10¹²), then bisection
/// of [0, upper] to a relative 10⁻¹².
fn upper_quantile_by_bisection(tail: f64, survival: impl Fn(f64) -> f64) -> f64 {
    let (mut lo, mut hi) = (0.0, 1.0);
    while survival(hi) > tail && hi < 1e12 {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if survival(mid) > tail {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo < 1e-12 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// Upper quantile of Student's t distribution with `nu` degrees of freedom:
/// the t with P(T > t) = `tail` (0 < tail < ½), from P(T > t) =
/// ½ I_{ν/(ν+t²)}(ν/2, ½) by bisection (the tail is monotone in t).
pub fn student_t_upper_quantile(tail: f64, nu: f64) -> f64 {
    if !(tail > 0.0 && tail < 0.5 && nu > 0.0) {
        return f64::NAN;
    }
    upper_quantile_by_bisection(tail, |t| {
        0.5 * regularized_incomplete_beta(nu / (nu + t * t), 0.5 * nu, 0.5)
    })
}

/// Kish's effective number of terms of a sum weighted by `weights`,
/// (Σ w)² / Σ w²: n for equal weights, 1 when one term carries all.  The
/// degrees of freedom of a scatter of blocks whose errors have unequal
/// variances w follow from it (Satterthwaite): the change test's Eq. C4'
/// (w = block power²) and the modal σ's Eq. S8' (docs/statistics.md).
/// 0 when the weights are all zero or empty.
pub fn kish_effective_count(weights: &[f64]) -> f64 {
    let (sum, sum_sq) = weights
        .iter()
        .fold((0.0, 0.0), |(a, b), w| (a + w, b + w * w));
    if sum_sq > 0.0 {
        sum * sum / sum_sq
    } else {
        0.0
    }
}

/// Median of `values` (reordered in place): the middle element, the upper
/// of the two middle ones for an even count; 0 when empty.
pub fn median_in_place(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let mid = values.len() / 2;
    values.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    values[mid]
}

/// Φ(x), the standard normal distribution function, as ½ erfc(−x/√2) with
/// erfc from the Chebyshev fit of Numerical Recipes (Press et al., 3rd ed.,
/// §6.2.2, `erfccheb`-style; |relative error| < 1.2e-7 everywhere), enough
/// for damage-state probabilities shown to three decimals.
pub fn standard_normal_cdf(x: f64) -> f64 {
    if x.is_nan() {
        return f64::NAN;
    }
    0.5 * erfc(-x / std::f64::consts::SQRT_2)
}

/// Complementary error function (see [`standard_normal_cdf`]).
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * poly.exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

/// An ordinary least-squares fit y = X β + ε, ε ~ N(0, σ²), with what its
/// prediction interval needs (e.g. Montgomery, Peck & Vining, *Introduction
/// to Linear Regression Analysis*, §3.5):
/// β̂ = (XᵀX)⁻¹ Xᵀ y, s² = ‖y − X β̂‖² / (n − p), and for a new x₀ the
/// two-sided interval ŷ₀ ± t_{(1+c)/2, n−p} · s · √(1 + x₀ᵀ (XᵀX)⁻¹ x₀).
/// The one home of this regression: the monitoring band (docs/monitoring.md
/// Eqs. M1–M3) and the amplitude dependence of a structure's history
/// (docs/history.md) both use it.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearFit {
    /// β̂, in the order of the regressors (the columns of X).
    pub coefficients: Vec<f64>,
    /// Residual standard deviation s.
    pub residual_std: f64,
    /// Residual sum of squares ‖y − X β̂‖².
    pub rss: f64,
    /// Degrees of freedom n − p.
    pub dof: usize,
    /// (XᵀX)⁻¹, row-major p × p.
    pub xtx_inverse: Vec<Vec<f64>>,
}

impl LinearFit {
    /// Fits `y` on the rows of `x` (each of the same length p); `None` when
    /// n ≤ p, when a value is not finite or when XᵀX is singular.
    pub fn fit(x: &[Vec<f64>], y: &[f64]) -> Option<LinearFit> {
        let n = y.len();
        let p = x.first()?.len();
        if n != x.len() || n <= p || p == 0 {
            return None;
        }
        if x.iter()
            .any(|r| r.len() != p || r.iter().any(|v| !v.is_finite()))
            || y.iter().any(|v| !v.is_finite())
        {
            return None;
        }
        let xtx =
            nalgebra::DMatrix::<f64>::from_fn(p, p, |i, j| x.iter().map(|r| r[i] * r[j]).sum());
        let inv = xtx.try_inverse()?;
        let xty: Vec<f64> = (0..p)
            .map(|i| x.iter().zip(y).map(|(r, v)| r[i] * v).sum())
            .collect();
        let beta: Vec<f64> = (0..p)
            .map(|i| (0..p).map(|j| inv[(i, j)] * xty[j]).sum())
            .collect();
        let rss: f64 = x
            .iter()
            .zip(y)
            .map(|(r, v)| (v - dot(r, &beta)).powi(2))
            .sum();
        let dof = n - p;
        Some(LinearFit {
            coefficients: beta,
            residual_std: (rss / dof as f64).sqrt(),
            rss,
            dof,
            xtx_inverse: (0..p)
                .map(|i| (0..p).map(|j| inv[(i, j)]).collect())
                .collect(),
        })
    }

    /// ŷ₀ = x₀ᵀ β̂.
    pub fn predict(&self, x0: &[f64]) -> f64 {
        dot(x0, &self.coefficients)
    }

    /// Leverage of a new point, x₀ᵀ (XᵀX)⁻¹ x₀.
    pub fn leverage(&self, x0: &[f64]) -> f64 {
        (0..x0.len())
            .map(|i| {
                (0..x0.len())
                    .map(|j| x0[i] * self.xtx_inverse[i][j] * x0[j])
                    .sum::<f64>()
            })
            .sum()
    }

    /// t_{(1+confidence)/2, n−p}.
    pub fn t_quantile(&self, confidence: f64) -> f64 {
        student_t_upper_quantile(0.5 * (1.0 - confidence), self.dof as f64)
    }

    /// Half width of the prediction interval at x₀ for the quantile `t`
    /// ([`LinearFit::t_quantile`]): t · s · √(1 + x₀ᵀ (XᵀX)⁻¹ x₀).
    pub fn prediction_half_width(&self, x0: &[f64], t: f64) -> f64 {
        t * self.residual_std * (1.0 + self.leverage(x0)).sqrt()
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
