//! Apparent (instantaneous) frequency during an event (issue 32): a
//! moving-window ARX identification of the fundamental over the record, for
//! the frequency drop during strong shaking and the permanent shift after it.
//!
//! 1. Anti-alias and decimate: both signals go through one symmetric
//!    windowed-sinc FIR (Hamming window, half length 2q, cut-off at 0.8 of the
//!    new Nyquist) and are kept every q samples, q = ⌊1 / (Δt · s · f_e)⌋ so
//!    that the new rate is about `samples_per_period` s times the expected
//!    frequency f_e.  A linear time-invariant relation between the raw
//!    signals holds between the filtered ones wherever the filter's support
//!    lies inside the span where the structure is linear (filtering commutes
//!    with an LTI system), so every decimated sample a window uses is built
//!    from raw samples *inside* the window only.
//! 2. Per window of W = max(window_periods / f_e, min_window_s) seconds,
//!    stepped by step_fraction · W, the ARX model of order n (Ljung, *System
//!    Identification*, 2nd ed., 1999, Eq. 4.7 and §7.3):
//!      y_k + a₁ y_{k−1} + … + a_n y_{k−n} = b₀ u_k + … + b_n u_{k−n} + c + e_k,
//!    with u the base (input) and y the floor absolute acceleration (output):
//!    y_abs = ü_rel + a_g has a direct term b₀, and the intercept c absorbs
//!    sensor offsets.  Without an input the AR model (b ≡ 0) is fitted to the
//!    output alone.  θ = (a, b, c) by least squares over the rows k whose lags
//!    all lie in the window (Ljung Eq. 7.34, normal equations, columns scaled
//!    to unit norm, a 10⁻¹⁰ ridge against the rank loss of noise-free,
//!    band-limited data, Cholesky).
//! 3. Poles: the roots μ of z^n + a₁ z^{n−1} + … + a_n (eigenvalues of the
//!    companion matrix), λ = ln μ / Δt_d, f = |λ| / 2π, ζ = −Re λ / |λ|
//!    (as [`super::poles::poles_of_order`]).  The apparent frequency of the
//!    window is the pole with Im μ > 0, f in `band` · f_e and 0 < ζ <
//!    `max_damping` nearest to f_e on a log scale; none: NaN.
//!
//! Noise-free and linear over a window, the ARX fit reproduces the
//! discrete poles of the decimated system (exact up to the model order's
//! truncation of the higher modes); with measurement noise the equation-error
//! estimate is biased (Ljung §8.3), less so for a higher order.  Measured
//! (tests/it/apparent_frequency.rs): noise-free, the defaults (5 periods,
//! order 8, 12 samples per period) are within 0.1 % of the true tangent f₁
//! of the yielding frame wherever it stays linear over the window; with
//! 30 dB noise the median error is < 1 % but single windows reach several
//! per cent (8 periods and order 8–12 halve that), and windows where the
//! noise dominates (quiet pads) may give a spurious pole or none.  The AR
//! (output-only) model needs a higher order and longer windows (order 16,
//! 40 periods: < 2.5 % on an ambient response).  I/O free.

// `!(x > 0.0)` is meant: it refuses NaN as well; index loops mirror the equations.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

use crate::error::{Error, Result};
use faer::Mat;
use rayon::prelude::*;

/// Settings of the moving-window identification (module doc).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ApparentSettings {
    /// Window length in periods of the expected frequency.
    pub window_periods: f64,
    /// Shortest window, s.
    pub min_window_s: f64,
    /// Step between windows as a fraction of the window.
    pub step_fraction: f64,
    /// Decimated sampling rate in multiples of the expected frequency (about).
    pub samples_per_period: f64,
    /// ARX / AR order n (poles of the output polynomial).
    pub order: usize,
    /// Accepted frequencies, as multiples of the expected one [low, high].
    pub band: [f64; 2],
    /// Largest accepted damping ratio.
    pub max_damping: f64,
}

impl Default for ApparentSettings {
    fn default() -> Self {
        ApparentSettings {
            window_periods: 5.0,
            min_window_s: 2.0,
            step_fraction: 0.2,
            samples_per_period: 12.0,
            order: 8,
            band: [0.4, 1.6],
            max_damping: 0.3,
        }
    }
}

impl ApparentSettings {
    pub fn validate(&self) -> Result<()> {
        let pos = |v: f64| v.is_finite() && v > 0.0;
        let problem = if !(pos(self.window_periods) && self.window_periods <= 1000.0) {
            Some("window_periods must be in (0, 1000]")
        } else if !(self.min_window_s.is_finite() && self.min_window_s >= 0.0) {
            Some("min_window_s must be ≥ 0")
        } else if !(self.step_fraction >= 0.01 && self.step_fraction <= 1.0) {
            // Steps below 1 % of the window only multiply the windows (and the time).
            Some("step_fraction must be in [0.01, 1]")
        } else if !(self.samples_per_period >= 4.0 && self.samples_per_period <= 1000.0) {
            Some("samples_per_period must be in [4, 1000] (the pole must lie well below the decimated Nyquist frequency)")
        } else if !(2..=40).contains(&self.order) {
            Some("order must be in 2..=40")
        } else if !(pos(self.band[0]) && self.band[1].is_finite() && self.band[1] > self.band[0]) {
            Some("band must be [low, high] with 0 < low < high")
        } else if !(pos(self.max_damping) && self.max_damping < 1.0) {
            Some("max_damping must be in (0, 1)")
        } else {
            None
        };
        match problem {
            Some(p) => Err(Error::usage(format!("apparent frequency settings: {p}"))),
            None => Ok(()),
        }
    }
}

/// One window of the track.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct TrackPoint {
    /// Window centre, s from the record start.
    pub time_s: f64,
    /// Apparent frequency, Hz; NaN: no pole in the band (or no motion).
    pub frequency_hz: f64,
    /// Damping ratio of that pole; NaN with it.
    pub damping_ratio: f64,
    /// RMS of the output over the window (offset included), the output's units.
    pub output_rms: f64,
    /// Time of the first and last raw samples the window uses, s: every
    /// value of the point depends on these samples only.
    pub start_s: f64,
    pub end_s: f64,
}

/// The apparent-frequency track of one output.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FrequencyTrack {
    /// "arx" (with an input) or "ar" (output only).
    pub method: &'static str,
    /// Window length, s.
    pub window_s: f64,
    /// Decimated sampling interval the model is fitted at, s.
    pub model_dt: f64,
    pub points: Vec<TrackPoint>,
}

/// Summary of a track round the strong phase ([`FrequencyTrack::phases`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FrequencyPhases {
    /// Median frequency of the windows wholly before the strong phase, Hz.
    pub pre_hz: Option<f64>,
    /// How many windows (with a frequency) that median is over.
    pub pre_windows: usize,
    /// Lowest frequency of the windows overlapping the strong phase, Hz.
    pub min_during_hz: Option<f64>,
    /// Median frequency of the windows wholly after the strong phase, Hz.
    pub post_hz: Option<f64>,
    pub post_windows: usize,
}

impl FrequencyTrack {
    /// Pre-event, during and post-event frequencies for a strong phase
    /// [strong_start_s, strong_end_s] (s from the record start).
    pub fn phases(&self, strong_start_s: f64, strong_end_s: f64) -> FrequencyPhases {
        let finite = |p: &&TrackPoint| p.frequency_hz.is_finite();
        let pre: Vec<f64> = self
            .points
            .iter()
            .filter(finite)
            .filter(|p| p.end_s <= strong_start_s)
            .map(|p| p.frequency_hz)
            .collect();
        let post: Vec<f64> = self
            .points
            .iter()
            .filter(finite)
            .filter(|p| p.start_s >= strong_end_s)
            .map(|p| p.frequency_hz)
            .collect();
        let min_during_hz = self
            .points
            .iter()
            .filter(finite)
            .filter(|p| p.end_s > strong_start_s && p.start_s < strong_end_s)
            .map(|p| p.frequency_hz)
            .min_by(f64::total_cmp);
        FrequencyPhases {
            pre_hz: median(pre.clone()),
            pre_windows: pre.len(),
            min_during_hz,
            post_hz: median(post.clone()),
            post_windows: post.len(),
        }
    }
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}

/// One output (and its input) of [`track_many`].
#[derive(Debug, Clone, Copy)]
pub struct TrackRequest<'a> {
    pub input: Option<&'a [f64]>,
    pub output: &'a [f64],
    pub expected_hz: f64,
}

/// [`track_apparent_frequency`] of every request, in parallel (rayon), in order.
pub fn track_many(
    requests: &[TrackRequest],
    dt: f64,
    settings: &ApparentSettings,
) -> Vec<Result<FrequencyTrack>> {
    requests
        .par_iter()
        .map(|r| track_apparent_frequency(r.input, r.output, dt, r.expected_hz, settings))
        .collect()
}

/// The apparent-frequency track of `output` (with `input` as the ARX input,
/// or AR when none), both sampled at `dt` (module doc).
pub fn track_apparent_frequency(
    input: Option<&[f64]>,
    output: &[f64],
    dt: f64,
    expected_hz: f64,
    settings: &ApparentSettings,
) -> Result<FrequencyTrack> {
    settings.validate()?;
    if !(dt.is_finite() && dt > 0.0) {
        return Err(Error::usage(format!(
            "apparent frequency: sampling interval must be > 0, got {dt}"
        )));
    }
    if !(expected_hz.is_finite() && expected_hz > 0.0) {
        return Err(Error::usage(format!(
            "apparent frequency: expected frequency must be > 0 Hz, got {expected_hz}"
        )));
    }
    if expected_hz * settings.band[1] >= 0.5 / dt {
        return Err(Error::usage(format!(
            "apparent frequency: the band up to {:.3} Hz reaches the Nyquist frequency {:.3} Hz",
            expected_hz * settings.band[1],
            0.5 / dt
        )));
    }
    if let Some(u) = input {
        if u.len() != output.len() {
            return Err(Error::usage(format!(
                "apparent frequency: input of {} samples, output of {}",
                u.len(),
                output.len()
            )));
        }
    }
    let all = output.iter().chain(input.into_iter().flatten());
    if let Some(bad) = all.clone().position(|v| !v.is_finite()) {
        return Err(Error::numerical(format!(
            "apparent frequency: non-finite sample (position {bad} of output then input)"
        )));
    }
    let window_s = (settings.window_periods / expected_hz).max(settings.min_window_s);
    let window = (window_s / dt).round() as usize;
    if output.len() < window {
        return Err(Error::usage(format!(
            "apparent frequency: a record of {:.2} s is shorter than one window of {window_s:.2} s ({} periods of the expected {expected_hz:.3} Hz, at least min_window_s = {} s)",
            output.len() as f64 * dt,
            settings.window_periods,
            settings.min_window_s
        )));
    }
    let q = ((1.0 / (dt * settings.samples_per_period * expected_hz)).floor() as usize).max(1);
    let fir = lowpass_fir(q);
    let half = fir.len() / 2;
    let y = decimate(output, &fir, q);
    let u = input.map(|u| decimate(u, &fir, q));
    let order = settings.order;
    let params = order + 1 + u.as_ref().map_or(0, |_| order + 1);
    // Decimated samples per window: those whose FIR support is inside it.
    let per_window = if window > 2 * half {
        (window - 2 * half - 1) / q + 1
    } else {
        0
    };
    if per_window < order + params + params / 2 {
        return Err(Error::usage(format!(
            "apparent frequency: a window of {window_s:.2} s holds {per_window} decimated samples, too few for order {order} ({params} parameters): lengthen the window or lower the order"
        )));
    }
    let model_dt = q as f64 * dt;
    let scale = output.iter().map(|v| v * v).sum::<f64>().sqrt();
    // Windows start on decimated samples, so that each uses the same count.
    let step = ((settings.step_fraction * window as f64 / q as f64).round() as usize).max(1) * q;
    let mut points = Vec::new();
    let mut start = 0;
    while start + window <= output.len() {
        let end = start + window - 1;
        // Decimated sample j has the support [j q, j q + 2 half].
        let j0 = start / q;
        let seg = &output[start..=end];
        let rms = (seg.iter().map(|v| v * v).sum::<f64>() / seg.len() as f64).sqrt();
        let mean = seg.iter().sum::<f64>() / seg.len() as f64;
        let spread = seg.iter().map(|v| (v - mean).abs()).fold(0.0, f64::max);
        // A window without motion (1e-9 of the record's norm) carries no pole.
        let moving = spread > 1e-9 * scale / (output.len() as f64).sqrt();
        let pole = if moving {
            let yw = &y[j0..j0 + per_window];
            let uw = u.as_ref().map(|u| &u[j0..j0 + per_window]);
            arx_poles(yw, uw, order)?
                .into_iter()
                .filter_map(|mu| continuous(mu, model_dt))
                .filter(|&(f, z)| {
                    f >= settings.band[0] * expected_hz
                        && f <= settings.band[1] * expected_hz
                        && z > 0.0
                        && z < settings.max_damping
                })
                .min_by(|a, b| {
                    (a.0 / expected_hz)
                        .ln()
                        .abs()
                        .total_cmp(&(b.0 / expected_hz).ln().abs())
                })
        } else {
            None
        };
        let (f, z) = pole.unwrap_or((f64::NAN, f64::NAN));
        points.push(TrackPoint {
            time_s: 0.5 * (start + end) as f64 * dt,
            frequency_hz: f,
            damping_ratio: z,
            output_rms: rms,
            start_s: start as f64 * dt,
            end_s: end as f64 * dt,
        });
        start += step;
    }
    Ok(FrequencyTrack {
        method: if input.is_some() { "arx" } else { "ar" },
        window_s: window as f64 * dt,
        model_dt,
        points,
    })
}

/// Symmetric low-pass FIR for decimation by q: windowed sinc (Hamming),
/// half length 2q, cut-off 0.8 · (0.5 / q) cycles per sample, unit DC gain;
/// q = 1: the identity.
fn lowpass_fir(q: usize) -> Vec<f64> {
    if q == 1 {
        return vec![1.0];
    }
    let half = 2 * q;
    let fc = 0.8 * 0.5 / q as f64;
    let mut h: Vec<f64> = (0..=2 * half)
        .map(|i| {
            let m = i as f64 - half as f64;
            let sinc = if m == 0.0 {
                2.0 * fc
            } else {
                (std::f64::consts::TAU * fc * m).sin() / (std::f64::consts::PI * m)
            };
            let w = 0.54 - 0.46 * (std::f64::consts::PI * i as f64 / half as f64).cos();
            sinc * w
        })
        .collect();
    let sum: f64 = h.iter().sum();
    h.iter_mut().for_each(|v| *v /= sum);
    h
}

/// Decimated sample j = Σ_i h_i x_{j q + i}: its support is [j q, j q + len − 1].
fn decimate(x: &[f64], h: &[f64], q: usize) -> Vec<f64> {
    if x.len() < h.len() {
        return Vec::new();
    }
    (0..=(x.len() - h.len()) / q)
        .map(|j| {
            let s = &x[j * q..j * q + h.len()];
            s.iter().zip(h).map(|(a, b)| a * b).sum()
        })
        .collect()
}

/// Least-squares ARX (or AR when `u` is None) fit of order n over the rows
/// whose lags lie in the window, and the roots of its output polynomial.
fn arx_poles(y: &[f64], u: Option<&[f64]>, n: usize) -> Result<Vec<faer::c64>> {
    let p = n + 1 + u.map_or(0, |_| n + 1);
    let mut g = vec![0.0; p * p];
    let mut rhs = vec![0.0; p];
    let mut phi = vec![0.0; p];
    for k in n..y.len() {
        for i in 0..n {
            phi[i] = -y[k - 1 - i];
        }
        if let Some(u) = u {
            for j in 0..=n {
                phi[n + j] = u[k - j];
            }
        }
        phi[p - 1] = 1.0;
        for a in 0..p {
            let pa = phi[a];
            rhs[a] += pa * y[k];
            for b in 0..=a {
                g[a * p + b] += pa * phi[b];
            }
        }
    }
    let theta = solve_scaled(&mut g, &mut rhs, p);
    let Some(theta) = theta else {
        return Ok(Vec::new());
    };
    if theta[..n].iter().any(|v| !v.is_finite()) {
        return Ok(Vec::new());
    }
    // Companion matrix of z^n + a₁ z^{n−1} + … + a_n.
    let c = Mat::<f64>::from_fn(n, n, |i, j| {
        if i == 0 {
            -theta[j]
        } else if i == j + 1 {
            1.0
        } else {
            0.0
        }
    });
    c.eigenvalues()
        .map_err(|e| Error::numerical(format!("apparent frequency: companion eigenvalues: {e:?}")))
}

/// Solves the normal equations (lower triangle of `g`, p × p) by Cholesky
/// after scaling the columns to unit diagonal, with a 10⁻¹⁰ ridge; None when
/// the matrix is not positive (no motion).
fn solve_scaled(g: &mut [f64], rhs: &mut [f64], p: usize) -> Option<Vec<f64>> {
    let d: Vec<f64> = (0..p).map(|i| g[i * p + i].sqrt()).collect();
    if d.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
        return None;
    }
    for a in 0..p {
        for b in 0..=a {
            g[a * p + b] /= d[a] * d[b];
        }
        g[a * p + a] += 1e-10;
        rhs[a] /= d[a];
    }
    // In-place Cholesky L Lᵀ of the lower triangle.
    for j in 0..p {
        let mut s = g[j * p + j];
        for k in 0..j {
            s -= g[j * p + k] * g[j * p + k];
        }
        if !(s > 0.0) {
            return None;
        }
        let l = s.sqrt();
        g[j * p + j] = l;
        for i in j + 1..p {
            let mut s = g[i * p + j];
            for k in 0..j {
                s -= g[i * p + k] * g[j * p + k];
            }
            g[i * p + j] = s / l;
        }
    }
    let mut z = rhs.to_vec();
    for i in 0..p {
        for k in 0..i {
            z[i] -= g[i * p + k] * z[k];
        }
        z[i] /= g[i * p + i];
    }
    for i in (0..p).rev() {
        for k in i + 1..p {
            z[i] -= g[k * p + i] * z[k];
        }
        z[i] /= g[i * p + i];
    }
    Some(z.iter().zip(&d).map(|(z, d)| z / d).collect())
}

/// (f, ζ) of a discrete pole μ with Im μ > 0 (module doc, step 3).
fn continuous(mu: faer::c64, dt: f64) -> Option<(f64, f64)> {
    if !(mu.im > 1e-12 * mu.norm().max(1e-300)) {
        return None;
    }
    let (re, im) = (mu.norm().ln() / dt, mu.arg() / dt);
    let omega = re.hypot(im);
    (omega.is_finite() && omega > 0.0).then(|| (omega / std::f64::consts::TAU, -re / omega))
}
