//! PEER NGA `.AT2` acceleration files, and look-alikes with an
//! `NPTS=…, DT=…` line.
//!
//! Layouts handled:
//! - NGA-West2: line 1 `PEER NGA STRONG MOTION DATABASE RECORD`, line 2
//!   `event, date, station, component`, line 3 `ACCELERATION TIME SERIES IN
//!   UNITS OF G`, line 4 `NPTS=   7999, DT=   .0050 SEC,`, then 5E15.7 values;
//! - old NGA: the same with `TIME HISTORY`, CRLF and trailing blanks;
//! - the older PEER form `  4000   0.0100   NPTS, DT` (numbers first);
//! - free text lines then `NPTS=  1559, DT= .02000 SEC` (elCentro), 8F10.5.
//!
//! Values are read free-format (touching values split at signs) up to the
//! end of the file, the last partial line included; their count must equal
//! NPTS exactly.

use super::textfmt::{self, Layout, Lines};
use super::{FileContents, ReadOptions};
use crate::error::Result;
use crate::vocab::{Channel, Direction, Record, SourceRef, Units};

/// Header lines searched for the `NPTS`/`DT` line.
const MAX_HEADER_LINES: usize = 12;

pub fn read(bytes: &[u8], source: &SourceRef, _opts: &ReadOptions) -> Result<FileContents> {
    let text = textfmt::decode(bytes, source)?;
    let lines = Lines::new(&text, source);
    if lines.len() == 0 {
        return Err(lines.err_file("empty AT2 file"));
    }
    let header = (0..lines.len().min(MAX_HEADER_LINES))
        .find(|&i| lines.get(i).to_ascii_uppercase().contains("NPTS"))
        .ok_or_else(|| {
            lines.err(
                0,
                format!("no NPTS/DT line in the first {MAX_HEADER_LINES} lines: not a PEER AT2 file, or its header is damaged"),
            )
        })?;
    let (npts, dt) = npts_dt(lines.get(header)).ok_or_else(|| {
        lines.err(
            header,
            format!(
                "cannot read NPTS and DT from {:?}",
                lines.get(header).trim()
            ),
        )
    })?;
    if !(dt > 0.0 && dt.is_finite()) {
        return Err(lines.err(
            header,
            format!("DT = {dt} s is not a positive sampling interval"),
        ));
    }

    // Units: "UNITS OF G" (PEER) or "The units are (g)"; PEER's own convention is g.
    let mut inferred = Vec::new();
    let mut units = None;
    for i in 0..header {
        if let Some(word) = units_word(lines.get(i)) {
            units =
                Some(textfmt::units_from_text(&word).map_err(|e| {
                    lines.err(i, format!("unknown units {word:?} in the header: {e}"))
                })?);
            break;
        }
    }
    let units = units.unwrap_or_else(|| {
        inferred.push("units=g assumed (PEER AT2 convention; the header names none)".to_string());
        Units::G
    });

    let id = file_stem(source);
    let block = textfmt::read_block(&lines, header + 1, npts, Layout::Free, &id)?;
    if block.extra_on_last_line > 0 {
        return Err(lines.err_ch(
            block.next_line - 1,
            &id,
            format!(
                "more values than NPTS={npts}: {} extra on this line",
                block.extra_on_last_line
            ),
        ));
    }
    if let Some(extra_line) =
        (block.next_line..lines.len()).find(|&i| !lines.get(i).trim().is_empty())
    {
        let more: usize = (extra_line..lines.len())
            .map(|i| textfmt::split_free(lines.get(i)).len())
            .sum();
        return Err(lines.err_ch(
            extra_line,
            &id,
            format!("about {more} values after the NPTS={npts} declared by the header"),
        ));
    }

    let mut channel = Channel::new(id.clone(), units, 1.0 / dt, source.clone());
    channel.inferred = inferred;
    let mut contents = FileContents::default();
    // PEER NGA line 2: "event, date, station, component".
    let first = lines.get(0).to_ascii_uppercase();
    if first.starts_with("PEER") && header >= 2 {
        let parts: Vec<&str> = lines.get(1).split(',').map(str::trim).collect();
        if parts.len() >= 4 {
            contents.event.name = Some(parts[0].to_string()).filter(|s| !s.is_empty());
            channel.station = Some(parts[2..parts.len() - 1].join(",")).filter(|s| !s.is_empty());
            let component = parts[parts.len() - 1];
            channel.channel_code = Some(component.to_string());
            channel.direction = component_direction(component);
        }
    } else {
        channel.location_text = Some(lines.get(0).trim().to_string()).filter(|s| !s.is_empty());
    }
    if channel.direction.is_none() {
        channel.missing.push("direction".into());
    }
    channel.missing.push("start_time".into());
    contents.records.push(Record::new(channel, block.values));
    Ok(contents)
}

/// Data lines checked after the `NPTS`/`DT` line when sniffing by content.
const SNIFF_DATA_LINES: usize = 20;

/// Whether `lines` (the head of a file, `\r` stripped) hold a complete AT2
/// header: an `NPTS`/`DT` line within the first lines with a positive count
/// and interval, followed by lines of numbers only (no more values than
/// NPTS).  Used for content sniffing, so a README quoting `NPTS=… DT=` is
/// not taken for a record.
pub(crate) fn header_complete(lines: &[&str]) -> bool {
    let Some(h) = (0..lines.len().min(MAX_HEADER_LINES))
        .find(|&i| lines[i].to_ascii_uppercase().contains("NPTS"))
    else {
        return false;
    };
    let Some((npts, dt)) = npts_dt(lines[h]) else {
        return false;
    };
    if npts == 0 || !(dt > 0.0 && dt.is_finite()) {
        return false;
    }
    let data: Vec<&str> = lines[h + 1..]
        .iter()
        .take(SNIFF_DATA_LINES)
        .copied()
        .filter(|l| !l.trim().is_empty())
        .collect();
    let values: usize = data.iter().map(|l| textfmt::split_free(l).len()).sum();
    !data.is_empty() && data.iter().all(|l| textfmt::is_numeric_line(l)) && values <= npts
}

/// `NPTS=   7999, DT=   .0050 SEC,` or `  4000   0.0100   NPTS, DT`.
fn npts_dt(line: &str) -> Option<(usize, f64)> {
    let upper = line.to_ascii_uppercase();
    let (n, dt) = if upper.contains("NPTS=") || upper.contains("NPTS =") {
        let n = textfmt::number_after(&upper.replace("NPTS =", "NPTS="), "NPTS=")?;
        let dt = textfmt::number_after(&upper.replace("DT =", "DT="), "DT=")?;
        (n, dt)
    } else {
        let nums: Vec<f64> = textfmt::split_free(&upper)
            .iter()
            .filter_map(|t| textfmt::parse_number(t.trim_end_matches(',')).ok())
            .collect();
        (*nums.first()?, *nums.get(1)?)
    };
    (n >= 0.0 && n.fract() == 0.0 && n < 1e9).then_some((n as usize, dt))
}

/// The units word of a header line, if it names one.
fn units_word(line: &str) -> Option<String> {
    let upper = line.to_ascii_uppercase();
    let after = if let Some(p) = upper.find("UNITS OF") {
        &line[p + "UNITS OF".len()..]
    } else if let Some(p) = upper.find("UNITS ARE") {
        &line[p + "UNITS ARE".len()..]
    } else {
        return None;
    };
    after
        .split_whitespace()
        .next()
        .map(|w| w.trim_end_matches([',', '.']).to_string())
}

/// PEER component labels: azimuths (`000`, `067`), `UP`/`DWN`/`V`, or
/// quadrant bearings.
fn component_direction(component: &str) -> Option<Direction> {
    let c = component.trim().to_ascii_uppercase();
    match c.as_str() {
        "DWN" | "DOWN" => Some(Direction::Down),
        _ => Direction::parse(&c),
    }
}

/// File name without directories or extension (member name when inside a zip).
pub(crate) fn file_stem(source: &SourceRef) -> String {
    let name = source.member.as_deref().unwrap_or(&source.file);
    let base = name.rsplit(['/', '\\', ':']).next().unwrap_or(name);
    let stem = match base.rfind('.') {
        Some(p) if p > 0 => &base[..p],
        _ => base,
    };
    if stem.is_empty() {
        "at2".to_string()
    } else {
        stem.to_string()
    }
}
