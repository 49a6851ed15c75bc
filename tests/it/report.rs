//! The post-earthquake report: rendered from a real pipeline run of the
//! sample event, parse-checked, its numbers compared with the Parquet
//! outputs they come from; later-stage sections from fixture tables.  The
//! four sample reports in headless Chromium: `report_browser`.

use std::fs::File;
use std::path::Path;

use arrow_array::cast::AsArray;
use arrow_array::types::{Float64Type, Int64Type};
use arrow_array::Array;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use quaketwin::report::plot::{decimate_min_max, render, Chart, Mark, Series};
use quaketwin::report::{
    self, decimate_curve, escape, format_number, IotaStatistic, Rating, ReportSettings,
};
use quaketwin::sinks::parquet::{write_parquet, TableBuilder};
use quaketwin::Error;

const SECTION_IDS: [&str; 14] = [
    "rating",
    "summary",
    "event",
    "channels",
    "fourier",
    "spectra",
    "time-histories",
    "drift",
    "modal",
    "hysteresis",
    "damage",
    "twin",
    "test-design",
    "appendix",
];

fn manifest() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Runs the post-earthquake pipeline on the bundled sample event.
fn run_sample(out: &Path) {
    quaketwin::commands::run_pipeline(
        &manifest().join("pipelines/post-earthquake.toml"),
        &manifest().join("sample-records/synthetic-4storey-quake"),
        out,
        true,
    )
    .expect("pipeline on the sample event");
}

/// Parquet column → Vec<Option<f64>> (Float64 or Int64), read independently
/// of the report's own loader.
fn parquet_numbers(path: &Path, column: &str) -> Vec<Option<f64>> {
    let reader = ParquetRecordBatchReaderBuilder::try_new(File::open(path).unwrap())
        .unwrap()
        .build()
        .unwrap();
    let mut out = Vec::new();
    for batch in reader {
        let batch = batch.unwrap();
        let a = batch
            .column_by_name(column)
            .unwrap_or_else(|| panic!("{column}"));
        if let Some(f) = a.as_primitive_opt::<Float64Type>() {
            out.extend((0..f.len()).map(|i| (!f.is_null(i)).then(|| f.value(i))));
        } else {
            let n = a.as_primitive::<Int64Type>();
            out.extend((0..n.len()).map(|i| (!n.is_null(i)).then(|| n.value(i) as f64)));
        }
    }
    out
}

fn parquet_strings(path: &Path, column: &str) -> Vec<String> {
    let reader = ParquetRecordBatchReaderBuilder::try_new(File::open(path).unwrap())
        .unwrap()
        .build()
        .unwrap();
    let mut out = Vec::new();
    for batch in reader {
        let batch = batch.unwrap();
        let a = batch.column_by_name(column).unwrap();
        let s = a.as_string::<i32>();
        out.extend((0..s.len()).map(|i| s.value(i).to_string()));
    }
    out
}

fn parse(html: &str) -> roxmltree::Document<'_> {
    let opts = roxmltree::ParsingOptions {
        allow_dtd: true,
        ..Default::default()
    };
    roxmltree::Document::parse_with_options(html, opts).expect("report parses as polyglot HTML")
}

fn node_text(n: roxmltree::Node) -> String {
    n.descendants()
        .filter(|d| d.is_text())
        .filter_map(|d| d.text())
        .collect()
}

fn by_id<'a, 'i>(doc: &'a roxmltree::Document<'i>, id: &str) -> Option<roxmltree::Node<'a, 'i>> {
    doc.descendants().find(|n| n.attribute("id") == Some(id))
}

/// Header names (the column name a heading in words carries as
/// `data-column`, else its text) and rows (cells) of the table with `id`.
fn table_cells<'a, 'i>(
    doc: &'a roxmltree::Document<'i>,
    id: &str,
) -> (Vec<String>, Vec<Vec<roxmltree::Node<'a, 'i>>>) {
    let t = by_id(doc, id).unwrap_or_else(|| panic!("table {id} missing"));
    let headers = t
        .descendants()
        .filter(|n| n.has_tag_name("th"))
        .map(|n| {
            n.attribute("data-column")
                .map(str::to_string)
                .unwrap_or_else(|| node_text(n))
        })
        .collect();
    let rows = t
        .descendants()
        .filter(|n| n.has_tag_name("tbody"))
        .flat_map(|b| b.children().filter(|r| r.has_tag_name("tr")))
        .map(|r| r.children().filter(|c| c.has_tag_name("td")).collect())
        .collect();
    (headers, rows)
}

fn section_text(doc: &roxmltree::Document, id: &str) -> String {
    node_text(by_id(doc, id).unwrap_or_else(|| panic!("section {id} missing")))
}

/// True when `path` is a Parquet file holding at least one row (a stage may
/// legitimately write an empty table, e.g. no direction identifiable).
fn has_rows(path: &Path) -> bool {
    let Ok(f) = std::fs::File::open(path) else {
        return false;
    };
    parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(f)
        .map(|b| b.metadata().file_metadata().num_rows() > 0)
        .unwrap_or(false)
}

fn svg_count(node: roxmltree::Node) -> usize {
    node.descendants().filter(|n| n.has_tag_name("svg")).count()
}

#[test]
fn sample_event_report_is_self_contained_and_matches_the_parquet_outputs() {
    let out = tempfile::tempdir().unwrap();
    run_sample(out.path());
    let path = report::write_report(out.path(), &ReportSettings::default()).unwrap();
    assert_eq!(path, out.path().join("report.html"));
    let html = std::fs::read_to_string(&path).unwrap();
    // Deterministic: rendering again gives the same page.
    assert!(
        report::render_report(out.path(), &ReportSettings::default()).unwrap() == html,
        "a second rendering differs from the first"
    );
    let artefacts = manifest().join("target/test-artifacts");
    std::fs::create_dir_all(&artefacts).unwrap();
    std::fs::copy(&path, artefacts.join("sample-report.html")).unwrap();

    // Self-contained: no URLs, scripts, external resources.
    for bad in [
        "http://",
        "https://",
        "<script",
        "<link",
        " src=",
        "url(",
        "@import",
        "@font-face",
    ] {
        assert!(!html.contains(bad), "report contains {bad:?}");
    }
    // The page is well-formed markup (polyglot HTML that parses as XML).
    let doc = parse(&html);
    for id in SECTION_IDS {
        let s = by_id(&doc, id).unwrap_or_else(|| panic!("section {id} missing"));
        assert!(s.has_tag_name("section"), "{id}");
    }
    // In page order, the rating first; the raw processing history only in
    // the appendix, after every other section.
    let order: Vec<&str> = doc
        .descendants()
        .filter(|n| n.has_tag_name("section"))
        .filter_map(|n| n.attribute("id"))
        .collect();
    assert_eq!(order, SECTION_IDS, "section order");
    let history = html
        .find("<ol class=\"history\">")
        .expect("processing history");
    assert!(history > html.find("<section id=\"appendix\">").unwrap());

    let channels_path = out.path().join("channels/channels.parquet");
    let ids = parquet_strings(&channels_path, "channel_id");
    assert_eq!(ids.len(), 10);

    // Plots: one acceleration multiple per channel, a spectra chart per
    // horizontal direction (X, Y), the drift profile.
    let histories = by_id(&doc, "time-histories").unwrap();
    assert_eq!(svg_count(histories), ids.len());
    assert_eq!(svg_count(by_id(&doc, "spectra").unwrap()), 2);
    assert_eq!(svg_count(by_id(&doc, "drift").unwrap()), 1);
    assert!(svg_count(doc.root()) >= ids.len() + 3);
    // Every trace is decimated to at most 2000 points.
    for poly in histories
        .descendants()
        .filter(|n| n.has_tag_name("polyline"))
    {
        let n = poly
            .attribute("points")
            .unwrap_or("")
            .split_whitespace()
            .count();
        assert!(n <= 2000, "polyline with {n} points");
    }

    // Channel table: every number equals channels/channels.parquet's value exactly
    // (data-value) and its 4-significant-digit display agrees.
    let (headers, rows) = table_cells(&doc, "channel-table");
    assert_eq!(rows.len(), ids.len());
    for col in [
        "channel_id",
        "pga_m_s2",
        "pgv_m_s",
        "arias_m_s",
        "d5_95_s",
        "qa_flags",
    ] {
        assert!(
            headers.iter().any(|h| h == col),
            "header {col} missing: {headers:?}"
        );
    }
    let col_of = |name: &str| headers.iter().position(|h| h == name).unwrap();
    // Natural order of the ids (…2 before …10); each row's numbers are its
    // channel's in the file.
    let shown: Vec<String> = rows
        .iter()
        .map(|row| node_text(row[col_of("channel_id")]))
        .collect();
    let mut natural = ids.clone();
    natural.sort_by(|a, b| report::natural_cmp(a, b));
    assert_eq!(shown, natural);
    let file_row = |r: usize| ids.iter().position(|i| *i == shown[r]).unwrap();
    let mut compared = 0;
    for name in [
        "sampling_rate_hz",
        "npts",
        "pga_m_s2",
        "pgv_m_s",
        "pgd_m",
        "arias_m_s",
        "d5_95_s",
        "cav_m_s",
        "snr_db",
    ] {
        let truth = parquet_numbers(&channels_path, name);
        let c = col_of(name);
        for (r, row) in rows.iter().enumerate() {
            let cell = row[c];
            let id = &shown[r];
            match truth[file_row(r)] {
                Some(v) => {
                    let exact: f64 = cell.attribute("data-value").unwrap().parse().unwrap();
                    assert_eq!(exact, v, "{name} of {id}");
                    let text: f64 = node_text(cell).parse().unwrap();
                    assert!(
                        (text - v).abs() <= 5e-4 * v.abs(),
                        "{name} of {id}: shown {text}, value {v}"
                    );
                    compared += 1;
                }
                None => assert_eq!(node_text(cell), "—", "{name} of {id}"),
            }
        }
    }
    assert!(compared >= 80, "{compared} numbers compared");

    // Drift table and the overall rating follow drift/drift.parquet.
    let drift_path = out.path().join("drift/drift.parquet");
    let drift = parquet_numbers(&drift_path, "peak_drift_ratio");
    assert!(!drift.is_empty());
    let (dh, drows) = table_cells(&doc, "drift-table");
    let dc = dh.iter().position(|h| h == "peak_drift_ratio").unwrap();
    for (row, v) in drows.iter().zip(&drift) {
        let exact: f64 = row[dc].attribute("data-value").unwrap().parse().unwrap();
        assert_eq!(Some(exact), *v);
    }
    let worst = drift.iter().flatten().fold(0.0f64, |a, b| a.max(*b));
    let drift_rating = if worst >= 0.015 {
        2
    } else if worst >= 0.005 {
        1
    } else {
        0
    };
    let labels = ["GREEN", "YELLOW", "RED"];
    let rating = section_text(&doc, "overall-rating");
    if out.path().join("damage/damage.parquet").exists() {
        // The overall rating is the worst criterion: never better than drift's.
        let shown = labels.iter().position(|l| rating.contains(l)).unwrap();
        assert!(shown >= drift_rating, "{rating} (worst drift {worst})");
    } else {
        assert!(
            rating.contains(labels[drift_rating]),
            "{rating} (worst drift {worst})"
        );
        assert!(rating.contains("peak inter-storey drift ratio"), "{rating}");
        assert!(rating.contains(&report::format_number(worst)), "{rating}");
    }

    // Residual drift: a resolved row shows drift/drift.parquet's value; an
    // unresolved one (or an artefact) says so, without a number.
    let residual = parquet_numbers(&drift_path, "residual_drift_m");
    let status = parquet_strings(&drift_path, "residual_status");
    let rc = dh
        .iter()
        .position(|h| h == "residual drift ± σ")
        .expect("residual drift column");
    for ((row, v), st) in drows.iter().zip(&residual).zip(&status) {
        let shown: Option<f64> = row[rc].attribute("data-value").map(|x| x.parse().unwrap());
        let text = node_text(row[rc]);
        match (v, st.as_str()) {
            (Some(_), "resolved") => assert_eq!(shown, *v),
            (Some(_), _) => {
                assert!(
                    shown.is_none() && text.starts_with("not resolved"),
                    "{text}"
                );
                assert!(!text.chars().any(|c| c.is_ascii_digit()), "{text}");
            }
            (None, _) => assert!(shown.is_none()),
        }
    }

    // Event facts from event.json, in the summary's first line and in full.
    let summary = section_text(&doc, "summary");
    assert!(summary.contains("Synthetic earthquake, 4-storey shear building"));
    assert!(summary.contains("2026-01-15 10:20:30 UTC"));
    assert!(summary.contains("M 6.0"), "{summary}");
    let event = section_text(&doc, "event");
    assert!(event.contains("floors.csv"));
    assert!(!event.contains("6.000"), "magnitude with 4 digits: {event}");

    // Stages that did not run say so; those that ran show no such message.
    for (id, file, words) in [
        (
            "modal",
            "stabilization/stabilization.parquet",
            "stabilisation diagram",
        ),
        ("modal", "modes/modes.parquet", "identified modes"),
        (
            "hysteresis",
            "hysteresis_fit/hysteresis_fit.parquet",
            "force–drift loops",
        ),
        (
            "hysteresis",
            "bouc_wen/bouc_wen.parquet",
            "Bouc-Wen parameters",
        ),
        ("damage", "damage/damage.parquet", "damage index ι(t)"),
        (
            "twin",
            "twin_update/twin_update.parquet",
            "twin-update candidates",
        ),
    ] {
        let text = section_text(&doc, id);
        let message = format!("Stage not run / output absent: {words}");
        if out.path().join(file).exists() {
            assert!(
                !text.contains(&message),
                "section {id}: {file} exists: {text}"
            );
        } else {
            assert!(
                text.contains(&message),
                "section {id} lacks the absent message for {file}: {text}"
            );
        }
    }
    // No design output at all: one line says why, not one per table.
    if !out.path().join("pod/pod.parquet").exists() {
        let text = section_text(&doc, "test-design");
        assert!(
            text.contains("No hybrid-test design in this run") && !text.contains("absent"),
            "{text}"
        );
    }
    if has_rows(&out.path().join("hysteresis_fit/hysteresis_fit.parquet")) {
        assert!(svg_count(by_id(&doc, "hysteresis").unwrap()) >= 1);
    }
    if has_rows(&out.path().join("damage/damage.parquet")) {
        assert!(svg_count(by_id(&doc, "damage").unwrap()) >= 1);
    } else if out.path().join("damage/damage.parquet").exists() {
        // Written but empty (no direction identifiable): said, not rated.
        assert!(section_text(&doc, "rating").contains("No damage index ι(t)"));
        assert!(section_text(&doc, "damage")
            .contains("ι needs a direction whose Bouc-Wen model is identified"));
    } else {
        assert!(section_text(&doc, "rating").contains("no damage index ι(t): stage damage not run"));
    }
}

fn meta() -> Vec<(String, String)> {
    Vec::new()
}

/// Fixture tables of the later stages with stated values.
fn write_fixtures(dir: &Path) {
    // Stabilisation: 3 orders × 2 poles; one non-physical pole.
    write_parquet(
        &dir.join("stabilization/stabilization.parquet"),
        &[TableBuilder::untyped()
            .u32("order", vec![4, 4, 6, 6, 8, 8])
            .f64("frequency_hz", vec![1.5, 4.4, 1.51, 4.41, 1.505, 7.9])
            .f64("damping_ratio", vec![0.02, 0.03, 0.021, 0.03, 0.02, -0.1])
            .bool(
                "stable_frequency",
                vec![false, false, true, true, true, false],
            )
            .bool(
                "stable_damping",
                vec![false, false, true, false, true, false],
            )
            .bool("stable_shape", vec![false, false, true, false, true, false])
            .bool("physical", vec![true, true, true, true, true, false])
            .i32("mode", vec![-1, -1, 0, 1, 0, -1])
            .build()
            .unwrap()],
        &meta(),
    )
    .unwrap();
    write_parquet(
        &dir.join("modes/modes.parquet"),
        &[TableBuilder::untyped()
            .i32("mode", vec![0, 1])
            .f64("frequency_hz", vec![1.507, 4.405])
            .f64("frequency_std_hz", vec![0.004, 0.01])
            .f64("damping_ratio", vec![0.0205, 0.03])
            .f64("damping_std", vec![0.001, 0.002])
            .f64("mpc", vec![0.99, 0.97])
            .f64("mpd_deg", vec![2.0, 4.5])
            .u32("pole_count", vec![2, 1])
            .list_f64(
                "shape_re",
                &[vec![0.25, 0.5, 0.75, 1.0], vec![1.0, 0.5, -0.5, -1.0]],
            )
            .build()
            .unwrap()],
        &meta(),
    )
    .unwrap();
    // Hysteresis: one loop per direction/dof; a column the report does not
    // know and no cost column (schemas are still moving).
    let n = 400;
    let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
    let d: Vec<f64> = t.iter().map(|t| 0.01 * (2.0 * t).sin()).collect();
    let f: Vec<f64> = t.iter().map(|t| 2.0e6 * (2.0 * t - 0.3).sin()).collect();
    let fm: Vec<f64> = f.iter().map(|x| 0.97 * x).collect();
    let mut dir_col = vec!["X"; n];
    dir_col.extend(vec!["Y"; n]);
    let cat = |a: &Vec<f64>| [a.clone(), a.clone()].concat();
    write_parquet(
        &dir.join("hysteresis_fit/hysteresis_fit.parquet"),
        &[TableBuilder::untyped()
            .str("direction", &dir_col)
            .i32("dof", vec![1; 2 * n])
            .f64("t_s", cat(&t))
            .f64("drift_m", cat(&d))
            .f64("force_record_n", cat(&f))
            .f64("force_model_n", cat(&fm))
            .build()
            .unwrap()],
        &meta(),
    )
    .unwrap();
    // Long layout, one row per parameter, without cost_j and with a column
    // the report does not know.
    write_parquet(
        &dir.join("bouc_wen/bouc_wen.parquet"),
        &[TableBuilder::untyped()
            .str("direction", &["X", "X", "Y", "Y"])
            .i32("dof", vec![1, 1, 1, 1])
            .str("parameter", &["K0", "N", "K0", "N"])
            .f64("value", vec![2.5e8, 1.8, 2.25e8, 2.2])
            .str("unit", &["N/m", "-", "N/m", "-"])
            .str("status", &["identified"; 4])
            .f64("extra_figure", vec![1.0, 2.0, 3.0, 4.0])
            .build()
            .unwrap()],
        &meta(),
    )
    .unwrap();
    // Damage: X ends at 0.03 (peak 0.045), Y ends at 0.06 (peak 0.07).
    let m = 101;
    let ts: Vec<f64> = (0..m).map(|i| i as f64 * 0.1).collect();
    let ramp = |end: f64, peak: f64| -> Vec<f64> {
        (0..m)
            .map(|i| {
                if i == 50 {
                    peak
                } else {
                    end * i as f64 / (m - 1) as f64
                }
            })
            .collect()
    };
    // Long layout: one row per direction, time and mode (ι repeated).
    let (mut dcol, mut tcol, mut icol, mut mcol, mut rcol) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (d, iota) in [("X", ramp(0.03, 0.045)), ("Y", ramp(0.06, 0.07))] {
        for i in 0..m {
            for mode in 0..2 {
                dcol.push(d);
                tcol.push(ts[i]);
                icol.push(iota[i]);
                mcol.push(mode);
                rcol.push(1.0 - 0.01 * (mode + 1) as f64 * i as f64 / m as f64);
            }
        }
    }
    write_parquet(
        &dir.join("damage/damage.parquet"),
        &[TableBuilder::untyped()
            .str("direction", &dcol)
            .f64("t_s", tcol)
            .f64("iota", icol)
            .i32("mode", mcol)
            .f64("omega_ratio", rcol)
            .build()
            .unwrap()],
        &meta(),
    )
    .unwrap();
    write_parquet(
        &dir.join("pod/pod.parquet"),
        &[TableBuilder::untyped()
            .i32("pod_mode", vec![1, 2, 3])
            .f64("energy_fraction", vec![0.9, 0.08, 0.02])
            .build()
            .unwrap()],
        &meta(),
    )
    .unwrap();
}

#[test]
fn later_stage_sections_render_fixture_tables_and_rate_damage() {
    let out = tempfile::tempdir().unwrap();
    write_fixtures(out.path());
    let html = report::render_report(out.path(), &ReportSettings::default()).unwrap();
    let doc = parse(&html);

    // Modal: stabilisation diagram and one shape chart per mode; the modes
    // table without the shape lists, which go to the components table.
    let modal = by_id(&doc, "modal").unwrap();
    assert_eq!(svg_count(modal), 3);
    let modal_text = node_text(modal);
    assert!(
        modal_text.contains("stable in frequency, damping and shape (2)"),
        "{modal_text}"
    );
    assert!(
        modal_text.contains("non-physical (filtered out) (1)"),
        "{modal_text}"
    );
    let (mh, mrows) = table_cells(&doc, "modes-table");
    assert_eq!(mrows.len(), 2);
    assert!(!mh.iter().any(|h| h == "shape_re"), "{mh:?}");
    let (sh, srows) = table_cells(&doc, "mode-shape-table");
    assert_eq!(sh.len(), 5, "mode and 4 components: {sh:?}");
    // The fixture has no shape_im column: real parts only, labelled so.
    let labels: Vec<String> = srows.iter().map(|r| node_text(r[0])).collect();
    assert_eq!(labels, ["0 (Re)", "1 (Re)"], "{labels:?}");
    assert_eq!(srows[1][4].attribute("data-value"), Some("-1"));
    let fc = mh.iter().position(|h| h == "frequency_hz").unwrap();
    assert_eq!(mrows[1][fc].attribute("data-value"), Some("4.405"));
    assert!(modal_text.contains("Not computed: no earlier event"));

    // Hysteresis: a loop per (direction, dof); unknown and missing columns named.
    let hyst = by_id(&doc, "hysteresis").unwrap();
    assert_eq!(svg_count(hyst), 2);
    let hyst_text = node_text(hyst);
    // Missing and unknown columns: for the maintainer, in the appendix only.
    assert!(!hyst_text.contains("column(s)"), "{hyst_text}");
    let checks = section_text(&doc, "appendix");
    assert!(
        checks.contains(
            "bouc_wen/bouc_wen.parquet: expected column(s) not present: segment, coupled_dof, stability_std, stable, reason, cost_j"
        ),
        "{checks}"
    );
    let (bh, brows) = table_cells(&doc, "bouc-wen-table");
    assert!(bh.iter().any(|h| h == "extra_figure"));
    let kc = bh.iter().position(|h| h == "value").unwrap();
    assert_eq!(brows[2][kc].attribute("data-value"), Some("225000000"));
    assert!(hyst_text.contains("Stage not run / output absent: instantaneous Bouc-Wen estimates"));

    // Damage: final ι rated by default (X 0.03 → YELLOW, Y 0.06 → RED).
    let (_, drows) = table_cells(&doc, "damage-table");
    let texts: Vec<Vec<String>> = drows
        .iter()
        .map(|r| r.iter().map(|c| node_text(*c)).collect())
        .collect();
    assert_eq!(texts[0][0], "X");
    assert!(texts[0][3].contains("YELLOW"), "{texts:?}");
    assert_eq!(drows[0][2].attribute("data-value"), Some("0.045"));
    assert!(texts[1][3].contains("RED"), "{texts:?}");
    assert_eq!(svg_count(by_id(&doc, "damage").unwrap()), 4);
    let overall = section_text(&doc, "overall-rating");
    assert!(overall.contains("RED"), "{overall}");
    assert!(
        overall.contains("damage index ι (final) = 0.06000 at direction Y"),
        "{overall}"
    );
    assert!(section_text(&doc, "rating").contains("no inter-storey drift: stage metrics not run"));
    // Absent base outputs are still announced.
    assert!(section_text(&doc, "channels")
        .contains("Stage not run / output absent: channel QA and strong-motion metrics"));

    // Peak statistic and custom thresholds: X peak 0.045 < 0.05 → GREEN.
    let settings = ReportSettings {
        iota_statistic: IotaStatistic::Peak,
        iota: report::Thresholds {
            yellow: 0.05,
            red: 0.08,
        },
        ..Default::default()
    };
    let html = report::render_report(out.path(), &settings).unwrap();
    let doc = parse(&html);
    let (_, drows) = table_cells(&doc, "damage-table");
    assert!(node_text(drows[0][3]).contains("GREEN"));
    assert!(node_text(drows[1][3]).contains("YELLOW"));
    assert!(section_text(&doc, "overall-rating").contains("YELLOW"));

    // Test design: POD energy plotted.
    assert_eq!(svg_count(by_id(&doc, "test-design").unwrap()), 1);
}

#[test]
fn unreadable_outputs_and_bad_arguments_are_reported() {
    let out = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(out.path().join("drift")).unwrap();
    std::fs::write(out.path().join("drift/drift.parquet"), b"not parquet").unwrap();
    std::fs::write(out.path().join("event.json"), b"{ broken").unwrap();
    let html = report::render_report(out.path(), &ReportSettings::default()).unwrap();
    let doc = parse(&html);
    assert!(section_text(&doc, "drift").contains("Output unreadable: inter-storey drift"));
    assert!(section_text(&doc, "event").contains("Output unreadable: event inventory"));
    // The file and the reason: in the appendix's table checks.
    assert!(section_text(&doc, "appendix").contains("drift/drift.parquet: unreadable"));
    assert!(section_text(&doc, "overall-rating").contains("NOT RATED"));

    let missing = out.path().join("no-such-dir");
    assert!(report::write_report(&missing, &ReportSettings::default()).is_err());
    let bad = ReportSettings {
        drift: report::Thresholds {
            yellow: 0.02,
            red: 0.01,
        },
        ..Default::default()
    };
    let err = report::write_report(out.path(), &bad).unwrap_err();
    assert_eq!(err.exit_code(), 2, "{err}");
    assert!(!out.path().join("report.html").exists());
}

// The report's pieces on their own: number formatting and escaping, rating
// thresholds and settings, trace decimation, the inline SVG chart.

#[test]
fn numbers_have_four_significant_digits() {
    assert_eq!(format_number(0.012346), "0.01235");
    assert_eq!(format_number(1.5), "1.500");
    assert_eq!(format_number(1234.5678), "1235");
    assert_eq!(format_number(2.5e-5), "2.500e-5");
    assert_eq!(format_number(0.0), "0");
    assert_eq!(format_number(-3.0), "-3.000");
}

#[test]
fn escaping_covers_markup() {
    assert_eq!(
        escape("<a href=\"x\">&'"),
        "&lt;a href=&quot;x&quot;&gt;&amp;&#39;"
    );
}

#[test]
fn thresholds_are_half_open_intervals() {
    let s = ReportSettings::default();
    assert_eq!(s.drift.rate(0.004_999), Some(Rating::Green));
    assert_eq!(s.drift.rate(0.005), Some(Rating::Yellow));
    assert_eq!(s.drift.rate(0.014_999), Some(Rating::Yellow));
    assert_eq!(s.drift.rate(0.015), Some(Rating::Red));
    assert_eq!(s.iota.rate(0.019), Some(Rating::Green));
    assert_eq!(s.iota.rate(0.02), Some(Rating::Yellow));
    assert_eq!(s.iota.rate(0.05), Some(Rating::Red));
    assert_eq!(s.iota.rate(f64::NAN), None);
}

#[test]
fn settings_deserialise_with_defaults_and_validate() {
    let s: ReportSettings = toml::from_str("drift = { yellow = 0.004, red = 0.01 }").unwrap();
    assert_eq!(s.drift.yellow, 0.004);
    assert_eq!(s.iota, ReportSettings::default().iota);
    assert!(s.validate().is_ok());
    let bad: ReportSettings = toml::from_str("iota = { yellow = 0.1, red = 0.05 }").unwrap();
    assert!(matches!(bad.validate(), Err(Error::Usage(_))));
    assert!(toml::from_str::<ReportSettings>("colour = 1").is_err());
}

/// A loop growing and drifting sideways, 500 samples a cycle: amplitude
/// a0 + growth·t, drift −drift·t, force lagging by `lag` rad.
fn drifting_loop(samples: usize, a0: f64, growth: f64, drift: f64, lag: f64) -> Vec<(f64, f64)> {
    (0..samples)
        .map(|i| {
            let t = i as f64 / 500.0;
            let a = a0 + growth * t;
            (
                a * (2.0 * std::f64::consts::PI * t).sin() - drift * t,
                a * (2.0 * std::f64::consts::PI * t - lag).sin(),
            )
        })
        .collect()
}

#[test]
fn curve_decimation_keeps_the_loop_shape_and_its_extremes() {
    // A drifting, growing loop: 40 cycles, 20 000 samples.
    let pts = drifting_loop(20_000, 0.2, 1.0 / 40.0, 0.002, 0.6);
    let d = decimate_curve(&pts, 1500);
    assert!(d.len() <= 1500 && d.len() > 1000, "{}", d.len());
    let max_x = |p: &[(f64, f64)]| p.iter().map(|q| q.0).fold(f64::MIN, f64::max);
    let min_x = |p: &[(f64, f64)]| p.iter().map(|q| q.0).fold(f64::MAX, f64::min);
    assert_eq!(max_x(&d), max_x(&pts));
    assert_eq!(min_x(&d), min_x(&pts));
    // The positive drift peak of every cycle survives within 2 % of the range.
    let kept: Vec<usize> = d
        .iter()
        .map(|p| pts.iter().position(|q| q == p).unwrap())
        .collect();
    let span = max_x(&pts) - min_x(&pts);
    for c in 0..40 {
        let peak = max_x(&pts[c * 500..(c + 1) * 500]);
        let drawn = kept
            .iter()
            .filter(|&&i| i / 500 == c)
            .map(|&i| pts[i].0)
            .fold(f64::MIN, f64::max);
        assert!(
            (peak - drawn).abs() < 0.02 * span,
            "cycle {c}: {peak} vs {drawn}"
        );
    }
}

#[test]
fn decimation_keeps_extremes_and_bounds_size() {
    let pts: Vec<(f64, f64)> = (0..10_000)
        .map(|i| (i as f64, ((i as f64) * 0.01).sin()))
        .chain(std::iter::once((10_000.0, 5.0)))
        .collect();
    let d = decimate_min_max(&pts, 2000);
    assert!(d.len() <= 2000, "{}", d.len());
    assert!(d.iter().any(|p| p.1 == 5.0));
    assert!(d.windows(2).all(|w| w[0].0 < w[1].0));
}

#[test]
fn chart_is_inline_svg_without_urls() {
    let mut c = Chart::new(300, 200, "period (s)", "PSA (m/s²)");
    c.log_x = true;
    c.series.push(Series::new(
        "a",
        vec![(0.05, 1.0), (0.5, 3.0), (2.0, 0.5)],
        0,
        Mark::Line,
    ));
    let svg = render(&c).unwrap();
    assert!(svg.starts_with("<svg class=\"plot\""), "{}", &svg[..60]);
    assert!(!svg.contains("http"));
    assert!(svg.contains("period (s)"));
    assert!(svg.contains("<polyline"));
}

/// Largest step of a path in either axis, as a share of that axis' range in `of`.
fn largest_step(path: &[(f64, f64)], of: &[(f64, f64)]) -> f64 {
    let span = |f: fn(&(f64, f64)) -> f64| {
        let (lo, hi) = of
            .iter()
            .map(f)
            .fold((f64::MAX, f64::MIN), |(l, h), v| (l.min(v), h.max(v)));
        hi - lo
    };
    let (sx, sy) = (span(|p| p.0), span(|p| p.1));
    path.windows(2)
        .map(|w| ((w[1].0 - w[0].0).abs() / sx).max((w[1].1 - w[0].1).abs() / sy))
        .fold(0.0, f64::max)
}

#[test]
fn curve_decimation_keeps_segments_short_within_its_budget() {
    use quaketwin::report::plot::CURVE_MAX_STEP;
    // 30 cycles of a loop drifting sideways, 15 000 samples.
    let pts = drifting_loop(15_000, 0.3, 1.0 / 30.0, 0.01, 0.8);
    let raw = largest_step(&pts, &pts);
    assert!(raw < CURVE_MAX_STEP, "{raw}");
    let d = decimate_curve(&pts, 6000);
    assert!(d.len() <= 6000 && d.len() < pts.len() / 2, "{}", d.len());
    let step = largest_step(&d, &pts);
    assert!(step <= CURVE_MAX_STEP + 1e-12, "{step}");
    // In time order: the kept points are a subsequence of the samples.
    let mut at = 0;
    for p in &d {
        at += pts[at..].iter().position(|q| q == p).expect("in order");
    }
    // A small budget holds; the step widens instead.
    assert!(decimate_curve(&pts, 300).len() <= 300);
}

/// One drift on the page (issue 34): in every sample event with drift and
/// force–drift loops, run through the shipped post-earthquake pipeline, each
/// loop's largest drawn drift is its drift-table row's peak drift (ratio ×
/// height, read from drift/drift.parquet here) within 1 %.
#[test]
fn loops_are_drawn_from_the_drift_the_drift_table_reports_on_every_sample() {
    use crate::common::{column_f64, column_i64, column_str, run_sample_pipeline};
    let samples = manifest().join("sample-records");
    let mut events: Vec<String> = std::fs::read_dir(&samples)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_dir())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        // The facade is the test-design sample: no drift, no loops.
        .filter(|n| n != "synthetic-facade")
        .collect();
    events.sort();
    assert!(events.len() >= 5, "{events:?}");
    let work = tempfile::tempdir().unwrap();
    std::thread::scope(|s| {
        for e in &events {
            let out = work.path().join(e);
            s.spawn(move || run_sample_pipeline("post-earthquake.toml", e, &out, &[]));
        }
    });
    let mut with_both = Vec::new();
    for e in &events {
        let out = work.path().join(e);
        let (drift, fit) = (
            out.join("drift/drift.parquet"),
            out.join("hysteresis_fit/hysteresis_fit.parquet"),
        );
        if !has_rows(&drift) || !has_rows(&fit) {
            eprintln!("{e}: no drift or no loops");
            continue;
        }
        let html = std::fs::read_to_string(out.join("report.html")).unwrap();
        let doc = parse(&html);
        let (headers, rows) = table_cells(&doc, "loop-drift-table");
        let col = |name: &str| headers.iter().position(|h| h == name).unwrap();
        let (dir_c, lev_c, drawn_c) = (
            col("direction"),
            col("levels"),
            col("largest drift drawn (m)"),
        );
        let (d_dir, d_kind) = (column_str(&drift, "direction"), column_str(&drift, "kind"));
        let (d_lo, d_up) = (
            column_i64(&drift, "lower_level"),
            column_i64(&drift, "upper_level"),
        );
        let (ratio, height) = (
            column_f64(&drift, "peak_drift_ratio"),
            column_f64(&drift, "storey_height_m"),
        );
        assert!(!rows.is_empty(), "{e}: no loop rows");
        for row in &rows {
            let direction = node_text(row[dir_c]);
            let levels = node_text(row[lev_c]);
            let (a, b) = levels.split_once('–').expect("levels a–b");
            let (a, b): (i64, i64) = (a.parse().unwrap(), b.parse().unwrap());
            let r = (0..d_dir.len())
                .find(|&r| {
                    d_dir[r] == direction && d_kind[r] != "estimate" && d_lo[r] == a && d_up[r] == b
                })
                .unwrap_or_else(|| panic!("{e}: no drift row for {direction} {levels}"));
            let table_peak = ratio[r] * height[r];
            let drawn: f64 = row[drawn_c]
                .attribute("data-value")
                .unwrap_or_else(|| panic!("{e} {direction} {levels}: nothing drawn"))
                .parse()
                .unwrap();
            eprintln!(
                "{e} {direction} levels {levels}: drawn {drawn:.5e} m, drift table {table_peak:.5e} m"
            );
            assert!(
                (drawn / table_peak - 1.0).abs() <= 0.01,
                "{e} {direction} levels {levels}: largest drift drawn {drawn} m, drift table's peak {table_peak} m"
            );
        }
        with_both.push(e.clone());
    }
    // The yielding frame and the 4-storey quake building have both (the
    // zipped network samples name no masses: no loops).
    for e in ["synthetic-2storey-yielding", "synthetic-4storey-quake"] {
        assert!(with_both.iter().any(|w| w == e), "{e}: {with_both:?}");
    }
}

#[test]
fn channel_names_sort_naturally_and_columns_read_as_words() {
    let mut ids = vec![
        "CE24386.10",
        "CE24386.02",
        "CE24386.19",
        "CE24386.01",
        "CE24386.20",
        "F10-X",
        "F2-X",
        "base_X",
    ];
    ids.sort_by(|a, b| report::natural_cmp(a, b));
    assert_eq!(
        ids,
        [
            "base_X",
            "CE24386.01",
            "CE24386.02",
            "CE24386.10",
            "CE24386.19",
            "CE24386.20",
            "F2-X",
            "F10-X"
        ]
    );
    use quaketwin::report::column_heading;
    assert_eq!(column_heading("pga_m_s2"), "PGA (m/s²)");
    assert_eq!(column_heading("peak_drift_ratio"), "peak drift ratio");
    assert_eq!(column_heading("frequency_hz"), "frequency (Hz)");
    assert_eq!(column_heading("peak |drift| (m)"), "peak |drift| (m)");
    // Segment labels: the en dash of earlier tables and the ASCII hyphen.
    assert_eq!(report::segment_levels("L0–L1"), Some((0, 1)));
    assert_eq!(report::segment_levels("L2-L6"), Some((2, 6)));
    assert_eq!(report::segment_levels("dof 1"), None);
}

/// The epicentral distance: the haversine on the mean Earth sphere against
/// known great-circle distances.
#[test]
fn epicentral_distance_is_the_great_circle_distance() {
    use quaketwin::geometry::great_circle_km;
    // One degree of latitude on the 6371.0088 km sphere: 111.195 km.
    assert!((great_circle_km(34.0, -118.0, 35.0, -118.0) - 111.195).abs() < 0.01);
    // Los Angeles City Hall to San Francisco City Hall: 559 km (geodesic
    // 559.1 km on WGS 84; the sphere is within 0.5 %).
    let d = great_circle_km(34.0537, -118.2428, 37.7793, -122.4193);
    assert!((d - 559.1).abs() < 0.005 * 559.1, "{d}");
    assert_eq!(great_circle_km(10.0, 20.0, 10.0, 20.0), 0.0);
}

/// A real CSMIP bridge record (Painter Street Overpass, Cape Mendocino
/// 1986, ../shared/records) through the shipped pipeline: the title block
/// names the structure (without the header's agency column), its station,
/// the epicentre of the header and the epicentral distance — the haversine
/// from the header's hypocentre (40.364 N, 124.433 W) to the station
/// (40.503 N, 124.100 W), 32.1 km —; channels in natural order; each time
/// history names its sensor location (no level on a bridge), never "level ?".
#[test]
fn real_record_cesmd_bridge_report_has_its_title_block_and_natural_channel_order() {
    let zip = crate::common::shared_record(
        "cesmd-bridges-corpus/painter-st-ce89324/capemendocino_21nov1986_ce89324p.zip",
    );
    let out = tempfile::tempdir().unwrap();
    quaketwin::commands::run_pipeline(
        &manifest().join("pipelines/post-earthquake.toml"),
        &zip,
        out.path(),
        true,
    )
    .expect("pipeline on the bridge record");
    let html = std::fs::read_to_string(out.path().join("report.html")).unwrap();
    let doc = parse(&html);
    let title = section_text(&doc, "title-block");
    let expected = {
        let (p1, p2) = (40.364f64.to_radians(), 40.503f64.to_radians());
        let dl = (-124.100f64 + 124.433).to_radians();
        let a = ((p2 - p1) / 2.0).sin().powi(2) + p1.cos() * p2.cos() * (dl / 2.0).sin().powi(2);
        2.0 * 6371.0088 * a.sqrt().asin()
    };
    for fact in [
        "RIO DELL - 101/PAINTER ST. OVERPASS (bridge)".to_string(),
        "station CE 89324".into(),
        "40.364° N, 124.433° W, depth 17 km".into(),
        format!("{expected:.1} km (great circle"),
        "origin 1986-11-21 23:33:01.8 UTC, M 5.1".into(),
    ] {
        assert!(title.contains(&fact), "{fact} not in {title}");
    }
    assert!(!title.contains("CGS"), "{title}");
    assert!(by_id(&doc, "review-block").is_some());
    // Natural order: …02 before …10; every channel placed in words.
    let (headers, rows) = table_cells(&doc, "channel-table");
    let id_col = headers.iter().position(|h| h == "channel_id").unwrap();
    let ids: Vec<String> = rows.iter().map(|r| node_text(r[id_col])).collect();
    let mut natural = ids.clone();
    natural.sort_by(|a, b| report::natural_cmp(a, b));
    assert_eq!(ids, natural);
    assert!(ids.len() >= 10, "{ids:?}");
    let at = |s: &str| ids.iter().position(|i| i.ends_with(s)).unwrap();
    assert!(at(".02") < at(".10"), "{ids:?}");
    let histories = section_text(&doc, "time-histories");
    assert!(!histories.contains("level ?") && !histories.contains("level unknown"));
    assert!(histories.contains("FREE FIELD"), "{histories}");
    // The sensor layout: one row per location, the inputs marked.
    let layout = by_id(&doc, "sensor-layout").expect("sensor layout");
    assert!(svg_count(layout) == 1 && node_text(layout).contains("input"));
}
