//! Anomaly band of a tracked frequency (docs/monitoring.md, Eqs. M1–M5).
//!
//! A monitored frequency moves with temperature and with the ambient level
//! (amplitude-dependent stiffness) every day; damage shows as a departure
//! from what those variables predict.  The only variables an archive of
//! accelerations carries are the window's RMS level and its time, so the
//! model regresses the frequency on the RMS level and one harmonic of the
//! time of day (the daily temperature cycle's proxy):
//!
//! (M1) f_w = β₀ + β₁ z_w + β₂ sin(2π h_w / P) + β₃ cos(2π h_w / P) + ε_w,
//!      z_w = (r_w − r̄) / s_r, the RMS level r_w standardised over the
//!      training windows, h_w the UTC time of day of the window's middle, P
//!      the cycle's period (24 h);
//! (M2) β̂ = (XᵀX)⁻¹ Xᵀ f, s² = ‖f − X β̂‖² / (n − p), fitted on the training
//!      windows (by default the first 24 h) where the mode was found;
//! (M3) the 99 % prediction interval of a new window x₀:
//!      f̂₀ ± t_{0.995, n−p} · s · √(1 + x₀ᵀ (XᵀX)⁻¹ x₀);
//! (M4) a window is flagged when its frequency lies outside (M3);
//! (M5) a window is anomalous when at least half of the modes with a band
//!      that were found in it are flagged; a run of at least `min_run`
//!      consecutive anomalous windows (windows without modes neither break
//!      nor extend it) after the training period is an anomaly from the
//!      run's first window.
//!
//! With too few training windows for four coefficients (n < p + 3) the
//! harmonic is dropped (p = 2), and with fewer than four no band is given.

use crate::stats::LinearFit;

/// Settings of the band.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct BandSettings {
    /// Windows starting before this time (ns) train the model.
    pub training_end_ns: i64,
    /// Period of the environmental cycle P, s (86 400).
    pub cycle_period_s: f64,
    /// Two-sided probability of the prediction interval (0.99).
    pub confidence: f64,
    /// Anomalous windows in a row that make an anomaly (M5).
    pub min_run: usize,
}

/// One observation: a tracked frequency in a window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    pub start_ns: i64,
    pub end_ns: i64,
    pub rms: f64,
    pub frequency_hz: f64,
}

/// The fitted model of one mode (M1–M2).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BandModel {
    /// Names of the regressors, in the order of `coefficients`.
    pub regressors: Vec<&'static str>,
    pub coefficients: Vec<f64>,
    /// Residual standard deviation s, Hz.
    pub residual_std_hz: f64,
    pub training_windows: usize,
    /// t_{(1+confidence)/2, n−p}.
    pub t_quantile: f64,
    rms_mean: f64,
    rms_std: f64,
    cycle_period_s: f64,
    #[serde(skip)]
    fit: LinearFit,
}

/// The band of one window (M3) and whether its frequency lies outside (M4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Band {
    pub predicted_hz: f64,
    pub low_hz: f64,
    pub high_hz: f64,
    pub flagged: bool,
}

impl BandModel {
    fn regressors_of(&self, o: &Observation) -> Vec<f64> {
        regressors(
            o,
            self.rms_mean,
            self.rms_std,
            self.cycle_period_s,
            self.coefficients.len(),
        )
    }

    /// The band at `o` and the flag of its frequency (M3, M4).
    pub fn band(&self, o: &Observation) -> Band {
        let x = self.regressors_of(o);
        let predicted = self.fit.predict(&x);
        let half = self.fit.prediction_half_width(&x, self.t_quantile);
        Band {
            predicted_hz: predicted,
            low_hz: predicted - half,
            high_hz: predicted + half,
            flagged: o.frequency_hz < predicted - half || o.frequency_hz > predicted + half,
        }
    }
}

/// Time of day of the window's middle as an angle of the cycle, radians.
fn cycle_angle(o: &Observation, period_s: f64) -> f64 {
    let mid_s = (o.start_ns as f64 + 0.5 * (o.end_ns - o.start_ns) as f64) * 1e-9;
    std::f64::consts::TAU * (mid_s.rem_euclid(period_s) / period_s)
}

/// The first `p` regressors of M1 at `o`: 1, z, sin, cos.
fn regressors(o: &Observation, rms_mean: f64, rms_std: f64, period_s: f64, p: usize) -> Vec<f64> {
    let z = if rms_std > 0.0 {
        (o.rms - rms_mean) / rms_std
    } else {
        0.0
    };
    let a = cycle_angle(o, period_s);
    [1.0, z, a.sin(), a.cos()][..p].to_vec()
}

/// Fits M1–M2 on the observations of the training period; `None` when
/// fewer than four windows train it (module doc).
pub fn fit(observations: &[Observation], settings: &BandSettings) -> Option<BandModel> {
    let train: Vec<&Observation> = observations
        .iter()
        .filter(|o| o.start_ns < settings.training_end_ns && o.rms.is_finite())
        .collect();
    let n = train.len();
    if n < 4 {
        return None;
    }
    let rms_mean = train.iter().map(|o| o.rms).sum::<f64>() / n as f64;
    let rms_std = (train
        .iter()
        .map(|o| (o.rms - rms_mean).powi(2))
        .sum::<f64>()
        / (n - 1) as f64)
        .sqrt();
    let p = if n >= 4 + 3 { 4 } else { 2 };
    let names = [
        "intercept",
        "rms_standardised",
        "sin_time_of_day",
        "cos_time_of_day",
    ];
    let x: Vec<Vec<f64>> = train
        .iter()
        .map(|o| regressors(o, rms_mean, rms_std, settings.cycle_period_s, p))
        .collect();
    let y: Vec<f64> = train.iter().map(|o| o.frequency_hz).collect();
    let fit = LinearFit::fit(&x, &y)?;
    Some(BandModel {
        regressors: names[..p].to_vec(),
        coefficients: fit.coefficients.clone(),
        residual_std_hz: fit.residual_std,
        training_windows: n,
        t_quantile: fit.t_quantile(settings.confidence),
        rms_mean,
        rms_std,
        cycle_period_s: settings.cycle_period_s,
        fit,
    })
}

/// M5: the index (into `anomalous`, one entry per window in time order:
/// `Some(is_anomalous)` for windows with bands, `None` for windows without
/// modes) of the first window of the first run of at least `min_run`
/// anomalous windows among those with `eligible[i]` (after training).
pub fn anomaly_onset(
    anomalous: &[Option<bool>],
    eligible: &[bool],
    min_run: usize,
) -> Option<usize> {
    let mut run_start: Option<usize> = None;
    let mut run = 0usize;
    for (i, a) in anomalous.iter().enumerate() {
        if !eligible[i] {
            continue;
        }
        match a {
            None => {}
            Some(true) => {
                if run == 0 {
                    run_start = Some(i);
                }
                run += 1;
                if run >= min_run.max(1) {
                    return run_start;
                }
            }
            Some(false) => run = 0,
        }
    }
    None
}
