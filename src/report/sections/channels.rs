//! Section 3, channels: QA flags and strong-motion metrics of channels.parquet.

use super::{present_columns, require, Loaded};
use crate::report::html::{missing_columns_note, note, table, Cell};
use crate::vocab::tables::{self, channels};

const CHANNEL_COLUMNS: [&str; 17] = [
    channels::CHANNEL_ID.name,
    channels::LEVEL.name,
    channels::DIRECTION.name,
    channels::ROLE.name,
    channels::UNITS.name,
    channels::SAMPLING_RATE_HZ.name,
    channels::NPTS.name,
    channels::PGA_M_S2.name,
    channels::PGV_M_S.name,
    channels::PGD_M.name,
    channels::ARIAS_M_S.name,
    channels::D5_95_S.name,
    channels::CAV_M_S.name,
    channels::SNR_DB.name,
    channels::QA_FLAGS.name,
    channels::MISSING.name,
    channels::INFERRED.name,
];

pub(super) fn channel_section(channels: &Loaded) -> String {
    let mut body = String::new();
    let Some(t) = require(channels, &tables::CHANNELS, &mut body) else {
        return body;
    };
    let present = present_columns(t, &CHANNEL_COLUMNS);
    let rows: Vec<Vec<Cell>> = (0..t.rows)
        .map(|r| {
            present
                .iter()
                .map(|c| match *c {
                    c if c == channels::DIRECTION.name => Cell::direction(t, c, r),
                    c => Cell::of(t, c, r),
                })
                .collect()
        })
        .collect();
    body.push_str(&note(
        "Units: m/s² (pga), m/s (pgv, arias, cav), m (pgd), s (d5_95), dB (snr). \
         QA flags, missing metadata and what was inferred (and how) as tags; — = not available. \
         Directions: X, Y, Z are the building axes every stage works in (applied once at ingest); \
         \"azimuth N°\" marks a channel whose relation to them is unknown (event.json notes say why; \
         structure.x_axis_azimuth_deg in event.toml settles it) — stages working in X/Y leave it out.",
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
