//! Issue 36 item 3 in `quaketwin track`: the compensation of a run's
//! tracked frequencies ([`quaketwin::monitor::compensation`]) and the
//! temperature inputs (`--temperature` CSV, `src/track/temperature.rs`).
//! Fabricated windows (no identification): fast.

use quaketwin::monitor::compensation::{compensate, RunCompensation};
use quaketwin::monitor::environment::{ChartSettings, EnvironmentSeries};
use quaketwin::monitor::tracking::TrackedMode;
use quaketwin::monitor::WindowModes;
use quaketwin::rng::Rng;
use quaketwin::track::temperature::read_csv;

const HOUR_NS: i64 = 3_600_000_000_000;
const REFERENCE_HZ: [f64; 3] = [1.0, 2.7, 4.1];

/// `days` days of hourly windows of a 3-mode structure whose stiffness
/// follows temperature (daily ±5 °C, a 0.3 °C/day drift: 1.6 × 10⁻³ per
/// °C on k); from day `damage_day` mode 1 is 0.3 % lower and mode 3
/// 0.1 % (a local loss), frequency noise 0.1 % per window.  Mode 2 is
/// missing in every 10th window.  Returns windows, rows, temperature.
fn run(
    days: usize,
    damage_day: usize,
    seed: u64,
) -> (Vec<WindowModes>, Vec<TrackedMode>, EnvironmentSeries) {
    let mut rng = Rng::new(seed);
    let mut windows = Vec::new();
    let mut rows = Vec::new();
    let mut temperature = Vec::new();
    for h in 0..days * 24 {
        let t = 5.0 + 0.3 * h as f64 / 24.0 + 5.0 * (std::f64::consts::TAU * h as f64 / 24.0).sin();
        let s = (1.0 - 1.6e-3 * (t - 5.0)).sqrt();
        let damaged = h >= damage_day * 24;
        let start = h as i64 * HOUR_NS;
        windows.push(WindowModes::skipped(
            start,
            start + HOUR_NS,
            1.0,
            String::new(),
        ));
        temperature.push((start + HOUR_NS / 2, t + 0.1 * rng.normal()));
        for (j, f0) in REFERENCE_HZ.iter().enumerate() {
            if j == 1 && h % 10 == 3 {
                continue;
            }
            let loss = match (damaged, j) {
                (true, 0) => 3e-3,
                (true, 2) => 1e-3,
                _ => 0.0,
            };
            rows.push(TrackedMode {
                window: h,
                mode_id: j + 1,
                frequency_hz: f0 * s * (1.0 - loss) * (1.0 + 1e-3 * rng.normal()),
                frequency_std_hz: 0.0,
                damping_ratio: 0.02,
                mac: 1.0,
                mpc: 1.0,
                pole_count: 10,
                direction: "X".into(),
            });
        }
    }
    let series = EnvironmentSeries::new(temperature, "test.csv").unwrap();
    (windows, rows, series)
}

fn chart(days: usize, training_days: usize, measured: bool) -> (RunCompensation, usize) {
    let (windows, rows, series) = run(days, 20, 11);
    let c = compensate(
        &windows,
        &rows,
        3,
        training_days as i64 * 24 * HOUR_NS,
        measured.then_some(&series),
        &ChartSettings::default(),
    );
    (c, rows.len())
}

/// Both models: the training subgroups marked, the subgroups one day each
/// and aligned on the training end, no out-of-control day before the
/// damage (day 20), the alarm on the damage's first day; rows of windows
/// without mode 2 have no residual, the others one; the measured value of
/// every window given.
#[test]
fn compensation_of_a_run_charts_days_and_finds_the_damage() {
    for measured in [true, false] {
        let (c, n_rows) = chart(26, 7, measured);
        assert_eq!(c.model, if measured { "measured" } else { "latent" });
        assert!(c.warnings.is_empty(), "{:?}", c.warnings);
        assert_eq!(c.subgroups.len(), 26);
        for (d, g) in c.subgroups.iter().enumerate() {
            assert_eq!((g.first, g.end), (24 * d, 24 * d + 24));
            assert_eq!(g.training, d < 7);
            let missing = (24 * d..24 * d + 24).filter(|h| h % 10 == 3).count();
            assert_eq!(g.charted, 24 - missing);
            if (7..20).contains(&d) {
                assert_eq!(g.out_of_control, Some(false), "{measured}: day {d}: {g:?}");
            }
            if g.training {
                assert_eq!(g.out_of_control, None);
            }
        }
        assert_eq!(c.alarm_from, Some(20), "{measured}");
        assert_eq!(c.residuals.len(), n_rows);
        assert!(c.residuals.iter().filter(|r| r.is_none()).count() > 0);
        assert_eq!(
            c.environment.iter().filter(|e| e.is_some()).count(),
            if measured { 26 * 24 } else { 0 }
        );
        let flagged_after = c.residual_flagged.iter().flatten().filter(|f| **f).count();
        assert!(
            flagged_after > 0,
            "the residual band flags the damaged windows"
        );
    }
}

/// tracking.html's control chart: the subgroups after training in and out
/// of control (the damage from day 20: six days out), the threshold and the
/// alarm's date named.
#[test]
fn control_chart_is_drawn_with_its_threshold_and_alarm() {
    let (c, _) = chart(26, 7, true);
    let origin = c.subgroups[0].start_ns;
    let html = quaketwin::report::tracking::control_chart_section(&c, origin);
    assert!(html.contains("<svg"), "{html}");
    for label in ["training", "in control", "out of control (Eq. E4)"] {
        assert!(html.contains(label), "{label}: {html}");
    }
    let threshold = c.chart.as_ref().unwrap().threshold;
    assert!(
        html.contains(&quaketwin::report::format_number(threshold)),
        "{html}"
    );
    let alarm = quaketwin::vocab::format_epoch_ns(c.subgroups[20].start_ns);
    assert!(html.contains(&format!("the alarm from {alarm}")), "{html}");
    // Without a chart: said, no figure.
    let none = quaketwin::report::tracking::control_chart_section(&Default::default(), 0);
    assert!(none.contains("No control chart") && !none.contains("<svg"));
}

/// A short training period: a warning (one day: fewer than two
/// subgroups), and with fewer windows than the chart needs (m + 5) no
/// chart, said, and no subgroup.
#[test]
fn a_short_training_period_is_said() {
    let (c, _) = chart(4, 1, true);
    assert!(c.chart.is_some());
    assert!(
        c.warnings
            .iter()
            .any(|w| w.contains("fewer than two subgroups")),
        "{:?}",
        c.warnings
    );
    let (windows, rows, series) = run(2, 20, 3);
    let c = compensate(
        &windows,
        &rows,
        3,
        7 * HOUR_NS,
        Some(&series),
        &ChartSettings::default(),
    );
    assert!(c.chart.is_none() && c.subgroups.is_empty());
    assert!(
        c.warnings.iter().any(|w| w.contains("no control chart")),
        "{:?}",
        c.warnings
    );
}

/// `--temperature`: a header, ISO-8601 and epoch-second times, comments;
/// a bad row is refused naming the file and the line.
#[test]
fn temperature_csv_reads_both_time_forms_and_names_bad_lines() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("t.csv");
    std::fs::write(
        &good,
        "time,value\n# sensor T1\n2026-01-01T00:00:00Z,4.5\n1767229200,5.5\n2026-01-01T02:00:00Z; 6.0\n",
    )
    .unwrap();
    let s = read_csv(&good).unwrap();
    assert_eq!(s.values, vec![4.5, 5.5, 6.0]);
    let t0 = 1_767_225_600_000_000_000i64;
    assert_eq!(s.times_ns, vec![t0, t0 + HOUR_NS, t0 + 2 * HOUR_NS]);
    assert_eq!(s.over(t0, t0 + 2 * HOUR_NS), Some(5.0));
    for (text, line, what) in [
        (
            "time,value\n2026-01-01T00:00:00Z,4.5\nyesterday,3\n",
            3,
            "time",
        ),
        (
            "2026-01-01T00:00:00Z,4.5\n2026-01-01T01:00:00Z,warm\n",
            2,
            "value",
        ),
        ("2026-01-01T00:00:00Z,4.5,1\n", 1, "fields"),
        ("2026-01-01T00:00:00Z,NaN\n", 1, "value"),
    ] {
        let bad = dir.path().join("bad.csv");
        std::fs::write(&bad, text).unwrap();
        let e = read_csv(&bad).unwrap_err().to_string();
        assert!(
            e.contains("bad.csv") && e.contains(&format!("line {line}")) && e.contains(what),
            "{e}"
        );
    }
}
