//! The output directory holds the results of one run of one event (issue 14
//! items 1, 2, 3, 9): the run manifest `run.json`, the lock, re-runs that
//! rebuild damaged files, and writes that never replace a link, FIFO or
//! device and leave no temporary file behind.

use std::path::{Path, PathBuf};
use std::process::Command;

use quaketwin::pipeline::lock::{host_name, DirLock, Holder, LOCK_FILE};
use quaketwin::pipeline::manifest::{self, StageState};
use quaketwin::pipeline::{self, StageOutcome};
use quaketwin::sinks::atomic::{is_temp_name, temp_path, write_atomically, write_bytes_atomically};
use quaketwin::stages::parse_pipeline;
use quaketwin::Error;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn event(name: &str) -> PathBuf {
    root().join("sample-records").join(name)
}

fn exe() -> &'static str {
    env!("CARGO_BIN_EXE_quaketwin")
}

const INGEST: &str = "[pipeline]\nname = \"t\"\n[[stage]]\nname = \"ingest\"\nkind = \"ingest\"\n[[stage]]\nname = \"condition\"\nkind = \"condition\"\ninputs = [\"ingest\"]\n";

/// ingest → condition → modal → update (two quick solvers, one round) → report.
fn twin_pipeline() -> quaketwin::pipeline::Pipeline {
    let text = format!(
        "{INGEST}[[stage]]\nname = \"modal\"\nkind = \"modal\"\ninputs = [\"condition\"]\n\
         [[stage]]\nname = \"update\"\nkind = \"update\"\ninputs = [\"modal\"]\n[stage.params]\nsolvers = [\"ps\", \"qn\"]\nmax_rounds = 1\n\
         [[stage]]\nname = \"report\"\nkind = \"report\"\ninputs = [\"modal\", \"update\"]\n"
    );
    parse_pipeline(&text, "twin.toml").unwrap()
}

fn ingest_pipeline() -> quaketwin::pipeline::Pipeline {
    parse_pipeline(INGEST, "ingest.toml").unwrap()
}

fn section<'a>(html: &'a str, id: &str) -> &'a str {
    let start = html
        .find(&format!("<section id=\"{id}\">"))
        .unwrap_or_else(|| panic!("no section {id}"));
    let len = html[start..].find("</section>").unwrap();
    &html[start..start + len]
}

/// The files in `dir` and in its folders (a table's: `modes/modes.parquet`).
fn names_in(dir: &Path) -> Vec<String> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let e = e.unwrap();
        let name = e.file_name().to_string_lossy().into_owned();
        if e.file_type().unwrap().is_dir() {
            for f in std::fs::read_dir(e.path()).unwrap() {
                v.push(format!(
                    "{name}/{}",
                    f.unwrap().file_name().to_string_lossy()
                ));
            }
        } else {
            v.push(name);
        }
    }
    v.sort();
    v
}

/// Item 1: `run P quake --out D; run P yielding --out D` — the second event
/// has no twin, so its update stage does not apply; the first event's twin
/// files must not survive into D nor show in the report.
#[test]
fn a_second_event_removes_the_first_events_results_and_the_report_ignores_them() {
    let out = tempfile::tempdir().unwrap();
    let d = out.path();
    let p = twin_pipeline();
    let first = pipeline::run(&p, &event("synthetic-4storey-quake"), d, true).unwrap();
    assert!(matches!(first[3].1, StageOutcome::Ran { .. }), "{first:?}");
    for f in [
        "twin_update/twin_update.parquet",
        "twin_modes/twin_modes.parquet",
        "twin_updated.toml",
    ] {
        assert!(d.join(f).exists(), "{f} missing after the first event");
    }
    let html = std::fs::read_to_string(d.join("report.html")).unwrap();
    assert!(section(&html, "twin").contains("<table"));

    let second = pipeline::run(&p, &event("synthetic-2storey-yielding"), d, true).unwrap();
    assert!(
        matches!(second[3].1, StageOutcome::NotApplicable(_)),
        "{second:?}"
    );
    assert!(
        second
            .iter()
            .all(|(_, o)| !matches!(o, StageOutcome::Skipped)),
        "nothing of the first event may count as up to date: {second:?}"
    );
    for f in [
        "twin_update/twin_update.parquet",
        "twin_modes/twin_modes.parquet",
        "twin_updated.toml",
    ] {
        assert!(!d.join(f).exists(), "{f} of the first event survived");
    }
    let html = std::fs::read_to_string(d.join("report.html")).unwrap();
    let twin = section(&html, "twin");
    assert!(!twin.contains("<table"), "{twin}");
    assert!(
        twin.contains(
            "Not applicable to this event (stage <code>update</code>): the event names no twin"
        ),
        "{twin}"
    );
    let m = manifest::read(d).unwrap().unwrap();
    assert!(
        m.event.path.ends_with("synthetic-2storey-yielding"),
        "{m:?}"
    );
    let update = m.stage("update").unwrap();
    assert_eq!(update.state, StageState::NotApplicable);
    assert!(update.outputs.is_empty());
    // Every file in D is listed by the manifest (or is the manifest).
    let listed = m.done_files();
    for n in names_in(d) {
        assert!(n == "run.json" || listed.contains(&n), "unlisted {n} in D");
    }
}

/// A file of another event that no manifest lists is not shown by the report.
#[test]
fn the_report_shows_only_files_the_run_manifest_lists() {
    let out = tempfile::tempdir().unwrap();
    let d = out.path();
    let p = parse_pipeline(
        &format!(
            "{INGEST}[[stage]]\nname = \"report\"\nkind = \"report\"\ninputs = [\"condition\"]\n"
        ),
        "r.toml",
    )
    .unwrap();
    // A stray channel table of another event (as an older run would leave it).
    let other = tempfile::tempdir().unwrap();
    let metrics = format!(
        "{INGEST}[[stage]]\nname = \"metrics\"\nkind = \"metrics\"\ninputs = [\"condition\"]\n"
    );
    let m = parse_pipeline(&metrics, "m.toml").unwrap();
    pipeline::run(&m, &event("synthetic-2storey-yielding"), other.path(), true).unwrap();
    std::fs::create_dir_all(d.join("channels")).unwrap();
    std::fs::copy(
        other.path().join("channels/channels.parquet"),
        d.join("channels/channels.parquet"),
    )
    .unwrap();
    pipeline::run(&p, &event("synthetic-4storey-quake"), d, true).unwrap();
    let html = std::fs::read_to_string(d.join("report.html")).unwrap();
    let channels = section(&html, "channels");
    assert!(
        channels.contains("Stage not run / output absent: channel QA and strong-motion metrics"),
        "{channels}"
    );
    assert!(!channels.contains("<table"), "{channels}");
}

/// Item 2: a run while another holds the directory's lock fails at once,
/// naming the holder; the lock of a killed run on this host is taken over.
#[test]
fn a_second_run_while_the_lock_is_held_fails_naming_the_holder() {
    let out = tempfile::tempdir().unwrap();
    let d = out.path();
    let held = pipeline::lock::DirLock::acquire(d, "the first run").unwrap();
    let r = Command::new(exe())
        .args(["-q", "run"])
        .arg(root().join("pipelines/ingest.toml"))
        .arg(event("synthetic-4storey-quake"))
        .arg("--out")
        .arg(d)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("in use by another quaketwin run")
            && stderr.contains(&format!("pid {}", std::process::id()))
            && stderr.contains("the first run")
            && stderr.contains(".quaketwin.lock"),
        "{stderr}"
    );
    assert!(
        !d.join("event.json").exists(),
        "the refused run wrote into D"
    );
    // In-process too (same message, usage error).
    let e = pipeline::run(
        &ingest_pipeline(),
        &event("synthetic-4storey-quake"),
        d,
        true,
    )
    .unwrap_err();
    assert_eq!(e.exit_code(), 2);
    drop(held);
    assert!(!d.join(".quaketwin.lock").exists());

    // A lock file left by a killed run on this host: taken over, and said so.
    let stale = pipeline::lock::Holder {
        pid: u32::MAX - 7,
        host: pipeline::lock::host_name(),
        started: "2026-01-01T00:00:00Z".into(),
        what: "a killed run".into(),
    };
    std::fs::write(
        d.join(".quaketwin.lock"),
        serde_json::to_string(&stale).unwrap(),
    )
    .unwrap();
    let r = Command::new(exe())
        .args(["-q", "run"])
        .arg(root().join("pipelines/ingest.toml"))
        .arg(event("synthetic-4storey-quake"))
        .arg("--out")
        .arg(d)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains("stale lock") && stderr.contains("a killed run"),
        "{stderr}"
    );
    assert!(!d.join(".quaketwin.lock").exists());
}

/// Two runs of different events started together into one D: never both
/// succeed with a mix of files; whatever ends last, D holds one event only.
#[test]
fn two_runs_started_together_never_mix_two_events() {
    let out = tempfile::tempdir().unwrap();
    let d = out.path();
    let spawn = |ev: &str| {
        Command::new(exe())
            .args(["-q", "run"])
            .arg(root().join("pipelines/ingest.toml"))
            .arg(event(ev))
            .arg("--out")
            .arg(d)
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap()
    };
    let a = spawn("synthetic-4storey-quake");
    let b = spawn("synthetic-2storey-yielding");
    let (a, b) = (a.wait_with_output().unwrap(), b.wait_with_output().unwrap());
    for r in [&a, &b] {
        let code = r.status.code();
        assert!(
            code == Some(0) || code == Some(2),
            "{}",
            String::from_utf8_lossy(&r.stderr)
        );
        if code == Some(2) {
            assert!(String::from_utf8_lossy(&r.stderr).contains("in use"));
        }
    }
    // Whichever ran (one or both, one after the other), D holds one event:
    // the manifest's, with every result verified.
    let m = manifest::read(d).unwrap().unwrap();
    assert!(
        m.stages.iter().all(|s| s.state == StageState::Done),
        "{m:?}"
    );
    for s in &m.stages {
        for o in &s.outputs {
            assert_eq!(manifest::verify_output(d, o).unwrap(), Ok(()), "{}", o.file);
        }
    }
}

/// Item 3: a truncated samples/samples.parquet and a garbage modes/modes.parquet in a
/// finished D are rebuilt by the next run (not "up to date").
#[test]
fn damaged_outputs_are_rebuilt_on_re_run() {
    let out = tempfile::tempdir().unwrap();
    let d = out.path();
    let text = format!(
        "{INGEST}[[stage]]\nname = \"modal\"\nkind = \"modal\"\ninputs = [\"condition\"]\n"
    );
    let p = parse_pipeline(&text, "m.toml").unwrap();
    let ev = event("synthetic-4storey-ambient");
    pipeline::run(&p, &ev, d, true).unwrap();
    let samples = std::fs::read(d.join("samples/samples.parquet")).unwrap();
    let modes = std::fs::read(d.join("modes/modes.parquet")).unwrap();

    // Truncated samples/samples.parquet: condition re-runs; modal is still valid.
    std::fs::write(
        d.join("samples/samples.parquet"),
        &samples[..samples.len() / 2],
    )
    .unwrap();
    let r = pipeline::run(&p, &ev, d, true).unwrap();
    assert_eq!(r[0].1, StageOutcome::Skipped, "{r:?}");
    assert!(matches!(r[1].1, StageOutcome::Ran { .. }), "{r:?}");
    assert_eq!(
        std::fs::read(d.join("samples/samples.parquet")).unwrap(),
        samples
    );

    // Same size, other bytes: the hash, not only the size, is checked.
    let mut garbage = modes.clone();
    for b in garbage.iter_mut().skip(8).take(64) {
        *b = b'x';
    }
    std::fs::write(d.join("modes/modes.parquet"), &garbage).unwrap();
    let r = pipeline::run(&p, &ev, d, true).unwrap();
    assert_eq!(r[1].1, StageOutcome::Skipped, "{r:?}");
    assert!(matches!(r[2].1, StageOutcome::Ran { .. }), "{r:?}");
    assert_eq!(std::fs::read(d.join("modes/modes.parquet")).unwrap(), modes);

    // And now everything is up to date again.
    let r = pipeline::run(&p, &ev, d, true).unwrap();
    assert!(r.iter().all(|(_, o)| *o == StageOutcome::Skipped), "{r:?}");
}

/// Same input and settings: identical run manifest.
#[test]
fn the_run_manifest_is_deterministic_and_lists_sizes_and_hashes() {
    let a = tempfile::tempdir().unwrap();
    let b = tempfile::tempdir().unwrap();
    let ev = event("synthetic-4storey-quake");
    pipeline::run(&ingest_pipeline(), &ev, a.path(), true).unwrap();
    pipeline::run(&ingest_pipeline(), &ev, b.path(), true).unwrap();
    let ra = std::fs::read(a.path().join("run.json")).unwrap();
    assert_eq!(ra, std::fs::read(b.path().join("run.json")).unwrap());
    let m = manifest::read(a.path()).unwrap().unwrap();
    let rec = m.stage("condition").unwrap();
    let o = &rec.outputs[0];
    assert_eq!(o.file, "samples/samples.parquet");
    assert_eq!(
        o.bytes,
        Some(
            std::fs::metadata(a.path().join("samples/samples.parquet"))
                .unwrap()
                .len()
        )
    );
    // Hashed as it was written: the hash of the file read back.
    let (bytes, hash) = manifest::hash_file(&a.path().join("samples/samples.parquet"))
        .unwrap()
        .unwrap();
    assert_eq!(
        (o.bytes, o.xxh64.as_deref()),
        (Some(bytes), Some(hash.as_str()))
    );
}

/// The hash of the run manifest is XXH64 (what `xxhsum -H1` prints), and a
/// file changed after it was written is hashed from what it holds now.
#[test]
fn output_hashes_are_xxh64_of_the_file_as_it_is() {
    use quaketwin::hash::Hash64;
    // XXH64 test vectors (seed 0).
    assert_eq!(Hash64::default().finish_hex(), "ef46db3751d8e999");
    assert_eq!(
        Hash64::default().write_raw(b"a").finish_hex(),
        "d24ec4f1a98c6e5b"
    );
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("x.json");
    write_bytes_atomically(&f, b"a").unwrap();
    let rec = manifest::record_output(dir.path(), "x.json").unwrap();
    assert_eq!(rec.xxh64.as_deref(), Some("d24ec4f1a98c6e5b"));
    write_bytes_atomically(&f, b"ab").unwrap();
    std::fs::write(&f, b"abc").unwrap();
    let rec = manifest::record_output(dir.path(), "x.json").unwrap();
    let expected = Hash64::default().write_raw(b"abc").finish_hex();
    assert_eq!((rec.bytes, rec.xxh64), (Some(3), Some(expected)));
}

/// Item 9: temporary files of a killed run are swept; only quaketwin's.
#[test]
fn stale_temporary_files_are_swept_at_the_next_run() {
    let out = tempfile::tempdir().unwrap();
    let d = out.path();
    pipeline::run(
        &ingest_pipeline(),
        &event("synthetic-4storey-quake"),
        d,
        true,
    )
    .unwrap();
    for n in [
        ".samples.parquet.quaketwin-4242-0.tmp",
        ".event.json.4242.tmp",
        ".x.mcap.tmp-4242",
    ] {
        std::fs::write(d.join(n), b"half").unwrap();
    }
    std::fs::write(d.join("notes.tmp"), b"mine").unwrap();
    pipeline::run(
        &ingest_pipeline(),
        &event("synthetic-4storey-quake"),
        d,
        true,
    )
    .unwrap();
    let names = names_in(d);
    assert!(
        names.iter().all(|n| !n.starts_with('.')),
        "temporary files left: {names:?}"
    );
    assert!(d.join("notes.tmp").exists(), "a user's file was removed");
}

#[cfg(unix)]
fn mkfifo(p: &Path) {
    let st = Command::new("mkfifo").arg(p).status().unwrap();
    assert!(st.success());
}

#[cfg(unix)]
fn file_type(p: &Path) -> std::fs::FileType {
    std::fs::symlink_metadata(p).unwrap().file_type()
}

/// Item 9: a symbolic link or FIFO at an output path is refused, never replaced.
#[cfg(unix)]
#[test]
fn a_symlink_or_fifo_at_an_output_path_is_refused() {
    use std::os::unix::fs::FileTypeExt;
    let out = tempfile::tempdir().unwrap();
    let d = out.path();
    let elsewhere = tempfile::tempdir().unwrap();
    let target = elsewhere.path().join("precious.parquet");
    std::fs::write(&target, b"keep me").unwrap();
    std::fs::create_dir_all(d.join("samples")).unwrap();
    std::os::unix::fs::symlink(&target, d.join("samples/samples.parquet")).unwrap();
    let e = pipeline::run(
        &ingest_pipeline(),
        &event("synthetic-4storey-quake"),
        d,
        true,
    )
    .unwrap_err();
    let msg = e.to_string();
    assert_eq!(e.exit_code(), 2, "{msg}");
    assert!(
        msg.contains("samples/samples.parquet") && msg.contains("symbolic link"),
        "{msg}"
    );
    assert!(file_type(&d.join("samples/samples.parquet")).is_symlink());
    assert_eq!(std::fs::read(&target).unwrap(), b"keep me");

    let d2 = tempfile::tempdir().unwrap();
    mkfifo(&d2.path().join("event.json"));
    let r = Command::new(exe())
        .args(["-q", "run"])
        .arg(root().join("pipelines/ingest.toml"))
        .arg(event("synthetic-4storey-quake"))
        .arg("--out")
        .arg(d2.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("event.json") && stderr.contains("FIFO"),
        "{stderr}"
    );
    assert!(file_type(&d2.path().join("event.json")).is_fifo());
}

/// Item 9: `ingest --mcap` never replaces a link or FIFO (elsewhere than D
/// too); a regular MCAP file inside D is listed by the run manifest.
#[cfg(unix)]
#[test]
fn mcap_output_refuses_links_and_fifos_and_is_listed_inside_the_output_directory() {
    use std::os::unix::fs::FileTypeExt;
    let out = tempfile::tempdir().unwrap();
    let other = tempfile::tempdir().unwrap();
    let target = other.path().join("real.mcap");
    std::fs::write(&target, b"keep me").unwrap();
    let link = other.path().join("link.mcap");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let fifo = other.path().join("pipe.mcap");
    mkfifo(&fifo);
    for (path, what) in [(&link, "symbolic link"), (&fifo, "FIFO")] {
        let r = Command::new(exe())
            .args(["-q", "ingest"])
            .arg(event("synthetic-4storey-quake"))
            .arg("--out")
            .arg(out.path())
            .arg("--mcap")
            .arg(path)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains(what), "{stderr}");
    }
    assert!(file_type(&link).is_symlink());
    assert!(file_type(&fifo).is_fifo());
    assert_eq!(std::fs::read(&target).unwrap(), b"keep me");
    let leftovers: Vec<_> = names_in(other.path())
        .into_iter()
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");

    let inside = out.path().join("replay.mcap");
    quaketwin::commands::ingest(
        &event("synthetic-4storey-quake"),
        out.path(),
        Some(&inside),
        true,
    )
    .unwrap();
    let m = manifest::read(out.path()).unwrap().unwrap();
    assert!(m.done_files().contains(&"replay.mcap".to_string()), "{m:?}");
    // A run of another event removes it.
    pipeline::run(
        &ingest_pipeline(),
        &event("synthetic-2storey-yielding"),
        out.path(),
        true,
    )
    .unwrap();
    assert!(!inside.exists());
}

// The lock and the atomic writes on their own (src/pipeline/lock.rs,
// src/sinks/atomic.rs).

#[test]
fn a_second_lock_is_refused_naming_the_holder_and_released_on_drop() {
    let d = tempfile::tempdir().unwrap();
    let first = DirLock::acquire(d.path(), "event A").unwrap();
    assert!(first.took_over.is_none());
    let e = DirLock::acquire(d.path(), "event B").unwrap_err();
    let msg = e.to_string();
    assert_eq!(e.exit_code(), 2);
    assert!(
        msg.contains(&format!("pid {}", std::process::id())),
        "{msg}"
    );
    assert!(msg.contains("event A") && msg.contains("in use"), "{msg}");
    drop(first);
    assert!(!d.path().join(LOCK_FILE).exists());
    let again = DirLock::acquire(d.path(), "event B").unwrap();
    assert!(again.took_over.is_none());
}

#[test]
fn a_stale_lock_on_this_host_is_taken_over_one_of_another_host_refused() {
    let d = tempfile::tempdir().unwrap();
    let stale = Holder {
        pid: u32::MAX - 1,
        host: host_name(),
        started: "2020-01-01T00:00:00Z".into(),
        what: "killed run".into(),
    };
    std::fs::write(
        d.path().join(LOCK_FILE),
        serde_json::to_string(&stale).unwrap(),
    )
    .unwrap();
    let l = DirLock::acquire(d.path(), "new").unwrap();
    let said = l.took_over.clone().unwrap();
    assert!(
        said.contains("stale lock") && said.contains("killed run"),
        "{said}"
    );
    drop(l);
    let foreign = Holder {
        host: format!("{}-elsewhere", host_name()),
        ..stale
    };
    std::fs::write(
        d.path().join(LOCK_FILE),
        serde_json::to_string(&foreign).unwrap(),
    )
    .unwrap();
    let e = DirLock::acquire(d.path(), "new").unwrap_err();
    assert!(e.to_string().contains("another host"), "{e}");
}

#[test]
fn temp_names_are_recognised() {
    let t = temp_path(Path::new("/x/samples/samples.parquet"));
    let name = t.file_name().unwrap().to_str().unwrap();
    assert!(is_temp_name(name), "{name}");
    assert!(is_temp_name(".samples.parquet.1234.tmp"));
    assert!(is_temp_name(".x.mcap.tmp-77"));
    assert!(!is_temp_name("samples/samples.parquet"));
    assert!(!is_temp_name(".hidden.tmp"));
    assert!(!is_temp_name("a.1.tmp"));
}

#[test]
fn writes_replace_regular_files_only_and_leave_no_temp_file() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("a.json");
    write_bytes_atomically(&p, b"one").unwrap();
    write_bytes_atomically(&p, b"two").unwrap();
    assert_eq!(std::fs::read(&p).unwrap(), b"two");
    std::fs::create_dir(d.path().join("sub")).unwrap();
    let e = write_bytes_atomically(&d.path().join("sub"), b"x").unwrap_err();
    assert!(e.to_string().contains("a directory"), "{e}");
    // A failing writer leaves neither a temp file nor a changed target.
    let e = write_atomically(&p, |_| Err(Error::numerical("boom"))).unwrap_err();
    assert!(e.to_string().contains("boom"));
    assert_eq!(std::fs::read(&p).unwrap(), b"two");
    let names: Vec<_> = std::fs::read_dir(d.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert!(names.iter().all(|n| !is_temp_name(n)), "{names:?}");
}

#[cfg(unix)]
#[test]
fn a_symlink_is_never_replaced() {
    let d = tempfile::tempdir().unwrap();
    let target = d.path().join("target");
    std::fs::write(&target, b"keep").unwrap();
    let link = d.path().join("link.json");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let e = write_bytes_atomically(&link, b"x").unwrap_err();
    assert_eq!(e.exit_code(), 2);
    assert!(e.to_string().contains("symbolic link"), "{e}");
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(std::fs::read(&target).unwrap(), b"keep");
}

/// Copies the regular files of `from` (one level) into a new folder `to`.
fn copy_folder(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let p = e.unwrap().path();
        if p.is_file() {
            std::fs::copy(&p, to.join(p.file_name().unwrap())).unwrap();
        }
    }
}

/// Issue 15 item 4: `--out` inside the event folder is not part of the
/// event.  The second run finds the event unchanged (every stage up to
/// date) and reads the same channels (the outputs are not taken for
/// records).
#[test]
fn an_output_directory_inside_the_event_folder_is_not_part_of_the_event() {
    let tmp = tempfile::tempdir().unwrap();
    let ev = tmp.path().join("quake");
    copy_folder(&event("synthetic-4storey-quake"), &ev);
    let out = ev.join("out");
    let p = ingest_pipeline();
    let first = pipeline::run(&p, &ev, &out, true).unwrap();
    assert!(first
        .iter()
        .all(|(_, o)| matches!(o, StageOutcome::Ran { .. })));
    let channels = || {
        let inv: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("event.json")).unwrap()).unwrap();
        (
            inv["channels"].as_array().unwrap().len(),
            inv["files"].as_array().unwrap().len(),
        )
    };
    let before = channels();
    let second = pipeline::run(&p, &ev, &out, true).unwrap();
    assert!(
        second.iter().all(|(_, o)| *o == StageOutcome::Skipped),
        "{second:?}"
    );
    // And the event, loaded again with the outputs beside it, is the same.
    let loaded = quaketwin::event_folder::load(&ev).unwrap();
    assert_eq!(
        (loaded.event.records.len(), loaded.files.len()),
        before,
        "the output folder was read as part of the event"
    );
}

/// Each table in a folder of its own; the flat tables a run made before the
/// folders are still found where a run is read back, and a new run into that
/// directory removes them (no other run's file survives).
#[test]
fn flat_tables_of_an_earlier_layout_are_read_back_and_then_removed() {
    use quaketwin::vocab::tables::{CHANNELS, SAMPLES};
    let out = tempfile::tempdir().unwrap();
    let d = out.path();
    let metrics = format!(
        "{INGEST}[[stage]]\nname = \"metrics\"\nkind = \"metrics\"\ninputs = [\"condition\"]\n"
    );
    let p = parse_pipeline(&metrics, "m.toml").unwrap();
    pipeline::run(&p, &event("synthetic-4storey-quake"), d, true).unwrap();
    assert!(d.join("channels/channels.parquet").is_file());
    assert!(!d.join("channels.parquet").exists());
    // The earlier layout: the tables flat, no manifest listing them.
    let flat = tempfile::tempdir().unwrap();
    let f = flat.path();
    for t in [CHANNELS, SAMPLES] {
        std::fs::copy(d.join(t.file), f.join(t.flat_file())).unwrap();
        assert_eq!(t.locate(f), f.join(t.flat_file()), "{}", t.name);
        assert_eq!(t.locate(d), d.join(t.file), "{}", t.name);
    }
    pipeline::run(&p, &event("synthetic-2storey-yielding"), f, true).unwrap();
    for t in [CHANNELS, SAMPLES] {
        assert!(
            !f.join(t.flat_file()).exists(),
            "{} survived",
            t.flat_file()
        );
        assert!(f.join(t.file).is_file());
    }
    let mut parquet_at_top = std::fs::read_dir(f)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".parquet"));
    assert_eq!(parquet_at_top.next(), None);
}
