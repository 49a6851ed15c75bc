//! The report's sections, in page order, one file each.  Each section renders
//! what its files hold and says plainly when a file is absent or unreadable.
//! This file holds the page and the helpers the sections share.

mod channels;
mod damage;
mod design;
mod drift;
mod hysteresis;
mod loops;
mod modal;
mod rating;
mod spectra;
mod summary;
mod time_histories;
mod twin;

use std::collections::BTreeMap;
use std::path::Path;

use serde_json::Value;

use super::html::{absent, escape, note, unreadable, whole_table, Cell};
use super::table::{self, Table};
use super::{Assessment, Rating, ReportSettings};
use crate::vocab::schema::{ColumnSpec, TableSchema};
use crate::vocab::tables;

/// Output files the report reads, with the stage that writes each.
const OUTPUTS: [(&str, &str); 17] = [
    ("event.json", "ingest"),
    (tables::SAMPLES.file, "condition"),
    (tables::CHANNELS.file, "metrics"),
    (tables::SPECTRA.file, "metrics"),
    (tables::DRIFT.file, "metrics"),
    (tables::STABILIZATION.file, "modal"),
    (tables::MODES.file, "modal"),
    (
        tables::FREQUENCY_SHIFTS.file,
        "modal (with a reference event)",
    ),
    (tables::HYSTERESIS_FIT.file, "hysteresis"),
    (tables::BOUC_WEN.file, "hysteresis"),
    (tables::BOUC_WEN_INSTANTANEOUS.file, "hysteresis"),
    (tables::DAMAGE.file, "damage"),
    (tables::TWIN_UPDATE.file, "update"),
    (tables::TWIN_MODES.file, "update"),
    (tables::POD.file, "design"),
    (tables::ACTUATOR_LAYOUT.file, "design"),
    ("report.html", "report"),
];

fn stage_of(file: &str) -> &'static str {
    OUTPUTS
        .iter()
        .find(|(f, _)| *f == file)
        .map(|(_, s)| *s)
        .unwrap_or("?")
}

/// A file as the report found it.
enum Loaded {
    /// Not there; with the reason when its stage did not apply (run.json).
    Absent(Option<String>),
    Unreadable(String),
    Ok(Box<Table>),
}

/// Whether `file` in `dir` is a result the report may show: listed by the
/// run manifest of a pipeline run (docs/pipelines.md), or — in a directory
/// without a manifest — present.  A file a run did not list (another
/// event's, a stage's that no longer applies) counts as absent.
fn listed(dir: &Path, file: &str) -> bool {
    match crate::pipeline::listed_results(dir) {
        Some(files) => files.iter().any(|f| f == file) && dir.join(file).exists(),
        None => dir.join(file).exists(),
    }
}

/// A file that is not [`listed`]: absent, with the reason when its stage did not apply.
fn not_loaded(dir: &Path, file: &str) -> Loaded {
    Loaded::Absent(crate::pipeline::not_applicable_reason(dir, stage_of(file)))
}

fn load(dir: &Path, declared: &TableSchema, only: Option<&[&str]>) -> Loaded {
    let file = declared.file;
    let path = dir.join(file);
    if !listed(dir, file) {
        return not_loaded(dir, file);
    }
    match table::load(&path, only) {
        Ok(t) => Loaded::Ok(Box::new(t)),
        Err(e) => Loaded::Unreadable(e.to_string()),
    }
}

/// The section's message for a file that is not usable, or the table (with
/// a note on columns whose type is not the declared one).
fn require<'a>(loaded: &'a Loaded, declared: &TableSchema, body: &mut String) -> Option<&'a Table> {
    let file = declared.file;
    match loaded {
        Loaded::Absent(Some(reason)) => {
            body.push_str(&format!(
                "<p class=\"absent\">Not applicable to this event (stage <code>{}</code>): {}</p>",
                escape(stage_of(file)),
                escape(reason)
            ));
            None
        }
        Loaded::Absent(None) => {
            body.push_str(&absent(file, stage_of(file)));
            None
        }
        Loaded::Unreadable(e) => {
            body.push_str(&unreadable(file, e));
            None
        }
        Loaded::Ok(t) if t.rows == 0 => {
            body.push_str(&note(&format!("{file} holds no rows.")));
            None
        }
        Loaded::Ok(t) => {
            let mismatches = t.type_mismatches(declared);
            if !mismatches.is_empty() {
                body.push_str(&note(&format!(
                    "{file}: {} (shown as found).",
                    mismatches.join("; ")
                )));
            }
            Some(t)
        }
    }
}

fn section(id: &str, number: usize, title: &str, body: &str) -> String {
    format!(
        "<section id=\"{id}\"><h2>{number}. {}</h2>\n{body}\n</section>\n",
        escape(title)
    )
}

fn figure(svg: Result<String, String>, caption: &str, legend: &str) -> String {
    match svg {
        Ok(svg) => format!(
            "<figure>{svg}{legend}<figcaption>{}</figcaption></figure>",
            escape(caption)
        ),
        Err(e) => note(&format!("Plot \"{caption}\" not drawn: {e}.")),
    }
}

fn rows_points(t: &Table, rows: &[usize], x: &str, y: &str) -> Vec<(f64, f64)> {
    let (Some(xs), Some(ys)) = (t.number(x), t.number(y)) else {
        return Vec::new();
    };
    rows.iter()
        .filter_map(
            |&r| match (xs.get(r).copied().flatten(), ys.get(r).copied().flatten()) {
                (Some(a), Some(b)) => Some((a, b)),
                _ => None,
            },
        )
        .collect()
}

/// The `known` columns `t` holds, in the section's order.
fn present_columns<'a>(t: &Table, known: &[&'a str]) -> Vec<&'a str> {
    known.iter().copied().filter(|c| t.has(c)).collect()
}

/// Known columns first (those present, in the section's order), then whatever
/// else the file holds (shapes…), in file order.
fn known_columns_first(t: &Table, known: &[&str]) -> Vec<String> {
    let mut cols: Vec<String> = present_columns(t, known)
        .into_iter()
        .map(str::to_string)
        .collect();
    cols.extend(t.unknown(known));
    cols
}

/// The whole page.
pub fn page(dir: &Path, settings: &ReportSettings) -> String {
    let event = summary::read_event(dir);
    let channels = load(dir, &tables::CHANNELS, None);
    let drift = load(dir, &tables::DRIFT, None);
    let damage = load(dir, &tables::DAMAGE, None);

    let mut assessments: Vec<Assessment> = Vec::new();
    let summary = summary::summary_section(dir, &event, &channels);
    let channel_table = channels::channel_section(&channels);
    let spectra = spectra::spectra_section(dir, &channels);
    let histories = time_histories::time_history_section(dir, &channels, settings);
    let residual = match load(dir, &tables::HYSTERESIS_FIT, None) {
        Loaded::Ok(t) => loops::residual_drifts(&t),
        _ => Default::default(),
    };
    let drift_html = drift::drift_section(&drift, &residual, settings, &mut assessments);
    let modal = modal::modal_section(dir, settings);
    let hysteresis = hysteresis::hysteresis_section(dir, settings);
    let damage_html = damage::damage_section(&damage, settings, &mut assessments);
    let twin = twin::twin_section(dir, settings);
    let design = design::design_section(dir, settings);
    let rating = rating::rating_section(&assessments, &drift, &damage, settings);

    let event_name = match &event {
        Ok(v) => v.get("name").and_then(Value::as_str).map(str::to_string),
        Err(_) => None,
    };
    let title = settings.title.clone().unwrap_or_else(|| match &event_name {
        Some(n) => format!("quaketwin report — {n}"),
        None => "quaketwin report".to_string(),
    });
    let toc = [
        ("summary", "Event and structure"),
        ("rating", "Overall rating"),
        ("channels", "Channels"),
        ("spectra", "Response spectra"),
        ("time-histories", "Acceleration"),
        ("drift", "Inter-storey drift"),
        ("modal", "Modal identification"),
        ("hysteresis", "Bouc-Wen hysteresis"),
        ("damage", "Damage index"),
        ("twin", "Twin update"),
        ("test-design", "Test design"),
    ]
    .iter()
    .enumerate()
    .map(|(i, (id, t))| format!("<a href=\"#{id}\">{}. {t}</a>", i + 1))
    .collect::<Vec<_>>()
    .join(" ");
    let mut page = String::with_capacity(1 << 20);
    page.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n");
    // No network at all: the policy blocks every fetch; styles are inline.
    page.push_str("<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; style-src 'unsafe-inline'; img-src data:\"/>\n");
    page.push_str("<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"/>\n");
    page.push_str(&format!("<title>{}</title>\n", escape(&title)));
    page.push_str(&format!("<style>{CSS}</style>\n</head>\n<body>\n"));
    page.push_str(&format!(
        "<header><h1>{}</h1><p class=\"meta\">Output directory: <code>{}</code> · quaketwin {}</p><nav>{toc}</nav></header>\n<main>\n",
        escape(&title),
        escape(&dir.display().to_string()),
        env!("CARGO_PKG_VERSION")
    ));
    for (i, (id, title, body)) in [
        ("summary", "Event and structure", summary),
        ("rating", "Overall rating", rating),
        (
            "channels",
            "Channels: QA and strong-motion metrics",
            channel_table,
        ),
        ("spectra", "Response spectra", spectra),
        ("time-histories", "Acceleration time histories", histories),
        ("drift", "Inter-storey drift ratios", drift_html),
        ("modal", "Modal identification", modal),
        (
            "hysteresis",
            "Bouc-Wen fit and hysteresis loops",
            hysteresis,
        ),
        ("damage", "Damage index ι(t)", damage_html),
        ("twin", "Digital-twin update", twin),
        ("test-design", "Hybrid-test design", design),
    ]
    .into_iter()
    .enumerate()
    {
        page.push_str(&section(id, i + 1, title, &body));
    }
    page.push_str("</main>\n<footer><p>Every number on this page is read from the Parquet/JSON outputs in the directory above. Ratings: see docs/report.md.</p></footer>\n</body>\n</html>\n");
    page
}

/// channel id → (direction, level) from channels.parquet.
fn channel_info(channels: &Loaded) -> BTreeMap<String, (Option<String>, Option<String>)> {
    let mut m = BTreeMap::new();
    if let Loaded::Ok(t) = channels {
        for r in 0..t.rows {
            let col = |c: &ColumnSpec, r| t.key(c.name, r);
            if let Some(id) = col(&tables::channels::CHANNEL_ID, r) {
                let direction = col(&tables::channels::DIRECTION, r);
                m.insert(id, (direction, col(&tables::channels::LEVEL, r)));
            }
        }
    }
    m
}

fn rating_cell(r: Option<Rating>) -> Cell {
    match r {
        Some(r) => Cell::raw(r.badge()),
        None => Cell::text("not rated"),
    }
}

fn generic(dir: &Path, declared: &TableSchema, settings: &ReportSettings, body: &mut String) {
    body.push_str(&format!("<h3><code>{}</code></h3>", escape(declared.file)));
    let loaded = load(dir, declared, None);
    if let Some(t) = require(&loaded, declared, body) {
        body.push_str(&whole_table(t, settings.max_table_rows));
    }
}

const CSS: &str = r#"
:root{--fg:#1b1b1b;--muted:#555;--line:#d0d0d0;--bg2:#f5f5f5}
*{box-sizing:border-box}
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,"Helvetica Neue",Arial,sans-serif;color:var(--fg);margin:0 auto;max-width:1200px;padding:0 16px 32px;font-size:14px;line-height:1.4}
header{border-bottom:2px solid var(--fg);margin-bottom:8px}
h1{font-size:22px;margin:16px 0 4px}
h2{font-size:18px;margin:24px 0 8px;border-bottom:1px solid var(--line);padding-bottom:2px}
h3{font-size:15px;margin:14px 0 6px}
nav{display:flex;flex-wrap:wrap;gap:4px 12px;padding:6px 0;font-size:13px}
nav a{color:#0b5394;text-decoration:none}
.meta,.note,figcaption{color:var(--muted);font-size:12.5px}
table{border-collapse:collapse;font-size:12.5px;margin:6px 0}
th,td{border:1px solid var(--line);padding:2px 6px;text-align:left;vertical-align:top}
th{background:var(--bg2);font-weight:600}
td.num{text-align:right;font-variant-numeric:tabular-nums}
td.null{color:#999;text-align:center}
.scroll{overflow-x:auto}
.tag{display:inline-block;background:#eee;border:1px solid #ccc;border-radius:3px;padding:0 4px;margin:1px;font-size:11.5px}
dl.facts{display:grid;grid-template-columns:max-content 1fr;gap:2px 16px;margin:6px 0}
dl.facts dt{font-weight:600}
dl.facts dd{margin:0}
ol.history{font-size:12px}
ol.history code{word-break:break-all}
.absent{background:#fff4e5;border-left:4px solid #e69f00;padding:6px 10px;margin:6px 0}
.absent-inline{color:#8a5a00}
figure{margin:6px 0;break-inside:avoid;page-break-inside:avoid}
svg.plot{max-width:100%;height:auto;display:block}
.multiples{display:grid;grid-template-columns:repeat(auto-fill,minmax(380px,1fr));gap:4px 12px}
.grid2{display:grid;grid-template-columns:repeat(auto-fill,minmax(480px,1fr));gap:4px 12px}
ul.legend{list-style:none;padding:0;margin:2px 0;display:flex;flex-wrap:wrap;gap:2px 14px;font-size:12px}
.swatch{font-weight:bold}
.badge{display:inline-block;padding:0 6px;border-radius:3px;font-weight:700;border:1px solid #333;white-space:nowrap}
.r-green{background:#009e73;color:#fff}
.r-yellow{background:#f0e442;color:#000}
.r-red{background:#d55e00;color:#fff}
.rating-box{border:2px solid #333;border-radius:6px;padding:8px 14px;margin:8px 0;max-width:800px}
.rating-box.r-green,.rating-box.r-yellow,.rating-box.r-red{background:none;color:var(--fg)}
.rating-box.r-green{border-color:#009e73}
.rating-box.r-yellow{border-color:#c8b800}
.rating-box.r-red{border-color:#d55e00}
.rating-box .big{font-size:20px;margin:2px 0}
.rating-box.r-none{border-color:#999;background:var(--bg2)}
footer{margin-top:24px;border-top:1px solid var(--line);color:var(--muted);font-size:12px}
@media print{body{max-width:none;font-size:11px}nav{display:none}section{break-before:auto}h2{break-after:avoid}.badge,.r-green,.r-yellow,.r-red{-webkit-print-color-adjust:exact;print-color-adjust:exact}}
"#;
