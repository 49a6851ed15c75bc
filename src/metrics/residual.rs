//! Residual (permanent) inter-storey drift from the unfiltered records.
//!
//! The drift ratios of [`super::storey_drift`] come from band-passed
//! displacements, which lose a permanent offset by construction.  Here the
//! storey's relative acceleration r = a_upper − a_lower (SI, as recorded: no
//! filter, no taper) is integrated twice from rest and baseline-corrected on
//! the post-event window only, where the truth is known: the storey has
//! come to rest, so its relative velocity oscillates about zero.
//!
//! 1. v = ∫ r dt, d = ∫ v dt (cumulative trapezoid, v(0) = d(0) = 0).
//! 2. Post-event window W = [t95, T], t95 the time at which the Husid curve
//!    of r reaches 95 %; at least the last [`MIN_WINDOW_FRACTION`] of the
//!    record.
//! 3. Baseline: a constant acceleration offset c from the record start (the
//!    usual error of an accelerometer: offset, tilt before the event), whose
//!    velocity error c·t is fitted to v over W by least squares through the
//!    origin: c = Σ_W v t / Σ_W t².
//! 4. Residual drift D = mean over W of d(t) − c t²/2.
//!
//! Relative rather than absolute accelerations are corrected, so the
//! ground's own permanent displacement (fling) cancels.
//!
//! Uncertainty σ_D: double integration turns broadband sensor noise into a
//! displacement random walk that no baseline fit can tell from a permanent
//! offset.  Its size is estimated from the noise density of r in
//! [`NOISE_BAND`] × Nyquist (above structural response for well-sampled
//! records; treated as white): σ_w = rms(band-passed r) / √(band width /
//! Nyquist), and a white noise of that density integrated twice to the middle
//! t_m of W has σ = σ_w √(dt t_m³ / 3).  The difference between the means of
//! the corrected displacement over the two halves of W (a drift the constant
//! offset does not explain) is added in quadrature.  It is a lower bound for
//! records whose noise is not white (tilt, 1/f) or that were low-passed below
//! the band; [`ResidualDrift::resolved`] says whether |D| stands out of it.

use crate::conditioning::{butter_sos, sosfiltfilt, sosfiltfilt_padlen, BandType};
use crate::error::{Error, Result};
use crate::numeric::RunningTrapezoid;

/// Shortest post-event window, as a share of the record (a record that ends
/// during strong shaking still gets a window, and a wider σ).
pub const MIN_WINDOW_FRACTION: f64 = 0.1;

/// Band (fractions of the Nyquist frequency) whose content of r is taken as
/// sensor noise.
pub const NOISE_BAND: (f64, f64) = (0.6, 0.9);

/// Residual drift of one storey and how well it is known.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResidualDrift {
    /// Permanent drift u_upper − u_lower after the event, m (signed).
    pub drift_m: f64,
    /// Its uncertainty σ_D, m (noise random walk and window instability).
    pub std_m: f64,
    /// Start of the post-event window, s from the first sample.
    pub window_start_s: f64,
    /// Fitted acceleration offset c, m/s².
    pub offset_m_s2: f64,
}

impl ResidualDrift {
    /// |D| ≥ 2σ: the estimate stands out of its uncertainty.
    pub fn resolved(&self) -> bool {
        self.drift_m.abs() >= 2.0 * self.std_m
    }
}

/// Residual drift of the storey between `lower` and `upper` (absolute
/// accelerations, m/s², unfiltered, same time grid of step `dt`).
pub fn residual_drift(lower: &[f64], upper: &[f64], dt: f64) -> Result<ResidualDrift> {
    if lower.len() != upper.len() {
        return Err(Error::usage(format!(
            "residual drift: the two levels' records differ in length ({} vs {})",
            lower.len(),
            upper.len()
        )));
    }
    let relative: Vec<f64> = upper.iter().zip(lower).map(|(u, l)| u - l).collect();
    residual_drift_of(&relative, dt)
}

/// [`residual_drift`] of a relative acceleration r(t).
pub fn residual_drift_of(relative: &[f64], dt: f64) -> Result<ResidualDrift> {
    let n = relative.len();
    if !(dt.is_finite() && dt > 0.0) {
        return Err(Error::usage(format!(
            "residual drift: time step must be positive, got {dt}"
        )));
    }
    if n < 64 {
        return Err(Error::usage(format!(
            "residual drift: {n} samples are too few for a post-event window"
        )));
    }
    if relative.iter().any(|x| !x.is_finite()) {
        return Err(Error::numerical(
            "residual drift: the record holds non-finite samples",
        ));
    }
    // The noise floor first; then the velocity and the displacement are
    // formed as they go by, twice (the same operations, so the same values
    // as the series): once for the offset, once for the window means.  Of a
    // day-long storey only the relative acceleration is held (and, while
    // the noise floor is measured, its filtered copy).
    let noise = white_noise_std(relative, dt)?;
    let (d5_95, t5) = super::significant_duration(relative, dt, 0.05, 0.95)?;
    let last = (n - 1) as f64 * dt;
    let start_s = (t5 + d5_95).min(last * (1.0 - MIN_WINDOW_FRACTION));
    let first = ((start_s / dt).ceil() as usize).min(n - 2);
    let t = |i: usize| i as f64 * dt;
    // c = Σ v t / Σ t² over W (velocity error c t, through the origin).
    let (mut vt, mut tt) = (0.0, 0.0);
    let mut velocity = RunningTrapezoid::new(dt);
    for (i, &r) in relative.iter().enumerate() {
        let v = velocity.next(r);
        if i >= first {
            vt += v * t(i);
            tt += t(i) * t(i);
        }
    }
    let offset = if tt > 0.0 { vt / tt } else { 0.0 };
    // Sums of the corrected displacement over W and its two halves, each in
    // order from −0.0 as `Iterator::sum` adds.
    let middle = first + (n - first) / 2;
    let (mut all, mut early, mut late) = (-0.0, -0.0, -0.0);
    let (mut velocity, mut displacement) = (RunningTrapezoid::new(dt), RunningTrapezoid::new(dt));
    for (i, &r) in relative.iter().enumerate() {
        let d = displacement.next(velocity.next(r));
        if i >= first {
            let corrected = d - 0.5 * offset * t(i) * t(i);
            all += corrected;
            if i < middle {
                early += corrected;
            } else {
                late += corrected;
            }
        }
    }
    let drift = all / (n - first) as f64;
    let halves = (early / (middle - first) as f64 - late / (n - middle) as f64).abs();
    let t_mid = 0.5 * (t(first) + last);
    let walk = noise * (dt * t_mid.powi(3) / 3.0).sqrt();
    Ok(ResidualDrift {
        drift_m: drift,
        std_m: walk.hypot(halves),
        window_start_s: t(first),
        offset_m_s2: offset,
    })
}

/// Standard deviation per sample of a white noise with the density r shows
/// in [`NOISE_BAND`] (zero-phase 4th-order Butterworth band-pass).
fn white_noise_std(relative: &[f64], dt: f64) -> Result<f64> {
    let rate = 1.0 / dt;
    let nyquist = 0.5 * rate;
    let band = [NOISE_BAND.0 * nyquist, NOISE_BAND.1 * nyquist];
    let sos = butter_sos(4, BandType::Bandpass, &band, rate)?;
    if relative.len() <= sosfiltfilt_padlen(&sos) {
        return Ok(0.0);
    }
    let filtered = sosfiltfilt(&sos, relative)?;
    let rms = (filtered.iter().map(|x| x * x).sum::<f64>() / filtered.len() as f64).sqrt();
    Ok(rms / (NOISE_BAND.1 - NOISE_BAND.0).sqrt())
}
