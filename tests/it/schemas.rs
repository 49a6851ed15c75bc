//! The table declarations (`vocab::tables`) are the one source of truth:
//! every table the sample runs write matches its declaration (names, order,
//! types, nullability, `unit` field metadata, schema metadata), docs/formats.md
//! lists every declared column with its type and unit in order, and the
//! writer refuses a table that does not match.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use quaketwin::error::Error;
use quaketwin::sinks::parquet::{write_parquet, TableBuilder};
use quaketwin::sinks::provenance::{EVENT_KEY, HISTORY_KEY};
use quaketwin::vocab::schema::{
    ColumnType, DESCRIPTION_KEY, FIELD_DESCRIPTION_KEY, SCHEMA_KEY, UNIT_ARBITRARY, UNIT_KEY,
    UNIT_VARIES, VERSION_KEY,
};
use quaketwin::vocab::tables::{self, drift, ALL_TABLES, DRIFT};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn declarations_are_well_formed() {
    let units = [
        "",
        "1",
        "m",
        "m/s",
        "m/s^2",
        // Amplitude spectral density (fourier/fourier.parquet).
        "m/s^2/Hz^0.5",
        "s",
        "Hz",
        "deg",
        "dB",
        "N",
        "N/m",
        "rad/s",
        "N^(1-N)/m",
        "J",
        "%",
        UNIT_VARIES,
        UNIT_ARBITRARY,
    ];
    let mut names = BTreeSet::new();
    let mut files = BTreeSet::new();
    for t in ALL_TABLES {
        assert!(names.insert(t.name), "table {} declared twice", t.name);
        assert!(files.insert(t.file), "file {} declared twice", t.file);
        assert_eq!(t.file, format!("{0}/{0}.parquet", t.name));
        assert!(tables::by_name(t.name) == Some(*t));
        assert!(!t.doc.is_empty() && !t.columns.is_empty(), "{}", t.name);
        let mut cols = BTreeSet::new();
        for c in t.columns {
            assert!(cols.insert(c.name), "{}: column {} twice", t.name, c.name);
            assert!(
                units.contains(&c.unit),
                "{}.{}: unit {:?}",
                t.name,
                c.name,
                c.unit
            );
            assert!(!c.doc.is_empty(), "{}.{} has no doc", t.name, c.name);
            // Issue 34: every number that is a quantity says its unit (a
            // unit, `1`, `varies` or `arbitrary`); integers are ids, indices
            // and counts, timestamps carry their unit in their type.
            if matches!(c.ty, ColumnType::F64 | ColumnType::ListF64) {
                assert!(
                    !c.unit.is_empty(),
                    "{}.{}: a float without unit",
                    t.name,
                    c.name
                );
            }
            if !matches!(c.ty, ColumnType::F64 | ColumnType::ListF64) {
                assert!(
                    c.unit.is_empty() || c.unit == UNIT_VARIES,
                    "{}.{}: unit {:?} on a non-float column",
                    t.name,
                    c.name,
                    c.unit
                );
            }
        }
    }
}

/// Issue 34: `read_parquet('out/*.parquet', union_by_name = true)` over a
/// run's directory works (docs/formats.md, "One file, one table"): a column
/// name means one type in every table, integers of different widths aside
/// (DuckDB widens them).
#[test]
fn a_column_name_has_one_type_across_the_tables() {
    let integer = |t: ColumnType| matches!(t, ColumnType::I32 | ColumnType::I64 | ColumnType::U32);
    let mut seen: std::collections::BTreeMap<&str, (ColumnType, &str)> = Default::default();
    for t in ALL_TABLES {
        for c in t.columns {
            let (ty, first) = *seen.entry(c.name).or_insert((c.ty, t.name));
            assert!(
                ty == c.ty || (integer(ty) && integer(c.ty)),
                "{}.{} is {:?}, {first}.{} is {ty:?}",
                t.name,
                c.name,
                c.ty,
                c.name
            );
        }
    }
}

/// The section of docs/formats.md whose heading names `file`: from that
/// heading to the next one.
fn section<'a>(doc: &'a str, file: &str) -> Option<&'a str> {
    let needle = format!("`{file}`");
    let start = doc
        .match_indices('#')
        .map(|(i, _)| i)
        .filter(|&i| i == 0 || doc.as_bytes()[i - 1] == b'\n')
        .find(|&i| doc[i..].lines().next().unwrap_or("").contains(&needle))?;
    let body_start = start + doc[start..].find('\n')? + 1;
    let end = doc[body_start..]
        .find("\n#")
        .map(|e| body_start + e + 1)
        .unwrap_or(doc.len());
    Some(&doc[body_start..end])
}

#[test]
fn formats_md_lists_every_declared_column_with_its_type_and_unit() {
    let doc = std::fs::read_to_string(root().join("docs/formats.md")).unwrap();
    let mut wrong = Vec::new();
    for t in ALL_TABLES {
        let expected = t.markdown();
        match section(&doc, t.file) {
            None => wrong.push(format!(
                "no heading naming `{}`; add a section with:\n{expected}",
                t.file
            )),
            Some(s) if !s.contains(&expected) => wrong.push(format!(
                "the section of `{}` does not hold the declared columns; expected:\n{expected}",
                t.file
            )),
            Some(_) => {}
        }
    }
    assert!(wrong.is_empty(), "docs/formats.md:\n{}", wrong.join("\n"));
}

/// Tables of the hybrid-test design, whose provenance is the design file (and, for the
/// comparison of a hybrid test with its rehearsal, the design run and the test's log).
const DESIGN_TABLES: [&str; 10] = [
    "actuator_layout",
    "pod",
    "reduction_validation",
    "interface_refinement",
    "hybrid_prototype",
    "rehearsal_summary",
    "rehearsal",
    "compare_test_summary",
    "compare_test_actuators",
    "compare_test",
];

/// Tables of a structure's history, made from a dataset of many events:
/// `quaketwin.event` names the dataset and `quaketwin.history` holds the
/// `history` step; each event's own processing is in its tables.
const DATASET_TABLES: [&str; 2] = ["history_modes", "history_events"];

fn run(pipeline: &Path, event: &str, out: &Path) {
    quaketwin::commands::run_pipeline(
        pipeline,
        &root().join("sample-records").join(event),
        out,
        true,
    )
    .unwrap();
}

/// Every Parquet file under `dir`, checked against the declaration its
/// `quaketwin.schema` names; returns the schema names seen.
fn check_outputs(dir: &Path, seen: &mut BTreeSet<String>) {
    // Each table in a folder of its own: nothing for `out/*.parquet` to mix.
    let mut paths = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let path = e.unwrap().path();
        assert!(
            path.extension().is_none_or(|x| x != "parquet"),
            "{}: a table directly in the output directory",
            path.display()
        );
        if path.is_dir() {
            for f in std::fs::read_dir(&path).unwrap() {
                let f = f.unwrap().path();
                if f.extension().is_some_and(|x| x == "parquet") {
                    let folder = path.file_name().unwrap();
                    assert_eq!(
                        f.file_stem().unwrap(),
                        folder,
                        "{}: not its table's folder",
                        f.display()
                    );
                    paths.push(f);
                }
            }
        }
    }
    paths.sort();
    for path in paths {
        let file = std::fs::File::open(&path).unwrap();
        let builder = ParquetRecordBatchReaderBuilder::try_new(file).unwrap();
        let schema = builder.schema().clone();
        let footer: Vec<String> = builder
            .metadata()
            .file_metadata()
            .key_value_metadata()
            .unwrap()
            .iter()
            .map(|kv| kv.key.clone())
            .collect();
        let p = path.display();
        let name = schema
            .metadata()
            .get(SCHEMA_KEY)
            .unwrap_or_else(|| panic!("{p}: no {SCHEMA_KEY}"));
        let declared = tables::by_name(name).unwrap_or_else(|| panic!("{p}: {name} undeclared"));
        let fields: Vec<&arrow_schema::Field> =
            schema.fields().iter().map(|f| f.as_ref()).collect();
        if let Err(e) = declared.check_fields(&fields) {
            panic!("{p}: {e}");
        }
        for f in &fields {
            let spec = declared.column(f.name()).unwrap();
            let unit = f.metadata().get(UNIT_KEY).map(String::as_str);
            if spec.family_prefix().is_some() && spec.unit == UNIT_VARIES {
                // Each member its own unit (twin_update's `param_<name>`: the
                // parameter's, from the twin).
                assert!(
                    unit.is_some_and(|u| !u.is_empty() && u != UNIT_VARIES),
                    "{p}: unit of {}: {unit:?}",
                    f.name()
                );
            } else {
                assert_eq!(unit, Some(spec.unit), "{p}: unit of {}", f.name());
            }
            // Issue 34: the meaning travels with the field.
            assert_eq!(
                f.metadata().get(FIELD_DESCRIPTION_KEY).map(String::as_str),
                Some(spec.doc),
                "{p}: description of {}",
                f.name()
            );
        }
        assert_eq!(
            schema.metadata().get(DESCRIPTION_KEY).map(String::as_str),
            Some(declared.doc),
            "{p}"
        );
        for key in [VERSION_KEY, SCHEMA_KEY, DESCRIPTION_KEY] {
            assert!(footer.iter().any(|k| k == key), "{p}: footer lacks {key}");
        }
        // Issue 15 item 2: every table made from an event says which event
        // and by which steps, in the Arrow schema (where pyarrow and polars
        // look) and in the footer.  The hybrid-test design tables carry
        // their own provenance (design file, twin, motion source) instead.
        if !DESIGN_TABLES.contains(&name.as_str()) && !DATASET_TABLES.contains(&name.as_str()) {
            for key in [EVENT_KEY, HISTORY_KEY] {
                assert!(footer.iter().any(|k| k == key), "{p}: footer lacks {key}");
            }
            let event: serde_json::Value =
                serde_json::from_str(schema.metadata().get(EVENT_KEY).unwrap()).unwrap();
            assert!(
                event["name"].as_str().is_some_and(|n| !n.is_empty()),
                "{p}: {event}"
            );
            let history: serde_json::Value =
                serde_json::from_str(schema.metadata().get(HISTORY_KEY).unwrap()).unwrap();
            let steps = history["steps"]
                .as_array()
                .unwrap_or_else(|| panic!("{p}: {history}"));
            // event/event.parquet is written as the records are read, before
            // any processing: its history is the reading's.
            assert!(
                name == "event" || steps.iter().any(|s| s["step"] == "units_to_si"),
                "{p}: the history does not start from the records: {history}"
            );
        }
        seen.insert(name.clone());
    }
}

#[test]
fn every_table_of_the_sample_runs_matches_its_declaration() {
    let quake = tempfile::tempdir().unwrap();
    run(
        &root().join("pipelines/post-earthquake.toml"),
        "synthetic-4storey-quake",
        quake.path(),
    );
    let design = tempfile::tempdir().unwrap();
    run(
        &root().join("pipelines/test-design.toml"),
        "synthetic-facade",
        design.path(),
    );
    // frequency_shifts/frequency_shifts.parquet: the ambient record against the quake's modes.
    let text = format!(
        "{}\n[[stage]]\nname = \"modal\"\nkind = \"modal\"\ninputs = [\"condition\"]\n[stage.params]\nreference_modes = {:?}\n",
        quaketwin::commands::INGEST_PIPELINE,
        quake.path().join("modes/modes.parquet").display().to_string()
    );
    let shifts = tempfile::tempdir().unwrap();
    let pipeline = shifts.path().join("shifts.toml");
    std::fs::write(&pipeline, text).unwrap();
    let out = shifts.path().join("out");
    run(&pipeline, "synthetic-4storey-ambient", &out);

    // modal_tracking/modal_tracking.parquet: a one-hour synthetic archive, 10-minute windows.
    let archive = tempfile::tempdir().unwrap();
    let settings = quaketwin::synth::archive::ArchiveSettings {
        days: 1,
        day_length_s: 3600.0,
        rate_hz: 20.0,
        channels: 4,
        ..Default::default()
    };
    quaketwin::synth::archive::write_archive(archive.path(), &settings).unwrap();
    let track = archive.path().join("track");
    let mut opts = quaketwin::track::TrackOptions::new(&archive.path().join("sds"), &track);
    opts.stationxml = Some(archive.path().join("station.xml"));
    opts.window = "10m".into();
    opts.end = Some("2026-01-01T01:00:00Z".into());
    quaketwin::track::run(&opts).unwrap();

    // history_*.parquet: the quake's run published as a one-event dataset.
    let dataset = tempfile::tempdir().unwrap();
    let partition = quaketwin::sinks::dataset::partition("building", "quake");
    quaketwin::sinks::dataset::publish_tables(dataset.path(), &partition, quake.path()).unwrap();
    let history = dataset.path().join("history");
    quaketwin::dataset_history::write_history(dataset.path(), None, &history).unwrap();
    for name in DATASET_TABLES {
        let file = history.join(format!("{name}/{name}.parquet"));
        let meta = quaketwin::sinks::parquet::ReadTable::open(&file).unwrap();
        assert!(meta
            .metadata(EVENT_KEY)
            .is_some_and(|e| e.contains("dataset")));
        assert!(meta
            .metadata(HISTORY_KEY)
            .is_some_and(|h| h.contains("\"history\"")));
    }

    // compare_test*.parquet: a short synthetic log of the facade design compared with its
    // rehearsal (the design run's rehearsal settings, read back from its summary).
    let lab = tempfile::tempdir().unwrap();
    let log_settings = quaketwin::synth::hybrid_log::HybridLogSettings {
        duration_s: Some(0.5),
        substeps: Some(20),
        ..Default::default()
    };
    quaketwin::stages::compare_test::write_synth_hybrid_log(
        design.path(),
        lab.path(),
        &log_settings,
    )
    .unwrap();
    let compared = lab.path().join("compare");
    let compare_settings = quaketwin::hybrid_test::CompareSettings {
        rehearsal: quaketwin::stages::compare_test::rehearsal_settings(design.path(), None)
            .unwrap(),
        ..Default::default()
    };
    quaketwin::stages::compare_test::compare_test(
        design.path(),
        lab.path(),
        &compared,
        compare_settings,
    )
    .unwrap();

    check_mode_shapes(quake.path());
    check_samples_time(quake.path());
    check_ascii_segments(quake.path());

    // lab_*.parquet: a small synthetic specimen test (plain Bouc–Wen, quasi-static protocol)
    // through the lab stage, its channels inferred from the CSV's header.
    let lab_event = tempfile::tempdir().unwrap();
    let t = quaketwin::synth::lab_specimen::reference_bwbn();
    let truth = quaketwin::lab::BwbnParameters::plain(
        t.initial_stiffness_n_per_m,
        t.post_yield_ratio,
        t.yield_displacement_m,
        t.beta,
        t.n,
    );
    let protocol = quaketwin::synth::lab_specimen::cyclic_protocol(&[0.005, 0.02, 0.04], 16);
    let rec = quaketwin::synth::lab_specimen::synthetic_specimen(truth, protocol, 0.0, 5);
    let mut csv = String::from("step,disp [mm],force [kN]\n");
    for (i, (x, f)) in rec
        .displacement_m
        .iter()
        .zip(&rec.measured_force_n)
        .enumerate()
    {
        csv.push_str(&format!("{i},{},{}\n", x * 1e3, f * 1e-3));
    }
    std::fs::write(lab_event.path().join("test.csv"), csv).unwrap();
    let lab_out = lab_event.path().join("out");
    std::fs::create_dir_all(&lab_out).unwrap();
    let lab_settings = quaketwin::lab::LabIdentifySettings {
        form: quaketwin::lab::FormChoice::Plain,
        draws: 8,
        refined: 1,
        ..Default::default()
    };
    quaketwin::stages::lab::identify_lab_event(lab_event.path(), &lab_settings, &lab_out).unwrap();

    let mut seen = BTreeSet::new();
    for dir in [
        quake.path(),
        design.path(),
        &out,
        &track,
        &history,
        &compared,
        &lab_out,
    ] {
        check_outputs(dir, &mut seen);
    }
    let never: Vec<&str> = ALL_TABLES
        .iter()
        .map(|t| t.name)
        .filter(|n| !seen.contains(*n))
        .collect();
    assert!(
        never.is_empty(),
        "tables the sample runs did not write: {never:?}"
    );
}

fn drift_columns(b: TableBuilder) -> TableBuilder {
    b.str(drift::DIRECTION, &["X"])
        .i32(drift::STOREY, vec![1])
        .str(drift::LOWER_CHANNEL, &["B-X"])
        .str(drift::UPPER_CHANNEL, &["F1-X"])
        .f64(drift::STOREY_HEIGHT_M, vec![3.0])
}

#[test]
fn the_writer_refuses_a_table_that_does_not_match_its_declaration() {
    let ok = drift_columns(TableBuilder::new(&DRIFT))
        .f64(drift::PEAK_DRIFT_RATIO, vec![0.01])
        .opt_f64(drift::RESIDUAL_DRIFT_M, vec![Some(0.002)])
        .opt_f64(drift::RESIDUAL_DRIFT_STD_M, vec![Some(0.001)])
        .opt_f64(drift::RESIDUAL_DRIFT_RATIO, vec![Some(0.002 / 3.0)])
        .opt_f64(drift::RESIDUAL_WINDOW_START_S, vec![None])
        .str(drift::KIND, &["measured"])
        .i32(drift::LOWER_LEVEL, vec![0])
        .i32(drift::UPPER_LEVEL, vec![1])
        .str(drift::METHOD, &["relative displacement of the two levels"])
        .str(drift::HEIGHT_SOURCE, &["stated"])
        .opt_str(drift::RESIDUAL_STATUS, &[Some("resolved")])
        .build()
        .unwrap();
    let unit = |name: &str| {
        ok.schema()
            .field_with_name(name)
            .unwrap()
            .metadata()
            .get(UNIT_KEY)
            .cloned()
    };
    assert_eq!(unit("storey_height_m").as_deref(), Some("m"));
    assert_eq!(unit("peak_drift_ratio").as_deref(), Some("1"));
    assert_eq!(ok.schema().metadata().get(SCHEMA_KEY).unwrap(), "drift");

    let refused = |b: TableBuilder, why: &str| {
        let e = b.build().unwrap_err();
        assert!(matches!(e, Error::Numerical(_)), "{e:?}");
        let msg = e.to_string();
        assert!(
            msg.contains("drift/drift.parquet") && msg.contains(why),
            "{msg}"
        );
    };
    // Missing.
    refused(
        drift_columns(TableBuilder::new(&DRIFT)),
        "peak_drift_ratio missing",
    );
    // Wrong type.
    refused(
        drift_columns(TableBuilder::new(&DRIFT)).opt_f64(drift::PEAK_DRIFT_RATIO, vec![None]),
        "peak_drift_ratio",
    );
    refused(
        drift_columns(TableBuilder::new(&DRIFT)).i32(drift::PEAK_DRIFT_RATIO, vec![1]),
        "declared float64",
    );
    // Extra.
    refused(
        drift_columns(TableBuilder::new(&DRIFT))
            .f64(drift::PEAK_DRIFT_RATIO, vec![0.01])
            .f64("extra", vec![1.0]),
        "extra",
    );
    // Out of order.
    refused(
        TableBuilder::new(&DRIFT)
            .i32(drift::STOREY, vec![1])
            .str(drift::DIRECTION, &["X"])
            .str(drift::LOWER_CHANNEL, &["B-X"])
            .str(drift::UPPER_CHANNEL, &["F1-X"])
            .f64(drift::STOREY_HEIGHT_M, vec![3.0])
            .f64(drift::PEAK_DRIFT_RATIO, vec![0.01]),
        "out of order",
    );
}

#[test]
fn a_quaketwin_file_of_the_wrong_type_is_an_input_error_naming_file_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("samples/samples.parquet");
    // acc_m_s2 as Int64: not what samples/samples.parquet declares.
    let batch = TableBuilder::untyped()
        .str(tables::samples::CHANNEL_ID, &["B-X"])
        .i64(tables::samples::ACC_M_S2, vec![1])
        .opt_f64(tables::samples::VEL_M_S, vec![None])
        .opt_f64(tables::samples::DISP_M, vec![None])
        .build()
        .unwrap();
    let source = quaketwin::vocab::SourceRef {
        file: "b.csv".into(),
        member: None,
        column: None,
        format: "csv".into(),
    };
    let channel =
        quaketwin::vocab::Channel::new("B-X", quaketwin::vocab::Units::MPerS2, 100.0, source);
    let meta = vec![
        (SCHEMA_KEY.to_string(), "samples".to_string()),
        (
            "quaketwin.channels".to_string(),
            serde_json::to_string(&[channel]).unwrap(),
        ),
    ];
    write_parquet(&path, &[batch], &meta).unwrap();
    let e = quaketwin::sinks::event_tables::read_samples(&path).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, Error::Input { .. }), "{e:?}");
    assert!(
        msg.contains("samples/samples.parquet")
            && msg.contains("acc_m_s2")
            && msg.contains("float64"),
        "{msg}"
    );
}

/// The rows of a Parquet file (all batches).
fn read_batches(path: &Path) -> Vec<arrow_array::RecordBatch> {
    quaketwin::sinks::parquet::ReadTable::open(path)
        .unwrap()
        .batches
}

/// Issue 34: `mode_shapes/mode_shapes.parquet` is `modes/modes.parquet`'s shapes in long
/// form — one row per mode and output channel, the same numbers bit for
/// bit, the channel named on the row with its level (channels/channels.parquet) and
/// direction (`quaketwin.output_directions`).
fn check_mode_shapes(out: &Path) {
    use arrow_array::{Array, Float64Array, Int32Array, StringArray, UInt32Array};
    let (modes, channels) =
        quaketwin::sinks::modal_tables::read_modes(&out.join("modes/modes.parquet")).unwrap();
    assert!(
        !modes.is_empty() && channels.len() >= 4,
        "{} modes",
        modes.len()
    );
    let directions: Vec<String> = serde_json::from_str(
        quaketwin::sinks::parquet::ReadTable::open(&out.join("modes/modes.parquet"))
            .unwrap()
            .metadata("quaketwin.output_directions")
            .unwrap(),
    )
    .unwrap();
    let ch = out.join("channels/channels.parquet");
    let level_of: std::collections::HashMap<String, i64> =
        crate::common::column_str(&ch, "channel_id")
            .into_iter()
            .zip(crate::common::column_i64(&ch, "level"))
            .collect();
    let batches = read_batches(&out.join("mode_shapes/mode_shapes.parquet"));
    let rows: usize = batches.iter().map(|b| b.num_rows()).sum();
    assert_eq!(rows, modes.len() * channels.len());
    let mut row = 0;
    for b in &batches {
        let col = |n: &str| b.column_by_name(n).unwrap().clone();
        let mode = col("mode");
        let mode = mode.as_any().downcast_ref::<UInt32Array>().unwrap();
        let id = col("channel_id");
        let id = id.as_any().downcast_ref::<StringArray>().unwrap();
        let level = col("level");
        let level = level.as_any().downcast_ref::<Int32Array>().unwrap();
        let dir = col("direction");
        let dir = dir.as_any().downcast_ref::<StringArray>().unwrap();
        let f = |n: &str| {
            col(n)
                .as_any()
                .downcast_ref::<Float64Array>()
                .unwrap()
                .clone()
        };
        let (freq, re, im, sd) = (f("frequency_hz"), f("real"), f("imag"), f("modulus_std"));
        for i in 0..b.num_rows() {
            let (m, k) = (row / channels.len(), row % channels.len());
            let x = &modes[m];
            assert_eq!(mode.value(i) as usize, m + 1);
            assert_eq!(id.value(i), channels[k]);
            assert_eq!(freq.value(i).to_bits(), x.frequency_hz.to_bits());
            assert_eq!(
                re.value(i).to_bits(),
                x.shape[k].re.to_bits(),
                "mode {m} {k}"
            );
            assert_eq!(
                im.value(i).to_bits(),
                x.shape[k].im.to_bits(),
                "mode {m} {k}"
            );
            assert_eq!(
                sd.value(i).to_bits(),
                x.shape_std[k].to_bits(),
                "mode {m} {k}"
            );
            assert_eq!(dir.value(i), directions[k]);
            assert!(!level.is_null(i), "{}: no level", channels[k]);
            assert_eq!(level.value(i) as i64, level_of[&channels[k]]);
            row += 1;
        }
    }
}

/// Issue 34: samples/samples.parquet's `time` is filled where the event's origin is
/// known.  The sample event's records (AT2, CSV) have no start time of their
/// own, its manifest an origin time (2026-01-15T10:20:30Z): every row's time
/// is that origin + `t_s`, and channels/channels.parquet says so in `time_source`.
fn check_samples_time(out: &Path) {
    use arrow_array::{Array, Float64Array, TimestampNanosecondArray};
    let origin_ns = 1_768_472_430_000_000_000i64; // 2026-01-15T10:20:30Z
    let sources = crate::common::column_str(&out.join("channels/channels.parquet"), "time_source");
    assert!(
        !sources.is_empty() && sources.iter().all(|s| s == "origin_time"),
        "{sources:?}"
    );
    let mut rows = 0;
    for b in read_batches(&out.join("samples/samples.parquet")) {
        let t = b.column_by_name("t_s").unwrap();
        let t = t.as_any().downcast_ref::<Float64Array>().unwrap();
        let time = b.column_by_name("time").unwrap();
        let time = time
            .as_any()
            .downcast_ref::<TimestampNanosecondArray>()
            .unwrap();
        assert_eq!(time.timezone(), Some("UTC"));
        assert_eq!(
            time.null_count(),
            0,
            "time null although the origin is known"
        );
        for i in 0..b.num_rows() {
            let expected = origin_ns + (t.value(i) * 1e9).round() as i64;
            assert!((time.value(i) - expected).abs() <= 1, "row {i}");
        }
        rows += b.num_rows();
    }
    assert!(rows > 1000, "{rows} rows");
}

/// Issue 34: segment labels are ASCII (`L0-L1`: `WHERE segment = 'L0-L1'`
/// matches), in both tables that carry them.
fn check_ascii_segments(out: &Path) {
    let mut seen = 0;
    for file in [
        "bouc_wen/bouc_wen.parquet",
        "hysteresis_fit/hysteresis_fit.parquet",
    ] {
        for s in crate::common::column_str(&out.join(file), "segment") {
            assert!(s.is_empty() || s.is_ascii(), "{file}: segment {s:?}");
            if !s.is_empty() {
                assert!(
                    s.starts_with('L') && s.contains("-L"),
                    "{file}: segment {s:?}"
                );
                seen += 1;
            }
        }
    }
    assert!(seen > 0, "no segment label to check");
}

/// Issue 34: with neither a record start nor an origin time, `time` is
/// null (never a made-up 1970 date) and `time_source` says `unknown`.
#[test]
fn samples_time_is_null_only_when_neither_start_nor_origin_is_known() {
    use arrow_array::Array;
    let dir = root().join("sample-records/synthetic-4storey-quake");
    let mut event = quaketwin::event_folder::load(&dir).unwrap().event;
    let record_start = 1_700_000_000_000_000_000i64;
    event.records[0].channel.start_ns = Some(record_start);
    let (start, source) =
        quaketwin::sinks::event_tables::time_base(&event.records[0].channel, event.origin_ns);
    assert_eq!((start, source), (Some(record_start), "record_start"));
    let (_, source) =
        quaketwin::sinks::event_tables::time_base(&event.records[1].channel, event.origin_ns);
    assert_eq!(source, "origin_time");
    event.origin_ns = None;
    let batches = quaketwin::sinks::event_tables::samples_table(&event, &[]).unwrap();
    let first_id = event.records[0].channel.id.clone();
    for b in &batches {
        let id = b.column_by_name("channel_id").unwrap();
        let id = id
            .as_any()
            .downcast_ref::<arrow_array::StringArray>()
            .unwrap();
        let time = b.column_by_name("time").unwrap();
        if id.value(0) == first_id {
            let time = time
                .as_any()
                .downcast_ref::<arrow_array::TimestampNanosecondArray>()
                .unwrap();
            assert_eq!(time.null_count(), 0);
            assert_eq!(time.value(0), record_start);
        } else {
            assert_eq!(time.null_count(), b.num_rows(), "{}", id.value(0));
        }
    }
    let (none, source) = quaketwin::sinks::event_tables::time_base(&event.records[1].channel, None);
    assert_eq!((none, source), (None, "unknown"));
}
