//! CSMIP (California Geological Survey) "Processed" V2 writer, the modern
//! layout of the CESMD downloads (`CHAN001.V2` … in a station zip) that
//! `readers::dmg` reads: per channel a 25-line text header (volume label,
//! `Rcrd of` trigger time in local time, `Start time:` in UTC, `Station No.`
//! line, station name, `Chan  n: <orientation>  (Sta Chn: k)  Location: …`,
//! filter band, peaks), 100 integers (16I5: [0] recorder channel, [2]
//! station channel, [16..23] start hour, minute, second, tenths, day of
//! year, month, day, year, [26] orientation azimuth (500 = up), [27] point
//! count), 100 reals (8F10.x: instrument period and damping, record length,
//! station coordinates; −999 elsewhere), then the acceleration (cm/sec2),
//! velocity (cm/sec) and displacement (cm) sections in 8F10 fixed fields
//! (decimals chosen so the section's largest value fits ten columns, stated
//! in each section line), and the `/&` end-of-channel line.  Several
//! channels may follow one another in one file (older multi-channel V2).
//! Pure text formatting, no I/O.

use std::fmt::Write as _;

use super::smc_writer::CivilTime;

/// Orientation of a CSMIP channel: an azimuth (`90 Deg`) or up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CsmipOrientation {
    AzimuthDeg(i64),
    Up,
}

/// One CSMIP V2 channel (acceleration and its integrals).
#[derive(Debug, Clone)]
pub struct CsmipChannel<'a> {
    pub station_number: u32,
    /// E.g. `Sample City - 6-story Commercial Bldg`.
    pub station_name: String,
    pub latitude: f64,
    /// East positive (written as `118.250W` when negative).
    pub longitude: f64,
    pub recorder: String,
    pub serial: u32,
    pub recorder_channel: u32,
    pub recorder_channels: u32,
    pub station_channel: u32,
    pub station_channels: u32,
    pub orientation: CsmipOrientation,
    /// `Location:` text, e.g. `Roof: near center`.
    pub location: String,
    /// Record start, UTC, and the local trigger time printed on `Rcrd of`
    /// lines with its zone (e.g. UTC − 7 h, `PDT`).
    pub start_utc: CivilTime,
    pub start_local: CivilTime,
    pub local_weekday: String,
    pub local_zone: String,
    /// Corners of the band-pass applied to the acceleration, Hz.
    pub band_hz: (f64, f64),
    pub sampling_rate_hz: f64,
    pub accel_cm_s2: &'a [f64],
    pub veloc_cm_s: &'a [f64],
    pub displ_cm: &'a [f64],
}

const MONTHS: [&str; 12] = [
    "Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec",
];

/// Fortran `F10.d` without the leading zero (`  -.001129`).
pub fn fortran_f10(v: f64, decimals: usize) -> String {
    let text = format!("{v:.decimals$}");
    let text = if let Some(rest) = text.strip_prefix("-0.") {
        format!("-.{rest}")
    } else if let Some(rest) = text.strip_prefix("0.") {
        format!(".{rest}")
    } else {
        text
    };
    let text = if text
        .trim_start_matches('-')
        .chars()
        .all(|c| c == '.' || c == '0')
    {
        text.trim_start_matches('-').to_string()
    } else {
        text
    };
    format!("{text:>10}")
}

/// Decimals of an `F10.d` section that fit its largest magnitude (d ≤ `most`).
pub fn section_decimals(values: &[f64], most: usize) -> usize {
    let peak = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    // Ten columns hold a sign, the integer digits, the point and d decimals.
    let integer_digits = if peak < 1.0 {
        0
    } else {
        peak.log10().floor() as usize + 1
    };
    most.min(8usize.saturating_sub(integer_digits))
}

/// The value an `F10.d` field written by [`fortran_f10`] reads back as.
pub fn fortran_f10_rounded(v: f64, decimals: usize) -> f64 {
    fortran_f10(v, decimals).trim().parse().unwrap_or(0.0)
}

fn civil_text(t: &CivilTime) -> String {
    format!(
        "{:>2}/{:02}/{:02}, {:02}:{:02}:{:04.1}",
        t.month,
        t.day,
        t.year % 100,
        t.hour,
        t.minute,
        t.second
    )
}

fn orientation_text(o: CsmipOrientation) -> String {
    match o {
        CsmipOrientation::AzimuthDeg(a) => format!("{a:>3} Deg"),
        CsmipOrientation::Up => "Up".into(),
    }
}

/// Day of the year of a civil date.
fn day_of_year(t: &CivilTime) -> i64 {
    const CUMULATIVE: [i64; 12] = [0, 31, 59, 90, 120, 151, 181, 212, 243, 273, 304, 334];
    let leap = (t.year % 4 == 0 && t.year % 100 != 0) || t.year % 400 == 0;
    CUMULATIVE[(t.month - 1) as usize] + t.day + i64::from(leap && t.month > 2)
}

/// The CSMIP V2 text of one channel block, ending with its `/&` line.
pub fn csmip_v2_text(ch: &CsmipChannel) -> String {
    let n = ch.accel_cm_s2.len();
    let dt = 1.0 / ch.sampling_rate_hz;
    let mut s = String::with_capacity(n * 31 + 8192);
    let st = &ch.start_utc;
    let tag = format!(
        "{:05}-S{:04}-{:02}{:03}.{:02}",
        ch.station_number,
        ch.serial,
        st.year % 100,
        day_of_year(st),
        st.hour * 100 / 24
    );
    let lt = &ch.start_local;
    let rcrd = format!(
        "Rcrd of {} {} {:>2}, {} {:02}:{:02}:{:04.1} {}",
        ch.local_weekday,
        MONTHS[(lt.month - 1) as usize],
        lt.day,
        lt.year,
        lt.hour,
        lt.minute,
        lt.second,
        ch.local_zone
    );
    let chan = format!(
        "Chan {:>2}: {}",
        ch.recorder_channel,
        orientation_text(ch.orientation)
    );
    let lat = format!(
        "{:.3}{}",
        ch.latitude.abs(),
        if ch.latitude < 0.0 { 'S' } else { 'N' }
    );
    let lon = format!(
        "{:.3}{}",
        ch.longitude.abs(),
        if ch.longitude < 0.0 { 'W' } else { 'E' }
    );
    let line = |s: &mut String, text: String| {
        let _ = writeln!(s, "{text:<80}");
    };
    let (accel_peak_i, _) = peak_of(ch.accel_cm_s2);
    let (veloc_peak_i, _) = peak_of(ch.veloc_cm_s);
    let (displ_peak_i, _) = peak_of(ch.displ_cm);
    let at = |v: &[f64], i: usize| v.get(i).copied().unwrap_or(0.0);
    line(
        &mut s,
        format!("Corrected accelerogram   {tag:<27}{chan:<21}from"),
    );
    line(
        &mut s,
        format!(
            "Uncorrected Accelerogram Data             Processed: {:02}/{:02}/{:02}, CGS",
            st.month,
            st.day,
            st.year % 100
        ),
    );
    line(&mut s, format!("{rcrd:<50}(Avol1 v6.4,64b,12/18; PC96)"));
    line(
        &mut s,
        "CSMIP Preliminary Processing            (Origin:  To be determined)".into(),
    );
    line(
        &mut s,
        format!("{tag:<37}Start time: {} UTC (GPS)", civil_text(st)),
    );
    line(
        &mut s,
        format!(
            "Station No. {:>5}   {lat}, {lon}    {:<6}  s/n {:>4}  ({} Chns of {:>2} at Sta)",
            ch.station_number, ch.recorder, ch.serial, ch.recorder_channels, ch.station_channels
        ),
    );
    line(
        &mut s,
        format!("{:<42}CGS   Data: Acceleration", ch.station_name),
    );
    line(
        &mut s,
        format!(
            "{chan:<17}  (Sta Chn: {:>2})     Location: {}",
            ch.station_channel, ch.location
        ),
    );
    line(&mut s, format!("{rcrd:<43}{}", &rcrd[8..]));
    line(
        &mut s,
        "Hypocenter:  To be determined.               ML:  To be determined.".into(),
    );
    line(
        &mut s,
        "Instr Period = 0.0100 sec,  Damping = 0.650,  Sensitivity = 1.25 v/g".into(),
    );
    line(
        &mut s,
        format!(
            "                        Record Length = {:.3} sec.",
            n as f64 * dt
        ),
    );
    line(
        &mut s,
        format!(
            "                                     Uncor Max  = {:.3} g, at {:>8.3} sec.",
            at(ch.accel_cm_s2, accel_peak_i) / 980.665,
            accel_peak_i as f64 * dt
        ),
    );
    line(
        &mut s,
        "RMS accel of (uncor) record  =        .   Chn. metadata effective date: 01/01/20".into(),
    );
    line(
        &mut s,
        format!(
            "Accelerogram bandpass filtered with 3 dB pts at {:>5} and {:.2} cyc/sec",
            fortran_f10(ch.band_hz.0, 2).trim(),
            ch.band_hz.1
        ),
    );
    line(
        &mut s,
        format!("{n:>6} points of instrument- and baseline-corrected accel, veloc and displ data"),
    );
    line(
        &mut s,
        format!(
            "At equally-spaced intervals of {:>8}  sec.",
            fortran_f10(dt, 3).trim()
        ),
    );
    line(
        &mut s,
        format!(
            "Peak acceleration = {:>9.3}    cm/sec/sec  at {:>8.3}   sec.",
            at(ch.accel_cm_s2, accel_peak_i),
            accel_peak_i as f64 * dt
        ),
    );
    line(
        &mut s,
        format!(
            "Peak   velocity   = {:>9.3}      cm/sec    at {:>8.3}   sec.",
            at(ch.veloc_cm_s, veloc_peak_i),
            veloc_peak_i as f64 * dt
        ),
    );
    line(
        &mut s,
        format!(
            "Peak displacement = {:>9.3}        cm      at {:>8.3}   sec.",
            at(ch.displ_cm, displ_peak_i),
            displ_peak_i as f64 * dt
        ),
    );
    line(
        &mut s,
        format!(
            "Initial velocity  = {:>9.3}   cm/sec;   Initial displacement = {:>8.3}   cm",
            at(ch.veloc_cm_s, 0),
            at(ch.displ_cm, 0)
        ),
    );
    line(&mut s, format!("{rcrd:<43}{}", &rcrd[8..]));
    line(&mut s, String::new());
    line(&mut s, format!("{tag:<26}{:<42}{chan}", ch.station_name));
    line(&mut s, String::new());
    let mut ints = [0i64; 100];
    ints[0] = ch.recorder_channel.into();
    ints[1] = 100;
    ints[2] = ch.station_channel.into();
    ints[3] = ch.recorder_channels.into();
    ints[4] = ch.station_channels.into();
    ints[11] = ch.serial.into();
    ints[13] = ch.station_number.into();
    ints[16] = st.hour;
    ints[17] = st.minute;
    ints[18] = st.second.floor() as i64;
    ints[19] = ((st.second - st.second.floor()) * 10.0).round().min(9.0) as i64;
    ints[20] = day_of_year(st);
    ints[21] = st.month;
    ints[22] = st.day;
    ints[23] = st.year;
    ints[26] = match ch.orientation {
        CsmipOrientation::AzimuthDeg(a) => a,
        CsmipOrientation::Up => 500,
    };
    ints[27] = n as i64;
    for row in ints.chunks(16) {
        for v in row {
            let _ = write!(s, "{v:>5}");
        }
        s.push('\n');
    }
    let mut reals = [-999.0f64; 100];
    reals[0] = 0.01;
    reals[1] = 0.65;
    reals[2] = n as f64 * dt;
    reals[28] = ch.latitude;
    reals[29] = ch.longitude;
    for row in reals.chunks(8) {
        for v in row {
            s.push_str(&fortran_f10(*v, if v.abs() >= 100.0 { 5 } else { 7 }));
        }
        s.push('\n');
    }
    let dt_text = fortran_f10(dt, 3);
    for (kind, units, values, most) in [
        ("accel", "cm/sec2.", ch.accel_cm_s2, 6),
        ("veloc", "cm/sec. ", ch.veloc_cm_s, 7),
        ("displ", "cm.     ", ch.displ_cm, 7),
    ] {
        let d = section_decimals(values, most);
        let _ = writeln!(
            s,
            "{n:>6} points of {kind} data equally spaced at {} sec, in {units} (8f10.{d})",
            dt_text.trim_start().trim_end()
        );
        for row in values.chunks(8) {
            for v in row {
                s.push_str(&fortran_f10(*v, d));
            }
            s.push('\n');
        }
    }
    let _ = writeln!(
        s,
        "/&  ----------  End of data for channel {:>2}  ----------",
        ch.recorder_channel
    );
    s
}

/// Index and magnitude of the largest |value|.
fn peak_of(v: &[f64]) -> (usize, f64) {
    v.iter().enumerate().fold(
        (0, 0.0),
        |(bi, bv), (i, x)| if x.abs() > bv { (i, x.abs()) } else { (bi, bv) },
    )
}
