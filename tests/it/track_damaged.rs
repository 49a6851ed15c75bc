//! `track` over a damaged archive (issue 33 item 4): a damaged record costs
//! only the windows it overlaps — its span becomes a gap with a note naming
//! the file and byte offset — a half-written last record is skipped with a
//! note, a FIFO day file is refused without blocking, and a day file of
//! gigabytes of zeros (sparse) is read within a memory and time bound.
//!
//! Every archive is written by the project's own synthetic-archive code
//! (`synth::archive::write_archive`) in a temporary directory, short (a few
//! hours, four channels, 50 Hz) to keep the tests fast, then damaged here.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use quaketwin::readers::mseed::StreamCodes;
use quaketwin::readers::sds::day_file;
use quaketwin::sinks::mseed_writer::{RECORD_LEN, SAMPLES_PER_RECORD};
use quaketwin::synth::archive::{write_archive, ArchiveSettings};

const HOURS: usize = 4;
const RATE: f64 = 50.0;

/// A 4-hour archive of four streams (two floors, X and Y) at 50 Hz.
fn archive(dir: &Path) -> (ArchiveSettings, Vec<StreamCodes>) {
    let settings = ArchiveSettings {
        days: 1,
        day_length_s: HOURS as f64 * 3600.0,
        channels: 4,
        rate_hz: RATE,
        seed: 5,
        ..Default::default()
    };
    write_archive(dir, &settings).unwrap();
    let streams = settings.streams().into_iter().map(|(c, _, _)| c).collect();
    (settings, streams)
}

/// Byte offset of the record holding the sample at `minute` after the start.
fn record_at(minute: f64) -> usize {
    let sample = (minute * 60.0 * RATE) as usize;
    sample / SAMPLES_PER_RECORD * RECORD_LEN
}

/// `quaketwin -q --json track ARCHIVE --out OUT` with 30-minute windows,
/// killed (and the test failed) after `limit`.
fn track(dir: &Path, out: &Path, limit: Duration) -> (Output, serde_json::Value) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_quaketwin"))
        .args(["-q", "--json", "track"])
        .arg(dir.join("sds"))
        .arg("--out")
        .arg(out)
        .arg("--stationxml")
        .arg(dir.join("station.xml"))
        .args(["--window", "30m", "--training", "2h", "--cycle", "4h"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let clock = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if clock.elapsed() > limit {
            let _ = child.kill();
            panic!("track still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let o = child.wait_with_output().unwrap();
    let v = serde_json::from_slice(&o.stdout)
        .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&o.stdout)));
    (o, v)
}

/// The `quaketwin.window_notes` of the tracking table: (window start, note).
fn window_notes(out: &Path) -> Vec<(String, String)> {
    use parquet::file::reader::{FileReader, SerializedFileReader};
    let f = std::fs::File::open(out.join("modal_tracking.parquet")).unwrap();
    let r = SerializedFileReader::new(f).unwrap();
    let kv = r.metadata().file_metadata().key_value_metadata().unwrap();
    let text = kv
        .iter()
        .find(|e| e.key == "quaketwin.window_notes")
        .and_then(|e| e.value.clone())
        .unwrap();
    let v: Vec<serde_json::Value> = serde_json::from_str(&text).unwrap();
    v.iter()
        .map(|n| {
            (
                n["window_start"].as_str().unwrap().to_string(),
                n["note"].as_str().unwrap().to_string(),
            )
        })
        .collect()
}

fn flip_bit(path: &Path, byte: usize, bit: u8) {
    let mut b = std::fs::read(path).unwrap();
    b[byte] ^= 1 << bit;
    std::fs::write(path, b).unwrap();
}

/// One damage of each kind, each on its own stream and hour, plus a
/// half-written last record: every window is still identified; the
/// windows the damage overlaps (and only those) carry a note naming the
/// file and the byte offset, in the table metadata, on stderr and in the
/// report; the run exits 0.  Before issue 33 each of these made every
/// window of the day fail and `track` exit 1 ("no reference").
#[test]
fn damaged_records_cost_only_the_windows_they_overlap() {
    let dir = tempfile::tempdir().unwrap();
    let (settings, streams) = archive(dir.path());
    let root = dir.path().join("sds");
    let file = |k: usize| day_file(&root, &streams[k], settings.start_ns);
    // (stream, byte offset expected in the note, window start, what).
    let mut expected: Vec<(PathBuf, usize, &str)> = Vec::new();
    // 1. A truncated record (0:40): its last 1000 bytes cut out, every
    // later record shifted off the 4096-byte grid.
    let at = record_at(40.0);
    let mut b = std::fs::read(file(0)).unwrap();
    b.drain(at + RECORD_LEN - 1000..at + RECORD_LEN);
    std::fs::write(file(0), &b).unwrap();
    expected.push((file(0), at, "2026-01-01T00:30:00"));
    // 2. A zeroed 4 KiB block (1:10): a file-system block lost, one record.
    let at = record_at(70.0);
    let mut b = std::fs::read(file(1)).unwrap();
    b[at..at + 4096].fill(0);
    std::fs::write(file(1), &b).unwrap();
    expected.push((file(1), at, "2026-01-01T01:00:00"));
    // 3. A flipped bit in a record length (blockette 1000's exponent 12 →
    // 13: the record would swallow the next one) (2:10).
    let at = record_at(130.0);
    flip_bit(&file(2), at + 54, 0);
    expected.push((file(2), at, "2026-01-01T02:00:00"));
    // 4. A flipped bit in a sample count (1008 → 33 776) (3:10).
    let at = record_at(190.0);
    flip_bit(&file(3), at + 30, 7);
    expected.push((file(3), at, "2026-01-01T03:00:00"));
    // 5. A half-written last record (stream 1): the file ends 1500 bytes into it.
    let len = std::fs::metadata(file(1)).unwrap().len();
    let last = (len as usize / RECORD_LEN - 1) * RECORD_LEN;
    std::fs::OpenOptions::new()
        .write(true)
        .open(file(1))
        .unwrap()
        .set_len((last + 1500) as u64)
        .unwrap();
    expected.push((file(1), last, "2026-01-01T03:30:00"));

    let out = dir.path().join("track");
    let (o, v) = track(dir.path(), &out, Duration::from_secs(300));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    assert_eq!(v["ok"], true);
    assert_eq!(v["windows"], 2 * HOURS as u64);
    assert_eq!(
        v["identified_windows"],
        2 * HOURS as u64,
        "every window tracked: {}",
        v["skipped"]
    );
    let notes = window_notes(&out);
    let damage: Vec<&(String, String)> = notes
        .iter()
        .filter(|(_, n)| n.starts_with("damaged MiniSEED skipped"))
        .collect();
    for (path, offset, window) in &expected {
        let said = format!("{} byte {offset} (", path.display());
        let hits: Vec<&&(String, String)> =
            damage.iter().filter(|(_, n)| n.contains(&said)).collect();
        assert_eq!(hits.len(), 1, "{said} in one window: {damage:#?}");
        assert!(hits[0].0.starts_with(window), "{said}: {hits:?}");
        assert!(stderr.contains(&said), "{said} on stderr: {stderr}");
    }
    assert_eq!(damage.len(), expected.len(), "{damage:#?}");
    let html = std::fs::read_to_string(out.join("tracking.html")).unwrap();
    assert!(html.contains("Damaged records"));
    for (path, offset, _) in &expected {
        assert!(html.contains(&format!("{} byte {offset} (", path.display())));
    }
    // What each note says.
    let says = |k: usize, what: &str| {
        let n = &damage[k].1;
        assert!(n.contains(what), "{n}");
    };
    let by_offset = |p: &Path, o: usize| {
        damage
            .iter()
            .position(|(_, n)| n.contains(&format!("{} byte {o} (", p.display())))
            .unwrap()
    };
    says(by_offset(&expected[0].0, expected[0].1), "truncated");
    says(by_offset(&expected[1].0, expected[1].1), "zero bytes");
    says(
        by_offset(&expected[2].0, expected[2].1),
        "the file's records have 4096",
    );
    says(
        by_offset(&expected[3].0, expected[3].1),
        "announces 33776 samples",
    );
    says(
        by_offset(&expected[4].0, expected[4].1),
        "still being written",
    );
    // The span of the flipped record: one record of samples, 20.16 s.
    says(
        by_offset(&expected[2].0, expected[2].1),
        "no samples from 2026-01-01T02:09:",
    );
    assert!(v["skipped"].as_array().unwrap().is_empty());
}

/// A FIFO where a day file should be: refused at once (not opened, so
/// nothing blocks), the windows that need it skipped with the reason
/// naming the file, exit 1 as no window is left to take a reference from.
#[test]
fn fifo_day_file_is_refused_without_blocking() {
    let dir = tempfile::tempdir().unwrap();
    let (settings, streams) = archive(dir.path());
    let path = day_file(&dir.path().join("sds"), &streams[0], settings.start_ns);
    std::fs::remove_file(&path).unwrap();
    let made = Command::new("mkfifo").arg(&path).status().unwrap();
    assert!(made.success());
    let out = dir.path().join("track");
    let clock = Instant::now();
    let (o, v) = track(dir.path(), &out, Duration::from_secs(120));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert_eq!(v["ok"], false);
    assert!(
        stderr.contains(&format!("{}: not a regular file", path.display())),
        "{stderr}"
    );
    assert!(v["error"].as_str().unwrap().contains("no reference"), "{v}");
    eprintln!(
        "FIFO day file: exit 1 after {:.1} s",
        clock.elapsed().as_secs_f64()
    );
}
