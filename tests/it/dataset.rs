//! Many events → one Hive-partitioned Parquet dataset
//! (`structure=…/event=…/`), read back with pyarrow.dataset when python3
//! with pyarrow is available (CI installs it).

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
    if !run.status.success() && stderr.contains("No module named 'pyarrow'") {
        println!("SKIPPED: pyarrow not installed");
        return None;
    }
    assert!(run.status.success(), "{stderr}");
    Some(String::from_utf8_lossy(&run.stdout).into_owned())
}

#[test]
fn events_run_in_parallel_into_a_hive_partitioned_dataset_readable_by_pyarrow() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let out = tempfile::tempdir().unwrap();
    // The folder of event folders expands to the four sample events.
    let events = quaketwin::commands::expand_events(&[root.join("sample-records")]);
    assert_eq!(events.len(), 4, "{events:?}");
    let results = quaketwin::commands::run_many(
        &root.join("pipelines/ingest.toml"),
        &events,
        out.path(),
        true,
    )
    .unwrap();
    for (e, r) in &results {
        assert!(r.is_ok(), "{}: {:?}", e.display(), r.as_ref().err());
    }
    let quake = out
        .path()
        .join("structure=Sample_4-storey_frame/event=synthetic-4storey-quake/channels.parquet");
    assert!(quake.exists(), "missing {}", quake.display());
    let yielding = out.path().join(
        "structure=Sample_2-storey_yielding_frame/event=synthetic-2storey-yielding/samples.parquet",
    );
    assert!(yielding.exists());

    let script = r#"
import glob, sys
import pyarrow.dataset as ds
root = sys.argv[1]
files = sorted(glob.glob(root + "/structure=*/event=*/channels.parquet"))
d = ds.dataset(files, format="parquet", partitioning="hive", partition_base_dir=root)
t = d.to_table(columns=["channel_id", "pga_m_s2", "structure", "event"])
print(t.num_rows, ",".join(sorted(set(t.column("event").to_pylist()))))
"#;
    let Some(stdout) = python(script, out.path()) else {
        return;
    };
    // 10 + 8 + 3 + 17 (facade: base + 16 at the PS) channels.
    assert_eq!(
        stdout.trim(),
        "38 synthetic-2storey-yielding,synthetic-4storey-ambient,synthetic-4storey-quake,synthetic-facade"
    );
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
    let Some(stdout) = python(script, &out.path().join("channels.parquet")) else {
        return;
    };
    assert_eq!(stdout.trim(), "channels m/s^2 True True");
}
