//! SAC binary reader (evenly sampled time series, header version 6 or 7).
//!
//! Written by hand: no maintained Rust crate reads SAC.  Layout: a 632-byte
//! header (70 f32 words, 40 i32 words, 192 bytes of 8/16-character fields)
//! followed by NPTS f32 samples.  The byte order is detected from NVHDR (= 6,
//! or 7 for files with a double-precision footer, which is ignored) read in
//! either order.  Undefined header values are −12345.
//!
//! Units: IDEP = 8 (IACC) says "acceleration" (the SAC standard means nm/s²,
//! which strong-motion writers rarely follow; the Community Seismic Network
//! files store g including gravity).  The header cannot tell which, so the
//! reader assumes what IDEP implies in SI (m/s² for IACC), writes that
//! assumption to `inferred` and lists `"units"` in `missing`: the event
//! manifest must state the units.  When the values look like g including
//! gravity (mean near 1), a `QaFlag::Note` says so.
//!
//! f32 header values are widened through their shortest decimal form
//! (0.02f32 → 0.02, not 0.0199999995529651…), which is what the writer meant.

use super::{FileContents, ReadOptions};
use crate::error::{Error, Result};
use crate::vocab::{epoch_ns_from_ordinal, Channel, Direction, QaFlag, Record, SourceRef, Units};

/// Length of the binary header, bytes (the samples follow it).
pub const HEADER_LEN: usize = 632;
const UNDEFINED_F: f64 = -12345.0;
const UNDEFINED_I: i32 = -12345;

/// The header fields quaketwin uses (undefined ones are `None`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SacHeader {
    pub little_endian: bool,
    pub nvhdr: i32,
    pub delta: f64,
    pub b: Option<f64>,
    pub e: Option<f64>,
    pub npts: usize,
    /// NZYEAR, NZJDAY, NZHOUR, NZMIN, NZSEC, NZMSEC.
    pub reference: Option<[i32; 6]>,
    pub knetwk: Option<String>,
    pub kstnm: Option<String>,
    pub khole: Option<String>,
    pub kcmpnm: Option<String>,
    pub cmpaz: Option<f64>,
    pub cmpinc: Option<f64>,
    pub stla: Option<f64>,
    pub stlo: Option<f64>,
    pub stel: Option<f64>,
    pub idep: Option<i32>,
    pub iftype: Option<i32>,
    pub leven: Option<i32>,
}

impl SacHeader {
    /// Reference time + B, ns since the Unix epoch.
    pub fn start_ns(&self) -> Option<i64> {
        let [y, d, h, m, s, ms] = self.reference?;
        if !(0..=24).contains(&h)
            || !(0..=59).contains(&m)
            || !(0..=60).contains(&s)
            || !(0..=999).contains(&ms)
        {
            return None;
        }
        let t0 = epoch_ns_from_ordinal(
            y as i64,
            u32::try_from(d).ok()?,
            h as u32,
            m as u32,
            s as f64,
        )?;
        // B (the first sample's offset from the reference time) beyond the
        // i64 nanosecond range is no time at all: refused, never saturated.
        let b_ns = (self.b.unwrap_or(0.0) * 1e9).round();
        if !(b_ns.abs() < 9e18) {
            return None;
        }
        t0.checked_add(ms as i64 * 1_000_000)?
            .checked_add(b_ns as i64)
    }
}

/// f32 → f64 through the shortest decimal that round-trips the f32.
fn widen(v: f32) -> f64 {
    format!("{v}").parse::<f64>().unwrap_or(v as f64)
}

/// Whether `head` looks like a SAC binary header (NVHDR = 6 or 7 in either
/// byte order, positive DELTA), for format sniffing.
pub fn looks_like(head: &[u8]) -> bool {
    if head.len() < HEADER_LEN {
        return false;
    }
    let w = |i: usize| [head[i], head[i + 1], head[i + 2], head[i + 3]];
    let (le, be) = (i32::from_le_bytes(w(304)), i32::from_be_bytes(w(304)));
    let delta = if matches!(le, 6 | 7) {
        f32::from_le_bytes(w(0))
    } else if matches!(be, 6 | 7) {
        f32::from_be_bytes(w(0))
    } else {
        return false;
    };
    delta.is_finite() && delta > 0.0
}

/// Parses and checks the 632-byte header.
pub fn read_header(bytes: &[u8], source: &SourceRef) -> Result<SacHeader> {
    let loc = || super::location(source);
    if bytes.len() < HEADER_LEN {
        return Err(Error::input(
            loc().at_byte(bytes.len() as u64),
            format!(
                "file ends at byte {} inside the {HEADER_LEN}-byte SAC header",
                bytes.len()
            ),
        ));
    }
    let word = |i: usize| -> [u8; 4] { [bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]] };
    let nv_at = 280 + 4 * 6;
    let little = match (
        i32::from_le_bytes(word(nv_at)),
        i32::from_be_bytes(word(nv_at)),
    ) {
        (6 | 7, _) => true,
        (_, 6 | 7) => false,
        _ => return Err(Error::input(
            loc().at_byte(nv_at as u64),
            "not a SAC binary file: header version NVHDR is neither 6 nor 7 in either byte order",
        )),
    };
    let f = |i: usize| -> Option<f64> {
        let w = word(4 * i);
        let v = if little {
            f32::from_le_bytes(w)
        } else {
            f32::from_be_bytes(w)
        };
        let v = widen(v);
        (v != UNDEFINED_F && v.is_finite()).then_some(v)
    };
    let n = |i: usize| -> Option<i32> {
        let w = word(280 + 4 * i);
        let v = if little {
            i32::from_le_bytes(w)
        } else {
            i32::from_be_bytes(w)
        };
        (v != UNDEFINED_I).then_some(v)
    };
    // Character fields: cut at the first NUL (writers leave garbage after it), trim spaces.
    let k = |at: usize, len: usize| -> Option<String> {
        let raw = &bytes[at..at + len];
        let cut = raw.iter().position(|&c| c == 0).unwrap_or(len);
        let s = String::from_utf8_lossy(&raw[..cut]).trim().to_string();
        (!s.is_empty() && s != "-12345").then_some(s)
    };
    let delta = f(0).filter(|d| *d > 0.0).ok_or_else(|| {
        Error::input(
            loc().at_byte(0),
            "DELTA (sampling interval) is undefined or not positive",
        )
    })?;
    let npts = n(9)
        .and_then(|v| usize::try_from(v).ok())
        .ok_or_else(|| Error::input(loc().at_byte(280 + 36), "NPTS is undefined or negative"))?;
    let reference = match (n(0), n(1), n(2), n(3), n(4), n(5)) {
        (Some(y), Some(d), Some(h), Some(m), Some(s), Some(ms)) => Some([y, d, h, m, s, ms]),
        _ => None,
    };
    Ok(SacHeader {
        little_endian: little,
        nvhdr: n(6).unwrap_or(6),
        delta,
        b: f(5),
        e: f(6),
        npts,
        reference,
        knetwk: k(608, 8),
        kstnm: k(440, 8),
        khole: k(464, 8),
        kcmpnm: k(600, 8),
        cmpaz: f(57),
        cmpinc: f(58),
        stla: f(31),
        stlo: f(32),
        stel: f(33),
        idep: n(16),
        iftype: n(15),
        leven: n(35),
    })
}

/// Reads one SAC file as one record.
pub fn read(bytes: &[u8], source: &SourceRef, _opts: &ReadOptions) -> Result<FileContents> {
    let mut src = source.clone();
    src.format = "sac".into();
    let h = read_header(bytes, &src)?;
    let loc = || super::location(&src);
    if let Some(t) = h.iftype {
        if t != 1 {
            return Err(Error::input(
                loc().at_byte(280 + 60),
                format!(
                    "IFTYPE={t}: only time series (ITIME = 1) are read, not spectra or x-y files"
                ),
            ));
        }
    }
    if h.leven == Some(0) {
        return Err(Error::input(
            loc().at_byte(280 + 140),
            "unevenly sampled SAC file (LEVEN = false) is not supported",
        ));
    }
    let need = HEADER_LEN + 4 * h.npts;
    if bytes.len() < need {
        return Err(Error::input(
            loc().at_byte(bytes.len() as u64),
            format!(
                "file ends at byte {} but NPTS={} needs {need} bytes ({} samples missing)",
                bytes.len(),
                h.npts,
                (need - bytes.len()).div_ceil(4)
            ),
        ));
    }
    let samples: Vec<f64> = bytes[HEADER_LEN..need]
        .chunks_exact(4)
        .map(|c| {
            let w = [c[0], c[1], c[2], c[3]];
            (if h.little_endian {
                f32::from_le_bytes(w)
            } else {
                f32::from_be_bytes(w)
            }) as f64
        })
        .collect();

    let id = if h.knetwk.is_none() && h.kstnm.is_none() && h.kcmpnm.is_none() {
        std::path::Path::new(&src.file)
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_else(|| src.file.clone())
    } else {
        format!(
            "{}.{}.{}.{}",
            h.knetwk.as_deref().unwrap_or(""),
            h.kstnm.as_deref().unwrap_or(""),
            h.khole.as_deref().unwrap_or(""),
            h.kcmpnm.as_deref().unwrap_or("")
        )
    };
    let (units, what) = match h.idep {
        Some(6) => (Units::M, "IDEP=6 (IDISP, displacement; the SAC standard says nm)"),
        Some(7) => (Units::MPerS, "IDEP=7 (IVEL, velocity; the SAC standard says nm/s)"),
        Some(8) => (
            Units::MPerS2,
            "IDEP=8 (IACC, acceleration; the SAC standard says nm/s², writers often store g or m/s²)",
        ),
        Some(5) => (Units::MPerS2, "IDEP=5 (IUNKN, unknown)"),
        Some(other) => (Units::MPerS2, if other == 50 { "IDEP=50 (IVOLTS)" } else { "IDEP has an unknown code" }),
        None => (Units::MPerS2, "IDEP undefined"),
    };
    let mut ch = Channel::new(id, units, 1.0 / h.delta, src.clone());
    ch.network = h.knetwk.clone();
    ch.station = h.kstnm.clone();
    ch.location_code = h.khole.clone();
    ch.channel_code = h.kcmpnm.clone();
    ch.elevation_m = h.stel;
    ch.missing.push("units".into());
    ch.inferred.push(format!(
        "units={} assumed: {what}; the SAC header does not state the units — set them in the manifest",
        units.name()
    ));
    match h.start_ns() {
        Some(t) => ch.start_ns = Some(t),
        None => ch.missing.push("start_time".into()),
    }
    // Orientation: CMPINC is measured from vertical-up (0 = up, 90 = horizontal, 180 = down);
    // StationXML dip = CMPINC − 90.
    if let Some(inc) = h.cmpinc {
        ch.dip_deg = Some(inc - 90.0);
        ch.direction = if inc.abs() < 1e-6 {
            Some(Direction::Up)
        } else if (inc - 180.0).abs() < 1e-6 {
            Some(Direction::Down)
        } else if (inc - 90.0).abs() < 1e-6 {
            h.cmpaz.map(|a| Direction::Azimuth(a.rem_euclid(360.0)))
        } else {
            None
        };
    }
    if bytes.len() > need {
        ch.qa.push(QaFlag::Note {
            text: format!(
                "{} bytes after the NPTS={} samples were ignored",
                bytes.len() - need,
                h.npts
            ),
        });
    }
    if let (Some(b), Some(e)) = (h.b, h.e) {
        let expect = b + (h.npts.saturating_sub(1)) as f64 * h.delta;
        if (e - expect).abs() > h.delta {
            ch.qa.push(QaFlag::Note {
                text: format!("header E={e} s disagrees with B + (NPTS−1)·DELTA = {expect} s"),
            });
        }
    }
    if h.idep == Some(8) && !samples.is_empty() {
        let mean = samples.iter().sum::<f64>() / samples.len() as f64;
        let peak = samples.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if (0.9..1.1).contains(&mean.abs()) && peak < 3.0 {
            ch.qa.push(QaFlag::Note {
                text: format!(
                    "values average {mean:.4}: they look like g including gravity; state units: g in the manifest if so"
                ),
            });
        }
    }
    Ok(FileContents {
        records: vec![Record::new(ch, samples)],
        ..Default::default()
    })
}
