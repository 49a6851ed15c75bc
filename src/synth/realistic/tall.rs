//! Benchmark (b): a 40-storey office tower with a ≈0.2 Hz fundamental — a
//! linear shear building per direction (exact ZOH response), masses 1.5e6 kg
//! per floor, storey stiffness tapering to 40 % at the top, modal damping
//! 2 % (X) and 2.5 % (Y) — under a long, distant synthetic earthquake
//! (330 s at 50 Hz), instrumented at the ground floor (X, Y, up), levels
//! 10, 20, 30 and the roof (X, Y), written as one multi-channel CSMIP V2
//! file in a CESMD-style zip; no manifest, `truth.toml` beside it.
//! X points to azimuth 360° (north), Y to 270° (Y = X − 90°).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::{
    civil, level_label, storey_and_segment_drifts, v2_processed, weekday, write_file, zip_bytes,
};
use crate::error::{Error, Result};
use crate::rng::Rng;
use crate::synth::csmip_writer::{csmip_v2_text, CsmipChannel, CsmipOrientation};
use crate::synth::{
    add_measurement_noise, synthetic_ground_motion, GroundMotionSpec, Sampling, ShearBuilding,
};

pub const FOLDER: &str = "synthetic-40storey";
pub const ZIP_NAME: &str = "ce99940p.zip";
pub const STOREYS: usize = 40;
pub const STATION: u32 = 99940;
/// Lobby 6 m, the others 4 m.
pub fn storey_heights_m() -> Vec<f64> {
    (0..STOREYS)
        .map(|i| if i == 0 { 6.0 } else { 4.0 })
        .collect()
}
pub const TARGET_HZ: [f64; 2] = [0.20, 0.23];
const RATE_HZ: f64 = 50.0;
const PRE_EVENT_S: f64 = 5.0;
const MOTION_S: f64 = 325.0;
const SNR_DB: f64 = 40.0;
const BAND_HZ: (f64, f64) = (0.04, 20.0);
pub const LEVELS: [usize; 5] = [0, 10, 20, 30, 40];

/// The tower per direction (X, Y).
pub fn buildings() -> Result<[ShearBuilding; 2]> {
    let masses: Vec<f64> = (0..STOREYS)
        .map(|i| if i + 1 == STOREYS { 1.2e6 } else { 1.5e6 })
        .collect();
    let profile: Vec<f64> = (0..STOREYS)
        .map(|i| 1.0 - 0.6 * i as f64 / (STOREYS - 1) as f64)
        .collect();
    let make = |target: f64, zeta: f64| -> Result<ShearBuilding> {
        let mut b = ShearBuilding {
            masses_kg: masses.clone(),
            storey_stiffness_n_per_m: profile.clone(),
            damping_ratios: vec![zeta],
        };
        let f = b.modes()?.frequencies_hz[0];
        b.storey_stiffness_n_per_m
            .iter_mut()
            .for_each(|k| *k *= (target / f).powi(2));
        Ok(b)
    };
    Ok([make(TARGET_HZ[0], 0.02)?, make(TARGET_HZ[1], 0.025)?])
}

pub fn write(out: &Path, seed: u64) -> Result<PathBuf> {
    let dir = out.join(FOLDER);
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let [bx, by] = buildings()?;
    let dt = 1.0 / RATE_HZ;
    let pre = (PRE_EVENT_S * RATE_HZ).round() as usize;
    let motion = |k: u64, pga: f64, fg: f64| -> Result<Vec<f64>> {
        let spec = GroundMotionSpec {
            seed: seed.wrapping_add(4000 + k),
            duration_s: MOTION_S,
            sampling: Sampling::RateHz(RATE_HZ),
            pga_m_per_s2: pga,
            ground_frequency_hz: fg,
            ground_damping: 0.5,
            highpass_frequency_hz: 0.06,
            envelope: crate::synth::Envelope::SaragoniHart {
                peak_fraction: 0.12,
                end_level: 0.02,
            },
            ..GroundMotionSpec::default()
        };
        let mut a = vec![0.0; pre];
        a.extend(synthetic_ground_motion(&spec)?);
        Ok(a)
    };
    let (gx, gy, gz) = (
        motion(0, 0.9, 0.7)?,
        motion(1, 0.75, 0.8)?,
        motion(2, 0.4, 4.0)?,
    );
    let rx = bx.simulate_base_motion(&gx, dt)?;
    let ry = by.simulate_base_motion(&gy, dt)?;
    let mut rng = Rng::new(seed.wrapping_add(4099));
    let start_utc = civil("2026-09-21T14:02:41.300Z", 0)?;
    let start_local = civil("2026-09-21T14:02:41.300Z", -7)?;
    // (level, orientation, record): ground X, Y, up; then X, Y per level.
    let mut chans: Vec<(usize, CsmipOrientation, Vec<f64>)> = Vec::new();
    for &level in &LEVELS {
        let pick = |r: &crate::synth::Response, g: &Vec<f64>| {
            if level == 0 {
                g.clone()
            } else {
                r.absolute_acceleration[level - 1].clone()
            }
        };
        chans.push((level, CsmipOrientation::AzimuthDeg(360), pick(&rx, &gx)));
        chans.push((level, CsmipOrientation::AzimuthDeg(270), pick(&ry, &gy)));
        if level == 0 {
            chans.push((level, CsmipOrientation::Up, gz.clone()));
        }
    }
    let total = chans.len() as u32;
    let mut text = String::new();
    for (k, (level, orientation, acc)) in chans.iter().enumerate() {
        let noisy = add_measurement_noise(acc, SNR_DB, &mut rng);
        let [a, v, d] = v2_processed(&noisy, RATE_HZ, BAND_HZ)?;
        let recorder = k as u32 / 12;
        text.push_str(&csmip_v2_text(&CsmipChannel {
            station_number: STATION,
            station_name: "Sample City - 40-story Office Bldg".into(),
            latitude: 34.049,
            longitude: -118.256,
            recorder: "Etna2".into(),
            serial: 4410 + recorder,
            recorder_channel: k as u32 + 1,
            recorder_channels: total,
            station_channel: k as u32 + 1,
            station_channels: total,
            orientation: *orientation,
            location: level_label(*level, STOREYS, "Ground Floor"),
            start_utc,
            start_local,
            local_weekday: weekday(&start_local).into(),
            local_zone: "PDT".into(),
            band_hz: BAND_HZ,
            sampling_rate_hz: RATE_HZ,
            accel_cm_s2: &a,
            veloc_cm_s: &v,
            displ_cm: &d,
        }));
    }
    let members = vec![(format!("CE{STATION}.V2"), text.into_bytes())];
    write_file(&dir, ZIP_NAME, &zip_bytes(&members, &start_utc)?)?;
    write_file(
        &dir,
        "truth.toml",
        truth(&[("X", &bx, &rx), ("Y", &by, &ry)], seed)?.as_bytes(),
    )?;
    Ok(dir)
}

fn truth(dirs: &[(&str, &ShearBuilding, &crate::synth::Response)], seed: u64) -> Result<String> {
    let heights = storey_heights_m();
    let mut s = String::new();
    let _ = writeln!(s, "# Truth of a synthetic event generated by `quaketwin synth` (seed {seed}); not a record file.");
    let _ = writeln!(s, "# 40-storey linear shear building per direction, modal damping; X at azimuth 360°, Y at 270°.");
    let _ = writeln!(s, "# Levels: 0 = base (Ground Floor), N = floor N+1, 40 = Roof. Instrumented levels {LEVELS:?}.");
    let _ = writeln!(s, "model = \"linear shear building per direction, modal damping, exact ZOH response\"\nseed = {seed}\nstoreys = {STOREYS}");
    let _ = writeln!(
        s,
        "storey_heights_m = {heights:?}\nrecord_rate_hz = {RATE_HZ}\nmeasurement_snr_db = {SNR_DB}"
    );
    for (axis, b, _) in dirs {
        let m = b.modes()?;
        let _ = writeln!(
            s,
            "\n[[direction]]\naxis = \"{axis}\"\nazimuth_deg = {}\nmasses_kg = {:?}\nstorey_stiffness_n_per_m = {:?}",
            if *axis == "X" { 360 } else { 270 },
            b.masses_kg, b.storey_stiffness_n_per_m
        );
        let _ = writeln!(
            s,
            "frequencies_hz = {:?}\ndamping_ratios = {:?}",
            &m.frequencies_hz[..6],
            &m.damping_ratios[..6]
        );
        let _ = writeln!(
            s,
            "# mass-normalised shapes of the lowest 3 modes (levels 1..40)\nshapes = {:?}",
            &m.shapes[..3]
        );
    }
    for (axis, _, r) in dirs {
        let end = |l: usize| {
            (l > 0)
                .then(|| r.relative_displacement[l - 1].last().copied())
                .flatten()
                .unwrap_or(0.0)
        };
        storey_and_segment_drifts(
            &mut s,
            axis,
            &r.relative_displacement,
            &heights,
            &LEVELS,
            end,
        );
    }
    Ok(s)
}
