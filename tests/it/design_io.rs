//! The I/O edge of the hybrid-test design: the design file, base motion from an event or a
//! ground-motion file, the `design` command and pipeline stage, the output tables read back.

use std::path::{Path, PathBuf};

use arrow_array::{BooleanArray, Float64Array, Int64Array, StringArray, UInt32Array};
use quaketwin::design::file::{load_design, parse_design, MotionSource};
use quaketwin::design::motion::{base_motion_from_file, twin_axis_of};
use quaketwin::design::plan::DesignSettings;
use quaketwin::pipeline::{self, StageOutcome};
use quaketwin::sinks::design_tables::{DESIGN_FILES, WNRMSE_KEY};
use quaketwin::sinks::parquet::ReadTable;
use quaketwin::stages::design::design_from_file;
use quaketwin::stages::parse_pipeline;
use quaketwin::synth::facade::{facade_twin_toml, write_facade_sample, FACADE_FOLDER};
use quaketwin::twin::parse_twin;
use quaketwin::vocab::{Axis, Direction};

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// A temporary folder holding the facade twin and the sample event (`synthetic-facade/`).
fn workspace() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    write_facade_sample(dir.path(), 2026).unwrap();
    write(dir.path(), "facade.toml", &facade_twin_toml());
    dir
}

const MINIMAL: &str = "[design]\ntwin = \"facade.toml\"\n[ps]\nboxes = [{ x = [2.0, 6.0], y = [1.5, 5.5] }]\n[motion]\nevent = \"synthetic-facade\"\n";

fn error_of(dir: &Path, text: &str) -> String {
    let p = write(dir, "design.toml", text);
    load_design(&p).unwrap_err().to_string()
}

#[test]
fn minimal_design_file_takes_every_default() {
    let ws = workspace();
    let p = write(ws.path(), "design.toml", MINIMAL);
    let d = load_design(&p).unwrap();
    // x ∈ [2, 6], y ∈ [1.5, 5.5] on a 0.5 m grid: 9 × 9 nodes (the window's inner nodes too).
    assert_eq!(d.ps_node_ids.len(), 81);
    // Node ids are row-major from 1: node (i, j) = 17 j + i + 1; (4, 3) is the box's corner.
    assert_eq!(d.ps_node_ids[0], 17 * 3 + 4 + 1);
    assert_eq!(*d.ps_node_ids.last().unwrap(), 17 * 11 + 12 + 1);
    let s = &d.settings;
    let def = DesignSettings::default();
    assert_eq!(s.energy_target, def.energy_target);
    assert_eq!(s.max_poms, def.max_poms);
    assert_eq!(s.wnrmse_target, def.wnrmse_target);
    assert_eq!(s.max_control_nodes, def.max_control_nodes);
    assert_eq!(s.refinement_candidates, def.refinement_candidates);
    assert!(!d.snapshots_from_records);
    assert_eq!(s.control_nodes, def.control_nodes);
    assert_eq!(s.constrained, def.constrained);
    assert_eq!(s.damping_ratio, def.damping_ratio);
    assert_eq!(s.gravity, def.gravity);
    assert_eq!(s.actuators.static_ratio, def.actuators.static_ratio);
    assert_eq!(s.actuators.min_force, def.actuators.min_force);
    assert_eq!(s.hybrid.actuator_band_hz, def.hybrid.actuator_band_hz);
    assert_eq!(s.hybrid.band_of_interest_hz, def.hybrid.band_of_interest_hz);
    assert_eq!(s.hybrid.accuracy, def.hybrid.accuracy);
    assert_eq!(s.hybrid.max_ns_modes, def.hybrid.max_ns_modes);
    assert_eq!(s.hybrid.time_scales, def.hybrid.time_scales);
    assert_eq!(d.motion.scale, 1.0);
    assert_eq!(d.motion.duration_s, None);
    match &d.motion.source {
        MotionSource::Event {
            folder,
            channels,
            axes,
        } => {
            assert_eq!(folder, &ws.path().join("synthetic-facade"));
            assert!(channels.is_empty() && axes.is_empty());
        }
        other => panic!("expected an event source, got {other:?}"),
    }
}

#[test]
fn full_design_file_sets_every_field() {
    let ws = workspace();
    let text = "[design]\nname = \"w\"\ntwin = \"facade.toml\"\ngravity = false\n\
        [ps]\nnodes = [1, 2]\nboxes = [{ x = [2.0, 6.0], y = [1.5, 5.5] }]\ntolerance = 1e-3\n\
        [motion]\nevent = \"synthetic-facade\"\nchannels = [\"B-X\"]\naxis = { \"B-X\" = \"y\" }\nscale = 0.5\nduration_s = 3.0\n\
        [pod]\nenergy_target = 0.99\nmax_poms = 6\n\
        [interface]\nwnrmse_target = 0.02\nmax_control_nodes = 30\ncontrol_nodes = [56]\n\
        constrained = [{ node = 56, dof = \"ux\" }, { node = 56, dof = \"uy\" }, { node = 64, dof = \"UY\" }]\n\
        [damping]\nratio = 0.03\n\
        [actuators]\nstatic_ratio = 0.1\nmin_force = 5.0\n\
        [hybrid]\nactuator_band_hz = 10.0\nband_of_interest_hz = 40.0\naccuracy = 0.02\nmax_ns_modes = 8\ntime_scales = [1.0, 10.0, 100.0]\n";
    let d = load_design(&write(ws.path(), "design.toml", text)).unwrap();
    assert_eq!(d.ps_node_ids.len(), 83);
    assert_eq!(&d.ps_node_ids[..2], &[1, 2]);
    let s = &d.settings;
    assert!(!s.gravity);
    assert_eq!((s.energy_target, s.max_poms), (0.99, 6));
    assert_eq!((s.wnrmse_target, s.max_control_nodes), (0.02, 30));
    assert_eq!(s.control_nodes, vec![56]);
    assert_eq!(
        s.constrained.as_deref(),
        Some(
            &[
                (56, "ux".to_string()),
                (56, "uy".to_string()),
                (64, "uy".to_string())
            ][..]
        )
    );
    assert_eq!(s.damping_ratio, 0.03);
    assert_eq!(
        (s.actuators.static_ratio, s.actuators.min_force),
        (0.1, 5.0)
    );
    assert_eq!(s.hybrid.actuator_band_hz, 10.0);
    assert_eq!(s.hybrid.band_of_interest_hz, 40.0);
    assert_eq!(s.hybrid.accuracy, 0.02);
    assert_eq!(s.hybrid.max_ns_modes, 8);
    assert_eq!(s.hybrid.time_scales, vec![1.0, 10.0, 100.0]);
    assert_eq!((d.motion.scale, d.motion.duration_s), (0.5, Some(3.0)));
    match &d.motion.source {
        MotionSource::Event { channels, axes, .. } => {
            assert_eq!(channels, &vec!["B-X".to_string()]);
            assert_eq!(axes.get("B-X"), Some(&1));
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn unknown_key_is_an_error_naming_file_and_line() {
    let ws = workspace();
    let e = error_of(ws.path(), &format!("{MINIMAL}[pod]\nenergy_targt = 0.9\n"));
    assert!(e.contains("design.toml line 8"), "{e}");
    assert!(e.contains("energy_targt"), "{e}");
    // Unknown table too.
    let e = error_of(ws.path(), &format!("{MINIMAL}[podd]\nmax_poms = 3\n"));
    assert!(e.contains("line 7") && e.contains("podd"), "{e}");
    // A missing required table.
    let e = error_of(
        ws.path(),
        "[design]\ntwin = \"facade.toml\"\n[ps]\nnodes = [60]\n",
    );
    assert!(e.contains("design.toml") && e.contains("motion"), "{e}");
}

#[test]
fn unknown_node_id_is_named_with_its_line() {
    let ws = workspace();
    let e = error_of(
        ws.path(),
        "[design]\ntwin = \"facade.toml\"\n[ps]\nnodes = [60,\n  61,\n  9999]\n[motion]\nevent = \"synthetic-facade\"\n",
    );
    assert!(e.contains("design.toml line 6"), "{e}");
    assert!(e.contains("node 9999 does not exist"), "{e}");
    // Control nodes and constrained DoFs are checked the same way.
    let e = error_of(
        ws.path(),
        &format!("{MINIMAL}[interface]\ncontrol_nodes = [4242]\n"),
    );
    assert!(e.contains("line 8") && e.contains("node 4242"), "{e}");
    let e = error_of(
        ws.path(),
        &format!("{MINIMAL}[interface]\nconstrained = [{{ node = 60, dof = \"rz\" }}, {{ node = 60, dof = \"uw\" }}]\n"),
    );
    assert!(e.contains("line 8") && e.contains("\"uw\""), "{e}");
    // A control node outside the PS.
    let e = error_of(
        ws.path(),
        &format!("{MINIMAL}[interface]\ncontrol_nodes = [1]\n"),
    );
    assert!(e.contains("not in the PS node set"), "{e}");
}

#[test]
fn box_selecting_no_node_and_empty_set_are_errors() {
    let ws = workspace();
    let e = error_of(
        ws.path(),
        "[design]\ntwin = \"facade.toml\"\n[ps]\nboxes = [\n  { x = [2.0, 6.0], y = [1.5, 5.5] },\n  { x = [20.0, 21.0] },\n]\n[motion]\nevent = \"x\"\n",
    );
    assert!(e.contains("design.toml line 6"), "{e}");
    assert!(
        e.contains("selects no node") && e.contains("x ∈ [20, 21]"),
        "{e}"
    );
    // A point box on a node is inclusive (tolerance), one just off it selects nothing.
    let p = write(
        ws.path(),
        "design.toml",
        "[design]\ntwin = \"facade.toml\"\n[ps]\nboxes = [{ x = [2.0, 2.0], y = [1.5, 1.5] }]\n[motion]\nevent = \"x\"\n",
    );
    assert_eq!(load_design(&p).unwrap().ps_node_ids, vec![17 * 3 + 4 + 1]);
    let e = error_of(
        ws.path(),
        "[design]\ntwin = \"facade.toml\"\n[ps]\nboxes = [{ x = [2.01, 2.01] }]\ntolerance = 1e-3\n[motion]\nevent = \"x\"\n",
    );
    assert!(e.contains("selects no node"), "{e}");
    let e = error_of(
        ws.path(),
        "[design]\ntwin = \"facade.toml\"\n[ps]\n\n[motion]\nevent = \"x\"\n",
    );
    assert!(e.contains("line 3") && e.contains("empty"), "{e}");
    // Motion: both sources, no source, a file without axis.
    let e = error_of(
        ws.path(),
        &MINIMAL.replace(
            "event = \"synthetic-facade\"",
            "event = \"a\"\nfile = \"b.AT2\"",
        ),
    );
    assert!(e.contains("line 5") && e.contains("not both"), "{e}");
    let e = error_of(
        ws.path(),
        &MINIMAL.replace("event = \"synthetic-facade\"", "file = \"b.AT2\""),
    );
    assert!(e.contains("axis"), "{e}");
    // Settings out of range name the table.
    let e = error_of(ws.path(), &format!("{MINIMAL}[pod]\nenergy_target = 1.5\n"));
    assert!(e.contains("line 7") && e.contains("energy_target"), "{e}");
    let e = error_of(
        ws.path(),
        &format!("{MINIMAL}[hybrid]\ntime_scales = [10.0, 5.0]\n"),
    );
    assert!(e.contains("line 7") && e.contains("ascending"), "{e}");
    // A twin that is not there.
    let e = error_of(ws.path(), &MINIMAL.replace("facade.toml", "nope.toml"));
    assert!(e.contains("line 2") && e.contains("nope.toml"), "{e}");
}

#[test]
fn parse_accepts_the_sample_design_file() {
    let text = quaketwin::synth::facade::facade_design_toml();
    let doc = parse_design(&text, "design.toml").unwrap();
    assert_eq!(doc.design.get_ref().twin.get_ref(), "facade.toml");
}

// ------------------------------------------------------------------ base motion

#[test]
fn channel_directions_map_to_twin_axes() {
    let plane = parse_twin(&facade_twin_toml(), "facade.toml", Path::new(".")).unwrap();
    let m = plane.model.as_ref().unwrap();
    assert_eq!(
        twin_axis_of(Some(Direction::Axis(Axis::X)), m),
        Ok((0, 1.0))
    );
    assert_eq!(twin_axis_of(Some(Direction::Up), m), Ok((1, 1.0)));
    assert_eq!(
        twin_axis_of(Some(Direction::Axis(Axis::Z)), m),
        Ok((1, 1.0))
    );
    assert_eq!(twin_axis_of(Some(Direction::Down), m), Ok((1, -1.0)));
    assert!(twin_axis_of(Some(Direction::Axis(Axis::Y)), m)
        .unwrap_err()
        .contains("out of the plane"));
    assert!(twin_axis_of(Some(Direction::Azimuth(30.0)), m)
        .unwrap_err()
        .contains("azimuth"));
    assert!(twin_axis_of(None, m).is_err());
    let spatial = parse_twin(
        "[twin]\nname = \"s\"\ndimension = 3\n[[materials]]\nname = \"m\"\nE = 1e9\nnu = 0.2\nrho = 1000.0\n\
         [[sections]]\nname = \"t\"\nthickness = 0.2\n[mesh]\nnodes = [[1, 0.0, 0.0, 0.0], [2, 1.0, 0.0, 0.0], [3, 1.0, 1.0, 0.0], [4, 0.0, 1.0, 0.0]]\n\
         [[elements]]\ntype = \"shell4\"\nmaterial = \"m\"\nsection = \"t\"\ngroup = \"g\"\nconnectivity = [[1, 1, 2, 3, 4]]\n\
         [[supports]]\nnodes = [1, 2]\ndofs = [\"ux\", \"uy\", \"uz\", \"rx\", \"ry\", \"rz\"]\n",
        "s.toml",
        Path::new("."),
    )
    .unwrap();
    let m = spatial.model.as_ref().unwrap();
    assert_eq!(
        twin_axis_of(Some(Direction::Axis(Axis::X)), m),
        Ok((0, 1.0))
    );
    assert_eq!(
        twin_axis_of(Some(Direction::Axis(Axis::Y)), m),
        Ok((1, 1.0))
    );
    assert_eq!(twin_axis_of(Some(Direction::Up), m), Ok((2, 1.0)));
}

/// El Centro 1940 (PEER AT2, in g) as a ground-motion file: converted to m/s², scaled,
/// truncated to `duration_s`, along the named axis.
#[test]
fn ground_motion_file_is_read_scaled_and_truncated() {
    let record = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/records/peer-at2-records/elCentro.AT2"
    );
    if !Path::new(record).exists() {
        eprintln!("skipped: {record} not available");
        return;
    }
    let ws = workspace();
    let text = format!(
        "[design]\ntwin = \"facade.toml\"\n[ps]\nboxes = [{{ x = [2.0, 6.0], y = [1.5, 5.5] }}]\n[motion]\nfile = {record:?}\naxis = \"x\"\nscale = 0.5\nduration_s = 2.0\n"
    );
    let d = load_design(&write(ws.path(), "design.toml", &text)).unwrap();
    let motion = base_motion_from_file(&d.motion, d.model().unwrap(), &d.source).unwrap();
    assert_eq!(motion.dt, 0.02);
    assert_eq!(motion.components.len(), 1);
    assert_eq!(motion.components[0].axis, 0);
    assert_eq!(motion.components[0].acceleration.len(), 101);
    // First values of elCentro.AT2 (g), independently of the reader: parse the text here.
    let body = std::fs::read_to_string(record).unwrap();
    let values: Vec<f64> = body
        .lines()
        .skip(4)
        .flat_map(|l| {
            l.split_whitespace()
                .map(|v| v.parse::<f64>().unwrap())
                .collect::<Vec<_>>()
        })
        .take(101)
        .collect();
    for (a, g) in motion.components[0].acceleration.iter().zip(&values) {
        assert!(
            (a - 0.5 * 9.80665 * g).abs() <= 1e-12 * (1.0 + a.abs()),
            "{a} vs {g} g"
        );
    }
    // A plane twin has no z axis.
    let bad = text.replace("axis = \"x\"", "axis = \"z\"");
    let d = load_design(&write(ws.path(), "design.toml", &bad)).unwrap();
    let e = base_motion_from_file(&d.motion, d.model().unwrap(), &d.source)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("twin axis z") && e.contains("design.toml") && e.contains("line 5"),
        "{e}"
    );
}

// ------------------------------------------------------------------ bad inputs end to end

fn design_error(ws: &Path, text: &str) -> String {
    let p = write(ws, "design.toml", text);
    design_from_file(&p, &ws.join("out"))
        .unwrap_err()
        .to_string()
}

#[test]
fn bad_ps_sets_fail_with_clear_errors() {
    let ws = workspace();
    let motion = "[motion]\nevent = \"synthetic-facade\"\nduration_s = 1.0\n";
    // One node: no complete element, the PS does not exist as a substructure.
    let e = design_error(
        ws.path(),
        &format!("[design]\ntwin = \"facade.toml\"\n[ps]\nnodes = [60]\n{motion}"),
    );
    assert!(
        e.contains("design.toml") && e.contains("no complete element"),
        "{e}"
    );
    // The whole wall: nothing left for the NS.
    let e = design_error(
        ws.path(),
        &format!(
            "[design]\ntwin = \"facade.toml\"\n[ps]\nboxes = [{{ x = [-1.0, 9.0] }}]\n{motion}"
        ),
    );
    assert!(e.contains("no numerical substructure"), "{e}");
    // A PS touching the supports is not floating.
    let e = design_error(
        ws.path(),
        &format!("[design]\ntwin = \"facade.toml\"\n[ps]\nboxes = [{{ x = [0.0, 2.0], y = [0.0, 2.0] }}]\n{motion}"),
    );
    assert!(e.contains("supported") && e.contains("floating"), "{e}");
    // A PS with no interface: a second, separate wall panel (supported at its own base).
    let mut twin = facade_twin_toml();
    twin.push_str(
        "\n[[elements]]\ntype = \"q4\"\nmaterial = \"masonry\"\nsection = \"wall\"\ngroup = \"panel\"\nconnectivity = [[1001, 1001, 1002, 1004, 1003]]\n\
         [[supports]]\nnodes = [1001, 1002]\ndofs = [\"ux\", \"uy\"]\n",
    );
    let twin = twin.replace(
        "nodes = [\n",
        "nodes = [\n  [1001, 20.0, 0.0],\n  [1002, 20.5, 0.0],\n  [1003, 20.0, 0.5],\n  [1004, 20.5, 0.5],\n",
    );
    write(ws.path(), "two.toml", &twin);
    let e = design_error(
        ws.path(),
        &format!("[design]\ntwin = \"two.toml\"\n[ps]\nboxes = [{{ x = [19.0, 21.0] }}]\n{motion}"),
    );
    assert!(e.contains("without interface"), "{e}");
}

#[test]
fn constrained_set_that_leaves_rigid_motion_is_refused() {
    let ws = workspace();
    let head = "[design]\ntwin = \"facade.toml\"\n[ps]\nboxes = [{ x = [2.0, 6.0], y = [1.5, 5.5] }]\n[motion]\nevent = \"synthetic-facade\"\nduration_s = 1.0\n";
    // ux at three nodes of the PS's bottom edge (y = 1.5): vertical translation stays free.
    let e = design_error(
        ws.path(),
        &format!("{head}[interface]\nconstrained = [{{ node = 56, dof = \"ux\" }}, {{ node = 58, dof = \"ux\" }}, {{ node = 60, dof = \"ux\" }}]\n"),
    );
    assert!(e.contains("does not remove the rigid-body modes"), "{e}");
    // Two DoFs for three rigid-body modes.
    let e = design_error(
        ws.path(),
        &format!("{head}[interface]\nconstrained = [{{ node = 56, dof = \"ux\" }}, {{ node = 56, dof = \"uy\" }}]\n"),
    );
    assert!(
        e.contains("rigid-body modes") && e.contains("exactly one DoF per"),
        "{e}"
    );
}

// ------------------------------------------------------------------ the sample, end to end

fn f64s(t: &ReadTable, name: &str) -> Vec<f64> {
    t.batches
        .iter()
        .flat_map(|b| t.column::<Float64Array>(b, name).unwrap().values().to_vec())
        .collect()
}

fn u32s(t: &ReadTable, name: &str) -> Vec<u32> {
    t.batches
        .iter()
        .flat_map(|b| t.column::<UInt32Array>(b, name).unwrap().values().to_vec())
        .collect()
}

fn bools(t: &ReadTable, name: &str) -> Vec<bool> {
    t.batches
        .iter()
        .flat_map(|b| {
            let a = t.column::<BooleanArray>(b, name).unwrap();
            (0..a.len()).map(|i| a.value(i)).collect::<Vec<_>>()
        })
        .collect()
}

/// Entries of a Matrix Market coordinate file: (rows, cols, [(r, c, v)]), 1-based.
fn read_mtx(path: &Path) -> (String, usize, usize, Vec<(usize, usize, f64)>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let banner = lines.next().unwrap().to_string();
    let mut lines = lines.filter(|l| !l.starts_with('%'));
    let size: Vec<usize> = lines
        .next()
        .unwrap()
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect();
    let entries: Vec<(usize, usize, f64)> = lines
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            (
                f[0].parse().unwrap(),
                f[1].parse().unwrap(),
                f[2].parse().unwrap(),
            )
        })
        .collect();
    assert_eq!(entries.len(), size[2]);
    (banner, size[0], size[1], entries)
}

/// The sample design (facade, PS around the window, synthetic base motion) through
/// `quaketwin design`: every table is written, consistent with itself and with the targets of
/// the design file; a second run gives identical bytes.
#[test]
fn design_command_on_the_sample_writes_consistent_tables_deterministically() {
    let ws = workspace();
    let design = ws.path().join(FACADE_FOLDER).join("design.toml");
    let out1 = ws.path().join("out1");
    let s = design_from_file(&design, &out1).unwrap();
    eprintln!("{s:#?}");
    for f in DESIGN_FILES {
        assert!(out1.join(f).is_file(), "{f} missing");
    }
    assert_eq!(s.rigid_body_modes, 3);
    assert_eq!(s.ps_nodes, 81);

    // pod/pod.parquet: energy fractions sum up to the cumulative column; retained rows first.
    let pod = ReadTable::open(&out1.join("pod/pod.parquet")).unwrap();
    let energy = f64s(&pod, "energy_fraction");
    let cumulative = f64s(&pod, "cumulative_energy");
    let retained = bools(&pod, "retained");
    let sv = f64s(&pod, "singular_value");
    let mut acc = 0.0;
    for i in 0..energy.len() {
        acc += energy[i];
        assert!((acc - cumulative[i]).abs() < 1e-12);
        if i > 0 {
            assert!(sv[i] <= sv[i - 1]);
        }
    }
    let k = retained.iter().filter(|&&r| r).count();
    assert_eq!(k, s.retained_poms);
    assert!(retained[..k].iter().all(|&r| r));
    assert!(
        cumulative[k - 1] >= 0.999,
        "retained energy {}",
        cumulative[k - 1]
    );
    assert!(k == 1 || cumulative[k - 2] < 0.999);
    assert_eq!(pod.metadata("quaketwin.schema"), Some("pod"));
    assert!(pod
        .metadata("quaketwin.design_file")
        .unwrap()
        .ends_with("design.toml"));
    assert!(pod
        .metadata("quaketwin.twin")
        .unwrap()
        .ends_with("facade.toml"));
    assert!(pod.metadata("quaketwin.motion").unwrap().contains("B-X→x"));
    // The sample's snapshots are its 16 PS records (the twin's own accelerations under the
    // unconditioned base record, then conditioned and integrated): the recorded dominant
    // pattern must be the twin's (MAC ≥ 0.99).
    assert!(pod
        .metadata("quaketwin.snapshot_source")
        .unwrap()
        .starts_with("records (16 DoFs measured"));
    let mac: Vec<f64> =
        serde_json::from_str(pod.metadata("quaketwin.pom_mac_with_twin").unwrap()).unwrap();
    assert!(mac[0] >= 0.99, "MAC of POM 1 with the twin's: {}", mac[0]);
    assert!(pod
        .metadata("quaketwin.settings")
        .unwrap()
        .contains("energy_target"));
    assert_eq!(
        pod.metadata("quaketwin.version"),
        Some(env!("CARGO_PKG_VERSION"))
    );

    // actuator_layout/actuator_layout.parquet: one pom_j column per retained POM, known control modes.
    let layout = ReadTable::open(&out1.join("actuator_layout/actuator_layout.parquet")).unwrap();
    let b = &layout.batches[0];
    assert_eq!(b.num_rows(), s.actuators);
    for j in 1..=k {
        assert!(b.column_by_name(&format!("pom_{j}")).is_some());
    }
    assert!(b.column_by_name(&format!("pom_{}", k + 1)).is_none());
    let modes = layout.column::<StringArray>(b, "control_mode").unwrap();
    let dirs = layout.column::<StringArray>(b, "direction").unwrap();
    let node_ids = layout.column::<Int64Array>(b, "node_id").unwrap();
    let design_loaded = load_design(&design).unwrap();
    let mut force = 0;
    for i in 0..b.num_rows() {
        assert!(["displacement", "force"].contains(&modes.value(i)));
        force += (modes.value(i) == "force") as usize;
        assert!(["ux", "uy"].contains(&dirs.value(i)));
        assert!(design_loaded.ps_node_ids.contains(&node_ids.value(i)));
    }
    assert_eq!(force, s.force_controlled);
    assert_eq!(
        u32s(&layout, "actuator"),
        (1..=s.actuators as u32).collect::<Vec<_>>()
    );

    // reduction_validation/reduction_validation.parquet: WNRMSE (metadata) = Σ w NRMSE / Σ w (Eq. 84) ≤ target.
    let val =
        ReadTable::open(&out1.join("reduction_validation/reduction_validation.parquet")).unwrap();
    let (nrmse, weight) = (f64s(&val, "nrmse"), f64s(&val, "weight"));
    let (num, den) = nrmse
        .iter()
        .zip(&weight)
        .filter(|(_, &w)| w > 0.0)
        .fold((0.0, 0.0), |(n, d), (e, w)| (n + e * w, d + w));
    let stated: f64 = val.metadata(WNRMSE_KEY).unwrap().parse().unwrap();
    assert!(
        (num / den - stated).abs() <= 1e-12 * stated.max(1e-300),
        "{} vs {stated}",
        num / den
    );
    assert!(stated <= 1e-2, "WNRMSE {stated}");
    assert_eq!(
        bools(&val, "is_master").iter().filter(|&&m| m).count(),
        s.actuators
    );

    // interface_refinement/interface_refinement.parquet: the last step meets the target, control nodes grow.
    let refine =
        ReadTable::open(&out1.join("interface_refinement/interface_refinement.parquet")).unwrap();
    let cn = u32s(&refine, "control_nodes");
    assert!(cn.windows(2).all(|w| w[1] > w[0]));
    assert_eq!(*cn.last().unwrap() as usize, s.control_nodes);
    assert!(*f64s(&refine, "wnrmse_deformation").last().unwrap() <= 1e-2);

    // hybrid_prototype/hybrid_prototype.parquet: bandwidth = highest prototype frequency / λ ≤ actuator band;
    // frequencies in the band of interest within the accuracy.
    let hy = ReadTable::open(&out1.join("hybrid_prototype/hybrid_prototype.parquet")).unwrap();
    let fp = f64s(&hy, "prototype_frequency_hz");
    let lambda = f64s(&hy, "time_scale")[0];
    let bw = f64s(&hy, "bandwidth_hz")[0];
    assert!((fp.last().unwrap() / lambda - bw).abs() < 1e-12 * bw);
    assert!(bw <= 2.0 && (bw - s.bandwidth_hz).abs() < 1e-12);
    let hb = &hy.batches[0];
    let err = hy.column::<Float64Array>(hb, "relative_error").unwrap();
    let in_band = bools(&hy, "in_band");
    let full = hy.column::<Float64Array>(hb, "full_frequency_hz").unwrap();
    eprintln!(
        "prototype vs full frequencies (Hz): {:?}",
        (0..fp.len().min(8))
            .map(|i| (fp[i], full.value(i), in_band[i]))
            .collect::<Vec<_>>()
    );
    assert!(in_band[0], "the first mode lies in the band of interest");
    for (i, &b) in in_band.iter().enumerate() {
        if b {
            assert!(
                err.value(i) <= 0.01,
                "mode {} error {}",
                i + 1,
                err.value(i)
            );
        }
    }

    // Matrix Market: K̂, M̂ symmetric of the prototype's size; T is n_PS × (masters + 3).
    let (banner, n, m, kk) = read_mtx(&out1.join("prototype_stiffness.mtx"));
    assert!(banner.contains("symmetric"));
    assert_eq!((n, m), (fp.len(), fp.len()));
    assert!(kk.iter().all(|&(r, c, _)| r >= c));
    let (banner, n, m, _) = read_mtx(&out1.join("prototype_mass.mtx"));
    assert!(banner.contains("symmetric") && n == fp.len() && m == fp.len());
    let (banner, rows, cols, t) = read_mtx(&out1.join("ps_basis.mtx"));
    assert!(banner.contains("general"));
    assert_eq!((rows, cols), (s.ps_dofs, s.actuators + 3));
    // Each master column is 1 at its own DoF (Guyan: u_m = I) — the basis interpolates.
    assert!(t.iter().all(|e| e.2.is_finite()));

    // Determinism: a second run, byte-identical files.
    let out2 = ws.path().join("out2");
    design_from_file(&design, &out2).unwrap();
    for f in DESIGN_FILES {
        let (a, b) = (
            std::fs::read(out1.join(f)).unwrap(),
            std::fs::read(out2.join(f)).unwrap(),
        );
        assert!(a == b, "{f} differs between runs");
    }
}

/// `pipelines/test-design.toml` on the sample event: ingest → condition → design → rehearse
/// writes the tables; a second run skips the design stage; editing a design file outside the event
/// folder makes it run again (the stage fingerprints its own inputs).
#[test]
fn test_design_pipeline_runs_and_tracks_the_design_file() {
    let ws = workspace();
    let event = ws.path().join(FACADE_FOLDER);
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/pipelines/test-design.toml"
    ))
    .unwrap();
    let p = parse_pipeline(&text, "test-design.toml").unwrap();
    let out = ws.path().join("run");
    let outcomes = pipeline::run(&p, &event, &out, true).unwrap();
    assert!(
        outcomes
            .iter()
            .all(|(_, o)| matches!(o, StageOutcome::Ran { .. })),
        "{outcomes:?}"
    );
    for f in DESIGN_FILES {
        assert!(out.join(f).is_file(), "{f}");
    }
    // The report a person reads carries the design: its facts and the two plots.
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    let section = &html[html.find("id=\"test-design\"").expect("design section")..];
    let section = &section[..section.find("</section>").unwrap_or(section.len())];
    let layout = ReadTable::open(&out.join("actuator_layout/actuator_layout.parquet")).unwrap();
    assert!(
        section.contains(&format!(
            "<dt>Actuators</dt><dd>{} (",
            layout.batches.iter().map(|b| b.num_rows()).sum::<usize>()
        )),
        "{section}"
    );
    assert!(section.contains("Reduced vs full twin at the PS (WNRMSE)"));
    assert!(section.contains("MAC of recorded vs twin POMs 1–3"));
    // The actuator layout drawn on the twin, the interface refinement and
    // the POD energies; the rehearsal in its own section of the test-design page.
    assert_eq!(section.matches("<svg").count(), 3);
    assert!(section.contains("id=\"actuator-layout\""));
    assert!(html.contains("Rehearsal of the hybrid test"));
    let again = pipeline::run(&p, &event, &out, true).unwrap();
    assert_eq!(stage(&again, "design"), &StageOutcome::Skipped);

    // A design file outside the event folder (absolute path in the stage params).
    let outside = ws.path().join("outside.toml");
    let sample = std::fs::read_to_string(event.join("design.toml")).unwrap();
    std::fs::write(
        &outside,
        sample.replace("facade.toml", "synthetic-facade/facade.toml"),
    )
    .unwrap();
    let text2 = text.replace(
        "design = \"design.toml\"",
        &format!("design = {:?}", outside.display().to_string()),
    );
    let p2 = parse_pipeline(&text2, "test-design.toml").unwrap();
    let out2 = ws.path().join("run2");
    pipeline::run(&p2, &event, &out2, true).unwrap();
    assert_eq!(
        stage(&pipeline::run(&p2, &event, &out2, true).unwrap(), "design"),
        &StageOutcome::Skipped
    );
    std::fs::write(
        &outside,
        sample
            .replace("facade.toml", "synthetic-facade/facade.toml")
            .replace("ratio = 0.05\n\n[actuators]", "ratio = 0.04\n\n[actuators]"),
    )
    .unwrap();
    let third = pipeline::run(&p2, &event, &out2, true).unwrap();
    assert!(
        matches!(stage(&third, "design"), StageOutcome::Ran { .. }),
        "{third:?}"
    );
    // The design from the pipeline equals the one of `quaketwin design` on the same file.
    let cli = ws.path().join("cli");
    design_from_file(&event.join("design.toml"), &cli).unwrap();
    let from_cli = ReadTable::open(&cli.join("pod/pod.parquet")).unwrap();
    let from_pipeline = ReadTable::open(&out.join("pod/pod.parquet")).unwrap();
    assert_eq!(
        f64s(&from_cli, "singular_value"),
        f64s(&from_pipeline, "singular_value")
    );
}

/// `quaketwin synth` regenerates the facade sample byte for byte, and the committed copy in
/// sample-records/ is what it generates.
#[test]
fn facade_sample_regenerates_identically() {
    let a = tempfile::tempdir().unwrap();
    let b = tempfile::tempdir().unwrap();
    let da = write_facade_sample(a.path(), 2026).unwrap();
    let db = write_facade_sample(b.path(), 2026).unwrap();
    let committed = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("sample-records")
        .join(FACADE_FOLDER);
    for f in ["facade.toml", "base.csv", "event.toml", "design.toml"] {
        let x = std::fs::read(da.join(f)).unwrap();
        assert_eq!(x, std::fs::read(db.join(f)).unwrap(), "{f}");
        assert_eq!(
            x,
            std::fs::read(committed.join(f)).unwrap(),
            "sample-records/{FACADE_FOLDER}/{f} is not what `quaketwin synth` writes"
        );
    }
    // The twin is the facade: 17 × 13 nodes, 192 − 16 window elements.
    let twin = parse_twin(&facade_twin_toml(), "facade.toml", Path::new(".")).unwrap();
    let m = twin.model.as_ref().unwrap();
    assert_eq!(m.nodes.len(), 17 * 13);
    assert_eq!(m.elements.len(), 16 * 12 - 16);
}

/// An event without a base channel: the design stage is not applicable (and says why).
#[test]
fn design_stage_is_not_applicable_without_base_channel() {
    let ws = workspace();
    let event = ws.path().join("roof-only");
    std::fs::create_dir_all(&event).unwrap();
    let mut csv = String::from("time_s,acc_X\n");
    for i in 0..500 {
        let t = i as f64 * 0.02;
        csv.push_str(&format!("{t:.2},{:.6e}\n", (6.0 * t).sin()));
    }
    write(&event, "roof.csv", &csv);
    write(
        &event,
        "event.toml",
        "[event]\nname = \"roof only\"\n[[channel]]\nfile = \"roof.csv\"\ncolumn = \"acc_X\"\nid = \"R-X\"\nlevel = 3\ndirection = \"X\"\nrole = \"output\"\nunits = \"m/s2\"\ntime_column = \"time_s\"\n",
    );
    let design = ws.path().join(FACADE_FOLDER).join("design.toml");
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/pipelines/test-design.toml"
    ))
    .unwrap()
    .replace(
        "design = \"design.toml\"",
        &format!("design = {:?}", design.display().to_string()),
    );
    let p = parse_pipeline(&text, "test-design.toml").unwrap();
    let outcomes = pipeline::run(&p, &event, &ws.path().join("out"), true).unwrap();
    match stage(&outcomes, "design") {
        StageOutcome::NotApplicable(why) => assert!(why.contains("no base channel"), "{why}"),
        other => panic!("expected not applicable, got {other:?}"),
    }
    // Naming the channel in the design file makes it the base motion (the stage runs).
    let sample = std::fs::read_to_string(&design).unwrap();
    let named = write(
        ws.path(),
        "named.toml",
        &sample
            .replace(
                "twin = \"facade.toml\"",
                "twin = \"synthetic-facade/facade.toml\"",
            )
            .replace(
                "event = \".\"",
                "event = \"roof-only\"\nchannels = [\"R-X\"]",
            ),
    );
    let motion = quaketwin::stages::design::load_motion(&load_design(&named).unwrap()).unwrap();
    assert_eq!(motion.components.len(), 1);
    assert_eq!(motion.components[0].axis, 0);
    assert_eq!(motion.components[0].acceleration.len(), 500);
    assert!(motion.source.contains("R-X→x"), "{}", motion.source);
}

#[test]
fn snapshot_source_is_checked() {
    let ws = workspace();
    let bad = format!("{MINIMAL}[snapshots]\nsource = \"lidar\"\n");
    let e = error_of(ws.path(), &bad);
    assert!(
        e.contains("design.toml") && e.contains("line 7") && e.contains("\"lidar\""),
        "{e}"
    );
    let file_motion = "[design]\ntwin = \"facade.toml\"\n[ps]\nboxes = [{ x = [2.0, 6.0], y = [1.5, 5.5] }]\n[motion]\nfile = \"base.at2\"\naxis = \"x\"\n[snapshots]\nsource = \"records\"\n";
    let e = error_of(ws.path(), file_motion);
    assert!(e.contains("needs the motion from an event"), "{e}");
    let ok = format!(
        "{MINIMAL}[snapshots]\nsource = \"records\"\n[interface]\nrefinement_candidates = 3\n"
    );
    let p = write(ws.path(), "design.toml", &ok);
    let d = load_design(&p).unwrap();
    assert!(d.snapshots_from_records);
    assert_eq!(d.settings.refinement_candidates, 3);
}

/// The outcome of the stage named `name`.
fn stage<'a>(outcomes: &'a [(String, StageOutcome)], name: &str) -> &'a StageOutcome {
    &outcomes
        .iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("no stage {name} in {outcomes:?}"))
        .1
}

#[test]
fn ps_by_elements_and_groups() {
    let ws = workspace();
    // Elements (i, j) of the 0.5 m grid have ids 16 j + i + 1; (4, 3) and (5, 3) share an edge.
    let by_elements = MINIMAL.replace(
        "boxes = [{ x = [2.0, 6.0], y = [1.5, 5.5] }]",
        "elements = [53, 54]",
    );
    let d = load_design(&write(ws.path(), "design.toml", &by_elements)).unwrap();
    let node = |i: i64, j: i64| 17 * j + i + 1;
    let mut expected = vec![
        node(4, 3),
        node(5, 3),
        node(6, 3),
        node(4, 4),
        node(5, 4),
        node(6, 4),
    ];
    expected.sort();
    assert_eq!(d.ps_node_ids, expected);
    // The group of every element selects every node of the wall but the 3 × 3 nodes inside the
    // window, which no element uses.
    let by_group = MINIMAL.replace(
        "boxes = [{ x = [2.0, 6.0], y = [1.5, 5.5] }]",
        "groups = [\"wall\"]",
    );
    let d = load_design(&write(ws.path(), "design.toml", &by_group)).unwrap();
    assert_eq!(d.ps_node_ids.len(), 17 * 13 - 9);
    let e = error_of(
        ws.path(),
        &MINIMAL.replace(
            "boxes = [{ x = [2.0, 6.0], y = [1.5, 5.5] }]",
            "groups = [\"roof\"]",
        ),
    );
    assert!(e.contains("line 4") && e.contains("group \"roof\""), "{e}");
    let e = error_of(
        ws.path(),
        &MINIMAL.replace(
            "boxes = [{ x = [2.0, 6.0], y = [1.5, 5.5] }]",
            "elements = [53, 99999]",
        ),
    );
    assert!(e.contains("line 4") && e.contains("element 99999"), "{e}");
}
