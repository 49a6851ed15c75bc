//! Linear single-degree-of-freedom response spectra by the exact
//! piecewise-linear recurrence of Nigam & Jennings (1969): for ground
//! acceleration linear between samples, the state (u, u̇) of
//! ü + 2ζω u̇ + ω² u = −a_g(t) is propagated exactly from sample to sample.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Default period set: 100 log-spaced periods from 0.01 s to 10 s.
pub fn default_periods() -> Vec<f64> {
    let n = 100;
    let (lo, hi) = (0.01f64.ln(), 10.0f64.ln());
    (0..n)
        .map(|i| (lo + (hi - lo) * i as f64 / (n - 1) as f64).exp())
        .collect()
}

/// Coefficients of the exact one-step recurrence
/// [u, u̇]_{i+1} = A [u, u̇]_i + B [a_i, a_{i+1}].
#[derive(Debug, Clone, Copy)]
struct Recurrence {
    a: [[f64; 2]; 2],
    b: [[f64; 2]; 2],
}

impl Recurrence {
    fn new(omega: f64, damping: f64, dt: f64) -> Self {
        let wd = omega * (1.0 - damping * damping).sqrt();
        let e = (-damping * omega * dt).exp();
        let (s, c) = (wd * dt).sin_cos();
        let r = damping / (1.0 - damping * damping).sqrt();
        // Free vibration over one step (homogeneous solution).
        let a = [
            [e * (c + r * s), e * s / wd],
            [
                -e * omega * s / (1.0 - damping * damping).sqrt(),
                e * (c - r * s),
            ],
        ];
        // Forced part: for forcing p(τ) = c0 + c1 τ the particular solution is
        // u_p = c1 τ/ω² + c0/ω² − 2ζ c1/ω³, u̇_p = c1/ω²; the homogeneous part
        // carries the mismatch of initial conditions. With c0 = −a_i and
        // c1 = −(a_{i+1} − a_i)/dt, B follows by linearity (unit a_i, unit a_{i+1}).
        let w2 = omega * omega;
        let w3 = w2 * omega;
        let step = |ai: f64, aj: f64| -> [f64; 2] {
            let c0 = -ai;
            let c1 = -(aj - ai) / dt;
            let up0 = c0 / w2 - 2.0 * damping * c1 / w3;
            let vp = c1 / w2;
            let up1 = up0 + c1 * dt / w2;
            let (h0, hv0) = (-up0, -vp);
            [
                up1 + a[0][0] * h0 + a[0][1] * hv0,
                vp + a[1][0] * h0 + a[1][1] * hv0,
            ]
        };
        let bi = step(1.0, 0.0);
        let bj = step(0.0, 1.0);
        Recurrence {
            a,
            b: [[bi[0], bj[0]], [bi[1], bj[1]]],
        }
    }
}

fn check_inputs(dt: f64, period: f64, damping: f64) -> Result<()> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(Error::usage(format!(
            "sampling interval must be positive, got {dt}"
        )));
    }
    if !(period.is_finite() && period > 0.0) {
        return Err(Error::usage(format!(
            "oscillator period must be positive, got {period}"
        )));
    }
    if !(0.0..1.0).contains(&damping) {
        return Err(Error::usage(format!(
            "damping ratio must be within [0, 1), got {damping}"
        )));
    }
    Ok(())
}

/// Relative displacement and velocity histories of a linear oscillator
/// (period s, damping ratio) under ground acceleration, from rest.
pub fn sdof_response(
    ground_acceleration: &[f64],
    dt: f64,
    period: f64,
    damping: f64,
) -> Result<(Vec<f64>, Vec<f64>)> {
    check_inputs(dt, period, damping)?;
    let omega = 2.0 * std::f64::consts::PI / period;
    let rec = Recurrence::new(omega, damping, dt);
    let n = ground_acceleration.len();
    let mut u = Vec::with_capacity(n);
    let mut v = Vec::with_capacity(n);
    let (mut ui, mut vi) = (0.0, 0.0);
    if n > 0 {
        u.push(0.0);
        v.push(0.0);
    }
    for w in ground_acceleration.windows(2) {
        let un = rec.a[0][0] * ui + rec.a[0][1] * vi + rec.b[0][0] * w[0] + rec.b[0][1] * w[1];
        let vn = rec.a[1][0] * ui + rec.a[1][1] * vi + rec.b[1][0] * w[0] + rec.b[1][1] * w[1];
        ui = un;
        vi = vn;
        u.push(ui);
        v.push(vi);
    }
    Ok((u, v))
}

/// (max |u|, max |u̇|, max |ü + a_g|) of one oscillator.
type Peaks = (f64, f64, f64);

/// Oscillators run side by side by [`sdof_peaks_lanes`].
const LANES: usize = 16;

/// Peaks (max |u|, max |u̇|, max |ü + a_g|) of up to [`LANES`] oscillators
/// (`omegas`, from rest) in one pass over the record: the lanes' recurrences
/// are independent, so the processor overlaps them (one oscillator alone
/// waits on its own previous step).  Each lane's operations are those of one
/// oscillator on its own, so its peaks do not depend on its neighbours.
///
/// Sixteen lanes fill the processor: one step of a lane waits on its
/// previous step through a multiplication and three dependent additions
/// (≈ 16 cycles), longer than the vector work of eight lanes, so a pass of
/// one AVX-512 register of eight was bound by that latency; two independent
/// registers (four AVX2 ones, eight 2-wide SSE2 ones in the baseline x86-64
/// build) keep the arithmetic units busy through it (metrics stage of an hour
/// of 64 channels: 4.5 s → 3.4 s).  So on x86-64 the same code is compiled for
/// those too and chosen at run time (2.4× faster with AVX-512 on an hour of
/// 64 channels, where the spectra were the largest part of the metrics stage).
/// The results are the same bit for bit: the operations and their order are
/// those of the source — IEEE additions and multiplications, which Rust
/// never contracts into fused multiply-adds — only the register width
/// differs (`tests/it/big_input.rs` checks every variant the processor runs
/// against the baseline, [`sdof_peaks_variants`]).
fn sdof_peaks_lanes(
    ground_acceleration: &[f64],
    dt: f64,
    omegas: &[f64],
    damping: f64,
) -> Vec<(f64, f64, f64)> {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the processor has AVX-512F, the only requirement of the function.
            return unsafe { sdof_peaks_lanes_avx512(ground_acceleration, dt, omegas, damping) };
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2, the only requirement of the function.
            return unsafe { sdof_peaks_lanes_avx2(ground_acceleration, dt, omegas, damping) };
        }
    }
    sdof_peaks_lanes_portable(ground_acceleration, dt, omegas, damping)
}

/// [`sdof_peaks_lanes`] compiled for AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn sdof_peaks_lanes_avx512(
    ground_acceleration: &[f64],
    dt: f64,
    omegas: &[f64],
    damping: f64,
) -> Vec<(f64, f64, f64)> {
    sdof_peaks_lanes_portable(ground_acceleration, dt, omegas, damping)
}

/// [`sdof_peaks_lanes`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn sdof_peaks_lanes_avx2(
    ground_acceleration: &[f64],
    dt: f64,
    omegas: &[f64],
    damping: f64,
) -> Vec<(f64, f64, f64)> {
    sdof_peaks_lanes_portable(ground_acceleration, dt, omegas, damping)
}

/// The peaks of oscillators `omegas` (at most [`LANES`]) by every compiled
/// variant of [`sdof_peaks_lanes`] this processor can run, named (`portable`
/// first) — for the test that they agree bit for bit.
#[doc(hidden)]
pub fn sdof_peaks_variants(
    ground_acceleration: &[f64],
    dt: f64,
    omegas: &[f64],
    damping: f64,
) -> Vec<(&'static str, Vec<Peaks>)> {
    let omegas = &omegas[..omegas.len().min(LANES)];
    #[allow(unused_mut)]
    let mut out = vec![(
        "portable",
        sdof_peaks_lanes_portable(ground_acceleration, dt, omegas, damping),
    )];
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2.
            let p = unsafe { sdof_peaks_lanes_avx2(ground_acceleration, dt, omegas, damping) };
            out.push(("avx2", p));
        }
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the processor has AVX-512F.
            let p = unsafe { sdof_peaks_lanes_avx512(ground_acceleration, dt, omegas, damping) };
            out.push(("avx512f", p));
        }
    }
    out
}

/// The body of [`sdof_peaks_lanes`], inlined into each variant (and compiled
/// for the baseline on its own).
#[inline(always)]
fn sdof_peaks_lanes_portable(
    ground_acceleration: &[f64],
    dt: f64,
    omegas: &[f64],
    damping: f64,
) -> Vec<(f64, f64, f64)> {
    let mut omega = [0.0f64; LANES];
    let (mut a00, mut a01, mut a10, mut a11) =
        ([0.0f64; LANES], [0.0; LANES], [0.0; LANES], [0.0; LANES]);
    let (mut b00, mut b01, mut b10, mut b11) =
        ([0.0f64; LANES], [0.0; LANES], [0.0; LANES], [0.0; LANES]);
    for j in 0..LANES {
        // Unused lanes repeat the last oscillator (their peaks are dropped).
        let w = omegas[j.min(omegas.len() - 1)];
        let rec = Recurrence::new(w, damping, dt);
        omega[j] = w;
        (a00[j], a01[j], a10[j], a11[j]) = (rec.a[0][0], rec.a[0][1], rec.a[1][0], rec.a[1][1]);
        (b00[j], b01[j], b10[j], b11[j]) = (rec.b[0][0], rec.b[0][1], rec.b[1][0], rec.b[1][1]);
    }
    let (mut ui, mut vi) = ([0.0f64; LANES], [0.0f64; LANES]);
    let (mut du, mut dv, mut da) = ([0.0f64; LANES], [0.0f64; LANES], [0.0f64; LANES]);
    for w in ground_acceleration.windows(2) {
        for j in 0..LANES {
            let un = a00[j] * ui[j] + a01[j] * vi[j] + b00[j] * w[0] + b01[j] * w[1];
            let vn = a10[j] * ui[j] + a11[j] * vi[j] + b10[j] * w[0] + b11[j] * w[1];
            ui[j] = un;
            vi[j] = vn;
            // Running peaks: `if x > peak` is `peak.max(x)` here (a peak starts
            // at 0 and is never NaN; a NaN x is skipped by both), and maps to
            // one max instruction.
            let (au, av) = (ui[j].abs(), vi[j].abs());
            du[j] = if au > du[j] { au } else { du[j] };
            dv[j] = if av > dv[j] { av } else { dv[j] };
            // Absolute acceleration ü + a_g = −2ζω u̇ − ω² u.
            let aa = (2.0 * damping * omega[j] * vi[j] + omega[j] * omega[j] * ui[j]).abs();
            da[j] = if aa > da[j] { aa } else { da[j] };
        }
    }
    (0..omegas.len()).map(|j| (du[j], dv[j], da[j])).collect()
}

/// Response spectrum of one record. Entry 0 is T = 0 (all spectral
/// accelerations equal PGA, displacement and velocity 0).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResponseSpectrum {
    pub damping: f64,
    /// Periods, s (first entry 0).
    pub periods_s: Vec<f64>,
    /// Spectral displacement max|u|, m.
    pub sd_m: Vec<f64>,
    /// Pseudo-velocity ω·SD, m/s.
    pub psv_m_per_s: Vec<f64>,
    /// Pseudo-acceleration ω²·SD, m/s².
    pub psa_m_per_s2: Vec<f64>,
    /// Peak absolute acceleration max|ü + a_g|, m/s².
    pub sa_abs_m_per_s2: Vec<f64>,
}

/// Response spectrum over `periods` (positive, s) for damping ratio
/// `damping` (e.g. 0.05), periods computed in parallel.
pub fn response_spectrum(
    ground_acceleration: &[f64],
    dt: f64,
    periods: &[f64],
    damping: f64,
) -> Result<ResponseSpectrum> {
    for &t in periods {
        check_inputs(dt, t, damping)?;
    }
    let pga = ground_acceleration
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let omegas: Vec<f64> = periods
        .iter()
        .map(|&t| 2.0 * std::f64::consts::PI / t)
        .collect();
    let peaks: Vec<(f64, f64, f64)> = omegas
        .par_chunks(LANES)
        .flat_map_iter(|w| sdof_peaks_lanes(ground_acceleration, dt, w, damping))
        .collect();
    let mut s = ResponseSpectrum {
        damping,
        periods_s: vec![0.0],
        sd_m: vec![0.0],
        psv_m_per_s: vec![0.0],
        psa_m_per_s2: vec![pga],
        sa_abs_m_per_s2: vec![pga],
    };
    for (&t, &(du, _dv, da)) in periods.iter().zip(&peaks) {
        let omega = 2.0 * std::f64::consts::PI / t;
        s.periods_s.push(t);
        s.sd_m.push(du);
        s.psv_m_per_s.push(omega * du);
        s.psa_m_per_s2.push(omega * omega * du);
        s.sa_abs_m_per_s2.push(da);
    }
    Ok(s)
}
