//! The actuators' tracking in a logged hybrid test: how far the measured displacement m_k
//! trails the command c_k, as an equivalent pure delay L (laboratory time) and the measurement
//! noise left after it.
//!
//! In continuous pseudo-dynamic testing (as `crate::rehearse::actuator` models it) the command
//! ramps linearly in laboratory time from one step's target to the next, c(t) piecewise linear
//! through (k h, c_k), h = λ Δt the laboratory time of a step. The lag model is
//!
//!   m_k = c(k h − L) + ε_k,   ε_k ~ N(0, σ²),
//!
//! fitted by least squares (the maximum-likelihood fit for Gaussian noise) pooled over the
//! actuators (all alike, as in the rehearsal). With D = L / h = j + f (j integer, f ∈ [0, 1)),
//! c(k h − L) = c_{k−j} − f (c_{k−j} − c_{k−j−1}); for each j the residual is linear in f, so
//! the sum of squares is a parabola in f minimised in closed form, and the best (j, f) over
//! j = 0 … J is the global minimum (the same samples k > J for every j). σ̂² is the residual
//! mean square. For a servo H(iω) = e^{−iωτ} / (1 + iωT) driven well inside its band
//! (ωT ≪ 1) the phase is −ω(τ + T) + O(ω³): the identified L is the servo's low-frequency
//! group delay τ + T (the slope of the transfer function's phase), which is what makes the
//! tracking error and the spurious energy (Shing & Mahin 1987; Mosqueda et al. 2007).

use crate::error::{Error, Result};

/// What the tracking of a log shows.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TrackingIdentification {
    /// Equivalent pure delay L of the measured displacement behind the command (s, laboratory
    /// time), pooled over the actuators.
    pub lag_s: f64,
    /// σ̂ of the measurement noise left after the lag model (m), pooled.
    pub noise_std_m: f64,
    /// Per actuator: the same fit alone (actuators that do not move: NaN).
    pub lag_per_actuator_s: Vec<f64>,
    pub noise_per_actuator_m: Vec<f64>,
    /// Per actuator: RMS and peak |command − measured| over the log (m).
    pub rms_m: Vec<f64>,
    pub peak_m: Vec<f64>,
}

/// RMS and peak of c − m per actuator.
pub fn tracking_error(command: &[Vec<f64>], measured: &[Vec<f64>]) -> (Vec<f64>, Vec<f64>) {
    command
        .iter()
        .zip(measured)
        .map(|(c, m)| {
            let n = c.len().max(1) as f64;
            let ss: f64 = c.iter().zip(m).map(|(c, m)| (c - m) * (c - m)).sum();
            let peak = c
                .iter()
                .zip(m)
                .fold(0.0_f64, |p, (c, m)| p.max((c - m).abs()));
            ((ss / n).sqrt(), peak)
        })
        .unzip()
}

/// RMS over actuators of per-actuator RMS values: √(mean of squares).
pub fn pooled_rms(per_actuator: &[f64]) -> f64 {
    if per_actuator.is_empty() {
        return 0.0;
    }
    (per_actuator.iter().map(|r| r * r).sum::<f64>() / per_actuator.len() as f64).sqrt()
}

/// The least-squares delay (in steps) and residual sum of squares, sample count, over the
/// actuators `which`; None when nothing moves.
fn fit_delay(
    command: &[Vec<f64>],
    measured: &[Vec<f64>],
    which: &[usize],
    max_steps: usize,
) -> Option<(f64, f64, usize)> {
    let n = command.first()?.len();
    let start = max_steps + 1;
    let mut best: Option<(f64, f64)> = None;
    for j in 0..=max_steps {
        let (mut suu, mut suw, mut sww) = (0.0, 0.0, 0.0);
        for &a in which {
            let (c, m) = (&command[a], &measured[a]);
            for k in start..n {
                let u = m[k] - c[k - j];
                let w = c[k - j] - c[k - j - 1];
                suu += u * u;
                suw += u * w;
                sww += w * w;
            }
        }
        if sww <= 0.0 {
            return None;
        }
        // Residual u + f w, f ∈ [0, 1]: S(f) = suu + 2 f suw + f² sww.
        let f = (-suw / sww).clamp(0.0, 1.0);
        let s = suu + 2.0 * f * suw + f * f * sww;
        if best.is_none_or(|(_, b)| s < b) {
            best = Some((j as f64 + f, s));
        }
    }
    let count = which.len() * n.saturating_sub(start);
    best.map(|(d, s)| (d, s, count))
}

/// The lag and noise of a log's actuators; `lab_step_s` the laboratory time of a step,
/// `max_lag_s` the longest delay searched.
pub fn identify_tracking(
    command: &[Vec<f64>],
    measured: &[Vec<f64>],
    lab_step_s: f64,
    max_lag_s: f64,
) -> Result<TrackingIdentification> {
    let n = command.first().map(|c| c.len()).unwrap_or(0);
    if !(lab_step_s > 0.0 && lab_step_s.is_finite() && max_lag_s > 0.0 && max_lag_s.is_finite()) {
        return Err(Error::usage(format!(
            "tracking: laboratory step {lab_step_s} s and longest lag {max_lag_s} s must be positive"
        )));
    }
    // At most as many steps as the log allows (checked below).
    let max_steps = ((max_lag_s / lab_step_s).ceil().min(n as f64) as usize).max(1);
    if n < max_steps + 3 {
        return Err(Error::usage(format!(
            "tracking: {n} steps are too few to search a lag of up to {max_lag_s} s ({max_steps} steps of {lab_step_s} s)"
        )));
    }
    let all: Vec<usize> = (0..command.len()).collect();
    let (d, ss, count) = fit_delay(command, measured, &all, max_steps).ok_or_else(|| {
        Error::numerical("tracking: no actuator's command moves: the lag cannot be identified")
    })?;
    let mut lag_per = Vec::with_capacity(all.len());
    let mut noise_per = Vec::with_capacity(all.len());
    for a in 0..command.len() {
        match fit_delay(command, measured, &[a], max_steps) {
            Some((d, s, c)) => {
                lag_per.push(d * lab_step_s);
                noise_per.push((s / (c.max(2) - 1) as f64).sqrt());
            }
            None => {
                lag_per.push(f64::NAN);
                noise_per.push(f64::NAN);
            }
        }
    }
    let (rms, peak) = tracking_error(command, measured);
    Ok(TrackingIdentification {
        lag_s: d * lab_step_s,
        noise_std_m: (ss / (count.max(2) - 1) as f64).sqrt(),
        lag_per_actuator_s: lag_per,
        noise_per_actuator_m: noise_per,
        rms_m: rms,
        peak_m: peak,
    })
}
