//! The test-design report: its own page for a run of the test-design
//! pipeline (design outputs, none of the post-earthquake analyses).  The
//! design first — its facts, the actuator layout drawn on the twin, the
//! reduction and interface, the Craig–Bampton prototype, the λ
//! recommendation —, then the rehearsal sweep (plot and a compact table),
//! the event and its sensor layout, and an appendix with the processing
//! history of this run (conditioning, design, rehearsal) and its output
//! files.  Laid out to print on a few A4 pages.

use std::path::Path;

use serde_json::Value;

use super::appendix::{history_items, output_files, step_item, table_checks};
use super::{design, event, load, rehearsal, section, Loaded};
use crate::report::html::{escape, note};
use crate::report::ReportSettings;
use crate::vocab::tables;

/// The sections of the test-design page, in order.
pub const SECTIONS: [(&str, &str); 4] = [
    ("test-design", "Hybrid-test design"),
    ("rehearsal", "Rehearsal of the hybrid test"),
    ("event", "Event and records"),
    ("appendix", "Appendix: processing history and output files"),
];

/// The stages of the test-design pipeline: the appendix lists their files.
const STAGES: [&str; 6] = [
    "ingest",
    "condition",
    "design",
    "rehearse",
    "report",
    "metrics",
];

/// A test-design run: design outputs, and none of the post-earthquake
/// analyses (drift, modes, hysteresis).  A pipeline doing both keeps the
/// post-earthquake page, with the design in its section.
pub(super) fn applies(dir: &Path) -> bool {
    design::has_design(dir)
        && [&tables::DRIFT, &tables::MODES, &tables::HYSTERESIS_FIT]
            .iter()
            .all(|t| matches!(load(dir, t, Some(&[])), Loaded::Absent(_)))
}

/// The parameters a design or rehearse step ran with, from a table's
/// metadata (`quaketwin.*` keys other than the recommendation and the
/// schema), as one JSON object.
fn step_params(dir: &Path, declared: &crate::vocab::schema::TableSchema) -> Option<Value> {
    let Loaded::Ok(t) = load(dir, declared, Some(&[])) else {
        return None;
    };
    let mut m = serde_json::Map::new();
    for (k, v) in &t.metadata {
        let Some(key) = k.strip_prefix("quaketwin.") else {
            continue;
        };
        if [
            "schema",
            "version",
            "recommendation",
            "nodes",
            "history",
            "event",
        ]
        .contains(&key)
        {
            continue;
        }
        let value = serde_json::from_str::<Value>(v).unwrap_or_else(|_| Value::String(v.clone()));
        m.insert(key.to_string(), value);
    }
    Some(Value::Object(m))
}

fn appendix(dir: &Path, event: &Result<Value, String>) -> String {
    let mut body = String::from("<h3 id=\"processing-history\">Processing history</h3>");
    // The conditioning as the conditioned records carry it, else as ingested.
    let samples = load(dir, &tables::SAMPLES, Some(&[]));
    let history = match &samples {
        Loaded::Ok(t) => t
            .metadata
            .get("quaketwin.history")
            .and_then(|h| serde_json::from_str::<Value>(h).ok()),
        _ => None,
    }
    .or_else(|| event.as_ref().ok().and_then(|e| e.get("history").cloned()));
    let mut steps = history_items(history.as_ref());
    if let Some(p) = step_params(dir, &tables::POD) {
        steps.push(step_item("design (stage design)", Some(&p)));
    }
    if let Some(p) = step_params(dir, &tables::REHEARSAL_SUMMARY) {
        steps.push(step_item("rehearse (stage rehearse)", Some(&p)));
    }
    if steps.is_empty() {
        body.push_str(&note(
            "No processing history recorded with the outputs of this run.",
        ));
    } else {
        body.push_str(&note(
            "Ingest and conditioning as recorded with the conditioned records (samples/samples.parquet, quaketwin.history), then the \
             design and the rehearsal with the settings their tables record (pod/pod.parquet and rehearsal_summary/rehearsal_summary.parquet metadata).",
        ));
        body.push_str(&format!("<ol class=\"history\">{}</ol>", steps.join("")));
    }
    body.push_str(&output_files(dir, Some(&STAGES)));
    body.push_str(&table_checks());
    body
}

/// The whole test-design page.
pub(super) fn page(dir: &Path, event: &Result<Value, String>, settings: &ReportSettings) -> String {
    let design_html = design::design_body(dir);
    let rehearsal_html = {
        let r = rehearsal::rehearsal_body(dir, settings);
        if r.is_empty() {
            let mut b = String::new();
            super::require(
                &load(dir, &tables::REHEARSAL_SUMMARY, None),
                &tables::REHEARSAL_SUMMARY,
                &mut b,
            );
            b
        } else {
            r
        }
    };
    let mut event_html = String::new();
    if let Ok(ev) = event {
        event_html.push_str(&super::layout::layout_figure(ev));
    }
    event_html.push_str(&event::event_section(event));
    let appendix_html = appendix(dir, event);

    let name = event
        .as_ref()
        .ok()
        .and_then(|v| v.get("name").and_then(Value::as_str).map(str::to_string));
    let title = settings.title.clone().unwrap_or_else(|| match &name {
        Some(n) => format!("Hybrid-test design — {n}"),
        None => "Hybrid-test design".to_string(),
    });
    let toc: Vec<(&str, &str)> = SECTIONS.to_vec();
    let mut page = String::with_capacity(1 << 18);
    page.push_str(&super::page_head(&title));
    page.push_str("<div class=\"test-design-page\">");
    page.push_str(&super::page_header(dir, event, &title, settings, &toc));
    for (i, ((id, t), body)) in SECTIONS
        .iter()
        .zip([design_html, rehearsal_html, event_html, appendix_html])
        .enumerate()
    {
        page.push_str(&section(id, i + 1, t, &body));
    }
    page.push_str(&format!(
        "</main>\n<footer><p>{}</p></footer></div>\n</body>\n</html>\n",
        escape(
            "Every number on this page is read from the outputs of the run in the directory above (the appendix lists them)."
        )
    ));
    page
}
