//! Digital Butterworth filter design as second-order sections, reproducing
//! `scipy.signal.butter(N, Wn, btype, fs=fs, output='sos')` step by step:
//! analog prototype poles (`buttap`), frequency transformation with
//! prewarping (`lp2lp_zpk`, `lp2hp_zpk`, `lp2bp_zpk`, `lp2bs_zpk`), bilinear
//! transform (`bilinear_zpk`) and pole–zero pairing into sections
//! (`zpk2sos`, pairing `'nearest'`), so that the sections come out in
//! scipy's order and agree with it to rounding (METHODS §1: the default
//! chain is a 4th-order Butterworth band-pass applied zero-phase).
//!
//! Written here rather than taken from a crate: `iir_filters` designs the
//! same sections but the pairing/order has to match scipy exactly for the
//! zero-phase output to be comparable, and the algorithm is short.

use rustfft::num_complex::Complex64;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// One second-order section `[b0, b1, b2, a0, a1, a2]` with `a0 = 1`
/// (scipy's `sos` row layout).
pub type Section = [f64; 6];

/// Filter band type (scipy's `btype`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BandType {
    Lowpass,
    Highpass,
    Bandpass,
    Bandstop,
}

impl BandType {
    pub fn name(&self) -> &'static str {
        match self {
            BandType::Lowpass => "lowpass",
            BandType::Highpass => "highpass",
            BandType::Bandpass => "bandpass",
            BandType::Bandstop => "bandstop",
        }
    }
}

/// Zeros, poles and gain of a filter.
#[derive(Debug, Clone)]
struct Zpk {
    zeros: Vec<Complex64>,
    poles: Vec<Complex64>,
    gain: f64,
}

/// Butterworth design, returned as second-order sections equal to
/// `scipy.signal.butter(order, corners_hz, btype, fs=sampling_rate_hz, output='sos')`.
///
/// `corners_hz` holds one corner for low/high-pass and two (low, high) for
/// band-pass/stop; every corner must lie strictly between 0 and Nyquist.
pub fn butter_sos(
    order: usize,
    band: BandType,
    corners_hz: &[f64],
    sampling_rate_hz: f64,
) -> Result<Vec<Section>> {
    if order == 0 || order > 64 {
        return Err(Error::usage(format!(
            "Butterworth order must be 1..=64, got {order}"
        )));
    }
    if !(sampling_rate_hz.is_finite() && sampling_rate_hz > 0.0) {
        return Err(Error::usage(format!(
            "sampling rate must be positive, got {sampling_rate_hz}"
        )));
    }
    let nyquist = sampling_rate_hz / 2.0;
    let expected = match band {
        BandType::Lowpass | BandType::Highpass => 1,
        BandType::Bandpass | BandType::Bandstop => 2,
    };
    if corners_hz.len() != expected {
        return Err(Error::usage(format!(
            "{} filter needs {expected} corner frequency(ies), got {}",
            band.name(),
            corners_hz.len()
        )));
    }
    for &c in corners_hz {
        if !(c.is_finite() && c > 0.0 && c < nyquist) {
            return Err(Error::usage(format!(
                "corner frequency {c} Hz must lie strictly between 0 and Nyquist ({nyquist} Hz)"
            )));
        }
    }
    if expected == 2 && corners_hz[0] >= corners_hz[1] {
        return Err(Error::usage(format!(
            "{} corners must be increasing, got {} and {} Hz",
            band.name(),
            corners_hz[0],
            corners_hz[1]
        )));
    }
    // scipy normalises Wn = 2 f / fs, then designs at fs = 2 with prewarping
    // warped = 2·fs·tan(π Wn / fs) = 4 tan(π Wn / 2).
    let warped: Vec<f64> = corners_hz
        .iter()
        .map(|&c| {
            let wn = 2.0 * c / sampling_rate_hz;
            4.0 * (std::f64::consts::PI * wn / 2.0).tan()
        })
        .collect();
    let proto = butterworth_prototype(order);
    let analog = match band {
        BandType::Lowpass => lowpass_to_lowpass(proto, warped[0]),
        BandType::Highpass => lowpass_to_highpass(proto, warped[0]),
        BandType::Bandpass => {
            let bw = warped[1] - warped[0];
            let wo = (warped[0] * warped[1]).sqrt();
            lowpass_to_bandpass(proto, wo, bw)
        }
        BandType::Bandstop => {
            let bw = warped[1] - warped[0];
            let wo = (warped[0] * warped[1]).sqrt();
            lowpass_to_bandstop(proto, wo, bw)
        }
    };
    let digital = bilinear(analog, 2.0);
    zpk_to_sos_nearest(digital)
}

/// Analog Butterworth prototype (scipy `buttap`): no zeros, poles
/// −exp(iπm/(2N)) for m = −N+1, −N+3, …, N−1, gain 1.
fn butterworth_prototype(order: usize) -> Zpk {
    let n = order as i64;
    let poles = (0..order as i64)
        .map(|j| {
            let m = -n + 1 + 2 * j;
            let theta = std::f64::consts::PI * m as f64 / (2 * n) as f64;
            -Complex64::new(0.0, theta).exp()
        })
        .collect();
    Zpk {
        zeros: Vec::new(),
        poles,
        gain: 1.0,
    }
}

/// Complex division as numpy computes it (Smith's algorithm with a
/// reciprocal scale), so that designs round exactly like scipy's: pole
/// pairing compares distances that can tie to the last bit.
fn c_div(a: Complex64, b: Complex64) -> Complex64 {
    let (ar, ai, br, bi) = (a.re, a.im, b.re, b.im);
    if br.abs() >= bi.abs() {
        let rat = bi / br;
        let scl = 1.0 / (br + bi * rat);
        Complex64::new((ar + ai * rat) * scl, (ai - ar * rat) * scl)
    } else {
        let rat = br / bi;
        let scl = 1.0 / (bi + br * rat);
        Complex64::new((ar * rat + ai) * scl, (ai * rat - ar) * scl)
    }
}

/// Principal complex square root as C99 `csqrt` (glibc, used by numpy)
/// computes it: uses 2·Re·Im = Im x to avoid cancellation.
fn c_sqrt(z: Complex64) -> Complex64 {
    let (x, y) = (z.re, z.im);
    if y == 0.0 {
        return if x < 0.0 {
            Complex64::new(0.0, (-x).sqrt().copysign(y))
        } else {
            Complex64::new(x.sqrt().abs(), 0.0f64.copysign(y))
        };
    }
    if x == 0.0 {
        let r = (0.5 * y.abs()).sqrt();
        return Complex64::new(r, r.copysign(y));
    }
    let d = x.hypot(y);
    let (r, s) = if x > 0.0 {
        let r = (0.5 * (d + x)).sqrt();
        (r, 0.5 * (y / r))
    } else {
        let s = (0.5 * (d - x)).sqrt();
        ((0.5 * (y / s)).abs(), s)
    };
    Complex64::new(r, s.copysign(y))
}

fn relative_degree(zpk: &Zpk) -> usize {
    zpk.poles.len().saturating_sub(zpk.zeros.len())
}

fn product(values: impl Iterator<Item = Complex64>) -> Complex64 {
    values.fold(Complex64::new(1.0, 0.0), |acc, v| acc * v)
}

/// scipy `lp2lp_zpk`: scale cut-off to `wo`.
fn lowpass_to_lowpass(zpk: Zpk, wo: f64) -> Zpk {
    let degree = relative_degree(&zpk);
    Zpk {
        zeros: zpk.zeros.iter().map(|z| z * wo).collect(),
        poles: zpk.poles.iter().map(|p| p * wo).collect(),
        gain: zpk.gain * wo.powi(degree as i32),
    }
}

/// scipy `lp2hp_zpk`: s → wo/s; zeros at the origin fill the degree.
fn lowpass_to_highpass(zpk: Zpk, wo: f64) -> Zpk {
    let degree = relative_degree(&zpk);
    let wo_c = Complex64::new(wo, 0.0);
    let mut zeros: Vec<Complex64> = zpk.zeros.iter().map(|z| c_div(wo_c, *z)).collect();
    zeros.extend(std::iter::repeat_n(Complex64::new(0.0, 0.0), degree));
    let ratio = c_div(
        product(zpk.zeros.iter().map(|z| -z)),
        product(zpk.poles.iter().map(|p| -p)),
    );
    Zpk {
        zeros,
        poles: zpk.poles.iter().map(|p| c_div(wo_c, *p)).collect(),
        gain: zpk.gain * ratio.re,
    }
}

/// Roots of s² − 2·x·s + wo² for each x: x ± sqrt(x² − wo²), the "+" half
/// first then the "−" half (scipy's concatenation order).
fn split_band(values: &[Complex64], wo: f64) -> Vec<Complex64> {
    let wo2 = Complex64::new(wo * wo, 0.0);
    let roots: Vec<Complex64> = values.iter().map(|x| c_sqrt(x * x - wo2)).collect();
    let mut out: Vec<Complex64> = values.iter().zip(&roots).map(|(x, r)| x + r).collect();
    out.extend(values.iter().zip(&roots).map(|(x, r)| x - r));
    out
}

/// scipy `lp2bp_zpk`.
fn lowpass_to_bandpass(zpk: Zpk, wo: f64, bw: f64) -> Zpk {
    let degree = relative_degree(&zpk);
    let z_lp: Vec<Complex64> = zpk.zeros.iter().map(|z| z * (bw / 2.0)).collect();
    let p_lp: Vec<Complex64> = zpk.poles.iter().map(|p| p * (bw / 2.0)).collect();
    let mut zeros = split_band(&z_lp, wo);
    zeros.extend(std::iter::repeat_n(Complex64::new(0.0, 0.0), degree));
    Zpk {
        zeros,
        poles: split_band(&p_lp, wo),
        gain: zpk.gain * bw.powi(degree as i32),
    }
}

/// scipy `lp2bs_zpk`.
fn lowpass_to_bandstop(zpk: Zpk, wo: f64, bw: f64) -> Zpk {
    let degree = relative_degree(&zpk);
    let half = Complex64::new(bw / 2.0, 0.0);
    let z_hp: Vec<Complex64> = zpk.zeros.iter().map(|z| c_div(half, *z)).collect();
    let p_hp: Vec<Complex64> = zpk.poles.iter().map(|p| c_div(half, *p)).collect();
    let mut zeros = split_band(&z_hp, wo);
    zeros.extend(std::iter::repeat_n(Complex64::new(0.0, wo), degree));
    zeros.extend(std::iter::repeat_n(Complex64::new(0.0, -wo), degree));
    let ratio = c_div(
        product(zpk.zeros.iter().map(|z| -z)),
        product(zpk.poles.iter().map(|p| -p)),
    );
    Zpk {
        zeros,
        poles: split_band(&p_hp, wo),
        gain: zpk.gain * ratio.re,
    }
}

/// scipy `bilinear_zpk`: z = (2fs + s)/(2fs − s); zeros at infinity go to z = −1.
fn bilinear(zpk: Zpk, fs: f64) -> Zpk {
    let degree = relative_degree(&zpk);
    let fs2 = Complex64::new(2.0 * fs, 0.0);
    let mut zeros: Vec<Complex64> = zpk.zeros.iter().map(|z| c_div(fs2 + z, fs2 - z)).collect();
    zeros.extend(std::iter::repeat_n(Complex64::new(-1.0, 0.0), degree));
    let ratio = c_div(
        product(zpk.zeros.iter().map(|z| fs2 - z)),
        product(zpk.poles.iter().map(|p| fs2 - p)),
    );
    Zpk {
        zeros,
        poles: zpk.poles.iter().map(|p| c_div(fs2 + p, fs2 - p)).collect(),
        gain: zpk.gain * ratio.re,
    }
}

/// scipy `_cplxreal`: one member (positive imaginary part) of each complex
/// conjugate pair, then the real values; sorted as scipy sorts them.
fn complex_pairs_then_reals(values: &[Complex64]) -> Result<Vec<Complex64>> {
    let tol = 100.0 * f64::EPSILON;
    let mut sorted = values.to_vec();
    // lexsort((|imag|, real)): primary key real part, secondary |imag| (stable).
    sorted.sort_by(|a, b| {
        a.re.total_cmp(&b.re)
            .then(a.im.abs().total_cmp(&b.im.abs()))
    });
    let is_real = |z: &Complex64| z.im.abs() <= tol * z.norm();
    let reals: Vec<f64> = sorted.iter().filter(|z| is_real(z)).map(|z| z.re).collect();
    let complex: Vec<Complex64> = sorted.iter().filter(|z| !is_real(z)).copied().collect();
    let mut positive: Vec<Complex64> = complex.iter().filter(|z| z.im > 0.0).copied().collect();
    let mut negative: Vec<Complex64> = complex.iter().filter(|z| z.im < 0.0).copied().collect();
    if positive.len() != negative.len() {
        return Err(Error::numerical(
            "filter design: complex value without a matching conjugate",
        ));
    }
    // Runs of (approximately) equal real part are sorted by |imag|.
    let mut start = 0;
    while start < positive.len() {
        let mut stop = start;
        while stop + 1 < positive.len()
            && positive[stop + 1].re - positive[stop].re <= tol * positive[stop].norm()
        {
            stop += 1;
        }
        if stop > start {
            positive[start..=stop].sort_by(|a, b| a.im.abs().total_cmp(&b.im.abs()));
            negative[start..=stop].sort_by(|a, b| a.im.abs().total_cmp(&b.im.abs()));
        }
        start = stop + 1;
    }
    let mut out = Vec::with_capacity(positive.len() + reals.len());
    for (p, n) in positive.iter().zip(&negative) {
        if (p - n.conj()).norm() > tol * n.norm() {
            return Err(Error::numerical(
                "filter design: complex value without a matching conjugate",
            ));
        }
        out.push(c_div(p + n.conj(), Complex64::new(2.0, 0.0)));
    }
    out.extend(reals.into_iter().map(|r| Complex64::new(r, 0.0)));
    Ok(out)
}

fn is_exactly_real(z: &Complex64) -> bool {
    z.im == 0.0
}

/// Index of the value closest to the unit circle (first on ties, like argmin).
fn index_closest_to_unit_circle(values: &[Complex64], candidates: &[usize]) -> usize {
    let mut best = candidates[0];
    let mut best_d = f64::INFINITY;
    for &i in candidates {
        let d = (1.0 - values[i].norm()).abs();
        if d < best_d {
            best_d = d;
            best = i;
        }
    }
    best
}

#[derive(Clone, Copy, PartialEq)]
enum Which {
    Real,
    Complex,
    Any,
}

/// scipy `_nearest_real_complex_idx`: nearest element of the wanted kind.
fn nearest_index(values: &[Complex64], to: Complex64, which: Which) -> Option<usize> {
    let mut order: Vec<usize> = (0..values.len()).collect();
    order.sort_by(|&a, &b| (values[a] - to).norm().total_cmp(&(values[b] - to).norm()));
    order.into_iter().find(|&i| match which {
        Which::Any => true,
        Which::Real => is_exactly_real(&values[i]),
        Which::Complex => !is_exactly_real(&values[i]),
    })
}

/// Monic polynomial with the given (up to two) roots, real part, padded on
/// the left to three coefficients (scipy `_single_zpksos` + `zpk2tf`).
fn quadratic_from_roots(roots: &[Complex64]) -> [f64; 3] {
    match roots {
        [] => [0.0, 0.0, 1.0],
        [r] => [0.0, 1.0, -r.re],
        // Call sites pass at most two roots.
        [r1, r2, ..] => {
            let sum = -r2 + -r1;
            let prod = r1 * r2;
            [1.0, sum.re, prod.re]
        }
    }
}

fn section_from(zeros: &[Complex64], poles: &[Complex64]) -> Section {
    let b = quadratic_from_roots(zeros);
    let a = quadratic_from_roots(poles);
    [b[0], b[1], b[2], a[0], a[1], a[2]]
}

/// scipy `zpk2sos(z, p, k, pairing='nearest')` for digital filters: poles
/// closest to the unit circle go into the last section, each paired with
/// the nearest zeros; the gain goes into the first section.
fn zpk_to_sos_nearest(zpk: Zpk) -> Result<Vec<Section>> {
    let Zpk {
        mut zeros,
        mut poles,
        gain,
    } = zpk;
    if zeros.is_empty() && poles.is_empty() {
        return Ok(vec![[gain, 0.0, 0.0, 1.0, 0.0, 0.0]]);
    }
    let zero = Complex64::new(0.0, 0.0);
    while poles.len() < zeros.len() {
        poles.push(zero);
    }
    while zeros.len() < poles.len() {
        zeros.push(zero);
    }
    let n_sections = poles.len().div_ceil(2);
    if poles.len() % 2 == 1 {
        poles.push(zero);
        zeros.push(zero);
    }
    let mut z = complex_pairs_then_reals(&zeros)?;
    let mut p = complex_pairs_then_reals(&poles)?;
    let missing = || Error::numerical("filter design: pole/zero pairing ran out of zeros");
    let mut sos = vec![[0.0; 6]; n_sections];
    for si in (0..n_sections).rev() {
        let all: Vec<usize> = (0..p.len()).collect();
        let p1_idx = index_closest_to_unit_circle(&p, &all);
        let p1 = p.remove(p1_idx);
        let reals_left = p.iter().filter(|v| is_exactly_real(v)).count();
        if is_exactly_real(&p1) && reals_left == 0 {
            // Special case 1: last remaining real pole, paired with a real zero.
            let z1_idx = nearest_index(&z, p1, Which::Real).ok_or_else(missing)?;
            let z1 = z.remove(z1_idx);
            sos[si] = section_from(&[z1, zero], &[p1, zero]);
        } else if p.len() + 1 == z.len()
            && !is_exactly_real(&p1)
            && reals_left == 1
            && z.iter().filter(|v| is_exactly_real(v)).count() == 1
        {
            // Special case 2: must pair with a complex zero.
            let z1_idx = nearest_index(&z, p1, Which::Complex).ok_or_else(missing)?;
            let z1 = z.remove(z1_idx);
            sos[si] = section_from(&[z1, z1.conj()], &[p1, p1.conj()]);
        } else {
            let p2 = if is_exactly_real(&p1) {
                let real_idx: Vec<usize> =
                    (0..p.len()).filter(|&i| is_exactly_real(&p[i])).collect();
                let p2_idx = index_closest_to_unit_circle(&p, &real_idx);
                p.remove(p2_idx)
            } else {
                p1.conj()
            };
            if z.is_empty() {
                sos[si] = section_from(&[], &[p1, p2]);
            } else {
                let z1_idx = nearest_index(&z, p1, Which::Any).ok_or_else(missing)?;
                let z1 = z.remove(z1_idx);
                if !is_exactly_real(&z1) {
                    sos[si] = section_from(&[z1, z1.conj()], &[p1, p2]);
                } else if z.is_empty() {
                    sos[si] = section_from(&[z1], &[p1, p2]);
                } else {
                    let z2_idx = nearest_index(&z, p1, Which::Real).ok_or_else(missing)?;
                    let z2 = z.remove(z2_idx);
                    sos[si] = section_from(&[z1, z2], &[p1, p2]);
                }
            }
        }
    }
    for c in &mut sos[0][..3] {
        *c *= gain;
    }
    Ok(sos)
}
