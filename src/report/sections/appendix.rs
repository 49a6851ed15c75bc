//! Appendix: the processing history as recorded (raw JSON parameters of
//! every step), the status of every output file and the raw rows of the
//! twin update.  What a reviewer checks, after what a reader decides on.

use std::path::Path;

use serde_json::Value;

use super::event::json_text;
use super::{listed, Loaded, Outputs, OUTPUTS};
use crate::report::html::{escape, note, table, whole_table, Cell};
use crate::report::ReportSettings;

pub(super) fn appendix_section(
    dir: &Path,
    event: &Result<Value, String>,
    o: &Outputs,
    settings: &ReportSettings,
) -> String {
    let mut body = String::new();
    // Processing history: the most complete copy is in channels/channels.parquet's metadata.
    let history = match &o.channels {
        Loaded::Ok(t) => t
            .metadata
            .get("quaketwin.history")
            .and_then(|h| serde_json::from_str::<Value>(h).ok()),
        _ => None,
    }
    .or_else(|| event.as_ref().ok().and_then(|e| e.get("history").cloned()));
    body.push_str("<h3 id=\"processing-history\">Processing history</h3>");
    let steps = history_items(history.as_ref());
    if steps.is_empty() {
        body.push_str(&note("No processing steps recorded."));
    } else {
        body.push_str(&note(
            "The conditioning steps with their parameters as recorded (channels/channels.parquet metadata quaketwin.history); \
             each later table carries its own history in its metadata.",
        ));
        body.push_str(&format!("<ol class=\"history\">{}</ol>", steps.join("")));
    }
    body.push_str(&output_files(dir, None));
    // The twin update's candidates, round by round (list columns as written).
    if let Loaded::Ok(t) = &o.twin_update {
        body.push_str("<h3 id=\"twin-candidates\">Twin update: every candidate</h3>");
        body.push_str(&note(
            "twin_update/twin_update.parquet as written: one row per ensemble round and candidate solver, with the model quantities z, \
             the normalised scatter and the score per voter (list columns). The section Digital-twin update summarises it.",
        ));
        body.push_str(&whole_table(t, settings.max_table_rows));
    }
    body.push_str(&table_checks());
    body
}

/// The steps of a recorded processing history (`{"steps": [...]}`) as list
/// items: name and parameters as JSON.
pub(super) fn history_items(history: Option<&Value>) -> Vec<String> {
    history
        .and_then(|h| h.get("steps"))
        .and_then(Value::as_array)
        .map(|a| {
            a.iter()
                .map(|s| step_item(&json_text(s.get("step")), s.get("params")))
                .collect()
        })
        .unwrap_or_default()
}

/// One step of the history: its name in bold, its parameters as JSON.
pub(super) fn step_item(name: &str, params: Option<&Value>) -> String {
    let params = params.map(|p| p.to_string()).unwrap_or_default();
    format!(
        "<li><b>{}</b> <code>{}</code></li>",
        escape(name),
        escape(&params)
    )
}

/// The notes gathered while the page was drawn (columns missing or unknown,
/// types not the declared ones, files unreadable), for whoever maintains
/// the outputs; nothing when there are none.
pub(super) fn table_checks() -> String {
    let checks = crate::report::html::take_diagnostics();
    if checks.is_empty() {
        return String::new();
    }
    let items: Vec<String> = checks
        .iter()
        .map(|c| format!("<li>{}</li>", escape(c)))
        .collect();
    format!(
        "<h3 id=\"table-checks\">Table checks</h3>{}<ul class=\"history\">{}</ul>",
        note("What the report found in the files it read beyond what it shows: columns expected and missing, further columns, types not the declared ones, files it could not read."),
        items.join("")
    )
}

/// The status of every output file (of the stages `stages` only, when given).
pub(super) fn output_files(dir: &Path, stages: Option<&[&str]>) -> String {
    let mut body = String::from("<h3 id=\"output-files\">Output files</h3>");
    let rows: Vec<Vec<Cell>> = OUTPUTS
        .iter()
        .filter(|(_, stage, _)| stages.is_none_or(|s| s.contains(stage)))
        .map(|(f, stage, label)| {
            // report.html is this page: its status must not depend on
            // whether an older copy exists (the page is deterministic).
            let fixed = (*f == "report.html").then_some("this page");
            let size = if fixed.is_some() {
                None
            } else {
                listed(dir, f)
                    .then(|| std::fs::metadata(dir.join(f)).ok().map(|m| m.len()))
                    .flatten()
            };
            // A file the run manifest does not list is not this run's
            // (another event's, a stage's that no longer applies).
            let stray = fixed.is_none()
                && size.is_none()
                && crate::pipeline::listed_results(dir).is_some()
                && std::fs::symlink_metadata(dir.join(f)).is_ok();
            vec![
                Cell::raw(format!("<code>{}</code>", escape(f))),
                Cell::text(label),
                Cell::text(stage),
                match (fixed, size) {
                    (Some(text), _) => Cell::text(text),
                    (None, Some(n)) => Cell::text(&format!("present, {n} bytes")),
                    (None, None) if stray => Cell::raw(
                        "<span class=\"absent-inline\">not from this run (not listed in run.json): not shown</span>"
                            .into(),
                    ),
                    (None, None) => Cell::raw("<span class=\"absent-inline\">absent</span>".into()),
                },
            ]
        })
        .collect();
    body.push_str(&table(
        Some("output-files"),
        &["file", "what", "stage", "status"].map(String::from),
        &rows,
    ));
    body
}
