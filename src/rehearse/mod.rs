//! Rehearsal of a hybrid test before the specimen is loaded (issue 16; thesis ch. 6,
//! METHODS §6): the test run virtually from the design — the Craig–Bampton prototype as the
//! numerical substructure, the specimen emulated at the actuated DoFs by its condensed linear
//! stiffness, actuators with lag, delay and noise in laboratory time (λ × simulation time),
//! integrated by the schemes of pseudo-dynamic testing. I/O free.
//!
//! - `model`: the hybrid system from the design (`rehearsal_model.json`), NS-mode truncation;
//! - `actuator`: servo transfer (ideal, first-, second-order) plus delay, in laboratory time;
//! - `integrator`: central difference and α-OS (Nakashima et al. 1990; Combescure & Pegon 1997);
//! - `energy`: energy balance and spurious energy (Mosqueda et al. 2005, 2007);
//! - `sweep`: one rehearsal, the sweep over λ and NS modes, the smallest safe λ.
//!
//! - `specimen`: the emulated specimen, linear or with Bouc–Wen springs (Bouc 1967; Wen 1976).
//!
//! - `gravity`: the static gravity state the dynamic test starts from (pre-load through the
//!   force-controlled actuators).

pub mod actuator;
pub mod energy;
pub mod gravity;
pub mod integrator;
pub mod model;
pub mod specimen;
pub mod sweep;

use serde::{Deserialize, Serialize};

pub use actuator::{ActuatorModel, ServoKind};
pub use integrator::Scheme;
pub use model::RehearsalModel;
pub use specimen::BoucWenSpring;
pub use sweep::{rehearse, Histories, Rehearsal, RunSummary};

use crate::error::{Error, Result};

/// A finite value above 0 (false for NaN).
pub(crate) fn positive(v: f64) -> bool {
    v > 0.0 && v.is_finite()
}

/// Settings of a rehearsal (the `rehearse` stage's params, `quaketwin rehearse --settings`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RehearseSettings {
    /// `alpha-os` or `central-difference`.
    pub scheme: Scheme,
    /// α of α-OS, in [−1/3, 0].
    pub alpha: f64,
    /// Simulation steps per base-motion step; default: the fewest with ω_max Δt ≤ 1.
    pub substeps: Option<usize>,
    /// Time scales λ to sweep; default: the design's candidates.
    pub time_scales: Vec<f64>,
    /// NS mode counts to sweep (each ≤ the design's); default: the design's count.
    pub ns_modes: Vec<usize>,
    /// Servo transfer: `ideal`, `first-order`, `second-order`.
    pub servo: ServoKind,
    /// Servo bandwidth (Hz); default: the design's `actuator_band_hz`.
    pub bandwidth_hz: Option<f64>,
    /// ζ of a second-order servo.
    pub servo_damping: f64,
    /// Pure delay (s, laboratory time).
    pub delay_s: f64,
    /// Standard deviation of the displacement measurement noise (m).
    pub displacement_noise_m: f64,
    /// Standard deviation of the load-cell noise (N).
    pub force_noise_n: f64,
    /// Seed of the noise (`crate::rng`).
    pub seed: u64,
    /// Divergence: a response beyond this many times the reference's peak (or non-finite).
    pub divergence_factor: f64,
    /// A run is safe when stable with response WNRMSE ≤ this …
    pub response_tolerance: f64,
    /// … and energy error ≤ this.
    pub energy_tolerance: f64,
    /// A Bouc–Wen spring on every actuated DoF (nonlinear rehearsal); none: linear specimen.
    pub bouc_wen: Option<BoucWenSpring>,
    /// Gravity pre-load (`gravity`): start from the static gravity state, the force-controlled
    /// actuators applying the PS's share of the weight. Default: on when the design has the
    /// gravity state and force-controlled actuators.
    pub gravity: Option<bool>,
}

/// Most simulation steps per base-motion step (`substeps`; the automatic
/// choice, ω_max Δt ≤ 1, needs far fewer).
pub const MAX_SUBSTEPS: usize = 10_000;

impl Default for RehearseSettings {
    fn default() -> Self {
        RehearseSettings {
            scheme: Scheme::AlphaOs,
            alpha: -0.05,
            substeps: None,
            time_scales: Vec::new(),
            ns_modes: Vec::new(),
            servo: ServoKind::FirstOrder,
            bandwidth_hz: None,
            servo_damping: 0.7,
            delay_s: 0.005,
            displacement_noise_m: 0.0,
            force_noise_n: 0.0,
            seed: 16,
            divergence_factor: 10.0,
            response_tolerance: 0.05,
            energy_tolerance: 0.1,
            bouc_wen: None,
            gravity: None,
        }
    }
}

impl RehearseSettings {
    /// Checks values; `source` names the settings' origin in errors.
    pub fn check(&self, source: &str) -> Result<()> {
        let bad = |what: String| Err(Error::usage(format!("{source}: {what}")));
        if !(-1.0 / 3.0..=0.0).contains(&self.alpha) {
            return bad(format!("alpha {} must lie in [-1/3, 0]", self.alpha));
        }
        if let Some(n) = self.substeps.filter(|n| !(1..=MAX_SUBSTEPS).contains(n)) {
            return bad(format!("substeps = {n}: must be 1..={MAX_SUBSTEPS}"));
        }
        let most = crate::design::plan::MAX_TIME_SCALES;
        if self.time_scales.len() > most || self.ns_modes.len() > most {
            return bad(format!(
                "time_scales ({}) and ns_modes ({}) list at most {most} values each",
                self.time_scales.len(),
                self.ns_modes.len()
            ));
        }
        if let Some(l) = self
            .time_scales
            .iter()
            .find(|l| !(**l > 0.0 && l.is_finite()))
        {
            return bad(format!("time scale {l} must be positive"));
        }
        if !(self.delay_s >= 0.0 && self.delay_s <= actuator::MAX_DELAY_S) {
            return bad(format!(
                "delay_s {} must lie in [0, {}] s",
                self.delay_s,
                actuator::MAX_DELAY_S
            ));
        }
        if let Some(b) = self.bandwidth_hz.filter(|b| !(*b > 0.0 && b.is_finite())) {
            return bad(format!("bandwidth_hz {b} must be positive"));
        }
        for (name, v) in [
            ("delay_s", self.delay_s),
            ("displacement_noise_m", self.displacement_noise_m),
            ("force_noise_n", self.force_noise_n),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return bad(format!("{name} {v} must be ≥ 0"));
            }
        }
        if !positive(self.servo_damping) {
            return bad(format!(
                "servo_damping {} must be positive",
                self.servo_damping
            ));
        }
        if !positive(self.divergence_factor - 1.0) {
            return bad(format!(
                "divergence_factor {} must exceed 1",
                self.divergence_factor
            ));
        }
        if !positive(self.response_tolerance) {
            return bad(format!(
                "response_tolerance {} must be positive",
                self.response_tolerance
            ));
        }
        if let Some(b) = &self.bouc_wen {
            b.check()
                .map_err(|e| Error::usage(format!("{source}: {e}")))?;
        }
        if !positive(self.energy_tolerance) {
            return bad(format!(
                "energy_tolerance {} must be positive",
                self.energy_tolerance
            ));
        }
        Ok(())
    }

    /// Whether the rehearsal of `model` applies the gravity pre-load.
    pub fn preload(&self, model: &RehearsalModel) -> bool {
        self.gravity.unwrap_or_else(|| {
            model.gravity
                && !model.gravity_load.is_empty()
                && model.actuators.iter().any(|a| a.control_mode == "force")
        })
    }

    /// The actuator model, the design's band as the default bandwidth.
    pub fn actuator(&self, design_band_hz: f64) -> ActuatorModel {
        ActuatorModel {
            servo: self.servo,
            bandwidth_hz: self.bandwidth_hz.unwrap_or(design_band_hz),
            damping: self.servo_damping,
            delay_s: self.delay_s,
        }
    }
}
