//! Realistic building benchmarks (issue 31 item 7), written as the networks
//! publish them — no manifest, nothing a real file would not hold — with a
//! `truth.toml` beside the record archive:
//! - [`nsmp`]: a 12-storey frame in plan (x, y, θ; eccentric mass), NSMP-style
//!   zip of SMC V2 files with `<loclbl=…>` labels;
//! - [`tall`]: a 40-storey building with a ≈0.2 Hz fundamental, a CSMIP V2 zip;
//! - [`degrading`]: a 6-storey frame whose ground storey yields and loses
//!   stiffness, a CSMIP V2 zip of one file per channel.
//!
//! Records are "processed" as V2 volumes are: the acceleration band-passed
//! (4th-order Butterworth, zero phase) and integrated (trapezoid) to the
//! velocity and displacement the CSMIP volumes carry.  The truth is the
//! model's, unfiltered and noise-free.  Level convention (team-wide): level 0
//! is the base; "Nth Floor" is level N − 1; "Roof" is level `storeys`.

pub mod degrading;
pub mod nsmp;
pub mod tall;

use std::fmt::Write as _;
use std::io::Write as _;

use crate::conditioning::{butter_sos, sosfiltfilt, BandType};
use crate::error::{Error, Result};
use crate::synth::smc_writer::CivilTime;
use crate::vocab::{epoch_ns_from_civil, format_epoch_ns};

/// Centimetres per metre.
pub const CM_PER_M: f64 = 100.0;

/// A deterministic zip (deflate, fixed time stamp, mode 0644) of `members`.
pub fn zip_bytes(members: &[(String, Vec<u8>)], stamp: &CivilTime) -> Result<Vec<u8>> {
    use zip::write::SimpleFileOptions;
    let time = zip::DateTime::from_date_and_time(
        stamp.year as u16,
        stamp.month as u8,
        stamp.day as u8,
        stamp.hour as u8,
        stamp.minute as u8,
        0,
    )
    .map_err(|e| Error::numerical(format!("zip time stamp: {e}")))?;
    let options = SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated)
        .last_modified_time(time)
        .unix_permissions(0o644);
    let mut w = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let zerr = |e: zip::result::ZipError| Error::numerical(format!("writing zip: {e}"));
    for (name, data) in members {
        w.start_file(name.as_str(), options).map_err(zerr)?;
        w.write_all(data)
            .map_err(|e| Error::numerical(format!("writing zip member {name}: {e}")))?;
    }
    Ok(w.finish().map_err(zerr)?.into_inner())
}

/// V2 processing of an acceleration record (m/s²): band-pass `band_hz`
/// (Butterworth order 4, zero phase), then cm/s², cm/s and cm by the
/// trapezoid rule from rest.
pub fn v2_processed(acc_m_s2: &[f64], rate_hz: f64, band_hz: (f64, f64)) -> Result<[Vec<f64>; 3]> {
    let sos = butter_sos(4, BandType::Bandpass, &[band_hz.0, band_hz.1], rate_hz)?;
    let acc: Vec<f64> = sosfiltfilt(&sos, acc_m_s2)?
        .into_iter()
        .map(|v| v * CM_PER_M)
        .collect();
    let vel = trapezoid(&acc, 1.0 / rate_hz);
    let disp = trapezoid(&vel, 1.0 / rate_hz);
    Ok([acc, vel, disp])
}

/// Running trapezoid integral from 0.
pub fn trapezoid(v: &[f64], dt: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(v.len());
    let mut sum = 0.0;
    for (i, x) in v.iter().enumerate() {
        if i > 0 {
            sum += 0.5 * dt * (x + v[i - 1]);
        }
        out.push(sum);
    }
    out
}

/// UTC civil time of `iso` (`2026-07-14T10:31:20.000Z`) shifted by `offset_h` hours.
pub fn civil(iso_utc: &str, offset_h: i64) -> Result<CivilTime> {
    let ns = crate::vocab::parse_iso8601_ns(iso_utc)
        .ok_or_else(|| Error::usage(format!("bad time {iso_utc:?}")))?
        + offset_h * 3_600_000_000_000;
    let text = format_epoch_ns(ns);
    let num = |a: usize, b: usize| text.get(a..b).and_then(|t| t.parse::<f64>().ok());
    match (
        num(0, 4),
        num(5, 7),
        num(8, 10),
        num(11, 13),
        num(14, 16),
        num(17, 23),
    ) {
        (Some(y), Some(mo), Some(d), Some(h), Some(mi), Some(s)) => Ok(CivilTime {
            year: y as i64,
            month: mo as i64,
            day: d as i64,
            hour: h as i64,
            minute: mi as i64,
            second: s,
        }),
        _ => Err(Error::numerical(format!(
            "cannot read back the time {text:?}"
        ))),
    }
}

/// English weekday abbreviation of a civil date (1970-01-01 was a Thursday).
pub fn weekday(t: &CivilTime) -> &'static str {
    const DAYS: [&str; 7] = ["Thu", "Fri", "Sat", "Sun", "Mon", "Tue", "Wed"];
    let ns = epoch_ns_from_civil(t.year, t.month as u32, t.day as u32, 0, 0, 0.0).unwrap_or(0);
    DAYS[(ns.div_euclid(86_400_000_000_000)).rem_euclid(7) as usize]
}

/// `1st`, `2nd`, `3rd`, `11th`, `21st` …
pub fn ordinal(n: usize) -> String {
    let suffix = match (n % 10, n % 100) {
        (_, 11..=13) => "th",
        (1, _) => "st",
        (2, _) => "nd",
        (3, _) => "rd",
        _ => "th",
    };
    format!("{n}{suffix}")
}

/// The location label of a level (module doc's convention): `base` at
/// level 0, `Roof` at the top, `(level + 1)th Floor` between.
pub fn level_label(level: usize, storeys: usize, base: &str) -> String {
    if level == 0 {
        base.to_string()
    } else if level == storeys {
        "Roof".to_string()
    } else {
        format!("{} Floor", ordinal(level + 1))
    }
}

/// Largest |value|.
pub fn peak_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// Heights of the levels above the base, m (cumulative storey heights).
pub fn level_heights(storey_heights_m: &[f64]) -> Vec<f64> {
    let mut z = vec![0.0];
    for h in storey_heights_m {
        z.push(z.last().copied().unwrap_or(0.0) + h);
    }
    z
}

/// Drift truth between two levels of one displacement history pair:
/// one `[[…]]` TOML table (`table` names it) with the peak and final drift.
#[allow(clippy::too_many_arguments)]
pub fn drift_table(
    s: &mut String,
    table: &str,
    labels: &[(&str, String)],
    lower: Option<&[f64]>,
    upper: &[f64],
    height_m: f64,
    residual_m: f64,
) {
    let drift: Vec<f64> = match lower {
        Some(l) => upper.iter().zip(l).map(|(u, b)| u - b).collect(),
        None => upper.to_vec(),
    };
    let peak = peak_abs(&drift);
    let _ = writeln!(s, "\n[[{table}]]");
    for (k, v) in labels {
        let _ = writeln!(s, "{k} = {v}");
    }
    let _ = writeln!(s, "height_m = {height_m}");
    let _ = writeln!(s, "peak_drift_m = {peak:.6e}");
    let _ = writeln!(s, "peak_drift_ratio = {:.6e}", peak / height_m);
    let _ = writeln!(s, "residual_drift_m = {residual_m:.6e}");
    let _ = writeln!(s, "residual_drift_ratio = {:.6e}", residual_m / height_m);
}

/// The `[[storey_drift]]` rows of storeys 1..=n and the `[[segment_drift]]`
/// rows between consecutive instrumented `levels` of one axis, n =
/// `storey_heights_m.len()`: `relative_displacement[l − 1]` is level l's
/// displacement relative to the base, `at_rest(l)` its displacement once the
/// motion has ended (the residual drift of a row is the difference of its
/// two levels' values).
pub fn storey_and_segment_drifts(
    s: &mut String,
    axis: &str,
    relative_displacement: &[Vec<f64>],
    storey_heights_m: &[f64],
    levels: &[usize],
    at_rest: impl Fn(usize) -> f64,
) {
    let disp = |l: usize| (l > 0).then(|| relative_displacement[l - 1].as_slice());
    let z = level_heights(storey_heights_m);
    for st in 1..=storey_heights_m.len() {
        let labels = [("storey", st.to_string()), ("axis", format!("\"{axis}\""))];
        drift_table(
            s,
            "storey_drift",
            &labels,
            disp(st - 1),
            &relative_displacement[st - 1],
            storey_heights_m[st - 1],
            at_rest(st) - at_rest(st - 1),
        );
    }
    for w in levels.windows(2) {
        let labels = [
            ("from_level", w[0].to_string()),
            ("to_level", w[1].to_string()),
            ("axis", format!("\"{axis}\"")),
        ];
        drift_table(
            s,
            "segment_drift",
            &labels,
            disp(w[0]),
            &relative_displacement[w[1] - 1],
            z[w[1]] - z[w[0]],
            at_rest(w[1]) - at_rest(w[0]),
        );
    }
}

/// Writes `bytes` to `dir/name` (atomically).
pub fn write_file(dir: &std::path::Path, name: &str, bytes: &[u8]) -> Result<()> {
    crate::sinks::parquet::write_bytes_atomically(&dir.join(name), bytes)
}
