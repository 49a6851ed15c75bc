//! Parameters are bounded where they are parsed (issue 33, item 1): the
//! values an outside audit found reaching allocation or running for minutes
//! — `exponent_max = 1e300`, `orders = [2, i64::MAX, 2]`, `--orders
//! 2,100000000000,2`, 10⁶ spectrum periods — and their neighbours in every
//! stage, flag and settings file exit 2 naming the key, quickly, within a
//! memory bound.
//!
//! The memory bound: each command runs under `ulimit -v` (address space of
//! `MEMORY_LIMIT_KIB`), so an allocation sized from an unchecked number
//! aborts the child instead of exiting 2, and the test fails.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Address space each command may use: the unbounded values asked for
/// 10¹⁸ bytes; an exit 2 needs a few MB (the rest is thread stacks and the
/// allocator's reservations).
const MEMORY_LIMIT_KIB: u64 = 2 * 1024 * 1024;
/// Every refusal here comes before any heavy work.
const TIME_LIMIT: Duration = Duration::from_secs(30);

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn sample(event: &str) -> PathBuf {
    root().join("sample-records").join(event)
}

/// Runs `quaketwin --quiet ARGS` under the memory limit; asserts exit 2
/// within the time limit with a message naming every string in `names`.
fn refused(args: &[&str], names: &[&str]) {
    let t0 = Instant::now();
    let o = std::process::Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v {MEMORY_LIMIT_KIB} && exec \"$0\" --quiet \"$@\""
        ))
        .arg(env!("CARGO_BIN_EXE_quaketwin"))
        .args(args)
        .output()
        .unwrap();
    let took = t0.elapsed();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(
        o.status.code(),
        Some(2),
        "{args:?}: {:?}\n{stderr}",
        o.status
    );
    for n in names {
        assert!(
            stderr.contains(n),
            "{args:?}: message should name {n}: {stderr}"
        );
    }
    assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    assert!(took < TIME_LIMIT, "{args:?} took {took:?}");
}

/// A pipeline file in `dir`: ingest → condition → the stage `kind` with
/// `params` (TOML lines of its `[stage.params]`).
fn pipeline(dir: &Path, kind: &str, params: &str) -> String {
    let input = if kind == "condition" {
        "ingest"
    } else {
        "condition"
    };
    let mut text = String::from(
        "[pipeline]\nname = \"bounds\"\n[[stage]]\nname = \"ingest\"\nkind = \"ingest\"\n",
    );
    if kind != "condition" {
        text += "[[stage]]\nname = \"condition\"\nkind = \"condition\"\ninputs = [\"ingest\"]\n";
    }
    text += &format!(
        "[[stage]]\nname = \"{kind}\"\nkind = \"{kind}\"\ninputs = [\"{input}\"]\n[stage.params]\n{params}\n"
    );
    let path = dir.join(format!("{kind}.toml"));
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

/// `quaketwin run PIPELINE EVENT --out DIR` with the stage's params refused.
fn run_refused(kind: &str, params: &str, event: &str, names: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let p = pipeline(dir.path(), kind, params);
    let out = dir.path().join("out");
    let ev = sample(event).display().to_string();
    refused(&["run", &p, &ev, "--out", out.to_str().unwrap()], names);
    // Refused before the run: nothing written.
    assert!(
        !out.join("samples/samples.parquet").exists(),
        "{kind}: {params}"
    );
}

#[test]
fn hysteresis_exponent_grid_is_bounded() {
    // 1e300 allocated 1.47e18 bytes; 1e12 the same; 1e5 ran for minutes.
    for max in ["1e300", "1e12", "1e5", "51.0", "inf", "nan"] {
        run_refused(
            "hysteresis",
            &format!("exponent_max = {max}"),
            "synthetic-2storey-yielding",
            &["exponent_max", "50"],
        );
    }
    // The grid count: 49 / 1e-6 points.
    run_refused(
        "hysteresis",
        "exponent_max = 50.0\nexponent_resolution = 1e-6",
        "synthetic-2storey-yielding",
        &["exponent_resolution", "100000"],
    );
    run_refused(
        "hysteresis",
        "exponent_min = 0.5",
        "synthetic-2storey-yielding",
        &["exponent_min"],
    );
    run_refused(
        "hysteresis",
        "band_low_hz = nan",
        "synthetic-2storey-yielding",
        &["band_low_hz"],
    );
    let many_floors = vec!["\"F1X\""; 101].join(", ");
    run_refused(
        "hysteresis",
        &format!("directions = [{{ direction = \"X\", base = \"B\", floors = [{many_floors}] }}]"),
        "synthetic-2storey-yielding",
        &["directions", "floors", "100"],
    );
}

#[test]
fn modal_orders_and_block_rows_are_bounded() {
    // i64::MAX panicked "capacity overflow".
    for orders in ["[2, 9223372036854775807, 2]", "[2, 481, 2]", "[0, 10, 2]"] {
        run_refused(
            "modal",
            &format!("orders = {orders}"),
            "synthetic-4storey-ambient",
            &["orders", "480"],
        );
    }
    for (params, key) in [
        ("block_rows = 9223372036854775807", "block_rows"),
        ("block_rows = 481", "block_rows"),
        ("decimation = 1000000", "decimation"),
        ("psd_segment = 1000000000000", "psd_segment"),
        ("uncertainty_blocks = 5", "uncertainty_blocks"),
        ("uncertainty_blocks = 100000", "uncertainty_blocks"),
        ("damping_max = 1e300", "damping_max"),
        ("frequency_max_hz = inf", "frequency_max_hz"),
    ] {
        run_refused("modal", params, "synthetic-4storey-ambient", &[key]);
    }
    let many = vec!["1.0"; 257].join(", ");
    run_refused(
        "modal",
        &format!("manual_frequencies_hz = [{many}]"),
        "synthetic-4storey-ambient",
        &["manual_frequencies_hz", "256"],
    );
}

#[test]
fn modal_cli_flags_are_refused_before_any_record_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    // The event does not exist: a refusal that names the flag's key comes
    // before any record is read (docs/cli.md).
    let ev = dir.path().join("no-such-event");
    let ev = ev.to_str().unwrap();
    for (flag, value, key) in [
        ("--orders", "2,100000000000,2", "orders"),
        ("--orders", "2,9223372036854775807", "orders"),
        ("--block-rows", "100000000000", "block_rows"),
        ("--decimate", "100000000000", "decimation"),
    ] {
        refused(&["modal", ev, "--out", out, flag, value], &[key]);
    }
}

#[test]
fn explicit_block_rows_beyond_the_hankel_bound_are_refused_at_run_time() {
    // 480 block rows × (8 references + 8 outputs) = 7 680 Hankel rows:
    // a Gram matrix of 470 MB, refused naming the key and the bound.
    let dir = tempfile::tempdir().unwrap();
    let p = pipeline(
        dir.path(),
        "modal",
        "method = \"ssi-data\"\nblock_rows = 480",
    );
    let out = dir.path().join("out");
    let ev = sample("synthetic-4storey-ambient").display().to_string();
    refused(
        &["run", &p, &ev, "--out", out.to_str().unwrap()],
        &["block_rows = 480", "4096"],
    );
    assert!(!out.join("modes/modes.parquet").exists());
}

#[test]
fn explicit_orders_beyond_what_the_record_supports_are_refused_at_run_time() {
    // 10 block rows × 8 outputs support orders up to 72: 400–480 none.
    let dir = tempfile::tempdir().unwrap();
    let params = "method = \"ssi-cov\"\nblock_rows = 10\norders = [400, 480, 40]";
    let p = pipeline(dir.path(), "modal", params);
    let out = dir.path().join("out");
    let ev = sample("synthetic-4storey-ambient").display().to_string();
    refused(
        &["run", &p, &ev, "--out", out.to_str().unwrap()],
        &["orders [400, 440, 480]", "exceed the subspace dimension"],
    );
    assert!(!out.join("modes/modes.parquet").exists());
}

#[test]
fn spectrum_periods_are_bounded() {
    let many = vec!["0.5"; 1001].join(", ");
    run_refused(
        "metrics",
        &format!("periods_s = [{many}]"),
        "synthetic-4storey-quake",
        &["periods_s", "1000"],
    );
    run_refused(
        "metrics",
        "periods_s = [0.1, 1e300]",
        "synthetic-4storey-quake",
        &["periods_s"],
    );
    // 10⁶ periods (2.8 GB of spectra) refused by the settings' own check,
    // the one the pipeline, the CLI and Python use.
    let t0 = Instant::now();
    let s = quaketwin::metrics::MetricsSettings {
        periods_s: vec![0.5; 1_000_000],
        ..Default::default()
    };
    let e = s.validate().unwrap_err();
    assert_eq!(e.exit_code(), 2);
    assert!(e.to_string().contains("periods_s"), "{e}");
    assert!(t0.elapsed() < Duration::from_secs(5));
}

#[test]
fn conditioning_steps_and_rates_are_bounded() {
    for (params, key) in [
        ("resample_hz = 1e300", "rate_hz"),
        ("resample_hz = 1e9", "rate_hz"),
        ("qa = { spike_threshold = nan }", "qa.spike_threshold"),
        ("qa = { clip_min_run = 0 }", "qa.clip_min_run"),
    ] {
        run_refused("condition", params, "synthetic-4storey-quake", &[key]);
    }
    let steps = vec!["{ step = \"detrend\", method = \"mean\" }"; 33].join(", ");
    run_refused(
        "condition",
        &format!("steps = [{steps}]"),
        "synthetic-4storey-quake",
        &["steps", "32"],
    );
    // Upsampling beyond 64 × refused before it allocates (a data-dependent
    // ratio: the rate is fine, the record's is 100 Hz).
    let x = vec![0.0; 1000];
    let e = quaketwin::conditioning::resample_to_rate(&x, 1.0, 1000.0).unwrap_err();
    assert!(e.to_string().contains("64"), "{e}");
}

#[test]
fn assess_tracking_settings_are_bounded() {
    run_refused(
        "assess",
        "tracking = { step_fraction = 1e-9 }",
        "synthetic-2storey-yielding",
        &["step_fraction"],
    );
    run_refused(
        "assess",
        "tracking = { samples_per_period = 1e300 }",
        "synthetic-2storey-yielding",
        &["samples_per_period"],
    );
}

#[test]
fn update_settings_and_twin_flags_are_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let twin = sample("synthetic-4storey-quake").join("twin.toml");
    let twin = twin.to_str().unwrap();
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    for (text, key) in [
        ("max_rounds = 1000000000000", "max_rounds"),
        ("extra_model_modes = 1000000000000", "extra_model_modes"),
        ("convergence = { window = 1000000000000 }", "window"),
        ("tolerance = nan", "tolerance"),
    ] {
        let settings = dir.path().join("update.toml");
        std::fs::write(&settings, text).unwrap();
        let s = settings.to_str().unwrap();
        refused(
            &[
                "update",
                twin,
                "--modes",
                out,
                "--out",
                out,
                "--settings",
                s,
            ],
            &[key],
        );
    }
    refused(
        &["twin", "modes", twin, "--count", "1000000000000"],
        &["--count"],
    );
    refused(&["twin", "modes", twin, "--count", "0"], &["--count"]);
}

#[test]
fn track_and_synth_archive_flags_are_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let archive = dir.path().join("sds");
    std::fs::create_dir_all(&archive).unwrap();
    let a = archive.to_str().unwrap();
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    let span = [
        "--start",
        "2026-01-01T00:00:00Z",
        "--end",
        "2027-01-01T00:00:00Z",
    ];
    let track = |extra: &[&str], names: &[&str]| {
        let mut args = vec!["track", a, "--out", out];
        args.extend(span);
        args.extend(extra);
        refused(&args, names);
    };
    // A year in 1-ms steps: 3·10¹⁰ windows.
    track(
        &["--window", "60s", "--step", "0.001s"],
        &["--step", "1000000"],
    );
    track(&["--window", "100d"], &["--window", "86400"]);
    refused(
        &["synth-archive", "--out", out, "--day-length", "1000d"],
        &["--day-length"],
    );
    refused(
        &["synth-archive", "--out", out, "--days", "100000000"],
        &["--days"],
    );
}

#[test]
fn library_settings_name_their_key() {
    use quaketwin::hysteresis::IdentifySettings;
    let s = IdentifySettings {
        exponent_max: 1e300,
        ..Default::default()
    };
    let e = quaketwin::hysteresis::settings::validate_settings(&s).unwrap_err();
    assert!(e.to_string().contains("exponent_max"), "{e}");

    let mut r = quaketwin::rehearse::RehearseSettings {
        substeps: Some(usize::MAX),
        ..Default::default()
    };
    let e = r.check("rehearse.toml").unwrap_err();
    assert!(e.to_string().contains("substeps"), "{e}");
    r.substeps = None;
    r.delay_s = 1e300;
    assert!(r.check("x").unwrap_err().to_string().contains("delay_s"));
    r.delay_s = 0.0;
    r.time_scales = vec![10.0; 101];
    assert!(r
        .check("x")
        .unwrap_err()
        .to_string()
        .contains("time_scales"));

    let report = quaketwin::report::ReportSettings {
        max_points_per_trace: usize::MAX,
        ..Default::default()
    };
    let e = report.validate().unwrap_err();
    assert!(e.to_string().contains("max_points_per_trace"), "{e}");

    // The Python `modal` takes the stage's params as JSON: the same check.
    let p: quaketwin::stages::modal::ModalParams =
        serde_json::from_str(r#"{"orders": [2, 9223372036854775807, 2]}"#).unwrap();
    assert!(p.validate().unwrap_err().to_string().contains("orders"));
}
