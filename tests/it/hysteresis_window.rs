//! The identification window of the Bouc-Wen stage (`hysteresis::window`):
//! a triggered record is identified whole; a long record is cut to its
//! strong motion with margins, identified as the event alone is, with times
//! from the record's start; the window is bounded by `window.max_s`.

use std::path::Path;

use quaketwin::hysteresis::{
    auto_directions, identification_window, DirectionOutcome, WindowRule, WindowSettings,
};
use quaketwin::rng::Rng;
use quaketwin::stages::hysteresis::{identify_event_at, HysteresisParams};
use quaketwin::vocab::{Event, Record, Samples};

fn sample_event(name: &str) -> Event {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("sample-records")
        .join(name);
    quaketwin::event_folder::load(&dir).unwrap().event
}

/// Base and floor records of every automatic direction of `event`.
fn directions(event: &Event) -> Vec<(String, Vec<&Record>)> {
    let (specs, _) = auto_directions(event);
    specs
        .iter()
        .map(|s| {
            let ids = std::iter::once(&s.base).chain(&s.floors);
            let records = ids.map(|id| event.record(id).unwrap()).collect();
            (s.direction.clone(), records)
        })
        .collect()
}

/// `event` with `before_s` and `after_s` seconds of quiet motion (white
/// noise at 1e-4 of each channel's peak) around every record: a continuous
/// record around the event.
fn padded(event: &Event, before_s: f64, after_s: f64) -> Event {
    let mut out = event.clone();
    let mut rng = Rng::new(7);
    for r in out.records.iter_mut() {
        let fs = r.channel.sampling_rate_hz;
        let x = r.samples.load().unwrap().into_owned();
        let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let mut quiet = |s: f64| rng.normal_vec((s * fs).round() as usize, 1e-4 * peak);
        let mut y = quiet(before_s);
        y.extend_from_slice(&x);
        y.extend(quiet(after_s));
        r.samples = Samples::new(y);
    }
    out
}

/// The bundled sample events are triggered records: each is its own
/// window, so their identification is what it was without windows.
#[test]
fn the_sample_events_are_identified_whole() {
    for name in ["synthetic-4storey-quake", "synthetic-2storey-yielding"] {
        let event = sample_event(name);
        let dirs = directions(&event);
        assert!(!dirs.is_empty(), "{name}");
        for (direction, records) in dirs {
            let w =
                identification_window(&direction, &records, &WindowSettings::default()).unwrap();
            let n = records[0].samples.len();
            assert_eq!(w.samples, 0..n, "{name} {direction}: {w:?}");
            assert!(w.strong_motion.is_some(), "{name} {direction}");
        }
    }
}

/// Around a long quiet record the window is the event's strong motion,
/// shifted, widened by the margins; the record rule takes all of it.
#[test]
fn a_long_record_is_cut_to_its_strong_motion_with_margins() {
    let event = sample_event("synthetic-2storey-yielding");
    let long = padded(&event, 300.0, 200.0);
    let settings = WindowSettings::default();
    let (direction, records) = &directions(&event)[0];
    let (_, long_records) = &directions(&long)[0];
    let fs = records[0].channel.sampling_rate_hz;
    let own = identification_window(direction, records, &settings).unwrap();
    let w = identification_window(direction, long_records, &settings).unwrap();
    let shift = (300.0 * fs) as usize;
    let strong = own.strong_motion.unwrap();
    assert_eq!(
        w.strong_motion,
        Some(strong.start + shift..strong.end + shift)
    );
    let margin = (settings.margin_s * fs) as usize;
    assert_eq!(
        w.samples,
        strong.start + shift - margin..strong.end + shift + margin
    );
    assert_eq!(w.record_samples, long_records[0].samples.len());
    let record = WindowSettings {
        rule: WindowRule::Record,
        ..settings
    };
    let all = identification_window(direction, long_records, &record).unwrap();
    assert_eq!(all.samples, 0..long_records[0].samples.len());
    assert_eq!(all.strong_motion, None);
}

/// The yielding chain of the sample event (`two_dof_chain`, recorded at 250 Hz)
/// under its earthquake 300 s into a 470 s record of a still ground: a
/// continuous record.  Its strong-motion window is identified as the sample
/// is (N within 0.01 of the truth, K0_dd within 1 %), with the times of the
/// outputs counted from the start of the long record.
#[test]
fn a_long_record_is_identified_on_its_window() {
    use quaketwin::synth::{synthetic_ground_motion, GroundMotionSpec};
    use quaketwin::vocab::Structure;
    let chain = crate::hysteresis::two_dof_chain();
    let quake = synthetic_ground_motion(&GroundMotionSpec::strong_50s(2033, 1000.0, 3.5)).unwrap();
    let (before, after) = (300_000, 120_000); // samples at 1000 Hz
    let mut ground = vec![0.0; before];
    ground.extend(&quake);
    ground.resize(ground.len() + after, 0.0);
    let response = chain.simulate(&ground, 1000.0, 4).unwrap().subsample(4);
    let record = |id: &str, level: i32, samples: Vec<f64>| {
        crate::common::x_record(id, level, 250.0, "long.csv", samples)
    };
    let mut records = vec![record(
        "B-X",
        0,
        ground.iter().step_by(4).copied().collect(),
    )];
    for (d, a) in response.absolute_acceleration.iter().enumerate() {
        records.push(record(&format!("F{}-X", d + 1), d as i32 + 1, a.clone()));
    }
    let event = Event {
        name: "long record".into(),
        structure: Some(Structure {
            storey_heights_m: vec![3.5, 3.5],
            masses_kg: vec![1e5, 1e5],
            ..Structure::default()
        }),
        records,
        ..Event::default()
    };
    let params = HysteresisParams {
        instantaneous: false,
        ..HysteresisParams::default()
    };
    let (outcomes, _) = identify_event_at(&event, None, &params).unwrap();
    let Some(DirectionOutcome::Identified(id)) = outcomes.first() else {
        panic!("not identified");
    };
    let (_, channels) = &directions(&event)[0];
    let w = identification_window("X", channels, &WindowSettings::default()).unwrap();
    let strong = w.strong_motion.clone().unwrap();
    eprintln!(
        "window {:?} s, strong motion {:?} s",
        (w.samples.start as f64 / 250.0, w.samples.end as f64 / 250.0),
        (strong.start as f64 / 250.0, strong.end as f64 / 250.0)
    );
    assert!(w.samples.start > 0 && w.samples.len() < w.record_samples);
    assert_eq!(id.start_s, w.start_s());
    assert!(id.start_s > 280.0 && id.start_s < 300.0, "{}", id.start_s);
    assert_eq!(id.damage.time_s[0], id.start_s);
    for (dof, (n, k)) in id.dofs.iter().zip([(1.4, 1e8), (2.2, 4e7)]) {
        eprintln!("DoF {}: N {} K0_dd {:?}", dof.dof, dof.exponent, dof.k0);
        assert!((dof.exponent - n).abs() <= 0.01, "DoF {}", dof.dof);
        let k0_dd = *dof.k0.last().unwrap();
        assert!((k0_dd - k).abs() < 0.01 * k, "DoF {}: {k0_dd}", dof.dof);
    }
}

/// A window longer than `max_s` makes the direction not identifiable,
/// naming the setting; bad settings are refused.
#[test]
fn the_window_is_bounded_by_max_s() {
    let long = padded(&sample_event("synthetic-2storey-yielding"), 60.0, 60.0);
    let params = HysteresisParams {
        window: WindowSettings {
            rule: WindowRule::Record,
            max_s: 100.0,
            ..WindowSettings::default()
        },
        ..HysteresisParams::default()
    };
    let (outcomes, _) = identify_event_at(&long, None, &params).unwrap();
    match &outcomes[0] {
        DirectionOutcome::NotIdentifiable { reason, .. } => {
            assert!(reason.contains("window.max_s = 100 s"), "{reason}");
            assert!(reason.contains("170.0 s"), "{reason}");
        }
        DirectionOutcome::Identified(_) => panic!("identified over a 170 s window"),
    }
    for bad in [
        WindowSettings {
            threshold: 0.0,
            ..WindowSettings::default()
        },
        WindowSettings {
            margin_s: -1.0,
            ..WindowSettings::default()
        },
        WindowSettings {
            max_s: 0.0,
            ..WindowSettings::default()
        },
    ] {
        let p = HysteresisParams {
            window: bad,
            ..HysteresisParams::default()
        };
        assert!(p.event_settings().is_err(), "{bad:?}");
    }
}
