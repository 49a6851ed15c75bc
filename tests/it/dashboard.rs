//! `quaketwin dashboard DATASET --out SITE` (issue 35 item 3) on a dataset
//! of three structures and four events (two with a stated position), one
//! with a history folder: opened in headless Chromium (the helper of
//! `report_browser`; SKIPPED when Chromium is absent), every structure is
//! listed once, the colours are those of the `assessment` tables (the
//! latest event's, by origin time), the structures come most urgent first,
//! the sorting script reorders them, every link of every page resolves to a
//! file of the site, the map has a dot per positioned structure; a second
//! generation after an event left the dataset removes its report.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::column_str;
use crate::report_browser::{attribute, rendered_dom, CHROMIUM};

use crate::watch::{copy_dir, root, run_into_dataset};

/// Copies a sample folder as event `name`, editing its manifest with `edit`.
fn event(events: &Path, sample: &str, name: &str, edit: impl Fn(String) -> String) -> PathBuf {
    let dir = events.join(name);
    copy_dir(&root().join("sample-records").join(sample), &dir);
    let manifest = dir.join("event.toml");
    if manifest.exists() {
        let text = std::fs::read_to_string(&manifest).unwrap();
        std::fs::write(&manifest, edit(text)).unwrap();
    }
    dir
}

/// Every start tag of `dom` with attribute `name`, as (tag, value).
fn tags_with<'a>(dom: &'a str, tag: &str, name: &str) -> Vec<(&'a str, &'a str)> {
    dom.match_indices(&format!("<{tag}"))
        .map(|(i, _)| &dom[i..])
        .filter_map(|t| attribute(t, name).map(|v| (t, v)))
        .collect()
}

/// Every `href` of `html` resolves to a file, relative to `page`'s folder.
fn check_links(html: &str, page: &Path) -> usize {
    let dir = page.parent().unwrap();
    let mut n = 0;
    for (_, href) in tags_with(html, "a", "href") {
        assert!(
            !href.contains("://") && !href.starts_with('/'),
            "{}: link {href} leaves the site",
            page.display()
        );
        let target = dir.join(href.split('#').next().unwrap());
        assert!(
            target.is_file(),
            "{}: link {href} does not resolve",
            page.display()
        );
        n += 1;
    }
    n
}

/// The (structure, event) → rating of the dataset's assessment tables, and
/// per structure its latest event by origin time (event.json).
fn truth(dataset: &Path) -> (BTreeMap<String, String>, BTreeMap<String, String>) {
    let mut rating = BTreeMap::new();
    let mut latest: BTreeMap<String, (String, String)> = BTreeMap::new();
    for s in std::fs::read_dir(dataset.join("tables/assessment"))
        .unwrap()
        .flatten()
    {
        let structure = s.file_name().to_string_lossy()["structure=".len()..].to_string();
        for e in std::fs::read_dir(s.path()).unwrap().flatten() {
            let ev = e.file_name().to_string_lossy()["event=".len()..].to_string();
            let r = column_str(&e.path().join("part-0.parquet"), "rating");
            rating.insert(format!("{structure}/{ev}"), r[0].clone());
            let json: serde_json::Value = serde_json::from_str(
                &std::fs::read_to_string(
                    dataset
                        .join("runs")
                        .join(s.file_name())
                        .join(e.file_name())
                        .join("event.json"),
                )
                .unwrap(),
            )
            .unwrap();
            let origin = json["origin_time"].as_str().unwrap_or("").to_string();
            let l = latest.entry(structure.clone()).or_default();
            if (origin.clone(), ev.clone()) > *l {
                *l = (origin, ev);
            }
        }
    }
    let latest = latest.into_iter().map(|(s, (_, e))| (s, e)).collect();
    (rating, latest)
}

fn rank(priority: &str) -> u8 {
    match priority {
        "high" => 4,
        "medium-high" => 3,
        "medium" => 2,
        "low" => 1,
        _ => 0,
    }
}

#[test]
fn dashboard_lists_every_structure_with_its_colour_and_links_that_resolve() {
    let work = tempfile::tempdir().unwrap();
    let events = work.path().join("events");
    let dataset = work.path().join("dataset");
    let site = work.path().join("site");
    let pipeline = crate::watch::quick_pipeline(work.path());
    let at = |lat: f64, lon: f64| {
        move |t: String| {
            t.replacen(
                "[structure]\n",
                &format!("[structure]\nlatitude_deg = {lat}\nlongitude_deg = {lon}\n"),
                1,
            )
        }
    };
    let evs = vec![
        event(
            &events,
            "synthetic-4storey-quake",
            "quake-2026",
            at(34.05, -118.25),
        ),
        // The same building, a later event: the latest by origin time.
        event(&events, "synthetic-4storey-quake", "quake-2027", |t| {
            at(34.05, -118.25)(t.replace("2026-01-15T10:20:30Z", "2027-03-01T00:00:00Z"))
        }),
        event(
            &events,
            "synthetic-2storey-yielding",
            "yield-2026",
            at(34.20, -118.50),
        ),
        {
            let dir = events.join("nsmp-2026");
            copy_dir(&root().join("sample-records/synthetic-12storey-nsmp"), &dir);
            dir
        },
    ];
    run_into_dataset(&pipeline, &evs, &dataset);
    // A history for one structure (what `quaketwin history` will write):
    // its page is copied into the site, its tables shown.
    let history = dataset.join("history/structure=sample-4-storey-frame");
    std::fs::create_dir_all(history.join("history_events")).unwrap();
    std::fs::write(
        history.join("history.html"),
        "<!DOCTYPE html><title>history</title><p>h</p>",
    )
    .unwrap();
    std::fs::copy(
        dataset.join(
            "tables/assessment/structure=sample-4-storey-frame/event=quake-2026/part-0.parquet",
        ),
        history.join("history_events/history_events.parquet"),
    )
    .unwrap();

    let dash = Command::new(env!("CARGO_BIN_EXE_quaketwin"))
        .args(["dashboard"])
        .arg(&dataset)
        .arg("--out")
        .arg(&site)
        .arg("--json")
        .output()
        .unwrap();
    assert!(
        dash.status.success(),
        "{}",
        String::from_utf8_lossy(&dash.stderr)
    );
    let written: serde_json::Value = serde_json::from_slice(&dash.stdout).unwrap();
    assert_eq!(written["structures"], 3);
    assert_eq!(written["events"], 4);

    let (rating, latest) = truth(&dataset);
    let structures: BTreeSet<String> = latest.keys().cloned().collect();
    assert_eq!(structures.len(), 3, "{structures:?}");
    assert_eq!(latest["sample-4-storey-frame"], "quake-2027");

    // site.json says what the pages show.
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(site.join("site.json")).unwrap()).unwrap();
    for s in doc["structures"].as_array().unwrap() {
        let key = s["structure"].as_str().unwrap();
        let ev = &latest[key];
        assert_eq!(s["latest_event"], ev.as_str(), "{key}");
        assert_eq!(
            s["latest_rating"],
            rating[&format!("{key}/{ev}")].as_str(),
            "{key}"
        );
        for f in doc["files"].as_array().unwrap() {
            assert!(site.join(f.as_str().unwrap()).is_file(), "{f}");
        }
    }
    // Every page's links resolve (in the files as written).
    let mut pages = vec![site.join("index.html")];
    for s in &structures {
        pages.push(site.join(format!("structures/{s}.html")));
    }
    let links: usize = pages
        .iter()
        .map(|p| check_links(&std::fs::read_to_string(p).unwrap(), p))
        .sum();
    // index: 3 structures + 2 map dots; pages: back link + reports (4) + history (1).
    assert_eq!(links, 5 + 3 + 4 + 1, "links");
    let structure_page =
        std::fs::read_to_string(site.join("structures/sample-4-storey-frame.html")).unwrap();
    assert!(structure_page.contains("history_events/history_events.parquet"));
    assert!(site.join("history/sample-4-storey-frame.html").is_file());

    if !Path::new(CHROMIUM).exists() {
        eprintln!("SKIPPED (browser part): {CHROMIUM} not installed (apt-get install -y chromium; .ci/run installs it)");
    } else {
        let dom = rendered_dom(&site.join("index.html"));
        let rows = tags_with(&dom, "tr", "data-structure");
        let listed: Vec<&str> = rows.iter().map(|(_, v)| *v).collect();
        assert_eq!(
            listed.iter().copied().collect::<BTreeSet<_>>(),
            structures.iter().map(String::as_str).collect(),
            "structures listed"
        );
        assert_eq!(listed.len(), 3, "each structure once: {listed:?}");
        let mut ranks = Vec::new();
        for (tag, key) in &rows {
            let expected = &rating[&format!("{key}/{}", latest[*key])];
            assert_eq!(
                attribute(tag, "data-rating"),
                Some(expected.as_str()),
                "{key}"
            );
            // The badge drawn in the row says the same colour.
            let row = &tag[..tag.find("</tr>").unwrap()];
            assert!(row.contains(&format!("{expected}</span>")), "{key}: {row}");
            ranks.push(rank(attribute(tag, "data-priority").unwrap()));
        }
        assert!(
            ranks.windows(2).all(|w| w[0] >= w[1]),
            "most urgent first: {ranks:?}"
        );
        // The map: one linked dot per positioned structure, coloured as its row.
        let dots = tags_with(&dom, "a", "data-rating");
        let dots: Vec<_> = dots.iter().filter(|(t, _)| t.contains("<circle")).collect();
        assert_eq!(dots.len(), 2, "map dots");
        for (tag, r) in dots {
            let key = attribute(tag, "data-structure").unwrap();
            assert_eq!(*r, rating[&format!("{key}/{}", latest[key])].as_str());
        }
        check_links(&dom, &site.join("index.html"));
        // Each structure page, rendered: one row per event, its colour the table's.
        for s in &structures {
            let page = site.join(format!("structures/{s}.html"));
            let dom = rendered_dom(&page);
            check_links(&dom, &page);
            for (tag, ev) in tags_with(&dom, "tr", "data-event") {
                assert_eq!(
                    attribute(tag, "data-rating"),
                    Some(rating[&format!("{s}/{ev}")].as_str()),
                    "{s}/{ev}"
                );
            }
            assert_eq!(
                tags_with(&dom, "tr", "data-event").len(),
                rating
                    .keys()
                    .filter(|k| k.starts_with(&format!("{s}/")))
                    .count()
            );
        }
        // The sorting script: a click on "Structure", then on "Priority".
        let harness = site.join("sorted.html");
        let page = std::fs::read_to_string(site.join("index.html")).unwrap();
        let clicks = "<script>var h=document.querySelectorAll('#structures th');\
            h[2].click();var a=[].map.call(document.querySelectorAll('#structures tbody tr'),function(r){return r.cells[2].textContent;});\
            h[1].click();var b=[].map.call(document.querySelectorAll('#structures tbody tr'),function(r){return r.getAttribute('data-priority');});\
            document.body.setAttribute('data-by-name',JSON.stringify(a));document.body.setAttribute('data-by-priority',JSON.stringify(b));</script></body>";
        std::fs::write(&harness, page.replace("</body>", clicks)).unwrap();
        let dom = rendered_dom(&harness);
        let body = &dom[dom.find("<body").unwrap()..];
        let by_name: Vec<String> = serde_json::from_str(
            &attribute(body, "data-by-name")
                .unwrap()
                .replace("&quot;", "\""),
        )
        .unwrap();
        let mut sorted = by_name.clone();
        sorted.sort();
        sorted.reverse(); // the first click sorts descending
        assert_eq!(by_name, sorted, "sorted by name");
        let by_priority: Vec<String> = serde_json::from_str(
            &attribute(body, "data-by-priority")
                .unwrap()
                .replace("&quot;", "\""),
        )
        .unwrap();
        let r: Vec<u8> = by_priority.iter().map(|p| rank(p)).collect();
        assert!(
            r.windows(2).all(|w| w[0] >= w[1]),
            "sorted by priority: {by_priority:?}"
        );
        std::fs::remove_file(&harness).unwrap();
    }

    // An event leaves the dataset: the next generation drops its report.
    let gone = "structure=sample-4-storey-frame/event=quake-2026";
    for d in [
        "runs",
        "assessment",
        "channels",
        "drift",
        "frequency_track",
        "samples",
        "samples_as_recorded",
        "spectra",
    ] {
        let p = dataset.join(d).join(gone);
        if p.exists() {
            std::fs::remove_dir_all(&p).unwrap();
        }
    }
    let again = Command::new(env!("CARGO_BIN_EXE_quaketwin"))
        .args(["-q", "dashboard"])
        .arg(&dataset)
        .arg("--out")
        .arg(&site)
        .output()
        .unwrap();
    assert!(
        again.status.success(),
        "{}",
        String::from_utf8_lossy(&again.stderr)
    );
    assert!(!site
        .join("reports/sample-4-storey-frame/quake-2026.html")
        .exists());
    assert!(site
        .join("reports/sample-4-storey-frame/quake-2027.html")
        .is_file());
}
