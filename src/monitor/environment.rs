//! Environmental compensation of tracked frequencies and the control chart
//! on what is left (docs/monitoring.md "Environmental compensation",
//! docs/statistics.md Eqs. E1–E5).
//!
//! A frequency follows temperature (a few per cent a year in concrete and
//! steel frames): without compensation the band of Eqs. M1–M5, trained on
//! one day, flags every season.  Two models remove it, fitted on the
//! training windows where every compensated mode was found:
//!
//! (E1) measured temperature T_w (the mean of a series over the window):
//!      per mode j, the squared relative frequency y_{j,w} = (f_{j,w}/f̄_j)²
//!      − 1 (f² ∝ stiffness, which is linear in T where f = √k is not) on
//!      T: y_{j,w} = β_{j0} + β_{j1} T_w + ε_{j,w} (least squares,
//!      [`crate::stats::LinearFit`]); r_{j,w} = ½ (y − ŷ) (≈ the relative
//!      frequency residual); then, unless `project_temperature` is off, the
//!      component along the temperature direction u = β_1/‖β_1‖ is removed,
//!      e_w = (I − u uᵀ) r_w.  Why: trained on a few weeks of one season the
//!      fit extrapolates its slope (and any curvature, and the bias the
//!      sensor's noise puts on the slope) to the other seasons, and those
//!      errors lie along u; what the temperature cannot explain across the
//!      modes is left.  Rank of the residual: m − 1 (m without projection).
//! (E2) nothing measured: the latent-variable model of Yan, Kerschen, De Boe
//!      & Golinval (2005, *Structural damage diagnosis under varying
//!      environmental conditions — Part I: a linear analysis*, MSSP 19):
//!      z_w = (f_w − f̄)/f̄ (relative deviations of the m modes); the first q
//!      principal directions U_q of the training z (their covariance's
//!      eigenvectors) carry the environmental variation — a change of
//!      temperature moves all frequencies together — and the residual
//!      e_w = (I − U_q U_qᵀ) z_w is what they do not explain.  q: the
//!      directions that stand above the estimation noise — the i-th
//!      (eigenvalues descending) is kept while λ_i > `dominance` (5) × the
//!      mean of the smaller ones, at most m − 1.  (Yan et al. keep a share
//!      of the variance; a fixed share keeps noise directions when the
//!      environment moved little over the training period, and those can
//!      hold the damage.)
//! (E3) control chart on subgroups of w consecutive windows (w = 24: one
//!      day of hourly windows; w = 1: each window): Hotelling's
//!      T²_g = w (ē_g − ē)ᵀ S⁺ (ē_g − ē),
//!      ē_g the subgroup's mean residual, ē and S the n training residuals'
//!      mean and covariance (S truncated to its rank k: m − 1 for E1, m − q
//!      for E2).  Beside its own scatter, ē_g − ē carries the error of the
//!      fitted model — means, slopes (E1) or directions (E2) — which grows
//!      with the leverage h_g = (x̄_g − x̄)ᵀ (Σ_w (x_w − x̄)(x_w − x̄)ᵀ)⁻¹
//!      (x̄_g − x̄) of the subgroup's mean regressor x̄_g (E1: the measured
//!      value T; E2: the q latent scores u_iᵀ z) among the training
//!      windows' x_w: its whitened size is w (1/n + h_g) χ²-ish, the
//!      leverage term of the band's Eq. M3 (for E2 the principal
//!      directions' estimation error, ≈ σ²/(n λ) per direction, leaks the
//!      same way).  That error is drawn once, at training, and every later
//!      subgroup shares it.  [`TrainingError`] says how the chart treats it:
//!      - `Bounded` (default, confidence 1 − γ = 99 %): given the training,
//!        T²_g is non-central with λ_g = w b̃_gᵀ b̃_g, b̃_g the whitened bias;
//!        b̃_g = A c_g, A the k × (p + 1) whitened errors of the fitted
//!        intercepts and slopes (standard normal entries), |c_g|² = 1/n +
//!        h_g, so λ_g ≤ w (1/n + h_g) ‖A‖²_F and ‖A‖²_F ~ χ²_{k(p+1)}: with
//!        probability 1 − γ over trainings, for *every* subgroup at once,
//!        λ_g ≤ λ̄_g = w (1/n + h_g) χ²_{k(p+1)}(1 − γ).  The threshold of
//!        subgroup g is the upper α quantile of the non-central T²(k, n − 1
//!        − p, λ̄_g) (`stats::noncentral_hotelling_upper_quantile`), its
//!        p-value that distribution's survival (an upper bound of the
//!        conditional one); the reported T²_g is rescaled by
//!        threshold / that quantile, so that one threshold serves the chart.
//!        The conditional false-alarm rate is then ≤ α per subgroup for all
//!        but a share γ of trainings (the "guaranteed conditional
//!        performance" of Gandy & Kvaløy 2013, Scand. J. Statist. 40; the
//!        parameter-estimation effect on charts: Jensen et al. 2006, J.
//!        Qual. Technol. 38).
//!      - `Averaged`: the error as a random term of each subgroup, T²_g /
//!        (1 + w/n + w h_g) against T²(k, n − 1 − p): α per subgroup on
//!        average over trainings, but not for the one at hand — the shared
//!        error makes a year's false alarms come in bunches (a 1-in-300
//!        training: 6–14 in a year, docs/statistics.md "Synthetic year").
//!      - `Ignored`: T²_g / (1 + w/n) (h_g = 0): a chart trained in winter
//!        alarms all summer.
//!      Threshold: the upper α quantile of T²(k, n − 1 − p), Hotelling's T²
//!      with the covariance estimated on n − 1 − p degrees of freedom, p
//!      regressors (Montgomery, *Introduction to Statistical Quality
//!      Control*, the Phase II chart; `stats::hotelling_upper_quantile`).
//!      Why subgroups: a 1 % stiffness loss changes the frequencies by
//!      ~0.1 %, mostly along the environment's own direction; what the
//!      model leaves of it is one window's scatter, a day's mean brings it
//!      out (docs/statistics.md).
//! (E4) a subgroup is out of control when T²_g exceeds the threshold;
//! (E5) an alarm: at least `min_run` consecutive out-of-control subgroups
//!      after training, dated at the first.

use crate::error::{Error, Result};
use crate::stats::{
    chi2_upper_quantile, hotelling_survival, hotelling_upper_quantile,
    noncentral_hotelling_survival, noncentral_hotelling_upper_quantile, LinearFit,
};
use faer::{Mat, Side};

/// A measured environmental series (time, value), e.g. temperature.
#[derive(Debug, Clone, PartialEq)]
pub struct EnvironmentSeries {
    /// Sample times, ns, increasing.
    pub times_ns: Vec<i64>,
    pub values: Vec<f64>,
    /// Where it came from (file or channel).
    pub source: String,
}

impl EnvironmentSeries {
    /// Checks times increasing and values finite (else a usage error naming `source`).
    pub fn new(mut pairs: Vec<(i64, f64)>, source: &str) -> Result<Self> {
        pairs.sort_by_key(|p| p.0);
        if pairs.is_empty() {
            return Err(Error::usage(format!("{source}: no (time, value) pair")));
        }
        if let Some(p) = pairs.iter().find(|p| !p.1.is_finite()) {
            return Err(Error::usage(format!(
                "{source}: value {} is not finite",
                p.1
            )));
        }
        Ok(EnvironmentSeries {
            times_ns: pairs.iter().map(|p| p.0).collect(),
            values: pairs.iter().map(|p| p.1).collect(),
            source: source.to_string(),
        })
    }

    /// The value over [start, end): the mean of the samples inside, or the
    /// linear interpolation at the middle when none lies inside; `None`
    /// outside the series' span.
    pub fn over(&self, start_ns: i64, end_ns: i64) -> Option<f64> {
        let a = self.times_ns.partition_point(|&t| t < start_ns);
        let b = self.times_ns.partition_point(|&t| t < end_ns);
        if b > a {
            return Some(self.values[a..b].iter().sum::<f64>() / (b - a) as f64);
        }
        let mid = start_ns + (end_ns - start_ns) / 2;
        let i = self.times_ns.partition_point(|&t| t <= mid);
        if i == 0 || i == self.times_ns.len() {
            return None;
        }
        let (t0, t1) = (self.times_ns[i - 1], self.times_ns[i]);
        let w = (mid - t0) as f64 / (t1 - t0).max(1) as f64;
        Some(self.values[i - 1] + w * (self.values[i] - self.values[i - 1]))
    }
}

/// Which model removes the environment (module doc).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub enum Compensation {
    /// E1: per mode, (f/f̄)² − 1 on the measured series: (β₀, β₁).
    Measured {
        mean_hz: Vec<f64>,
        fits: Vec<(f64, f64)>,
        /// u of (E1) when the temperature direction is projected out.
        direction: Option<Vec<f64>>,
    },
    /// E2: principal directions of the training deviations.
    Latent {
        mean_hz: Vec<f64>,
        retained: usize,
        explained: f64,
        #[serde(skip)]
        directions: Vec<Vec<f64>>,
    },
}

/// The fitted compensation and its control chart (E1–E4).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ControlChart {
    pub compensation: Compensation,
    pub training_windows: usize,
    /// k of (E3).
    pub dof: usize,
    pub threshold: f64,
    pub false_alarm_rate: f64,
    /// w of (E3).
    pub subgroup: usize,
    #[serde(skip)]
    residual_mean: Vec<f64>,
    #[serde(skip)]
    whitening: Vec<Vec<f64>>,
    /// Degrees of freedom of S: n − 1 − p (E3).
    pub covariance_dof: usize,
    /// x̄ and (Σ (x − x̄)(x − x̄)ᵀ)⁻¹ of (E3); empty without leverage.
    #[serde(skip)]
    regressor_mean: Vec<f64>,
    #[serde(skip)]
    scatter_inverse: Vec<Vec<f64>>,
    pub training_error: TrainingError,
    /// χ²_{k(p+1)}(confidence) of [`TrainingError::Bounded`], else 0.
    pub training_error_bound: f64,
}

/// One subgroup's test (E3–E4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SubgroupTest {
    /// T²_g of (E3), on the scale of [`ControlChart::threshold`].
    pub statistic: f64,
    /// P(T² ≥ T²_g) in the training state (bounded: its upper bound).
    pub p_value: f64,
}

/// Settings of the chart.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ChartSettings {
    /// α of (E3) per window.
    pub false_alarm_rate: f64,
    /// How far above the mean of the smaller eigenvalues a latent
    /// direction's must be to be kept (E2).
    pub dominance: f64,
    /// Consecutive out-of-control subgroups that make an alarm (E5).
    pub min_run: usize,
    /// Windows per subgroup w (E3).
    pub subgroup: usize,
    /// Remove the temperature direction from the E1 residual (module doc).
    pub project_temperature: bool,
    /// How the error of the fitted model enters the chart (E3).
    pub training_error: TrainingError,
}

/// How (E3) accounts for the fitted model's error, which every subgroup
/// after training shares (module doc, "Why bounded").
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub enum TrainingError {
    /// Only the fitted means' (variance 1 + w/n; h_g = 0): a chart that
    /// ignores the extrapolation.
    Ignored,
    /// As a random error of each subgroup (variance 1 + w/n + w h_g): the
    /// false-alarm rate is α averaged over trainings, not for this one.
    Averaged,
    /// Bounded: the subgroup's non-centrality λ̄_g = w (1/n + h_g)
    /// χ²_{k(p+1)}(`confidence`); the threshold the upper α quantile of the
    /// non-central T²(k, n − 1 − p, λ̄_g): α per subgroup for every
    /// training but a share 1 − `confidence` of them.
    Bounded { confidence: f64 },
}

impl Default for ChartSettings {
    fn default() -> Self {
        ChartSettings {
            false_alarm_rate: 0.001,
            dominance: 5.0,
            min_run: 1,
            subgroup: 24,
            project_temperature: true,
            training_error: TrainingError::Bounded { confidence: 0.99 },
        }
    }
}

/// Mean of each column of `rows`.
fn column_means(rows: &[Vec<f64>]) -> Vec<f64> {
    let n = rows.len() as f64;
    (0..rows[0].len())
        .map(|j| rows.iter().map(|r| r[j]).sum::<f64>() / n)
        .collect()
}

/// (I − Σ d dᵀ) v for orthonormal directions d.
fn project_out(mut v: Vec<f64>, directions: &[Vec<f64>]) -> Vec<f64> {
    for d in directions {
        let c: f64 = d.iter().zip(&v).map(|(a, b)| a * b).sum();
        for (vi, di) in v.iter_mut().zip(d) {
            *vi -= c * di;
        }
    }
    v
}

fn symmetric_eigen(rows: &[Vec<f64>]) -> Result<(Vec<f64>, Mat<f64>)> {
    // Covariance of the rows (each an observation), eigenvalues ascending.
    let n = rows.len();
    let m = rows[0].len();
    let mean: Vec<f64> = (0..m)
        .map(|j| rows.iter().map(|r| r[j]).sum::<f64>() / n as f64)
        .collect();
    let c = Mat::<f64>::from_fn(m, m, |i, j| {
        rows.iter()
            .map(|r| (r[i] - mean[i]) * (r[j] - mean[j]))
            .sum::<f64>()
            / (n - 1) as f64
    });
    let evd = c
        .self_adjoint_eigen(Side::Lower)
        .map_err(|e| Error::numerical(format!("control chart: eigenvalues: {e:?}")))?;
    let lambda = evd.S().column_vector().iter().copied().collect();
    Ok((lambda, evd.U().to_owned()))
}

impl ControlChart {
    /// Fits on the training rows: `frequencies[w][j]` of mode j in window w
    /// (every mode found), `environment[w]` the measured value when E1.
    pub fn fit(
        frequencies: &[Vec<f64>],
        environment: Option<&[f64]>,
        settings: &ChartSettings,
    ) -> Result<ControlChart> {
        let n = frequencies.len();
        let m = frequencies.first().map_or(0, |r| r.len());
        if m == 0 || n < m + 5 {
            return Err(Error::numerical(format!(
                "control chart: {n} training windows with all {m} modes: at least {} needed",
                m + 5
            )));
        }
        let compensation = match environment {
            Some(t) => {
                let mean_hz = column_means(frequencies);
                let x: Vec<Vec<f64>> = t.iter().map(|&v| vec![1.0, v]).collect();
                let fits = (0..m)
                    .map(|j| {
                        let y: Vec<f64> = frequencies
                            .iter()
                            .map(|r| (r[j] / mean_hz[j]).powi(2) - 1.0)
                            .collect();
                        LinearFit::fit(&x, &y)
                            .map(|f| (f.coefficients[0], f.coefficients[1]))
                            .ok_or_else(|| {
                                Error::numerical(
                                    "control chart: the measured series does not vary over the training windows",
                                )
                            })
                    })
                    .collect::<Result<Vec<_>>>()?;
                let norm = fits.iter().map(|f| f.1 * f.1).sum::<f64>().sqrt();
                let direction = (settings.project_temperature && norm > 0.0)
                    .then(|| fits.iter().map(|f| f.1 / norm).collect());
                Compensation::Measured {
                    mean_hz,
                    fits,
                    direction,
                }
            }
            None => {
                let mean_hz = column_means(frequencies);
                let z: Vec<Vec<f64>> = frequencies
                    .iter()
                    .map(|r| r.iter().zip(&mean_hz).map(|(f, f0)| f / f0 - 1.0).collect())
                    .collect();
                let (lambda, u) = symmetric_eigen(&z)?;
                let total: f64 = lambda.iter().map(|v| v.max(0.0)).sum();
                let descending: Vec<f64> = lambda.iter().rev().map(|v| v.max(0.0)).collect();
                let mut retained = 0;
                while retained + 1 < m {
                    let rest = &descending[retained + 1..];
                    let floor = rest.iter().sum::<f64>() / rest.len() as f64;
                    if descending[retained] <= settings.dominance * floor {
                        break;
                    }
                    retained += 1;
                }
                let kept: f64 = descending[..retained].iter().sum();
                let directions = (0..retained)
                    .map(|r| (0..m).map(|i| u[(i, m - 1 - r)]).collect())
                    .collect();
                Compensation::Latent {
                    mean_hz,
                    retained,
                    explained: if total > 0.0 { kept / total } else { 0.0 },
                    directions,
                }
            }
        };
        let mut chart = ControlChart {
            compensation,
            training_windows: n,
            dof: 0,
            threshold: f64::NAN,
            false_alarm_rate: settings.false_alarm_rate,
            subgroup: 1,
            residual_mean: vec![0.0; m],
            whitening: Vec::new(),
            covariance_dof: 0,
            regressor_mean: Vec::new(),
            scatter_inverse: Vec::new(),
            training_error: settings.training_error,
            training_error_bound: 0.0,
        };
        let residuals: Vec<Vec<f64>> = frequencies
            .iter()
            .enumerate()
            .map(|(w, r)| chart.residual(r, environment.map(|t| t[w])))
            .collect();
        chart.residual_mean = (0..m)
            .map(|j| residuals.iter().map(|r| r[j]).sum::<f64>() / n as f64)
            .collect();
        let (lambda, u) = symmetric_eigen(&residuals)?;
        let max = lambda.iter().fold(0.0f64, |a, &v| a.max(v));
        let keep: Vec<usize> = (0..m).filter(|&i| lambda[i] > 1e-9 * max).collect();
        let k = keep.len();
        if k == 0 || n <= k + 1 {
            return Err(Error::numerical("control chart: the residuals do not vary"));
        }
        chart.whitening = keep
            .iter()
            .map(|&i| (0..m).map(|j| u[(j, i)] / lambda[i].sqrt()).collect())
            .collect();
        let x: Vec<Vec<f64>> = frequencies
            .iter()
            .enumerate()
            .map(|(w, r)| chart.regressors(r, environment.map(|t| t[w])))
            .collect();
        let p = x[0].len();
        if settings.training_error != TrainingError::Ignored && p > 0 {
            chart.regressor_mean = column_means(&x);
            let xm = &chart.regressor_mean;
            let scatter = nalgebra::DMatrix::<f64>::from_fn(p, p, |a, b| {
                x.iter().map(|r| (r[a] - xm[a]) * (r[b] - xm[b])).sum()
            });
            let inverse = scatter.try_inverse().ok_or_else(|| {
                Error::numerical(
                    "control chart: the environment does not vary over the training windows",
                )
            })?;
            chart.scatter_inverse = (0..p)
                .map(|a| (0..p).map(|b| inverse[(a, b)]).collect())
                .collect();
        }
        if n <= k + 1 + p {
            return Err(Error::numerical(
                "control chart: too few training windows for the residuals' covariance",
            ));
        }
        chart.dof = k;
        chart.covariance_dof = n - 1 - p;
        chart.subgroup = settings.subgroup.max(1);
        chart.threshold = hotelling_upper_quantile(
            settings.false_alarm_rate,
            k as f64,
            chart.covariance_dof as f64,
        );
        if let TrainingError::Bounded { confidence } = settings.training_error {
            if !(confidence > 0.0 && confidence < 1.0) {
                return Err(Error::usage(format!(
                    "control chart: confidence {confidence} of the training error's bound must lie in (0, 1)"
                )));
            }
            chart.training_error_bound =
                chi2_upper_quantile(1.0 - confidence, (k * (p + 1)) as f64);
        }
        Ok(chart)
    }

    /// x_w of (E3): the measured value (E1) or the latent scores (E2).
    fn regressors(&self, frequencies: &[f64], environment: Option<f64>) -> Vec<f64> {
        match &self.compensation {
            Compensation::Measured { .. } => vec![environment.unwrap_or(f64::NAN)],
            Compensation::Latent {
                mean_hz,
                directions,
                ..
            } => {
                let z = relative_deviations(frequencies, mean_hz);
                directions
                    .iter()
                    .map(|d| d.iter().zip(&z).map(|(a, b)| a * b).sum())
                    .collect()
            }
        }
    }

    /// The residual of one window (E1/E2).
    pub fn residual(&self, frequencies: &[f64], environment: Option<f64>) -> Vec<f64> {
        match &self.compensation {
            Compensation::Measured {
                mean_hz,
                fits,
                direction,
            } => {
                let t = environment.unwrap_or(f64::NAN);
                let r: Vec<f64> = frequencies
                    .iter()
                    .zip(mean_hz)
                    .zip(fits)
                    .map(|((f, f0), (b0, b1))| 0.5 * ((f / f0).powi(2) - 1.0 - b0 - b1 * t))
                    .collect();
                project_out(r, direction.as_slice())
            }
            Compensation::Latent {
                mean_hz,
                directions,
                ..
            } => {
                let z = relative_deviations(frequencies, mean_hz);
                project_out(z, directions)
            }
        }
    }

    /// T² of a subgroup (E3): `windows` are (frequencies, measured value)
    /// of its windows; NaN when a measured value is missing.
    pub fn statistic(&self, windows: &[(&[f64], Option<f64>)]) -> f64 {
        self.test(windows).statistic
    }

    /// T²_g of (E3) and its p-value: `windows` as [`Self::statistic`].
    pub fn test(&self, windows: &[(&[f64], Option<f64>)]) -> SubgroupTest {
        let w = windows.len().max(1) as f64;
        let m = self.residual_mean.len();
        let p = self.regressor_mean.len();
        let mut mean = vec![0.0; m];
        let mut x = vec![0.0; p];
        for (f, env) in windows {
            for (acc, e) in mean.iter_mut().zip(self.residual(f, *env)) {
                *acc += e / w;
            }
            if p > 0 {
                for (acc, v) in x.iter_mut().zip(self.regressors(f, *env)) {
                    *acc += v / w;
                }
            }
        }
        let d: Vec<f64> = x
            .iter()
            .zip(&self.regressor_mean)
            .map(|(a, b)| a - b)
            .collect();
        let leverage: f64 = (0..p)
            .map(|a| {
                (0..p)
                    .map(|b| d[a] * self.scatter_inverse[a][b] * d[b])
                    .sum::<f64>()
            })
            .sum();
        let (k, nu) = (self.dof as f64, self.covariance_dof as f64);
        let shared = w / self.training_windows as f64 + w * leverage;
        let raw = w * self
            .whitening
            .iter()
            .map(|row| {
                let v: f64 = row
                    .iter()
                    .zip(mean.iter().zip(&self.residual_mean))
                    .map(|(a, (x, m))| a * (x - m))
                    .sum();
                v * v
            })
            .sum::<f64>();
        if raw.is_nan() {
            return SubgroupTest {
                statistic: f64::NAN,
                p_value: f64::NAN,
            };
        }
        match self.training_error {
            TrainingError::Ignored | TrainingError::Averaged => {
                let statistic = raw / (1.0 + shared);
                SubgroupTest {
                    statistic,
                    p_value: hotelling_survival(statistic, k, nu),
                }
            }
            TrainingError::Bounded { .. } => {
                // Rescaled so that the subgroup's own threshold maps onto
                // the chart's (central) one: the decision is raw > its
                // threshold.
                let lambda = shared * self.training_error_bound;
                let own = noncentral_hotelling_upper_quantile(self.false_alarm_rate, k, nu, lambda);
                SubgroupTest {
                    statistic: raw * self.threshold / own,
                    p_value: noncentral_hotelling_survival(raw, k, nu, lambda),
                }
            }
        }
    }
}

/// (E5): index of the first window of the first run of `min_run`
/// out-of-control windows among `eligible` ones (`None` = not charted).
pub fn alarm_onset(
    out_of_control: &[Option<bool>],
    eligible: &[bool],
    min_run: usize,
) -> Option<usize> {
    super::anomaly::anomaly_onset(out_of_control, eligible, min_run)
}

/// z_w of (E2): each frequency's relative deviation from its training mean.
fn relative_deviations(frequencies: &[f64], mean_hz: &[f64]) -> Vec<f64> {
    frequencies
        .iter()
        .zip(mean_hz)
        .map(|(f, f0)| f / f0 - 1.0)
        .collect()
}
