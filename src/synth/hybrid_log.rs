//! A synthetic hybrid-test log (`quaketwin synth-hybrid-log`): the rehearsal of a design run
//! with a known actuator (servo, delay, measurement noise; seeded, `crate::rng`) recorded at
//! every integration step as a pseudo-dynamic test's controller logs it
//! (`crate::hybrid_test::log`). The truth — the actuator's equivalent lag τ + T and the noise —
//! goes beside it, so that `compare-test` can be checked against it.

use crate::error::{Error, Result};
use crate::hybrid_test::compare::equivalent_lag_s;
use crate::hybrid_test::HybridLog;
use crate::rehearse::sweep::{auto_substeps, run_recorded};
use crate::rehearse::{RehearsalModel, RehearseSettings};

/// What the generator is asked for.
#[derive(Debug, Clone, PartialEq)]
pub struct HybridLogSettings {
    /// The emulated test: scheme, servo, bandwidth, delay, noise, seed, specimen (Bouc–Wen).
    pub test: RehearseSettings,
    /// λ; default the design's.
    pub time_scale: Option<f64>,
    /// Integration steps per motion step; default the rehearsal's automatic choice.
    pub substeps: Option<usize>,
    /// Simulation time logged (s); default the design's whole motion.
    pub duration_s: Option<f64>,
}

impl Default for HybridLogSettings {
    fn default() -> Self {
        HybridLogSettings {
            test: RehearseSettings {
                delay_s: 0.008,
                displacement_noise_m: 2e-8,
                seed: 37,
                ..RehearseSettings::default()
            },
            time_scale: None,
            substeps: None,
            duration_s: None,
        }
    }
}

/// The generator's truth (written as `truth.json`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct HybridLogTruth {
    pub time_scale: f64,
    pub substeps: usize,
    pub dt_s: f64,
    pub lab_step_s: f64,
    pub steps: usize,
    pub servo: String,
    pub bandwidth_hz: f64,
    pub delay_s: f64,
    /// τ + T: the low-frequency group delay of the servo (s, laboratory time).
    pub lag_s: f64,
    pub displacement_noise_m: f64,
    pub force_noise_n: f64,
    pub seed: u64,
    pub bouc_wen: Option<crate::rehearse::BoucWenSpring>,
    pub stable: bool,
}

/// The log of `model`'s hybrid test under `settings`.
pub fn synth_hybrid_log(
    model: &RehearsalModel,
    settings: &HybridLogSettings,
    source: &str,
) -> Result<(HybridLog, HybridLogTruth)> {
    crate::fixed_order_reductions();
    model.validate("rehearsal model")?;
    settings.test.check("synth-hybrid-log")?;
    let lam = settings.time_scale.unwrap_or(model.time_scale);
    if !(lam > 0.0 && lam.is_finite()) {
        return Err(Error::usage(format!(
            "--time-scale {lam}: must be positive"
        )));
    }
    let substeps = settings.substeps.unwrap_or_else(|| auto_substeps(model));
    if !(1..=crate::rehearse::MAX_SUBSTEPS).contains(&substeps) {
        return Err(Error::usage(format!(
            "--substeps {substeps}: must be 1..={}",
            crate::rehearse::MAX_SUBSTEPS
        )));
    }
    let steps = match settings.duration_s {
        None => model.steps(),
        Some(d) if d > 0.0 && d.is_finite() => {
            ((d / model.dt).round() as usize + 1).clamp(2, model.steps())
        }
        Some(d) => return Err(Error::usage(format!("--duration {d}: must be positive"))),
    };
    let model = model.truncated(steps)?;
    let actuator = settings.test.actuator(model.actuator_band_hz);
    actuator.check()?;
    let (summary, h) = run_recorded(&model, &settings.test, &actuator, lam, substeps, 0, Some(1))?;
    if !summary.stable {
        // A diverged test has no log worth comparing (its last steps are not finite).
        return Err(Error::numerical(format!(
            "synth-hybrid-log: the emulated test diverged at {} s of simulation time (λ = {lam}, {substeps} steps per motion step): choose a larger λ or another specimen",
            summary.divergence_time_s.unwrap_or(f64::NAN)
        )));
    }
    let dt = model.dt / substeps as f64;
    let n = h.time_s.len();
    let log = HybridLog {
        source: source.to_string(),
        actuators: model.actuators.iter().map(|a| a.actuator).collect(),
        lab_time_s: Some((0..n).map(|k| lam * k as f64 * dt).collect()),
        time_s: (0..n).map(|k| k as f64 * dt).collect(),
        command_m: h.command,
        measured_m: h.achieved,
        force_n: h.force,
        response_m: Some(h.response),
    };
    let truth = HybridLogTruth {
        time_scale: lam,
        substeps,
        dt_s: dt,
        lab_step_s: lam * dt,
        steps: n,
        servo: actuator.servo.name().into(),
        bandwidth_hz: actuator.bandwidth_hz,
        delay_s: actuator.delay_s,
        lag_s: equivalent_lag_s(&actuator),
        displacement_noise_m: settings.test.displacement_noise_m,
        force_noise_n: settings.test.force_noise_n,
        seed: settings.test.seed,
        bouc_wen: settings.test.bouc_wen.clone(),
        stable: summary.stable,
    };
    Ok((log, truth))
}
