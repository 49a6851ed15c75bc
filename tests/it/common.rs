//! Helpers shared by the integration-test modules.

use std::path::PathBuf;

/// `../shared/records` beside the repository (real public records, never
/// copied into it).  Panics with a clear message when the folder is missing,
/// so a test that needs real data never passes silently without it.
pub fn shared_records() -> PathBuf {
    let p = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/records"));
    assert!(
        p.is_dir(),
        "this test reads real records from {} (the shared folder beside the repository); it is missing",
        p.display()
    );
    p
}

/// Runs `pipelines/<pipeline>` on `sample-records/<event>` into `out` with
/// the CLI binary (so the process-wide settings of `main` apply), with the
/// environment variables `env`; panics with the run's stderr when it fails.
pub fn run_sample_pipeline(
    pipeline: &str,
    event: &str,
    out: &std::path::Path,
    env: &[(&str, &str)],
) {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_quaketwin"))
        .arg("--quiet")
        .arg("run")
        .arg(root.join("pipelines").join(pipeline))
        .arg(root.join("sample-records").join(event))
        .arg("--out")
        .arg(out)
        .envs(env.iter().copied())
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{pipeline} on {event} with {env:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// The CLI binary run with `args` (its output captured).
pub fn quaketwin(args: &[&std::ffi::OsStr]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_quaketwin"))
        .args(args)
        .output()
        .unwrap()
}

/// Any path or string as a command-line argument.
pub fn os<P: AsRef<std::ffi::OsStr> + ?Sized>(p: &P) -> &std::ffi::OsStr {
    p.as_ref()
}

/// The files of an output directory and of its tables' folders
/// (`modes/modes.parquet`), sorted, without its lock.
pub fn output_files(dir: &std::path::Path) -> Vec<String> {
    let mut names = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let e = e.unwrap();
        let name = e.file_name().to_string_lossy().into_owned();
        if e.file_type().unwrap().is_dir() {
            for f in std::fs::read_dir(e.path()).unwrap() {
                names.push(format!(
                    "{name}/{}",
                    f.unwrap().file_name().to_string_lossy()
                ));
            }
        } else if name != ".quaketwin.lock" {
            names.push(name);
        }
    }
    names.sort();
    names
}

/// A file or folder under `../shared/records`, checked to exist.
pub fn shared_record(rel: &str) -> PathBuf {
    let p = shared_records().join(rel);
    assert!(p.exists(), "real record {} is missing", p.display());
    p
}

/// An acceleration record (m/s²) along building X at `level`: the base (level 0) is the
/// input, every floor an output.  The shared fixture of the hysteresis tests.
pub fn x_record(
    id: &str,
    level: i32,
    rate_hz: f64,
    file: &str,
    samples: Vec<f64>,
) -> quaketwin::vocab::Record {
    use quaketwin::vocab::{Axis, Channel, Direction, Record, Role, SourceRef, Units};
    let mut c = Channel::new(
        id,
        Units::MPerS2,
        rate_hz,
        SourceRef {
            file: file.into(),
            ..SourceRef::default()
        },
    );
    c.level = Some(level);
    c.direction = Some(Direction::Axis(Axis::X));
    c.role = if level == 0 {
        Role::Input
    } else {
        Role::Output
    };
    Record::new(c, samples)
}

fn batches(path: &std::path::Path) -> Vec<arrow_array::RecordBatch> {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(file)
        .unwrap()
        .build()
        .unwrap()
        .map(|b| b.unwrap())
        .collect()
}

/// A Float64 column of a Parquet file, all row groups (nulls as NaN).
pub fn column_f64(path: &std::path::Path, name: &str) -> Vec<f64> {
    use arrow_array::Array;
    let mut out = Vec::new();
    for b in batches(path) {
        let col = b
            .column_by_name(name)
            .unwrap_or_else(|| panic!("{}: no column {name}", path.display()));
        let a = col
            .as_any()
            .downcast_ref::<arrow_array::Float64Array>()
            .unwrap_or_else(|| panic!("{}: {name} is not Float64", path.display()));
        out.extend((0..a.len()).map(|i| if a.is_null(i) { f64::NAN } else { a.value(i) }));
    }
    out
}

/// An integer column (Int32 or Int64) of a Parquet file, all row groups
/// (nulls as `i64::MIN`).
pub fn column_i64(path: &std::path::Path, name: &str) -> Vec<i64> {
    use arrow_array::Array;
    let mut out = Vec::new();
    for b in batches(path) {
        let col = b
            .column_by_name(name)
            .unwrap_or_else(|| panic!("{}: no column {name}", path.display()));
        if let Some(a) = col.as_any().downcast_ref::<arrow_array::Int32Array>() {
            out.extend((0..a.len()).map(|i| {
                if a.is_null(i) {
                    i64::MIN
                } else {
                    a.value(i) as i64
                }
            }));
        } else if let Some(a) = col.as_any().downcast_ref::<arrow_array::Int64Array>() {
            out.extend((0..a.len()).map(|i| if a.is_null(i) { i64::MIN } else { a.value(i) }));
        } else {
            panic!("{}: {name} is not an integer column", path.display());
        }
    }
    out
}

/// A Utf8 column of a Parquet file, all row groups (nulls as "").
pub fn column_str(path: &std::path::Path, name: &str) -> Vec<String> {
    use arrow_array::Array;
    let mut out = Vec::new();
    for b in batches(path) {
        let col = b
            .column_by_name(name)
            .unwrap_or_else(|| panic!("{}: no column {name}", path.display()));
        let a = col
            .as_any()
            .downcast_ref::<arrow_array::StringArray>()
            .unwrap_or_else(|| panic!("{}: {name} is not Utf8", path.display()));
        out.extend((0..a.len()).map(|i| a.value(i).to_string()));
    }
    out
}

/// A USGS SMC file in the published layout (11 text lines, 48 integers in
/// 8I10, 50 reals in 5E15.7, one `|` comment line, then `data_lines`).
/// `label` is line 1, `line4` the event line (date and `hhmm`), `station`
/// the 4-character station code, `component` the orientation text;
/// `ints` patches integer fields (0-based) over the defaults (missing code
/// -32768; start 2020, day 2, 03:04:05; orientation 360; 1 comment line;
/// `npts` samples); `rate` None leaves the sampling rate at the SMC missing
/// sentinel 1.7E+38.
#[allow(clippy::too_many_arguments)]
pub fn smc_file(
    label: &str,
    line4: &str,
    station: &str,
    component: &str,
    ints: &[(usize, i64)],
    npts: usize,
    rate: Option<f64>,
    data_lines: &[String],
) -> String {
    let mut s = String::new();
    s.push_str(&format!(
        "{label}\n*\n{station}A\n{line4}\nMoment Mag=      5.0\n"
    ));
    s.push_str(&format!(
        "station = Test site component=    {component}\nepicentral dist =  1.0\ninst type=X\n*\n*\n*\n"
    ));
    let miss = -32768i64;
    let mut header = vec![miss; 48];
    header[1] = 2020;
    header[2] = 2;
    header[3] = 3;
    header[4] = 4;
    header[5] = 5;
    header[13] = 360;
    header[15] = 1;
    header[16] = npts as i64;
    for &(k, v) in ints {
        header[k] = v;
    }
    for row in header.chunks(8) {
        s.push_str(&row.iter().map(|v| format!("{v:10}")).collect::<String>());
        s.push('\n');
    }
    let mut reals = vec![1.7e38; 50];
    if let Some(r) = rate {
        reals[1] = r;
    }
    for row in reals.chunks(5) {
        s.push_str(&row.iter().map(|v| format!("{v:15.7E}")).collect::<String>());
        s.push('\n');
    }
    s.push_str("| a comment\n");
    for l in data_lines {
        s.push_str(l);
        s.push('\n');
    }
    s
}

/// Values in the SMC data layout (8 fields of E10.4 per line).
pub fn fixed_e10(values: &[f64]) -> Vec<String> {
    values
        .chunks(8)
        .map(|c| c.iter().map(|v| format!("{v:10.4E}")).collect())
        .collect()
}

/// A mode of a modal table with a real shape (largest component as given),
/// for tests of the pairing: frequency `f`, its standard deviation `sd`,
/// damping 2 %, direction label `direction`.
pub fn test_mode(f: f64, sd: f64, direction: &str, shape: &[f64]) -> quaketwin::modal::Mode {
    quaketwin::modal::Mode {
        frequency_hz: f,
        frequency_std_hz: sd,
        damping_ratio: 0.02,
        damping_std: 0.001,
        shape: shape.iter().map(|&x| faer::c64::new(x, 0.0)).collect(),
        shape_std: vec![0.0; shape.len()],
        mpc: 1.0,
        mpd_deg: 0.0,
        mean_mac: 1.0,
        pole_count: 10,
        order_min: 10,
        order_max: 40,
        manual: false,
        direction: direction.into(),
        data_std: None,
    }
}

/// Writes a seeded synthetic quake of `buildings` (the sample 4-storey frame's
/// event, `quaketwin::synth::event`) into `dir`, without the `omit` channels.
pub fn write_sample_quake(
    dir: &std::path::Path,
    buildings: &[(&str, quaketwin::synth::ShearBuilding)],
    seed: u64,
    omit: &[&str],
) {
    use quaketwin::synth::event::{write_quake_event, QuakeEvent, SynthSettings};
    let settings = SynthSettings {
        seed,
        ..Default::default()
    };
    let ev = QuakeEvent {
        name: &format!("synthetic quake {seed}"),
        origin_time: "2026-03-01T00:00:00Z",
        structure: "Sample 4-storey frame",
        storey_heights_m: &quaketwin::synth::event::STOREY_HEIGHTS_M,
        buildings,
        omit_channels: omit,
        twin_toml: None,
    };
    write_quake_event(dir, &ev, &settings, &mut quaketwin::rng::Rng::new(seed)).unwrap();
}
