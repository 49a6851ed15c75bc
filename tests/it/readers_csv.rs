//! CSV reader on crafted files: quoting (through the `csv` crate), ISO 8601
//! and epoch time columns, text columns, semicolons, the bounded resampling
//! grid, and units per column from an event manifest.

use std::time::Instant;

use quaketwin::error::Error;
use quaketwin::event_folder;
use quaketwin::readers::csv::{
    data_like, decimal_to_ns, epoch_unit, parse_datetime_cell, parse_start_time, Zone,
    MAX_RESAMPLE_GROWTH,
};
use quaketwin::readers::resample::check_grid;
use quaketwin::readers::{self, FileContents, ReadOptions};
use quaketwin::vocab::{epoch_ns_from_civil, QaFlag, SourceRef, Units};

fn src(name: &str) -> SourceRef {
    SourceRef {
        file: name.to_string(),
        ..Default::default()
    }
}

fn read(name: &str, text: &str) -> quaketwin::Result<FileContents> {
    readers::csv::read(text.as_bytes(), &src(name), &ReadOptions::default())
}

fn input_error(e: Error) -> (quaketwin::Location, String) {
    match e {
        Error::Input { location, message } => (*location, message),
        other => panic!("expected an input error, got {other:?}"),
    }
}

fn resampled(fc: &FileContents) -> bool {
    fc.records[0]
        .channel
        .qa
        .iter()
        .any(|q| matches!(q, QaFlag::Resampled { .. }))
}

/// 2024-03-01T12:00:00 UTC.
fn noon() -> i64 {
    epoch_ns_from_civil(2024, 3, 1, 12, 0, 0.0).unwrap()
}

#[test]
fn quoted_fields_in_preamble_and_text_column_with_iso_timestamps() {
    let mut text = String::from(
        "Comment:,\"a, b\"\n\"Site: lab, bay 2\",\"x\"\nDeviceTag:,\"roof, north\"\n\n\
         timestamp,station,note,acc_x [g],acc_y [m/s2]\n",
    );
    for i in 0..6 {
        text += &format!(
            "2024-03-01T12:00:00.{:03}Z,ST01,\"a, b\",{},{}\n",
            10 * i,
            0.1 * i as f64,
            -(i as f64)
        );
    }
    let fc = read("q.csv", &text).unwrap();
    assert_eq!(fc.records.len(), 2, "text columns are not read");
    for r in &fc.records {
        let c = &r.channel;
        assert_eq!(c.sampling_rate_hz, 100.0);
        assert_eq!(c.start_ns, Some(noon()));
        assert_eq!(c.station.as_deref(), Some("roof, north"));
        assert!(
            c.inferred.iter().any(|s| s.contains("Z = UTC")),
            "{:?}",
            c.inferred
        );
        assert!(c.missing.is_empty(), "{:?}", c.missing);
        assert!(!c.qa.iter().any(|q| matches!(q, QaFlag::Resampled { .. })));
    }
    assert_eq!(fc.records[0].channel.units, Units::G);
    assert_eq!(fc.records[1].channel.units, Units::MPerS2);
    assert_eq!(fc.records[0].samples[3], 0.1 * 3.0);
    assert_eq!(
        fc.records[1].samples,
        vec![-0.0, -1.0, -2.0, -3.0, -4.0, -5.0]
    );
    assert_eq!(
        fc.records[0].channel.source.column.as_deref(),
        Some("acc_x [g]")
    );
}

#[test]
fn iso_timestamp_variants_give_rate_and_utc_start() {
    // 200 Hz starting at 12:00:00.005 local time of each variant.
    let start_utc = noon() + 5_000_000;
    let hour = 3_600_000_000_000i64;
    let cases: [(&str, &str, i64, &str); 6] = [
        ("T", "Z", start_utc, "Z = UTC"),
        ("T", "", start_utc, "taken as UTC"),
        (" ", "", start_utc, "taken as UTC"),
        ("T", "+01:00", start_utc - hour, "UTC+01:00"),
        (" ", "+01:00", start_utc - hour, "UTC+01:00"),
        ("T", "-0500", start_utc + 5 * hour, "UTC-05:00"),
    ];
    for (sep, zone, start, why) in cases {
        let mut text = String::from("time,acc\n");
        for i in 0..8 {
            text += &format!("2024-03-01{sep}12:00:00.{:03}{zone},{i}\n", 5 + 5 * i);
        }
        let fc = read("v.csv", &text).unwrap_or_else(|e| panic!("{sep:?}{zone:?}: {e}"));
        let c = &fc.records[0].channel;
        assert_eq!(c.sampling_rate_hz, 200.0, "{sep:?}{zone:?}");
        assert_eq!(c.start_ns, Some(start), "{sep:?}{zone:?}");
        assert!(
            c.inferred.iter().any(|s| s.contains(why)),
            "{sep:?}{zone:?}: {:?}",
            c.inferred
        );
        assert_eq!(fc.records[0].samples.len(), 8);
        assert!(!resampled(&fc));
    }
}

#[test]
fn date_time_column_under_another_name_is_the_time_column() {
    let text = "UTC;a_x\n2024-03-01 12:00:00.00;1\n2024-03-01 12:00:00.02;2\n\
                2024-03-01 12:00:00.04;3\n2024-03-01 12:00:00.06;4\n";
    let fc = read("u.csv", text).unwrap();
    assert_eq!(fc.records[0].channel.sampling_rate_hz, 50.0);
    assert_eq!(fc.records[0].channel.start_ns, Some(noon()));
}

#[test]
fn iso_time_column_errors_name_the_line() {
    // The bad row after 4 good ones: the table is found, then each row is read.
    let bad = "timestamp,acc_x\n2024-03-01T12:00:00.00Z,1\n2024-03-01T12:00:00.01Z,2\n\
               2024-03-01T12:00:00.02Z,3\n2024-03-01T12:00:00.03Z,4\nyesterday,5\n\
               2024-03-01T12:00:00.05Z,6\n";
    let (loc, msg) = input_error(read("b.csv", bad).unwrap_err());
    assert_eq!(loc.file, "b.csv");
    assert_eq!(loc.line, Some(6));
    assert_eq!(loc.channel.as_deref(), Some("timestamp"));
    assert!(msg.contains("\"yesterday\""), "{msg}");
    // 30 February does not exist: the calendar is checked, not just the shape.
    let feb30 = bad.replace("yesterday", "2024-02-30T12:00:00.04Z");
    let (loc, _) = input_error(read("b.csv", &feb30).unwrap_err());
    assert_eq!(loc.line, Some(6));
    let back = bad.replace("yesterday", "2024-03-01T12:00:00.02Z");
    let (loc, msg) = input_error(read("b.csv", &back).unwrap_err());
    assert_eq!(loc.line, Some(6));
    assert!(msg.contains("does not increase"), "{msg}");
}

#[test]
fn epoch_milliseconds_and_seconds_time_columns() {
    // 2024-03-01T12:00:00.005Z in ms since the epoch, 100 Hz.
    let t0_ms: i64 = 1_709_294_400_005;
    assert_eq!(t0_ms * 1_000_000, noon() + 5_000_000);
    let mut ms = String::from("timestamp,acc_x\n");
    let mut secs = String::from("time,acc_x\n");
    for i in 0..10i64 {
        ms += &format!("{},{i}\n", t0_ms + 10 * i);
        secs += &format!(
            "{}.{:03},{i}\n",
            (t0_ms + 10 * i) / 1000,
            (t0_ms + 10 * i) % 1000
        );
    }
    for (text, unit) in [(ms, "milliseconds"), (secs, "seconds")] {
        let fc = read("e.csv", &text).unwrap();
        let c = &fc.records[0].channel;
        assert_eq!(c.sampling_rate_hz, 100.0, "{unit}");
        assert_eq!(c.start_ns, Some(t0_ms * 1_000_000), "{unit}: exact start");
        assert!(
            c.inferred
                .iter()
                .any(|s| s.contains(&format!("epoch {unit}"))),
            "{:?}",
            c.inferred
        );
        assert_eq!(fc.records[0].samples.len(), 10);
        assert!(!resampled(&fc), "{unit}");
    }
    // A stated unit wins over the magnitude rule: ms since the epoch in `time[ms]`.
    let text = format!(
        "time[ms],acc_x\n{}\n",
        (0..5)
            .map(|i| format!("{},{i}", t0_ms + 8 * i))
            .collect::<Vec<_>>()
            .join("\n")
    );
    let c = read("e.csv", &text).unwrap().records[0].channel.clone();
    assert_eq!(c.sampling_rate_hz, 125.0);
    assert_eq!(c.start_ns, Some(t0_ms * 1_000_000));
    // An elapsed-time column is not epoch time: no start time from it.
    let c = read("e.csv", "t,acc\n0,1\n0.5,2\n1.0,3\n1.5,4\n")
        .unwrap()
        .records[0]
        .channel
        .clone();
    assert_eq!(c.sampling_rate_hz, 2.0);
    assert_eq!(c.start_ns, None);
}

#[test]
fn semicolons_with_decimal_points_and_quoted_text() {
    let text = "\"time [s]\";\"acc_x (g)\";\"comment\"\n0.000;0.25;\"north; roof\"\n\
                0.005;-0.5;\"\"\"quoted\"\"\"\n0.010;1.5e-1;plain\n0.015;2;\n";
    let fc = read("s.csv", text).unwrap();
    assert_eq!(fc.records.len(), 1);
    let r = &fc.records[0];
    assert_eq!(r.channel.units, Units::G);
    assert_eq!(r.channel.sampling_rate_hz, 200.0);
    assert_eq!(r.samples, vec![0.25, -0.5, 0.15, 2.0]);
    // Forced by `sep=;` too.
    let fc = read("s.csv", &format!("sep=;\n{text}")).unwrap();
    assert_eq!(fc.records[0].samples, vec![0.25, -0.5, 0.15, 2.0]);
}

#[test]
fn text_column_named_like_acceleration_is_skipped_not_fatal() {
    let text = "time,accelerometer,acc_x\n0,SN-1,1\n0.1,SN-1,2\n0.2,SN-1,3\n0.3,SN-1,4\n";
    let fc = read("t.csv", text).unwrap();
    assert_eq!(fc.records.len(), 1);
    assert_eq!(fc.records[0].samples, vec![1.0, 2.0, 3.0, 4.0]);
    assert!(fc.records[0]
        .channel
        .qa
        .iter()
        .any(|q| matches!(q, QaFlag::Note { text } if text.contains("accelerometer"))));
    // Named explicitly, it is an error naming line and column.
    let opts = ReadOptions {
        columns: Some(vec!["accelerometer".into()]),
        ..Default::default()
    };
    let (loc, msg) =
        input_error(readers::csv::read(text.as_bytes(), &src("t.csv"), &opts).unwrap_err());
    assert_eq!(loc.line, Some(2));
    assert_eq!(loc.channel.as_deref(), Some("accelerometer"));
    assert!(msg.contains("SN-1"), "{msg}");
}

/// 199 rows at 100 Hz, then a last row at `last` seconds.
fn jump_file(last: &str, columns: usize) -> String {
    let head: Vec<String> = (0..columns).map(|c| format!("acc_{c}")).collect();
    let mut text = format!("time,{}\n", head.join(","));
    let row = vec!["0.5"; columns].join(",");
    for i in 0..199 {
        text += &format!("{:.2},{row}\n", i as f64 * 0.01);
    }
    text += &format!("{last},{row}\n");
    text
}

#[test]
fn resampling_grid_is_bounded_before_allocation() {
    for (last, columns) in [("1e12", 1), ("1000000", 1), ("1000000", 3), ("1e300", 2)] {
        let t = Instant::now();
        let (loc, msg) = input_error(read("j.csv", &jump_file(last, columns)).unwrap_err());
        assert!(
            t.elapsed().as_secs_f64() < 2.0,
            "refused without building the grid"
        );
        assert_eq!(loc.file, "j.csv");
        assert_eq!(loc.line, Some(201), "the row after the jump: {msg}");
        assert_eq!(loc.channel.as_deref(), Some("time"));
        assert!(msg.contains("resampling"), "{msg}");
        assert!(msg.contains(&format!("{MAX_RESAMPLE_GROWTH} ×")), "{msg}");
    }
    // A gap the grid can hold is still resampled and flagged: 199 rows + 1 s gap.
    let fc = read("j.csv", &jump_file("2.98", 1)).unwrap();
    assert!(resampled(&fc));
    assert_eq!(fc.records[0].samples.len(), 299);
    assert!(fc.records[0]
        .channel
        .qa
        .iter()
        .any(|q| matches!(q, QaFlag::Gap { .. })));
}

#[test]
fn manifest_units_per_csv_column() {
    let dir = tempfile::tempdir().unwrap();
    let mut csv = String::from("time,acc_x,acc_y,acc_z [g]\n");
    for i in 0..50 {
        csv += &format!(
            "{:.2},{},{},{}\n",
            i as f64 * 0.01,
            0.01 * i as f64,
            0.1,
            1.0
        );
    }
    std::fs::write(dir.path().join("floor.csv"), csv).unwrap();
    std::fs::write(
        dir.path().join("event.toml"),
        "[[channel]]\nfile = \"floor.csv\"\ncolumn = \"acc_x\"\nid = \"X\"\nunits = \"g\"\n\
         [[channel]]\nfile = \"floor.csv\"\ncolumn = \"acc_y\"\nid = \"Y\"\nunits = \"m/s2\"\n\
         [[channel]]\nfile = \"floor.csv\"\ncolumn = \"acc_z [g]\"\nid = \"Z\"\n\
         [[channel]]\nfile = \"floor.csv\"\ncolumn = 2\nid = \"Y2\"\nunits = \"cm/s2\"\n",
    )
    .unwrap();
    let loaded = event_folder::load(dir.path()).unwrap();
    let got: Vec<(&str, Units, f64)> = loaded
        .event
        .records
        .iter()
        .map(|r| (r.channel.id.as_str(), r.channel.units.clone(), r.samples[1]))
        .collect();
    assert_eq!(
        got,
        [
            ("X", Units::G, 0.01),
            ("Y", Units::MPerS2, 0.1),
            ("Z", Units::G, 1.0),
            ("Y2", "cm/s2".parse::<Units>().unwrap(), 0.1),
        ]
    );
    for r in &loaded.event.records {
        assert!(
            !r.channel.missing.contains(&"units".to_string()),
            "{}: {:?}",
            r.channel.id,
            r.channel.missing
        );
        assert_eq!(r.channel.sampling_rate_hz, 100.0);
    }
}

#[test]
fn semicolon_with_units_and_time() {
    let text = "# test\ntime[s];acc_x[m/s2];acc_y (g);temp\n0.00;1;2;20\n0.01;3;4;20\n0.02;5;6;20\n0.03;7;8;20\n";
    let fc = read("x.csv", text).unwrap();
    assert_eq!(fc.records.len(), 2);
    assert_eq!(fc.records[0].channel.units, Units::MPerS2);
    assert_eq!(fc.records[1].channel.units, Units::G);
    assert_eq!(fc.records[0].channel.sampling_rate_hz, 100.0);
    assert_eq!(fc.records[1].samples, vec![2.0, 4.0, 6.0, 8.0]);
    assert!(fc.records[0].channel.missing.is_empty());
}

#[test]
fn uneven_time_is_resampled() {
    // v = 10 t sampled at uneven times: linear resampling is exact.
    let ts = [0.0, 0.1, 0.19, 0.31, 0.4, 0.5, 0.6];
    let mut text = String::from("t,a_x\n");
    for t in ts {
        text += &format!("{t},{}\n", 10.0 * t);
    }
    let fc = read("x.csv", &text).unwrap();
    let r = &fc.records[0];
    assert_eq!(r.channel.sampling_rate_hz, 10.0);
    assert!(resampled(&fc));
    assert_eq!(r.samples.len(), 7);
    for (i, v) in r.samples.iter().enumerate() {
        assert!((v - i as f64).abs() < 1e-9, "{i}: {v}");
    }
}

#[test]
fn whitespace_no_header_needs_rate() {
    let text = "1 2\n3 4\n5 6\n";
    let opts = ReadOptions {
        sampling_rate_hz: Some(50.0),
        columns: Some(vec!["1".into()]),
        ..Default::default()
    };
    let fc = readers::csv::read(text.as_bytes(), &src("x.csv"), &opts).unwrap();
    assert_eq!(fc.records[0].samples, vec![2.0, 4.0, 6.0]);
    let e = readers::csv::read(
        text.as_bytes(),
        &src("x.csv"),
        &ReadOptions {
            columns: Some(vec!["0".into()]),
            ..Default::default()
        },
    );
    assert!(e.is_err());
}

#[test]
fn xsens_start_time_zone() {
    let (ns, _) = parse_start_time("2025-03-06_12:26:07_000 PST").unwrap();
    assert_eq!(ns, epoch_ns_from_civil(2025, 3, 6, 20, 26, 7.0).unwrap());
    let (ns, _) = parse_start_time("2025-04-11_11:49:50_000 PDT").unwrap();
    assert_eq!(ns, epoch_ns_from_civil(2025, 4, 11, 18, 49, 50.0).unwrap());
}

#[test]
fn exact_decimal_epoch_values() {
    assert_eq!(
        decimal_to_ns("1709294400.005", 1_000_000_000),
        Some(1_709_294_400_005_000_000)
    );
    assert_eq!(
        decimal_to_ns("1709294400005", 1_000_000),
        Some(1_709_294_400_005_000_000)
    );
    assert_eq!(decimal_to_ns("-1.5", 1_000), Some(-1_500));
    assert_eq!(
        decimal_to_ns("1.7e12", 1_000_000),
        None,
        "exponent: f64 path"
    );
    assert_eq!(
        decimal_to_ns("99999999999", 1_000_000_000),
        None,
        "past i64 ns"
    );
    assert_eq!(decimal_to_ns(".", 1), None);
}

#[test]
fn epoch_unit_by_magnitude() {
    assert_eq!(epoch_unit(1.7e9).1, "seconds");
    assert_eq!(epoch_unit(1.7e12).1, "milliseconds");
    assert_eq!(epoch_unit(1.7e15).1, "microseconds");
    assert_eq!(epoch_unit(1.7e18).1, "nanoseconds");
}

#[test]
fn datetime_cells() {
    let noon = noon();
    let h = 3_600_000_000_000;
    assert_eq!(
        parse_datetime_cell("2024-03-01T12:00:00.005Z"),
        Some((noon + 5_000_000, Zone::Z))
    );
    assert_eq!(
        parse_datetime_cell("2024-03-01 12:00:00+01:00"),
        Some((noon - h, Zone::Offset(3600)))
    );
    assert_eq!(
        parse_datetime_cell("2024-03-01T12:00:00.123456789"),
        Some((noon + 123_456_789, Zone::Naive))
    );
    assert_eq!(parse_datetime_cell("2024-02-30T12:00:00"), None);
    assert_eq!(parse_datetime_cell("2024-03-01"), None);
    assert_eq!(parse_datetime_cell("12:00:00"), None);
}

#[test]
fn rows_know_which_are_data() {
    let rec = |f: &[&str]| csv::StringRecord::from(f.to_vec());
    assert!(!data_like(&rec(&["SampleRate:", "60"])));
    assert!(data_like(&rec(&[
        "2024-03-01T12:00:00Z",
        "ST01",
        "a, b",
        "0.1"
    ])));
    assert!(!data_like(&rec(&["ST01", "site", "0.1"])));
    assert!(data_like(&rec(&["ST01", "0.2", "0.1"])));
}

#[test]
fn absurd_spans_are_refused_before_allocating() {
    assert!(check_grid(200, 1e9, 0.01).is_err());
    assert!(check_grid(200, f64::INFINITY, 0.01).is_err());
    assert_eq!(check_grid(200, 1.99, 0.01), Ok(200));
}

/// The bound of fields per line a delimiter could give — scanned in
/// parallel, lines without whitespace not split — is the one of splitting
/// every line, one thread (as first written).
#[test]
fn most_fields_in_parallel_is_the_line_by_line_bound() {
    use quaketwin::readers::csv::most_fields_by;
    fn line_by_line(text: &str, delimiter: Option<u8>) -> Option<usize> {
        let per_line = |l: &str| match delimiter {
            Some(d) => l.bytes().filter(|&b| b == d).count() + 1,
            None => l.split_whitespace().count(),
        };
        match delimiter {
            Some(_) if text.contains('"') => None,
            _ => Some(text.split('\n').map(per_line).max().unwrap_or(0)),
        }
    }
    let long: String = (0..5000)
        .map(|i| format!("{i},{}.5,{}\r\n", i * 2, -i))
        .collect();
    let texts = [
        "t,a,b\n0,1,2\n1,2,3\n".to_string(),
        "a b  c\n1 2 3 4\n".to_string(),
        "x\u{a0}y\u{3000}z\n1\n".to_string(),
        "1\x0b2\x0c3\n\n\r\n".to_string(),
        "a;b;\"c;d\"\n".to_string(),
        "1,2\r\n3,4,5\r\n".to_string(),
        long.replace(',', " "),
        // Line feeds alone: whole chunks without a delimiter or whitespace
        // are counted without splitting their lines.
        long.replace('\r', ""),
        long.replace('\r', "").replace(',', "\n"),
        "\n\n\n".to_string(),
        long,
    ];
    for t in &texts {
        for d in [Some(b','), Some(b'\t'), Some(b';'), None] {
            assert_eq!(
                most_fields_by(t, d),
                line_by_line(t, d),
                "{d:?} on {:?}",
                &t[..t.len().min(40)]
            );
        }
    }
}
