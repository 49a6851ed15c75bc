//! Section 3, channels: QA flags and strong-motion metrics of channels.parquet.

use super::{present_columns, require, Loaded};
use crate::report::html::{missing_columns_note, note, table, Cell};

const CHANNEL_COLUMNS: [&str; 16] = [
    "channel_id",
    "level",
    "direction",
    "role",
    "units",
    "sampling_rate_hz",
    "npts",
    "pga_m_s2",
    "pgv_m_s",
    "pgd_m",
    "arias_m_s",
    "d5_95_s",
    "cav_m_s",
    "snr_db",
    "qa_flags",
    "missing",
];

pub(super) fn channel_section(channels: &Loaded) -> String {
    let mut body = String::new();
    let Some(t) = require(channels, "channels.parquet", &mut body) else {
        return body;
    };
    let present = present_columns(t, &CHANNEL_COLUMNS);
    let rows: Vec<Vec<Cell>> = (0..t.rows)
        .map(|r| present.iter().map(|c| Cell::of(t, c, r)).collect())
        .collect();
    body.push_str(&note(
        "Units: m/s² (pga), m/s (pgv, arias, cav), m (pgd), s (d5_95), dB (snr). \
         QA flags and missing metadata as tags; — = not available.",
    ));
    body.push_str(&format!(
        "<div class=\"scroll\">{}</div>",
        table(
            Some("channel-table"),
            &present.iter().map(|s| s.to_string()).collect::<Vec<_>>(),
            &rows
        )
    ));
    body.push_str(&missing_columns_note(t, &CHANNEL_COLUMNS));
    body
}
