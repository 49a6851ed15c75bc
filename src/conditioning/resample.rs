//! Resampling to a common rate and alignment on a common time base.
//!
//! Resampling is rational polyphase (up by L, low-pass FIR, down by M, the
//! method of scipy's `resample_poly`): the anti-aliasing filter is a
//! Kaiser-windowed sinc (β = 5, 2·10·max(L, M) + 1 taps) with its cut-off
//! at the lower of the two Nyquist frequencies, normalised to unit DC
//! gain, applied with zero delay. The transition band is not a brick
//! wall: attenuation is ½ at the cut-off and about 50 dB some 15–20 % above
//! it, so content just below the new Nyquist is attenuated too. Chosen over FFT resampling because it
//! does not assume the record is periodic (no wrap-around at the ends).
//! The ratio must be a fraction with denominator ≤ 1000 (e.g. 250 → 200 Hz
//! is 4/5).

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::vocab::Record;

/// Greatest common divisor (also the lag steps of the change test's two records).
pub(crate) fn gcd(a: usize, b: usize) -> usize {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// Most a resampling step may multiply a record's samples by (and its
/// memory): upsampling further adds no information.
pub const MAX_UPSAMPLING: usize = 64;

/// (up, down) with up/down = to_hz/from_hz, reduced, denominators ≤ 1000
/// (best rational approximation by continued fractions, accepted when it
/// matches to 1e-9 relative).
pub fn rational_ratio(from_hz: f64, to_hz: f64) -> Result<(usize, usize)> {
    if !(from_hz.is_finite() && from_hz > 0.0 && to_hz.is_finite() && to_hz > 0.0) {
        return Err(Error::usage(format!(
            "resampling rates must be positive: {from_hz} → {to_hz} Hz"
        )));
    }
    let ratio = to_hz / from_hz;
    // Continued-fraction convergents h/k of `ratio`.
    let (mut h0, mut h1, mut k0, mut k1) = (0u128, 1u128, 1u128, 0u128);
    let mut x = ratio;
    for _ in 0..40 {
        let a = x.floor();
        if a > 1e12 {
            break;
        }
        let ai = a as u128;
        let (h2, k2) = (ai * h1 + h0, ai * k1 + k0);
        if h2 > 1_000_000 || k2 > 1000 {
            break;
        }
        (h0, h1, k0, k1) = (h1, h2, k1, k2);
        if ((h1 as f64 / k1 as f64) - ratio).abs() <= 1e-9 * ratio {
            let g = gcd(h1 as usize, k1 as usize).max(1);
            return Ok((h1 as usize / g, k1 as usize / g));
        }
        let frac = x - a;
        if frac <= 0.0 {
            break;
        }
        x = 1.0 / frac;
    }
    Err(Error::usage(format!(
        "cannot resample {from_hz} Hz to {to_hz} Hz: the ratio is not a simple fraction (denominator ≤ 1000)"
    )))
}

/// Modified Bessel function I0 (power series; converges for all x used here).
fn bessel_i0(x: f64) -> f64 {
    let q = x * x / 4.0;
    let mut term = 1.0;
    let mut sum = 1.0;
    for k in 1..200 {
        term *= q / (k as f64 * k as f64);
        sum += term;
        if term < 1e-17 * sum {
            break;
        }
    }
    sum
}

/// Kaiser-windowed sinc low-pass FIR (odd length), cut-off `cutoff` as a
/// fraction of Nyquist, unit DC gain.
fn kaiser_lowpass(taps: usize, cutoff: f64, beta: f64) -> Vec<f64> {
    let centre = (taps - 1) as f64 / 2.0;
    let i0_beta = bessel_i0(beta);
    let mut h: Vec<f64> = (0..taps)
        .map(|j| {
            let m = j as f64 - centre;
            let arg = std::f64::consts::PI * cutoff * m;
            let sinc = if m == 0.0 { 1.0 } else { arg.sin() / arg };
            let r = if centre > 0.0 { m / centre } else { 0.0 };
            let window = bessel_i0(beta * (1.0 - r * r).max(0.0).sqrt()) / i0_beta;
            cutoff * sinc * window
        })
        .collect();
    let sum: f64 = h.iter().sum();
    h.iter_mut().for_each(|v| *v /= sum);
    h
}

/// Rational polyphase resampling by up/down (see module doc). Output length
/// ceil(n·up/down); sample k sits at time k·down/(up·fs_in).
pub fn resample_rational(data: &[f64], up: usize, down: usize) -> Result<Vec<f64>> {
    if up == 0 || down == 0 {
        return Err(Error::usage("resampling factors must be positive"));
    }
    let g = gcd(up, down);
    let (up, down) = (up / g, down / g);
    if up == 1 && down == 1 {
        return Ok(data.to_vec());
    }
    let n = data.len();
    if n == 0 {
        return Ok(Vec::new());
    }
    let max_rate = up.max(down);
    let half_len = 10 * max_rate;
    let taps = 2 * half_len + 1;
    let h: Vec<f64> = kaiser_lowpass(taps, 1.0 / max_rate as f64, 5.0)
        .into_iter()
        .map(|v| v * up as f64)
        .collect();
    let n_out = (n * up).div_ceil(down);
    let mut out = Vec::with_capacity(n_out);
    for k in 0..n_out {
        // Index into the (virtual) upsampled-and-filtered sequence, centred.
        let m = k * down + half_len;
        let i_min = m.saturating_sub(taps - 1).div_ceil(up);
        let i_max = (m / up).min(n - 1);
        let mut acc = 0.0;
        let mut i = i_min;
        while i <= i_max {
            acc += data[i] * h[m - i * up];
            i += 1;
        }
        out.push(acc);
    }
    Ok(out)
}

/// Resamples from `from_hz` to `to_hz` (see `rational_ratio`, `resample_rational`).
pub fn resample_to_rate(data: &[f64], from_hz: f64, to_hz: f64) -> Result<Vec<f64>> {
    let (up, down) = rational_ratio(from_hz, to_hz)?;
    if up > MAX_UPSAMPLING * down {
        return Err(Error::usage(format!(
            "resampling {from_hz} Hz to {to_hz} Hz multiplies the samples by more than {MAX_UPSAMPLING}: choose a rate_hz closer to the record's"
        )));
    }
    resample_rational(data, up, down)
}

/// What `align_records` did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Alignment {
    /// Common start, ns since the epoch (None when no record had a start time).
    pub common_start_ns: Option<i64>,
    pub samples: usize,
    /// Samples dropped at the start of each record (input order).
    pub trimmed_start: Vec<usize>,
    /// Largest sub-sample misalignment left (records are trimmed by whole
    /// samples, not shifted by fractions of one), seconds.
    pub max_residual_offset_s: f64,
}

/// Trims records (all at the same sampling rate) to their common time
/// window from `channel.start_ns`. Records without a start time are only
/// accepted when no record has one (they are then taken as simultaneous and
/// cut to the shortest). Errors when records do not overlap.
pub fn align_records(records: &mut [Record]) -> Result<Alignment> {
    let Some(first) = records.first() else {
        return Ok(Alignment {
            common_start_ns: None,
            samples: 0,
            trimmed_start: Vec::new(),
            max_residual_offset_s: 0.0,
        });
    };
    let rate = first.channel.sampling_rate_hz;
    for r in records.iter() {
        if r.channel.sampling_rate_hz != rate {
            return Err(Error::usage(format!(
                "cannot align channel {} at {} Hz with channel {} at {} Hz: resample to a common rate first",
                r.channel.id, r.channel.sampling_rate_hz, first.channel.id, rate
            )));
        }
    }
    let with_start = records
        .iter()
        .filter(|r| r.channel.start_ns.is_some())
        .count();
    if with_start == 0 {
        let n = records.iter().map(|r| r.samples.len()).min().unwrap_or(0);
        for r in records.iter_mut() {
            r.samples.as_mut_vec().truncate(n);
        }
        return Ok(Alignment {
            common_start_ns: None,
            samples: n,
            trimmed_start: vec![0; records.len()],
            max_residual_offset_s: 0.0,
        });
    }
    if let Some(r) = records.iter().find(|r| r.channel.start_ns.is_none()) {
        return Err(Error::usage(format!(
            "channel {} has no start time while others do: cannot align records on a common time base",
            r.channel.id
        )));
    }
    let dt_ns = 1e9 / rate;
    let start = |r: &Record| r.channel.start_ns.unwrap_or(0);
    let end_ns = |r: &Record| start(r) as f64 + r.samples.len() as f64 * dt_ns;
    let common_start = records.iter().map(start).max().unwrap_or(0);
    let common_end = records.iter().map(end_ns).fold(f64::INFINITY, f64::min);
    if common_end <= common_start as f64 {
        let names: Vec<&str> = records.iter().map(|r| r.channel.id.as_str()).collect();
        return Err(Error::usage(format!(
            "records do not overlap in time: {}",
            names.join(", ")
        )));
    }
    let mut trimmed = Vec::with_capacity(records.len());
    let mut max_residual: f64 = 0.0;
    let mut n_common = usize::MAX;
    for r in records.iter() {
        let offset = ((common_start - start(r)) as f64 / dt_ns).round() as usize;
        let residual = (common_start - start(r)) as f64 - offset as f64 * dt_ns;
        max_residual = max_residual.max(residual.abs() / 1e9);
        trimmed.push(offset);
        n_common = n_common.min(r.samples.len().saturating_sub(offset));
    }
    if n_common == 0 {
        return Err(Error::usage("records overlap by less than one sample"));
    }
    for (r, &offset) in records.iter_mut().zip(&trimmed) {
        let v = r.samples.as_mut_vec();
        v.drain(..offset);
        v.truncate(n_common);
        r.channel.start_ns = Some(start(r) + (offset as f64 * dt_ns).round() as i64);
    }
    Ok(Alignment {
        common_start_ns: Some(common_start),
        samples: n_common,
        trimmed_start: trimmed,
        max_residual_offset_s: max_residual,
    })
}
