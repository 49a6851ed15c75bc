//! Conditioning tests: scipy-identical Butterworth design and zero-phase
//! filtering (stored reference from tests/reference/make_filter_reference.py),
//! and closed-form checks of the other steps.

use quaketwin::conditioning::{
    self, align_records, butter_sos, cosine_taper, integrate_motion, qa, remove_linear_trend,
    remove_polynomial, resample_to_rate, sosfilt::sosfilt_in_place, sosfilt_zi, sosfiltfilt,
    sosfiltfilt_channels, sosfiltfilt_padlen, BandType, ConditioningSettings, DriftControl, Step,
};
use quaketwin::geometry::{normalise_orientation, OrientationSettings};
use quaketwin::numeric::cumulative_trapezoid;
use quaketwin::vocab::{Axis, Channel, Direction, Event, QaFlag, Record, SourceRef, Units};
use quaketwin::Error;

struct ReferenceCase {
    name: String,
    order: usize,
    band: BandType,
    corners: Vec<f64>,
    sos: Vec<[f64; 6]>,
    output: Vec<f64>,
}

fn load_reference() -> (f64, Vec<f64>, Vec<ReferenceCase>) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/filter_reference.txt"
    );
    let text = std::fs::read_to_string(path).expect("reference file");
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let mut next = || lines.next().expect("unexpected end of reference file");
    let fs: f64 = next().strip_prefix("fs ").unwrap().parse().unwrap();
    let n: usize = next().strip_prefix("input ").unwrap().parse().unwrap();
    let input: Vec<f64> = (0..n).map(|_| next().parse().unwrap()).collect();
    let mut cases = Vec::new();
    loop {
        let Some(header) = lines.next() else { break };
        let mut next = || lines.next().expect("unexpected end of reference file");
        let parts: Vec<&str> = header.split_whitespace().collect();
        assert_eq!(parts[0], "case");
        let band = match parts[3] {
            "lowpass" => BandType::Lowpass,
            "highpass" => BandType::Highpass,
            "bandpass" => BandType::Bandpass,
            "bandstop" => BandType::Bandstop,
            other => panic!("unknown band {other}"),
        };
        let corners = parts[4..].iter().map(|v| v.parse().unwrap()).collect();
        let ns: usize = next().strip_prefix("sos ").unwrap().parse().unwrap();
        let sos = (0..ns)
            .map(|_| {
                let v: Vec<f64> = next()
                    .split_whitespace()
                    .map(|x| x.parse().unwrap())
                    .collect();
                [v[0], v[1], v[2], v[3], v[4], v[5]]
            })
            .collect();
        let no: usize = next().strip_prefix("output ").unwrap().parse().unwrap();
        let output = (0..no).map(|_| next().parse().unwrap()).collect();
        cases.push(ReferenceCase {
            name: parts[1].into(),
            order: parts[2].parse().unwrap(),
            band,
            corners,
            sos,
            output,
        });
    }
    (fs, input, cases)
}

/// Butterworth sections equal scipy's (same order of sections) to 1e-12,
/// and sosfiltfilt output equals scipy's to 1e-9 relative (max abs diff /
/// max abs of scipy output), for band-pass, high-pass, low-pass, odd orders
/// and band-stop.
#[test]
fn butterworth_and_sosfiltfilt_match_scipy() {
    let (fs, input, cases) = load_reference();
    assert_eq!(cases.len(), 7);
    for case in &cases {
        let sos = butter_sos(case.order, case.band, &case.corners, fs).unwrap();
        assert_eq!(sos.len(), case.sos.len(), "{}: section count", case.name);
        let mut worst_coef: f64 = 0.0;
        for (mine, theirs) in sos.iter().zip(&case.sos) {
            for (a, b) in mine.iter().zip(theirs) {
                worst_coef = worst_coef.max((a - b).abs());
            }
        }
        assert!(
            worst_coef <= 1e-12,
            "{}: sos differ from scipy by {worst_coef:e}",
            case.name
        );
        let y = sosfiltfilt(&sos, &input).unwrap();
        let scale = case.output.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let diff = y
            .iter()
            .zip(&case.output)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        let relative = diff / scale;
        eprintln!(
            "{}: max sos diff {worst_coef:.2e}, sosfiltfilt relative diff {relative:.2e}",
            case.name
        );
        assert!(
            relative <= 1e-9,
            "{}: sosfiltfilt differs from scipy by {relative:e} (relative)",
            case.name
        );
    }
}

#[test]
fn order4_bandpass_is_four_sections_and_parallel_equals_serial() {
    let sos = butter_sos(4, BandType::Bandpass, &[0.5, 20.0], 200.0).unwrap();
    assert_eq!(sos.len(), 4);
    // 19 channels: one full group of 8 lanes and a partial one at 2000
    // samples, three at 1500, one non-finite and one too short (the
    // per-channel path and its errors), so every grouping case is met.
    let mut channels: Vec<Vec<f64>> = (0..19)
        .map(|c| {
            let n = if c % 6 == 5 { 1500 } else { 2000 };
            (0..n)
                .map(|i| ((i * (c + 3)) as f64 * 0.013).sin() + 0.1 * c as f64)
                .collect()
        })
        .collect();
    channels[7][100] = f64::NAN;
    channels[12].truncate(20);
    // 2 and 4 sections (fixed kernels) and 13 (the generic one).
    for order in [2, 4, 13] {
        let sos = butter_sos(order, BandType::Bandpass, &[0.5, 20.0], 200.0).unwrap();
        let parallel = sosfiltfilt_channels(&sos, &channels);
        let serial: Vec<_> = channels.iter().map(|c| sosfiltfilt(&sos, c)).collect();
        match parallel {
            Ok(_) => panic!("order {order}: a non-finite channel must fail"),
            Err(e) => assert_eq!(e.to_string(), serial[7].as_ref().unwrap_err().to_string()),
        }
        let good: Vec<Vec<f64>> = channels
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != 7 && *i != 12)
            .map(|(_, c)| c.clone())
            .collect();
        let parallel = sosfiltfilt_channels(&sos, &good).unwrap();
        for (c, p) in good.iter().zip(&parallel) {
            // Bit for bit: same operations in the same order per lane.
            assert_eq!(&sosfiltfilt(&sos, c).unwrap(), p, "order {order}");
        }
    }
}

#[test]
fn sosfiltfilt_refuses_non_finite_and_short_input() {
    let sos = butter_sos(4, BandType::Bandpass, &[0.5, 20.0], 200.0).unwrap();
    let mut x = vec![0.0; 100];
    x[50] = f64::NAN;
    assert!(sosfiltfilt(&sos, &x).is_err());
    assert!(sosfiltfilt(&sos, &[1.0; 10]).is_err());
}

#[test]
fn taper_shape_and_detrend() {
    let mut d = vec![1.0; 100];
    let m = cosine_taper(&mut d, 0.1).unwrap();
    assert_eq!(m, 10);
    assert_eq!(d[0], 0.0);
    assert_eq!(d[99], 0.0);
    // w(5) = ½(1 − cos(π/2)) = 0.5, symmetric at the end.
    assert!((d[5] - 0.5).abs() < 1e-15 && (d[94] - 0.5).abs() < 1e-15);
    assert!(d[10..90].iter().all(|&v| v == 1.0));
    assert!(cosine_taper(&mut d, 0.6).is_err());

    let mut line: Vec<f64> = (0..500).map(|i| 2.0 + 0.3 * i as f64).collect();
    remove_linear_trend(&mut line).unwrap();
    assert!(line.iter().all(|v| v.abs() < 1e-10));
    // Order-5 polynomial over a long record (well conditioned in scaled time).
    let n = 20_000;
    let mut p: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 * 0.005;
            1.0 + 1e-2 * t - 3e-4 * t * t + 2e-6 * t.powi(3) - 1e-8 * t.powi(4) + 1e-11 * t.powi(5)
        })
        .collect();
    remove_polynomial(&mut p, 5).unwrap();
    let worst = p.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(worst < 1e-9, "residual {worst:e}");
}

fn channel(id: &str, units: Units, rate: f64) -> Channel {
    Channel::new(
        id,
        units,
        rate,
        SourceRef {
            file: "event/records.csv".into(),
            member: None,
            column: Some(id.into()),
            format: "csv".into(),
        },
    )
}

#[test]
fn counts_without_sensitivity_error_names_the_channel() {
    let mut event = Event::default();
    event.records.push(Record::new(
        channel(
            "B1",
            Units::Counts {
                counts_per_si: None,
            },
            100.0,
        ),
        vec![1.0; 1000],
    ));
    let err =
        conditioning::condition_event(&mut event, &ConditioningSettings::default()).unwrap_err();
    match &err {
        Error::Input { location, .. } => assert_eq!(location.channel.as_deref(), Some("B1")),
        other => panic!("unexpected error {other}"),
    }
    assert!(err.to_string().contains("B1"));
}

#[test]
fn non_finite_values_are_flagged_and_refused() {
    let mut event = Event::default();
    let mut x = vec![0.0; 1000];
    x[10] = f64::INFINITY;
    x[20] = f64::NAN;
    event
        .records
        .push(Record::new(channel("F2", Units::G, 100.0), x));
    let err =
        conditioning::condition_event(&mut event, &ConditioningSettings::default()).unwrap_err();
    assert!(
        err.to_string().contains("F2") && err.to_string().contains("2 non-finite"),
        "{err}"
    );
    assert!(event.records[0]
        .channel
        .qa
        .contains(&QaFlag::NonFinite { count: 2 }));
}

#[test]
fn units_conversion_and_history_of_default_chain() {
    let mut event = Event::default();
    let n = 4000;
    let x: Vec<f64> = (0..n)
        .map(|i| 0.1 * (2.0 * std::f64::consts::PI * 2.0 * i as f64 / 200.0).sin() + 0.02)
        .collect();
    event
        .records
        .push(Record::new(channel("A", Units::G, 200.0), x.clone()));
    let motions =
        conditioning::condition_event_with_motion(&mut event, &ConditioningSettings::default())
            .unwrap();
    let steps: Vec<&str> = event
        .history
        .steps
        .iter()
        .map(|s| s.step.as_str())
        .collect();
    assert_eq!(
        steps,
        [
            "qa",
            "units_to_si",
            "detrend",
            "taper",
            "filter",
            "integrate"
        ]
    );
    assert_eq!(event.records[0].channel.units, Units::MPerS2);
    assert_eq!(event.history.steps[4].params["order"], 4);
    assert_eq!(motions.len(), 1);
    // 2 Hz sine of 0.1 g is in the pass band: amplitude in the middle is kept
    // (taper and filter edges excluded) to 1e-3.
    let expected = 0.1 * 9.80665;
    let mid_peak = event.records[0].samples[1000..3000]
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(
        (mid_peak / expected - 1.0).abs() < 1e-3,
        "mid peak {mid_peak} vs {expected}"
    );
}

#[test]
fn settings_deserialize_with_defaults_and_minimal_has_no_filter() {
    let s: ConditioningSettings = serde_json::from_str("{}").unwrap();
    assert_eq!(s, ConditioningSettings::default());
    let Some(Step::Filter(f)) = s.step("filter") else {
        panic!("default filter")
    };
    assert_eq!(
        (f.order, f.band, f.corners_hz.clone(), f.zero_phase),
        (4, BandType::Bandpass, vec![0.5, 20.0], true)
    );
    assert_eq!(s.step("taper"), Some(&Step::Taper { fraction: 0.05 }));
    let s: ConditioningSettings = toml::from_str(
        "taper_fraction = 0.1\n[filter]\norder = 2\nband = \"highpass\"\ncorners_hz = [0.1]\n",
    )
    .unwrap();
    let Some(Step::Filter(f)) = s.step("filter") else {
        panic!("filter")
    };
    assert_eq!(f.order, 2);
    let m = ConditioningSettings::minimal();
    assert!(
        m.step("filter").is_none() && m.step("taper").is_none() && m.step("integrate").is_some()
    );
}

#[test]
fn steps_list_reads_in_order_and_equals_the_keyed_form() {
    let listed: ConditioningSettings = toml::from_str(
        r#"steps = [
  { step = "detrend", method = "mean" },
  { step = "taper", fraction = 0.05 },
  { step = "filter", order = 4, band = "bandpass", corners_hz = [0.5, 20.0], zero_phase = true },
  { step = "integrate", drift = { method = "polynomial", velocity_order = 1, displacement_order = 2 } },
]"#,
    )
    .unwrap();
    assert_eq!(listed, ConditioningSettings::default());
    // Another order is another chain: a filter before the taper.
    let swapped: ConditioningSettings = toml::from_str(
        "steps = [{ step = \"filter\", order = 2, band = \"highpass\", corners_hz = [0.1] }, { step = \"taper\", fraction = 0.1 }]",
    )
    .unwrap();
    let names: Vec<&str> = swapped.steps.iter().map(|s| s.name()).collect();
    assert_eq!(names, ["filter", "taper"]);
    // No steps: QA and SI units only.
    let none: ConditioningSettings = toml::from_str("steps = []").unwrap();
    assert!(none.steps.is_empty());
    // Both forms at once, an unknown step, a step key misspelt: refused.
    for bad in [
        "steps = []\ntaper_fraction = 0.1",
        "steps = [{ step = \"smooth\" }]",
        "steps = [{ step = \"taper\", fracton = 0.1 }]",
    ] {
        assert!(
            toml::from_str::<ConditioningSettings>(bad).is_err(),
            "{bad}"
        );
    }
    // Integration must come last.
    let late: ConditioningSettings =
        toml::from_str("steps = [{ step = \"integrate\" }, { step = \"taper\", fraction = 0.1 }]")
            .unwrap();
    assert!(late
        .validate()
        .unwrap_err()
        .to_string()
        .contains("last step"));
}

#[test]
fn reversed_sensor_is_flipped_and_off_axis_pair_rotated() {
    let n = 200;
    let signal: Vec<f64> = (0..n).map(|i| (i as f64 * 0.1).sin()).collect();
    let mut floor = channel("F1", Units::MPerS2, 100.0);
    floor.direction = Some(Direction::Azimuth(171.0));
    floor.level = Some(1);
    let mut base = channel("B1", Units::MPerS2, 100.0);
    base.direction = Some(Direction::Azimuth(351.0));
    base.level = Some(0);
    // Off-axis orthogonal pair at level 2: sensors at 30° and 120°, building X at 171°.
    let (az1, az2) = (30.0f64, 120.0f64);
    let x_az = 171.0f64;
    let y_az = x_az - 90.0;
    // A true motion vector along X with amplitude `signal`: sensor reading = s·cos(α − X).
    let s1: Vec<f64> = signal
        .iter()
        .map(|s| s * (az1 - x_az).to_radians().cos())
        .collect();
    let s2: Vec<f64> = signal
        .iter()
        .map(|s| s * (az2 - x_az).to_radians().cos())
        .collect();
    let mut p1 = channel("P1", Units::MPerS2, 100.0);
    p1.direction = Some(Direction::Azimuth(az1));
    p1.level = Some(2);
    let mut p2 = channel("P2", Units::MPerS2, 100.0);
    p2.direction = Some(Direction::Azimuth(az2));
    p2.level = Some(2);
    let mut lonely = channel("L", Units::MPerS2, 100.0);
    lonely.direction = Some(Direction::Azimuth(45.0));
    lonely.level = Some(3);
    let mut records = vec![
        Record::new(floor, signal.clone()),
        Record::new(base, signal.clone()),
        Record::new(p1, s1),
        Record::new(p2, s2),
        Record::new(lonely, signal.clone()),
    ];
    let actions = normalise_orientation(
        &mut records,
        &OrientationSettings {
            x_azimuth_deg: x_az,
            y_azimuth_deg: None,
            tolerance_deg: 5.0,
        },
    )
    .unwrap();
    assert_eq!(records[0].samples, signal);
    assert_eq!(records[0].channel.direction, Some(Direction::Axis(Axis::X)));
    assert!(records[1]
        .samples
        .iter()
        .zip(&signal)
        .all(|(a, b)| *a == -*b));
    assert_eq!(records[1].channel.direction, Some(Direction::Axis(Axis::X)));
    let x_rec = records
        .iter()
        .find(|r| {
            r.channel.direction == Some(Direction::Axis(Axis::X)) && r.channel.level == Some(2)
        })
        .unwrap();
    let y_rec = records
        .iter()
        .find(|r| {
            r.channel.direction == Some(Direction::Axis(Axis::Y)) && r.channel.level == Some(2)
        })
        .unwrap();
    for i in 0..n {
        assert!((x_rec.samples[i] - signal[i]).abs() < 1e-12);
        assert!(y_rec.samples[i].abs() < 1e-12);
    }
    assert_eq!(y_az, 81.0);
    let kinds: Vec<(&str, &str)> = actions
        .iter()
        .map(|a| (a.channel.as_str(), a.action.as_str()))
        .collect();
    assert!(
        kinds.contains(&("B1", "flip"))
            && kinds.contains(&("F1", "relabel"))
            && kinds.contains(&("L", "unresolved"))
    );
    assert_eq!(kinds.iter().filter(|k| k.1 == "rotate").count(), 2);
}

#[test]
fn resampling_keeps_passband_and_removes_alias() {
    // 250 Hz → 200 Hz (ratio 4/5). A 5 Hz sine is preserved in the interior
    // to 1e-3; a 120 Hz sine (above the new 100 Hz Nyquist, 20 % past the
    // anti-alias cut-off) is attenuated below 1e-2 (Kaiser β = 5 transition
    // band ≈ 85–115 Hz here).
    let fs_in = 250.0;
    let n = 5000;
    let t = |i: usize, fs: f64| i as f64 / fs;
    let low: Vec<f64> = (0..n)
        .map(|i| (2.0 * std::f64::consts::PI * 5.0 * t(i, fs_in)).sin())
        .collect();
    let y = resample_to_rate(&low, fs_in, 200.0).unwrap();
    assert_eq!(y.len(), 4000);
    let worst = (200..3800)
        .map(|k| (y[k] - (2.0 * std::f64::consts::PI * 5.0 * t(k, 200.0)).sin()).abs())
        .fold(0.0f64, f64::max);
    assert!(worst < 1e-3, "pass-band error {worst:e}");
    let high: Vec<f64> = (0..n)
        .map(|i| (2.0 * std::f64::consts::PI * 120.0 * t(i, fs_in)).sin())
        .collect();
    let y = resample_to_rate(&high, fs_in, 200.0).unwrap();
    let leak = y[200..3800].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(leak < 1e-2, "alias leakage {leak:e}");
    assert!(resample_to_rate(&low, 200.0, 200.0 * std::f64::consts::PI).is_err());
}

#[test]
fn alignment_trims_to_common_window_and_rejects_disjoint_records() {
    let mut a = channel("A", Units::MPerS2, 100.0);
    a.start_ns = Some(1_000_000_000);
    let mut b = channel("B", Units::MPerS2, 100.0);
    b.start_ns = Some(1_500_000_000); // starts 50 samples later
    let mut records = vec![
        Record::new(a.clone(), (0..1000).map(|i| i as f64).collect::<Vec<_>>()),
        Record::new(b.clone(), (0..800).map(|i| i as f64).collect::<Vec<_>>()),
    ];
    let al = align_records(&mut records).unwrap();
    assert_eq!(al.samples, 800.min(1000 - 50));
    assert_eq!(al.trimmed_start, vec![50, 0]);
    assert_eq!(records[0].samples[0], 50.0);
    assert_eq!(records[0].channel.start_ns, Some(1_500_000_000));
    assert_eq!(records[0].len(), records[1].len());
    b.start_ns = Some(20_000_000_000);
    let mut records = vec![
        Record::new(a, vec![0.0; 100]),
        Record::new(b, vec![0.0; 100]),
    ];
    assert!(align_records(&mut records).is_err());
}

/// Drift control on a known displacement u(t) = A sin²(πt/T) sin(2πft),
/// whose acceleration is computed analytically, with a constant baseline
/// error of 2 mm/s² added: plain integration drifts by ½·0.002·T² = 0.4 m;
/// polynomial drift control recovers u to 0.1 % of A (measured 1.7e-4),
/// the 0.1 Hz high-pass to 2 % (measured 6.7e-3).
#[test]
fn integration_drift_control_recovers_known_displacement() {
    let (amp, f, dur, dt) = (0.05f64, 1.0f64, 20.0f64, 0.005f64);
    let n = (dur / dt) as usize + 1;
    let pi = std::f64::consts::PI;
    let (w, k) = (2.0 * pi * f, pi / dur);
    let mut truth_u = Vec::with_capacity(n);
    let mut acc = Vec::with_capacity(n);
    for i in 0..n {
        let t = i as f64 * dt;
        let (e, de, dde) = (
            (k * t).sin().powi(2),
            k * (2.0 * k * t).sin(),
            2.0 * k * k * (2.0 * k * t).cos(),
        );
        let (s, ds, dds) = ((w * t).sin(), w * (w * t).cos(), -w * w * (w * t).sin());
        truth_u.push(amp * e * s);
        acc.push(amp * (dde * s + 2.0 * de * ds + e * dds) + 0.002);
    }
    let err = |u: &[f64]| {
        u.iter()
            .zip(&truth_u)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
            / amp
    };
    let plain = integrate_motion("c", &acc, dt, &DriftControl::None).unwrap();
    let poly = integrate_motion(
        "c",
        &acc,
        dt,
        &DriftControl::Polynomial {
            velocity_order: 1,
            displacement_order: 2,
        },
    )
    .unwrap();
    let hp = integrate_motion(
        "c",
        &acc,
        dt,
        &DriftControl::Highpass {
            corner_hz: 0.1,
            order: 4,
        },
    )
    .unwrap();
    eprintln!(
        "relative displacement error: none {:.3e}, polynomial {:.3e}, highpass {:.3e}",
        err(&plain.displacement),
        err(&poly.displacement),
        err(&hp.displacement)
    );
    assert!(err(&plain.displacement) > 5.0);
    assert!(err(&poly.displacement) < 1e-3);
    assert!(err(&hp.displacement) < 0.02);
    // Polynomial drift control keeps a, v, u consistent: re-integrating the
    // corrected acceleration gives the corrected velocity (trapezoid-exact).
    let v_again = cumulative_trapezoid(&poly.acceleration, dt);
    let offset = poly.velocity[0] - v_again[0];
    let worst = v_again
        .iter()
        .zip(&poly.velocity)
        .fold(0.0f64, |m, (a, b)| m.max((a + offset - b).abs()));
    assert!(worst < 1e-9, "velocity inconsistency {worst:e}");
}

#[test]
fn qa_detects_clipping_flat_spikes_and_low_snr() {
    let dt = 0.01;
    let n = 6000;
    // Pre-event noise (deterministic pseudo-random) then a strong 2 Hz burst.
    let mut state = 0x1234_5678_9abc_def0u64;
    let mut noise = || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) as f64 / u64::MAX as f64) - 0.5
    };
    let mut x: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 * dt;
            let burst = if (20.0..40.0).contains(&t) {
                (2.0 * std::f64::consts::PI * 2.0 * t).sin()
            } else {
                0.0
            };
            burst + 0.001 * noise()
        })
        .collect();
    let settings = qa::QaSettings::default();
    let clean = qa::quality_flags(&x, dt, &settings);
    assert!(clean.is_empty(), "clean record flagged: {clean:?}");
    let snr = qa::snr_db(&x, dt, 2.0).unwrap();
    assert!(snr > 50.0, "snr {snr}");
    // Spikes at three isolated places.
    for &i in &[500usize, 2500, 5000] {
        x[i] += 0.5;
    }
    assert_eq!(
        qa::spike_indices(&x, settings.spike_threshold),
        vec![500, 2500, 5000]
    );
    // Clip the burst at 0.8: runs at ±0.8.
    let clipped: Vec<f64> = x.iter().map(|v| v.clamp(-0.8, 0.8)).collect();
    match qa::detect_clipping(&clipped, 5, 1e-9) {
        Some(QaFlag::Clipping { samples, level }) => {
            assert_eq!(level, 0.8);
            assert!(samples > 100, "{samples}");
        }
        other => panic!("no clipping flag: {other:?}"),
    }
    assert!(qa::detect_clipping(&x, 5, 1e-9).is_none());
    // A 2 s flat segment starting at 45 s.
    let mut flat = x.clone();
    for v in &mut flat[4500..4700] {
        *v = 0.25;
    }
    let flags = qa::detect_flat_segments(&flat, dt, 1.0);
    assert_eq!(flags.len(), 1);
    match flags[0] {
        QaFlag::FlatSegment { at_s, duration_s } => {
            assert!((at_s - 45.0).abs() < 1e-9 && (duration_s - 1.99).abs() < 1e-9)
        }
        _ => unreachable!(),
    }
    // Noise only: low SNR.
    let only_noise: Vec<f64> = (0..n).map(|_| noise()).collect();
    let flags = qa::quality_flags(&only_noise, dt, &settings);
    assert!(
        flags.iter().any(|f| matches!(f, QaFlag::LowSnr { .. })),
        "{flags:?}"
    );
}

// The building blocks on their own: polynomial detrend, Butterworth design,
// the filter's initial state, cumulative integration.

#[test]
fn cubic_is_removed_exactly() {
    let n = 1001;
    let mut d: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 * 0.01;
            3.0 - 2.0 * t + 0.5 * t * t - 0.01 * t * t * t
        })
        .collect();
    remove_polynomial(&mut d, 3).unwrap();
    assert!(
        d.iter().all(|v| v.abs() < 1e-9),
        "max residual {}",
        d.iter().fold(0.0f64, |m, v| m.max(v.abs()))
    );
}

#[test]
fn bandpass_order4_has_four_sections_with_unit_a0() {
    let sos = butter_sos(4, BandType::Bandpass, &[0.5, 20.0], 200.0).unwrap();
    assert_eq!(sos.len(), 4);
    assert!(sos.iter().all(|s| s[3] == 1.0));
}

#[test]
fn rejects_corner_above_nyquist() {
    assert!(butter_sos(4, BandType::Lowpass, &[150.0], 200.0).is_err());
    assert!(butter_sos(4, BandType::Bandpass, &[20.0, 0.5], 200.0).is_err());
}

#[test]
fn zi_gives_steady_state_for_a_step() {
    let sos = butter_sos(4, BandType::Lowpass, &[10.0], 100.0).unwrap();
    let mut zi = sosfilt_zi(&sos).unwrap();
    let mut ones = vec![1.0; 50];
    sosfilt_in_place(&sos, &mut ones, &mut zi).unwrap();
    assert!(ones.iter().all(|v| (v - 1.0).abs() < 1e-12));
}

#[test]
fn too_short_signal_is_an_error() {
    let sos = butter_sos(4, BandType::Bandpass, &[0.5, 20.0], 200.0).unwrap();
    assert_eq!(sosfiltfilt_padlen(&sos), 27);
    assert!(sosfiltfilt(&sos, &[0.0; 27]).is_err());
    assert!(sosfiltfilt(&sos, &[0.0; 28]).is_ok());
}

#[test]
fn trapezoid_starts_at_zero_and_is_exact_for_a_line() {
    assert!(cumulative_trapezoid(&[], 0.1).is_empty());
    assert_eq!(cumulative_trapezoid(&[3.0], 0.1), vec![0.0]);
    // ∫₀ᵗ 2s ds = t² at t = 0, 0.5, 1.
    assert_eq!(
        cumulative_trapezoid(&[0.0, 1.0, 2.0], 0.5),
        vec![0.0, 0.25, 1.0]
    );
}

/// The integration that parks each series as soon as it is final (two
/// series of a day-long channel held, not three) gives the values of
/// correcting all three together — the three-series algorithm, written out
/// here — bit for bit, for every drift control; and it parks the
/// acceleration first, then the velocity, then the displacement.
#[test]
fn integration_parking_each_series_when_final_gives_the_three_series_values() {
    use quaketwin::conditioning::baseline::{fit_polynomial, for_each_polynomial_value};
    use quaketwin::conditioning::integrate_motion_parking;
    use quaketwin::vocab::Samples;
    use std::sync::Mutex;
    let dt = 0.005;
    let acc: Vec<f64> = (0..20_000)
        .map(|i| {
            let t = i as f64 * dt;
            (3.1 * t).sin() * (-0.05 * t).exp() + 0.01 * (17.0 * t).cos() + 1e-3
        })
        .collect();
    // Removes the polynomial fitted to `target` from it and its derivatives
    // from the lower derivatives (the correction, all series at once).
    let remove = |target: &mut [f64], lower: &mut [f64], lowest: Option<&mut [f64]>, order| {
        let n = target.len();
        let c = fit_polynomial(target, order).unwrap();
        let ds_dt = 2.0 / ((n - 1) as f64 * dt);
        let mut lowest = lowest;
        for_each_polynomial_value(&c, n, |i, v, d1, d2| {
            target[i] -= v;
            lower[i] -= d1 * ds_dt;
            if let Some(l) = lowest.as_deref_mut() {
                l[i] -= d2 * ds_dt * ds_dt;
            }
        });
    };
    let mut a = acc.clone();
    let mut v = cumulative_trapezoid(&a, dt);
    remove(&mut v, &mut a, None, 1);
    let mut u = cumulative_trapezoid(&v, dt);
    remove(&mut u, &mut v, Some(&mut a), 2);
    let bits = |s: &[f64]| s.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let parked = Mutex::new(Vec::new());
    let park = |values: Vec<f64>| {
        parked.lock().unwrap().push(bits(&values));
        Ok(Samples::new(values))
    };
    let polynomial = DriftControl::Polynomial {
        velocity_order: 1,
        displacement_order: 2,
    };
    let m = integrate_motion_parking("c", acc.clone(), dt, &polynomial, &park).unwrap();
    assert_eq!(bits(&m.acceleration), bits(&a));
    assert_eq!(bits(&m.velocity), bits(&v));
    assert_eq!(bits(&m.displacement), bits(&u));
    assert_eq!(*parked.lock().unwrap(), [bits(&a), bits(&v), bits(&u)]);
    // No drift control and the high-pass: integrals of the series before.
    let none = integrate_motion_parking("c", acc.clone(), dt, &DriftControl::None, &park).unwrap();
    let v0 = cumulative_trapezoid(&acc, dt);
    assert_eq!(bits(&none.velocity), bits(&v0));
    assert_eq!(
        bits(&none.displacement),
        bits(&cumulative_trapezoid(&v0, dt))
    );
    let highpass = DriftControl::Highpass {
        corner_hz: 0.1,
        order: 4,
    };
    let hp = integrate_motion_parking("c", acc.clone(), dt, &highpass, &park).unwrap();
    let sos = butter_sos(4, BandType::Highpass, &[0.1], 1.0 / dt).unwrap();
    let vh = sosfiltfilt(&sos, &v0).unwrap();
    let uh = sosfiltfilt(&sos, &cumulative_trapezoid(&vh, dt)).unwrap();
    assert_eq!(bits(&hp.acceleration), bits(&acc));
    assert_eq!(bits(&hp.velocity), bits(&vh));
    assert_eq!(bits(&hp.displacement), bits(&uh));
    // The in-memory integration is the same function.
    let in_memory = integrate_motion("c", &acc, dt, &polynomial).unwrap();
    assert_eq!(bits(&in_memory.displacement), bits(&u));
}

/// The polynomial baseline is evaluated and fitted several samples side by
/// side: each value and derivative must be the one of a sample at a time,
/// bit for bit (the Legendre recurrence and the sums in the same order).
#[test]
fn polynomial_baseline_in_blocks_is_sample_by_sample() {
    use quaketwin::conditioning::baseline::{fit_polynomial, for_each_polynomial_value};
    // Legendre values and their first two derivatives at sample i of n, a
    // sample at a time (Bonnet and derivative recurrences).
    let legendre = |i: usize, n: usize, order: usize| -> [Vec<f64>; 3] {
        let x = if n <= 1 {
            0.0
        } else {
            2.0 * i as f64 / (n - 1) as f64 - 1.0
        };
        let mut p = vec![1.0; order + 1];
        if order >= 1 {
            p[1] = x;
        }
        for k in 1..order {
            let kf = k as f64;
            p[k + 1] = ((2.0 * kf + 1.0) * x * p[k] - kf * p[k - 1]) / (kf + 1.0);
        }
        let (mut dp, mut ddp) = (vec![0.0; order + 1], vec![0.0; order + 1]);
        for k in 1..=order {
            dp[k] = if k == 1 {
                1.0
            } else {
                dp[k - 2] + (2 * k - 1) as f64 * p[k - 1]
            };
            if k >= 2 {
                ddp[k] = ddp[k - 2] + (2 * k - 1) as f64 * dp[k - 1];
            }
        }
        [p, dp, ddp]
    };
    for n in [1, 2, 7, 8, 9, 23, 64, 101] {
        let data: Vec<f64> = (0..n)
            .map(|i| (i as f64 * 0.37).sin() * 3.0 + i as f64 * 0.01)
            .collect();
        for order in 0..=5usize.min(n - 1) {
            let c = fit_polynomial(&data, order).unwrap();
            let mut seen = 0;
            for_each_polynomial_value(&c, n, |i, v, d1, d2| {
                assert_eq!(i, seen);
                let want = legendre(i, n, order)
                    .map(|b| b.iter().zip(&c).map(|(b, c)| b * c).sum::<f64>().to_bits());
                assert_eq!(
                    [v.to_bits(), d1.to_bits(), d2.to_bits()],
                    want,
                    "n {n} order {order} sample {i}"
                );
                seen += 1;
            });
            assert_eq!(seen, n);
        }
    }
}
