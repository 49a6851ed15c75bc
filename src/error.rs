//! Errors that help the user: every input error names the file, and where it
//! applies the zip member, channel, line or byte offset.

use std::fmt;
use std::path::PathBuf;

/// Where in the input something went wrong. Rendered as
/// `file[:member] [channel C] [line L] [byte B]`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Location {
    pub file: String,
    /// Member inside a zip (nested members joined with `:`).
    pub member: Option<String>,
    pub channel: Option<String>,
    /// 1-based line number in a text file.
    pub line: Option<usize>,
    /// 0-based byte offset in a binary file.
    pub byte_offset: Option<u64>,
}

impl Location {
    pub fn file(file: impl Into<String>) -> Self {
        Location {
            file: file.into(),
            ..Default::default()
        }
    }
    pub fn with_member(mut self, member: impl Into<String>) -> Self {
        self.member = Some(member.into());
        self
    }
    pub fn with_channel(mut self, channel: impl Into<String>) -> Self {
        self.channel = Some(channel.into());
        self
    }
    pub fn at_line(mut self, line: usize) -> Self {
        self.line = Some(line);
        self
    }
    pub fn at_byte(mut self, offset: u64) -> Self {
        self.byte_offset = Some(offset);
        self
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if let Some(m) = &self.member {
            write!(f, ":{m}")?;
        }
        if let Some(c) = &self.channel {
            write!(f, " channel {c}")?;
        }
        if let Some(l) = self.line {
            write!(f, " line {l}")?;
        }
        if let Some(b) = self.byte_offset {
            write!(f, " byte {b}")?;
        }
        Ok(())
    }
}

/// The one error type of the library. `Input` errors are the user's data
/// (exit code 1); `Usage` errors are the user's command or settings (exit code 2).
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Bad input data: names the place and says what is wrong.
    /// (The location is boxed to keep `Result<T, Error>` small: clippy `result_large_err`.)
    #[error("{location}: {message}")]
    Input {
        location: Box<Location>,
        message: String,
    },
    /// Bad settings, pipeline file or command-line usage.
    #[error("{0}")]
    Usage(String),
    /// A path the user named in a setting or flag (`--reference`,
    /// `reference_modes`) that does not exist: a usage error (exit code 2)
    /// that keeps the path, so that a host can tell it from other usage
    /// errors (Python's `FileNotFoundError`).
    #[error("{message}")]
    MissingPath { path: PathBuf, message: String },
    /// A method could not produce a trustworthy answer from valid data
    /// (e.g. a non-yielding response for Bouc-Wen identification).
    #[error("{stage}: {message}")]
    NotIdentifiable {
        stage: String,
        message: String,
        /// The F-test of the hysteretic terms (F, p) when that is what
        /// failed (bouc_wen.parquet tables it on the not-identifiable row).
        f_test: Option<(f64, f64)>,
    },
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// A numerical routine failed (singular matrix, no convergence).
    #[error("{0}")]
    Numerical(String),
    #[error("writing {path}: {message}")]
    Output { path: PathBuf, message: String },
}

impl Error {
    pub fn input(location: Location, message: impl Into<String>) -> Self {
        Error::Input {
            location: Box::new(location),
            message: message.into(),
        }
    }
    pub fn usage(message: impl Into<String>) -> Self {
        Error::Usage(message.into())
    }
    /// This error as a usage error about the setting or flag `what`
    /// (`"--reference: …"`); a missing path stays one.
    pub fn usage_about(self, what: &str) -> Self {
        match self {
            Error::Usage(m) => Error::Usage(format!("{what}: {m}")),
            Error::MissingPath { path, message } => Error::MissingPath {
                path,
                message: format!("{what}: {message}"),
            },
            other => Error::Usage(format!("{what}: {other}")),
        }
    }
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
    pub fn numerical(message: impl Into<String>) -> Self {
        Error::Numerical(message.into())
    }
    pub fn output(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Error::Output {
            path: path.into(),
            message: message.into(),
        }
    }
    /// A copy of this error for a second place that reports it (a twin that
    /// failed to load, reported once per direction that needed it): same
    /// kind, same message, same exit code.  An I/O error keeps its path and
    /// kind of failure (`std::io::Error` itself cannot be cloned).
    pub fn duplicate(&self) -> Error {
        match self {
            Error::Input { location, message } => Error::Input {
                location: location.clone(),
                message: message.clone(),
            },
            Error::Usage(m) => Error::Usage(m.clone()),
            Error::MissingPath { path, message } => Error::MissingPath {
                path: path.clone(),
                message: message.clone(),
            },
            Error::NotIdentifiable {
                stage,
                message,
                f_test,
            } => Error::NotIdentifiable {
                stage: stage.clone(),
                message: message.clone(),
                f_test: *f_test,
            },
            Error::Io { path, source } => Error::Io {
                path: path.clone(),
                source: std::io::Error::new(source.kind(), source.to_string()),
            },
            Error::Numerical(m) => Error::Numerical(m.clone()),
            Error::Output { path, message } => Error::Output {
                path: path.clone(),
                message: message.clone(),
            },
        }
    }

    /// Process exit code: 1 for bad input or failed processing, 2 for usage errors.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Usage(_) | Error::MissingPath { .. } => 2,
            _ => 1,
        }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Longest error text printed, characters (a message quoting a hostile
/// file's bytes must not flood the terminal).
pub const MAX_PRINTED_ERROR_CHARS: usize = 2000;

/// `text` made safe to print: control characters (NUL, escape sequences,
/// carriage returns) escaped as `\u{..}` — a newline is kept — and the
/// whole capped at `max` characters, saying how many were left out.
pub fn printable(text: &str, max: usize) -> String {
    let mut out = String::new();
    let mut shown = 0usize;
    let total = text.chars().count();
    for c in text.chars() {
        if shown >= max {
            out.push_str(&format!(" … ({} more characters)", total - shown));
            break;
        }
        if c.is_control() && c != '\n' {
            out.extend(c.escape_unicode());
        } else {
            out.push(c);
        }
        shown += 1;
    }
    out
}
