//! `quaketwin._native`: the Python face of the quaketwin library, one thin
//! layer.  Every function calls one library function; tables cross the
//! boundary through the Arrow C data interface (`arrow-pyarrow`: pyarrow
//! takes the Rust buffers without a copy, and hands its own over the same
//! way); errors become Python exceptions of their kind with the library's
//! message (the classes are python/quaketwin/_errors.py); the library's
//! warnings and log lines go to Python's `warnings` and `logging`.  The GIL
//! is released while the library works.  The Python package
//! (python/quaketwin) wraps these with docstrings, the Event and Modes
//! objects and the fleet runner; `_native.pyi` types them.

use std::path::PathBuf;
use std::sync::Mutex;

use arrow_array::RecordBatch;
use arrow_pyarrow::{FromPyArrow, IntoPyArrow, Table as PyArrowTable};
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use quaketwin::console::Kind;
use quaketwin::error::Error;
use quaketwin::in_memory::{self, Table};

/// The lines the library logged (warnings, notes, progress) since the last
/// call ended, from any thread: the console's sink in this process (a
/// library must not write to a notebook's stderr).  The call that ends next
/// hands them to Python ([`deliver`]).  Bounded: past the cap a line is
/// counted, not kept.
static LINES: Mutex<(Vec<(Kind, String)>, usize)> = Mutex::new((Vec::new(), 0));
const MAX_PENDING_LINES: usize = 10_000;

fn collect(kind: Kind, line: &str) {
    let line = quaketwin::error::printable(line, quaketwin::error::MAX_PRINTED_ERROR_CHARS);
    let mut pending = LINES
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    if pending.0.len() < MAX_PENDING_LINES {
        pending.0.push((kind, line));
    } else {
        pending.1 += 1;
    }
}

/// Hands the pending lines to `quaketwin._errors._deliver` (Python's
/// `warnings` and `logging`).  Its error — a warning the caller's filters
/// turn into an exception — is the call's.
fn deliver(py: Python<'_>) -> PyResult<()> {
    let (lines, dropped) = {
        let mut pending = LINES
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        (
            std::mem::take(&mut pending.0),
            std::mem::take(&mut pending.1),
        )
    };
    if lines.is_empty() && dropped == 0 {
        return Ok(());
    }
    let mut out: Vec<(&str, String)> = lines
        .into_iter()
        .map(|(kind, line)| {
            let kind = match kind {
                Kind::Warning => "warning",
                Kind::Note => "note",
                Kind::Info => "info",
                Kind::Detail => "detail",
            };
            (kind, line)
        })
        .collect();
    if dropped > 0 {
        out.push(("info", format!("{dropped} more log lines left out")));
    }
    py.import("quaketwin._errors")?
        .getattr("_deliver")?
        .call1((out,))?;
    Ok(())
}

/// The Python exception of `class` (python/quaketwin/_errors.py) with
/// `args`; a RuntimeError when the package cannot be imported.
fn exception<'py>(
    py: Python<'py>,
    class: &str,
    args: impl pyo3::call::PyCallArgs<'py>,
    text: &str,
) -> PyErr {
    let made = py
        .import("quaketwin._errors")
        .and_then(|m| m.getattr(class))
        .and_then(|c| c.call1(args));
    match made {
        Ok(e) => PyErr::from_value(e),
        Err(_) => PyRuntimeError::new_err(text.to_string()),
    }
}

/// The library's error as the Python exception of its kind: bad settings
/// `UsageError` and bad input `InputError` (both `ValueError`s), a missing
/// path `PathNotFoundError` (a `FileNotFoundError`), a refused one
/// `PathPermissionError`, another failure on a path `PathError` (an
/// `OSError`), the rest `QuaketwinError`.  An OS error carries its errno
/// and the path as `filename`.
fn raise(py: Python<'_>, e: Error) -> PyErr {
    let text =
        quaketwin::error::printable(&e.to_string(), quaketwin::error::MAX_PRINTED_ERROR_CHARS);
    // POSIX numbers (ENOENT, EACCES): the same on every platform CPython runs on.
    let (class, errno, path) = match &e {
        Error::Usage(_) => ("UsageError", 0, None),
        Error::Input { .. } => ("InputError", 0, None),
        Error::MissingPath { path, .. } => ("PathNotFoundError", 2, Some(path)),
        Error::Io { path, source } => {
            let (class, errno) = match source.kind() {
                std::io::ErrorKind::NotFound => ("PathNotFoundError", 2),
                std::io::ErrorKind::PermissionDenied => ("PathPermissionError", 13),
                _ => ("PathError", 0),
            };
            (class, source.raw_os_error().unwrap_or(errno), Some(path))
        }
        _ => ("QuaketwinError", 0, None),
    };
    match path {
        Some(path) => exception(
            py,
            class,
            (errno, text.clone(), path.as_os_str().to_os_string()),
            &text,
        ),
        None => exception(py, class, (text.clone(),), &text),
    }
}

/// `QuaketwinError` with `text`.
fn quaketwin_error(py: Python<'_>, text: String) -> PyErr {
    exception(py, "QuaketwinError", (text.clone(),), &text)
}

/// Runs `f` (the library call of the exported function `name`) without the
/// GIL, then hands the lines it logged to Python; a panic inside becomes
/// `QuaketwinError` naming the function — never
/// `pyo3_runtime.PanicException`, which `except Exception` misses.  The
/// parameters are bounded where they are parsed, so a panic is a bug.
fn guarded<T: Send>(
    py: Python<'_>,
    name: &str,
    f: impl FnOnce() -> quaketwin::error::Result<T> + Send,
) -> PyResult<T> {
    let result = py.detach(|| std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)));
    deliver(py)?;
    result
        .map_err(|panic| {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "no message".into());
            quaketwin_error(
                py,
                format!(
                    "internal error in quaketwin.{name} (a bug, please report it): {}",
                    quaketwin::error::printable(&what, quaketwin::error::MAX_PRINTED_ERROR_CHARS)
                ),
            )
        })?
        .map_err(|e| raise(py, e))
}

fn to_pyarrow<'py>(py: Python<'py>, t: Table) -> PyResult<Bound<'py, PyAny>> {
    let table = PyArrowTable::try_new(t.batches, t.schema)
        .map_err(|e| quaketwin_error(py, e.to_string()))?;
    table.into_pyarrow(py)
}

fn from_pyarrow(table: &Bound<'_, PyAny>) -> PyResult<Table> {
    let (batches, schema): (Vec<RecordBatch>, _) =
        PyArrowTable::from_pyarrow_bound(table)?.into_inner();
    Ok(Table::new(schema, batches))
}

/// The inventory of an event folder or zip (the `event.json` document), as JSON text.
#[pyfunction]
fn inspect_json(py: Python<'_>, event: PathBuf) -> PyResult<String> {
    guarded(py, "inspect_json", || {
        quaketwin::commands::inspect_json(&event)
    })
}

/// A run's summary as JSON text, or its error.
fn summary_json(
    pipeline: &str,
    event: &std::path::Path,
    out: &std::path::Path,
    result: quaketwin::error::Result<Vec<(String, quaketwin::pipeline::StageOutcome)>>,
) -> quaketwin::error::Result<String> {
    let summary = quaketwin::summary::RunSummary::of_run(pipeline, event, out, &result);
    result?;
    quaketwin::summary::to_json(&summary)
}

/// `quaketwin run`: a pipeline file on one event into `out`, or on several
/// events (or a folder of events) into the many-event dataset at `out`; the
/// `--json` document as JSON text.  One event's failure raises; of many
/// events, each one's failure is in its summary (as `quaketwin.fleet.run`
/// reports them), and only an error before any event ran raises.
#[pyfunction]
#[pyo3(signature = (pipeline, events, out, reference=None))]
fn run_json(
    py: Python<'_>,
    pipeline: PathBuf,
    events: Vec<PathBuf>,
    out: PathBuf,
    reference: Option<PathBuf>,
) -> PyResult<String> {
    guarded(py, "run_json", || {
        let runs = quaketwin::commands::run_events(
            &pipeline,
            &events,
            &out,
            reference.as_deref(),
            // Not quiet: the stage lines go to Python's logging (INFO).
            false,
        )?;
        let json = runs.summary_json(&pipeline.display().to_string(), &out)?;
        if let quaketwin::commands::Runs::One { .. } = runs {
            runs.into_result()?;
        }
        Ok(json)
    })
}

/// The built-in hysteresis command (Bouc-Wen + damage) into `out`; the run summary as JSON.
#[pyfunction]
fn hysteresis_json(py: Python<'_>, event: PathBuf, out: PathBuf) -> PyResult<String> {
    guarded(py, "hysteresis_json", || {
        let result = quaketwin::commands::hysteresis(&event, &out, false);
        summary_json("hysteresis (built-in)", &event, &out, result)
    })
}

/// Ensemble update of a twin against a modes.parquet (or a run directory
/// holding one) into `out`; the update summary as JSON.
#[pyfunction]
#[pyo3(signature = (twin, modes, out, settings=None))]
fn update_json(
    py: Python<'_>,
    twin: PathBuf,
    modes: PathBuf,
    out: PathBuf,
    settings: Option<PathBuf>,
) -> PyResult<String> {
    guarded(py, "update_json", || {
        let s = quaketwin::commands::update(&twin, &modes, &out, settings.as_deref())?;
        quaketwin::summary::to_json(&s)
    })
}

/// The records of an event as the `samples` table (pyarrow), without files.
#[pyfunction]
fn read_event<'py>(py: Python<'py>, event: PathBuf) -> PyResult<Bound<'py, PyAny>> {
    let table = guarded(py, "read_event", || in_memory::read_event(&event))?;
    to_pyarrow(py, table)
}

/// Modal identification of a `samples` table in memory: (modes, stabilization, warnings).
#[pyfunction]
fn modal<'py>(
    py: Python<'py>,
    samples: &Bound<'py, PyAny>,
    settings_json: &str,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Vec<String>)> {
    let samples = from_pyarrow(samples)?;
    let settings = settings_json.to_string();
    let r = guarded(py, "modal", || {
        let r = in_memory::modal(&samples, &settings)?;
        // Warned as the pipeline's modal stage does.
        for w in &r.warnings {
            quaketwin::console::warn(format!("modal: {w}"));
        }
        Ok(r)
    })?;
    Ok((
        to_pyarrow(py, r.modes)?,
        to_pyarrow(py, r.stabilization)?,
        r.warnings,
    ))
}

/// The Hive partition `structure=…/event=…` of an event (the many-event layout).
#[pyfunction]
fn event_partition(py: Python<'_>, event: PathBuf) -> PyResult<String> {
    guarded(py, "event_partition", || {
        quaketwin::commands::event_partition(&event)
    })
    .map(|p| p.to_string_lossy().replace('\\', "/"))
}

/// The table files of a finished run directory (`run.json`'s list), with
/// the dataset table each belongs to: [(file, table)].
#[pyfunction]
fn run_tables(py: Python<'_>, run_dir: PathBuf) -> PyResult<Vec<(String, String)>> {
    guarded(py, "run_tables", || {
        quaketwin::sinks::dataset::run_tables(&run_dir)
    })
}

/// The fingerprint of an event folder or zip (names, sizes, modification
/// times): what a run manifest records to tell a changed event.
#[pyfunction]
fn event_fingerprint(py: Python<'_>, event: PathBuf) -> PyResult<String> {
    guarded(py, "event_fingerprint", || {
        quaketwin::pipeline::fingerprint::path_fingerprint(&event)
    })
}

/// `quaketwin track` in this process (options as JSON, the fields of the
/// library's `TrackOptions`); the summary as JSON.
#[pyfunction]
fn track_json(py: Python<'_>, options_json: &str) -> PyResult<String> {
    guarded(py, "track_json", || {
        let opts = quaketwin::track::options_from_json(options_json)?;
        let (summary, _) = quaketwin::track::run(&opts)?;
        quaketwin::summary::to_json(&summary)
    })
}

/// `quaketwin watch` in this process (options as JSON, the fields of the
/// library's `WatchFlags`); the summary as JSON.  With `once` false it runs
/// until the process is stopped.
#[pyfunction]
fn watch_json(py: Python<'_>, options_json: &str) -> PyResult<String> {
    guarded(py, "watch_json", || {
        let opts = quaketwin::watch::flags::options_from_json(options_json)?;
        let summary = quaketwin::watch::run(&opts)?;
        quaketwin::summary::to_json(&summary)
    })
}

/// The start times (ns since the epoch) of every window of a track run.
#[pyfunction]
fn track_starts(py: Python<'_>, options_json: &str) -> PyResult<Vec<i64>> {
    guarded(py, "track_starts", || {
        let opts = quaketwin::track::options_from_json(options_json)?;
        Ok(quaketwin::track::prepare(&opts)?.starts())
    })
}

/// Identifies the windows starting at `starts` (ns); JSON to hand to `track_finish_json`.
#[pyfunction]
fn track_windows_json(py: Python<'_>, options_json: &str, starts: Vec<i64>) -> PyResult<String> {
    guarded(py, "track_windows_json", || {
        let opts = quaketwin::track::options_from_json(options_json)?;
        quaketwin::track::identify_windows_json(&opts, &starts)
    })
}

/// Tracks, fits the bands and writes the outputs from every window's JSON; the summary as JSON.
#[pyfunction]
fn track_finish_json(py: Python<'_>, options_json: &str, parts: Vec<String>) -> PyResult<String> {
    guarded(py, "track_finish_json", || {
        let opts = quaketwin::track::options_from_json(options_json)?;
        let summary = quaketwin::track::finish_from_json(&opts, &parts)?;
        quaketwin::summary::to_json(&summary)
    })
}

/// The factor t of the 95 % interval θ̂ ± t σ of a data-driven σ with
/// `dof` degrees of freedom (`uncertainty_dof`; docs/statistics.md,
/// Eqs. S8–S8'); NaN below 1.
#[pyfunction]
fn interval_factor(dof: f64) -> f64 {
    quaketwin::modal::uncertainty::interval_factor(dof)
}

/// A deliberate panic inside [`guarded`]: the test that a panic reaches
/// Python as `QuaketwinError` (python/tests), not `PanicException`.
#[pyfunction]
fn _panic_probe(py: Python<'_>) -> PyResult<()> {
    guarded(py, "_panic_probe", || -> quaketwin::error::Result<()> {
        panic!("deliberate panic of the probe")
    })
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // Results independent of the thread count, as from the command line.
    quaketwin::fixed_order_reductions();
    // The library's lines go to Python's warnings and logging (every
    // detail: the logger's level decides what is shown), never to stderr.
    quaketwin::console::set_sink(collect);
    quaketwin::console::set_verbosity(quaketwin::console::Verbosity::Verbose);
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(inspect_json, m)?)?;
    m.add_function(wrap_pyfunction!(run_json, m)?)?;
    m.add_function(wrap_pyfunction!(hysteresis_json, m)?)?;
    m.add_function(wrap_pyfunction!(update_json, m)?)?;
    m.add_function(wrap_pyfunction!(read_event, m)?)?;
    m.add_function(wrap_pyfunction!(modal, m)?)?;
    m.add_function(wrap_pyfunction!(event_partition, m)?)?;
    m.add_function(wrap_pyfunction!(run_tables, m)?)?;
    m.add_function(wrap_pyfunction!(event_fingerprint, m)?)?;
    m.add_function(wrap_pyfunction!(track_json, m)?)?;
    m.add_function(wrap_pyfunction!(track_starts, m)?)?;
    m.add_function(wrap_pyfunction!(track_windows_json, m)?)?;
    m.add_function(wrap_pyfunction!(track_finish_json, m)?)?;
    m.add_function(wrap_pyfunction!(watch_json, m)?)?;
    m.add_function(wrap_pyfunction!(interval_factor, m)?)?;
    m.add_function(wrap_pyfunction!(_panic_probe, m)?)?;
    Ok(())
}
