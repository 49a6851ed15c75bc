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
use quaketwin::monitor::environment::{alarm_onset, ChartSettings, ControlChart};
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
        extrapolation_leverage: false,
        ..settings
    };
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
        "{label}: latent (PCA, {} direction(s)) {}",
        o.retained,
        show(o.latent)
    );
}

/// CI version: 40 days of spring (from day 60, when the season moves
/// fastest), training on the first 10 or 20, damage from day 30.
/// Uncompensated, the season's drift makes false alarms; both
/// compensations make none; trained on 20 days they detect the 1 % loss
/// within 3 days (on 10, the damage lies 7 °C beyond the training mean and
/// the leverage term of Eq. E3 widens the chart: printed, not asserted).
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
    for (name, (fa, delay)) in [("measured", o.measured), ("latent", o.latent)] {
        assert_eq!(fa, 0, "{name}: false alarms");
        assert!(delay.is_some_and(|d| d <= 72), "{name}: delay {delay:?} h");
    }
}

/// Issue 36 "Must show": a year of hourly windows, training on the first
/// 60 days, damage from day 300, over 5 seeds (`QT_SEEDS=N` for more):
/// false-alarm episodes per year before (stated, asserted > 1) and after
/// the compensation — latent model (E2) and measured temperature (E1) —
/// (≤ 1 each), detection within 3 days.
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
    let mut totals = [0usize; 6];
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
        "{seeds} seeds, false alarms in total: before {}, latent {}, measured {}, measured without projection {}, latent without leverage {}, measured without leverage {}",
        totals[0], totals[1], totals[2], totals[3], totals[4], totals[5]
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
