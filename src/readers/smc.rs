//! USGS SMC strong-motion files (one channel per file).
//!
//! Layout: 11 text lines (line 1 `2 CORRECTED ACCELEROGRAM` or
//! `1 UNCORRECTED ACCELEROGRAM`; line 4 the event date and `hhmm`, e.g.
//! `     1989  10  18    0004 Loma Prieta, CA`), 48 integers (8I10 on 6
//! lines; the first is the "missing" code, then the record start, [13]
//! horizontal orientation, [15] comment-line count, [16] number of samples),
//! 50 reals (5E15.7 on 10 lines; the first is the "missing" value, then the
//! sampling rate, epicentre latitude, longitude, depth, moment/surface/local
//! magnitudes …), comment lines starting `|`, then the samples in 8E10.4
//! fixed fields that may touch.  A real equal to 1.7E+38 (the SMC sentinel)
//! is missing even where the header's own missing value differs.
//!
//! Only acceleration is read: velocity (`3 VELOCITY`) and displacement
//! (`4 DISPLACEMENT`) files are refused here and skipped with that reason
//! by the event folder (`readers::classify`).
//!
//! Record start: the integer header holds either year, day of year, hour,
//! minute, second, millisecond (fields 2–7, the SMC default) or, in NSMP
//! files, year, month, day, hour, minute, second, millisecond (fields 2–8).
//! Both readings are checked against line 4's date and `hhmm` (within one
//! hour: that is the event time, the record starts minutes later); the
//! agreeing one is used and recorded in `inferred`.  When neither agrees or
//! line 4 has no date, the default reading is kept and a `QaFlag::Note` says so.
//!
//! Variants handled besides evenly sampled data:
//! - files with values after the declared count: the declared count is kept
//!   and a `QaFlag::Note` says how many were ignored;
//! - uncorrected files (or files without a sampling rate) of uneven
//!   `(time, value)` pairs (digitised film records): integer field 17 counts
//!   either the pairs or the values (2 × pairs); the numbers present in the
//!   data section decide (pairs with increasing times in the pair-count
//!   reading, else in the value-count one, which is recorded in
//!   `inferred`).  The pairs are resampled onto a uniform grid by linear
//!   interpolation (at the header rate, or the median time step when the
//!   header has none), flagged `QaFlag::Resampled`, and the step is recorded
//!   in the channel's `inferred` list.

use super::resample::{clean_pair_times, looks_like_pair_times, median_step, resample_linear};
use super::textfmt::{self, Layout, Lines};
use super::{FileContents, ReadOptions};
use crate::error::Result;
use crate::vocab::{
    epoch_ns_from_civil, epoch_ns_from_ordinal, format_epoch_ns, Channel, Direction, QaFlag,
    Record, SourceRef, Units,
};

const TEXT_LINES: usize = 11;
const INT_LINES: usize = 6;
const INT_COUNT: usize = 48;
const REAL_LINES: usize = 10;
const REAL_COUNT: usize = 50;
const DATA_LAYOUT: Layout = Layout::Fixed {
    per_line: 8,
    width: 10,
};

pub fn read(bytes: &[u8], source: &SourceRef, _opts: &ReadOptions) -> Result<FileContents> {
    let text = textfmt::decode(bytes, source)?;
    let lines = Lines::new(&text, source);
    let first = lines.get(0).trim().to_ascii_uppercase();
    if first.contains("VELOCITY") || first.contains("DISPLACEMENT") {
        return Err(lines.err(
            0,
            format!("SMC {first:?}: only acceleration files are read"),
        ));
    }
    let uncorrected = first.contains("UNCORRECTED");
    if !first.contains("ACCELEROGRAM") {
        return Err(lines.err(
            0,
            format!("first line {:?} is not an SMC accelerogram label (e.g. \"2 CORRECTED ACCELEROGRAM\")", lines.get(0).trim()),
        ));
    }
    if lines.len() < TEXT_LINES + INT_LINES + REAL_LINES {
        return Err(lines.err(
            lines.len().saturating_sub(1),
            format!(
                "file ends inside the header ({} lines; the SMC header alone has {})",
                lines.len(),
                TEXT_LINES + INT_LINES + REAL_LINES
            ),
        ));
    }

    // Integer header, 8I10.
    let mut ints = Vec::with_capacity(INT_COUNT);
    for i in TEXT_LINES..TEXT_LINES + INT_LINES {
        for f in textfmt::fixed_fields(lines.get(i), 10, 8) {
            ints.push(textfmt::parse_int(&f).ok_or_else(|| {
                lines.err(
                    i,
                    format!("integer header field {:?} is not an integer", f.trim()),
                )
            })?);
        }
    }
    if ints.len() < INT_COUNT {
        return Err(lines.err(
            TEXT_LINES + INT_LINES - 1,
            format!("integer header has {} of {INT_COUNT} values", ints.len()),
        ));
    }
    let int_missing = ints[0];
    let int_at = |k: usize| ints.get(k).copied().filter(|&v| v != int_missing);

    // Real header, 5E15.7.
    let real_start = TEXT_LINES + INT_LINES;
    let mut reals = Vec::with_capacity(REAL_COUNT);
    for i in real_start..real_start + REAL_LINES {
        for f in textfmt::fixed_fields(lines.get(i), 15, 5) {
            reals.push(textfmt::parse_number(&f).map_err(|_| {
                lines.err(
                    i,
                    format!("real header field {:?} is not a number", f.trim()),
                )
            })?);
        }
    }
    if reals.len() < REAL_COUNT {
        return Err(lines.err(
            real_start + REAL_LINES - 1,
            format!("real header has {} of {REAL_COUNT} values", reals.len()),
        ));
    }
    let real_missing = reals[0];
    // Missing reals: the header's own code (field 1), and the SMC sentinel
    // 1.7E+38 itself, which real files use even where field 1 differs.
    let real_at = |k: usize| {
        reals.get(k).copied().filter(|&v| {
            (v - real_missing).abs() > 1e-6 * real_missing.abs().max(1.0) && v.abs() < 1e38
        })
    };

    // Comment lines start with '|'; the header says how many.
    let mut data_start = real_start + REAL_LINES;
    while lines.exists(data_start) && lines.get(data_start).starts_with('|') {
        data_start += 1;
    }
    let declared_comments = int_at(15).unwrap_or(0);
    if declared_comments >= 0 && (data_start - real_start - REAL_LINES) as i64 != declared_comments
    {
        return Err(lines.err(
            data_start,
            format!(
                "the header declares {declared_comments} comment lines but {} lines starting with '|' were found",
                data_start - real_start - REAL_LINES
            ),
        ));
    }

    let npts = int_at(16).filter(|&n| n > 0).ok_or_else(|| {
        lines.err(
            TEXT_LINES + 2,
            "integer header field 17 (number of samples) is missing or not positive",
        )
    })? as usize;
    let rate = real_at(1).filter(|&r| r > 0.0 && r < 1e5);

    // Station, component and channel identity.
    let station_code: String = lines
        .get(2)
        .chars()
        .take(4)
        .collect::<String>()
        .trim()
        .trim_matches('\0')
        .to_string();
    let station_line = lines.get(5);
    let (station_name, component) = match station_line.to_ascii_lowercase().find("component=") {
        Some(p) => (
            station_line[..p]
                .trim()
                .trim_start_matches("station")
                .trim()
                .trim_start_matches('=')
                .trim()
                .to_string(),
            station_line[p + "component=".len()..].trim().to_string(),
        ),
        None => (String::new(), String::new()),
    };
    // `<tag=value>` fields of the text header and comment lines (NSMP
    // building files: `|<loclbl=Roof>`; `<SCNL>STA.CHN.NET.LOC`).
    let tags: Vec<(String, String)> = (0..data_start)
        .filter(|&i| i < TEXT_LINES || lines.get(i).starts_with('|'))
        .flat_map(|i| textfmt::angle_tags(lines.get(i)))
        .collect();
    let tag = |name: &str| tags.iter().find(|(t, _)| t == name).map(|(_, v)| v.clone());
    let location_label = tag("loclbl");
    let scnl: Option<Vec<String>> = tag("scnl")
        .map(|s| {
            s.split_whitespace()
                .next()
                .unwrap_or("")
                .split('.')
                .map(str::to_string)
                .collect::<Vec<_>>()
        })
        .filter(|p| p.len() == 4);
    let direction = Direction::parse(&component)
        .or_else(|| int_at(13).map(|a| Direction::Azimuth((a as f64).rem_euclid(360.0))));
    let station = if station_code.is_empty() {
        super::at2::file_stem(source)
    } else {
        station_code.clone()
    };
    let id = if component.is_empty() {
        station.clone()
    } else {
        format!("{station}.{}", component.to_ascii_uppercase())
    };

    let (values, marks) = textfmt::read_to_end(&lines, data_start, DATA_LAYOUT, &id)?;
    let mut qa = Vec::new();
    let mut inferred = vec![
        "units=cm/s2 (USGS SMC convention for acceleration; the file does not name units)"
            .to_string(),
    ];
    let mut start_offset_s = 0.0;

    // Uneven (time, value) pairs: the integer header counts either the
    // pairs or the values (2 × pairs) — both occur in real files — so the
    // numbers actually present decide: pairs with increasing times, first
    // in the pair-count reading, then in the value-count one.
    // Times that go forward at nearly every step: real film digitisations
    // repeat stamps and step back now and then (cleaned below).
    let increasing_times = |n_values: usize| {
        let times: Vec<f64> = values[..n_values].iter().step_by(2).copied().collect();
        looks_like_pair_times(&times)
    };
    let maybe_pairs = uncorrected || rate.is_none();
    let n_pairs = if maybe_pairs
        && npts >= 2
        && values.len() >= 2 * npts
        && increasing_times(2 * npts)
    {
        Some(npts)
    } else if maybe_pairs
        && npts >= 4
        && npts % 2 == 0
        && values.len() >= npts
        && increasing_times(npts)
    {
        inferred.push(format!(
            "integer header field 17 = {npts} counts values, not pairs: the data section holds {} numbers forming {} (time, value) pairs with times going forward",
            values.len(),
            npts / 2
        ));
        Some(npts / 2)
    } else {
        None
    };
    let (samples, rate_hz) = if let Some(n_pairs) = n_pairs {
        let used = 2 * n_pairs;
        let raw_times: Vec<f64> = values[..used].iter().step_by(2).copied().collect();
        let raw_accel: Vec<f64> = values[..used].iter().skip(1).step_by(2).copied().collect();
        let (times, accel, cleaning) = clean_pair_times(&raw_times, &raw_accel);
        if !cleaning.is_clean() {
            qa.push(QaFlag::Note {
                text: cleaning.describe(&source.to_string()),
            });
        }
        if times.len() < 2 {
            return Err(lines.err_ch(
                data_start,
                &id,
                "fewer than two (time, value) pairs with distinct times",
            ));
        }
        let dt = match rate {
            Some(r) => 1.0 / r,
            None => median_step(&times),
        };
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(lines.err_ch(
                data_start,
                &id,
                "cannot find a time step for the (time, value) pairs",
            ));
        }
        let span = times[times.len() - 1] - times[0];
        super::resample::check_grid(times.len(), span, dt)
            .map_err(|m| lines.err_ch(data_start, &id, m))?;
        let uniform = resample_linear(&times, &accel, dt);
        qa.push(QaFlag::Resampled {
            from: "uneven (time,value) pairs".into(),
        });
        inferred.push(format!(
            "samples resampled from {n_pairs} uneven (time,value) pairs onto a uniform grid dt={dt} s ({}) by linear interpolation",
            if rate.is_some() { "header rate" } else { "median time step; the header has no sampling rate" }
        ));
        start_offset_s = times[0];
        if values.len() > used {
            qa.push(QaFlag::Note {
                text: format!(
                    "{} values after the {n_pairs} declared (time,value) pairs were ignored",
                    values.len() - used
                ),
            });
        }
        (uniform, 1.0 / dt)
    } else {
        if values.len() < npts {
            let last = marks.last().map(|&(i, _)| i).unwrap_or(data_start);
            return Err(lines.err_ch(
                last,
                &id,
                format!(
                    "the data has {} values but the header declares {npts} (truncated file?)",
                    values.len()
                ),
            ));
        }
        let rate = rate.ok_or_else(|| {
            let times: Vec<f64> = values.iter().step_by(2).copied().collect();
            let backwards = times.windows(2).filter(|w| w[1] < w[0]).count();
            lines.err(
                real_start,
                format!(
                    "real header field 2 (sampling rate) is missing, so the samples cannot be placed in time: read as (time, value) pairs, {backwards} of {} time steps go backwards (more than 5 %), so they are not a time column either; state `sampling_rate_hz` in event.toml",
                    times.len().saturating_sub(1)
                ),
            )
        })?;
        if values.len() > npts {
            let at = textfmt::line_of_value(&marks, npts)
                .map(|i| i + 1)
                .unwrap_or(0);
            qa.push(QaFlag::Note {
                text: format!(
                    "{} values after the {npts} declared by the header (from line {at}) were ignored",
                    values.len() - npts
                ),
            });
        }
        (values[..npts].to_vec(), rate)
    };

    let mut channel = Channel::new(id, Units::CmPerS2, rate_hz, source.clone());
    channel.station = Some(station).filter(|s| !s.is_empty());
    channel.channel_code = Some(component.clone()).filter(|s| !s.is_empty());
    if let Some(p) = &scnl {
        channel.network = Some(p[2].clone()).filter(|s| !s.is_empty());
        channel.location_code = Some(p[3].clone()).filter(|s| !s.is_empty() && s != "--");
    }
    // The sensor's location: its `<loclbl>` label, else (as before) the
    // station line, whose words may still name a ground or structure sensor.
    channel.location_text = match &location_label {
        Some(l) => {
            inferred.push(format!("location {l:?} from the header's <loclbl> tag"));
            Some(l.clone())
        }
        None => Some(station_name.clone()).filter(|s| !s.is_empty()),
    };
    channel.direction = direction;
    if direction.is_none() {
        channel.missing.push("direction".into());
    }
    let start = start_time(&ints, int_missing, lines.get(3));
    inferred.extend(start.inferred);
    qa.extend(start.qa);
    channel.start_ns = start
        .start_ns
        .map(|t| t + (start_offset_s * 1e9).round() as i64);
    if channel.start_ns.is_none() {
        channel.missing.push("start_time".into());
    }
    channel.qa = qa;
    channel.inferred = inferred;

    let mut contents = FileContents::default();
    // Line 4: "     1989  10  18    0004 Loma Prieta, CA".
    let event_line = lines.get(3);
    let name: String = event_line
        .split_whitespace()
        .skip_while(|t| t.chars().all(|c| c.is_ascii_digit()))
        .collect::<Vec<_>>()
        .join(" ");
    contents.event.name = Some(name).filter(|s| !s.is_empty());
    contents.event.station_name = Some(station_name).filter(|s| !s.is_empty());
    contents.event.magnitude =
        textfmt::number_after(lines.get(4), "Moment Mag=").or_else(|| real_at(5));
    if let (Some(lat), Some(lon), Some(depth_km)) = (real_at(2), real_at(3), real_at(4)) {
        contents.event.hypocenter = Some((lat, lon, depth_km));
    }
    // Reals 10 and 11: the station's latitude and longitude.
    contents.event.station_position = real_at(10)
        .zip(real_at(11))
        .filter(|(lat, lon)| lat.abs() <= 90.0 && lon.abs() <= 180.0);
    contents.records.push(Record::new(channel, samples));
    Ok(contents)
}

/// Record start and how it was decided.
struct Start {
    start_ns: Option<i64>,
    inferred: Vec<String>,
    qa: Vec<QaFlag>,
}

/// Largest distance between the record start and the text header's
/// `hhmm` (the event time, to the minute) for the two to agree: records
/// start within minutes of the origin, while a mistaken layout is off by
/// days or hours.
const TEXT_TIME_TOLERANCE_NS: i64 = 3_600 * 1_000_000_000;

/// Record start from the integer header, whose first fields are laid out
/// either as year, day of year, hour, minute, second, millisecond (SMC
/// default) or as year, month, day, hour, minute, second, millisecond (NSMP
/// files).  The layout is chosen by cross-checking with the date (and
/// `hhmm`) the text header states on line 4 (`     2018  01  04    1039
/// …`); the choice is recorded in `inferred`, and a disagreement or an
/// unchecked start is a `QaFlag::Note`, never a silent choice.
fn start_time(ints: &[i64], missing: i64, event_line: &str) -> Start {
    let int_at = |k: usize| ints.get(k).copied().filter(|&v| v != missing);
    let in_range = |v: i64, lo: i64, hi: i64| (lo..=hi).contains(&v);
    let second = |s: usize, ms: usize| -> Option<f64> {
        let sec = int_at(s).unwrap_or(0);
        let milli = int_at(ms).unwrap_or(0);
        (in_range(sec, 0, 60) && in_range(milli, 0, 999)).then(|| sec as f64 + milli as f64 / 1e3)
    };
    let doy_reading = match (int_at(1), int_at(2), int_at(3), int_at(4), second(5, 6)) {
        (Some(y), Some(doy), Some(h), Some(m), Some(sec))
            if in_range(doy, 1, 366) && in_range(h, 0, 23) && in_range(m, 0, 59) =>
        {
            epoch_ns_from_ordinal(y, doy as u32, h as u32, m as u32, sec)
        }
        _ => None,
    };
    let md_reading = match (
        int_at(1),
        int_at(2),
        int_at(3),
        int_at(4),
        int_at(5),
        second(6, 7),
    ) {
        (Some(y), Some(mo), Some(d), Some(h), Some(m), Some(sec))
            if in_range(mo, 1, 12)
                && in_range(d, 1, 31)
                && in_range(h, 0, 23)
                && in_range(m, 0, 59) =>
        {
            epoch_ns_from_civil(y, mo as u32, d as u32, h as u32, m as u32, sec)
        }
        _ => None,
    };
    const DOY: &str = "year, day of year, hour, minute, second, millisecond";
    const MD: &str = "year, month, day, hour, minute, second, millisecond";
    let show = |t: Option<i64>| t.map_or("not a valid time".to_string(), format_epoch_ns);
    let mut out = Start {
        start_ns: None,
        inferred: Vec::new(),
        qa: Vec::new(),
    };
    // The documented default, and what is kept when nothing confirms a layout.
    let (default_ns, default_layout) = match (doy_reading, md_reading) {
        (Some(t), _) => (Some(t), DOY),
        (None, Some(t)) => (Some(t), MD),
        (None, None) => (None, DOY),
    };
    let Some((text, text_ns, has_time)) = text_date(event_line) else {
        out.start_ns = default_ns;
        if default_ns.is_some() {
            out.qa.push(QaFlag::Note {
                text: format!(
                    "start time not cross-checked: the text header (line 4) states no date; integer header read as {default_layout}"
                ),
            });
        }
        return out;
    };
    let agrees = |t: Option<i64>| {
        t.is_some_and(|t| {
            if has_time {
                (t - text_ns).abs() <= TEXT_TIME_TOLERANCE_NS
            } else {
                (text_ns..text_ns + 86_400 * 1_000_000_000).contains(&t)
            }
        })
    };
    match (agrees(doy_reading), agrees(md_reading)) {
        (true, _) => {
            out.start_ns = doy_reading;
            out.inferred.push(format!(
                "start time from the integer header read as {DOY} (agrees with the text header's {text:?})"
            ));
        }
        (false, true) => {
            out.start_ns = md_reading;
            out.inferred.push(format!(
                "start time from the integer header read as {MD} (NSMP layout): it agrees with the text header's {text:?}, the {DOY} reading ({}) does not",
                show(doy_reading)
            ));
        }
        (false, false) => {
            out.start_ns = default_ns;
            out.qa.push(QaFlag::Note {
                text: format!(
                    "start time disagrees with the text header's {text:?} in both integer-header layouts ({DOY}: {}; {MD}: {}); {}",
                    show(doy_reading),
                    show(md_reading),
                    if default_ns.is_some() {
                        format!("the {default_layout} reading is kept")
                    } else {
                        "no start time".to_string()
                    }
                ),
            });
        }
    }
    out
}

/// Date (and `hhmm` when present) the text header states on line 4:
/// `     1989  10  18    0004 Loma Prieta, CA` → (the text, epoch ns, has time).
fn text_date(line: &str) -> Option<(String, i64, bool)> {
    let tokens: Vec<&str> = line.split_whitespace().take(4).collect();
    let num = |k: usize| -> Option<i64> {
        let t = tokens.get(k)?;
        t.chars()
            .all(|c| c.is_ascii_digit())
            .then(|| t.parse().ok())
            .flatten()
    };
    let (y, mo, d) = (num(0)?, num(1)?, num(2)?);
    if !((1900..=2200).contains(&y) && (1..=12).contains(&mo) && (1..=31).contains(&d)) {
        return None;
    }
    let hhmm =
        num(3).filter(|v| (3..=4).contains(&tokens[3].len()) && v / 100 < 24 && v % 100 < 60);
    let (h, m) = hhmm.map_or((0, 0), |v| (v / 100, v % 100));
    let ns = epoch_ns_from_civil(y, mo as u32, d as u32, h as u32, m as u32, 0.0)?;
    let shown = tokens[..if hhmm.is_some() { 4 } else { 3 }].join(" ");
    Some((shown, ns, hhmm.is_some()))
}

/// Uncorrected SMC files (`1 UNCORRECTED ACCELEROGRAM`) of a folder that
/// duplicate a corrected one (`2 CORRECTED ACCELEROGRAM`) of the same
/// channel — same station code (text line 3), component (line 6) and
/// `<loclbl>` — as NSMP zips ship them side by side: name → the corrected
/// file's name.  `files` are (name, first bytes) pairs; a V1 without its V2
/// is not listed (it is read).
pub fn uncorrected_duplicates(
    files: &[(String, &[u8])],
) -> std::collections::BTreeMap<String, String> {
    let key_of = |head: &[u8]| -> Option<(u8, String)> {
        let text = String::from_utf8_lossy(head);
        let lines: Vec<&str> = text.lines().collect();
        let first = lines.first()?.trim().to_ascii_uppercase();
        let volume = if first.contains("UNCORRECTED ACCELEROGRAM") {
            1
        } else if first.contains("CORRECTED ACCELEROGRAM") {
            2
        } else {
            return None;
        };
        let station: String = lines.get(2)?.chars().take(4).collect();
        let line6 = lines.get(5)?.to_ascii_lowercase();
        let component = line6
            .find("component=")
            .map(|p| line6[p + 10..].trim().to_string())?;
        let label = lines
            .iter()
            .enumerate()
            .filter(|(i, l)| *i < TEXT_LINES || l.starts_with('|'))
            .flat_map(|(_, l)| textfmt::angle_tags(l))
            .find(|(t, _)| t == "loclbl")
            .map(|(_, v)| v.to_ascii_lowercase())
            .unwrap_or_default();
        Some((volume, format!("{}|{component}|{label}", station.trim())))
    };
    let keyed: Vec<(&String, u8, String)> = files
        .iter()
        .filter(|(n, _)| n.to_ascii_lowercase().ends_with(".smc"))
        .filter_map(|(n, h)| key_of(h).map(|(v, k)| (n, v, k)))
        .collect();
    let mut out = std::collections::BTreeMap::new();
    for (name, v, key) in keyed.iter().filter(|(_, v, _)| *v == 1) {
        debug_assert_eq!(*v, 1);
        if let Some((v2, _, _)) = keyed.iter().find(|(_, v, k)| *v == 2 && k == key) {
            let base = v2.rsplit([':', '/', '\\']).next().unwrap_or(v2);
            out.insert((*name).clone(), base.to_string());
        }
    }
    out
}
