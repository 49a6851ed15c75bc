//! Issue 13 must-show, real-data consistency: the same bridge recorded in
//! several small earthquakes shows the same transverse mode with the shipped
//! defaults (`quaketwin modal EVENT`: the ingest pipeline's conditioning and
//! the modal stage's defaults, nothing tuned per record).
//!
//! Records: `../shared/records/cesmd-bridges-corpus/` (CSMIP zips, never
//! copied into the repository).  "Small" = peak horizontal deck acceleration
//! (conditioned, `pga_m_s2` of the output channels in channels/channels.parquet)
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
//! Not covered here (see the issue-13 note): the longitudinal modes.  Each
//! bridge has one longitudinal deck channel, so a longitudinal mode's shape
//! cannot be checked for coherence; identified on that channel alone, the
//! poles of every event are a different scatter (docs/real-records).

use crate::common::{column_f64, column_str, shared_record};
use quaketwin::modal::global::{dominant_channel, LOCAL_ENERGY_SHARE};
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
    let channels = out.join("channels/channels.parquet");
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
    let modes_of = |r: &EventRun| read_modes(&r.out.join("modes/modes.parquet")).unwrap();
    for r in &runs {
        if !r.out.join("modes/modes.parquet").exists() {
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
    // Issue 31 item 4: no structural mode lives on one channel, and the
    // bridge's modes near its transverse frequency carry one label in
    // every event (checked over all its events, small or strong).
    let mut labels_near_transverse: Vec<(String, f64, String)> = Vec::new();
    for r in runs
        .iter()
        .filter(|r| r.out.join("modes/modes.parquet").exists())
    {
        let (modes, channels) = modes_of(r);
        for m in &modes {
            let (k, share) = dominant_channel(&m.shape).expect("a mode has a shape");
            assert!(
                share <= LOCAL_ENERGY_SHARE,
                "{folder} {}: mode {:.3} Hz holds {:.1} % of its shape's energy on channel {} alone: a local mode reported as structural",
                r.name,
                m.frequency_hz,
                100.0 * share,
                channels[k]
            );
            labels_near_transverse.push((r.name.clone(), m.frequency_hz, m.direction.clone()));
        }
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
    for (name, f, direction) in &labels_near_transverse {
        if (f / f_ref - 1.0).abs() <= 0.05 {
            assert_eq!(
                direction, "Y",
                "{folder} {name}: mode {f:.3} Hz, within 5 % of the transverse {f_ref:.3} Hz, is labelled {direction}"
            );
        }
    }
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
/// (0.022 and 0.062 g).  Input–output identification with the centre bent's
/// ground sensors selects nothing (scattered low-MPC poles: one bent's
/// ground motion is not the input of a deck driven at its abutments too);
/// `auto` then falls back to output-only SSI-COV, whose transverse mode is a
/// resonance (response ≈ 4.4–4.6 × the ground motion at it): 5.24 and
/// 5.51 Hz.
#[test]
fn shared_lake_crowley_small_events_agree_on_the_transverse_mode() {
    check_transverse_consistency("crowley-ce54730", 2);
}

/// The Painter St. records of the 1980s give only azimuths (transverse 360°,
/// longitudinal 270°).  Their location texts name the east and west
/// abutments, so the deck runs east–west and X is the 270° line, as CSMIP's
/// Long = X / Tran = Y of the later records: the transverse deck channel is
/// Y and the transverse mode is labelled Y in every event.
#[test]
fn shared_painter_street_azimuth_records_take_the_bridge_axes() {
    let zip =
        shared_record("cesmd-bridges-corpus/painter-st-ce89324/eureka_24aug1983_ce89324p.zip");
    let loaded = quaketwin::event_folder::load(&zip).unwrap();
    let event = &loaded.event;
    let direction_of = |text: &str| -> Vec<String> {
        event
            .records
            .iter()
            .filter(|r| {
                r.channel
                    .location_text
                    .as_deref()
                    .is_some_and(|t| t.to_ascii_uppercase().contains(text))
            })
            .filter_map(|r| r.channel.direction.map(|d| d.to_string()))
            .collect()
    };
    let deck = direction_of("DECK, NEAR EAST ABUTMENT");
    assert!(
        deck.contains(&"X".to_string()) && deck.contains(&"Y".to_string()),
        "east-abutment deck channels: {deck:?}"
    );
    assert!(
        event
            .notes
            .iter()
            .any(|n| n.contains("abutments") && n.contains("east–west")),
        "notes: {:?}",
        event.notes
    );
    // The transverse (originally 360°) deck channel is now Y.
    let history = serde_json::to_string(&event.history).unwrap();
    assert!(
        history.contains(r#""from":"0deg","to":"Y""#)
            || history.contains(r#""from":"360deg","to":"Y""#),
        "building_axes actions: {history}"
    );
    let tmp = tempfile::tempdir().unwrap();
    let run = modal_run(&zip, tmp.path());
    let (modes, _) = read_modes(&run.out.join("modes/modes.parquet")).unwrap();
    assert!(!modes.is_empty(), "no mode in {}", run.name);
    assert_eq!(
        modes[0].direction, "Y",
        "lowest mode of {}: {:?}",
        run.name, modes[0]
    );
}

/// The output-only fallback keeps only resonances: on the 1980 Trinidad
/// record (two deck channels) input–output finds no mode, and output-only
/// SSI-COV's candidates (1.12, 1.66, 3.65 Hz) are all peaks of the ground
/// motion (response at most 1.9 × the ground motion): no mode, and a
/// warning that says so.
#[test]
fn shared_output_only_fallback_rejects_ground_motion_peaks() {
    let zip = shared_record(
        "cesmd-bridges-corpus/painter-st-ce89324/trinidad-offshore_08nov1980_ce89324p.zip",
    );
    let tmp = tempfile::tempdir().unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_quaketwin"))
        .arg("modal")
        .arg(&zip)
        .arg("--out")
        .arg(tmp.path())
        .arg("--quiet")
        .output()
        .unwrap();
    assert!(out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("peaks the ground motion brings") && stderr.contains("× the ground motion"),
        "{stderr}"
    );
    let (modes, _) = read_modes(&tmp.path().join("modes/modes.parquet")).unwrap();
    assert!(modes.is_empty(), "{modes:?}");
}
