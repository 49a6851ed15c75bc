//! Text-format strong-motion readers (COSMOS, CSMIP/DMG V2/V3, SMC, PEER
//! AT2, GeoNet V2A) against the real files of /work/shared/records: every
//! assertion compares with a fact stated in the folder's PROVENANCE.md (or
//! the gmprocess reference values it quotes), with the tolerance of the
//! printed rounding.  Bad-input tests use crafted byte strings.

use quaketwin::error::Error;
use quaketwin::readers::resample::{median_step, resample_linear};
use quaketwin::readers::textfmt::{
    line_values, parse_number, signed_degrees, split_free, units_from_text, us_datetime_ns, Layout,
    NumError,
};
use quaketwin::readers::{self, FileContents, Format, ReadOptions};
use quaketwin::vocab::{epoch_ns_from_civil, Direction, QaFlag, Record, SourceRef, Units};
use std::io::Read;

use crate::common::{fixed_e10, smc_file};

const RECORDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/records");

fn source(file: &str, member: Option<&str>, format: Format) -> SourceRef {
    SourceRef {
        file: file.into(),
        member: member.map(String::from),
        column: None,
        format: format.name().into(),
    }
}

fn read_file(rel: &str, format: Format) -> FileContents {
    let bytes = std::fs::read(format!("{RECORDS}/{rel}")).unwrap_or_else(|e| panic!("{rel}: {e}"));
    readers::read(
        format,
        &bytes,
        &source(rel, None, format),
        &ReadOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

/// Every member of a zip (nested zips opened, their members named `outer:inner`).
fn zip_members(rel: &str) -> Vec<(String, Vec<u8>)> {
    let bytes = std::fs::read(format!("{RECORDS}/{rel}")).unwrap_or_else(|e| panic!("{rel}: {e}"));
    let mut out = Vec::new();
    collect_members(bytes, "", &mut out);
    out
}

fn collect_members(bytes: Vec<u8>, prefix: &str, out: &mut Vec<(String, Vec<u8>)>) {
    let mut archive = zip::ZipArchive::new(std::io::Cursor::new(bytes)).expect("zip archive");
    for i in 0..archive.len() {
        let mut member = archive.by_index(i).expect("zip member");
        let name = member.name().expect("member name").to_string();
        let mut data = Vec::new();
        member.read_to_end(&mut data).expect("member bytes");
        let full = format!("{prefix}{name}");
        if name.to_ascii_lowercase().ends_with(".zip") {
            collect_members(data, &format!("{full}:"), out);
        } else {
            out.push((full, data));
        }
    }
}

/// Reads every V2 (records) and V3 (spectra) member of a CSMIP zip.
fn read_csmip_zip(
    rel: &str,
    only_prefix: &str,
) -> (Vec<Record>, Vec<readers::FileSpectrum>, Vec<FileContents>) {
    let mut records = Vec::new();
    let mut spectra = Vec::new();
    let mut all = Vec::new();
    for (member, data) in zip_members(rel) {
        if !member.starts_with(only_prefix) {
            continue;
        }
        let lower = member.to_ascii_lowercase();
        if !(lower.ends_with(".v2") || lower.ends_with(".v3")) {
            continue;
        }
        if lower.ends_with(".v2") {
            assert_eq!(
                readers::sniff(&member, &data),
                Some(Format::Dmg),
                "{member}"
            );
        } else {
            assert_eq!(
                readers::sniff(&member, &data),
                None,
                "{member}: V3 spectra are not record files"
            );
        }
        let c = readers::read(
            Format::Dmg,
            &data,
            &source(rel, Some(&member), Format::Dmg),
            &ReadOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        if lower.ends_with(".v2") {
            assert!(c.spectra.is_empty(), "{member}");
            records.extend(c.records.iter().cloned());
        } else {
            assert!(c.records.is_empty(), "{member}");
            spectra.extend(c.spectra.iter().cloned());
        }
        all.push(c);
    }
    records.sort_by(|a, b| a.channel.id.cmp(&b.channel.id));
    (records, spectra, all)
}

/// The sample of largest magnitude (sign kept).
fn peak(samples: &[f64]) -> f64 {
    samples
        .iter()
        .copied()
        .fold(0.0, |a: f64, v| if v.abs() > a.abs() { v } else { a })
}

/// `got` equals a value printed with `decimals` decimals.
fn assert_printed(got: f64, printed: f64, decimals: i32, what: &str) {
    let tol = 0.5 * 10f64.powi(-decimals) + 1e-9;
    assert!(
        (got - printed).abs() <= tol,
        "{what}: got {got}, printed {printed} (±{tol})"
    );
}

fn azimuth(d: Option<Direction>) -> Option<f64> {
    match d {
        Some(Direction::Azimuth(a)) => Some(a),
        _ => None,
    }
}

fn ns(y: i64, mo: u32, d: u32, h: u32, mi: u32, s: f64) -> i64 {
    epoch_ns_from_civil(y, mo, d, h, mi, s).expect("valid date")
}

// ---------------------------------------------------------------- PEER AT2

#[test]
fn at2_peer_records_match_provenance() {
    // (file, npts, dt, peak g (4 decimals), direction, first, last)
    let cases: [(&str, usize, f64, f64, Option<f64>, f64, f64); 4] = [
        (
            "RSN763_LOMAP_GIL067.AT2",
            7999,
            0.005,
            -0.3585,
            Some(67.0),
            -0.8075668e-3,
            0.3362115e-3,
        ),
        (
            "RSN763_LOMAP_GIL337.AT2",
            7999,
            0.005,
            -0.3266,
            Some(337.0),
            -0.4518843e-3,
            0.4250957e-4,
        ),
        (
            "TAK000.AT2",
            4096,
            0.010,
            0.6177,
            Some(0.0),
            -0.1259993e-2,
            0.4044295e-3,
        ),
        ("elCentro.AT2", 1559, 0.02, -0.3188, None, 0.00630, 0.0),
    ];
    for (file, npts, dt, pk, dir, first, last) in cases {
        let rel = format!("peer-at2-records/{file}");
        let bytes = std::fs::read(format!("{RECORDS}/{rel}")).unwrap();
        assert_eq!(readers::sniff(file, &bytes), Some(Format::At2));
        let c = read_file(&rel, Format::At2);
        assert_eq!(c.records.len(), 1);
        let r = &c.records[0];
        assert_eq!(
            r.len(),
            npts,
            "{file}: every value incl. the partial last line"
        );
        assert!((r.channel.dt() - dt).abs() < 1e-12, "{file}");
        assert_eq!(r.channel.units, Units::G, "{file}");
        assert_printed(peak(&r.samples), pk, 4, file);
        assert_eq!(azimuth(r.channel.direction), dir, "{file}");
        assert_eq!(r.samples[0], first, "{file}");
        assert_eq!(*r.samples.last().unwrap(), last, "{file}");
        assert!(
            r.channel.inferred.is_empty(),
            "{file}: units come from the header"
        );
    }
    let c = read_file("peer-at2-records/RSN763_LOMAP_GIL067.AT2", Format::At2);
    assert_eq!(c.event.name.as_deref(), Some("Loma Prieta"));
    assert_eq!(
        c.records[0].channel.station.as_deref(),
        Some("Gilroy - Gavilan Coll.")
    );
    assert_eq!(c.records[0].channel.id, "RSN763_LOMAP_GIL067");
}

// --------------------------------------------------------------------- SMC

#[test]
fn smc_loma_prieta_matches_gmprocess_reference() {
    // (file, npts, first, last, header peak (1 decimal), direction)
    let cases = [
        (
            "0111a",
            6001,
            1.5057,
            -0.28745,
            104.4,
            Some(Direction::Azimuth(0.0)),
        ),
        ("0111b", 6002, -12.518, -1.6806, 48.3, Some(Direction::Up)),
        (
            "0111c",
            6004,
            -5.8486,
            -1.1594,
            70.4,
            Some(Direction::Azimuth(270.0)),
        ),
    ];
    for (name, npts, first, last, pk, dir) in cases {
        let rel = format!("usgs-gmprocess-format-samples/smc/{name}.smc");
        let bytes = std::fs::read(format!("{RECORDS}/{rel}")).unwrap();
        assert_eq!(readers::sniff(&rel, &bytes), Some(Format::Smc));
        let c = read_file(&rel, Format::Smc);
        let r = &c.records[0];
        assert_eq!(r.len(), npts, "{name}");
        assert_eq!(r.channel.sampling_rate_hz, 200.0, "{name}");
        assert!(
            (r.samples[0] - first).abs() < 1e-9,
            "{name} first {}",
            r.samples[0]
        );
        assert!((r.samples[npts - 1] - last).abs() < 1e-9, "{name} last");
        assert_printed(peak(&r.samples).abs(), pk, 1, name);
        assert_eq!(r.channel.direction, dir, "{name}");
        assert_eq!(r.channel.units, Units::CmPerS2);
        assert_eq!(r.channel.station.as_deref(), Some("SAF0"));
        // 1989 day 291 = 18 October, 00:04.
        assert_eq!(
            r.channel.start_ns,
            Some(ns(1989, 10, 18, 0, 4, 0.0)),
            "{name}"
        );
        assert!(
            r.channel.qa.is_empty(),
            "{name}: no extra values, evenly sampled"
        );
        assert_eq!(c.event.magnitude, Some(7.1));
        assert_eq!(c.event.name.as_deref(), Some("Loma Prieta, CA"));
    }
}

/// SMC header for crafted files: `npts` samples, `rate` (None → missing).
fn smc_text(label: &str, npts: usize, rate: Option<f64>, data_lines: &[String]) -> String {
    smc_file(
        label,
        "     2020   1   2    0304 Test quake",
        "TST0",
        "360",
        &[],
        npts,
        rate,
        data_lines,
    )
}

#[test]
fn smc_uneven_pairs_are_resampled_and_flagged() {
    // Uneven times; the value is a known linear function of time, which
    // linear interpolation reproduces exactly on the uniform grid.
    let times: Vec<f64> = (0..41)
        .map(|k| 0.01 * k as f64 + if k % 3 == 1 { 0.003 } else { 0.0 })
        .collect();
    let f = |t: f64| 2.0 - 50.0 * t;
    let mut pairs = Vec::new();
    for &t in &times {
        pairs.push(t);
        pairs.push(f(t));
    }
    let text = smc_text(
        "1 UNCORRECTED ACCELEROGRAM",
        times.len(),
        None,
        &fixed_e10(&pairs),
    );
    let c = readers::read(
        Format::Smc,
        text.as_bytes(),
        &source("pairs.smc", None, Format::Smc),
        &ReadOptions::default(),
    )
    .unwrap();
    let r = &c.records[0];
    // The median step of these times is 0.01 s → 41 uniform samples over 0..0.40 s.
    assert_eq!(r.channel.sampling_rate_hz.round(), 100.0);
    assert_eq!(r.len(), 41);
    for (k, v) in r.samples.iter().enumerate() {
        assert!((v - f(0.01 * k as f64)).abs() < 1e-3, "sample {k}: {v}"); // E10.4 print precision
    }
    assert!(r.channel.qa.contains(&QaFlag::Resampled {
        from: "uneven (time,value) pairs".into()
    }));
    assert!(r
        .channel
        .inferred
        .iter()
        .any(|s| s.contains("resampled") && s.contains("linear interpolation")));
    assert_eq!(
        r.channel.start_ns,
        epoch_ns_from_civil(2020, 1, 2, 3, 4, 5.0)
    );
}

#[test]
fn smc_extra_values_keep_declared_count_with_note() {
    let values: Vec<f64> = (0..20)
        .map(|k| (k as f64 * 0.7).sin() * 100.0 - 50.0)
        .collect();
    let text = smc_text(
        "2 CORRECTED ACCELEROGRAM",
        16,
        Some(100.0),
        &fixed_e10(&values),
    );
    let c = readers::read(
        Format::Smc,
        text.as_bytes(),
        &source("extra.smc", None, Format::Smc),
        &ReadOptions::default(),
    )
    .unwrap();
    let r = &c.records[0];
    assert_eq!(r.len(), 16);
    for (k, v) in r.samples.iter().enumerate() {
        assert!(
            (v - values[k]).abs() <= 5e-4 * values[k].abs().max(1.0),
            "touching E10.4 fields, sample {k}"
        );
    }
    assert!(r
        .channel
        .qa
        .iter()
        .any(|q| matches!(q, QaFlag::Note { text } if text.contains("4 values after the 16"))));
}

#[test]
fn smc_pairs_counted_as_values_without_rate() {
    // NSMP V1 film digitisation: integer field 17 gives the number of
    // *values* (2 × pairs), and the rate is the missing sentinel 1.7E+38.
    let times: Vec<f64> = (0..25)
        .map(|k| 0.02 * k as f64 + if k % 4 == 1 { 0.005 } else { 0.0 })
        .collect();
    let f = |t: f64| 3.0 + 20.0 * t;
    let values: Vec<f64> = times.iter().flat_map(|&t| [t, f(t)]).collect();
    let text = smc_text(
        "1 UNCORRECTED ACCELEROGRAM",
        values.len(),
        None,
        &fixed_e10(&values),
    );
    let c = read_text(Format::Smc, "v1.smc", &text).unwrap();
    let r = &c.records[0];
    // Median step 0.02 s over 0..0.48 s → 25 uniform samples.
    assert!(
        (r.channel.dt() - 0.02).abs() < 1e-12,
        "dt {}",
        r.channel.dt()
    );
    assert_eq!(r.len(), 25);
    for (k, v) in r.samples.iter().enumerate() {
        assert!((v - f(0.02 * k as f64)).abs() < 1e-3, "sample {k}: {v}");
    }
    assert!(
        r.channel
            .inferred
            .iter()
            .any(|s| s.contains("counts values, not pairs") && s.contains("25 (time, value) pairs")),
        "{:?}",
        r.channel.inferred
    );
    assert!(r
        .channel
        .inferred
        .iter()
        .any(|s| s.contains("median time step")));
    assert!(r.channel.qa.contains(&QaFlag::Resampled {
        from: "uneven (time,value) pairs".into()
    }));
    // Evenly sampled values with no rate and no increasing times are still an error.
    let even: Vec<f64> = (0..16).map(|k| (k as f64 * 0.9).sin()).collect();
    expect_input_error(
        read_text(
            Format::Smc,
            "even.smc",
            &smc_text("2 CORRECTED ACCELEROGRAM", 16, None, &fixed_e10(&even)),
        ),
        "even.smc",
        None,
        "sampling rate",
    );
}

/// An SMC file with the given start fields (integer header 1..) and line 4.
fn smc_with_start(start: &[i64], line4: &str) -> Record {
    let ints: Vec<(usize, i64)> = start.iter().enumerate().map(|(k, &v)| (k + 1, v)).collect();
    let values: Vec<f64> = (0..16).map(|k| k as f64 - 7.5).collect();
    let text = smc_file(
        "2 CORRECTED ACCELEROGRAM",
        line4,
        "ANC1",
        "90",
        &ints,
        16,
        Some(100.0),
        &fixed_e10(&values),
    );
    read_text(Format::Smc, "t_a.smc", &text).unwrap().records[0].clone()
}

#[test]
fn smc_start_time_layout_is_cross_checked_with_the_text_header() {
    // NSMP: year, month, day, hour, minute, second, millisecond.
    let r = smc_with_start(
        &[2018, 1, 4, 10, 39, 0, 164],
        "     2018  01  04    1039 Anchorage test",
    );
    assert_eq!(
        r.channel.start_ns,
        Some(ns(2018, 1, 4, 10, 39, 0.164)),
        "{:?}",
        r.channel.start_ns.map(quaketwin::vocab::format_epoch_ns)
    );
    assert!(
        r.channel
            .inferred
            .iter()
            .any(|s| s.contains("year, month, day") && s.contains("2018 01 04 1039")),
        "{:?}",
        r.channel.inferred
    );
    assert!(r.channel.qa.is_empty(), "{:?}", r.channel.qa);

    // The default layout (year, day of year, …) when it is the one that agrees.
    let r = smc_with_start(&[2018, 4, 10, 39, 0, 164], "     2018  01  04    1039 Test");
    assert_eq!(r.channel.start_ns, Some(ns(2018, 1, 4, 10, 39, 0.164)));
    assert!(r.channel.qa.is_empty(), "{:?}", r.channel.qa);

    // Neither layout agrees: the default reading is kept, and a QA note says so.
    let r = smc_with_start(
        &[2018, 1, 4, 10, 39, 0, 164],
        "     2018  02  20    1200 Test",
    );
    assert_eq!(r.channel.start_ns, Some(ns(2018, 1, 1, 4, 10, 39.0)));
    assert!(
        r.channel
            .qa
            .iter()
            .any(|q| matches!(q, QaFlag::Note { text }
            if text.contains("disagrees") && text.contains("2018 02 20 1200"))),
        "{:?}",
        r.channel.qa
    );

    // No date in the text header: default reading, flagged as not cross-checked.
    let r = smc_with_start(&[2018, 4, 10, 39, 0, 164], "Test quake without a date");
    assert_eq!(r.channel.start_ns, Some(ns(2018, 1, 4, 10, 39, 0.164)));
    assert!(
        r.channel
            .qa
            .iter()
            .any(|q| matches!(q, QaFlag::Note { text }
            if text.contains("not cross-checked"))),
        "{:?}",
        r.channel.qa
    );
}

// ------------------------------------------------------------------ GeoNet

#[test]
fn geonet_v2a_three_components() {
    let rel = "usgs-gmprocess-format-samples/geonet/20180212_211557_WPWS_20.V2A";
    let c = read_file(rel, Format::GeoNet);
    assert_eq!(c.records.len(), 3);
    let expected = [
        ("WPWS.S16W", Direction::Azimuth(196.0), -41.6),
        ("WPWS.S74E", Direction::Azimuth(106.0), -194.0),
        ("WPWS.UP", Direction::Up, -27.3),
    ];
    for (r, (id, dir, pk)) in c.records.iter().zip(expected) {
        assert_eq!(r.channel.id, id);
        assert_eq!(r.channel.station.as_deref(), Some("WPWS"));
        assert_eq!(r.channel.direction, Some(dir), "{id}");
        assert_eq!(r.len(), 5800, "{id}");
        assert!((r.channel.dt() - 0.02).abs() < 1e-12);
        assert_eq!(r.channel.units, Units::MmPerS2);
        assert_printed(peak(&r.samples), pk, 1, id);
        assert_eq!(
            r.channel.location_text.as_deref(),
            Some("Waipawa District Council")
        );
    }
    assert_eq!(c.event.magnitude, Some(4.17));
    assert_eq!(c.event.origin_ns, Some(ns(2018, 2, 12, 21, 15, 54.0)));
    assert_eq!(c.event.name.as_deref(), Some("6 km south of Waipukurau"));
}

// ------------------------------------------------------------------ COSMOS

#[test]
fn cosmos_v0_building_channel_counts() {
    let rel = "usgs-gmprocess-format-samples/cosmos/NP8040-n.1000hyfh.HNE.01.V0c";
    let c = read_file(rel, Format::Cosmos);
    assert_eq!(c.records.len(), 1);
    let r = &c.records[0];
    let ch = &r.channel;
    // gmprocess cosmos_test.py: channel HN2, horizontal orientation 90.
    assert_eq!(ch.channel_code.as_deref(), Some("HN2"));
    assert_eq!(ch.direction, Some(Direction::Azimuth(90.0)));
    assert_eq!(ch.id, "NP.8040.01.HN2");
    assert_eq!(
        (ch.network.as_deref(), ch.station.as_deref()),
        (Some("NP"), Some("8040"))
    );
    assert_eq!(ch.location_text.as_deref(), Some("Basement NW corner"));
    assert_eq!(r.len(), 42000);
    assert_eq!(ch.sampling_rate_hz, 200.0);
    assert!(matches!(ch.units, Units::Counts { counts_per_si: Some(s) } if s > 0.0));
    // "Max = 1033406 counts, at 45.580 sec."
    let (imax, vmax) = r.samples.iter().enumerate().fold((0, 0.0f64), |b, (i, v)| {
        if v.abs() > b.1.abs() {
            (i, *v)
        } else {
            b
        }
    });
    assert_eq!(vmax.abs(), 1_033_406.0);
    assert_eq!(imax, (45.58 * 200.0_f64).round() as usize);
    // "Rcrd start time: 2018/11/30 17:29:06.332 UTC"
    let start = ch.start_ns.expect("start time");
    assert!(
        (start - ns(2018, 11, 30, 17, 29, 6.332)).abs() < 1_000_000,
        "start {start}"
    );
    assert_eq!(c.event.magnitude, Some(7.0));
    assert_eq!(c.event.hypocenter, Some((61.3464, -149.9552, 46.7)));
    assert_eq!(c.event.origin_ns, Some(ns(2018, 11, 30, 17, 29, 29.0)));
}

#[test]
fn cosmos_v2_free_field_acceleration() {
    let rel =
        "usgs-gmprocess-format-samples/cosmos/us1000hyfh_akbmrp_AKBMR--n.1000hyfh.BNZ.--.acc.V2c";
    let c = read_file(rel, Format::Cosmos);
    let r = &c.records[0];
    assert_eq!(r.len(), 42000);
    assert_eq!(r.channel.units, Units::CmPerS2);
    assert_eq!(r.channel.station.as_deref(), Some("BMR"));
    assert_eq!(r.channel.direction, Some(Direction::Up));
    // "Max = -6.852 cm/sec2 at 76.215 sec"
    assert_printed(peak(&r.samples), -6.852, 3, "AK.BMR peak");
    let imax =
        r.samples.iter().enumerate().fold(
            0,
            |b, (i, v)| if v.abs() > r.samples[b].abs() { i } else { b },
        );
    assert!((imax as f64 / r.channel.sampling_rate_hz - 76.215).abs() < 0.006);
    assert_eq!(r.channel.elevation_m, Some(842.0));
}

// --------------------------------------------------------- CSMIP / DMG V2

#[test]
fn dmg_modern_multichannel_file() {
    let c = read_file("usgs-gmprocess-format-samples/dmg/CE58667.V2", Format::Dmg);
    assert_eq!(c.records.len(), 3);
    let expected = [
        ("58667.01", "H1", None, 27.114),
        ("58667.02", "Up", Some(Direction::Up), 11.244),
        ("58667.03", "H2", None, -26.411),
    ];
    for (r, (id, label, dir, pk)) in c.records.iter().zip(expected) {
        assert_eq!(r.channel.id, id);
        assert!(
            r.channel.channel_code.as_deref().unwrap().ends_with(label),
            "{id}"
        );
        assert_eq!(r.channel.direction, dir, "{id}");
        assert_eq!(
            r.channel.missing.contains(&"direction".to_string()),
            dir.is_none()
        );
        assert_eq!(r.len(), 7500);
        assert_eq!(r.channel.sampling_rate_hz, 100.0);
        assert_eq!(r.channel.units, Units::CmPerS2);
        assert_printed(peak(&r.samples), pk, 3, id);
        assert_eq!(r.channel.start_ns, Some(ns(2014, 8, 24, 10, 20, 33.0)));
    }
}

#[test]
fn dmg_1983_multichannel_file_with_unequal_lengths() {
    let c = read_file(
        "usgs-gmprocess-format-samples/dmg/ce36456p_CE36456.V2",
        Format::Dmg,
    );
    assert_eq!(c.records.len(), 3);
    let expected = [
        (3251, Direction::Azimuth(90.0), -267.957),
        (3250, Direction::Up, -94.805),
        (3250, Direction::Azimuth(0.0), -256.231),
    ];
    for (r, (n, dir, pk)) in c.records.iter().zip(expected) {
        assert_eq!(r.len(), n, "{}", r.channel.id);
        assert_eq!(r.channel.direction, Some(dir));
        assert!((r.channel.dt() - 0.02).abs() < 1e-12);
        assert_printed(peak(&r.samples), pk, 3, &r.channel.id);
        assert_eq!(r.channel.station.as_deref(), Some("36456"));
        // "TRIGGER TIME: 05/02/83, 16:42:48.2 PDT" = 23:42:48.2 UTC.
        assert_eq!(r.channel.start_ns, Some(ns(1983, 5, 2, 23, 42, 48.2)));
    }
    assert_eq!(c.event.magnitude, Some(6.5));
    assert_eq!(c.event.hypocenter, Some((36.25, -120.28, 9.0)));
    assert_eq!(c.event.name.as_deref(), Some("COALINGA EARTHQUAKE"));
    assert_eq!(c.event.origin_ns, Some(ns(1983, 5, 2, 23, 42, 38.5)));
}

#[test]
fn dmg_meloland_two_recorders() {
    let (records, spectra, all) = read_csmip_zip(
        "csmip-ce01336-meloland-overpass/imperialvalley79_ce01336p.zip",
        "",
    );
    assert_eq!(records.len(), 26);
    // (station channel, direction, npts, peak cm/s², 1 decimal) from PROVENANCE.md.
    let up = Direction::Up;
    let az = Direction::Azimuth;
    let table: [(Direction, usize, f64); 26] = [
        (up, 1138, 171.6),
        (az(270.0), 1138, -311.4),
        (az(270.0), 1138, -460.0),
        (az(0.0), 1138, 281.1),
        (az(270.0), 1138, -488.6),
        (up, 1138, 176.3),
        (az(270.0), 1138, -483.6),
        (az(0.0), 1138, 386.0),
        (az(270.0), 1138, -476.6),
        (up, 1138, 240.5),
        (az(270.0), 1138, -406.0),
        (az(0.0), 1138, 272.9),
        (az(270.0), 1138, -462.1),
        (up, 5696, 225.1),
        (az(0.0), 5690, -305.0),
        (up, 5695, 472.0),
        (up, 5695, 223.9),
        (up, 5694, -428.6),
        (up, 5695, 200.4),
        (up, 5694, 450.9),
        (up, 5694, 261.8),
        (up, 5694, 392.4),
        (up, 5693, 227.1),
        (az(270.0), 5694, -292.7),
        (az(0.0), 5695, -332.9),
        (az(270.0), 5694, -375.8),
    ];
    for (k, (r, (dir, n, pk))) in records.iter().zip(table).enumerate() {
        let sta_chn = k + 1;
        let ch = &r.channel;
        assert_eq!(ch.id, format!("01336.{sta_chn:02}"));
        assert_eq!(
            ch.location_code.as_deref(),
            Some(sta_chn.to_string().as_str())
        );
        assert_eq!(ch.direction, Some(dir), "{}", ch.id);
        assert_eq!(r.len(), n, "{}", ch.id);
        assert_printed(peak(&r.samples), pk, 1, &ch.id);
        let (rate, recorder_chan) = if sta_chn <= 13 {
            (50.0, sta_chn)
        } else {
            (100.0, sta_chn - 13)
        };
        assert_eq!(ch.sampling_rate_hz, rate, "{}", ch.id);
        // The recorder channel ("CHAN n" on line 1) differs from the station channel on recorder 2.
        assert!(
            ch.channel_code
                .as_deref()
                .unwrap()
                .starts_with(&format!("CHAN {recorder_chan}:")),
            "{}",
            ch.id
        );
        assert_eq!(ch.units, Units::CmPerS2);
        assert_eq!(ch.network.as_deref(), Some("CE"));
    }
    assert_eq!(
        records[0].channel.location_text.as_deref(),
        Some("FOOTING OF CENTER COLUMN: W. EDGE")
    );
    assert_eq!(
        records[13].channel.location_text.as_deref(),
        Some("FREEFIELD")
    );
    // Recorder-1 files state the hypocentre, recorder-2 files leave H and ML blank.
    let with_hypo: Vec<&FileContents> = all
        .iter()
        .filter(|c| c.event.hypocenter.is_some())
        .collect();
    assert_eq!(with_hypo.len(), 26, "13 V2 + 13 V3 files of recorder 1");
    assert!(with_hypo
        .iter()
        .all(|c| c.event.hypocenter == Some((32.64, -115.33, 12.0))
            && c.event.magnitude == Some(6.6)));

    // V3: 26 files × 5 dampings; line 1 says "(79 PERIODS,  .04 -  6.5 SEC)"
    // for recorder 1 and "(83 PERIODS,  .04 -  8.5 SEC)" for recorder 2.
    assert_eq!(spectra.len(), 26 * 5);
    for s in &spectra {
        let recorder_1 = s.channel_id.as_str() <= "01336.13";
        let (n, last) = if recorder_1 { (79, 6.5) } else { (83, 8.5) };
        assert_eq!(s.periods_s.len(), n, "{}", s.channel_id);
        assert_eq!((s.periods_s[0], s.periods_s[n - 1]), (0.04, last));
        assert_eq!(s.units, "g");
        assert!(s.psa.iter().all(|v| v.is_finite() && *v >= 0.0));
    }
    let dampings: Vec<f64> = spectra
        .iter()
        .filter(|s| s.channel_id == "01336.01")
        .map(|s| s.damping)
        .collect();
    assert_eq!(dampings, vec![0.0, 0.02, 0.05, 0.1, 0.2]);
    // CHAN01.V3, 5 %: SD(0.04 s) = .303E-02 in → PSA = (2π/T)² SD; the file's SA there is .194 g.
    let s5 = spectra
        .iter()
        .find(|s| s.channel_id == "01336.01" && s.damping == 0.05)
        .unwrap();
    let expected = (2.0 * std::f64::consts::PI / 0.04f64).powi(2) * 0.303e-2 * 0.0254 / 9.80665;
    assert!((s5.psa[0] - expected).abs() < 1e-12);
    assert!((s5.psa[0] - 0.194).abs() < 0.002, "PSA ≈ SA at 5 % damping");
}

const PETROLIA: [(f64, f64); 20] = [
    // (direction: azimuth or -1 for UP, peak accel cm/s², 1 decimal)
    (270.0, -318.7),
    (-1.0, -156.6),
    (0.0, -438.6),
    (0.0, 1067.0),
    (-1.0, -174.1),
    (-1.0, -657.1),
    (0.0, 844.4),
    (-1.0, 576.1),
    (0.0, -672.7),
    (-1.0, 305.7),
    (270.0, -443.3),
    (270.0, -372.3),
    (-1.0, -191.6),
    (0.0, 532.6),
    (270.0, -429.5),
    (-1.0, 199.1),
    (0.0, 765.1),
    (270.0, -684.4),
    (-1.0, -411.7),
    (0.0, 1311.6),
];

fn check_petrolia(records: &[Record]) {
    assert_eq!(records.len(), 20);
    for (k, (r, (dir, pk))) in records.iter().zip(PETROLIA).enumerate() {
        let ch = &r.channel;
        assert_eq!(ch.id, format!("89324.{:02}", k + 1));
        assert_eq!(r.len(), 3000, "{}", ch.id);
        assert_eq!(ch.sampling_rate_hz, 50.0);
        let want = if dir < 0.0 {
            Direction::Up
        } else {
            Direction::Azimuth(dir)
        };
        assert_eq!(ch.direction, Some(want), "{}", ch.id);
        assert_printed(peak(&r.samples), pk, 1, &ch.id);
    }
    // Station channels 9–20 are on the second recorder (S/N 0138): CHAN9 is its "CHAN 1".
    assert!(records[8]
        .channel
        .channel_code
        .as_deref()
        .unwrap()
        .starts_with("CHAN 1:"));
    assert_eq!(records[8].channel.location_code.as_deref(), Some("9"));
    assert_eq!(
        records[19].channel.location_text.as_deref(),
        Some("ON GROUND NEAR WEST ABUTMENT")
    );
}

#[test]
fn dmg_petrolia_flat_zip() {
    let (records, spectra, all) = read_csmip_zip(
        "csmip-ce89324-painterst-overpass/petrolia_25apr1992_ce89324p.zip",
        "",
    );
    check_petrolia(&records);
    assert_eq!(spectra.len(), 20 * 5);
    let e = &all[0].event;
    assert_eq!(
        e.name.as_deref(),
        Some("CAPE MENDOCINO/PETROLIA EARTHQUAKE")
    );
    assert_eq!(e.origin_ns, Some(ns(1992, 4, 25, 18, 6, 4.2)));
    assert_eq!(e.magnitude, Some(7.0));
    assert_eq!(e.hypocenter, Some((40.368, -124.316, 15.0)));
}

#[test]
fn dmg_petrolia_zip_in_zip() {
    let rel = "csmip-ce89324-painterst-overpass/nested_original/petrolia_25apr1992_ce89324p.zip";
    let (structure, _, _) = read_csmip_zip(rel, "Structure.zip:");
    check_petrolia(&structure);
    assert!(structure[0]
        .channel
        .source
        .member
        .as_deref()
        .unwrap()
        .starts_with("Structure.zip:CHAN"));
    // Same samples as the flat zip.
    let (flat, _, _) = read_csmip_zip(
        "csmip-ce89324-painterst-overpass/petrolia_25apr1992_ce89324p.zip",
        "",
    );
    for (a, b) in structure.iter().zip(&flat) {
        assert_eq!(a.samples, b.samples, "{}", a.channel.id);
    }
    // Free Field.zip: station channels 12–14, a different processing; horizontal labelled 272 DEG.
    let (free, spectra, _) = read_csmip_zip(rel, "Free Field.zip:");
    assert_eq!(
        free.iter()
            .map(|r| r.channel.id.as_str())
            .collect::<Vec<_>>(),
        ["89324.12", "89324.13", "89324.14"]
    );
    assert_eq!(free[0].channel.direction, Some(Direction::Azimuth(272.0)));
    assert!(free.iter().all(|r| r.len() == 3000));
    assert_ne!(
        free[0].samples, flat[11].samples,
        "prelim processing differs"
    );
    assert_eq!(spectra.len(), 3 * 5);
}

#[test]
fn dmg_ferndale_2023_lower_case() {
    let (records, spectra, _) = read_csmip_zip(
        "csmip-ce89324-painterst-overpass/nc73943821_ce89324p.zip",
        "",
    );
    assert_eq!(records.len(), 17);
    // Peaks as printed in each file's header ("Peak acceleration =   140.895"),
    // which PROVENANCE.md rounds to 2 decimals.
    let table: [(usize, &str, f64); 17] = [
        (1, "Long", 23.468),
        (2, "Up", 16.676),
        (3, "Tran", 41.332),
        (4, "Tran", -87.977),
        (5, "Up", -21.356),
        (6, "Up", -91.068),
        (7, "Tran", 140.895),
        (8, "Up", -113.000),
        (9, "Tran", -98.437),
        (10, "Up", -33.918),
        (11, "Long", 55.791),
        (15, "Long", 47.908),
        (16, "Up", -13.344),
        (17, "Tran", -68.798),
        (18, "Long", 47.708),
        (19, "Up", -13.002),
        (20, "Tran", -70.737),
    ];
    for (k, (r, (sta, label, pk))) in records.iter().zip(table).enumerate() {
        let ch = &r.channel;
        assert_eq!(ch.id, format!("89324.{sta:02}"));
        assert_eq!(ch.location_code.as_deref(), Some(sta.to_string().as_str()));
        assert_eq!(r.len(), 8294);
        assert_eq!(ch.sampling_rate_hz, 100.0);
        assert_printed(peak(&r.samples), pk, 3, &ch.id);
        assert_eq!(ch.start_ns, Some(ns(2023, 9, 30, 15, 26, 1.0)));
        // Recorder channels run 1..17 while station channels skip 12–14.
        assert_eq!(
            ch.channel_code.as_deref(),
            Some(format!("CHAN {}: {label}", k + 1).as_str())
        );
        // Long/Tran are the bridge's own axes: X and Y, said in `inferred`.
        let expected = match label {
            "Up" => Direction::Up,
            "Long" => Direction::Axis(quaketwin::vocab::Axis::X),
            _ => Direction::Axis(quaketwin::vocab::Axis::Y),
        };
        assert_eq!(ch.direction, Some(expected), "{label}");
        if label != "Up" {
            assert!(ch.inferred.iter().any(|i| i.contains(label)), "{label}");
            assert!(!ch.missing.contains(&"direction".to_string()));
        }
    }
    assert_eq!(
        records[11].channel.location_text.as_deref(),
        Some("On Ground: Near East Abutment")
    );
    // V3: 17 × 5 dampings, 100 periods 0.04–32 s; chan001 5 %: SD(0.04) = 0.405E-03 in, SA = 0.259E-01 g.
    assert_eq!(spectra.len(), 17 * 5);
    let s5 = spectra
        .iter()
        .find(|s| s.channel_id == "89324.01" && s.damping == 0.05)
        .unwrap();
    assert_eq!(s5.periods_s.len(), 100);
    assert_eq!((s5.periods_s[0], s5.periods_s[99]), (0.04, 32.0));
    assert!(
        (s5.psa[0] - (2.0 * std::f64::consts::PI / 0.04f64).powi(2) * 0.405e-3 * 0.0254 / 9.80665)
            .abs()
            < 1e-12
    );
    assert!((s5.psa[0] - 0.0259).abs() < 0.0005);
}

// --------------------------------------------------------------- sniffing

#[test]
fn sniff_by_content_without_extension() {
    let dir = format!("{RECORDS}/usgs-gmprocess-format-samples");
    let head = |p: &str| std::fs::read(format!("{dir}/{p}")).unwrap();
    assert_eq!(
        readers::sniff("x.dat", &head("cosmos/NP8040-n.1000hyfh.HNE.01.V0c")),
        Some(Format::Cosmos)
    );
    assert_eq!(
        readers::sniff(
            "x.V2",
            &head("cosmos/us1000hyfh_akbmrp_AKBMR--n.1000hyfh.BNZ.--.acc.V2c")
        ),
        Some(Format::Cosmos)
    );
    assert_eq!(
        readers::sniff("x.dat", &head("smc/0111a.smc")),
        Some(Format::Smc)
    );
    assert_eq!(
        readers::sniff("x.dat", &head("geonet/20180212_211557_WPWS_20.V2A")),
        Some(Format::GeoNet)
    );
    assert_eq!(
        readers::sniff("x.raw", &head("dmg/CE58667.V2")),
        Some(Format::Dmg)
    );
    assert_eq!(
        readers::sniff("CE58667.V2", &head("dmg/CE58667.V2")),
        Some(Format::Dmg)
    );
    assert_eq!(readers::sniff("notes.txt", b"hello"), None);
}

#[test]
fn content_sniffing_needs_a_complete_header() {
    use readers::Sniffed;
    let skip_reason = |name: &str, text: &str| match readers::classify(name, text.as_bytes()) {
        Sniffed::Skip(r) => r,
        other => panic!("{name}: expected a skip, got {other:?}"),
    };
    // A README quoting an AT2 header line is documentation, not a record.
    let readme =
        "# Records\n\nEach file has a line like\nNPTS=  100, DT= 0.01 SEC\nthen the values.\n";
    assert!(skip_reason("README.md", readme).contains("documentation"));
    assert!(skip_reason("PROVENANCE", readme).contains("text file without a record header"));
    // The same line followed by numbers only is a complete AT2 header,
    // whatever the extension.
    assert_eq!(
        readers::sniff("record.txt", AT2_OK.as_bytes()),
        Some(Format::At2)
    );
    assert_eq!(
        readers::sniff("record", AT2_OK.as_bytes()),
        Some(Format::At2)
    );
    // A count of values above NPTS is not an AT2 header.
    let too_many = AT2_OK.replace("NPTS=      7", "NPTS=      3");
    assert_eq!(readers::sniff("record.dat", too_many.as_bytes()), None);
    // First lines alone are not enough for the other text formats either.
    assert!(skip_reason("x.dat", "2 CORRECTED ACCELEROGRAM\nshort\n").contains("text file"));
    assert!(skip_reason("x.dat", "CORRECTED ACCELEROGRAM 1\nno header\n").contains("text file"));
    assert!(skip_reason(
        "x.md",
        "Corrected accelerogram (Format v01.20 with 13 text lines)\n"
    )
    .contains("documentation"));
    assert!(skip_reason("x.bin", "\u{0}\u{1}\u{2}binary").contains("binary"));
    // Products that are not acceleration series say what they are.
    assert!(skip_reason("a_v.smc", "3 VELOCITY\n").contains("SMC velocity series"));
    assert!(skip_reason("a_d.smc", "4 DISPLACEMENT\n").contains("SMC displacement series"));
    assert!(skip_reason("a_f.fs1", "anything").contains("Fourier amplitude spectrum (.fs1)"));
    assert!(skip_reason("a_r.rs2", "anything").contains("response spectrum (.rs2)"));
    assert!(
        skip_reason("CHAN001.V3", "Response and Fourier amplitude spectra\n")
            .contains("CSMIP V3 spectra")
    );
    assert!(skip_reason(
        "x.V2c",
        "Corrected velocity (Format v01.20 with 13 text lines)\n"
    )
    .contains("COSMOS velocity series"));
    // An uncorrected V1 beside its corrected V2 is a duplicate; alone it is read.
    let v1 = "UNCORRECTED ACCELEROGRAM DATA\n";
    let folder = vec![
        "e.zip:CHAN001.V1".to_string(),
        "e.zip:CHAN001.V2".to_string(),
    ];
    match readers::classify_in_folder("e.zip:CHAN001.V1", v1.as_bytes(), &folder) {
        Sniffed::Skip(r) => assert!(r.contains("duplicate") && r.contains("CHAN001.V2"), "{r}"),
        other => panic!("{other:?}"),
    }
    assert_eq!(
        readers::classify_in_folder("e.zip:CHAN001.V1", v1.as_bytes(), &folder[..1]),
        Sniffed::Record(Format::Dmg)
    );
    // Real files keep their verdict (the whole real head is a complete header).
    for (rel, want) in [
        ("peer-at2-records/elCentro.AT2", Format::At2),
        ("peer-at2-records/TAK000.AT2", Format::At2),
        ("usgs-gmprocess-format-samples/smc/0111b.smc", Format::Smc),
        ("usgs-gmprocess-format-samples/dmg/CE58667.V2", Format::Dmg),
        (
            "usgs-gmprocess-format-samples/cosmos/NP8040-n.1000hyfh.HNE.01.V0c",
            Format::Cosmos,
        ),
        (
            "usgs-gmprocess-format-samples/geonet/20180212_211557_WPWS_20.V2A",
            Format::GeoNet,
        ),
    ] {
        let bytes = std::fs::read(format!("{RECORDS}/{rel}")).unwrap();
        assert_eq!(readers::sniff("no_extension", &bytes), Some(want), "{rel}");
        assert_eq!(readers::sniff("renamed.txt", &bytes), Some(want), "{rel}");
    }
}

// -------------------------------------------------------------- bad input

/// The error is an input error naming the file and the expected 1-based line.
fn expect_input_error(
    result: quaketwin::Result<FileContents>,
    file: &str,
    line: Option<usize>,
    needle: &str,
) {
    match result {
        Err(Error::Input { location, message }) => {
            assert_eq!(location.file, file, "{message}");
            if line.is_some() {
                assert_eq!(location.line, line, "{message}");
            }
            assert!(
                message.contains(needle),
                "message {message:?} lacks {needle:?}"
            );
        }
        Err(e) => panic!("expected Error::Input, got {e:?}"),
        Ok(_) => panic!("expected an error ({needle})"),
    }
}

fn read_text(format: Format, file: &str, text: &str) -> quaketwin::Result<FileContents> {
    readers::read(
        format,
        text.as_bytes(),
        &source(file, None, format),
        &ReadOptions::default(),
    )
}

const AT2_OK: &str = "PEER NGA STRONG MOTION DATABASE RECORD\nTest, 01/01/2000, Site, 090\nACCELERATION TIME SERIES IN UNITS OF G\nNPTS=      7, DT=   .0100 SEC,\n  .1000000E-01  -.2000000E-01   .3000000E-01  -.4000000E-01   .5000000E-01\n  .6000000E-01  -.7000000E-01\n";

#[test]
fn at2_bad_inputs() {
    let ok = read_text(Format::At2, "t.AT2", AT2_OK).unwrap();
    assert_eq!(
        ok.records[0].samples,
        vec![0.01, -0.02, 0.03, -0.04, 0.05, 0.06, -0.07]
    );
    assert_eq!(
        ok.records[0].channel.direction,
        Some(Direction::Azimuth(90.0))
    );
    // Touching values and D exponents.
    let glued = AT2_OK.replace("  .6000000E-01  -.7000000E-01", "0.6D-01-0.7D-01");
    assert_eq!(
        read_text(Format::At2, "t.AT2", &glued).unwrap().records[0].samples[5..],
        [0.06, -0.07]
    );
    // Truncated: the last line is missing.
    let truncated = AT2_OK.replace("  .6000000E-01  -.7000000E-01\n", "");
    expect_input_error(
        read_text(Format::At2, "t.AT2", &truncated),
        "t.AT2",
        Some(5),
        "truncated",
    );
    // Missing NPTS line.
    expect_input_error(
        read_text(Format::At2, "t.AT2", &AT2_OK.replace("NPTS=", "NP=")),
        "t.AT2",
        Some(1),
        "NPTS",
    );
    // Non-numeric value.
    expect_input_error(
        read_text(
            Format::At2,
            "t.AT2",
            &AT2_OK.replace("-.7000000E-01", "-.70000x0E-01"),
        ),
        "t.AT2",
        Some(6),
        "non-numeric",
    );
    // NaN in the data.
    expect_input_error(
        read_text(
            Format::At2,
            "t.AT2",
            &AT2_OK.replace("-.7000000E-01", "NaN"),
        ),
        "t.AT2",
        Some(6),
        "non-finite",
    );
    // Count disagreeing with NPTS, both ways.
    expect_input_error(
        read_text(
            Format::At2,
            "t.AT2",
            &AT2_OK.replace("NPTS=      7", "NPTS=      6"),
        ),
        "t.AT2",
        Some(6),
        "NPTS=6",
    );
    expect_input_error(
        read_text(Format::At2, "t.AT2", &format!("{AT2_OK}  .1\n")),
        "t.AT2",
        Some(7),
        "after the NPTS=7",
    );
    // Unknown units.
    expect_input_error(
        read_text(
            Format::At2,
            "t.AT2",
            &AT2_OK.replace("UNITS OF G", "UNITS OF FURLONGS"),
        ),
        "t.AT2",
        Some(3),
        "unknown units",
    );
    // Empty and binary garbage: errors, not panics.
    expect_input_error(read_text(Format::At2, "t.AT2", ""), "t.AT2", None, "empty");
    assert!(readers::read(
        Format::At2,
        &[0xff, 0x00, 0x1a, 0x80],
        &source("b.AT2", None, Format::At2),
        &ReadOptions::default()
    )
    .is_err());
}

#[test]
fn smc_bad_inputs() {
    let values: Vec<f64> = (0..16).map(|k| k as f64 - 7.5).collect();
    let good = smc_text(
        "2 CORRECTED ACCELEROGRAM",
        16,
        Some(100.0),
        &fixed_e10(&values),
    );
    assert_eq!(
        read_text(Format::Smc, "t.smc", &good).unwrap().records[0].len(),
        16
    );
    let lines: Vec<&str> = good.lines().collect();
    // Data on lines 29–30 (11 text + 6 int + 10 real + 1 comment = 28 header lines).
    let truncated = lines[..29].join("\n");
    expect_input_error(
        read_text(Format::Smc, "t.smc", &truncated),
        "t.smc",
        Some(29),
        "declares 16",
    );
    expect_input_error(
        read_text(Format::Smc, "t.smc", &lines[..20].join("\n")),
        "t.smc",
        Some(20),
        "header",
    );
    expect_input_error(
        read_text(
            Format::Smc,
            "t.smc",
            &good.replacen("2 CORRECTED ACCELEROGRAM", "9 BOGUS RECORD", 1),
        ),
        "t.smc",
        Some(1),
        "label",
    );
    let mut bad = lines.clone();
    let replaced = format!("{}    abcdef{}", &lines[29][..10], &lines[29][20..]);
    bad[29] = &replaced;
    expect_input_error(
        read_text(Format::Smc, "t.smc", &bad.join("\n")),
        "t.smc",
        Some(30),
        "non-numeric",
    );
    let nan = format!("{}       NaN{}", &lines[29][..10], &lines[29][20..]);
    bad[29] = &nan;
    expect_input_error(
        read_text(Format::Smc, "t.smc", &bad.join("\n")),
        "t.smc",
        Some(30),
        "non-finite",
    );
    let mut bad_int = lines.clone();
    let int_line = lines[13].replacen("      ", "  x   ", 1);
    bad_int[13] = &int_line;
    expect_input_error(
        read_text(Format::Smc, "t.smc", &bad_int.join("\n")),
        "t.smc",
        Some(14),
        "integer",
    );
}

#[test]
fn cosmos_bad_inputs() {
    let full = std::fs::read_to_string(format!(
        "{RECORDS}/usgs-gmprocess-format-samples/cosmos/NP8040-n.1000hyfh.HNE.01.V0c"
    ))
    .unwrap();
    // Keep the header (49 lines) and 10 samples, and declare 10 points.
    let lines: Vec<&str> = full.lines().collect();
    let head = lines[..49]
        .join("\n")
        .replace("   42000 raw accel.", "      10 raw accel.");
    let data = lines[49..59].join("\n");
    let good = format!("{head}\n{data}\nEnd-of-data for ChanHNE\n");
    let c = read_text(Format::Cosmos, "t.V0c", &good).unwrap();
    assert_eq!(c.records[0].samples[..2], [-160876.0, -160942.0]);
    // Truncated.
    let short = format!("{head}\n{}\n", lines[49..54].join("\n"));
    expect_input_error(
        read_text(Format::Cosmos, "t.V0c", &short),
        "t.V0c",
        Some(54),
        "truncated",
    );
    // Too many values.
    let long = format!("{head}\n{}\nEnd-of-data\n", lines[49..61].join("\n"));
    expect_input_error(
        read_text(Format::Cosmos, "t.V0c", &long),
        "t.V0c",
        Some(60),
        "more values",
    );
    // Non-numeric and NaN values.
    expect_input_error(
        read_text(
            Format::Cosmos,
            "t.V0c",
            &good.replacen(" -160879", " -16o879", 1),
        ),
        "t.V0c",
        Some(52),
        "non-numeric",
    );
    expect_input_error(
        read_text(
            Format::Cosmos,
            "t.V0c",
            &good.replacen(" -160879", "     NaN", 1),
        ),
        "t.V0c",
        Some(52),
        "non-finite",
    );
    // Wrong header lines.
    expect_input_error(
        read_text(
            Format::Cosmos,
            "t.V0c",
            &good.replacen("(Format v01.20", "(Fmt", 1),
        ),
        "t.V0c",
        Some(1),
        "COSMOS header",
    );
    expect_input_error(
        read_text(
            Format::Cosmos,
            "t.V0c",
            &good.replacen("Integer-header", "Integer-hdr", 1),
        ),
        "t.V0c",
        Some(14),
        "Integer-header",
    );
    // Unknown units code (99) in the integer header.
    let bad_units = good.replacen(
        "       0       1      50     120",
        "       0       1      99     120",
        1,
    );
    expect_input_error(
        read_text(Format::Cosmos, "t.V0c", &bad_units),
        "t.V0c",
        Some(15),
        "units",
    );
}

fn dmg_sample() -> String {
    let full = std::fs::read_to_string(format!(
        "{RECORDS}/usgs-gmprocess-format-samples/dmg/ce36456p_CE36456.V2"
    ))
    .unwrap();
    full.lines().take(1270).collect::<Vec<_>>().join("\n") + "\n"
}

#[test]
fn dmg_bad_inputs() {
    let good = dmg_sample();
    let c = read_text(Format::Dmg, "t.V2", &good).unwrap();
    assert_eq!(c.records.len(), 1);
    assert_eq!(c.records[0].len(), 3251);
    let lines: Vec<&str> = good.lines().collect();
    // Truncated inside the acceleration block (data starts on line 47).
    expect_input_error(
        read_text(Format::Dmg, "t.V2", &lines[..300].join("\n")),
        "t.V2",
        Some(300),
        "truncated",
    );
    // Wrong first line.
    expect_input_error(
        read_text(
            Format::Dmg,
            "t.V2",
            &good.replacen("CORRECTED ACCELEROGRAM", "SOMETHING ELSE", 1),
        ),
        "t.V2",
        Some(1),
        "CSMIP header",
    );
    // Non-numeric and NaN samples on line 47.
    let mut bad = lines.clone();
    let l47 = lines[46].replacen("-3.038", "-3.0x8", 1);
    bad[46] = &l47;
    expect_input_error(
        read_text(Format::Dmg, "t.V2", &bad.join("\n")),
        "t.V2",
        Some(47),
        "non-numeric",
    );
    let l47n = lines[46].replacen("    -3.038", "       NaN", 1);
    bad[46] = &l47n;
    expect_input_error(
        read_text(Format::Dmg, "t.V2", &bad.join("\n")),
        "t.V2",
        Some(47),
        "non-finite",
    );
    // Sample count disagreeing with the section header: 3252 declared.
    let more = good.replacen(" 3251 POINTS OF ACCEL", " 3252 POINTS OF ACCEL", 1);
    expect_input_error(
        read_text(Format::Dmg, "t.V2", &more),
        "t.V2",
        Some(454),
        "3252",
    );
    let fewer = good.replacen(" 3251 POINTS OF ACCEL", " 3249 POINTS OF ACCEL", 1);
    expect_input_error(
        read_text(Format::Dmg, "t.V2", &fewer),
        "t.V2",
        Some(453),
        "more values",
    );
    // Unknown units.
    let units = good.replacen("(UNITS: CM/SEC/SEC)", "(UNITS: FURLONGS)", 1);
    expect_input_error(
        read_text(Format::Dmg, "t.V2", &units),
        "t.V2",
        Some(46),
        "unknown units",
    );
}

#[test]
fn geonet_bad_inputs() {
    let full = std::fs::read_to_string(format!(
        "{RECORDS}/usgs-gmprocess-format-samples/geonet/20180212_211557_WPWS_20.V2A"
    ))
    .unwrap();
    let lines: Vec<&str> = full.lines().collect();
    // Truncated in the middle of the first component's acceleration block.
    expect_input_error(
        read_text(Format::GeoNet, "t.V2A", &lines[..100].join("\n")),
        "t.V2A",
        Some(100),
        "truncated",
    );
    expect_input_error(
        read_text(
            Format::GeoNet,
            "t.V2A",
            &full.replacen("Site WPWS", "Stie WPWS", 1),
        ),
        "t.V2A",
        Some(2),
        "Site",
    );
    expect_input_error(
        read_text(
            Format::GeoNet,
            "t.V2A",
            &full.replacen("-41.6 mm/s/s", "-41.6 furlong/s", 1),
        ),
        "t.V2A",
        Some(14),
        "unknown units",
    );
    expect_input_error(
        read_text(
            Format::GeoNet,
            "t.V2A",
            &full.replacen("Number of points  5800", "Number of points  5801", 1),
        ),
        "t.V2A",
        Some(10),
        "5801",
    );
    let mut bad = lines.clone();
    let l = lines[30].replacen("     0.0", "    abcd", 1);
    bad[30] = &l;
    expect_input_error(
        read_text(Format::GeoNet, "t.V2A", &bad.join("\n")),
        "t.V2A",
        Some(31),
        "non-numeric",
    );
    let n = lines[30].replacen("     0.0", "     NaN", 1);
    bad[30] = &n;
    expect_input_error(
        read_text(Format::GeoNet, "t.V2A", &bad.join("\n")),
        "t.V2A",
        Some(31),
        "non-finite",
    );
}

#[test]
fn dmg_v1_time_value_pairs_in_g_over_10() {
    // An old-style uncorrected file: digitised (time, value) pairs in g/10,
    // unevenly spaced; the value is linear in time, so the resampled series
    // is exact at the grid points.
    let mut text = String::from(
        "UNCORRECTED ACCELEROGRAM DATA              PROCESSED: 02/28/94\nTEST EARTHQUAKE\n",
    );
    text.push_str(
        "STATION NO. 99999   34.000N, 118.000W   SMA-1  S/N 0001\nTEST SITE\nCHAN  1:  90 DEG\n",
    );
    text.push_str("UNITS OF UNCOR ACCEL ARE SEC AND G/10.     MAX  =  9.999 G.\n");
    let ints = [1i64, 1, 1, 3, 3, 0, 1, 1, 1, 2048, 0, 0, 0, 0, 0, 0];
    text.push_str(&ints.iter().map(|v| format!("{v:5}")).collect::<String>());
    text.push('\n');
    for _ in 0..5 {
        text.push_str(&"    0".repeat(16));
        text.push('\n');
    }
    text.push_str(&"    0".repeat(4));
    text.push('\n');
    for row in 0..13 {
        let n = if row == 12 { 4 } else { 8 };
        text.push_str(&"      .000".repeat(n));
        text.push('\n');
    }
    let times: Vec<f64> = (0..31)
        .map(|k| 0.02 * k as f64 + if k % 4 == 2 { 0.006 } else { 0.0 })
        .collect();
    let g10 = |t: f64| 1.0 + 10.0 * t;
    let mut fields = Vec::new();
    for &t in &times {
        fields.push(format!("{t:7.3}"));
        fields.push(format!("{:7.3}", g10(t)));
    }
    for chunk in fields.chunks(10) {
        text.push_str(&chunk.concat());
        text.push('\n');
    }
    text.push_str("/&  ----------  END OF DATA FOR CHANNEL  1  ----------\n");
    let c = read_text(Format::Dmg, "old.V1", &text).unwrap();
    let r = &c.records[0];
    assert_eq!(r.channel.units, Units::G);
    assert_eq!(r.len(), 31);
    assert!((r.channel.dt() - 0.02).abs() < 1e-12, "median step");
    for (k, v) in r.samples.iter().enumerate() {
        assert!(
            (v - 0.1 * g10(0.02 * k as f64)).abs() < 1e-9,
            "sample {k}: {v}"
        );
    }
    assert!(r.channel.qa.contains(&QaFlag::Resampled {
        from: "uneven (time,value) pairs".into()
    }));
    assert_eq!(r.channel.direction, Some(Direction::Azimuth(90.0)));
    assert_eq!(r.channel.id, "99999.01");
}

#[test]
fn truncated_real_files_never_panic() {
    // Cutting real files at many byte offsets must give Ok or Error::Input, never a panic.
    let files = [
        ("peer-at2-records/TAK000.AT2", Format::At2),
        ("usgs-gmprocess-format-samples/smc/0111b.smc", Format::Smc),
        (
            "usgs-gmprocess-format-samples/geonet/20180212_211557_WPWS_20.V2A",
            Format::GeoNet,
        ),
        (
            "usgs-gmprocess-format-samples/cosmos/NP8040-n.1000hyfh.HNE.01.V0c",
            Format::Cosmos,
        ),
        ("usgs-gmprocess-format-samples/dmg/CE58667.V2", Format::Dmg),
    ];
    for (rel, format) in files {
        let bytes = std::fs::read(format!("{RECORDS}/{rel}")).unwrap();
        let head_len = bytes.len().min(12_000);
        let mut cuts: Vec<usize> = (0..head_len).step_by(97).collect();
        cuts.extend((0..40).map(|k| bytes.len() * k / 40));
        for cut in cuts {
            let r = readers::read(
                format,
                &bytes[..cut],
                &source(rel, None, format),
                &ReadOptions::default(),
            );
            if let Err(e) = r {
                assert!(matches!(e, Error::Input { .. }), "{rel} cut {cut}: {e:?}");
            }
        }
    }
}

/// Ridgecrest 2019 (CSMIP 33742): `Start time:  7/04/19, 17:35:07.3(*LoQ*)`
/// names no zone; read as UTC and confirmed by `Rcrd of Thu Jul  4, 2019
/// 10:35:07.3 PDT` (= 17:35:07.3 UTC).
#[test]
fn shared_dmg_zoneless_start_time_is_cross_checked_against_the_record_line() {
    let (records, _, _) = read_csmip_zip(
        "cesmd-bridges-corpus/ridgecrest-ce33742/ci38443183_ce33742p.zip",
        "",
    );
    assert_eq!(records.len(), 9);
    // The free-field recorder (channels 1–3) triggered at 17:35:07.3 UTC; the
    // bridge recorder's channels state their own start and record line.
    let free_field = ["33742.01", "33742.02", "33742.03"];
    for r in records
        .iter()
        .filter(|r| free_field.contains(&r.channel.id.as_str()))
    {
        assert_eq!(
            r.channel.start_ns,
            Some(ns(2019, 7, 4, 17, 35, 7.3)),
            "{}",
            r.channel.id
        );
    }
    for r in &records {
        assert!(r.channel.start_ns.is_some(), "{}", r.channel.id);
        assert!(r
            .channel
            .inferred
            .iter()
            .any(|i| i.contains("no zone stated, read as UTC") && i.contains("agrees")));
        assert!(!r
            .channel
            .qa
            .iter()
            .any(|q| matches!(q, QaFlag::Note { .. })));
    }
}

/// Issue 14 item 4: a GeoNet V2A cut at a component boundary gave 1 of 3
/// channels with no word; now each component read says how many the file holds.
#[test]
fn shared_geonet_file_cut_at_a_component_boundary_is_flagged() {
    let rel = "usgs-gmprocess-format-samples/geonet/20180212_211557_WPWS_20.V2A";
    let text = String::from_utf8(std::fs::read(format!("{RECORDS}/{rel}")).unwrap()).unwrap();
    let first = text.lines().next().unwrap().to_string();
    let whole = readers::read(
        Format::GeoNet,
        text.as_bytes(),
        &source(rel, None, Format::GeoNet),
        &ReadOptions::default(),
    )
    .unwrap();
    assert_eq!(whole.records.len(), 3);
    assert!(whole.records.iter().all(|r| !r
        .channel
        .qa
        .iter()
        .any(|q| matches!(q, QaFlag::Note { .. }))));
    // Cut before the second component's header line.
    let second = text[first.len()..].find(&first).unwrap() + first.len();
    let cut = &text[..second];
    let part = readers::read(
        Format::GeoNet,
        cut.as_bytes(),
        &source(rel, None, Format::GeoNet),
        &ReadOptions::default(),
    )
    .unwrap();
    assert_eq!(part.records.len(), 1);
    assert!(part.records[0]
        .channel
        .qa
        .iter()
        .any(|q| matches!(q, QaFlag::Note { text } if text.contains("1 of the 3 components"))));
}

/// Issue 14 item 6: counts read from a header are checked against the bytes
/// there before allocating — a COSMOS comment count or point count of 10¹²
/// and an SMC pair file with one time at 10⁹ s give clear errors, not an
/// allocation failure.
#[test]
fn shared_header_counts_of_a_trillion_are_errors_not_aborts() {
    let rel = "usgs-gmprocess-format-samples/cosmos/NP8040-n.1000hyfh.HNE.01.V0c";
    let text = String::from_utf8(std::fs::read(format!("{RECORDS}/{rel}")).unwrap()).unwrap();
    // The comment-count line: "   N Comment line(s) follow…".
    let lines: Vec<&str> = text.lines().collect();
    let k = lines
        .iter()
        .position(|l| l.to_ascii_lowercase().contains("comment line"))
        .unwrap();
    let n = lines[k].split_whitespace().next().unwrap().to_string();
    let mut bad = lines.clone();
    let patched = lines[k].replacen(&n, "1000000000000", 1);
    bad[k] = &patched;
    let e = readers::read(
        Format::Cosmos,
        bad.join("\n").as_bytes(),
        &source(rel, None, Format::Cosmos),
        &ReadOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("comment lines") && e.contains(rel), "{e}");
}

// The shared pieces of the text readers on their own: uneven times onto a
// uniform grid, Fortran numbers and layouts, unit words, civil times.

#[test]
fn linear_resampling_reproduces_a_line() {
    // A straight line is reproduced exactly by linear interpolation.
    let t = [0.0, 0.013, 0.02, 0.041, 0.05];
    let v: Vec<f64> = t.iter().map(|x| 3.0 * x - 1.0).collect();
    let r = resample_linear(&t, &v, 0.01);
    assert_eq!(r.len(), 6);
    for (k, y) in r.iter().enumerate() {
        assert!((y - (3.0 * (k as f64 * 0.01) - 1.0)).abs() < 1e-12);
    }
    assert!((median_step(&t) - 0.011).abs() < 1e-12);
}

#[test]
fn fortran_numbers() {
    assert_eq!(parse_number(" -.8075668E-03"), Ok(-0.8075668e-3));
    assert_eq!(parse_number("1.5D+02"), Ok(150.0));
    assert_eq!(
        parse_number("1.234-105").map(|v| (v / 1.234e-105 - 1.0).abs() < 1e-12),
        Ok(true)
    );
    assert_eq!(parse_number("NaN"), Err(NumError::NonFinite));
    assert_eq!(parse_number("abc"), Err(NumError::NotANumber));
    assert_eq!(
        split_free("-1.234E-02-5.678E-03 1.5057E+0-2.2223E+0"),
        vec!["-1.234E-02", "-5.678E-03", "1.5057E+0", "-2.2223E+0"]
    );
    assert_eq!(
        Layout::from_fortran("(8F10.5)"),
        Some(Layout::Fixed {
            per_line: 8,
            width: 10
        })
    );
    assert_eq!(
        Layout::from_fortran("(1I8)"),
        Some(Layout::Fixed {
            per_line: 1,
            width: 8
        })
    );
    assert_eq!(
        Layout::from_fortran("8f10.6"),
        Some(Layout::Fixed {
            per_line: 8,
            width: 10
        })
    );
    // Fields that touch: fixed widths separate them.
    let v = line_values(
        "  1234.5671234.567   -1.000",
        Layout::Fixed {
            per_line: 8,
            width: 10,
        },
    )
    .unwrap();
    assert_eq!(v, vec![1234.567, 1234.567, -1.0]);
}

#[test]
fn units_and_times() {
    assert_eq!(units_from_text("CM/SEC/SEC"), Ok(Units::CmPerS2));
    assert_eq!(units_from_text("(g)"), Ok(Units::G));
    assert_eq!(
        units_from_text("counts(50)"),
        Ok(Units::Counts {
            counts_per_si: None
        })
    );
    assert!(units_from_text("furlongs").is_err());
    // 05/02/83 16:42:48.2 PDT = 23:42:48.2 UTC.
    assert_eq!(
        us_datetime_ns("05/02/83", "16:42:48.2", "PDT"),
        epoch_ns_from_civil(1983, 5, 2, 23, 42, 48.2)
    );
    assert_eq!(
        us_datetime_ns("9/30/23", "15:26: 1.0", "UTC"),
        epoch_ns_from_civil(2023, 9, 30, 15, 26, 1.0)
    );
    assert_eq!(signed_degrees("115.448W,"), Some(-115.448));
}
