//! Actuators in laboratory time: command → achieved displacement per actuated DoF.
//!
//! A pseudo-dynamic test with time scale λ spends λ·Δt of laboratory time on a simulation
//! step Δt. The command of each actuator is the target displacement of the current step,
//! ramped linearly in laboratory time from the previous target (continuous PsD testing),
//! passed through a pure delay τ and a servo-hydraulic transfer function:
//!
//! - `ideal`: x(t) = c(t − τ);
//! - `first-order`: T ẋ + x = c(t − τ), T = 1 / (2π f_c), f_c the stated bandwidth (−3 dB);
//! - `second-order`: ẍ + 2ζω ẋ + ω² x = ω² c(t − τ), ω = 2π f_n (f_n the stated bandwidth).
//!
//! The servo is integrated exactly for an input held over sub-steps of laboratory time
//! (zero-order hold at the sub-step midpoint: x_{k+1} = Φ x_k + Γ u_k, Φ = e^{A h},
//! Γ = ∫₀ʰ e^{A s} ds B, by the exponential of the augmented matrix [[A, B], [0, 0]] h).
//! Tracking errors enter the hybrid loop through the restoring forces, which the load cells
//! measure at the achieved, not the commanded, displacement (Shing & Mahin 1987; Shing &
//! Vannan 1991). Optional Gaussian measurement noise (seeded) on displacement and force.

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Servo transfer of every actuator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ServoKind {
    Ideal,
    FirstOrder,
    SecondOrder,
}

impl ServoKind {
    pub fn name(self) -> &'static str {
        match self {
            ServoKind::Ideal => "ideal",
            ServoKind::FirstOrder => "first-order",
            ServoKind::SecondOrder => "second-order",
        }
    }
}

/// The actuators' dynamics in laboratory time.
#[derive(Debug, Clone, PartialEq)]
pub struct ActuatorModel {
    pub servo: ServoKind,
    /// f_c (first order) or f_n (second order), Hz.
    pub bandwidth_hz: f64,
    /// ζ of the second-order servo.
    pub damping: f64,
    /// Pure delay τ (s, laboratory time).
    pub delay_s: f64,
}

/// Longest pure delay of the actuator loop, s.
pub const MAX_DELAY_S: f64 = 1.0;

impl ActuatorModel {
    /// A perfect actuator: no lag, no delay.
    pub fn ideal() -> Self {
        ActuatorModel {
            servo: ServoKind::Ideal,
            bandwidth_hz: f64::INFINITY,
            damping: 1.0,
            delay_s: 0.0,
        }
    }

    pub fn check(&self) -> Result<()> {
        if !(self.delay_s >= 0.0 && self.delay_s <= MAX_DELAY_S) {
            return Err(Error::usage(format!(
                "actuator delay_s {} must lie in [0, {MAX_DELAY_S}] s (a laboratory loop's delay is milliseconds; the history kept grows with it)",
                self.delay_s
            )));
        }
        if self.servo != ServoKind::Ideal
            && !(self.bandwidth_hz > 0.0 && self.bandwidth_hz.is_finite())
        {
            return Err(Error::usage(format!(
                "actuator bandwidth_hz {} must be positive",
                self.bandwidth_hz
            )));
        }
        if self.servo == ServoKind::SecondOrder && !super::positive(self.damping) {
            return Err(Error::usage(format!(
                "servo_damping {} must be positive",
                self.damping
            )));
        }
        Ok(())
    }
}

/// x_{k+1} = Φ x_k + Γ u for one sub-step (state: displacement, velocity).
#[derive(Debug, Clone, Copy)]
struct Discrete {
    phi: [[f64; 2]; 2],
    gamma: [f64; 2],
}

/// e^{X} of a 3×3 matrix by scaling and squaring of a Taylor series (‖X/2^s‖ ≤ 1/2, 16 terms).
fn expm3(x: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let norm = x
        .iter()
        .map(|r| r.iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max);
    let s = if norm > 0.5 {
        (norm / 0.5).log2().ceil() as i32
    } else {
        0
    };
    let scale = 0.5_f64.powi(s);
    let a: Vec<[f64; 3]> = x.iter().map(|r| r.map(|v| v * scale)).collect();
    let mul = |p: &[[f64; 3]; 3], q: &[[f64; 3]; 3]| {
        let mut r = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                r[i][j] = (0..3).map(|k| p[i][k] * q[k][j]).sum();
            }
        }
        r
    };
    let a = [a[0], a[1], a[2]];
    let mut term = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mut sum = term;
    for k in 1..=16 {
        term = mul(&term, &a).map(|r| r.map(|v| v / k as f64));
        for i in 0..3 {
            for j in 0..3 {
                sum[i][j] += term[i][j];
            }
        }
    }
    for _ in 0..s {
        sum = mul(&sum, &sum);
    }
    sum
}

fn discretize(model: &ActuatorModel, h: f64) -> Discrete {
    let w = 2.0 * std::f64::consts::PI * model.bandwidth_hz;
    let (a, b) = match model.servo {
        ServoKind::Ideal => {
            return Discrete {
                phi: [[0.0; 2]; 2],
                gamma: [1.0, 0.0],
            }
        }
        // T ẋ + x = u as a 2-state system whose second state stays 0.
        ServoKind::FirstOrder => ([[-w, 0.0], [0.0, 0.0]], [w, 0.0]),
        ServoKind::SecondOrder => (
            [[0.0, 1.0], [-w * w, -2.0 * model.damping * w]],
            [0.0, w * w],
        ),
    };
    let e = expm3([
        [a[0][0] * h, a[0][1] * h, b[0] * h],
        [a[1][0] * h, a[1][1] * h, b[1] * h],
        [0.0, 0.0, 0.0],
    ]);
    Discrete {
        phi: [[e[0][0], e[0][1]], [e[1][0], e[1][1]]],
        gamma: [e[0][2], e[1][2]],
    }
}

/// The actuators of one rehearsal: command history (for the delay), servo states.
pub struct ActuatorBank {
    ideal: bool,
    discrete: Discrete,
    substeps: usize,
    /// Delay in simulation steps (τ / (λ Δt)).
    delay_steps: f64,
    /// Targets d_k of the most recent steps; `first` is the step index of the front.
    history: VecDeque<Vec<f64>>,
    first: usize,
    /// Index of the newest target.
    newest: usize,
    state: Vec<[f64; 2]>,
    /// Per sub-step of the current step: the command's history rows and fraction.
    schedule: Vec<(usize, usize, f64)>,
}

impl ActuatorBank {
    /// `count` actuators at rest; `step_lab_s` = λ Δt, the laboratory time of one step.
    pub fn new(model: &ActuatorModel, count: usize, step_lab_s: f64) -> Self {
        // Sub-steps: at least 8 per servo time constant 1/(2π f).
        let substeps = match model.servo {
            ServoKind::Ideal => 1,
            _ => {
                let tau = 1.0 / (2.0 * std::f64::consts::PI * model.bandwidth_hz);
                ((8.0 * step_lab_s / tau).ceil() as usize).clamp(1, 10_000)
            }
        };
        let h = step_lab_s / substeps as f64;
        let delay_steps = model.delay_s / step_lab_s;
        let keep = delay_steps.ceil() as usize + 3;
        let mut history = VecDeque::with_capacity(keep + 1);
        history.push_back(vec![0.0; count]);
        ActuatorBank {
            ideal: model.servo == ServoKind::Ideal,
            discrete: discretize(model, h),
            substeps,
            delay_steps,
            history,
            first: 0,
            newest: 0,
            state: vec![[0.0; 2]; count],
            schedule: Vec::with_capacity(substeps),
        }
    }

    /// Actuators holding `d` at rest (the gravity pre-load's static displacement): the
    /// command history and the servo states start there.
    pub fn hold(&mut self, d: &[f64]) {
        for row in self.history.iter_mut() {
            row.copy_from_slice(d);
        }
        for (s, v) in self.state.iter_mut().zip(d) {
            *s = [*v, 0.0];
        }
    }

    /// Where the command at step-time `s` lies (in steps; linear ramp between targets, 0 before
    /// the first): rows (in `history`) of the two targets and the fraction between them.
    fn locate(&self, s: f64) -> (usize, usize, f64) {
        if s <= self.first as f64 {
            return (0, 0, 0.0);
        }
        let i = s.floor() as usize;
        let f = s - i as f64;
        let row = |k: usize| k.clamp(self.first, self.newest) - self.first;
        (row(i), row(i + 1), f)
    }

    /// Sends the next step's targets and runs one step of laboratory time; returns the
    /// achieved displacements at its end into `achieved`.
    pub fn advance(&mut self, targets: &[f64], achieved: &mut [f64]) {
        let keep = self.delay_steps.ceil() as usize + 3;
        // Reuse the oldest row's allocation for the new targets.
        let mut row = if self.history.len() >= keep {
            self.first += 1;
            self.history.pop_front().unwrap_or_default()
        } else {
            Vec::with_capacity(targets.len())
        };
        row.clear();
        row.extend_from_slice(targets);
        self.history.push_back(row);
        self.newest += 1;
        let start = (self.newest - 1) as f64;
        let n = self.substeps;
        let d = self.discrete;
        // The delayed command's position at each sub-step (the same for every actuator):
        // the end of the sub-step for the ideal actuator, its midpoint for the servo (ZOH).
        let at = if self.ideal { 1.0 } else { 0.5 };
        self.schedule.clear();
        for j in 0..n {
            let s = start + (j as f64 + at) / n as f64 - self.delay_steps;
            let p = self.locate(s);
            self.schedule.push(p);
        }
        for (a, out) in achieved.iter_mut().enumerate().take(self.state.len()) {
            let mut x = self.state[a];
            for &(i0, i1, f) in &self.schedule {
                let (c0, c1) = (self.history[i0][a], self.history[i1][a]);
                let u = c0 + f * (c1 - c0);
                if self.ideal {
                    // Ideal: follows the delayed command exactly.
                    x = [u, 0.0];
                    continue;
                }
                x = [
                    d.phi[0][0] * x[0] + d.phi[0][1] * x[1] + d.gamma[0] * u,
                    d.phi[1][0] * x[0] + d.phi[1][1] * x[1] + d.gamma[1] * u,
                ];
            }
            self.state[a] = x;
            *out = x[0];
        }
    }
}
