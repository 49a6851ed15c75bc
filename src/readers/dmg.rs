//! CSMIP / CDMG (California strong-motion programme) volume 1, 2 and 3
//! files, old upper-case (1979–1992) and modern layouts, one or several
//! channels per file.  Each channel block is:
//! - a text header (about 25 lines; its length varies: the second recorder's
//!   Meloland files repeat `(STA CHN: n)` on a line of its own, modern files
//!   wrap the last line), which names the recorder channel and orientation
//!   (`CHAN  1: 270 DEG`, `Chan 12:  Long`), the station channel
//!   (`(STA CHN: 15)`), the sensor location, the station (`STATION NO. 89324
//!   40.503N, 124.100W …`), the record start (`Start time:` / `TRIGGER TIME:`
//!   with zone), the origin and hypocentre;
//! - 100 integers (16I5: [0] recorder channel, [2] station channel, [26]
//!   orientation: an azimuth in old files, a code in modern ones, [67]/[68]
//!   period and damping counts of a V3);
//! - 100 reals (8F10);
//! - V1: the uncorrected samples, evenly spaced after a `N POINTS OF …`
//!   line, or old film digitisations as uneven `(time, value)` pairs, which
//!   are resampled (linear interpolation at the median step) and flagged;
//! - V2: `N POINTS OF ACCEL DATA EQUALLY SPACED AT .020 SEC. (UNITS:
//!   CM/SEC/SEC)` (modern: `… at 0.010 sec, in cm/sec2. (8f10.6)`) and the
//!   values, then the velocity and displacement blocks (not returned);
//! - V3: damping values, periods, Fourier amplitudes, then per damping the
//!   arrays SD, SV, SA, PSSV, TTSD, TTSV, TTSA (inches and seconds, SA in g);
//! - the line `/&  ----------  END OF DATA FOR CHANNEL  1  ----------`.
//!
//! Channel ids are `{station}.{station channel:02}` (`01336.14`), the same
//! for a V2 record and its V3 spectra.  `location_code` is the station
//! channel number; `channel_code` keeps the recorder's label as printed
//! (`CHAN 12: Long`).  `Long`/`Tran` are the structure's own axes (a
//! bridge's longitudinal and transverse axes) and become X and Y, said in
//! `inferred`; `H1`-style labels give no direction (`missing` lists it).

use super::textfmt::{self, Layout, Lines};
use super::{FileContents, FileSpectrum, ReadOptions};
use crate::error::Result;
use crate::vocab::{Channel, Direction, QaFlag, Record, SourceRef, Units, STANDARD_GRAVITY};

const INT_COUNT: usize = 100;
const REAL_COUNT: usize = 100;
const DEFAULT_DATA_LAYOUT: Layout = Layout::Fixed {
    per_line: 8,
    width: 10,
};
/// Longest text header searched for the integer block.
const MAX_TEXT_LINES: usize = 40;
/// Metres per inch (V3 spectra are in inches).
const METRES_PER_INCH: f64 = 0.0254;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Volume {
    V1,
    V2,
    V3,
}

pub fn read(bytes: &[u8], source: &SourceRef, _opts: &ReadOptions) -> Result<FileContents> {
    textfmt::read_channel_blocks(bytes, source, "empty CSMIP/DMG file", read_channel)
}

fn volume_of(line: &str) -> Option<Volume> {
    let u = line.trim_start().to_ascii_uppercase();
    if u.starts_with("RESPONSE AND FOURIER") {
        Some(Volume::V3)
    } else if u.starts_with("UNCORRECTED ACCELEROGRAM") {
        Some(Volume::V1)
    } else if u.starts_with("CORRECTED ACCELEROGRAM") {
        Some(Volume::V2)
    } else {
        None
    }
}

/// A line of the 16I5 integer block: only integers, no decimal points.
fn is_int_line(line: &str) -> bool {
    let t = line.trim_end();
    !t.trim().is_empty() && !t.contains('.') && {
        let f = textfmt::fixed_fields(t, 5, 16);
        f.len() >= 4 && f.iter().all(|x| textfmt::parse_int(x).is_some())
    }
}

/// Whether `lines` (the head of a file) hold a complete CSMIP header: a
/// volume label on the first line, a `STATION NO.` line and the 16I5
/// integer block within the text-header length.  Used for content sniffing.
pub(crate) fn header_complete(lines: &[&str]) -> bool {
    if lines.first().and_then(|l| volume_of(l)).is_none() {
        return false;
    }
    let end = lines.len().min(MAX_TEXT_LINES);
    match (5..end).find(|&i| is_int_line(lines[i])) {
        Some(int_at) => lines[..int_at]
            .iter()
            .any(|l| l.to_ascii_uppercase().contains("STATION NO.")),
        None => false,
    }
}

/// What the text header says about one channel.
#[derive(Debug, Default)]
struct TextHeader {
    recorder_chan: Option<i64>,
    label: Option<String>,
    station_chan: Option<i64>,
    location: Option<String>,
    station: Option<String>,
    /// The station's name: a header line naming the storeys
    /// ("Sherman Oaks - 13-story Commercial Bldg"), else the line after
    /// `STATION NO.`.
    station_name: Option<String>,
    latitude: Option<f64>,
    longitude: Option<f64>,
    start_ns: Option<i64>,
    /// The `Start time:` line names no time zone (read as UTC, the CSMIP
    /// convention, and cross-checked against `record_ns`).
    start_zone_missing: bool,
    /// The trigger time of the `Rcrd of Thu Jul  4, 2019 10:35:07.3 PDT` line.
    record_ns: Option<i64>,
    origin_ns: Option<i64>,
    event_name: Option<String>,
    hypocenter: Option<(f64, f64, f64)>,
    magnitude: Option<f64>,
}

fn parse_text_header(lines: &Lines, from: usize, to: usize) -> TextHeader {
    let mut h = TextHeader::default();
    let mut v1_marker_line = None;
    for i in from..to {
        let line = lines.get(i);
        let upper = line.to_ascii_uppercase();
        let trimmed = upper.trim_start();
        // "CHAN  1: UP       (STA CHN:  1)     LOCATION: FOOTING OF …"
        if trimmed.starts_with("CHAN") && h.label.is_none() {
            let rest = &line.trim_start()[4..];
            if let Some((num, after)) = rest.split_once(':') {
                h.recorder_chan = textfmt::parse_int(num);
                let cut = [after.find('('), after.to_ascii_uppercase().find("LOCATION")]
                    .into_iter()
                    .flatten()
                    .min();
                let label = match cut {
                    Some(c) => &after[..c],
                    None => after,
                };
                h.label = Some(label.trim().to_string()).filter(|s| !s.is_empty());
            }
            if let Some(p) = upper.find("LOCATION:") {
                h.location = Some(line[p + 9..].trim().to_string()).filter(|s| !s.is_empty());
            }
        }
        if h.station_chan.is_none() {
            if let Some(p) = upper.find("STA CHN:") {
                h.station_chan = textfmt::parse_int(line[p + 8..].split(')').next().unwrap_or(""));
            }
        }
        if h.station_name.is_none() && (upper.contains("STORY") || upper.contains("STOREY")) {
            h.station_name = Some(line.trim().to_string());
        }
        if h.station.is_none() {
            if let Some(p) = upper.find("STATION NO.") {
                let next = lines.get(i + 1).trim();
                let next_upper = next.to_ascii_uppercase();
                if i + 1 < to
                    && !next.is_empty()
                    && !next_upper.starts_with("CHAN")
                    && next.chars().any(|c| c.is_ascii_alphabetic())
                {
                    // "Ridgecrest - Hwy 395/Brown Road Bridge    CGS   Data: Acceleration":
                    // the name ends where the agency column starts (a run of spaces).
                    let name = next.split("   ").next().unwrap_or(next).trim();
                    h.station_name.get_or_insert_with(|| name.to_string());
                }
                let mut it = line[p + 11..].split_whitespace();
                h.station = it
                    .next()
                    .and_then(textfmt::parse_int)
                    .map(|n| format!("{n:05}"));
                h.latitude = it.next().and_then(textfmt::signed_degrees);
                h.longitude = it.next().and_then(textfmt::signed_degrees);
            }
        }
        if h.start_ns.is_none() {
            for key in ["START TIME:", "TRIGGER TIME:"] {
                if let Some(p) = upper.find(key) {
                    let text = &line[p + key.len()..];
                    h.start_ns = zoned_time(text);
                    if h.start_ns.is_none() {
                        // `7/04/19, 17:35:07.3(*LoQ*)`: no zone stated.
                        h.start_ns = zoneless_time_as_utc(text);
                        h.start_zone_missing = h.start_ns.is_some();
                    }
                }
            }
        }
        if h.record_ns.is_none() && upper.trim_start().starts_with("RCRD OF") {
            h.record_ns = record_line_time(line.trim_start()[7..].trim());
        }
        if h.origin_ns.is_none() {
            if let Some(p) = upper.find("(ORIGIN(") {
                if let Some(q) = line[p..].find("):") {
                    h.origin_ns = zoned_time(line[p + q + 2..].trim_end().trim_end_matches(')'));
                }
            }
        }
        if trimmed.starts_with("HYPOCENTER") && h.hypocenter.is_none() {
            if let Some(p) = line.find(':') {
                let parts: Vec<&str> = line[p + 1..].split(',').map(str::trim).collect();
                let lat = parts.first().and_then(|s| textfmt::signed_degrees(s));
                let lon = parts.get(1).and_then(|s| textfmt::signed_degrees(s));
                let depth = textfmt::number_after(&upper, "H=");
                if let (Some(lat), Some(lon), Some(depth)) = (lat, lon, depth) {
                    h.hypocenter = Some((lat, lon, depth));
                }
            }
            h.magnitude = ["MW=", "ML=", "MS=", "M="]
                .iter()
                .find_map(|k| textfmt::number_after(&upper, k));
        }
        if trimmed.starts_with("UNCORRECTED ACCELEROGRAM") && v1_marker_line.is_none() {
            v1_marker_line = Some(i);
        }
    }
    // Old layouts name the event on the line after "UNCORRECTED ACCELEROGRAM DATA";
    // modern ones print "Rcrd of …" there instead.
    if let Some(i) = v1_marker_line {
        let name = lines.get(i + 1).trim();
        let upper = name.to_ascii_uppercase();
        if !name.is_empty()
            && !upper.starts_with("RCRD OF")
            && (upper.contains("EARTHQUAKE") || upper.contains("EQ"))
        {
            h.event_name = Some(name.to_string());
        }
    }
    h
}

/// `7/04/19, 17:35:07.3(*LoQ*)` (no zone) → epoch ns, read as UTC.
fn zoneless_time_as_utc(s: &str) -> Option<i64> {
    let (date, rest) = s.trim().split_once(',')?;
    let time: String = rest
        .trim()
        .chars()
        .take_while(|c| c.is_ascii_digit() || *c == ':' || *c == '.' || *c == ' ')
        .collect();
    textfmt::us_datetime_ns(date, &time, "UTC")
}

/// `Thu Jul  4, 2019 10:35:07.3 PDT` (after `Rcrd of`) → epoch ns.
fn record_line_time(s: &str) -> Option<i64> {
    const MONTHS: [&str; 12] = [
        "JAN", "FEB", "MAR", "APR", "MAY", "JUN", "JUL", "AUG", "SEP", "OCT", "NOV", "DEC",
    ];
    let (before, after) = s.split_once(',')?;
    let mut words = before.split_whitespace();
    let _weekday = words.next()?;
    let month_word = words.next()?.to_ascii_uppercase();
    let month = MONTHS.iter().position(|m| month_word.starts_with(m))? + 1;
    let day: u32 = words.next()?.parse().ok()?;
    let mut rest = after.split_whitespace();
    let year: i64 = rest.next()?.parse().ok()?;
    let time = rest.next()?;
    let zone: String = rest
        .next()?
        .chars()
        .take_while(|c| c.is_ascii_alphabetic())
        .collect();
    textfmt::us_datetime_ns(&format!("{month}/{day}/{year}"), time, &zone)
}

/// `05/02/83, 16:42:48.2 PDT` or ` 9/30/23, 15:26: 1.0 UTC (GPS)` → epoch ns.
fn zoned_time(s: &str) -> Option<i64> {
    let (date, rest) = s.trim().split_once(',')?;
    let zones = ["UTC", "GMT", "PDT", "PST", "UT"];
    let upper = rest.to_ascii_uppercase();
    let (zpos, zone) = zones
        .iter()
        .filter_map(|z| upper.find(z).map(|p| (p, *z)))
        .min_by_key(|(p, _)| *p)?;
    textfmt::us_datetime_ns(date, &rest[..zpos], zone)
}

fn read_channel(
    lines: &Lines,
    b: usize,
    source: &SourceRef,
    contents: &mut FileContents,
) -> Result<usize> {
    let volume = volume_of(lines.get(b)).ok_or_else(|| {
        lines.err(
            b,
            format!(
                "expected a CSMIP header line (\"CORRECTED ACCELEROGRAM …\", \"UNCORRECTED ACCELEROGRAM …\" or \"RESPONSE AND FOURIER …\"), found {:?}",
                lines.get(b).trim()
            ),
        )
    })?;
    // The integer block ends the text header.
    let int_start = (b + 5..(b + MAX_TEXT_LINES).min(lines.len())).find(|&i| is_int_line(lines.get(i))).ok_or_else(|| {
        if lines.len() < b + 10 {
            lines.err(lines.len().saturating_sub(1), "file ends inside the text header (truncated file?)")
        } else {
            lines.err(b, format!("no 16I5 integer header within {MAX_TEXT_LINES} lines of this channel header"))
        }
    })?;
    let th = parse_text_header(lines, b, int_start);

    // Integer header (16I5).
    let mut ints: Vec<i64> = Vec::with_capacity(INT_COUNT);
    let mut i = int_start;
    while ints.len() < INT_COUNT {
        if !lines.exists(i) {
            return Err(lines.err(
                i.saturating_sub(1),
                "file ends inside the integer header (truncated file?)",
            ));
        }
        for f in textfmt::fixed_fields(lines.get(i), 5, 16) {
            ints.push(textfmt::parse_int(&f).ok_or_else(|| {
                lines.err(
                    i,
                    format!("integer header field {:?} is not an integer", f.trim()),
                )
            })?);
        }
        i += 1;
    }
    let reals = textfmt::read_block(lines, i, REAL_COUNT, DEFAULT_DATA_LAYOUT, "real header")?;
    let mut next = reals.next_line;

    let station = th
        .station
        .clone()
        .ok_or_else(|| lines.err(b, "no \"STATION NO.\" line in the text header"))?;
    let station_chan = th
        .station_chan
        .or_else(|| ints.get(2).copied().filter(|&c| c > 0));
    let recorder_chan = th.recorder_chan.or_else(|| ints.first().copied());
    let id = match station_chan {
        Some(c) => format!("{station}.{c:02}"),
        None => format!("{station}.R{:02}", recorder_chan.unwrap_or(0)),
    };

    if contents.event.name.is_none() && contents.event.origin_ns.is_none() {
        contents.event.name = th.event_name.clone();
        contents.event.origin_ns = th.origin_ns;
        contents.event.hypocenter = th.hypocenter;
        contents.event.magnitude = th.magnitude;
    }
    if contents.event.station_name.is_none() {
        contents.event.station_name = th.station_name.clone();
    }
    if contents.event.station_position.is_none() {
        contents.event.station_position = th.latitude.zip(th.longitude);
    }

    match volume {
        Volume::V3 => {
            next = read_spectra(lines, next, &ints, &id, contents)?;
        }
        Volume::V1 | Volume::V2 => {
            let (record, after) = read_series(lines, next, volume, &id, source)?;
            contents.records.push(Record::new(
                fill_channel(record.0, &th, &ints, station, station_chan, recorder_chan),
                record.1,
            ));
            next = after;
        }
    }
    // Skip to the end-of-channel line "/& … END OF DATA …".
    while lines.exists(next) && lines.get(next).trim().is_empty() {
        next += 1;
    }
    if lines.exists(next) {
        if lines.get(next).trim_start().starts_with("/&") {
            next += 1;
        } else if volume_of(lines.get(next)).is_none() {
            let what = if textfmt::is_numeric_line(lines.get(next)) {
                "more values than the header declares"
            } else {
                "unexpected text"
            };
            return Err(lines.err_ch(
                next,
                &id,
                format!(
                    "{what}: expected the end-of-channel line \"/& … END OF DATA …\", found {:?}",
                    lines.get(next).trim()
                ),
            ));
        }
    }
    Ok(next)
}

/// A `N POINTS OF ACCEL DATA EQUALLY SPACED AT .020 SEC. (UNITS: CM/SEC/SEC)` line.
struct Section {
    npts: usize,
    kind: String,
    dt: Option<f64>,
    units: Option<String>,
    layout: Layout,
    evenly: bool,
}

fn parse_section(line: &str) -> Option<Section> {
    let upper = line.to_ascii_uppercase();
    if !upper.contains("POINTS OF") {
        return None;
    }
    let npts = textfmt::split_free(line)
        .first()
        .and_then(|t| textfmt::parse_int(t))
        .filter(|&n| n > 0)? as usize;
    let kind = upper
        .split("POINTS OF")
        .nth(1)?
        .split_whitespace()
        .next()?
        .to_string();
    let dt = textfmt::number_after(&upper, "SPACED AT");
    let units = if let Some(p) = upper.find("UNITS:") {
        Some(
            line[p + 6..]
                .trim()
                .trim_end_matches(')')
                .trim()
                .to_string(),
        )
    } else if let Some(p) = upper.find(", IN ") {
        // "… at 0.010 sec, in cm/sec2. (8f10.6)"
        line[p + 5..]
            .split_whitespace()
            .next()
            .map(|w| w.trim_end_matches('.').to_string())
    } else if let Some(p) = upper.find("UNITS OF") {
        line[p + 8..]
            .split_whitespace()
            .next()
            .map(|w| w.trim_end_matches('.').to_string())
    } else {
        None
    };
    let layout = line
        .rfind('(')
        .and_then(|p| {
            let inner = &line[p..];
            let lower = inner.to_ascii_lowercase();
            (!lower.contains("units"))
                .then(|| Layout::from_fortran(inner))
                .flatten()
        })
        .unwrap_or(DEFAULT_DATA_LAYOUT);
    Some(Section {
        npts,
        kind,
        dt,
        units,
        layout,
        evenly: upper.contains("EQUALLY"),
    })
}

/// Units word of a CSMIP data section; `G/10` (old film digitisations) is
/// returned as g with a scale of 0.1.
fn section_units(word: &str) -> std::result::Result<(Units, f64), String> {
    let w = word.trim().to_ascii_uppercase();
    if w == "G/10" {
        return Ok((Units::G, 0.1));
    }
    textfmt::units_from_text(word).map(|u| (u, 1.0))
}

type ChannelSamples = (Channel, Vec<f64>);

/// Reads the acceleration series of a V1/V2 channel starting at line `at`
/// (after the real header); returns it and the line after the last section.
fn read_series(
    lines: &Lines,
    at: usize,
    volume: Volume,
    id: &str,
    source: &SourceRef,
) -> Result<(ChannelSamples, usize)> {
    let mut i = at;
    while lines.exists(i) && lines.get(i).trim().is_empty() {
        i += 1;
    }
    if !lines.exists(i) {
        return Err(lines.err_ch(
            i.saturating_sub(1),
            id,
            "file ends before the data (truncated file?)",
        ));
    }
    let mut inferred = Vec::new();
    let mut qa = Vec::new();
    let first = lines.get(i);
    let mut accel: Option<(Units, f64, Vec<f64>)> = None;
    if let Some(sec) = parse_section(first) {
        // One or more sections: accel (kept), veloc and displ (skipped).
        let mut cur = Some((i, sec));
        let mut after = i;
        while let Some((head, sec)) = cur.take() {
            let block = textfmt::read_block(lines, head + 1, sec.npts, sec.layout, id)?;
            if block.extra_on_last_line > 0 {
                return Err(lines.err_ch(
                    block.next_line - 1,
                    id,
                    format!(
                        "more values than the {} points the section header declares",
                        sec.npts
                    ),
                ));
            }
            after = block.next_line;
            if sec.kind.starts_with("ACCEL") && accel.is_none() {
                let word = sec.units.clone().ok_or_else(|| {
                    lines.err_ch(head, id, "no units on the acceleration data line")
                })?;
                let (units, scale) = section_units(&word)
                    .map_err(|e| lines.err_ch(head, id, format!("unknown units {word:?}: {e}")))?;
                if scale != 1.0 {
                    inferred.push(format!(
                        "values scaled by {scale} (file stores {word}) to {units}"
                    ));
                }
                if !sec.evenly {
                    return Err(lines.err_ch(
                        head,
                        id,
                        "acceleration section is not equally spaced and carries no times",
                    ));
                }
                let dt = sec.dt.filter(|d| *d > 0.0).ok_or_else(|| {
                    lines.err_ch(head, id, "no positive sampling interval on the data line")
                })?;
                let values: Vec<f64> = block.values.iter().map(|v| v * scale).collect();
                accel = Some((units, 1.0 / dt, values));
            }
            let mut n = after;
            while lines.exists(n) && lines.get(n).trim().is_empty() {
                n += 1;
            }
            if let Some(s) = parse_section(lines.get(n)) {
                cur = Some((n, s));
            }
        }
        i = after;
    } else if volume == Volume::V1 && textfmt::is_numeric_line(first) {
        // Old film digitisations: (time, value) pairs up to the end-of-channel line.
        let mut end = i;
        while lines.exists(end) && textfmt::is_numeric_line(lines.get(end)) {
            end += 1;
        }
        let mut values = Vec::new();
        for k in i..end {
            values.extend(
                textfmt::line_values(lines.get(k), Layout::Free)
                    .map_err(|(f, _)| lines.err_ch(k, id, format!("bad value {f:?}")))?,
            );
        }
        if values.len() % 2 != 0 || values.len() < 4 {
            return Err(lines.err_ch(
                end.saturating_sub(1),
                id,
                format!("{} numbers do not form (time, value) pairs", values.len()),
            ));
        }
        let raw_times: Vec<f64> = values.iter().step_by(2).copied().collect();
        let raw_accel: Vec<f64> = values.iter().skip(1).step_by(2).copied().collect();
        if !super::resample::looks_like_pair_times(&raw_times) {
            let backwards = raw_times.windows(2).filter(|w| w[1] < w[0]).count();
            return Err(lines.err_ch(
                i,
                id,
                format!(
                    "the (time, value) pairs' times do not go forward: {backwards} of {} steps go backwards (at most 5 % are dropped as digitising slips)",
                    raw_times.len() - 1
                ),
            ));
        }
        // Repeated stamps merged, backwards ones dropped (noted).
        let (times, accel_raw, cleaning) =
            super::resample::clean_pair_times(&raw_times, &raw_accel);
        if !cleaning.is_clean() {
            qa.push(QaFlag::Note {
                text: cleaning.describe(&format!("{}", lines.source())),
            });
        }
        // Units from the text header ("UNITS OF UNCOR ACCEL ARE SEC AND G/10").
        let word = th_units_word(lines, at).ok_or_else(|| {
            lines.err_ch(
                i,
                id,
                "no units statement (\"UNITS OF … ARE SEC AND …\") for the (time, value) pairs",
            )
        })?;
        let (units, scale) = section_units(&word)
            .map_err(|e| lines.err_ch(i, id, format!("unknown units {word:?}: {e}")))?;
        let mut steps: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
        steps.sort_by(f64::total_cmp);
        let dt = steps[steps.len() / 2];
        let span = times[times.len() - 1] - times[0];
        super::resample::check_grid(times.len(), span, dt).map_err(|m| lines.err_ch(i, id, m))?;
        let uniform: Vec<f64> = super::resample::resample_linear(&times, &accel_raw, dt)
            .into_iter()
            .map(|v| v * scale)
            .collect();
        qa.push(QaFlag::Resampled {
            from: "uneven (time,value) pairs".into(),
        });
        inferred.push(format!(
            "samples resampled from {} uneven (time,value) pairs onto a uniform grid dt={dt} s (median step) by linear interpolation{}",
            times.len(),
            if scale != 1.0 { format!("; values scaled by {scale} (file stores {word})") } else { String::new() }
        ));
        accel = Some((units, 1.0 / dt, uniform));
        i = end;
    } else {
        return Err(lines.err_ch(
            i,
            id,
            format!(
                "expected the data line \"N POINTS OF ACCEL DATA …\", found {:?}",
                first.trim()
            ),
        ));
    }
    let (units, rate, values) =
        accel.ok_or_else(|| lines.err_ch(at, id, "the channel has no acceleration section"))?;
    let mut channel = Channel::new(id, units, rate, source.clone());
    channel.inferred = inferred;
    channel.qa = qa;
    Ok(((channel, values), i))
}

/// Units word stated in an old V1 text header (`UNITS OF UNCOR ACCEL ARE SEC AND G/10.`),
/// searched backwards from the data.
fn th_units_word(lines: &Lines, before: usize) -> Option<String> {
    (before.saturating_sub(60)..before).rev().find_map(|k| {
        let u = lines.get(k).to_ascii_uppercase();
        let p = u.find("ARE SEC AND")?;
        u[p + 11..]
            .split_whitespace()
            .next()
            .map(|w| w.trim_end_matches(['.', ',']).to_string())
    })
}

fn fill_channel(
    mut channel: Channel,
    th: &TextHeader,
    ints: &[i64],
    station: String,
    station_chan: Option<i64>,
    recorder_chan: Option<i64>,
) -> Channel {
    channel.network = Some("CE".into());
    channel.station = Some(station);
    channel.location_code = station_chan.map(|c| c.to_string());
    let label = th.label.clone();
    channel.channel_code = match (recorder_chan, &label) {
        (Some(r), Some(l)) => Some(format!("CHAN {r}: {l}")),
        (None, Some(l)) => Some(l.clone()),
        (Some(r), None) => Some(format!("CHAN {r}")),
        (None, None) => None,
    };
    channel.location_text = th.location.clone();
    channel.direction = label.as_deref().and_then(label_direction).or_else(|| {
        // Old layouts state the azimuth in integer [26] (500 = up).
        match ints.get(26).copied() {
            Some(500) if label.is_none() => Some(Direction::Up),
            Some(a) if label.is_none() && (0..=360).contains(&a) => {
                Some(Direction::Azimuth((a as f64).rem_euclid(360.0)))
            }
            _ => None,
        }
    });
    if let (Some(Direction::Axis(a)), Some(l)) = (channel.direction, &label) {
        channel.inferred.push(format!(
            "direction {a:?} from the recorder label {l:?} (the structure's {} axis: Long = X, Tran = Y)",
            if a == crate::vocab::Axis::X { "longitudinal" } else { "transverse" }
        ));
    }
    if channel.direction.is_none() {
        channel.missing.push("direction".into());
    }
    channel.start_ns = th.start_ns;
    if let Some(start) = th.start_ns {
        // Cross-check the start against the trigger time the `Rcrd of` line
        // states with its zone: the record starts at (or shortly before) the
        // trigger, so they agree within a minute (a time-zone slip is hours).
        let zone = if th.start_zone_missing {
            "no zone stated, read as UTC"
        } else {
            "zone as stated"
        };
        match th.record_ns {
            Some(rec) if (rec - start).abs() <= 60_000_000_000 => channel.inferred.push(format!(
                "start time ({zone}) agrees with the zoned `Rcrd of` trigger time"
            )),
            Some(rec) => channel.qa.push(QaFlag::Note {
                text: format!(
                    "start time ({zone}) differs by {:.0} s from the `Rcrd of` trigger time: one of them may be off by a time-zone offset",
                    (rec - start) as f64 / 1e9
                ),
            }),
            None if th.start_zone_missing => channel.inferred.push(
                "start time: no zone stated, read as UTC (CSMIP convention; no other time in the header to check it against)".into(),
            ),
            None => {}
        }
    }
    if channel.start_ns.is_none() {
        channel.missing.push("start_time".into());
    }
    channel
}

/// `270 DEG`, `360 DEG`, `UP`, `Up`, `DOWN`; `Long` and `Tran` name the
/// structure's own axes (a bridge's longitudinal and transverse axes: X and
/// Y, said in `inferred` by the caller); `H1`, `RADL`… give none.
fn label_direction(label: &str) -> Option<Direction> {
    let u = label.trim().to_ascii_uppercase();
    match u.as_str() {
        "LONG" => return Some(Direction::Axis(crate::vocab::Axis::X)),
        "TRAN" => return Some(Direction::Axis(crate::vocab::Axis::Y)),
        "H1" | "H2" | "RADL" | "TANG" => return None,
        _ => {}
    }
    Direction::parse(&u)
}

/// Reads a V3 spectra block starting after the real header.
fn read_spectra(
    lines: &Lines,
    at: usize,
    ints: &[i64],
    id: &str,
    contents: &mut FileContents,
) -> Result<usize> {
    // Units statement in the text header.
    let units_ok = (at.saturating_sub(130)..at).any(|k| {
        let u = lines.get(k).to_ascii_uppercase();
        u.contains("UNITS FOR SPECTRA ARE INCHES AND SEC") && u.contains("SA IS IN FRACTION OF G")
    });
    if !units_ok {
        return Err(lines.err_ch(
            at,
            id,
            "no \"Units for spectra are inches and sec, except Sa is in fraction of g\" statement",
        ));
    }
    let n_damp = ints
        .get(68)
        .copied()
        .filter(|&n| (1..=20).contains(&n))
        .unwrap_or(5) as usize;
    let damp_block = textfmt::read_block(lines, at, n_damp, DEFAULT_DATA_LAYOUT, id)?;
    // Periods: every number up to the "Fourier amplitude spectra" line.
    let mut i = damp_block.next_line;
    let mut periods_all = Vec::new();
    while lines.exists(i) && textfmt::is_numeric_line(lines.get(i)) {
        periods_all.extend(
            textfmt::line_values(lines.get(i), DEFAULT_DATA_LAYOUT)
                .map_err(|(f, _)| lines.err_ch(i, id, format!("bad period {f:?}")))?,
        );
        i += 1;
    }
    if !lines.get(i).to_ascii_uppercase().starts_with("FOURIER") {
        return Err(lines.err_ch(
            i,
            id,
            format!(
                "expected \"FOURIER AMPLITUDE SPECTRA …\" after the periods, found {:?}",
                lines.get(i).trim()
            ),
        ));
    }
    let block_len = periods_all.len();
    let leading = periods_all.iter().take_while(|&&p| p > 0.0).count();
    let n_periods = ints
        .get(67)
        .copied()
        .filter(|&n| n > 0 && (n as usize) <= leading)
        .map(|n| n as usize)
        .unwrap_or(leading);
    if n_periods == 0 {
        return Err(lines.err_ch(i, id, "no positive periods in the spectra"));
    }
    let periods = periods_all[..n_periods].to_vec();
    // Fourier amplitudes (not kept).
    let fourier = textfmt::read_block(lines, i + 1, block_len, DEFAULT_DATA_LAYOUT, id)?;
    let mut i = fourier.next_line;
    for &damping in &damp_block.values {
        let head = lines.get(i);
        let upper = head.to_ascii_uppercase();
        if !upper.starts_with("DAMPING") {
            return Err(lines.err_ch(
                i,
                id,
                format!(
                    "expected \"DAMPING = … DATA OF SD,SV,SA,PSSV,…\", found {:?}",
                    head.trim()
                ),
            ));
        }
        let stated = textfmt::number_after(&upper, "DAMPING =")
            .or_else(|| textfmt::number_after(&upper, "DAMPING="));
        if stated.is_some_and(|d| (d - damping).abs() > 0.006) {
            return Err(lines.err_ch(
                i,
                id,
                format!(
                    "damping {} differs from the header's list value {damping}",
                    stated.unwrap_or(f64::NAN)
                ),
            ));
        }
        let data = textfmt::read_block(lines, i + 1, 7 * block_len, DEFAULT_DATA_LAYOUT, id)?;
        // Arrays in order SD, SV, SA, PSSV, TTSD, TTSV, TTSA; SD in inches.
        let sd = &data.values[..n_periods];
        let psa: Vec<f64> = sd
            .iter()
            .zip(&periods)
            .map(|(d, t)| {
                (2.0 * std::f64::consts::PI / t).powi(2) * d * METRES_PER_INCH / STANDARD_GRAVITY
            })
            .collect();
        contents.spectra.push(FileSpectrum {
            channel_id: id.to_string(),
            damping,
            periods_s: periods.clone(),
            psa,
            units: "g".into(),
        });
        i = data.next_line;
    }
    Ok(i)
}
