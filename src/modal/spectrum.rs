//! Data plotted beside the stabilisation diagram: singular values of the
//! output cross-power spectral density matrix at each frequency (as in
//! frequency-domain decomposition).  The PSD matrix is estimated by Welch's
//! method (Hann window, 50 % overlap, one-sided); being Hermitian positive
//! semi-definite, its singular values are its eigenvalues.

use crate::error::{Error, Result};
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::{c64, Accum, Mat, MatMut, Par, Side};
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
/// The segments' spectra are computed channel by channel and the PSD
/// matrices accumulated bin by bin, in parallel over channels and bins (each
/// sum in the same order: the result does not depend on the threads).
pub fn spectral_overlay<S: AsRef<[f64]> + Sync>(
    outputs: &[S],
    dt: f64,
    segment_length: usize,
) -> Result<SpectralOverlay> {
    use rayon::prelude::*;
    let outputs: Vec<&[f64]> = outputs.iter().map(|s| s.as_ref()).collect();
    let l = outputs.len();
    let n = outputs.iter().map(|s| s.len()).min().unwrap_or(0);
    let seg = (segment_length / 2 * 2).max(16);
    if l == 0 || n < seg {
        return Err(Error::numerical(format!(
            "spectral overlay: need channels of at least {seg} samples"
        )));
    }
    let window: Vec<f64> = (0..seg)
        .map(|i| 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / seg as f64).cos())
        .collect();
    let window_power: f64 = window.iter().map(|w| w * w).sum();
    let mut planner = RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(seg);
    let bins = seg / 2 + 1;
    let hop = seg / 2;
    let segments = (n - seg) / hop + 1;
    // Segments go in blocks, so that the spectra held are a block's.
    const BLOCK: usize = 64;
    let mut psd = vec![c64::new(0.0, 0.0); bins * l * l];
    for block in (0..segments).step_by(BLOCK) {
        let count = BLOCK.min(segments - block);
        // spectra[c][s * bins + k]: channel c, segment block + s, bin k.
        let spectra: Vec<Vec<c64>> = outputs
            .par_iter()
            .map(|signal| {
                let mut buffer = fft.make_input_vec();
                let mut out = fft.make_output_vec();
                let mut spec = Vec::with_capacity(count * bins);
                for s in block..block + count {
                    let part = &signal[s * hop..s * hop + seg];
                    let mean = part.iter().sum::<f64>() / seg as f64;
                    for i in 0..seg {
                        buffer[i] = (part[i] - mean) * window[i];
                    }
                    fft.process(&mut buffer, &mut out)
                        .map_err(|e| Error::numerical(format!("FFT: {e}")))?;
                    spec.extend(out.iter().map(|z| c64::new(z.re, z.im)));
                }
                Ok(spec)
            })
            .collect::<Result<_>>()?;
        // Each bin's matrix gains X Xᴴ, X the block's spectra at that bin
        // (channels × segments): one lower-triangular matrix product per bin
        // (faer's kernels, sequential inside a bin, so the sums do not depend
        // on the threads) instead of a running sum per entry, whose chain of
        // dependent additions set the pace (the overlay took most of the
        // modal stage of a 64-channel hour).  The upper triangle is never
        // formed: it is the conjugate of the lower one.
        psd.par_chunks_mut(l * l).enumerate().for_each_init(
            || Mat::<c64>::zeros(l, BLOCK),
            |x, (k, m)| {
                for s in 0..count {
                    for (a, spectrum) in spectra.iter().enumerate() {
                        x[(a, s)] = spectrum[s * bins + k];
                    }
                }
                let block_spectra = x.as_ref().subcols(0, count);
                triangular::matmul(
                    MatMut::from_column_major_slice_mut(m, l, l),
                    BlockStructure::TriangularLower,
                    Accum::Add,
                    block_spectra,
                    BlockStructure::Rectangular,
                    block_spectra.adjoint(),
                    BlockStructure::Rectangular,
                    c64::new(1.0, 0.0),
                    Par::Seq,
                );
            },
        );
    }
    // One-sided density scaling: 2 Δt / (Σw² · segments), except DC and Nyquist.
    let singular_values: Vec<Vec<f64>> = psd
        .par_chunks(l * l)
        .enumerate()
        .map(|(k, m)| {
            let factor = if k == 0 || k == bins - 1 { 1.0 } else { 2.0 } * dt
                / (window_power * segments as f64);
            // Column-major, lower triangle (a ≥ b) summed.
            let entry = |a: usize, b: usize| {
                if b <= a {
                    m[a + b * l]
                } else {
                    m[b + a * l].conj()
                }
            };
            let mat = Mat::<c64>::from_fn(l, l, |a, b| entry(a, b) * factor);
            let mut ev = mat
                .self_adjoint_eigenvalues(Side::Lower)
                .map_err(|e| Error::numerical(format!("PSD matrix eigenvalues: {e:?}")))?;
            ev.reverse();
            Ok(ev.into_iter().map(|v| v.max(0.0)).collect())
        })
        .collect::<Result<_>>()?;
    let frequencies_hz = (0..bins).map(|k| k as f64 / (seg as f64 * dt)).collect();
    Ok(SpectralOverlay {
        frequencies_hz,
        singular_values,
        segment_length: seg,
    })
}

/// Frequency of the lowest clear peak of the summed output auto-spectra
/// (the trace of the Welch PSD matrix of [`spectral_overlay`], segments of
/// `seg` samples) inside
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
    // The trace of the PSD matrix is the sum of its eigenvalues.
    let overlay = spectral_overlay(outputs, dt, seg).ok()?;
    let trace: Vec<f64> = overlay
        .singular_values
        .iter()
        .map(|sv| sv.iter().sum())
        .collect();
    let bins = trace.len();
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
        .find(|&k| trace[k] >= PEAK_FRACTION * top && (k - 2..=k + 2).all(|j| trace[j] <= trace[k]))
        .map(|k| k as f64 * df)
}

/// Structural amplification of `output` over `inputs` around
/// `frequency_hz`: √(Σ S_yy / mean_i Σ S_uiui), the auto-spectra (Welch,
/// segments of `seg` samples, [`spectral_overlay`] of one channel) summed
/// over the bins within ±`relative_band` of the frequency (at least the
/// nearest bin).  A resonance of the structure makes the response larger
/// than the ground motion that drives it (a lightly damped mode by ≈ 1/2ζ);
/// a peak the ground motion brings (site, source, digitisation noise) shows
/// in both and gives ≈ 1.  `None` when a record is shorter than a segment.
pub fn structural_amplification(
    output: &[f64],
    inputs: &[&[f64]],
    dt: f64,
    seg: usize,
    frequency_hz: f64,
    relative_band: f64,
) -> Option<f64> {
    if inputs.is_empty() {
        return None;
    }
    let band_power = |signal: &[f64]| -> Option<f64> {
        let overlay = spectral_overlay(&[signal], dt, seg).ok()?;
        let f = &overlay.frequencies_hz;
        let (lo, hi) = (
            frequency_hz * (1.0 - relative_band),
            frequency_hz * (1.0 + relative_band),
        );
        let nearest = (0..f.len()).min_by(|&a, &b| {
            (f[a] - frequency_hz)
                .abs()
                .total_cmp(&(f[b] - frequency_hz).abs())
        })?;
        let sum: f64 = (0..f.len())
            .filter(|&k| (lo..=hi).contains(&f[k]) || k == nearest)
            .map(|k| overlay.singular_values[k][0])
            .sum();
        Some(sum)
    };
    let response = band_power(output)?;
    let ground: Vec<f64> = inputs
        .iter()
        .map(|u| band_power(u))
        .collect::<Option<_>>()?;
    let ground = ground.iter().sum::<f64>() / ground.len() as f64;
    (ground > 0.0).then(|| (response / ground).sqrt())
}
