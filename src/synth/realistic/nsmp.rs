//! Benchmark (a): a 12-storey steel frame in plan ([`PlanBuilding`]: x, y, θ
//! per floor, the centre of mass 2.0 m / 1.5 m off the centre of stiffness),
//! instrumented like an NSMP building — basement (X, Y, up), 7th floor
//! (level 6) and roof (level 12), each with two parallel X channels at the
//! north and south ends and one Y channel near the centre — under a seeded
//! three-component synthetic earthquake, written as an NSMP-style zip of
//! SMC V2 files (`NP.9999.zip`) with `truth.toml` beside it, no manifest.
//! The building's X axis points to azimuth 20°, Y to 290° (Y = X − 90°).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::{civil, drift_table, level_heights, level_label, v2_processed, write_file, zip_bytes};
use crate::error::{Error, Result};
use crate::rng::Rng;
use crate::synth::smc_writer::{smc_text, SmcChannel};
use crate::synth::{
    add_measurement_noise, synthetic_ground_motion, GroundMotionSpec, PlanBuilding, Sampling,
    Sensor, ShearBuilding,
};
use crate::vocab::Axis;

pub const FOLDER: &str = "synthetic-12storey-nsmp";
pub const ZIP_NAME: &str = "NP.9999.zip";
pub const STOREYS: usize = 12;
/// Ground storey 5.0 m, the others 3.9 m.
pub fn storey_heights_m() -> Vec<f64> {
    (0..STOREYS)
        .map(|i| if i == 0 { 5.0 } else { 3.9 })
        .collect()
}
/// Azimuth of the building's X axis, degrees; Y is X − 90°.
pub const X_AZIMUTH_DEG: i64 = 20;
/// Target uncoupled fundamentals (X, Y, torsion), Hz: the stiffness profiles are scaled to them.
pub const TARGET_HZ: [f64; 3] = [0.90, 1.10, 1.60];
const RATE_HZ: f64 = 100.0;
const PRE_EVENT_S: f64 = 5.0;
const MOTION_S: f64 = 75.0;
const SNR_DB: f64 = 40.0;
const BAND_HZ: (f64, f64) = (0.10, 40.0);

/// Modal damping of mode j (ascending): 2 % rising by 0.15 % per mode, at most 5 %.
fn modal_damping(j: usize) -> f64 {
    (0.02 + 0.0015 * j as f64).min(0.05)
}

/// Scales a stiffness profile so that its shear chain over `masses` has fundamental `target_hz`.
fn scaled(profile: &[f64], masses: &[f64], target_hz: f64) -> Result<Vec<f64>> {
    let f = ShearBuilding {
        masses_kg: masses.to_vec(),
        storey_stiffness_n_per_m: profile.to_vec(),
        damping_ratios: vec![0.02],
    }
    .modes()?
    .frequencies_hz[0];
    Ok(profile
        .iter()
        .map(|k| k * (target_hz / f).powi(2))
        .collect())
}

/// The benchmark building: masses 1.2e6 kg (roof 1.0e6), plan 25 m (X) × 40 m (Y),
/// storey stiffness tapering linearly to 55 % at the top.
pub fn building() -> Result<PlanBuilding> {
    let masses: Vec<f64> = (0..STOREYS)
        .map(|i| if i + 1 == STOREYS { 1.0e6 } else { 1.2e6 })
        .collect();
    let inertia: Vec<f64> = masses
        .iter()
        .map(|m| m * (40f64.powi(2) + 25f64.powi(2)) / 12.0)
        .collect();
    let profile: Vec<f64> = (0..STOREYS)
        .map(|i| 1.0 - 0.45 * i as f64 / (STOREYS - 1) as f64)
        .collect();
    Ok(PlanBuilding {
        storey_stiffness_x_n_per_m: scaled(&profile, &masses, TARGET_HZ[0])?,
        storey_stiffness_y_n_per_m: scaled(&profile, &masses, TARGET_HZ[1])?,
        storey_torsional_stiffness_n_m_per_rad: scaled(&profile, &inertia, TARGET_HZ[2])?,
        rotational_inertia_kg_m2: inertia,
        masses_kg: masses,
        mass_eccentricity_m: [2.0, 1.5],
        damping_ratios: (0..3 * STOREYS).map(modal_damping).collect(),
    })
}

/// The instrumented sensors: (sensor, SMC channel code, location code, azimuth).
pub fn sensors() -> Vec<(Sensor, &'static str, i64)> {
    let y_az = (X_AZIMUTH_DEG - 90).rem_euclid(360);
    let mut out = Vec::new();
    for level in [0usize, 6, 12] {
        let name = |k: &str| format!("L{level}-{k}");
        let sensor = |id: String, position_m: [f64; 2], axis: Axis| Sensor {
            id,
            level,
            position_m,
            axis,
        };
        if level == 0 {
            out.push((sensor(name("X"), [0.0, 2.0], Axis::X), "HN1", X_AZIMUTH_DEG));
            out.push((sensor(name("Y"), [0.0, 2.0], Axis::Y), "HN2", y_az));
        } else {
            out.push((
                sensor(name("XN"), [0.0, 18.0], Axis::X),
                "HN1",
                X_AZIMUTH_DEG,
            ));
            out.push((sensor(name("Y"), [0.0, 2.0], Axis::Y), "HN2", y_az));
            out.push((
                sensor(name("XS"), [0.0, -18.0], Axis::X),
                "HN3",
                X_AZIMUTH_DEG,
            ));
        }
    }
    out
}

/// Writes the benchmark under `out/FOLDER`; returns the folder.
pub fn write(out: &Path, seed: u64) -> Result<PathBuf> {
    let dir = out.join(FOLDER);
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let b = building()?;
    let dt = 1.0 / RATE_HZ;
    let pre = (PRE_EVENT_S * RATE_HZ).round() as usize;
    let motion = |k: u64, pga: f64, fg: f64| -> Result<Vec<f64>> {
        let spec = GroundMotionSpec {
            seed: seed.wrapping_add(3100 + k),
            duration_s: MOTION_S,
            sampling: Sampling::RateHz(RATE_HZ),
            pga_m_per_s2: pga,
            ground_frequency_hz: fg,
            highpass_frequency_hz: 0.15,
            ..GroundMotionSpec::default()
        };
        let mut a = vec![0.0; pre];
        a.extend(synthetic_ground_motion(&spec)?);
        Ok(a)
    };
    let (gx, gy, gz) = (
        motion(0, 1.5, 1.2)?,
        motion(1, 1.2, 1.4)?,
        motion(2, 0.8, 6.0)?,
    );
    let resp = b.simulate_base_motion(&gx, &gy, dt)?;
    let mut rng = Rng::new(seed.wrapping_add(3199));
    let event_time = civil("2026-07-14T10:31:00Z", 0)?;
    let start = civil("2026-07-14T10:31:12.250Z", 0)?;
    let list = sensors();
    let mut members = Vec::new();
    let mut channel_rows: Vec<(String, Sensor)> = Vec::new();
    let up = Sensor {
        id: "L0-Z".into(),
        level: 0,
        position_m: [2.0, 0.0],
        axis: Axis::Z,
    };
    let mut all: Vec<(Sensor, &str, Option<i64>)> = list
        .iter()
        .map(|(s, c, a)| (s.clone(), *c, Some(*a)))
        .collect();
    all.insert(2, (up, "HNZ", None));
    for (k, (sensor, code, azimuth)) in all.iter().enumerate() {
        let acc = match sensor.axis {
            Axis::Z => gz.clone(),
            _ => resp.sensor_acceleration(sensor)?,
        };
        let noisy = add_measurement_noise(&acc, SNR_DB, &mut rng);
        let [acc_cm, _, _] = v2_processed(&noisy, RATE_HZ, BAND_HZ)?;
        let location = format!("{:02}", k + 1);
        let label = level_label(sensor.level, STOREYS, "Basement");
        let file = format!("NP.9999.{code}.{location}.smc");
        let text = smc_text(&SmcChannel {
            station_code: "9999".into(),
            station_name: "Sample City; 12-story Steel Frame,".into(),
            component: azimuth.map_or("up".to_string(), |a| a.to_string()),
            azimuth_deg: *azimuth,
            channel_number: k as i64 + 1,
            station_channels: all.len() as i64,
            event_time,
            event_name: "Sample City, CA".into(),
            magnitude: 6.4,
            hypocentre: (34.212, -118.541, 12.0),
            station_lat_lon: (34.051, -118.252),
            epicentral_distance_km: 31.6,
            instrument: "Episensor".into(),
            start,
            sampling_rate_hz: RATE_HZ,
            comments: vec![
                String::new(),
                format!("<SCNL>9999.{code}.NP.{location}    <AUTH> 2026/07/15 02:14:09.000"),
                format!("<loclbl={label}>"),
                "Band-pass filtered, 4-pole Butterworth, 3 dB points 0.10 and 40.00 Hz, acausal"
                    .into(),
                String::new(),
            ],
            samples_cm_s2: &acc_cm,
        });
        members.push((file.clone(), text.into_bytes()));
        if sensor.axis != Axis::Z {
            channel_rows.push((file, sensor.clone()));
        }
    }
    write_file(&dir, ZIP_NAME, &zip_bytes(&members, &start)?)?;
    write_file(
        &dir,
        "truth.toml",
        truth(&b, &resp, &channel_rows, seed)?.as_bytes(),
    )?;
    Ok(dir)
}

fn truth(
    b: &PlanBuilding,
    resp: &crate::synth::PlanResponse,
    channels: &[(String, Sensor)],
    seed: u64,
) -> Result<String> {
    let modes = b.modes()?;
    let heights = storey_heights_m();
    let z = level_heights(&heights);
    let mut s = String::new();
    let _ = writeln!(s, "# Truth of a synthetic event generated by `quaketwin synth` (seed {seed}); not a record file.");
    let _ = writeln!(s, "# 12-storey frame in plan (synth::plan): rigid floors, DoFs x, y (centre of mass) and θ per floor;");
    let _ = writeln!(s, "# modal damping; X axis at azimuth {X_AZIMUTH_DEG}°, Y = X − 90°. Levels: 0 = base (Basement), N = floor N+1, 12 = Roof.");
    let _ = writeln!(s, "model = \"plan shear building, modal damping, exact ZOH response\"\nseed = {seed}\nstoreys = {STOREYS}");
    let _ = writeln!(s, "storey_heights_m = {heights:?}\nlevel_heights_m = {z:?}\nrecord_rate_hz = {RATE_HZ}\nmeasurement_snr_db = {SNR_DB}");
    let _ = writeln!(
        s,
        "x_axis_azimuth_deg = {X_AZIMUTH_DEG}\nmass_eccentricity_m = {:?}",
        b.mass_eccentricity_m
    );
    let _ = writeln!(
        s,
        "masses_kg = {:?}\nrotational_inertia_kg_m2 = {:?}",
        b.masses_kg, b.rotational_inertia_kg_m2
    );
    let _ = writeln!(
        s,
        "storey_stiffness_x_n_per_m = {:?}\nstorey_stiffness_y_n_per_m = {:?}",
        b.storey_stiffness_x_n_per_m, b.storey_stiffness_y_n_per_m
    );
    let _ = writeln!(
        s,
        "storey_torsional_stiffness_n_m_per_rad = {:?}",
        b.storey_torsional_stiffness_n_m_per_rad
    );
    let m = &modes.modes;
    for j in 0..9 {
        let kind = if modes.rotation_share[j] > 0.5 {
            "torsion"
        } else if m.participation[j].abs() > modes.participation_y[j].abs() {
            "X"
        } else {
            "Y"
        };
        let _ = writeln!(
            s,
            "\n[[mode]]\nkind = \"{kind}\"\nfrequency_hz = {}\ndamping_ratio = {}",
            m.frequencies_hz[j], m.damping_ratios[j]
        );
        if kind != "torsion" {
            let az = if kind == "X" {
                X_AZIMUTH_DEG
            } else {
                (X_AZIMUTH_DEG - 90).rem_euclid(360)
            };
            let _ = writeln!(s, "azimuth_deg = {az}");
        }
        let _ = writeln!(
            s,
            "rotation_share = {}\nparticipation_x = {}\nparticipation_y = {}",
            modes.rotation_share[j], m.participation[j], modes.participation_y[j]
        );
        let _ = writeln!(
            s,
            "# mass-normalised shape over (x, y, θ) of levels 1..12\nshape = {:?}",
            m.shapes[j]
        );
    }
    // Storey drifts at the plan origin (centre of stiffness) along X and Y.
    for (axis, name) in [(Axis::X, "X"), (Axis::Y, "Y")] {
        let point = |level: usize| Sensor {
            id: String::new(),
            level,
            position_m: [0.0, 0.0],
            axis,
        };
        for st in 1..=STOREYS {
            let upper = resp.sensor_relative_displacement(&point(st))?;
            let lower = resp.sensor_relative_displacement(&point(st - 1))?;
            let residual =
                upper.last().copied().unwrap_or(0.0) - lower.last().copied().unwrap_or(0.0);
            drift_table(
                &mut s,
                "storey_drift",
                &[
                    ("storey", st.to_string()),
                    ("axis", format!("\"{name}\"")),
                    ("point_m", "[0.0, 0.0]".into()),
                ],
                Some(&lower),
                &upper,
                heights[st - 1],
                residual,
            );
        }
    }
    // Segments between instrumented levels, at each channel's point.
    for (file, sensor) in channels.iter().filter(|(_, s)| s.level > 0) {
        let below = channels
            .iter()
            .rev()
            .find(|(_, o)| {
                o.level < sensor.level && o.axis == sensor.axis && o.position_m == sensor.position_m
            })
            .map(|(_, o)| o.level)
            .unwrap_or(0);
        let lower_point = Sensor {
            level: below,
            ..sensor.clone()
        };
        let upper = resp.sensor_relative_displacement(sensor)?;
        let lower = resp.sensor_relative_displacement(&lower_point)?;
        let residual = upper.last().copied().unwrap_or(0.0) - lower.last().copied().unwrap_or(0.0);
        let labels = [
            ("from_level", below.to_string()),
            ("to_level", sensor.level.to_string()),
            ("axis", format!("\"{:?}\"", sensor.axis)),
            ("point_m", format!("{:?}", sensor.position_m)),
            ("channel", format!("\"{file}\"")),
        ];
        drift_table(
            &mut s,
            "segment_drift",
            &labels,
            Some(&lower),
            &upper,
            z[sensor.level] - z[below],
            residual,
        );
    }
    Ok(s)
}
