//! Environmental compensation of a tracking run (`quaketwin track`,
//! docs/statistics.md "Environmental compensation", Eqs. E1–E6): the
//! control chart of [`super::environment`] fitted on the run's training
//! windows and applied to every window, and the residual band per mode.
//!
//! A window is *charted* when every reference mode was tracked in it (and,
//! with a measured series, the series covers it).  Training: the charted
//! windows that start before the training end (the anomaly band's).
//! Subgroups (E3): consecutive blocks of `subgroup` windows of the run's
//! grid, counted from the first window after training (and backwards from
//! it over the training period), so that no subgroup mixes the two; a
//! subgroup's statistic uses its charted windows, none = not charted.
//!
//! (E6) residual band of mode j: the window is flagged when
//!      |e_{j,w} − ē_j| > t_{0.995, n−1} · s_j, with ē_j, s_j the mean and
//!      standard deviation of the mode's residual over the n training
//!      windows — Eq. M4's band on what the environment does not explain.

use super::environment::{ChartSettings, Compensation, ControlChart, EnvironmentSeries};
use super::tracking::TrackedMode;
use super::WindowModes;
use crate::stats::student_t_upper_quantile;

/// One subgroup of the chart (E3–E4).
#[derive(Debug, Clone, PartialEq)]
pub struct Subgroup {
    /// First window (index into the run's windows) and one past the last.
    pub first: usize,
    pub end: usize,
    pub start_ns: i64,
    pub end_ns: i64,
    /// Charted windows in it.
    pub charted: usize,
    pub training: bool,
    /// T²_g (E3); `None` when no window of it is charted.
    pub statistic: Option<f64>,
    /// P(T² ≥ T²_g) in the training state: T²(k, n − 1 − p) of (E3).
    pub p_value: Option<f64>,
    /// Above the threshold (E4); `None` for training or uncharted subgroups.
    pub out_of_control: Option<bool>,
}

/// The compensation of a run: the fitted chart (or why there is none),
/// per window the environment, per row the residual and its band.
#[derive(Debug, Clone, Default)]
pub struct RunCompensation {
    pub chart: Option<ControlChart>,
    /// `measured` (E1) or `latent` (E2); empty without a chart.
    pub model: String,
    /// Where the measured series came from (E1), if any.
    pub source: Option<String>,
    /// Per window: the measured value over it.
    pub environment: Vec<Option<f64>>,
    /// Per tracked row: e_{j,w} of its mode (E1/E2), relative.
    pub residuals: Vec<Option<f64>>,
    /// Per tracked row: outside the residual band (E6).
    pub residual_flagged: Vec<Option<bool>>,
    /// Per mode: the half-width t · s_j of (E6).
    pub residual_half_width: Vec<Option<f64>>,
    pub subgroups: Vec<Subgroup>,
    /// Index into `subgroups` of the first alarm (E5).
    pub alarm_from: Option<usize>,
    /// Warnings for the user (training too short, extrapolation).
    pub warnings: Vec<String>,
}

/// Fits and applies the compensation (module doc).  `modes`: the number of
/// reference modes; `subgroup`: windows per subgroup (a cycle's worth).
pub fn compensate(
    windows: &[WindowModes],
    rows: &[TrackedMode],
    modes: usize,
    training_end_ns: i64,
    environment: Option<&EnvironmentSeries>,
    settings: &ChartSettings,
) -> RunCompensation {
    let mut out = RunCompensation {
        environment: windows
            .iter()
            .map(|w| environment.and_then(|e| e.over(w.start_ns, w.end_ns)))
            .collect(),
        residuals: vec![None; rows.len()],
        residual_flagged: vec![None; rows.len()],
        residual_half_width: vec![None; modes],
        source: environment.map(|e| e.source.clone()),
        ..Default::default()
    };
    // Per window: the frequencies of all modes, when every one was tracked.
    let mut found: Vec<Vec<Option<f64>>> = vec![vec![None; modes]; windows.len()];
    for r in rows {
        found[r.window][r.mode_id - 1] = Some(r.frequency_hz);
    }
    let charted: Vec<Option<Vec<f64>>> = found
        .iter()
        .zip(&out.environment)
        .map(|(f, env)| {
            let all: Option<Vec<f64>> = f.iter().copied().collect();
            all.filter(|_| environment.is_none() || env.is_some())
        })
        .collect();
    let training: Vec<usize> = (0..windows.len())
        .filter(|&w| windows[w].start_ns < training_end_ns && charted[w].is_some())
        .collect();
    let train_f: Vec<Vec<f64>> = training
        .iter()
        .filter_map(|&w| charted[w].clone())
        .collect();
    let train_env: Option<Vec<f64>> = environment.map(|_| {
        training
            .iter()
            .filter_map(|&w| out.environment[w])
            .collect()
    });
    let w = settings.subgroup.max(1);
    if train_f.len() < 2 * w {
        out.warnings.push(format!(
            "environmental compensation: the training period holds {} windows with all {modes} modes{}, fewer than two subgroups of {w}: the chart's covariance is poorly estimated (lengthen --training; a few weeks that span the environment's range are best)",
            train_f.len(),
            if environment.is_some() { " and a measured value" } else { "" }
        ));
    }
    let chart = match ControlChart::fit(&train_f, train_env.as_deref(), settings) {
        Ok(c) => c,
        Err(e) => {
            out.warnings.push(format!(
                "environmental compensation: no control chart: {e} (lengthen --training)"
            ));
            return out;
        }
    };
    if let (Some(series), Some(t)) = (environment, &train_env) {
        let range = |v: &mut dyn Iterator<Item = f64>| {
            v.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                (a.min(x), b.max(x))
            })
        };
        let (t0, t1) = range(&mut t.iter().copied());
        let (a0, a1) = range(&mut out.environment.iter().flatten().copied());
        if a0 < t0 - 0.5 * (t1 - t0) || a1 > t1 + 0.5 * (t1 - t0) {
            out.warnings.push(format!(
                "environmental compensation: {} spans {t0:.3} … {t1:.3} over the training windows but {a0:.3} … {a1:.3} over the run: the regression (E1) extrapolates; train over the environment's range",
                series.source
            ));
        }
    }
    out.model = match chart.compensation {
        Compensation::Measured { .. } => "measured".into(),
        Compensation::Latent { .. } => "latent".into(),
    };
    // Residuals of every charted window, and the band of (E6).
    let residual: Vec<Option<Vec<f64>>> = charted
        .iter()
        .zip(&out.environment)
        .map(|(f, env)| f.as_ref().map(|f| chart.residual(f, *env)))
        .collect();
    let n = training.len() as f64;
    let t = student_t_upper_quantile(0.005, n - 1.0);
    let stats: Vec<(f64, f64)> = (0..modes)
        .map(|j| {
            let e: Vec<f64> = training
                .iter()
                .filter_map(|&w| residual[w].as_ref().map(|r| r[j]))
                .collect();
            let mean = e.iter().sum::<f64>() / n;
            let var = e.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
            (mean, var.sqrt())
        })
        .collect();
    out.residual_half_width = stats.iter().map(|&(_, s)| Some(t * s)).collect();
    for (k, r) in rows.iter().enumerate() {
        if let Some(e) = &residual[r.window] {
            let (mean, s) = stats[r.mode_id - 1];
            let v = e[r.mode_id - 1];
            out.residuals[k] = Some(v);
            out.residual_flagged[k] = Some((v - mean).abs() > t * s);
        }
    }
    // Subgroups aligned on the first window after training (module doc).
    let first_after = windows
        .iter()
        .position(|x| x.start_ns >= training_end_ns)
        .unwrap_or(windows.len());
    let mut bounds: Vec<usize> = (0..=first_after).rev().step_by(w).collect();
    bounds.reverse();
    if bounds.first() != Some(&0) {
        bounds.insert(0, 0);
    }
    bounds.extend((first_after + w..windows.len()).step_by(w));
    if bounds.last() != Some(&windows.len()) {
        bounds.push(windows.len());
    }
    for pair in bounds.windows(2).filter(|p| p[1] > p[0]) {
        let (a, b) = (pair[0], pair[1]);
        let members: Vec<(&[f64], Option<f64>)> = (a..b)
            .filter_map(|i| charted[i].as_deref().map(|f| (f, out.environment[i])))
            .collect();
        let test = (!members.is_empty()).then(|| chart.test(&members));
        let statistic = test.map(|t| t.statistic);
        let is_training = b <= first_after;
        out.subgroups.push(Subgroup {
            first: a,
            end: b,
            start_ns: windows[a].start_ns,
            end_ns: windows[b - 1].end_ns,
            charted: members.len(),
            training: is_training,
            statistic,
            p_value: test.map(|t| t.p_value),
            out_of_control: statistic
                .filter(|_| !is_training)
                .map(|s| s > chart.threshold),
        });
    }
    let flags: Vec<Option<bool>> = out.subgroups.iter().map(|g| g.out_of_control).collect();
    let eligible: Vec<bool> = out.subgroups.iter().map(|g| !g.training).collect();
    out.alarm_from = super::environment::alarm_onset(&flags, &eligible, settings.min_run);
    out.chart = Some(chart);
    out
}
