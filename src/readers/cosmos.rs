//! COSMOS strong-motion format v1.20 (V0 raw counts, V1 uncorrected, V2
//! corrected), one or more channels per file.  Each channel block is:
//! - text header, its length stated on line 1 (`(Format v01.20 with 13 text
//!   lines)`): event name, origin, `Statn No: … Code:NP-8040 …`, record start,
//!   `Sta Chan   1: 90 Deg (Rcrdr Chan  ?) Location:Basement NW corner`, and
//!   on the last text line the codes used for unknown values (`-999, -999.00`);
//! - `100 Integer-header values follow on 10 lines, Format= (10I8)`;
//! - `100 Real-header values follow on 20 lines, Format= (5F15.6)`;
//! - `2 Comment line(s) follow, each starting with a "|":` (a `<SCNL>` comment
//!   names station, channel, network, location);
//! - `42000 raw accel. pts, approx 210 secs, units= counts(50),Format=(1I8)`
//!   and the samples in that Fortran format;
//! - an `End-of-data` line.
//!
//! Header indices used (0-based, COSMOS v1.20 tables): integers [1] data
//! type (1 acceleration, 2 velocity, 3 displacement), [2] physical units,
//! [19]/[20] reference azimuths, [39] year, [40] day of year, [43] hour,
//! [44] minute, [18] station/structure type (10 building, 11 bridge…: the event
//! folder reads the kind of structure from it), [49] station channel number, [53] orientation from north
//! (or a code: 400 up … 700 H1), [54] orientation from the reference,
//! [55] location index; reals [0..3] station latitude, longitude, elevation
//! (m), [9..13] hypocentre and magnitude, [21] recorder LSB (µV/count), [29]
//! start second, [41] sensor sensitivity (V/g), [46] gain, [61] sampling
//! interval (ms).
//!
//! The record start is taken from the integer/real header and cross-checked
//! against the text line `Rcrd start time: … UTC`; a difference above 5 ms
//! is a `QaFlag::Note` (the header value is kept).

use super::textfmt::{self, Layout, Lines};
use super::{EventHints, FileContents, ReadOptions};
use crate::error::Result;
use crate::vocab::{
    epoch_ns_from_ordinal, format_epoch_ns, parse_iso8601_ns, Channel, Direction, QaFlag, Record,
    SourceRef, Units, STANDARD_GRAVITY,
};

/// Largest difference between the two start times a COSMOS header states
/// (integer/real fields and the `Rcrd start time:` text, printed to the
/// millisecond) before it is flagged.
const START_TOLERANCE_NS: i64 = 5_000_000;

pub fn read(bytes: &[u8], source: &SourceRef, _opts: &ReadOptions) -> Result<FileContents> {
    textfmt::read_channel_blocks(bytes, source, "empty COSMOS file", read_channel)
}

/// A numeric header block announced by a line such as
/// ` 100 Integer-header values follow on  10 lines, Format= (10I8)`.
fn header_block(lines: &Lines, at: usize, what: &str) -> Result<(Vec<f64>, usize)> {
    let line = lines.get(at);
    if !lines.exists(at)
        || !line
            .to_ascii_lowercase()
            .contains(&what.to_ascii_lowercase())
    {
        return Err(lines.err(
            at,
            format!(
                "expected the \"… {what} values follow on … lines, Format= (…)\" line, found {:?}",
                line.trim()
            ),
        ));
    }
    let count = textfmt::split_free(line)
        .first()
        .and_then(|t| textfmt::parse_int(t))
        .filter(|&n| n > 0);
    let layout = line
        .find("Format=")
        .and_then(|p| Layout::from_fortran(&line[p + "Format=".len()..]));
    let (Some(count), Some(layout)) = (count, layout) else {
        return Err(lines.err(
            at,
            format!(
                "cannot read the value count and Fortran format of {:?}",
                line.trim()
            ),
        ));
    };
    let block = textfmt::read_block(lines, at + 1, count as usize, layout, what)?;
    Ok((block.values, block.next_line))
}

/// Reads the channel block starting at 0-based line `b`: text header, integer and real
/// headers, comments, data header and samples; an acceleration channel becomes a record.
/// Returns the line after the block.
fn read_channel(
    lines: &Lines,
    b: usize,
    source: &SourceRef,
    contents: &mut FileContents,
) -> Result<usize> {
    let n_text = text_header_length(lines, b)?;
    let text_line = |k: usize| lines.get(b + k);
    let header = numeric_header(lines, b, n_text)?;
    // Line of the integer header's first values, named by header-value errors.
    let header_values_at = b + n_text + 1;
    let (comments, data_head_at) = comment_lines(lines, header.next_line)?;
    let (npts, layout) = data_header(lines, data_head_at)?;
    let data_head = lines.get(data_head_at);

    let identity = Identity::read(&comments, text_line(4));
    let chan_line = ChannelLine::read(text_line(8), &header);
    let units = units(lines, &header, data_head_at, header_values_at)?;
    let rate = 1.0 / sampling_interval(lines, &header, data_head, npts, header_values_at)?;

    let mut inferred = Vec::new();
    let (direction, code_orientation) = direction(
        &header,
        chan_line.orientation_text.as_deref(),
        identity.scnl_channel.as_deref(),
        &mut inferred,
    );
    let channel_code = channel_code(rate, direction, code_orientation);
    if let (Some(c), Some(s)) = (&channel_code, &identity.scnl_channel) {
        if c != s {
            inferred.push(format!("channel_code={c} from orientation and {rate} Hz (gmprocess convention); the SCNL comment says {s}"));
        }
    }

    let location_code = identity
        .scnl_location
        .clone()
        .or_else(|| header.int_at(55).map(|l| format!("{l:02}")))
        .or_else(|| chan_line.sta_chan.map(|c| format!("{c:02}")));
    let id = channel_id(
        &identity,
        location_code.as_deref(),
        channel_code.as_deref(),
        source,
    );

    let (values, next) = samples(lines, data_head_at, npts, layout, &id)?;

    // Only acceleration channels become records.
    if !is_acceleration(&header, data_head, &units) {
        return Ok(next);
    }

    if contents.event.station_name.is_none() {
        contents.event.station_name = identity.station_name.clone();
    }
    if contents.event.structure_kind.is_none() {
        contents.event.structure_kind = header.int_at(18).and_then(structure_kind);
    }
    let units = calibrate_counts(units, &header, &mut inferred);
    let mut channel = Channel::new(id, units, rate, source.clone());
    channel.network = identity.network;
    channel.station = identity.station;
    channel.location_code = location_code;
    channel.channel_code = channel_code;
    channel.location_text = chan_line.location_text.or(identity.station_name);
    channel.direction = direction;
    if direction.is_none() {
        channel.missing.push("direction".into());
    }
    channel.elevation_m = header.real_at(2);
    set_start_time(&mut channel, &header, text_line(7));
    channel.inferred = inferred;
    contents.records.push(Record::new(channel, values));

    if contents.event.name.is_none() {
        fill_event(&mut contents.event, &header, text_line);
    }
    Ok(next)
}

/// Channel id `network.station.location.channel`: "--" for an unknown network or location,
/// the file stem for an unknown station, the SCNL channel (else "CH") without a channel code.
fn channel_id(
    identity: &Identity,
    location_code: Option<&str>,
    channel_code: Option<&str>,
    source: &SourceRef,
) -> String {
    format!(
        "{}.{}.{}.{}",
        identity.network.as_deref().unwrap_or("--"),
        identity
            .station
            .clone()
            .unwrap_or_else(|| super::at2::file_stem(source)),
        location_code.unwrap_or("--"),
        channel_code
            .map(str::to_string)
            .or_else(|| identity.scnl_channel.clone())
            .unwrap_or_else(|| "CH".into())
    )
}

/// Data type integer [1] (1 acceleration, 2 velocity, 3 displacement), else the data
/// header's words; and units of acceleration.
fn is_acceleration(header: &NumericHeader, data_head: &str, units: &Units) -> bool {
    let data_type = header.int_at(1);
    let head_lower = data_head.to_ascii_lowercase();
    let is_accel = match data_type {
        Some(1) => true,
        Some(_) => false,
        None => head_lower.contains("accel"),
    };
    is_accel && units.is_acceleration()
}

/// Length of the text header from the block's first line "… (Format v01.20 with 13 text
/// lines)" (13 when unstated or outside 3..=100); the file must hold the whole text header.
fn text_header_length(lines: &Lines, b: usize) -> Result<usize> {
    let first = lines.get(b);
    let lower = first.to_ascii_lowercase();
    let Some(p) = lower.find("(format v") else {
        return Err(lines.err(b, format!("expected a COSMOS header line \"… (Format v01.20 with 13 text lines)\", found {:?}", first.trim())));
    };
    // "(Format v01.20 with 13 text lines)"
    let n_text = textfmt::number_after(&lower[p..], "with")
        .map(|n| n as usize)
        .filter(|&n| (3..=100).contains(&n))
        .unwrap_or(13);
    if !lines.exists(b + n_text) {
        return Err(lines.err(
            lines.len().saturating_sub(1),
            "file ends inside the COSMOS text header (truncated file?)",
        ));
    }
    Ok(n_text)
}

/// The integer and real headers of a channel with the codes its text header gives for
/// unknown values.
struct NumericHeader {
    ints: Vec<f64>,
    reals: Vec<f64>,
    int_unknown: f64,
    real_unknown: f64,
    /// 0-based line after the real header.
    next_line: usize,
}

impl NumericHeader {
    /// Integer header value `k` (0-based), `None` when it holds the unknown code.
    fn int_at(&self, k: usize) -> Option<i64> {
        self.ints
            .get(k)
            .copied()
            .filter(|&v| v != self.int_unknown)
            .map(|v| v as i64)
    }

    /// Real header value `k` (0-based), `None` when it holds the unknown code.
    fn real_at(&self, k: usize) -> Option<f64> {
        self.reals
            .get(k)
            .copied()
            .filter(|&v| (v - self.real_unknown).abs() > 1e-9)
    }
}

/// The unknown-value codes from the last text line ("Values used when parameter or data
/// value is unknown/unspecified:   -999, -999.00"; −999 when absent), then the integer and
/// real header blocks that follow the `n_text` text lines.
fn numeric_header(lines: &Lines, b: usize, n_text: usize) -> Result<NumericHeader> {
    let unknown_line = lines.get(b + n_text - 1);
    let unknowns: Vec<f64> = unknown_line
        .split(':')
        .nth(1)
        .map(|s| {
            s.split(',')
                .filter_map(|t| textfmt::parse_number(t).ok())
                .collect()
        })
        .unwrap_or_default();
    let int_unknown = unknowns.first().copied().unwrap_or(-999.0);
    let real_unknown = unknowns.get(1).copied().unwrap_or(-999.0);

    let (ints, after_ints) = header_block(lines, b + n_text, "Integer-header")?;
    let (reals, after_reals) = header_block(lines, after_ints, "Real-header")?;
    Ok(NumericHeader {
        ints,
        reals,
        int_unknown,
        real_unknown,
        next_line: after_reals,
    })
}

/// The "N Comment line(s) follow" line at `at` and the comment lines after it; returns
/// them and the 0-based line of the data header.
fn comment_lines<'a>(lines: &Lines<'a>, at: usize) -> Result<(Vec<&'a str>, usize)> {
    let comment_head = lines.get(at);
    if !comment_head.to_ascii_lowercase().contains("comment") {
        return Err(lines.err(
            at,
            format!(
                "expected the \"N Comment line(s) follow\" line, found {:?}",
                comment_head.trim()
            ),
        ));
    }
    let n_comments = textfmt::split_free(comment_head)
        .first()
        .and_then(|t| textfmt::parse_int(t))
        .filter(|&n| n >= 0)
        .ok_or_else(|| lines.err(at, "cannot read the number of comment lines"))?
        as usize;
    // The count is the header's word: check it against the lines there are
    // before collecting them (a claimed 10¹² must not reach the allocator).
    if n_comments >= lines.len().saturating_sub(at) {
        return Err(lines.err(
            at,
            format!(
                "the header announces {n_comments} comment lines; the file has {} lines after it (truncated file or corrupt count)",
                lines.len().saturating_sub(at + 1)
            ),
        ));
    }
    let comments: Vec<&str> = (at + 1..at + 1 + n_comments)
        .map(|i| lines.get(i))
        .collect();
    Ok((comments, at + 1 + n_comments))
}

/// Data header at `at`: "   42000 raw accel.   pts, approx  210 secs, units=
/// counts(50),Format=(1I8)": the number of points and the Fortran layout of the samples.
fn data_header(lines: &Lines, at: usize) -> Result<(usize, Layout)> {
    if !lines.exists(at) {
        return Err(lines.err(
            lines.len().saturating_sub(1),
            "file ends before the data block (truncated file?)",
        ));
    }
    let data_head = lines.get(at);
    let npts = textfmt::split_free(data_head)
        .first()
        .and_then(|t| textfmt::parse_int(t))
        .filter(|&n| n > 0)
        .ok_or_else(|| {
            lines.err(
                at,
                format!(
                    "cannot read the number of points from {:?}",
                    data_head.trim()
                ),
            )
        })? as usize;
    let layout = data_head
        .to_ascii_lowercase()
        .find("format=")
        .and_then(|p| Layout::from_fortran(&data_head[p + "format=".len()..]))
        .ok_or_else(|| {
            lines.err(
                at,
                format!(
                    "no Fortran Format=(…) on the data header {:?}",
                    data_head.trim()
                ),
            )
        })?;
    Ok((npts, layout))
}

/// Station identity: the `<SCNL>` comment (station.channel.network.location), else
/// "Code:NP-8040" on the station line, which also names the station.
struct Identity {
    station: Option<String>,
    network: Option<String>,
    scnl_channel: Option<String>,
    scnl_location: Option<String>,
    station_name: Option<String>,
}

impl Identity {
    fn read(comments: &[&str], station_line: &str) -> Identity {
        let scnl = comments.iter().find_map(|c| {
            c.find("<SCNL>").map(|p| {
                c[p + 6..]
                    .split_whitespace()
                    .next()
                    .unwrap_or("")
                    .to_string()
            })
        });
        let (mut station, mut network, mut scnl_channel, mut scnl_location) =
            (None, None, None, None);
        if let Some(s) = &scnl {
            // station.channel.network.location
            let parts: Vec<&str> = s.split('.').collect();
            if parts.len() == 4 {
                station = Some(parts[0].to_string());
                scnl_channel = Some(parts[1].to_string());
                network = Some(parts[2].to_string());
                scnl_location = Some(parts[3].to_string()).filter(|l| !l.is_empty() && l != "--");
            }
        }
        if let Some(p) = station_line.find("Code:") {
            let code = station_line[p + 5..]
                .split_whitespace()
                .next()
                .unwrap_or("");
            if let Some((net, sta)) = code.split_once('-') {
                network.get_or_insert_with(|| net.to_string());
                station.get_or_insert_with(|| sta.to_string());
            }
        }
        let station_name = station_line
            .find("Code:")
            .map(|p| {
                station_line[p..]
                    .split_whitespace()
                    .skip(2)
                    .collect::<Vec<_>>()
                    .join(" ")
            })
            .filter(|s| !s.is_empty());
        Identity {
            station,
            network,
            scnl_channel,
            scnl_location,
            station_name,
        }
    }
}

/// The text header's channel line "Sta Chan   1: 90 Deg (Rcrdr Chan  ?) Location:Basement
/// NW corner".
struct ChannelLine {
    /// Station channel number (else integer header [49]).
    sta_chan: Option<i64>,
    orientation_text: Option<String>,
    location_text: Option<String>,
}

impl ChannelLine {
    fn read(chan_line: &str, header: &NumericHeader) -> ChannelLine {
        let sta_chan = textfmt::number_after(chan_line, "Sta Chan")
            .map(|v| v as i64)
            .or_else(|| header.int_at(49));
        let orientation_text = chan_line
            .find(':')
            .map(|p| {
                chan_line[p + 1..]
                    .split('(')
                    .next()
                    .unwrap_or("")
                    .trim()
                    .to_string()
            })
            .filter(|s| !s.is_empty());
        let location_text = chan_line
            .find("Location:")
            .map(|p| chan_line[p + 9..].trim().to_string())
            .filter(|s| !s.is_empty());
        ChannelLine {
            sta_chan,
            orientation_text,
            location_text,
        }
    }
}

/// Units: integer header [2], cross-checked with the data header's `units=` word (a
/// contradiction is an error).
fn units(
    lines: &Lines,
    header: &NumericHeader,
    data_head_at: usize,
    header_values_at: usize,
) -> Result<Units> {
    let data_head = lines.get(data_head_at);
    let units_text = data_head.to_ascii_lowercase().find("units=").map(|p| {
        let rest = &data_head[p + 6..];
        rest.split(',').next().unwrap_or("").trim().to_string()
    });
    let units = match header.int_at(2) {
        Some(50) => Units::Counts {
            counts_per_si: None,
        },
        Some(4) | Some(10) => Units::CmPerS2,
        Some(2) => Units::G,
        Some(5) => Units::CmPerS,
        Some(6) => Units::Cm,
        Some(code) => {
            return Err(lines.err(
                header_values_at,
                format!(
                    "COSMOS physical-units code {code} ({}) is not a units quaketwin reads",
                    units_text.clone().unwrap_or_default()
                ),
            ))
        }
        None => {
            let word = units_text.clone().ok_or_else(|| {
                lines.err(
                    data_head_at,
                    "no units code in the header and no units= on the data line",
                )
            })?;
            textfmt::units_from_text(&word)
                .map_err(|e| lines.err(data_head_at, format!("unknown units {word:?}: {e}")))?
        }
    };
    if let Some(word) = &units_text {
        if let Ok(stated) = textfmt::units_from_text(word) {
            if std::mem::discriminant(&stated) != std::mem::discriminant(&units) {
                return Err(lines.err(
                    data_head_at,
                    format!("data line says units {word:?} but the header code says {units}"),
                ));
            }
        }
    }
    Ok(units)
}

/// Sampling interval (s): real [61] in ms, else the data header's "approx N secs" over the
/// point count.
fn sampling_interval(
    lines: &Lines,
    header: &NumericHeader,
    data_head: &str,
    npts: usize,
    header_values_at: usize,
) -> Result<f64> {
    let dt = header
        .real_at(61)
        .map(|ms| ms / 1000.0)
        .filter(|d| *d > 0.0)
        .or_else(|| {
            let secs = textfmt::number_after(data_head, "approx")?;
            (secs > 0.0).then(|| secs / npts as f64)
        });
    dt.ok_or_else(|| {
        lines.err(
            header_values_at,
            "no sampling interval (real header value 62)",
        )
    })
}

/// Direction: orientation code [53] (azimuth 1–360, 400 up … 700 H1), else the relative
/// orientation [54] from the reference azimuth [19]/[20], else the orientation text, else
/// the SCNL channel code's last letter (each inference said in `inferred`).  Also returns
/// the orientation digit ('1'/'2') of an H1/H2-style code when no direction is known.
fn direction(
    header: &NumericHeader,
    orientation_text: Option<&str>,
    scnl_channel: Option<&str>,
    inferred: &mut Vec<String>,
) -> (Option<Direction>, Option<char>) {
    let direction_code = header
        .int_at(53)
        .filter(|&a| (1..=360).contains(&a) || a >= 400);
    let mut direction = None;
    let mut code_orientation: Option<char> = None;
    match direction_code {
        Some(a) if (1..=360).contains(&a) => {
            direction = Some(Direction::Azimuth((a as f64).rem_euclid(360.0)))
        }
        Some(400) | Some(402) => direction = Some(Direction::Up),
        Some(401) => direction = Some(Direction::Down),
        Some(_) => {} // Radial/transverse/longitudinal/H1/H2/other: no azimuth.
        None => {
            // A reference azimuth outside 0–360° is no azimuth (a damaged
            // header); never summed unchecked (the long fuzz run found an
            // integer overflow here).
            let reference = header
                .int_at(19)
                .or_else(|| header.int_at(20))
                .filter(|a| (0..=360).contains(a));
            if let (Some(rel), Some(reference)) = (
                header.int_at(54).filter(|a| (0..=360).contains(a)),
                reference,
            ) {
                direction = Some(Direction::Azimuth(
                    ((rel + reference) as f64).rem_euclid(360.0),
                ));
                inferred.push(format!("direction = {rel} deg from the reference azimuth {reference} deg (header values 55, 20/21)"));
            } else if let Some(d) = orientation_text.and_then(Direction::parse) {
                direction = Some(d);
            } else if let Some(last) = scnl_channel.and_then(|c| c.chars().last()) {
                direction = match last {
                    'Z' => Some(Direction::Up),
                    'N' => Some(Direction::Azimuth(0.0)),
                    'E' => Some(Direction::Azimuth(90.0)),
                    _ => None,
                };
                if direction.is_some() {
                    inferred.push(format!(
                        "direction from the SCNL channel code {:?} (orientation code missing)",
                        scnl_channel.unwrap_or("")
                    ));
                }
            }
        }
    }
    if direction.is_none() {
        code_orientation = match direction_code {
            Some(600) | Some(500) | Some(700) => Some('1'),
            Some(601) | Some(501) | Some(701) => Some('2'),
            _ => None,
        };
    }
    (direction, code_orientation)
}

/// SEED-style code as gmprocess builds it: band from the rate, N for an
/// accelerometer, then Z / 1 (north-ish) / 2 (east-ish).
fn channel_code(
    rate: f64,
    direction: Option<Direction>,
    code_orientation: Option<char>,
) -> Option<String> {
    let band = if rate >= 80.0 {
        'H'
    } else if rate >= 10.0 {
        'B'
    } else {
        'L'
    };
    let orient = match direction {
        Some(Direction::Up)
        | Some(Direction::Down)
        | Some(Direction::Axis(crate::vocab::Axis::Z)) => Some('Z'),
        Some(Direction::Azimuth(a)) => Some(
            if !(45.0..=315.0).contains(&a) || (135.0..225.0).contains(&a) {
                '1'
            } else {
                '2'
            },
        ),
        _ => code_orientation,
    };
    orient.map(|o| format!("{band}N{o}"))
}

/// The `npts` samples after the data header at `data_head_at`, and the 0-based line after
/// the channel (past blank lines and an `End-of-data` line).  More values than declared, on
/// the last data line or after it, is an error naming the channel.
fn samples(
    lines: &Lines,
    data_head_at: usize,
    npts: usize,
    layout: Layout,
    id: &str,
) -> Result<(Vec<f64>, usize)> {
    let block = textfmt::read_block(lines, data_head_at + 1, npts, layout, id)?;
    if block.extra_on_last_line > 0 {
        return Err(lines.err_ch(
            block.next_line - 1,
            id,
            format!("more values than the {npts} points the data header declares"),
        ));
    }
    let mut next = block.next_line;
    while lines.exists(next) && lines.get(next).trim().is_empty() {
        next += 1;
    }
    if lines.exists(next) {
        let l = lines.get(next);
        if textfmt::is_numeric_line(l) {
            return Err(lines.err_ch(
                next,
                id,
                format!("more values than the {npts} points the data header declares"),
            ));
        }
        if l.to_ascii_lowercase().starts_with("end-of-data") {
            next += 1;
        }
    }
    Ok((block.values, next))
}

/// Counts with a known scale: counts → m/s² = LSB (µV/count, real [21]) / sensitivity (V/g,
/// real [41]) / gain (real [46], 1 when unknown) × g, said in `inferred`.
fn calibrate_counts(units: Units, header: &NumericHeader, inferred: &mut Vec<String>) -> Units {
    let mut units = units;
    if let Units::Counts { .. } = units {
        // counts → m/s²: LSB (µV/count) / sensitivity (V/g) / gain × g.
        if let (Some(lsb_uv), Some(v_per_g)) = (header.real_at(21), header.real_at(41)) {
            let gain = header.real_at(46).filter(|g| *g > 0.0).unwrap_or(1.0);
            let si_per_count = lsb_uv * 1e-6 / v_per_g / gain * STANDARD_GRAVITY;
            if si_per_count > 0.0 && si_per_count.is_finite() {
                units = Units::Counts {
                    counts_per_si: Some(1.0 / si_per_count),
                };
                inferred.push(format!(
                    "counts_per_si={:.6e} from the header's recorder LSB {lsb_uv} uV/count, sensor sensitivity {v_per_g} V/g and gain {gain}",
                    1.0 / si_per_count
                ));
            }
        }
    }
    units
}

/// Record start from the integer/real header (year [39], day of year [40], hour [43],
/// minute [44], second real [29]), cross-checked with the text line `Rcrd start time: …
/// UTC`; the text's time is used only when the header has none.
fn set_start_time(channel: &mut Channel, header: &NumericHeader, start_line: &str) {
    let header_start = match (
        header.int_at(39),
        header.int_at(40),
        header.int_at(43),
        header.int_at(44),
    ) {
        (Some(y), Some(doy), Some(h), Some(m))
            if (1..=366).contains(&doy) && (0..24).contains(&h) && (0..60).contains(&m) =>
        {
            epoch_ns_from_ordinal(
                y,
                doy as u32,
                h as u32,
                m as u32,
                header.real_at(29).unwrap_or(0.0),
            )
        }
        _ => None,
    };
    let text_start = text_time(start_line, "Rcrd start time:");
    // The header states the start twice; a disagreement is flagged, not
    // silently resolved (the text prints milliseconds, hence the tolerance).
    if let (Some(h), Some(t)) = (header_start, text_start) {
        if (h - t).abs() > START_TOLERANCE_NS {
            channel.qa.push(QaFlag::Note {
                text: format!(
                    "start time: the integer header ({}) and the text header's \"Rcrd start time\" ({}) disagree by {:.3} s; the integer header's is used",
                    format_epoch_ns(h),
                    format_epoch_ns(t),
                    (h - t) as f64 / 1e9
                ),
            });
        }
    }
    channel.start_ns = header_start.or(text_start);
    if channel.start_ns.is_none() {
        channel.missing.push("start_time".into());
    }
}

/// Event name (text line 1), origin (text line 3), magnitude (real [12]) and hypocentre
/// (reals [9..11]) from the first acceleration channel.
fn fill_event<'a>(
    event: &mut EventHints,
    header: &NumericHeader,
    text_line: impl Fn(usize) -> &'a str,
) {
    // "Record of Point MacKenzie Earthquake of Fri Nov 30, 2018 17:29 UTC"
    let l = text_line(1);
    event.name = l
        .find("Record of ")
        .map(|p| &l[p + 10..])
        .map(|r| {
            r.rfind(" of ")
                .map(|q| &r[..q])
                .unwrap_or(r)
                .trim()
                .to_string()
        })
        .filter(|s| !s.is_empty());
    event.origin_ns = text_time(text_line(3), "Origin:");
    event.magnitude = header.real_at(12);
    if let (Some(lat), Some(lon), Some(depth_km)) =
        (header.real_at(9), header.real_at(10), header.real_at(11))
    {
        event.hypocenter = Some((lat, lon, depth_km));
    }
    // Reals 0 and 1: the station's latitude and longitude.
    event.station_position = header
        .real_at(0)
        .zip(header.real_at(1))
        .filter(|(lat, lon)| lat.abs() <= 90.0 && lon.abs() <= 180.0);
}

/// `Origin: 2018/11/30 17:29:29    UTC` → epoch ns (UTC only).
fn text_time(line: &str, key: &str) -> Option<i64> {
    let p = line.find(key)? + key.len();
    let mut it = line[p..].split_whitespace();
    let date = it.next()?.replace('/', "-");
    let time = it.next()?;
    let zone = it.next().unwrap_or("");
    if !matches!(zone, "UTC" | "GMT" | "UT") {
        return None;
    }
    parse_iso8601_ns(&format!("{date}T{time}"))
}

/// Kind of structure from the station/structure type code, integer header
/// field 18 (0-based; COSMOS v1.20 Table 6, as USGS gmprocess reads it):
/// 10 building, 5 base of a building, 11 bridge, 12 dam, 13 wharf, 14
/// tunnel, 6 free field.  Other codes (shelters, vaults, arrays) name no
/// structure.
fn structure_kind(code: i64) -> Option<(String, String)> {
    let kind = match code {
        5 | 10 => "building",
        11 => "bridge",
        12 => "dam",
        13 => "wharf",
        14 => "tunnel",
        _ => return None,
    };
    Some((
        kind.to_string(),
        format!("COSMOS integer header field 18 (station/structure type) = {code}"),
    ))
}
