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

/// Channels filtered together by one thread in `sosfiltfilt_channels`.
const LANES: usize = 4;

/// `LANES` equal-length signals cascaded through `S` sections in lock-step,
/// visiting samples in the order of `indices`. Independent channels hide
/// the latency of each section's recursion (the per-lane arithmetic is the
/// same, operation for operation, as `cascade_fixed`, so results are
/// bit-identical to filtering each channel alone).
#[inline(always)]
fn cascade_lanes_fixed<const S: usize>(
    sos: &[Section],
    state: &mut [[[f64; LANES]; 2]],
    bufs: &mut [Vec<f64>; LANES],
    indices: impl Iterator<Item = usize>,
) {
    let mut coef = [[0.0f64; 5]; S];
    let mut z = [[[0.0f64; LANES]; 2]; S];
    for s in 0..S {
        coef[s] = [sos[s][0], sos[s][1], sos[s][2], sos[s][4], sos[s][5]];
        z[s] = state[s];
    }
    let n = bufs[0].len();
    let [b0s, b1s, b2s, b3s] = bufs;
    let (b0s, b1s, b2s, b3s) = (&mut b0s[..n], &mut b1s[..n], &mut b2s[..n], &mut b3s[..n]);
    for i in indices {
        let mut x = [b0s[i], b1s[i], b2s[i], b3s[i]];
        for s in 0..S {
            let [b0, b1, b2, a1, a2] = coef[s];
            let mut y = [0.0; LANES];
            for l in 0..LANES {
                y[l] = b0 * x[l] + z[s][0][l];
                z[s][0][l] = b1 * x[l] - a1 * y[l] + z[s][1][l];
                z[s][1][l] = b2 * x[l] - a2 * y[l];
            }
            x = y;
        }
        b0s[i] = x[0];
        b1s[i] = x[1];
        b2s[i] = x[2];
        b3s[i] = x[3];
    }
    state[..S].copy_from_slice(&z);
}

fn cascade_lanes(
    sos: &[Section],
    state: &mut [[[f64; LANES]; 2]],
    bufs: &mut [Vec<f64>; LANES],
    indices: impl Iterator<Item = usize>,
) {
    macro_rules! dispatch {
        ($($n:literal),*) => {
            match sos.len() {
                $($n => cascade_lanes_fixed::<$n>(sos, state, bufs, indices),)*
                _ => {
                    // Many sections: lane by lane with the generic kernel.
                    let order: Vec<usize> = indices.collect();
                    for (l, buf) in bufs.iter_mut().enumerate() {
                        let mut zi: Vec<[f64; 2]> = state.iter().map(|s| [s[0][l], s[1][l]]).collect();
                        let mut values: Vec<f64> = order.iter().map(|&i| buf[i]).collect();
                        cascade_any(sos, &mut zi, values.iter_mut());
                        for (&i, v) in order.iter().zip(values) {
                            buf[i] = v;
                        }
                        for (s, z) in state.iter_mut().zip(zi) {
                            s[0][l] = z[0];
                            s[1][l] = z[1];
                        }
                    }
                }
            }
        };
    }
    dispatch!(1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12)
}

/// Odd extension by `pad` samples at both ends (scipy `odd_ext`).
fn odd_extension(data: &[f64], pad: usize) -> Vec<f64> {
    let n = data.len();
    let (first, last) = (data[0], data[n - 1]);
    let mut ext = Vec::with_capacity(n + 2 * pad);
    ext.extend((1..=pad).rev().map(|i| 2.0 * first - data[i]));
    ext.extend_from_slice(data);
    ext.extend((0..pad).map(|i| 2.0 * last - data[n - 2 - i]));
    ext
}

/// `sosfiltfilt` of `LANES` equal-length channels in lock-step.
fn sosfiltfilt_lanes(
    sos: &[Section],
    zi: &[[f64; 2]],
    pad: usize,
    inputs: [&[f64]; LANES],
) -> [Vec<f64>; LANES] {
    let n = inputs[0].len();
    let mut bufs = inputs.map(|x| odd_extension(x, pad));
    let len = n + 2 * pad;
    let scaled = |bufs: &[Vec<f64>; LANES], at: usize| -> Vec<[[f64; LANES]; 2]> {
        zi.iter()
            .map(|z| {
                [
                    std::array::from_fn(|l| z[0] * bufs[l][at]),
                    std::array::from_fn(|l| z[1] * bufs[l][at]),
                ]
            })
            .collect()
    };
    let mut state = scaled(&bufs, 0);
    cascade_lanes(sos, &mut state, &mut bufs, 0..len);
    let mut state = scaled(&bufs, len - 1);
    cascade_lanes(sos, &mut state, &mut bufs, (0..len).rev());
    bufs.map(|mut b| {
        b.copy_within(pad..pad + n, 0);
        b.truncate(n);
        b
    })
}

/// `sosfiltfilt` on many channels, in parallel (rayon): channels of equal
/// length are filtered four at a time in lock-step (results bit-identical
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
            c.len() > pad && c.iter().all(|v| v.is_finite())
        })
        .collect();
    eligible.sort_by_key(|&i| channels[i].as_ref().len());
    let mut groups: Vec<[usize; LANES]> = Vec::new();
    let mut is_eligible = vec![false; channels.len()];
    eligible.iter().for_each(|&i| is_eligible[i] = true);
    let mut rest: Vec<usize> = (0..channels.len()).filter(|&i| !is_eligible[i]).collect();
    let mut k = 0;
    while k < eligible.len() {
        let len = channels[eligible[k]].as_ref().len();
        let mut end = k;
        while end < eligible.len() && channels[eligible[end]].as_ref().len() == len {
            end += 1;
        }
        let mut j = k;
        while j + LANES <= end {
            groups.push(std::array::from_fn(|l| eligible[j + l]));
            j += LANES;
        }
        rest.extend_from_slice(&eligible[j..end]);
        k = end;
    }
    let grouped: Vec<Vec<(usize, Vec<f64>)>> = groups
        .par_iter()
        .map(|g| {
            let outs = sosfiltfilt_lanes(sos, &zi, pad, g.map(|i| channels[i].as_ref()));
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
