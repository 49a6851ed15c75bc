//! Short-time Fourier transform layout and the time–frequency integrated
//! products of Eq. 15 and Eq. 20 of METHODS.md §4.
//!
//! Conventions (stated once, used everywhere):
//! - symmetric Hamming window w[m] = 0.54 − 0.46 cos(2πm/(L−1)), m = 0..L−1;
//! - hop L/2 (50 % overlap), L even; frame j starts at s_j = j·L/2;
//! - L is the even length for which the number of full frames
//!   ⌊(n − L)/(L/2)⌋ + 1 is closest to the number of one-sided bins L/2 + 1
//!   (ties → shorter window; gives L = 220 for n = 12 500 as in the thesis);
//!   one extra zero-padded frame is appended when the last full frame leaves
//!   samples uncovered, so that every sample contributes;
//! - X_j[k] = Σ_m w[m] x[s_j + m] e^{−2πikm/L} (x = 0 past the end);
//! - Eq. 20: 2∫₀^{fs/2} Q df is the trapezoid rule on the bins (Δf = fs/L,
//!   DC and Nyquist with half weight); ∫₀ᵗ dτ is the rectangle rule over
//!   frames with spacing hop/fs. One frame then contributes
//!   G_j[i][k] = (hop/fs)·Δf·Σ_k c_k Re(X_i X_k*) with c = 1 at DC/Nyquist, 2
//!   elsewhere.
//!
//! Parseval: over the full band Σ_k c_k Re(X_i X_k*) = L Σ_m w[m]² x_i x_k, so
//! G_j[i][k] = hop · Σ_m w[m]² x_i[s_j+m] x_k[s_j+m] exactly: a window-weighted
//! time-domain sum. A band [f_low, fs/2] keeps Parseval on the remaining bins:
//! the excluded low bins are projected out of the windowed frame (their
//! cos/sin vectors are orthogonal), at O(L) per excluded bin. That is the
//! default path (`Transform::Parseval`). The explicit FFT path
//! (`Transform::Fft`) handles any band and is used to test the equivalence.
//!
//! Both paths produce, per signal and frame, a real vector ("frame
//! representation") whose dot products are the G_j entries; stacked over the
//! frames they are the rows of an equivalent least-squares design matrix.

use crate::error::{Error, Result};
use realfft::RealFftPlanner;

/// Symmetric Hamming window of length `len` (MATLAB `hamming(len)`).
pub fn hamming_symmetric(len: usize) -> Vec<f64> {
    if len == 1 {
        return vec![1.0];
    }
    (0..len)
        .map(|m| 0.54 - 0.46 * (2.0 * std::f64::consts::PI * m as f64 / (len - 1) as f64).cos())
        .collect()
}

/// Frame layout of the STFT of an n-sample record.
#[derive(Debug, Clone, PartialEq)]
pub struct StftLayout {
    pub n_samples: usize,
    pub window_len: usize,
    pub hop: usize,
    /// Start sample of every frame (the last may run past the end: zero padding).
    pub frame_starts: Vec<usize>,
    pub window: Vec<f64>,
}

/// Frequency band of the integral over f in Eq. 20 (Hz); bins whose centre
/// frequency lies in [low_hz, high_hz] are integrated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrequencyBand {
    pub low_hz: f64,
    pub high_hz: f64,
}

impl FrequencyBand {
    /// The thesis's [0, fs/2].
    pub fn full() -> Self {
        FrequencyBand {
            low_hz: 0.0,
            high_hz: f64::INFINITY,
        }
    }
    /// [low_hz, fs/2].
    pub fn above(low_hz: f64) -> Self {
        FrequencyBand {
            low_hz,
            high_hz: f64::INFINITY,
        }
    }
    fn contains(&self, f: f64, df: f64) -> bool {
        f >= self.low_hz - 1e-9 * df && f <= self.high_hz + 1e-9 * df
    }
}

impl Default for FrequencyBand {
    fn default() -> Self {
        Self::full()
    }
}

impl StftLayout {
    /// Window length chosen so that frames ≈ bins (see module doc).
    pub fn for_record(n_samples: usize) -> Result<Self> {
        if n_samples < 8 {
            return Err(Error::usage(format!(
                "STFT needs at least 8 samples, got {n_samples}"
            )));
        }
        let full_frames = |len: usize| (n_samples - len) / (len / 2) + 1;
        let mut best = (usize::MAX, 4usize);
        let mut len = 4;
        while len <= n_samples {
            let frames = full_frames(len);
            let bins = len / 2 + 1;
            let diff = frames.abs_diff(bins);
            if diff < best.0 {
                best = (diff, len);
            }
            if bins > frames + 2 {
                break;
            }
            len += 2;
        }
        Self::with_window(n_samples, best.1)
    }

    /// Layout with a given even window length.
    pub fn with_window(n_samples: usize, window_len: usize) -> Result<Self> {
        if window_len < 4 || !window_len.is_multiple_of(2) || window_len > n_samples {
            return Err(Error::usage(format!(
                "STFT window length must be even, ≥ 4 and ≤ the record length ({n_samples}); got {window_len}"
            )));
        }
        let hop = window_len / 2;
        let full = (n_samples - window_len) / hop + 1;
        let mut frame_starts: Vec<usize> = (0..full).map(|j| j * hop).collect();
        if (full - 1) * hop + window_len < n_samples {
            frame_starts.push(full * hop);
        }
        Ok(StftLayout {
            n_samples,
            window_len,
            hop,
            frame_starts,
            window: hamming_symmetric(window_len),
        })
    }

    pub fn frames(&self) -> usize {
        self.frame_starts.len()
    }

    /// Time of frame j's centre, s.
    pub fn frame_time(&self, j: usize, sampling_rate_hz: f64) -> f64 {
        (self.frame_starts[j] as f64 + 0.5 * (self.window_len - 1) as f64) / sampling_rate_hz
    }

    /// Parseval weights of the whole record: W[n] = hop · Σ_j w[n − s_j]², so
    /// that Σ_j G_j[i][k] = Σ_n W[n] x_i[n] x_k[n] (scalar estimate, t = te).
    pub fn time_weights(&self) -> Vec<f64> {
        let mut weights = vec![0.0; self.n_samples];
        for &start in &self.frame_starts {
            for (m, w) in self.window.iter().enumerate() {
                if let Some(slot) = weights.get_mut(start + m) {
                    *slot += self.hop as f64 * w * w;
                }
            }
        }
        weights
    }
}

/// How the frame products of Eq. 15/20 are evaluated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Transform {
    /// Window-weighted time-domain frames (Parseval); bands must reach fs/2.
    #[default]
    Parseval,
    /// Explicit FFT of every frame (any band).
    Fft,
}

/// Frame representations of a signal: `frames × width` values such that the
/// dot product of two signals' frame-j rows is G_j (Eq. 15 integrated over the
/// band, times the frame's share hop/fs of the time integral).
#[derive(Debug, Clone, PartialEq)]
pub struct FrameRepresentation {
    pub width: usize,
    pub values: Vec<f64>,
}

impl FrameRepresentation {
    pub fn frame(&self, j: usize) -> &[f64] {
        &self.values[j * self.width..(j + 1) * self.width]
    }
}

/// Builds frame representations for one layout, transform and band.
pub struct FrameTransformer {
    layout: StftLayout,
    transform: Transform,
    /// Time domain: excluded bins (projected out). FFT: included bins and weights.
    excluded_bins: Vec<usize>,
    included: Vec<(usize, f64)>,
    cos_sin: Vec<(Vec<f64>, Vec<f64>)>,
    fft: std::sync::Arc<dyn realfft::RealToComplex<f64>>,
}

impl FrameTransformer {
    pub fn new(
        layout: &StftLayout,
        transform: Transform,
        band: FrequencyBand,
        sampling_rate_hz: f64,
    ) -> Result<Self> {
        let len = layout.window_len;
        let bins = len / 2 + 1;
        let df = sampling_rate_hz / len as f64;
        let nyquist = sampling_rate_hz / 2.0;
        if !(band.low_hz >= 0.0) || band.high_hz <= band.low_hz {
            return Err(Error::usage(format!(
                "frequency band [{}, {}] Hz is empty",
                band.low_hz, band.high_hz
            )));
        }
        let included: Vec<(usize, f64)> = (0..bins)
            .filter(|&b| band.contains(b as f64 * df, df))
            .map(|b| {
                (
                    b,
                    if b == 0 || (len.is_multiple_of(2) && b == bins - 1) {
                        1.0
                    } else {
                        2.0
                    },
                )
            })
            .collect();
        if included.is_empty() {
            return Err(Error::usage(format!(
                "frequency band [{}, {}] Hz contains no STFT bin (Δf = {df:.3} Hz)",
                band.low_hz, band.high_hz
            )));
        }
        let excluded_bins: Vec<usize> = (0..bins)
            .filter(|&b| !band.contains(b as f64 * df, df))
            .collect();
        if transform == Transform::Parseval
            && excluded_bins.iter().any(|&b| b as f64 * df > band.low_hz)
        {
            return Err(Error::usage(format!(
                "the Parseval path integrates up to fs/2 = {nyquist} Hz; a band ending at {} Hz needs Transform::Fft",
                band.high_hz
            )));
        }
        let cos_sin = excluded_bins
            .iter()
            .map(|&b| {
                let arg = |m: usize| 2.0 * std::f64::consts::PI * (b * m) as f64 / len as f64;
                (
                    (0..len).map(|m| arg(m).cos()).collect(),
                    (0..len).map(|m| arg(m).sin()).collect(),
                )
            })
            .collect();
        let fft = RealFftPlanner::<f64>::new().plan_fft_forward(len);
        Ok(FrameTransformer {
            layout: layout.clone(),
            transform,
            excluded_bins,
            included,
            cos_sin,
            fft,
        })
    }

    pub fn layout(&self) -> &StftLayout {
        &self.layout
    }

    /// Frame representation of `signal` (zero past its end).
    pub fn represent(&self, signal: &[f64]) -> FrameRepresentation {
        let layout = &self.layout;
        let len = layout.window_len;
        let frames = layout.frames();
        let root_hop = (layout.hop as f64).sqrt();
        match self.transform {
            Transform::Parseval => {
                let mut values = vec![0.0; frames * len];
                for (j, &start) in layout.frame_starts.iter().enumerate() {
                    let row = &mut values[j * len..(j + 1) * len];
                    for m in 0..len {
                        row[m] = layout.window[m] * signal.get(start + m).copied().unwrap_or(0.0);
                    }
                    // Project out the excluded bins (orthogonal cos/sin vectors;
                    // DC has norm² L, others L/2; Nyquist cos has norm² L).
                    for (&b, (cos, sin)) in self.excluded_bins.iter().zip(&self.cos_sin) {
                        let edge = b == 0 || 2 * b == len;
                        let norm2 = if edge { len as f64 } else { 0.5 * len as f64 };
                        let c: f64 = row.iter().zip(cos).map(|(y, c)| y * c).sum::<f64>() / norm2;
                        let s: f64 = if edge {
                            0.0
                        } else {
                            row.iter().zip(sin).map(|(y, s)| y * s).sum::<f64>() / norm2
                        };
                        for m in 0..len {
                            row[m] -= c * cos[m] + s * sin[m];
                        }
                    }
                    row.iter_mut().for_each(|y| *y *= root_hop);
                }
                FrameRepresentation { width: len, values }
            }
            Transform::Fft => {
                let width = 2 * self.included.len();
                let mut values = vec![0.0; frames * width];
                let mut buffer = vec![0.0; len];
                let mut spectrum = self.fft.make_output_vec();
                // (hop/fs)·Δf·c_b = hop·c_b/L.
                let scale: Vec<f64> = self
                    .included
                    .iter()
                    .map(|(_, c)| (layout.hop as f64 * c / len as f64).sqrt())
                    .collect();
                for (j, &start) in layout.frame_starts.iter().enumerate() {
                    for m in 0..len {
                        buffer[m] =
                            layout.window[m] * signal.get(start + m).copied().unwrap_or(0.0);
                    }
                    // Buffer lengths match the plan, so processing cannot fail.
                    let _ = self.fft.process(&mut buffer, &mut spectrum);
                    let row = &mut values[j * width..(j + 1) * width];
                    for (i, (b, _)) in self.included.iter().enumerate() {
                        // Q_ik = Re X_i Re X_k + Im X_i Im X_k (Eq. 15).
                        row[2 * i] = scale[i] * spectrum[*b].re;
                        row[2 * i + 1] = scale[i] * spectrum[*b].im;
                    }
                }
                FrameRepresentation { width, values }
            }
        }
    }
}

/// Per-frame products G_j[i][k] between every `left` and every `right`
/// representation (the frame terms of Q_ik, Eq. 15), all of one width. Output layout:
/// `out[(j * left.len() + i) * right.len() + k]`.
///
/// Each G_j[i][k] is the sum over the frame's values in their order, exactly as a dot
/// product adds them; one `left` row is accumulated against [`PRODUCT_LANES`] `right` rows
/// (fewer in a last block) side by side, so their additions overlap instead of each waiting for the one before (a
/// dot product at a time was bound by the latency of its additions: the hysteresis stage's
/// largest cost, issue 18). Same operations in the same order: the same bits.
pub fn frame_products(
    left: &[&FrameRepresentation],
    right: &[&FrameRepresentation],
    frames: usize,
) -> Vec<f64> {
    let (nl, nr) = (left.len(), right.len());
    let width = left.first().or(right.first()).map_or(0, |r| r.width);
    assert!(
        left.iter().chain(right).all(|r| r.width == width),
        "frame_products: representations of different widths"
    );
    let mut out = vec![0.0; frames * nl * nr];
    for j in 0..frames {
        for (i, l) in left.iter().enumerate() {
            let a = l.frame(j);
            let sums = &mut out[(j * nl + i) * nr..(j * nl + i + 1) * nr];
            for (block, rows) in sums
                .chunks_mut(PRODUCT_LANES)
                .zip(right.chunks(PRODUCT_LANES))
            {
                // A last block of fewer rows fills its lanes with its first row and keeps
                // only its own sums (a lane costs little beside the chain of additions).
                let lanes: [&[f64]; PRODUCT_LANES] =
                    std::array::from_fn(|q| rows.get(q).unwrap_or(&rows[0]).frame(j));
                let sums = dot_lanes(a, lanes);
                block.copy_from_slice(&sums[..block.len()]);
            }
        }
    }
    out
}

/// Right-hand rows accumulated together by [`frame_products`].
pub const PRODUCT_LANES: usize = 8;

/// The dot products of `a` with each of `rows` (all of `a`'s length), each summed in order
/// from −0.0 as `Iterator::sum` does.
fn dot_lanes(a: &[f64], rows: [&[f64]; PRODUCT_LANES]) -> [f64; PRODUCT_LANES] {
    let n = a.len();
    let rows = rows.map(|r| &r[..n]);
    let mut s = [-0.0f64; PRODUCT_LANES];
    for m in 0..n {
        let x = a[m];
        for (s, r) in s.iter_mut().zip(&rows) {
            *s += x * r[m];
        }
    }
    s
}
