//! Event folders: safe zip handling, nested zips, manifest contracts, and
//! the bad-input errors they must give (naming file, member, line).

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::common::{fixed_e10, smc_file};
use quaketwin::event_folder::{self, ArchiveLimits};
use quaketwin::Error;
use zip::write::SimpleFileOptions;

const AT2: &str = "PEER NGA STRONG MOTION DATABASE RECORD\nTest record\nACCELERATION TIME SERIES IN UNITS OF G\nNPTS=      7, DT=    .0100 SEC\n  0.1000000E-01  0.2000000E-01  0.3000000E-01 -0.1000000E-01 -0.2000000E-01\n  0.5000000E-02  0.0000000E+00\n";

fn zip_bytes(members: &[(&str, &[u8])]) -> Vec<u8> {
    let mut w = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let opts = SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
    for (name, data) in members {
        w.start_file(*name, opts).unwrap();
        w.write_all(data).unwrap();
    }
    w.finish().unwrap().into_inner()
}

fn temp_file(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn input_error_text(e: Error) -> String {
    match &e {
        Error::Input { .. } => e.to_string(),
        other => panic!("expected an input error, got {other:?}"),
    }
}

#[test]
fn reads_a_directory_with_manifest_in_manifest_order() {
    let dir = tempfile::tempdir().unwrap();
    temp_file(dir.path(), "b.AT2", AT2.as_bytes());
    temp_file(dir.path(), "a.AT2", AT2.as_bytes());
    temp_file(
        dir.path(),
        "event.toml",
        b"[event]\nname = \"T\"\n[[channel]]\nfile = \"b.AT2\"\nid = \"B\"\nlevel = 1\ndirection = \"X\"\n[[channel]]\nfile = \"a.AT2\"\nid = \"A\"\nlevel = 0\ndirection = 90\n",
    );
    let loaded = event_folder::load(dir.path()).unwrap();
    let ids: Vec<_> = loaded
        .event
        .records
        .iter()
        .map(|r| r.channel.id.as_str())
        .collect();
    assert_eq!(ids, ["B", "A"]);
    assert_eq!(loaded.event.name, "T");
    let a = &loaded.event.records[1].channel;
    assert_eq!(a.role, quaketwin::vocab::Role::Input, "level 0 → input");
    assert!(a.inferred.iter().any(|s| s.contains("level 0")));
    // B is stated along X, A at azimuth 90°: how the two relate is unknown
    // without structure.x_axis_azimuth_deg, so A stays at its azimuth and
    // the notes say what to state.
    assert_eq!(
        a.direction,
        Some(quaketwin::vocab::Direction::Azimuth(90.0))
    );
    assert!(loaded.geometry.axes.is_none());
    assert!(loaded
        .event
        .notes
        .iter()
        .any(|n| n.contains("channel A") && n.contains("x_axis_azimuth_deg")));
    assert_eq!(loaded.event.records[0].samples.len(), 7);
    assert_eq!(loaded.event.records[0].channel.sampling_rate_hz, 100.0);
}

#[test]
fn zip_inside_zip_is_expanded_and_member_paths_are_kept() {
    let inner = zip_bytes(&[("inner/rec.AT2", AT2.as_bytes())]);
    let outer = zip_bytes(&[("Structure.zip", &inner), ("README.txt", b"hello")]);
    let dir = tempfile::tempdir().unwrap();
    let p = temp_file(dir.path(), "event.zip", &outer);
    let loaded = event_folder::load(&p).unwrap();
    assert_eq!(loaded.event.records.len(), 1);
    let src = &loaded.event.records[0].channel.source;
    assert_eq!(src.file, "event.zip");
    assert_eq!(src.member.as_deref(), Some("Structure.zip:inner/rec.AT2"));
    assert!(loaded
        .files
        .iter()
        .any(|f| f.name.ends_with("README.txt") && f.skipped.is_some()));
}

#[test]
fn zip_member_with_parent_components_is_refused() {
    let z = zip_bytes(&[("../evil.AT2", AT2.as_bytes())]);
    let dir = tempfile::tempdir().unwrap();
    let p = temp_file(dir.path(), "bad.zip", &z);
    let msg = input_error_text(event_folder::load(&p).unwrap_err());
    assert!(
        msg.contains("bad.zip") && msg.contains("../evil.AT2") && msg.contains(".."),
        "{msg}"
    );
}

#[test]
fn zip_member_with_absolute_path_is_refused() {
    let z = zip_bytes(&[("/etc/evil.AT2", AT2.as_bytes())]);
    let dir = tempfile::tempdir().unwrap();
    let p = temp_file(dir.path(), "abs.zip", &z);
    let msg = input_error_text(event_folder::load(&p).unwrap_err());
    assert!(msg.contains("abs.zip") && msg.contains("absolute"), "{msg}");
}

/// What `collect` makes of a zip holding one member named `name`: `Ok`, or
/// `Err` with its refusal of the member name (any other error fails the test).
fn member_name_check(name: &str) -> Result<(), String> {
    let dir = tempfile::tempdir().unwrap();
    let p = temp_file(dir.path(), "names.zip", &zip_bytes(&[(name, b"x")]));
    match event_folder::collect(&p, &ArchiveLimits::default()) {
        Ok(_) => Ok(()),
        Err(e) => {
            let msg = input_error_text(e);
            assert!(msg.contains("member name"), "{msg}");
            Err(msg)
        }
    }
}

#[test]
fn member_names_that_escape_are_refused() {
    assert!(member_name_check("CHAN1.V2").is_ok());
    assert!(member_name_check("Structure/CHAN1.V2").is_ok());
    assert!(member_name_check("../evil").is_err());
    assert!(member_name_check("a/../../evil").is_err());
    assert!(member_name_check("/etc/passwd").is_err());
    assert!(member_name_check("C:/x").is_err());
    assert!(member_name_check("..\\evil").is_err());
}

#[test]
fn zips_nested_deeper_than_the_limit_are_refused() {
    let mut z = zip_bytes(&[("rec.AT2", AT2.as_bytes())]);
    for i in 0..3 {
        z = zip_bytes(&[(&format!("level{i}.zip"), &z)]);
    }
    let dir = tempfile::tempdir().unwrap();
    let p = temp_file(dir.path(), "deep.zip", &z);
    let limits = ArchiveLimits {
        max_zip_depth: 3,
        ..ArchiveLimits::default()
    };
    let msg = input_error_text(event_folder::load_with_limits(&p, &limits).unwrap_err());
    assert!(
        msg.contains("deep.zip") && msg.contains("nested deeper"),
        "{msg}"
    );
    // One level less is fine.
    let limits = ArchiveLimits {
        max_zip_depth: 4,
        ..ArchiveLimits::default()
    };
    assert_eq!(
        event_folder::load_with_limits(&p, &limits)
            .unwrap()
            .event
            .records
            .len(),
        1
    );
}

/// Overwrites the 4-byte little-endian size fields of every header (local
/// and central) of a stored zip: a member that claims more than the file holds.
fn patch_sizes(z: &mut [u8], claimed: u32) {
    let mut i = 0;
    while i + 30 < z.len() {
        if z[i..i + 4] == [0x50, 0x4b, 0x03, 0x04] {
            z[i + 18..i + 22].copy_from_slice(&claimed.to_le_bytes());
            z[i + 22..i + 26].copy_from_slice(&claimed.to_le_bytes());
        }
        if z[i..i + 4] == [0x50, 0x4b, 0x01, 0x02] {
            z[i + 20..i + 24].copy_from_slice(&claimed.to_le_bytes());
            z[i + 24..i + 28].copy_from_slice(&claimed.to_le_bytes());
        }
        i += 1;
    }
}

#[test]
fn member_claiming_more_bytes_than_the_archive_holds_is_refused() {
    let mut z = zip_bytes(&[("rec.AT2", AT2.as_bytes())]);
    patch_sizes(&mut z, 50_000_000);
    let dir = tempfile::tempdir().unwrap();
    let p = temp_file(dir.path(), "liar.zip", &z);
    let msg = input_error_text(event_folder::load(&p).unwrap_err());
    assert!(msg.contains("liar.zip"), "{msg}");
}

#[test]
fn manifest_errors_name_the_manifest_and_line() {
    let dir = tempfile::tempdir().unwrap();
    temp_file(dir.path(), "a.AT2", AT2.as_bytes());
    temp_file(
        dir.path(),
        "event.toml",
        b"[event]\nname = \"x\"\n\n[[channel]]\nfile = \"a.AT2\"\nlevle = 1\n",
    );
    let msg = input_error_text(event_folder::load(dir.path()).unwrap_err());
    assert!(
        msg.contains("event.toml") && msg.contains("line 6") && msg.contains("levle"),
        "{msg}"
    );
}

/// Found by the in-process structured fuzz run (case 1258 of seed 33): an
/// origin time out of range in a zipped event's manifest named
/// `event.toml` alone, not the zip it is in.
#[test]
fn a_bad_origin_time_names_the_zip_holding_the_manifest() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = b"[event]\norigin_time = \"Z\"\n\n[[channel]]\nfile = \"a.AT2\"\nlevel = 0\ndirection = \"X\"\nrole = \"input\"\n";
    let zip = temp_file(
        dir.path(),
        "quake-17.zip",
        &zip_bytes(&[("a.AT2", AT2.as_bytes()), ("event.toml", manifest)]),
    );
    let msg = input_error_text(event_folder::load(&zip).unwrap_err());
    assert!(
        msg.contains("quake-17.zip") && msg.contains("event.toml") && msg.contains("origin_time"),
        "{msg}"
    );
}

#[test]
fn manifest_naming_a_missing_file_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    temp_file(dir.path(), "a.AT2", AT2.as_bytes());
    temp_file(
        dir.path(),
        "event.toml",
        b"[[channel]]\nfile = \"missing.AT2\"\nid = \"M\"\n",
    );
    let msg = input_error_text(event_folder::load(dir.path()).unwrap_err());
    assert!(
        msg.contains("missing.AT2") && msg.contains("channel M"),
        "{msg}"
    );
}

#[test]
fn manifest_with_unknown_units_or_role_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    temp_file(dir.path(), "a.AT2", AT2.as_bytes());
    temp_file(
        dir.path(),
        "event.toml",
        b"[[channel]]\nfile = \"a.AT2\"\nid = \"A\"\nunits = \"furlongs\"\n",
    );
    let msg = input_error_text(event_folder::load(dir.path()).unwrap_err());
    assert!(
        msg.contains("furlongs") && msg.contains("channel A"),
        "{msg}"
    );
    temp_file(
        dir.path(),
        "event.toml",
        b"[[channel]]\nfile = \"a.AT2\"\nid = \"A\"\nrole = \"base\"\n",
    );
    let msg = input_error_text(event_folder::load(dir.path()).unwrap_err());
    assert!(msg.contains("role"), "{msg}");
}

#[test]
fn folder_without_manifest_reports_what_is_missing() {
    let dir = tempfile::tempdir().unwrap();
    temp_file(dir.path(), "a.AT2", AT2.as_bytes());
    let loaded = event_folder::load(dir.path()).unwrap();
    let ch = &loaded.event.records[0].channel;
    for m in ["level", "role", "direction"] {
        assert!(
            ch.missing.iter().any(|x| x == m),
            "missing {m}: {:?}",
            ch.missing
        );
    }
    assert!(loaded
        .event
        .notes
        .iter()
        .any(|n| n.contains("no event.toml")));
    assert!(loaded
        .event
        .notes
        .iter()
        .any(|n| n.contains("no base (input) channel")));
}

#[test]
fn an_empty_folder_is_an_error_not_an_empty_event() {
    let dir = tempfile::tempdir().unwrap();
    temp_file(dir.path(), "notes.txt", b"nothing here");
    let msg = input_error_text(event_folder::load(dir.path()).unwrap_err());
    assert!(msg.contains("no record files"), "{msg}");
}

#[test]
fn inputs_are_never_modified() {
    let dir = tempfile::tempdir().unwrap();
    let p = temp_file(dir.path(), "a.AT2", AT2.as_bytes());
    let before = std::fs::metadata(&p).unwrap().modified().unwrap();
    let _ = event_folder::load(dir.path()).unwrap();
    assert_eq!(std::fs::read(&p).unwrap(), AT2.as_bytes());
    assert_eq!(std::fs::metadata(&p).unwrap().modified().unwrap(), before);
}

/// Channel counts per zip of the CESMD bridge corpus, as listed in its
/// PROVENANCE.md (counted there by an independent reader).
const CESMD_CHANNELS: &[(&str, usize)] = &[
    ("painter-st-ce89324/nc73201181_ce89324p.zip", 16),
    ("painter-st-ce89324/nc73351710_ce89324p.zip", 16),
    ("painter-st-ce89324/nc73666231_ce89324p.zip", 16),
    ("painter-st-ce89324/nc73667866_ce89324p.zip", 16),
    (
        "painter-st-ce89324/ferndale_28jan2015_72387946_ce89324p.zip",
        17,
    ),
    (
        "painter-st-ce89324/riodell_19oct2014_72330211_ce89324p.zip",
        17,
    ),
    (
        "painter-st-ce89324/petrolia_05dec2016_72733405_ce89324p.zip",
        17,
    ),
    (
        "painter-st-ce89324/capemendocino_21nov1986_ce89324p.zip",
        20,
    ),
    ("painter-st-ce89324/eureka_24aug1983_ce89324p.zip", 15),
    ("painter-st-ce89324/petrolia91_ce89324p.zip", 3),
    ("painter-st-ce89324/riodell82_ce89324p.zip", 15),
    (
        "painter-st-ce89324/trinidad-offshore_08nov1980_ce89324p.zip",
        18,
    ),
    ("ridgecrest-ce33742/ci38443183_ce33742p.zip", 9),
    ("ridgecrest-ce33742/ci38996632_ce33742p.zip", 9),
    ("ridgecrest-ce33742/ci39462536_ce33742p.zip", 9),
    ("crowley-ce54730/QualeysCamp_18Sep2004_CE54730.ZIP", 9),
    ("crowley-ce54730/mammothlakes_12jun2007_ce54730p.zip", 9),
    ("capistrano-ce13795/Inglewood_17May2009_CE13795P.zip", 12),
];

#[test]
fn shared_cesmd_bridge_corpus_ingests_with_the_provenance_channel_counts() {
    let corpus = super::common::shared_record("cesmd-bridges-corpus");
    // Every zip of the folder is listed (a new one must be added above).
    let mut on_disk = Vec::new();
    for bridge in std::fs::read_dir(&corpus).unwrap() {
        let bridge = bridge.unwrap().path();
        if bridge.is_dir() {
            for z in std::fs::read_dir(&bridge).unwrap() {
                let z = z.unwrap().path();
                on_disk.push(format!(
                    "{}/{}",
                    bridge.file_name().unwrap().to_string_lossy(),
                    z.file_name().unwrap().to_string_lossy()
                ));
            }
        }
    }
    on_disk.sort();
    let mut listed: Vec<String> = CESMD_CHANNELS.iter().map(|(z, _)| z.to_string()).collect();
    listed.sort();
    assert_eq!(on_disk, listed);
    for (zip, expected) in CESMD_CHANNELS {
        let loaded = event_folder::load(&corpus.join(zip)).unwrap_or_else(|e| panic!("{zip}: {e}"));
        let sensors = loaded
            .event
            .records
            .iter()
            .filter(|r| !r.channel.is_floor_motion())
            .count();
        assert_eq!(sensors, *expected, "{zip}");
        // Every horizontal sensor ends in building axes or is named as unresolved.
        for r in &loaded.event.records {
            let c = &r.channel;
            if let Some(quaketwin::vocab::Direction::Azimuth(az)) = c.direction {
                assert!(
                    loaded.event.notes.iter().any(|n| n.contains(&c.id)),
                    "{zip}: {} left at {az}° without a note",
                    c.id
                );
            }
        }
    }
}

#[test]
fn zipped_event_reads_its_twin_from_the_zip() {
    let sample =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("sample-records/synthetic-4storey-quake");
    let members: Vec<(String, Vec<u8>)> = [
        "event.toml",
        "twin.toml",
        "base_X.AT2",
        "base_Y.AT2",
        "floors.csv",
    ]
    .iter()
    .map(|f| (f.to_string(), std::fs::read(sample.join(f)).unwrap()))
    .collect();
    let refs: Vec<(&str, &[u8])> = members
        .iter()
        .map(|(n, b)| (n.as_str(), b.as_slice()))
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let zip = temp_file(dir.path(), "quake.zip", &zip_bytes(&refs));
    let loaded = event_folder::load(&zip).unwrap();
    let twin_rel = loaded
        .event
        .structure
        .as_ref()
        .unwrap()
        .twin
        .clone()
        .unwrap();
    let mut files = event_folder::ReferencedFiles::new(&zip);
    let twin_path = files.resolve(&twin_rel, "structure.twin").unwrap();
    let twin = quaketwin::twin::load_twin(&twin_path).unwrap();
    assert_eq!(twin.system.start_values().len(), 2);
    // Outside the event, missing, or not a regular file: clear errors.
    let e = files
        .resolve("../twin.toml", "structure.twin")
        .unwrap_err()
        .to_string();
    assert!(e.contains("inside the event"), "{e}");
    let e = files
        .resolve("nothere.toml", "structure.twin")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("quake.zip") && e.contains("not in the event"),
        "{e}"
    );
    let extracted = twin_path.parent().unwrap().to_path_buf();
    drop(files);
    assert!(!extracted.exists(), "the extraction directory is removed");
}

#[cfg(unix)]
#[test]
fn referenced_twin_must_be_a_regular_file() {
    let dir = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink("/dev/zero", dir.path().join("twin.toml")).unwrap();
    let mut files = event_folder::ReferencedFiles::new(dir.path());
    let e = files
        .resolve("twin.toml", "structure.twin")
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a regular file"), "{e}");
}

#[test]
fn paths_outside_the_event_are_refused() {
    // Every path exists, so only the inside-the-event check can refuse one.
    let dir = tempfile::tempdir().unwrap();
    let event = dir.path().join("event");
    std::fs::create_dir_all(event.join("model")).unwrap();
    for f in ["event/twin.toml", "event/model/twin.toml", "twin.toml"] {
        temp_file(dir.path(), f, b"");
    }
    let mut files = event_folder::ReferencedFiles::new(&event);
    let mut is_relative_inside = |rel: &str| match files.resolve(rel, "structure.twin") {
        Ok(_) => true,
        Err(e) => {
            let msg = e.to_string();
            assert!(
                msg.contains("must be a relative path inside the event"),
                "{msg}"
            );
            false
        }
    };
    assert!(is_relative_inside("twin.toml"));
    assert!(is_relative_inside("model/twin.toml"));
    assert!(!is_relative_inside("../twin.toml"));
    assert!(!is_relative_inside("/etc/passwd"));
    assert!(!is_relative_inside(""));
}

#[test]
fn folder_without_manifest_still_gives_a_report() {
    let dir = tempfile::tempdir().unwrap();
    let ev = dir.path().join("ev");
    std::fs::create_dir(&ev).unwrap();
    // Two records whose headers say nothing of roles or levels.
    let sample =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("sample-records/synthetic-4storey-quake");
    std::fs::copy(sample.join("base_X.AT2"), ev.join("a.AT2")).unwrap();
    std::fs::copy(sample.join("base_Y.AT2"), ev.join("b.AT2")).unwrap();
    let pipeline = quaketwin::stages::load_pipeline(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/post-earthquake.toml"),
    )
    .unwrap();
    let out = dir.path().join("out");
    let outcomes = quaketwin::pipeline::run(&pipeline, &ev, &out, true).unwrap();
    let outcome = |name: &str| &outcomes.iter().find(|(n, _)| n == name).unwrap().1;
    match outcome("modal") {
        quaketwin::pipeline::StageOutcome::NotApplicable(why) => {
            assert!(why.contains("role"), "{why}")
        }
        other => panic!("modal: {other:?}"),
    }
    assert!(matches!(
        outcome("report"),
        quaketwin::pipeline::StageOutcome::Ran { .. }
    ));
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(
        html.contains("role"),
        "the report says what is missing to go further"
    );
}

/// Why `name` (a suffix of its display name) was skipped; panics when it was read.
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

#[test]
fn nsmp_zip_reads_acceleration_and_lists_other_products_with_reasons() {
    // Per channel: acceleration, velocity, displacement, Fourier and
    // response spectra, as in USGS NSMP event zips.
    let values: Vec<f64> = (0..16).map(|k| (k as f64 * 0.4).sin() * 10.0).collect();
    let data = fixed_e10(&values);
    let line4 = "     2018  01  04    1039 Anchorage test";
    let start = [
        (1, 2018),
        (2, 1),
        (3, 4),
        (4, 10),
        (5, 39),
        (6, 0),
        (7, 164),
    ];
    let mut members: Vec<(String, Vec<u8>)> = Vec::new();
    for (code, comp) in [("ANC1", "360"), ("ANC2", "90")] {
        for (suffix, label) in [
            ("a.smc", "2 CORRECTED ACCELEROGRAM"),
            ("v.smc", "3 VELOCITY"),
            ("d.smc", "4 DISPLACEMENT"),
        ] {
            let text = smc_file(label, line4, code, comp, &start, 16, Some(100.0), &data);
            members.push((format!("8040/{code}_{suffix}"), text.into_bytes()));
        }
        members.push((
            format!("8040/{code}_f.fs1"),
            b"5 FOURIER AMPLITUDE SPECTRA\n 0.1 0.2\n".to_vec(),
        ));
        members.push((
            format!("8040/{code}_r.rs2"),
            b"5 RESPONSE SPECTRA\n 0.1 0.2\n".to_vec(),
        ));
    }
    let refs: Vec<(&str, &[u8])> = members
        .iter()
        .map(|(n, b)| (n.as_str(), b.as_slice()))
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let p = temp_file(dir.path(), "nsmp.zip", &zip_bytes(&refs));
    let loaded = event_folder::load(&p).unwrap();

    let ids: Vec<&str> = loaded
        .event
        .records
        .iter()
        .map(|r| r.channel.id.as_str())
        .collect();
    assert_eq!(ids, ["ANC1.360", "ANC2.90"]);
    for r in &loaded.event.records {
        assert_eq!(
            r.channel.start_ns,
            quaketwin::vocab::epoch_ns_from_civil(2018, 1, 4, 10, 39, 0.164)
        );
    }
    let skipped: Vec<_> = loaded
        .files
        .iter()
        .filter(|f| f.skipped.is_some())
        .collect();
    assert_eq!(skipped.len(), 8, "{:?}", loaded.files);
    for code in ["ANC1", "ANC2"] {
        let r = skip_reason(&loaded, &format!("{code}_v.smc"));
        assert!(
            r.contains("SMC velocity series (only acceleration is read)"),
            "{r}"
        );
        let r = skip_reason(&loaded, &format!("{code}_d.smc"));
        assert!(r.contains("SMC displacement series"), "{r}");
        let r = skip_reason(&loaded, &format!("{code}_f.fs1"));
        assert!(r.contains("Fourier amplitude spectrum (.fs1)"), "{r}");
        let r = skip_reason(&loaded, &format!("{code}_r.rs2"));
        assert!(r.contains("response spectrum (.rs2)"), "{r}");
    }
}

#[test]
fn documentation_quoting_a_record_header_is_skipped_not_fatal() {
    let dir = tempfile::tempdir().unwrap();
    temp_file(dir.path(), "rec.AT2", AT2.as_bytes());
    temp_file(
        dir.path(),
        "README.md",
        b"# Test event\n\nThe AT2 header line reads\nNPTS=  100, DT= 0.01\nand the values follow.\n",
    );
    temp_file(
        dir.path(),
        "PROVENANCE.md",
        b"Records copied unchanged.\nNPTS=  100, DT= 0.01 SEC\n",
    );
    let loaded = event_folder::load(dir.path()).unwrap();
    assert_eq!(loaded.event.records.len(), 1);
    assert_eq!(loaded.event.records[0].samples.len(), 7);
    for doc in ["README.md", "PROVENANCE.md"] {
        let r = skip_reason(&loaded, doc);
        assert!(
            r.contains("documentation") && r.contains(".md"),
            "{doc}: {r}"
        );
    }
}

/// A CSMIP file of one channel (station 99999, channel 1) in the published
/// layout: `label` on line 1, 16I5 and 8F10 headers, then the 8-value
/// acceleration section.
fn csmip_channel(label: &str) -> String {
    let mut t = format!("{label}\nTEST EARTHQUAKE\n");
    t.push_str(
        "STATION NO. 99999   34.000N, 118.000W   SMA-1  S/N 0001\nTEST SITE\nCHAN  1:  90 DEG\n",
    );
    t.push_str(
        &[1i64, 1, 1, 3, 3]
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
    t.push_str("/&  ----------  END OF DATA FOR CHANNEL  1  ----------\n");
    t
}

#[test]
fn csmip_v1_beside_its_v2_is_a_duplicate_and_alone_is_read() {
    let v1 = csmip_channel("UNCORRECTED ACCELEROGRAM DATA");
    let v2 = csmip_channel("CORRECTED ACCELEROGRAM");
    let dir = tempfile::tempdir().unwrap();
    let both = temp_file(
        dir.path(),
        "both.zip",
        &zip_bytes(&[("CHAN001.V1", v1.as_bytes()), ("CHAN001.V2", v2.as_bytes())]),
    );
    let loaded = event_folder::load(&both).unwrap();
    assert_eq!(loaded.event.records.len(), 1, "{:?}", loaded.files);
    let rec = &loaded.event.records[0];
    assert_eq!(
        rec.channel.id, "99999.01",
        "no #n suffix: the V1 was not read"
    );
    assert_eq!(rec.channel.source.member.as_deref(), Some("CHAN001.V2"));
    let r = skip_reason(&loaded, "CHAN001.V1");
    assert!(
        r.contains("uncorrected V1 duplicate") && r.contains("CHAN001.V2"),
        "{r}"
    );

    let only = temp_file(
        dir.path(),
        "raw.zip",
        &zip_bytes(&[("CHAN001.V1", v1.as_bytes())]),
    );
    let loaded = event_folder::load(&only).unwrap();
    assert_eq!(loaded.event.records.len(), 1);
    assert_eq!(
        loaded.event.records[0].channel.source.member.as_deref(),
        Some("CHAN001.V1")
    );
    assert_eq!(
        loaded.event.records[0].samples,
        [1., 2., 3., 4., 5., 6., 7., 8.]
    );
}

/// Issue 14 item 5: values that used to pass silently into nonsense.
#[test]
fn manifest_values_outside_their_physical_range_are_errors_naming_the_key() {
    let cases: [(&str, &str); 6] = [
        (
            "[event]\norigin_time = \"99999-01-01T00:00:00Z\"\n",
            "event.origin_time",
        ),
        // The structured fuzz run, case 576448 of seed 33: an azimuth of
        // ±1e300 reached the geometry as "axes must be orthogonal", naming
        // no file.
        (
            "[structure]\nx_axis_azimuth_deg = -1e300\n",
            "structure.x_axis_azimuth_deg",
        ),
        (
            "[structure]\nx_axis_azimuth_deg = 361.0\n",
            "structure.x_axis_azimuth_deg",
        ),
        (
            "[structure]\nstorey_heights_m = [1e-300, 3.0]\n",
            "storey_heights_m",
        ),
        (
            "[structure]\nstorey_heights_m = [3.0, 3.0]\nmasses_kg = [1e5]\n",
            "masses_kg lists 1 levels",
        ),
        (
            "[[channel]]\nfile = \"a.AT2\"\nid = \"A\"\nlevel = -1\n",
            "level -1",
        ),
    ];
    for (manifest, key) in cases {
        let dir = tempfile::tempdir().unwrap();
        temp_file(dir.path(), "a.AT2", AT2.as_bytes());
        temp_file(dir.path(), "event.toml", manifest.as_bytes());
        let e = input_error_text(event_folder::load(dir.path()).unwrap_err());
        assert!(
            e.contains("event.toml") && e.contains(key),
            "{manifest}: {e}"
        );
    }
}

/// Issue 11: a design file (and the twin it names) inside a zipped event is
/// read from the zip by the test-design pipeline.
#[test]
fn zipped_event_reads_its_design_file_and_twin_from_the_zip() {
    let sample = Path::new(env!("CARGO_MANIFEST_DIR")).join("sample-records/synthetic-facade");
    let mut members: Vec<(String, Vec<u8>)> = std::fs::read_dir(&sample)
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| {
            (
                p.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    members.sort();
    let refs: Vec<(&str, &[u8])> = members
        .iter()
        .map(|(n, b)| (n.as_str(), b.as_slice()))
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let zip = temp_file(dir.path(), "facade.zip", &zip_bytes(&refs));
    let pipeline = quaketwin::stages::load_pipeline(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/test-design.toml"),
    )
    .unwrap();
    let out = dir.path().join("out");
    let outcomes = quaketwin::pipeline::run(&pipeline, &zip, &out, true).unwrap();
    let design = &outcomes.iter().find(|(n, _)| n == "design").unwrap().1;
    assert!(
        matches!(design, quaketwin::pipeline::StageOutcome::Ran { .. }),
        "{design:?}"
    );
    assert!(out
        .join("actuator_layout/actuator_layout.parquet")
        .is_file());
}

/// Issue 14 item 8: `inspect` on a FIFO or a device hung or grew without
/// bound; only directories and regular files are events.
#[cfg(unix)]
#[test]
fn an_event_that_is_a_fifo_or_device_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("event.zip");
    let status = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap();
    assert!(status.success());
    for p in [fifo.as_path(), Path::new("/dev/zero")] {
        let e = input_error_text(event_folder::load(p).unwrap_err());
        assert!(e.contains("regular file"), "{e}");
    }
}
