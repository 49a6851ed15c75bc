//! Section 3, channels: QA flags and strong-motion metrics of channels/channels.parquet.

use serde_json::Value;

use super::layout::place_text;
use super::{present_columns, require, Loaded};
use crate::report::html::{missing_columns_note, natural_cmp, note, table, Cell};
use crate::report::table::Table;
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

/// Rows of the channel table in natural order of their ids (…02 before …10).
pub(super) fn natural_rows(t: &Table) -> Vec<usize> {
    let mut rows: Vec<usize> = (0..t.rows).collect();
    rows.sort_by(|&a, &b| {
        natural_cmp(
            &t.key(channels::CHANNEL_ID.name, a).unwrap_or_default(),
            &t.key(channels::CHANNEL_ID.name, b).unwrap_or_default(),
        )
    });
    rows
}

pub(super) fn channel_section(channels: &Loaded, event: &Result<Value, String>) -> String {
    let mut body = String::new();
    let Some(t) = require(channels, &tables::CHANNELS, &mut body) else {
        return body;
    };
    let storeys = event.as_ref().ok().and_then(super::layout::storeys);
    let present = present_columns(t, &CHANNEL_COLUMNS);
    let rows: Vec<Vec<Cell>> = natural_rows(t)
        .into_iter()
        .map(|r| {
            present
                .iter()
                .map(|c| match *c {
                    c if c == channels::DIRECTION.name => Cell::direction(t, c, r),
                    c if c == channels::LEVEL.name => {
                        let level = t
                            .number(c)
                            .and_then(|v| v.get(r).copied().flatten())
                            .map(|l| l as i32);
                        let place = t.key(channels::LOCATION_TEXT.name, r);
                        Cell {
                            value: level.map(f64::from),
                            ..Cell::text(&place_text(level, place.as_deref(), storeys))
                        }
                    }
                    c => Cell::of(t, c, r),
                })
                .collect()
        })
        .collect();
    body.push_str(&note(
        "Peak ground or floor acceleration (PGA), velocity (PGV) and displacement (PGD), Arias intensity, significant duration \
         D5–95, cumulative absolute velocity (CAV) and signal-to-noise ratio (SNR) of the conditioned records. \
         Channels in natural order of their ids; level: the level of the structure (0 = the base), else the sensor location the \
         record header names. QA flags, missing metadata and what was inferred (and how) as tags; — = not available. \
         Directions: X, Y, Z are the building axes every stage works in (applied once at ingest); \
         \"azimuth N°\" marks a channel whose relation to them is unknown (the event notes say why; \
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
