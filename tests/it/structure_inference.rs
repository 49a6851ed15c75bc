//! Issue 31 items 1 and 5: the structure from what the networks publish
//! (SMC `<loclbl=…>` labels, CSMIP location strings, storeys from station
//! names), `quaketwin init`, and the real-file pathologies (repeated time
//! stamps, lengths a few samples apart, non-seismic files beside records).

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::common::{fixed_e10, smc_file};
use quaketwin::event_folder::{self, structure, Manifest};
use quaketwin::readers::{self, Format, ReadOptions};
use quaketwin::vocab::{QaFlag, Role, SourceRef};
use zip::write::SimpleFileOptions;

fn zip_bytes(members: &[(String, Vec<u8>)]) -> Vec<u8> {
    let mut w = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let opts = SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
    for (name, data) in members {
        w.start_file(name.as_str(), opts).unwrap();
        w.write_all(data).unwrap();
    }
    w.finish().unwrap().into_inner()
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// An NSMP-style SMC file in the published layout: 11 text lines (line 6
/// `station = …, component= …`), 48 integers (NSMP start layout: year,
/// month, day, hour, minute, second, ms), 50 reals (rate in field 2), the
/// `|` comment block holding `comment` (e.g. `|<loclbl=Roof>`), 8E10.4 data.
fn nsmp_smc(label: &str, station: &str, component: &str, comment: &str, values: &[f64]) -> String {
    let mut s =
        format!("{label}\n*\nSMPL\n     2024  03  05    1012 Sample quake\nMoment Mag=      5.8\n");
    s.push_str(&format!(
        "station = {station}, component=    {component}\nepicentral dist =  12.0\ninst type=K2\n*\n*\n*\n"
    ));
    let miss = -32768i64;
    let mut ints = vec![miss; 48];
    let start = [2024, 3, 5, 10, 12, 30, 0];
    ints[1..8].copy_from_slice(&start);
    ints[13] = 360;
    ints[15] = 2;
    ints[16] = values.len() as i64;
    for row in ints.chunks(8) {
        s.push_str(&row.iter().map(|v| format!("{v:10}")).collect::<String>());
        s.push('\n');
    }
    let mut reals = vec![1.7e38; 50];
    reals[1] = 100.0;
    for row in reals.chunks(5) {
        s.push_str(&row.iter().map(|v| format!("{v:15.7E}")).collect::<String>());
        s.push('\n');
    }
    s.push_str("| USGS NSMP building record\n");
    s.push_str(comment);
    s.push('\n');
    for l in fixed_e10(values) {
        s.push_str(&l);
        s.push('\n');
    }
    s
}

fn signal(n: usize, amp: f64, f_hz: f64) -> Vec<f64> {
    (0..n)
        .map(|k| amp * (2.0 * std::f64::consts::PI * f_hz * k as f64 / 100.0).sin())
        .collect()
}

/// (level label, the level it must get) of the 7-storey building.
const LEVELS: [(&str, i32); 3] = [("Basement", 0), ("4th floor", 3), ("Roof", 7)];

/// The NSMP-style zip of the 7-storey building: per level two horizontals
/// and a vertical, with `<loclbl=…>`; plus a readme, a plot, a station CSV
/// and an uncorrected V1 beside its V2.  Returns the members.
fn building_members(station: &str, lengths: [usize; 3]) -> Vec<(String, Vec<u8>)> {
    let mut m = Vec::new();
    for (k, (label, _)) in LEVELS.iter().enumerate() {
        for (c, comp) in ["360", "90", "Up"].iter().enumerate() {
            let values = signal(lengths[c], 10.0 * (k + 1) as f64, 1.0 + c as f64);
            let name = format!("SMPL{k}{c}.smc");
            let text = nsmp_smc(
                "2 CORRECTED ACCELEROGRAM",
                station,
                comp,
                &format!("|<loclbl={label}>"),
                &values,
            );
            m.push((name, text.into_bytes()));
        }
    }
    let v1 = nsmp_smc(
        "1 UNCORRECTED ACCELEROGRAM",
        station,
        "360",
        "|<loclbl=Roof>",
        &signal(lengths[0], 30.0, 1.0),
    );
    m.push(("raw/SMPL20_v1.smc".into(), v1.into_bytes()));
    m.push((
        "readme.txt".into(),
        b"USGS NSMP record of the Sample quake.\nChannels: see the plots.\n".to_vec(),
    ));
    m.push((
        "plot.png".into(),
        b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\x00\x00".to_vec(),
    ));
    m.push((
        "stations.csv".into(),
        b"station,name,latitude,longitude\nSMPL,Sample City,34.0,-118.0\n".to_vec(),
    ));
    m
}

fn skip_reason(loaded: &event_folder::LoadedEvent, name: &str) -> String {
    let f = loaded
        .files
        .iter()
        .find(|f| f.name.ends_with(name))
        .unwrap_or_else(|| panic!("{name} not listed: {:?}", loaded.files));
    f.skipped
        .clone()
        .unwrap_or_else(|| panic!("{name} was read, not skipped"))
}

/// Item 6 acceptance: an NSMP-style zip of a 7-storey building, no manifest.
#[test]
fn nsmp_building_zip_without_manifest_gets_levels_roles_storeys_and_located_ids() {
    let dir = tempfile::tempdir().unwrap();
    let zip = write(
        dir.path(),
        "building.zip",
        &zip_bytes(&building_members(
            "Sample City; 7-story Hotel, Steel Frame",
            [1000; 3],
        )),
    );
    let loaded = event_folder::load(&zip).unwrap();
    let e = &loaded.event;
    assert_eq!(e.records.len(), 9, "{:?}", loaded.files);
    let st = e.structure.as_ref().expect("a structure inferred");
    assert_eq!(st.storeys, Some(7));
    assert_eq!(st.kind.as_deref(), Some("building"));
    assert!(st
        .inferred
        .iter()
        .any(|i| i.contains("storeys=7") && i.contains("7-story")));
    for r in &e.records {
        let c = &r.channel;
        let label = c.location_text.as_deref().unwrap();
        let (_, level) = LEVELS.iter().find(|(l, _)| *l == label).unwrap();
        assert_eq!(c.level, Some(*level), "{}", c.id);
        let role = if *level == 0 {
            Role::Input
        } else {
            Role::Output
        };
        assert_eq!(c.role, role, "{}", c.id);
        let tag = match *level {
            0 => "BASEMENT",
            3 => "FLOOR4",
            _ => "ROOF",
        };
        assert!(c.id.ends_with(tag), "id {} carries the location", c.id);
        assert!(
            c.inferred
                .iter()
                .any(|i| i.starts_with(&format!("level={level}"))),
            "{}: {:?}",
            c.id,
            c.inferred
        );
        assert!(c.inferred.iter().any(|i| i.contains("<loclbl>")));
        assert!(!c.missing.iter().any(|m| m == "level" || m == "role"));
    }
    let ids: std::collections::BTreeSet<&str> =
        e.records.iter().map(|r| r.channel.id.as_str()).collect();
    assert_eq!(ids.len(), 9, "ids unique: {ids:?}");
    // Skipped with their reasons, never fatal.
    assert!(skip_reason(&loaded, "readme.txt").contains("documentation"));
    assert!(skip_reason(&loaded, "plot.png").contains("without a record header"));
    assert!(skip_reason(&loaded, "stations.csv").contains("CSV file that is not a record"));
    let v1 = skip_reason(&loaded, "SMPL20_v1.smc");
    assert!(
        v1.contains("uncorrected SMC V1 duplicate") && v1.contains("SMPL20.smc"),
        "{v1}"
    );
    // inspect lists the inferences.
    let text = quaketwin::commands::inspect(&zip).unwrap();
    assert!(text.contains("inferred: level=7"), "{text}");
    assert!(text.contains("inferred: storeys=7"), "{text}");
}

#[test]
fn roof_without_a_storey_count_is_an_assumption_said_in_inferred_and_notes() {
    let dir = tempfile::tempdir().unwrap();
    let zip = write(
        dir.path(),
        "b.zip",
        &zip_bytes(&building_members(
            "Sample City; Steel Frame Bldg",
            [1000; 3],
        )),
    );
    let e = event_folder::load(&zip).unwrap().event;
    let roof: Vec<_> = e
        .records
        .iter()
        .filter(|r| r.channel.location_text.as_deref() == Some("Roof"))
        .collect();
    assert_eq!(roof.len(), 3);
    for r in roof {
        // Highest labelled floor (4th floor = level 3) + 1.
        assert_eq!(r.channel.level, Some(4));
        assert!(r.channel.inferred.iter().any(|i| i.contains("ASSUMED")));
    }
    assert!(
        e.notes.iter().any(|n| n.contains("roof level 4 assumed")),
        "{:?}",
        e.notes
    );
    assert_eq!(e.structure.as_ref().unwrap().storeys, None);
}

#[test]
fn init_writes_a_manifest_that_loads_to_the_same_structure() {
    let dir = tempfile::tempdir().unwrap();
    let members = building_members("Sample City; 7-story Hotel", [1000; 3]);
    let zip = write(dir.path(), "building.zip", &zip_bytes(&members));
    let first = event_folder::load(&zip).unwrap();
    let text = quaketwin::commands::init(&zip, None, false)
        .unwrap()
        .expect("stdout text");
    let m = Manifest::parse(&text, "event.toml").unwrap();
    assert_eq!(m.channels.len(), 9);
    assert_eq!(m.structure.as_ref().unwrap().storeys, Some(7));
    assert!(
        text.contains("# storey_heights_m = [...]  # unknown"),
        "{text}"
    );
    assert!(text.contains("# masses_kg"), "{text}");
    assert!(text.contains("# type = \"C1\""), "{text}");

    // Placed in the event: the same levels, roles, directions and ids.
    let mut with = members.clone();
    with.push(("event.toml".into(), text.clone().into_bytes()));
    let zip2 = write(dir.path(), "with-manifest.zip", &zip_bytes(&with));
    let second = event_folder::load(&zip2).unwrap();
    let key = |l: &event_folder::LoadedEvent| {
        let mut v: Vec<_> = l
            .event
            .records
            .iter()
            .map(|r| {
                let c = &r.channel;
                (
                    c.id.clone(),
                    c.level,
                    c.role,
                    c.direction.map(|d| d.to_string()),
                )
            })
            .collect();
        v.sort_by(|a, b| a.0.cmp(&b.0));
        v
    };
    assert_eq!(key(&first), key(&second));
    assert_eq!(second.event.structure.as_ref().unwrap().storeys, Some(7));

    // -o: atomically, never into the input, never over a file without --force.
    let out = dir.path().join("event.toml");
    assert!(quaketwin::commands::init(&zip, Some(&out), false)
        .unwrap()
        .is_none());
    assert_eq!(std::fs::read_to_string(&out).unwrap(), text);
    let again = quaketwin::commands::init(&zip, Some(&out), false).unwrap_err();
    assert!(again.to_string().contains("--force"), "{again}");
    assert!(quaketwin::commands::init(&zip, Some(&out), true).is_ok());
    let folder = dir.path().join("folder");
    std::fs::create_dir(&folder).unwrap();
    for (n, b) in members.iter().filter(|(n, _)| !n.contains('/')) {
        write(&folder, n, b);
    }
    let inside =
        quaketwin::commands::init(&folder, Some(&folder.join("event.toml")), true).unwrap_err();
    assert!(inside.to_string().contains("never modifies"), "{inside}");
    assert!(!folder.join("event.toml").exists());
}

/// CSMIP V2 channel files of a building: location strings and the station
/// name on the line after `STATION NO.`.
fn csmip_building_channel(chan: u32, location: &str, station_name: &str) -> String {
    let mut t = "CORRECTED ACCELEROGRAM\nSAMPLE EARTHQUAKE\n".to_string();
    t.push_str(&format!(
        "STATION NO. 24999   34.000N, 118.000W   QDR  S/N 0001\n{station_name}\nCHAN  {chan}:  90 DEG   (STA CHN: {chan})   LOCATION: {location}\n"
    ));
    t.push_str(
        &[chan as i64, 1, chan as i64, 3, 3]
            .iter()
            .map(|v| format!("{v:5}"))
            .collect::<String>(),
    );
    t.push_str(&"    0".repeat(11));
    t.push('\n');
    for _ in 0..5 {
        t.push_str(&"    0".repeat(16));
        t.push('\n');
    }
    t.push_str(&"    0".repeat(4));
    t.push('\n');
    for row in 0..13 {
        t.push_str(&"      .000".repeat(if row == 12 { 4 } else { 8 }));
        t.push('\n');
    }
    t.push_str("    8 POINTS OF ACCEL DATA EQUALLY SPACED AT  .020 SEC. (UNITS: CM/SEC/SEC)\n");
    t.push_str(
        "     1.000     2.000     3.000     4.000     5.000     6.000     7.000     8.000\n",
    );
    t.push_str(&format!(
        "/&  ----------  END OF DATA FOR CHANNEL  {chan}  ----------\n"
    ));
    t
}

#[test]
fn csmip_building_location_strings_give_levels_and_station_name_the_storeys() {
    let name = "Sample City - 6-story Office Bldg";
    let members: Vec<(String, Vec<u8>)> =
        [(1, "Ground Floor", 0), (2, "3rd Floor", 2), (3, "Roof", 6)]
            .iter()
            .map(|(c, loc, _)| {
                (
                    format!("CHAN00{c}.V2"),
                    csmip_building_channel(*c, loc, name).into_bytes(),
                )
            })
            .collect();
    let dir = tempfile::tempdir().unwrap();
    let zip = write(dir.path(), "csmip.zip", &zip_bytes(&members));
    let e = event_folder::load(&zip).unwrap().event;
    assert_eq!(e.structure.as_ref().unwrap().storeys, Some(6));
    let level_of = |id_start: &str| {
        e.records
            .iter()
            .find(|r| r.channel.id.starts_with(id_start))
            .unwrap_or_else(|| {
                panic!(
                    "{id_start}: {:?}",
                    e.records.iter().map(|r| &r.channel.id).collect::<Vec<_>>()
                )
            })
            .channel
            .level
    };
    assert_eq!(level_of("24999.01.GROUND"), Some(0));
    assert_eq!(level_of("24999.02.FLOOR3"), Some(2));
    assert_eq!(level_of("24999.03.ROOF"), Some(6));
}

#[test]
fn location_phrases_table() {
    use structure::{place_from_text, storeys_from_name, Place};
    let cases: [(&str, Option<Place>); 16] = [
        ("Roof", Some(Place::Roof)),
        ("4th Floor", Some(Place::Floor(4))),
        ("4th Flr", Some(Place::Floor(4))),
        ("Floor 12 - north", Some(Place::Floor(12))),
        ("Third level", Some(Place::Floor(3))),
        ("Basement", Some(Place::Base("BASEMENT"))),
        ("Grnd Level", Some(Place::Base("GROUND"))),
        ("Ground floor", Some(Place::Base("GROUND"))),
        ("1st floor", Some(Place::Floor(1))),
        ("Penthouse", Some(Place::Penthouse)),
        ("Mezzanine", Some(Place::Mezzanine)),
        ("Deck: Near East Abutment", Some(Place::Bridge("DECK"))),
        (
            "On Ground Near West Abutment",
            Some(Place::Bridge("ABUTMENT")),
        ),
        ("Free field", Some(Place::FreeField)),
        ("Base of building", Some(Place::Base("BASE"))),
        ("Sample City", None),
    ];
    for (text, want) in cases {
        assert_eq!(place_from_text(text), want, "{text}");
    }
    for (name, n) in [
        ("Van Nuys - 7-story Hotel", Some(7)),
        ("Los Angeles - 52-story Office Bldg", Some(52)),
        ("12-storey frame", Some(12)),
        ("a 7 story building", Some(7)),
        ("Seven-story hotel", Some(7)),
        ("Sample City; Steel Frame", None),
    ] {
        assert_eq!(storeys_from_name(name), n, "{name}");
    }
}

fn read_smc(name: &str, text: &str) -> quaketwin::Result<readers::FileContents> {
    let source = SourceRef {
        file: name.into(),
        member: None,
        column: None,
        format: "smc".into(),
    };
    readers::read(
        Format::Smc,
        text.as_bytes(),
        &source,
        &ReadOptions::default(),
    )
}

/// Item 5: an SMC V1 film digitisation with repeated and backwards stamps.
#[test]
fn smc_v1_pairs_with_repeated_and_backwards_stamps_are_cleaned_with_a_note() {
    // Times 0, 0.01, …; stamp k = 10 repeated (values 1 and 3 → mean 2 at
    // t = 0.10) and one stamp going back (0.05 after 0.20) dropped.  The
    // value elsewhere is linear in time, so the resampled series is exact.
    let f = |t: f64| 5.0 + 20.0 * t;
    let mut pairs: Vec<(f64, f64)> = (0..31)
        .map(|k| (0.01 * k as f64, f(0.01 * k as f64)))
        .collect();
    pairs[10].1 = 1.0;
    pairs.insert(11, (0.10, 3.0));
    pairs.insert(22, (0.05, 999.0));
    let flat: Vec<f64> = pairs.iter().flat_map(|&(t, v)| [t, v]).collect();
    let text = smc_file(
        "1 UNCORRECTED ACCELEROGRAM",
        "     1989  10  18    0004 Loma Prieta, CA",
        "TWR0",
        "90",
        &[(1, 1989), (2, 291), (3, 0), (4, 4), (5, 10)],
        pairs.len(),
        None,
        &fixed_e10(&flat),
    );
    let c = read_smc("tower_v1.smc", &text).unwrap();
    let r = &c.records[0];
    assert_eq!(r.len(), 31);
    assert!(
        (r.samples[10] - 2.0).abs() < 1e-3,
        "mean of the repeated stamp: {}",
        r.samples[10]
    );
    for k in (0..31).filter(|&k| k != 10 && k != 9 && k != 11) {
        assert!(
            (r.samples[k] - f(0.01 * k as f64)).abs() < 2e-3,
            "sample {k}: {}",
            r.samples[k]
        );
    }
    let note = r
        .channel
        .qa
        .iter()
        .find_map(|q| match q {
            QaFlag::Note { text } if text.contains("repeated") => Some(text.clone()),
            _ => None,
        })
        .expect("a note");
    assert!(
        note.contains("tower_v1.smc")
            && note.contains("1 repeated")
            && note.contains("1 time stamp(s) going back"),
        "{note}"
    );

    // Not pairs at all and no rate: the error names the real cause.
    let noise: Vec<f64> = (0..40).map(|k| 10.0 * (1.3 * k as f64).sin()).collect();
    let text = smc_file(
        "1 UNCORRECTED ACCELEROGRAM",
        "     1989  10  18    0004 X",
        "TWR0",
        "90",
        &[],
        40,
        None,
        &fixed_e10(&noise),
    );
    let e = read_smc("noise.smc", &text).unwrap_err().to_string();
    assert!(
        e.contains("sampling rate) is missing") && e.contains("go backwards"),
        "{e}"
    );
}

/// Item 5: channels a few samples apart are trimmed; far apart left alone.
#[test]
fn channels_a_few_samples_apart_are_trimmed_to_their_common_window() {
    let dir = tempfile::tempdir().unwrap();
    let zip = write(
        dir.path(),
        "b.zip",
        &zip_bytes(&building_members("Sample 7-story", [1000, 996, 1001])),
    );
    let loaded = event_folder::load(&zip).unwrap();
    for r in &loaded.event.records {
        assert_eq!(r.len(), 996, "{}", r.channel.id);
    }
    let trimmed = loaded
        .event
        .records
        .iter()
        .filter(|r| {
            r.channel
                .qa
                .iter()
                .any(|q| matches!(q, QaFlag::Note { text } if text.contains("trimmed from")))
        })
        .count();
    assert_eq!(trimmed, 6, "the 1000- and 1001-sample channels");
    assert!(loaded
        .event
        .notes
        .iter()
        .any(|n| n.contains("trimmed to their common 996 samples")));

    let zip = write(
        dir.path(),
        "c.zip",
        &zip_bytes(&building_members("Sample 7-story", [1000, 900, 1000])),
    );
    let loaded = event_folder::load(&zip).unwrap();
    assert!(loaded.event.records.iter().any(|r| r.len() == 900));
    assert!(loaded.event.records.iter().any(|r| r.len() == 1000));
    assert!(loaded.event.notes.iter().any(|n| n.contains("left alone")));
}

#[test]
fn a_ground_floor_beside_a_first_floor_counts_floors_from_the_ground() {
    use quaketwin::event_folder::structure::{infer_structure, HeaderFacts};
    use quaketwin::vocab::{Channel, Event, Record, SourceRef, Units};
    let record = |id: &str, location: &str| {
        let mut ch = Channel::new(id, Units::MPerS2, 100.0, SourceRef::default());
        ch.location_text = Some(location.to_string());
        Record::new(ch, vec![0.0; 8])
    };
    let labelled = |labels: &[&str]| {
        let mut event = Event {
            records: labels
                .iter()
                .enumerate()
                .map(|(k, l)| record(&format!("c{k}"), l))
                .collect(),
            ..Default::default()
        };
        let facts = HeaderFacts {
            station_names: vec!["Test - 3-story Office Bldg".into()],
            ..Default::default()
        };
        infer_structure(&mut event, &facts, false);
        event
            .records
            .iter()
            .map(|r| r.channel.level)
            .collect::<Vec<_>>()
    };
    // Ground, 1st, 2nd and 3rd floors of a 3-storey frame: European counting.
    assert_eq!(
        labelled(&[
            "Ground Floor",
            "1st Floor",
            "2nd Floor",
            "3rd Floor (Top floor)"
        ]),
        vec![Some(0), Some(1), Some(2), Some(3)]
    );
    // The same labels without a ground-floor sensor: the US convention.
    assert_eq!(
        labelled(&["Basement", "2nd Floor", "Roof"]),
        vec![Some(0), Some(1), Some(3)]
    );
}

/// A structure's folder whose subfolders are named after its levels (the
/// shared mini shake-table: "Ground Floor", "1st Floor", …) is one event,
/// not a folder of events; a folder of benchmark events still is one.
#[test]
fn floor_subfolders_are_one_structure_not_a_collection_of_events() {
    use quaketwin::commands::expand_events;
    let floors = crate::common::shared_record("mdof-mini-shake-table-flexible-3story");
    assert_eq!(
        expand_events(std::slice::from_ref(&floors)),
        vec![floors.clone()]
    );
    let samples = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("sample-records");
    assert!(expand_events(std::slice::from_ref(&samples)).len() >= 7);
}

/// A building whose storey count no header states: the roof's level is
/// assumed, so the segment up to it has an unknown height — its drift is
/// shown and never rated (the 4th floor → roof segment of a 7-storey
/// building would otherwise be one assumed storey for three real ones).
#[test]
fn a_segment_up_to_an_assumed_roof_level_is_shown_and_not_rated() {
    let dir = tempfile::tempdir().unwrap();
    let zip = write(
        dir.path(),
        "b.zip",
        &zip_bytes(&building_members(
            "Sample City; Steel Frame Bldg",
            [3000; 3],
        )),
    );
    let out = dir.path().join("out");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_quaketwin"))
        .args(["--quiet", "run"])
        .arg(
            std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("pipelines/post-earthquake.toml"),
        )
        .arg(&zip)
        .arg("--out")
        .arg(&out)
        .arg("--json")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let f = out.join("drift/drift.parquet");
    let sources = crate::common::column_str(&f, "height_source");
    let upper = crate::common::column_i64(&f, "upper_level");
    let kinds = crate::common::column_str(&f, "kind");
    let mut roof_rows = 0;
    for i in 0..sources.len() {
        if kinds[i] != "estimate" && upper[i] == 4 {
            assert_eq!(sources[i], "unknown: roof level assumed");
            roof_rows += 1;
        }
    }
    assert!(roof_rows > 0, "{sources:?} {upper:?}");
    // Rated: only the basement → 4th floor segments.
    for a in summary["screening"]["assessments"].as_array().unwrap() {
        let subject = a["subject"].as_str().unwrap();
        assert!(subject.contains("levels 0–3"), "rated {subject}");
    }
}
