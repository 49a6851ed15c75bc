//! Settings of the Bouc-Wen identification (METHODS.md §4) and their check.

use crate::error::{Error, Result};

use super::basis::{BasisForm, StiffnessPattern, VelocityDrift};
use super::stft::{FrequencyBand, Transform};

/// Settings of the identification; defaults follow METHODS.md §4.
#[derive(Debug, Clone, PartialEq)]
pub struct IdentifySettings {
    /// Basis form. Default: the jerk form (A7–A10). Both forms recover the
    /// parameters at 1000 Hz; at 250 Hz the integral form (Eq. 27–30) is
    /// biased by the low-frequency drift of the twice-integrated displacement
    /// (noise-free synthetic 2-DoF: N off by 0.085 over the full band; with
    /// 1e-3 m/s² sensor noise it fails outright), while the jerk form needs
    /// only velocities and stays within 0.001 on N. Choose `Integral` with a
    /// band above the drift bins (e.g. `FrequencyBand::above(1.5)`) to use it.
    pub form: BasisForm,
    /// How the time–frequency products are evaluated (Parseval by default).
    pub transform: Transform,
    /// Band of the frequency integral of Eq. 20 ([0, fs/2] in the thesis).
    pub band: FrequencyBand,
    /// STFT window length; `None` = frames ≈ bins.
    pub window_len: Option<usize>,
    pub exponent_min: f64,
    pub exponent_max: f64,
    /// Resolution of N (0.001 in the thesis).
    pub exponent_resolution: f64,
    /// Coarse grid step of N (a multiple of the resolution).
    pub coarse_step: f64,
    /// How many coarse local minima of J(N) are refined.
    pub refine_candidates: usize,
    pub stiffness_pattern: StiffnessPattern,
    /// Shortest record accepted, samples.
    pub min_samples: usize,
    /// Below this share of the record explained by the hysteretic terms
    /// (‖β n_β + γ n_γ‖_W / ‖n_e‖_W) the response is called non-yielding.
    pub min_hysteretic_share: f64,
    /// Below this relative contrast (max_N J − J*)/J* over the coarse grid, N is
    /// not determined by the data.
    pub min_cost_contrast: f64,
    /// Instantaneous estimates count as informative once the cumulative
    /// weight of the hysteretic columns reaches this fraction of its final value.
    pub onset_fraction: f64,
    /// Relative standard deviation (over informative frames) above which a
    /// parameter is called unstable (model-adequacy indicator).
    pub stability_threshold: f64,
    /// Compute instantaneous (cumulative) estimates.
    pub instantaneous: bool,
    /// Drift control if this stage integrates the velocities.
    pub velocity_drift: VelocityDrift,
    /// Significance level α of the test of the hysteretic columns against the
    /// nested linear model (see `hysteresis_significance`): the nonlinear
    /// parameters are identifiable only when the F-test p-value is below α.
    pub significance_level: f64,
    /// Damage index every `damage_stride` samples.
    pub damage_stride: usize,
}

impl Default for IdentifySettings {
    fn default() -> Self {
        IdentifySettings {
            form: BasisForm::Jerk,
            transform: Transform::Parseval,
            band: FrequencyBand::full(),
            window_len: None,
            exponent_min: 1.0,
            exponent_max: 10.0,
            exponent_resolution: 0.001,
            coarse_step: 0.05,
            refine_candidates: 3,
            stiffness_pattern: StiffnessPattern::Full,
            min_samples: 1024,
            min_hysteretic_share: 0.02,
            min_cost_contrast: 0.01,
            onset_fraction: 0.1,
            stability_threshold: 0.1,
            instantaneous: true,
            velocity_drift: VelocityDrift::None,
            significance_level: 1e-3,
            damage_stride: 1,
        }
    }
}

/// Largest Bouc-Wen exponent N searched.  Identified exponents of
/// structures lie between 1 and a few tens (N → ∞ is the elastic–perfectly
/// plastic limit, reached to within 1 % of the force by N ≈ 20 at
/// z/z_y = 0.8); a larger bound only adds grid points — each a least-squares
/// fit over every frame — and overflows |z|^N.
pub const MAX_EXPONENT: f64 = 50.0;
/// Most points of the exponent grid, (exponent_max − exponent_min) /
/// exponent_resolution: 9 000 by default, 49 000 over the widest range at the
/// thesis's resolution 0.001.  The coarse search evaluates
/// (max − min) / coarse_step of them; the refinement a few per candidate.
pub const MAX_EXPONENT_GRID_POINTS: f64 = 100_000.0;

/// Settings the N search and the estimates can work with, else
/// `Error::Usage` naming the key (the pipeline's `hysteresis` params, the
/// library callers' [`IdentifySettings`]): 1 ≤ exponent_min < exponent_max
/// ≤ [`MAX_EXPONENT`], a grid of at most [`MAX_EXPONENT_GRID_POINTS`]
/// points no finer than needed, the coarse step a multiple of it.
pub fn validate_settings(s: &IdentifySettings) -> Result<()> {
    let bad = |m: String| Err(Error::usage(format!("hysteresis settings: {m}")));
    let (lo, hi, res) = (s.exponent_min, s.exponent_max, s.exponent_resolution);
    if !(1.0..MAX_EXPONENT).contains(&lo) {
        return bad(format!(
            "exponent_min = {lo:?}: must lie in [1, {MAX_EXPONENT}) (Bouc-Wen exponents of structures are 1 to a few tens)"
        ));
    }
    if !(hi.is_finite() && hi > lo && hi <= MAX_EXPONENT) {
        return bad(format!(
            "exponent_max = {hi:?}: must lie in (exponent_min = {lo:?}, {MAX_EXPONENT}] (Bouc-Wen exponents of structures are 1 to a few tens)"
        ));
    }
    if !(res.is_finite() && res > 0.0 && (hi - lo) / res <= MAX_EXPONENT_GRID_POINTS) {
        return bad(format!(
            "exponent_resolution = {res:?}: must be positive with (exponent_max − exponent_min) / exponent_resolution ≤ {MAX_EXPONENT_GRID_POINTS} grid points, got {}",
            (hi - lo) / res
        ));
    }
    if !(s.coarse_step.is_finite() && s.coarse_step >= res && s.coarse_step <= MAX_EXPONENT) {
        return bad(format!(
            "coarse step {} of N must lie in [exponent_resolution = {res}, {MAX_EXPONENT}]",
            s.coarse_step
        ));
    }
    if !(1..=100).contains(&s.refine_candidates) {
        return bad(format!(
            "refine_candidates = {}: must be 1..=100",
            s.refine_candidates
        ));
    }
    if !(s.onset_fraction > 0.0 && s.onset_fraction < 1.0) {
        return bad(format!(
            "onset_fraction = {}: must lie in (0, 1)",
            s.onset_fraction
        ));
    }
    Ok(())
}
