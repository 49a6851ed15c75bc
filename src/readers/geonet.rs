//! GeoNet (GNS Science, New Zealand) V1A/V2A strong-motion files: several
//! components one after the other, each with
//! - 16 text lines (line 2 `Site WPWS …`, line 3 the site name, line 7 the
//!   event's place, line 9 `Epicentre … Depth 9km M 4.17`, line 10
//!   `Number of points 5800 …`, line 11 `… data at 0.020 sec intervals`,
//!   line 13 `Component S16W …`, line 14 `Acceleration: peak -41.6 mm/s/s …`);
//! - 100 header numbers in 10 lines of 10 fields of 8 characters (rows 1–4
//!   integers: origin date and time, epicentre and site coordinates, record
//!   start; rows 5–10 reals: instrument, sampling interval at row 7 col 6);
//! - the acceleration samples (10F8), then for V2A the velocity and
//!   displacement blocks, which are skipped.

use super::textfmt::{self, Layout, Lines};
use super::{FileContents, ReadOptions};
use crate::error::Result;
use crate::vocab::{epoch_ns_from_civil, Channel, Direction, QaFlag, Record, SourceRef, Units};

const TEXT_LINES: usize = 16;
const HEADER_LINES: usize = 10;
const HEADER_COUNT: usize = 100;
const DATA_LAYOUT: Layout = Layout::Fixed {
    per_line: 10,
    width: 8,
};

/// Whether `lines` (the head of a file) hold a complete GeoNet header: the
/// 16 text lines, then the numeric header rows.  Used for content sniffing.
pub(crate) fn header_complete(lines: &[&str]) -> bool {
    lines.len() > TEXT_LINES + 1
        && lines[TEXT_LINES..TEXT_LINES + 2]
            .iter()
            .all(|l| textfmt::is_numeric_line(l))
}

/// Components in one GeoNet strong-motion file (two horizontals, vertical).
const COMPONENTS_PER_FILE: usize = 3;

pub fn read(bytes: &[u8], source: &SourceRef, _opts: &ReadOptions) -> Result<FileContents> {
    // Every component read adds one record, so "no block" is "no component".
    let mut contents = textfmt::read_channel_blocks(
        bytes,
        source,
        "no GeoNet component found (empty file)",
        read_component,
    )?;
    // A V1A/V2A file carries the three components of one instrument; fewer
    // means a file cut at a component boundary, which must not pass as whole.
    let n = contents.records.len();
    if n < COMPONENTS_PER_FILE {
        for r in &mut contents.records {
            r.channel.qa.push(QaFlag::Note {
                text: format!(
                    "the file holds {n} of the {COMPONENTS_PER_FILE} components a GeoNet V1A/V2A file carries (truncated at a component boundary?)"
                ),
            });
        }
    }
    Ok(contents)
}

/// Reads the component starting at 0-based line `b`; returns the line after it.
fn read_component(
    lines: &Lines,
    b: usize,
    source: &SourceRef,
    contents: &mut FileContents,
) -> Result<usize> {
    let first = lines.get(b).to_ascii_lowercase();
    if !first.contains("accelerogram") {
        return Err(lines.err(
            b,
            format!(
                "expected a GeoNet component header (\"Corrected accelerogram …\"), found {:?}",
                lines.get(b).trim()
            ),
        ));
    }
    let corrected = !first.contains("uncorrected");
    if !lines.exists(b + TEXT_LINES + HEADER_LINES) {
        return Err(lines.err(
            lines.len().saturating_sub(1),
            "file ends inside a component header (truncated file?)",
        ));
    }
    let station = lines
        .get(b + 1)
        .split_whitespace()
        .nth(1)
        .unwrap_or("")
        .to_string();
    if !lines.get(b + 1).trim_start().starts_with("Site") || station.is_empty() {
        return Err(lines.err(
            b + 1,
            format!(
                "expected \"Site <code> …\", found {:?}",
                lines.get(b + 1).trim()
            ),
        ));
    }
    let component_line = lines.get(b + 12);
    let component = component_line
        .split_whitespace()
        .nth(1)
        .unwrap_or("")
        .to_string();
    if !component_line.trim_start().starts_with("Component") || component.is_empty() {
        return Err(lines.err(
            b + 12,
            format!(
                "expected \"Component <bearing> …\", found {:?}",
                component_line.trim()
            ),
        ));
    }
    let id = format!("{station}.{}", component.to_ascii_uppercase());

    // Numeric header: 10 lines of 10 fields, 8 characters each.
    let mut h = Vec::with_capacity(HEADER_COUNT);
    for i in b + TEXT_LINES..b + TEXT_LINES + HEADER_LINES {
        for f in textfmt::fixed_fields(lines.get(i), 8, 10) {
            h.push(textfmt::parse_number(&f).map_err(|_| {
                lines.err_ch(
                    i,
                    &id,
                    format!("header field {:?} is not a number", f.trim()),
                )
            })?);
        }
    }
    if h.len() < HEADER_COUNT {
        return Err(lines.err_ch(
            b + TEXT_LINES + HEADER_LINES - 1,
            &id,
            format!("numeric header has {} of {HEADER_COUNT} values", h.len()),
        ));
    }
    let dt = h[65];
    if !(dt > 0.0 && dt.is_finite()) {
        return Err(lines.err_ch(
            b + TEXT_LINES + 6,
            &id,
            format!("sampling interval {dt} s is not positive"),
        ));
    }
    let header_npts = if corrected { h[33] } else { h[30] };
    let text_npts = textfmt::number_after(lines.get(b + 9), "Number of points");
    let npts = match text_npts {
        Some(n) => n,
        None => header_npts,
    };
    if !(npts >= 1.0 && npts.fract() == 0.0 && npts < 1e9) {
        return Err(lines.err_ch(
            b + 9,
            &id,
            format!("number of points {npts} is not a positive integer"),
        ));
    }
    let npts = npts as usize;
    if (header_npts - npts as f64).abs() > 0.5 {
        return Err(lines.err_ch(
            b + 9,
            &id,
            format!("the text says {npts} points but the numeric header says {header_npts}"),
        ));
    }

    // Units from "Acceleration:  peak    -41.6 mm/s/s at …".
    let mut inferred = Vec::new();
    let accel_line = lines.get(b + 13);
    let units = if accel_line.trim_start().starts_with("Acceleration") {
        let word = accel_line
            .split_whitespace()
            .skip_while(|t| textfmt::parse_number(t).is_err())
            .nth(1)
            .ok_or_else(|| lines.err_ch(b + 13, &id, "no units after the peak acceleration"))?;
        textfmt::units_from_text(word)
            .map_err(|e| lines.err_ch(b + 13, &id, format!("unknown units {word:?}: {e}")))?
    } else {
        inferred.push("units=mm/s2 (GeoNet convention; the header names none)".to_string());
        Units::MmPerS2
    };

    let data_start = b + TEXT_LINES + HEADER_LINES;
    let block = textfmt::read_block(lines, data_start, npts, DATA_LAYOUT, &id)?;
    if block.extra_on_last_line > 0 {
        return Err(lines.err_ch(
            block.next_line - 1,
            &id,
            format!("more values than the {npts} points the header declares"),
        ));
    }
    let mut next = block.next_line;
    if corrected {
        // Velocity and displacement blocks (counts at header [34], [35]).
        for (k, what) in [(34, "velocity"), (35, "displacement")] {
            let n = h[k];
            if n >= 1.0 && n.fract() == 0.0 && n < 1e9 {
                let skipped = textfmt::read_block(
                    lines,
                    next,
                    n as usize,
                    DATA_LAYOUT,
                    &format!("{id} {what}"),
                )?;
                next = skipped.next_line;
            }
        }
    }
    if lines.exists(next) && textfmt::is_numeric_line(lines.get(next)) {
        return Err(lines.err_ch(
            next,
            &id,
            format!("numbers after the component's declared blocks ({npts} points each)"),
        ));
    }

    let mut channel = Channel::new(id, units, 1.0 / dt, source.clone());
    channel.network = Some("NZ".into());
    channel.station = Some(station);
    channel.channel_code = Some(component.clone());
    channel.location_text = Some(lines.get(b + 2).trim().to_string()).filter(|s| !s.is_empty());
    channel.direction = Direction::parse(&component);
    if channel.direction.is_none() {
        channel.missing.push("direction".into());
    }
    // Record start: year [8], month [9], day [18], hour [19], minute [38], milliseconds [39].
    channel.start_ns = civil(h[8], h[9], h[18], h[19], h[38], h[39] / 1000.0);
    if channel.start_ns.is_none() {
        channel.missing.push("start_time".into());
    }
    channel.inferred = inferred;
    contents.records.push(Record::new(channel, block.values));

    if contents.event.origin_ns.is_none() {
        // Origin: year, month, day, hour, minute, tenths of seconds at [0..6].
        contents.event.origin_ns = civil(h[0], h[1], h[2], h[3], h[4], h[5] / 10.0);
        contents.event.name = Some(lines.get(b + 6).trim().to_string()).filter(|s| !s.is_empty());
        let epi = lines.get(b + 8);
        contents.event.magnitude = textfmt::number_after(epi, " M ");
        let south = epi
            .split_whitespace()
            .nth(3)
            .is_some_and(|t| t.ends_with('S'));
        let west = epi
            .split_whitespace()
            .nth(6)
            .is_some_and(|t| t.ends_with('W'));
        let lat = (h[10] + h[11] / 60.0 + h[12] / 3600.0) * if south { -1.0 } else { 1.0 };
        let lon = (h[13] + h[14] / 60.0 + h[15] / 3600.0) * if west { -1.0 } else { 1.0 };
        if lat != 0.0 || lon != 0.0 {
            contents.event.hypocenter = Some((lat, lon, h[16]));
        }
    }
    Ok(next)
}

fn civil(year: f64, month: f64, day: f64, hour: f64, minute: f64, second: f64) -> Option<i64> {
    let ok = |v: f64, lo: f64, hi: f64| v.fract() == 0.0 && (lo..=hi).contains(&v);
    if !(ok(year, 1900.0, 2200.0)
        && ok(month, 1.0, 12.0)
        && ok(day, 1.0, 31.0)
        && ok(hour, 0.0, 23.0)
        && ok(minute, 0.0, 59.0))
    {
        return None;
    }
    epoch_ns_from_civil(
        year as i64,
        month as u32,
        day as u32,
        hour as u32,
        minute as u32,
        second,
    )
}
