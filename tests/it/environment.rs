//! Issue 36 item 3: environmental compensation of tracked frequencies and
//! the control chart on the residuals (src/monitor/environment.rs,
//! docs/statistics.md "Environmental compensation"), on a synthetic year of
//! hourly windows of the 5-storey shear building: ±3 % seasonal (and a
//! smaller daily) temperature effect on every storey's stiffness, a 1 %
//! stiffness loss of the ground storey from day 300.
//!
//! The year is simulated at the frequency level: each window's five
//! frequencies are the building's exact ones times (1 + relative noise),
//! the noise's standard deviation per mode the scatter of the SSI-COV
//! estimate of one-hour ambient windows (measured by the ignored study
//! below on 20 windows; the CI test uses the figures it printed).

use crate::modal::five_storey;
use quaketwin::monitor::anomaly::{self, BandSettings, Observation};
use quaketwin::monitor::environment::{alarm_onset, ChartSettings, ControlChart, TrainingError};
use quaketwin::rng::Rng;

const HOUR_NS: i64 = 3_600_000_000_000;

/// Temperature of hour h, °C: seasonal 10 ± 15 (coldest at h = 0) and a
/// daily ± 4 (warmest at 15:00).
fn temperature(h: usize) -> f64 {
    let year = std::f64::consts::TAU * h as f64 / 8760.0;
    let day = std::f64::consts::TAU * (h as f64 - 9.0) / 24.0;
    10.0 - 15.0 * year.cos() + 4.0 * day.sin()
}

/// Stiffness factor of every storey at temperature t: ±3 % over the
/// seasonal and daily extremes (−9 … 29 °C), softer when warm.
fn stiffness_factor(t: f64) -> f64 {
    1.0 - 0.03 * (t - 10.0) / 19.0
}

/// Exact frequencies of the building at temperature t, with the ground
/// storey `loss` softer.
fn frequencies(t: f64, loss: f64) -> Vec<f64> {
    let mut b = five_storey();
    for k in b.storey_stiffness_n_per_m.iter_mut() {
        *k *= stiffness_factor(t);
    }
    b.storey_stiffness_n_per_m[0] *= 1.0 - loss;
    b.modes().unwrap().frequencies_hz
}

/// Relative standard deviation of each mode's frequency estimate from one
/// one-hour ambient window at 100 Hz, 20 dB noise, SSI-COV with the
/// shipped settings: printed by `estimator_scatter_of_one_hour_windows`.
const MEASURED_RELATIVE_STD: [f64; 5] = [1.0e-3, 1.0e-3, 1.0e-3, 1.0e-3, 1.0e-3];

struct Year {
    /// Per window: the five observed frequencies.
    observed: Vec<Vec<f64>>,
    /// Measured temperature (0.2 °C sensor noise).
    measured: Vec<f64>,
    rms: Vec<f64>,
    damage_from: usize,
}

/// `hours` hourly windows from day `first_day` of the year, the damage
/// from day `damage_day` (counted from `first_day`).
fn synthetic_year(
    first_day: usize,
    hours: usize,
    damage_day: usize,
    noise: &[f64; 5],
    seed: u64,
) -> Year {
    let mut rng = Rng::new(seed);
    let damage_from = damage_day * 24;
    let mut observed = Vec::with_capacity(hours);
    let mut measured = Vec::with_capacity(hours);
    let mut rms = Vec::with_capacity(hours);
    for h in 0..hours {
        let t = temperature(first_day * 24 + h);
        let loss = if h >= damage_from { 0.01 } else { 0.0 };
        observed.push(
            frequencies(t, loss)
                .iter()
                .zip(noise)
                .map(|(f, s)| f * (1.0 + s * rng.normal()))
                .collect(),
        );
        measured.push(t + 0.2 * rng.normal());
        // Ambient level, independent of the frequencies here.
        rms.push(1e-3 * (0.3 * rng.normal()).exp());
    }
    Year {
        observed,
        measured,
        rms,
        damage_from,
    }
}

/// Alarm episodes (runs of ≥ min_run out-of-control windows) that start
/// in [from, to), each counted once, and the first one at or after `to`.
fn episodes(flags: &[bool], min_run: usize, from: usize, to: usize) -> (usize, Option<usize>) {
    let (mut count, mut first_after) = (0, None);
    let mut run = 0;
    for (i, &f) in flags.iter().enumerate() {
        run = if f { run + 1 } else { 0 };
        if run == min_run {
            let start = i + 1 - min_run;
            if start >= from && start < to {
                count += 1;
            } else if start >= to && first_after.is_none() {
                first_after = Some(start);
            }
        }
    }
    (count, first_after)
}

/// What each method gives on a year: (false-alarm episodes in the healthy
/// part after training, detection delay in hours).
struct Outcome {
    before: (usize, Option<usize>),
    measured: (usize, Option<usize>),
    /// E1 without removing the temperature direction (f² regression only).
    measured_unprojected: (usize, Option<usize>),
    /// E1 and E2 without the leverage term of (E3).
    measured_no_leverage: (usize, Option<usize>),
    latent_no_leverage: (usize, Option<usize>),
    /// E1 and E2 with the training error averaged (the leverage as a
    /// random error of each subgroup).
    measured_averaged: (usize, Option<usize>),
    latent_averaged: (usize, Option<usize>),
    latent: (usize, Option<usize>),
    retained: usize,
}

fn evaluate(year: &Year, training_hours: usize) -> Outcome {
    let n = year.observed.len();
    let settings = ChartSettings::default();
    // Before compensation: the band of Eqs. M1–M5 per mode (RMS and time of
    // day), a window anomalous when half its modes are flagged.
    let band = BandSettings {
        training_end_ns: training_hours as i64 * HOUR_NS,
        cycle_period_s: 86_400.0,
        confidence: 0.99,
        min_run: 3,
    };
    let obs = |h: usize, j: usize| Observation {
        start_ns: h as i64 * HOUR_NS,
        end_ns: (h as i64 + 1) * HOUR_NS,
        rms: year.rms[h],
        frequency_hz: year.observed[h][j],
    };
    let models: Vec<_> = (0..5)
        .map(|j| {
            let o: Vec<Observation> = (0..n).map(|h| obs(h, j)).collect();
            anomaly::fit(&o, &band).unwrap()
        })
        .collect();
    let before_flags: Vec<bool> = (0..n)
        .map(|h| {
            let flagged = (0..5)
                .filter(|&j| models[j].band(&obs(h, j)).flagged)
                .count();
            2 * flagged >= 5
        })
        .collect();
    let training = &year.observed[..training_hours];
    let measured_chart =
        ControlChart::fit(training, Some(&year.measured[..training_hours]), &settings).unwrap();
    let unprojected_chart = ControlChart::fit(
        training,
        Some(&year.measured[..training_hours]),
        &ChartSettings {
            project_temperature: false,
            ..settings
        },
    )
    .unwrap();
    let latent_chart = ControlChart::fit(training, None, &settings).unwrap();
    let no_leverage = ChartSettings {
        training_error: TrainingError::Ignored,
        ..settings
    };
    let averaged = ChartSettings {
        training_error: TrainingError::Averaged,
        ..settings
    };
    let measured_averaged =
        ControlChart::fit(training, Some(&year.measured[..training_hours]), &averaged).unwrap();
    let latent_averaged = ControlChart::fit(training, None, &averaged).unwrap();
    let measured_no_leverage = ControlChart::fit(
        training,
        Some(&year.measured[..training_hours]),
        &no_leverage,
    )
    .unwrap();
    let latent_no_leverage = ControlChart::fit(training, None, &no_leverage).unwrap();
    let retained = match &latent_chart.compensation {
        quaketwin::monitor::environment::Compensation::Latent { retained, .. } => *retained,
        _ => 0,
    };
    // Daily subgroups from the end of training (E3–E5): the alarm of a
    // subgroup is raised when it is complete, so the delay runs to its end.
    let w = settings.subgroup;
    let days: Vec<std::ops::Range<usize>> = (training_hours..n)
        .step_by(w)
        .map(|s| s..(s + w).min(n))
        .collect();
    let charted = |chart: &ControlChart, env: bool| -> (usize, Option<usize>) {
        let flags: Vec<Option<bool>> = days
            .iter()
            .map(|d| {
                let rows: Vec<(&[f64], Option<f64>)> = d
                    .clone()
                    .map(|h| (year.observed[h].as_slice(), env.then(|| year.measured[h])))
                    .collect();
                let s = chart.statistic(&rows);
                if std::env::var("QT_DEBUG").is_ok()
                    && s > chart.threshold
                    && d.end <= year.damage_from
                {
                    eprintln!("  day {}: T² {s:.1} > {:.1}", d.start / 24, chart.threshold);
                }
                Some(s > chart.threshold)
            })
            .collect();
        let healthy: Vec<bool> = days.iter().map(|d| d.end <= year.damage_from).collect();
        let damaged: Vec<bool> = healthy.iter().map(|h| !h).collect();
        // False alarms: episodes of min_run out-of-control subgroups before the damage.
        let mut false_alarms = 0;
        let mut run = 0;
        for (f, &h) in flags.iter().zip(&healthy) {
            run = if h && f == &Some(true) { run + 1 } else { 0 };
            if run == settings.min_run {
                false_alarms += 1;
            }
        }
        let first = alarm_onset(&flags, &damaged, settings.min_run)
            .map(|g| days[g + settings.min_run - 1].end - year.damage_from);
        (false_alarms, first)
    };
    let delay = |(c, first): (usize, Option<usize>)| (c, first.map(|f| f - year.damage_from));
    Outcome {
        before: delay(episodes(&before_flags, 3, training_hours, year.damage_from)),
        measured: charted(&measured_chart, true),
        measured_unprojected: charted(&unprojected_chart, true),
        measured_no_leverage: charted(&measured_no_leverage, true),
        latent_no_leverage: charted(&latent_no_leverage, false),
        measured_averaged: charted(&measured_averaged, true),
        latent_averaged: charted(&latent_averaged, false),
        latent: charted(&latent_chart, false),
        retained,
    }
}

fn print(label: &str, o: &Outcome) {
    let show = |(c, d): (usize, Option<usize>)| {
        format!(
            "{c} false alarms, detection after {}",
            d.map_or("never".into(), |d| format!(
                "{d} h ({:.1} d)",
                d as f64 / 24.0
            ))
        )
    };
    eprintln!("{label}: before compensation {}", show(o.before));
    eprintln!("{label}: measured temperature {}", show(o.measured));
    eprintln!(
        "{label}: measured temperature, direction kept {}",
        show(o.measured_unprojected)
    );
    eprintln!(
        "{label}: without leverage: measured {}; latent {}",
        show(o.measured_no_leverage),
        show(o.latent_no_leverage)
    );
    eprintln!(
        "{label}: training error averaged: measured {}; latent {}",
        show(o.measured_averaged),
        show(o.latent_averaged)
    );
    eprintln!(
        "{label}: latent (PCA, {} direction(s)) {}",
        o.retained,
        show(o.latent)
    );
}

/// CI version: 40 days of spring (from day 60, when the season moves
/// fastest), training on the first 10 or 20, damage from day 30.
/// Uncompensated, the season's drift makes false alarms; both
/// compensations make none; trained on 20 days they detect the 1 % loss
/// within 3 days with the training error averaged, within 5 with it
/// bounded (the default, Eq. E3: the damage lies ~5 °C beyond a short
/// training's mean and the bound widens the chart there); on 10 days of
/// training, detection is printed, not asserted.
#[test]
fn compensation_removes_the_season_and_keeps_the_damage_short_run() {
    let year = synthetic_year(60, 40 * 24, 30, &MEASURED_RELATIVE_STD, 7);
    let short = evaluate(&year, 10 * 24);
    print("40 days, 10 of training", &short);
    let o = evaluate(&year, 20 * 24);
    let (healthy, damaged) = (frequencies(10.0, 0.0), frequencies(10.0, 0.01));
    eprintln!(
        "1 % ground-storey loss, relative frequency changes: {:?}",
        healthy
            .iter()
            .zip(&damaged)
            .map(|(h, d)| format!("{:+.2e}", d / h - 1.0))
            .collect::<Vec<_>>()
    );
    print("40 days, 20 of training", &o);
    for (name, (fa, _)) in [("measured", short.measured), ("latent", short.latent)] {
        assert_eq!(fa, 0, "{name}, 10 days of training: false alarms");
    }
    assert!(
        o.before.0 >= 1,
        "the season should trouble the uncompensated band"
    );
    for (name, (fa, delay)) in [
        ("measured, averaged", o.measured_averaged),
        ("latent, averaged", o.latent_averaged),
    ] {
        assert_eq!(fa, 0, "{name}: false alarms");
        assert!(delay.is_some_and(|d| d <= 72), "{name}: delay {delay:?} h");
    }
    // The bounded chart (the default) pays for its guarantee where the
    // model extrapolates: here 3 (E1) and 5 (E2) days.
    for (name, (fa, delay)) in [("measured", o.measured), ("latent", o.latent)] {
        assert_eq!(fa, 0, "{name}: false alarms");
        assert!(
            delay.is_some_and(|d| d <= 5 * 24),
            "{name}: delay {delay:?} h"
        );
    }
}

/// Issue 36 "Must show": a year of hourly windows, training on the first
/// 60 days, damage from day 300, over 5 seeds (`QT_SEEDS=N` for more):
/// false-alarm episodes per year before (stated, asserted > 1) and after
/// the compensation — latent model (E2) and measured temperature (E1) —
/// (≤ 1 each), detection within 3 days.  Default 5 seeds (CI-independent,
/// a few seconds); the figures of docs/statistics.md are from 100.
///
/// Run: `cargo test --test it environment::synthetic_year -- --ignored --nocapture`
#[test]
#[ignore]
fn synthetic_year_false_alarms_and_detection_delay() {
    let seeds: u64 = std::env::var("QT_SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    let mut failures = Vec::new();
    let mut totals = [0usize; 8];
    let first: u64 = std::env::var("QT_FIRST_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    for seed in first..=seeds {
        let year = synthetic_year(0, 365 * 24, 300, &MEASURED_RELATIVE_STD, seed);
        let o = evaluate(&year, 60 * 24);
        print(&format!("seed {seed}"), &o);
        for (k, fa) in [
            o.before.0,
            o.latent.0,
            o.measured.0,
            o.measured_unprojected.0,
            o.latent_no_leverage.0,
            o.measured_no_leverage.0,
            o.latent_averaged.0,
            o.measured_averaged.0,
        ]
        .into_iter()
        .enumerate()
        {
            totals[k] += fa;
        }
        for (name, (fa, delay)) in [("latent", o.latent), ("measured", o.measured)] {
            if fa > 1 || !delay.is_some_and(|d| d <= 72) {
                failures.push(format!(
                    "seed {seed} {name}: {fa} false alarms, delay {delay:?} h"
                ));
            }
        }
        assert!(
            o.before.0 > 1,
            "seed {seed}: the season should trouble the uncompensated band"
        );
    }
    eprintln!(
        "seeds {first}–{seeds}, false alarms in total: before {}, latent {}, measured {}, measured without projection {}, latent without leverage {}, measured without leverage {}, latent averaged {}, measured averaged {}",
        totals[0], totals[1], totals[2], totals[3], totals[4], totals[5], totals[6], totals[7]
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The noise model of the synthetic year: relative scatter of each mode's
/// SSI-COV frequency over 20 one-hour ambient windows (100 Hz, 20 dB, the
/// shipped settings) of the healthy building, printed for
/// `MEASURED_RELATIVE_STD` and docs/statistics.md.  Asserts every mode was
/// found in at least 18 windows.
///
/// Run: `cargo test --release --test it environment::estimator_scatter -- --ignored --nocapture`
#[test]
#[ignore]
fn estimator_scatter_of_one_hour_windows() {
    use quaketwin::modal::{identify, ModalInput, ModalSettings};
    use quaketwin::synth::five_storey::noisy_ambient;
    use rayon::prelude::*;
    let truth = five_storey().modes().unwrap().frequencies_hz;
    let found: Vec<Vec<Option<f64>>> = (0..20u64)
        .into_par_iter()
        .map(|seed| {
            let input = ModalInput {
                dt: 0.01,
                output_ids: (1..=5).map(|i| format!("L{i}")).collect(),
                outputs: noisy_ambient(&five_storey(), 360_000, 0.01, 500 + seed).unwrap(),
                ..Default::default()
            };
            let modes = identify(&input, &ModalSettings::default()).unwrap().modes;
            truth
                .iter()
                .map(|&f| {
                    modes
                        .iter()
                        .map(|m| m.frequency_hz / f - 1.0)
                        .filter(|d| d.abs() < 0.05)
                        .min_by(|a, b| a.abs().total_cmp(&b.abs()))
                })
                .collect()
        })
        .collect();
    for (j, f) in truth.iter().enumerate() {
        let d: Vec<f64> = found.iter().filter_map(|w| w[j]).collect();
        let mean = d.iter().sum::<f64>() / d.len() as f64;
        let std = (d.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (d.len() - 1) as f64).sqrt();
        eprintln!(
            "mode {} ({f:.3} Hz): found in {} of 20 windows, relative bias {mean:+.2e}, relative std {std:.2e}",
            j + 1,
            d.len()
        );
        assert!(d.len() >= 18, "mode {} found in {} windows", j + 1, d.len());
    }
}

/// Why a seed fails the year (docs/statistics.md "Synthetic year", the
/// conditional false-alarm rate): per seed, the chart fitted on that
/// seed's 60 training days, then the 240 healthy monitoring days re-drawn
/// `QT_REDRAWS` times (default 200) with fresh noise: the false alarms
/// expected *given this training* and P(more than one).  For E1 also the
/// fitted slopes' error against the truth, whitened — Sxx · ½Δᵀ S⁺ ½Δ
/// (Δ projected off the temperature direction), χ²(m − 1) under the model.
///
/// Run: `QT_SEEDS=20 cargo test --test it environment::conditional -- --ignored --nocapture`
#[test]
#[ignore]
fn conditional_false_alarms_given_the_training() {
    use quaketwin::monitor::environment::Compensation;
    let env = |k: &str, d: u64| {
        std::env::var(k)
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(d)
    };
    let (first, seeds, redraws) = (
        env("QT_FIRST_SEED", 1),
        env("QT_SEEDS", 20),
        env("QT_REDRAWS", 200),
    );
    let settings = ChartSettings::default();
    let (training_hours, damage_hours, w) = (60 * 24, 300 * 24, settings.subgroup);
    let exact: Vec<Vec<f64>> = (0..damage_hours)
        .map(|h| frequencies(temperature(h), 0.0))
        .collect();
    for seed in first..=seeds {
        let year = synthetic_year(0, damage_hours, 400, &MEASURED_RELATIVE_STD, seed);
        let training = &year.observed[..training_hours];
        let t_train = &year.measured[..training_hours];
        let e1 = ControlChart::fit(training, Some(t_train), &settings).unwrap();
        let e2 = ControlChart::fit(training, None, &settings).unwrap();
        let averaged = ChartSettings {
            training_error: TrainingError::Averaged,
            ..settings
        };
        let e1a = ControlChart::fit(training, Some(t_train), &averaged).unwrap();
        let e2a = ControlChart::fit(training, None, &averaged).unwrap();
        // E1's whitened slope error.
        let Compensation::Measured {
            mean_hz,
            fits,
            direction,
        } = &e1.compensation
        else {
            unreachable!()
        };
        let u = direction.clone().unwrap();
        let truth: Vec<f64> = (0..5)
            .map(|j| {
                ((frequencies(20.0, 0.0)[j] / mean_hz[j]).powi(2)
                    - (frequencies(0.0, 0.0)[j] / mean_hz[j]).powi(2))
                    / 20.0
            })
            .collect();
        let mut delta: Vec<f64> = fits
            .iter()
            .zip(&truth)
            .map(|(f, t)| 0.5 * (f.1 - t))
            .collect();
        let c: f64 = u.iter().zip(&delta).map(|(a, b)| a * b).sum();
        delta.iter_mut().zip(&u).for_each(|(d, ui)| *d -= c * ui);
        let res: Vec<Vec<f64>> = (0..training_hours)
            .map(|h| e1.residual(&training[h], Some(t_train[h])))
            .collect();
        let mean: Vec<f64> = (0..5)
            .map(|j| res.iter().map(|r| r[j]).sum::<f64>() / training_hours as f64)
            .collect();
        let s = nalgebra::DMatrix::<f64>::from_fn(5, 5, |a, b| {
            res.iter()
                .map(|r| (r[a] - mean[a]) * (r[b] - mean[b]))
                .sum::<f64>()
                / (training_hours - 2) as f64
        });
        let eig = s.clone().symmetric_eigen();
        let tm = t_train.iter().sum::<f64>() / training_hours as f64;
        let sxx: f64 = t_train.iter().map(|t| (t - tm).powi(2)).sum();
        let whitened: f64 = (0..5)
            .filter(|&i| eig.eigenvalues[i] > 1e-9 * eig.eigenvalues.max())
            .map(|i| {
                let v: f64 = (0..5).map(|j| eig.eigenvectors[(j, i)] * delta[j]).sum();
                sxx * v * v / eig.eigenvalues[i]
            })
            .sum();
        // Daily means of the training residuals: variance against S/w.
        let daily: Vec<Vec<f64>> = res
            .chunks(w)
            .map(|d| {
                (0..5)
                    .map(|j| d.iter().map(|r| r[j]).sum::<f64>() / w as f64)
                    .collect()
            })
            .collect();
        let dvar: f64 = (0..5)
            .map(|j| {
                daily.iter().map(|d| (d[j] - mean[j]).powi(2)).sum::<f64>()
                    / (daily.len() - 1) as f64
            })
            .sum::<f64>();
        let ratio = dvar * w as f64 / s.trace();
        // Re-draws of the monitoring period.
        let mut counts = [Vec::new(), Vec::new(), Vec::new(), Vec::new()];
        for r in 0..redraws {
            let mut rng = Rng::derived(seed, 1000 + r);
            let obs: Vec<(Vec<f64>, f64)> = (training_hours..damage_hours)
                .map(|h| {
                    let f = exact[h]
                        .iter()
                        .zip(&MEASURED_RELATIVE_STD)
                        .map(|(f, s)| f * (1.0 + s * rng.normal()))
                        .collect();
                    (f, temperature(h) + 0.2 * rng.normal())
                })
                .collect();
            for (k, (chart, measured)) in [(&e1a, true), (&e2a, false), (&e1, true), (&e2, false)]
                .into_iter()
                .enumerate()
            {
                let n = obs
                    .chunks(w)
                    .filter(|d| {
                        let rows: Vec<(&[f64], Option<f64>)> = d
                            .iter()
                            .map(|(f, t)| (f.as_slice(), measured.then_some(*t)))
                            .collect();
                        chart.statistic(&rows) > chart.threshold
                    })
                    .count();
                counts[k].push(n);
            }
        }
        let summary = |c: &[usize]| {
            let mean = c.iter().sum::<usize>() as f64 / c.len() as f64;
            let over = c.iter().filter(|&&n| n > 1).count() as f64 / c.len() as f64;
            format!("E[alarms] {mean:.2}, P(>1) {over:.2}")
        };
        eprintln!(
            "seed {seed}: E1 slope error (½Δ⊥, 1e-6/°C) {:?}, whitened {whitened:.1} (χ²₄ p {:.1e}); S eigen ×1e6 {:?}; daily-mean var / (S/w) {ratio:.2}; averaged: E1 {}, E2 {}; bounded: E1 {}, E2 {}",
            delta.iter().map(|d| format!("{:+.1}", d * 1e6)).collect::<Vec<_>>(),
            quaketwin::stats::chi2_survival(whitened, 4.0),
            eig.eigenvalues.iter().map(|v| format!("{:.2}", v * 1e6)).collect::<Vec<_>>(),
            summary(&counts[0]),
            summary(&counts[1]),
            summary(&counts[2]),
            summary(&counts[3])
        );
    }
}

/// The non-central T² of Eq. E3's bounded chart (`stats`): its survival
/// against 100 000 draws of |z + b|² (z ~ N(0, I₄), |b|² = λ = 10; the
/// covariance known, m = 10⁷), within 4 binomial standard errors, and the
/// quantile inverts the survival.
#[test]
fn noncentral_hotelling_matches_simulation() {
    use quaketwin::stats::{noncentral_hotelling_survival, noncentral_hotelling_upper_quantile};
    let (k, m, lambda) = (4.0, 1e7, 10.0);
    let q = noncentral_hotelling_upper_quantile(0.01, k, m, lambda);
    assert!((noncentral_hotelling_survival(q, k, m, lambda) - 0.01).abs() < 1e-8);
    assert!((noncentral_hotelling_survival(13.28, k, m, 0.0) - 0.01).abs() < 1e-4);
    let mut rng = Rng::new(3);
    let draws = 100_000;
    let t = 20.0;
    let above = (0..draws)
        .filter(|_| {
            let x: f64 = (0..4)
                .map(|i| (rng.normal() + if i == 0 { lambda.sqrt() } else { 0.0 }).powi(2))
                .sum();
            x > t
        })
        .count() as f64
        / draws as f64;
    let p = noncentral_hotelling_survival(t, k, m, lambda);
    let se = (p * (1.0 - p) / draws as f64).sqrt();
    eprintln!("P(χ'²₄(10) > 20): {p:.4} exact, {above:.4} simulated; 1 % quantile {q:.2}");
    assert!((above - p).abs() < 4.0 * se, "{above} vs {p}");
}
