//! CSV / TSV reader, including the Xsens (Movella) DOT export.
//!
//! Written by hand rather than with the `csv` crate: the work here is not
//! field splitting (no quoted delimiters in sensor exports) but finding where
//! the table starts after a free-form preamble, guessing the delimiter, and
//! turning a time column into a sampling rate — none of which a CSV crate does.
//!
//! Layout understood:
//! - an optional `sep=X` first line (Excel hint) fixes the delimiter; otherwise
//!   comma, tab, semicolon and whitespace are tried and the one giving the
//!   widest consistent numeric table wins;
//! - preamble lines before the header row (`Key:,value` or `Key: value`):
//!   `DeviceTag` → station, `StartTime` (`2025-03-06_12:26:07_000 PST`, or ISO
//!   8601 UTC) → start time, `SampleRate`/`Sampling rate` → rate;
//! - a header row (optional; without it columns are named by their 0-based index);
//! - a time column (`ReadOptions.time_column`, else `time`, `t`, `timestamp`,
//!   `seconds`, `SampleTimeFine`…) in seconds unless the header says `[ms]`,
//!   `(us)`…; `SampleTimeFine` is the Xsens microsecond counter, which wraps at 2³².
//!   Without a time column the rate comes from `ReadOptions.sampling_rate_hz` or the preamble;
//! - columns from `ReadOptions.columns` (names or 0-based indices), else every
//!   acceleration-like column (`Acc_*`, `acc*`, `a_*`, `ax`…).
//!
//! The sampling interval is the median time step.  When it is within the time
//! resolution of a whole rate in Hz (Xsens: 8333 µs = 1/120 s truncated to
//! whole µs) the whole rate is used and noted in `inferred`.  Steps further
//! than max(1 % of the interval, 1.5 × resolution) from it make the column
//! uneven: the samples are resampled linearly onto a uniform grid and flagged
//! `QaFlag::Resampled` (steps longer than 1.5 intervals are also flagged `QaFlag::Gap`).
//!
//! Units come from the column header (`acc_x[m/s2]`, `Acc_X (g)`).  When the
//! header states none, m/s² is assumed, noted in `inferred`, and `"units"`
//! is listed in `missing`.

use super::{FileContents, ReadOptions};
use crate::error::{Error, Result};
use crate::vocab::{
    epoch_ns_from_civil, parse_iso8601_ns, Channel, QaFlag, Record, SourceRef, Units,
};

/// How fields are separated.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Delim {
    Char(char),
    Whitespace,
}

impl Delim {
    fn split<'a>(&self, line: &'a str) -> Vec<&'a str> {
        let clean = |s: &'a str| s.trim().trim_matches('"').trim();
        match self {
            Delim::Char(c) => line.split(*c).map(clean).collect(),
            Delim::Whitespace => line.split_whitespace().map(clean).collect(),
        }
    }
}

fn is_number(s: &str) -> bool {
    !s.is_empty() && s.parse::<f64>().is_ok()
}

/// More than half of the fields are numbers.
fn mostly_numeric(fields: &[&str]) -> bool {
    !fields.is_empty() && 2 * fields.iter().filter(|f| is_number(f)).count() > fields.len()
}

/// Where the table is: header line index (if any), first data line index, field count.
#[derive(Debug, Clone, Copy)]
struct Layout {
    delim: Delim,
    header: Option<usize>,
    data_start: usize,
    fields: usize,
}

fn find_layout(lines: &[&str], first: usize, delim: Delim) -> Option<Layout> {
    let nonblank: Vec<usize> = (first..lines.len())
        .filter(|&i| !lines[i].trim().is_empty())
        .collect();
    for (k, &i) in nonblank.iter().enumerate() {
        let f = delim.split(lines[i]);
        if !mostly_numeric(&f) {
            continue;
        }
        let n = f.len();
        let follow = &nonblank[k + 1..nonblank.len().min(k + 4)];
        if follow.iter().all(|&j| {
            let g = delim.split(lines[j]);
            g.len() == n && mostly_numeric(&g)
        }) {
            // Walk back over data rows with a bad cell (still mostly numeric) so they are parsed and reported.
            let mut start = i;
            while start > first {
                let prev = lines[start - 1];
                let g = delim.split(prev);
                if prev.trim().is_empty() || g.len() != n || !mostly_numeric(&g) {
                    break;
                }
                start -= 1;
            }
            let header = (start > first).then(|| start - 1).filter(|&h| {
                let g = delim.split(lines[h]);
                !lines[h].trim().is_empty()
                    && g.len() == n
                    && 2 * g.iter().filter(|x| is_number(x)).count() < n.max(1)
            });
            return Some(Layout {
                delim,
                header,
                data_start: start,
                fields: n,
            });
        }
    }
    None
}

/// Column name without a trailing unit in brackets or parentheses, lower case.
fn base_name(name: &str) -> String {
    let cut = name.find(['[', '(']).unwrap_or(name.len());
    name[..cut].trim().to_ascii_lowercase()
}

/// Unit text in brackets or parentheses of a column name (`acc_x[m/s2]` → `m/s2`).
fn unit_text(name: &str) -> Option<String> {
    let open = name.find(['[', '('])?;
    let close = name[open + 1..].find([']', ')'])? + open + 1;
    Some(name[open + 1..close].trim().to_string())
}

fn is_acceleration_like(name: &str) -> bool {
    let b = base_name(name);
    b.contains("acc") || b.starts_with("a_") || matches!(b.as_str(), "ax" | "ay" | "az" | "a")
}

/// Time zone abbreviations seen in sensor exports → offset from UTC in hours.
fn zone_offset_hours(zone: &str) -> Option<i64> {
    Some(match zone.to_ascii_uppercase().as_str() {
        "UTC" | "GMT" | "Z" => 0,
        "PST" => -8,
        "PDT" | "MST" => -7,
        "MDT" | "CST" => -6,
        "CDT" | "EST" => -5,
        "EDT" => -4,
        "CET" => 1,
        "CEST" | "EET" => 2,
        "JST" => 9,
        "NZST" => 12,
        "NZDT" => 13,
        _ => return None,
    })
}

/// Parses `2025-03-06_12:26:07_000 PST` (Xsens) or ISO 8601 UTC.
/// Returns (ns since epoch UTC, description of the zone used).
fn parse_start_time(s: &str) -> Option<(i64, String)> {
    let s = s.trim();
    let (stamp, zone) = match s.rsplit_once(' ') {
        Some((a, z)) if z.chars().all(|c| c.is_ascii_alphabetic()) => (a.trim(), Some(z)),
        _ => (s, None),
    };
    let offset_h = match zone {
        Some(z) => zone_offset_hours(z)?,
        None => 0,
    };
    let parts: Vec<&str> = stamp.split('_').collect();
    let local = if parts.len() >= 2 {
        let mut d = parts[0].split('-');
        let y: i64 = d.next()?.parse().ok()?;
        let m: u32 = d.next()?.parse().ok()?;
        let day: u32 = d.next()?.parse().ok()?;
        let mut t = parts[1].split(':');
        let hh: u32 = t.next()?.parse().ok()?;
        let mm: u32 = t.next()?.parse().ok()?;
        let ss: f64 = t.next()?.parse().ok()?;
        let ms: f64 = parts.get(2).map(|x| x.parse().ok()).unwrap_or(Some(0.0))?;
        epoch_ns_from_civil(y, m, day, hh, mm, ss)? + (ms * 1e6).round() as i64
    } else {
        parse_iso8601_ns(stamp)?
    };
    let desc = match zone {
        Some(z) => format!("{z} = UTC{offset_h:+}"),
        None => "UTC".into(),
    };
    Some((local - offset_h * 3_600_000_000_000, desc))
}

/// How the time column counts.
#[derive(Debug, Clone, Copy, PartialEq)]
enum TimeKind {
    /// Value × factor = seconds.
    Seconds(f64),
    /// Xsens SampleTimeFine: µs, unsigned 32-bit counter that wraps.
    XsensFine,
}

fn time_kind(name: &str) -> Option<TimeKind> {
    let b = base_name(name);
    if b == "sampletimefine" {
        return Some(TimeKind::XsensFine);
    }
    let from_unit = |u: &str| -> Option<f64> {
        Some(match u.trim().to_ascii_lowercase().as_str() {
            "s" | "sec" | "seconds" => 1.0,
            "ms" => 1e-3,
            "us" | "µs" | "μs" => 1e-6,
            "ns" => 1e-9,
            "min" => 60.0,
            _ => return None,
        })
    };
    let named = matches!(
        b.as_str(),
        "time" | "t" | "times" | "timestamp" | "seconds" | "sec" | "time_s" | "elapsed"
    );
    let suffixed = ["time_ms", "time_us", "time_ns", "t_ms", "t_us", "t_s"].contains(&b.as_str());
    if !named && !suffixed {
        return None;
    }
    if let Some(u) = unit_text(name) {
        return from_unit(&u).map(TimeKind::Seconds);
    }
    let factor = match b.rsplit('_').next() {
        Some("ms") if suffixed => 1e-3,
        Some("us") if suffixed => 1e-6,
        Some("ns") if suffixed => 1e-9,
        _ => 1.0,
    };
    Some(TimeKind::Seconds(factor))
}

/// Reads the selected columns of a CSV/TSV file, one record per column.
pub fn read(bytes: &[u8], source: &SourceRef, opts: &ReadOptions) -> Result<FileContents> {
    let mut src = source.clone();
    src.format = "csv".into();
    let text = String::from_utf8_lossy(bytes);
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let lines: Vec<&str> = text.split('\n').map(|l| l.trim_end_matches('\r')).collect();
    let loc = |line: usize| super::location(&src).at_line(line + 1);

    // Optional `sep=X` first line.
    let mut first = 0;
    let mut forced: Option<Delim> = None;
    if let Some(rest) = lines.first().and_then(|l| l.trim().strip_prefix("sep=")) {
        forced = Some(match rest {
            "\\t" | "\t" | "" => Delim::Char('\t'),
            r => Delim::Char(r.chars().next().unwrap_or(',')),
        });
        first = 1;
    }
    let candidates = match forced {
        Some(d) => vec![d],
        None => vec![
            Delim::Char(','),
            Delim::Char('\t'),
            Delim::Char(';'),
            Delim::Whitespace,
        ],
    };
    let mut layout: Option<Layout> = None;
    for d in candidates {
        if let Some(l) = find_layout(&lines, first, d) {
            if layout.is_none_or(|best| l.fields > best.fields) {
                layout = Some(l);
            }
        }
    }
    let layout = layout.ok_or_else(|| {
        Error::input(
            super::location(&src),
            "no table of numbers found in this CSV file",
        )
    })?;
    let names: Vec<String> = match layout.header {
        Some(h) => layout
            .delim
            .split(lines[h])
            .iter()
            .map(|s| s.to_string())
            .collect(),
        None => (0..layout.fields).map(|i| i.to_string()).collect(),
    };
    let header_line = layout.header.unwrap_or(layout.data_start);

    // Preamble key/value lines.
    let preamble_end = layout.header.unwrap_or(layout.data_start);
    let mut station: Option<String> = None;
    let mut start: Option<(i64, String, usize)> = None;
    let mut preamble_rate: Option<f64> = None;
    let mut is_xsens = false;
    for (i, line) in lines.iter().enumerate().take(preamble_end).skip(first) {
        if line.contains("Xsens") || line.contains("Movella") {
            is_xsens = true;
        }
        let Some((key, value)) = line.split_once(':') else {
            continue;
        };
        let key = key.trim().to_ascii_lowercase();
        let value = value.trim().trim_start_matches([',', '\t', ';']).trim();
        match key.as_str() {
            "devicetag" => {
                is_xsens = true;
                if !value.is_empty() {
                    station = Some(value.to_string());
                }
            }
            "starttime" | "start time" | "start_time" => match parse_start_time(value) {
                Some((ns, zone)) => start = Some((ns, zone, i)),
                None => {
                    return Err(Error::input(
                        loc(i),
                        format!("StartTime {value:?} is not a date and time this reader knows"),
                    ))
                }
            },
            "samplerate" | "sample rate" | "sampling rate" | "sampling_rate" | "fs" => {
                let num = value.trim_end_matches("Hz").trim_end_matches("hz").trim();
                preamble_rate = num.parse::<f64>().ok().filter(|r| *r > 0.0);
            }
            _ => {}
        }
    }

    let resolve = |spec: &str| -> Option<usize> {
        let s = spec.trim();
        names
            .iter()
            .position(|n| n.eq_ignore_ascii_case(s))
            .or_else(|| {
                names
                    .iter()
                    .position(|n| base_name(n) == s.to_ascii_lowercase())
            })
            .or_else(|| s.parse::<usize>().ok().filter(|&i| i < names.len()))
    };
    let time_col: Option<(usize, TimeKind)> = match &opts.time_column {
        Some(t) => {
            let i = resolve(t).ok_or_else(|| {
                Error::input(
                    loc(header_line),
                    format!("time column {t:?} not found; columns are {names:?}"),
                )
            })?;
            Some((i, time_kind(&names[i]).unwrap_or(TimeKind::Seconds(1.0))))
        }
        None => names
            .iter()
            .enumerate()
            .find_map(|(i, n)| time_kind(n).map(|k| (i, k))),
    };
    let selected: Vec<usize> = match &opts.columns {
        Some(cols) => cols
            .iter()
            .map(|c| {
                resolve(c).ok_or_else(|| {
                    Error::input(
                        loc(header_line),
                        format!("column {c:?} not found; columns are {names:?}"),
                    )
                })
            })
            .collect::<Result<_>>()?,
        None => (0..names.len())
            .filter(|&i| Some(i) != time_col.map(|t| t.0) && is_acceleration_like(&names[i]))
            .collect(),
    };
    if selected.is_empty() {
        return Err(Error::input(
            loc(header_line),
            format!("no acceleration-like column (Acc_*, acc*, a_*); name the columns to read in the manifest. Columns are {names:?}"),
        ));
    }

    // Parse the cells we need.
    let mut values: Vec<Vec<f64>> = vec![Vec::new(); selected.len()];
    let mut times_raw: Vec<f64> = Vec::new();
    let mut time_decimals = 0usize;
    let mut time_lines: Vec<usize> = Vec::new();
    for (i, line) in lines.iter().enumerate().skip(layout.data_start) {
        if line.trim().is_empty() {
            continue;
        }
        let fields = layout.delim.split(line);
        if fields.len() != layout.fields {
            return Err(Error::input(
                loc(i),
                format!(
                    "expected {} fields as in the header, found {}",
                    layout.fields,
                    fields.len()
                ),
            ));
        }
        let cell = |c: usize| -> Result<f64> {
            fields[c].parse::<f64>().map_err(|_| {
                Error::input(
                    loc(i).with_channel(names[c].clone()),
                    format!(
                        "cell {:?} in column {} ({}) is not a number",
                        fields[c], c, names[c]
                    ),
                )
            })
        };
        if let Some((tc, _)) = time_col {
            times_raw.push(cell(tc)?);
            time_decimals = time_decimals.max(
                fields[tc]
                    .split_once('.')
                    .map(|(_, d)| d.len())
                    .unwrap_or(0),
            );
            time_lines.push(i);
        }
        for (k, &c) in selected.iter().enumerate() {
            values[k].push(cell(c)?);
        }
    }
    let n = values[0].len();
    if n < 2 {
        return Err(Error::input(
            loc(layout.data_start),
            "fewer than two data rows",
        ));
    }

    // Sampling rate and grid.
    let mut inferred_common: Vec<String> = Vec::new();
    let mut qa_common: Vec<QaFlag> = Vec::new();
    let rate_hz: f64;
    if let Some((tc, kind)) = time_col {
        let (times, resolution) = match kind {
            TimeKind::XsensFine => {
                let mut wraps = 0.0;
                let mut out = Vec::with_capacity(n);
                for (k, &t) in times_raw.iter().enumerate() {
                    if k > 0 && t < times_raw[k - 1] {
                        wraps += 4_294_967_296.0; // 2^32 µs counter wrapped
                    }
                    out.push((t + wraps) * 1e-6);
                }
                (out, 1e-6)
            }
            TimeKind::Seconds(f) => (
                times_raw.iter().map(|t| t * f).collect::<Vec<_>>(),
                10f64.powi(-(time_decimals as i32)) * f,
            ),
        };
        let mut steps: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
        if let Some(k) = steps.iter().position(|s| *s <= 0.0 || !s.is_finite()) {
            return Err(Error::input(
                loc(time_lines[k + 1]).with_channel(names[tc].clone()),
                format!(
                    "time column {} does not increase ({} after {})",
                    names[tc],
                    times_raw[k + 1],
                    times_raw[k]
                ),
            ));
        }
        let raw_steps = steps.clone();
        steps.sort_by(|a, b| a.total_cmp(b));
        let dt = steps[steps.len() / 2];
        let whole = (1.0 / dt).round();
        rate_hz = if whole >= 1.0 && (1.0 / whole - dt).abs() <= resolution {
            inferred_common.push(format!(
                "sampling rate {whole} Hz: median step {:.9} s of column {} is 1/{whole} s within its resolution {resolution:e} s",
                dt, names[tc]
            ));
            whole
        } else {
            1.0 / dt
        };
        let tol = (0.01 * dt).max(1.5 * resolution);
        let uneven = raw_steps.iter().any(|s| (s - dt).abs() > tol);
        if uneven {
            for (k, s) in raw_steps.iter().enumerate() {
                if *s > 1.5 * dt {
                    qa_common.push(QaFlag::Gap {
                        at_s: times[k] - times[0],
                        duration_s: s - dt,
                    });
                }
            }
            let (lo, hi) = (steps[0], steps[steps.len() - 1]);
            qa_common.push(QaFlag::Resampled {
                from: format!("uneven time column {} (steps {lo:.6}–{hi:.6} s), linear interpolation onto {rate_hz} Hz", names[tc]),
            });
            for v in values.iter_mut() {
                *v = resample_linear(&times, v, 1.0 / rate_hz);
            }
        }
        if let Some(r) = opts.sampling_rate_hz {
            if ((r - rate_hz) / rate_hz).abs() > 0.01 {
                qa_common.push(QaFlag::Note {
                    text: format!("manifest sampling rate {r} Hz disagrees with the time column ({rate_hz} Hz); the time column was used"),
                });
            }
        }
    } else if let Some(r) = opts.sampling_rate_hz.or(preamble_rate) {
        if !(r.is_finite() && r > 0.0) {
            return Err(Error::usage(format!(
                "sampling rate {r} Hz is not positive"
            )));
        }
        rate_hz = r;
    } else {
        return Err(Error::input(
            loc(header_line),
            "no time column and no sampling rate: give `sampling_rate_hz` (or `time_column`) in the manifest",
        ));
    }

    let prefix = station.clone().unwrap_or_else(|| {
        std::path::Path::new(&src.file)
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_default()
    });
    let mut records = Vec::new();
    for (k, &c) in selected.iter().enumerate() {
        let name = &names[c];
        let mut s = src.clone();
        s.column = Some(name.clone());
        let mut missing = Vec::new();
        let mut inferred = inferred_common.clone();
        let mut qa = qa_common.clone();
        let units = match unit_text(name) {
            Some(u) => match u.parse::<Units>() {
                Ok(units) => units,
                Err(e) => {
                    qa.push(QaFlag::Note {
                        text: format!("column {name}: {e}"),
                    });
                    missing.push("units".to_string());
                    inferred.push(format!(
                        "units=m/s2 assumed: unit {u:?} of column {name} is not understood"
                    ));
                    Units::MPerS2
                }
            },
            None => {
                missing.push("units".to_string());
                inferred.push(if is_xsens && base_name(name).starts_with("acc") {
                    format!("units=m/s2 assumed: column {name} states none; Xsens DOT exports Acc_* in m/s² (including gravity)")
                } else {
                    format!("units=m/s2 assumed: column {name} states none")
                });
                Units::MPerS2
            }
        };
        let mut ch = Channel::new(format!("{prefix}.{name}"), units, rate_hz, s);
        ch.station = station.clone();
        if let Some((ns, zone, line)) = &start {
            ch.start_ns = Some(*ns);
            inferred.push(format!(
                "start time from the StartTime line {} ({zone})",
                line + 1
            ));
        }
        let nonfinite = values[k].iter().filter(|v| !v.is_finite()).count();
        if nonfinite > 0 {
            qa.push(QaFlag::NonFinite { count: nonfinite });
        }
        ch.missing = missing;
        ch.inferred = inferred;
        ch.qa = qa;
        records.push(Record::new(ch, std::mem::take(&mut values[k])));
    }
    Ok(FileContents {
        records,
        ..Default::default()
    })
}

/// Linear interpolation of (t, v) onto t0 + i·dt, i = 0..=floor((t_last − t0)/dt).
/// `t` must increase strictly.
fn resample_linear(t: &[f64], v: &[f64], dt: f64) -> Vec<f64> {
    let (Some(&t0), Some(&t_last)) = (t.first(), t.last()) else {
        return Vec::new();
    };
    let count = ((t_last - t0) / dt + 1e-9).floor() as usize + 1;
    let mut out = Vec::with_capacity(count);
    let mut j = 0;
    for i in 0..count {
        let ti = t0 + i as f64 * dt;
        while j + 2 < t.len() && t[j + 1] < ti {
            j += 1;
        }
        let (ta, tb) = (t[j], t[(j + 1).min(t.len() - 1)]);
        let w = if tb > ta {
            ((ti - ta) / (tb - ta)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.push(v[j] + w * (v[(j + 1).min(v.len() - 1)] - v[j]));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn src() -> SourceRef {
        SourceRef {
            file: "x.csv".into(),
            ..Default::default()
        }
    }

    #[test]
    fn semicolon_with_units_and_time() {
        let text = "# test\ntime[s];acc_x[m/s2];acc_y (g);temp\n0.00;1;2;20\n0.01;3;4;20\n0.02;5;6;20\n0.03;7;8;20\n";
        let fc = read(text.as_bytes(), &src(), &ReadOptions::default()).unwrap();
        assert_eq!(fc.records.len(), 2);
        assert_eq!(fc.records[0].channel.units, Units::MPerS2);
        assert_eq!(fc.records[1].channel.units, Units::G);
        assert_eq!(fc.records[0].channel.sampling_rate_hz, 100.0);
        assert_eq!(fc.records[1].samples, vec![2.0, 4.0, 6.0, 8.0]);
        assert!(fc.records[0].channel.missing.is_empty());
    }

    #[test]
    fn uneven_time_is_resampled() {
        // v = 10 t sampled at uneven times: linear resampling is exact.
        let ts = [0.0, 0.1, 0.19, 0.31, 0.4, 0.5, 0.6];
        let mut text = String::from("t,a_x\n");
        for t in ts {
            text += &format!("{t},{}\n", 10.0 * t);
        }
        let fc = read(text.as_bytes(), &src(), &ReadOptions::default()).unwrap();
        let r = &fc.records[0];
        assert_eq!(r.channel.sampling_rate_hz, 10.0);
        assert!(r
            .channel
            .qa
            .iter()
            .any(|q| matches!(q, QaFlag::Resampled { .. })));
        assert_eq!(r.samples.len(), 7);
        for (i, v) in r.samples.iter().enumerate() {
            assert!((v - i as f64).abs() < 1e-9, "{i}: {v}");
        }
    }

    #[test]
    fn whitespace_no_header_needs_rate() {
        let text = "1 2\n3 4\n5 6\n";
        let opts = ReadOptions {
            sampling_rate_hz: Some(50.0),
            columns: Some(vec!["1".into()]),
            ..Default::default()
        };
        let fc = read(text.as_bytes(), &src(), &opts).unwrap();
        assert_eq!(fc.records[0].samples, vec![2.0, 4.0, 6.0]);
        let e = read(
            text.as_bytes(),
            &src(),
            &ReadOptions {
                columns: Some(vec!["0".into()]),
                ..Default::default()
            },
        );
        assert!(e.is_err());
    }

    #[test]
    fn xsens_start_time_zone() {
        let (ns, _) = parse_start_time("2025-03-06_12:26:07_000 PST").unwrap();
        assert_eq!(ns, epoch_ns_from_civil(2025, 3, 6, 20, 26, 7.0).unwrap());
        let (ns, _) = parse_start_time("2025-04-11_11:49:50_000 PDT").unwrap();
        assert_eq!(ns, epoch_ns_from_civil(2025, 4, 11, 18, 49, 50.0).unwrap());
    }
}
