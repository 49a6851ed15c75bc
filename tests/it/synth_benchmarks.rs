//! Issue 31 item 7: the realistic building benchmarks of `sample-records/`
//! — the SMC and CSMIP V2 writers read back by the project's own readers,
//! the yielding storey's integrator and degraded stiffness, the truth of
//! the committed benchmarks against independent solutions, and the
//! regeneration byte for byte.

use std::path::{Path, PathBuf};

use quaketwin::readers::{self, Format, ReadOptions};
use quaketwin::synth::csmip_writer::{
    csmip_v2_text, fortran_f10_rounded, section_decimals, CsmipChannel, CsmipOrientation,
};
use quaketwin::synth::smc_writer::{smc_e10_4_rounded, smc_text, CivilTime, SmcChannel};
use quaketwin::synth::yielding::YieldingShearBuilding;
use quaketwin::synth::ShearBuilding;
use quaketwin::vocab::{epoch_ns_from_civil, Direction, SourceRef, Units};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn source(file: &str, format: Format) -> SourceRef {
    SourceRef {
        file: file.into(),
        member: None,
        column: None,
        format: format.name().into(),
    }
}

/// A test signal spanning five decades, with exact zeros.
fn signal(n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| {
            let t = i as f64 * 0.01;
            if i % 97 == 0 {
                0.0
            } else {
                (t * 7.3).sin() * 10f64.powi((i % 5) as i32 - 2) * 3.7
            }
        })
        .collect()
}

fn time(y: i64, mo: i64, d: i64, h: i64, mi: i64, s: f64) -> CivilTime {
    CivilTime {
        year: y,
        month: mo,
        day: d,
        hour: h,
        minute: mi,
        second: s,
    }
}

#[test]
fn smc_writer_round_trips_through_the_smc_reader() {
    let samples = signal(1001);
    let start = time(2026, 7, 14, 10, 31, 12.25);
    for (component, azimuth, expected) in [
        ("20", Some(20), Direction::Azimuth(20.0)),
        ("up", None, Direction::Up),
    ] {
        let text = smc_text(&SmcChannel {
            station_code: "9999".into(),
            station_name: "Sample City; 12-story Steel Frame,".into(),
            component: component.into(),
            azimuth_deg: azimuth,
            channel_number: 1,
            station_channels: 3,
            event_time: time(2026, 7, 14, 10, 31, 0.0),
            event_name: "Sample City, CA".into(),
            magnitude: 6.4,
            hypocentre: (34.2, -118.5, 12.0),
            station_lat_lon: (34.05, -118.25),
            epicentral_distance_km: 31.6,
            instrument: "Episensor".into(),
            start,
            sampling_rate_hz: 200.0,
            comments: vec![String::new(), "<loclbl=7th Floor>".into()],
            samples_cm_s2: &samples,
        });
        // Fixed-width layout: 80-column text, 8I10, 5E15.7, 8E10.4.
        let lines: Vec<&str> = text.lines().collect();
        assert!(lines[..11].iter().all(|l| l.len() == 80));
        assert!(lines[11..17].iter().all(|l| l.len() == 80));
        assert!(lines[17..27].iter().all(|l| l.len() == 75));
        assert_eq!(
            lines[27..29],
            [
                "|".to_string() + &" ".repeat(79),
                format!("{:<80}", "|<loclbl=7th Floor>")
            ]
        );
        assert_eq!(lines[29].len(), 80);
        let c = readers::read(
            Format::Smc,
            text.as_bytes(),
            &source("x.smc", Format::Smc),
            &ReadOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(c.records.len(), 1);
        let r = &c.records[0];
        assert_eq!(r.channel.sampling_rate_hz, 200.0);
        assert_eq!(r.channel.units, Units::CmPerS2);
        assert_eq!(r.channel.direction, Some(expected));
        assert_eq!(
            r.channel.start_ns,
            epoch_ns_from_civil(2026, 7, 14, 10, 31, 12.25)
        );
        assert_eq!(r.len(), samples.len());
        for (i, (got, v)) in r.samples.iter().zip(&samples).enumerate() {
            let want = smc_e10_4_rounded(*v);
            assert_eq!(*got, want, "sample {i}");
            // E10.4 keeps five significant digits (values ≥ 1e-9).
            assert!(
                (got - v).abs() <= 5e-5 * v.abs() + 1e-9,
                "sample {i}: {got} vs {v}"
            );
        }
    }
}

#[test]
fn csmip_writer_round_trips_through_the_dmg_reader() {
    let acc: Vec<f64> = signal(1500).iter().map(|v| v * 40.0).collect();
    let vel: Vec<f64> = acc.iter().map(|v| v * 0.03).collect();
    let disp: Vec<f64> = acc.iter().map(|v| v * 0.001).collect();
    let start_utc = time(2026, 8, 3, 21, 47, 9.6);
    let start_local = time(2026, 8, 3, 14, 47, 9.6);
    let block = |k: u32, orientation, location: &str| {
        csmip_v2_text(&CsmipChannel {
            station_number: 99906,
            station_name: "Sample City - 6-story Commercial Bldg".into(),
            latitude: 34.181,
            longitude: -118.592,
            recorder: "Etna2".into(),
            serial: 3817,
            recorder_channel: k,
            recorder_channels: 2,
            station_channel: k + 4,
            station_channels: 9,
            orientation,
            location: location.into(),
            start_utc,
            start_local,
            local_weekday: "Mon".into(),
            local_zone: "PDT".into(),
            band_hz: (0.1, 40.0),
            sampling_rate_hz: 100.0,
            accel_cm_s2: &acc,
            veloc_cm_s: &vel,
            displ_cm: &disp,
        })
    };
    let text = block(1, CsmipOrientation::AzimuthDeg(90), "3rd Floor")
        + &block(2, CsmipOrientation::Up, "Ground Floor");
    assert_eq!(
        readers::classify("CE99906.V2", text.as_bytes()).format(),
        Some(Format::Dmg)
    );
    let c = readers::read(
        Format::Dmg,
        text.as_bytes(),
        &source("CE99906.V2", Format::Dmg),
        &ReadOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(c.records.len(), 2);
    let d = section_decimals(&acc, 6);
    for (r, (id, dir, loc)) in c.records.iter().zip([
        ("99906.05", Direction::Azimuth(90.0), "3rd Floor"),
        ("99906.06", Direction::Up, "Ground Floor"),
    ]) {
        assert_eq!(r.channel.id, id);
        assert_eq!(r.channel.direction, Some(dir));
        assert_eq!(r.channel.location_text.as_deref(), Some(loc));
        assert_eq!(r.channel.units, Units::CmPerS2);
        assert!((r.channel.sampling_rate_hz - 100.0).abs() < 1e-9);
        assert_eq!(
            r.channel.start_ns,
            epoch_ns_from_civil(2026, 8, 3, 21, 47, 9.6)
        );
        // The `Rcrd of` local time (PDT) agrees with the UTC start.
        assert!(
            r.channel
                .inferred
                .iter()
                .any(|s| s.contains("agrees with the zoned `Rcrd of`")),
            "{:?}",
            r.channel.inferred
        );
        assert_eq!(r.len(), acc.len());
        for (i, (got, v)) in r.samples.iter().zip(&acc).enumerate() {
            assert_eq!(*got, fortran_f10_rounded(*v, d), "sample {i}");
            assert!((got - v).abs() <= 0.5 * 10f64.powi(-(d as i32)) + 1e-12);
        }
    }
}

/// With a yield force never reached and no damping, the central-difference
/// chain follows the exact (ZOH) linear response to O((ωh)²).
#[test]
fn yielding_building_in_its_elastic_range_matches_the_exact_linear_response() {
    let b = YieldingShearBuilding {
        masses_kg: vec![6e5, 6e5, 5e5],
        storey_stiffness_n_per_m: vec![4e8, 5e8, 3e8],
        yield_force_n: 1e12,
        hardening_ratio: 0.03,
        degradation_exponent: 0.5,
        damping_ratio: 0.0,
    };
    let dt = 0.01;
    let ag: Vec<f64> = (0..2000)
        .map(|i| (i as f64 * dt * 9.0).sin() * (i as f64 * dt * 0.7).sin())
        .collect();
    let nl = b.simulate(&ag, dt, 40).unwrap();
    let lin = ShearBuilding {
        damping_ratios: vec![0.0],
        ..b.initial()
    };
    // The linear reference with the same excitation, finely sampled (ZOH of a
    // signal linear between samples converges as the sampling refines).
    let fine: Vec<f64> = (0..2000 * 40)
        .map(|k| {
            let (i, f) = (k / 40, (k % 40) as f64 / 40.0 + 1.0 / 80.0);
            let next = ag.get(i + 1).copied().unwrap_or(ag[i]);
            ag[i] + (next - ag[i]) * f
        })
        .collect();
    let exact = lin.simulate_base_motion(&fine, dt / 40.0).unwrap();
    let peak = exact.relative_displacement[2]
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let worst = (0..2000)
        .map(|i| (nl.relative_displacement[2][i] - exact.relative_displacement[2][40 * i]).abs())
        .fold(0.0f64, f64::max);
    assert!(worst < 2e-3 * peak, "worst {worst:e} vs peak {peak:e}");
    assert_eq!(nl.final_storey1_stiffness_n_per_m, 4e8);
}

fn truth(folder: &str) -> toml::Table {
    let text = std::fs::read_to_string(
        root()
            .join("sample-records")
            .join(folder)
            .join("truth.toml"),
    )
    .unwrap();
    toml::from_str(&text).unwrap()
}

/// A TOML number (`3600000` or `0.1`) as f64.
fn num(v: &toml::Value) -> f64 {
    v.as_float().or(v.as_integer().map(|i| i as f64)).unwrap()
}

fn floats(v: &toml::Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_float().or(x.as_integer().map(|i| i as f64)).unwrap())
        .collect()
}

/// Number of eigenvalues of K φ = λ M φ below σ: the negative pivots of
/// K − σM (Sylvester's law of inertia), by symmetric Gaussian elimination.
fn eigenvalues_below(k: &[Vec<f64>], m: &[f64], sigma: f64) -> usize {
    let n = m.len();
    let mut a: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| k[i][j] - if i == j { sigma * m[i] } else { 0.0 })
                .collect()
        })
        .collect();
    let mut negative = 0;
    for p in 0..n {
        let pivot = a[p][p];
        if pivot < 0.0 {
            negative += 1;
        }
        for i in p + 1..n {
            let f = a[i][p] / pivot;
            if f != 0.0 {
                for j in p..n {
                    a[i][j] -= f * a[p][j];
                }
            }
        }
    }
    negative
}

fn chain(k: &[f64]) -> Vec<Vec<f64>> {
    let n = k.len();
    let mut kk = vec![vec![0.0; n]; n];
    for i in 0..n {
        kk[i][i] = k[i] + k.get(i + 1).copied().unwrap_or(0.0);
        if i + 1 < n {
            kk[i][i + 1] = -k[i + 1];
            kk[i + 1][i] = -k[i + 1];
        }
    }
    kk
}

/// (a): the truth's modal frequencies are eigenvalues of the plan model
/// assembled here independently (x, y, θ per floor, eccentric mass), the
/// lowest X, Y and torsion modes are well separated and damped 2–5 %.
#[test]
fn nsmp_benchmark_truth_modes_solve_the_plan_model_independently() {
    let t = truth("synthetic-12storey-nsmp");
    let m = floats(&t["masses_kg"]);
    let j = floats(&t["rotational_inertia_kg_m2"]);
    let e = floats(&t["mass_eccentricity_m"]);
    let (kx, ky, kt) = (
        chain(&floats(&t["storey_stiffness_x_n_per_m"])),
        chain(&floats(&t["storey_stiffness_y_n_per_m"])),
        chain(&floats(&t["storey_torsional_stiffness_n_m_per_rad"])),
    );
    let n = m.len();
    assert_eq!(n, 12);
    // DoFs at the centre of mass; the stiffness acts at the plan origin:
    // u_x,sc = u_x + e_y θ, u_y,sc = u_y − e_x θ.
    let mut k = vec![vec![0.0; 3 * n]; 3 * n];
    let mut mass = vec![0.0; 3 * n];
    for a in 0..n {
        mass[3 * a] = m[a];
        mass[3 * a + 1] = m[a];
        mass[3 * a + 2] = j[a];
        for b in 0..n {
            let (x, y, r) = (kx[a][b], ky[a][b], kt[a][b]);
            k[3 * a][3 * b] = x;
            k[3 * a][3 * b + 2] = x * e[1];
            k[3 * a + 2][3 * b] = x * e[1];
            k[3 * a + 1][3 * b + 1] = y;
            k[3 * a + 1][3 * b + 2] = -y * e[0];
            k[3 * a + 2][3 * b + 1] = -y * e[0];
            k[3 * a + 2][3 * b + 2] = r + x * e[1] * e[1] + y * e[0] * e[0];
        }
    }
    let modes = t["mode"].as_array().unwrap();
    let mut lowest = std::collections::BTreeMap::new();
    for (idx, mode) in modes.iter().enumerate() {
        let f = mode["frequency_hz"].as_float().unwrap();
        let lambda = (std::f64::consts::TAU * f).powi(2);
        assert_eq!(
            eigenvalues_below(&k, &mass, lambda * (1.0 - 1e-7)),
            idx,
            "mode {idx}: {f} Hz"
        );
        assert_eq!(
            eigenvalues_below(&k, &mass, lambda * (1.0 + 1e-7)),
            idx + 1,
            "mode {idx}: {f} Hz"
        );
        let zeta = mode["damping_ratio"].as_float().unwrap();
        assert!((0.02..=0.05).contains(&zeta));
        lowest
            .entry(mode["kind"].as_str().unwrap().to_string())
            .or_insert(f);
    }
    let (fx, fy, ft) = (lowest["X"], lowest["Y"], lowest["torsion"]);
    assert!(
        (0.85..0.95).contains(&fx) && (1.05..1.15).contains(&fy) && (1.5..1.7).contains(&ft),
        "{fx} {fy} {ft}"
    );
    // Segment drifts are stated for every instrumented floor channel.
    let segments = t["segment_drift"].as_array().unwrap();
    assert_eq!(segments.len(), 6);
    for s in segments {
        let ratio = s["peak_drift_ratio"].as_float().unwrap();
        assert!(ratio > 1e-4 && ratio < 0.02, "{s:?}");
    }
}

/// (b): the lowest frequency of each direction is the lowest eigenvalue of
/// the stated chain (independent count), near 0.2 Hz.
#[test]
fn tall_benchmark_fundamental_is_near_0_2_hz() {
    let t = truth("synthetic-40storey");
    for d in t["direction"].as_array().unwrap() {
        let m = floats(&d["masses_kg"]);
        let k = chain(&floats(&d["storey_stiffness_n_per_m"]));
        let f = floats(&d["frequencies_hz"]);
        assert_eq!(m.len(), 40);
        let lambda = (std::f64::consts::TAU * f[0]).powi(2);
        assert_eq!(eigenvalues_below(&k, &m, lambda * (1.0 - 1e-7)), 0);
        assert_eq!(eigenvalues_below(&k, &m, lambda * (1.0 + 1e-7)), 1);
        assert!((0.18..0.25).contains(&f[0]), "{}", f[0]);
    }
}

/// (c): the ground storey of X yields (peak drift 1.5–3 %), ends softer —
/// the stated final stiffness is the slope of its own force–drift trace in
/// the free vibration after the event — with a residual far below the peak.
#[test]
fn yielding_benchmark_ground_storey_degrades_as_stated() {
    let t = truth("synthetic-6storey-yielding");
    let x = &t["direction"].as_array().unwrap()[0];
    let k0 = floats(&x["storey_stiffness_n_per_m"])[0];
    let k_final = num(&x["storey1_final_stiffness_n_per_m"]);
    assert!(k_final < 0.8 * k0, "{k_final} vs {k0}");
    let f0 = floats(&x["initial_frequencies_hz"])[0];
    let f1 = floats(&x["final_frequencies_hz"])[0];
    assert!(f1 < 0.95 * f0, "{f1} vs {f0}");
    let storey1 = t["storey_drift"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["storey"].as_integer() == Some(1) && s["axis"].as_str() == Some("X"))
        .unwrap();
    let peak = storey1["peak_drift_ratio"].as_float().unwrap();
    let residual = storey1["residual_drift_ratio"].as_float().unwrap();
    assert!((0.015..=0.03).contains(&peak), "peak drift ratio {peak}");
    assert!(
        residual.abs() < 0.25 * peak,
        "residual {residual} vs peak {peak}"
    );
    // Re-simulate the stated model and measure the post-event tangent.
    let b = YieldingShearBuilding {
        masses_kg: floats(&x["masses_kg"]),
        storey_stiffness_n_per_m: floats(&x["storey_stiffness_n_per_m"]),
        yield_force_n: num(&x["yield_force_n"]),
        hardening_ratio: num(&x["hardening_ratio"]),
        degradation_exponent: num(&x["degradation_exponent"]),
        damping_ratio: num(&x["damping_ratio"]),
    };
    let spec =
        quaketwin::synth::GroundMotionSpec::strong_50s(2026 + 6001, 100.0, num(&t["pga_x_m_s2"]));
    let mut ag = vec![0.0; 500];
    ag.extend(quaketwin::synth::synthetic_ground_motion(&spec).unwrap());
    ag.extend(vec![0.0; 2000]);
    let r = b.simulate(&ag, 0.01, 40).unwrap();
    assert_eq!(r.final_storey1_stiffness_n_per_m, k_final);
    let tail = ag.len() - 1000..ag.len();
    let (d, f) = (
        &r.relative_displacement[0][tail.clone()],
        &r.storey1_force_n[tail],
    );
    let (md, mf) = (
        d.iter().sum::<f64>() / d.len() as f64,
        f.iter().sum::<f64>() / f.len() as f64,
    );
    let slope = d
        .iter()
        .zip(f)
        .map(|(a, b)| (a - md) * (b - mf))
        .sum::<f64>()
        / d.iter().map(|a| (a - md).powi(2)).sum::<f64>();
    assert!(
        (slope / k_final - 1.0).abs() < 1e-6,
        "slope {slope} vs {k_final}"
    );
}

fn files_under(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            files_under(&p, out);
        } else {
            out.push(p);
        }
    }
}

/// `quaketwin synth --seed 2026` rewrites the committed benchmarks byte for
/// byte (the record zips and the truth); each stays small and has no
/// manifest.  (The facade sample's `ps.csv` is left to its own test: its
/// last digits depend on the platform's floating point.)
#[test]
fn benchmarks_regenerate_byte_for_byte() {
    let out = tempfile::tempdir().unwrap();
    quaketwin::commands::synth(out.path(), 2026).unwrap();
    let committed = root().join("sample-records");
    for folder in [
        "synthetic-12storey-nsmp",
        "synthetic-40storey",
        "synthetic-6storey-yielding",
    ] {
        let mut files = Vec::new();
        files_under(&out.path().join(folder), &mut files);
        // The yielding frame also has its per-sample frequency truth.
        let expected = if folder == "synthetic-6storey-yielding" {
            3
        } else {
            2
        };
        assert_eq!(files.len(), expected, "{folder}: a zip and truth.toml");
        for f in &files {
            let rel = f.strip_prefix(out.path()).unwrap();
            let old = std::fs::read(committed.join(rel))
                .unwrap_or_else(|e| panic!("{}: {e}", rel.display()));
            assert!(
                old == std::fs::read(f).unwrap(),
                "{} differs from what `quaketwin synth` writes",
                rel.display()
            );
        }
        let dir = committed.join(folder);
        assert!(!dir.join("event.toml").exists());
        let size: u64 = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().metadata().unwrap().len())
            .sum();
        assert!(size < 3_200_000, "{folder}: {size} bytes");
    }
}

/// Each benchmark folder is an event as published: the zip read, the truth
/// skipped as documentation, every channel read at its rate.
#[test]
fn benchmark_folders_load_as_events_without_a_manifest() {
    for (folder, channels, rate) in [
        ("synthetic-12storey-nsmp", 9, 100.0),
        ("synthetic-40storey", 11, 50.0),
        ("synthetic-6storey-yielding", 7, 100.0),
    ] {
        let loaded = quaketwin::event_folder::load(&root().join("sample-records").join(folder))
            .unwrap_or_else(|e| panic!("{folder}: {e}"));
        assert!(loaded.manifest.is_none());
        // Sensor channels; floor motions the geometry formed from several
        // sensors of one level (rigid-floor combination) come on top.
        let sensors = loaded
            .event
            .records
            .iter()
            .filter(|r| !r.channel.is_floor_motion())
            .count();
        assert_eq!(sensors, channels, "{folder}");
        assert!(loaded
            .event
            .records
            .iter()
            .all(|r| (r.channel.sampling_rate_hz - rate).abs() < 1e-9));
        let truth = loaded
            .files
            .iter()
            .find(|f| f.name.ends_with("truth.toml"))
            .unwrap();
        assert!(
            truth.skipped.is_some(),
            "{folder}: truth.toml must not be read as a record"
        );
    }
}
