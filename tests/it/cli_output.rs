//! The command line for scripts and people: `--json` summaries on stdout
//! (logs on stderr), `-q` / `-v`, and help with an example for every
//! command and a description for every flag (docs/cli.md).

use std::path::{Path, PathBuf};
use std::process::Output;

use crate::common::{os, quaketwin};
use serde_json::Value;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn stdout_json(o: &Output) -> Value {
    let text = String::from_utf8_lossy(&o.stdout);
    serde_json::from_str(&text).unwrap_or_else(|e| {
        panic!(
            "stdout is not one JSON document ({e}):\n{text}\nstderr:\n{}",
            String::from_utf8_lossy(&o.stderr)
        )
    })
}

fn sample(name: &str) -> PathBuf {
    root().join("sample-records").join(name)
}

/// `run --json`: one JSON document on stdout with the stages, the files the
/// run manifest lists, the modes and Bouc-Wen status read back from the
/// tables, and the report's rating; the progress lines stay on stderr.
#[test]
fn run_json_summarises_stages_results_and_rating_on_stdout() {
    let out = tempfile::tempdir().unwrap();
    let pipeline = root().join("pipelines/post-earthquake.toml");
    let event = sample("synthetic-2storey-yielding");
    let o = quaketwin(&[
        os("run"),
        os(&pipeline),
        os(&event),
        os("--out"),
        os(out.path()),
        os("--json"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v = stdout_json(&o);
    assert_eq!(v["ok"], true);
    assert_eq!(v["error"], Value::Null);
    let stages: Vec<&str> = v["stages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap())
        .collect();
    let declared = quaketwin::stages::load_pipeline(&pipeline).unwrap();
    let names: Vec<&str> = declared
        .stages
        .iter()
        .map(|s| s.decl.name.as_str())
        .collect();
    assert_eq!(stages, names);
    // The update stage does not apply (no twin), and says why.
    let update = v["stages"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["name"] == "update")
        .unwrap();
    assert_eq!(update["outcome"], "not_applicable");
    assert!(update["reason"].as_str().unwrap().contains("twin"));
    // Outputs are the manifest's list; every listed file exists.
    let outputs: Vec<&str> = v["outputs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f.as_str().unwrap())
        .collect();
    assert!(outputs.contains(&"modes/modes.parquet") && outputs.contains(&"report.html"));
    for f in &outputs {
        assert!(out.path().join(f).is_file(), "{f}");
    }
    // Modes as modes/modes.parquet holds them.
    let modes = v["modes"].as_array().unwrap();
    let (tabled, _) =
        quaketwin::sinks::modal_tables::read_modes(&out.path().join("modes/modes.parquet"))
            .unwrap();
    assert_eq!(modes.len(), tabled.len());
    for (m, t) in modes.iter().zip(&tabled) {
        assert_eq!(m["frequency_hz"].as_f64().unwrap(), t.frequency_hz);
    }
    // The yielding frame: X identified, and the rating the report opens with.
    assert_eq!(v["bouc_wen"][0]["direction"], "X");
    assert_eq!(v["bouc_wen"][0]["status"], "identified");
    let rating = v["assessment"]["rating"].as_str().unwrap();
    let html = std::fs::read_to_string(out.path().join("report.html")).unwrap();
    let opening = &html[html.find("id=\"overall-rating\"").unwrap()..][..400];
    assert!(
        opening.contains(&rating.to_uppercase()),
        "JSON says {rating}, the report opens with {opening}"
    );
    assert!(!v["assessment"]["drivers"].as_array().unwrap().is_empty());
    // Progress went to stderr.
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("[post-earthquake] hysteresis"), "{stderr}");
}

/// A failed run still prints its summary (`ok: false` and the error), and
/// exits 1 with the error on stderr.
#[test]
fn a_failed_run_prints_ok_false_and_exits_1() {
    let dir = tempfile::tempdir().unwrap();
    let event = dir.path().join("event");
    std::fs::create_dir(&event).unwrap();
    std::fs::write(event.join("notes.txt"), "no records here").unwrap();
    let out = dir.path().join("out");
    let o = quaketwin(&[
        os("run"),
        os(&root().join("pipelines/post-earthquake.toml")),
        os(&event),
        os("--out"),
        os(&out),
        os("--json"),
        os("-q"),
    ]);
    assert_eq!(o.status.code(), Some(1));
    let v = stdout_json(&o);
    assert_eq!(v["ok"], false);
    let error = v["error"].as_str().unwrap();
    assert!(!error.is_empty());
    assert!(String::from_utf8_lossy(&o.stderr).contains(error));
}

/// `-q` leaves warnings only; `-v` adds each stage's start and files.
#[test]
fn quiet_and_verbose_choose_what_goes_to_stderr() {
    let event = sample("synthetic-2storey-yielding");
    let pipeline = root().join("pipelines/ingest.toml");
    let run = |flag: Option<&str>| {
        let out = tempfile::tempdir().unwrap();
        let mut args = vec![
            os("run"),
            os(&pipeline),
            os(&event),
            os("--out"),
            os(out.path()),
        ];
        args.extend(flag.map(os));
        let o = quaketwin(&args);
        assert!(o.status.success());
        assert!(o.stdout.is_empty(), "without --json nothing on stdout");
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let quiet = run(Some("-q"));
    assert!(!quiet.contains("[ingest]"), "{quiet}");
    let verbose = run(Some("-v"));
    assert!(verbose.contains("running (ingest)"), "{verbose}");
    assert!(verbose.contains("-> event.json"), "{verbose}");
    let normal = run(None);
    assert!(normal.contains("[ingest] ingest       done in"), "{normal}");
    assert!(!normal.contains("running ("), "{normal}");
}

/// `inspect --json` is the event.json document: channels, files, geometry.
#[test]
fn inspect_json_lists_channels_files_and_geometry() {
    let event = sample("synthetic-4storey-quake");
    let o = quaketwin(&[os("inspect"), os(&event), os("--json")]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v = stdout_json(&o);
    let text = quaketwin::commands::inspect(&event).unwrap();
    let channels = v["channels"].as_array().unwrap();
    assert!(!channels.is_empty());
    for c in channels {
        let id = c["id"].as_str().unwrap();
        assert!(text.contains(id), "{id} not in the text inventory");
        assert!(c["npts"].as_u64().unwrap() > 0);
    }
    assert!(v["files"].as_array().unwrap().len() >= 3);
    assert!(v["geometry"].is_object(), "{}", v["geometry"]);
}

/// `inspect` lists an event without keeping its samples: its document is
/// the one a full load gives (what ingest writes as event.json), for the
/// sample events and for real records whose geometry rotates azimuth pairs
/// (Eureka 1983) or reads modern CSMIP layouts.
#[test]
fn inspect_lists_without_samples_the_document_a_full_load_gives() {
    let bridges = crate::common::shared_records().join("cesmd-bridges-corpus");
    let events = [
        sample("synthetic-4storey-quake"),
        sample("synthetic-2storey-yielding"),
        sample("synthetic-4storey-ambient"),
        sample("synthetic-facade"),
        bridges.join("painter-st-ce89324/eureka_24aug1983_ce89324p.zip"),
        bridges.join("painter-st-ce89324/petrolia_05dec2016_72733405_ce89324p.zip"),
        bridges.join("crowley-ce54730/QualeysCamp_18Sep2004_CE54730.ZIP"),
    ];
    for event in &events {
        let full = quaketwin::event_folder::load(event).unwrap();
        let listing = quaketwin::event_folder::load_listing(event).unwrap();
        assert!(
            listing.event.records.iter().all(|r| r.samples.is_parked()),
            "{}: a listed record kept its samples",
            event.display()
        );
        assert_eq!(
            String::from_utf8(quaketwin::stages::ingest::inventory_json(&listing).unwrap()),
            String::from_utf8(quaketwin::stages::ingest::inventory_json(&full).unwrap()),
            "{}",
            event.display()
        );
        assert_eq!(
            quaketwin::commands::render_inventory(&listing),
            quaketwin::commands::render_inventory(&full),
            "{}",
            event.display()
        );
    }
}

/// Many events: one summary per event, in the order given, each naming its
/// run directory's files.
#[test]
fn many_event_run_json_has_one_summary_per_event() {
    let out = tempfile::tempdir().unwrap();
    let events = [
        sample("synthetic-2storey-yielding"),
        sample("synthetic-4storey-ambient"),
    ];
    let o = quaketwin(&[
        os("run"),
        os(&root().join("pipelines/ingest.toml")),
        os(&events[0]),
        os(&events[1]),
        os("--out"),
        os(out.path()),
        os("--json"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v = stdout_json(&o);
    let summaries = v["events"].as_array().unwrap();
    assert_eq!(summaries.len(), 2);
    for (s, e) in summaries.iter().zip(&events) {
        assert_eq!(s["event"].as_str().unwrap(), e.display().to_string());
        assert_eq!(s["ok"], true);
        let dir = Path::new(s["out"].as_str().unwrap());
        assert!(
            dir.starts_with(out.path().join("runs")),
            "{}",
            dir.display()
        );
        assert!(dir.join("event.json").is_file());
    }
}

/// `twin export` writes K and M of the free DoFs as Matrix Market files
/// that read back to the matrices the twin solves: the lowest frequency from
/// the exported matrices (dense generalised eigenproblem of the 4-storey
/// sample's twin, in Python-free Rust via the library's own reader) equals
/// `twin modes`'.
#[test]
fn twin_export_writes_the_matrices_twin_modes_solves() {
    let out = tempfile::tempdir().unwrap();
    let twin = sample("synthetic-4storey-quake").join("twin.toml");
    let o = quaketwin(&[
        os("--json"),
        os("twin"),
        os("export"),
        os(&twin),
        os("--out"),
        os(out.path()),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let e = stdout_json(&o);
    let n = e["dofs"].as_u64().unwrap() as usize;
    let read = |f: &str| {
        let text = std::fs::read_to_string(out.path().join(f)).unwrap();
        assert!(
            text.starts_with("%%MatrixMarket matrix coordinate real symmetric"),
            "{f}"
        );
        let mut dense = vec![vec![0.0f64; n]; n];
        let mut lines = text.lines().filter(|l| !l.starts_with('%'));
        let size: Vec<usize> = lines
            .next()
            .unwrap()
            .split_whitespace()
            .map(|x| x.parse().unwrap())
            .collect();
        assert_eq!((size[0], size[1]), (n, n), "{f}");
        for l in lines {
            let v: Vec<&str> = l.split_whitespace().collect();
            let (i, j, x): (usize, usize, f64) = (
                v[0].parse().unwrap(),
                v[1].parse().unwrap(),
                v[2].parse().unwrap(),
            );
            assert!(i >= j, "{f}: upper-triangle entry {i},{j}");
            dense[i - 1][j - 1] = x;
            dense[j - 1][i - 1] = x;
        }
        dense
    };
    let (k, m) = (read("stiffness.mtx"), read("mass.mtx"));
    // Lowest eigenvalue of K x = λ M x by inverse iteration (K is SPD).
    let solve = |a: &Vec<Vec<f64>>, b: &[f64]| -> Vec<f64> {
        let mut a = a.clone();
        let mut x = b.to_vec();
        for c in 0..n {
            let p = (c..n)
                .max_by(|&r, &s| a[r][c].abs().total_cmp(&a[s][c].abs()))
                .unwrap();
            a.swap(c, p);
            x.swap(c, p);
            let pivot = a[c].clone();
            for r in c + 1..n {
                let f = a[r][c] / pivot[c];
                for (v, p) in a[r].iter_mut().zip(&pivot).skip(c) {
                    *v -= f * p;
                }
                x[r] -= f * x[c];
            }
        }
        for c in (0..n).rev() {
            let s: f64 = (c + 1..n).map(|q| a[c][q] * x[q]).sum();
            x[c] = (x[c] - s) / a[c][c];
        }
        x
    };
    let mul = |a: &Vec<Vec<f64>>, x: &[f64]| -> Vec<f64> {
        a.iter()
            .map(|row| row.iter().zip(x).map(|(p, q)| p * q).sum())
            .collect()
    };
    let mut x = vec![1.0; n];
    let mut lambda = 0.0;
    for _ in 0..500 {
        let y = solve(&k, &mul(&m, &x));
        let ky: f64 = y.iter().zip(mul(&k, &y)).map(|(p, q)| p * q).sum();
        let my: f64 = y.iter().zip(mul(&m, &y)).map(|(p, q)| p * q).sum();
        lambda = ky / my;
        let norm = my.sqrt();
        x = y.iter().map(|v| v / norm).collect();
    }
    let f_exported = lambda.sqrt() / (2.0 * std::f64::consts::PI);
    let o = quaketwin(&[
        os("--json"),
        os("twin"),
        os("modes"),
        os(&twin),
        os("--count"),
        os("2"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let f1 = stdout_json(&o)["frequencies_hz"][0].as_f64().unwrap();
    assert!(
        (f_exported / f1 - 1.0).abs() < 1e-9,
        "exported matrices give {f_exported} Hz, twin modes {f1} Hz"
    );
}

/// Every command's help has an example, and every flag a description.
#[test]
fn help_has_an_example_per_command_and_a_description_per_flag() {
    let commands = [
        "inspect",
        "ingest",
        "update",
        "report",
        "modal",
        "hysteresis",
        "design",
        "synth",
        "run",
        "fleet",
        "watch",
        "dashboard",
        "rehearse",
        "twin export",
        "twin modes",
        "twin plate",
    ];
    let top = quaketwin(&[os("--help")]);
    let top_text = String::from_utf8_lossy(&top.stdout);
    for c in commands {
        let words: Vec<&str> = c.split(' ').collect();
        assert!(top_text.contains(words[0]), "{c} missing from --help");
        let mut args: Vec<&std::ffi::OsStr> = words.iter().map(os).collect();
        args.push(os("--help"));
        let o = quaketwin(&args);
        assert!(o.status.success());
        let text = String::from_utf8_lossy(&o.stdout);
        let examples = &text[text
            .find("Examples:")
            .unwrap_or_else(|| panic!("{c} --help has no example:\n{text}"))..];
        assert!(
            examples.contains(&format!("quaketwin {c}")),
            "{c}: {examples}"
        );
        // Option lines: `  -x, --flag <V>  description` — the description
        // follows on the same line (clap's layout when there is one).
        let options = &text[text.find("Options:").unwrap()..text.find("Examples:").unwrap()];
        for line in options.lines().filter(|l| l.trim_start().starts_with('-')) {
            let words = line.split_whitespace().count();
            let flag_words = line
                .split_whitespace()
                .take_while(|w| w.starts_with('-') || w.starts_with('<'))
                .count();
            assert!(
                words > flag_words,
                "{c}: flag without a description: {line:?}"
            );
        }
    }
}
