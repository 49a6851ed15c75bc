//! Binary and sensor-export readers on the real records in ../shared/records
//! (MiniSEED + StationXML, SAC, Xsens CSV) and MCAP round trips, plus crafted
//! bad inputs.  Reference numbers for MiniSEED and SAC come from ObsPy
//! (tests/reference/obspy_reference.py); the data files are never copied here.

use std::io::Cursor;
use std::path::Path;

use quaketwin::error::Error;
use quaketwin::readers::mseed::{
    decode_steim, join_segments, rate_from_factor, ByteOrder, Segment,
};
use quaketwin::readers::{self, mcap as mcap_reader, stationxml, FileContents, ReadOptions};
use quaketwin::rng::SplitMix64;
use quaketwin::sinks::mcap_writer::{self, McapMessages, McapWriteOptions};
use quaketwin::vocab::{
    epoch_ns_from_civil, parse_iso8601_ns, Channel, Direction, Event, QaFlag, Record, SourceRef,
    Units,
};

const RECORDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/records");

fn bytes_of(rel: &str) -> Vec<u8> {
    let p = format!("{RECORDS}/{rel}");
    std::fs::read(&p).unwrap_or_else(|e| panic!("{p}: {e}"))
}

fn src(name: &str) -> SourceRef {
    SourceRef {
        file: name.to_string(),
        ..Default::default()
    }
}

fn read_as(format: readers::Format, rel: &str) -> FileContents {
    let name = Path::new(rel)
        .file_name()
        .unwrap()
        .to_string_lossy()
        .to_string();
    readers::read(format, &bytes_of(rel), &src(&name), &ReadOptions::default())
        .unwrap_or_else(|e| panic!("{rel}: {e}"))
}

fn input_error(e: Error) -> (quaketwin::Location, String) {
    match e {
        Error::Input { location, message } => (*location, message),
        other => panic!("expected an input error, got {other:?}"),
    }
}

const MSEED_DIR: &str = "nsmp-8040-anchorage-downhole-2018-mseed";

/// (id, first three samples, last three samples, sum of all samples), from ObsPy 1.5.1.
const OBSPY_MSEED: [(&str, [i64; 3], [i64; 3], i64); 21] = [
    (
        "NP.8040.D0.HNE",
        [-18241, -18269, -18222],
        [-19063, -19010, -18947],
        -1206808626,
    ),
    (
        "NP.8040.D0.HNN",
        [26775, 26713, 26684],
        [26688, 26848, 26820],
        1762589169,
    ),
    (
        "NP.8040.D0.HNZ",
        [17310, 17532, 17720],
        [17938, 17724, 17534],
        1156169386,
    ),
    (
        "NP.8040.D1.HNE",
        [-9109, -9080, -9110],
        [-9741, -9726, -9734],
        -593447702,
    ),
    (
        "NP.8040.D1.HNN",
        [-30374, -30398, -30419],
        [-30448, -30415, -30393],
        -1997885445,
    ),
    (
        "NP.8040.D1.HNZ",
        [6313, 6308, 6261],
        [6443, 6331, 6300],
        419258392,
    ),
    (
        "NP.8040.D2.HNE",
        [-3863, -3877, -3904],
        [-4479, -4535, -4539],
        -251391862,
    ),
    (
        "NP.8040.D2.HNN",
        [33941, 33958, 33995],
        [33818, 33830, 33817],
        2243115330,
    ),
    (
        "NP.8040.D2.HNZ",
        [26706, 26670, 26618],
        [26826, 26819, 26876],
        1763667699,
    ),
    (
        "NP.8040.D3.HNE",
        [84301, 91951, 76227],
        [79335, 101095, 82731],
        5748773402,
    ),
    (
        "NP.8040.D3.HNN",
        [19054, 19038, 19067],
        [19146, 19180, 19230],
        1273639750,
    ),
    (
        "NP.8040.D3.HNZ",
        [-30918, -30923, -30904],
        [-30741, -30726, -30689],
        -2041770137,
    ),
    (
        "NP.8040.D4.HNE",
        [-12342, -12319, -12327],
        [-13047, -13022, -13038],
        -814995457,
    ),
    (
        "NP.8040.D4.HNN",
        [18621, 18617, 18621],
        [18937, 18944, 19002],
        1233788039,
    ),
    (
        "NP.8040.D4.HNZ",
        [12467, 12461, 12505],
        [12718, 12770, 12750],
        827445683,
    ),
    (
        "NP.8040.D5.HNE",
        [6750, 6755, 6740],
        [6386, 6345, 6299],
        448277958,
    ),
    (
        "NP.8040.D5.HNN",
        [5522, 5516, 5505],
        [5573, 5552, 5569],
        366503274,
    ),
    (
        "NP.8040.D5.HNZ",
        [-34089, -34087, -34093],
        [-33793, -33742, -33748],
        -2247647659,
    ),
    (
        "NP.8040.D6.HNE",
        [-17943, -17940, -17935],
        [-17247, -17283, -17294],
        -1115258715,
    ),
    (
        "NP.8040.D6.HNN",
        [124338, 124338, 124340],
        [124421, 124431, 124448],
        8214270167,
    ),
    (
        "NP.8040.D6.HNZ",
        [28922, 28922, 28918],
        [29203, 29207, 29209],
        1911701538,
    ),
];

fn read_all_mseed() -> Vec<Record> {
    let mut out = Vec::new();
    for (id, ..) in OBSPY_MSEED {
        let fc = read_as(
            readers::Format::MiniSeed,
            &format!("{MSEED_DIR}/{id}.mseed"),
        );
        assert_eq!(fc.records.len(), 1, "{id}");
        out.extend(fc.records);
    }
    out
}

#[test]
fn mseed_anchorage_matches_obspy() {
    let start = parse_iso8601_ns("2018-11-30T17:28:59.3345Z").unwrap();
    for ((id, first, last, sum), rec) in OBSPY_MSEED.iter().zip(read_all_mseed()) {
        let ch = &rec.channel;
        assert_eq!(ch.id, *id);
        assert_eq!(ch.network.as_deref(), Some("NP"));
        assert_eq!(ch.station.as_deref(), Some("8040"));
        assert_eq!(ch.sampling_rate_hz, 200.0);
        assert_eq!(ch.start_ns, Some(start), "{id}");
        assert_eq!(
            ch.units,
            Units::Counts {
                counts_per_si: None
            }
        );
        assert_eq!(rec.samples.len(), 66000, "{id}");
        assert!(ch.qa.is_empty(), "{id}: {:?}", ch.qa);
        let n = rec.samples.len();
        for k in 0..3 {
            assert_eq!(rec.samples[k], first[k] as f64, "{id} sample {k}");
            assert_eq!(
                rec.samples[n - 3 + k],
                last[k] as f64,
                "{id} sample {}",
                n - 3 + k
            );
        }
        let s: i64 = rec.samples.iter().map(|v| *v as i64).sum();
        assert_eq!(s, *sum, "{id} sum");
    }
}

/// Decodes the start of the first Steim-2 frame of D0.HNE with plain byte
/// arithmetic (independent of the reader) and compares.
#[test]
fn mseed_first_steim_frame_by_hand() {
    let b = bytes_of(&format!("{MSEED_DIR}/NP.8040.D0.HNE.mseed"));
    // Fixed header: data offset (bytes 44-45, big-endian) and blockette 1000 encoding 11 at byte 52.
    let data = u16::from_be_bytes([b[44], b[45]]) as usize;
    assert_eq!(b[52], 11, "Steim-2");
    let word = |i: usize| {
        u32::from_be_bytes([
            b[data + 4 * i],
            b[data + 4 * i + 1],
            b[data + 4 * i + 2],
            b[data + 4 * i + 3],
        ])
    };
    let x0 = word(1) as i32;
    let nibble3 = (word(0) >> (30 - 6)) & 3;
    assert_eq!(nibble3, 1, "word 3 holds four 8-bit differences");
    let d: Vec<i32> = (0..4)
        .map(|k| ((word(3) >> (24 - 8 * k)) & 0xff) as u8 as i8 as i32)
        .collect();
    // d[0] refers to the previous record; x1 = x0 + d1, x2 = x1 + d2, x3 = x2 + d3.
    let by_hand = [x0, x0 + d[1], x0 + d[1] + d[2], x0 + d[1] + d[2] + d[3]];
    let rec = &read_as(
        readers::Format::MiniSeed,
        &format!("{MSEED_DIR}/NP.8040.D0.HNE.mseed"),
    )
    .records[0];
    for (k, v) in by_hand.iter().enumerate() {
        assert_eq!(rec.samples[k], *v as f64, "sample {k}");
    }
    assert_eq!(x0, -18241);
}

#[test]
fn stationxml_applies_to_anchorage_channels() {
    let xml = bytes_of(&format!("{MSEED_DIR}/NP.8040.xml"));
    let meta = stationxml::parse(&xml, &src("NP.8040.xml")).unwrap();
    assert_eq!(meta.len(), 53);
    let d0e = meta.iter().find(|m| m.id() == "NP.8040.D0.HNE").unwrap();
    let sens = d0e.sensitivity.as_ref().unwrap();
    assert_eq!(sens.value, 213180.0);
    assert_eq!(sens.frequency_hz, Some(1.0));
    assert_eq!(sens.input_units, "m/s**2");
    assert_eq!(d0e.sensor_description.as_deref(), Some("Episensor"));
    assert_eq!(d0e.latitude, Some(61.21349));
    assert_eq!(d0e.longitude, Some(-149.89328));
    assert_eq!(d0e.sample_rate_hz, Some(200.0));
    assert_eq!(d0e.start_ns, parse_iso8601_ns("2004-09-01T18:00:00Z"));
    assert_eq!(d0e.end_ns, None);

    let mut recs = read_all_mseed();
    stationxml::apply(&mut recs, &meta);
    let elevations = [
        ("D0", 28.0),
        ("D1", 23.4),
        ("D2", 17.3),
        ("D3", 9.7),
        ("D4", -2.5),
        ("D5", -17.4),
        ("D6", -33.0),
    ];
    for r in &recs {
        let c = &r.channel;
        let loc = c.location_code.as_deref().unwrap();
        let cha = c.channel_code.as_deref().unwrap();
        let Units::Counts {
            counts_per_si: Some(s),
        } = c.units
        else {
            panic!("{}: no sensitivity applied", c.id)
        };
        assert!((2.11e5..2.15e5).contains(&s), "{}: {s}", c.id);
        let xml_value = meta
            .iter()
            .find(|m| m.id() == c.id)
            .unwrap()
            .sensitivity
            .as_ref()
            .unwrap()
            .value;
        assert_eq!(s, xml_value);
        let e = elevations.iter().find(|(l, _)| *l == loc).unwrap().1;
        assert_eq!(c.elevation_m, Some(e), "{}", c.id);
        match cha {
            "HNE" => {
                assert_eq!(c.direction, Some(Direction::Azimuth(90.0)));
                assert_eq!(c.dip_deg, Some(0.0));
            }
            "HNN" => assert_eq!(c.direction, Some(Direction::Azimuth(0.0))), // 360 in the XML
            "HNZ" => {
                assert_eq!(c.direction, Some(Direction::Up));
                assert_eq!(c.dip_deg, Some(-90.0));
            }
            other => panic!("unexpected channel {other}"),
        }
        assert_eq!(
            c.location_text.as_deref(),
            Some("AK:Anchorage;R B Atwood Bld")
        );
        assert!(!c.missing.contains(&"sensitivity".to_string()));
        assert!(
            c.inferred.iter().any(|s| s.starts_with("counts_per_si=")),
            "{:?}",
            c.inferred
        );
    }
    let d0e = recs
        .iter()
        .find(|r| r.channel.id == "NP.8040.D0.HNE")
        .unwrap();
    assert_eq!(
        d0e.channel.units,
        Units::Counts {
            counts_per_si: Some(213180.0)
        }
    );
}

/// (component, first three, last three, sum), from ObsPy 1.5.1.
const OBSPY_SAC: [(&str, [f64; 3], [f64; 3], f64); 3] = [
    (
        "HNE",
        [
            0.02247929945588112,
            0.022265300154685974,
            0.022356700152158737,
        ],
        [
            0.021709000691771507,
            0.021735824644565582,
            0.021762650460004807,
        ],
        334.5583166247234,
    ),
    (
        "HNN",
        [
            0.015256700105965137,
            0.014844699762761593,
            0.014829999767243862,
        ],
        [
            0.016598999500274658,
            0.01630149967968464,
            0.01600399985909462,
        ],
        225.9066565623507,
    ),
    (
        "HNZ",
        [1.0030332803726196, 1.0026212930679321, 1.0028660297393799],
        [1.0027976036071777, 1.0029234886169434, 1.0030492544174194],
        15041.430212199688,
    ),
];

#[test]
fn sac_csn_ridgecrest_matches_obspy() {
    let start = parse_iso8601_ns("2019-07-06T03:19:52Z").unwrap();
    for (cmp, first, last, sum) in OBSPY_SAC {
        let rel = format!("usgs-gmprocess-format-samples/sac/20190706031952.CJ.T001230.{cmp}.sac");
        let bytes = bytes_of(&rel);
        let h = readers::sac::read_header(&bytes, &src("x.sac")).unwrap();
        assert!(h.little_endian);
        assert_eq!(h.stla, Some(34.063694));
        assert!((h.stla.unwrap() - 34.0637).abs() < 1e-4);
        assert_eq!(h.kcmpnm.as_deref(), Some(cmp), "KCMPNM cut at its NUL");
        assert_eq!(h.khole, None, "KHOLE is -12345");
        assert_eq!(h.idep, Some(8));
        let fc = read_as(readers::Format::Sac, &rel);
        let r = &fc.records[0];
        let c = &r.channel;
        assert_eq!(c.id, format!("CJ.T001230..{cmp}"));
        assert_eq!(c.network.as_deref(), Some("CJ"));
        assert_eq!(c.sampling_rate_hz, 50.0);
        assert_eq!(c.start_ns, Some(start + (h.b.unwrap() * 1e9) as i64));
        assert_eq!(r.samples.len(), 15001);
        for k in 0..3 {
            assert_eq!(r.samples[k], first[k]);
            assert_eq!(r.samples[15001 - 3 + k], last[k]);
        }
        let s: f64 = r.samples.iter().sum();
        assert!((s - sum).abs() < 1e-9 * sum.abs(), "{s} vs {sum}");
        assert_eq!(c.missing, vec!["units".to_string()]);
        assert!(
            c.inferred.iter().any(|i| i.contains("IDEP=8")),
            "{:?}",
            c.inferred
        );
        let g_note = c
            .qa
            .iter()
            .any(|q| matches!(q, QaFlag::Note { text } if text.contains("g including gravity")));
        assert_eq!(g_note, cmp == "HNZ", "only the vertical averages ≈1");
        if cmp == "HNE" {
            assert_eq!(c.direction, Some(Direction::Azimuth(90.0)));
        }
    }
}

const MDOF: &str = "mdof-mini-shake-table-flexible-3story";

#[test]
fn csv_xsens_northridge_ground_floor() {
    let fc = read_as(
        readers::Format::Csv,
        &format!("{MDOF}/Ground Floor/(Northridge)Xsens DOT_20250306_122607.csv"),
    );
    let names: Vec<&str> = fc
        .records
        .iter()
        .map(|r| r.channel.source.column.as_deref().unwrap())
        .collect();
    assert_eq!(names, ["Acc_X", "Acc_Y", "Acc_Z"]);
    let start = parse_iso8601_ns("2025-03-06T20:26:07Z").unwrap(); // 12:26:07 PST = UTC−8
    for r in &fc.records {
        let c = &r.channel;
        assert_eq!(c.sampling_rate_hz, 120.0);
        assert_eq!(r.samples.len(), 12117);
        assert_eq!(r.samples[0], 0.0, "first row all accelerations exactly 0");
        assert_eq!(c.station.as_deref(), Some("Xsens DOT"));
        assert_eq!(c.start_ns, Some(start));
        assert_eq!(c.missing, vec!["units".to_string()]);
        assert!(!c.qa.iter().any(|q| matches!(q, QaFlag::Resampled { .. })));
    }
    // Second data row, from the file: 0.08530480414629,-0.16412913799286,9.80184078216553.
    assert_eq!(fc.records[0].samples[1], 0.08530480414629);
    assert_eq!(fc.records[1].samples[1], -0.16412913799286);
    assert_eq!(fc.records[2].samples[1], 9.80184078216553);
    let mean_z: f64 = fc.records[2].samples[1..].iter().sum::<f64>() / 12116.0;
    assert!(
        (mean_z - 9.8).abs() < 0.1,
        "Acc_Z includes gravity: {mean_z}"
    );
}

#[test]
fn csv_xsens_all_runs_row_counts() {
    let cases = [
        (
            "Ground Floor/(Northridge)Xsens DOT_20250306_122607.csv",
            12117,
        ),
        ("1st Floor/(Northridge)Xsens DOT_20250306_122607.csv", 12117),
        ("2nd Floor/(Northridge)left leg_20250306_122607.csv", 12117),
        (
            "3rd Floor (Top floor)/(Northridge)Xsens DOT_20250306_122607.csv",
            12117,
        ),
        (
            "Ground Floor/(Bonus Event)_D422CD00556E_20250411_114950.csv",
            2709,
        ),
        (
            "1st Floor/(Bonus Event)_D422CD005686_20250411_114950.csv",
            2730,
        ),
        (
            "2nd Floor/(Bonus Event)_D422CD0055C4_20250411_114950.csv",
            2709,
        ),
        (
            "3rd Floor (Top floor)/(Bonus Event)Xsens DOT_D422CD00567B_20250411_114950.csv",
            2709,
        ),
    ];
    let bonus_start = parse_iso8601_ns("2025-04-11T18:49:50Z").unwrap(); // 11:49:50 PDT = UTC−7
    for (rel, rows) in cases {
        let fc = read_as(readers::Format::Csv, &format!("{MDOF}/{rel}"));
        assert_eq!(fc.records.len(), 3, "{rel}");
        for r in &fc.records {
            assert_eq!(r.samples.len(), rows, "{rel}");
            assert_eq!(r.channel.sampling_rate_hz, 120.0, "{rel}");
            if rel.contains("Bonus") {
                assert_eq!(r.channel.start_ns, Some(bonus_start), "{rel}");
            }
        }
    }
    let fc = read_as(
        readers::Format::Csv,
        &format!("{MDOF}/1st Floor/(Bonus Event)_D422CD005686_20250411_114950.csv"),
    );
    assert_eq!(
        fc.records[0].channel.station.as_deref(),
        Some("topfloor"),
        "DeviceTag as stored in the file"
    );
}

#[test]
fn csv_column_selection_by_name_and_index() {
    let bytes = bytes_of(&format!(
        "{MDOF}/Ground Floor/(Northridge)Xsens DOT_20250306_122607.csv"
    ));
    let opts = ReadOptions {
        columns: Some(vec!["Gyr_Z".into(), "5".into()]),
        ..Default::default()
    };
    let fc = readers::csv::read(&bytes, &src("g.csv"), &opts).unwrap();
    assert_eq!(fc.records.len(), 2);
    assert_eq!(
        fc.records[0].channel.source.column.as_deref(),
        Some("Gyr_Z")
    );
    assert_eq!(
        fc.records[1].channel.source.column.as_deref(),
        Some("Acc_X")
    );
    assert_eq!(fc.records[0].samples[1], -0.85598927736282);
}

// ---------------------------------------------------------------- MCAP

fn anchorage_event() -> Event {
    let xml = bytes_of(&format!("{MSEED_DIR}/NP.8040.xml"));
    let meta = stationxml::parse(&xml, &src("NP.8040.xml")).unwrap();
    let mut records: Vec<Record> = ["HNE", "HNN", "HNZ"]
        .iter()
        .flat_map(|c| {
            read_as(
                readers::Format::MiniSeed,
                &format!("{MSEED_DIR}/NP.8040.D0.{c}.mseed"),
            )
            .records
        })
        .collect();
    stationxml::apply(&mut records, &meta);
    let mut ev = Event {
        name: "anchorage-2018".into(),
        records,
        ..Default::default()
    };
    ev.history
        .push("units_to_si", serde_json::json!({"note": "test"}));
    ev
}

fn assert_same_records(a: &[Record], b: &[Record]) {
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b) {
        assert_eq!(x.channel.id, y.channel.id);
        assert_eq!(x.channel.sampling_rate_hz, y.channel.sampling_rate_hz);
        assert_eq!(x.channel.start_ns, y.channel.start_ns);
        assert_eq!(x.channel.units, y.channel.units);
        assert_eq!(x.channel.direction, y.channel.direction);
        assert_eq!(x.samples.len(), y.samples.len(), "{}", x.channel.id);
        for (i, (u, v)) in x.samples.iter().zip(&y.samples).enumerate() {
            assert!(
                u.to_bits() == v.to_bits() || (u.is_nan() && v.is_nan()),
                "{} sample {i}: {u} vs {v}",
                x.channel.id
            );
        }
    }
}

#[test]
fn mcap_round_trip_zstd_chunked_atomic() {
    let ev = anchorage_event();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("anchorage.mcap");
    mcap_writer::write_event(&ev, &path, &McapWriteOptions::default()).unwrap();
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    assert_eq!(names, ["anchorage.mcap"], "no temporary file left behind");
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(
        readers::sniff("anchorage.mcap", &bytes),
        Some(readers::Format::Mcap)
    );
    let back = readers::read(
        readers::Format::Mcap,
        &bytes,
        &src("anchorage.mcap"),
        &ReadOptions::default(),
    )
    .unwrap();
    assert_same_records(&ev.records, &back.records);
    assert_eq!(
        back.records[0].channel.units,
        Units::Counts {
            counts_per_si: Some(213180.0)
        }
    );
    assert!(back.records.iter().all(|r| r.channel.qa.is_empty()));

    // Container facts: zstd chunks, one message per sample (Foxglove plots
    // `/accel/<id>.value`), log_time = the sample's time, history metadata.
    let mut zstd_chunks = 0;
    let mut history = None;
    for rec in mcap::read::LinearReader::new(&bytes).unwrap() {
        match rec.unwrap() {
            mcap::records::Record::Chunk { header, .. } => {
                assert_eq!(header.compression, "zstd");
                zstd_chunks += 1;
            }
            mcap::records::Record::Metadata(m) if m.name == mcap_writer::HISTORY_METADATA_NAME => {
                history = m.metadata.get("history").cloned();
            }
            _ => {}
        }
    }
    assert!(zstd_chunks >= 1);
    assert_eq!(history, Some(ev.history.to_json()));
    let messages: Vec<_> = mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(Result::unwrap)
        .collect();
    assert_eq!(messages.len(), 3 * 66000);
    let first = &messages[0];
    assert_eq!(
        first.channel.schema.as_ref().unwrap().name,
        "quaketwin.AccelSample"
    );
    assert_eq!(first.channel.metadata["time_base"], "record_start");
    assert_eq!(Some(first.log_time as i64), ev.records[0].channel.start_ns);
    assert!(messages.windows(2).all(|w| w[0].log_time <= w[1].log_time));
    let v: serde_json::Value = serde_json::from_slice(&first.data).unwrap();
    assert_eq!(v["t_ns"].as_i64(), Some(first.log_time as i64));
    assert!(v["value"].is_number());
}

#[test]
fn mcap_round_trip_lz4_and_uncompressed_with_nan_and_unknown_start() {
    let ev = anchorage_event();
    let mut rec = ev.records[0].clone();
    rec.channel.id = "synthetic".into();
    rec.channel.start_ns = None;
    rec.channel.sampling_rate_hz = 120.0;
    rec.samples.as_mut_vec().truncate(1000);
    rec.samples[17] = f64::NAN;
    let ev2 = Event {
        name: "s".into(),
        records: vec![rec],
        ..Default::default()
    };
    let layouts = [
        McapMessages::Blocks { seconds: 0.25 },
        McapMessages::PerSample,
    ];
    for (compression, messages) in [Some(mcap::Compression::Lz4), None]
        .into_iter()
        .flat_map(|c| layouts.map(|m| (c, m)))
    {
        let opts = McapWriteOptions {
            messages,
            compression,
            ..Default::default()
        };
        let w = mcap_writer::write_event_to(
            &ev2,
            Cursor::new(Vec::new()),
            &opts,
            Path::new("mem.mcap"),
        )
        .unwrap();
        let bytes = w.into_inner();
        let back = mcap_reader::read(&bytes, &src("mem.mcap"), &ReadOptions::default()).unwrap();
        assert_same_records(&ev2.records, &back.records);
        assert!(back.records[0].samples[17].is_nan());
        assert_eq!(back.records[0].channel.start_ns, None);
        assert!(back.records[0]
            .channel
            .qa
            .iter()
            .any(|q| matches!(q, QaFlag::NonFinite { count: 1 })));
    }
}

#[test]
fn mcap_writer_is_deterministic() {
    let ev = anchorage_event();
    let a = mcap_writer::write_event_to(
        &ev,
        Cursor::new(Vec::new()),
        &McapWriteOptions::default(),
        Path::new("a"),
    )
    .unwrap();
    let b = mcap_writer::write_event_to(
        &ev,
        Cursor::new(Vec::new()),
        &McapWriteOptions::default(),
        Path::new("b"),
    )
    .unwrap();
    assert!(a.into_inner() == b.into_inner());
}

/// Protobuf encoder written here, independently of the reader's decoder.
fn pb_varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

fn pb_accel_block(
    channel: &str,
    t0_ns: i64,
    rate_hz: f64,
    units: &str,
    samples: &[f64],
) -> Vec<u8> {
    let mut out = Vec::new();
    out.push(1 << 3 | 2);
    pb_varint(&mut out, channel.len() as u64);
    out.extend_from_slice(channel.as_bytes());
    out.push(2 << 3);
    pb_varint(&mut out, t0_ns as u64);
    out.push(3 << 3 | 1);
    out.extend_from_slice(&rate_hz.to_le_bytes());
    out.push(4 << 3 | 2);
    pb_varint(&mut out, units.len() as u64);
    out.extend_from_slice(units.as_bytes());
    out.push(5 << 3 | 2);
    pb_varint(&mut out, 8 * samples.len() as u64);
    for s in samples {
        out.extend_from_slice(&s.to_le_bytes());
    }
    out
}

fn signal(i: usize) -> f64 {
    (0.37 * i as f64).sin() * 0.1
}

#[test]
fn mcap_protobuf_blocks_with_gap_and_json_per_sample() {
    let t0 = parse_iso8601_ns("2024-01-01T00:00:00Z").unwrap();
    let mut w = mcap::WriteOptions::new()
        .compression(Some(mcap::Compression::Zstd))
        .create(Cursor::new(Vec::new()))
        .unwrap();
    let schema = w
        .add_schema(
            mcap_reader::ACCEL_BLOCK_SCHEMA,
            "protobuf",
            mcap_reader::ACCEL_BLOCK_PROTO.as_bytes(),
        )
        .unwrap();
    let pb = w
        .add_channel(schema, "/sensors/floor1", "protobuf", &Default::default())
        .unwrap();
    // Three 1-s blocks at 100 Hz; the third starts 0.5 s late (a 50-sample gap).
    let starts = [0usize, 100, 250];
    for (k, s0) in starts.iter().enumerate() {
        let samples: Vec<f64> = (*s0..*s0 + 100).map(signal).collect();
        let t = t0 + (*s0 as i64) * 10_000_000;
        let payload = pb_accel_block("F1-X", t, 100.0, "g", &samples);
        let h = mcap::records::MessageHeader {
            channel_id: pb,
            sequence: k as u32,
            log_time: t as u64,
            publish_time: t as u64,
        };
        w.write_to_known_channel(&h, &payload).unwrap();
    }
    // Per-sample JSON messages at 250 Hz, time from t_ns; and an unrelated topic that must be skipped.
    let js = w
        .add_channel(0, "/accel/F2-Y", "json", &Default::default())
        .unwrap();
    let other = w
        .add_channel(0, "/diagnostics", "json", &Default::default())
        .unwrap();
    for i in 0..500usize {
        let t = t0 + i as i64 * 4_000_000;
        let payload = serde_json::to_vec(
            &serde_json::json!({"t_ns": t, "value": signal(i), "units": "m/s2"}),
        )
        .unwrap();
        let h = mcap::records::MessageHeader {
            channel_id: js,
            sequence: i as u32,
            log_time: t as u64,
            publish_time: t as u64,
        };
        w.write_to_known_channel(&h, &payload).unwrap();
    }
    let h = mcap::records::MessageHeader {
        channel_id: other,
        sequence: 0,
        log_time: t0 as u64,
        publish_time: t0 as u64,
    };
    w.write_to_known_channel(&h, b"{\"cpu\": 0.5}").unwrap();
    w.finish().unwrap();
    let bytes = w.into_inner().into_inner();

    let fc = mcap_reader::read(&bytes, &src("pb.mcap"), &ReadOptions::default()).unwrap();
    assert_eq!(fc.records.len(), 2);
    let f1 = &fc.records[0];
    assert_eq!(f1.channel.id, "F1-X");
    assert_eq!(f1.channel.units, Units::G);
    assert_eq!(f1.channel.sampling_rate_hz, 100.0);
    assert_eq!(f1.channel.start_ns, Some(t0));
    assert_eq!(f1.samples.len(), 350);
    for i in (0..200).chain(250..350) {
        assert_eq!(f1.samples[i], signal(i), "sample {i}");
    }
    // Gap filled on the straight line between samples 199 and 250.
    let line = signal(199) + (signal(250) - signal(199)) * (25.0 / 51.0);
    assert!((f1.samples[224] - line).abs() < 1e-15);
    let gap = f1.channel.qa.iter().find_map(|q| match q {
        QaFlag::Gap { at_s, duration_s } => Some((*at_s, *duration_s)),
        _ => None,
    });
    let (at_s, dur) = gap.expect("gap flagged");
    assert!(
        (at_s - 2.0).abs() < 1e-9 && (dur - 0.5).abs() < 1e-9,
        "{at_s} {dur}"
    );

    let f2 = &fc.records[1];
    assert_eq!(f2.channel.id, "F2-Y");
    assert_eq!(f2.channel.sampling_rate_hz, 250.0);
    assert_eq!(f2.channel.units, Units::MPerS2);
    assert_eq!(f2.samples, (0..500).map(signal).collect::<Vec<_>>());
    assert!(f2.channel.qa.is_empty());
}

// ---------------------------------------------------------------- bad input

#[test]
fn bad_mseed_truncated_record_names_its_offset() {
    let b = bytes_of(&format!("{MSEED_DIR}/NP.8040.D0.HNE.mseed"));
    let mut cut = b[..1024].to_vec();
    cut.extend_from_slice(&b[1024..1024 + 300]);
    let e = readers::mseed::read(&cut, &src("cut.mseed"), &ReadOptions::default()).unwrap_err();
    let (loc, msg) = input_error(e);
    assert_eq!(loc.file, "cut.mseed");
    assert_eq!(loc.byte_offset, Some(1024));
    assert!(msg.contains("truncated"), "{msg}");
    // A stub shorter than a fixed header.
    let e = readers::mseed::read(&b[..1024 + 20], &src("cut.mseed"), &ReadOptions::default())
        .unwrap_err();
    assert_eq!(input_error(e).0.byte_offset, Some(1024));
}

#[test]
fn bad_mseed_steim_constants() {
    let b = bytes_of(&format!("{MSEED_DIR}/NP.8040.D0.HNE.mseed"));
    let mut bad = b[..1536].to_vec();
    // Third record: bump its reverse integration constant Xn (frame 0, word 2 of the data at byte 64).
    let at = 1024 + 64 + 8;
    let xn = i32::from_be_bytes([bad[at], bad[at + 1], bad[at + 2], bad[at + 3]]);
    bad[at..at + 4].copy_from_slice(&(xn + 1).to_be_bytes());
    let e = readers::mseed::read(&bad, &src("bad.mseed"), &ReadOptions::default()).unwrap_err();
    let (loc, msg) = input_error(e);
    assert_eq!(loc.byte_offset, Some(1024));
    assert!(
        msg.contains("integration constants") && msg.contains(&format!("Xn = {}", xn + 1)),
        "{msg}"
    );
}

#[test]
fn bad_sac_shorter_than_npts() {
    let b = bytes_of("usgs-gmprocess-format-samples/sac/20190706031952.CJ.T001230.HNE.sac");
    let e = readers::sac::read(&b[..632 + 400], &src("short.sac"), &ReadOptions::default())
        .unwrap_err();
    let (loc, msg) = input_error(e);
    assert_eq!(loc.file, "short.sac");
    assert_eq!(loc.byte_offset, Some(1032));
    assert!(msg.contains("NPTS=15001"), "{msg}");
    let e = readers::sac::read(&b[..100], &src("short.sac"), &ReadOptions::default()).unwrap_err();
    assert_eq!(input_error(e).0.byte_offset, Some(100));
    let mut garbage = b[..1032].to_vec();
    garbage[304..308].copy_from_slice(&[9, 9, 9, 9]);
    let (_, msg) = input_error(
        readers::sac::read(&garbage, &src("g.sac"), &ReadOptions::default()).unwrap_err(),
    );
    assert!(msg.contains("NVHDR"), "{msg}");
}

#[test]
fn bad_csv_non_numeric_cell_names_file_line_column() {
    let text = "sep=,\nDeviceTag:,x\nStartTime: ,2025-03-06_12:26:07_000 PST\n\nPacketCounter,SampleTimeFine,Acc_X,Acc_Y\n\
                0,100,0.1,0.2\n1,8433,0.1,0.2\n2,16766,0.1,0.2\n3,25099,0.1,0.2\n4,33432,0.1,oops\n5,41765,0.1,0.2\n";
    let e =
        readers::csv::read(text.as_bytes(), &src("bad.csv"), &ReadOptions::default()).unwrap_err();
    let (loc, msg) = input_error(e);
    assert_eq!(loc.file, "bad.csv");
    assert_eq!(loc.line, Some(10));
    assert_eq!(loc.channel.as_deref(), Some("Acc_Y"));
    assert!(msg.contains("\"oops\""), "{msg}");
    // Ragged row.
    let ragged = "t,acc\n0,1\n0.1,2\n0.2,3\n0.3\n";
    let (loc, _) = input_error(
        readers::csv::read(ragged.as_bytes(), &src("r.csv"), &ReadOptions::default()).unwrap_err(),
    );
    assert_eq!(loc.line, Some(5));
}

#[test]
fn bad_mcap_unknown_encoding_and_garbage() {
    let mut w = mcap::Writer::new(Cursor::new(Vec::new())).unwrap();
    let ch = w
        .add_channel(0, "/accel/F1-X", "cbor", &Default::default())
        .unwrap();
    let h = mcap::records::MessageHeader {
        channel_id: ch,
        sequence: 0,
        log_time: 0,
        publish_time: 0,
    };
    w.write_to_known_channel(&h, &[0xa1, 0x01, 0x02]).unwrap();
    w.finish().unwrap();
    let bytes = w.into_inner().into_inner();
    let (loc, msg) = input_error(
        mcap_reader::read(&bytes, &src("c.mcap"), &ReadOptions::default()).unwrap_err(),
    );
    assert_eq!(loc.channel.as_deref(), Some("/accel/F1-X"));
    assert!(
        msg.contains("unknown message encoding") && msg.contains("cbor"),
        "{msg}"
    );

    let mut garbage = b"\x89MCAP0\r\n".to_vec();
    garbage.extend_from_slice(&[0xff; 40]);
    let (_, msg) = input_error(
        mcap_reader::read(&garbage, &src("g.mcap"), &ReadOptions::default()).unwrap_err(),
    );
    assert!(!msg.is_empty());
    // Truncated real file.
    let ev = anchorage_event();
    let good = mcap_writer::write_event_to(
        &ev,
        Cursor::new(Vec::new()),
        &McapWriteOptions::default(),
        Path::new("x"),
    )
    .unwrap()
    .into_inner();
    let (loc, msg) = input_error(
        mcap_reader::read(
            &good[..good.len() / 2],
            &src("t.mcap"),
            &ReadOptions::default(),
        )
        .unwrap_err(),
    );
    assert!(
        loc.byte_offset.is_some_and(|b| b < good.len() as u64 / 2),
        "{loc:?}"
    );
    assert!(msg.contains("truncated"), "{msg}");
}

#[test]
fn sniff_binary_formats_by_content() {
    let m = bytes_of(&format!("{MSEED_DIR}/NP.8040.D0.HNE.mseed"));
    assert_eq!(
        readers::sniff("record.bin", &m[..4096]),
        Some(readers::Format::MiniSeed)
    );
    let s = bytes_of("usgs-gmprocess-format-samples/sac/20190706031952.CJ.T001230.HNE.sac");
    assert_eq!(
        readers::sniff("record.bin", &s[..4096]),
        Some(readers::Format::Sac)
    );
    assert_eq!(readers::sniff("notes.bin", &[b'x'; 1000]), None);
}

/// Index below `n` (modulo reduction) from the corruption test's seeded stream.
fn below(rng: &mut SplitMix64, n: usize) -> usize {
    (rng.next_u64() % n as u64) as usize
}

/// Corrupted and truncated inputs give `Ok` or `Err`, never a panic.
#[test]
fn readers_never_panic_on_corrupted_bytes() {
    let mseed = bytes_of(&format!("{MSEED_DIR}/NP.8040.D0.HNE.mseed"))[..2048].to_vec();
    let sac = bytes_of("usgs-gmprocess-format-samples/sac/20190706031952.CJ.T001230.HNE.sac");
    let csv_full = bytes_of(&format!(
        "{MDOF}/Ground Floor/(Northridge)Xsens DOT_20250306_122607.csv"
    ));
    let csv = csv_full[..6000].to_vec();
    let mut small = anchorage_event();
    for r in &mut small.records {
        r.samples.as_mut_vec().truncate(400);
    }
    let mcap_bytes = mcap_writer::write_event_to(
        &small,
        Cursor::new(Vec::new()),
        &McapWriteOptions::default(),
        Path::new("m"),
    )
    .unwrap()
    .into_inner();
    let cases: [(readers::Format, &[u8]); 4] = [
        (readers::Format::MiniSeed, &mseed),
        (readers::Format::Sac, &sac),
        (readers::Format::Csv, &csv),
        (readers::Format::Mcap, &mcap_bytes),
    ];
    let mut rng = SplitMix64::new(20240601);
    for (format, original) in cases {
        for trial in 0..600 {
            let mut b = original.to_vec();
            if trial % 3 == 0 {
                b.truncate(below(&mut rng, b.len()));
            } else {
                for _ in 0..1 + below(&mut rng, 8) {
                    let i = below(&mut rng, b.len());
                    b[i] = rng.next_u64() as u8;
                }
            }
            let _ = readers::read(format, &b, &src("corrupt"), &ReadOptions::default());
        }
    }
}

/// Issue 14 item 4: a data record whose sample-rate factor, sample count or
/// encoding was zeroed used to vanish without a word (65,588 samples instead
/// of 66,000). Now the channel carries a QA note naming the record.
#[test]
fn shared_mseed_record_without_samples_is_noted_not_dropped_silently() {
    let rel = format!("{MSEED_DIR}/NP.8040.D0.HNE.mseed");
    let intact = bytes_of(&rel);
    let n_intact = readers::read(
        readers::Format::MiniSeed,
        &intact,
        &src(&rel),
        &ReadOptions::default(),
    )
    .unwrap()
    .records[0]
        .samples
        .len();
    // Records are 512 bytes here; zero a field of the third record (byte 1024).
    for (field, why) in [(32..34, "sample rate 0"), (30..32, "0 samples")] {
        let mut bytes = intact.clone();
        assert_eq!(&bytes[1024..1030], b"000003");
        bytes[1024 + field.start..1024 + field.end].fill(0);
        let rec = &readers::read(
            readers::Format::MiniSeed,
            &bytes,
            &src(&rel),
            &ReadOptions::default(),
        )
        .unwrap()
        .records[0];
        let note = rec
            .channel
            .qa
            .iter()
            .find_map(|q| match q {
                QaFlag::Note { text } if text.contains("skipped without samples") => {
                    Some(text.clone())
                }
                _ => None,
            })
            .unwrap_or_else(|| panic!("{why}: no note in {:?}", rec.channel.qa));
        assert!(note.contains("byte 1024") && note.contains(why), "{note}");
        // The lost span is a gap (filled and flagged), not a silent shift.
        assert_eq!(rec.samples.len(), n_intact, "{why}");
        assert!(
            rec.channel
                .qa
                .iter()
                .any(|q| matches!(q, QaFlag::Gap { .. })),
            "{why}"
        );
    }
}

/// Issue 14 item 5: a StationXML sensitivity of −1, INF or 1e300 used to be
/// applied (PGA 5.7e5 m/s²); now it is refused with a QA note and the
/// channel stays without sensitivity, so conditioning stops with an error
/// naming the channel instead of scaling the record into nonsense.
#[test]
fn shared_stationxml_absurd_sensitivity_is_refused_not_applied() {
    let xml = String::from_utf8(bytes_of(&format!("{MSEED_DIR}/NP.8040.xml"))).unwrap();
    assert!(xml.contains("<Value>213180.0</Value>"));
    for bad in ["-1", "INF", "1e300"] {
        let patched = xml.replace("<Value>213180.0</Value>", &format!("<Value>{bad}</Value>"));
        let meta = stationxml::parse(patched.as_bytes(), &src("NP.8040.xml")).unwrap();
        let mut records: Vec<Record> = read_all_mseed()
            .into_iter()
            .filter(|r| r.channel.id == "NP.8040.D0.HNE")
            .collect();
        stationxml::apply(&mut records, &meta);
        let ch = &records[0].channel;
        assert_eq!(
            ch.units,
            Units::Counts {
                counts_per_si: None
            },
            "{bad}"
        );
        assert!(
            ch.qa
                .iter()
                .any(|q| matches!(q, QaFlag::Note { text } if text.contains("refused"))),
            "{bad}: {:?}",
            ch.qa
        );
        let mut event = Event {
            name: "t".into(),
            records,
            ..Default::default()
        };
        let e = quaketwin::conditioning::condition_event(&mut event, &Default::default())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("NP.8040.D0.HNE") && e.contains("sensitivity"),
            "{e}"
        );
    }
}

// Pieces of the binary readers on crafted bytes: the MCAP protobuf block
// decoder, MiniSEED records, Steim frames, rate factors and record joins,
// SAC in both byte orders, StationXML epochs.

#[test]
fn mcap_protobuf_decoder_reads_packed_and_unpacked() {
    // channel "A" (1), t0 = -5 (2, two's complement varint), rate 100 (3), samples packed [1.5] and unpacked [2.5].
    let mut d = vec![0x0a, 1, b'A', 0x10];
    d.extend_from_slice(&[0xfb, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x01]);
    d.push(0x19);
    d.extend_from_slice(&100f64.to_le_bytes());
    d.extend_from_slice(&[0x2a, 8]);
    d.extend_from_slice(&1.5f64.to_le_bytes());
    d.push(0x29);
    d.extend_from_slice(&2.5f64.to_le_bytes());
    d.extend_from_slice(&[0x30, 0x07]); // unknown field 6 varint, skipped
    let b = mcap_reader::decode_accel_block_protobuf(&d).unwrap();
    assert_eq!(b.channel, "A");
    assert_eq!(b.t0_ns, -5);
    assert_eq!(b.rate_hz, 100.0);
    assert_eq!(b.samples, vec![1.5, 2.5]);
    // Truncated packed field.
    let e = mcap_reader::decode_accel_block_protobuf(&d[..d.len() - 14]).unwrap_err();
    assert!(e.contains("runs past the end"), "{e}");
}

/// Builds one 512-byte record (big- or little-endian) with the given encoding and data bytes.
fn mseed_record(
    order: ByteOrder,
    encoding: u8,
    nsamples: u16,
    start_sec: u8,
    data: &[u8],
) -> Vec<u8> {
    let mut r = vec![0u8; 512];
    r[..8].copy_from_slice(b"000001D ");
    r[8..13].copy_from_slice(b"STA  ");
    r[13..15].copy_from_slice(b"00");
    r[15..18].copy_from_slice(b"HNZ");
    r[18..20].copy_from_slice(b"XX");
    let put16 = |r: &mut Vec<u8>, at: usize, v: u16| {
        let b = if order == ByteOrder::Big {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        };
        r[at..at + 2].copy_from_slice(&b);
    };
    put16(&mut r, 20, 2020);
    put16(&mut r, 22, 32);
    r[24] = 1;
    r[25] = 2;
    r[26] = start_sec;
    put16(&mut r, 28, 5000); // 0.5 s
    put16(&mut r, 30, nsamples);
    put16(&mut r, 32, 100);
    put16(&mut r, 34, 1);
    r[39] = 1;
    put16(&mut r, 44, 64);
    put16(&mut r, 46, 48);
    put16(&mut r, 48, 1000);
    put16(&mut r, 50, 0);
    r[52] = encoding;
    r[53] = if order == ByteOrder::Big { 1 } else { 0 };
    r[54] = 9;
    r[64..64 + data.len()].copy_from_slice(data);
    r
}

#[test]
fn mseed_int32_both_byte_orders_and_gap_join() {
    for order in [ByteOrder::Big, ByteOrder::Little] {
        let vals = [1i32, -2, 300_000, -4];
        let data: Vec<u8> = vals
            .iter()
            .flat_map(|v| {
                if order == ByteOrder::Big {
                    v.to_be_bytes()
                } else {
                    v.to_le_bytes()
                }
            })
            .collect();
        let mut bytes = mseed_record(order, 3, 4, 10, &data);
        // Second record 0.06 s after the first ends (4 samples at 100 Hz = 0.04 s): 2 samples missing.
        let mut second = mseed_record(order, 3, 4, 10, &data);
        let fract: u16 = 5000 + 600; // 10.56 s
        let b = if order == ByteOrder::Big {
            fract.to_be_bytes()
        } else {
            fract.to_le_bytes()
        };
        second[28..30].copy_from_slice(&b);
        bytes.extend(second);
        let source = SourceRef {
            format: "mseed".into(),
            ..src("t.mseed")
        };
        let fc = readers::mseed::read(&bytes, &source, &ReadOptions::default()).unwrap();
        assert_eq!(fc.records.len(), 1);
        let r = &fc.records[0];
        assert_eq!(r.channel.id, "XX.STA.00.HNZ");
        assert_eq!(r.channel.sampling_rate_hz, 100.0);
        assert_eq!(r.samples.len(), 10);
        assert_eq!(&r.samples[..4], &[1.0, -2.0, 300_000.0, -4.0]);
        // Interpolated between -4 and 1 over two missing samples.
        assert!((r.samples[4] - (-4.0 + 5.0 / 3.0)).abs() < 1e-12);
        assert!(r.channel.qa.iter().any(
            |q| matches!(q, QaFlag::Gap { duration_s, .. } if (duration_s - 0.02).abs() < 1e-9)
        ));
        let expect = epoch_ns_from_civil(2020, 2, 1, 1, 2, 10.5).unwrap();
        assert_eq!(r.channel.start_ns, Some(expect));
    }
}

#[test]
fn mseed_steim1_hand_built_frame() {
    // Samples 10, 12, 9, 9, 1000: differences (d0 unused) 2, -3, 0, 991.
    let mut frame = vec![0u8; 64];
    // nibbles: w0=0, w1=0 (X0), w2=0 (Xn), w3=1 (four bytes), w4=3 (one 32-bit)
    let nibbles: u32 = (1 << (30 - 6)) | (3 << (30 - 8));
    frame[0..4].copy_from_slice(&nibbles.to_be_bytes());
    frame[4..8].copy_from_slice(&10i32.to_be_bytes());
    frame[8..12].copy_from_slice(&1000i32.to_be_bytes());
    frame[12..16].copy_from_slice(&[0u8, 2, (-3i8) as u8, 0]);
    frame[16..20].copy_from_slice(&991i32.to_be_bytes());
    let out = decode_steim(&frame, false, ByteOrder::Big, 5).unwrap();
    assert_eq!(out, vec![10, 12, 9, 9, 1000]);
    // Wrong reverse constant.
    frame[8..12].copy_from_slice(&999i32.to_be_bytes());
    let e = decode_steim(&frame, false, ByteOrder::Big, 5).unwrap_err();
    assert!(e.contains("reverse constant"), "{e}");
}

#[test]
fn mseed_rate_factor_multiplier_rules() {
    assert_eq!(rate_from_factor(200, 1), 200.0);
    assert_eq!(rate_from_factor(-10, 1), 0.1);
    assert_eq!(rate_from_factor(1, -10), 0.1);
    assert_eq!(rate_from_factor(-10, -10), 0.01);
    assert_eq!(rate_from_factor(20, -2), 10.0);
}

fn mseed_segment(start_ns: i64, samples: Vec<f64>) -> Segment {
    Segment {
        start_ns,
        rate_hz: 10.0,
        samples,
        origin: "test".into(),
    }
}

#[test]
fn mseed_join_overlap_identical_is_silent_and_different_is_flagged() {
    // 10 Hz: second segment starts 0.2 s (2 samples) before the first ends.
    let j = join_segments(vec![
        mseed_segment(0, vec![1.0, 2.0, 3.0, 4.0]),
        mseed_segment(200_000_000, vec![3.0, 4.0, 5.0]),
    ])
    .unwrap();
    assert_eq!(j.samples, vec![1.0, 2.0, 3.0, 4.0, 5.0]);
    assert!(j.qa.is_empty());
    let j = join_segments(vec![
        mseed_segment(200_000_000, vec![9.0, 4.0, 5.0]),
        mseed_segment(0, vec![1.0, 2.0, 3.0, 4.0]),
    ])
    .unwrap();
    assert_eq!(
        j.samples,
        vec![1.0, 2.0, 3.0, 4.0, 5.0],
        "sorted by start, earlier samples kept"
    );
    assert!(j
        .qa
        .iter()
        .any(|q| matches!(q, QaFlag::Gap { duration_s, .. } if (duration_s + 0.2).abs() < 1e-9)));
}

#[test]
fn mseed_join_absurd_gap_and_rate_change_are_errors() {
    assert!(join_segments(vec![
        mseed_segment(0, vec![1.0]),
        mseed_segment(i64::MAX / 2, vec![2.0])
    ])
    .is_err());
    let mut other = mseed_segment(100_000_000, vec![2.0]);
    other.rate_hz = 20.0;
    let e = join_segments(vec![mseed_segment(0, vec![1.0]), other]).unwrap_err();
    assert!(e.contains("sampling rate changes"), "{e}");
}

/// Builds a SAC file with the given byte order.
fn sac_file(little: bool, npts: i32, data: &[f32]) -> Vec<u8> {
    let mut b = vec![0u8; readers::sac::HEADER_LEN];
    let putf = |b: &mut Vec<u8>, i: usize, v: f32| {
        let w = if little {
            v.to_le_bytes()
        } else {
            v.to_be_bytes()
        };
        b[4 * i..4 * i + 4].copy_from_slice(&w);
    };
    let puti = |b: &mut Vec<u8>, i: usize, v: i32| {
        let w = if little {
            v.to_le_bytes()
        } else {
            v.to_be_bytes()
        };
        b[280 + 4 * i..284 + 4 * i].copy_from_slice(&w);
    };
    for i in 0..70 {
        putf(&mut b, i, -12345.0);
    }
    for i in 0..40 {
        puti(&mut b, i, -12345);
    }
    for c in b[440..632].chunks_mut(8) {
        c.copy_from_slice(b"-12345  ");
    }
    putf(&mut b, 0, 0.01);
    putf(&mut b, 5, 1.5);
    putf(&mut b, 58, 0.0);
    for (i, v) in [2001, 32, 0, 0, 0, 250, 6].iter().enumerate() {
        puti(&mut b, i, *v);
    }
    puti(&mut b, 9, npts);
    puti(&mut b, 15, 1);
    puti(&mut b, 16, 8);
    b[440..448].copy_from_slice(b"ABC\0xyz ");
    b[600..608].copy_from_slice(b"HNZ     ");
    for v in data {
        b.extend_from_slice(&if little {
            v.to_le_bytes()
        } else {
            v.to_be_bytes()
        });
    }
    b
}

#[test]
fn sac_both_byte_orders() {
    for little in [true, false] {
        let bytes = sac_file(little, 3, &[1.0, -2.5, 3.25]);
        let fc = readers::sac::read(&bytes, &src("x.sac"), &ReadOptions::default()).unwrap();
        let r = &fc.records[0];
        assert_eq!(r.samples, vec![1.0, -2.5, 3.25]);
        assert_eq!(r.channel.id, ".ABC..HNZ");
        assert_eq!(r.channel.sampling_rate_hz, 100.0);
        assert_eq!(r.channel.direction, Some(Direction::Up));
        let t = epoch_ns_from_civil(2001, 2, 1, 0, 0, 1.75).unwrap();
        assert_eq!(r.channel.start_ns, Some(t));
        assert_eq!(r.channel.missing, vec!["units".to_string()]);
    }
}

#[test]
fn sac_short_file_is_an_error_with_offset() {
    let bytes = sac_file(true, 5, &[1.0, 2.0]);
    let e = readers::sac::read(&bytes, &src("x.sac"), &ReadOptions::default()).unwrap_err();
    let (location, message) = input_error(e);
    assert_eq!(location.byte_offset, Some(640));
    assert!(message.contains("NPTS=5"), "{message}");
}

/// Issue 14 item 5: B = 3e38 s put the start ~1727 (the nanosecond sum
/// wrapped; a panic in debug builds).  A start i64 nanoseconds cannot hold is
/// unknown, and said so.
#[test]
fn sac_absurd_begin_offset_leaves_the_start_unknown() {
    let mut bytes = sac_file(true, 3, &[1.0, -2.5, 3.25]);
    bytes[20..24].copy_from_slice(&3e38f32.to_le_bytes());
    let fc = readers::sac::read(&bytes, &src("x.sac"), &ReadOptions::default()).unwrap();
    let ch = &fc.records[0].channel;
    assert_eq!(ch.start_ns, None);
    assert!(
        ch.missing.contains(&"start_time".to_string()),
        "{:?}",
        ch.missing
    );
}

/// One channel in two epochs (2010–2015 and from 2015) with different
/// elevation, dip and sensitivity.
const STATIONXML_EPOCHS: &str = r#"<?xml version="1.0"?>
<FDSNStationXML xmlns="http://www.fdsn.org/xml/station/1" schemaVersion="1.1">
 <Network code="XX"><Station code="S1">
  <Site><Name>Test site</Name></Site>
  <Channel code="HNZ" locationCode="00" startDate="2010-01-01T00:00:00Z" endDate="2015-01-01T00:00:00Z">
   <Elevation>5.0</Elevation><Azimuth>0</Azimuth><Dip>-90</Dip><SampleRate>100</SampleRate>
   <Response><InstrumentSensitivity><Value>1000</Value><Frequency>1</Frequency>
    <InputUnits><Name>M/S**2</Name></InputUnits></InstrumentSensitivity></Response>
  </Channel>
  <Channel code="HNZ" locationCode="00" startDate="2015-01-01T00:00:00Z">
   <Elevation>6.0</Elevation><Azimuth>0</Azimuth><Dip>90</Dip><SampleRate>100</SampleRate>
   <Response><InstrumentSensitivity><Value>20</Value><Frequency>1</Frequency>
    <InputUnits><Name>cm/s**2</Name></InputUnits></InstrumentSensitivity></Response>
  </Channel>
 </Station></Network>
</FDSNStationXML>"#;

fn stationxml_source() -> SourceRef {
    SourceRef {
        format: "stationxml".into(),
        ..src("s.xml")
    }
}

#[test]
fn stationxml_epochs_select_by_time() {
    let meta = stationxml::parse(STATIONXML_EPOCHS.as_bytes(), &stationxml_source()).unwrap();
    assert_eq!(meta.len(), 2);
    let mut ch = Channel::new(
        "XX.S1.00.HNZ",
        Units::Counts {
            counts_per_si: None,
        },
        100.0,
        SourceRef {
            format: "mseed".into(),
            ..Default::default()
        },
    );
    ch.network = Some("XX".into());
    ch.station = Some("S1".into());
    ch.location_code = Some("00".into());
    ch.channel_code = Some("HNZ".into());
    ch.start_ns = parse_iso8601_ns("2016-05-01T00:00:00Z");
    let mut recs = vec![Record::new(ch.clone(), vec![0.0])];
    stationxml::apply(&mut recs, &meta);
    let c = &recs[0].channel;
    assert_eq!(
        c.units,
        Units::Counts {
            counts_per_si: Some(2000.0)
        }
    );
    assert_eq!(c.direction, Some(Direction::Down));
    assert_eq!(c.elevation_m, Some(6.0));
    ch.start_ns = parse_iso8601_ns("2012-05-01T00:00:00Z");
    let mut recs = vec![Record::new(ch, vec![0.0])];
    stationxml::apply(&mut recs, &meta);
    let c = &recs[0].channel;
    assert_eq!(
        c.units,
        Units::Counts {
            counts_per_si: Some(1000.0)
        }
    );
    assert_eq!(c.direction, Some(Direction::Up));
    assert_eq!(c.location_text.as_deref(), Some("Test site"));
}

#[test]
fn stationxml_bad_number_names_the_line() {
    let bad =
        STATIONXML_EPOCHS.replace("<Elevation>5.0</Elevation>", "<Elevation>five</Elevation>");
    let e = stationxml::parse(bad.as_bytes(), &stationxml_source()).unwrap_err();
    let (location, message) = input_error(e);
    assert_eq!(location.line, Some(6));
    assert!(message.contains("five"));
}

/// A record without a start time of its own is placed at the event's origin
/// time (stated in the channel metadata), not at 1970; it still reads back
/// with no start time.
#[test]
fn mcap_record_without_start_is_placed_at_the_origin_time() {
    let mut rec = anchorage_event().records[0].clone();
    rec.channel.start_ns = None;
    rec.samples.as_mut_vec().truncate(500);
    let origin = 1_700_000_000_000_000_000i64;
    let ev = Event {
        name: "o".into(),
        origin_ns: Some(origin),
        records: vec![rec],
        ..Default::default()
    };
    let bytes = mcap_writer::write_event_to(
        &ev,
        Cursor::new(Vec::new()),
        &McapWriteOptions::default(),
        Path::new("o.mcap"),
    )
    .unwrap()
    .into_inner();
    let first = mcap::MessageStream::new(&bytes)
        .unwrap()
        .next()
        .unwrap()
        .unwrap();
    assert_eq!(first.log_time as i64, origin);
    assert_eq!(first.channel.metadata["time_base"], "origin_time");
    assert_eq!(first.channel.metadata["start_known"], "false");
    let back = mcap_reader::read(&bytes, &src("o.mcap"), &ReadOptions::default()).unwrap();
    assert_eq!(back.records[0].channel.start_ns, None);
    assert_same_records(&ev.records, &back.records);
}
