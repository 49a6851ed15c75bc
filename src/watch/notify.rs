//! Where `quaketwin watch` sends a notification (`--notify`, repeatable):
//!
//! - `http://HOST[:PORT]/PATH`: an HTTP POST of the notification JSON
//!   (`Content-Type: application/json`; headers `Idempotency-Key` and
//!   `X-Quaketwin-Notification-Id` carry its id).  Any 2xx status is
//!   delivered; anything else, or no answer within the timeout, is retried.
//!   Plain HTTP only (no TLS stack in the binary): for an `https://`
//!   endpoint use the command form with curl.
//! - `cmd:COMMAND`: `sh -c COMMAND` with the notification JSON on standard
//!   input and its id, structure, event and rating in the environment
//!   (`QUAKETWIN_NOTIFICATION_ID`, `QUAKETWIN_STRUCTURE`, `QUAKETWIN_EVENT`,
//!   `QUAKETWIN_RATING`); exit status 0 is delivered, anything else (or
//!   running past the timeout, when it is killed) is retried.

use std::io::{Read, Write};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::error::{Error, Result};

/// Prefix of the command form of `--notify`.
pub const COMMAND_PREFIX: &str = "cmd:";
/// Most of a command's output kept for the error of a failed delivery.
const KEPT_OUTPUT_CHARS: usize = 2000;

#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Target {
    Http(String),
    Command(String),
}

impl Target {
    /// Parses one `--notify` value (usage error naming it when it is neither form).
    pub fn parse(text: &str) -> Result<Target> {
        if let Some(cmd) = text.strip_prefix(COMMAND_PREFIX) {
            if cmd.trim().is_empty() {
                return Err(Error::usage("--notify cmd: needs a command after `cmd:`"));
            }
            return Ok(Target::Command(cmd.to_string()));
        }
        let lower = text.to_ascii_lowercase();
        if lower.starts_with("https://") {
            return Err(Error::usage(format!(
                "--notify {text}: quaketwin posts plain http:// only; for https use the command form, e.g. --notify 'cmd:curl -fsS -H \"Content-Type: application/json\" --data-binary @- {text}'"
            )));
        }
        if lower.starts_with("http://") && text.len() > "http://".len() {
            return Ok(Target::Http(text.to_string()));
        }
        Err(Error::usage(format!(
            "--notify {text}: expected http://HOST[:PORT]/PATH or cmd:COMMAND"
        )))
    }

    /// The `--notify` text of the target.
    pub fn text(&self) -> String {
        match self {
            Target::Http(url) => url.clone(),
            Target::Command(cmd) => format!("{COMMAND_PREFIX}{cmd}"),
        }
    }

    /// Delivers `body` (the notification JSON) once; `Err` says why not.
    pub fn send(
        &self,
        id: &str,
        body: &[u8],
        env: &[(&str, String)],
        timeout: Duration,
    ) -> std::result::Result<(), String> {
        match self {
            Target::Http(url) => post(url, id, body, timeout),
            Target::Command(cmd) => run_command(cmd, body, env, timeout),
        }
    }
}

fn post(url: &str, id: &str, body: &[u8], timeout: Duration) -> std::result::Result<(), String> {
    let agent: ureq::Agent = ureq::Agent::config_builder()
        .timeout_global(Some(timeout))
        .http_status_as_error(false)
        .build()
        .into();
    let response = agent
        .post(url)
        .header("Content-Type", "application/json")
        .header("Idempotency-Key", id)
        .header("X-Quaketwin-Notification-Id", id)
        .send(body)
        .map_err(|e| format!("POST {url}: {e}"))?;
    let status = response.status();
    if status.is_success() {
        Ok(())
    } else {
        Err(format!("POST {url}: HTTP status {status}"))
    }
}

fn run_command(
    cmd: &str,
    body: &[u8],
    env: &[(&str, String)],
    timeout: Duration,
) -> std::result::Result<(), String> {
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(cmd)
        .envs(env.iter().map(|(k, v)| (k, v)))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cmd:{cmd}: cannot start sh: {e}"))?;
    // Written and read on threads: a command that reads no input, or
    // prints much, blocks neither itself nor us.
    let mut stdin = child.stdin.take();
    let body = body.to_vec();
    let writer = std::thread::spawn(move || {
        if let Some(s) = stdin.as_mut() {
            let _ = s.write_all(&body); // a command that exits without reading: EPIPE, fine
        }
    });
    // The output comes back over a channel: a background process the
    // command left holding the pipes must not keep us waiting.
    let (sent, received) = std::sync::mpsc::channel::<String>();
    let mut readers = 0;
    for stream in [
        child
            .stdout
            .take()
            .map(|s| Box::new(s) as Box<dyn Read + Send>),
        child
            .stderr
            .take()
            .map(|s| Box::new(s) as Box<dyn Read + Send>),
    ]
    .into_iter()
    .flatten()
    {
        readers += 1;
        let sent = sent.clone();
        std::thread::spawn(move || {
            let mut text = String::new();
            let _ = stream.take(1 << 20).read_to_string(&mut text);
            let _ = sent.send(text);
        });
    }
    let start = Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(status)) => break Some(status),
            Ok(None) if start.elapsed() < timeout => std::thread::sleep(Duration::from_millis(20)),
            _ => {
                let _ = child.kill();
                let _ = child.wait();
                break None;
            }
        }
    };
    drop(writer); // detached: it ends when the pipe closes
    let output: String = (0..readers)
        .map_while(|_| received.recv_timeout(Duration::from_secs(1)).ok())
        .collect::<Vec<_>>()
        .join("");
    let tail: String = {
        let chars: Vec<char> = output.trim().chars().collect();
        chars[chars.len().saturating_sub(KEPT_OUTPUT_CHARS)..]
            .iter()
            .collect()
    };
    match status {
        Some(s) if s.success() => Ok(()),
        Some(s) => Err(format!("cmd:{cmd}: {s}: {tail}")),
        None => Err(format!(
            "cmd:{cmd}: still running after {:.0} s, killed: {tail}",
            timeout.as_secs_f64()
        )),
    }
}
