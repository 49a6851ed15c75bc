//! `quaketwin dashboard DATASET --out SITE`: the fleet as a static site —
//! no server, so it can be served from any web server or object store, or
//! opened from disk:
//!
//! ```text
//! SITE/index.html                  the map and the structures, most urgent first
//! SITE/structures/<S>.html         one structure: latest assessment, history, events
//! SITE/reports/<S>/<E>.html        each event's report.html (hard link, else copy)
//! SITE/history/<S>.html            the structure's history.html, when there is one
//! SITE/site.json                   what the pages show, as data, and the site's files
//! ```
//!
//! Reports are put into the site (hard links where the file system allows,
//! copies elsewhere) rather than linked into the dataset, so that the site
//! is whole by itself: every link resolves inside `SITE`.  Every file is
//! written atomically (the atomic writer; reports and histories by link and
//! rename), so a reader of a site being regenerated sees each page whole,
//! old or new; `site.json` is written last, and files an earlier generation
//! listed and this one does not (an event or structure removed from the
//! dataset) are then removed.  `quaketwin watch` regenerates the site after
//! each event.

pub mod map;
pub mod pages;
pub mod scan;

use std::path::{Component, Path};

use serde_json::json;

use crate::error::{Error, Result};
use crate::sinks::atomic::write_bytes_atomically;
use crate::sinks::dataset::{history_dir, link_or_copy_atomically, partition_value};
use scan::StructureView;

/// The site's index of itself.
pub const SITE_FILE: &str = "site.json";
/// Layout version of `site.json`.
pub const SITE_VERSION: u32 = 1;
/// Rows of a history table shown on a structure page.
const MAX_HISTORY_ROWS: usize = 200;
/// Largest `site.json` read back (the list of an earlier generation's files).
const MAX_SITE_JSON_BYTES: u64 = 256 << 20;

/// The page of the structure whose partition value is `structure`, relative to the site.
pub fn structure_page(structure: &str) -> String {
    format!("structures/{}.html", partition_value(structure))
}

/// What [`write_site`] wrote.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SiteWritten {
    pub site: String,
    pub structures: usize,
    pub events: usize,
    /// Files of the site, relative to it (`site.json` included).
    pub files: usize,
}

/// Order of the index: most urgent latest priority first, then the most
/// recent latest event, then the key.
fn urgency_order(structures: &[StructureView]) -> Vec<&StructureView> {
    let mut order: Vec<&StructureView> = structures.iter().collect();
    order.sort_by(|a, b| {
        let rank = |s: &StructureView| {
            pages::priority_rank(
                s.latest()
                    .assessment
                    .as_ref()
                    .and_then(|x| x.priority.as_deref()),
            )
        };
        rank(b)
            .cmp(&rank(a))
            .then(b.latest().time_key().0.cmp(&a.latest().time_key().0))
            .then(a.key.cmp(&b.key))
    });
    order
}

/// Writes the site of the dataset at `dataset` into `site`.
pub fn write_site(dataset: &Path, site: &Path) -> Result<SiteWritten> {
    let structures = scan::scan(dataset)?;
    let order = urgency_order(&structures);
    std::fs::create_dir_all(site).map_err(|e| Error::io(site, e))?;
    let mut files: Vec<String> = Vec::new();
    let mut all_links = Vec::with_capacity(order.len());
    for s in &order {
        let mut reports = Vec::with_capacity(s.events.len());
        for e in &s.events {
            let copied = match &e.report {
                Some(src) => {
                    let rel = format!("reports/{}/{}.html", s.key, partition_value(&e.event));
                    place(src, &site.join(&rel))?;
                    files.push(rel.clone());
                    Some(rel)
                }
                None => None,
            };
            reports.push(copied);
        }
        let hdir = history_dir(dataset, &s.key);
        let history = if hdir.join("history.html").is_file() {
            let rel = format!("history/{}.html", s.key);
            place(&hdir.join("history.html"), &site.join(&rel))?;
            files.push(rel.clone());
            Some(rel)
        } else {
            None
        };
        let links = pages::Links {
            page: structure_page(&s.key),
            history,
            reports,
        };
        let page = pages::structure(s, &links, &history_tables(&hdir), "../");
        write_bytes_atomically(&site.join(&links.page), page.as_bytes())?;
        files.push(links.page.clone());
        all_links.push(links);
    }
    let places: Vec<map::Place> = order
        .iter()
        .zip(&all_links)
        .filter_map(|(s, l)| {
            let (lat, lon) = s.position()?;
            Some(map::Place {
                key: s.key.clone(),
                label: s.display_name(),
                latitude_deg: lat,
                longitude_deg: lon,
                rating: s.latest().rating().to_string(),
                href: l.page.clone(),
            })
        })
        .collect();
    let index = pages::index(
        &order,
        &all_links,
        map::svg(&places),
        &dataset.display().to_string(),
    );
    write_bytes_atomically(&site.join("index.html"), index.as_bytes())?;
    files.push("index.html".into());
    files.push(SITE_FILE.into());
    files.sort();

    let events: usize = order.iter().map(|s| s.events.len()).sum();
    let stale = earlier_files(site)
        .into_iter()
        .filter(|f| !files.contains(f))
        .collect::<Vec<_>>();
    let doc = site_json(&order, &all_links, &files);
    let text = serde_json::to_string_pretty(&doc)
        .map_err(|e| Error::output(site.join(SITE_FILE), e.to_string()))?;
    write_bytes_atomically(&site.join(SITE_FILE), (text + "\n").as_bytes())?;
    for f in stale {
        remove_stale(site, &f);
    }
    Ok(SiteWritten {
        site: site.display().to_string(),
        structures: order.len(),
        events,
        files: files.len(),
    })
}

/// Puts `src` (a report, a history page) at `to` in the site: a hard link,
/// else a copy — skipped when `to` is already a copy of it (same size, made
/// after `src` was last written), so that a site on another file system is
/// not copied whole again after every event.
fn place(src: &Path, to: &Path) -> Result<()> {
    let modified = |p: &Path| std::fs::metadata(p).and_then(|m| Ok((m.len(), m.modified()?)));
    if let (Ok((n, made)), Ok((m, written))) = (modified(to), modified(src)) {
        let regular = std::fs::symlink_metadata(to).is_ok_and(|m| m.is_file());
        if regular && n == m && made >= written {
            return Ok(());
        }
    }
    link_or_copy_atomically(src, to)
}

/// The history tables of a structure (`history_modes`, `history_events` in
/// its history folder), each as an HTML table; a table that does not read
/// says why.
fn history_tables(dir: &Path) -> Vec<(String, String)> {
    use crate::vocab::tables::{HISTORY_EVENTS, HISTORY_MODES};
    let mut found: Vec<(String, std::path::PathBuf)> = [HISTORY_EVENTS, HISTORY_MODES]
        .iter()
        .map(|t| (t.file.to_string(), t.locate(dir)))
        .filter(|(_, p)| p.is_file())
        .collect();
    found.sort();
    found
        .into_iter()
        .map(|(n, path)| {
            let html = match crate::report::table::load(&path, None) {
                Ok(t) => crate::report::whole_table(&t, MAX_HISTORY_ROWS),
                Err(e) => format!(
                    "<p class=\"note\">unreadable: {}</p>",
                    crate::report::escape(&e.to_string())
                ),
            };
            (n, html)
        })
        .collect()
}

/// `site.json`: what the index and the structure pages show.
fn site_json(
    order: &[&StructureView],
    links: &[pages::Links],
    files: &[String],
) -> serde_json::Value {
    let structures: Vec<serde_json::Value> = order
        .iter()
        .zip(links)
        .map(|(s, l)| {
            let latest = s.latest();
            let events: Vec<serde_json::Value> = s
                .events
                .iter()
                .zip(&l.reports)
                .map(|(e, r)| {
                    let a = e.assessment.as_ref();
                    json!({
                        "event": e.event,
                        "name": e.name,
                        "origin_time": e.origin_ns.map(crate::vocab::format_epoch_ns),
                        "magnitude": e.magnitude,
                        "rating": a.map(|a| a.rating.clone()),
                        "priority": a.and_then(|a| a.priority.clone()),
                        "damage_state": a.and_then(|a| a.damage_state.clone()),
                        "frequencies_hz": e.modes.iter().map(|m| m.frequency_hz).collect::<Vec<_>>(),
                        "report": r,
                    })
                })
                .collect();
            let a = latest.assessment.as_ref();
            json!({
                "structure": s.key,
                "name": s.display_name(),
                "kind": s.kind(),
                "latitude_deg": s.position().map(|p| p.0),
                "longitude_deg": s.position().map(|p| p.1),
                "page": l.page,
                "history": l.history,
                "latest_event": latest.event,
                "latest_rating": a.map(|a| a.rating.clone()),
                "latest_priority": a.and_then(|a| a.priority.clone()),
                "events": events,
            })
        })
        .collect();
    json!({
        "site_version": SITE_VERSION,
        "structures": structures,
        "files": files,
    })
}

/// The files an earlier generation's `site.json` lists (none when absent
/// or unreadable: then nothing is removed).
fn earlier_files(site: &Path) -> Vec<String> {
    let Ok(text) = crate::input_file::read_to_string(&site.join(SITE_FILE), MAX_SITE_JSON_BYTES)
    else {
        return Vec::new();
    };
    serde_json::from_str::<serde_json::Value>(&text)
        .ok()
        .and_then(|d| d["files"].as_array().cloned())
        .unwrap_or_default()
        .iter()
        .filter_map(|f| f.as_str().map(str::to_string))
        .collect()
}

/// Removes a site file no longer listed: only a plain relative path inside
/// the site naming a regular file (a hand-edited `site.json` cannot make
/// it remove anything else), then its folder when empty.
fn remove_stale(site: &Path, rel: &str) {
    let p = Path::new(rel);
    if !p.components().all(|c| matches!(c, Component::Normal(_))) {
        return;
    }
    let full = site.join(p);
    if std::fs::symlink_metadata(&full).is_ok_and(|m| m.is_file())
        && std::fs::remove_file(&full).is_ok()
    {
        if let Some(parent) = full.parent() {
            if parent != site {
                let _ = std::fs::remove_dir(parent);
            }
        }
    }
}
