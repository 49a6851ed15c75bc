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

/// What the test of the hysteretic terms (β, γ, N) concluded at one DoF.
#[derive(Debug, Clone, PartialEq)]
pub enum HystereticTerms {
    /// Significant: the share, F-test, exponent-range and J(N)-contrast checks
    /// pass; β, γ, N are identified.
    Significant,
    /// Not significant at this DoF: it carries the nested model (K0, K0·δ of
    /// Eq. 23b fitted alone; β = γ = 0) so that the DoFs below can still be
    /// identified (Table 15 goes on downwards). `reason` names the check and
    /// its numbers. This is not a verdict of "linear": the nested model keeps
    /// the energy-driven stiffness degradation K0·δ, and the test sees only
    /// what β, γ, N add to it (docs/hysteresis.md).
    NotSignificant { reason: String },
}

impl HystereticTerms {
    pub fn significant(&self) -> bool {
        matches!(self, HystereticTerms::Significant)
    }
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
    /// The verdict of the checks on the hysteretic terms. When not
    /// significant, `k0`, `k0_delta`, `delta`, `parameters` and `fit.model`
    /// are those of the nested model, `beta` = `gamma` = 0, `exponent` NaN,
    /// `cost` its J; `hysteretic_share`, `cost_contrast`, `significance` stay
    /// those of the full model at N* (what the test saw).
    pub hysteresis: HystereticTerms,
    /// (N, J(N)) on the coarse grid, for plots of the non-convex cost.
    pub cost_curve: Vec<(f64, f64)>,
    /// Distinct trial exponents evaluated.
    pub evaluations: usize,
    pub instantaneous: Vec<InstantaneousEstimate>,
    pub stability: Option<ParameterStability>,
    pub fit: FitSeries,
    /// E_rec = ∫ V_d dΔu_d: work of the recorded storey (segment) shear along
    /// the segment drift over the identified window, J (`super::energy`):
    /// the energy the measured loops enclose — hysteretic and viscous
    /// dissipation, plus the elastic energy still stored at the end.
    pub energy_record_j: f64,
    /// E_h = ∫ h_d dΔu_d, h_d(t) = ∫₀ᵗ BW_d dτ (Eq. 23c): work of the
    /// identified Bouc-Wen hysteretic storey force along the recorded drift,
    /// J; the hysteretic energy dissipated (0 when the hysteretic terms are
    /// not significant).
    pub energy_hysteretic_j: f64,
    /// Scaled parameters (used for the known side of the DoFs below).
    pub parameters: DofParameters,
}

fn sum_squares(x: &[f64]) -> f64 {
    x.iter().map(|a| a * a).sum()
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
    let hysteresis = check_identifiable(
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
    let cost_curve = search
        .grid
        .iter()
        .zip(&search.coarse_costs)
        .map(|(&k, &c)| (engine.exponent(k), c))
        .collect();
    if !hysteresis.significant() {
        return fit.nested(
            problem,
            cost_contrast,
            cost_curve,
            engine.cache.len(),
            hysteresis,
        );
    }

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
    Ok(DofIdentification {
        dof: dof + 1,
        coupled: problem.coupled.iter().map(|r| r + 1).collect(),
        k0: parameters.k0.clone(),
        k0_delta: parameters.k0_delta.clone(),
        delta: delta_of(parameters),
        beta: parameters.beta(),
        gamma: parameters.gamma(),
        exponent: n_star,
        cost,
        cost_relative: cost / fit.target_energy,
        hysteretic_share: fit.hysteretic_share,
        cost_contrast,
        significance: fit.significance,
        hysteresis,
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
        energy_record_j: f64::NAN,
        energy_hysteretic_j: f64::NAN,
        parameters: fit.parameters,
    })
}

/// δ_dr = (K0_dr·δ_dr)/K0_dr (NaN where K0_dr = 0).
fn delta_of(parameters: &DofParameters) -> Vec<f64> {
    parameters
        .k0
        .iter()
        .zip(&parameters.k0_delta)
        .map(|(k, kd)| if *k != 0.0 { kd / k } else { f64::NAN })
        .collect()
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
    /// The nested model (hysteretic columns dropped): [fixed…] and its J.
    nested_p: Vec<f64>,
    /// Σ p_i n_i(t) of the nested model.
    nested_model: Vec<f64>,
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
        let nested_model: Vec<f64> = (0..problem.target.len())
            .map(|k| {
                columns[..i0]
                    .iter()
                    .zip(&linear.p)
                    .map(|(c, pi)| c[k] * pi)
                    .sum()
            })
            .collect();
        Ok(ScalarFit {
            p,
            cost,
            parameters,
            significance,
            target_energy,
            model,
            hysteretic_share,
            nested_p: linear.p,
            nested_model,
        })
    }

    /// The DoF carried by the nested model when its hysteretic terms are not
    /// significant: K0, K0·δ of the nested fit, β = γ = 0 (the hysteretic
    /// columns then vanish from the known side of the DoFs below, Eq. 30),
    /// N reported NaN; no instantaneous estimates (nothing to track).
    fn nested(
        self,
        problem: &DofProblem,
        cost_contrast: f64,
        cost_curve: Vec<(f64, f64)>,
        evaluations: usize,
        hysteresis: HystereticTerms,
    ) -> Result<DofIdentification> {
        let i0 = problem.fixed_count();
        if !(self.nested_p[problem.coupled.len() - 1] > 0.0) {
            return Err(Error::NotIdentifiable {
                stage: "hysteresis".into(),
                message: format!(
                    "DoF {}: the nested model's initial stiffness K0_dd hits its bound 0: the record does not determine \
                     the storey stiffness",
                    problem.dof + 1
                ),
                f_test: None,
            });
        }
        let mut p = self.nested_p.clone();
        p.resize(i0 + 2, 0.0);
        // Exponent 1: with β = γ = 0 any N gives zero hysteretic terms; 1 keeps
        // |V/V_ref|^N finite.
        let parameters = problem.parameters(&p, 1.0);
        let cost = self.significance.linear_cost;
        Ok(DofIdentification {
            dof: problem.dof + 1,
            coupled: problem.coupled.iter().map(|r| r + 1).collect(),
            k0: parameters.k0.clone(),
            k0_delta: parameters.k0_delta.clone(),
            delta: delta_of(&parameters),
            beta: 0.0,
            gamma: 0.0,
            exponent: f64::NAN,
            cost,
            cost_relative: cost / self.target_energy,
            hysteretic_share: self.hysteretic_share,
            cost_contrast,
            significance: self.significance,
            hysteresis,
            cost_curve,
            evaluations,
            instantaneous: Vec::new(),
            stability: None,
            fit: FitSeries {
                target: problem.target.clone(),
                model: self.nested_model,
                force_record: Vec::new(),
                force_model: Vec::new(),
                storey_drift: Vec::new(),
            },
            energy_record_j: f64::NAN,
            energy_hysteretic_j: f64::NAN,
            parameters,
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

/// The checks on one DoF, in this order: K0_dd at its bound and a record with too few windows
/// to test anything (errors: the DoF is not identifiable, and neither are the DoFs below it,
/// whose known side needs it); then the hysteretic share, the F-test, N* at the edge of its
/// range and a flat J(N) (`NotSignificant`: the hysteretic terms add nothing the test can
/// tell from the nested model; the DoF carries the nested model and Table 15 goes on).
fn check_identifiable(
    d: &Diagnostics,
    settings: &IdentifySettings,
    direction: &str,
    dof: usize,
) -> Result<HystereticTerms> {
    if !(d.k0_dd > 0.0) {
        return Err(not_identifiable(direction, dof, "the initial stiffness K0_dd hits its bound 0: the record does not determine the storey stiffness".into()));
    }
    if d.significance.denominator_dof == 0 {
        let e = not_identifiable(
            direction,
            dof,
            format!(
                "the record holds n_eff = {} independent windows, no more than the {} unknowns of this DoF \
                 (K0 and K0·δ of each coupled storey, β, γ, N): the hysteretic terms cannot be tested against the \
                 linear fit, and the nonlinear Bouc-Wen parameters are not identifiable from this record",
                d.significance.effective_samples, d.unknowns
            ),
        );
        // Tested before the share: with no windows to spare nothing about the
        // hysteretic terms is known, not even that they are small.
        return Err(e);
    }
    let not_significant = |why: String| {
        Ok(HystereticTerms::NotSignificant {
            reason: format!(
                "direction {direction}, DoF {}: {why}; the DoF carries the nested model (K0, K0·δ; β = γ = 0)",
                dof + 1
            ),
        })
    };
    if !(d.hysteretic_share >= settings.min_hysteretic_share) {
        return not_significant(format!(
            "the hysteretic terms explain {:.3} % of the record (threshold {:.3} %): no significant hysteresis beyond \
             the degrading stiffness K0·δ; β, γ, N not identified",
            100.0 * d.hysteretic_share,
            100.0 * settings.min_hysteretic_share
        ));
    }
    if !(d.significance.p_value < settings.significance_level) {
        return not_significant(format!(
            "the hysteretic terms do not improve the nested fit significantly: F = {:.3} on ({}, {}) degrees of freedom \
             (n_eff = {} independent windows), p = {:.2e} ≥ α = {:.0e}; β, γ, N not identified",
            d.significance.f_statistic,
            d.significance.numerator_dof,
            d.significance.denominator_dof,
            d.significance.effective_samples,
            d.significance.p_value,
            settings.significance_level
        ));
    }
    let edge = settings.exponent_resolution * 1.5;
    if (d.exponent - settings.exponent_min).abs() < edge
        || (settings.exponent_max - d.exponent).abs() < edge
    {
        return not_significant(format!(
            "the exponent N = {:.3} sits at the edge of its search range [{}, {}]: the optimum of J(N) (Eq. 31) is not \
             inside the admissible set (at N = 1 with γ = −β the hysteretic terms act as a viscous damping term, not as \
             yielding); β, γ, N not identified",
            d.exponent, settings.exponent_min, settings.exponent_max
        ));
    }
    if !(d.cost_contrast >= settings.min_cost_contrast) {
        return not_significant(format!(
            "J(N) is flat over [{}, {}] (relative contrast {:.2e} < {:.2e}): the exponent N is not determined by this record",
            settings.exponent_min, settings.exponent_max, d.cost_contrast, settings.min_cost_contrast
        ));
    }
    Ok(HystereticTerms::Significant)
}
