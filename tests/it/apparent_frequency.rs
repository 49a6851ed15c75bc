//! Issue 32: the apparent frequency during an event (`modal::apparent`):
//! linear buildings of known frequency, a stiffness step, the failure
//! modes, and the validation on the 6-storey yielding frame at three
//! intensities against the true instantaneous tangent f₁
//! (`synth::yielding`): within 3 % wherever the frame stays linear over the
//! whole window, and before and after the shaking.

use quaketwin::metrics::significant_duration;
use quaketwin::modal::apparent::{
    track_apparent_frequency, track_many, ApparentSettings, FrequencyTrack, TrackRequest,
};
use quaketwin::rng::Rng;
use quaketwin::synth::realistic::degrading::{self, Intensity};
use quaketwin::synth::{
    add_measurement_noise, synthetic_ground_motion, GroundMotionSpec, Sampling, ShearBuilding,
};

fn ground(seed: u64, duration_s: f64, rate_hz: f64) -> Vec<f64> {
    synthetic_ground_motion(&GroundMotionSpec {
        seed,
        duration_s,
        sampling: Sampling::RateHz(rate_hz),
        ..Default::default()
    })
    .unwrap()
}

fn three_storey(k: f64) -> ShearBuilding {
    ShearBuilding {
        masses_kg: vec![3.0e5, 3.0e5, 2.5e5],
        storey_stiffness_n_per_m: vec![k, 0.9 * k, 0.8 * k],
        damping_ratios: vec![0.03],
    }
}

/// Largest relative error of the points where `truth(start_s, end_s)`
/// gives a frequency, and how many there are; a missing pole among them
/// counts as an infinite error.
fn max_rel_error(track: &FrequencyTrack, truth: impl Fn(f64, f64) -> Option<f64>) -> (f64, usize) {
    let mut worst: f64 = 0.0;
    let mut n = 0;
    for p in &track.points {
        if let Some(f) = truth(p.start_s, p.end_s) {
            let e = (p.frequency_hz / f - 1.0).abs();
            worst = worst.max(if e.is_nan() { f64::INFINITY } else { e });
            n += 1;
        }
    }
    (worst, n)
}

#[test]
fn apparent_frequency_of_a_linear_building_is_its_fundamental() {
    let dt = 0.01;
    let b = three_storey(3.0e8);
    let f1 = b.modes().unwrap().frequencies_hz[0];
    let g = ground(41, 40.0, 100.0);
    let r = b.simulate_base_motion(&g, dt).unwrap();
    let roof = &r.absolute_acceleration[2];
    let settings = ApparentSettings::default();
    let track = track_apparent_frequency(Some(&g), roof, dt, f1, &settings).unwrap();
    assert_eq!(track.method, "arx");
    let (worst, n) = max_rel_error(&track, |_, _| Some(f1));
    assert!(n > 30, "{n} windows");
    assert!(
        worst < 0.005,
        "ARX: worst error {:.3} % of f1 = {f1:.3} Hz",
        100.0 * worst
    );
    // An expected frequency 20 % off changes the window and decimation, not the answer.
    let off = track_apparent_frequency(Some(&g), roof, dt, 1.2 * f1, &settings).unwrap();
    let (worst_off, _) = max_rel_error(&off, |_, _| Some(f1));
    assert!(
        worst_off < 0.005,
        "expected 1.2 f1: {:.3} %",
        100.0 * worst_off
    );
    // Through track_many, the same tracks in the same order.
    let req = [
        TrackRequest {
            input: Some(&g),
            output: roof,
            expected_hz: f1,
        },
        TrackRequest {
            input: Some(&g),
            output: roof,
            expected_hz: 1.2 * f1,
        },
    ];
    let many = track_many(&req, dt, &settings);
    assert_eq!(many[0].as_ref().unwrap(), &track);
    assert_eq!(many[1].as_ref().unwrap(), &off);
}

#[test]
fn output_only_ar_tracks_an_ambient_response() {
    let dt = 0.01;
    let b = three_storey(3.0e8);
    let f1 = b.modes().unwrap().frequencies_hz[0];
    let mut rng = Rng::new(5);
    let r = b.simulate_ambient(12_000, dt, 1.0e4, &mut rng).unwrap();
    let roof = &r.absolute_acceleration[2];
    // The response to floor forces is an ARMA process: a pure AR model
    // needs a higher order and longer windows than the ARX one (order 8,
    // 20 periods: 9 % off; order 16, 40 periods: < 2.5 %).
    let settings = ApparentSettings {
        window_periods: 40.0,
        order: 16,
        ..Default::default()
    };
    let track = track_apparent_frequency(None, roof, dt, f1, &settings).unwrap();
    assert_eq!(track.method, "ar");
    let (worst, n) = max_rel_error(&track, |_, _| Some(f1));
    assert!(n > 20);
    assert!(worst < 0.03, "AR: worst error {:.3} %", 100.0 * worst);
}

/// Two linear segments (stiffness then 70 % of it), each excited by its own
/// record: the windows wholly inside either segment give its fundamental.
#[test]
fn apparent_frequency_follows_a_stiffness_step() {
    let dt = 0.01;
    let (a, b) = (three_storey(3.0e8), three_storey(2.1e8));
    let (fa, fb) = (
        a.modes().unwrap().frequencies_hz[0],
        b.modes().unwrap().frequencies_hz[0],
    );
    let (ga, gb) = (ground(42, 30.0, 100.0), ground(43, 30.0, 100.0));
    let ra = a.simulate_base_motion(&ga, dt).unwrap();
    let rb = b.simulate_base_motion(&gb, dt).unwrap();
    let g: Vec<f64> = ga.iter().chain(&gb).copied().collect();
    let roof: Vec<f64> = ra.absolute_acceleration[2]
        .iter()
        .chain(&rb.absolute_acceleration[2])
        .copied()
        .collect();
    let joint = ga.len() as f64 * dt;
    let track =
        track_apparent_frequency(Some(&g), &roof, dt, fa, &ApparentSettings::default()).unwrap();
    let (worst, n) = max_rel_error(&track, |s, e| {
        if e < joint {
            Some(fa)
        } else if s >= joint {
            Some(fb)
        } else {
            None
        }
    });
    assert!(n > 40);
    assert!(
        worst < 0.005,
        "step {fa:.3} → {fb:.3} Hz: worst {:.3} %",
        100.0 * worst
    );
    let phases = track.phases(joint, joint);
    assert!((phases.pre_hz.unwrap() / fa - 1.0).abs() < 0.005);
    assert!((phases.post_hz.unwrap() / fb - 1.0).abs() < 0.005);
    assert!(phases.min_during_hz.unwrap() >= 0.99 * fb);
}

#[test]
fn apparent_frequency_refuses_bad_records_without_panicking() {
    let s = ApparentSettings::default();
    // Shorter than one window (5 periods of 1 Hz = 5 s).
    let short = vec![1.0; 300];
    let e = track_apparent_frequency(None, &short, 0.01, 1.0, &s).unwrap_err();
    assert!(e.to_string().contains("shorter than one window"), "{e}");
    let mut nan = vec![0.5; 2000];
    nan[700] = f64::NAN;
    assert!(track_apparent_frequency(None, &nan, 0.01, 1.0, &s).is_err());
    assert!(track_apparent_frequency(Some(&short), &nan, 0.01, 1.0, &s).is_err());
    assert!(track_apparent_frequency(None, &short, 0.01, 0.0, &s).is_err());
    assert!(track_apparent_frequency(None, &short, 0.0, 1.0, &s).is_err());
    // Constant (and zero) records: no motion, no pole, no error.
    for c in [0.0, 3.0] {
        let flat = vec![c; 3000];
        let t = track_apparent_frequency(Some(&flat), &flat, 0.01, 1.0, &s).unwrap();
        assert!(!t.points.is_empty());
        assert!(t.points.iter().all(|p| p.frequency_hz.is_nan()));
        assert!(t.phases(10.0, 20.0).pre_hz.is_none());
    }
    // Bad settings are named.
    let bad = ApparentSettings {
        step_fraction: 0.0,
        ..Default::default()
    };
    assert!(bad
        .validate()
        .unwrap_err()
        .to_string()
        .contains("step_fraction"));
    // Settings read from TOML with defaults and unknown keys refused.
    let parsed: ApparentSettings = toml::from_str("window_periods = 4.0").unwrap();
    assert_eq!(parsed.window_periods, 4.0);
    assert!(toml::from_str::<ApparentSettings>("windows = 4.0").is_err());
}

/// Strong phase of a ground record: the Arias 5–95 % span, s.
fn strong_phase(g: &[f64], dt: f64) -> (f64, f64) {
    let (d, t0) = significant_duration(g, dt, 0.05, 0.95).unwrap();
    (t0, t0 + d)
}

struct Row {
    name: &'static str,
    axis: &'static str,
    pga: f64,
    initial: f64,
    final_: f64,
    pre: Option<f64>,
    post: Option<f64>,
    during: Option<f64>,
    worst: f64,
    defined: usize,
    points: usize,
    drift_pct: f64,
    strong: (f64, f64),
    windows: (usize, usize),
}

/// The track of direction `d` (0 = X, 1 = Y): roof over ground.
fn validate(intensity: Intensity, d: usize, noise_snr_db: Option<f64>) -> Row {
    let sim = degrading::simulate(2026, &intensity.options()).unwrap();
    let fx = &sim.true_first_frequency_hz().unwrap()[d];
    let rx = &sim.response[d];
    let dt = sim.dt;
    let initial = fx[0];
    let final_ = *fx.last().unwrap();
    let (mut g, mut roof) = (sim.ground[d].clone(), rx.absolute_acceleration[5].clone());
    if let Some(snr) = noise_snr_db {
        let mut rng = Rng::new(77);
        g = add_measurement_noise(&g, snr, &mut rng);
        roof = add_measurement_noise(&roof, snr, &mut rng);
    }
    let track =
        track_apparent_frequency(Some(&g), &roof, dt, initial, &ApparentSettings::default())
            .unwrap();
    let index = |t: f64| (t / dt).round() as usize;
    let (worst, defined) = max_rel_error(&track, |s, e| {
        rx.is_linear_over(index(s), index(e)).then(|| fx[index(s)])
    });
    let (t0, t1) = strong_phase(&sim.ground[d], dt);
    let phases = track.phases(t0, t1);
    Row {
        name: intensity.name(),
        axis: ["X", "Y"][d],
        pga: intensity.pga_x_m_s2() * [1.0, 0.8][d],
        initial,
        final_,
        pre: phases.pre_hz,
        post: phases.post_hz,
        during: phases.min_during_hz,
        strong: (t0, t1),
        windows: (phases.pre_windows, phases.post_windows),
        worst,
        defined,
        points: track.points.len(),
        drift_pct: 100.0 * rx.storey1_max_drift_m / degrading::STOREY_HEIGHTS_M[0],
    }
}

fn print_table(title: &str, rows: &[Row]) {
    let o = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.4}"));
    eprintln!("\n{title}");
    eprintln!("| intensity | axis | PGA m/s² | peak storey-1 drift % | true initial f1 Hz | true final f1 Hz | strong phase s | identified pre Hz (windows) | identified post Hz (windows) | min during Hz | max error where defined % | defined points / all |");
    eprintln!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        eprintln!(
            "| {} | {} | {} | {:.2} | {:.4} | {:.4} | {:.1}–{:.1} | {} ({}) | {} ({}) | {} | {} | {} / {} |",
            r.name,
            r.axis,
            format!("{:.2}", r.pga),
            r.drift_pct,
            r.initial,
            r.final_,
            r.strong.0,
            r.strong.1,
            o(r.pre),
            r.windows.0,
            o(r.post),
            r.windows.1,
            o(r.during),
            if r.worst.is_finite() {
                format!("{:.2}", 100.0 * r.worst)
            } else {
                "a window without a pole".into()
            },
            r.defined,
            r.points
        );
    }
}

fn within(v: Option<f64>, truth: f64, tol: f64) -> bool {
    v.is_some_and(|v| (v / truth - 1.0).abs() < tol)
}

#[test]
fn apparent_frequency_matches_the_yielding_frame_at_three_intensities() {
    let rows: Vec<Row> = Intensity::ALL
        .iter()
        .flat_map(|&i| [validate(i, 0, None), validate(i, 1, None)])
        .collect();
    print_table("Apparent frequency, roof / ground ARX, noise-free", &rows);
    for r in &rows {
        assert!(r.defined >= 10, "{}: {} defined windows", r.name, r.defined);
        assert!(r.worst < 0.03, "{}: {:.2} %", r.name, 100.0 * r.worst);
        assert!(
            within(r.pre, r.initial, 0.03),
            "{}: pre {:?}",
            r.name,
            r.pre
        );
        assert!(
            within(r.post, r.final_, 0.03),
            "{}: post {:?}",
            r.name,
            r.post
        );
        assert!(r.during.unwrap() <= r.post.unwrap() * 1.001, "{}", r.name);
    }
    // The three intensities are what they say (in X; rows X, Y per intensity).
    let drop = |r: &Row| 1.0 - r.final_ / r.initial;
    assert_eq!(
        rows[0].final_, rows[0].initial,
        "elastic: storey 1 yielded in X"
    );
    assert_eq!(
        rows[1].final_, rows[1].initial,
        "elastic: storey 1 yielded in Y"
    );
    assert!(
        (0.05..0.15).contains(&drop(&rows[2])),
        "moderate drop {}",
        drop(&rows[2])
    );
    assert!(drop(&rows[4]) > 0.25 && rows[4].drift_pct > 2.5, "severe");
}

#[test]
fn apparent_frequency_with_30_db_noise_at_three_intensities() {
    let rows: Vec<Row> = Intensity::ALL
        .iter()
        .map(|&i| validate(i, 0, Some(30.0)))
        .collect();
    print_table(
        "Apparent frequency, X, roof / ground ARX, 30 dB noise on both (of the whole record's RMS)",
        &rows,
    );
    for r in &rows {
        assert!(
            within(r.pre, r.initial, 0.05),
            "{}: pre {:?}",
            r.name,
            r.pre
        );
        assert!(
            within(r.post, r.final_, 0.05),
            "{}: post {:?}",
            r.name,
            r.post
        );
    }
}

#[test]
fn intensity_events_are_written_with_their_frequency_truth() {
    let dir = tempfile::tempdir().unwrap();
    let sim = degrading::write_event(dir.path(), 2026, &Intensity::Moderate.options()).unwrap();
    assert!(dir.path().join(degrading::ZIP_NAME).is_file());
    let truth: toml::Table =
        toml::from_str(&std::fs::read_to_string(dir.path().join("truth.toml")).unwrap()).unwrap();
    assert_eq!(truth["pre_event_s"].as_float(), Some(15.0));
    let csv = std::fs::read_to_string(dir.path().join("truth_frequency.csv")).unwrap();
    let [fx, _] = sim.true_first_frequency_hz().unwrap();
    assert_eq!(csv.lines().count(), fx.len() + 1);
    let last: Vec<&str> = csv.lines().last().unwrap().split(',').collect();
    assert_eq!(last[1].parse::<f64>().unwrap(), *fx.last().unwrap());
    // Elastic: one stiffness, no plastic step anywhere.
    let elastic = degrading::simulate(2026, &Intensity::Elastic.options()).unwrap();
    for r in &elastic.response {
        assert!(r.storey1_plastic_step.iter().all(|&p| !p));
        assert!(r.is_linear_over(0, r.storey1_plastic_step.len() - 1));
    }
}
