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

fn emit(line: &str) {
    bars().suspend(|| eprintln!("{line}"));
}

/// A progress line (`-q` hides it).
pub fn info(line: impl Display) {
    if verbosity() >= Verbosity::Normal {
        emit(&line.to_string());
    }
}

/// A detail shown with `-v` only.
pub fn detail(line: impl Display) {
    if verbosity() >= Verbosity::Verbose {
        emit(&line.to_string());
    }
}

/// Something the user should act on or know about the results; shown at
/// every verbosity.
pub fn warn(line: impl Display) {
    emit(&format!("quaketwin: warning: {line}"));
}

/// What a run removed or took over (why files disappeared); shown at every
/// verbosity.
pub fn note(line: impl Display) {
    emit(&format!("quaketwin: note: {line}"));
}

/// A structured log line (one JSON object, `quaketwin watch`): shown at
/// every verbosity, since an unattended service's log is its output.
pub fn record(line: impl Display) {
    emit(&line.to_string());
}

/// A bar of `len` steps labelled `prefix` (an event's name in many-event
/// runs), hidden with `-q` or when `hidden`.  Remove it with
/// `finish_and_clear` when its work ends.
pub fn bar(len: u64, prefix: &str, unit: &str, hidden: bool) -> ProgressBar {
    if hidden || verbosity() == Verbosity::Quiet {
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
