//! One building geometry, applied once at ingest (issue 11): stated and
//! inferred building axes, sign flips and rotations checked against the same
//! event written directly in X/Y, and the rigid-floor combination of several
//! channels per level against a floor motion known by construction.

use std::path::{Path, PathBuf};

use quaketwin::event_folder;
use quaketwin::geometry::{
    apply_building_geometry, bridge_line_from_abutments, bridge_x_axis, infer_x_axis,
    one_record_per_level, AxesSource,
};
use quaketwin::pipeline::{self, StageOutcome};
use quaketwin::stages::hysteresis::auto_directions;
use quaketwin::stages::parse_pipeline;
use quaketwin::vocab::{Axis, Channel, Direction, Event, QaFlag, Record, Role, SourceRef, Units};

use super::common::{column_f64, column_str};

fn sample(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("sample-records")
        .join(name)
}

/// Negates every sample value of an AT2 file (header of 4 lines kept).
fn negate_at2(text: &str) -> String {
    let mut out = String::new();
    for (i, line) in text.lines().enumerate() {
        if i < 4 {
            out.push_str(line);
        } else {
            let vals: Vec<String> = line
                .split_whitespace()
                .map(|v| format!("{:.7E}", -v.parse::<f64>().unwrap()))
                .collect();
            out.push_str(&vals.join("  "));
        }
        out.push('\n');
    }
    out
}

/// Negates one column of a CSV file with a header row.
fn negate_csv_column(text: &str, column: &str) -> String {
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let k = header.split(',').position(|c| c == column).unwrap();
    let mut out = format!("{header}\n");
    for line in lines {
        let mut f: Vec<String> = line.split(',').map(String::from).collect();
        let v: f64 = f[k].parse().unwrap();
        f[k] = format!("{:e}", -v);
        out.push_str(&f.join(","));
        out.push('\n');
    }
    out
}

/// The 4-storey sample rewritten as a building whose X axis points to 171°,
/// with the basement X sensor mounted at 351° (reads −X) and the roof Y
/// sensor at 261° (reads −Y, Y = X − 90° = 81°).
fn azimuth_labelled_copy(dir: &Path) {
    let src = sample("synthetic-4storey-quake");
    for f in ["base_Y.AT2", "twin.toml"] {
        std::fs::copy(src.join(f), dir.join(f)).unwrap();
    }
    let base_x = std::fs::read_to_string(src.join("base_X.AT2")).unwrap();
    std::fs::write(dir.join("base_X.AT2"), negate_at2(&base_x)).unwrap();
    let floors = std::fs::read_to_string(src.join("floors.csv")).unwrap();
    std::fs::write(
        dir.join("floors.csv"),
        negate_csv_column(&floors, "acc_L4_Y"),
    )
    .unwrap();
    let manifest = std::fs::read_to_string(src.join("event.toml")).unwrap();
    let mut out = String::new();
    let mut current_id = String::new();
    for line in manifest.lines() {
        if let Some(id) = line.strip_prefix("id = ") {
            current_id = id.trim_matches('"').to_string();
        }
        let line = match (current_id.as_str(), line.starts_with("direction = ")) {
            ("B-X", true) => "direction = 351.0".to_string(),
            ("F4-Y", true) => "direction = 261.0".to_string(),
            _ => line.to_string(),
        };
        out.push_str(&line);
        out.push('\n');
        if line == "[structure]" {
            out.push_str("x_axis_azimuth_deg = 171.0\n");
        }
    }
    assert!(out.contains("direction = 351.0") && out.contains("direction = 261.0"));
    std::fs::write(dir.join("event.toml"), out).unwrap();
}

const PIPELINE: &str = r#"
[pipeline]
name = "geometry-check"

[[stage]]
name = "ingest"
kind = "ingest"

[[stage]]
name = "condition"
kind = "condition"
inputs = ["ingest"]

[[stage]]
name = "metrics"
kind = "metrics"
inputs = ["condition"]

[[stage]]
name = "modal"
kind = "modal"
inputs = ["condition"]

[[stage]]
name = "as-recorded"
kind = "condition"
inputs = ["ingest"]
[stage.params]
steps = []
samples_file = "samples_as_recorded.parquet"

[[stage]]
name = "hysteresis"
kind = "hysteresis"
inputs = ["as-recorded"]
[stage.params]
exponent_resolution = 0.01
"#;

#[test]
fn stated_axes_flip_sensors_onto_the_same_event_written_in_xy() {
    let tmp = tempfile::tempdir().unwrap();
    let rotated = tmp.path().join("rotated");
    std::fs::create_dir(&rotated).unwrap();
    azimuth_labelled_copy(&rotated);

    // Ingest: directions X, Y only; the two sensors flipped, axes stated.
    let loaded = event_folder::load(&rotated).unwrap();
    let axes = loaded.geometry.axes.clone().unwrap();
    assert_eq!(axes.source, AxesSource::Stated);
    assert_eq!((axes.x_azimuth_deg, axes.y_azimuth_deg), (171.0, 81.0));
    let flips: Vec<(&str, &str)> = loaded
        .geometry
        .actions
        .iter()
        .map(|a| (a.channel.as_str(), a.action.as_str()))
        .collect();
    assert_eq!(flips, vec![("B-X", "flip"), ("F4-Y", "flip")]);
    // `inspect` lists it without its samples: the same inventory.
    let listing = event_folder::load_listing(&rotated).unwrap();
    assert_eq!(
        quaketwin::stages::ingest::inventory_json(&listing).unwrap(),
        quaketwin::stages::ingest::inventory_json(&loaded).unwrap()
    );
    let reference = event_folder::load(&sample("synthetic-4storey-quake")).unwrap();
    for (a, b) in loaded.event.records.iter().zip(&reference.event.records) {
        assert_eq!(a.channel.id, b.channel.id);
        assert_eq!(a.channel.direction, b.channel.direction, "{}", a.channel.id);
        assert_eq!(a.samples, b.samples, "{}: samples differ", a.channel.id);
    }
    assert!(loaded
        .event
        .history
        .steps
        .iter()
        .any(|s| s.step == "building_axes"));

    // Every stage's output: the same numbers, directions named X and Y only.
    let p = parse_pipeline(PIPELINE, "geometry-check").unwrap();
    let out_r = tmp.path().join("out-rotated");
    let out_x = tmp.path().join("out-xy");
    for (event, out) in [
        (&rotated, &out_r),
        (&sample("synthetic-4storey-quake"), &out_x),
    ] {
        let outcomes = pipeline::run(&p, event, out, true).unwrap();
        assert!(outcomes
            .iter()
            .all(|(_, o)| matches!(o, StageOutcome::Ran { .. })));
    }
    for dir in column_str(&out_r.join("channels/channels.parquet"), "direction") {
        assert!(matches!(dir.as_str(), "X" | "Y" | "Z"), "direction {dir}");
    }
    for (file, cols) in [
        (
            "samples/samples.parquet",
            &["acc_m_s2", "vel_m_s", "disp_m"][..],
        ),
        ("drift/drift.parquet", &["peak_drift_ratio"][..]),
        (
            "modes/modes.parquet",
            &["frequency_hz", "damping_ratio"][..],
        ),
    ] {
        for c in cols {
            assert_eq!(
                column_f64(&out_r.join(file), c),
                column_f64(&out_x.join(file), c),
                "{file} {c}"
            );
        }
    }
    let dirs = column_str(&out_r.join("drift/drift.parquet"), "direction");
    assert!(dirs.iter().all(|d| d == "X" || d == "Y") && dirs.len() == 8);
    let bw_dirs = column_str(&out_r.join("bouc_wen/bouc_wen.parquet"), "direction");
    assert!(!bw_dirs.is_empty());
    assert!(bw_dirs.iter().all(|d| d == "X" || d == "Y"), "{bw_dirs:?}");
    assert_eq!(
        bw_dirs,
        column_str(&out_x.join("bouc_wen/bouc_wen.parquet"), "direction")
    );
}

fn channel(id: &str, level: i32, direction: Direction, position: Option<[f64; 2]>) -> Channel {
    let source = SourceRef {
        file: "test.csv".into(),
        member: None,
        column: Some(id.into()),
        format: "csv".into(),
    };
    let mut c = Channel::new(id, Units::MPerS2, 100.0, source);
    c.level = Some(level);
    c.direction = Some(direction);
    c.role = if level == 0 {
        Role::Input
    } else {
        Role::Output
    };
    c.position_m = position;
    c
}

fn signal(n: usize, f: f64, phase: f64) -> Vec<f64> {
    (0..n)
        .map(|i| (2.0 * std::f64::consts::PI * f * i as f64 / 100.0 + phase).sin())
        .collect()
}

#[test]
fn inferred_axes_group_a_sensor_line_and_its_reverse() {
    // No stated axes: basement at 351°, roof at 171° and 261° (the issue's
    // "four directions" case): one X line (171/351), one Y line (81/261).
    let n = 400;
    let x = signal(n, 1.0, 0.0);
    let y = signal(n, 1.7, 0.3);
    let neg = |v: &[f64]| v.iter().map(|a| -a).collect::<Vec<_>>();
    let mut event = Event {
        name: "t".into(),
        records: vec![
            Record::new(channel("B351", 0, Direction::Azimuth(351.0), None), neg(&x)),
            Record::new(
                channel("R171", 2, Direction::Azimuth(171.0), None),
                x.clone(),
            ),
            Record::new(channel("R261", 2, Direction::Azimuth(261.0), None), neg(&y)),
            Record::new(channel("V", 0, Direction::Up, None), y.clone()),
        ],
        ..Default::default()
    };
    let report = apply_building_geometry(&mut event).unwrap();
    let axes = report.axes.unwrap();
    assert_eq!(axes.source, AxesSource::Inferred);
    assert_eq!(axes.x_azimuth_deg, 171.0);
    let r = |id: &str| event.records.iter().find(|r| r.channel.id == id).unwrap();
    assert_eq!(r("B351").channel.axis(), Some(Axis::X));
    assert_eq!(r("B351").samples, x);
    assert_eq!(r("R171").samples, x);
    assert_eq!(r("R261").channel.axis(), Some(Axis::Y));
    assert_eq!(r("R261").samples, y);
    assert_eq!(r("V").channel.direction, Some(Direction::Axis(Axis::Z)));
    assert!(event.notes.iter().any(|n| n.contains("inferred")));
    // The hysteresis stage now sees one base and one floor per direction.
    let (specs, _) = auto_directions(&event);
    assert_eq!(specs.len(), 1);
    assert_eq!(specs[0].direction, "X");
    assert_eq!(specs[0].base, "B351");
}

/// A rigid floor translating (u_x, u_y) at its centre of mass (5, 4) and
/// rotating θ: four sensors at the corners of a 10 × 8 m plan, one of them
/// also carrying a local wall mode.
#[test]
fn rigid_floor_least_squares_recovers_translation_and_rotation() {
    let n = 1000;
    let ux = signal(n, 1.1, 0.0);
    let uy = signal(n, 1.4, 0.5);
    let th: Vec<f64> = signal(n, 2.3, 0.2).iter().map(|v| 0.05 * v).collect();
    let (xc, yc) = (5.0, 4.0);
    let along_x = |y: f64| -> Vec<f64> { (0..n).map(|t| ux[t] - th[t] * (y - yc)).collect() };
    let along_y = |x: f64| -> Vec<f64> { (0..n).map(|t| uy[t] + th[t] * (x - xc)).collect() };
    let wall: Vec<f64> = signal(n, 7.9, 0.0);
    let mut bad = along_x(8.0);
    bad.iter_mut().zip(&wall).for_each(|(b, w)| *b += 0.8 * w);
    let ax = Direction::Axis(Axis::X);
    let ay = Direction::Axis(Axis::Y);
    let mut event = Event {
        name: "t".into(),
        records: vec![
            Record::new(channel("SW-X", 3, ax, Some([0.0, 0.0])), along_x(0.0)),
            Record::new(channel("NE-X", 3, ax, Some([10.0, 8.0])), along_x(8.0)),
            Record::new(channel("NW-X", 3, ax, Some([0.0, 8.0])), bad),
            Record::new(channel("SW-Y", 3, ay, Some([0.0, 0.0])), along_y(0.0)),
            Record::new(channel("NE-Y", 3, ay, Some([10.0, 8.0])), along_y(10.0)),
        ],
        structure: Some(quaketwin::vocab::Structure {
            centre_of_mass_m: Some([xc, yc]),
            ..Default::default()
        }),
        ..Default::default()
    };
    let report = apply_building_geometry(&mut event).unwrap();
    assert_eq!(report.floors.len(), 1);
    let f = &report.floors[0];
    assert_eq!(f.method, "rigid_floor_least_squares");
    assert_eq!(f.floors, vec!["L3.X", "L3.Y"]);
    // The wall-mode sensor is flagged and left out.
    assert_eq!(f.disagreeing.len(), 1);
    assert_eq!(f.disagreeing[0].0, "NW-X");
    let nw = event
        .records
        .iter()
        .find(|r| r.channel.id == "NW-X")
        .unwrap();
    assert!(nw
        .channel
        .qa
        .iter()
        .any(|q| matches!(q, QaFlag::Note { text } if text.contains("rigid-floor"))));
    assert_eq!(nw.channel.combined_into, None);
    let peak_theta = th.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!((f.peak_rotation_rad_s2.unwrap() - peak_theta).abs() < 1e-9);
    let sel = one_record_per_level(&event.records);
    assert!(sel.ambiguous.is_empty());
    let floor_x = sel.records[&(Axis::X, 3)];
    let floor_y = sel.records[&(Axis::Y, 3)];
    assert!(floor_x.channel.is_floor_motion() && floor_y.channel.is_floor_motion());
    for t in 0..n {
        assert!((floor_x.samples[t] - ux[t]).abs() < 1e-9);
        assert!((floor_y.samples[t] - uy[t]).abs() < 1e-9);
    }
    assert_eq!(floor_x.channel.combines, vec!["SW-X", "NE-X"]);
}

#[test]
fn without_positions_two_disagreeing_sensors_are_both_flagged() {
    let n = 500;
    let a = signal(n, 1.0, 0.0);
    let same: Vec<f64> = a.iter().map(|v| v * 1.02).collect();
    let other = signal(n, 3.0, 1.0);
    let ax = Direction::Axis(Axis::X);
    // Level 1: two sensors that agree → their mean, nobody flagged.
    // Level 2: two that disagree → mean kept, both flagged, said why.
    let mut event = Event {
        name: "t".into(),
        records: vec![
            Record::new(channel("A1", 1, ax, None), a.clone()),
            Record::new(channel("B1", 1, ax, None), same.clone()),
            Record::new(channel("A2", 2, ax, None), a.clone()),
            Record::new(channel("B2", 2, ax, None), other),
        ],
        ..Default::default()
    };
    let report = apply_building_geometry(&mut event).unwrap();
    assert_eq!(report.floors.len(), 2);
    assert_eq!(report.floors[0].method, "mean");
    assert!(report.floors[0].disagreeing.is_empty());
    assert_eq!(report.floors[1].disagreeing.len(), 2);
    assert!(report.floors[1].note.contains("position_m"));
    let sel = one_record_per_level(&event.records);
    let l1 = sel.records[&(Axis::X, 1)];
    for t in 0..n {
        assert!((l1.samples[t] - 0.5 * (a[t] + same[t])).abs() < 1e-12);
    }
}

#[test]
fn condition_stage_orientation_is_refused_with_where_it_moved() {
    let text = r#"
[pipeline]
name = "old"
[[stage]]
name = "condition"
kind = "condition"
[stage.params]
orientation = { x_azimuth_deg = 171.0 }
"#;
    // Refused when the pipeline file is read (typed params), before any data.
    let err = parse_pipeline(text, "old.toml").unwrap_err().to_string();
    assert!(err.contains("x_axis_azimuth_deg"), "{err}");
}

#[test]
fn x_axis_is_the_line_with_most_sensors() {
    // 351/171 line: 3 sensors; 261/81 line: 2.
    assert_eq!(
        infer_x_axis(&[351.0, 171.0, 261.0, 350.0, 81.0], 5.0),
        Some(170.0)
    );
    // A tie goes to the smaller line azimuth.
    assert_eq!(infer_x_axis(&[351.0, 261.0], 5.0), Some(81.0));
    assert_eq!(infer_x_axis(&[], 5.0), None);
}

#[test]
fn a_bridge_deck_line_comes_from_its_abutments() {
    let ew = [
        "DECK, NEAR EAST ABUTMENT",
        "ON GROUND NEAR WEST ABUTMENT",
        "BASE OF CENTER BENT",
    ];
    assert_eq!(bridge_line_from_abutments(ew.into_iter()), Some(90.0));
    let ns = ["Deck near South Abutment", "Center Bent: Deck Level"];
    assert_eq!(bridge_line_from_abutments(ns.into_iter()), Some(0.0));
    // No abutment named, or both pairs named: no line.
    assert_eq!(
        bridge_line_from_abutments(["Roof", "East wall"].into_iter()),
        None
    );
    let both = ["North abutment", "West abutment"];
    assert_eq!(bridge_line_from_abutments(both.into_iter()), None);
    // "Eastbound" is not "east".
    assert_eq!(
        bridge_line_from_abutments(["Eastbound abutment"].into_iter()),
        None
    );
}

#[test]
fn a_bridge_x_axis_is_the_sensor_line_along_its_deck() {
    // Painter St. 1980s: transverse 360°, longitudinal 270°; deck east–west.
    // The tie that `infer_x_axis` breaks towards 0° goes to the deck's line.
    let azimuths = [360.0, 270.0, 360.0, 270.0];
    assert_eq!(infer_x_axis(&azimuths, 5.0), Some(0.0));
    assert_eq!(bridge_x_axis(&azimuths, 90.0, 5.0), Some(90.0));
    assert_eq!(bridge_x_axis(&azimuths, 0.0, 5.0), Some(0.0));
    // A skewed deck still picks the nearer line; none within 45°: no axis.
    assert_eq!(bridge_x_axis(&[20.0, 110.0], 90.0, 5.0), Some(110.0));
    assert_eq!(bridge_x_axis(&[45.0], 90.0, 5.0), None);
}

/// Issue 31 item 4: a building's X axis from its geometry alone — the same
/// in two events of one building whether or not a channel is missing.
#[test]
fn building_axes_do_not_depend_on_how_many_channels_an_event_has() {
    use quaketwin::geometry::{building_x_axis, infer_x_axis};
    // Three sensors along the 110° line, one along the 20° line…
    let full = [110.0, 290.0, 110.0, 20.0];
    // …and the same building with one 110° channel dead.
    let lacking = [110.0, 20.0];
    assert_eq!(building_x_axis(&full, 5.0), Some(20.0));
    assert_eq!(building_x_axis(&lacking, 5.0), Some(20.0));
    // The channel-count rule swaps the axes between the two events.
    assert_eq!(infer_x_axis(&full, 5.0), Some(110.0));
    assert_eq!(infer_x_axis(&lacking, 5.0), Some(20.0));
    // Lines merged within the tolerance across 0°/180°; a stray line with no
    // perpendicular partner is not an axis.
    assert_eq!(building_x_axis(&[179.0, 89.5, 45.0], 5.0), Some(89.5));
    assert_eq!(building_x_axis(&[30.0, 75.0], 5.0), None);
}
