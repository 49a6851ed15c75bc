//! Event and structure: event.json's facts, notes and files (the
//! processing history and the output files are in the appendix).

use std::path::Path;

use serde_json::Value;

use super::listed;
use crate::report::format_number;
use crate::report::html::{absent, escape, note, table, time_text, unreadable, Cell};

pub(super) fn read_event(dir: &Path) -> Result<Value, String> {
    let path = dir.join("event.json");
    if !listed(dir, "event.json") {
        return Err(String::new());
    }
    let text = crate::input_file::read_to_string(&path, crate::input_file::MAX_INPUT_BYTES)
        .map_err(|e| e.to_string())?;
    serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))
}

pub(super) fn json_text(v: Option<&Value>) -> String {
    match v {
        None | Some(Value::Null) => "—".to_string(),
        Some(Value::String(s)) => s.clone(),
        Some(Value::Number(n)) if n.is_i64() || n.is_u64() => n.to_string(),
        Some(Value::Number(n)) => match n.as_f64() {
            Some(x) => format_number(x),
            None => n.to_string(),
        },
        Some(Value::Array(a)) => a
            .iter()
            .map(|x| json_text(Some(x)))
            .collect::<Vec<_>>()
            .join(", "),
        Some(other) => other.to_string(),
    }
}

/// Magnitude as seismology writes it: one decimal ("6.0", not "6.000").
pub(super) fn magnitude_text(v: Option<&Value>) -> String {
    match v.and_then(Value::as_f64) {
        Some(m) => format!("{m:.1}"),
        None => json_text(v),
    }
}

pub(super) fn event_section(event: &Result<Value, String>) -> String {
    let mut body = String::new();
    match event {
        Err(e) if e.is_empty() => body.push_str(&absent(super::label_of("event.json"), "ingest")),
        Err(e) => body.push_str(&unreadable(super::label_of("event.json"), "event.json", e)),
        Ok(ev) => {
            let structure = ev.get("structure");
            let s = |k: &str| structure.and_then(|s| s.get(k));
            let mut dl = String::from("<dl class=\"facts\">");
            for (k, v) in [
                ("Event", json_text(ev.get("name"))),
                ("Origin time", time_text(&json_text(ev.get("origin_time")))),
                ("Magnitude", magnitude_text(ev.get("magnitude"))),
                ("Structure", json_text(s("name"))),
                ("Storey heights (m)", json_text(s("storey_heights_m"))),
                ("Masses (kg)", json_text(s("masses_kg"))),
                ("Digital twin", json_text(s("twin"))),
                (
                    "Channels",
                    ev.get("channels")
                        .and_then(Value::as_array)
                        .map(|a| a.len().to_string())
                        .unwrap_or_else(|| "—".into()),
                ),
            ] {
                dl.push_str(&format!("<dt>{}</dt><dd>{}</dd>", escape(k), escape(&v)));
            }
            dl.push_str("</dl>");
            body.push_str(&dl);
            let notes: Vec<String> = ev
                .get("notes")
                .and_then(Value::as_array)
                .map(|a| a.iter().map(|n| json_text(Some(n))).collect())
                .unwrap_or_default();
            body.push_str("<h3>Notes</h3>");
            if notes.is_empty() {
                body.push_str(&note("No notes with the event."));
            } else {
                body.push_str("<ul>");
                for n in notes {
                    body.push_str(&format!("<li>{}</li>", escape(&n)));
                }
                body.push_str("</ul>");
            }
            body.push_str("<h3>Event files</h3>");
            let files = ev.get("files").and_then(Value::as_array);
            match files {
                Some(files) if !files.is_empty() => {
                    let rows: Vec<Vec<Cell>> = files
                        .iter()
                        .map(|f| {
                            vec![
                                Cell::text(&json_text(f.get("name"))),
                                Cell::text(&json_text(f.get("format"))),
                                Cell::text(&json_text(f.get("channels"))),
                                Cell::text(&json_text(f.get("skipped"))),
                            ]
                        })
                        .collect();
                    body.push_str(&table(
                        Some("event-files"),
                        &["file", "format", "channels", "skipped because"].map(String::from),
                        &rows,
                    ));
                }
                _ => body.push_str(&note("The event inventory lists no files.")),
            }
        }
    }
    body
}
