//! Deterministic synthetic ground motion for test events: seeded Gaussian white
//! noise shaped in the frequency domain by the Kanai–Tajimi ground filter and a
//! Clough–Penzien high-pass (no drift from very low frequencies), a
//! low-pass roll-off, then multiplied by a Jennings-type envelope (quadratic
//! rise, strong-motion plateau, exponential decay) and scaled to a target PGA.
//!
//! The PRNG is `crate::rng::SplitMix64` (the project keeps randomness seeded and
//! dependency-free); Gaussian deviates come from the Box–Muller transform.

use crate::error::{Error, Result};
use crate::rng::SplitMix64;
use realfft::RealFftPlanner;

/// Settings of the synthetic accelerogram; every field is stated in the tests.
#[derive(Debug, Clone, PartialEq)]
pub struct GroundMotionSpec {
    pub seed: u64,
    pub sampling_rate_hz: f64,
    pub duration_s: f64,
    /// Peak ground acceleration of the result, m/s².
    pub pga: f64,
    /// Kanai–Tajimi ground frequency (Hz) and damping ratio.
    pub ground_frequency_hz: f64,
    pub ground_damping: f64,
    /// Clough–Penzien high-pass corner (Hz) and damping ratio.
    pub highpass_frequency_hz: f64,
    pub highpass_damping: f64,
    /// Corner of a 4th-order Butterworth-magnitude low-pass (Hz).
    pub lowpass_frequency_hz: f64,
    /// Envelope: quadratic rise until `rise_end_s`, plateau until
    /// `strong_end_s`, then exp(−decay_per_s · (t − strong_end_s)).
    pub rise_end_s: f64,
    pub strong_end_s: f64,
    pub decay_per_s: f64,
}

impl GroundMotionSpec {
    /// A 50 s strong-motion record at `sampling_rate_hz`: KT 2.5 Hz / 0.6,
    /// CP 0.3 Hz / 0.7, low-pass 25 Hz, rise to 3 s, plateau to 15 s, decay 0.2/s.
    pub fn strong_50s(seed: u64, sampling_rate_hz: f64, pga: f64) -> Self {
        GroundMotionSpec {
            seed,
            sampling_rate_hz,
            duration_s: 50.0,
            pga,
            ground_frequency_hz: 2.5,
            ground_damping: 0.6,
            highpass_frequency_hz: 0.3,
            highpass_damping: 0.7,
            lowpass_frequency_hz: 25.0,
            rise_end_s: 3.0,
            strong_end_s: 15.0,
            decay_per_s: 0.2,
        }
    }
}

/// Generates the accelerogram (m/s²) described by `spec`.
pub fn synthetic_ground_motion(spec: &GroundMotionSpec) -> Result<Vec<f64>> {
    let fs = spec.sampling_rate_hz;
    let positive = [
        fs,
        spec.duration_s,
        spec.pga,
        spec.ground_frequency_hz,
        spec.highpass_frequency_hz,
        spec.lowpass_frequency_hz,
    ];
    if positive.iter().any(|x| !(x.is_finite() && *x > 0.0)) || spec.rise_end_s > spec.strong_end_s
    {
        return Err(Error::usage(
            "synthetic ground motion: rates, duration, PGA and corner frequencies must be positive",
        ));
    }
    let n = (spec.duration_s * fs).round() as usize;
    if n < 16 {
        return Err(Error::usage(
            "synthetic ground motion: fewer than 16 samples",
        ));
    }
    let mut rng = SplitMix64::new(spec.seed);
    let mut noise: Vec<f64> = (0..n).map(|_| rng.next_gaussian()).collect();
    let mut planner = RealFftPlanner::<f64>::new();
    let forward = planner.plan_fft_forward(n);
    let inverse = planner.plan_fft_inverse(n);
    let mut spectrum = forward.make_output_vec();
    forward
        .process(&mut noise, &mut spectrum)
        .map_err(|e| Error::numerical(format!("FFT: {e}")))?;
    for (k, bin) in spectrum.iter_mut().enumerate() {
        let f = k as f64 * fs / n as f64;
        // Kanai–Tajimi magnitude.
        let r = f / spec.ground_frequency_hz;
        let z = spec.ground_damping;
        let kt =
            ((1.0 + 4.0 * z * z * r * r) / ((1.0 - r * r).powi(2) + 4.0 * z * z * r * r)).sqrt();
        // Clough–Penzien high-pass magnitude.
        let rf = f / spec.highpass_frequency_hz;
        let zf = spec.highpass_damping;
        let cp = (rf.powi(4) / ((1.0 - rf * rf).powi(2) + 4.0 * zf * zf * rf * rf)).sqrt();
        // Butterworth (order 4) low-pass magnitude.
        let lp = 1.0 / (1.0 + (f / spec.lowpass_frequency_hz).powi(8)).sqrt();
        *bin *= kt * cp * lp;
    }
    // The inverse real FFT needs purely real DC (and Nyquist for even n).
    spectrum[0].im = 0.0;
    if n.is_multiple_of(2) {
        if let Some(last) = spectrum.last_mut() {
            last.im = 0.0;
        }
    }
    let mut signal = inverse.make_output_vec();
    inverse
        .process(&mut spectrum, &mut signal)
        .map_err(|e| Error::numerical(format!("inverse FFT: {e}")))?;
    for (i, x) in signal.iter_mut().enumerate() {
        let t = i as f64 / fs;
        let envelope = if t < spec.rise_end_s {
            (t / spec.rise_end_s).powi(2)
        } else if t <= spec.strong_end_s {
            1.0
        } else {
            (-spec.decay_per_s * (t - spec.strong_end_s)).exp()
        };
        *x *= envelope;
    }
    let peak = signal.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if peak <= 0.0 {
        return Err(Error::numerical(
            "synthetic ground motion is identically zero",
        ));
    }
    let scale = spec.pga / peak;
    signal.iter_mut().for_each(|x| *x *= scale);
    Ok(signal)
}
