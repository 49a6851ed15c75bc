//! UTC timestamps as i64 nanoseconds since the Unix epoch.  Written by hand
//! (days-from-civil arithmetic) because readers only need calendar <-> epoch
//! conversion in UTC, with no time zones; a date-time crate would add weight
//! for twenty lines of integer arithmetic.

const NS_PER_S: i64 = 1_000_000_000;

/// Days since 1970-01-01 for a proleptic Gregorian date (y, m 1..12, d 1..31).
fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = if y >= 0 { y } else { y - 399 } / 400;
    let yoe = y - era * 400;
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

fn civil_from_days(z: i64) -> (i64, i64, i64) {
    let z = z + 719_468;
    let era = if z >= 0 { z } else { z - 146_096 } / 146_097;
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    (if m <= 2 { y + 1 } else { y }, m, d)
}

/// Epoch nanoseconds for a UTC civil time; `second` may carry a fraction.
/// Returns `None` for out-of-range fields and for times that i64
/// nanoseconds cannot hold (before 1677-09-21 or after 2262-04-11): a year
/// read from a damaged header never wraps into another century.
pub fn epoch_ns_from_civil(
    year: i64,
    month: u32,
    day: u32,
    hour: u32,
    minute: u32,
    second: f64,
) -> Option<i64> {
    if !(1..=12).contains(&month)
        || !(1..=31).contains(&day)
        || hour > 24
        || minute > 59
        || !(0.0..61.0).contains(&second)
    {
        return None;
    }
    // Years beyond ±10⁶ are far outside the i64 range below; bounding them
    // first keeps the day arithmetic itself from overflowing.
    if !(-1_000_000..=1_000_000).contains(&year) {
        return None;
    }
    let days = days_from_civil(year, month as i64, day as i64);
    let whole = second.floor();
    let frac_ns = ((second - whole) * 1e9).round() as i64;
    (days * 86_400 + hour as i64 * 3600 + minute as i64 * 60 + whole as i64)
        .checked_mul(NS_PER_S)?
        .checked_add(frac_ns)
}

/// Epoch nanoseconds from a day-of-year form (SEED, SAC): year, day 1..366.
pub fn epoch_ns_from_ordinal(
    year: i64,
    day_of_year: u32,
    hour: u32,
    minute: u32,
    second: f64,
) -> Option<i64> {
    if !(1..=366).contains(&day_of_year) {
        return None;
    }
    let jan1 = epoch_ns_from_civil(year, 1, 1, hour, minute, second)?;
    jan1.checked_add((day_of_year as i64 - 1) * 86_400 * NS_PER_S)
}

/// A UTC time in the day-of-year form of SEED headers and SDS file names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OrdinalTime {
    pub year: i64,
    /// 1..=366.
    pub day_of_year: u32,
    pub hour: u32,
    pub minute: u32,
    pub second: u32,
    /// Nanoseconds within the second.
    pub nanosecond: u32,
}

/// The day-of-year form of epoch nanoseconds `ns` (inverse of [`epoch_ns_from_ordinal`]).
pub fn ordinal_from_epoch_ns(ns: i64) -> OrdinalTime {
    let secs = ns.div_euclid(NS_PER_S);
    let days = secs.div_euclid(86_400);
    let sod = secs.rem_euclid(86_400);
    let (y, _, _) = civil_from_days(days);
    OrdinalTime {
        year: y,
        day_of_year: (days - days_from_civil(y, 1, 1) + 1) as u32,
        hour: (sod / 3600) as u32,
        minute: ((sod / 60) % 60) as u32,
        second: (sod % 60) as u32,
        nanosecond: ns.rem_euclid(NS_PER_S) as u32,
    }
}

/// Epoch nanoseconds of the UTC midnight that starts the day holding `ns`.
pub fn day_start_ns(ns: i64) -> i64 {
    ns.div_euclid(86_400 * NS_PER_S) * 86_400 * NS_PER_S
}

/// `2018-11-30T17:28:59.334500000Z`
pub fn format_epoch_ns(ns: i64) -> String {
    let secs = ns.div_euclid(NS_PER_S);
    let sub = ns.rem_euclid(NS_PER_S);
    let days = secs.div_euclid(86_400);
    let sod = secs.rem_euclid(86_400);
    let (y, m, d) = civil_from_days(days);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}.{sub:09}Z",
        sod / 3600,
        (sod / 60) % 60,
        sod % 60
    )
}

/// Parses `YYYY-MM-DD[T ]HH:MM:SS[.fff][Z]` (UTC; a trailing `Z` or nothing).
pub fn parse_iso8601_ns(s: &str) -> Option<i64> {
    let s = s.trim().trim_end_matches('Z');
    let (date, time) = s.split_once(['T', ' ']).unwrap_or((s, "00:00:00"));
    let mut dp = date.split('-');
    let y: i64 = dp.next()?.parse().ok()?;
    let m: u32 = dp.next()?.parse().ok()?;
    let d: u32 = dp.next()?.parse().ok()?;
    let mut tp = time.split(':');
    let hh: u32 = tp.next()?.parse().ok()?;
    let mm: u32 = tp.next().unwrap_or("0").parse().ok()?;
    let ss: f64 = tp.next().unwrap_or("0").parse().ok()?;
    epoch_ns_from_civil(y, m, d, hh, mm, ss)
}
