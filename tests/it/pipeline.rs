//! The stage mechanism and the CLI contract: outputs, skipping of
//! up-to-date stages, re-running on changed parameters, exit codes.

use std::path::{Path, PathBuf};
use std::process::Command;

use quaketwin::error::printable;
use quaketwin::pipeline::{self, StageOutcome};
use quaketwin::stages::parse_pipeline;

fn sample_event() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("sample-records/synthetic-4storey-quake")
}

fn pipeline_text(taper: f64) -> String {
    format!(
        "[pipeline]\nname = \"t\"\n[[stage]]\nname = \"ingest\"\nkind = \"ingest\"\n[[stage]]\nname = \"condition\"\nkind = \"condition\"\ninputs = [\"ingest\"]\n[stage.params]\ntaper_fraction = {taper}\n[[stage]]\nname = \"metrics\"\nkind = \"metrics\"\ninputs = [\"condition\"]\n"
    )
}

#[test]
fn stages_write_outputs_skip_when_up_to_date_and_rerun_on_new_params() {
    let out = tempfile::tempdir().unwrap();
    let p = parse_pipeline(&pipeline_text(0.05), "t.toml").unwrap();
    let first = pipeline::run(&p, &sample_event(), out.path(), true).unwrap();
    assert!(
        first
            .iter()
            .all(|(_, o)| matches!(o, StageOutcome::Ran { .. })),
        "{first:?}"
    );
    for f in [
        "event.json",
        "samples/samples.parquet",
        "channels/channels.parquet",
        "spectra/spectra.parquet",
        "drift/drift.parquet",
    ] {
        assert!(out.path().join(f).exists(), "{f} missing");
    }
    let second = pipeline::run(&p, &sample_event(), out.path(), true).unwrap();
    assert!(
        second.iter().all(|(_, o)| *o == StageOutcome::Skipped),
        "{second:?}"
    );
    // A changed parameter re-runs that stage and what reads it, not what precedes it.
    let p2 = parse_pipeline(&pipeline_text(0.02), "t.toml").unwrap();
    let third = pipeline::run(&p2, &sample_event(), out.path(), true).unwrap();
    assert_eq!(third[0].1, StageOutcome::Skipped);
    assert!(matches!(third[1].1, StageOutcome::Ran { .. }));
    assert!(matches!(third[2].1, StageOutcome::Ran { .. }));
    // A deleted output re-runs its stage; the metrics stage then loads the
    // conditioned event back from samples/samples.parquet (condition was skipped).
    std::fs::remove_file(out.path().join("spectra/spectra.parquet")).unwrap();
    let fourth = pipeline::run(&p2, &sample_event(), out.path(), true).unwrap();
    assert_eq!(fourth[1].1, StageOutcome::Skipped);
    assert!(matches!(fourth[2].1, StageOutcome::Ran { .. }));
    assert!(out.path().join("spectra/spectra.parquet").exists());
}

#[test]
fn pipeline_file_errors_are_usage_errors() {
    let bad_kind = "[pipeline]\nname = \"t\"\n[[stage]]\nname = \"x\"\nkind = \"nope\"\n";
    let e = parse_pipeline(bad_kind, "p.toml").unwrap_err();
    assert_eq!(e.exit_code(), 2);
    assert!(e.to_string().contains("nope"));
    let bad_input = "[pipeline]\nname = \"t\"\n[[stage]]\nname = \"c\"\nkind = \"condition\"\ninputs = [\"later\"]\n";
    assert!(parse_pipeline(bad_input, "p.toml")
        .unwrap_err()
        .to_string()
        .contains("later"));
    let bad_param =
        pipeline_text(0.05).replace("taper_fraction = 0.05", "taper_fraction = \"lots\"");
    // Typed params are read with the pipeline file: refused before any data is read.
    let e = parse_pipeline(&bad_param, "p.toml").unwrap_err();
    assert_eq!(e.exit_code(), 2, "{e}");
    assert!(e.to_string().contains("condition"), "{e}");
    assert!(e.to_string().contains("p.toml line 11"), "{e}");
}

#[test]
fn cli_exit_codes() {
    let exe = env!("CARGO_BIN_EXE_quaketwin");
    let ok = Command::new(exe)
        .args(["inspect"])
        .arg(sample_event())
        .output()
        .unwrap();
    assert_eq!(
        ok.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let table = String::from_utf8_lossy(&ok.stdout);
    assert!(table.contains("F4-Y") && table.contains("B-X"), "{table}");
    let usage = Command::new(exe)
        .args(["inspect", "--no-such-flag"])
        .output()
        .unwrap();
    assert_eq!(usage.status.code(), Some(2));
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("x.AT2"), "garbage\n").unwrap();
    let bad = Command::new(exe)
        .args(["inspect"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("x.AT2"));
}

/// Error text is printed through `printable` (src/main.rs).
#[test]
fn control_bytes_are_escaped_and_length_is_capped() {
    assert_eq!(printable("a\0b\x1b[2Jc\nd", 100), "a\\u{0}b\\u{1b}[2Jc\nd");
    let long = "x".repeat(50);
    assert_eq!(
        printable(&long, 10),
        format!("{} … (40 more characters)", "x".repeat(10))
    );
}
