//! The measured environmental series of `quaketwin track` (`--temperature`
//! a CSV of time, value; `--temperature-channel` a stream of the archive),
//! read into an [`EnvironmentSeries`] for the compensation (Eq. E1 of
//! docs/statistics.md).  The regression is unchanged by an affine change
//! of the series' unit, so a channel's counts serve as well as °C.

use std::path::Path;

use crate::error::{Error, Location, Result};
use crate::monitor::environment::EnvironmentSeries;
use crate::readers::sds::{SdsArchive, StreamPattern};
use crate::vocab::parse_iso8601_ns;

/// At most this many rows in a temperature CSV (10 years of 1-min samples).
pub const MAX_ROWS: usize = 6_000_000;

/// A time field: epoch seconds (a number) or an ISO-8601 UTC time.
fn parse_time(field: &str) -> Option<i64> {
    let f = field.trim();
    match f.parse::<f64>() {
        Ok(s) if s.is_finite() && s.abs() < 1e11 => Some((s * 1e9).round() as i64),
        Ok(_) => None,
        Err(_) => parse_iso8601_ns(f),
    }
}

/// Reads `time,value` rows (comma, semicolon or tab separated; a header
/// line whose fields are not a time and a number is skipped; `#` comments
/// and blank lines too).  A bad row is an input error naming file and line.
pub fn read_csv(path: &Path) -> Result<EnvironmentSeries> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let name = path.display().to_string();
    let mut pairs = Vec::new();
    let mut seen_header = false;
    for (k, line) in text.lines().enumerate() {
        let line_no = k + 1;
        let body = line.trim();
        if body.is_empty() || body.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = body.split([',', ';', '\t']).map(str::trim).collect();
        let bad = |msg: String| Error::input(Location::file(&name).at_line(line_no), msg);
        if fields.len() != 2 {
            return Err(bad(format!(
                "{} fields; a temperature file has two: time (ISO-8601 UTC or epoch seconds), value",
                fields.len()
            )));
        }
        let time = parse_time(fields[0]);
        let value = fields[1].parse::<f64>().ok();
        match (time, value) {
            (Some(t), Some(v)) if v.is_finite() => pairs.push((t, v)),
            (None, None) if pairs.is_empty() && !seen_header => seen_header = true,
            (None, _) => {
                return Err(bad(format!(
                    "time {:?} is neither an ISO-8601 UTC time (2026-01-01T00:00:00Z) nor epoch seconds",
                    fields[0]
                )))
            }
            _ => return Err(bad(format!("value {:?} is not a finite number", fields[1]))),
        }
        if pairs.len() > MAX_ROWS {
            return Err(bad(format!("more than {MAX_ROWS} rows")));
        }
    }
    if let Some(w) = pairs.windows(2).position(|p| p[1].0 == p[0].0) {
        return Err(Error::input(
            Location::file(&name),
            format!(
                "time {} given twice",
                crate::vocab::format_epoch_ns(pairs[w].0)
            ),
        ));
    }
    EnvironmentSeries::new(pairs, &name)
}

/// The mean of stream `id` (`NET.STA.LOC.CHAN`, no wildcard) over each
/// window `[t, t + length)` of `starts`; windows without samples give no
/// value.  Values as recorded (counts).
pub fn read_channel(
    root: &Path,
    id: &str,
    starts: &[i64],
    length_ns: i64,
) -> Result<EnvironmentSeries> {
    if id.contains(['*', '?']) {
        return Err(Error::usage(format!(
            "--temperature-channel {id:?}: one stream NET.STA.LOC.CHAN, without wildcards"
        )));
    }
    let archive = SdsArchive::open(root)?.select(&[StreamPattern::parse(id)?])?;
    let mut pairs = Vec::with_capacity(starts.len());
    for &t0 in starts {
        if let Some(w) = archive.read_window(t0, t0 + length_ns)? {
            let s = &w.signals[0];
            if !s.is_empty() {
                pairs.push((t0 + length_ns / 2, s.iter().sum::<f64>() / s.len() as f64));
            }
        }
        archive.forget_before(t0 + length_ns);
    }
    if pairs.is_empty() {
        return Err(Error::input(
            Location::file(root.display().to_string()).with_channel(id),
            "the temperature channel has no sample in the run's windows",
        ));
    }
    EnvironmentSeries::new(pairs, &format!("channel {id}"))
}
