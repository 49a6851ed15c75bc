//! Quasi-direct instantaneous identification of the degrading Bouc-Wen chain,
//! DoF by DoF from the top (Table 15; Eq. 6–20, 27–31 of METHODS.md §4).
//!
//! For one DoF and a trial exponent N the unknowns enter linearly: per STFT
//! frame j the products G_j (Eq. 15 integrated over the band) are formed, the
//! cumulative sums H(t_j) = Σ_{j' ≤ j} G_j' and b(t_j) (Eq. 20) give one bounded
//! least-squares problem per frame (Eq. 19 under Eq. 47). The last frame is the
//! scalar estimate (t = te); earlier frames are the instantaneous (cumulative)
//! estimates. J(N) (Eq. 31) is the weighted residual at the solution.
//!
//! N search on [N_min, N_max] at `exponent_resolution`: a coarse grid (J is
//! not convex in N), then the best `refine_candidates` local minima are
//! refined by successively finer grids (steps ÷5) down to the resolution.
//! Every trial N is cached; trial batches run in parallel (rayon).
//! The scalar parameters at the chosen N are re-solved on the weighted design
//! matrix by QR (same problem, better conditioned than the normal equations).

use std::collections::BTreeMap;

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::vocab::ProcessingHistory;

use super::basis::{
    cumulative_cubic, hysteretic_rate, BasisForm, DirectionKinematics, DirectionRecords,
    DofParameters, DofProblem, StiffnessPattern, VelocityDrift,
};
use super::damage::{damage_index, DamageSeries};
use super::solve::{bounded_lsq_columns, bounded_lsq_gram};
use super::stft::{
    frame_products, FrameRepresentation, FrameTransformer, FrequencyBand, StftLayout, Transform,
};

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

/// Record vs model time series of one DoF (hysteresis_fit).
#[derive(Debug, Clone, PartialEq)]
pub struct FitSeries {
    /// n_e(t): the record side of Eq. 30 (or A10), per unit mass.
    pub target: Vec<f64>,
    /// n_n(t) = Σ p_i n_i(t) with the scalar estimates.
    pub model: Vec<f64>,
    /// f_d from the record, −m_d (a + ü_d), N (Eq. 46).
    pub force_record: Vec<f64>,
    /// f_d from the identified model along the recorded kinematics (integral
    /// of Eq. 25 with all identified parameters), N.
    pub force_model: Vec<f64>,
    /// Inter-storey drift u_d − u_{d−1}, m (for hysteresis loops).
    pub storey_drift: Vec<f64>,
}

/// Result of one DoF.
#[derive(Debug, Clone, PartialEq)]
pub struct DofIdentification {
    /// 1-based DoF number (1 = lowest).
    pub dof: usize,
    /// 1-based DoFs r of K0_dr, K0_dr·δ_dr.
    pub coupled: Vec<usize>,
    pub k0: Vec<f64>,
    pub k0_delta: Vec<f64>,
    /// δ_dr = (K0_dr·δ_dr)/K0_dr (NaN where K0_dr = 0), 1/J.
    pub delta: Vec<f64>,
    pub beta: f64,
    pub gamma: f64,
    pub exponent: f64,
    /// J(N*) (Eq. 31; units of n_e² · samples, see `stft`).
    pub cost: f64,
    /// J(N*) / ‖n_e‖²_W: unexplained share of the record energy.
    pub cost_relative: f64,
    /// ‖β n_β + γ n_γ‖_W / ‖n_e‖_W.
    pub hysteretic_share: f64,
    /// (max over the coarse grid of J − J*)/J*.
    pub cost_contrast: f64,
    /// Test of the hysteretic terms against the nested linear model.
    pub significance: Significance,
    /// (N, J(N)) on the coarse grid, for plots of the non-convex cost.
    pub cost_curve: Vec<(f64, f64)>,
    /// Distinct trial exponents evaluated.
    pub evaluations: usize,
    pub instantaneous: Vec<InstantaneousEstimate>,
    pub stability: Option<ParameterStability>,
    pub fit: FitSeries,
    /// Scaled parameters (used for the known side of the DoFs below).
    pub parameters: DofParameters,
}

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

/// Result of one direction.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionIdentification {
    pub direction: String,
    pub sampling_rate_hz: f64,
    pub form: BasisForm,
    pub window_len: usize,
    pub hop: usize,
    pub frames: usize,
    /// DoF 1 first.
    pub dofs: Vec<DofIdentification>,
    /// Full symmetric K0 (unidentified couplings of `Tridiagonal` are 0).
    pub k0_matrix: Vec<Vec<f64>>,
    /// Full K0∘δ (antisymmetric off the diagonal).
    pub k0_delta_matrix: Vec<Vec<f64>>,
    pub masses: Vec<f64>,
    pub damage: DamageSeries,
    /// Declared processing plus this stage's steps and settings.
    pub processing: ProcessingHistory,
}

/// Per-frame cumulative solution at one trial N.
#[derive(Debug, Clone)]
struct FrameFit {
    cost: f64,
    p: Vec<f64>,
    /// Cumulative H_ss + H_tt (weight of the hysteretic columns so far).
    nonlinear_weight: f64,
}

#[derive(Debug, Clone)]
struct Evaluation {
    frames: Vec<FrameFit>,
}

impl Evaluation {
    fn last(&self) -> &FrameFit {
        // An evaluation always has at least one frame (layouts have ≥ 1 frame).
        &self.frames[self.frames.len() - 1]
    }
}

/// Evaluates trial exponents for one DoF with cached per-frame products of
/// the N-independent columns.
struct DofEngine<'a> {
    problem: &'a DofProblem,
    transformer: &'a FrameTransformer,
    frames: usize,
    /// Frame representations of [fixed…, target].
    fixed_reps: Vec<FrameRepresentation>,
    /// Products over [fixed…, target], per frame, (I0+1)².
    fixed_products: Vec<f64>,
    all_frames: bool,
    constrained: [usize; 3],
    exponent_min: f64,
    resolution: f64,
    max_index: i64,
    cache: BTreeMap<i64, Evaluation>,
}

impl<'a> DofEngine<'a> {
    fn new(
        problem: &'a DofProblem,
        transformer: &'a FrameTransformer,
        settings: &IdentifySettings,
    ) -> Self {
        let mut fixed_reps: Vec<FrameRepresentation> = problem
            .fixed_columns
            .iter()
            .map(|c| transformer.represent(c))
            .collect();
        fixed_reps.push(transformer.represent(&problem.target));
        let frames = transformer.layout().frames();
        let refs: Vec<&FrameRepresentation> = fixed_reps.iter().collect();
        let fixed_products = frame_products(&refs, &refs, frames);
        let i0 = problem.fixed_count();
        let span = settings.exponent_max - settings.exponent_min;
        DofEngine {
            problem,
            transformer,
            frames,
            fixed_reps,
            fixed_products,
            all_frames: settings.instantaneous,
            // K0_dd ≥ 0 (last K column), s ≥ 0, t ≥ 0 (Eq. 47 after β = s + t, γ = s − t).
            constrained: [problem.coupled.len() - 1, i0, i0 + 1],
            exponent_min: settings.exponent_min,
            resolution: settings.exponent_resolution,
            max_index: (span / settings.exponent_resolution).round() as i64,
            cache: BTreeMap::new(),
        }
    }

    fn exponent(&self, index: i64) -> f64 {
        self.exponent_min + index as f64 * self.resolution
    }

    fn compute(&self, index: i64) -> Result<Evaluation> {
        let n_exp = self.exponent(index);
        let problem = self.problem;
        let i0 = problem.fixed_count();
        let dim = i0 + 2;
        let width = dim + 1; // unknowns + target
        let nonlinear = problem.nonlinear_columns(n_exp);
        let nl_reps: Vec<FrameRepresentation> = nonlinear
            .iter()
            .map(|c| self.transformer.represent(c))
            .collect();
        let left: Vec<&FrameRepresentation> = nl_reps.iter().collect();
        let mut right: Vec<&FrameRepresentation> = self.fixed_reps[..i0].iter().collect();
        right.extend(nl_reps.iter());
        right.push(&self.fixed_reps[i0]);
        let frames = self.frames;
        let nl_products = frame_products(&left, &right, frames);
        let fixed_width = i0 + 1;
        // Column index in `right` order → index in the fixed block (target last).
        let fixed_index = |a: usize| if a < i0 { a } else { i0 };
        let mut cumulative = vec![0.0; width * width];
        let mut out = Vec::with_capacity(if self.all_frames { frames } else { 1 });
        for j in 0..frames {
            for a in 0..width {
                for b in 0..width {
                    let value = if a == i0 || a == i0 + 1 {
                        nl_products[(j * 2 + (a - i0)) * width + b]
                    } else if b == i0 || b == i0 + 1 {
                        nl_products[(j * 2 + (b - i0)) * width + a]
                    } else {
                        self.fixed_products
                            [(j * fixed_width + fixed_index(a)) * fixed_width + fixed_index(b)]
                    };
                    cumulative[a * width + b] += value;
                }
            }
            if self.all_frames || j + 1 == frames {
                let h: Vec<f64> = (0..dim)
                    .flat_map(|a| (0..dim).map(move |b| (a, b)))
                    .map(|(a, b)| cumulative[a * width + b])
                    .collect();
                let rhs: Vec<f64> = (0..dim).map(|a| cumulative[a * width + dim]).collect();
                let yy = cumulative[dim * width + dim];
                let solution = bounded_lsq_gram(&h, &rhs, yy, &self.constrained)?;
                out.push(FrameFit {
                    cost: solution.cost,
                    p: solution.p,
                    nonlinear_weight: cumulative[i0 * width + i0]
                        + cumulative[(i0 + 1) * width + i0 + 1],
                });
            }
        }
        Ok(Evaluation { frames: out })
    }

    /// Evaluates every index not yet cached (in parallel).
    fn evaluate(&mut self, indices: &[i64]) -> Result<()> {
        let mut todo: Vec<i64> = indices
            .iter()
            .copied()
            .filter(|k| *k >= 0 && *k <= self.max_index && !self.cache.contains_key(k))
            .collect();
        todo.sort_unstable();
        todo.dedup();
        let results: Vec<Result<(i64, Evaluation)>> = todo
            .par_iter()
            .map(|&k| self.compute(k).map(|e| (k, e)))
            .collect();
        for r in results {
            let (k, e) = r?;
            self.cache.insert(k, e);
        }
        Ok(())
    }

    fn scalar_cost(&self, k: i64) -> f64 {
        self.cache.get(&k).map_or(f64::INFINITY, |e| e.last().cost)
    }

    /// Successive refinement around `center` from `step` down to 1 (steps ÷5).
    fn refine(
        &mut self,
        mut center: i64,
        mut step: i64,
        cost: impl Fn(&Self, i64) -> f64,
    ) -> Result<i64> {
        while step > 1 {
            let next = (step / 5).max(1);
            let reach = step / next;
            let points: Vec<i64> = (-reach..=reach).map(|m| center + m * next).collect();
            self.evaluate(&points)?;
            center = points
                .iter()
                .copied()
                .filter(|k| self.cache.contains_key(k))
                .min_by(|a, b| cost(self, *a).total_cmp(&cost(self, *b)).then(a.cmp(b)))
                .unwrap_or(center);
            step = next;
        }
        Ok(center)
    }
}

/// Coarse grid indices: multiples of `step` plus the upper end.
fn coarse_grid(max_index: i64, step: i64) -> Vec<i64> {
    let mut grid: Vec<i64> = (0..=max_index).step_by(step.max(1) as usize).collect();
    if grid.last() != Some(&max_index) {
        grid.push(max_index);
    }
    grid
}

/// Local minima of `values` over the grid (plateaus keep their first point).
fn local_minima(grid: &[i64], values: &[f64]) -> Vec<(i64, f64)> {
    let mut minima = Vec::new();
    for i in 0..grid.len() {
        let left = if i > 0 { values[i - 1] } else { f64::INFINITY };
        let right = values.get(i + 1).copied().unwrap_or(f64::INFINITY);
        if values[i] < left && values[i] <= right {
            minima.push((grid[i], values[i]));
        }
    }
    minima.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    minima
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
fn ln_gamma(x: f64) -> f64 {
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

fn sum_squares(x: &[f64]) -> f64 {
    x.iter().map(|a| a * a).sum()
}

fn validate_settings(s: &IdentifySettings) -> Result<()> {
    let ok = s.exponent_min >= 1.0
        && s.exponent_max > s.exponent_min
        && s.exponent_resolution > 0.0
        && s.coarse_step >= s.exponent_resolution
        && s.exponent_max.is_finite()
        && s.refine_candidates >= 1
        && s.onset_fraction > 0.0
        && s.onset_fraction < 1.0;
    if !ok {
        return Err(Error::usage(
            "hysteresis settings: need 1 ≤ N_min < N_max, 0 < resolution ≤ coarse step, ≥ 1 refined candidate, 0 < onset fraction < 1",
        ));
    }
    Ok(())
}

/// Identifies one direction from its records (Table 15, steps A–C).
pub fn identify_direction(
    records: &DirectionRecords,
    settings: &IdentifySettings,
) -> Result<DirectionIdentification> {
    validate_settings(settings)?;
    let kin =
        DirectionKinematics::from_records(records, settings.min_samples, settings.velocity_drift)?;
    identify_kinematics(&kin, &records.direction, settings)
}

/// Identifies several directions in parallel (they are independent, Ch. 4.2).
pub fn identify_directions(
    records: &[DirectionRecords],
    settings: &IdentifySettings,
) -> Result<Vec<DirectionIdentification>> {
    records
        .par_iter()
        .map(|r| identify_direction(r, settings))
        .collect()
}

/// Identification from already-derived kinematics.
pub fn identify_kinematics(
    kin: &DirectionKinematics,
    direction: &str,
    settings: &IdentifySettings,
) -> Result<DirectionIdentification> {
    validate_settings(settings)?;
    let fs = kin.sampling_rate_hz;
    let n = kin.samples();
    let layout = match settings.window_len {
        Some(len) => StftLayout::with_window(n, len)?,
        None => StftLayout::for_record(n)?,
    };
    if layout.frames() < 4 {
        return Err(Error::usage(format!(
            "hysteresis: only {} STFT frames; use a shorter window",
            layout.frames()
        )));
    }
    let transformer = FrameTransformer::new(&layout, settings.transform, settings.band, fs)?;
    let dofs = kin.dofs();
    let mut identified: Vec<DofIdentification> = Vec::with_capacity(dofs);
    // Table 15: from d = D down to 1; `above` holds DoFs d+1..D in order.
    for d in (0..dofs).rev() {
        let above: Vec<DofParameters> = identified
            .iter()
            .rev()
            .map(|r| r.parameters.clone())
            .collect();
        let problem = DofProblem::new(kin, d, &above, settings.form, settings.stiffness_pattern)?;
        let result = identify_dof(&problem, &transformer, settings, fs, direction)?;
        identified.push(result);
    }
    identified.reverse();
    // Model adequacy: estimates unstable over time at every DoF. Seen on a
    // linear building with 40 dB noise (every DoF unstable, N at its bound).
    if !identified.is_empty()
        && identified
            .iter()
            .all(|f| f.stability.as_ref().map(|st| !st.stable).unwrap_or(false))
    {
        return Err(Error::NotIdentifiable {
            stage: "hysteresis".into(),
            message: format!(
                "direction {direction}: the parameter estimates are unstable over time at every DoF (model-adequacy check): \
                 not identifiable from this record"
            ),
        });
    }
    // Assemble K0 and K0∘δ (lower triangle identified, mirrored by Eq. 23 symmetry).
    let mut k0 = vec![vec![0.0; dofs]; dofs];
    let mut k0_delta = vec![vec![0.0; dofs]; dofs];
    for (d, dof) in identified.iter().enumerate() {
        for (i, &r) in dof.parameters.coupled.iter().enumerate() {
            k0[d][r] = dof.parameters.k0[i];
            k0[r][d] = dof.parameters.k0[i];
            k0_delta[d][r] = dof.parameters.k0_delta[i];
            if r != d {
                k0_delta[r][d] = -dof.parameters.k0_delta[i];
            }
        }
    }
    // Model restoring forces along the recorded kinematics (integral of Eq. 25).
    let params: Vec<DofParameters> = identified.iter().map(|d| d.parameters.clone()).collect();
    let hysteretic: Vec<Vec<f64>> = (0..dofs)
        .map(|d| cumulative_cubic(&hysteretic_rate(kin, d, &params[d]), kin.dt()))
        .collect();
    for d in 0..dofs {
        let mut force = vec![0.0; n];
        for r in 0..dofs {
            let rate: Vec<f64> = (0..n)
                .map(|k| -kin.energy(d, r, k) * kin.relative_velocity[r][k])
                .collect();
            let degradation = cumulative_cubic(&rate, kin.dt());
            for k in 0..n {
                force[k] +=
                    k0[d][r] * kin.relative_displacement[r][k] + k0_delta[d][r] * degradation[k];
            }
        }
        for k in 0..n {
            force[k] += hysteretic[d][k]
                - if d + 1 < dofs {
                    hysteretic[d + 1][k]
                } else {
                    0.0
                };
        }
        identified[d].fit.force_model = force;
        identified[d].fit.force_record = kin.restoring_force[d].clone();
        identified[d].fit.storey_drift = (0..n)
            .map(|k| {
                kin.relative_displacement[d][k]
                    - if d > 0 {
                        kin.relative_displacement[d - 1][k]
                    } else {
                        0.0
                    }
            })
            .collect();
    }
    let damage = damage_index(
        &k0,
        &k0_delta,
        &kin.masses,
        &kin.energy_upper,
        fs,
        settings.damage_stride,
    )?;
    let mut processing = kin.processing.clone();
    processing.push(
        "hysteresis_identification",
        serde_json::json!({
            "form": settings.form.name(),
            "transform": match settings.transform { Transform::Parseval => "parseval_time_domain", Transform::Fft => "fft" },
            "band_hz": [settings.band.low_hz, if settings.band.high_hz.is_finite() { settings.band.high_hz } else { fs / 2.0 }],
            "window": "symmetric hamming",
            "window_len": layout.window_len,
            "hop": layout.hop,
            "frames": layout.frames(),
            "exponent_range": [settings.exponent_min, settings.exponent_max],
            "exponent_resolution": settings.exponent_resolution,
            "coarse_step": settings.coarse_step,
            "constraints": "K0_dd >= 0, beta >= 0, -beta <= gamma <= beta (Eq. 47)",
        }),
    );
    Ok(DirectionIdentification {
        direction: direction.to_string(),
        sampling_rate_hz: fs,
        form: settings.form,
        window_len: layout.window_len,
        hop: layout.hop,
        frames: layout.frames(),
        dofs: identified,
        k0_matrix: k0,
        k0_delta_matrix: k0_delta,
        masses: kin.masses.clone(),
        damage,
        processing,
    })
}

fn not_identifiable(direction: &str, dof: usize, message: String) -> Error {
    Error::NotIdentifiable {
        stage: "hysteresis".into(),
        message: format!("direction {direction}, DoF {}: {message}", dof + 1),
    }
}

/// Table 15 step A for one DoF: N search, scalar and instantaneous estimates.
fn identify_dof(
    problem: &DofProblem,
    transformer: &FrameTransformer,
    settings: &IdentifySettings,
    fs: f64,
    direction: &str,
) -> Result<DofIdentification> {
    let layout = transformer.layout();
    let mut engine = DofEngine::new(problem, transformer, settings);
    let coarse_step = ((settings.coarse_step / settings.exponent_resolution).round() as i64).max(1);
    let grid = coarse_grid(engine.max_index, coarse_step);
    engine.evaluate(&grid)?;
    let coarse_costs: Vec<f64> = grid.iter().map(|&k| engine.scalar_cost(k)).collect();
    let candidates = local_minima(&grid, &coarse_costs);
    let mut best: Option<(i64, f64)> = None;
    for &(k, _) in candidates.iter().take(settings.refine_candidates) {
        let refined = engine.refine(k, coarse_step, |e, i| e.scalar_cost(i))?;
        let cost = engine.scalar_cost(refined);
        if best.is_none_or(|b| cost < b.1 || (cost == b.1 && refined < b.0)) {
            best = Some((refined, cost));
        }
    }
    let (best_index, _) =
        best.ok_or_else(|| Error::numerical("hysteresis: J(N) has no finite value on the grid"))?;
    let n_star = engine.exponent(best_index);

    // Scalar estimate at N*: QR on the stacked frame representations (the
    // design matrix whose normal equations are H, b of Eq. 20 at t = te;
    // better conditioned than solving H p = b).
    let nonlinear = problem.nonlinear_columns(n_star);
    let nl_reps: Vec<FrameRepresentation> =
        nonlinear.iter().map(|c| transformer.represent(c)).collect();
    let i0 = problem.fixed_count();
    let mut design: Vec<&[f64]> = engine.fixed_reps[..i0]
        .iter()
        .map(|r| r.values.as_slice())
        .collect();
    design.push(&nl_reps[0].values);
    design.push(&nl_reps[1].values);
    let target_rep = &engine.fixed_reps[i0].values;
    let constrained = [problem.coupled.len() - 1, i0, i0 + 1];
    let solution = bounded_lsq_columns(&design, target_rep, None, &constrained)?;
    let (p, cost) = (solution.p, solution.cost);
    let parameters = problem.parameters(&p, n_star);
    // Nested linear model: the same fixed columns, hysteretic columns dropped.
    let linear = bounded_lsq_columns(
        &design[..i0],
        target_rep,
        None,
        &[problem.coupled.len() - 1],
    )?;
    let significance = hysteresis_significance(
        linear.cost,
        cost,
        i0 + 3,
        layout.n_samples / layout.window_len.max(1),
    );
    let target_energy = sum_squares(target_rep);
    let mut columns: Vec<&[f64]> = problem.fixed_columns.iter().map(|c| c.as_slice()).collect();
    columns.push(&nonlinear[0]);
    columns.push(&nonlinear[1]);
    let model: Vec<f64> = (0..problem.target.len())
        .map(|k| columns.iter().zip(&p).map(|(c, pi)| c[k] * pi).sum())
        .collect();
    let hysteretic_part: Vec<f64> = nl_reps[0]
        .values
        .iter()
        .zip(&nl_reps[1].values)
        .map(|(a, b)| p[i0] * a + p[i0 + 1] * b)
        .collect();
    let hysteretic_share = (sum_squares(&hysteretic_part) / target_energy).sqrt();
    let cost_max = coarse_costs
        .iter()
        .copied()
        .filter(|c| c.is_finite())
        .fold(0.0f64, f64::max);
    let cost_contrast = if cost > 0.0 {
        (cost_max - cost) / cost
    } else {
        f64::INFINITY
    };

    // Bad input: a response that does not yield leaves β, γ, N undetermined.
    let dof = problem.dof;
    if !(p[problem.coupled.len() - 1] > 0.0) {
        return Err(not_identifiable(direction, dof, "the initial stiffness K0_dd hits its bound 0: the record does not determine the storey stiffness".into()));
    }
    if !(hysteretic_share >= settings.min_hysteretic_share) {
        return Err(not_identifiable(
            direction,
            dof,
            format!(
                "the response stays (nearly) linear: the hysteretic terms explain {:.3} % of the record (threshold {:.3} %); \
                 the nonlinear Bouc-Wen parameters β, γ, N are not identifiable from this record",
                100.0 * hysteretic_share,
                100.0 * settings.min_hysteretic_share
            ),
        ));
    }
    if !(significance.p_value < settings.significance_level) {
        return Err(not_identifiable(
            direction,
            dof,
            format!(
                "the hysteretic terms do not improve the linear fit significantly: F = {:.3} on ({}, {}) degrees of freedom \
                 (n_eff = {} independent windows), p = {:.2e} ≥ α = {:.0e}; the nonlinear Bouc-Wen parameters are not identifiable from this record",
                significance.f_statistic,
                significance.numerator_dof,
                significance.denominator_dof,
                significance.effective_samples,
                significance.p_value,
                settings.significance_level
            ),
        ));
    }
    let edge = settings.exponent_resolution * 1.5;
    if (n_star - settings.exponent_min).abs() < edge
        || (settings.exponent_max - n_star).abs() < edge
    {
        return Err(not_identifiable(
            direction,
            dof,
            format!(
                "the exponent N = {n_star:.3} sits at the edge of its search range [{}, {}]: the optimum of J(N) (Eq. 31) is not \
                 inside the admissible set, so the record does not determine the nonlinear parameters (a linear, viscously damped \
                 response is fitted by N = 1, γ = −β, which acts as a damping term)",
                settings.exponent_min, settings.exponent_max
            ),
        ));
    }
    if !(cost_contrast >= settings.min_cost_contrast) {
        return Err(not_identifiable(
            direction,
            dof,
            format!(
                "J(N) is flat over [{}, {}] (relative contrast {:.2e} < {:.2e}): the exponent N is not identifiable from this record",
                settings.exponent_min, settings.exponent_max, cost_contrast, settings.min_cost_contrast
            ),
        ));
    }

    let (instantaneous, stability) = if settings.instantaneous {
        instantaneous_estimates(
            &mut engine,
            problem,
            layout,
            settings,
            fs,
            best_index,
            &grid,
            coarse_step,
            &parameters,
        )?
    } else {
        (Vec::new(), None)
    };
    let cost_curve = grid
        .iter()
        .zip(&coarse_costs)
        .map(|(&k, &c)| (engine.exponent(k), c))
        .collect();
    let delta = parameters
        .k0
        .iter()
        .zip(&parameters.k0_delta)
        .map(|(k, kd)| if *k != 0.0 { kd / k } else { f64::NAN })
        .collect();
    Ok(DofIdentification {
        dof: dof + 1,
        coupled: problem.coupled.iter().map(|r| r + 1).collect(),
        k0: parameters.k0.clone(),
        k0_delta: parameters.k0_delta.clone(),
        delta,
        beta: parameters.beta(),
        gamma: parameters.gamma(),
        exponent: n_star,
        cost,
        cost_relative: cost / target_energy,
        hysteretic_share,
        cost_contrast,
        significance,
        cost_curve,
        evaluations: engine.cache.len(),
        instantaneous,
        stability,
        fit: FitSeries {
            target: problem.target.clone(),
            model,
            force_record: Vec::new(),
            force_model: Vec::new(),
            storey_drift: Vec::new(),
        },
        parameters,
    })
}

/// Instantaneous estimates: for every frame j, N_j minimises the cumulative
/// J_j(N) (coarse grid for all frames, refined to full resolution for the
/// informative frames with shared trial exponents).
#[allow(clippy::too_many_arguments)]
fn instantaneous_estimates(
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
