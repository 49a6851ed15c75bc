//! Amplitude dependence of one mode's frequency across a structure's events,
//! the events outside it, and a permanent shift (docs/history.md, Eqs.
//! H1–H6).  Numerical code only.
//!
//! A structure's frequency falls as the shaking grows (soil, abutments,
//! cracks that open and close), so one event's frequency is judged against
//! what the other events predict at its intensity:
//!
//! (H1) ln f_e = a + b ln(A_e / g) + c S_e + ε_e,  ε_e ~ N(0, s²),
//!      A_e the event's intensity (peak acceleration), S_e = 1 for the
//!      events from a detected step on (H5), else 0 (no c without a step);
//! (H2) ordinary least squares over the fitted events ([`LinearFit`]);
//! (H3) the prediction interval of confidence γ at an event:
//!      exp(ŷ ± t_{(1+γ)/2, n−p} s √(1 + x₀ᵀ(XᵀX)⁻¹x₀));
//! (H4) outliers: the Bonferroni outlier test on the externally
//!      studentised residuals (e.g. Weisberg, *Applied Linear Regression*,
//!      4th ed., §9.1): each of the n fitted events is compared with the
//!      fit *without* it (one strong, softened event must not bend the line
//!      it is tested against), t_e = (y_e − ŷ_(e)) / (s_(e) √(1 + h_e)); the
//!      event with the largest |t_e| leaves the fit when it exceeds
//!      t_{1 − (1−γ)/(2n), n−p−1} (the family-wise level of γ over the n
//!      tests), and the test is repeated on the rest, at most ⌊n/4⌋ times
//!      and never below `min_events` fitted events;
//! (H5) a permanent shift: for every candidate date τ (an event with at
//!      least `min_before` events before it and `min_after` from it on, so
//!      one odd event cannot make a step), H4 run with the step S_e(τ) in
//!      the model (an outlier hides a step from a fit without one, and a
//!      step hides an outlier), then on the events kept the fit with the
//!      step against the fit without: F = (RSS₀ − RSS₁)/(RSS₁/(n − 3));
//!      a date qualifies when its p-value P(F(1, n−3) > F) times the number
//!      of candidates (Bonferroni) is below `step_alpha` and the shift
//!      |e^c − 1| is at least `min_step`; of the qualifying dates the one
//!      whose H4 keeps the most events is taken (a step one event off takes
//!      that event out as an outlier and fits as well), then the largest F;
//!      dated by its first event, which must stay in the fit.
//!      Without a step, H4 runs with H1 alone;
//! (H6) status of an event: inside the interval → `in_band`; below it →
//!      `amplitude_softened` when its intensity exceeds every fitted
//!      event's and a later event of the mode is back inside the band
//!      (softer than the trend predicts at a shaking stronger than any the
//!      band was fitted on, and recovered: a temporary softening), else
//!      `below_band`; above it → `above_band`.

use crate::stats::{f_survival, LinearFit};

/// Standard gravity, m/s²: intensities enter H1 in g.
pub const G: f64 = 9.80665;

/// Settings of the band, the outlier test and the step search.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BandSettings {
    /// γ of the prediction interval (H3).
    pub confidence: f64,
    /// Fewest fitted events for a band (H1 without a step needs n ≥ 4 for
    /// two degrees of freedom).
    pub min_events: usize,
    /// Share of the events the outlier test may take out of the fit (H4).
    pub max_outlier_fraction: f64,
    /// Family-wise significance of a step (H5).
    pub step_alpha: f64,
    /// Least relative size |e^c − 1| of a step (H5).
    pub min_step: f64,
    /// Fitted events before a step's date, at least (H5).
    pub min_before: usize,
    /// Fitted events from a step's date on, at least (H5).
    pub min_after: usize,
}

impl Default for BandSettings {
    fn default() -> Self {
        BandSettings {
            confidence: 0.99,
            min_events: 4,
            max_outlier_fraction: 0.25,
            step_alpha: 0.01,
            min_step: 0.01,
            min_before: 3,
            min_after: 2,
        }
    }
}

/// One event of a mode, in date order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    pub frequency_hz: f64,
    /// The event's intensity, m/s² (NaN when unknown).
    pub intensity_m_s2: f64,
}

impl Point {
    fn usable(&self) -> bool {
        self.frequency_hz > 0.0
            && self.frequency_hz.is_finite()
            && self.intensity_m_s2 > 0.0
            && self.intensity_m_s2.is_finite()
    }
}

/// Where an event lies against the band (H6).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    InBand,
    AmplitudeSoftened,
    BelowBand,
    AboveBand,
    /// No band: too few events, or the intensities do not vary.
    NoBand,
    /// The event's intensity is unknown: it cannot be placed.
    NoIntensity,
}

impl Status {
    /// The name written to `history_modes/history_modes.parquet` (`status`).
    pub fn name(self) -> &'static str {
        match self {
            Status::InBand => "in_band",
            Status::AmplitudeSoftened => "amplitude_softened",
            Status::BelowBand => "below_band",
            Status::AboveBand => "above_band",
            Status::NoBand => "no_band",
            Status::NoIntensity => "no_intensity",
        }
    }

    /// Outside the band.
    pub fn flagged(self) -> bool {
        matches!(
            self,
            Status::AmplitudeSoftened | Status::BelowBand | Status::AboveBand
        )
    }
}

/// A permanent shift (H5).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Step {
    /// Index (into the points) of the first event on the new level.
    pub from: usize,
    /// e^c − 1: the relative frequency change at equal intensity.
    pub relative_change: f64,
    pub f_statistic: f64,
    /// Bonferroni-adjusted p-value.
    pub p_value: f64,
}

/// The fitted model of a mode (H1–H3).
#[derive(Debug, Clone, PartialEq)]
pub struct ModeBand {
    pub fit: LinearFit,
    /// t_{(1+γ)/2, n−p}.
    pub t_quantile: f64,
    pub step: Option<Step>,
    /// Indices of the points the band was fitted on.
    pub fitted: Vec<usize>,
}

impl ModeBand {
    /// The regressors of H1 at intensity `a` (m/s²), before or after the step.
    fn regressors(&self, a: f64, after_step: bool) -> Vec<f64> {
        regressors(a, self.step.map(|_| after_step))
    }

    /// Predicted frequency and the interval (H3) at intensity `a`, Hz.
    pub fn band_at(&self, a: f64, after_step: bool) -> (f64, f64, f64) {
        let x = self.regressors(a, after_step);
        let y = self.fit.predict(&x);
        let half = self.fit.prediction_half_width(&x, self.t_quantile);
        (y.exp(), (y - half).exp(), (y + half).exp())
    }

    /// a, b (and c) of H1.
    pub fn coefficients(&self) -> &[f64] {
        &self.fit.coefficients
    }
}

/// One event's place against the band.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Verdict {
    pub status: Status,
    /// Predicted frequency and interval, Hz (None without a band).
    pub band: Option<(f64, f64, f64)>,
    /// The event is among those the band was fitted on.
    pub fitted: bool,
    /// The event is on or after the step's date.
    pub after_step: bool,
}

/// The band of a mode and every event's verdict (same order as the points).
#[derive(Debug, Clone, PartialEq)]
pub struct ModeAssessment {
    pub band: Option<ModeBand>,
    pub verdicts: Vec<Verdict>,
    /// Why there is no band, when there is none.
    pub note: Option<String>,
}

/// [1, ln(A/g)] and, with a step, S.
fn regressors(a: f64, step: Option<bool>) -> Vec<f64> {
    let mut x = vec![1.0, (a / G).ln()];
    if let Some(after) = step {
        x.push(if after { 1.0 } else { 0.0 });
    }
    x
}

/// H2 over the points `use_` (indices), with a step from index `step_from`.
fn fit_over(points: &[Point], use_: &[usize], step_from: Option<usize>) -> Option<LinearFit> {
    let x: Vec<Vec<f64>> = use_
        .iter()
        .map(|&i| regressors(points[i].intensity_m_s2, step_from.map(|s| i >= s)))
        .collect();
    let y: Vec<f64> = use_.iter().map(|&i| points[i].frequency_hz.ln()).collect();
    LinearFit::fit(&x, &y)
}

/// H4: the fitted point with the largest externally studentised residual
/// beyond the Bonferroni critical value, and that |t|, if any.
fn worst_outlier(
    points: &[Point],
    use_: &[usize],
    step: Option<&Step>,
    s: &BandSettings,
) -> Option<(usize, f64)> {
    let step_from = step.map(|st| st.from);
    let n = use_.len() as f64;
    let mut worst: Option<(usize, f64)> = None;
    for &e in use_ {
        let others: Vec<usize> = use_.iter().copied().filter(|&i| i != e).collect();
        let Some(fit) = fit_over(points, &others, step_from) else {
            continue;
        };
        let x = regressors(points[e].intensity_m_s2, step_from.map(|f| e >= f));
        let critical = crate::stats::student_t_upper_quantile(
            (1.0 - s.confidence) / (2.0 * n),
            fit.dof as f64,
        );
        let t = (points[e].frequency_hz.ln() - fit.predict(&x)).abs()
            / fit.prediction_half_width(&x, 1.0);
        if t > critical && worst.is_none_or(|w| t > w.1) {
            worst = Some((e, t));
        }
    }
    worst
}

/// H4 repeated: the fit over `usable` (with the step from index
/// `step_from`, if any) after taking out, one at a time, the events the
/// outlier test rejects; the events kept and their fit.
fn outlier_loop(
    points: &[Point],
    usable: &[usize],
    step_from: Option<usize>,
    s: &BandSettings,
) -> Option<(Vec<usize>, LinearFit)> {
    let min_events = s.min_events.max(4);
    let max_removed = (s.max_outlier_fraction * usable.len() as f64).floor() as usize;
    let step = step_from.map(|from| Step {
        from,
        relative_change: 0.0,
        f_statistic: 0.0,
        p_value: 1.0,
    });
    let mut fitted = usable.to_vec();
    loop {
        let fit = fit_over(points, &fitted, step_from)?;
        let removed = usable.len() - fitted.len();
        if removed < max_removed && fitted.len() > min_events {
            if let Some((e, _)) = worst_outlier(points, &fitted, step.as_ref(), s) {
                fitted.retain(|&i| i != e);
                continue;
            }
        }
        return Some((fitted, fit));
    }
}

/// H5: for every candidate date (an event of `usable` with `min_before`
/// usable events before it and `min_after` from it on), the outlier loop
/// with the step there, and the F test of the step on the events that loop
/// kept; among the dates whose step passes (Bonferroni over the candidates)
/// and is large enough, the one keeping the most events, then the largest F.  Searching the step with the outliers taken
/// out under the step model itself: an outlier hides a step from a
/// no-step fit (it inflates s), and a step hides an outlier.
fn best_step(
    points: &[Point],
    usable: &[usize],
    s: &BandSettings,
) -> Option<(Step, LinearFit, Vec<usize>)> {
    let n = usable.len();
    if n < s.min_before + s.min_after || n < 5 {
        return None;
    }
    let candidates: Vec<usize> = (s.min_before.max(1)..=n - s.min_after)
        .map(|k| usable[k])
        .collect();
    let mut best: Option<(Step, LinearFit, Vec<usize>)> = None;
    for &from in &candidates {
        let Some((kept, f1)) = outlier_loop(points, usable, Some(from), s) else {
            continue;
        };
        // The step is dated by an event on the new level: the candidate's
        // own event must stay in the fit.
        let after = kept.iter().filter(|&&i| i >= from).count();
        if !kept.contains(&from)
            || after < s.min_after
            || kept.len() - after < s.min_before
            || f1.dof < 2
        {
            continue;
        }
        let Some(base) = fit_over(points, &kept, None) else {
            continue;
        };
        let f_stat = if f1.rss > 0.0 {
            (base.rss - f1.rss).max(0.0) / (f1.rss / f1.dof as f64)
        } else {
            f64::INFINITY
        };
        let p = (f_survival(f_stat, 1.0, f1.dof as f64) * candidates.len() as f64).min(1.0);
        let change = f1.coefficients[2].exp() - 1.0;
        if !(p < s.step_alpha && change.abs() >= s.min_step) {
            continue;
        }
        // Among the significant dates, the one that leaves the fewest
        // events out of the fit (a date one event off takes that event out
        // as an outlier and fits as well), then the largest F.
        if best
            .as_ref()
            .is_none_or(|b| (kept.len(), f_stat) > (b.2.len(), b.0.f_statistic))
        {
            let step = Step {
                from,
                relative_change: change,
                f_statistic: f_stat,
                p_value: p,
            };
            best = Some((step, f1, kept));
        }
    }
    best
}

/// The band of one mode and the verdict of each of its events (module doc,
/// H1–H6); `points` in date order.
pub fn assess(points: &[Point], s: &BandSettings) -> ModeAssessment {
    let usable: Vec<usize> = (0..points.len()).filter(|&i| points[i].usable()).collect();
    let no_band = |note: String| ModeAssessment {
        band: None,
        verdicts: points
            .iter()
            .map(|p| Verdict {
                status: if p.usable() {
                    Status::NoBand
                } else {
                    Status::NoIntensity
                },
                band: None,
                fitted: false,
                after_step: false,
            })
            .collect(),
        note: Some(note),
    };
    let min_events = s.min_events.max(4);
    if usable.len() < min_events {
        return no_band(format!(
            "{} event(s) with a known intensity: a band needs at least {min_events}",
            usable.len()
        ));
    }
    let Some((fitted, fit)) = outlier_loop(points, &usable, None, s) else {
        return no_band(
            "the intensities of the events do not vary: the amplitude dependence cannot be fitted"
                .into(),
        );
    };
    let (fitted, fit, step) = match best_step(points, &usable, s) {
        Some((st, f, set)) => (set, f, Some(st)),
        None => (fitted, fit, None),
    };
    let band = ModeBand {
        t_quantile: fit.t_quantile(s.confidence),
        fit,
        step,
        fitted: fitted.clone(),
    };
    let strongest_fitted = fitted
        .iter()
        .map(|&i| points[i].intensity_m_s2)
        .fold(f64::NEG_INFINITY, f64::max);
    let mut verdicts: Vec<Verdict> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            if !p.usable() {
                return Verdict {
                    status: Status::NoIntensity,
                    band: None,
                    fitted: false,
                    after_step: false,
                };
            }
            let after_step = step.is_some_and(|st| i >= st.from);
            let b = band.band_at(p.intensity_m_s2, after_step);
            let status = if p.frequency_hz < b.1 {
                Status::BelowBand
            } else if p.frequency_hz > b.2 {
                Status::AboveBand
            } else {
                Status::InBand
            };
            Verdict {
                status,
                band: Some(b),
                fitted: fitted.contains(&i),
                after_step,
            }
        })
        .collect();
    // H6: softened beyond the trend at an unseen amplitude, and recovered.
    for i in 0..verdicts.len() {
        let recovered = verdicts[i + 1..].iter().any(|v| v.status == Status::InBand);
        if verdicts[i].status == Status::BelowBand
            && points[i].intensity_m_s2 > strongest_fitted
            && recovered
        {
            verdicts[i].status = Status::AmplitudeSoftened;
        }
    }
    ModeAssessment {
        band: Some(band),
        verdicts,
        note: None,
    }
}
