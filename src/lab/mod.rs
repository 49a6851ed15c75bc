//! Laboratory tests (issue 37): hysteresis identification of a specimen from
//! its measured displacement and restoring force (numerical code, no I/O;
//! the readers of lab records are in `crate::readers`, the stage in
//! `crate::stages::lab`). docs/lab-tests.md has the equations (L1–L9).
//!
//! - [`model`]: the Bouc–Wen–Baber–Noori spring (Foliente 1995 form).
//! - [`fit`]: variable-projection least squares, seeded multistart,
//!   Levenberg–Marquardt, s² (JᵀJ)⁻¹ uncertainty.
//! - [`loops`]: force NRMSE, dissipated energy per cycle, damage indices.
//!
//! The plain model is always fitted; the degrading/pinching one as well, and
//! it is chosen when the F-test of the nested plain model (6 extra
//! parameters) rejects the plain model at `significance` with the effective
//! sample count of correlated residuals (`fit::effective_samples`). Dynamic records (a time base)
//! are fitted the same way: with the restoring force measured, the force
//! equation is the observation itself and no mass or acceleration enters,
//! so the whole-history fit applies to both protocols. A uniformly sampled
//! record is also identified by the thesis's time–frequency method
//! ([`instantaneous`], reusing `crate::hysteresis` on the measured force).

#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

pub mod fit;
pub mod instantaneous;
pub mod loops;
pub mod model;

use crate::error::{Error, Result};
use crate::rehearse::specimen::BoucWenSpring;
use crate::rng::Rng;
use crate::stats::f_survival;
use crate::vocab::{times_problem, LabRecord, LabRole, Quantity};

pub use loops::{CycleEnergy, SpecimenDamage};
pub use model::BwbnParameters;

/// A specimen's measured history: displacement (m) and restoring force (N),
/// one pair per sample; `time_s` None for a quasi-static protocol (the step
/// index orders the samples).
#[derive(Debug, Clone, Copy)]
pub struct SpecimenHistory<'a> {
    pub displacement_m: &'a [f64],
    pub force_n: &'a [f64],
    pub time_s: Option<&'a [f64]>,
}

/// Which model form to fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FormChoice {
    /// Both; the degrading/pinching one when the F-test says so.
    #[default]
    Auto,
    Plain,
    Degrading,
}

impl FormChoice {
    pub fn parse(s: &str) -> Option<FormChoice> {
        match s {
            "auto" => Some(FormChoice::Auto),
            "plain" => Some(FormChoice::Plain),
            "degrading" | "bwbn" => Some(FormChoice::Degrading),
            _ => None,
        }
    }
}

/// The model form identified.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelForm {
    /// Plain Bouc–Wen (k₀, α, u_y, β, n).
    Plain,
    /// Bouc–Wen–Baber–Noori: plain + δ_ν, δ_η, ζ_s, p, q, ψ.
    Degrading,
}

impl ModelForm {
    pub fn name(&self) -> &'static str {
        match self {
            ModelForm::Plain => "plain",
            ModelForm::Degrading => "degrading_pinching",
        }
    }
}

/// Settings of [`identify_specimen`]; `Default` = the shipped defaults
/// (the `lab_hysteresis` stage's params, docs/pipelines.md).
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct LabIdentifySettings {
    /// Seed of the global search (src/rng.rs).
    pub seed: u64,
    pub form: FormChoice,
    /// Uniform draws of the plain model's shape parameters.
    pub draws: usize,
    /// Uniform draws of the degrading/pinching extras around the plain fit.
    pub degrading_draws: usize,
    /// How many of the best draws Levenberg–Marquardt refines.
    pub refined: usize,
    pub max_iterations: usize,
    /// F-test level below which the degrading/pinching model is chosen.
    pub significance: f64,
    /// Longer records are fitted on every k-th sample (the model is rate
    /// independent; each increment is integrated in sub-steps anyway).
    pub max_samples: usize,
    /// Dead band of the cycle count, fraction of the displacement range.
    pub cycle_band: f64,
    /// β of Park–Ang.
    pub park_ang_beta: f64,
    /// δ_u of Park–Ang (m); None: Park–Ang not computed.
    pub ultimate_displacement_m: Option<f64>,
    /// Also run the thesis's time–frequency identification
    /// ([`instantaneous`]) on records with a uniform time base.
    pub instantaneous: bool,
}

impl Default for LabIdentifySettings {
    fn default() -> Self {
        LabIdentifySettings {
            seed: 37,
            form: FormChoice::Auto,
            draws: 48,
            degrading_draws: 96,
            refined: 3,
            max_iterations: 100,
            significance: 0.01,
            max_samples: 3000,
            cycle_band: 0.05,
            park_ang_beta: 0.15,
            ultimate_displacement_m: None,
            instantaneous: true,
        }
    }
}

impl LabIdentifySettings {
    pub fn check(&self) -> Result<()> {
        let ok = self.draws <= 100_000
            && self.degrading_draws <= 100_000
            && (1..=100).contains(&self.refined)
            && (1..=10_000).contains(&self.max_iterations)
            && self.significance > 0.0
            && self.significance < 1.0
            && (50..=10_000_000).contains(&self.max_samples)
            && self.cycle_band > 0.0
            && self.cycle_band < 0.5
            && self.park_ang_beta >= 0.0
            && self.park_ang_beta <= 10.0
            && self
                .ultimate_displacement_m
                .is_none_or(|d| d > 0.0 && d.is_finite());
        if ok {
            Ok(())
        } else {
            Err(Error::usage(format!(
                "lab identification settings out of range: {self:?} (draws ≤ 100000, refined 1–100, max_iterations 1–10000, significance in (0, 1), max_samples 50–10⁷, cycle_band in (0, 0.5), park_ang_beta 0–10, ultimate_displacement_m > 0)"
            )))
        }
    }
}

/// One identified parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterEstimate {
    pub name: &'static str,
    pub value: f64,
    /// Standard deviation (NaN when not determined; 0 for a fixed one).
    pub std: f64,
    pub units: &'static str,
    /// Fixed by the form (not fitted).
    pub fixed: bool,
}

/// The F-test of the plain model nested in the degrading/pinching one:
/// F = [(S_plain − S_deg)/q] / [S_deg/(N_eff − p)], q = 6, p = 11.
#[derive(Debug, Clone, PartialEq)]
pub struct FormTest {
    pub plain_ssr: f64,
    pub degrading_ssr: f64,
    pub f_statistic: f64,
    pub numerator_dof: usize,
    pub denominator_dof: usize,
    pub effective_samples: usize,
    pub p_value: f64,
}

/// The identified specimen.
#[derive(Debug, Clone)]
pub struct SpecimenIdentification {
    pub form: ModelForm,
    /// Why this form (the F-test's verdict in words).
    pub form_reason: String,
    pub initial_stiffness_n_per_m: f64,
    /// The plain part in the rehearsal's parameterisation.
    pub spring: BoucWenSpring,
    /// All parameters of Eq. L1–L6 (the plain form has zero degradation and
    /// pinching).
    pub parameters: BwbnParameters,
    pub estimates: Vec<ParameterEstimate>,
    /// The fitted force at every sample of the history (N).
    pub fitted_force_n: Vec<f64>,
    pub force_nrmse: f64,
    /// The plain model's force at every sample (equal to `fitted_force_n`
    /// when plain is chosen) and its NRMSE.
    pub plain_force_n: Vec<f64>,
    pub plain_nrmse: f64,
    /// (fitted − measured)/|measured| dissipated energy, per cycle.
    pub energy_error_per_cycle: Vec<f64>,
    pub cycles: Vec<CycleEnergy>,
    /// None when only one form was fitted.
    pub form_test: Option<FormTest>,
    pub damage: SpecimenDamage,
    /// Samples fitted (after thinning) and in the history.
    pub samples_fitted: usize,
    pub samples: usize,
    pub quasi_static: bool,
    /// Lag-1 autocorrelation of the chosen fit's residuals and the variance
    /// inflation N/N_eff (`fit::effective_samples`) applied to the standard
    /// deviations.
    pub residual_autocorrelation: f64,
    pub variance_inflation: f64,
}

fn check_history(history: &SpecimenHistory<'_>) -> Result<()> {
    let n = history.displacement_m.len();
    if history.force_n.len() != n {
        return Err(Error::usage(format!(
            "lab identification: {n} displacement samples but {} force samples",
            history.force_n.len()
        )));
    }
    if n < 20 {
        return Err(Error::usage(format!(
            "lab identification: {n} samples; at least 20 (displacement, force) pairs are needed"
        )));
    }
    for (what, v) in [
        ("displacement", history.displacement_m),
        ("force", history.force_n),
    ] {
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            return Err(Error::usage(format!(
                "lab identification: {what} sample {i} is not finite ({})",
                v[i]
            )));
        }
    }
    if let Some(problem) = history
        .time_s
        .and_then(|t| times_problem(t, n, "lab identification"))
    {
        return Err(Error::usage(problem));
    }
    let (lo, hi) = history
        .displacement_m
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    if !(hi > lo) {
        return Err(Error::usage(
            "lab identification: the displacement never changes; nothing to identify",
        ));
    }
    Ok(())
}

const PLAIN_FREE: [usize; 3] = [0, 1, 2];
const DEGRADING_FREE: [usize; 9] = [0, 1, 2, 3, 4, 5, 6, 7, 8];
const PARAMETER_UNITS: [&str; 9] = ["m", "1", "1", "1", "1", "1", "1", "1", "1"];

/// Identifies the specimen's hysteresis from its measured (x, F) history
/// (docs/lab-tests.md).
pub fn identify_specimen(
    history: &SpecimenHistory<'_>,
    settings: &LabIdentifySettings,
) -> Result<SpecimenIdentification> {
    settings.check()?;
    check_history(history)?;
    let n = history.displacement_m.len();
    let stride = n.div_ceil(settings.max_samples).max(1);
    let x: Vec<f64> = history
        .displacement_m
        .iter()
        .step_by(stride)
        .copied()
        .collect();
    let f: Vec<f64> = history.force_n.iter().step_by(stride).copied().collect();
    let substep = model::substep_for(history.displacement_m);
    let range = history
        .displacement_m
        .iter()
        .fold(f64::NEG_INFINITY, |m, &v| m.max(v))
        - history
            .displacement_m
            .iter()
            .fold(f64::INFINITY, |m, &v| m.min(v));
    let (lower, upper) = fit::shape_bounds(range);
    let mut rng = Rng::new(settings.seed);

    let problem_with = |free: &[usize]| fit::Problem {
        x: &x,
        force: &f,
        substep_m: substep,
        free: free.to_vec(),
        lower,
        upper,
    };
    let plain_problem = problem_with(&PLAIN_FREE);
    let start = BwbnParameters::plain(1.0, 0.1, range / 20.0, 0.5, 2.0).shape();
    let plain = plain_problem
        .search(
            &start,
            &PLAIN_FREE,
            &mut rng,
            settings.draws,
            settings.refined,
            settings.max_iterations,
        )
        .ok_or_else(|| Error::numerical("lab identification: no plain Bouc–Wen model fits the record (the force does not follow the displacement)"))?;

    let degrading_problem = problem_with(&DEGRADING_FREE);
    let degrading = if settings.form == FormChoice::Plain {
        None
    } else {
        // Extras start from small degradation and pinching around the plain optimum.
        let mut base = plain.params.shape();
        base[3] = 0.0;
        base[4] = 0.0;
        base[5] = 0.0;
        base[6] = 1.0;
        base[7] = 0.1;
        base[8] = 0.2;
        let mut draw_rng = Rng::derived(settings.seed, 1);
        // The extras drawn with the plain part held, the best draws refined
        // over all nine shape parameters.
        degrading_problem.search(
            &base,
            &DEGRADING_FREE[3..],
            &mut draw_rng,
            settings.degrading_draws,
            settings.refined,
            settings.max_iterations,
        )
    };

    let form_test = degrading.as_ref().map(|d| {
        // The noise's correlation is estimated under the unrestricted
        // (degrading/pinching) model: under H0 its residuals are the plain
        // model's, under H1 only they are noise — the plain model's carry its
        // misfit, whose smoothness would shrink N_eff exactly when the plain
        // model is inadequate (Eq. L9).
        let deg_resid: Vec<f64> = f.iter().zip(&d.model_force).map(|(a, b)| a - b).collect();
        let n_eff = fit::effective_samples(&deg_resid).0.floor() as usize;
        let q = 6usize;
        let p = 11usize;
        let d2 = n_eff.saturating_sub(p);
        let (fs, pv) = if d2 == 0 {
            (f64::NAN, 1.0)
        } else if d.ssr > 0.0 {
            let fs = ((plain.ssr - d.ssr).max(0.0) / q as f64) / (d.ssr / d2 as f64);
            (fs, f_survival(fs, q as f64, d2 as f64))
        } else if plain.ssr > 0.0 {
            (f64::INFINITY, 0.0)
        } else {
            (f64::NAN, 1.0)
        };
        FormTest {
            plain_ssr: plain.ssr,
            degrading_ssr: d.ssr,
            f_statistic: fs,
            numerator_dof: q,
            denominator_dof: d2,
            effective_samples: n_eff,
            p_value: pv,
        }
    });

    let (form, chosen, problem, form_reason) = match (settings.form, degrading, &form_test) {
        (FormChoice::Degrading, Some(d), _) => (
            ModelForm::Degrading,
            d,
            &degrading_problem,
            "degrading/pinching form requested".to_string(),
        ),
        (FormChoice::Auto, Some(d), Some(t)) if t.p_value < settings.significance => (
            ModelForm::Degrading,
            d,
            &degrading_problem,
            format!(
                "the plain model is not enough: F = {:.3} on ({}, {}) dof (N_eff = {} of {} samples), p = {:.2e} < {}",
                t.f_statistic, t.numerator_dof, t.denominator_dof, t.effective_samples, x.len(), t.p_value, settings.significance
            ),
        ),
        (FormChoice::Auto, Some(_), Some(t)) => (
            ModelForm::Plain,
            plain.clone(),
            &plain_problem,
            format!(
                "degradation and pinching not significant: F = {:.3} on ({}, {}) dof (N_eff = {} of {} samples), p = {:.2e} ≥ {}",
                t.f_statistic, t.numerator_dof, t.denominator_dof, t.effective_samples, x.len(), t.p_value, settings.significance
            ),
        ),
        _ => (
            ModelForm::Plain,
            plain.clone(),
            &plain_problem,
            "plain form requested".to_string(),
        ),
    };

    let resid: Vec<f64> = f
        .iter()
        .zip(&chosen.model_force)
        .map(|(a, b)| a - b)
        .collect();
    let (n_eff, rho) = fit::effective_samples(&resid);
    let inflation = x.len() as f64 / n_eff;
    let stds = problem.standard_deviations(&chosen, inflation);
    let p = chosen.params;
    let mut estimates = vec![
        ParameterEstimate {
            name: "initial_stiffness_n_per_m",
            value: p.initial_stiffness_n_per_m,
            std: stds[0],
            units: "N/m",
            fixed: false,
        },
        ParameterEstimate {
            name: "post_yield_ratio",
            value: p.post_yield_ratio,
            std: stds[1],
            units: "1",
            fixed: false,
        },
    ];
    let shape = p.shape();
    for i in 0..9 {
        let k = problem.free.iter().position(|&j| j == i);
        estimates.push(ParameterEstimate {
            name: model::SHAPE_NAMES[i],
            value: shape[i],
            std: k.map_or(0.0, |k| stds[2 + k]),
            units: PARAMETER_UNITS[i],
            fixed: k.is_none(),
        });
    }

    let fitted_force_n = model::restoring_force(history.displacement_m, &p, substep);
    let plain_full = model::restoring_force(history.displacement_m, &plain.params, substep);
    let cycles = loops::cycle_energies(
        history.displacement_m,
        history.force_n,
        &fitted_force_n,
        settings.cycle_band,
    );
    let state = model::hysteretic_state(history.displacement_m, &shape, substep);
    let eta_end = 1.0 + p.stiffness_degradation * state.energy.last().copied().unwrap_or(0.0);
    let damage = loops::specimen_damage(
        history.displacement_m,
        history.force_n,
        p.initial_stiffness_n_per_m,
        p.post_yield_ratio,
        p.yield_displacement_m,
        eta_end,
        settings.park_ang_beta,
        settings.ultimate_displacement_m,
    );
    Ok(SpecimenIdentification {
        form,
        form_reason,
        initial_stiffness_n_per_m: p.initial_stiffness_n_per_m,
        spring: p.spring(),
        parameters: p,
        estimates,
        force_nrmse: loops::nrmse(history.force_n, &fitted_force_n),
        plain_nrmse: loops::nrmse(history.force_n, &plain_full),
        plain_force_n: plain_full,
        fitted_force_n,
        energy_error_per_cycle: cycles.iter().map(CycleEnergy::relative_error).collect(),
        cycles,
        form_test,
        damage,
        samples_fitted: x.len(),
        samples: n,
        quasi_static: history.time_s.is_none(),
        residual_autocorrelation: rho,
        variance_inflation: inflation,
    })
}

/// The specimen history of a lab record: its first measured displacement
/// and first measured force (and its times, unless quasi-static).
pub fn history_of(record: &LabRecord) -> Result<SpecimenHistory<'_>> {
    let find = |q: Quantity| {
        record.find(q, LabRole::Measured, None).ok_or_else(|| {
            Error::usage(format!(
                "lab record {:?}: no measured {q} channel (channels: {})",
                record.name,
                record
                    .channels
                    .iter()
                    .map(|c| format!("{} ({} {})", c.id, c.role.name(), c.quantity))
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
        })
    };
    let d = find(Quantity::Displacement)?;
    let f = find(Quantity::Force)?;
    Ok(SpecimenHistory {
        displacement_m: &record.values[d],
        force_n: &record.values[f],
        time_s: record.time_s.as_deref(),
    })
}
