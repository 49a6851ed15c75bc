//! Significance of the hysteretic terms: the F-test of the full Bouc-Wen model
//! against the nested linear model of the same DoF (METHODS.md §4).

use crate::stats::f_survival;

/// F-test of the hysteretic columns (β, γ and the exponent N) against the
/// nested linear model (the same K0, K0·δ columns, hysteretic columns dropped),
/// both fitted to the same weighted target (Eq. 19–20 at t = te):
///   F = [(J_lin − J) / q] / [J / (n_eff − p)],  q = 3 (β, γ, N), p = unknowns + 1,
/// with p-value from the F(q, n_eff − p) distribution. The residuals of the
/// time–frequency problem are correlated within one STFT window, so the
/// effective number of independent samples is taken as the number of
/// non-overlapping windows in the record, n_eff = ⌊n / window_len⌋ (≈ frames/2
/// at 50 % overlap) — a conservative count (fewer samples, larger p-value).
#[derive(Debug, Clone, PartialEq)]
pub struct Significance {
    /// J of the nested linear model.
    pub linear_cost: f64,
    pub f_statistic: f64,
    pub numerator_dof: usize,
    pub denominator_dof: usize,
    pub effective_samples: usize,
    pub p_value: f64,
}

/// F-test of the hysteretic columns (see [`Significance`]); `unknowns` = p
/// counts every fitted quantity of the full model including N.
pub fn hysteresis_significance(
    linear_cost: f64,
    full_cost: f64,
    unknowns: usize,
    effective_samples: usize,
) -> Significance {
    let q = 3usize;
    let d2 = effective_samples.saturating_sub(unknowns);
    let (f, p_value) = if d2 == 0 {
        (f64::NAN, 1.0)
    } else if full_cost > 0.0 {
        let f = ((linear_cost - full_cost).max(0.0) / q as f64) / (full_cost / d2 as f64);
        (f, f_survival(f, q as f64, d2 as f64))
    } else if linear_cost > 0.0 {
        (f64::INFINITY, 0.0)
    } else {
        (f64::NAN, 1.0)
    };
    Significance {
        linear_cost,
        f_statistic: f,
        numerator_dof: q,
        denominator_dof: d2,
        effective_samples,
        p_value,
    }
}
