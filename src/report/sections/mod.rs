//! The report's sections, in page order, one file each.  Each section renders
//! what its files hold and says plainly when a file is absent or unreadable.
//! This file holds the page and the helpers the sections share.

mod actuators;
mod appendix;
pub(crate) mod assessment;
mod channels;
mod compare_test;
mod damage;
mod design;
mod drift;
mod event;
mod fourier;
mod hysteresis;
mod lab;
mod layout;
mod loops;
mod modal;
mod mode_shapes;
mod rating;
mod rehearsal;
mod spectra;
mod summary;
mod test_design;
mod time_histories;
mod title;
mod twin;

use std::collections::BTreeMap;
use std::path::Path;

use serde_json::Value;

use super::html::{absent, escape, note, unreadable, Cell};
use super::table::{self, Table};
use super::{Assessment, Rating, ReportSettings};
use crate::vocab::schema::{ColumnSpec, TableSchema};
use crate::vocab::tables;
pub(crate) use assessment::read_assessment;
pub use loops::segment_levels;

/// Output files the report reads, with the stage that writes each and what
/// the page calls it (every table of `vocab::tables`, the run's JSON/TOML
/// files and the page itself).  File names appear on the page only in the
/// appendix; sections name an output in words.
const OUTPUTS: [(&str, &str, &str); 34] = [
    ("event.json", "ingest", "event inventory"),
    (tables::SAMPLES.file, "condition", "conditioned records"),
    (
        tables::FOURIER.file,
        "condition",
        "Fourier spectra and filter corners",
    ),
    (
        tables::CHANNELS.file,
        "metrics",
        "channel QA and strong-motion metrics",
    ),
    (tables::SPECTRA.file, "metrics", "response spectra"),
    (tables::DRIFT.file, "metrics", "inter-storey drift"),
    (tables::STABILIZATION.file, "modal", "stabilisation diagram"),
    (tables::MODES.file, "modal", "identified modes"),
    (tables::MODAL_SPECTRUM.file, "modal", "modal spectrum"),
    (
        tables::FREQUENCY_SHIFTS.file,
        "modal (with a reference event)",
        "frequency shifts against a reference event",
    ),
    (
        tables::HYSTERESIS_FIT.file,
        "hysteresis",
        "force–drift loops",
    ),
    (tables::BOUC_WEN.file, "hysteresis", "Bouc-Wen parameters"),
    (
        tables::BOUC_WEN_INSTANTANEOUS.file,
        "hysteresis",
        "instantaneous Bouc-Wen estimates",
    ),
    (tables::DAMAGE.file, "damage", "damage index ι(t)"),
    (tables::TWIN_UPDATE.file, "update", "twin-update candidates"),
    (
        tables::TWIN_MODES.file,
        "update",
        "twin modes before and after the update",
    ),
    ("twin_updated.toml", "update", "updated twin"),
    (tables::ASSESSMENT.file, "assess", "assessment"),
    (
        tables::FREQUENCY_TRACK.file,
        "assess",
        "apparent-frequency track",
    ),
    (tables::POD.file, "design", "proper orthogonal modes (POD)"),
    (tables::ACTUATOR_LAYOUT.file, "design", "actuator layout"),
    (
        tables::REDUCTION_VALIDATION.file,
        "design",
        "reduction validation",
    ),
    (
        tables::INTERFACE_REFINEMENT.file,
        "design",
        "interface refinement",
    ),
    (
        tables::HYBRID_PROTOTYPE.file,
        "design",
        "Craig–Bampton prototype",
    ),
    ("rehearsal_model.json", "design", "rehearsal model"),
    (
        tables::REHEARSAL_SUMMARY.file,
        "rehearse",
        "rehearsal sweep",
    ),
    (
        tables::REHEARSAL.file,
        "rehearse",
        "rehearsal time histories",
    ),
    (
        tables::COMPARE_TEST_SUMMARY.file,
        "compare-test",
        "hybrid test against its rehearsal",
    ),
    (
        tables::COMPARE_TEST_ACTUATORS.file,
        "compare-test",
        "tracking per actuator",
    ),
    (
        tables::COMPARE_TEST.file,
        "compare-test",
        "logged and rehearsed time histories",
    ),
    (
        tables::LAB_IDENTIFICATION.file,
        "lab_hysteresis",
        "lab specimen identification",
    ),
    (
        tables::LAB_FIT.file,
        "lab_hysteresis",
        "lab force–displacement loops",
    ),
    (
        tables::LAB_CYCLES.file,
        "lab_hysteresis",
        "lab dissipated energy per cycle",
    ),
    ("report.html", "report", "this report"),
];

/// The files the report reads (all of [`OUTPUTS`] but the page itself).
pub(super) fn files_read() -> Vec<&'static str> {
    OUTPUTS
        .iter()
        .map(|(f, _, _)| *f)
        .filter(|f| *f != "report.html")
        .collect()
}

/// The stage that writes `file` (a table not listed above is named by its
/// declaration's table name, never "?").
fn stage_of(file: &str) -> &'static str {
    OUTPUTS
        .iter()
        .find(|(f, _, _)| *f == file)
        .map(|(_, s, _)| *s)
        .unwrap_or("the stage that writes it")
}

/// What the page calls `file` (its words, never the file name).
pub(super) fn label_of(file: &str) -> &'static str {
    OUTPUTS
        .iter()
        .find(|(f, _, _)| *f == file)
        .map(|(_, _, l)| *l)
        .unwrap_or("output")
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
            body.push_str(&absent(label_of(file), stage_of(file)));
            None
        }
        Loaded::Unreadable(e) => {
            body.push_str(&unreadable(label_of(file), file, e));
            None
        }
        Loaded::Ok(t) if t.rows == 0 => {
            body.push_str(&note(&empty_text(file)));
            None
        }
        Loaded::Ok(t) => {
            let mismatches = t.type_mismatches(declared);
            if !mismatches.is_empty() {
                super::html::diagnostic(&format!(
                    "{file}: {} (shown as found).",
                    mismatches.join("; ")
                ));
            }
            Some(t)
        }
    }
}

/// "No <label>: the stage ran and its table is empty." — an empty output in words.
pub(super) fn empty_text(file: &str) -> String {
    format!(
        "No {}: the {} stage ran and found nothing to tabulate.",
        label_of(file),
        stage_of(file)
    )
}

fn section(id: &str, number: usize, title: &str, body: &str) -> String {
    format!(
        "<section id=\"{id}\"><h2>{number}. {}</h2>\n{body}\n</section>\n",
        escape(title)
    )
}

fn figure(svg: Result<String, String>, caption: &str, legend: &str) -> String {
    figure_with("", svg, caption, legend)
}

/// A figure whose element carries `attributes` (a class or id the browser
/// test and the print stylesheet find it by).
fn figure_with(
    attributes: &str,
    svg: Result<String, String>,
    caption: &str,
    legend: &str,
) -> String {
    let open = if attributes.is_empty() {
        "<figure>".to_string()
    } else {
        format!("<figure {attributes}>")
    };
    match svg {
        Ok(svg) => format!(
            "{open}{svg}{legend}<figcaption>{}</figcaption></figure>",
            escape(caption)
        ),
        Err(e) => note(&format!("Plot \"{caption}\" not drawn: {e}.")),
    }
}

/// Time series as lines on the page's common time axis (min–max decimated
/// to `max_points_per_trace`), with their legend under the chart.
fn time_series_figure(
    mut chart: super::plot::Chart,
    series: Vec<(String, Vec<(f64, f64)>)>,
    time_axis: Option<(f64, f64)>,
    settings: &ReportSettings,
    caption: &str,
) -> String {
    use super::plot::{self, Mark, Series};
    chart.x_range = time_axis;
    for (i, (label, pts)) in series.into_iter().enumerate() {
        chart.series.push(Series::new(
            label,
            plot::decimate_min_max(&pts, settings.max_points_per_trace),
            i,
            Mark::Line,
        ));
    }
    let legend = plot::legend(&chart.series);
    figure(plot::render(&chart), caption, &legend)
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

/// The section ids and titles, in page order: the rating first, then the
/// one-screen summary, the evidence section by section, and the appendix.
pub const SECTIONS: [(&str, &str); 14] = [
    ("rating", "Overall rating"),
    ("summary", "Summary"),
    ("event", "Event and structure"),
    ("channels", "Channels: QA and strong-motion metrics"),
    ("fourier", "Fourier spectra and filter corners"),
    ("spectra", "Response spectra"),
    ("time-histories", "Acceleration time histories"),
    ("drift", "Inter-storey drift"),
    ("modal", "Modal identification"),
    ("hysteresis", "Bouc-Wen fit and hysteresis loops"),
    ("damage", "Damage index ι(t)"),
    ("twin", "Digital-twin update"),
    ("test-design", "Hybrid-test design"),
    ("appendix", "Appendix: processing history and output files"),
];

/// The tables several sections read, loaded once.
struct Outputs {
    channels: Loaded,
    drift: Loaded,
    damage: Loaded,
    modes: Loaded,
    shifts: Loaded,
    twin_update: Loaded,
    twin_modes: Loaded,
    /// Common time axis of the time-history charts: 0 (each record's first
    /// sample) to the longest record's duration, s.
    time_axis: Option<(f64, f64)>,
}

/// Every rated value of the outputs in `dir` (the drift and damage
/// criteria), as the page rates them.
pub fn assessments(dir: &Path, settings: &ReportSettings) -> Vec<Assessment> {
    let mut out = Vec::new();
    drift::drift_section(&load(dir, &tables::DRIFT, None), settings, &mut out);
    let o = Outputs {
        channels: Loaded::Absent(None),
        drift: Loaded::Absent(None),
        damage: load(dir, &tables::DAMAGE, None),
        modes: Loaded::Absent(None),
        shifts: Loaded::Absent(None),
        twin_update: Loaded::Absent(None),
        twin_modes: Loaded::Absent(None),
        time_axis: None,
    };
    damage::damage_section(&o, settings, &mut out);
    // Table checks are a page's (its appendix): none kept from here.
    let _ = super::html::take_diagnostics();
    out
}

/// The whole page: the test-design report for a run of the test-design
/// pipeline (`test_design::applies`), else the post-earthquake report.
pub fn page(dir: &Path, settings: &ReportSettings) -> String {
    // Table checks of an earlier page (or of `assessments`) are not this one's.
    let _ = super::html::take_diagnostics();
    if compare_test::applies(dir) {
        return compare_test::page(dir, settings);
    }
    let event = event::read_event(dir);
    if test_design::applies(dir) {
        return test_design::page(dir, &event, settings);
    }
    if lab::applies(dir) {
        return lab::page(dir, &event, settings);
    }
    let channels = load(dir, &tables::CHANNELS, None);
    let time_axis = time_axis(&channels);
    let o = Outputs {
        drift: load(dir, &tables::DRIFT, None),
        damage: load(dir, &tables::DAMAGE, None),
        modes: load(dir, &tables::MODES, None),
        shifts: load(dir, &tables::FREQUENCY_SHIFTS, None),
        twin_update: load(dir, &tables::TWIN_UPDATE, None),
        twin_modes: load(dir, &tables::TWIN_MODES, None),
        channels,
        time_axis,
    };

    let mut assessments: Vec<Assessment> = Vec::new();
    let mut event_html = String::new();
    if let Ok(ev) = &event {
        event_html.push_str(&layout::layout_figure(ev));
    }
    event_html.push_str(&event::event_section(&event));
    let channel_table = channels::channel_section(&o.channels, &event);
    let fourier_html = fourier::fourier_section(dir);
    let spectra = spectra::spectra_section(dir, &o.channels);
    let histories = time_histories::time_history_section(dir, &o, &event, settings);
    let drift_html = drift::drift_section(&o.drift, settings, &mut assessments);
    let modal = modal::modal_section(dir, &o, settings);
    let hysteresis = hysteresis::hysteresis_section(dir, &o, settings);
    let damage_html = damage::damage_section(&o, settings, &mut assessments);
    let twin = twin::twin_section(&o, settings);
    let design = design::design_section(dir, settings);
    let rating = rating::rating_section(dir, &assessments, &o, settings);
    let summary = summary::summary_section(dir, &event, &o, settings);
    let appendix = appendix::appendix_section(dir, &event, &o, settings);

    let event_name = match &event {
        Ok(v) => v.get("name").and_then(Value::as_str).map(str::to_string),
        Err(_) => None,
    };
    let title = settings.title.clone().unwrap_or_else(|| match &event_name {
        Some(n) => format!("Post-earthquake report — {n}"),
        None => "Post-earthquake report".to_string(),
    });
    let mut page = String::with_capacity(1 << 20);
    page.push_str(&page_head(&title));
    page.push_str(&page_header(dir, &event, &title, settings, &SECTIONS));
    let bodies = [
        rating,
        summary,
        event_html,
        channel_table,
        fourier_html,
        spectra,
        histories,
        drift_html,
        modal,
        hysteresis,
        damage_html,
        twin,
        design,
        appendix,
    ];
    for (i, ((id, title), body)) in SECTIONS.iter().zip(bodies).enumerate() {
        page.push_str(&section(id, i + 1, title, &body));
    }
    page.push_str("</main>\n<footer><p>Every number on this page is read from the outputs of the run in the directory above (the appendix lists them). Ratings: see docs/report.md.</p></footer>\n</body>\n</html>\n");
    page
}

/// The page's header: title, the title block (structure, event, date,
/// software) beside the review block (to sign), the output directory and
/// the table of contents; opens `<main>`.
pub(super) fn page_header(
    dir: &Path,
    event: &Result<Value, String>,
    title: &str,
    settings: &ReportSettings,
    sections: &[(&str, &str)],
) -> String {
    let toc = sections
        .iter()
        .enumerate()
        .map(|(i, (id, t))| format!("<a href=\"#{id}\">{}. {}</a>", i + 1, escape(t)))
        .collect::<Vec<_>>()
        .join(" ");
    format!(
        "<header><h1>{}</h1><div class=\"title-grid\">{}{}</div><p class=\"meta\">Output directory: <code>{}</code></p><nav>{toc}</nav></header>\n<main>\n",
        escape(title),
        title::title_block(dir, event, settings),
        title::review_block(),
        escape(&dir.display().to_string()),
    )
}

/// 0 to the longest record (npts / sampling rate of channels/channels.parquet): every
/// time axis of the page starts where the records start.
fn time_axis(channels: &Loaded) -> Option<(f64, f64)> {
    let Loaded::Ok(t) = channels else {
        return None;
    };
    let (npts, rate) = (
        t.number(tables::channels::NPTS.name)?,
        t.number(tables::channels::SAMPLING_RATE_HZ.name)?,
    );
    let end = npts
        .iter()
        .zip(rate)
        .filter_map(|(n, r)| Some((n.as_ref()? - 1.0) / r.as_ref()?))
        .filter(|d| d.is_finite() && *d > 0.0)
        .fold(0.0f64, f64::max);
    (end > 0.0).then_some((0.0, end))
}

/// channel id → (direction, level) from channels/channels.parquet.
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

/// The start of a self-contained page up to `<body>`: no network at all
/// (the policy blocks every fetch), styles inline.
pub(crate) fn page_head(title: &str) -> String {
    head(title, "")
}

/// [`page_head`] for a page with an inline script of its own (the fleet
/// dashboard's table sorting): still no network.
pub fn page_head_with_script(title: &str) -> String {
    head(title, " script-src 'unsafe-inline';")
}

fn head(title: &str, script_policy: &str) -> String {
    let mut page = String::new();
    page.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n");
    page.push_str(&format!("<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; style-src 'unsafe-inline';{script_policy} img-src data:\"/>\n"));
    page.push_str("<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"/>\n");
    page.push_str(&format!("<title>{}</title>\n", escape(title)));
    page.push_str(&format!("<style>{CSS}</style>\n</head>\n<body>\n"));
    page
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
.r-orange{background:#e69f00;color:#000}
.r-red{background:#d55e00;color:#fff}
.rating-box{border:2px solid #333;border-radius:6px;padding:8px 14px;margin:8px 0;max-width:800px}
.rating-box.r-green,.rating-box.r-yellow,.rating-box.r-orange,.rating-box.r-red{background:none;color:var(--fg)}
.rating-box.r-orange{border-color:#e69f00}
.rating-box.r-green{border-color:#009e73}
.rating-box.r-yellow{border-color:#c8b800}
.rating-box.r-red{border-color:#d55e00}
.rating-box .big{font-size:20px;margin:2px 0}
.rating-box.r-none{border-color:#999;background:var(--bg2)}
.title-grid{display:grid;grid-template-columns:minmax(0,1.5fr) minmax(0,1fr);gap:6px 24px;align-items:start;margin:4px 0}
dl.title-block{grid-template-columns:max-content 1fr;font-size:13px}
table.review-block{width:100%}
table.review-block td.sign{height:26px;min-width:70px}
svg.layout,svg.actuators{max-width:100%;height:auto;display:block}
footer{margin-top:24px;border-top:1px solid var(--line);color:var(--muted);font-size:12px}
.lead{font-size:15px;margin:4px 0 8px}
.glance{display:grid;grid-template-columns:repeat(auto-fill,minmax(300px,1fr));gap:6px 18px;align-items:start}
.card.wide{grid-column:span 2}
#summary-storeys td.num{white-space:nowrap}
.card h3{margin:6px 0 2px}
.card table{margin:2px 0}
ul.not-identifiable li{margin:4px 0}
details summary{cursor:pointer;color:#0b5394;font-size:13px}
@page{size:A4;margin:12mm 11mm}
@media print{
body{max-width:none;font-size:10.5px;padding:0}
nav,footer{display:none}
header{border-bottom:1px solid var(--fg)}
h1{font-size:17px;margin:0 0 2px}
h2{font-size:14px;margin:12px 0 6px;break-after:avoid;page-break-after:avoid}
h3{font-size:12px;break-after:avoid;page-break-after:avoid}
#event{break-before:page;page-break-before:always}
.test-design-page #event{break-before:auto;page-break-before:auto}
.title-grid{grid-template-columns:minmax(0,1.5fr) minmax(0,1fr)}
dl.title-block{font-size:9.5px}
table.review-block td.sign{height:22px}
table{font-size:9px;break-inside:auto}
thead{display:table-header-group}
tr,figure,.card,.rating-box{break-inside:avoid;page-break-inside:avoid}
th,td{padding:1px 4px}
.scroll{overflow:visible}
.multiples,.grid2{grid-template-columns:repeat(2,minmax(0,1fr))}
.glance{grid-template-columns:repeat(2,minmax(0,1fr))}
ol.history code{font-size:8.5px}
.meta,.note,figcaption,ul.legend,dl.facts{font-size:9.5px}
.lead{font-size:12px}
.rating-box .big{font-size:16px}
.badge,.r-green,.r-yellow,.r-orange,.r-red,.rating-box,th,.absent{-webkit-print-color-adjust:exact;print-color-adjust:exact}
}
"#;
