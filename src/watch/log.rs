//! The structured log of `quaketwin watch`: one JSON object per line on
//! stderr, `{"ts": …, "level": …, "msg": …, <fields>}` (keys sorted), so that
//! a log shipper or `jq` reads it without a parser of its own.  The messages
//! and their fields are listed in docs/cli.md ("watch").

use serde_json::{Map, Value};

/// Now, as epoch nanoseconds.
pub fn now_ns() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as i64)
        .unwrap_or(0)
}

/// Now, UTC, ISO 8601 with nanoseconds.
pub fn now_text() -> String {
    crate::vocab::format_epoch_ns(now_ns())
}

/// Writes one log line: `level` (`info`, `warn`, `error`), `msg` (what
/// happened, snake_case), and `fields` (an object; anything else is put
/// under `detail`).
pub fn line(level: &str, msg: &str, fields: Value) {
    let mut m = match fields {
        Value::Object(m) => m,
        Value::Null => Map::new(),
        other => {
            let mut m = Map::new();
            m.insert("detail".into(), other);
            m
        }
    };
    m.insert("ts".into(), Value::String(now_text()));
    m.insert("level".into(), Value::String(level.into()));
    m.insert("msg".into(), Value::String(msg.into()));
    crate::console::record(Value::Object(m));
}

pub fn info(msg: &str, fields: Value) {
    line("info", msg, fields);
}

pub fn warn(msg: &str, fields: Value) {
    line("warn", msg, fields);
}

pub fn error(msg: &str, fields: Value) {
    line("error", msg, fields);
}
