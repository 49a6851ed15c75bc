//! Identification of one DoF (Table 15 step A; METHODS.md §4): the N search,
//! the scalar estimate at N* (t = te), the non-identifiability checks and the
//! instantaneous estimates.

use crate::error::{Error, Result};

use super::basis::{DofParameters, DofProblem};
use super::exponent_search::DofEngine;
use super::instantaneous::{instantaneous_estimates, InstantaneousEstimate, ParameterStability};
use super::settings::IdentifySettings;
use super::significance::{hysteresis_significance, Significance};
use super::solve::bounded_lsq_columns;
use super::stft::{FrameRepresentation, FrameTransformer};

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

fn sum_squares(x: &[f64]) -> f64 {
    x.iter().map(|a| a * a).sum()
}

/// `e` carrying the F-test (F, p) that made the DoF not identifiable.
fn with_f_test(e: Error, test: (f64, f64)) -> Error {
    match e {
        Error::NotIdentifiable { stage, message, .. } => Error::NotIdentifiable {
            stage,
            message,
            f_test: Some(test),
        },
        other => other,
    }
}

fn not_identifiable(direction: &str, dof: usize, message: String) -> Error {
    Error::NotIdentifiable {
        stage: "hysteresis".into(),
        message: format!("direction {direction}, DoF {}: {message}", dof + 1),
        f_test: None,
    }
}

/// Table 15 step A for one DoF: N search, scalar and instantaneous estimates.
pub(super) fn identify_dof(
    problem: &DofProblem,
    transformer: &FrameTransformer,
    settings: &IdentifySettings,
    fs: f64,
    direction: &str,
) -> Result<DofIdentification> {
    let layout = transformer.layout();
    let mut engine = DofEngine::new(problem, transformer, settings);
    let search = engine.search_scalar(settings)?;
    let best_index = search.best_index;
    let n_star = engine.exponent(best_index);
    let fit = ScalarFit::at(&engine, problem, transformer, n_star)?;
    let (p, cost, parameters) = (&fit.p, fit.cost, &fit.parameters);
    let cost_max = search
        .coarse_costs
        .iter()
        .copied()
        .filter(|c| c.is_finite())
        .fold(0.0f64, f64::max);
    let cost_contrast = if cost > 0.0 {
        (cost_max - cost) / cost
    } else {
        f64::INFINITY
    };
    let dof = problem.dof;
    check_identifiable(
        &Diagnostics {
            k0_dd: p[problem.coupled.len() - 1],
            hysteretic_share: fit.hysteretic_share,
            significance: &fit.significance,
            unknowns: problem.fixed_count() + 3,
            exponent: n_star,
            cost_contrast,
        },
        settings,
        direction,
        dof,
    )?;

    let (instantaneous, stability) = if settings.instantaneous {
        engine.solve_every_frame()?;
        instantaneous_estimates(
            &mut engine,
            problem,
            layout,
            settings,
            fs,
            best_index,
            &search.grid,
            search.coarse_step,
            parameters,
        )?
    } else {
        (Vec::new(), None)
    };
    let cost_curve = search
        .grid
        .iter()
        .zip(&search.coarse_costs)
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
        cost_relative: cost / fit.target_energy,
        hysteretic_share: fit.hysteretic_share,
        cost_contrast,
        significance: fit.significance,
        cost_curve,
        evaluations: engine.cache.len(),
        instantaneous,
        stability,
        fit: FitSeries {
            target: problem.target.clone(),
            model: fit.model,
            force_record: Vec::new(),
            force_model: Vec::new(),
            storey_drift: Vec::new(),
        },
        parameters: fit.parameters,
    })
}

/// The scalar estimate at N* (t = te) and what the checks and outputs need from it.
struct ScalarFit {
    /// Unknowns [fixed…, s, t] (β = s + t, γ = s − t) and J at them.
    p: Vec<f64>,
    cost: f64,
    parameters: DofParameters,
    significance: Significance,
    /// ‖n_e‖²_W.
    target_energy: f64,
    /// n_n(t) = Σ p_i n_i(t).
    model: Vec<f64>,
    /// ‖β n_β + γ n_γ‖_W / ‖n_e‖_W.
    hysteretic_share: f64,
}

impl ScalarFit {
    fn at(
        engine: &DofEngine,
        problem: &DofProblem,
        transformer: &FrameTransformer,
        n_star: f64,
    ) -> Result<ScalarFit> {
        let layout = transformer.layout();
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
        Ok(ScalarFit {
            p,
            cost,
            parameters,
            significance,
            target_energy,
            model,
            hysteretic_share,
        })
    }
}

/// What the non-identifiability checks look at.
struct Diagnostics<'a> {
    /// K0_dd, the DoF's own initial stiffness.
    k0_dd: f64,
    hysteretic_share: f64,
    significance: &'a Significance,
    /// Unknowns of the full model (K0 and K0·δ per coupling, β, γ, N).
    unknowns: usize,
    /// N*.
    exponent: f64,
    /// (max over the coarse grid of J − J*)/J*.
    cost_contrast: f64,
}

/// Bad input, not a numerical failure: a response that does not yield leaves β, γ, N
/// undetermined.  Checked in this order: K0_dd at its bound, hysteretic share, F-test (and
/// whether the record has the windows to compute it),
/// N* at the edge of its range, flat J(N).
fn check_identifiable(
    d: &Diagnostics,
    settings: &IdentifySettings,
    direction: &str,
    dof: usize,
) -> Result<()> {
    if !(d.k0_dd > 0.0) {
        return Err(not_identifiable(direction, dof, "the initial stiffness K0_dd hits its bound 0: the record does not determine the storey stiffness".into()));
    }
    if !(d.hysteretic_share >= settings.min_hysteretic_share) {
        return Err(not_identifiable(
            direction,
            dof,
            format!(
                "the response stays (nearly) linear: the hysteretic terms explain {:.3} % of the record (threshold {:.3} %); \
                 the nonlinear Bouc-Wen parameters β, γ, N are not identifiable from this record",
                100.0 * d.hysteretic_share,
                100.0 * settings.min_hysteretic_share
            ),
        ));
    }
    if d.significance.denominator_dof == 0 {
        return Err(not_identifiable(
            direction,
            dof,
            format!(
                "the record holds n_eff = {} independent windows, no more than the {} unknowns of this DoF \
                 (K0 and K0·δ of each coupled storey, β, γ, N): the hysteretic terms cannot be tested against the \
                 linear fit, and the nonlinear Bouc-Wen parameters are not identifiable from this record",
                d.significance.effective_samples, d.unknowns
            ),
        ));
    }
    if !(d.significance.p_value < settings.significance_level) {
        let f_test = (d.significance.f_statistic, d.significance.p_value);
        return Err(with_f_test(not_identifiable(
            direction,
            dof,
            format!(
                "the hysteretic terms do not improve the linear fit significantly: F = {:.3} on ({}, {}) degrees of freedom \
                 (n_eff = {} independent windows), p = {:.2e} ≥ α = {:.0e}; the nonlinear Bouc-Wen parameters are not identifiable from this record",
                d.significance.f_statistic,
                d.significance.numerator_dof,
                d.significance.denominator_dof,
                d.significance.effective_samples,
                d.significance.p_value,
                settings.significance_level
            ),
        ), f_test));
    }
    let edge = settings.exponent_resolution * 1.5;
    if (d.exponent - settings.exponent_min).abs() < edge
        || (settings.exponent_max - d.exponent).abs() < edge
    {
        return Err(not_identifiable(
            direction,
            dof,
            format!(
                "the exponent N = {:.3} sits at the edge of its search range [{}, {}]: the optimum of J(N) (Eq. 31) is not \
                 inside the admissible set, so the record does not determine the nonlinear parameters (a linear, viscously damped \
                 response is fitted by N = 1, γ = −β, which acts as a damping term)",
                d.exponent, settings.exponent_min, settings.exponent_max
            ),
        ));
    }
    if !(d.cost_contrast >= settings.min_cost_contrast) {
        return Err(not_identifiable(
            direction,
            dof,
            format!(
                "J(N) is flat over [{}, {}] (relative contrast {:.2e} < {:.2e}): the exponent N is not identifiable from this record",
                settings.exponent_min, settings.exponent_max, d.cost_contrast, settings.min_cost_contrast
            ),
        ));
    }
    Ok(())
}
