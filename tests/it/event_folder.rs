//! Event folders: safe zip handling, nested zips, manifest contracts, and
//! the bad-input errors they must give (naming file, member, line).

use std::io::Write;
use std::path::{Path, PathBuf};

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
    // The only azimuth-labelled sensor fixes the inferred building X axis.
    assert_eq!(
        a.direction,
        Some(quaketwin::vocab::Direction::Axis(quaketwin::vocab::Axis::X))
    );
    let axes = loaded.geometry.axes.as_ref().unwrap();
    assert_eq!(axes.x_azimuth_deg, 90.0);
    assert_eq!(axes.source, quaketwin::geometry::AxesSource::Inferred);
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
