//! Many events → one table-first, Hive-partitioned Parquet dataset
//! (`DIR/tables/<table>/structure=…/event=…/part-0.parquet`), read back with
//! pyarrow.dataset, DuckDB and polars when python3 has them (CI installs them).

use std::path::{Path, PathBuf};
use std::process::Command;

/// Runs a Python script with one argument; `None` (and a SKIPPED line) when
/// python3 or pyarrow is missing.  The script's stdout.
fn python(script: &str, arg: &Path) -> Option<String> {
    let Ok(run) = Command::new("python3")
        .arg("-c")
        .arg(script)
        .arg(arg)
        .output()
    else {
        println!("SKIPPED: python3 not available");
        return None;
    };
    let stderr = String::from_utf8_lossy(&run.stderr);
    if !run.status.success() && stderr.contains("No module named") {
        println!("SKIPPED: a Python module is missing (CI installs them): {stderr}");
        return None;
    }
    assert!(run.status.success(), "{stderr}");
    Some(String::from_utf8_lossy(&run.stdout).into_owned())
}

/// Rows of a Parquet file, read with the Rust reader.
fn rows(path: &Path) -> i64 {
    let file = std::fs::File::open(path).unwrap();
    parquet::file::reader::FileReader::metadata(
        &parquet::file::reader::SerializedFileReader::new(file).unwrap(),
    )
    .file_metadata()
    .num_rows()
}

/// Every file under `dir`, relative to it, sorted.
fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push(p.strip_prefix(dir).unwrap().to_path_buf());
            }
        }
    }
    out.sort();
    out
}

/// Issue 15 item 3: a many-event run is a table-first Hive dataset —
/// `DIR/tables/<table>/structure=…/event=…/part-0.parquet`, runs (JSON,
/// HTML, TOML) under `DIR/runs/` — and pyarrow.dataset, DuckDB and polars
/// each query `modes` across the events, with the row count per event that
/// each run's own modes/modes.parquet holds.  Issue 34: the partitions are ids
/// (the structure's name in canonical form here) with the free text in the
/// `event` table, and a glob over the whole table tree counts every table
/// file once (the runs' copies are outside it).
#[test]
fn events_run_in_parallel_into_a_table_first_dataset_that_pyarrow_duckdb_and_polars_query() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let out = tempfile::tempdir().unwrap();
    // The folder of event folders expands to the seven sample events (three of them network zips with no manifest).
    let events = quaketwin::commands::expand_events(&[root.join("sample-records")]);
    assert_eq!(events.len(), 7, "{events:?}");
    let results = quaketwin::commands::run_many(
        &root.join("pipelines/post-earthquake.toml"),
        &events,
        out.path(),
        true,
    )
    .unwrap();
    for run in &results {
        assert!(
            run.result.is_ok(),
            "{}: {:?}",
            run.event.display(),
            run.result.as_ref().err()
        );
    }
    // Issue 33: neither the run nor a re-run (whose tables are already
    // published as links to the runs' files) leaves a temporary file.
    let temps = |dir: &Path| -> Vec<PathBuf> {
        files_under(dir)
            .into_iter()
            .filter(|f| f.to_string_lossy().ends_with(".tmp"))
            .collect()
    };
    assert_eq!(temps(out.path()), Vec::<PathBuf>::new());
    let rerun = quaketwin::commands::run_many(
        &root.join("pipelines/post-earthquake.toml"),
        &events,
        out.path(),
        true,
    )
    .unwrap();
    assert!(rerun.iter().all(|r| r.result.is_ok()));
    assert_eq!(temps(out.path()), Vec::<PathBuf>::new());
    let quake = Path::new("structure=sample-4-storey-frame/event=synthetic-4storey-quake");
    let run = out.path().join("runs").join(quake);
    for f in [
        "event.json",
        "run.json",
        "report.html",
        "modes/modes.parquet",
    ] {
        assert!(run.join(f).is_file(), "missing {f} in {}", run.display());
    }
    // The dataset root holds the table tree and the runs, nothing else.
    let mut top: Vec<String> = std::fs::read_dir(out.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    top.sort();
    assert_eq!(top, ["runs", "tables"]);
    // Table folders hold only part files, one per event that has the table.
    let mut expected = String::new();
    let mut part_rows = 0;
    for entry in std::fs::read_dir(out.path().join("tables")).unwrap() {
        let dir = entry.unwrap().path();
        let name = dir.file_name().unwrap().to_string_lossy().into_owned();
        assert!(
            quaketwin::vocab::tables::by_name(&name).is_some(),
            "{name}: not a table folder"
        );
        for f in files_under(&dir) {
            assert_eq!(
                f.file_name().unwrap(),
                "part-0.parquet",
                "{name}/{}",
                f.display()
            );
            part_rows += rows(&dir.join(&f));
            let partition = f.parent().unwrap();
            let own = out
                .path()
                .join("runs")
                .join(partition)
                .join(format!("{name}/{name}.parquet"));
            assert_eq!(
                std::fs::read(dir.join(&f)).unwrap(),
                std::fs::read(&own).unwrap(),
                "{name}/{} differs from the run's table",
                f.display()
            );
        }
    }
    let modes = out.path().join("tables/modes");
    let mut per_event: Vec<(String, i64)> = files_under(&modes)
        .iter()
        .map(|f| {
            let event = f.parent().unwrap().file_name().unwrap().to_string_lossy();
            (
                event.trim_start_matches("event=").to_string(),
                rows(&modes.join(f)),
            )
        })
        .collect();
    per_event.sort();
    assert!(per_event.len() >= 3, "modes of {per_event:?}");
    for (event, n) in &per_event {
        expected.push_str(&format!("{event}:{n} "));
    }
    // Issue 32: every event has one assessment row, the same as its run's
    // assessment/assessment.parquet, and its report opens with that rating.
    let assessments = out.path().join("tables/assessment");
    let mut ratings: Vec<(String, String)> = Vec::new();
    for f in files_under(&assessments) {
        let event = f.parent().unwrap().file_name().unwrap().to_string_lossy();
        let rating = crate::common::column_str(&assessments.join(&f), "rating");
        assert_eq!(rating.len(), 1, "{}", f.display());
        let report = std::fs::read_to_string(
            out.path()
                .join("runs")
                .join(f.parent().unwrap())
                .join("report.html"),
        )
        .unwrap();
        let opening = &report[report.find("id=\"overall-rating\"").unwrap()..][..300];
        assert!(
            opening.contains(&rating[0]),
            "{event}: {} vs {opening}",
            rating[0]
        );
        ratings.push((
            event.trim_start_matches("event=").to_string(),
            rating[0].clone(),
        ));
    }
    ratings.sort();
    assert_eq!(ratings.len(), events.len(), "{ratings:?}");
    let expected_ratings = ratings
        .iter()
        .map(|(e, r)| format!("{e}:{r}"))
        .collect::<Vec<_>>()
        .join(" ");

    let script = r#"
import sys
import duckdb, polars as pl, pyarrow.dataset as ds
root = sys.argv[1]
def line(pairs):
    return " ".join(f"{e}:{n}" for e, n in sorted(pairs))
t = ds.dataset(root + "/tables/modes", format="parquet", partitioning="hive").to_table(columns=["frequency_hz", "event"])
counts = {}
for e in t.column("event").to_pylist():
    counts[e] = counts.get(e, 0) + 1
print("pyarrow", line(counts.items()))
rows = duckdb.sql(f"select event, count(*) from read_parquet('{root}/tables/modes/**/*.parquet', hive_partitioning=true) group by event").fetchall()
print("duckdb", line(rows))
df = pl.scan_parquet(root + "/tables/modes/**/*.parquet", hive_partitioning=True).group_by("event").len().collect()
print("polars", line(zip(df["event"].to_list(), df["len"].to_list())))
a = ds.dataset(root + "/tables/assessment", format="parquet", partitioning="hive").to_table(columns=["event", "rating"])
print("pyarrow-assessment", line(zip(a.column("event").to_pylist(), a.column("rating").to_pylist())))
rows = duckdb.sql(f"select event, rating from read_parquet('{root}/tables/assessment/**/*.parquet', hive_partitioning=true)").fetchall()
print("duckdb-assessment", line(rows))
# Issue 34: the whole table tree in one glob: every file once (no run copy),
# the tables' columns side by side (one type per column name).
n, runs = duckdb.sql(f"select count(*), count(*) filter (where filename like '%/runs/%') from read_parquet('{root}/tables/**/*.parquet', union_by_name=true, hive_partitioning=true, filename=true)").fetchall()[0]
print("duckdb-tree", n, runs)
# The free text beside the ids: the structure's name for its partition.
names = duckdb.sql(f"select distinct structure, structure_name from read_parquet('{root}/tables/event/**/*.parquet', hive_partitioning=true) where event = 'synthetic-4storey-quake'").fetchall()
print("duckdb-names", names)
"#;
    let Some(stdout) = python(script, out.path()) else {
        return;
    };
    let expected = expected.trim();
    assert_eq!(
        stdout.trim(),
        format!(
            "pyarrow {expected}\nduckdb {expected}\npolars {expected}\npyarrow-assessment {expected_ratings}\nduckdb-assessment {expected_ratings}\nduckdb-tree {part_rows} 0\nduckdb-names [('sample-4-storey-frame', 'Sample 4-storey frame')]"
        )
    );
}

/// A re-run of an event whose pipeline no longer writes a table withdraws
/// that table's file of the event from the dataset (no stale table of an
/// earlier run survives); other tables are republished.
#[test]
fn republishing_an_event_withdraws_the_tables_its_run_no_longer_has() {
    use quaketwin::sinks::dataset::{partition, publish_tables, PART_FILE};
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let out = tempfile::tempdir().unwrap();
    let part = partition("Sample 4-storey frame", "synthetic-4storey-quake");
    assert_eq!(
        part,
        Path::new("structure=sample-4-storey-frame/event=synthetic-4storey-quake")
    );
    let run = out.path().join("runs").join(&part);
    quaketwin::commands::run_pipeline(
        &root.join("pipelines/ingest.toml"),
        &root.join("sample-records/synthetic-4storey-quake"),
        &run,
        true,
    )
    .unwrap();
    // A foreign file in the run directory is never published.
    std::fs::write(run.join("notes.parquet"), b"not a table").unwrap();
    let first = publish_tables(out.path(), &part, &run).unwrap();
    let channels = out
        .path()
        .join("tables/channels")
        .join(&part)
        .join(PART_FILE);
    assert!(first.contains(&channels), "{first:?}");
    assert!(!out.path().join("tables/notes").exists());
    std::fs::remove_file(run.join("channels/channels.parquet")).unwrap();
    let second = publish_tables(out.path(), &part, &run).unwrap();
    assert_eq!(second.len(), first.len() - 1);
    assert!(
        !channels.exists(),
        "stale channels table left in the dataset"
    );
    assert!(out
        .path()
        .join("tables/samples")
        .join(&part)
        .join(PART_FILE)
        .is_file());
}

/// pyarrow sees the `quaketwin.*` metadata in the Arrow schema (not only in
/// the Parquet footer) and the unit of every field in its field metadata.
#[test]
fn pyarrow_sees_the_schema_metadata_and_the_units() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let out = tempfile::tempdir().unwrap();
    quaketwin::commands::run_pipeline(
        &root.join("pipelines/ingest.toml"),
        &root.join("sample-records/synthetic-4storey-quake"),
        out.path(),
        true,
    )
    .unwrap();
    let script = r#"
import sys
import pyarrow.parquet as pq
t = pq.read_table(sys.argv[1])
m = t.schema.metadata or {}
unit = (t.schema.field("pga_m_s2").metadata or {}).get(b"unit", b"?").decode()
print(m.get(b"quaketwin.schema", b"?").decode(), unit, b"quaketwin.version" in m, b"quaketwin.event" in m)
"#;
    let Some(stdout) = python(script, &out.path().join("channels/channels.parquet")) else {
        return;
    };
    assert_eq!(stdout.trim(), "channels m/s^2 True True");
}

/// Issue 15 item 5: the MCAP of `ingest --mcap` reads back with the Python
/// `mcap` reader (what Foxglove-side scripts use): one topic per channel,
/// one JSON message per sample with a numeric `value`, log times from the
/// record start or, as for this sample (no record start), the origin time —
/// not 1970 — and as many messages as samples.
#[test]
fn python_mcap_reader_reads_the_mcap_output_one_topic_per_channel() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let out = tempfile::tempdir().unwrap();
    let mcap = out.path().join("event.mcap");
    let status = Command::new(env!("CARGO_BIN_EXE_quaketwin"))
        .args(["ingest", "-q"])
        .arg(root.join("sample-records/synthetic-4storey-quake"))
        .arg("--out")
        .arg(out.path().join("out"))
        .arg("--mcap")
        .arg(&mcap)
        .status()
        .unwrap();
    assert!(status.success());
    let inventory: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.path().join("out/event.json")).unwrap()).unwrap();
    let mut expected: Vec<String> = inventory["channels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| format!("/accel/{}:{}", c["id"].as_str().unwrap(), c["npts"]))
        .collect();
    expected.sort();
    let script = r#"
import sys, json
from mcap.reader import make_reader
counts, bad, first = {}, 0, None
with open(sys.argv[1], "rb") as f:
    for schema, channel, message in make_reader(f).iter_messages():
        v = json.loads(message.data)
        if not isinstance(v.get("value"), (int, float)) or v["t_ns"] != message.log_time:
            bad += 1
        counts[channel.topic] = counts.get(channel.topic, 0) + 1
        first = message.log_time if first is None else min(first, message.log_time)
print(" ".join(f"{t}:{n}" for t, n in sorted(counts.items())))
print(bad, first >= 1_000_000_000 * 10**9)
"#;
    let Some(stdout) = python(script, &mcap) else {
        return;
    };
    assert_eq!(stdout.trim(), format!("{}\n0 True", expected.join(" ")));
}

/// Issue 34: partition values are ids in one canonical form (lower case,
/// runs of other characters one `-`), the same for two spellings of one
/// name and unchanged when applied again; `structure.id` and `event.id` of
/// event.toml, when stated, are the ids instead of the name and the folder.
#[test]
fn partition_values_are_canonical_ids_and_the_manifest_may_state_them() {
    use quaketwin::pipeline::dataset::{event_ids, event_partition};
    use quaketwin::sinks::dataset::partition_value;
    for (text, id) in [
        ("Sample 4-storey frame", "sample-4-storey-frame"),
        ("sample 4 storey  FRAME", "sample-4-storey-frame"),
        ("  Building A / East wing ", "building-a-east-wing"),
        ("CE.24386", "ce.24386"),
        ("a=b/../c", "a-b-..-c"),
        ("..", "__"),
        ("Ünïcode", "n-code"),
        ("", "unnamed"),
    ] {
        assert_eq!(partition_value(text), id, "{text:?}");
        assert_eq!(partition_value(id), id, "{id:?} not a fixed point");
        assert!(id.is_ascii() && !id.contains('/') && !id.contains('='));
    }
    let dir = tempfile::tempdir().unwrap();
    let event = dir.path().join("Quake Folder");
    std::fs::create_dir_all(&event).unwrap();
    std::fs::write(
        event.join("event.toml"),
        "[event]\nname = \"M 6.4, 12 km S of Somewhere\"\n\n[structure]\nname = \"Hotel Somewhere (7 storeys)\"\n",
    )
    .unwrap();
    assert_eq!(
        event_ids(&event).unwrap(),
        ("hotel-somewhere-7-storeys".into(), "quake-folder".into())
    );
    std::fs::write(
        event.join("event.toml"),
        "[event]\nid = \"us7000ABCD\"\nname = \"M 6.4\"\n\n[structure]\nid = \"CE.24386\"\nname = \"Hotel\"\n",
    )
    .unwrap();
    assert_eq!(
        event_partition(&event).unwrap(),
        Path::new("structure=ce.24386/event=us7000abcd")
    );
}

/// Network zips as published carry no `event.toml`: their events are
/// partitioned by the recording station of their headers, so the events of
/// one instrumented structure share a partition (1980s CSMIP V2 and
/// post-2014 COSMOS zips of Painter St. alike), and two structures never do.
#[test]
fn zips_without_a_manifest_are_partitioned_by_their_station() {
    let corpus = crate::common::shared_records().join("cesmd-bridges-corpus");
    let events = [
        "painter-st-ce89324/riodell82_ce89324p.zip",
        "painter-st-ce89324/nc73201181_ce89324p.zip",
        "capistrano-ce13795/Inglewood_17May2009_CE13795P.zip",
    ];
    let out = tempfile::tempdir().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_quaketwin"))
        .args(["--quiet", "run"])
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/ingest.toml"))
        .args(events.iter().map(|e| corpus.join(e)))
        .arg("--out")
        .arg(out.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let partitions = quaketwin::sinks::dataset::partitions_under(
        &out.path().join(quaketwin::sinks::dataset::RUNS_DIR),
    )
    .unwrap();
    let expected: Vec<(String, String)> = [
        ("ce.13795", "inglewood_17may2009_ce13795p"),
        ("ce.89324", "nc73201181_ce89324p"),
        ("ce.89324", "riodell82_ce89324p"),
    ]
    .iter()
    .map(|(s, e)| (s.to_string(), e.to_string()))
    .collect();
    assert_eq!(partitions, expected);
}
