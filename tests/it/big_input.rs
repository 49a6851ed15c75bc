//! Big input in bounded memory (issue 14 item 5): the paths that hold an
//! event a channel at a time give the results of the paths that held it
//! whole — parked samples, per-channel conditioning, the parallel CSV parse,
//! the column-parallel Parquet writer, the streaming report decimation, the
//! response spectra run several oscillators at a time.  The figures
//! themselves are measured by `scripts/bigload.sh` (docs/performance.md).

use std::path::Path;
use std::sync::Arc;

use arrow_array::RecordBatch;
use quaketwin::readers::{self, ReadOptions};
use quaketwin::vocab::{SampleStore, Samples, SourceRef};

use crate::common::{output_files as files, run_sample_pipeline};

/// Runs `pipeline` on sample event `event` into `out`; with `park`, every
/// event is parked in the spill file however small.
fn run(pipeline: &str, event: &str, out: &Path, park: bool) {
    let env: &[(&str, &str)] = if park {
        &[(quaketwin::pipeline::context::PARK_ABOVE_ENV, "0")]
    } else {
        &[]
    };
    run_sample_pipeline(pipeline, event, out, env);
}

/// Rows `from..from + n` of channel `id` of a samples table: acceleration
/// `acc(i)`, velocity `vel(i)` (null when `None`).
fn samples_rows(
    id: &str,
    from: usize,
    n: usize,
    acc: impl Fn(usize) -> f64,
    vel: impl Fn(usize) -> Option<f64>,
) -> RecordBatch {
    use quaketwin::sinks::parquet::TableBuilder;
    use quaketwin::vocab::tables::{samples, SAMPLES};
    let rows = from..from + n;
    TableBuilder::new(&SAMPLES)
        .str(samples::CHANNEL_ID, &vec![id; n])
        .i64(samples::SAMPLE, rows.clone().map(|i| i as i64).collect())
        .f64(
            samples::T_S,
            rows.clone().map(|i| i as f64 * 0.005).collect(),
        )
        .opt_timestamp_ns(samples::TIME, vec![None; n])
        .f64(samples::ACC_M_S2, rows.clone().map(&acc).collect())
        .opt_f64(samples::VEL_M_S, rows.map(&vel).collect())
        .opt_f64(samples::DISP_M, vec![None; n])
        .build()
        .unwrap()
}

/// Every output of a run whose samples were parked in the spill file (read
/// back channel by channel by every stage) is byte for byte the output of
/// the run that held them in memory — and the spill file leaves nothing
/// behind.  The same output path serves both runs (report and run.json name it).
#[test]
fn parked_runs_write_the_same_bytes_as_runs_in_memory() {
    for (pipeline, event) in [
        ("post-earthquake.toml", "synthetic-4storey-quake"),
        ("post-earthquake.toml", "synthetic-2storey-yielding"),
        ("ingest.toml", "synthetic-4storey-ambient"),
        ("test-design.toml", "synthetic-facade"),
    ] {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("out");
        run(pipeline, event, &out, false);
        let memory = tmp.path().join("memory");
        std::fs::rename(&out, &memory).unwrap();
        run(pipeline, event, &out, true);
        let names = files(&out);
        assert_eq!(names, files(&memory), "{event}: different files");
        assert!(names.iter().any(|n| n.ends_with(".parquet")), "{names:?}");
        let differing: Vec<&String> = names
            .iter()
            .filter(|n| {
                std::fs::read(out.join(n)).unwrap() != std::fs::read(memory.join(n)).unwrap()
            })
            .collect();
        assert!(
            differing.is_empty(),
            "{pipeline} on {event}: parked and in-memory runs differ in {differing:?}"
        );
        // A skipped condition stage restores its product (parked) from samples/samples.parquet.
        run(pipeline, event, &out, true);
        assert_eq!(files(&out), names);
    }
}

/// A store in memory, for the `Samples` tests.
#[derive(Default)]
struct VecStore(std::sync::Mutex<Vec<f64>>);

impl SampleStore for VecStore {
    fn put(&self, values: &[f64]) -> std::io::Result<u64> {
        let mut v = self.0.lock().unwrap();
        let at = v.len() as u64;
        v.extend_from_slice(values);
        Ok(at)
    }
    fn get(&self, position: u64, offset: usize, out: &mut [f64]) -> std::io::Result<()> {
        let v = self.0.lock().unwrap();
        let start = position as usize + offset;
        out.copy_from_slice(&v[start..start + out.len()]);
        Ok(())
    }
    fn describe(&self) -> String {
        "a test store".into()
    }
}

#[test]
fn parked_samples_read_back_exactly_and_share_their_store() {
    let store: Arc<dyn SampleStore> = Arc::new(VecStore::default());
    let values: Vec<f64> = (0..1000).map(|i| (i as f64 * 0.37).sin() * 1e-3).collect();
    let mut s = Samples::new(values.clone());
    s.park(&store).unwrap();
    assert!(s.is_parked());
    assert_eq!(s.len(), 1000);
    assert_eq!(&*s.load().unwrap(), &values[..]);
    assert_eq!(&*s.get_range(990, 50).unwrap(), &values[990..]);
    // A clone reads the same stored values, not a copy of them.
    let mut c = s.clone();
    assert!(c.is_parked());
    // Negation is recorded while parked and exact.
    c.negate();
    assert!(c.is_parked());
    assert_eq!(
        c.load().unwrap().to_vec(),
        values.iter().map(|v| -v).collect::<Vec<_>>()
    );
    assert_eq!(&s[..], &values[..], "dereferencing reads (and caches)");
    s.release();
    // Mutation brings them back into memory for good.
    c.iter_mut().for_each(|v| *v *= 2.0);
    assert!(!c.is_parked());
    assert_eq!(c[3], -2.0 * values[3]);
    // A file spill: created in a directory, exact, and gone from it at once on Unix.
    let dir = tempfile::tempdir().unwrap();
    let spill = quaketwin::pipeline::spill::SpillFile::create(dir.path()).unwrap();
    let mut f = Samples::new(values.clone());
    f.park(&spill).unwrap();
    let mut g = Samples::new(vec![f64::MIN_POSITIVE, -0.0, f64::MAX]);
    g.park(&spill).unwrap();
    assert_eq!(f.load().unwrap().to_vec(), values);
    assert_eq!(
        g.load()
            .unwrap()
            .iter()
            .map(|v| v.to_bits())
            .collect::<Vec<_>>(),
        [f64::MIN_POSITIVE, -0.0, f64::MAX].map(f64::to_bits)
    );
    #[cfg(unix)]
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

fn csv_source() -> SourceRef {
    SourceRef {
        file: "t.csv".into(),
        member: None,
        column: None,
        format: "csv".into(),
    }
}

/// Reads `text` as CSV: the records' samples and rates, or the error text.
fn read_csv(text: &str, opts: &ReadOptions) -> Result<Vec<(String, f64, Vec<u64>)>, String> {
    readers::csv::read(text.as_bytes(), &csv_source(), opts)
        .map(|c| {
            c.records
                .into_iter()
                .map(|r| {
                    (
                        r.channel.id.clone(),
                        r.channel.sampling_rate_hz,
                        r.samples.iter().map(|v| v.to_bits()).collect(),
                    )
                })
                .collect()
        })
        .map_err(|e| e.to_string())
}

/// A comma table of `rows` rows (time, two accelerations, a text column).
fn table(rows: usize, crlf: bool, text: &str) -> String {
    table_with(rows, crlf, text, |_, row| row)
}

/// As [`table`], row i (0-based, without its line end) passed through `edit`.
fn table_with(
    rows: usize,
    crlf: bool,
    text: &str,
    edit: impl Fn(usize, String) -> String,
) -> String {
    let end = if crlf { "\r\n" } else { "\n" };
    let mut s = format!("Preamble: line{end}t,acc_x,acc_y,note{end}");
    for i in 0..rows {
        let row = format!(
            "{:.3}, {:.7e} ,{:.6e},{text}",
            i as f64 * 0.005,
            (i as f64 * 0.1).sin(),
            (i as f64 * 0.07).cos() * 1e-3
        );
        s.push_str(&edit(i, row));
        s.push_str(end);
        if i % 5000 == 17 {
            s.push_str(end); // blank lines are skipped
            s.push_str(&format!("   {end}"));
        }
    }
    s
}

/// The parallel parse of a simple table (no quotes: lines are rows) gives
/// the values of the row-by-row parse of the `csv` crate, which a quote in
/// the table forces — and the same errors, naming the same line.
#[test]
fn the_parallel_csv_parse_matches_the_row_by_row_parse() {
    let opts = ReadOptions::default();
    for crlf in [false, true] {
        let simple = table(40_000, crlf, "ok");
        let quoted = table(40_000, crlf, "\"o,k\"");
        let a = read_csv(&simple, &opts).unwrap();
        assert_eq!(a.len(), 2);
        assert_eq!(a[0].2.len(), 40_000);
        assert_eq!(a, read_csv(&quoted, &opts).unwrap());
        // A bad cell, and a row of the wrong width, late in the table (rows
        // 30 000: after 7 blank lines and the 2 lines above the table).
        let bad_cell = |i: usize, row: String| {
            if i == 30_000 {
                row.replacen(", ", ", 0.1x", 1)
            } else {
                row
            }
        };
        let wide = |i: usize, row: String| if i == 30_000 { row + ",1" } else { row };
        for edit in [&bad_cell as &dyn Fn(usize, String) -> String, &wide] {
            let e1 = read_csv(&table_with(40_000, crlf, "ok", edit), &opts).unwrap_err();
            let e2 = read_csv(&table_with(40_000, crlf, "\"o,k\"", edit), &opts).unwrap_err();
            assert_eq!(e1, e2);
            assert!(e1.contains("30015"), "{e1}");
        }
    }
}

/// The streaming min–max decimation of the report equals the decimation of
/// the whole trace (the implementation before it, kept here as the reference).
#[test]
fn streaming_min_max_decimation_matches_the_whole_trace() {
    fn reference(points: &[(f64, f64)], max_points: usize) -> Vec<(f64, f64)> {
        let max_points = max_points.max(2);
        if points.len() <= max_points {
            return points.to_vec();
        }
        let buckets = max_points / 2;
        let mut out = Vec::new();
        for b in 0..buckets {
            let lo = b * points.len() / buckets;
            let hi = ((b + 1) * points.len() / buckets).min(points.len());
            let chunk = &points[lo..hi];
            if chunk.is_empty() {
                continue;
            }
            let (mut imin, mut imax) = (0usize, 0usize);
            for (i, p) in chunk.iter().enumerate() {
                if p.1 < chunk[imin].1 {
                    imin = i;
                }
                if p.1 > chunk[imax].1 {
                    imax = i;
                }
            }
            let (first, second) = if imin <= imax {
                (imin, imax)
            } else {
                (imax, imin)
            };
            out.push(chunk[first]);
            if second != first {
                out.push(chunk[second]);
            }
        }
        out
    }
    let mut rng = quaketwin::rng::Rng::new(5);
    for n in [0usize, 1, 7, 800, 801, 1601, 12_345] {
        let pts: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let y = if rng.uniform() < 0.01 {
                    f64::NAN
                } else {
                    rng.normal()
                };
                (i as f64, y)
            })
            .collect();
        for max in [0usize, 3, 800, 1000] {
            let got = quaketwin::report::plot::decimate_min_max(&pts, max);
            let want = reference(&pts, max);
            let bits = |v: &[(f64, f64)]| {
                v.iter()
                    .map(|p| (p.0.to_bits(), p.1.to_bits()))
                    .collect::<Vec<_>>()
            };
            assert_eq!(bits(&got), bits(&want), "n {n}, max {max}");
        }
    }
}

/// The response spectrum, 8 oscillators per pass, gives each oscillator's
/// peaks as its own exact recurrence does (`sdof_response`).
#[test]
fn spectra_in_lanes_match_one_oscillator_at_a_time() {
    let dt = 0.005;
    let a: Vec<f64> = (0..4000)
        .map(|i| (i as f64 * 0.031).sin() * (i as f64 * 0.0023).cos())
        .collect();
    let periods: Vec<f64> = (1..=11).map(|k| 0.05 * k as f64).collect();
    let s = quaketwin::metrics::response_spectrum(&a, dt, &periods, 0.05).unwrap();
    for (k, &t) in periods.iter().enumerate() {
        let (u, v) = quaketwin::metrics::sdof_response(&a, dt, t, 0.05).unwrap();
        let w = 2.0 * std::f64::consts::PI / t;
        let sd = u.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let sa = u.iter().zip(&v).fold(0.0f64, |m, (u, v)| {
            m.max((2.0 * 0.05 * w * v + w * w * u).abs())
        });
        assert_eq!(s.sd_m[k + 1].to_bits(), sd.to_bits(), "T = {t}");
        assert_eq!(s.sa_abs_m_per_s2[k + 1].to_bits(), sa.to_bits(), "T = {t}");
    }
}

/// The spectra's oscillator lanes compiled for wider vector registers
/// (chosen at run time) give the peaks of the baseline build bit for bit,
/// on a record with a tail of quiet samples and a NaN-free spike.
#[test]
fn spectra_lanes_are_the_same_in_every_instruction_set() {
    let dt = 0.005;
    let mut a: Vec<f64> = (0..6000)
        .map(|i| (i as f64 * 0.017).sin() * (i as f64 * 0.0041).cos() * 3.7)
        .collect();
    a[2500] = 40.0;
    a.extend(std::iter::repeat_n(1e-9, 500));
    let periods = quaketwin::metrics::default_periods();
    for omegas in periods
        .iter()
        .map(|t| 2.0 * std::f64::consts::PI / t)
        .collect::<Vec<_>>()
        .chunks(8)
    {
        let variants = quaketwin::metrics::spectra::sdof_peaks_variants(&a, dt, omegas, 0.05);
        let bits = |v: &[(f64, f64, f64)]| {
            v.iter()
                .map(|p| (p.0.to_bits(), p.1.to_bits(), p.2.to_bits()))
                .collect::<Vec<_>>()
        };
        let (_, portable) = &variants[0];
        assert_eq!(portable.len(), omegas.len());
        for (name, peaks) in &variants[1..] {
            assert_eq!(bits(peaks), bits(portable), "{name}, ω = {omegas:?}");
        }
    }
}

/// A Parquet table of several row groups written by the column-parallel
/// writer is the file `ArrowWriter` writes from the same batches.
#[test]
fn column_parallel_parquet_is_the_file_arrow_writer_writes() {
    use quaketwin::sinks::parquet::write_parquet;
    let batch = |from: usize, n: usize| {
        samples_rows("A", from, n, |i| (i as f64).sin(), |i| Some(i as f64))
    };
    // Batches straddling the 2²⁰-row row groups at odd places.
    let sizes = [700_001usize, 3, 600_000, 1_000_000];
    let mut batches = Vec::new();
    let mut from = 0;
    for n in sizes {
        batches.push(batch(from, n));
        from += n;
    }
    let dir = tempfile::tempdir().unwrap();
    let ours = dir.path().join("ours.parquet");
    let meta = vec![("quaketwin.test".to_string(), "x".to_string())];
    write_parquet(&ours, &batches, &meta).unwrap();
    // The reference: ArrowWriter with the schema and properties of write_parquet.
    let reference = {
        use parquet::arrow::ArrowWriter;
        let (schema, props) =
            quaketwin::sinks::parquet::writer_setup(&ours, &batches[0], &meta).unwrap();
        let mut bytes = Vec::new();
        let mut w = ArrowWriter::try_new(&mut bytes, schema.clone(), Some(props)).unwrap();
        for b in &batches {
            w.write(&b.clone().with_schema(schema.clone()).unwrap())
                .unwrap();
        }
        w.close().unwrap();
        bytes
    };
    let written = std::fs::read(&ours).unwrap();
    assert!(
        written == reference,
        "the files differ ({} and {} bytes)",
        written.len(),
        reference.len()
    );
}

/// A table of time-series samples is written without dictionaries for its
/// floats (byte-stream-split) and its sample index and time (delta), and
/// reads back to the same values; a table of results keeps Parquet's
/// default dictionary.
#[test]
fn series_tables_are_byte_stream_split_and_delta_encoded() {
    use parquet::basic::Encoding;
    use parquet::file::reader::{FileReader, SerializedFileReader};
    use quaketwin::sinks::parquet::{write_parquet, ReadTable, TableBuilder};
    use quaketwin::vocab::tables::{spectra, SPECTRA};
    let dir = tempfile::tempdir().unwrap();
    let series = dir.path().join("samples/samples.parquet");
    let batch = samples_rows(
        "A",
        0,
        10_000,
        |i| (i as f64 * 0.1).sin(),
        |i| (i % 7 != 0).then_some(i as f64 * 1e-3),
    );
    write_parquet(&series, std::slice::from_ref(&batch), &[]).unwrap();
    let results = dir.path().join("spectra/spectra.parquet");
    let n = 100;
    let spectra_batch = TableBuilder::new(&SPECTRA)
        .str(spectra::CHANNEL_ID, &vec!["A"; n])
        .f64(spectra::DAMPING, vec![0.05; n])
        .f64(spectra::PERIOD_S, (0..n).map(|i| i as f64 * 0.1).collect())
        .f64(spectra::SD_M, vec![1.0; n])
        .f64(spectra::PSV_M_S, vec![1.0; n])
        .f64(spectra::PSA_M_S2, vec![1.0; n])
        .f64(spectra::SA_ABS_M_S2, vec![1.0; n])
        .build()
        .unwrap();
    write_parquet(&results, &[spectra_batch], &[]).unwrap();
    // (column, encodings, whether it has a dictionary page)
    let layout = |path: &Path| -> Vec<(String, Vec<Encoding>, bool)> {
        let r = SerializedFileReader::new(std::fs::File::open(path).unwrap()).unwrap();
        let rg = r.metadata().row_group(0);
        rg.columns()
            .iter()
            .map(|c| {
                (
                    c.column_path().string(),
                    c.encodings().collect(),
                    c.dictionary_page_offset().is_some(),
                )
            })
            .collect()
    };
    for (column, encodings, dictionary) in layout(&series) {
        let expected = match column.as_str() {
            "channel_id" => None,
            "sample" | "time" => Some(Encoding::DELTA_BINARY_PACKED),
            _ => Some(Encoding::BYTE_STREAM_SPLIT),
        };
        match expected {
            Some(e) => {
                assert!(!dictionary, "{column}: {encodings:?}");
                assert!(encodings.contains(&e), "{column}: {encodings:?}");
            }
            None => assert!(dictionary, "{column}: {encodings:?}"),
        }
    }
    for (column, encodings, dictionary) in layout(&results) {
        assert!(dictionary, "{column}: {encodings:?}");
    }
    let (_, reader) = ReadTable::open_stream(&series, Some(batch.num_rows())).unwrap();
    let back: Vec<RecordBatch> = reader.map(|b| b.unwrap()).collect();
    assert_eq!(back.len(), 1);
    assert_eq!(back[0].columns(), batch.columns());
}

/// A big file of a folder is listed by its head and read when its records
/// are: the records are those of a folder of small files.
#[test]
fn big_files_of_a_folder_are_read_when_their_records_are() {
    let dir = tempfile::tempdir().unwrap();
    let text = table(60_000, false, "ok");
    assert!(text.len() as u64 > quaketwin::event_folder::READ_LATER_ABOVE);
    std::fs::write(dir.path().join("big.csv"), &text).unwrap();
    let loaded = quaketwin::event_folder::load(dir.path()).unwrap();
    let direct =
        readers::csv::read(text.as_bytes(), &csv_source(), &ReadOptions::default()).unwrap();
    assert_eq!(loaded.event.records.len(), 2);
    for (a, b) in loaded.event.records.iter().zip(&direct.records) {
        assert_eq!(a.samples, b.samples);
    }
}

/// The report's time histories read samples/samples.parquet in one pass when each
/// channel's rows are together (our files), and in two when a file
/// interleaves them: the figures are the same.
#[test]
fn report_time_histories_of_interleaved_rows_are_those_of_contiguous_rows() {
    use quaketwin::sinks::parquet::write_parquet;
    use quaketwin::vocab::tables::SAMPLES;
    let rows = |id: &str, from: usize, n: usize| {
        let w = if id == "A" { 0.1 } else { 0.37 };
        samples_rows(id, from, n, |i| (i as f64 * w).sin(), |_| None)
    };
    let section = |batches: Vec<RecordBatch>| {
        let dir = tempfile::tempdir().unwrap();
        write_parquet(&dir.path().join(SAMPLES.file), &batches, &[]).unwrap();
        let html = quaketwin::report::render_report(dir.path(), &Default::default()).unwrap();
        let start = html.find("id=\"time-histories\"").unwrap();
        let end = html[start..].find("</section>").unwrap();
        html[start..start + end].to_string()
    };
    let contiguous = section(vec![rows("A", 0, 5000), rows("B", 0, 5000)]);
    let interleaved = section(vec![
        rows("A", 0, 2000),
        rows("B", 0, 3000),
        rows("A", 2000, 3000),
        rows("B", 3000, 2000),
    ]);
    assert!(contiguous.matches("<figure>").count() == 2, "{contiguous}");
    assert_eq!(contiguous, interleaved);
}

/// Conditioning a channel at a time reports the error of running each step
/// over all records: the earliest step that failed, and in it the first
/// channel — with or without an `align` step — and gives the records back.
#[test]
fn channel_at_a_time_conditioning_reports_the_earliest_step_that_failed() {
    use quaketwin::conditioning::{condition_event, ConditioningSettings};
    use quaketwin::vocab::{Channel, Event, Record, Units};
    let channel = |id: &str, rate: f64| {
        let mut c = Channel::new(id, Units::MPerS2, rate, csv_source());
        c.start_ns = Some(0);
        c
    };
    let wave = |n: usize| (0..n).map(|i| (i as f64 * 0.1).sin()).collect::<Vec<_>>();
    let mut bad = wave(4000);
    bad[7] = f64::NAN;
    for align in [false, true] {
        let mut settings = ConditioningSettings::default();
        if align {
            settings
                .steps
                .insert(0, quaketwin::conditioning::Step::Align);
        }
        // A: its filter corner (20 Hz) is above the Nyquist frequency of 30 Hz
        // sampling — a filter-step failure; B: a non-finite sample — a check failure.
        let mut event = Event::default();
        event
            .records
            .push(Record::new(channel("A", 30.0), wave(4000)));
        event
            .records
            .push(Record::new(channel("B", 30.0), bad.clone()));
        let e = condition_event(&mut event, &settings)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("B") && e.contains("non-finite"),
            "align {align}: {e}"
        );
        assert_eq!(event.records.len(), 2, "the records are given back");
        // Without B's fault, A's filter failure is the one reported.
        event.records[1] = Record::new(channel("B", 30.0), wave(4000));
        let e = condition_event(&mut event, &settings)
            .unwrap_err()
            .to_string();
        assert!(e.contains("A"), "align {align}: {e}");
    }
}

/// The block-Hankel Gram matrix, its products formed four at a time, is
/// bit for bit the one formed a product at a time with `dot` (the code it
/// replaced, below), for rows of several signals and shifts of both signs
/// of lag, record lengths with and without a tail.
#[test]
fn hankel_gram_products_in_fours_are_the_products_one_at_a_time() {
    use quaketwin::modal::hankel::{dot, hankel_gram, HankelRow};
    fn reference(signals: &[&[f64]], rows: &[HankelRow], columns: usize) -> Vec<f64> {
        let max_shift = rows.iter().map(|r| r.shift).max().unwrap_or(0);
        let span = 2 * max_shift + 1;
        let base = |a: usize, b: usize, d: usize| {
            // The canonical product of (a, b, d), as the old code chose it.
            let (a, b, d) = if a < b || (a == b && d <= max_shift) {
                (a, b, d)
            } else {
                (b, a, span - 1 - d)
            };
            let lag = d as isize - max_shift as isize;
            let (sa, sb) = if lag >= 0 {
                (0, lag as usize)
            } else {
                ((-lag) as usize, 0)
            };
            dot(&signals[a][sa..sa + columns], &signals[b][sb..sb + columns])
        };
        let nr = rows.len();
        let mut g = vec![0.0; nr * nr];
        for (i, ra) in rows.iter().enumerate() {
            for (k, rb) in rows.iter().enumerate().skip(i) {
                let lag = rb.shift as isize - ra.shift as isize;
                let d = (lag + max_shift as isize) as usize;
                let mut value = base(ra.signal, rb.signal, d);
                let steps = ra.shift.min(rb.shift);
                let (xa, xb) = (signals[ra.signal], signals[rb.signal]);
                let (mut sa, mut sb) = (ra.shift - steps, rb.shift - steps);
                for _ in 0..steps {
                    value += xa[columns + sa] * xb[columns + sb] - xa[sa] * xb[sb];
                    sa += 1;
                    sb += 1;
                }
                let v = value / columns as f64;
                g[i * nr + k] = v;
                g[k * nr + i] = v;
            }
        }
        g
    }
    let signal = |seed: u64, n: usize| -> Vec<f64> {
        let mut rng = quaketwin::rng::Rng::new(seed);
        (0..n).map(|_| rng.normal()).collect()
    };
    let owned: Vec<Vec<f64>> = (0..3).map(|s| signal(11 + s, 1_203)).collect();
    let signals: Vec<&[f64]> = owned.iter().map(|s| s.as_slice()).collect();
    for (shifts, columns) in [(7usize, 1_190usize), (3, 1_001), (1, 4), (10, 1_193)] {
        let rows: Vec<HankelRow> = (0..signals.len())
            .flat_map(|signal| (0..shifts).map(move |shift| HankelRow { signal, shift }))
            .collect();
        let want: Vec<u64> = reference(&signals, &rows, columns)
            .iter()
            .map(|v| v.to_bits())
            .collect();
        let got: Vec<u64> = hankel_gram(&signals, &rows, columns)
            .iter()
            .map(|v| v.to_bits())
            .collect();
        assert_eq!(got, want, "{shifts} shifts, {columns} columns");
    }
}
