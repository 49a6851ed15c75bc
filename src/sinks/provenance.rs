//! Provenance of a table: the two metadata keys every quaketwin table carries
//! (docs/formats.md, "Metadata of every table"): `quaketwin.event`, the event's
//! identity, and `quaketwin.history`, every processing step from the records
//! to the table, in order.  One home for both, so that a table written by any
//! stage (or by a command run on its own) says the same thing the same way.
//!
//! Provenance travels with the data: a stage that starts from another table
//! (twin updating starts from `modes/modes.parquet`) reads the provenance of that
//! table back ([`Provenance::from_metadata`]) and appends its own steps.

use crate::vocab::{Event, ProcessingHistory, ProcessingStep};

/// Metadata key of the processing history (JSON `{"steps": [...]}`).
pub const HISTORY_KEY: &str = "quaketwin.history";
/// Metadata key of the event's identity (JSON: name, origin time, magnitude,
/// structure, notes).
pub const EVENT_KEY: &str = "quaketwin.event";

/// What a table derives from: the event's identity (JSON) and the steps that
/// made it.
#[derive(Debug, Clone, PartialEq)]
pub struct Provenance {
    event_json: String,
    history: ProcessingHistory,
}

impl Provenance {
    /// The provenance of `event` as conditioned so far (its own history).
    pub fn of_event(event: &Event) -> Self {
        let doc = serde_json::json!({
            "name": event.name,
            "origin_time": event.origin_ns.map(crate::vocab::format_epoch_ns),
            "magnitude": event.magnitude,
            "structure": event.structure,
            "notes": event.notes,
        });
        Provenance {
            event_json: doc.to_string(),
            history: event.history.clone(),
        }
    }

    /// The provenance of data that is not an event (a continuous archive):
    /// its identity as given, no steps yet.
    pub fn of_source(identity: serde_json::Value) -> Self {
        Provenance {
            event_json: identity.to_string(),
            history: ProcessingHistory::default(),
        }
    }

    /// Reads the provenance back from a table's key/value metadata; `None`
    /// when the table does not carry the event key (a table another tool
    /// wrote).  A missing or unreadable history is taken as empty: the event
    /// is still known, and what follows is appended.
    pub fn from_metadata<'a>(
        mut entries: impl Iterator<Item = (&'a str, Option<&'a str>)>,
    ) -> Option<Self> {
        let (mut event_json, mut history) = (None, ProcessingHistory::default());
        for (key, value) in entries.by_ref() {
            match (key, value) {
                (EVENT_KEY, Some(v)) => event_json = Some(v.to_string()),
                (HISTORY_KEY, Some(v)) => history = serde_json::from_str(v).unwrap_or_default(),
                _ => {}
            }
        }
        Some(Provenance {
            event_json: event_json?,
            history,
        })
    }

    /// The same provenance followed by `steps` (what the writing stage did).
    pub fn then(mut self, steps: impl IntoIterator<Item = ProcessingStep>) -> Self {
        self.history.steps.extend(steps);
        self
    }

    /// The same provenance followed by one step `step` with `params`.
    pub fn then_step(mut self, step: &str, params: serde_json::Value) -> Self {
        self.history.push(step, params);
        self
    }

    /// The two metadata entries, event first.
    pub fn metadata(&self) -> Vec<(String, String)> {
        vec![
            (EVENT_KEY.to_string(), self.event_json.clone()),
            (HISTORY_KEY.to_string(), self.history.to_json()),
        ]
    }
}
