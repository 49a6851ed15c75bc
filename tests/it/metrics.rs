//! Strong-motion metrics against closed forms and an independent
//! high-resolution integration.

use quaketwin::conditioning::Motion;
use quaketwin::metrics::{
    arias_intensity, cumulative_absolute_velocity, default_periods, interstorey_drift,
    interstorey_drifts, peak_abs, response_spectrum, sdof_response, significant_duration,
    strong_motion_metrics, MetricsSettings,
};
use quaketwin::vocab::STANDARD_GRAVITY;

const PI: f64 = std::f64::consts::PI;

fn sine(amp: f64, freq: f64, duration: f64, dt: f64) -> Vec<f64> {
    let n = (duration / dt).round() as usize + 1;
    (0..n)
        .map(|i| amp * (2.0 * PI * freq * i as f64 * dt).sin())
        .collect()
}

/// Steady-state amplitude of a 5 %-damped oscillator (T = 1 s) under a
/// harmonic ground acceleration A sin(Ωt), Ω = 2π·0.8 rad/s:
/// |u| = A / sqrt((ω² − Ω²)² + (2ζωΩ)²). Measured over the last 20 s of
/// 120 s (transient decayed by e^{−ζω·100} ≈ 2e−14); tolerance 1e-3
/// relative (sampling of the peak and linear interpolation of the sine at
/// dt = 0.01 s each cost ~1e-4).
#[test]
fn harmonic_steady_state_matches_closed_form() {
    let (amp, f_in, dt, damping, period) = (1.5, 0.8, 0.01, 0.05, 1.0);
    let a = sine(amp, f_in, 120.0, dt);
    let (u, v) = sdof_response(&a, dt, period, damping).unwrap();
    let (w, big_w) = (2.0 * PI / period, 2.0 * PI * f_in);
    let expected_u =
        amp / ((w * w - big_w * big_w).powi(2) + (2.0 * damping * w * big_w).powi(2)).sqrt();
    let tail = a.len() - 2000;
    let got_u = peak_abs(&u[tail..]);
    let got_v = peak_abs(&v[tail..]);
    assert!(
        (got_u / expected_u - 1.0).abs() < 1e-3,
        "u {got_u} vs {expected_u}"
    );
    assert!(
        (got_v / (expected_u * big_w) - 1.0).abs() < 1e-3,
        "v {got_v} vs {}",
        expected_u * big_w
    );
}

/// The Nigam–Jennings recurrence is exact for piecewise-linear input:
/// compare with classical RK4 using 400 sub-steps per sample on the same
/// piecewise-linear ground motion (RK4 error ~ (ω h)^4 ≈ 1e-12 here).
#[test]
fn recurrence_equals_fine_rk4_on_piecewise_linear_input() {
    let dt = 0.02;
    let n = 500;
    let a: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 * dt;
            (2.0 * PI * 1.3 * t).sin() * (-0.2 * t).exp()
                + 0.5 * (2.0 * PI * 3.7 * t + 0.4).cos()
                + if i % 7 == 0 { 0.3 } else { 0.0 }
        })
        .collect();
    for &(period, damping) in &[(0.3, 0.05), (1.0, 0.02), (0.05, 0.1), (2.0, 0.0)] {
        let (u, v) = sdof_response(&a, dt, period, damping).unwrap();
        let w = 2.0 * PI / period;
        let sub = 400;
        let h = dt / sub as f64;
        let (mut x, mut xd) = (0.0f64, 0.0f64);
        let mut worst_u: f64 = 0.0;
        let mut worst_v: f64 = 0.0;
        for i in 0..n - 1 {
            let ag = |tau: f64| a[i] + (a[i + 1] - a[i]) * tau / dt;
            let f = |tau: f64, x: f64, xd: f64| (xd, -ag(tau) - 2.0 * damping * w * xd - w * w * x);
            for s in 0..sub {
                let t0 = s as f64 * h;
                let (k1x, k1v) = f(t0, x, xd);
                let (k2x, k2v) = f(t0 + h / 2.0, x + h / 2.0 * k1x, xd + h / 2.0 * k1v);
                let (k3x, k3v) = f(t0 + h / 2.0, x + h / 2.0 * k2x, xd + h / 2.0 * k2v);
                let (k4x, k4v) = f(t0 + h, x + h * k3x, xd + h * k3v);
                x += h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
                xd += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
            }
            worst_u = worst_u.max((x - u[i + 1]).abs());
            worst_v = worst_v.max((xd - v[i + 1]).abs());
        }
        let (su, sv) = (peak_abs(&u), peak_abs(&v));
        assert!(
            worst_u / su < 1e-8 && worst_v / sv < 1e-8,
            "T={period} ζ={damping}: rel err u {:.2e} v {:.2e}",
            worst_u / su,
            worst_v / sv
        );
    }
}

#[test]
fn spectrum_structure_and_limits() {
    let dt = 0.005;
    let a = sine(2.0, 1.0, 20.0, dt);
    let periods = default_periods();
    assert_eq!(periods.len(), 100);
    assert!((periods[0] - 0.01).abs() < 1e-15 && (periods[99] - 10.0).abs() < 1e-12);
    let s = response_spectrum(&a, dt, &periods, 0.05).unwrap();
    assert_eq!(s.periods_s.len(), 101);
    assert_eq!(s.periods_s[0], 0.0);
    assert_eq!(s.psa_m_per_s2[0], peak_abs(&a));
    for i in 1..101 {
        let w = 2.0 * PI / s.periods_s[i];
        assert!((s.psa_m_per_s2[i] - w * w * s.sd_m[i]).abs() <= 1e-12 * s.psa_m_per_s2[i]);
        assert!((s.psv_m_per_s[i] - w * s.sd_m[i]).abs() <= 1e-12 * s.psv_m_per_s[i]);
    }
    // A stiff oscillator (T = 0.01 s) follows a 1 Hz ground motion: PSA ≈ PGA
    // (quasi-static, amplification 1/(1 − (Ω/ω)²) − 1 ≈ 1e-4).
    assert!(
        (s.psa_m_per_s2[1] / 2.0 - 1.0).abs() < 2e-3,
        "{}",
        s.psa_m_per_s2[1]
    );
    assert!(response_spectrum(&a, dt, &[0.5], 1.0).is_err());
    assert!(response_spectrum(&a, dt, &[0.0], 0.05).is_err());
}

/// Constant-amplitude sine A sin(2πft) over whole cycles:
/// Ia = π/(2g)·A²·T/2 (trapezoid exact for a periodic integrand), CAV = 2AT/π, and the Husid curve
/// H(t) ∝ t/2 − sin(4πft)/(8πf) gives D5–95 by solving H = 0.05 and 0.95.
#[test]
fn arias_cav_and_significant_duration_of_a_sine() {
    let (amp, f, dur, dt) = (3.0, 2.0, 10.0, 0.001);
    let a = sine(amp, f, dur, dt);
    let ia = arias_intensity(&a, dt);
    let ia_exact = PI / (2.0 * STANDARD_GRAVITY) * amp * amp * dur / 2.0;
    assert!((ia / ia_exact - 1.0).abs() < 1e-6, "Ia {ia} vs {ia_exact}");
    let cav = cumulative_absolute_velocity(&a, dt);
    // The trapezoid rule on |sin| with samples on the zero crossings has the
    // exact factor (ωdt/2)·cot(ωdt/2) ≈ 1 − (ωdt)²/12 (1.3e-5 here).
    let half = PI * f * dt;
    let cav_exact = 2.0 * amp * dur / PI;
    let cav_trapezoid = cav_exact * half / half.tan();
    assert!(
        (cav / cav_trapezoid - 1.0).abs() < 1e-9,
        "CAV {cav} vs {cav_trapezoid}"
    );
    assert!(
        (cav / cav_exact - 1.0).abs() < 2e-5,
        "CAV {cav} vs {cav_exact}"
    );
    let husid = |t: f64| (t / 2.0 - (4.0 * PI * f * t).sin() / (8.0 * PI * f)) / (dur / 2.0);
    let solve = |level: f64| {
        let (mut lo, mut hi) = (0.0, dur);
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if husid(mid) < level {
                lo = mid
            } else {
                hi = mid
            }
        }
        0.5 * (lo + hi)
    };
    let (d, start) = significant_duration(&a, dt, 0.05, 0.95).unwrap();
    let (t5, t95) = (solve(0.05), solve(0.95));
    assert!((start - t5).abs() < 1e-4, "t5 {start} vs {t5}");
    assert!((d - (t95 - t5)).abs() < 1e-4, "D5-95 {d} vs {}", t95 - t5);
    assert!(significant_duration(&a, dt, 0.95, 0.05).is_err());
}

#[test]
fn interstorey_drift_ratios() {
    let n = 1000;
    let lower: Vec<f64> = (0..n).map(|i| (i as f64 * 0.01).sin()).collect();
    let upper: Vec<f64> = lower.iter().map(|v| 2.0 * v + 0.01).collect();
    // max |upper − lower| = max |sin + 0.01| = 1.01 (sin reaches 1 at i ≈ 157).
    let r = interstorey_drift(&lower, &upper, 3.0).unwrap();
    let expected = lower.iter().fold(0.0f64, |m, v| m.max((v + 0.01).abs())) / 3.0;
    assert!((r - expected).abs() < 1e-15, "{r} vs {expected}");
    assert!((r - 1.01 / 3.0).abs() < 1e-4);
    assert!(interstorey_drift(&lower, &upper, 0.0).is_err());
    assert!(interstorey_drift(&lower, &upper[..10], 3.0).is_err());
    let base = vec![0.0; n];
    let drifts = interstorey_drifts(&[&base, &lower, &upper], &[4.0, 3.0]).unwrap();
    assert_eq!(drifts.len(), 2);
    assert!((drifts[0] - peak_abs(&lower) / 4.0).abs() < 1e-15 && drifts[1] == r);
    assert!(interstorey_drifts(&[&base, &lower], &[4.0, 3.0]).is_err());
}

#[test]
fn channel_metrics_from_motion() {
    let dt = 0.01;
    let (amp, f) = (0.5, 1.0);
    let w = 2.0 * PI * f;
    let n = 2001;
    let t = |i: usize| i as f64 * dt;
    let motion = Motion {
        channel_id: "F3X".into(),
        dt,
        acceleration: (0..n).map(|i| -amp * w * w * (w * t(i)).sin()).collect(),
        velocity: (0..n).map(|i| amp * w * (w * t(i)).cos()).collect(),
        displacement: (0..n).map(|i| amp * (w * t(i)).sin()).collect(),
    };
    let m = strong_motion_metrics(&motion, &MetricsSettings::default()).unwrap();
    assert_eq!(m.channel_id, "F3X");
    assert!((m.pga_m_per_s2 / (amp * w * w) - 1.0).abs() < 1e-3);
    assert_eq!(m.pgv_m_per_s, amp * w);
    assert!((m.pgd_m / amp - 1.0).abs() < 1e-3);
    assert_eq!(m.spectrum.periods_s.len(), 101);
    assert!((m.arias_m_per_s - arias_intensity(&motion.acceleration, dt)).abs() == 0.0);
    assert!(m.d5_95_s > 17.0 && m.d5_95_s < 19.0);
}

// Residual drift (metrics::residual): a storey that moves to a permanent
// offset D while it rings down, recorded as relative acceleration.

/// d(t) = D·S((t − 3)/5) + 0.03·E(t)·sin(2π 1.7 t): S a smoothstep (0 → 1),
/// E a smooth onset times a 1 %-damped decay, so d(0) = ḋ(0) = 0 and the
/// offset builds up while the storey still rings strongly (95 % of the
/// Arias intensity at ≈ 14 s, as in an earthquake); the acceleration is d̈
/// in closed form, sampled at `dt` for `duration` s.
fn storey_acceleration(offset: f64, dt: f64, duration: f64) -> Vec<f64> {
    let n = (duration / dt).round() as usize + 1;
    let w = 2.0 * PI * 1.7;
    let decay = 0.01 * w;
    // smoothstep s(u) = 3u² − 2u³ on [0, 1]: s'' = (6 − 12u)/L² inside.
    let step2 = |t: f64, start: f64, len: f64| {
        let u = (t - start) / len;
        if (0.0..=1.0).contains(&u) {
            (6.0 - 12.0 * u) / (len * len)
        } else {
            0.0
        }
    };
    let step = |t: f64, start: f64, len: f64| {
        let u = ((t - start) / len).clamp(0.0, 1.0);
        3.0 * u * u - 2.0 * u * u * u
    };
    let step1 = |t: f64, start: f64, len: f64| {
        let u = (t - start) / len;
        if (0.0..=1.0).contains(&u) {
            (6.0 * u - 6.0 * u * u) / len
        } else {
            0.0
        }
    };
    (0..n)
        .map(|i| {
            let t = i as f64 * dt;
            // Ringing: g(t) = s(t/4) e^{−decay t} sin(w t), differentiated twice.
            let (s0, s1, s2) = (step(t, 0.0, 4.0), step1(t, 0.0, 4.0), step2(t, 0.0, 4.0));
            let e = (-decay * t).exp();
            let (sn, cs) = ((w * t).sin(), (w * t).cos());
            let h0 = e * sn;
            let h1 = e * (w * cs - decay * sn);
            let h2 = e * ((decay * decay - w * w) * sn - 2.0 * decay * w * cs);
            let ring = 0.03 * (s2 * h0 + 2.0 * s1 * h1 + s0 * h2);
            offset * step2(t, 3.0, 5.0) + ring
        })
        .collect()
}

#[test]
fn residual_drift_recovers_a_permanent_offset_and_removes_an_acceleration_offset() {
    use quaketwin::metrics::residual::residual_drift_of;
    let dt = 0.005;
    for offset in [0.0, -0.02, 0.035] {
        let clean = storey_acceleration(offset, dt, 60.0);
        let r = residual_drift_of(&clean, dt).unwrap();
        assert!(
            (r.drift_m - offset).abs() < 5e-4,
            "clean record: D = {} vs {offset}",
            r.drift_m
        );
        // A sensor offset of 2 mm/s² would integrate to 3.6 m at 60 s; the
        // post-event fit takes it out.
        let shifted: Vec<f64> = clean.iter().map(|a| a + 0.002).collect();
        let naive = quaketwin::numeric::cumulative_trapezoid(
            &quaketwin::numeric::cumulative_trapezoid(&shifted, dt),
            dt,
        );
        assert!((naive.last().unwrap() - offset).abs() > 1.0);
        let r = residual_drift_of(&shifted, dt).unwrap();
        assert!(
            (r.drift_m - offset).abs() < 2e-3,
            "offset record: D = {} vs {offset}",
            r.drift_m
        );
        assert!((r.offset_m_s2 - 0.002).abs() < 1e-4, "{}", r.offset_m_s2);
        if offset != 0.0 {
            assert!(r.resolved(), "{r:?}");
        }
    }
}

/// Broadband sensor noise integrated twice wanders like a permanent offset;
/// the estimate's σ says so: pure noise is not resolved, and σ is of the
/// size of the scatter of D over independent noise records.
#[test]
fn residual_drift_of_noise_is_not_resolved() {
    use quaketwin::metrics::residual::residual_drift_of;
    let (dt, n) = (0.005, 9000);
    let mut estimates = Vec::new();
    for seed in 0..12 {
        let mut rng = quaketwin::rng::Rng::new(seed);
        let noise: Vec<f64> = (0..n).map(|_| 0.01 * rng.normal()).collect();
        let r = residual_drift_of(&noise, dt).unwrap();
        assert!(!r.resolved(), "seed {seed}: {r:?}");
        estimates.push(r);
    }
    let rms =
        (estimates.iter().map(|r| r.drift_m.powi(2)).sum::<f64>() / estimates.len() as f64).sqrt();
    let sigma = estimates.iter().map(|r| r.std_m).sum::<f64>() / estimates.len() as f64;
    assert!(
        rms < sigma && sigma < 20.0 * rms,
        "scatter of D {rms} against the mean σ {sigma}"
    );
}
