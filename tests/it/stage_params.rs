//! Typed stage parameters: a misspelt key in any stage's params is a usage
//! error (exit 2) naming the file, the line and the key, raised when the
//! pipeline file is read — before any event data is touched.  One test per
//! stage kind.

use quaketwin::stages::parse_pipeline;

/// Every stage kind, in an order whose `inputs` route every product; the
/// stage named `broken` gets `bad_line` as its only params line.
fn pipeline_with(broken: &str, bad_line: &str) -> (String, usize) {
    let stages: [(&str, &str, &str); 9] = [
        ("ingest", "ingest", ""),
        ("condition", "condition", "\"ingest\""),
        ("metrics", "metrics", "\"condition\""),
        ("modal", "modal", "\"condition\""),
        ("hysteresis", "hysteresis", "\"condition\""),
        ("damage", "damage", "\"hysteresis\""),
        ("update", "update", "\"modal\""),
        ("design", "design", "\"condition\""),
        ("report", "report", ""),
    ];
    let mut text = String::from("[pipeline]\nname = \"typo\"\n");
    let mut line = 0;
    for (name, kind, inputs) in stages {
        text.push_str(&format!(
            "\n[[stage]]\nname = \"{name}\"\nkind = \"{kind}\"\ninputs = [{inputs}]\n"
        ));
        if kind == "design" {
            text.push_str("[stage.params]\ndesign = \"design.toml\"\n");
        }
        if name == broken {
            if kind != "design" {
                text.push_str("[stage.params]\n");
            }
            line = text.lines().count() + 1;
            text.push_str(bad_line);
            text.push('\n');
        }
    }
    (text, line)
}

fn assert_refused(kind: &str, key: &str, value: &str) {
    let (text, line) = pipeline_with(kind, &format!("{key} = {value}"));
    let e = parse_pipeline(&text, "typo.toml").expect_err(kind);
    let msg = e.to_string();
    assert_eq!(e.exit_code(), 2, "{kind}: {msg}");
    assert!(msg.contains(key), "{kind}: the key is named: {msg}");
    assert!(
        msg.contains(&format!("typo.toml line {line}")),
        "{kind}: file and line {line}: {msg}"
    );
    assert!(msg.contains(&format!("stage \"{kind}\"")), "{kind}: {msg}");
}

#[test]
fn the_pipeline_with_every_kind_builds_without_the_typo() {
    let (text, _) = pipeline_with("none", "");
    let p = parse_pipeline(&text, "typo.toml").unwrap();
    assert_eq!(p.stages.len(), 9);
}

#[test]
fn misspelt_ingest_key() {
    assert_refused("ingest", "chanels", "1");
}

#[test]
fn misspelt_condition_key() {
    assert_refused("condition", "taper_fration", "0.05");
}

#[test]
fn misspelt_metrics_key() {
    assert_refused("metrics", "dampng", "0.05");
}

#[test]
fn misspelt_modal_key() {
    assert_refused("modal", "ordres", "[2, 42, 2]");
}

#[test]
fn misspelt_hysteresis_key() {
    assert_refused("hysteresis", "exponent_mx", "10.0");
}

#[test]
fn misspelt_damage_key() {
    assert_refused("damage", "output_decimaton", "2");
}

#[test]
fn misspelt_update_key() {
    assert_refused("update", "solver", "[\"ps\"]");
}

#[test]
fn misspelt_design_key() {
    assert_refused("design", "desing_file", "\"design.toml\"");
}

#[test]
fn misspelt_report_key() {
    assert_refused("report", "iota_statistc", "\"final\"");
}

#[test]
fn nested_typo_and_wrong_enum_value_are_refused_with_their_line() {
    let (text, line) = pipeline_with(
        "condition",
        "filter = { order = 4, band = \"bandpass\", corner_hz = [0.5, 20.0] }",
    );
    let msg = parse_pipeline(&text, "typo.toml").unwrap_err().to_string();
    assert!(
        msg.contains("corner_hz") && msg.contains(&format!("line {line}")),
        "{msg}"
    );
    let (text, line) = pipeline_with("hysteresis", "form = \"jerky\"");
    let msg = parse_pipeline(&text, "typo.toml").unwrap_err().to_string();
    assert!(
        msg.contains("jerky") && msg.contains(&format!("line {line}")),
        "{msg}"
    );
    // Values that parse but make no sense are settings errors too, not bad data.
    let (text, _) = pipeline_with(
        "condition",
        "filter = { order = 0, band = \"lowpass\", corners_hz = [5.0] }",
    );
    let e = parse_pipeline(&text, "typo.toml").unwrap_err();
    assert_eq!(e.exit_code(), 2);
    assert!(e.to_string().contains("order 0"), "{e}");
}

#[test]
fn a_product_without_a_provider_among_the_inputs_is_refused() {
    let text = "[pipeline]\nname = \"t\"\n[[stage]]\nname = \"ingest\"\nkind = \"ingest\"\n\
                [[stage]]\nname = \"modal\"\nkind = \"modal\"\ninputs = [\"ingest\"]\n";
    let e = parse_pipeline(text, "t.toml").unwrap_err();
    assert_eq!(e.exit_code(), 2);
    let msg = e.to_string();
    assert!(
        msg.contains("conditioned records") && msg.contains("condition"),
        "{msg}"
    );
}

#[test]
fn the_cli_refuses_a_misspelt_key_before_reading_the_event() {
    let dir = tempfile::tempdir().unwrap();
    let (text, line) = pipeline_with("metrics", "dampng = 0.05");
    let pipeline = dir.path().join("typo.toml");
    std::fs::write(&pipeline, text).unwrap();
    let out = dir.path().join("out");
    // The event does not exist: a run that read it first would say so.
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_quaketwin"))
        .arg("run")
        .arg(&pipeline)
        .arg(dir.path().join("no-such-event"))
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("dampng") && stderr.contains(&format!("line {line}")),
        "{stderr}"
    );
    assert!(!stderr.contains("no-such-event"), "{stderr}");
    assert!(!out.exists(), "nothing is written");
}
