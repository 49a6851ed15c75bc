//! Issue 33 item 3: one policy for every path the program opens.  Every
//! user-named input is a regular file (a FIFO or device refused before it is
//! opened, so nothing blocks); links in an event folder are followed only to
//! regular files inside it, with one message in `inspect`, `ingest`, `run`
//! and the fingerprint; `synth-archive` writes through the atomic writer;
//! `report` checks what it shows against run.json; no temporary file
//! survives a successful run.  Each case runs the binary with a deadline.

#![cfg(unix)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

fn exe() -> &'static str {
    env!("CARGO_BIN_EXE_quaketwin")
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn sample(name: &str) -> PathBuf {
    root().join("sample-records").join(name)
}

fn mkfifo(p: &Path) {
    let st = Command::new("mkfifo").arg(p).status().unwrap();
    assert!(st.success(), "mkfifo {}", p.display());
}

/// Exit code and stderr of `quaketwin -q ARGS`, which must end within
/// `limit` (killed and failed otherwise: it blocked).
fn quaketwin(args: &[&dyn AsRef<std::ffi::OsStr>], limit: Duration) -> (i32, String) {
    let mut all = vec![std::ffi::OsStr::new("-q")];
    all.extend(args.iter().map(|a| a.as_ref()));
    let here = std::env::current_dir().unwrap();
    let o = crate::child::run_quaketwin(&all, &here, limit);
    assert!(
        !o.timed_out,
        "quaketwin {all:?} did not return within {limit:?} (it blocked)"
    );
    (o.code.unwrap_or(-1), o.stderr)
}

/// Refusals come before any record is read: well within this.
const QUICK: Duration = Duration::from_secs(15);
/// A whole (small) run in the debug build.
const RUN: Duration = Duration::from_secs(120);

/// Every file under `dir` whose name marks a temporary file.
fn temp_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let e = e.unwrap();
            let p = e.path();
            if e.file_type().unwrap().is_dir() {
                stack.push(p);
            } else if e.file_name().to_string_lossy().contains(".tmp") {
                out.push(p);
            }
        }
    }
    out
}

fn assert_refused(code: i32, stderr: &str, want_code: i32, path: &Path, what: &str) {
    assert_eq!(code, want_code, "{stderr}");
    assert!(
        stderr.contains(&path.display().to_string()) && stderr.contains(what),
        "the message names {} and says {what:?}: {stderr}",
        path.display()
    );
}

/// A FIFO given as any user-named input file is refused at once, naming it:
/// the pipeline file, `--reference`, `update TWIN`, `--modes`, `--settings`
/// of `update`/`report`/`rehearse`, `twin modes`, `design`, `track
/// --stationxml` (what Python's `run(reference=…)` and
/// `track(stationxml=…)` call).  A device is refused the same way.
#[test]
fn a_fifo_or_device_named_as_an_input_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fifo = d.join("input.fifo");
    mkfifo(&fifo);
    let event = sample("synthetic-4storey-quake");
    let twin = event.join("twin.toml");
    let out = d.join("out");
    let post = root().join("pipelines/post-earthquake.toml");

    let (code, e) = quaketwin(&[&"run", &fifo, &event, &"--out", &out], QUICK);
    assert_refused(code, &e, 1, &fifo, "FIFO");
    assert!(e.contains("not a regular file"), "{e}");
    let (code, e) = quaketwin(&[&"run", &"/dev/zero", &event, &"--out", &out], QUICK);
    assert_refused(code, &e, 1, Path::new("/dev/zero"), "a device");
    // --reference is a usage error (exit 2), as every --reference error is.
    let (code, e) = quaketwin(
        &[&"run", &post, &event, &"--out", &out, &"--reference", &fifo],
        QUICK,
    );
    assert_refused(code, &e, 2, &fifo, "FIFO");
    let (code, e) = quaketwin(
        &[&"update", &fifo, &"--modes", &fifo, &"--out", &out],
        QUICK,
    );
    assert_refused(code, &e, 1, &fifo, "FIFO");
    let (code, e) = quaketwin(
        &[&"update", &twin, &"--modes", &fifo, &"--out", &out],
        QUICK,
    );
    assert_refused(code, &e, 1, &fifo, "FIFO");
    let (code, e) = quaketwin(
        &[
            &"update",
            &twin,
            &"--modes",
            &fifo,
            &"--out",
            &out,
            &"--settings",
            &fifo,
        ],
        QUICK,
    );
    assert_refused(code, &e, 1, &fifo, "FIFO");
    let (code, e) = quaketwin(&[&"twin", &"modes", &fifo], QUICK);
    assert_refused(code, &e, 1, &fifo, "FIFO");
    let (code, e) = quaketwin(&[&"design", &fifo, &"--out", &out], QUICK);
    assert_refused(code, &e, 1, &fifo, "FIFO");
    let (code, e) = quaketwin(&[&"report", &d, &"--settings", &fifo], QUICK);
    assert_refused(code, &e, 1, &fifo, "FIFO");
    let (code, e) = quaketwin(
        &[&"rehearse", &d, &"--out", &out, &"--settings", &fifo],
        QUICK,
    );
    assert_refused(code, &e, 1, &fifo, "FIFO");

    // track --stationxml: a small archive, then the FIFO as its StationXML.
    let arch = d.join("arch");
    let (code, e) = quaketwin(
        &[
            &"synth-archive",
            &"--out",
            &arch,
            &"--days",
            &"1",
            &"--channels",
            &"2",
            &"--rate",
            &"20",
            &"--day-length",
            &"2h",
            &"--damage-day",
            &"0",
        ],
        RUN,
    );
    assert_eq!(code, 0, "{e}");
    let (code, e) = quaketwin(
        &[
            &"track",
            &arch.join("sds"),
            &"--out",
            &out,
            &"--stationxml",
            &fifo,
        ],
        QUICK,
    );
    assert_refused(code, &e, 1, &fifo, "FIFO");

    // The pipeline run's own inputs are untouched: nothing was written.
    assert!(!out.join("run.json").exists());
}

/// A user-named file above the 1 GiB cap is refused from its size, before
/// it is read (a sparse file: no disk, no time); the cap and the size are named.
#[test]
fn an_oversized_input_file_is_refused_before_it_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let big = dir.path().join("pipeline.toml");
    let f = std::fs::File::create(&big).unwrap();
    f.set_len(2 << 30).unwrap();
    drop(f);
    let out = dir.path().join("out");
    let (code, e) = quaketwin(
        &[
            &"run",
            &big,
            &sample("synthetic-4storey-quake"),
            &"--out",
            &out,
        ],
        QUICK,
    );
    // A pipeline file is usage (exit 2), capped at 1 MiB (issue 33 item 2).
    assert_refused(code, &e, 2, &big, "2147483648 bytes");
    assert!(e.contains("the limit of 1048576 bytes"), "{e}");

    // The function itself, with a small cap: the read is bounded by it.
    let small = dir.path().join("eleven");
    std::fs::write(&small, b"hello world").unwrap();
    let err = quaketwin::input_file::read(&small, 10).unwrap_err();
    assert_eq!(err.exit_code(), 1);
    assert!(
        err.to_string()
            .contains("has 11 bytes; the limit is 10 bytes"),
        "{err}"
    );
    assert_eq!(
        quaketwin::input_file::read(&small, 11).unwrap(),
        b"hello world"
    );
    let err = quaketwin::input_file::read_to_string(Path::new("/dev/null"), 10).unwrap_err();
    assert!(
        err.to_string().contains("is a device, not a regular file"),
        "{err}"
    );
}

/// A copy of the sample event `name` in `dir/name` (regular files).
fn copy_event(name: &str, dir: &Path) -> PathBuf {
    let to = dir.join(name);
    std::fs::create_dir_all(&to).unwrap();
    for e in std::fs::read_dir(sample(name)).unwrap() {
        let p = e.unwrap().path();
        std::fs::copy(&p, to.join(p.file_name().unwrap())).unwrap();
    }
    to
}

/// Links inside an event folder: followed to a regular file inside the
/// folder (a linked `event.toml` is the manifest, a linked record named by
/// the manifest is read); refused with one message — the same in `inspect`,
/// `ingest`, `run` and the fingerprint — when dangling or leading outside.
#[test]
fn links_in_an_event_folder_follow_one_policy_everywhere() {
    let dir = tempfile::tempdir().unwrap();
    let event = copy_event("synthetic-4storey-quake", dir.path());
    // Both the manifest and a record it names, moved aside (into a hidden
    // folder, which is not read itself) and linked back.
    std::fs::create_dir(event.join(".store")).unwrap();
    for f in ["event.toml", "base_X.AT2"] {
        std::fs::rename(event.join(f), event.join(".store").join(f)).unwrap();
        std::os::unix::fs::symlink(Path::new(".store").join(f), event.join(f)).unwrap();
    }
    let (code, e) = quaketwin(&[&"inspect", &event], RUN);
    assert_eq!(code, 0, "{e}");
    let out = Command::new(exe())
        .args(["-q", "inspect", "--json"])
        .arg(&event)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(!text.contains("no event.toml manifest"), "{text}");
    assert!(text.contains("B-X"), "the linked record is read: {text}");

    let run_out = dir.path().join("run-out");
    let (code, e) = quaketwin(
        &[
            &"run",
            &root().join("pipelines/ingest.toml"),
            &event,
            &"--out",
            &run_out,
        ],
        RUN,
    );
    assert_eq!(code, 0, "{e}");
    assert!(
        temp_files(&run_out).is_empty(),
        "{:?}",
        temp_files(&run_out)
    );

    // Dangling, and leading outside: one error, everywhere.
    let elsewhere = tempfile::tempdir().unwrap();
    let outside = elsewhere.path().join("notes.txt");
    std::fs::write(&outside, b"not the event's").unwrap();
    for (target, says) in [
        (dir.path().join("gone.csv"), "leads nowhere"),
        (outside.clone(), "leads outside the folder"),
    ] {
        let link = event.join("extra.csv");
        let _ = std::fs::remove_file(&link);
        std::os::unix::fs::symlink(&target, &link).unwrap();
        let mut messages = Vec::new();
        for args in [
            vec!["inspect".to_string(), event.display().to_string()],
            vec![
                "ingest".into(),
                event.display().to_string(),
                "--out".into(),
                dir.path().join("ingest-out").display().to_string(),
            ],
            vec![
                "run".into(),
                root().join("pipelines/ingest.toml").display().to_string(),
                event.display().to_string(),
                "--out".into(),
                dir.path().join("run-out2").display().to_string(),
            ],
        ] {
            let refs: Vec<&dyn AsRef<std::ffi::OsStr>> = args
                .iter()
                .map(|a| a as &dyn AsRef<std::ffi::OsStr>)
                .collect();
            let (code, e) = quaketwin(&refs, QUICK);
            assert_refused(code, &e, 1, &link, says);
            assert!(e.contains("followed only to a regular file inside"), "{e}");
            let line = e
                .lines()
                .find(|l| l.contains("extra.csv"))
                .unwrap()
                .to_string();
            messages.push(line[line.find(&link.display().to_string()).unwrap()..].to_string());
        }
        let fp = quaketwin::pipeline::fingerprint::path_fingerprint(&event)
            .unwrap_err()
            .to_string();
        messages.push(fp[fp.find(&link.display().to_string()).unwrap()..].to_string());
        assert!(
            messages.iter().all(|m| *m == messages[0]),
            "one message everywhere: {messages:#?}"
        );
    }
    assert_eq!(std::fs::read(&outside).unwrap(), b"not the event's");

    // A FIFO in the event folder: refused at once, never opened.
    std::fs::remove_file(event.join("extra.csv")).unwrap();
    let fifo = event.join("pipe.csv");
    mkfifo(&fifo);
    let (code, e) = quaketwin(&[&"inspect", &event], QUICK);
    assert_refused(code, &e, 1, &fifo, "FIFO");
}

/// `synth-archive` writes through the atomic writer: a link at a day file's
/// path is refused (the file it points to, outside the archive, is kept), a
/// FIFO there does not block; no temporary file is left either way.
#[test]
fn synth_archive_never_writes_through_a_link_or_into_a_fifo() {
    let dir = tempfile::tempdir().unwrap();
    let arch = dir.path().join("arch");
    let args = |arch: &Path| -> Vec<String> {
        [
            "synth-archive",
            "--out",
            &arch.display().to_string(),
            "--days",
            "1",
            "--channels",
            "2",
            "--rate",
            "20",
            "--day-length",
            "2h",
        ]
        .map(String::from)
        .to_vec()
    };
    let run = |arch: &Path, limit| {
        let a = args(arch);
        let refs: Vec<&dyn AsRef<std::ffi::OsStr>> =
            a.iter().map(|a| a as &dyn AsRef<std::ffi::OsStr>).collect();
        quaketwin(&refs, limit)
    };
    let (code, e) = run(&arch, RUN);
    assert_eq!(code, 0, "{e}");
    assert!(temp_files(&arch).is_empty(), "{:?}", temp_files(&arch));
    let mut days: Vec<PathBuf> = Vec::new();
    let mut stack = vec![arch.join("sds")];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                days.push(p);
            }
        }
    }
    days.sort();
    assert_eq!(days.len(), 2, "{days:?}");

    let elsewhere = tempfile::tempdir().unwrap();
    let precious = elsewhere.path().join("precious");
    std::fs::write(&precious, b"keep me").unwrap();
    std::fs::remove_file(&days[0]).unwrap();
    std::os::unix::fs::symlink(&precious, &days[0]).unwrap();
    let (code, e) = run(&arch, QUICK);
    assert_refused(code, &e, 2, &days[0], "symbolic link");
    assert_eq!(std::fs::read(&precious).unwrap(), b"keep me");
    assert!(std::fs::symlink_metadata(&days[0])
        .unwrap()
        .file_type()
        .is_symlink());
    assert!(temp_files(&arch).is_empty(), "{:?}", temp_files(&arch));

    std::fs::remove_file(&days[0]).unwrap();
    mkfifo(&days[0]);
    let (code, e) = run(&arch, QUICK);
    assert_refused(code, &e, 2, &days[0], "FIFO");
    assert!(temp_files(&arch).is_empty(), "{:?}", temp_files(&arch));
}

/// `quaketwin report DIR` shows only this run's files: a listed table
/// replaced by another event's is an error naming it and run.json (exit 1,
/// no page written); a table run.json does not list is not shown, and the
/// appendix says it is not from this run.
#[test]
fn report_checks_the_files_it_shows_against_run_json() {
    let dir = tempfile::tempdir().unwrap();
    let ingest = root().join("pipelines/ingest.toml");
    let a = dir.path().join("a");
    let b = dir.path().join("b");
    for (event, out) in [
        ("synthetic-4storey-quake", &a),
        ("synthetic-2storey-yielding", &b),
    ] {
        let (code, e) = quaketwin(&[&"run", &ingest, &sample(event), &"--out", out], RUN);
        assert_eq!(code, 0, "{e}");
        assert!(temp_files(out).is_empty(), "{:?}", temp_files(out));
    }
    // A clean directory: the report is written.
    let (code, e) = quaketwin(&[&"report", &a], RUN);
    assert_eq!(code, 0, "{e}");
    let page = a.join("report.html");
    let before = std::fs::read(&page).unwrap();

    // Another event's channels/channels.parquet copied in: refused, page kept as it was.
    std::fs::copy(
        b.join("channels/channels.parquet"),
        a.join("channels/channels.parquet"),
    )
    .unwrap();
    let (code, e) = quaketwin(&[&"report", &a], RUN);
    assert_refused(
        code,
        &e,
        1,
        &a.join("channels/channels.parquet"),
        "run.json",
    );
    assert!(e.contains("not the file the run recorded"), "{e}");
    assert_eq!(std::fs::read(&page).unwrap(), before);

    // Rebuilt by a re-run, then a file the run does not list (the ingest
    // pipeline has no modal stage) is left out and named as not this run's.
    let (code, e) = quaketwin(
        &[
            &"run",
            &ingest,
            &sample("synthetic-4storey-quake"),
            &"--out",
            &a,
        ],
        RUN,
    );
    assert_eq!(code, 0, "{e}");
    std::fs::create_dir_all(a.join("modes")).unwrap();
    std::fs::write(a.join("modes/modes.parquet"), b"another run's").unwrap();
    let (code, e) = quaketwin(&[&"report", &a], RUN);
    assert_eq!(code, 0, "{e}");
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(
        html.contains("not from this run (not listed in run.json): not shown"),
        "the appendix names the stray file"
    );
    assert!(temp_files(&a).is_empty(), "{:?}", temp_files(&a));
}

/// A re-run of a many-event dataset leaves no temporary file (the tables are
/// already published as links to the runs' files: a rename of a link onto
/// its own inode is a no-op, which left one `.part-0.parquet.quaketwin-PID.tmp`
/// per table and event).
#[test]
fn a_rerun_of_a_dataset_leaves_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("dataset");
    let ingest = root().join("pipelines/ingest.toml");
    let e1 = sample("synthetic-4storey-quake");
    let e2 = sample("synthetic-2storey-yielding");
    for pass in 0..2 {
        let (code, e) = quaketwin(&[&"run", &ingest, &e1, &e2, &"--out", &out], RUN);
        assert_eq!(code, 0, "pass {pass}: {e}");
        let left = temp_files(&out);
        assert!(left.is_empty(), "pass {pass}: {left:?}");
    }
    // The tables are still published (part files of both events).
    let channels = out.join("tables/channels");
    let parts: Vec<PathBuf> = {
        let mut v = Vec::new();
        let mut stack = vec![channels];
        while let Some(d) = stack.pop() {
            for e in std::fs::read_dir(&d).unwrap() {
                let p = e.unwrap().path();
                if p.is_dir() {
                    stack.push(p);
                } else {
                    v.push(p);
                }
            }
        }
        v
    };
    assert_eq!(parts.len(), 2, "{parts:?}");
}
