//! Outputs do not depend on the number of threads (issue 14, item 7): the
//! README's main job run with one rayon thread and with three writes the same
//! bytes in every file, Parquet tables, run manifest and report alike.

use std::path::Path;

use crate::common::{output_files as files, run_sample_pipeline};

/// Runs the post-earthquake pipeline on the sample quake into `out` with
/// `threads` rayon threads.
fn run_with_threads(out: &Path, threads: usize) {
    let threads = threads.to_string();
    run_sample_pipeline(
        "post-earthquake.toml",
        "synthetic-4storey-quake",
        out,
        &[("RAYON_NUM_THREADS", &threads)],
    );
}

/// Regression: `modes`, `stabilization`, `modal_spectrum` (and the twin update
/// fed by them) changed in the 15th digit between 1 and 2+ threads, because
/// faer's linear algebra split its sums by the thread count.  The same output
/// path is used for both runs (the report and run.json name it).
#[test]
fn outputs_are_byte_identical_with_one_and_three_threads() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    run_with_threads(&out, 1);
    let one = tmp.path().join("one-thread");
    std::fs::rename(&out, &one).unwrap();
    run_with_threads(&out, 3);
    let names = files(&out);
    assert_eq!(names, files(&one), "the two runs wrote different files");
    for expected in [
        "modes/modes.parquet",
        "stabilization/stabilization.parquet",
        "modal_spectrum/modal_spectrum.parquet",
    ] {
        assert!(
            names.iter().any(|n| n == expected),
            "no {expected}: {names:?}"
        );
    }
    let differing: Vec<&String> = names
        .iter()
        .filter(|n| std::fs::read(out.join(n)).unwrap() != std::fs::read(one.join(n)).unwrap())
        .collect();
    assert!(
        differing.is_empty(),
        "bytes differ between RAYON_NUM_THREADS=1 and 3: {differing:?}"
    );
}
