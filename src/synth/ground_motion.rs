//! Seeded synthetic ground acceleration: Gaussian white noise filtered by the
//! Kanai–Tajimi soil filter (ω_g, ζ_g) and the Clough–Penzien high-pass
//! filter (ω_f, ζ_f), modulated by an envelope and scaled to a target peak
//! ground acceleration.  One generator, [`synthetic_ground_motion`], whose
//! [`GroundMotionSpec`] states explicitly how each step is realised:
//!
//! - white noise ([`WhiteNoise`]): the SplitMix64 or the xoshiro256** stream of
//!   `crate::rng`, each with its own Box–Muller variant;
//! - filtering ([`Shaping`]):
//!   - `Oscillators`, in the time domain.  Kanai–Tajimi:
//!     ẍ₁ + 2ζ_gω_g ẋ₁ + ω_g² x₁ = −w(t), a₁ = −(2ζ_gω_g ẋ₁ + ω_g² x₁)
//!     (absolute acceleration of the soil column), PSD ∝ (ω_g⁴ + 4ζ_g²ω_g²ω²)/((ω_g²−ω²)² + 4ζ_g²ω_g²ω²).
//!     Clough–Penzien: ẍ₂ + 2ζ_fω_f ẋ₂ + ω_f² x₂ = a₁, a_g = ẍ₂, which multiplies
//!     the PSD by ω⁴/((ω_f²−ω²)² + 4ζ_f²ω_f²ω²) and removes the unrealistic
//!     low-frequency content (finite ground velocity and displacement).
//!     Both filters use the exact zero-order-hold oscillator step of `super::sdof_zoh`.
//!   - `Spectral`, in the frequency domain: the noise spectrum is multiplied by
//!     the Kanai–Tajimi and Clough–Penzien magnitudes (no drift from very low
//!     frequencies) and a 4th-order Butterworth-magnitude low-pass roll-off;
//! - envelope ([`Envelope`]): Saragoni–Hart e(t) = a (t/t_n)^b exp(−c t/t_n) with
//!   b, c chosen so that the peak is at ε t_n and the envelope has fallen to η at
//!   t_n; or a Jennings-type plateau (quadratic rise, strong-motion plateau,
//!   exponential decay).
//!
//! The bundled building samples use the default (xoshiro256**, oscillators,
//! Saragoni–Hart); the yielding sample and the Bouc-Wen tests use
//! [`GroundMotionSpec::strong_50s`] (SplitMix64, spectral, plateau).

use super::sdof_zoh;
use crate::error::{Error, Result};
use crate::rng::{Rng, SplitMix64};
use realfft::RealFftPlanner;

/// Time axis of the record: a sampling rate or a sampling interval (the sample
/// count and instants are computed from the one given, so that each caller's
/// samples stay exactly as they were).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sampling {
    /// Sampling rate f_s, Hz: n = round(t_n f_s), t_i = i / f_s.
    RateHz(f64),
    /// Sampling interval Δt, s: n = round(t_n / Δt), t_i = i Δt.
    IntervalS(f64),
}

impl Sampling {
    /// Sampling rate, Hz.
    pub fn rate_hz(self) -> f64 {
        match self {
            Sampling::RateHz(fs) => fs,
            Sampling::IntervalS(dt) => 1.0 / dt,
        }
    }

    /// Sampling interval, s.
    pub fn interval_s(self) -> f64 {
        match self {
            Sampling::RateHz(fs) => 1.0 / fs,
            Sampling::IntervalS(dt) => dt,
        }
    }

    fn sample_count(self, duration_s: f64) -> usize {
        match self {
            Sampling::RateHz(fs) => (duration_s * fs).round() as usize,
            Sampling::IntervalS(dt) => (duration_s / dt).round() as usize,
        }
    }

    fn time_of(self, i: usize) -> f64 {
        match self {
            Sampling::RateHz(fs) => i as f64 / fs,
            Sampling::IntervalS(dt) => i as f64 * dt,
        }
    }

    fn value(self) -> f64 {
        match self {
            Sampling::RateHz(v) | Sampling::IntervalS(v) => v,
        }
    }
}

/// The seeded white-noise stream w(t) (unit variance).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WhiteNoise {
    /// `SplitMix64::next_gaussian` (Box–Muller, cosine branch, uniforms in (0, 1]).
    SplitMix64,
    /// `Rng::normal` (xoshiro256**, Box–Muller with the second deviate cached).
    Xoshiro256,
}

/// How the Kanai–Tajimi and Clough–Penzien filters are applied.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shaping {
    /// Exact zero-order-hold oscillators in the time domain (damping ratios in [0, 1)).
    Oscillators,
    /// Magnitudes applied to the noise's real FFT, times a 4th-order
    /// Butterworth-magnitude low-pass with this corner (Hz).
    Spectral { lowpass_frequency_hz: f64 },
}

/// Amplitude envelope e(t).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Envelope {
    /// Saragoni–Hart: peak 1 at ε t_n (`peak_fraction` ε), value η (`end_level`) at t_n.
    SaragoniHart { peak_fraction: f64, end_level: f64 },
    /// Quadratic rise until `rise_end_s`, plateau until `strong_end_s`, then
    /// exp(−decay_per_s · (t − strong_end_s)).
    Plateau {
        rise_end_s: f64,
        strong_end_s: f64,
        decay_per_s: f64,
    },
}

impl Envelope {
    /// Envelope value at time t of a record of duration t_n.
    pub fn at(&self, t: f64, duration_s: f64) -> f64 {
        match *self {
            Envelope::SaragoniHart {
                peak_fraction,
                end_level,
            } => saragoni_hart_envelope(t, duration_s, peak_fraction, end_level),
            Envelope::Plateau {
                rise_end_s,
                strong_end_s,
                decay_per_s,
            } => {
                if t < rise_end_s {
                    (t / rise_end_s).powi(2)
                } else if t <= strong_end_s {
                    1.0
                } else {
                    (-decay_per_s * (t - strong_end_s)).exp()
                }
            }
        }
    }
}

/// Settings of the synthetic ground motion.
#[derive(Debug, Clone, PartialEq)]
pub struct GroundMotionSpec {
    pub seed: u64,
    /// Duration of the record t_n, s.
    pub duration_s: f64,
    pub sampling: Sampling,
    /// Peak ground acceleration of the result, m/s².
    pub pga_m_per_s2: f64,
    /// Kanai–Tajimi soil frequency f_g, Hz.
    pub ground_frequency_hz: f64,
    /// Kanai–Tajimi soil damping ratio ζ_g.
    pub ground_damping: f64,
    /// Clough–Penzien high-pass corner f_f, Hz.
    pub highpass_frequency_hz: f64,
    /// Clough–Penzien damping ratio ζ_f.
    pub highpass_damping: f64,
    pub noise: WhiteNoise,
    pub shaping: Shaping,
    pub envelope: Envelope,
}

impl Default for GroundMotionSpec {
    /// 40 s at 200 Hz, firm soil (f_g = 2.5 Hz, ζ_g = 0.6), high-pass at 0.2 Hz,
    /// envelope peak at 20 % of the record, PGA 2 m/s² (≈0.2 g); xoshiro256**
    /// noise through the time-domain oscillators, Saragoni–Hart envelope.
    fn default() -> Self {
        GroundMotionSpec {
            seed: 1,
            duration_s: 40.0,
            sampling: Sampling::IntervalS(0.005),
            pga_m_per_s2: 2.0,
            ground_frequency_hz: 2.5,
            ground_damping: 0.6,
            highpass_frequency_hz: 0.2,
            highpass_damping: 0.6,
            noise: WhiteNoise::Xoshiro256,
            shaping: Shaping::Oscillators,
            envelope: Envelope::SaragoniHart {
                peak_fraction: 0.2,
                end_level: 0.05,
            },
        }
    }
}

impl GroundMotionSpec {
    /// A 50 s strong-motion record at `sampling_rate_hz`: KT 2.5 Hz / 0.6,
    /// CP 0.3 Hz / 0.7, low-pass 25 Hz, rise to 3 s, plateau to 15 s, decay 0.2/s;
    /// SplitMix64 noise shaped in the frequency domain.
    pub fn strong_50s(seed: u64, sampling_rate_hz: f64, pga: f64) -> Self {
        GroundMotionSpec {
            seed,
            duration_s: 50.0,
            sampling: Sampling::RateHz(sampling_rate_hz),
            pga_m_per_s2: pga,
            ground_frequency_hz: 2.5,
            ground_damping: 0.6,
            highpass_frequency_hz: 0.3,
            highpass_damping: 0.7,
            noise: WhiteNoise::SplitMix64,
            shaping: Shaping::Spectral {
                lowpass_frequency_hz: 25.0,
            },
            envelope: Envelope::Plateau {
                rise_end_s: 3.0,
                strong_end_s: 15.0,
                decay_per_s: 0.2,
            },
        }
    }

    /// Sampling interval of the record, s.
    pub fn dt(&self) -> f64 {
        self.sampling.interval_s()
    }

    fn validate(&self) -> Result<usize> {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        let lowpass_ok = match self.shaping {
            Shaping::Spectral {
                lowpass_frequency_hz,
            } => positive(lowpass_frequency_hz),
            Shaping::Oscillators => true,
        };
        if !(positive(self.duration_s)
            && positive(self.sampling.value())
            && positive(self.ground_frequency_hz)
            && positive(self.highpass_frequency_hz)
            && lowpass_ok)
        {
            return Err(Error::usage(
                "synthetic ground motion: duration, sampling and filter frequencies must be positive",
            ));
        }
        if self.shaping == Shaping::Oscillators
            && !((0.0..1.0).contains(&self.ground_damping)
                && (0.0..1.0).contains(&self.highpass_damping))
        {
            return Err(Error::usage(
                "synthetic ground motion: filter damping ratios must lie in [0, 1)",
            ));
        }
        match self.envelope {
            Envelope::SaragoniHart {
                peak_fraction,
                end_level,
            } => {
                if !(peak_fraction > 0.0
                    && peak_fraction < 1.0
                    && end_level > 0.0
                    && end_level < 1.0)
                {
                    return Err(Error::usage(
                        "synthetic ground motion: envelope peak fraction and end level must lie in (0, 1)",
                    ));
                }
            }
            Envelope::Plateau {
                rise_end_s,
                strong_end_s,
                ..
            } => {
                if rise_end_s > strong_end_s {
                    return Err(Error::usage(
                        "synthetic ground motion: the envelope's rise must end before its plateau",
                    ));
                }
            }
        }
        if !positive(self.pga_m_per_s2) {
            return Err(Error::usage(
                "synthetic ground motion: PGA must be positive",
            ));
        }
        let n = self.sampling.sample_count(self.duration_s);
        // The FFT shaping wants a spectrum worth the name.
        let fewest = match self.shaping {
            Shaping::Oscillators => 2,
            Shaping::Spectral { .. } => 16,
        };
        if n < fewest {
            return Err(Error::usage(format!(
                "synthetic ground motion: fewer than {fewest} samples"
            )));
        }
        Ok(n)
    }
}

/// Saragoni–Hart envelope value at time t for a record of duration t_n
/// (peak 1 at ε t_n, value η at t_n).
pub fn saragoni_hart_envelope(t: f64, duration_s: f64, peak_fraction: f64, end_level: f64) -> f64 {
    let eps = peak_fraction;
    let b = -eps * end_level.ln() / (1.0 + eps * (eps.ln() - 1.0));
    let c = b / eps;
    let a = (std::f64::consts::E / eps).powf(b);
    let x = t / duration_s;
    if x <= 0.0 {
        return 0.0;
    }
    a * x.powf(b) * (-c * x).exp()
}

/// Synthetic ground acceleration (m/s²) described by `spec`; deterministic in its seed.
pub fn synthetic_ground_motion(spec: &GroundMotionSpec) -> Result<Vec<f64>> {
    let n = spec.validate()?;
    let noise: Vec<f64> = match spec.noise {
        WhiteNoise::SplitMix64 => {
            let mut rng = SplitMix64::new(spec.seed);
            (0..n).map(|_| rng.next_gaussian()).collect()
        }
        WhiteNoise::Xoshiro256 => {
            let mut rng = Rng::new(spec.seed);
            (0..n).map(|_| rng.normal()).collect()
        }
    };
    let mut signal = match spec.shaping {
        Shaping::Oscillators => filter_by_oscillators(spec, &noise),
        Shaping::Spectral {
            lowpass_frequency_hz,
        } => filter_in_spectrum(spec, noise, lowpass_frequency_hz)?,
    };
    for (i, x) in signal.iter_mut().enumerate() {
        *x *= spec.envelope.at(spec.sampling.time_of(i), spec.duration_s);
    }
    let peak = signal.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if !(peak > 0.0) {
        return Err(Error::numerical(
            "synthetic ground motion: generated record is identically zero",
        ));
    }
    let scale = spec.pga_m_per_s2 / peak;
    signal.iter_mut().for_each(|v| *v *= scale);
    Ok(signal)
}

/// Kanai–Tajimi then Clough–Penzien oscillators driven by `noise`, stepped
/// exactly (zero-order hold); the output at step k precedes the update.
fn filter_by_oscillators(spec: &GroundMotionSpec, noise: &[f64]) -> Vec<f64> {
    let dt = spec.sampling.interval_s();
    let (wg, zg) = (
        std::f64::consts::TAU * spec.ground_frequency_hz,
        spec.ground_damping,
    );
    let (wf, zf) = (
        std::f64::consts::TAU * spec.highpass_frequency_hz,
        spec.highpass_damping,
    );
    let (a1, b1) = sdof_zoh(wg, zg, dt);
    let (a2, b2) = sdof_zoh(wf, zf, dt);
    let (mut x1, mut v1, mut x2, mut v2) = (0.0, 0.0, 0.0, 0.0);
    let mut out = Vec::with_capacity(noise.len());
    for &w in noise {
        // Kanai–Tajimi output (soil absolute acceleration).
        let soil = -(2.0 * zg * wg * v1 + wg * wg * x1);
        // Clough–Penzien output: relative acceleration of the second oscillator.
        out.push(soil - 2.0 * zf * wf * v2 - wf * wf * x2);
        let x1n = a1[0][0] * x1 + a1[0][1] * v1 - b1[0] * w;
        v1 = a1[1][0] * x1 + a1[1][1] * v1 - b1[1] * w;
        x1 = x1n;
        let x2n = a2[0][0] * x2 + a2[0][1] * v2 + b2[0] * soil;
        v2 = a2[1][0] * x2 + a2[1][1] * v2 + b2[1] * soil;
        x2 = x2n;
    }
    out
}

/// Kanai–Tajimi, Clough–Penzien and low-pass magnitudes applied to the real
/// FFT of `noise`, back to the time domain.
fn filter_in_spectrum(
    spec: &GroundMotionSpec,
    mut noise: Vec<f64>,
    lowpass_frequency_hz: f64,
) -> Result<Vec<f64>> {
    let n = noise.len();
    let fs = spec.sampling.rate_hz();
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
        let lp = 1.0 / (1.0 + (f / lowpass_frequency_hz).powi(8)).sqrt();
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
    Ok(signal)
}
