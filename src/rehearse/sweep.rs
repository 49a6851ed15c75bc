//! One rehearsal and the sweep over time scales λ and NS mode counts.
//!
//! A run integrates the hybrid system (`integrator`) with the specimen emulated at the
//! actuated coordinates: the actuators (`actuator`) move it in laboratory time λ Δt per step,
//! the load cells measure K_P d_achieved (+ noise). Per run: stability (a response beyond
//! `divergence_factor` × the reference's peak, or non-finite, is divergence; its simulation
//! time is reported), the energy error (`energy`), the response WNRMSE (Eq. 84,
//! `design::pod::wnrmse`) of the total displacement at the actuated DoFs against the full
//! twin's (`model::fine_reference`), tracking-error statistics per actuator. The smallest safe
//! λ (stable, WNRMSE ≤ `response_tolerance`, energy error ≤ `energy_tolerance`) at the
//! design's NS mode count is recommended.

use faer::Mat;
use rayon::prelude::*;

use super::actuator::{ActuatorBank, ActuatorModel};
use super::energy::EnergyBalance;
use super::gravity::{static_state, Preload};
use super::integrator::{HybridSystem, Integrator, Specimen};
use super::model::{mat, RehearsalModel};
use super::specimen::SpecimenModel;
use super::RehearseSettings;
use crate::design::pod::wnrmse;
use crate::error::{Error, Result};
use crate::rng::Rng;

/// The outcome of one rehearsal run.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSummary {
    pub ns_modes: usize,
    pub time_scale: f64,
    /// Highest prototype frequency with these NS modes (Hz) and its laboratory frequency / λ.
    pub top_frequency_hz: f64,
    pub bandwidth_hz: f64,
    pub stable: bool,
    /// Simulation time of divergence (s).
    pub divergence_time_s: Option<f64>,
    pub energy_error: f64,
    /// WNRMSE against the reference (None when diverged).
    pub response_wnrmse: Option<f64>,
    /// Per actuator: RMS and max |command − achieved| (m).
    pub tracking_rms_m: Vec<f64>,
    pub tracking_max_m: Vec<f64>,
    /// max_t |E_in(t)|, the ground motion's input energy (J): the energy error's denominator.
    pub max_input_energy_j: f64,
    pub safe: bool,
}

/// Time histories of one run at the base-motion steps, `[actuator][sample]`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Histories {
    pub time_s: Vec<f64>,
    pub command: Vec<Vec<f64>>,
    pub achieved: Vec<Vec<f64>>,
    pub force: Vec<Vec<f64>>,
    pub response: Vec<Vec<f64>>,
}

/// A rehearsal: every run of the sweep, the recommendation and one run's histories.
#[derive(Debug, Clone)]
pub struct Rehearsal {
    pub runs: Vec<RunSummary>,
    /// The NS mode count the recommendation is for (the design's, or the largest swept).
    pub ns_modes: usize,
    /// Index in `runs` of the smallest safe λ at `ns_modes` (None: no λ is safe).
    pub recommended: Option<usize>,
    /// Index of the run whose histories are kept: the recommended one, else the one at the
    /// design's λ (or the nearest swept λ).
    pub history_run: usize,
    pub histories: Histories,
    pub substeps: usize,
    pub dt_s: f64,
    pub actuator: ActuatorModel,
    /// The gravity pre-load's static state at the design's NS modes (None: not applied).
    pub preload: Option<Preload>,
}

/// The specimen behind its actuators: its force at the achieved displacement.
struct Emulated {
    bank: ActuatorBank,
    specimen: SpecimenModel,
    achieved: Vec<f64>,
    measured: Vec<f64>,
    noise: (f64, f64),
    rng: Rng,
}

impl Specimen for Emulated {
    fn impose(&mut self, targets: &[f64], force: &mut [f64]) {
        self.bank.advance(targets, &mut self.achieved);
        let m = targets.len();
        self.specimen.force(&self.achieved, force);
        for f in force.iter_mut().take(m) {
            if self.noise.1 > 0.0 {
                *f += self.noise.1 * self.rng.normal();
            }
        }
        for i in 0..m {
            self.measured[i] = self.achieved[i];
            if self.noise.0 > 0.0 {
                self.measured[i] += self.noise.0 * self.rng.normal();
            }
        }
    }
}

/// Simulation steps per base-motion step: the fewest with ω_max Δt ≤ 1.
pub fn auto_substeps(model: &RehearsalModel) -> usize {
    let w = 2.0 * std::f64::consts::PI * model.top_frequency_hz();
    ((w * model.dt).ceil() as usize).max(1)
}

/// One rehearsal of `model` at time scale λ; `stream` seeds its noise; histories (at the
/// base-motion steps) when `record`.
pub fn run(
    model: &RehearsalModel,
    settings: &RehearseSettings,
    actuator: &ActuatorModel,
    time_scale: f64,
    substeps: usize,
    stream: u64,
    record: bool,
) -> Result<(RunSummary, Histories)> {
    let every = record.then_some(substeps);
    run_recorded(
        model, settings, actuator, time_scale, substeps, stream, every,
    )
}

/// [`run`] with histories every `record_every` simulation steps (`Some(1)`: every step, what
/// a pseudo-dynamic test's controller logs — `crate::synth::hybrid_log`, `crate::hybrid_test`);
/// None: no histories.
pub fn run_recorded(
    model: &RehearsalModel,
    settings: &RehearseSettings,
    actuator: &ActuatorModel,
    time_scale: f64,
    substeps: usize,
    stream: u64,
    record_every: Option<usize>,
) -> Result<(RunSummary, Histories)> {
    let record = record_every.is_some();
    let every = record_every.unwrap_or(substeps).max(1);
    let n = model.n_coordinates();
    let (o, m) = (model.ns_modes, model.actuators.len());
    let k_hat = mat(&model.stiffness);
    let mass = mat(&model.mass);
    let kp = mat(&model.ps_stiffness);
    let mut kn = k_hat.clone();
    for i in 0..m {
        for j in 0..m {
            kn[(o + i, o + j)] -= kp[(i, j)];
        }
    }
    let [a0, a1] = model.rayleigh;
    let sys = HybridSystem {
        damping: Mat::from_fn(n, n, |i, j| a0 * mass[(i, j)] + a1 * k_hat[(i, j)]),
        mass,
        numerical_stiffness: kn,
        ps_stiffness: kp.clone(),
        offset: o,
    };
    let dt = model.dt / substeps as f64;
    let steps = model.steps();
    // f(t) = −Σ_d ψᵀ b_d a_d(t), the motion linearly interpolated between its samples.
    let load = |j: usize| -> Vec<f64> {
        let (k, r) = (j / substeps, (j % substeps) as f64 / substeps as f64);
        let mut f = vec![0.0; n];
        for (b, acc) in model.loads.iter().zip(&model.accelerations) {
            let a = if k + 1 < steps {
                acc[k] + r * (acc[k + 1] - acc[k])
            } else {
                acc[k]
            };
            for i in 0..n {
                f[i] -= b[i] * a;
            }
        }
        f
    };
    let mut integ = Integrator::new(&sys, settings.scheme, settings.alpha, dt, &load(0))?;
    // Gravity pre-load (`gravity`, Eq. G1–G2): the static state, the specimen driven to d_g,
    // the actuators holding it; f̂_g is added to every step's load.
    let preload = if settings.preload(model) {
        Some(static_state(model)?)
    } else {
        None
    };
    let f_g = preload
        .as_ref()
        .map(|_| model.gravity_load.clone())
        .unwrap_or_else(|| vec![0.0; n]);
    let total_load = |j: usize| -> Vec<f64> {
        let mut f = load(j);
        axpy_(&f_g, &mut f);
        f
    };
    let mut spec = Emulated {
        bank: ActuatorBank::new(actuator, m, time_scale * dt),
        specimen: SpecimenModel::new(
            (0..m * m).map(|k| kp[(k / m, k % m)]).collect(),
            m,
            settings.bouc_wen.clone(),
        ),
        achieved: vec![0.0; m],
        measured: vec![0.0; m],
        noise: (settings.displacement_noise_m, settings.force_noise_n),
        rng: Rng::derived(settings.seed, stream),
    };
    let (mut r_g, mut d_g, mut y_g) = (vec![0.0; m], vec![0.0; m], vec![0.0; m]);
    if let Some(p) = &preload {
        d_g.copy_from_slice(&p.displacement);
        spec.specimen.force(&d_g, &mut r_g);
        spec.bank.hold(&d_g);
        spec.achieved.copy_from_slice(&d_g);
        spec.measured.copy_from_slice(&d_g);
        integ.preload(&p.x, &r_g);
        for (a, ya) in y_g.iter_mut().enumerate() {
            *ya = model.observation[a]
                .iter()
                .zip(&p.x)
                .map(|(o, x)| o * x)
                .sum();
        }
    }
    let ref_peak = model
        .reference
        .iter()
        .flatten()
        .fold(0.0_f64, |a, v| a.max(v.abs()));
    let limit = settings.divergence_factor * ref_peak;
    let mut energy = EnergyBalance::default();
    let mut command = d_g.clone();
    // The energy balance is of the seismic increment about the static state: forces r − r_g,
    // loads without f̂_g.
    let (mut dc0, mut dm0, mut r0) = (d_g.clone(), d_g.clone(), vec![0.0; m]);
    let mut r_inc = vec![0.0; m];
    let (mut sum_sq, mut max_e) = (vec![0.0; m], vec![0.0_f64; m]);
    let mut response: Vec<Vec<f64>> = vec![vec![0.0]; m];
    let mut h = Histories::default();
    if record {
        h.time_s.push(0.0);
        h.command = d_g.iter().map(|d| vec![*d]).collect();
        h.achieved = h.command.clone();
        h.force = r_g.iter().map(|r| vec![*r]).collect();
        h.response = vec![vec![0.0]; m];
    }
    let mut diverged = None;
    let total = (steps - 1) * substeps;
    let (mut f_n, mut fd_n) = (total_load(0), load(0));
    let mut y = vec![0.0; m];
    for j in 0..total {
        let (f_next, fd_next) = (total_load(j + 1), load(j + 1));
        let x0 = integ.x.clone();
        integ.step(&f_n, &f_next, &mut spec, &mut command);
        let r1 = integ.measured_force();
        for a in 0..m {
            r_inc[a] = r1[a] - r_g[a];
        }
        energy.add_actuators(&r0, &r_inc, &dm0, &spec.measured, &dc0, &command);
        energy.add_input(&fd_n, &fd_next, &x0, &integ.x);
        for a in 0..m {
            let e = command[a] - spec.achieved[a];
            sum_sq[a] += e * e;
            max_e[a] = max_e[a].max(e.abs());
        }
        r0.copy_from_slice(&r_inc);
        dc0.copy_from_slice(&command);
        dm0.copy_from_slice(&spec.measured);
        (f_n, fd_n) = (f_next, fd_next);
        // The seismic response: total displacement less the static one (the reference's).
        let observe = |x: &[f64], a: usize| -> f64 {
            model.observation[a]
                .iter()
                .zip(x)
                .map(|(p, x)| p * x)
                .sum::<f64>()
                - y_g[a]
        };
        if (j + 1) % substeps == 0 {
            for (a, ya) in y.iter_mut().enumerate() {
                *ya = observe(&integ.x, a);
            }
            let t = (j + 1) as f64 * dt;
            if y.iter().any(|v| !v.is_finite() || v.abs() > limit) {
                diverged = Some(t);
                break;
            }
            for a in 0..m {
                response[a].push(y[a]);
            }
        }
        if record && (j + 1) % every == 0 {
            h.time_s.push((j + 1) as f64 * dt);
            for a in 0..m {
                h.command[a].push(command[a]);
                h.achieved[a].push(spec.measured[a]);
                h.force[a].push(r1[a]);
                h.response[a].push(observe(&integ.x, a));
            }
        }
    }
    let done = total.max(1) as f64;
    let response_wnrmse = diverged.is_none().then(|| {
        let reference = mat(&model.reference);
        let got = mat(&response);
        wnrmse(reference.as_ref(), got.as_ref()).0
    });
    let top = model.top_frequency_hz();
    let safe = response_wnrmse.is_some_and(|w| w <= settings.response_tolerance)
        && energy.error() <= settings.energy_tolerance;
    Ok((
        RunSummary {
            ns_modes: model.ns_modes,
            time_scale,
            top_frequency_hz: top,
            bandwidth_hz: top / time_scale,
            stable: diverged.is_none(),
            divergence_time_s: diverged,
            energy_error: energy.error(),
            response_wnrmse,
            tracking_rms_m: sum_sq.iter().map(|s| (s / done).sqrt()).collect(),
            tracking_max_m: max_e,
            max_input_energy_j: energy.max_input,
            safe,
        },
        h,
    ))
}

/// The sweep over the settings' NS mode counts × time scales (parallel over runs, collected in
/// order, faer's reductions sequential: the result does not depend on the thread count), the recommendation and the
/// histories of the recommended run.
pub fn rehearse(model: &RehearsalModel, settings: &RehearseSettings) -> Result<Rehearsal> {
    // Dense products in a fixed summation order, whatever the thread count (as `pipeline::run`).
    crate::fixed_order_reductions();
    model.validate("rehearsal model")?;
    settings.check("rehearsal settings")?;
    let actuator = settings.actuator(model.actuator_band_hz);
    actuator.check()?;
    let ns_list = if settings.ns_modes.is_empty() {
        vec![model.ns_modes]
    } else {
        settings.ns_modes.clone()
    };
    let mut scales = if !settings.time_scales.is_empty() {
        settings.time_scales.clone()
    } else if !model.time_scales.is_empty() {
        model.time_scales.clone()
    } else {
        vec![model.time_scale]
    };
    scales.sort_by(f64::total_cmp);
    scales.dedup();
    let substeps = settings.substeps.unwrap_or_else(|| auto_substeps(model));
    let models = ns_list
        .iter()
        .map(|&s| model.with_ns_modes(s))
        .collect::<Result<Vec<_>>>()?;
    let jobs: Vec<(usize, f64)> = (0..models.len())
        .flat_map(|i| scales.iter().map(move |&l| (i, l)))
        .collect();
    // Histories are kept for every run (at the motion's steps: small) so that the chosen one
    // needs no second integration.
    let mut results = jobs
        .par_iter()
        .enumerate()
        .map(|(k, &(i, l))| run(&models[i], settings, &actuator, l, substeps, k as u64, true))
        .collect::<Result<Vec<_>>>()?;
    let runs: Vec<RunSummary> = results.iter().map(|r| r.0.clone()).collect();
    let ns_modes = if ns_list.contains(&model.ns_modes) {
        model.ns_modes
    } else {
        ns_list.iter().copied().max().unwrap_or(0)
    };
    let recommended = runs.iter().position(|r| r.ns_modes == ns_modes && r.safe);
    let history_run = recommended
        .or_else(|| {
            runs.iter()
                .enumerate()
                .filter(|(_, r)| r.ns_modes == ns_modes)
                .min_by(|a, b| {
                    let d = |r: &RunSummary| (r.time_scale / model.time_scale).ln().abs();
                    d(a.1).total_cmp(&d(b.1))
                })
                .map(|(i, _)| i)
        })
        .ok_or_else(|| Error::usage("rehearsal: nothing to sweep"))?;
    let histories = std::mem::take(&mut results[history_run].1);
    let preload = if settings.preload(model) {
        Some(static_state(model)?)
    } else {
        None
    };
    Ok(Rehearsal {
        runs,
        ns_modes,
        recommended,
        history_run,
        histories,
        substeps,
        dt_s: model.dt / substeps as f64,
        actuator,
        preload,
    })
}

fn axpy_(x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += xi;
    }
}
