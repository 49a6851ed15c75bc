//! Second-order-section filtering: causal `sosfilt` (transposed direct
//! form II), its steady-state initial conditions `sosfilt_zi`, and the
//! zero-phase forward–backward `sosfiltfilt` with scipy's edge handling
//! (METHODS §1: band-pass applied zero-phase "as scipy's sosfiltfilt").
//!
//! Hand-written because no crate offers scipy-identical zero-phase SOS
//! filtering; the kernel keeps the section states in registers
//! (const-generic section count) and cascades all sections sample by
//! sample in a single pass per direction.

use rayon::prelude::*;

use super::butterworth::Section;
use crate::error::{Error, Result};

fn validate_sections(sos: &[Section]) -> Result<()> {
    if sos.is_empty() {
        return Err(Error::usage("filter has no second-order sections"));
    }
    for (i, s) in sos.iter().enumerate() {
        if s.iter().any(|c| !c.is_finite()) {
            return Err(Error::usage(format!(
                "second-order section {i} has a non-finite coefficient"
            )));
        }
        if s[3] != 1.0 {
            return Err(Error::usage(format!(
                "second-order section {i} must have a0 = 1, got {}",
                s[3]
            )));
        }
    }
    Ok(())
}

/// Initial conditions of each section for a unit step's steady state
/// (scipy `sosfilt_zi`): per section solve zi = A·zi + B (scipy
/// `lfilter_zi`, closed form for a 2×2 companion system) and scale by the
/// DC gain of the sections before it.
pub fn sosfilt_zi(sos: &[Section]) -> Result<Vec<[f64; 2]>> {
    validate_sections(sos)?;
    let mut zi = Vec::with_capacity(sos.len());
    let mut scale = 1.0;
    for (i, s) in sos.iter().enumerate() {
        let (b0, b1, b2, a1, a2) = (s[0], s[1], s[2], s[4], s[5]);
        let denominator = 1.0 + a1 + a2;
        if denominator == 0.0 {
            return Err(Error::numerical(format!(
                "section {i} has a pole at z = 1: no steady state"
            )));
        }
        // (I − Aᵀ_companion) zi = B, with B = [b1 − a1 b0, b2 − a2 b0]:
        // (1 + a1) z0 − z1 = B0,  a2 z0 + z1 = B1.
        let rhs0 = b1 - a1 * b0;
        let rhs1 = b2 - a2 * b0;
        let z0 = (rhs0 + rhs1) / denominator;
        let z1 = rhs1 - a2 * z0;
        zi.push([scale * z0, scale * z1]);
        scale *= (b0 + b1 + b2) / denominator;
    }
    Ok(zi)
}

/// Cascade of `S` sections over `data` (in the iterator's order), state in
/// `zi` updated in place. Transposed direct form II, operation order as in
/// scipy's `_sosfilt` so rounding matches closely.
#[inline(always)]
fn cascade_fixed<'a, const S: usize>(
    sos: &[Section],
    zi: &mut [[f64; 2]],
    data: impl Iterator<Item = &'a mut f64>,
) {
    let mut coef = [[0.0f64; 5]; S];
    let mut state = [[0.0f64; 2]; S];
    for s in 0..S {
        coef[s] = [sos[s][0], sos[s][1], sos[s][2], sos[s][4], sos[s][5]];
        state[s] = zi[s];
    }
    for v in data {
        let mut x = *v;
        for s in 0..S {
            let [b0, b1, b2, a1, a2] = coef[s];
            let y = b0 * x + state[s][0];
            state[s][0] = b1 * x - a1 * y + state[s][1];
            state[s][1] = b2 * x - a2 * y;
            x = y;
        }
        *v = x;
    }
    zi[..S].copy_from_slice(&state);
}

/// Same as `cascade_fixed` for any number of sections (state in memory).
fn cascade_any<'a>(sos: &[Section], zi: &mut [[f64; 2]], data: impl Iterator<Item = &'a mut f64>) {
    for v in data {
        let mut x = *v;
        for (s, z) in sos.iter().zip(zi.iter_mut()) {
            let y = s[0] * x + z[0];
            z[0] = s[1] * x - s[4] * y + z[1];
            z[1] = s[2] * x - s[5] * y;
            x = y;
        }
        *v = x;
    }
}

fn cascade<'a>(sos: &[Section], zi: &mut [[f64; 2]], data: impl Iterator<Item = &'a mut f64>) {
    macro_rules! dispatch {
        ($($n:literal),*) => {
            match sos.len() {
                $($n => cascade_fixed::<$n>(sos, zi, data),)*
                _ => cascade_any(sos, zi, data),
            }
        };
    }
    dispatch!(1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12)
}

/// Causal filtering in place (scipy `sosfilt` with `zi`); `zi` holds the
/// initial state on entry and the final state on return.
pub fn sosfilt_in_place(sos: &[Section], data: &mut [f64], zi: &mut [[f64; 2]]) -> Result<()> {
    validate_sections(sos)?;
    if zi.len() != sos.len() {
        return Err(Error::usage(format!(
            "{} initial states for {} sections",
            zi.len(),
            sos.len()
        )));
    }
    cascade(sos, zi, data.iter_mut());
    Ok(())
}

/// Causal filtering from rest (zero initial state).
pub fn sosfilt(sos: &[Section], data: &[f64]) -> Result<Vec<f64>> {
    let mut out = data.to_vec();
    let mut zi = vec![[0.0; 2]; sos.len()];
    sosfilt_in_place(sos, &mut out, &mut zi)?;
    Ok(out)
}

/// Edge padding length used by `sosfiltfilt` (scipy's default):
/// 3·(2·n_sections + 1 − min(#{b2 = 0}, #{a2 = 0})).
pub fn sosfiltfilt_padlen(sos: &[Section]) -> usize {
    let b2_zero = sos.iter().filter(|s| s[2] == 0.0).count();
    let a2_zero = sos.iter().filter(|s| s[5] == 0.0).count();
    3 * (2 * sos.len() + 1 - b2_zero.min(a2_zero))
}

/// Zero-phase forward–backward filtering with scipy's `sosfiltfilt`
/// defaults: odd extension of `padlen` samples at both ends, initial states
/// `sosfilt_zi` scaled by the first sample of the padded signal (forward)
/// and by the last sample of the forward output (backward). The signal must
/// be longer than `padlen`. Non-finite samples are refused.
pub fn sosfiltfilt(sos: &[Section], data: &[f64]) -> Result<Vec<f64>> {
    let zi = sosfilt_zi(sos)?;
    let pad = sosfiltfilt_padlen(sos);
    let n = data.len();
    if n <= pad {
        return Err(Error::numerical(format!(
            "{n} samples is too short for zero-phase filtering with {} sections: need more than {pad}",
            sos.len()
        )));
    }
    if let Some(i) = data.iter().position(|v| !v.is_finite()) {
        return Err(Error::numerical(format!(
            "non-finite sample at index {i}: refusing to filter"
        )));
    }
    let first = data[0];
    let last = data[n - 1];
    let mut ext = Vec::with_capacity(n + 2 * pad);
    // Odd extension: 2·x[0] − x[pad..0:-1] on the left, 2·x[-1] − x[-2..] on the right.
    ext.extend((1..=pad).rev().map(|i| 2.0 * first - data[i]));
    ext.extend_from_slice(data);
    ext.extend((0..pad).map(|i| 2.0 * last - data[n - 2 - i]));

    let x0 = ext[0];
    let mut state: Vec<[f64; 2]> = zi.iter().map(|z| [z[0] * x0, z[1] * x0]).collect();
    cascade(sos, &mut state, ext.iter_mut());
    let y0 = ext[ext.len() - 1];
    let mut state: Vec<[f64; 2]> = zi.iter().map(|z| [z[0] * y0, z[1] * y0]).collect();
    cascade(sos, &mut state, ext.iter_mut().rev());

    ext.copy_within(pad..pad + n, 0);
    ext.truncate(n);
    Ok(ext)
}

/// Channels filtered together, one per SIMD lane, in `sosfiltfilt_channels`:
/// 8 f64 lanes fill an AVX-512 register (two AVX2 ones).
const LANES: usize = 8;

/// Most sections the lane kernels are compiled for (more: channel by channel).
const MAX_LANE_SECTIONS: usize = 12;

/// One sample of `LANES` channels, interleaved: the kernel loads and stores
/// whole vectors.
type Frame = [f64; LANES];

/// One frame through the `S` sections, each lane one channel: the
/// arithmetic of `cascade_fixed`, operation for operation and without fused
/// multiply–adds, so every lane is bit-identical to filtering its channel
/// alone.  The lanes hide each section's recursion latency, and the
/// fixed-size loops compile to vector instructions.
#[inline(always)]
fn step_frame<const S: usize>(
    coef: &[[f64; 5]; S],
    state: &mut [[Frame; 2]; S],
    frame: Frame,
) -> Frame {
    let mut x = frame;
    for s in 0..S {
        let [b0, b1, b2, a1, a2] = coef[s];
        let mut y = [0.0; LANES];
        for l in 0..LANES {
            y[l] = b0 * x[l] + state[s][0][l];
            state[s][0][l] = b1 * x[l] - a1 * y[l] + state[s][1][l];
            state[s][1][l] = b2 * x[l] - a2 * y[l];
        }
        x = y;
    }
    x
}

/// `sosfiltfilt` of `LANES` channels of `n` samples (`n > pad`) through `S`
/// sections, in two passes: the forward one reads the channels (and their
/// odd extension) and writes interleaved frames, the backward one reads the
/// frames and writes the channels' outputs; the backward pass stops where
/// the left extension starts (its outputs are dropped anyway).
#[inline(always)]
fn filtfilt_group<const S: usize>(
    sos: &[Section],
    zi: &[[f64; 2]],
    pad: usize,
    inputs: &[&[f64]; LANES],
    outputs: &mut [Vec<f64>; LANES],
) {
    let n = inputs[0].len();
    let inputs: [&[f64]; LANES] = std::array::from_fn(|l| &inputs[l][..n]);
    let at = |i: usize| -> Frame { std::array::from_fn(|l| inputs[l][i]) };
    let coef: [[f64; 5]; S] =
        std::array::from_fn(|s| [sos[s][0], sos[s][1], sos[s][2], sos[s][4], sos[s][5]]);
    let scaled = |x: &Frame| -> [[Frame; 2]; S] {
        std::array::from_fn(|s| [x.map(|v| zi[s][0] * v), x.map(|v| zi[s][1] * v)])
    };
    let (first, last) = (at(0), at(n - 1));
    let odd = |edge: &Frame, x: Frame| -> Frame { std::array::from_fn(|l| 2.0 * edge[l] - x[l]) };
    let mut frames: Vec<Frame> = Vec::with_capacity(n + 2 * pad);
    let mut state = scaled(&odd(&first, at(pad)));
    for i in (1..=pad).rev() {
        frames.push(step_frame(&coef, &mut state, odd(&first, at(i))));
    }
    for i in 0..n {
        frames.push(step_frame(&coef, &mut state, at(i)));
    }
    for i in 0..pad {
        frames.push(step_frame(&coef, &mut state, odd(&last, at(n - 2 - i))));
    }
    let mut state = scaled(&frames[frames.len() - 1]);
    for &frame in frames[pad + n..].iter().rev() {
        step_frame(&coef, &mut state, frame);
    }
    for out in outputs.iter_mut() {
        out.clear();
        out.resize(n, 0.0);
    }
    let outs: [&mut [f64]; LANES] = outputs.each_mut().map(|o| &mut o[..n]);
    for i in (0..n).rev() {
        let y = step_frame(&coef, &mut state, frames[pad + i]);
        for l in 0..LANES {
            outs[l][i] = y[l];
        }
    }
}

/// [`filtfilt_group`] for the section count of `sos` (at most
/// [`MAX_LANE_SECTIONS`]).
#[inline(always)]
fn filtfilt_group_any(
    sos: &[Section],
    zi: &[[f64; 2]],
    pad: usize,
    inputs: &[&[f64]; LANES],
    outputs: &mut [Vec<f64>; LANES],
) {
    macro_rules! dispatch {
        ($($n:literal),*) => {
            match sos.len() {
                $($n => filtfilt_group::<$n>(sos, zi, pad, inputs, outputs),)*
                _ => unreachable!("at most MAX_LANE_SECTIONS sections reach the lane kernel"),
            }
        };
    }
    dispatch!(1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn filtfilt_group_avx512(
    sos: &[Section],
    zi: &[[f64; 2]],
    pad: usize,
    inputs: &[&[f64]; LANES],
    outputs: &mut [Vec<f64>; LANES],
) {
    filtfilt_group_any(sos, zi, pad, inputs, outputs)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn filtfilt_group_avx2(
    sos: &[Section],
    zi: &[[f64; 2]],
    pad: usize,
    inputs: &[&[f64]; LANES],
    outputs: &mut [Vec<f64>; LANES],
) {
    filtfilt_group_any(sos, zi, pad, inputs, outputs)
}

/// `sosfiltfilt` of up to `LANES` equal-length channels in lock-step
/// (unused lanes filter zeros and are dropped), compiled for the widest
/// vector unit this processor has (checked at run time; the same
/// arithmetic, so the same bits).
fn sosfiltfilt_lanes(
    sos: &[Section],
    zi: &[[f64; 2]],
    pad: usize,
    channels: &[&[f64]],
) -> Vec<Vec<f64>> {
    let n = channels[0].len();
    let zeros = vec![0.0; if channels.len() < LANES { n } else { 0 }];
    let inputs: [&[f64]; LANES] =
        std::array::from_fn(|l| channels.get(l).copied().unwrap_or(zeros.as_slice()));
    let mut outputs: [Vec<f64>; LANES] = std::array::from_fn(|_| Vec::new());
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the processor supports AVX-512F (checked above).
            unsafe { filtfilt_group_avx512(sos, zi, pad, &inputs, &mut outputs) };
        } else if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor supports AVX2 (checked above).
            unsafe { filtfilt_group_avx2(sos, zi, pad, &inputs, &mut outputs) };
        } else {
            filtfilt_group_any(sos, zi, pad, &inputs, &mut outputs);
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    filtfilt_group_any(sos, zi, pad, &inputs, &mut outputs);
    outputs.into_iter().take(channels.len()).collect()
}

/// `sosfiltfilt` on many channels, in parallel (rayon): channels of equal
/// length are filtered eight at a time in SIMD lanes (results bit-identical
/// to `sosfiltfilt` on each channel). Results in input order; fails on the
/// first failing channel (lowest index).
pub fn sosfiltfilt_channels<T: AsRef<[f64]> + Sync>(
    sos: &[Section],
    channels: &[T],
) -> Result<Vec<Vec<f64>>> {
    let zi = sosfilt_zi(sos)?;
    let pad = sosfiltfilt_padlen(sos);
    // Channels that are valid for the lane kernel, grouped by length.
    let mut eligible: Vec<usize> = (0..channels.len())
        .filter(|&i| {
            let c = channels[i].as_ref();
            sos.len() <= MAX_LANE_SECTIONS && c.len() > pad && c.iter().all(|v| v.is_finite())
        })
        .collect();
    eligible.sort_by_key(|&i| channels[i].as_ref().len());
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut is_eligible = vec![false; channels.len()];
    eligible.iter().for_each(|&i| is_eligible[i] = true);
    let rest: Vec<usize> = (0..channels.len()).filter(|&i| !is_eligible[i]).collect();
    let mut k = 0;
    while k < eligible.len() {
        let len = channels[eligible[k]].as_ref().len();
        let mut end = k;
        while end < eligible.len() && channels[eligible[end]].as_ref().len() == len {
            end += 1;
        }
        groups.extend(eligible[k..end].chunks(LANES).map(<[usize]>::to_vec));
        k = end;
    }
    let grouped: Vec<Vec<(usize, Vec<f64>)>> = groups
        .par_iter()
        .map(|g| {
            let inputs: Vec<&[f64]> = g.iter().map(|&i| channels[i].as_ref()).collect();
            let outs = sosfiltfilt_lanes(sos, &zi, pad, &inputs);
            g.iter().copied().zip(outs).collect()
        })
        .collect();
    let singles: Vec<(usize, Result<Vec<f64>>)> = rest
        .par_iter()
        .map(|&i| (i, sosfiltfilt(sos, channels[i].as_ref())))
        .collect();
    let mut out: Vec<Option<Result<Vec<f64>>>> = (0..channels.len()).map(|_| None).collect();
    for (i, y) in grouped.into_iter().flatten() {
        out[i] = Some(Ok(y));
    }
    for (i, y) in singles {
        out[i] = Some(y);
    }
    out.into_iter()
        .map(|o| o.unwrap_or_else(|| Err(Error::numerical("internal: channel not filtered"))))
        .collect()
}
