//! The outbox of `quaketwin watch`: one file per notification and target,
//! `DATASET/_watch/outbox/<id>.<target>.json`, written atomically before the
//! journal marks its event done and removed only after a delivery succeeded.
//! A kill between the two sends it again on restart, with the same id: every
//! notification is delivered at least once, and a receiver de-duplicates by
//! its id.
//!
//! A failed delivery is retried with exponential backoff: after the n-th
//! failure the next attempt waits `first · 2ⁿ⁻¹`, at most `max_delay`.
//! After `attempts` failures the letter moves to
//! `DATASET/_watch/dead_letter/` (same file, with the last error), where
//! it stays for a person to look at; `quaketwin watch` never sends it again.

use std::path::{Path, PathBuf};
use std::time::Duration;

use serde::{Deserialize, Serialize};
use serde_json::json;

use super::log;
use super::notify::Target;
use crate::error::{Error, Location, Result};

pub const OUTBOX_DIR: &str = "outbox";
pub const DEAD_LETTER_DIR: &str = "dead_letter";
/// Largest letter read back.
const MAX_LETTER_BYTES: u64 = 64 << 20;

/// When to try again.
#[derive(Debug, Clone, Copy)]
pub struct RetryPolicy {
    /// Wait after the first failure.
    pub first: Duration,
    /// Longest wait between two attempts.
    pub max_delay: Duration,
    /// Attempts before the letter goes to the dead-letter folder.
    pub attempts: u32,
    /// Time one attempt may take.
    pub timeout: Duration,
}

impl RetryPolicy {
    /// Wait after `failures` failed attempts (≥ 1).
    pub fn delay(&self, failures: u32) -> Duration {
        let doubled = self
            .first
            .saturating_mul(1u32 << failures.saturating_sub(1).min(30));
        doubled.min(self.max_delay)
    }
}

/// One notification for one target.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Letter {
    pub id: String,
    /// The `--notify` text it goes to.
    pub target: String,
    pub attempts: u32,
    /// Not before (epoch milliseconds).
    pub next_attempt_ms: i64,
    pub created_at: String,
    pub last_error: Option<String>,
    /// Environment of a command target.
    pub structure: Option<String>,
    pub event: Option<String>,
    pub rating: Option<String>,
    /// The notification JSON, as sent.
    pub payload: serde_json::Value,
}

/// What one delivery round did.
#[derive(Debug, Default, Clone, Copy)]
pub struct Round {
    pub sent: usize,
    pub retried: usize,
    pub dead: usize,
}

pub struct Outbox {
    dir: PathBuf,
    dead_dir: PathBuf,
}

fn now_ms() -> i64 {
    log::now_ns() / 1_000_000
}

/// A short stable tag of a target for the file name.
fn target_tag(target: &str) -> String {
    let mut h = crate::hash::Hash64::default();
    h.write_str(target);
    h.finish_hex()[..8].to_string()
}

impl Outbox {
    /// The outbox of the state folder `state` (created).
    pub fn open(state: &Path) -> Result<Outbox> {
        let dir = state.join(OUTBOX_DIR);
        let dead_dir = state.join(DEAD_LETTER_DIR);
        for d in [&dir, &dead_dir] {
            std::fs::create_dir_all(d).map_err(|e| Error::io(d, e))?;
        }
        Ok(Outbox { dir, dead_dir })
    }

    fn letter_path(&self, id: &str, target: &str) -> PathBuf {
        self.dir.join(format!("{id}.{}.json", target_tag(target)))
    }

    /// Puts the notification `payload` (id `id`) in the outbox, one letter
    /// per target; a letter already there for the id and target is kept
    /// (its attempts count on).
    pub fn post(
        &self,
        id: &str,
        targets: &[Target],
        labels: [Option<String>; 3],
        payload: &serde_json::Value,
    ) -> Result<()> {
        let [structure, event, rating] = labels;
        for t in targets {
            let text = t.text();
            let path = self.letter_path(id, &text);
            if path.exists() {
                continue;
            }
            let letter = Letter {
                id: id.to_string(),
                target: text,
                attempts: 0,
                next_attempt_ms: 0,
                created_at: log::now_text(),
                last_error: None,
                structure: structure.clone(),
                event: event.clone(),
                rating: rating.clone(),
                payload: payload.clone(),
            };
            write_letter(&path, &letter)?;
        }
        Ok(())
    }

    /// The letters waiting, by file name.
    fn letters(&self) -> Result<Vec<(PathBuf, Letter)>> {
        let mut paths: Vec<PathBuf> = std::fs::read_dir(&self.dir)
            .map_err(|e| Error::io(&self.dir, e))?
            .flatten()
            .map(|e| e.path())
            .filter(|p| {
                p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| !n.starts_with('.') && n.ends_with(".json"))
            })
            .collect();
        paths.sort();
        let mut out = Vec::with_capacity(paths.len());
        for p in paths {
            let text = crate::input_file::read_to_string(&p, MAX_LETTER_BYTES)?;
            let letter: Letter = serde_json::from_str(&text).map_err(|e| {
                Error::input(
                    Location::file(p.display().to_string()),
                    format!("not an outbox letter: {e}"),
                )
            })?;
            out.push((p, letter));
        }
        Ok(out)
    }

    /// How many letters wait, and when the next one is due (epoch ms).
    pub fn waiting(&self) -> Result<(usize, Option<i64>)> {
        let letters = self.letters()?;
        let next = letters.iter().map(|(_, l)| l.next_attempt_ms).min();
        Ok((letters.len(), next))
    }

    /// Tries every letter that is due, once.
    pub fn deliver_due(&self, policy: &RetryPolicy) -> Result<Round> {
        let mut round = Round::default();
        for (path, mut letter) in self.letters()? {
            if letter.next_attempt_ms > now_ms() {
                continue;
            }
            let target = match Target::parse(&letter.target) {
                Ok(t) => t,
                Err(e) => {
                    letter.last_error = Some(e.to_string());
                    letter.attempts = policy.attempts;
                    self.bury(&path, &letter)?;
                    round.dead += 1;
                    continue;
                }
            };
            let body = serde_json::to_vec(&letter.payload)
                .map_err(|e| Error::output(&path, format!("serialising: {e}")))?;
            let env = [
                ("QUAKETWIN_NOTIFICATION_ID", letter.id.clone()),
                (
                    "QUAKETWIN_STRUCTURE",
                    letter.structure.clone().unwrap_or_default(),
                ),
                ("QUAKETWIN_EVENT", letter.event.clone().unwrap_or_default()),
                (
                    "QUAKETWIN_RATING",
                    letter.rating.clone().unwrap_or_default(),
                ),
            ];
            let outcome = target.send(&letter.id, &body, &env, policy.timeout);
            letter.attempts += 1;
            match outcome {
                Ok(()) => {
                    // Removed after the delivery: a kill in between sends
                    // it again (same id), never loses it.
                    std::fs::remove_file(&path).map_err(|e| Error::io(&path, e))?;
                    round.sent += 1;
                    log::info(
                        "notification_sent",
                        json!({"id": letter.id, "target": letter.target, "attempts": letter.attempts}),
                    );
                }
                Err(why) if letter.attempts >= policy.attempts => {
                    letter.last_error = Some(why);
                    self.bury(&path, &letter)?;
                    round.dead += 1;
                }
                Err(why) => {
                    let wait = policy.delay(letter.attempts);
                    letter.next_attempt_ms = now_ms() + wait.as_millis() as i64;
                    log::warn(
                        "notification_retry",
                        json!({"id": letter.id, "target": letter.target, "attempts": letter.attempts,
                               "retry_in_s": wait.as_secs_f64(), "error": why}),
                    );
                    letter.last_error = Some(why);
                    write_letter(&path, &letter)?;
                    round.retried += 1;
                }
            }
        }
        Ok(round)
    }

    /// Moves a letter to the dead-letter folder (written there first, then
    /// removed from the outbox: a kill in between leaves it in both, and the
    /// next round buries it again).
    fn bury(&self, path: &Path, letter: &Letter) -> Result<()> {
        let name = path.file_name().map(PathBuf::from).unwrap_or_default();
        let dead = self.dead_dir.join(name);
        write_letter(&dead, letter)?;
        std::fs::remove_file(path).map_err(|e| Error::io(path, e))?;
        log::error(
            "notification_dead_letter",
            json!({"id": letter.id, "target": letter.target, "attempts": letter.attempts,
                   "error": letter.last_error, "file": dead}),
        );
        Ok(())
    }
}

fn write_letter(path: &Path, letter: &Letter) -> Result<()> {
    let text = serde_json::to_string_pretty(letter)
        .map_err(|e| Error::output(path, format!("serialising a letter: {e}")))?;
    crate::sinks::atomic::write_bytes_atomically(path, (text + "\n").as_bytes())
}
