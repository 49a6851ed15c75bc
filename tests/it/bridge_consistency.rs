//! Issue 13 must-show, real-data consistency: the same bridge recorded in
//! several small earthquakes shows the same transverse mode with the shipped
//! defaults (`quaketwin modal EVENT`: the ingest pipeline's conditioning and
//! the modal stage's defaults, nothing tuned per record).
//!
//! Records: `../shared/records/cesmd-bridges-corpus/` (CSMIP zips, never
//! copied into the repository).  "Small" = peak horizontal deck acceleration
//! (conditioned, `pga_m_s2` of the output channels in channels.parquet)
//! below 0.1 g: stronger shaking softens the soil and the abutments
//! (the Painter St. transverse mode falls from 4.4 Hz at 0.03 g to about
//! 4.0 Hz at 0.25–0.4 g), which is physics, not inconsistency.
//!
//! The transverse mode of a bridge is the lowest mode labelled `Y` (CSMIP's
//! `Tran` channels map to Y, `Long` to X) of its smallest event; in every
//! other small event it must be paired by the product's own pre/post pairing
//! (`modal::compare_events`: MAC ≥ 0.8 on the shared channels within a 20 %
//! window) with a mode labelled Y whose frequency is within 10 % of it.
//! Pairing by shape rather than "the lowest Y mode of each event" because a
//! small event may show an extra, differently shaped mode below it (Painter
//! St. nc73667866: 3.42 Hz dominated by the west abutment, besides 4.39 Hz).
//!
//! Not covered here (see the issue-13 note): the longitudinal modes (one
//! longitudinal deck channel on Painter St.; no consistent column yet) and
//! the Lake Crowley bridge, whose two small events give no mode with the
//! defaults (`shared_lake_crowley_small_events_show_a_mode`, ignored).

use crate::common::{column_f64, column_str, shared_record};
use quaketwin::modal::{compare_events, ModeSet, PairingSettings};
use quaketwin::sinks::modal_tables::read_modes;
use std::path::{Path, PathBuf};

const G: f64 = 9.80665;
const SMALL_PEAK_G: f64 = 0.1;

struct EventRun {
    name: String,
    out: PathBuf,
    peak_g: f64,
}

/// `quaketwin modal ZIP --out DIR` with the defaults; the peak horizontal
/// acceleration of the response (output) channels.
fn modal_run(zip: &Path, out: &Path) -> EventRun {
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_quaketwin"))
        .arg("modal")
        .arg(zip)
        .arg("--out")
        .arg(out)
        .arg("--quiet")
        .output()
        .expect("quaketwin runs");
    assert!(
        status.status.success(),
        "{}: {}",
        zip.display(),
        String::from_utf8_lossy(&status.stderr)
    );
    let channels = out.join("channels.parquet");
    let roles = column_str(&channels, "role");
    let directions = column_str(&channels, "direction");
    let pga = column_f64(&channels, "pga_m_s2");
    let peak = (0..roles.len())
        .filter(|&i| roles[i] == "output" && (directions[i] == "X" || directions[i] == "Y"))
        .map(|i| pga[i])
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max);
    EventRun {
        name: zip.file_name().unwrap().to_string_lossy().into_owned(),
        out: out.to_path_buf(),
        peak_g: peak / G,
    }
}

/// Runs every event of `folder` (two at a time: the CI machine has 2 cores).
fn run_bridge(folder: &str, tmp: &Path) -> Vec<EventRun> {
    let dir = shared_record(&format!("cesmd-bridges-corpus/{folder}"));
    let mut zips: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("zip")))
        .collect();
    zips.sort();
    let mut runs: Vec<EventRun> = Vec::new();
    for pair in zips.chunks(2) {
        std::thread::scope(|s| {
            let handles: Vec<_> = pair
                .iter()
                .map(|z| {
                    let out = tmp.join(z.file_name().unwrap());
                    s.spawn(move || modal_run(z, &out))
                })
                .collect();
            runs.extend(handles.into_iter().map(|h| h.join().unwrap()));
        });
    }
    runs
}

/// The table of the note (issue 13): every event, its peak and its Y modes;
/// then the consistency check over the small events.
fn check_transverse_consistency(folder: &str, expected_small: usize) {
    let tmp = tempfile::tempdir().unwrap();
    let mut runs = run_bridge(folder, tmp.path());
    runs.sort_by(|a, b| a.peak_g.total_cmp(&b.peak_g));
    let modes_of = |r: &EventRun| read_modes(&r.out.join("modes.parquet")).unwrap();
    for r in &runs {
        if !r.out.join("modes.parquet").exists() {
            // petrolia91: three free-field channels, no response channel.
            eprintln!(
                "{folder} {:<45} no response channel: modal stage not applicable",
                r.name
            );
            continue;
        }
        let (modes, _) = modes_of(r);
        let list: Vec<String> = modes
            .iter()
            .map(|m| {
                format!(
                    "{:.3} Hz {} (ζ {:.1} %)",
                    m.frequency_hz,
                    m.direction,
                    100.0 * m.damping_ratio
                )
            })
            .collect();
        eprintln!(
            "{folder} {:<45} peak {:.3} g: {}",
            r.name,
            r.peak_g,
            list.join(", ")
        );
    }
    let small: Vec<&EventRun> = runs
        .iter()
        .filter(|r| r.peak_g > 0.0 && r.peak_g < SMALL_PEAK_G)
        .collect();
    assert_eq!(
        small.len(),
        expected_small,
        "{folder}: small events {:?}",
        small
            .iter()
            .map(|r| (&r.name, r.peak_g))
            .collect::<Vec<_>>()
    );
    let reference = small[0];
    let (ref_modes, ref_channels) = modes_of(reference);
    let transverse = ref_modes
        .iter()
        .position(|m| m.direction == "Y")
        .unwrap_or_else(|| {
            panic!(
                "{folder}: no transverse (Y) mode in the smallest event {}: {:?}",
                reference.name,
                ref_modes
                    .iter()
                    .map(|m| (m.frequency_hz, &m.direction))
                    .collect::<Vec<_>>()
            )
        });
    let f_ref = ref_modes[transverse].frequency_hz;
    for r in &small[1..] {
        let (modes, channels) = modes_of(r);
        let comparison = compare_events(
            ModeSet {
                modes: &ref_modes,
                channels: &ref_channels,
            },
            ModeSet {
                modes: &modes,
                channels: &channels,
            },
            &PairingSettings::default(),
        );
        let pair = comparison
            .shifts
            .iter()
            .find(|s| s.reference_mode == transverse)
            .unwrap_or_else(|| {
                panic!(
                    "{folder}: the transverse mode {f_ref:.3} Hz of {} is not found in {} (modes {:?}; notes {:?})",
                    reference.name,
                    r.name,
                    modes.iter().map(|m| (m.frequency_hz, &m.direction)).collect::<Vec<_>>(),
                    comparison.notes
                )
            });
        eprintln!(
            "{folder}: {} transverse {:.3} Hz vs {:.3} Hz in {}: {:+.1} % (MAC {:?})",
            r.name, pair.frequency_current_hz, f_ref, reference.name, pair.shift_percent, pair.mac
        );
        assert_eq!(
            pair.direction_current, "Y",
            "{}: paired mode is not transverse",
            r.name
        );
        assert!(
            pair.shift_percent.abs() <= 10.0,
            "{folder}: {} transverse {:.3} Hz differs from {:.3} Hz by {:.1} %",
            r.name,
            pair.frequency_current_hz,
            f_ref,
            pair.shift_percent
        );
    }
}

/// Rio Dell – Painter St. overpass (CSMIP 89324): 12 events 1980–2016; four
/// modern ones below 0.1 g.  Measured with the defaults: 4.23–4.39 Hz.
#[test]
fn shared_painter_street_small_events_agree_on_the_transverse_mode() {
    check_transverse_consistency("painter-st-ce89324", 4);
}

/// Ridgecrest – Hwy 395/Brown Rd. bridge (CSMIP 33742): 3 events 2019–2020,
/// two below 0.1 g (3.46 and 3.25 Hz; the 0.27-g event gives 3.07 Hz).
#[test]
fn shared_ridgecrest_small_events_agree_on_the_transverse_mode() {
    check_transverse_consistency("ridgecrest-ce33742", 2);
}

/// Lake Crowley – Hwy 395 bridge (CSMIP 54730): both events are small
/// (0.022 and 0.062 g) and the defaults select no mode in either (scattered
/// low-MPC poles at 6–6.5 Hz; output-only SSI gives 5.2–5.6 Hz, unstable).
/// Kept as the open case of issue 13: run with `--ignored` to see it fail.
#[test]
#[ignore]
fn shared_lake_crowley_small_events_show_a_mode() {
    check_transverse_consistency("crowley-ce54730", 2);
}
