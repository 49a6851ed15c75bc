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

fn batches(path: &std::path::Path) -> Vec<arrow_array::RecordBatch> {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(file)
        .unwrap()
        .build()
        .unwrap()
        .map(|b| b.unwrap())
        .collect()
}

/// A Float64 column of a Parquet file, all row groups (nulls as NaN).
pub fn column_f64(path: &std::path::Path, name: &str) -> Vec<f64> {
    use arrow_array::Array;
    let mut out = Vec::new();
    for b in batches(path) {
        let col = b
            .column_by_name(name)
            .unwrap_or_else(|| panic!("{}: no column {name}", path.display()));
        let a = col
            .as_any()
            .downcast_ref::<arrow_array::Float64Array>()
            .unwrap_or_else(|| panic!("{}: {name} is not Float64", path.display()));
        out.extend((0..a.len()).map(|i| if a.is_null(i) { f64::NAN } else { a.value(i) }));
    }
    out
}

/// A Utf8 column of a Parquet file, all row groups (nulls as "").
pub fn column_str(path: &std::path::Path, name: &str) -> Vec<String> {
    use arrow_array::Array;
    let mut out = Vec::new();
    for b in batches(path) {
        let col = b
            .column_by_name(name)
            .unwrap_or_else(|| panic!("{}: no column {name}", path.display()));
        let a = col
            .as_any()
            .downcast_ref::<arrow_array::StringArray>()
            .unwrap_or_else(|| panic!("{}: {name} is not Utf8", path.display()));
        out.extend((0..a.len()).map(|i| a.value(i).to_string()));
    }
    out
}
