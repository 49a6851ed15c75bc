//! USGS SMC writer: one channel per file, the layout `readers::smc` reads
//! (and documents): 11 text lines, 48 integers (8I10), 50 reals (5E15.7),
//! `|` comment lines, then the samples in 8E10.4 (mantissa d.dddd, a
//! one-digit exponent, fields touching as in real files).  The integer
//! header carries the record start in the NSMP layout (year, month, day,
//! hour, minute, second, millisecond in fields 2–8), the channel number,
//! the vertical angle (90 = horizontal, 0 = up) and the horizontal azimuth
//! (fields 13–14), the comment count (16) and the sample count (17); the
//! real header the sampling rate, the hypocentre, the magnitudes, the
//! station coordinates, the epicentral distance and the times and values
//! of the extremes.  Everything else holds the "missing" codes −32768 and
//! 1.7E+38, as real files do.  Pure text formatting, no I/O.

use std::fmt::Write as _;

/// SMC integer "missing" code.
const INT_MISSING: i64 = -32768;
/// SMC real "missing" sentinel.
const REAL_MISSING: f64 = 1.7e38;

/// Record start (UTC) as SMC stores it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CivilTime {
    pub year: i64,
    pub month: i64,
    pub day: i64,
    pub hour: i64,
    pub minute: i64,
    /// Seconds with the milliseconds, 0 ≤ s < 60.
    pub second: f64,
}

/// One SMC "2 CORRECTED ACCELEROGRAM" channel.
#[derive(Debug, Clone)]
pub struct SmcChannel<'a> {
    /// Text line 3 (the station code; the reader keeps its first four characters).
    pub station_code: String,
    /// Text line 6 before `component=`.
    pub station_name: String,
    /// `component=` text: an azimuth (`"20"`) or `"up"`.
    pub component: String,
    /// Horizontal azimuth (integer field 14), `None` for a vertical sensor.
    pub azimuth_deg: Option<i64>,
    /// Channel number at the station (integer field 9) and the station's channel count (10–11).
    pub channel_number: i64,
    pub station_channels: i64,
    /// Event date and time (line 4, to the minute) and name.
    pub event_time: CivilTime,
    pub event_name: String,
    pub magnitude: f64,
    /// Hypocentre latitude, longitude (degrees) and depth (km).
    pub hypocentre: (f64, f64, f64),
    pub station_lat_lon: (f64, f64),
    pub epicentral_distance_km: f64,
    pub instrument: String,
    pub start: CivilTime,
    pub sampling_rate_hz: f64,
    /// Comment lines without their leading `|`.
    pub comments: Vec<String>,
    /// Acceleration, cm/s² (the SMC convention).
    pub samples_cm_s2: &'a [f64],
}

/// A text line padded to 80 columns, as the real files are.
fn line80(s: &mut String, text: &str) {
    let _ = writeln!(s, "{text:<80}");
}

/// Fortran `E15.7`: ` 0.2000000E+03`, `-0.1218830E+03`.
pub fn fortran_e15_7(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{:>15}", "0.0000000E+00");
    }
    let mut exponent = v.abs().log10().floor() as i32 + 1;
    let mut mantissa = (v.abs() / 10f64.powi(exponent) * 1e7).round();
    if mantissa >= 1e7 {
        mantissa /= 10.0;
        exponent += 1;
    }
    let sign = if v < 0.0 { "-" } else { "" };
    let exp_sign = if exponent < 0 { '-' } else { '+' };
    format!(
        "{:>15}",
        format!(
            "{sign}0.{:07}E{exp_sign}{:02}",
            mantissa as i64,
            exponent.abs()
        )
    )
}

/// SMC data field `E10.4` with a one-digit exponent: ` 1.5057E+0`,
/// `-5.0138E-1`.  Values below 1E−9 in magnitude are written as zero
/// (they cannot be written in ten columns).
pub fn smc_e10_4(v: f64) -> String {
    if v.abs() < 1e-9 || !v.is_finite() {
        return " 0.0000E+0".to_string();
    }
    let mut exponent = v.abs().log10().floor() as i32;
    let mut mantissa = (v.abs() / 10f64.powi(exponent) * 1e4).round();
    if mantissa >= 1e5 {
        mantissa /= 10.0;
        exponent += 1;
    }
    let m = mantissa as i64;
    let sign = if v < 0.0 { '-' } else { ' ' };
    let exp_sign = if exponent < 0 { '-' } else { '+' };
    format!(
        "{sign}{}.{:04}E{exp_sign}{}",
        m / 10_000,
        m % 10_000,
        exponent.abs()
    )
}

/// The value an `E10.4` field written by [`smc_e10_4`] reads back as.
pub fn smc_e10_4_rounded(v: f64) -> f64 {
    smc_e10_4(v).trim().parse().unwrap_or(0.0)
}

/// The SMC text of `ch`.
pub fn smc_text(ch: &SmcChannel) -> String {
    let n = ch.samples_cm_s2.len();
    let mut s = String::with_capacity(n * 11 + 4096);
    let (imax, imin) = extremes(ch.samples_cm_s2);
    let peak = ch.samples_cm_s2.get(imax).copied().unwrap_or(0.0);
    let e = &ch.event_time;
    line80(&mut s, "2 CORRECTED ACCELEROGRAM");
    line80(&mut s, "*");
    line80(&mut s, &ch.station_code);
    line80(
        &mut s,
        &format!(
            "{:>9}{:>4}{:>4}    {:02}{:02} {}",
            e.year, e.month, e.day, e.hour, e.minute, ch.event_name
        ),
    );
    line80(
        &mut s,
        &format!(
            "Moment Mag={:>9.1} Ms={:>9.1} Ml={:>9.1}",
            ch.magnitude, ch.magnitude, ch.magnitude
        ),
    );
    line80(
        &mut s,
        &format!(
            "station = {} component={:>7}",
            ch.station_name, ch.component
        ),
    );
    line80(
        &mut s,
        &format!(
            "epicentral dist ={:>9.1}       pk     ={:>9.1}",
            ch.epicentral_distance_km,
            peak.abs()
                .max(ch.samples_cm_s2.get(imin).copied().unwrap_or(0.0).abs())
        ),
    );
    line80(
        &mut s,
        &format!("inst type={:<11}data source = USGS", ch.instrument),
    );
    for _ in 0..3 {
        line80(&mut s, "*");
    }
    let mut ints = [INT_MISSING; 48];
    let st = &ch.start;
    let whole = st.second.floor();
    ints[1] = st.year;
    ints[2] = st.month;
    ints[3] = st.day;
    ints[4] = st.hour;
    ints[5] = st.minute;
    ints[6] = whole as i64;
    ints[7] = ((st.second - whole) * 1000.0).round().min(999.0) as i64;
    ints[8] = ch.channel_number;
    ints[9] = ch.station_channels;
    ints[10] = ch.station_channels;
    ints[12] = if ch.azimuth_deg.is_some() { 90 } else { 0 };
    if let Some(az) = ch.azimuth_deg {
        ints[13] = az;
    }
    ints[15] = ch.comments.len() as i64;
    ints[16] = n as i64;
    for row in ints.chunks(8) {
        for v in row {
            let _ = write!(s, "{v:>10}");
        }
        s.push('\n');
    }
    let mut reals = [REAL_MISSING; 50];
    let dt = 1.0 / ch.sampling_rate_hz;
    reals[1] = ch.sampling_rate_hz;
    (reals[2], reals[3], reals[4]) = ch.hypocentre;
    reals[5] = ch.magnitude;
    (reals[10], reals[11]) = ch.station_lat_lon;
    reals[16] = ch.epicentral_distance_km;
    reals[28] = imax as f64 * dt;
    reals[29] = peak;
    reals[30] = imin as f64 * dt;
    reals[31] = ch.samples_cm_s2.get(imin).copied().unwrap_or(0.0);
    for row in reals.chunks(5) {
        for v in row {
            s.push_str(&fortran_e15_7(*v));
        }
        s.push('\n');
    }
    for c in &ch.comments {
        line80(&mut s, &format!("|{c}"));
    }
    for row in ch.samples_cm_s2.chunks(8) {
        for v in row {
            s.push_str(&smc_e10_4(*v));
        }
        s.push('\n');
    }
    s
}

/// Indices of the largest and the smallest sample.
fn extremes(v: &[f64]) -> (usize, usize) {
    let mut imax = 0;
    let mut imin = 0;
    for (i, x) in v.iter().enumerate() {
        if *x > v[imax] {
            imax = i;
        }
        if *x < v[imin] {
            imin = i;
        }
    }
    (imax, imin)
}
