//! `quaketwin watch INBOX --pipeline P --out DATASET`: unattended intake.
//! A new event folder or zip in the inbox is processed once its upload is
//! complete ([`inbox`]), added to the many-event dataset through the one
//! path every many-event run takes ([`crate::pipeline::dataset::add_event`]),
//! notified ([`outbox`], [`notify`]), and the structure's history and the
//! fleet dashboard are refreshed.
//!
//! Crash safety (kill -9 at any moment, then a restart): the steps of an
//! event are ordered so that each is either redone harmlessly or already
//! recorded ([`journal`]):
//!
//! 1. journal: `processing` (with the entry's fingerprint);
//! 2. the run and the publication into the dataset — idempotent: a rerun
//!    finds its stages up to date and publishes the same files again, so
//!    the event is in the dataset once however often it was begun;
//! 3. the notification into the outbox (one file per target, its id a hash
//!    of the partition and the fingerprint: the same at every attempt);
//! 4. journal: `done` (or `failed`);
//! 5. delivery of what is due (a letter is removed only after delivery);
//! 6. the history hook and the dashboard, then journal: `followed_up`.
//!
//! A restart redoes from step 2 an entry left `processing`, delivers every
//! letter left in the outbox, and follows up every entry not followed up.
//! State lives in `DATASET/_watch/` (locked by the running watch): the
//! inbox is only read.

pub mod flags;
pub mod inbox;
pub mod journal;
pub mod log;
pub mod notify;
pub mod outbox;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use serde::Serialize;
use serde_json::json;

use crate::error::{Error, Result};
use crate::pipeline::dataset::add_event;
use crate::summary::RunSummary;
use inbox::{CompletionRule, Judgement, Settling};
use journal::{Item, Journal, Status};
use notify::Target;
use outbox::{Outbox, RetryPolicy};

/// The state folder inside the dataset.
pub const STATE_DIR: &str = "_watch";
/// Layout version of the notification JSON.
pub const NOTIFICATION_VERSION: u32 = 1;

/// The command's options.
#[derive(Debug, Clone)]
pub struct WatchOptions {
    pub inbox: PathBuf,
    pub pipeline: PathBuf,
    /// The dataset.
    pub out: PathBuf,
    pub notify: Vec<String>,
    /// Time between two looks at the inbox.
    pub poll: Duration,
    pub rule: CompletionRule,
    pub retry: RetryPolicy,
    /// Where the dashboard is written (None: not written).
    pub dashboard: Option<PathBuf>,
    /// Process what is complete, deliver, and exit.
    pub once: bool,
}

/// What a `--once` run did (`--json`).
#[derive(Debug, Default, Clone, Serialize)]
pub struct WatchSummary {
    pub inbox: String,
    pub dataset: String,
    pub processed: Vec<String>,
    pub failed: Vec<String>,
    /// Entries at rest but not whole (never processed as they are).
    pub incomplete: Vec<String>,
    pub notifications_sent: usize,
    pub notifications_dead: usize,
}

impl WatchSummary {
    /// Whether the run left something for a person to look at.
    pub fn has_failures(&self) -> bool {
        !self.failed.is_empty() || self.notifications_dead > 0
    }
}

/// The absolute form of `p` (for the containment checks).
fn absolute(p: &Path) -> PathBuf {
    std::fs::canonicalize(p).unwrap_or_else(|_| {
        std::env::current_dir()
            .map(|d| d.join(p))
            .unwrap_or_else(|_| p.to_path_buf())
    })
}

/// Usage errors before anything is read: the inbox a folder, no output
/// inside the inbox (it would become an entry) nor the inbox inside an output.
fn check_paths(o: &WatchOptions) -> Result<()> {
    if !o.inbox.is_dir() {
        return Err(Error::usage(format!(
            "{}: the inbox must be a folder",
            o.inbox.display()
        )));
    }
    let inbox = absolute(&o.inbox);
    let outputs =
        std::iter::once(("--out", &o.out)).chain(o.dashboard.iter().map(|d| ("--dashboard", d)));
    for (flag, p) in outputs {
        let p_abs = absolute(p);
        if p_abs.starts_with(&inbox) || inbox.starts_with(&p_abs) {
            return Err(Error::usage(format!(
                "{flag} {}: the inbox {} and the outputs must not contain one another (the inbox is only read)",
                p.display(),
                o.inbox.display()
            )));
        }
    }
    if o.poll.is_zero() || o.retry.attempts == 0 {
        return Err(Error::usage(
            "--poll must be positive and --notify-attempts at least 1",
        ));
    }
    Ok(())
}

/// The id of the notification of `entry` at `fingerprint` (its partition
/// when known): the same however often the event is begun.
fn notification_id(key: &str, fingerprint: &str) -> String {
    let mut h = crate::hash::Hash64::default();
    h.write_str(key).write_str(fingerprint);
    format!("qt-{}", h.finish_hex())
}

/// The value of `key=` in a partition `structure=S/event=E`.
fn partition_part(partition: &str, key: &str) -> Option<String> {
    partition
        .split('/')
        .find_map(|c| c.strip_prefix(&format!("{key}=")))
        .map(str::to_string)
}

/// Runs the watch until killed (or, with `once`, until everything complete
/// is processed and delivered).
pub fn run(o: &WatchOptions) -> Result<WatchSummary> {
    check_paths(o)?;
    let targets: Vec<Target> = o
        .notify
        .iter()
        .map(|t| Target::parse(t))
        .collect::<Result<_>>()?;
    let pipeline = crate::stages::load_pipeline(&o.pipeline)?;
    let state = o.out.join(STATE_DIR);
    std::fs::create_dir_all(&state).map_err(|e| Error::io(&state, e))?;
    let lock = crate::pipeline::lock::DirLock::acquire(
        &state,
        &format!("quaketwin watch {}", o.inbox.display()),
    )?;
    if let Some(said) = &lock.took_over {
        log::warn("lock_taken_over", json!({ "detail": said }));
    }
    let mut journal = Journal::load(&state)?;
    let outbox = Outbox::open(&state)?;
    let mut summary = WatchSummary {
        inbox: o.inbox.display().to_string(),
        dataset: o.out.display().to_string(),
        ..Default::default()
    };
    log::info(
        "watch_started",
        json!({"inbox": o.inbox, "dataset": o.out, "pipeline": o.pipeline,
               "settle_s": o.rule.settle.as_secs_f64(), "poll_s": o.poll.as_secs_f64(),
               "require_done": o.rule.require_done, "targets": o.notify, "once": o.once,
               "journal_entries": journal.items.len()}),
    );
    // What a killed run left: letters to send, follow-ups not done.
    deliver(&outbox, o, &mut summary)?;
    follow_up_pending(o, &state, &mut journal, true)?;

    let mut settling = Settling::default();
    let mut said: std::collections::BTreeMap<String, String> = Default::default();
    loop {
        let scan = inbox::scan(&o.inbox)?;
        for name in &scan.ignored {
            if said.insert(name.clone(), "ignored".into()).is_none() {
                log::info(
                    "entry_ignored",
                    json!({"entry": name, "reason": "neither a folder nor a .zip"}),
                );
            }
        }
        let names: Vec<&str> = scan.entries.iter().map(|e| e.name.as_str()).collect();
        settling.retain(&names);
        let mut waiting = 0usize;
        for entry in &scan.entries {
            let fingerprint = match crate::pipeline::fingerprint::path_fingerprint(&entry.path) {
                Ok(f) => f,
                Err(e) => {
                    // Vanished or unreadable mid-scan: looked at again next poll.
                    let why = e.to_string();
                    if said.insert(entry.name.clone(), why.clone()).as_ref() != Some(&why) {
                        log::warn(
                            "entry_unreadable",
                            json!({"entry": entry.name, "error": why}),
                        );
                    }
                    continue;
                }
            };
            if journal.finished(&entry.name, &fingerprint) {
                continue;
            }
            let begun = journal.begun(&entry.name, &fingerprint);
            match settling.judge(entry, &fingerprint, begun, o.rule, Instant::now()) {
                Judgement::Complete => {
                    said.remove(&entry.name);
                    process(
                        o,
                        &pipeline,
                        &targets,
                        &state,
                        &mut journal,
                        &outbox,
                        entry,
                        &fingerprint,
                        &mut summary,
                    )?;
                }
                Judgement::Waiting(why) => {
                    waiting += 1;
                    if said.insert(entry.name.clone(), why.clone()).is_none() {
                        log::info("entry_waiting", json!({"entry": entry.name, "reason": why}));
                    }
                }
                Judgement::Unmarked(why) => {
                    if said.insert(entry.name.clone(), why.clone()).is_none() {
                        log::info("entry_waiting", json!({"entry": entry.name, "reason": why}));
                    }
                }
                Judgement::Incomplete(why) => {
                    if said.insert(entry.name.clone(), why.clone()).as_ref() != Some(&why) {
                        log::warn(
                            "entry_incomplete",
                            json!({"entry": entry.name, "reason": why}),
                        );
                        if !summary.incomplete.contains(&entry.name) {
                            summary.incomplete.push(entry.name.clone());
                        }
                    }
                }
            }
        }
        deliver(&outbox, o, &mut summary)?;
        let (letters, next_due_ms) = outbox.waiting()?;
        if o.once && waiting == 0 && letters == 0 {
            break;
        }
        // Sleep a poll, or less when a retry falls due sooner.
        let mut nap = o.poll;
        if let Some(due) = next_due_ms {
            let until = (due - log::now_ns() / 1_000_000).max(0) as u64;
            nap = nap.min(Duration::from_millis(until.max(10)));
        }
        std::thread::sleep(nap);
    }
    log::info(
        "watch_finished",
        json!({"processed": summary.processed.len(), "failed": summary.failed.len(),
               "incomplete": summary.incomplete, "notifications_sent": summary.notifications_sent,
               "notifications_dead": summary.notifications_dead}),
    );
    drop(lock);
    Ok(summary)
}

fn deliver(outbox: &Outbox, o: &WatchOptions, summary: &mut WatchSummary) -> Result<()> {
    let round = outbox.deliver_due(&o.retry)?;
    summary.notifications_sent += round.sent;
    summary.notifications_dead += round.dead;
    Ok(())
}

/// Steps 1–6 of the module doc for one complete entry.
#[allow(clippy::too_many_arguments)]
fn process(
    o: &WatchOptions,
    pipeline: &crate::pipeline::Pipeline,
    targets: &[Target],
    state: &Path,
    journal: &mut Journal,
    outbox: &Outbox,
    entry: &inbox::Entry,
    fingerprint: &str,
    summary: &mut WatchSummary,
) -> Result<()> {
    let complete_at = match journal.items.get(&entry.name) {
        Some(i) if i.fingerprint == fingerprint => i.complete_at.clone(),
        _ => log::now_text(),
    };
    log::info(
        "event_started",
        json!({"entry": entry.name, "fingerprint": fingerprint, "complete_at": complete_at}),
    );
    let started = Instant::now();
    let mut item = Item {
        fingerprint: fingerprint.to_string(),
        status: Status::Processing,
        partition: None,
        notification_id: None,
        complete_at,
        started_at: log::now_text(),
        finished_at: None,
        seconds: None,
        error: None,
        followed_up: false,
    };
    journal.items.insert(entry.name.clone(), item.clone());
    journal.save(state)?;

    let run = add_event(pipeline, &entry.path, &o.out, true);
    let partition = run
        .partition
        .as_ref()
        .map(|p| p.to_string_lossy().replace('\\', "/"));
    let run_dir = run.run_dir.clone().unwrap_or_else(|| o.out.clone());
    let run_summary = RunSummary::of_run(
        &o.pipeline.display().to_string(),
        &entry.path,
        &run_dir,
        &run.result,
    );
    let id = notification_id(partition.as_deref().unwrap_or(&entry.name), fingerprint);
    let seconds = started.elapsed().as_secs_f64();
    item.partition = partition.clone();
    item.notification_id = Some(id.clone());
    item.seconds = Some(seconds);
    item.finished_at = Some(log::now_text());
    item.error = run.result.as_ref().err().map(|e| e.to_string());
    item.status = if run.result.is_ok() {
        Status::Done
    } else {
        Status::Failed
    };

    let structure = partition
        .as_deref()
        .and_then(|p| partition_part(p, "structure"));
    let event = partition
        .as_deref()
        .and_then(|p| partition_part(p, "event"));
    let assessment = run_summary.assessment.clone();
    let rating = assessment.as_ref().map(|a| a.rating.clone());
    let report = run
        .run_dir
        .as_ref()
        .map(|d| d.join("report.html"))
        .filter(|p| p.is_file())
        .and_then(|p| {
            p.strip_prefix(&o.out)
                .ok()
                .map(|r| r.to_string_lossy().replace('\\', "/"))
        });
    let dashboard_page = match (&o.dashboard, &structure) {
        (Some(site), Some(s)) => Some(site.join(crate::dashboard::structure_page(s))),
        _ => None,
    };
    let payload = json!({
        "notification_version": NOTIFICATION_VERSION,
        "id": id,
        "kind": if run.result.is_ok() { "event_processed" } else { "event_failed" },
        "inbox_entry": entry.name,
        "event_fingerprint": fingerprint,
        "dataset": absolute(&o.out),
        "partition": partition,
        "structure": structure,
        "event": event,
        "ok": run.result.is_ok(),
        "error": item.error,
        "rating": rating,
        "priority": assessment.as_ref().and_then(|a| a.priority.clone()),
        "assessment": assessment,
        "report": report,
        "dashboard_page": dashboard_page,
        "upload_complete_at": item.complete_at,
        "processed_at": item.finished_at,
        "summary": run_summary,
    });
    outbox.post(
        &id,
        targets,
        [structure.clone(), event.clone(), rating.clone()],
        &payload,
    )?;
    journal.items.insert(entry.name.clone(), item.clone());
    journal.save(state)?;
    match &run.result {
        Ok(_) => {
            summary.processed.push(entry.name.clone());
            log::info(
                "event_processed",
                json!({"entry": entry.name, "partition": partition, "rating": rating,
                       "notification_id": id, "seconds": seconds}),
            );
        }
        Err(e) => {
            summary.failed.push(entry.name.clone());
            log::error(
                "event_failed",
                json!({"entry": entry.name, "partition": partition, "error": e.to_string(),
                       "notification_id": id, "seconds": seconds}),
            );
        }
    }
    deliver(outbox, o, summary)?;
    follow_up_pending(o, state, journal, false)
}

/// Step 6 for every entry not yet followed up: the history hook once per
/// structure, then the dashboard once (at start, `always_dashboard`: also
/// when nothing was pending, so that a site killed half-written is whole).
fn follow_up_pending(
    o: &WatchOptions,
    state: &Path,
    journal: &mut Journal,
    always_dashboard: bool,
) -> Result<()> {
    let pending: Vec<String> = journal
        .items
        .iter()
        .filter(|(_, i)| !i.followed_up)
        .map(|(n, _)| n.clone())
        .collect();
    let structures: std::collections::BTreeSet<String> = pending
        .iter()
        .filter_map(|n| journal.items[n].partition.as_deref())
        .filter_map(|p| partition_part(p, "structure"))
        .collect();
    for s in &structures {
        if let Err(e) = refresh_structure_history(&o.out, s) {
            log::error(
                "history_failed",
                json!({"structure": s, "error": e.to_string()}),
            );
        }
    }
    if let Some(site) = &o.dashboard {
        if always_dashboard || !pending.is_empty() {
            match crate::dashboard::write_site(&o.out, site) {
                Ok(written) => log::info(
                    "dashboard_written",
                    json!({"site": site, "structures": written.structures, "events": written.events}),
                ),
                Err(e) => log::error(
                    "dashboard_failed",
                    json!({"site": site, "error": e.to_string()}),
                ),
            }
        }
    }
    if !pending.is_empty() {
        for n in &pending {
            if let Some(i) = journal.items.get_mut(n) {
                i.followed_up = true;
            }
        }
        journal.save(state)?;
    }
    Ok(())
}

/// The one call site of the structure history after an event (issue 35
/// item 1): refreshes the history of `structure` (its partition value) in
/// `dataset`, into [`crate::sinks::dataset::history_dir`] — where the
/// dashboard reads it ([`crate::dataset_history::write_history`]).
pub fn refresh_structure_history(dataset: &Path, structure: &str) -> Result<()> {
    let out = crate::sinks::dataset::history_dir(dataset, structure);
    let summary = crate::dataset_history::write_history(dataset, Some(structure), &out)?;
    let flagged: usize = summary
        .structures
        .iter()
        .flat_map(|s| &s.modes)
        .map(|m| m.flagged.len())
        .sum();
    log::info(
        "history_written",
        json!({
            "structure": structure,
            "out": out,
            "events": summary.structures.iter().map(|s| s.events).sum::<usize>(),
            "flagged": flagged,
        }),
    );
    Ok(())
}
