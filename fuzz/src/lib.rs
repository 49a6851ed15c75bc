//! What the cargo-fuzz targets feed their input to, and what every input
//! must give: the properties of the seeded mutation fuzzing in
//! `tests/it/fuzz.rs`.
//!
//! - no panic (libFuzzer reports a panic as a crash);
//! - `Ok`, or an error that names the file (or a file of the folder it
//!   belongs to) with the documented exit code: 1 for bad data, 2 for a bad
//!   pipeline file (docs/cli.md);
//! - bounded memory and time: libFuzzer's `-malloc_limit_mb`,
//!   `-rss_limit_mb` and `-timeout` (`scripts/fuzz.sh`).
//!
//! The event-folder targets need `fuzz/events/small-quake/`, written with the
//! seed corpus by `scripts/fuzz-corpus.sh`.  Inputs that must be files
//! (manifests, zips, design files) are written to a scratch folder under
//! the temporary directory, one per process.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use quaketwin::design::file::load_design;
use quaketwin::design::motion::design_inputs;
use quaketwin::event_folder;
use quaketwin::readers::{self, stationxml, Format, ReadOptions};
use quaketwin::vocab::{Event, SourceRef};
use quaketwin::Result;

/// Exit code of bad data.
const DATA: i32 = 1;
/// Exit code of a bad pipeline file.
const USAGE: i32 = 2;

/// Fails the input unless `result` is `Ok` or an error with exit code `code`
/// whose text names one of `names`.
fn check(result: Result<()>, code: i32, names: &[String]) {
    let Err(e) = result else { return };
    let message = e.to_string();
    assert_eq!(e.exit_code(), code, "exit code for: {message}");
    assert!(
        names.iter().any(|n| message.contains(n.as_str())),
        "error does not name the file ({names:?}): {message}"
    );
}

fn source(name: &str) -> SourceRef {
    SourceRef {
        file: name.to_string(),
        ..Default::default()
    }
}

/// Sniffing and one reader on the bytes of a file called `name`.
pub fn reader(format: Format, name: &str, data: &[u8]) {
    reader_with(format, name, data, &ReadOptions::default());
}

fn reader_with(format: Format, name: &str, data: &[u8], opts: &ReadOptions) {
    let _ = readers::classify(name, data);
    let read = readers::read(format, data, &source(name), opts).map(|_| ());
    check(read, DATA, &[name.to_string()]);
}

/// The CSV reader as sniffed, and with a time column and two columns
/// chosen (the manifest's `time_column` and `columns`: resampling).
pub fn csv(data: &[u8]) {
    reader(Format::Csv, "floors.csv", data);
    let opts = ReadOptions {
        time_column: Some("time_s".into()),
        columns: Some(vec!["acc_L1_X".into(), "acc_L4_Y".into()]),
        ..Default::default()
    };
    reader_with(Format::Csv, "floors.csv", data, &opts);
}

/// StationXML metadata.
pub fn stationxml(data: &[u8]) {
    let name = "NP.8040.xml";
    let parsed = stationxml::parse(data, &source(name)).map(|_| ());
    check(parsed, DATA, &[name.to_string()]);
}

/// The event folder loader on a copy of `folder` whose `event.toml` is
/// the input.
pub fn manifest(folder: &Path, data: &[u8]) {
    let dir = scratch_copy(folder);
    std::fs::write(dir.join("event.toml"), data).unwrap();
    let loaded = event_folder::load(&dir).map(|_| ());
    check(loaded, DATA, &file_names(folder));
}

/// The event folder loader on a zipped event.
pub fn event_zip(data: &[u8]) {
    let zip = scratch().join("quake.zip");
    std::fs::write(&zip, data).unwrap();
    let loaded = event_folder::load(&zip).map(|_| ());
    check(loaded, DATA, &["quake.zip".to_string()]);
}

/// A twin file parsed and assembled (matrix files resolved in an empty
/// folder).
pub fn twin(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    let base = scratch().join("twin-base");
    std::fs::create_dir_all(&base).unwrap();
    let built = quaketwin::twin::file::parse_twin(&text, "twin.toml", &base).map(|_| ());
    check(built, DATA, &["twin.toml".to_string()]);
}

/// A design file beside the facade's twin, loaded, and its base motion and
/// recorded response taken from the facade event (as read).
pub fn design(data: &[u8]) {
    let facade = facade_folder();
    let dir = scratch_copy(&facade);
    let path = dir.join("design.toml");
    std::fs::write(&path, data).unwrap();
    let designed = load_design(&path)
        .and_then(|design| design_inputs(&design, Some((facade_event(), "facade"))).map(|_| ()));
    check(designed, DATA, &file_names(&facade));
}

/// A pipeline file built with this build's stage kinds (a bad one is a
/// usage error).
pub fn pipeline(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    let built = quaketwin::stages::parse_pipeline(&text, "pipeline.toml").map(|_| ());
    check(built, USAGE, &["pipeline.toml".to_string()]);
}

// ---------------------------------------------------------------------------
// Folders.

fn fuzz_dir() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The small sample quake (records cut to 400 samples) the corpus script
/// writes.
pub fn small_quake() -> PathBuf {
    let dir = fuzz_dir().join("events/small-quake");
    assert!(
        dir.join("event.toml").is_file(),
        "{} is missing: run scripts/fuzz-corpus.sh first",
        dir.display()
    );
    dir
}

pub fn facade_folder() -> PathBuf {
    fuzz_dir().join("../sample-records/synthetic-facade")
}

/// The sample facade event as read (loaded once).
fn facade_event() -> &'static Event {
    static EVENT: OnceLock<Event> = OnceLock::new();
    EVENT.get_or_init(|| event_folder::load(&facade_folder()).unwrap().event)
}

/// This process's scratch folder (under the temporary directory:
/// `scripts/fuzz.sh` points `TMPDIR` at a folder it removes).
fn scratch() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("quaketwin-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    })
}

/// A copy of `folder` in the scratch folder (made on first use; the input
/// overwrites one of its files each time).
fn scratch_copy(folder: &Path) -> PathBuf {
    let dir = scratch().join(folder.file_name().unwrap());
    if !dir.exists() {
        std::fs::create_dir_all(&dir).unwrap();
        for e in std::fs::read_dir(folder).unwrap() {
            let e = e.unwrap();
            std::fs::copy(e.path(), dir.join(e.file_name())).unwrap();
        }
    }
    dir
}

/// Names an error about a file of `folder` may give instead of the input's
/// (the twin a design names, the records a manifest lists).
fn file_names(folder: &Path) -> Vec<String> {
    std::fs::read_dir(folder)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect()
}
