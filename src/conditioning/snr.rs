//! Filter corners chosen per record from its signal-to-noise ratio (issue 34
//! item 1), the way gmprocess chooses them (`get_corner_frequencies`,
//! method `snr`), with the pipeline's corners as bounds.
//!
//! **Windows.**  The record (SI units, before any step) is split at the
//! signal **onset**, found by Maeda's (1985) AIC picker
//! AIC(k) = k·ln var(x[0..k]) + (n − k − 1)·ln var(x[k..n]) over the record
//! up to a quarter of its energy Σx² (the shaking has begun by then): the
//! onset is the split into a quiet and a loud part that the two variances
//! explain best.  The AIC needs no threshold and no pre-event length (gmprocess
//! splits at a P pick from travel times or its AR picker; a building's records
//! come without the event's location).  The **noise window** is the record
//! before the onset (at most its last 30 minutes), the **signal window** from
//! the onset to 95 % of the record's energy.  A noise window is used only when it is
//! - at least `noise_min_s` long (4 s by default): a triggered film record has
//!   no pre-event memory — it starts on the P wave, and its first seconds are
//!   shaking, not noise; and
//! - quiet: its RMS at most a tenth (−20 dB) of the signal window's, which a
//!   window holding the P wave rarely is.
//!
//! Otherwise the record keeps the pipeline's corners and the history says why.
//! The records of an event combined by later stages are filtered alike
//! ([`common_corners`]: the highest high-pass and lowest low-pass of its
//! horizontal records, and of its vertical ones).
//!
//! **Spectra.**  Each window is demeaned and tapered (Hann, 5 % at each end, as
//! gmprocess), both are transformed with the same FFT length (the next power of
//! two of the longer), |X(f)|·Δt is smoothed by the Konno–Ohmachi (1998)
//! window W = [sin(b·log₁₀(f/f_c)) / (b·log₁₀(f/f_c))]⁴, b = 20 (gmprocess's
//! default), at 50 centre frequencies per decade from the signal window's
//! resolution 1/T_s to the Nyquist frequency, and divided by √(window
//! duration): an amplitude spectral density, so that stationary noise has the
//! same level in a window of any length.  SNR(f) = S(f)/N(f).  The noise
//! spectrum is not resolved below 1/T_n (the noise window's length): there it
//! is not given and the ratio is not judged.
//!
//! **Corners.**  With θ = `snr_min` (3, gmprocess's default):
//! - the high-pass corner is the lowest frequency above which SNR ≥ θ up to the
//!   high-pass bound (found walking down from the bound, the crossing
//!   interpolated in log f and log SNR); bounded below by the pipeline's corner
//!   (never filter less than the pipeline says) and above by `high_pass_max_hz`
//!   (0.5 Hz, METHODS §1's corner, lowered to the band modal identification
//!   uses — so that a noisy record does not lose its first mode).  Where the
//!   noise window is too short to resolve a frequency, the pipeline's corner
//!   stands: unlike gmprocess (which never goes below 1/T_n), a record is not
//!   filtered more because its pre-event memory is short — a structure's peak
//!   drift needs its long-period content (docs/pipelines.md);
//! - the low-pass corner is the highest frequency below which SNR ≥ θ from
//!   `low_pass_min_hz` (10 Hz) up, bounded above by the pipeline's corner.
//!
//! Numerical code only: slices in, values out.

use std::ops::Range;

use realfft::RealFftPlanner;

use crate::error::{Error, Result};

/// Konno–Ohmachi bandwidth coefficient (gmprocess's default).
pub const KONNO_OHMACHI_B: f64 = 20.0;
/// Centre frequencies per decade of the smoothed spectra.
pub const PER_DECADE: f64 = 50.0;
/// Hann taper of each window, fraction at each end (gmprocess's).
pub const WINDOW_TAPER: f64 = 0.05;
/// A noise window counts when its RMS is at most this fraction of the signal
/// window's (−20 dB).
pub const QUIET_FRACTION: f64 = 0.1;
/// The onset is searched up to this fraction of the record's energy.
const ONSET_SEARCH_ENERGY: f64 = 0.25;
/// The signal window ends at this fraction of the record's energy.
const SIGNAL_END_ENERGY: f64 = 0.95;
/// Fewest samples on each side of an AIC split, and in a window.
const MIN_WINDOW_SAMPLES: usize = 10;
/// Longest signal window whose spectrum is formed, s: a triggered record lasts
/// minutes; a continuous record is analysed on its event window
/// (`event_window`), and one without is ambient vibration, not an event.
pub const MAX_SIGNAL_S: f64 = super::event_window::CONTINUOUS_ABOVE_S;
/// The smoothing window is cut at its third zero, |b·log₁₀(f/f_c)| = 3π
/// (the side lobes beyond are below 1.3·10⁻⁴ of the centre).
const KO_HALF_WIDTH: f64 = 3.0 * std::f64::consts::PI;

/// The signal and noise windows of one record (sample ranges).
#[derive(Debug, Clone, PartialEq)]
pub struct Windows {
    /// The AIC onset, when the record has a quiet part before its shaking.
    pub onset: Option<usize>,
    /// From the record's first sample to the onset, when usable.
    pub noise: Option<Range<usize>>,
    /// Why there is no noise window (in words), when there is none.
    pub no_noise: Option<String>,
    /// From the onset (the first sample without one) to 95 % of the energy.
    pub signal: Range<usize>,
}

/// The onset of `x` by Maeda's AIC: the split k (each part at least
/// [`MIN_WINDOW_SAMPLES`] long) minimising
/// k·ln var(x[0..k]) + (n − k − 1)·ln var(x[k..n]); `None` when `x` is too short.
pub fn aic_onset(x: &[f64]) -> Option<usize> {
    let n = x.len();
    let m = MIN_WINDOW_SAMPLES;
    if n < 2 * m + 1 {
        return None;
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    // Prefix sums of the demeaned values and their squares (the prefix
    // variance of a quiet start is then free of the record's offset).
    let mut s1 = Vec::with_capacity(n + 1);
    let mut s2 = Vec::with_capacity(n + 1);
    let (mut a, mut b) = (0.0, 0.0);
    s1.push(0.0);
    s2.push(0.0);
    for v in x {
        let d = v - mean;
        a += d;
        b += d * d;
        s1.push(a);
        s2.push(b);
    }
    // A variance floor keeps ln finite on an exactly silent part (a
    // noise-free synthetic record), relative to the record's scale.
    let floor = (s2[n] / n as f64 * 1e-30).max(f64::MIN_POSITIVE);
    let var = |lo: usize, hi: usize| {
        let len = (hi - lo) as f64;
        let m1 = (s1[hi] - s1[lo]) / len;
        ((s2[hi] - s2[lo]) / len - m1 * m1).max(floor)
    };
    let mut best: Option<(f64, usize)> = None;
    for k in m..=n - m {
        let aic = k as f64 * var(0, k).ln() + (n - k - 1) as f64 * var(k, n).ln();
        if best.is_none_or(|(b, _)| aic < b) {
            best = Some((aic, k));
        }
    }
    best.map(|(_, k)| k)
}

fn rms_about_mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    (x.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / x.len() as f64).sqrt()
}

/// The first index at which the running energy Σ(x − x̄)² reaches
/// `fraction` of the total (the total is passed: the sum is formed once).
fn energy_index(x: &[f64], mean: f64, total: f64, fraction: f64) -> usize {
    let target = fraction * total;
    let mut acc = 0.0;
    for (i, v) in x.iter().enumerate() {
        acc += (v - mean) * (v - mean);
        if acc >= target {
            return i;
        }
    }
    x.len().saturating_sub(1)
}

/// The windows of record `x` sampled every `dt` s; `None` when the record is
/// too short or silent to have a signal window.
pub fn windows(x: &[f64], dt: f64, noise_min_s: f64) -> Option<Windows> {
    let n = x.len();
    if n < 4 * MIN_WINDOW_SAMPLES || dt.is_nan() || dt <= 0.0 {
        return None;
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let total: f64 = x.iter().map(|v| (v - mean) * (v - mean)).sum();
    if !(total > 0.0 && total.is_finite()) {
        return None;
    }
    let search_end = energy_index(x, mean, total, ONSET_SEARCH_ENERGY) + 1;
    let end = (energy_index(x, mean, total, SIGNAL_END_ENERGY) + 1).min(n);
    let onset = aic_onset(&x[..search_end]).filter(|&k| k + MIN_WINDOW_SAMPLES <= end);
    let start = onset.unwrap_or(0);
    let signal = start..end.max(start + MIN_WINDOW_SAMPLES).min(n);
    let (noise, no_noise) = match onset {
        None => (
            None,
            Some("the record starts with its shaking (no quiet part before it)".to_string()),
        ),
        Some(k) if (k as f64) * dt < noise_min_s => (
            None,
            Some(format!(
                "{:.1} s of record before the shaking, shorter than the {noise_min_s} s a noise window needs (a triggered record with little or no pre-event memory)",
                k as f64 * dt
            )),
        ),
        Some(k) => {
            // At most the last MAX_SIGNAL_S before the onset: a longer
            // window adds nothing (the lowest frequency the corners look at
            // is 1/30 min) and would size the FFT of hours.
            let noise = k.saturating_sub((MAX_SIGNAL_S / dt) as usize)..k;
            let (rn, rs) = (
                rms_about_mean(&x[noise.clone()]),
                rms_about_mean(&x[signal.clone()]),
            );
            if rn > QUIET_FRACTION * rs {
                (
                    None,
                    Some(format!(
                        "the {:.1} s before the onset are not quiet: their RMS is {:.0} % of the shaking's (at most {:.0} % for a noise window; a record that starts on its P wave)",
                        k as f64 * dt,
                        100.0 * rn / rs,
                        100.0 * QUIET_FRACTION
                    )),
                )
            } else {
                (Some(noise), None)
            }
        }
    };
    Some(Windows {
        onset,
        noise,
        no_noise,
        signal,
    })
}

/// The smoothed spectra of one record.
#[derive(Debug, Clone, PartialEq)]
pub struct FourierSpectra {
    /// Centre frequencies, Hz (10^(k/50), from 1/T_s to the Nyquist frequency).
    pub frequencies_hz: Vec<f64>,
    /// Signal window: Konno–Ohmachi-smoothed |X|·Δt / √T_s, m/s²/√Hz.
    pub signal: Vec<f64>,
    /// Noise window, the same way (None below 1/T_n); empty without a noise window.
    pub noise: Vec<Option<f64>>,
    /// Windows, s from the record's first sample: [start, end).
    pub signal_window_s: [f64; 2],
    pub noise_window_s: Option<[f64; 2]>,
    /// Why there is no noise window.
    pub no_noise: Option<String>,
}

impl FourierSpectra {
    /// S/N at each centre frequency; None where the noise is not resolved or
    /// zero, and everywhere without a noise window.
    pub fn snr(&self) -> Vec<Option<f64>> {
        (0..self.frequencies_hz.len())
            .map(|i| match self.noise.get(i).copied().flatten() {
                Some(n) if n > 0.0 => Some(self.signal[i] / n),
                _ => None,
            })
            .collect()
    }
    /// The lowest frequency at which the noise is resolved (1/T_n), Hz.
    pub fn noise_resolved_hz(&self) -> Option<f64> {
        self.noise_window_s.map(|[a, b]| 1.0 / (b - a))
    }
}

/// Centre frequencies 10^(k/`PER_DECADE`) within [lo, hi].
pub fn log_frequencies(lo: f64, hi: f64) -> Vec<f64> {
    if !(lo > 0.0 && hi >= lo && hi.is_finite()) {
        return Vec::new();
    }
    let k0 = (PER_DECADE * lo.log10() - 1e-9).ceil() as i64;
    let k1 = (PER_DECADE * hi.log10() + 1e-9).floor() as i64;
    (k0..=k1)
        .map(|k| 10f64.powf(k as f64 / PER_DECADE))
        .collect()
}

/// Konno–Ohmachi smoothing of `amplitude` given at bins k·`df` (k ≥ 1: the
/// first entry is bin 1) at each centre of `centres`:
/// Σ W(f_k/f_c)·A_k / Σ W(f_k/f_c), the window cut at |b·log₁₀(f/f_c)| = 3π.
pub fn konno_ohmachi(amplitude: &[f64], df: f64, centres: &[f64], b: f64) -> Vec<f64> {
    let reach = 10f64.powf(KO_HALF_WIDTH / b);
    // log₁₀ of every bin's frequency, once (not once per centre and bin).
    let log_f: Vec<f64> = (1..=amplitude.len())
        .map(|k| (k as f64 * df).log10())
        .collect();
    centres
        .iter()
        .map(|&fc| {
            let log_fc = fc.log10();
            let lo = ((fc / reach / df).ceil() as usize).max(1);
            let hi = ((fc * reach / df).floor() as usize).min(amplitude.len());
            let (mut num, mut den) = (0.0, 0.0);
            for k in lo..=hi {
                let x = b * (log_f[k - 1] - log_fc);
                let w = if x.abs() < 1e-12 {
                    1.0
                } else {
                    (x.sin() / x).powi(4)
                };
                num += w * amplitude[k - 1];
                den += w;
            }
            if den > 0.0 {
                num / den
            } else {
                // A centre between bins of a short window: the nearest bin.
                let k = ((fc / df).round() as usize).clamp(1, amplitude.len().max(1));
                amplitude.get(k - 1).copied().unwrap_or(0.0)
            }
        })
        .collect()
}

/// |FFT| · Δt of `part` demeaned and Hann-tapered, zero-padded to `nfft`;
/// bins 1..=nfft/2.
fn amplitude(part: &[f64], dt: f64, nfft: usize) -> Result<Vec<f64>> {
    let n = part.len();
    let mean = part.iter().sum::<f64>() / n as f64;
    let taper = ((WINDOW_TAPER * n as f64) as usize).max(1);
    let fft = RealFftPlanner::<f64>::new().plan_fft_forward(nfft);
    let mut input = fft.make_input_vec();
    for (i, v) in part.iter().enumerate() {
        let edge = i.min(n - 1 - i);
        let w = if edge < taper {
            0.5 - 0.5 * (std::f64::consts::PI * edge as f64 / taper as f64).cos()
        } else {
            1.0
        };
        input[i] = (v - mean) * w;
    }
    let mut out = fft.make_output_vec();
    fft.process(&mut input, &mut out)
        .map_err(|e| Error::numerical(format!("FFT: {e}")))?;
    Ok(out[1..].iter().map(|z| z.norm() * dt).collect())
}

/// The smoothed signal (and noise) spectra of record `x`; `None` when it has
/// no signal window to transform (too short, silent, or longer than
/// [`MAX_SIGNAL_S`]) — the reason in the error text is not needed: the
/// caller says the record keeps the pipeline's corners.
pub fn fourier_spectra(x: &[f64], dt: f64, noise_min_s: f64) -> Result<Option<FourierSpectra>> {
    let Some(w) = windows(x, dt, noise_min_s) else {
        return Ok(None);
    };
    let t_s = w.signal.len() as f64 * dt;
    if t_s > MAX_SIGNAL_S {
        return Ok(None);
    }
    let longest = w.signal.len().max(w.noise.as_ref().map_or(0, |r| r.len()));
    let nfft = longest.next_power_of_two().max(2);
    let df = 1.0 / (nfft as f64 * dt);
    let centres = log_frequencies(1.0 / t_s, 0.5 / dt);
    let signal_raw = amplitude(&x[w.signal.clone()], dt, nfft)?;
    let signal: Vec<f64> = konno_ohmachi(&signal_raw, df, &centres, KONNO_OHMACHI_B)
        .into_iter()
        .map(|a| a / t_s.sqrt())
        .collect();
    let (noise, noise_window_s) = match &w.noise {
        Some(r) => {
            let t_n = r.len() as f64 * dt;
            let raw = amplitude(&x[r.clone()], dt, nfft)?;
            let smooth = konno_ohmachi(&raw, df, &centres, KONNO_OHMACHI_B);
            let resolved = 1.0 / t_n;
            let noise = centres
                .iter()
                .zip(smooth)
                .map(|(&f, a)| (f >= resolved).then(|| a / t_n.sqrt()))
                .collect();
            (noise, Some([r.start as f64 * dt, r.end as f64 * dt]))
        }
        None => (Vec::new(), None),
    };
    Ok(Some(FourierSpectra {
        frequencies_hz: centres,
        signal,
        noise,
        signal_window_s: [w.signal.start as f64 * dt, w.signal.end as f64 * dt],
        noise_window_s,
        no_noise: w.no_noise,
    }))
}

/// The range each corner may take, Hz: `[lowest, highest]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CornerBounds {
    /// The pipeline's high-pass corner and the upper bound of the high-pass.
    pub high_pass: Option<[f64; 2]>,
    /// The lower bound of the low-pass and the pipeline's low-pass corner.
    pub low_pass: Option<[f64; 2]>,
}

/// One chosen corner and why, in words.
#[derive(Debug, Clone, PartialEq)]
pub struct Corner {
    pub hz: f64,
    pub why: String,
}

/// The corners of one record.
#[derive(Debug, Clone, PartialEq)]
pub struct CornerChoice {
    pub high_pass: Option<Corner>,
    pub low_pass: Option<Corner>,
    /// Whether they come from the record's SNR (false: the pipeline's corners).
    pub from_snr: bool,
}

impl CornerChoice {
    /// The pipeline's corners (the lower high-pass and upper low-pass
    /// bounds), each with `why`.
    pub fn stated(bounds: &CornerBounds, why: &str) -> CornerChoice {
        let corner = |hz: f64| Corner {
            hz,
            why: why.to_string(),
        };
        CornerChoice {
            high_pass: bounds.high_pass.map(|[lo, _]| corner(lo)),
            low_pass: bounds.low_pass.map(|[_, hi]| corner(hi)),
            from_snr: false,
        }
    }
}

/// SNR at `f` interpolated linearly in log f and log SNR between centres;
/// `None` outside the centres or where the ratio is not judged; +∞ where the
/// noise is zero (a silent noise window).
fn snr_at(spectra: &FourierSpectra, snr: &[Option<f64>], f: f64) -> Option<f64> {
    let fs = &spectra.frequencies_hz;
    let value = |i: usize| -> Option<f64> {
        match (snr[i], spectra.noise.get(i).copied().flatten()) {
            (Some(s), _) => Some(s),
            (None, Some(n)) if n == 0.0 => Some(f64::INFINITY),
            _ => None,
        }
    };
    let i = fs.partition_point(|&c| c < f);
    if i < fs.len() && (fs[i] - f).abs() <= 1e-12 * f {
        return value(i);
    }
    if i == 0 || i >= fs.len() {
        return None;
    }
    let (a, b) = (value(i - 1)?, value(i)?);
    if !(a.is_finite() && b.is_finite()) || a <= 0.0 || b <= 0.0 {
        return Some(a.min(b));
    }
    let t = (f.ln() - fs[i - 1].ln()) / (fs[i].ln() - fs[i - 1].ln());
    Some((a.ln() + t * (b.ln() - a.ln())).exp())
}

/// The frequency between `a` (SNR ≥ θ) and `b` (SNR < θ) where the ratio
/// crosses θ, interpolated in log f and log SNR.
fn crossing(spectra: &FourierSpectra, snr: &[Option<f64>], a: f64, b: f64, theta: f64) -> f64 {
    match (snr_at(spectra, snr, a), snr_at(spectra, snr, b)) {
        (Some(sa), Some(sb)) if sa.is_finite() && sa > 0.0 && sb > 0.0 && sa > sb => {
            let t = ((sa.ln() - theta.ln()) / (sa.ln() - sb.ln())).clamp(0.0, 1.0);
            (a.ln() + t * (b.ln() - a.ln())).exp()
        }
        _ => b,
    }
}

/// The frequencies walked from `from` towards `to` (either direction): the
/// two ends and every centre strictly between.
fn walk(spectra: &FourierSpectra, from: f64, to: f64) -> Vec<f64> {
    let (lo, hi) = (from.min(to), from.max(to));
    let mut pts: Vec<f64> = std::iter::once(from)
        .chain(
            spectra
                .frequencies_hz
                .iter()
                .copied()
                .filter(|&f| f > lo && f < hi),
        )
        .collect();
    if from > to {
        pts[1..].reverse();
    }
    pts.push(to);
    pts
}

/// A frequency in words: 3 decimals below 1 Hz, 2 to 10 Hz, 1 above.
pub fn hz_text(f: f64) -> String {
    if f >= 10.0 {
        format!("{f:.1} Hz")
    } else if f >= 1.0 {
        format!("{f:.2} Hz")
    } else {
        format!("{f:.3} Hz")
    }
}

/// The high-pass corner within `[lo, hi]` (see the module doc).
fn high_pass(
    spectra: &FourierSpectra,
    snr: &[Option<f64>],
    [lo, hi]: [f64; 2],
    theta: f64,
) -> Corner {
    if hi <= lo {
        return Corner {
            hz: lo,
            why: format!(
                "the pipeline's corner: it is also the highest high-pass allowed ({})",
                hz_text(hi)
            ),
        };
    }
    let resolved = spectra.noise_resolved_hz().unwrap_or(f64::INFINITY);
    match snr_at(spectra, snr, hi) {
        Some(s) if s < theta => {
            return Corner {
                hz: hi,
                why: format!(
                    "the highest high-pass allowed: the signal-to-noise ratio is {s:.1} there, below {theta}"
                ),
            }
        }
        None => {
            return Corner {
                hz: lo,
                why: format!(
                    "the pipeline's corner: the noise window resolves frequencies above {} only",
                    hz_text(resolved.min(1e9))
                ),
            }
        }
        Some(_) => {}
    }
    let pts = walk(spectra, hi, lo);
    for pair in pts.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        match snr_at(spectra, snr, b) {
            Some(s) if s < theta => {
                let f = crossing(spectra, snr, a, b, theta).clamp(lo, hi);
                return Corner {
                    hz: f,
                    why: format!("where the signal-to-noise ratio rises above {theta}"),
                };
            }
            Some(_) => {}
            None => {
                return Corner {
                    hz: lo,
                    why: format!(
                        "the pipeline's corner: the signal-to-noise ratio is at least {theta} down to {}, the lowest frequency the windows resolve",
                        hz_text(a)
                    ),
                }
            }
        }
    }
    Corner {
        hz: lo,
        why: format!(
            "the pipeline's corner: the signal-to-noise ratio is at least {theta} down to it"
        ),
    }
}

/// The low-pass corner within `[lo, hi]` (see the module doc).
fn low_pass(
    spectra: &FourierSpectra,
    snr: &[Option<f64>],
    [lo, hi]: [f64; 2],
    theta: f64,
) -> Corner {
    if hi <= lo {
        return Corner {
            hz: hi,
            why: format!(
                "the pipeline's corner: it is also the lowest low-pass allowed ({})",
                hz_text(lo)
            ),
        };
    }
    match snr_at(spectra, snr, lo) {
        Some(s) if s < theta => {
            return Corner {
                hz: lo,
                why: format!(
                    "the lowest low-pass allowed: the signal-to-noise ratio is {s:.1} there, below {theta}"
                ),
            }
        }
        None => {
            return Corner {
                hz: hi,
                why: "the pipeline's corner: the signal-to-noise ratio is not known there".into(),
            }
        }
        Some(_) => {}
    }
    let pts = walk(spectra, lo, hi);
    for pair in pts.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        match snr_at(spectra, snr, b) {
            Some(s) if s < theta => {
                let f = crossing(spectra, snr, a, b, theta).clamp(lo, hi);
                return Corner {
                    hz: f,
                    why: format!("where the signal-to-noise ratio falls below {theta}"),
                };
            }
            Some(_) => {}
            None => break,
        }
    }
    Corner {
        hz: hi,
        why: format!(
            "the pipeline's corner: the signal-to-noise ratio is at least {theta} up to it"
        ),
    }
}

/// The corners of a record from its spectra (see the module doc); the
/// pipeline's corners when it has no noise window.
pub fn choose_corners(
    spectra: &FourierSpectra,
    bounds: &CornerBounds,
    snr_min: f64,
) -> CornerChoice {
    if spectra.noise_window_s.is_none() {
        let why = match &spectra.no_noise {
            Some(w) => format!("the pipeline's corner: no noise window ({w})"),
            None => "the pipeline's corner: no noise window".into(),
        };
        return CornerChoice::stated(bounds, &why);
    }
    let snr = spectra.snr();
    CornerChoice {
        high_pass: bounds
            .high_pass
            .map(|b| high_pass(spectra, &snr, b, snr_min)),
        low_pass: bounds.low_pass.map(|b| low_pass(spectra, &snr, b, snr_min)),
        from_snr: true,
    }
}

/// The corners applied to a group of an event's records (its horizontal or
/// its vertical ones), from each record's own choice (`own`, with its
/// channel id), in the same order.
///
/// Records combined by later stages — inter-storey drift subtracts two
/// levels' displacements, modal identification fits one model to every
/// channel — must be filtered alike: a base record high-passed at 0.1 Hz and
/// a roof record at 0.3 Hz would leave the ground's 0.1–0.3 Hz displacement,
/// common to both, in their difference.  So, as gmprocess makes the two
/// horizontal components of a station share their corners (`same_horiz`):
/// the highest high-pass and the lowest low-pass of the records that have a
/// noise window, applied to all of them — every record's ratio is then at
/// least θ inside the pass band.  When half or more of the group has no noise
/// window, the event's recorders are taken to start on the shaking (a film
/// recorder triggers on the P wave; a lone "noise window" among them holds it)
/// and the whole group keeps the pipeline's corners.
pub fn common_corners(
    own: &[(&str, &CornerChoice)],
    bounds: &CornerBounds,
    group: &str,
) -> Vec<CornerChoice> {
    let n = own.len();
    let with_noise: Vec<&(&str, &CornerChoice)> = own.iter().filter(|(_, c)| c.from_snr).collect();
    let k = with_noise.len();
    if n <= 1 || k == 0 {
        return own.iter().map(|(_, c)| (*c).clone()).collect();
    }
    if 2 * k <= n {
        let why = format!(
            "the pipeline's corner: only {k} of the event's {n} {group} records have a quiet pre-event, so its recorders are taken to start on the shaking (such a window may hold the P wave)"
        );
        return vec![CornerChoice::stated(bounds, &why); n];
    }
    let alike = format!("applied to all {n} {group} records so that they are filtered alike");
    let pick = |corner: fn(&CornerChoice) -> Option<&Corner>, highest: bool| -> Option<Corner> {
        let (id, c) = with_noise
            .iter()
            .filter_map(|(id, c)| corner(c).map(|c| (*id, c)))
            .reduce(|a, b| {
                let better = if highest {
                    b.1.hz > a.1.hz
                } else {
                    b.1.hz < a.1.hz
                };
                if better {
                    b
                } else {
                    a
                }
            })?;
        let all_same = with_noise
            .iter()
            .filter_map(|(_, c)| corner(c))
            .all(|x| x.hz == c.hz);
        let why = if all_same {
            format!(
                "{} on each of the {k} {group} records with a noise window; {alike}",
                c.why
            )
        } else {
            format!(
                "{} on {id}, the {} of the {k} {group} records with a noise window; {alike}",
                c.why,
                if highest { "highest" } else { "lowest" }
            )
        };
        Some(Corner { hz: c.hz, why })
    };
    let common = CornerChoice {
        high_pass: pick(|c| c.high_pass.as_ref(), true),
        low_pass: pick(|c| c.low_pass.as_ref(), false),
        from_snr: true,
    };
    vec![common; n]
}
