//! The subspace χ² change test in the assessment (docs/assessment.md, "The
//! subspace change test"; docs/statistics.md Eq. C4'): the indicator's rule,
//! and what the `modal` stage's test gives on event records — the sample
//! 4-storey frame's 40-s synthetic quakes and two real earthquakes of the
//! Painter Street overpass: their response lies in too few blocks for the
//! test, so no test is made and the indicator says why (before Eq. C4' the
//! real pair was a false "change", a YELLOW on the test alone).

use std::path::Path;

use quaketwin::assessment::change_test::{change_test_indicator, ChangeTestEvidence};
use quaketwin::assessment::DamageState;
use quaketwin::report::table::{load, Table};
use quaketwin::synth::event::sample_building;
use quaketwin::vocab::tables::{assessment as a, ASSESSMENT, CHANGE_TEST};

/// Storey-1 stiffness of the X direction in the second synthetic event.
const RETAINED_K1_X: f64 = 0.7;

const PIPELINE: &str = r#"
[pipeline]
name = "modal-assess"
[[stage]]
name = "ingest"
kind = "ingest"
[[stage]]
name = "condition"
kind = "condition"
inputs = ["ingest"]
[[stage]]
name = "modal"
kind = "modal"
inputs = ["condition"]
[[stage]]
name = "as-recorded"
kind = "condition"
inputs = ["ingest"]
[stage.params]
steps = []
samples_file = "samples_as_recorded.parquet"
[[stage]]
name = "assess"
kind = "assess"
inputs = ["as-recorded"]
"#;

fn write_event(dir: &Path, retained_k1_x: f64, seed: u64) {
    let mut buildings = sample_building();
    buildings[0].1.storey_stiffness_n_per_m[0] *= retained_k1_x;
    crate::common::write_sample_quake(dir, &buildings, seed, &[]);
}

fn run(pipeline: &Path, event: &Path, out: &Path, reference: Option<&Path>) {
    let mut args: Vec<&std::ffi::OsStr> = vec![
        "run".as_ref(),
        pipeline.as_os_str(),
        event.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
        "--quiet".as_ref(),
    ];
    if let Some(r) = reference {
        args.extend(["--reference".as_ref(), r.as_os_str()]);
    }
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_quaketwin"))
        .args(&args)
        .output()
        .unwrap();
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

fn text(t: &Table, c: &str) -> Option<String> {
    t.key(c, 0)
}
fn num(t: &Table, c: &str) -> Option<f64> {
    t.number(c).and_then(|v| v[0])
}

/// The rule: a detected change is slight and no more, no change is none, a
/// test that could not be made is not rated and says why.
#[test]
fn change_test_indicator_rule() {
    let tested = |changed: bool, statistic: f64| ChangeTestEvidence::Tested {
        statistic,
        threshold: 58.6,
        p_value: if changed { 1e-6 } else { 0.4 },
        false_alarm_rate: 0.01,
        changed,
        leading_mode: Some((2.0, 0.8 * statistic)),
    };
    let detected = change_test_indicator(&tested(true, 940.0));
    assert_eq!(detected.state, Some(DamageState::Slight));
    assert!((detected.value.unwrap() - 940.0 / 58.6).abs() < 1e-12);
    assert!(
        detected.verdict.starts_with("change detected") && detected.verdict.contains("2.000 Hz"),
        "{}",
        detected.verdict
    );
    let quiet = change_test_indicator(&tested(false, 20.0));
    assert_eq!(quiet.state, Some(DamageState::None));
    assert!(quiet.verdict.starts_with("none"), "{}", quiet.verdict);
    let not = change_test_indicator(&ChangeTestEvidence::NotTested {
        reason: "the reference's 14 blocks count as 1.3".into(),
    });
    assert_eq!(not.state, None);
    assert!(
        not.verdict.starts_with("not rated") && not.verdict.contains("count as 1.3"),
        "{}",
        not.verdict
    );
}

/// The no-test path of an event pair: the table without rows, its note
/// naming the effective blocks (Eq. C4'), the indicator not rated with that
/// reason, and nothing of it among the rating's drivers.
fn assert_no_test_for_too_few_effective_blocks(out: &Path) {
    let test = load(&CHANGE_TEST.locate(out), None).unwrap();
    let note = test
        .metadata
        .get("quaketwin.note")
        .cloned()
        .unwrap_or_default();
    eprintln!("{}: {note}", out.display());
    assert_eq!(test.rows, 0, "{note}");
    assert!(
        note.contains("count as") && note.contains("Eq. C4'"),
        "{note}"
    );
    let row = load(&ASSESSMENT.locate(out), None).unwrap();
    assert_eq!(text(&row, a::CHANGE_TEST_STATE.name), None);
    let verdict = text(&row, a::CHANGE_TEST_VERDICT.name).unwrap();
    assert!(
        verdict.starts_with("not rated: no change test could be made")
            && verdict.contains("count as"),
        "{verdict}"
    );
    let drivers = row.text_list(a::DRIVERS.name).unwrap()[0]
        .clone()
        .unwrap_or_default();
    assert!(
        !drivers
            .iter()
            .any(|d| d.starts_with("subspace change test")),
        "{drivers:?}"
    );
}

/// Two 40-s synthetic quakes of the sample frame, the second after a 30 %
/// loss of storey 1's stiffness in X: the run without a reference has no
/// change-test indicator; the run with one makes no test — its 12 blocks
/// count as about 4 (the quake's strong phase), 3 degrees of freedom — and
/// says so.  (Before Eq. C4' this pair was "detected", χ² 940 against 58.6,
/// with 11 degrees of freedom assumed: healthy pairs of the same frame were
/// then flagged 1 time in 10 at α = 1 %, median χ² 17 for a null median of 7.)
#[test]
fn event_records_too_short_for_the_change_test_say_so() {
    let dir = tempfile::tempdir().unwrap();
    let pipeline = dir.path().join("modal-assess.toml");
    std::fs::write(&pipeline, PIPELINE).unwrap();
    let (before, after) = (dir.path().join("2026"), dir.path().join("2027"));
    write_event(&before, 1.0, 11);
    write_event(&after, RETAINED_K1_X, 12);
    let (out_before, out_after) = (dir.path().join("out-2026"), dir.path().join("out-2027"));
    run(&pipeline, &before, &out_before, None);
    run(&pipeline, &after, &out_after, Some(&out_before));

    // Without a reference: no test, no indicator.
    let plain = load(&ASSESSMENT.locate(&out_before), None).unwrap();
    assert!(!CHANGE_TEST.locate(&out_before).exists());
    for c in [a::CHANGE_TEST_RATIO.name, a::CHANGE_TEST_P_VALUE.name] {
        assert_eq!(num(&plain, c), None, "{c}");
    }
    for c in [a::CHANGE_TEST_STATE.name, a::CHANGE_TEST_VERDICT.name] {
        assert_eq!(text(&plain, c), None, "{c}");
    }
    assert_no_test_for_too_few_effective_blocks(&out_after);
}

/// Two real earthquakes recorded by the Painter Street overpass (CSMIP
/// 89324), 2019-06-22 against 2020-03-08: before Eq. C4' the test saw
/// χ² 1 485 against 62 (a YELLOW on the test alone; the other pairs of
/// 2014–2021 against 2020: 1 971–8 163); the response lies in one of the
/// 14 blocks (they count as 1.3), and the test is not made.
#[test]
fn two_real_earthquakes_of_a_bridge_are_not_a_false_change() {
    let dir = tempfile::tempdir().unwrap();
    let pipeline = dir.path().join("modal-assess.toml");
    std::fs::write(&pipeline, PIPELINE).unwrap();
    let record = |name: &str| {
        crate::common::shared_record(&format!("cesmd-bridges-corpus/painter-st-ce89324/{name}"))
    };
    let (out_2020, out_2019) = (dir.path().join("out-2020"), dir.path().join("out-2019"));
    run(
        &pipeline,
        &record("nc73351710_ce89324p.zip"),
        &out_2020,
        None,
    );
    run(
        &pipeline,
        &record("nc73201181_ce89324p.zip"),
        &out_2019,
        Some(&out_2020),
    );
    assert_no_test_for_too_few_effective_blocks(&out_2019);
}
