//! A continuous record is analysed on its event window (issue 33 item 6,
//! `conditioning::event_window`): the window brackets the earthquake, the
//! analyses are those of the same records cut by hand to the window, the
//! records as recorded are written whole, and the spill file stores records
//! of float32 values in four bytes a sample, exactly.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use quaketwin::rng::SplitMix64;
use quaketwin::vocab::{SampleStore, Samples};

use super::common::{column_f64, column_str};

const RATE_HZ: f64 = 50.0;
/// 40 minutes: a continuous record (longer than half an hour).
const RECORD_S: f64 = 2400.0;
/// The earthquake's burst, s.
const QUAKE_S: [f64; 2] = [1500.0, 1530.0];

/// Base and roof in X: microtremor everywhere (1 mm/s²), an earthquake burst
/// (1 m/s² at the base, amplified ×2.5 on a 1.2 Hz roof resonance).
fn continuous_records() -> [Vec<f64>; 2] {
    let n = (RECORD_S * RATE_HZ) as usize;
    let mut rng = SplitMix64::new(33);
    let mut base = Vec::with_capacity(n);
    let mut roof = Vec::with_capacity(n);
    let (mut v, mut x) = (0.0f64, 0.0f64);
    let (w, zeta, dt) = (2.0 * std::f64::consts::PI * 1.2, 0.03, 1.0 / RATE_HZ);
    for i in 0..n {
        let t = i as f64 / RATE_HZ;
        let inside = t >= QUAKE_S[0] && t < QUAKE_S[1];
        let shape = if inside {
            (std::f64::consts::PI * (t - QUAKE_S[0]) / (QUAKE_S[1] - QUAKE_S[0])).sin()
        } else {
            0.0
        };
        let ground = 1e-3 * rng.next_gaussian() + shape * rng.next_gaussian();
        // A damped oscillator driven by the ground (semi-implicit Euler).
        let a = -ground - 2.0 * zeta * w * v - w * w * x;
        v += a * dt;
        x += v * dt;
        base.push(ground);
        roof.push(-w * w * x - 2.0 * zeta * w * v + 1e-3 * rng.next_gaussian());
    }
    [base, roof]
}

/// An event folder of `records` (rows `rows` of them) as one CSV.
fn write_event(dir: &Path, records: &[Vec<f64>; 2], rows: std::ops::Range<usize>) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let mut csv = String::from("time_s,base_x,roof_x\n");
    for (k, i) in rows.enumerate() {
        csv.push_str(&format!(
            "{:.4},{:?},{:?}\n",
            k as f64 / RATE_HZ,
            records[0][i],
            records[1][i]
        ));
    }
    std::fs::write(dir.join("records.csv"), csv).unwrap();
    let toml = r#"[event]
name = "continuous"

[structure]
storey_heights_m = [10.0]

[[channel]]
file = "records.csv"
column = "base_x"
time_column = "time_s"
id = "B-X"
level = 0
direction = "X"
role = "input"
units = "m/s2"

[[channel]]
file = "records.csv"
column = "roof_x"
time_column = "time_s"
id = "R-X"
level = 1
direction = "X"
role = "output"
units = "m/s2"
"#;
    std::fs::write(dir.join("event.toml"), toml).unwrap();
    dir.to_path_buf()
}

fn run_ingest(event: &Path, out: &Path) {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_quaketwin"))
        .args(["--quiet", "run"])
        .arg(root.join("pipelines/ingest.toml"))
        .arg(event)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{}: {}",
        event.display(),
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn a_continuous_record_is_analysed_on_its_event_window() {
    let tmp = tempfile::tempdir().unwrap();
    let records = continuous_records();
    let n = records[0].len();
    let continuous = write_event(&tmp.path().join("continuous"), &records, 0..n);
    let out = tmp.path().join("out");
    run_ingest(&continuous, &out);

    // The window brackets the burst and the roof's free decay after it (a
    // 1.2 Hz, 3 % oscillator falls to 5 % in 13 s), widened by the margin
    // (120 s), no more.
    let event: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("event.json")).unwrap()).unwrap();
    let w = &event["event_window"];
    let pair = |k: &str| [w[k][0].as_f64().unwrap(), w[k][1].as_f64().unwrap()];
    let (strong, window) = (pair("strong_motion_s"), pair("window_s"));
    assert!(
        strong[0] >= QUAKE_S[0] - 1.0 && strong[1] <= QUAKE_S[1] + 15.0,
        "strong motion {strong:?} outside the burst {QUAKE_S:?}"
    );
    assert!(
        strong[1] - strong[0] >= 0.5 * (QUAKE_S[1] - QUAKE_S[0]),
        "strong motion {strong:?} misses most of the burst {QUAKE_S:?}"
    );
    assert_eq!(window, [strong[0] - 120.0, strong[1] + 120.0]);

    // Conditioned records: the window's rows only; as recorded: whole.
    let ids = column_str(&out.join("samples/samples.parquet"), "channel_id");
    let window_rows = ids.iter().filter(|c| *c == "B-X").count();
    let expected = ((window[1] - window[0]) * RATE_HZ).round() as usize;
    assert_eq!(window_rows, expected);
    let recorded = out.join("samples_as_recorded/samples_as_recorded.parquet");
    let recorded_ids = column_str(&recorded, "channel_id");
    assert_eq!(recorded_ids.iter().filter(|c| *c == "B-X").count(), n);
    let values = column_f64(&recorded, "acc_m_s2");
    assert_eq!(&values[..n], &records[0][..], "the base as recorded, whole");

    // The analyses are those of the records cut by hand to the window.
    let start = (window[0] * RATE_HZ).round() as usize;
    let cut = write_event(
        &tmp.path().join("cut"),
        &records,
        start..start + window_rows,
    );
    let cut_out = tmp.path().join("cut-out");
    run_ingest(&cut, &cut_out);
    for column in [
        "pga_m_s2",
        "pgv_m_s",
        "pgd_m",
        "arias_m_s",
        "d5_95_s",
        "cav_m_s",
    ] {
        assert_eq!(
            column_f64(&out.join("channels/channels.parquet"), column),
            column_f64(&cut_out.join("channels/channels.parquet"), column),
            "{column}"
        );
    }
    assert_eq!(
        column_f64(&out.join("spectra/spectra.parquet"), "psa_m_s2"),
        column_f64(&cut_out.join("spectra/spectra.parquet"), "psa_m_s2")
    );
    // The burst's peak, not a day's taper of it.
    let pga = column_f64(&out.join("channels/channels.parquet"), "pga_m_s2");
    assert!(pga[0] > 1.0, "base PGA {} of a 1 m/s² burst", pga[0]);

    // A re-run skips every stage and leaves every output as it was.
    let before = std::fs::read(out.join("channels/channels.parquet")).unwrap();
    run_ingest(&continuous, &out);
    assert_eq!(
        std::fs::read(out.join("channels/channels.parquet")).unwrap(),
        before
    );
}

/// A spill file for the tests (the run's own, in a temporary directory).
fn spill(dir: &Path) -> Arc<dyn SampleStore> {
    quaketwin::pipeline::spill::SpillFile::create(dir).unwrap()
}

#[test]
fn parked_float32_values_take_four_bytes_and_read_back_exactly() {
    let tmp = tempfile::tempdir().unwrap();
    let store = spill(tmp.path());
    let mut rng = SplitMix64::new(7);
    let single: Vec<f64> = (0..1000)
        .map(|_| rng.next_gaussian() as f32 as f64)
        .chain([0.0, -0.0, f32::MAX as f64, f32::MIN_POSITIVE as f64])
        .collect();
    let double: Vec<f64> = (0..1000).map(|_| rng.next_gaussian()).collect();
    let mut a = Samples::new(single.clone());
    let mut b = Samples::new(double.clone());
    a.park(&store).unwrap();
    b.park(&store).unwrap();
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&a.get().unwrap()), bits(&single));
    assert_eq!(bits(&b.get().unwrap()), bits(&double));
    // Windows and scaled views read the same stored values.
    assert_eq!(
        bits(&a.window(10..20).get().unwrap()),
        bits(&single[10..20])
    );
    let scaled: Vec<f64> = double[5..9].iter().map(|x| x * 9.80665).collect();
    assert_eq!(
        bits(&b.window(5..9).scaled(9.80665).get().unwrap()),
        bits(&scaled)
    );
    // The float32 series took 4 bytes a sample, the other 8: the next put
    // lands at 4 × 1004 + 8 × 1000 bytes.
    let position = store.put(&[0.5]).unwrap() & !(1 << 63);
    assert_eq!(position, 4 * 1004 + 8 * 1000);
}
