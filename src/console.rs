//! What a person sees on the terminal while quaketwin works: log lines on
//! stderr at the chosen verbosity (`-q`, default, `-v`) and the progress bars.
//!
//! One home for both, because they share the terminal: every line is
//! printed through the bars' [`MultiProgress::suspend`], which clears the
//! bars, prints, and redraws them — so a log line never leaves a stale bar
//! behind (printing with `eprintln!` while a bar is drawn does).  Standard
//! output is kept for results (`--json` summaries, `inspect`'s table).
//!
//! The verbosity is process-wide, like a logger's level: the binary sets it
//! once from its flags; the library's default is [`Verbosity::Normal`].
//!
//! A host that is not a terminal program installs a [`Sink`] instead
//! ([`set_sink`]): every line then goes to it, with its [`Kind`], and
//! nothing to stderr.  The Python bindings do, so that warnings reach
//! Python's `warnings` module and the other lines its `logging` (a library
//! must not write to a notebook's stderr; docs/python.md).

use std::fmt::Display;
use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::OnceLock;
use std::time::Duration;

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

/// How much goes to stderr.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Verbosity {
    /// Warnings, notes and errors only: no progress, no stage lines.
    Quiet = 0,
    /// Progress bars (on a terminal) and one line per stage.
    Normal = 1,
    /// Also each stage's time and files, and the stages' details.
    Verbose = 2,
}

static LEVEL: AtomicU8 = AtomicU8::new(Verbosity::Normal as u8);

/// Sets the process-wide verbosity (the binary, from `-q` / `-v`).
pub fn set_verbosity(v: Verbosity) {
    LEVEL.store(v as u8, Ordering::Relaxed);
}

pub fn verbosity() -> Verbosity {
    match LEVEL.load(Ordering::Relaxed) {
        0 => Verbosity::Quiet,
        1 => Verbosity::Normal,
        _ => Verbosity::Verbose,
    }
}

/// The bars of this process, drawn on stderr (indicatif draws nothing when
/// stderr is not a terminal, so logs captured to a file hold lines only).
fn bars() -> &'static MultiProgress {
    static BARS: OnceLock<MultiProgress> = OnceLock::new();
    BARS.get_or_init(|| MultiProgress::with_draw_target(ProgressDrawTarget::stderr()))
}

/// What a line is (what a [`Sink`] is told with it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Info,
    Detail,
    Warning,
    Note,
}

/// Where lines go instead of stderr: called with the line's kind and its
/// text (without the `quaketwin: warning:` prefix), from any thread.
pub type Sink = fn(Kind, &str);

static SINK: OnceLock<Sink> = OnceLock::new();

/// Sends every line of this process to `sink` from now on (once per
/// process: false when a sink was already installed).  Progress bars are
/// then hidden too.
pub fn set_sink(sink: Sink) -> bool {
    SINK.set(sink).is_ok()
}

fn emit(kind: Kind, line: &str) {
    match (SINK.get(), kind) {
        (Some(sink), _) => sink(kind, line),
        (None, Kind::Warning) => bars().suspend(|| eprintln!("quaketwin: warning: {line}")),
        (None, Kind::Note) => bars().suspend(|| eprintln!("quaketwin: note: {line}")),
        (None, _) => bars().suspend(|| eprintln!("{line}")),
    }
}

/// A progress line (`-q` hides it).
pub fn info(line: impl Display) {
    if verbosity() >= Verbosity::Normal {
        emit(Kind::Info, &line.to_string());
    }
}

/// A detail shown with `-v` only.
pub fn detail(line: impl Display) {
    if verbosity() >= Verbosity::Verbose {
        emit(Kind::Detail, &line.to_string());
    }
}

/// Something the user should act on or know about the results; shown at
/// every verbosity.
pub fn warn(line: impl Display) {
    emit(Kind::Warning, &line.to_string());
}

/// What a run removed or took over (why files disappeared); shown at every
/// verbosity.
pub fn note(line: impl Display) {
    emit(Kind::Note, &line.to_string());
}

/// A structured log line (one JSON object, `quaketwin watch`): shown at
/// every verbosity, since an unattended service's log is its output.
pub fn record(line: impl Display) {
    emit(Kind::Info, &line.to_string());
}

/// A bar of `len` steps labelled `prefix` (an event's name in many-event
/// runs), hidden with `-q` or when `hidden`.  Remove it with
/// `finish_and_clear` when its work ends.
pub fn bar(len: u64, prefix: &str, unit: &str, hidden: bool) -> ProgressBar {
    if hidden || verbosity() == Verbosity::Quiet || SINK.get().is_some() {
        return ProgressBar::hidden();
    }
    let b = bars().add(ProgressBar::new(len));
    let template = format!(
        "{{spinner}} [{{elapsed_precise}}] {{prefix}} {{bar:30}} {{pos}}/{{len}} {unit}: {{msg}}"
    );
    if let Ok(style) = ProgressStyle::with_template(&template) {
        b.set_style(style);
    }
    b.set_prefix(prefix.to_string());
    b.enable_steady_tick(Duration::from_millis(200));
    b
}
