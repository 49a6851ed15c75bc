//! Data problems exit 1, usage errors 2, in every stage (issue 14, items 6
//! and 11; docs/cli.md): conditions of the records themselves are reported as
//! input errors naming the file and channel, never as usage errors.

use std::path::{Path, PathBuf};
use std::process::Output;

use quaketwin::modal::{identify, spectral_overlay, Method, ModalInput, ModalSettings};
use quaketwin::Location;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn quaketwin(args: &[&std::ffi::OsStr]) -> Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_quaketwin"))
        .arg("--quiet")
        .args(args)
        .output()
        .unwrap()
}

/// An event of one file holding one response channel: the first `rows`
/// samples of the sample ambient record's floor-1 X column, stated as an
/// output at level 1.
fn one_channel_event(dir: &Path, rows: usize) -> PathBuf {
    let ev = dir.join("one-channel");
    std::fs::create_dir_all(&ev).unwrap();
    let text = std::fs::read_to_string(
        root().join("sample-records/synthetic-4storey-ambient/ambient.csv"),
    )
    .unwrap();
    let csv: String = text
        .lines()
        .take(rows + 1)
        .map(|l| {
            let mut cols = l.split(',');
            format!("{},{}\n", cols.next().unwrap(), cols.next().unwrap())
        })
        .collect();
    std::fs::write(ev.join("one.csv"), csv).unwrap();
    std::fs::write(
        ev.join("event.toml"),
        "[event]\nname = \"one channel\"\n\n[[channel]]\nfile = \"one.csv\"\ncolumn = \"acc_L1_X\"\n\
         id = \"F1-X\"\nlevel = 1\ndirection = \"X\"\nrole = \"output\"\nunits = \"m/s2\"\n\
         time_column = \"time_s\"\n",
    )
    .unwrap();
    ev
}

/// Regression: `run` on a one-file, one-channel event exited 2 at the modal
/// stage ("output-only identification needs at least two response channels"),
/// a data problem reported as a usage error.  Now exit 1, naming file and channel.
#[test]
fn one_channel_event_fails_the_modal_stage_as_a_data_error() {
    let tmp = tempfile::tempdir().unwrap();
    let ev = one_channel_event(tmp.path(), 3000);
    let out = tmp.path().join("out");
    let pipeline = root().join("pipelines/post-earthquake.toml");
    for command in [
        vec!["run".as_ref(), pipeline.as_os_str(), ev.as_os_str()],
        vec!["modal".as_ref(), ev.as_os_str()],
    ] {
        let mut args: Vec<&std::ffi::OsStr> = command;
        args.extend(["--out".as_ref(), out.as_os_str()]);
        let o = quaketwin(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        for said in ["one.csv", "channel F1-X", "two response channels"] {
            assert!(err.contains(said), "{args:?}: no {said:?} in {err}");
        }
    }
}

fn one_output(samples: Vec<f64>, dt: f64) -> ModalInput {
    ModalInput {
        outputs: vec![samples],
        output_ids: vec!["F1-X".into()],
        locations: vec![Location::file("one.csv")],
        dt,
        ..Default::default()
    }
}

/// The library's checks of the signals: a single response channel and a
/// non-positive sampling interval are input errors (exit 1) with the place.
#[test]
fn modal_signal_checks_are_input_errors_naming_the_channel() {
    let wave: Vec<f64> = (0..4000).map(|i| (i as f64 * 0.1).sin()).collect();
    let cov = ModalSettings {
        method: Method::SsiCov,
        ..Default::default()
    };
    let e = identify(&one_output(wave.clone(), 0.01), &cov).unwrap_err();
    assert_eq!(e.exit_code(), 1, "{e}");
    assert!(e.to_string().starts_with("one.csv channel F1-X"), "{e}");

    let mut two = one_output(wave.clone(), 0.0);
    two.outputs
        .push(wave.iter().map(|v| 2.0 * v + 0.1).collect());
    two.output_ids.push("F2-X".into());
    two.locations.push(Location::file("one.csv"));
    let e = identify(&two, &cov).unwrap_err();
    assert_eq!(e.exit_code(), 1, "{e}");
    assert!(e.to_string().contains("sampling interval"), "{e}");

    let io = ModalSettings {
        method: Method::Io,
        ..Default::default()
    };
    let mut no_output = one_output(wave.clone(), 0.01);
    no_output.inputs = std::mem::take(&mut no_output.outputs);
    no_output.input_ids = std::mem::take(&mut no_output.output_ids);
    let e = identify(&no_output, &io).unwrap_err();
    assert_eq!(e.exit_code(), 1, "{e}");
    assert!(e.to_string().starts_with("one.csv"), "{e}");
}

/// A record shorter than one Welch segment is a data condition (the stage
/// leaves the overlay out), not a usage error.
#[test]
fn spectral_overlay_of_a_short_record_is_not_a_usage_error() {
    let e = spectral_overlay(&[vec![0.5; 40], vec![0.25; 40]], 0.01, 1024).unwrap_err();
    assert_eq!(e.exit_code(), 1, "{e}");
}
