//! A logged hybrid test against its rehearsal and its twin (numerical code, no I/O;
//! docs/lab-tests.md, "Comparing a hybrid test with its rehearsal").
//!
//! 1. Tracking: the log's command − measured (RMS, peak) and the lag and noise behind it
//!    (`tracking`).
//! 2. The rehearsal of the same design re-run at the log's time scale λ and step Δt, its
//!    histories recorded at every step, with the design's rehearsal settings: its tracking
//!    error, spurious energy, command, force and response against the log's.
//! 3. Energy: the spurious energy of the log (Mosqueda et al. 2005, 2007; `rehearse::energy`),
//!    E_s = Σ ½ (r_k + r_{k+1}) · [(d^m_{k+1} − d^m_k) − (d^c_{k+1} − d^c_k)], r the force
//!    less its value at step 0 (the static state), over the input energy of the ground motion
//!    (the rehearsal's: the same design and motion) — exactly the rehearsal's energy error.
//! 4. Response: the log's `response_m` (when logged) and the rehearsal's against the twin (the
//!    full model's response at the actuated DoFs, `reference` of the rehearsal model), WNRMSE
//!    Eq. 84, at the motion's steps.
//! 5. Update: the specimen model identified from the logged (measured displacement, restoring
//!    force) (`update_specimen`: `crate::lab`'s identification) and the actuator model from the
//!    identified lag and noise; the rehearsal re-run with both: predicted against logged.

use faer::linalg::solvers::Solve;
use faer::Mat;

use super::log::HybridLog;
use super::tracking::{identify_tracking, pooled_rms, tracking_error, TrackingIdentification};
use crate::design::pod::wnrmse;
use crate::error::{Error, Result};
use crate::rehearse::actuator::MAX_DELAY_S;
use crate::rehearse::energy::EnergyBalance;
use crate::rehearse::sweep::run_recorded;
use crate::rehearse::{
    ActuatorModel, BoucWenSpring, Histories, RehearsalModel, RehearseSettings, ServoKind,
};

/// Settings of a comparison.
#[derive(Debug, Clone, PartialEq)]
pub struct CompareSettings {
    /// The rehearsal's settings (the design run's, else the defaults); λ and the step come
    /// from the log.
    pub rehearsal: RehearseSettings,
    /// λ when the log has no `lab_time_s` (else it must agree with the log's).
    pub time_scale: Option<f64>,
    /// Longest lag searched (s, laboratory time).
    pub max_lag_s: f64,
    /// Identify the specimen and re-run the rehearsal with it.
    pub update_specimen: bool,
}

impl Default for CompareSettings {
    fn default() -> Self {
        CompareSettings {
            rehearsal: RehearseSettings::default(),
            time_scale: None,
            max_lag_s: MAX_DELAY_S,
            update_specimen: true,
        }
    }
}

/// One history set's figures over the log's steps.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RunFigures {
    /// `logged`, `rehearsal` or `updated rehearsal`.
    pub source: String,
    /// The identified lag (logged) or the actuator model's low-frequency group delay (s).
    pub lag_s: f64,
    /// The identified noise (logged) or the model's displacement noise (m).
    pub noise_std_m: f64,
    /// RMS and peak of command − measured per actuator (m).
    pub tracking_rms_m: Vec<f64>,
    pub tracking_peak_m: Vec<f64>,
    /// max |E_s| / max |E_in|.
    pub energy_error: f64,
    /// WNRMSE against the log of the command, the force, the response (None: the log itself,
    /// or the quantity not logged, or a diverged run).
    pub command_wnrmse: Option<f64>,
    pub force_wnrmse: Option<f64>,
    pub response_wnrmse: Option<f64>,
    /// WNRMSE of the response against the twin at the motion's steps.
    pub twin_wnrmse: Option<f64>,
    pub stable: bool,
    /// Simulation time of a rehearsal's divergence (s).
    pub divergence_time_s: Option<f64>,
}

impl RunFigures {
    pub fn pooled_tracking_rms_m(&self) -> f64 {
        pooled_rms(&self.tracking_rms_m)
    }
}

/// The specimen identified from the log.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SpecimenFit {
    /// `bouc-wen` or `bouc-wen-baber-noori` (lab's model form).
    pub form: String,
    pub initial_stiffness_n_per_m: f64,
    pub spring: BoucWenSpring,
    /// NRMSE of the fitted force (lab's definition).
    pub force_nrmse: f64,
    /// Mean over the cycles of |fitted − measured| / |measured| dissipated energy (NaN: no cycle).
    pub mean_energy_error_per_cycle: f64,
}

/// The specimen update: on which actuator, and what came of it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SpecimenUpdate {
    /// The design's actuator number whose (measured displacement, own force) was fitted.
    pub actuator: usize,
    /// K_P's diagonal there (N/m): the design's specimen stiffness.
    pub design_stiffness_n_per_m: f64,
    pub fit: Option<SpecimenFit>,
    /// Why there is no fit.
    pub failure: Option<String>,
}

/// Everything a comparison found.
#[derive(Debug, Clone)]
pub struct Comparison {
    pub time_scale: f64,
    pub substeps: usize,
    pub dt_s: f64,
    pub lab_step_s: f64,
    pub tracking: TrackingIdentification,
    /// logged, rehearsal, updated rehearsal (when run).
    pub runs: Vec<RunFigures>,
    pub specimen: Option<SpecimenUpdate>,
    pub rehearsal: Histories,
    pub updated: Option<Histories>,
    pub rehearsal_settings: RehearseSettings,
    pub updated_settings: Option<RehearseSettings>,
    /// The rehearsal model cut to the log's duration (its reference: the twin).
    pub model: RehearsalModel,
}

/// Low-frequency group delay of an actuator model (s): τ + T (first order, T = 1/2πf_c),
/// τ + 2ζ/ω (second order).
pub fn equivalent_lag_s(a: &ActuatorModel) -> f64 {
    let w = 2.0 * std::f64::consts::PI * a.bandwidth_hz;
    a.delay_s
        + match a.servo {
            ServoKind::Ideal => 0.0,
            ServoKind::FirstOrder => 1.0 / w,
            ServoKind::SecondOrder => 2.0 * a.damping / w,
        }
}

/// The spurious energy of histories (force less its step-0 value) over `max_input`.
fn energy_error(
    command: &[Vec<f64>],
    measured: &[Vec<f64>],
    force: &[Vec<f64>],
    max_input: f64,
) -> f64 {
    let m = command.len();
    let n = command.first().map(|c| c.len()).unwrap_or(0);
    let mut e = EnergyBalance::default();
    let at = |v: &[Vec<f64>], k: usize| -> Vec<f64> { (0..m).map(|a| v[a][k]).collect() };
    let r = |k: usize| -> Vec<f64> { (0..m).map(|a| force[a][k] - force[a][0]).collect() };
    for k in 0..n.saturating_sub(1) {
        e.add_actuators(
            &r(k),
            &r(k + 1),
            &at(measured, k),
            &at(measured, k + 1),
            &at(command, k),
            &at(command, k + 1),
        );
    }
    if max_input > 0.0 {
        e.max_spurious / max_input
    } else {
        0.0
    }
}

fn rows_mat(rows: &[Vec<f64>], n: usize) -> Mat<f64> {
    Mat::from_fn(rows.len(), n, |i, j| rows[i][j])
}

/// WNRMSE (Eq. 84) of `approx` against `truth`, over their common first `n` columns.
fn wn(truth: &[Vec<f64>], approx: &[Vec<f64>]) -> Option<f64> {
    let n = truth.first()?.len().min(approx.first()?.len());
    (n >= 2).then(|| wnrmse(rows_mat(truth, n).as_ref(), rows_mat(approx, n).as_ref()).0)
}

/// Every `substeps`-th sample of each row: the motion's steps.
fn at_motion_steps(rows: &[Vec<f64>], substeps: usize) -> Vec<Vec<f64>> {
    rows.iter()
        .map(|r| r.iter().step_by(substeps).copied().collect())
        .collect()
}

/// The log's actuators checked against the design's: the same count and numbers.
fn check_actuators(log: &HybridLog, model: &RehearsalModel) -> Result<()> {
    let design: Vec<usize> = model.actuators.iter().map(|a| a.actuator).collect();
    if log.actuators.len() != design.len() {
        return Err(Error::usage(format!(
            "{}: the log has {} actuators, the design {}: a log of another design?",
            log.source,
            log.actuators.len(),
            design.len()
        )));
    }
    let mut sorted = design.clone();
    sorted.sort_unstable();
    if sorted != log.actuators || design != sorted {
        return Err(Error::usage(format!(
            "{}: the log's actuators {:?} are not the design's {:?}",
            log.source, log.actuators, design
        )));
    }
    Ok(())
}

/// The log's λ and the simulation steps per motion step.
fn time_base(
    log: &HybridLog,
    model: &RehearsalModel,
    settings: &CompareSettings,
) -> Result<(f64, usize)> {
    let dt = log.dt_s();
    let ratio = model.dt / dt;
    let substeps = ratio.round() as usize;
    if substeps == 0 || (ratio - substeps as f64).abs() > 1e-6 * ratio {
        return Err(Error::usage(format!(
            "{}: the log's step {dt} s does not divide the design's motion step {} s",
            log.source, model.dt
        )));
    }
    let lam = match (log.time_scale(), settings.time_scale) {
        (Some(l), Some(given)) if (l - given).abs() > 1e-6 * l => {
            return Err(Error::usage(format!(
                "{}: the log's λ (lab_time_s / time_s) is {l}, --time-scale says {given}",
                log.source
            )))
        }
        (Some(l), _) | (None, Some(l)) => l,
        (None, None) => {
            return Err(Error::usage(format!(
                "{}: no `lab_time_s` column: give the time scale λ (--time-scale)",
                log.source
            )))
        }
    };
    if !(lam > 0.0 && lam.is_finite()) {
        return Err(Error::usage(format!(
            "time scale λ = {lam} must be positive"
        )));
    }
    Ok((lam, substeps))
}

/// One rehearsal recorded at every step, cut to `n` steps.
fn rehearse_steps(
    model: &RehearsalModel,
    settings: &RehearseSettings,
    time_scale: f64,
    substeps: usize,
    n: usize,
) -> Result<(crate::rehearse::RunSummary, Histories)> {
    settings.check("rehearsal settings")?;
    let actuator = settings.actuator(model.actuator_band_hz);
    actuator.check()?;
    let (summary, mut h) =
        run_recorded(model, settings, &actuator, time_scale, substeps, 0, Some(1))?;
    for v in [
        &mut h.command,
        &mut h.achieved,
        &mut h.force,
        &mut h.response,
    ] {
        for r in v.iter_mut() {
            r.truncate(n);
        }
    }
    h.time_s.truncate(n);
    Ok((summary, h))
}

/// The figures of rehearsed histories against the log (`settings`: the rehearsal's).
fn figures(
    source: &str,
    h: &Histories,
    summary: &crate::rehearse::RunSummary,
    settings: &RehearseSettings,
    log: &HybridLog,
    model: &RehearsalModel,
    substeps: usize,
) -> RunFigures {
    let (rms, peak) = tracking_error(&h.command, &h.achieved);
    let stable = summary.stable;
    RunFigures {
        source: source.into(),
        lag_s: equivalent_lag_s(&settings.actuator(model.actuator_band_hz)),
        noise_std_m: settings.displacement_noise_m,
        tracking_rms_m: rms,
        tracking_peak_m: peak,
        energy_error: energy_error(
            &h.command,
            &h.achieved,
            &h.force,
            summary.max_input_energy_j,
        ),
        command_wnrmse: stable.then(|| wn(&log.command_m, &h.command)).flatten(),
        force_wnrmse: stable.then(|| wn(&log.force_n, &h.force)).flatten(),
        response_wnrmse: log
            .response_m
            .as_ref()
            .and_then(|r| stable.then(|| wn(r, &h.response)).flatten()),
        twin_wnrmse: stable
            .then(|| wn(&model.reference, &at_motion_steps(&h.response, substeps)))
            .flatten(),
        stable,
        divergence_time_s: summary.divergence_time_s,
    }
}

/// The specimen model from the logged (measured displacement, restoring force) of one
/// actuator: `crate::lab`'s identification with its shipped defaults in the **plain** form
/// (docs/lab-tests.md): the rehearsal's specimen is a plain Bouc–Wen hinge
/// (`rehearse::specimen`), and the plain part of a Bouc–Wen–Baber–Noori fit is not the best
/// plain model — on a 1 s yielding facade log the F-test chose the degrading form and the
/// rehearsal re-run with its plain part predicted 7 × the logged tracking error. The failure's
/// text when it cannot be identified.
pub fn update_specimen(
    displacement_m: &[f64],
    force_n: &[f64],
    time_s: Option<&[f64]>,
) -> std::result::Result<SpecimenFit, String> {
    let history = crate::lab::SpecimenHistory {
        displacement_m,
        force_n,
        time_s,
    };
    let settings = crate::lab::LabIdentifySettings {
        form: crate::lab::FormChoice::Plain,
        ..Default::default()
    };
    let id = crate::lab::identify_specimen(&history, &settings).map_err(|e| e.to_string())?;
    let cycles = &id.energy_error_per_cycle;
    Ok(SpecimenFit {
        form: id.form.name().to_string(),
        initial_stiffness_n_per_m: id.initial_stiffness_n_per_m,
        spring: id.spring,
        force_nrmse: id.force_nrmse,
        mean_energy_error_per_cycle: if cycles.is_empty() {
            f64::NAN
        } else {
            cycles.iter().map(|e| e.abs()).sum::<f64>() / cycles.len() as f64
        },
    })
}

/// The actuator whose measured displacement spans the widest range, its own force, and the
/// fit. The rehearsal's specimen is a Bouc–Wen hinge in series with K_P at every actuated DoF,
/// r = K_P e, e_a = α d_a + (1 − α) u_y z_a (`rehearse::specimen`): so e = K_P⁻¹ r holds the
/// hinge of DoF a alone, and K_P,aa e_a is a single-DoF Bouc–Wen force of d_a (Eq. L1) whatever
/// the other DoFs do. (Subtracting the elastic coupling Σ_{j≠a} K_P,aj d_j instead leaves the
/// other hinges' slips in it once they yield.) A linear specimen gives K_P,aa d_a either way.
fn specimen_update(log: &HybridLog, model: &RehearsalModel, lab_time: &[f64]) -> SpecimenUpdate {
    let range = |v: &[f64]| {
        v.iter().fold(f64::NEG_INFINITY, |a, b| a.max(*b))
            - v.iter().fold(f64::INFINITY, |a, b| a.min(*b))
    };
    let a = (0..log.actuators.len())
        .max_by(|&i, &j| range(&log.measured_m[i]).total_cmp(&range(&log.measured_m[j])))
        .unwrap_or(0);
    let kp = &model.ps_stiffness;
    let m = kp.len();
    // Row a of K_P⁻¹ (K_P symmetric: the solution of K_P w = unit_a).
    let unit = Mat::from_fn(m, 1, |i, _| if i == a { 1.0 } else { 0.0 });
    let w = crate::rehearse::model::mat(kp)
        .partial_piv_lu()
        .solve(&unit);
    let own: Vec<f64> = (0..log.steps())
        .map(|k| kp[a][a] * (0..m).map(|j| w[(j, 0)] * log.force_n[j][k]).sum::<f64>())
        .collect();
    let (fit, failure) = match update_specimen(&log.measured_m[a], &own, Some(lab_time)) {
        Ok(f) => (Some(f), None),
        Err(e) => (None, Some(e)),
    };
    SpecimenUpdate {
        actuator: log.actuators[a],
        design_stiffness_n_per_m: kp[a][a],
        fit,
        failure,
    }
}

/// Compares `log` with the rehearsal of `model` (a design's `rehearsal_model.json`).
pub fn compare(
    log: &HybridLog,
    model: &RehearsalModel,
    settings: &CompareSettings,
) -> Result<Comparison> {
    crate::fixed_order_reductions();
    model.validate("rehearsal model")?;
    check_actuators(log, model)?;
    let (time_scale, substeps) = time_base(log, model, settings)?;
    let n = log.steps();
    let motion_steps = (n - 1).div_ceil(substeps) + 1;
    if motion_steps > model.steps() {
        return Err(Error::usage(format!(
            "{}: the log covers {} s of simulation, the design's motion {} s",
            log.source,
            log.time_s[n - 1] - log.time_s[0],
            (model.steps() - 1) as f64 * model.dt
        )));
    }
    let model = model.truncated(motion_steps)?;
    let dt = model.dt / substeps as f64;
    let lab_step = time_scale * dt;
    let tracking = identify_tracking(
        &log.command_m,
        &log.measured_m,
        lab_step,
        settings.max_lag_s,
    )?;

    let (summary, rehearsal) =
        rehearse_steps(&model, &settings.rehearsal, time_scale, substeps, n)?;
    let predicted = figures(
        "rehearsal",
        &rehearsal,
        &summary,
        &settings.rehearsal,
        log,
        &model,
        substeps,
    );
    let logged = RunFigures {
        source: "logged".into(),
        lag_s: tracking.lag_s,
        noise_std_m: tracking.noise_std_m,
        tracking_rms_m: tracking.rms_m.clone(),
        tracking_peak_m: tracking.peak_m.clone(),
        energy_error: energy_error(
            &log.command_m,
            &log.measured_m,
            &log.force_n,
            summary.max_input_energy_j,
        ),
        command_wnrmse: None,
        force_wnrmse: None,
        response_wnrmse: None,
        twin_wnrmse: log
            .response_m
            .as_ref()
            .and_then(|r| wn(&model.reference, &at_motion_steps(r, substeps))),
        stable: true,
        divergence_time_s: None,
    };
    let mut runs = vec![logged, predicted];
    let (mut specimen, mut updated, mut updated_settings) = (None, None, None);
    if settings.update_specimen {
        let lab_time: Vec<f64> = (0..n).map(|k| k as f64 * lab_step).collect();
        let update = specimen_update(log, &model, &lab_time);
        let mut s = settings.rehearsal.clone();
        // The identified actuator: a pure delay L (the lag model the tracking fit rests on)
        // and the identified noise.
        s.servo = ServoKind::Ideal;
        s.delay_s = tracking.lag_s.min(MAX_DELAY_S);
        s.displacement_noise_m = tracking.noise_std_m;
        if let Some(f) = &update.fit {
            s.bouc_wen = Some(f.spring.clone());
        }
        let (sum, h) = rehearse_steps(&model, &s, time_scale, substeps, n)?;
        runs.push(figures(
            "updated rehearsal",
            &h,
            &sum,
            &s,
            log,
            &model,
            substeps,
        ));
        specimen = Some(update);
        updated = Some(h);
        updated_settings = Some(s);
    }
    Ok(Comparison {
        time_scale,
        substeps,
        dt_s: dt,
        lab_step_s: lab_step,
        tracking,
        runs,
        specimen,
        rehearsal,
        updated,
        rehearsal_settings: settings.rehearsal.clone(),
        updated_settings,
        model,
    })
}
