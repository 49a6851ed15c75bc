//! The watch's settings as a user gives them — the flags of `quaketwin
//! watch`, the keywords of `quaketwin.fleet.watch` (as JSON) — with their
//! defaults and bounds in one place, checked into [`WatchOptions`].

use std::path::PathBuf;

use serde::Deserialize;

use super::inbox::CompletionRule;
use super::outbox::RetryPolicy;
use super::WatchOptions;
use crate::error::{Error, Result};
use crate::flags::seconds;

pub const DEFAULT_POLL_S: f64 = 2.0;
pub const DEFAULT_SETTLE_S: f64 = 10.0;
pub const DEFAULT_NOTIFY_ATTEMPTS: u32 = 8;
pub const DEFAULT_NOTIFY_BACKOFF_S: f64 = 2.0;
pub const DEFAULT_NOTIFY_MAX_DELAY_S: f64 = 600.0;
pub const DEFAULT_NOTIFY_TIMEOUT_S: f64 = 30.0;

/// One field per flag (durations in seconds, as given).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WatchFlags {
    pub inbox: PathBuf,
    pub pipeline: PathBuf,
    pub out: PathBuf,
    #[serde(default)]
    pub notify: Vec<String>,
    #[serde(default = "poll")]
    pub poll: f64,
    #[serde(default = "settle")]
    pub settle: f64,
    #[serde(default)]
    pub require_done: bool,
    #[serde(default)]
    pub once: bool,
    #[serde(default)]
    pub dashboard: Option<PathBuf>,
    #[serde(default)]
    pub no_dashboard: bool,
    #[serde(default = "attempts")]
    pub notify_attempts: u32,
    #[serde(default = "backoff")]
    pub notify_backoff: f64,
    #[serde(default = "max_delay")]
    pub notify_max_delay: f64,
    #[serde(default = "timeout")]
    pub notify_timeout: f64,
}

fn poll() -> f64 {
    DEFAULT_POLL_S
}
fn settle() -> f64 {
    DEFAULT_SETTLE_S
}
fn attempts() -> u32 {
    DEFAULT_NOTIFY_ATTEMPTS
}
fn backoff() -> f64 {
    DEFAULT_NOTIFY_BACKOFF_S
}
fn max_delay() -> f64 {
    DEFAULT_NOTIFY_MAX_DELAY_S
}
fn timeout() -> f64 {
    DEFAULT_NOTIFY_TIMEOUT_S
}

impl WatchFlags {
    /// The checked options (usage errors name the flag).
    pub fn options(&self) -> Result<WatchOptions> {
        if self.no_dashboard && self.dashboard.is_some() {
            return Err(Error::usage(
                "--dashboard and --no-dashboard exclude each other",
            ));
        }
        Ok(WatchOptions {
            inbox: self.inbox.clone(),
            pipeline: self.pipeline.clone(),
            out: self.out.clone(),
            notify: self.notify.clone(),
            poll: seconds("--poll", self.poll, false)?,
            rule: CompletionRule {
                settle: seconds("--settle", self.settle, true)?,
                require_done: self.require_done,
            },
            retry: RetryPolicy {
                first: seconds("--notify-backoff", self.notify_backoff, false)?,
                max_delay: seconds("--notify-max-delay", self.notify_max_delay, false)?,
                attempts: self.notify_attempts,
                timeout: seconds("--notify-timeout", self.notify_timeout, false)?,
            },
            dashboard: match (self.no_dashboard, &self.dashboard) {
                (true, _) => None,
                (false, Some(d)) => Some(d.clone()),
                (false, None) => Some(self.out.join("dashboard")),
            },
            once: self.once,
        })
    }
}

/// The options as JSON (the fields of [`WatchFlags`]; unset fields take the
/// command's defaults): how the Python package hands them over.
pub fn options_from_json(text: &str) -> Result<WatchOptions> {
    let flags: WatchFlags =
        serde_json::from_str(text).map_err(|e| Error::usage(format!("watch options: {e}")))?;
    flags.options()
}
