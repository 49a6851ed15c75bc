//! Helpers shared by the integration-test modules.

use std::path::PathBuf;

/// `../shared/records` beside the repository (real public records, never
/// copied into it).  Panics with a clear message when the folder is missing,
/// so a test that needs real data never passes silently without it.
pub fn shared_records() -> PathBuf {
    let p = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/records"));
    assert!(
        p.is_dir(),
        "this test reads real records from {} (the shared folder beside the repository); it is missing",
        p.display()
    );
    p
}

/// A file or folder under `../shared/records`, checked to exist.
pub fn shared_record(rel: &str) -> PathBuf {
    let p = shared_records().join(rel);
    assert!(p.exists(), "real record {} is missing", p.display());
    p
}
