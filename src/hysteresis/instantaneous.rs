//! Instantaneous (cumulative, t_e → t) estimates of one DoF and their
//! stability over the informative frames (METHODS.md §4: the estimates at
//! earlier frames of Eq. 19–20; model-adequacy indicator).

use crate::error::{Error, Result};

use super::basis::{DofParameters, DofProblem};
use super::exponent_search::DofEngine;
use super::settings::IdentifySettings;
use super::stft::StftLayout;

/// One instantaneous (cumulative, t_e → t) estimate of a DoF.
#[derive(Debug, Clone, PartialEq)]
pub struct InstantaneousEstimate {
    /// Frame centre time, s.
    pub time_s: f64,
    /// N minimising J over [0, t] (Eq. 31 with te → t).
    pub exponent: f64,
    /// J at that N.
    pub cost: f64,
    /// K0_dr for the coupled r, N/m.
    pub k0: Vec<f64>,
    /// K0_dr·δ_dr, N/(m·J).
    pub k0_delta: Vec<f64>,
    pub beta: f64,
    pub gamma: f64,
    /// Parameters at the scalar N* (fixed exponent), same order.
    pub k0_at_scalar_exponent: Vec<f64>,
    pub k0_delta_at_scalar_exponent: Vec<f64>,
    pub beta_at_scalar_exponent: f64,
    pub gamma_at_scalar_exponent: f64,
    /// After the onset of the hysteretic response (see `IdentifySettings::onset_fraction`);
    /// N was refined to the full resolution only for these frames.
    pub informative: bool,
}

/// Spread of the instantaneous estimates over the informative frames.
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterStability {
    pub informative_frames: usize,
    /// Onset time of the informative window, s.
    pub onset_s: f64,
    /// Standard deviation of N(t), absolute.
    pub exponent_std: f64,
    /// std/|scalar| of K0_dr(t) at the scalar N*, same order as `coupled`
    /// (likewise for K0·δ, β, γ).
    pub k0_rel_std: Vec<f64>,
    pub k0_delta_rel_std: Vec<f64>,
    pub beta_rel_std: f64,
    pub gamma_rel_std: f64,
    /// Every relative spread ≤ `stability_threshold` and exponent_std ≤ 10 × threshold.
    pub stable: bool,
}

/// Instantaneous estimates: for every frame j, N_j minimises the cumulative
/// J_j(N) (coarse grid for all frames, refined to full resolution for the
/// informative frames with shared trial exponents).
#[allow(clippy::too_many_arguments)]
pub(super) fn instantaneous_estimates(
    engine: &mut DofEngine,
    problem: &DofProblem,
    layout: &StftLayout,
    settings: &IdentifySettings,
    fs: f64,
    best_index: i64,
    grid: &[i64],
    coarse_step: i64,
    scalar: &DofParameters,
) -> Result<(Vec<InstantaneousEstimate>, Option<ParameterStability>)> {
    let frames = layout.frames();
    let at_best = engine
        .cache
        .get(&best_index)
        .cloned()
        .ok_or_else(|| Error::numerical("hysteresis: missing evaluation"))?;
    let final_weight = at_best.last().nonlinear_weight;
    let informative: Vec<bool> = at_best
        .frames
        .iter()
        .map(|f| final_weight > 0.0 && f.nonlinear_weight >= settings.onset_fraction * final_weight)
        .collect();
    let frame_cost = |e: &DofEngine, k: i64, j: usize| {
        e.cache
            .get(&k)
            .map_or(f64::INFINITY, |ev| ev.frames[j].cost)
    };
    // Coarse choice per frame.
    let mut centers: Vec<i64> = (0..frames)
        .map(|j| {
            grid.iter()
                .copied()
                .min_by(|a, b| {
                    frame_cost(engine, *a, j)
                        .total_cmp(&frame_cost(engine, *b, j))
                        .then(a.cmp(b))
                })
                .unwrap_or(0)
        })
        .collect();
    // Shared refinement levels for the informative frames.
    let mut step = coarse_step;
    while step > 1 {
        let next = (step / 5).max(1);
        let reach = step / next;
        let mut points: Vec<i64> = Vec::new();
        for j in 0..frames {
            if informative[j] {
                points.extend((-reach..=reach).map(|m| centers[j] + m * next));
            }
        }
        engine.evaluate(&points)?;
        for j in 0..frames {
            if informative[j] {
                let c = centers[j];
                centers[j] = (-reach..=reach)
                    .map(|m| c + m * next)
                    .filter(|k| engine.cache.contains_key(k))
                    .min_by(|a, b| {
                        frame_cost(engine, *a, j)
                            .total_cmp(&frame_cost(engine, *b, j))
                            .then(a.cmp(b))
                    })
                    .unwrap_or(c);
            }
        }
        step = next;
    }
    let mut estimates = Vec::with_capacity(frames);
    for j in 0..frames {
        let k = centers[j];
        let n_exp = engine.exponent(k);
        let fit = &engine.cache[&k].frames[j];
        let own = problem.parameters(&fit.p, n_exp);
        let fixed = problem.parameters(&at_best.frames[j].p, engine.exponent(best_index));
        estimates.push(InstantaneousEstimate {
            time_s: layout.frame_time(j, fs),
            exponent: n_exp,
            cost: fit.cost,
            k0: own.k0.clone(),
            k0_delta: own.k0_delta.clone(),
            beta: own.beta(),
            gamma: own.gamma(),
            k0_at_scalar_exponent: fixed.k0.clone(),
            k0_delta_at_scalar_exponent: fixed.k0_delta.clone(),
            beta_at_scalar_exponent: fixed.beta(),
            gamma_at_scalar_exponent: fixed.gamma(),
            informative: informative[j],
        });
    }
    let stability = parameter_stability(&estimates, scalar, settings.stability_threshold);
    Ok((estimates, stability))
}

/// Relative spread of the instantaneous estimates over the informative frames.
fn parameter_stability(
    estimates: &[InstantaneousEstimate],
    scalar: &DofParameters,
    threshold: f64,
) -> Option<ParameterStability> {
    let window: Vec<&InstantaneousEstimate> = estimates.iter().filter(|e| e.informative).collect();
    if window.len() < 2 {
        return None;
    }
    let std = |values: &[f64]| {
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / values.len() as f64).sqrt()
    };
    let rel = |values: Vec<f64>, reference: f64| {
        if reference != 0.0 {
            std(&values) / reference.abs()
        } else {
            f64::INFINITY
        }
    };
    let exponent_std = std(&window.iter().map(|e| e.exponent).collect::<Vec<_>>());
    // The linear parameters are compared at the scalar N* (β and γ scale with
    // V_ref^N, so their spread at a varying N_j would mostly repeat N's spread).
    let k0_rel_std: Vec<f64> = (0..scalar.k0.len())
        .map(|i| {
            rel(
                window.iter().map(|e| e.k0_at_scalar_exponent[i]).collect(),
                scalar.k0[i],
            )
        })
        .collect();
    let k0_delta_rel_std: Vec<f64> = (0..scalar.k0_delta.len())
        .map(|i| {
            rel(
                window
                    .iter()
                    .map(|e| e.k0_delta_at_scalar_exponent[i])
                    .collect(),
                scalar.k0_delta[i],
            )
        })
        .collect();
    let beta_rel_std = rel(
        window.iter().map(|e| e.beta_at_scalar_exponent).collect(),
        scalar.beta(),
    );
    let gamma_rel_std = rel(
        window.iter().map(|e| e.gamma_at_scalar_exponent).collect(),
        scalar.gamma(),
    );
    let stable = k0_rel_std
        .iter()
        .chain(&k0_delta_rel_std)
        .chain([&beta_rel_std, &gamma_rel_std])
        .all(|v| *v <= threshold)
        && exponent_std <= 10.0 * threshold;
    Some(ParameterStability {
        informative_frames: window.len(),
        onset_s: window[0].time_s,
        exponent_std,
        k0_rel_std,
        k0_delta_rel_std,
        beta_rel_std,
        gamma_rel_std,
        stable,
    })
}
