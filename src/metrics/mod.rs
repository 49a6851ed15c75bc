//! Strong-motion metrics per channel (METHODS §1): PGA, PGV, PGD, Arias
//! intensity, significant duration D5–95, CAV, damped response spectra and
//! inter-storey drift ratios. Inputs in SI (m/s², m/s, m); no I/O.

pub mod drift;
pub mod profile;
pub mod residual;
pub mod spectra;

pub use drift::{
    storey_drift, storey_residual_drifts, DriftKind, DriftRow, DriftTable, HeightSource,
    ResidualStatus, StoreyHeights,
};
pub use residual::{residual_drift, ResidualDrift};
pub use spectra::{default_periods, response_spectrum, sdof_response, ResponseSpectrum};

use serde::{Deserialize, Serialize};

use crate::conditioning::Motion;
use crate::error::{Error, Result};
use crate::vocab::STANDARD_GRAVITY;

/// Largest absolute value (peak ground/floor acceleration, velocity or displacement).
pub fn peak_abs(data: &[f64]) -> f64 {
    data.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

/// Cumulative trapezoid integral of a², scaled by π/(2g): the Husid curve
/// of Arias intensity, m/s. Ia(t) = π/(2g) ∫₀ᵗ a² dτ.
pub fn arias_husid(acceleration: &[f64], dt: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(acceleration.len());
    walk_husid(acceleration, dt, |_, v| {
        out.push(v);
        true
    });
    out
}

/// The values of [`arias_husid`] in order, handed to `each(index, value)`
/// without being stored (a day at 200 Hz is 17 M of them); stops when
/// `each` returns false.
fn walk_husid(acceleration: &[f64], dt: f64, mut each: impl FnMut(usize, f64) -> bool) {
    let scale = std::f64::consts::PI / (2.0 * STANDARD_GRAVITY);
    let mut acc = 0.0;
    if let Some(&first) = acceleration.first() {
        if !each(0, 0.0) {
            return;
        }
        let mut prev = first * first;
        for (i, &a) in acceleration[1..].iter().enumerate() {
            let sq = a * a;
            acc += 0.5 * dt * (prev + sq) * scale;
            if !each(i + 1, acc) {
                return;
            }
            prev = sq;
        }
    }
}

/// Arias intensity Ia = π/(2g) ∫ a² dt, m/s (trapezoid rule).
pub fn arias_intensity(acceleration: &[f64], dt: f64) -> f64 {
    let mut last = 0.0;
    walk_husid(acceleration, dt, |_, v| {
        last = v;
        true
    });
    last
}

/// Time at which the Husid curve first reaches `level`, with linear
/// interpolation between samples.
fn crossing_time(acceleration: &[f64], level: f64, dt: f64) -> f64 {
    let (mut count, mut previous) = (0usize, 0.0);
    let mut found: Option<(usize, f64, f64)> = None;
    walk_husid(acceleration, dt, |i, c| {
        count = i + 1;
        if c >= level {
            found = Some((i, previous, c));
            return false;
        }
        previous = c;
        true
    });
    match found {
        None => (count.saturating_sub(1)) as f64 * dt,
        Some((0, _, _)) => 0.0,
        Some((i, c0, c1)) => {
            let frac = if c1 > c0 {
                (level - c0) / (c1 - c0)
            } else {
                0.0
            };
            (i as f64 - 1.0 + frac) * dt
        }
    }
}

/// Significant duration between `from` and `to` fractions of the Arias
/// intensity (D5–95: from = 0.05, to = 0.95), s, and the start time, s.
pub fn significant_duration(
    acceleration: &[f64],
    dt: f64,
    from: f64,
    to: f64,
) -> Result<(f64, f64)> {
    if !(0.0..1.0).contains(&from) || !(from..=1.0).contains(&to) {
        return Err(Error::usage(format!(
            "significant duration fractions must satisfy 0 ≤ from < to ≤ 1, got {from}, {to}"
        )));
    }
    // The curve is walked again for each crossing, not stored.
    let total = arias_intensity(acceleration, dt);
    if total <= 0.0 {
        return Ok((0.0, 0.0));
    }
    let t0 = crossing_time(acceleration, from * total, dt);
    let t1 = crossing_time(acceleration, to * total, dt);
    Ok((t1 - t0, t0))
}

/// Cumulative absolute velocity CAV = ∫ |a| dt, m/s (trapezoid rule on |a|).
pub fn cumulative_absolute_velocity(acceleration: &[f64], dt: f64) -> f64 {
    acceleration
        .windows(2)
        .map(|w| 0.5 * dt * (w[0].abs() + w[1].abs()))
        .sum()
}

/// Peak inter-storey drift ratio max_t |u_upper − u_lower| / h between the
/// displacement histories of two consecutive levels (same time grid).
pub fn interstorey_drift(lower: &[f64], upper: &[f64], height_m: f64) -> Result<f64> {
    if !(height_m.is_finite() && height_m > 0.0) {
        return Err(Error::usage(format!(
            "storey height must be positive, got {height_m} m"
        )));
    }
    if lower.len() != upper.len() {
        return Err(Error::usage(format!(
            "displacement histories of consecutive levels differ in length ({} vs {}): align them first",
            lower.len(),
            upper.len()
        )));
    }
    Ok(lower
        .iter()
        .zip(upper)
        .fold(0.0f64, |m, (l, u)| m.max((u - l).abs()))
        / height_m)
}

/// Peak drift ratios of every storey from displacement histories of levels
/// 0 (base), 1, …, n and storey heights h_1..h_n (`Structure::storey_heights_m`).
pub fn interstorey_drifts(levels: &[&[f64]], storey_heights_m: &[f64]) -> Result<Vec<f64>> {
    if levels.len() != storey_heights_m.len() + 1 {
        return Err(Error::usage(format!(
            "{} level histories need {} storey heights, got {}",
            levels.len(),
            levels.len().saturating_sub(1),
            storey_heights_m.len()
        )));
    }
    levels
        .windows(2)
        .zip(storey_heights_m)
        .map(|(w, &h)| interstorey_drift(w[0], w[1], h))
        .collect()
}

/// Most oscillator periods of a response spectrum (the default has 100;
/// each costs a pass over every sample of every channel).
pub const MAX_SPECTRUM_PERIODS: usize = 1000;
/// Longest oscillator period, s: longer than any usable strong-motion
/// record's band (the default spectrum stops at 10 s).
pub const MAX_SPECTRUM_PERIOD_S: f64 = 1000.0;

/// Settings of `strong_motion_metrics`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MetricsSettings {
    pub damping: f64,
    /// Oscillator periods, s (T = 0 is added in front).
    pub periods_s: Vec<f64>,
    /// Storey height assumed where the structure states neither storey
    /// heights nor a total height with a storey count, m (drift ratios and
    /// their ratings then provisional; `drift::DEFAULT_ASSUMED_STOREY_HEIGHT_M`).
    pub assumed_storey_height_m: f64,
}

impl MetricsSettings {
    /// Checks the settings before any record is read: damping in [0, 1),
    /// periods positive and finite.
    pub fn validate(&self) -> Result<()> {
        if !(self.damping >= 0.0 && self.damping < 1.0) {
            return Err(crate::error::Error::usage(format!(
                "damping = {}: must be a fraction of critical in [0, 1)",
                self.damping
            )));
        }
        if !(self.assumed_storey_height_m >= 0.5 && self.assumed_storey_height_m <= 50.0) {
            return Err(crate::error::Error::usage(format!(
                "assumed_storey_height_m = {}: must be a storey height in metres, 0.5 to 50",
                self.assumed_storey_height_m
            )));
        }
        if self.periods_s.len() > MAX_SPECTRUM_PERIODS {
            return Err(crate::error::Error::usage(format!(
                "periods_s lists {} periods: at most {MAX_SPECTRUM_PERIODS} (each is an oscillator run over every sample of every channel)",
                self.periods_s.len()
            )));
        }
        if let Some(t) = self
            .periods_s
            .iter()
            .find(|t| !(t.is_finite() && **t > 0.0 && **t <= MAX_SPECTRUM_PERIOD_S))
        {
            return Err(crate::error::Error::usage(format!(
                "periods_s contains {t:?}: periods must be positive seconds, at most {MAX_SPECTRUM_PERIOD_S}"
            )));
        }
        Ok(())
    }
}

impl Default for MetricsSettings {
    fn default() -> Self {
        MetricsSettings {
            damping: 0.05,
            periods_s: default_periods(),
            assumed_storey_height_m: drift::DEFAULT_ASSUMED_STOREY_HEIGHT_M,
        }
    }
}

/// Metrics of one channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StrongMotionMetrics {
    pub channel_id: String,
    pub pga_m_per_s2: f64,
    pub pgv_m_per_s: f64,
    pub pgd_m: f64,
    pub arias_m_per_s: f64,
    pub d5_95_s: f64,
    pub cav_m_per_s: f64,
    pub spectrum: ResponseSpectrum,
}

/// All metrics of one channel from its conditioned motion.
pub fn strong_motion_metrics(
    motion: &Motion,
    settings: &MetricsSettings,
) -> Result<StrongMotionMetrics> {
    metrics_of_parts(
        &motion.channel_id,
        motion.dt,
        &motion.acceleration,
        peak_abs(&motion.velocity),
        peak_abs(&motion.displacement),
        settings,
    )
}

/// As [`strong_motion_metrics`], given the acceleration and the peaks of the
/// velocity and displacement (a long parked motion is read a series at a time).
pub fn metrics_of_parts(
    channel_id: &str,
    dt: f64,
    a: &[f64],
    pgv_m_per_s: f64,
    pgd_m: f64,
    settings: &MetricsSettings,
) -> Result<StrongMotionMetrics> {
    let (d5_95, _) = significant_duration(a, dt, 0.05, 0.95)?;
    Ok(StrongMotionMetrics {
        channel_id: channel_id.to_string(),
        pga_m_per_s2: peak_abs(a),
        pgv_m_per_s,
        pgd_m,
        arias_m_per_s: arias_intensity(a, dt),
        d5_95_s: d5_95,
        cav_m_per_s: cumulative_absolute_velocity(a, dt),
        spectrum: response_spectrum(a, dt, &settings.periods_s, settings.damping)?,
    })
}
