//! The report's sections, in page order.  Each section renders what its
//! files hold and says plainly when a file is absent or unreadable.

use std::collections::BTreeMap;
use std::path::Path;

use serde_json::Value;

use super::html::{absent, column_notes, escape, note, table, unreadable, whole_table, Cell};
use super::plot::{self, Chart, Mark, RefLine, Series};
use super::table::{self, Table};
use super::{Assessment, IotaStatistic, Rating, ReportSettings};

/// Output files the report reads, with the stage that writes each.
const OUTPUTS: [(&str, &str); 17] = [
    ("event.json", "ingest"),
    ("samples.parquet", "condition"),
    ("channels.parquet", "metrics"),
    ("spectra.parquet", "metrics"),
    ("drift.parquet", "metrics"),
    ("stabilization.parquet", "modal"),
    ("modes.parquet", "modal"),
    ("frequency_shifts.parquet", "modal (with a reference event)"),
    ("hysteresis_fit.parquet", "hysteresis"),
    ("bouc_wen.parquet", "hysteresis"),
    ("bouc_wen_instantaneous.parquet", "hysteresis"),
    ("damage.parquet", "damage"),
    ("twin_update.parquet", "update"),
    ("twin_modes.parquet", "update"),
    ("pod.parquet", "design"),
    ("actuator_layout.parquet", "design"),
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

fn load(dir: &Path, file: &str, only: Option<&[&str]>) -> Loaded {
    let path = dir.join(file);
    if !listed(dir, file) {
        return Loaded::Absent(crate::pipeline::not_applicable_reason(dir, stage_of(file)));
    }
    match table::load(&path, only) {
        Ok(t) => Loaded::Ok(Box::new(t)),
        Err(e) => Loaded::Unreadable(e.to_string()),
    }
}

/// The section's message for a file that is not usable, or the table.
fn require<'a>(loaded: &'a Loaded, file: &str, body: &mut String) -> Option<&'a Table> {
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
        Loaded::Ok(t) => Some(t),
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

/// Keeps every k-th point so at most `max` remain (for x–y loops, where
/// min–max decimation in time order does not apply).  Display only.
fn stride(points: Vec<(f64, f64)>, max: usize) -> Vec<(f64, f64)> {
    if points.len() <= max || max == 0 {
        return points;
    }
    let k = points.len().div_ceil(max);
    points.into_iter().step_by(k).collect()
}

/// The whole page.
pub fn page(dir: &Path, settings: &ReportSettings) -> String {
    let event = read_event(dir);
    let channels = load(dir, "channels.parquet", None);
    let drift = load(dir, "drift.parquet", None);
    let damage = load(dir, "damage.parquet", None);

    let mut assessments: Vec<Assessment> = Vec::new();
    let summary = summary_section(dir, &event, &channels);
    let channel_table = channel_section(&channels);
    let spectra = spectra_section(dir, &channels);
    let histories = time_history_section(dir, &channels, settings);
    let drift_html = drift_section(&drift, settings, &mut assessments);
    let modal = modal_section(dir, settings);
    let hysteresis = hysteresis_section(dir, settings);
    let damage_html = damage_section(&damage, settings, &mut assessments);
    let twin = twin_section(dir, settings);
    let design = design_section(dir, settings);
    let rating = rating_section(&assessments, &drift, &damage, settings);

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

fn read_event(dir: &Path) -> Result<Value, String> {
    let path = dir.join("event.json");
    if !listed(dir, "event.json") {
        return Err(String::new());
    }
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))
}

fn json_text(v: Option<&Value>) -> String {
    match v {
        None | Some(Value::Null) => "—".to_string(),
        Some(Value::String(s)) => s.clone(),
        Some(Value::Number(n)) if n.is_i64() || n.is_u64() => n.to_string(),
        Some(Value::Number(n)) => match n.as_f64() {
            Some(x) => super::format_number(x),
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

fn summary_section(dir: &Path, event: &Result<Value, String>, channels: &Loaded) -> String {
    let mut body = String::new();
    match event {
        Err(e) if e.is_empty() => body.push_str(&absent("event.json", "ingest")),
        Err(e) => body.push_str(&unreadable("event.json", e)),
        Ok(ev) => {
            let structure = ev.get("structure");
            let s = |k: &str| structure.and_then(|s| s.get(k));
            let mut dl = String::from("<dl class=\"facts\">");
            for (k, v) in [
                ("Event", json_text(ev.get("name"))),
                ("Origin time (UTC)", json_text(ev.get("origin_time"))),
                ("Magnitude", json_text(ev.get("magnitude"))),
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
                body.push_str(&note("No notes in event.json."));
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
                _ => body.push_str(&note("event.json lists no files.")),
            }
        }
    }
    // Processing history: the most complete copy is in channels.parquet's metadata.
    let history = match channels {
        Loaded::Ok(t) => t
            .metadata
            .get("quaketwin.history")
            .and_then(|h| serde_json::from_str::<Value>(h).ok()),
        _ => None,
    }
    .or_else(|| event.as_ref().ok().and_then(|e| e.get("history").cloned()));
    body.push_str("<h3>Processing history</h3>");
    let steps: Vec<String> = history
        .as_ref()
        .and_then(|h| h.get("steps"))
        .and_then(Value::as_array)
        .map(|a| {
            a.iter()
                .map(|s| {
                    let name = json_text(s.get("step"));
                    let params = s.get("params").map(|p| p.to_string()).unwrap_or_default();
                    format!(
                        "<li><b>{}</b> <code>{}</code></li>",
                        escape(&name),
                        escape(&params)
                    )
                })
                .collect()
        })
        .unwrap_or_default();
    if steps.is_empty() {
        body.push_str(&note("No processing steps recorded."));
    } else {
        body.push_str(&format!("<ol class=\"history\">{}</ol>", steps.join("")));
    }
    body.push_str("<h3>Output files</h3>");
    let rows: Vec<Vec<Cell>> = OUTPUTS
        .iter()
        .map(|(f, stage)| {
            // report.html is this page: its status must not depend on
            // whether an older copy exists (the page is deterministic).
            let size = if *f == "report.html" {
                Some(0)
            } else {
                listed(dir, f)
                    .then(|| std::fs::metadata(dir.join(f)).ok().map(|m| m.len()))
                    .flatten()
            };
            vec![
                Cell::raw(format!("<code>{}</code>", escape(f))),
                Cell::text(stage),
                match size {
                    Some(_) if *f == "report.html" => Cell::text("this page"),
                    Some(n) => Cell::text(&format!("present, {n} bytes")),
                    None => Cell::raw("<span class=\"absent-inline\">absent</span>".into()),
                },
            ]
        })
        .collect();
    body.push_str(&table(
        Some("output-files"),
        &["file", "stage", "status"].map(String::from),
        &rows,
    ));
    body
}

const CHANNEL_COLUMNS: [&str; 16] = [
    "channel_id",
    "level",
    "direction",
    "role",
    "units",
    "sampling_rate_hz",
    "npts",
    "pga_m_s2",
    "pgv_m_s",
    "pgd_m",
    "arias_m_s",
    "d5_95_s",
    "cav_m_s",
    "snr_db",
    "qa_flags",
    "missing",
];

fn channel_section(channels: &Loaded) -> String {
    let mut body = String::new();
    let Some(t) = require(channels, "channels.parquet", &mut body) else {
        return body;
    };
    let present: Vec<&str> = CHANNEL_COLUMNS
        .iter()
        .copied()
        .filter(|c| t.has(c))
        .collect();
    let rows: Vec<Vec<Cell>> = (0..t.rows)
        .map(|r| present.iter().map(|c| Cell::of(t, c, r)).collect())
        .collect();
    body.push_str(&note(
        "Units: m/s² (pga), m/s (pgv, arias, cav), m (pgd), s (d5_95), dB (snr). \
         QA flags and missing metadata as tags; — = not available.",
    ));
    body.push_str(&format!(
        "<div class=\"scroll\">{}</div>",
        table(
            Some("channel-table"),
            &present.iter().map(|s| s.to_string()).collect::<Vec<_>>(),
            &rows
        )
    ));
    let missing = t.missing(&CHANNEL_COLUMNS);
    if !missing.is_empty() {
        body.push_str(&note(&format!(
            "channels.parquet: expected column(s) not present: {}.",
            missing.join(", ")
        )));
    }
    body
}

/// channel id → (direction, level) from channels.parquet.
fn channel_info(channels: &Loaded) -> BTreeMap<String, (Option<String>, Option<String>)> {
    let mut m = BTreeMap::new();
    if let Loaded::Ok(t) = channels {
        for r in 0..t.rows {
            if let Some(id) = t.key("channel_id", r) {
                m.insert(id, (t.key("direction", r), t.key("level", r)));
            }
        }
    }
    m
}

fn spectra_section(dir: &Path, channels: &Loaded) -> String {
    let mut body = String::new();
    let loaded = load(dir, "spectra.parquet", None);
    let Some(t) = require(&loaded, "spectra.parquet", &mut body) else {
        return body;
    };
    body.push_str(&column_notes(
        t,
        &[
            "channel_id",
            "damping",
            "period_s",
            "sd_m",
            "psv_m_s",
            "psa_m_s2",
            "sa_abs_m_s2",
        ],
    ));
    if !t.has("period_s") || !t.has("psa_m_s2") {
        return body;
    }
    let info = channel_info(channels);
    let dampings: Vec<String> = t
        .groups(&["damping"])
        .into_iter()
        .map(|(k, _)| k.join(""))
        .collect();
    // One chart per direction so curves of one direction compare directly.
    let mut by_dir: BTreeMap<String, Vec<(String, Vec<usize>)>> = BTreeMap::new();
    for (key, rows) in t.groups(&["channel_id"]) {
        let id = key.join("");
        let dir = info
            .get(&id)
            .and_then(|(d, _)| d.clone())
            .unwrap_or_else(|| "unknown direction".into());
        by_dir.entry(dir).or_default().push((id, rows));
    }
    body.push_str("<div class=\"grid2\">");
    for (dir, list) in by_dir {
        let mut chart = Chart::new(560, 320, "period T (s)", "PSA (m/s²)");
        chart.log_x = true;
        for (i, (id, rows)) in list.iter().enumerate() {
            // T = 0 (the PGA row) has no place on a log axis.
            let pts: Vec<(f64, f64)> = rows_points(t, rows, "period_s", "psa_m_s2")
                .into_iter()
                .filter(|p| p.0 > 0.0)
                .collect();
            chart
                .series
                .push(Series::new(id.clone(), pts, i, Mark::Line));
        }
        let legend = plot::legend(&chart.series);
        body.push_str(&figure(
            plot::render(&chart),
            &format!(
                "Pseudo-acceleration response spectra, direction {dir}, damping {}",
                dampings.join(", ")
            ),
            &legend,
        ));
    }
    body.push_str("</div>");
    body
}

fn time_history_section(dir: &Path, channels: &Loaded, settings: &ReportSettings) -> String {
    let mut body = String::new();
    let loaded = load(
        dir,
        "samples.parquet",
        Some(&["channel_id", "t_s", "acc_m_s2"]),
    );
    let Some(t) = require(&loaded, "samples.parquet", &mut body) else {
        return body;
    };
    let missing = t.missing(&["channel_id", "t_s", "acc_m_s2"]);
    if !missing.is_empty() {
        body.push_str(&note(&format!(
            "samples.parquet: column(s) needed for the plots not present: {}.",
            missing.join(", ")
        )));
        return body;
    }
    let info = channel_info(channels);
    let pga: BTreeMap<String, f64> = match channels {
        Loaded::Ok(c) => (0..c.rows)
            .filter_map(|r| {
                Some((
                    c.key("channel_id", r)?,
                    c.number("pga_m_s2")?.get(r).copied().flatten()?,
                ))
            })
            .collect(),
        _ => BTreeMap::new(),
    };
    let groups = t.groups(&["channel_id"]);
    let traces: Vec<(String, Vec<(f64, f64)>)> = groups
        .into_iter()
        .map(|(k, rows)| {
            let pts = rows_points(t, &rows, "t_s", "acc_m_s2");
            (
                k.join(""),
                plot::decimate_min_max(&pts, settings.max_points_per_trace),
            )
        })
        .collect();
    // Common symmetric y-axis so amplitudes compare across the multiples.
    let peak = traces
        .iter()
        .flat_map(|(_, p)| p.iter().map(|x| x.1.abs()))
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    let y = if peak > 0.0 { 1.05 * peak } else { 1.0 };
    body.push_str(&note(&format!(
        "Conditioned acceleration, common vertical scale. Traces drawn with at most {} points (min–max decimation keeps the peaks); PGA values from channels.parquet.",
        settings.max_points_per_trace
    )));
    body.push_str("<div class=\"multiples\">");
    for (i, (id, pts)) in traces.into_iter().enumerate() {
        let mut chart = Chart::new(440, 170, "t (s)", "a (m/s²)");
        chart.y_range = Some((-y, y));
        chart
            .series
            .push(Series::new(id.clone(), pts, i % 7, Mark::Line));
        let (dir, level) = info.get(&id).cloned().unwrap_or((None, None));
        let caption = format!(
            "{id} — level {}, direction {}{}",
            level.unwrap_or_else(|| "?".into()),
            dir.unwrap_or_else(|| "?".into()),
            pga.get(&id)
                .map(|p| format!(", PGA {} m/s²", super::format_number(*p)))
                .unwrap_or_default()
        );
        body.push_str(&figure(plot::render(&chart), &caption, ""));
    }
    body.push_str("</div>");
    body
}

fn rating_cell(r: Option<Rating>) -> Cell {
    match r {
        Some(r) => Cell::raw(r.badge()),
        None => Cell::text("not rated"),
    }
}

fn drift_section(drift: &Loaded, settings: &ReportSettings, out: &mut Vec<Assessment>) -> String {
    let mut body = String::new();
    let Some(t) = require(drift, "drift.parquet", &mut body) else {
        return body;
    };
    let known = [
        "direction",
        "storey",
        "lower_channel",
        "upper_channel",
        "storey_height_m",
        "peak_drift_ratio",
    ];
    body.push_str(&column_notes(t, &known));
    let Some(ratio) = t.number("peak_drift_ratio") else {
        return body;
    };
    let th = settings.drift;
    body.push_str(&note(&format!(
        "Rating of the peak drift ratio: GREEN < {} ≤ YELLOW < {} ≤ RED.",
        super::format_number(th.yellow),
        super::format_number(th.red)
    )));
    let mut headers: Vec<String> = known
        .iter()
        .filter(|c| t.has(c))
        .map(|s| s.to_string())
        .collect();
    headers.push("drift (%)".into());
    headers.push("rating".into());
    let mut rows = Vec::new();
    for r in 0..t.rows {
        let v = ratio.get(r).copied().flatten();
        let rating = v.and_then(|v| th.rate(v));
        let mut row: Vec<Cell> = known
            .iter()
            .filter(|c| t.has(c))
            .map(|c| Cell::of(t, c, r))
            .collect();
        row.push(match v {
            Some(v) => Cell::text(&format!("{:.3}", 100.0 * v)),
            None => Cell::number(None),
        });
        row.push(rating_cell(rating));
        rows.push(row);
        if let (Some(v), Some(rating)) = (v, rating) {
            out.push(Assessment {
                criterion: "peak inter-storey drift ratio".into(),
                subject: format!(
                    "storey {}, direction {}",
                    t.key("storey", r).unwrap_or_else(|| "?".into()),
                    t.key("direction", r).unwrap_or_else(|| "?".into())
                ),
                value: v,
                rating,
                source: "drift.parquet".into(),
            });
        }
    }
    body.push_str(&table(Some("drift-table"), &headers, &rows));
    // Drift profile: storey on the vertical axis, one line per direction.
    if t.has("storey") {
        let mut chart = Chart::new(520, 300, "peak inter-storey drift ratio", "storey");
        for (i, (dir, rows)) in t.groups(&["direction"]).into_iter().enumerate() {
            let mut pts: Vec<(f64, f64)> = rows_points(t, &rows, "peak_drift_ratio", "storey");
            pts.sort_by(|a, b| a.1.total_cmp(&b.1));
            chart.series.push(Series::new(
                format!("direction {}", dir.join("")),
                pts,
                i,
                Mark::LinePoints,
            ));
        }
        let max = ratio.iter().flatten().fold(0.0f64, |a, b| a.max(*b));
        chart.x_range = Some((0.0, (1.1 * max).max(1.1 * th.yellow)));
        chart.ref_lines.push(RefLine {
            at: th.yellow,
            horizontal: false,
            colour: 4,
        });
        chart.ref_lines.push(RefLine {
            at: th.red,
            horizontal: false,
            colour: 1,
        });
        let legend = plot::legend(&chart.series);
        body.push_str(&figure(
            plot::render(&chart),
            "Peak drift ratio per storey; dashed lines: yellow (orange) and red (vermillion) thresholds",
            &legend,
        ));
    }
    body
}

fn rating_section(
    assessments: &[Assessment],
    drift: &Loaded,
    damage: &Loaded,
    settings: &ReportSettings,
) -> String {
    let mut body = String::new();
    let worst = assessments.iter().map(|a| a.rating).max();
    let mut considered = Vec::new();
    for (file, loaded) in [("drift.parquet", drift), ("damage.parquet", damage)] {
        considered.push(match loaded {
            Loaded::Ok(_) if assessments.iter().any(|a| a.source == file) => {
                format!("{file}: rated")
            }
            Loaded::Ok(_) => format!("{file}: present but holds no ratable value"),
            Loaded::Absent(Some(why)) => format!("{file}: not applicable ({why})"),
            Loaded::Absent(None) => format!("{file}: absent (stage {} not run)", stage_of(file)),
            Loaded::Unreadable(_) => format!("{file}: unreadable"),
        });
    }
    match worst {
        None => {
            body.push_str(
                "<div class=\"rating-box r-none\" id=\"overall-rating\"><p class=\"big\">NOT RATED</p><p>No rating criterion is available.</p></div>",
            );
        }
        Some(w) => {
            // The criterion values that reach the worst rating, largest first.
            let mut drivers: Vec<&Assessment> =
                assessments.iter().filter(|a| a.rating == w).collect();
            drivers.sort_by(|a, b| b.value.total_cmp(&a.value));
            let mut by_criterion: BTreeMap<&str, &Assessment> = BTreeMap::new();
            for d in &drivers {
                by_criterion.entry(d.criterion.as_str()).or_insert(d);
            }
            let driven: Vec<String> = by_criterion
                .values()
                .map(|a| {
                    format!(
                        "{} = {} at {} ({})",
                        escape(&a.criterion),
                        super::format_number(a.value),
                        escape(&a.subject),
                        escape(&a.source)
                    )
                })
                .collect();
            body.push_str(&format!(
                "<div class=\"rating-box {cls}\" id=\"overall-rating\"><p class=\"big\">{badge}</p><p>{meaning}.</p><p>Driven by: {}.</p></div>",
                driven.join("; "),
                cls = match w {
                    Rating::Green => "r-green",
                    Rating::Yellow => "r-yellow",
                    Rating::Red => "r-red",
                },
                badge = w.badge(),
                meaning = escape(w.meaning()),
            ));
        }
    }
    body.push_str("<ul>");
    for c in considered {
        body.push_str(&format!("<li>{}</li>", escape(&c)));
    }
    body.push_str("</ul>");
    body.push_str(&note(&format!(
        "Overall rating = worst of the available criteria. Thresholds: drift ratio GREEN < {} ≤ YELLOW < {} ≤ RED; damage index ι ({} value) GREEN < {} ≤ YELLOW < {} ≤ RED. Screening values, see docs/report.md.",
        super::format_number(settings.drift.yellow),
        super::format_number(settings.drift.red),
        match settings.iota_statistic {
            IotaStatistic::Final => "final",
            IotaStatistic::Peak => "peak",
        },
        super::format_number(settings.iota.yellow),
        super::format_number(settings.iota.red),
    )));
    body
}

fn modal_section(dir: &Path, settings: &ReportSettings) -> String {
    let mut body = String::new();
    let stab = load(dir, "stabilization.parquet", None);
    let modes = load(dir, "modes.parquet", None);
    let shifts = load(dir, "frequency_shifts.parquet", None);
    let mode_freqs: Vec<f64> = match &modes {
        Loaded::Ok(m) => m
            .number("frequency_hz")
            .map(|v| v.iter().flatten().copied().collect())
            .unwrap_or_default(),
        _ => Vec::new(),
    };

    body.push_str("<h3>Stabilisation diagram</h3>");
    if let Some(t) = require(&stab, "stabilization.parquet", &mut body) {
        let known = [
            "order",
            "frequency_hz",
            "damping_ratio",
            "stable_frequency",
            "stable_damping",
            "stable_shape",
            "physical",
            "mode",
        ];
        body.push_str(&column_notes(t, &known));
        if t.has("order") && t.has("frequency_hz") {
            let flag = |name: &str, r: usize| {
                t.boolean(name)
                    .and_then(|v| v.get(r).copied().flatten())
                    .unwrap_or(false)
            };
            let has_physical = t.has("physical");
            // Categories, worst first; a pole falls in the first that applies.
            let mut cats: [Vec<(f64, f64)>; 4] = Default::default();
            let (Some(fcol), Some(ocol)) = (t.number("frequency_hz"), t.number("order")) else {
                return body;
            };
            for r in 0..t.rows {
                let (Some(f), Some(o)) = (
                    fcol.get(r).copied().flatten(),
                    ocol.get(r).copied().flatten(),
                ) else {
                    continue;
                };
                let physical = !has_physical || flag("physical", r);
                let idx = if !physical {
                    3
                } else if flag("stable_frequency", r)
                    && flag("stable_damping", r)
                    && flag("stable_shape", r)
                {
                    0
                } else if flag("stable_frequency", r) {
                    1
                } else {
                    2
                };
                cats[idx].push((f, o));
            }
            let labels = [
                (
                    "stable in frequency, damping and shape",
                    Mark::FilledCircle,
                    0,
                ),
                ("stable in frequency only", Mark::HollowCircle, 2),
                ("new or unstable", Mark::Cross, 4),
                ("non-physical (filtered out)", Mark::Triangle, 6),
            ];
            let mut chart = Chart::new(900, 380, "frequency (Hz)", "model order");
            for (i, pts) in cats.into_iter().enumerate() {
                let (label, mark, colour) = labels[i];
                chart.series.push(Series::new(
                    format!("{label} ({})", pts.len()),
                    pts,
                    colour,
                    mark,
                ));
            }
            for f in &mode_freqs {
                chart.ref_lines.push(RefLine {
                    at: *f,
                    horizontal: false,
                    colour: 1,
                });
            }
            let mut legend_series = chart.series.clone();
            if !mode_freqs.is_empty() {
                legend_series.push(Series::new(
                    "identified mode (modes.parquet)",
                    vec![],
                    1,
                    Mark::Dashed,
                ));
            }
            body.push_str(&figure(
                plot::render(&chart),
                &format!("Stabilisation diagram: {} poles", t.rows),
                &plot::legend(&legend_series),
            ));
        }
    }

    body.push_str("<h3>Identified modes</h3>");
    if let Some(t) = require(&modes, "modes.parquet", &mut body) {
        let known = [
            "mode",
            "frequency_hz",
            "frequency_std_hz",
            "damping_ratio",
            "damping_std",
            "mpc",
            "mpd_deg",
            "pole_count",
        ];
        let missing = t.missing(&known);
        if !missing.is_empty() {
            body.push_str(&note(&format!(
                "modes.parquet: expected column(s) not present: {}.",
                missing.join(", ")
            )));
        }
        // Known columns first, then whatever else the file holds (shapes…).
        let mut cols: Vec<String> = known
            .iter()
            .filter(|c| t.has(c))
            .map(|s| s.to_string())
            .collect();
        cols.extend(t.unknown(&known));
        let rows: Vec<Vec<Cell>> = (0..t.rows.min(settings.max_table_rows))
            .map(|r| cols.iter().map(|c| Cell::of(t, c, r)).collect())
            .collect();
        body.push_str(&format!(
            "<div class=\"scroll\">{}</div>",
            table(Some("modes-table"), &cols, &rows)
        ));
    }

    body.push_str("<h3>Frequency shift against a reference event</h3>");
    match &shifts {
        Loaded::Absent(_) => body.push_str(&format!(
            "<p class=\"absent\">Output absent: <code>frequency_shifts.parquet</code> (written by the modal stage only when a previous event of the same structure is given).</p>"
        )),
        _ => {
            if let Some(t) = require(&shifts, "frequency_shifts.parquet", &mut body) {
                let known = [
                    "reference_mode",
                    "other_mode",
                    "frequency_reference_hz",
                    "frequency_other_hz",
                    "relative_shift",
                    "mac",
                ];
                body.push_str(&column_notes(t, &known));
                let mut cols: Vec<String> = known
                    .iter()
                    .filter(|c| t.has(c))
                    .map(|s| s.to_string())
                    .collect();
                cols.extend(t.unknown(&known));
                let rows: Vec<Vec<Cell>> = (0..t.rows.min(settings.max_table_rows))
                    .map(|r| cols.iter().map(|c| Cell::of(t, c, r)).collect())
                    .collect();
                body.push_str(&table(Some("shifts-table"), &cols, &rows));
            }
        }
    }
    body
}

fn hysteresis_section(dir: &Path, settings: &ReportSettings) -> String {
    let mut body = String::new();
    let fit = load(dir, "hysteresis_fit.parquet", None);
    let params = load(dir, "bouc_wen.parquet", None);
    body.push_str("<h3>Identified Bouc-Wen parameters</h3>");
    if let Some(t) = require(&params, "bouc_wen.parquet", &mut body) {
        // Long layout (one row per parameter: `parameter`, `value`, `unit`…)
        // or wide (one column per parameter).
        let known: &[&str] = if t.has("parameter") && t.has("value") {
            &[
                "direction",
                "dof",
                "parameter",
                "coupled_dof",
                "value",
                "unit",
                "stability_std",
                "stable",
                "status",
                "cost_j",
            ]
        } else {
            &[
                "direction",
                "dof",
                "k0_n_m",
                "beta",
                "gamma",
                "n_exponent",
                "cost_j",
            ]
        };
        let missing = t.missing(known);
        if !missing.is_empty() {
            body.push_str(&note(&format!(
                "bouc_wen.parquet: expected column(s) not present: {}.",
                missing.join(", ")
            )));
        }
        let mut cols: Vec<String> = known
            .iter()
            .filter(|c| t.has(c))
            .map(|s| s.to_string())
            .collect();
        cols.extend(t.unknown(known));
        let rows: Vec<Vec<Cell>> = (0..t.rows.min(settings.max_table_rows))
            .map(|r| cols.iter().map(|c| Cell::of(t, c, r)).collect())
            .collect();
        body.push_str(&format!(
            "<div class=\"scroll\">{}</div>",
            table(Some("bouc-wen-table"), &cols, &rows)
        ));
    }
    body.push_str("<h3>Instantaneous estimates</h3>");
    let inst = load(dir, "bouc_wen_instantaneous.parquet", None);
    if let Some(t) = require(&inst, "bouc_wen_instantaneous.parquet", &mut body) {
        let keys: Vec<&str> = ["direction", "dof"]
            .into_iter()
            .filter(|k| t.has(k))
            .collect();
        if t.number("t_s").is_some() && t.number("n_exponent").is_some() {
            let mut chart = Chart::new(560, 260, "end of growing window t (s)", "exponent N");
            for (i, (key, rows)) in t.groups(&keys).into_iter().enumerate() {
                let label = keys
                    .iter()
                    .zip(&key)
                    .map(|(k, v)| format!("{k} {v}"))
                    .collect::<Vec<_>>()
                    .join(", ");
                let pts = rows_points(t, &rows, "t_s", "n_exponent");
                chart.series.push(Series::new(
                    label,
                    plot::decimate_min_max(&pts, settings.max_points_per_trace),
                    i,
                    Mark::Line,
                ));
            }
            let legend = plot::legend(&chart.series);
            body.push_str(&figure(
                plot::render(&chart),
                "Instantaneous Bouc-Wen exponent N(t) (growing window)",
                &legend,
            ));
        } else {
            body.push_str(&note(
                "bouc_wen_instantaneous.parquet: columns t_s and n_exponent needed for the plot.",
            ));
        }
        body.push_str(&note(&format!(
            "bouc_wen_instantaneous.parquet columns: {}.",
            t.names.join(", ")
        )));
    }
    body.push_str("<h3>Hysteresis loops: record and model</h3>");
    if let Some(t) = require(&fit, "hysteresis_fit.parquet", &mut body) {
        let known = [
            "direction",
            "dof",
            "t_s",
            "drift_m",
            "force_record_n",
            "force_model_n",
        ];
        body.push_str(&column_notes(t, &known));
        if !t.has("drift_m") || !(t.has("force_record_n") || t.has("force_model_n")) {
            return body;
        }
        let keys: Vec<&str> = ["direction", "dof"]
            .into_iter()
            .filter(|k| t.has(k))
            .collect();
        body.push_str("<div class=\"multiples\">");
        for (key, rows) in t.groups(&keys) {
            let kn = |col: &str| -> Vec<(f64, f64)> {
                let pts: Vec<(f64, f64)> = rows_points(t, &rows, "drift_m", col)
                    .into_iter()
                    .map(|(d, f)| (d, f / 1000.0))
                    .collect();
                stride(pts, settings.max_points_per_trace)
            };
            let mut chart = Chart::new(440, 300, "inter-storey drift (m)", "storey force (kN)");
            chart
                .series
                .push(Series::new("record", kn("force_record_n"), 0, Mark::Line));
            chart
                .series
                .push(Series::new("model", kn("force_model_n"), 1, Mark::Dashed));
            let label = keys
                .iter()
                .zip(&key)
                .map(|(k, v)| format!("{k} {v}"))
                .collect::<Vec<_>>()
                .join(", ");
            let legend = plot::legend(&chart.series);
            body.push_str(&figure(
                plot::render(&chart),
                &format!("Force–drift loop, {label}"),
                &legend,
            ));
        }
        body.push_str("</div>");
    }
    body
}

fn damage_section(damage: &Loaded, settings: &ReportSettings, out: &mut Vec<Assessment>) -> String {
    let mut body = String::new();
    let Some(t) = require(damage, "damage.parquet", &mut body) else {
        return body;
    };
    // Two layouts: long (one row per direction, time and `mode`, with
    // `omega_ratio`) or wide (`omega_ratio_<mode>` columns).
    let long = t.has("mode") && t.number("mode").is_some();
    let known = [
        "direction",
        "t_s",
        "iota",
        "mode",
        "omega_rad_s",
        "omega_ratio",
        "participation",
    ];
    let ratio_cols: Vec<String> = t
        .names
        .iter()
        .filter(|n| n.starts_with("omega_ratio") && t.number(n).is_some())
        .filter(|n| !long || n.as_str() != "omega_ratio")
        .cloned()
        .collect();
    let mut all_known: Vec<&str> = known.to_vec();
    all_known.extend(ratio_cols.iter().map(|s| s.as_str()));
    body.push_str(&column_notes(t, &all_known));
    if t.number("t_s").is_none() || t.number("iota").is_none() {
        return body;
    }
    let th = settings.iota;
    let stat = settings.iota_statistic;
    body.push_str(&note(&format!(
        "Rating of the {} value of ι(t): GREEN < {} ≤ YELLOW < {} ≤ RED.",
        match stat {
            IotaStatistic::Final => "final",
            IotaStatistic::Peak => "peak",
        },
        super::format_number(th.yellow),
        super::format_number(th.red)
    )));
    let keys: Vec<&str> = if t.has("direction") {
        vec!["direction"]
    } else {
        vec![]
    };
    let groups = if keys.is_empty() {
        vec![(vec!["—".to_string()], (0..t.rows).collect::<Vec<_>>())]
    } else {
        t.groups(&keys)
    };
    let mut rows_html = Vec::new();
    let mut figures = String::new();
    for (gi, (key, rows)) in groups.iter().enumerate() {
        let dir = key.join("");
        // In the long layout ι repeats on every mode's row: take one mode's rows.
        let mode_groups: Vec<(String, Vec<usize>)> = if long {
            let mut m: BTreeMap<i64, Vec<usize>> = BTreeMap::new();
            let modes = t.number("mode").unwrap_or(&[]);
            for &r in rows {
                if let Some(Some(k)) = modes.get(r) {
                    m.entry(*k as i64).or_default().push(r);
                }
            }
            m.into_iter()
                .map(|(k, v)| (format!("mode {k}"), v))
                .collect()
        } else {
            Vec::new()
        };
        let iota_rows: &[usize] = mode_groups.first().map(|g| g.1.as_slice()).unwrap_or(rows);
        let pts = rows_points(t, iota_rows, "t_s", "iota");
        // Final = value at the latest time; peak = maximum over time.
        let final_v = pts.iter().max_by(|a, b| a.0.total_cmp(&b.0)).map(|p| p.1);
        let peak_v = pts
            .iter()
            .map(|p| p.1)
            .filter(|v| v.is_finite())
            .reduce(f64::max);
        let rated = match stat {
            IotaStatistic::Final => final_v,
            IotaStatistic::Peak => peak_v,
        };
        let rating = rated.and_then(|v| th.rate(v));
        rows_html.push(vec![
            Cell::text(&dir),
            Cell::number(final_v),
            Cell::number(peak_v),
            rating_cell(rating),
        ]);
        if let (Some(v), Some(rating)) = (rated, rating) {
            out.push(Assessment {
                criterion: format!(
                    "damage index ι ({})",
                    match stat {
                        IotaStatistic::Final => "final",
                        IotaStatistic::Peak => "peak",
                    }
                ),
                subject: format!("direction {dir}"),
                value: v,
                rating,
                source: "damage.parquet".into(),
            });
        }
        if !pts.iter().any(|p| p.1.is_finite()) {
            figures.push_str(&note(&format!(
                "ι(t), direction {dir}: no finite value in damage.parquet — not rated."
            )));
        }
        let mut chart = Chart::new(560, 280, "t (s)", "ι");
        chart.series.push(Series::new(
            format!("ι(t), direction {dir}"),
            plot::decimate_min_max(&pts, settings.max_points_per_trace),
            gi % 7,
            Mark::Line,
        ));
        chart.ref_lines.push(RefLine {
            at: th.yellow,
            horizontal: true,
            colour: 4,
        });
        chart.ref_lines.push(RefLine {
            at: th.red,
            horizontal: true,
            colour: 1,
        });
        figures.push_str(&figure(
            plot::render(&chart),
            &format!("Damage index ι(t), direction {dir}; dashed: yellow (orange) and red (vermillion) thresholds"),
            "",
        ));
        let ratio_series: Vec<(String, Vec<(f64, f64)>)> = if long && t.has("omega_ratio") {
            mode_groups
                .iter()
                .map(|(label, r)| (label.clone(), rows_points(t, r, "t_s", "omega_ratio")))
                .collect()
        } else {
            ratio_cols
                .iter()
                .map(|c| (c.clone(), rows_points(t, rows, "t_s", c)))
                .collect()
        };
        if !ratio_series.is_empty() {
            let mut chart = Chart::new(560, 280, "t (s)", "ω(t)/ω(0)");
            for (i, (label, pts)) in ratio_series.into_iter().enumerate() {
                chart.series.push(Series::new(
                    label,
                    plot::decimate_min_max(&pts, settings.max_points_per_trace),
                    i,
                    Mark::Line,
                ));
            }
            let legend = plot::legend(&chart.series);
            figures.push_str(&figure(
                plot::render(&chart),
                &format!("Natural-frequency ratios, direction {dir}"),
                &legend,
            ));
        }
    }
    if let Some(steps) = t.metadata.get("quaketwin.indefinite_steps") {
        body.push_str(&note(&format!(
            "Time steps where K(t) lost positive definiteness (damage.parquet metadata): {steps}."
        )));
    }
    body.push_str(&table(
        Some("damage-table"),
        &["direction", "final ι", "peak ι", "rating"].map(String::from),
        &rows_html,
    ));
    body.push_str(&format!("<div class=\"grid2\">{figures}</div>"));
    body.push_str(&note(
        "ι(t) includes recoverable energy and can oscillate during shaking (METHODS.md §4); the final value is the post-event state.",
    ));
    body
}

fn generic(dir: &Path, file: &str, settings: &ReportSettings, body: &mut String) {
    body.push_str(&format!("<h3><code>{}</code></h3>", escape(file)));
    let loaded = load(dir, file, None);
    if let Some(t) = require(&loaded, file, body) {
        body.push_str(&whole_table(t, settings.max_table_rows));
    }
}

fn twin_section(dir: &Path, settings: &ReportSettings) -> String {
    let mut body = String::new();
    generic(dir, "twin_update.parquet", settings, &mut body);
    generic(dir, "twin_modes.parquet", settings, &mut body);
    body
}

fn design_section(dir: &Path, settings: &ReportSettings) -> String {
    let mut body = String::new();
    // Key facts from the tables and their metadata (docs/test-design.md).
    let pod = load(dir, "pod.parquet", None);
    let layout = load(dir, "actuator_layout.parquet", None);
    let validation = load(dir, "reduction_validation.parquet", None);
    let hybrid = load(dir, "hybrid_prototype.parquet", None);
    let refinement = load(dir, "interface_refinement.parquet", None);
    let meta = |l: &Loaded, key: &str| -> String {
        match l {
            Loaded::Ok(t) => t.metadata.get(key).cloned().unwrap_or_else(|| "—".into()),
            _ => "—".into(),
        }
    };
    let mut facts: Vec<(String, String)> = Vec::new();
    if let Loaded::Ok(t) = &pod {
        let retained = meta(&pod, "quaketwin.retained_poms");
        let energy = t
            .number("cumulative_energy")
            .and_then(|c| {
                retained
                    .parse::<usize>()
                    .ok()
                    .and_then(|k| c.get(k.checked_sub(1)?).copied().flatten())
            })
            .map(|e| format!("{:.4} %", 100.0 * e))
            .unwrap_or_else(|| "—".into());
        facts.push(("Snapshots".into(), meta(&pod, "quaketwin.snapshot_source")));
        facts.push(("Base motion".into(), meta(&pod, "quaketwin.motion")));
        facts.push((
            "Retained POMs (energy)".into(),
            format!("{retained} ({energy})"),
        ));
        if let Some(mac) = t.metadata.get("quaketwin.pom_mac_with_twin") {
            let first: Vec<String> = serde_json::from_str::<Vec<f64>>(mac)
                .unwrap_or_default()
                .iter()
                .take(3)
                .map(|v| format!("{v:.3}"))
                .collect();
            facts.push(("MAC of recorded vs twin POMs 1–3".into(), first.join(", ")));
        }
    }
    if let Loaded::Ok(t) = &layout {
        let control = t.text("control_mode").unwrap_or(&[]);
        let force = control
            .iter()
            .filter(|c| c.as_deref() == Some("force"))
            .count();
        facts.push((
            "Actuators".into(),
            format!(
                "{} ({} displacement-, {force} force-controlled)",
                t.rows,
                t.rows - force
            ),
        ));
    }
    if let Loaded::Ok(_) = &validation {
        facts.push(("Reduced vs full twin at the PS (WNRMSE)".into(), {
            let fmt = |k: &str| {
                meta(&validation, k)
                    .parse::<f64>()
                    .map(|v| format!("{v:.2e}"))
                    .unwrap_or_else(|_| "—".into())
            };
            format!(
                "deformation {}, total displacement {}",
                fmt("quaketwin.wnrmse"),
                fmt("quaketwin.wnrmse_total")
            )
        }));
    }
    if let Loaded::Ok(_) = &hybrid {
        let rec: Option<Value> =
            serde_json::from_str(&meta(&hybrid, "quaketwin.recommendation")).ok();
        let num = |k: &str| rec.as_ref().and_then(|r| r.get(k)).and_then(Value::as_f64);
        let text = match (num("ns_modes"), num("time_scale"), num("bandwidth_hz"), num("highest_frequency_hz")) {
            (Some(n), Some(l), Some(b), Some(top)) => format!(
                "Craig–Bampton prototype with {n} NS modes (highest frequency {top:.1} Hz); time scale λ = {l}: hybrid bandwidth {b:.3} Hz"
            ),
            _ => "—".into(),
        };
        facts.push(("Hybrid recommendation".into(), text));
    }
    if !facts.is_empty() {
        let mut dl = String::from("<dl class=\"facts\">");
        for (k, v) in &facts {
            dl.push_str(&format!("<dt>{}</dt><dd>{}</dd>", escape(k), escape(v)));
        }
        dl.push_str("</dl>");
        body.push_str(&dl);
    }
    // The trade-off of the interface refinement: accuracy against actuators.
    if let Loaded::Ok(t) = &refinement {
        if let (Some(act), Some(def), Some(tot)) = (
            t.number("actuators"),
            t.number("wnrmse_deformation"),
            t.number("wnrmse_total"),
        ) {
            let pts = |y: &[Option<f64>]| -> Vec<(f64, f64)> {
                act.iter()
                    .zip(y)
                    .filter_map(|(a, y)| Some((((*a)?), (*y)?)))
                    .collect()
            };
            let mut chart = Chart::new(520, 260, "actuators", "WNRMSE");
            chart
                .series
                .push(Series::new("deformation", pts(def), 0, Mark::LinePoints));
            chart.series.push(Series::new(
                "total displacement",
                pts(tot),
                1,
                Mark::LinePoints,
            ));
            let legend = plot::legend(&chart.series);
            body.push_str(&figure(
                plot::render(&chart),
                "Interface refinement: reduced-twin WNRMSE against the number of actuators (interface_refinement.parquet)",
                &legend,
            ));
        }
    }
    // POD energy per mode.
    if let Loaded::Ok(t) = &pod {
        if let Some(v) = t.number("energy_fraction") {
            let pts: Vec<(f64, f64)> = v
                .iter()
                .enumerate()
                .filter_map(|(i, x)| x.map(|x| ((i + 1) as f64, x)))
                .collect();
            let mut chart = Chart::new(520, 260, "POM", "energy fraction");
            chart
                .series
                .push(Series::new("energy fraction", pts, 0, Mark::LinePoints));
            body.push_str(&figure(
                plot::render(&chart),
                "POD: energy fraction per POM (pod.parquet)",
                "",
            ));
        }
    }
    generic(dir, "actuator_layout.parquet", settings, &mut body);
    generic(dir, "hybrid_prototype.parquet", settings, &mut body);
    generic(dir, "pod.parquet", settings, &mut body);
    body
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
