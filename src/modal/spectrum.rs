//! Data plotted beside the stabilisation diagram: singular values of the
//! output cross-power spectral density matrix at each frequency (as in
//! frequency-domain decomposition).  The PSD matrix is estimated by Welch's
//! method (Hann window, 50 % overlap, one-sided); being Hermitian positive
//! semi-definite, its singular values are its eigenvalues.

use crate::error::{Error, Result};
use faer::{c64, Mat, Side};
use realfft::RealFftPlanner;

/// Singular values of the PSD matrix per frequency bin.
#[derive(Debug, Clone, PartialEq)]
pub struct SpectralOverlay {
    pub frequencies_hz: Vec<f64>,
    /// `singular_values[k][i]`: i-th largest singular value at bin k, (units)²/Hz.
    pub singular_values: Vec<Vec<f64>>,
    pub segment_length: usize,
}

/// Welch PSD-matrix singular values of `outputs` (equal lengths) with
/// segments of `segment_length` samples (rounded down to even, at least 16).
pub fn spectral_overlay(
    outputs: &[Vec<f64>],
    dt: f64,
    segment_length: usize,
) -> Result<SpectralOverlay> {
    let l = outputs.len();
    let n = outputs.iter().map(|s| s.len()).min().unwrap_or(0);
    let seg = (segment_length / 2 * 2).max(16);
    if l == 0 || n < seg {
        return Err(Error::numerical(format!(
            "spectral overlay: need channels of at least {seg} samples"
        )));
    }
    let bins = seg / 2 + 1;
    let mut psd = vec![c64::new(0.0, 0.0); bins * l * l];
    let (segments, window_power) = welch_segments(outputs, seg, |spectra| {
        for k in 0..bins {
            for a in 0..l {
                for b in 0..l {
                    psd[(k * l + a) * l + b] += spectra[a][k] * spectra[b][k].conj();
                }
            }
        }
    })?;
    // One-sided density scaling: 2 Δt / (Σw² · segments), except DC and Nyquist.
    let mut singular_values = Vec::with_capacity(bins);
    for k in 0..bins {
        let factor =
            if k == 0 || k == bins - 1 { 1.0 } else { 2.0 } * dt / (window_power * segments as f64);
        let m = Mat::<c64>::from_fn(l, l, |a, b| psd[(k * l + a) * l + b] * factor);
        let mut ev = m
            .self_adjoint_eigenvalues(Side::Lower)
            .map_err(|e| Error::numerical(format!("PSD matrix eigenvalues: {e:?}")))?;
        ev.reverse();
        singular_values.push(ev.into_iter().map(|v| v.max(0.0)).collect());
    }
    let frequencies_hz = (0..bins).map(|k| k as f64 / (seg as f64 * dt)).collect();
    Ok(SpectralOverlay {
        frequencies_hz,
        singular_values,
        segment_length: seg,
    })
}

/// Welch's segments (Hann window, 50 % overlap, each segment's mean
/// removed) of equal-length `outputs`: `each` receives the FFT of every
/// channel of one segment (`seg / 2 + 1` bins per channel).  Returns the
/// number of segments and the window's power Σw² (the density scaling).
fn welch_segments(
    outputs: &[Vec<f64>],
    seg: usize,
    mut each: impl FnMut(&[Vec<c64>]),
) -> Result<(usize, f64)> {
    let n = outputs.iter().map(|s| s.len()).min().unwrap_or(0);
    let window: Vec<f64> = (0..seg)
        .map(|i| 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / seg as f64).cos())
        .collect();
    let window_power: f64 = window.iter().map(|w| w * w).sum();
    let mut planner = RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(seg);
    let bins = seg / 2 + 1;
    let hop = seg / 2;
    let segments = (n - seg) / hop + 1;
    let mut spectra = vec![vec![c64::new(0.0, 0.0); bins]; outputs.len()];
    let mut buffer = fft.make_input_vec();
    let mut out = fft.make_output_vec();
    for s in 0..segments {
        let start = s * hop;
        for (c, signal) in outputs.iter().enumerate() {
            let part = &signal[start..start + seg];
            let mean = part.iter().sum::<f64>() / seg as f64;
            for i in 0..seg {
                buffer[i] = (part[i] - mean) * window[i];
            }
            fft.process(&mut buffer, &mut out)
                .map_err(|e| Error::numerical(format!("FFT: {e}")))?;
            for (k, z) in out.iter().enumerate() {
                spectra[c][k] = c64::new(z.re, z.im);
            }
        }
        each(&spectra);
    }
    Ok((segments, window_power))
}

/// Frequency of the lowest clear peak of the summed output auto-spectra
/// (the trace of the Welch PSD matrix, segments of `seg` samples) inside
/// `band_hz`: the lowest local maximum (over ±2 bins) that reaches
/// `PEAK_FRACTION` of the band's largest value.  `None` when the record is
/// shorter than two segments or nothing in the band is a peak.  Used by the
/// modal plan to give the block rows a horizon of half a period of the
/// lowest mode the record shows (issue 13).
pub fn lowest_spectral_peak_hz(
    outputs: &[Vec<f64>],
    dt: f64,
    seg: usize,
    band_hz: [f64; 2],
) -> Option<f64> {
    /// A peak counts when it reaches this fraction of the band's maximum.
    const PEAK_FRACTION: f64 = 0.1;
    let seg = (seg / 2 * 2).max(16);
    let n = outputs.iter().map(|s| s.len()).min().unwrap_or(0);
    if outputs.is_empty() || n < 2 * seg {
        return None;
    }
    let bins = seg / 2 + 1;
    let mut trace = vec![0.0f64; bins];
    welch_segments(outputs, seg, |spectra| {
        for channel in spectra {
            for (t, z) in trace.iter_mut().zip(channel) {
                *t += z.norm_sqr();
            }
        }
    })
    .ok()?;
    let df = 1.0 / (seg as f64 * dt);
    let lo = ((band_hz[0] / df).ceil() as usize).max(2);
    let hi = ((band_hz[1] / df).floor() as usize).min(bins - 3);
    if lo > hi {
        return None;
    }
    let top = trace[lo..=hi].iter().cloned().fold(0.0f64, f64::max);
    if !(top > 0.0 && top.is_finite()) {
        return None;
    }
    (lo..=hi)
        .find(|&k| {
            trace[k] >= PEAK_FRACTION * top && (k - 2..=k + 2).all(|j| trace[j] <= trace[k])
        })
        .map(|k| k as f64 * df)
}
