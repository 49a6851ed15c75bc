//! Issue 3 "Must show": subspace identification against synthetic truth and
//! real records.  Accuracy figures are printed (run with `--nocapture`).

use faer::c64;
use quaketwin::modal::hankel::{cross_covariances, dot, hankel_gram, HankelRow};
use quaketwin::modal::poles::poles_of_order;
use quaketwin::modal::preprocess::{antialias_taps, apply, decimate};
use quaketwin::modal::{
    self, identify, mac, mac_matrix, mpc_mpd, pair_modes, spectral_overlay, Method, ModalInput,
    ModalSettings, Mode, Preprocessing,
};
use quaketwin::rng::Rng;
use quaketwin::synth::{
    add_measurement_noise, synthetic_ground_motion, BuildingModes, GroundMotionSpec, ShearBuilding,
};

/// The 5-storey test building: f ≈ 2.0–12.4 Hz (T₁ ≈ 0.5 s, typical of five
/// storeys), damping 1.5–4 %.
pub fn five_storey() -> ShearBuilding {
    quaketwin::synth::five_storey::five_storey_building()
}

struct Accuracy {
    max_rel_freq: f64,
    max_abs_damping: f64,
    min_mac: f64,
}

/// Matches every truth mode to the identified mode nearest in frequency
/// (each identified mode used once) and returns the worst errors; panics
/// when a truth mode has no identified mode within 10 %.
fn compare_with_truth(truth: &BuildingModes, modes: &[Mode]) -> Accuracy {
    let mut used = vec![false; modes.len()];
    let mut acc = Accuracy {
        max_rel_freq: 0.0,
        max_abs_damping: 0.0,
        min_mac: 1.0,
    };
    for (j, &f_true) in truth.frequencies_hz.iter().enumerate() {
        let best = (0..modes.len())
            .filter(|&i| !used[i])
            .min_by(|&a, &b| {
                (modes[a].frequency_hz - f_true)
                    .abs()
                    .total_cmp(&(modes[b].frequency_hz - f_true).abs())
            })
            .unwrap_or_else(|| panic!("truth mode {j} ({f_true:.4} Hz) not found"));
        let m = &modes[best];
        assert!(
            (m.frequency_hz / f_true - 1.0).abs() < 0.1,
            "truth mode {j} ({f_true:.4} Hz) not found; nearest {:.4} Hz",
            m.frequency_hz
        );
        used[best] = true;
        let truth_shape: Vec<faer::c64> = truth.shapes[j]
            .iter()
            .map(|&v| faer::c64::new(v, 0.0))
            .collect();
        let mac = modal::mac(&truth_shape, &m.shape);
        let df = (m.frequency_hz / f_true - 1.0).abs();
        let dz = (m.damping_ratio - truth.damping_ratios[j]).abs();
        eprintln!(
            "mode {j}: f {:.5} Hz (truth {f_true:.5}, rel err {df:.2e}), zeta {:.4} ± {:.4} (truth {:.4}), MAC {mac:.5}, poles {}",
            m.frequency_hz, m.damping_ratio, m.damping_std, truth.damping_ratios[j], m.pole_count
        );
        acc.max_rel_freq = acc.max_rel_freq.max(df);
        acc.max_abs_damping = acc.max_abs_damping.max(dz);
        acc.min_mac = acc.min_mac.min(mac);
    }
    acc
}

/// Ambient case: independent white-noise floor forces, 600 s at 100 Hz,
/// floor accelerations with 20 dB noise.
/// Seed 1 is the first seed of the 20-seed study reported in the module
/// note: the tolerances of the issue (3e-3, 0.005) sit at about two standard
/// deviations of the statistical scatter of 600-s records (std of Δf/f
/// 1.1–1.9e-3 per mode, means ≤ 3.5e-4), so 16 of 20 seeds pass for each
/// method; `ambient_identification_is_unbiased_over_seeds` checks the bias.
pub fn ambient_input() -> ModalInput {
    ambient_input_seeded(1)
}

pub fn ambient_input_seeded(seed: u64) -> ModalInput {
    let outputs =
        quaketwin::synth::five_storey::noisy_ambient(&five_storey(), 60_000, 0.01, seed).unwrap();
    ModalInput {
        dt: 0.01,
        output_ids: (1..=5).map(|i| format!("L{i}")).collect(),
        outputs,
        ..Default::default()
    }
}

fn ambient_settings(method: Method) -> ModalSettings {
    let mut s = ModalSettings {
        method,
        ..Default::default()
    };
    // The truth damping (1.5–4 %) lies inside the default 0.9–5.5 % window;
    // set explicitly as the issue asks.
    s.filters.damping_min = 0.005;
    s.filters.damping_max = 0.06;
    s
}

#[test]
fn ambient_five_storey_ssi_cov_and_ssi_data_find_all_modes() {
    let truth = five_storey().modes().unwrap();
    let input = ambient_input();
    for method in [Method::SsiCov, Method::SsiData] {
        let result = identify(&input, &ambient_settings(method)).unwrap();
        eprintln!(
            "{}: {} modes, block rows {}",
            method.name(),
            result.modes.len(),
            result.block_rows
        );
        for m in &result.modes {
            eprintln!(
                "  {:.4} Hz ζ {:.4} poles {} orders {}–{} mpc {:.3} mean MAC {:.4}",
                m.frequency_hz,
                m.damping_ratio,
                m.pole_count,
                m.order_min,
                m.order_max,
                m.mpc,
                m.mean_mac
            );
        }
        assert_eq!(
            result.modes.len(),
            5,
            "{}: found {:?}",
            method.name(),
            result
                .modes
                .iter()
                .map(|m| m.frequency_hz)
                .collect::<Vec<_>>()
        );
        let acc = compare_with_truth(&truth, &result.modes);
        assert!(
            acc.max_rel_freq <= 3e-3,
            "{}: max |Δf/f| {}",
            method.name(),
            acc.max_rel_freq
        );
        assert!(
            acc.max_abs_damping <= 0.005,
            "{}: max |Δζ| {}",
            method.name(),
            acc.max_abs_damping
        );
        assert!(
            acc.min_mac >= 0.995,
            "{}: min MAC {}",
            method.name(),
            acc.min_mac
        );
    }
}

/// Earthquake case: 40 s Kanai–Tajimi/Clough–Penzien base motion at 200 Hz,
/// base + 5 floors with 30 dB noise.
pub fn earthquake_input() -> ModalInput {
    earthquake_input_seeded(7)
}

/// The noise-free base motion of the earthquake case and its sampling
/// interval: 40 s at 200 Hz, Kanai–Tajimi soil frequency of a rock site
/// (4 Hz), so that the base motion carries energy up to the fifth mode (12.4 Hz).
pub fn earthquake_base_motion(seed: u64) -> (Vec<f64>, f64) {
    let params = GroundMotionSpec {
        seed,
        ground_frequency_hz: 4.0,
        ..Default::default()
    };
    (synthetic_ground_motion(&params).unwrap(), params.dt())
}

pub fn earthquake_input_seeded(seed: u64) -> ModalInput {
    earthquake_input_with_noise(seed, 30.0)
}

/// The earthquake case with `snr_db` of measurement noise on the base and
/// every floor (the issue-13 study uses 20 dB).
pub fn earthquake_input_with_noise(seed: u64, snr_db: f64) -> ModalInput {
    let (ag, dt) = earthquake_base_motion(seed);
    let response = five_storey().simulate_base_motion(&ag, dt).unwrap();
    let mut rng = Rng::new(seed + 92);
    let outputs = response
        .absolute_acceleration
        .iter()
        .map(|a| add_measurement_noise(a, snr_db, &mut rng))
        .collect();
    let base = add_measurement_noise(&response.base_acceleration, snr_db, &mut rng);
    ModalInput {
        dt,
        output_ids: (1..=5).map(|i| format!("L{i}")).collect(),
        outputs,
        input_ids: vec!["L0".into()],
        inputs: vec![base],
        ..Default::default()
    }
}

#[test]
fn earthquake_five_storey_input_output_finds_five_modes_and_nothing_else() {
    let truth = five_storey().modes().unwrap();
    let input = earthquake_input();
    let settings = ModalSettings {
        method: Method::Io,
        ..Default::default()
    };
    let result = identify(&input, &settings).unwrap();
    eprintln!(
        "io: {} modes, block rows {}",
        result.modes.len(),
        result.block_rows
    );
    assert_eq!(
        result.modes.len(),
        5,
        "found {:?}",
        result
            .modes
            .iter()
            .map(|m| m.frequency_hz)
            .collect::<Vec<_>>()
    );
    let acc = compare_with_truth(&truth, &result.modes);
    assert!(acc.max_rel_freq <= 1e-3, "max |Δf/f| {}", acc.max_rel_freq);
}

/// Over 16 independent records the automatic selection always returns the 5
/// modes, and the mean errors show no bias: |mean Δf/f| ≤ 1.5e-3 and
/// |mean Δζ| ≤ 0.0015 per mode.  These bounds are about 3.5 standard errors
/// of a 16-record mean given the single-record scatter measured on 20 seeds
/// (std of Δf/f ≤ 1.9e-3, of Δζ ≤ 0.0025), so a real bias of that size would
/// be caught while chance scatter passes.
#[test]
fn ambient_identification_is_unbiased_over_seeds() {
    let truth = five_storey().modes().unwrap();
    let seeds: Vec<u64> = (101..117).collect();
    let mut df = vec![Vec::new(); 5];
    let mut dz = vec![Vec::new(); 5];
    for &seed in &seeds {
        let result = identify(
            &ambient_input_seeded(seed),
            &ambient_settings(Method::SsiCov),
        )
        .unwrap();
        assert_eq!(
            result.modes.len(),
            5,
            "seed {seed}: {:?}",
            result
                .modes
                .iter()
                .map(|m| m.frequency_hz)
                .collect::<Vec<_>>()
        );
        for j in 0..5 {
            df[j].push(result.modes[j].frequency_hz / truth.frequencies_hz[j] - 1.0);
            dz[j].push(result.modes[j].damping_ratio - truth.damping_ratios[j]);
        }
    }
    let mean_and_se = |v: &[f64]| {
        let n = v.len() as f64;
        let m = v.iter().sum::<f64>() / n;
        let sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        (m, sd / n.sqrt())
    };
    for j in 0..5 {
        let (bias_f, se_f) = mean_and_se(&df[j]);
        let (bias_z, se_z) = mean_and_se(&dz[j]);
        eprintln!("mode {j}: mean Δf/f {bias_f:.2e} (s.e. {se_f:.1e}), mean Δζ {bias_z:.5} (s.e. {se_z:.5})");
        assert!(bias_f.abs() <= 1.5e-3, "mode {j}: frequency bias {bias_f}");
        assert!(bias_z.abs() <= 0.0015, "mode {j}: damping bias {bias_z}");
    }
}

// ---------------------------------------------------------------- real data

use quaketwin::readers::{self, ReadOptions};
use quaketwin::vocab::SourceRef;

fn records_dir() -> std::path::PathBuf {
    std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/records"))
}

/// Reads one column of an Xsens DOT CSV export with the project's CSV reader.
fn xsens_column(path: &std::path::Path, column: &str) -> (Vec<f64>, f64) {
    let bytes = std::fs::read(path).unwrap();
    let source = SourceRef {
        file: path.display().to_string(),
        member: None,
        column: None,
        format: "csv".into(),
    };
    let opts = ReadOptions {
        columns: Some(vec![column.into()]),
        ..Default::default()
    };
    let contents = readers::csv::read(&bytes, &source, &opts).unwrap();
    let record = contents.records.into_iter().next().unwrap();
    (record.samples.to_vec(), record.channel.sampling_rate_hz)
}

fn rms_about_mean(v: &[f64]) -> f64 {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
}

/// Lab 3-storey flexible model on the mini shake table (Northridge run):
/// ground-floor Acc_X as input, top-floor Acc_X as output.  The data's
/// source states a fundamental period of 0.274 s (3.65 Hz); assert within 5 %.
#[test]
fn lab_three_storey_fundamental_near_3_65_hz() {
    let dir = records_dir().join("mdof-mini-shake-table-flexible-3story");
    let ground_file = dir.join("Ground Floor/(Northridge)Xsens DOT_20250306_122607.csv");
    let top_file = dir.join("3rd Floor (Top floor)/(Northridge)Xsens DOT_20250306_122607.csv");
    let (ground_x, rate) = xsens_column(&ground_file, "Acc_X");
    let (ground_y, _) = xsens_column(&ground_file, "Acc_Y");
    let (top, top_rate) = xsens_column(&top_file, "Acc_X");
    assert!(
        (rate - 120.0).abs() < 0.01 && (top_rate - 120.0).abs() < 0.01,
        "{rate} {top_rate}"
    );
    // Shaking axis check: the table moves along X (its rms dominates Y's).
    eprintln!(
        "ground rms: Acc_X {:.3}, Acc_Y {:.3} m/s2",
        rms_about_mean(&ground_x),
        rms_about_mean(&ground_y)
    );
    assert!(rms_about_mean(&ground_x) > 2.0 * rms_about_mean(&ground_y));
    let n = ground_x.len().min(top.len());
    let input = ModalInput {
        dt: 1.0 / rate,
        output_ids: vec!["top_x".into()],
        // The first sample of the ground file is an exact 0 (device start-up): skip it.
        outputs: vec![top[1..n].to_vec()],
        input_ids: vec!["ground_x".into()],
        inputs: vec![ground_x[1..n].to_vec()],
        ..Default::default()
    };
    let mut settings = ModalSettings {
        method: Method::Io,
        ..Default::default()
    };
    // Small steel model: damping unknown, widen the window; one output channel,
    // so MPC/MPD are trivially perfect.
    settings.filters.damping_min = 0.001;
    settings.filters.damping_max = 0.10;
    let result = identify(&input, &settings).unwrap();
    for m in &result.modes {
        eprintln!(
            "lab mode: f {:.4} Hz (T {:.4} s), zeta {:.4}, poles {}",
            m.frequency_hz,
            1.0 / m.frequency_hz,
            m.damping_ratio,
            m.pole_count
        );
    }
    let fundamental = result.modes.first().expect("no mode identified");
    assert!(
        (fundamental.frequency_hz / 3.65 - 1.0).abs() <= 0.05,
        "fundamental {} Hz",
        fundamental.frequency_hz
    );
}

/// Painter St. overpass, 2023-09-30 Ferndale M4.7 (weak motion), transverse
/// direction: station channels 3, 17, 20 (ground) → 7, 9, 4 (bent top and
/// deck), as in the data source's channel configuration.  Reported transverse
/// mode 0.24–0.25 s; assert the fundamental's period lies within 5 % of that
/// range (0.228–0.2625 s).
///
/// Default settings (no tuning to this record): the 3 % stability tolerance
/// and zero damping weight once needed here are gone.  The mode is damped
/// (ζ ≈ 7 %): it is found since the damping window is 0.5–10 % and pole
/// columns link within ζ/2 (issue 13).
#[test]
fn painter_street_overpass_transverse_mode() {
    let zip_path = records_dir().join("csmip-ce89324-painterst-overpass/nc73943821_ce89324p.zip");
    let file = std::fs::File::open(&zip_path).unwrap();
    let mut archive = zip::ZipArchive::new(file).unwrap();
    let mut read_channel = |chan: u32| -> (Vec<f64>, f64) {
        let name = format!("chan{chan:03}.v2");
        let mut entry = archive.by_name(&name).unwrap();
        let mut bytes = Vec::new();
        std::io::Read::read_to_end(&mut entry, &mut bytes).unwrap();
        let source = SourceRef {
            file: zip_path.display().to_string(),
            member: Some(name.clone()),
            column: None,
            format: "dmg".into(),
        };
        let contents = readers::dmg::read(&bytes, &source, &ReadOptions::default()).unwrap();
        let record = contents.records.into_iter().next().unwrap();
        let to_si = record.channel.units.to_si_factor().unwrap();
        (
            record.samples.iter().map(|v| v * to_si).collect(),
            record.channel.sampling_rate_hz,
        )
    };
    let inputs: Vec<(Vec<f64>, f64)> = [3, 17, 20].into_iter().map(&mut read_channel).collect();
    let outputs: Vec<(Vec<f64>, f64)> = [7, 9, 4].into_iter().map(&mut read_channel).collect();
    let rate = inputs[0].1;
    assert!((rate - 100.0).abs() < 1e-6);
    let n = inputs
        .iter()
        .chain(&outputs)
        .map(|(s, _)| s.len())
        .min()
        .unwrap();
    let input = ModalInput {
        dt: 1.0 / rate,
        output_ids: vec!["07".into(), "09".into(), "04".into()],
        outputs: outputs.iter().map(|(s, _)| s[..n].to_vec()).collect(),
        input_ids: vec!["03".into(), "17".into(), "20".into()],
        inputs: inputs.iter().map(|(s, _)| s[..n].to_vec()).collect(),
        ..Default::default()
    };
    let settings = ModalSettings {
        method: Method::Io,
        ..Default::default()
    };
    // Default settings (issue 13): no stability tolerance, damping weight or
    // band tuned to this record.
    let result = identify(&input, &settings).unwrap();
    for m in &result.modes {
        eprintln!(
            "painter st mode: T {:.4} s (f {:.3} Hz), zeta {:.4}, poles {}, MPC {:.3}",
            1.0 / m.frequency_hz,
            m.frequency_hz,
            m.damping_ratio,
            m.pole_count,
            m.mpc
        );
    }
    let fundamental = result.modes.first().expect("no mode identified");
    let period = 1.0 / fundamental.frequency_hz;
    assert!(
        (0.24 * 0.95..=0.25 * 1.05).contains(&period),
        "fundamental period {period} s"
    );
}

/// The same 2023 Painter St. record through the event path with the shipped
/// defaults (roles and directions inferred from the CSMIP headers, inputs
/// the horizontal base channels, vertical channels left out): a transverse
/// (Y) mode with a period in 0.23–0.27 s (issue 13's must-show).
#[test]
fn painter_street_overpass_event_defaults_find_transverse_mode() {
    let zip_path = records_dir().join("csmip-ce89324-painterst-overpass/nc73943821_ce89324p.zip");
    let mut event = quaketwin::event_folder::load(&zip_path).unwrap().event;
    for r in event.records.iter_mut() {
        let k = r.channel.units.to_si_factor().unwrap();
        r.samples.iter_mut().for_each(|v| *v *= k);
    }
    let params = quaketwin::stages::modal::ModalParams::default();
    let settings = params.settings_for(&event).unwrap();
    let result = quaketwin::modal::identify_event(
        &event,
        &settings,
        &quaketwin::modal::ChannelChoice::default(),
    )
    .unwrap();
    for m in &result.modes {
        eprintln!(
            "painter st (event defaults): T {:.4} s, ζ {:.3}, {}",
            1.0 / m.frequency_hz,
            m.damping_ratio,
            m.direction
        );
    }
    assert!(
        result
            .modes
            .iter()
            .any(|m| m.direction == "Y" && (0.23..=0.27).contains(&(1.0 / m.frequency_hz))),
        "no transverse mode in 0.23–0.27 s: {:?}; warnings {:?}",
        result
            .modes
            .iter()
            .map(|m| (m.frequency_hz, m.direction.clone()))
            .collect::<Vec<_>>(),
        result.warnings
    );
}

// The pieces of the identification on their own: mode pairing by MAC, the
// block-Hankel Gram matrix, pole indicators, decimation, the spectral overlay.

fn real_shape(v: &[f64]) -> Vec<c64> {
    v.iter().map(|&x| c64::new(x, 0.0)).collect()
}

#[test]
fn pairing_follows_mac_not_order() {
    let a = vec![real_shape(&[1.0, 1.0, 1.0]), real_shape(&[1.0, 0.0, -1.0])];
    let b = vec![
        real_shape(&[1.0, 0.1, -0.9]),
        real_shape(&[0.9, 1.0, 1.1]),
        real_shape(&[0.0, 1.0, 0.0]),
    ];
    let m = mac_matrix(&a, &b);
    assert_eq!(m.len(), 2);
    assert_eq!(m[0].len(), 3);
    let pairs = pair_modes(&a, &b, 0.8);
    assert_eq!(pairs.len(), 2);
    assert_eq!((pairs[0].reference, pairs[0].other), (0, 1));
    assert_eq!((pairs[1].reference, pairs[1].other), (1, 0));
    assert!(pairs.iter().all(|p| p.mac > 0.95));
}

#[test]
fn gram_matches_explicit_hankel_product() {
    let x: Vec<f64> = (0..57)
        .map(|i| ((i * 37 % 11) as f64 - 5.0) * 0.3 + (i as f64 * 0.1).sin())
        .collect();
    let y: Vec<f64> = (0..57).map(|i| ((i * 13 % 7) as f64 - 3.0) * 0.5).collect();
    let signals: Vec<&[f64]> = vec![&x, &y];
    let rows = vec![
        HankelRow {
            signal: 1,
            shift: 0,
        },
        HankelRow {
            signal: 0,
            shift: 0,
        },
        HankelRow {
            signal: 1,
            shift: 1,
        },
        HankelRow {
            signal: 0,
            shift: 3,
        },
        HankelRow {
            signal: 0,
            shift: 5,
        },
        HankelRow {
            signal: 1,
            shift: 4,
        },
    ];
    let cols = 50;
    let g = hankel_gram(&signals, &rows, cols);
    for (i, ra) in rows.iter().enumerate() {
        for (k, rb) in rows.iter().enumerate() {
            let explicit: f64 = (0..cols)
                .map(|c| signals[ra.signal][c + ra.shift] * signals[rb.signal][c + rb.shift])
                .sum::<f64>()
                / cols as f64;
            assert!((g[i * rows.len() + k] - explicit).abs() < 1e-12, "{i} {k}");
        }
    }
    assert!((dot(&x, &y) - x.iter().zip(&y).map(|(a, b)| a * b).sum::<f64>()).abs() < 1e-12);
}

/// The covariances are formed several lags at a time (lengths that differ by
/// up to three samples, so some sums end in a different whole chunk): each
/// must still be the one dot product per entry, bit for bit.
#[test]
fn cross_covariances_are_the_dot_products_bit_for_bit() {
    let signal = |seed: usize, len: usize| -> Vec<f64> {
        (0..len)
            .map(|i| {
                ((i * (7 + seed) % 13) as f64 - 6.0) * 0.37 + (i as f64 * 0.11 * seed as f64).sin()
            })
            .collect()
    };
    let (y0, y1, x0, x1) = (
        signal(1, 103),
        signal(2, 101),
        signal(3, 102),
        signal(4, 110),
    );
    let outputs: Vec<&[f64]> = vec![&y0, &y1];
    let refs: Vec<&[f64]> = vec![&x0, &x1];
    let n = 101;
    for max_lag in [0, 2, 6, 9, 104] {
        let cov = cross_covariances(&outputs, &refs, max_lag);
        assert_eq!(cov.len(), max_lag + 1);
        for (k, r) in cov.iter().enumerate() {
            for (i, &v) in r.iter().enumerate() {
                let (y, x) = (outputs[i / 2], refs[i % 2]);
                let count = n - k.min(n);
                let want = if count == 0 {
                    0.0
                } else {
                    dot(&y[k..k + count], &x[..count]) / count as f64
                };
                assert_eq!(v.to_bits(), want.to_bits(), "lag {k} entry {i}");
            }
        }
    }
}

#[test]
fn indicators_of_real_and_complex_shapes() {
    let real = vec![c64::new(1.0, 0.0), c64::new(-0.5, 0.0), c64::new(0.25, 0.0)];
    let (mpc, mpd) = mpc_mpd(&real);
    assert!((mpc - 1.0).abs() < 1e-12 && mpd.abs() < 1e-9);
    // Rotating a real shape by any phase keeps MPC = 1, MPD = 0.
    let rot: Vec<c64> = real.iter().map(|z| z * c64::new(0.6, 0.8)).collect();
    let (mpc, mpd) = mpc_mpd(&rot);
    assert!((mpc - 1.0).abs() < 1e-12 && mpd.abs() < 1e-6, "{mpc} {mpd}");
    assert!((mac(&real, &rot) - 1.0).abs() < 1e-12);
    // Two components 90° apart with equal modulus: MPC = 0, MPD = 45°.
    let (mpc, mpd) = mpc_mpd(&[c64::new(1.0, 0.0), c64::new(0.0, 1.0)]);
    assert!(
        mpc.abs() < 1e-12 && (mpd - 45.0).abs() < 1e-9,
        "{mpc} {mpd}"
    );
    let orth = vec![c64::new(1.0, 0.0), c64::new(2.0, 0.0), c64::new(0.0, 0.0)];
    let other = vec![c64::new(2.0, 0.0), c64::new(-1.0, 0.0), c64::new(0.0, 0.0)];
    assert!(mac(&orth, &other).abs() < 1e-15);
}

#[test]
fn discrete_pole_maps_back_to_frequency_and_damping() {
    let (f, zeta, dt) = (2.0, 0.03, 0.01);
    let w = std::f64::consts::TAU * f;
    let lambda = c64::new(-zeta * w, w * (1.0 - zeta * zeta).sqrt());
    let mu = (lambda * dt).exp();
    let poles = poles_of_order(
        2,
        vec![
            (mu, vec![c64::new(2.0, 0.0)]),
            (mu.conj(), vec![c64::new(2.0, 0.0)]),
        ],
        dt,
    );
    assert_eq!(poles.len(), 1);
    assert!((poles[0].frequency_hz - f).abs() < 1e-12);
    assert!((poles[0].damping_ratio - zeta).abs() < 1e-12);
    assert_eq!(poles[0].shape, vec![c64::new(1.0, 0.0)]);
}

#[test]
fn decimation_passes_low_and_rejects_aliasing_frequencies() {
    let dt = 0.005; // 200 Hz, decimate by 4 → 50 Hz, new Nyquist 25 Hz
    let n = 8000;
    let tone = |f: f64| {
        (0..n)
            .map(|i| (std::f64::consts::TAU * f * i as f64 * dt).sin())
            .collect::<Vec<f64>>()
    };
    let taps = antialias_taps(4);
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
    // Pass band (5 Hz): amplitude kept within 0.1 % away from the edges.
    let low = decimate(&tone(5.0), 4, &taps);
    let gain = rms(&low[100..1900]) / std::f64::consts::FRAC_1_SQRT_2;
    assert!((gain - 1.0).abs() < 1e-3, "pass-band gain {gain}");
    // 40 Hz would alias to 10 Hz: must be attenuated below −60 dB.
    let high = decimate(&tone(40.0), 4, &taps);
    assert!(rms(&high[100..1900]) < 1e-3 * std::f64::consts::FRAC_1_SQRT_2);
    let (out, dt2, steps) = apply(
        &[tone(5.0)],
        dt,
        &Preprocessing {
            remove_mean: true,
            decimation: Some(4),
        },
    );
    assert_eq!(out[0].len(), 2000);
    assert!((dt2 - 0.02).abs() < 1e-15);
    assert_eq!(steps.len(), 2);
}

#[test]
fn sine_shows_as_first_singular_value_peak_and_white_noise_level_is_right() {
    let dt = 0.01;
    let n = 20_000;
    let mut rng = Rng::new(11);
    let a: Vec<f64> = (0..n)
        .map(|i| (std::f64::consts::TAU * 7.0 * i as f64 * dt).sin() + 0.1 * rng.normal())
        .collect();
    let b: Vec<f64> = (0..n)
        .map(|i| 0.5 * (std::f64::consts::TAU * 7.0 * i as f64 * dt).sin() + 0.1 * rng.normal())
        .collect();
    let o = spectral_overlay(&[a, b], dt, 1000).unwrap();
    let peak = (0..o.frequencies_hz.len())
        .max_by(|&x, &y| o.singular_values[x][0].total_cmp(&o.singular_values[y][0]))
        .unwrap();
    assert!((o.frequencies_hz[peak] - 7.0).abs() < 0.11);
    // Away from the sine, the mean of the two singular values (half the trace)
    // equals the one-sided white-noise density 2σ²Δt = 2e-4; averaged over 200 bins.
    let mean_level: f64 = (200..400)
        .map(|k| 0.5 * (o.singular_values[k][0] + o.singular_values[k][1]))
        .sum::<f64>()
        / 200.0;
    assert!((mean_level / 2e-4 - 1.0).abs() < 0.05, "{mean_level}");
    assert!(o.singular_values[peak][0] > 1e3 * o.singular_values[peak][1]);
}

// Direction labels of mode shapes (moved from src/modal/direction.rs).
mod direction_labels {
    use faer::c64;
    use quaketwin::modal::direction::{label, VERTICAL};

    fn s(v: &[&str]) -> Vec<String> {
        v.iter().map(|x| x.to_string()).collect()
    }
    fn real(v: &[f64]) -> Vec<c64> {
        v.iter().map(|&x| c64::new(x, 0.0)).collect()
    }

    #[test]
    fn translation_torsion_vertical_and_mixed() {
        // Two floors, each with Y sensors at two corners and one X sensor.
        let dirs = s(&["Y", "Y", "X", "Y", "Y", "X"]);
        let groups = s(&["1", "1", "1", "2", "2", "2"]);
        let y = real(&[0.5, 0.45, 0.02, 1.0, 0.9, 0.05]);
        assert_eq!(label(&y, &dirs, &groups), "Y");
        let torsion = real(&[0.5, -0.45, 0.1, 1.0, -0.9, 0.2]);
        assert_eq!(label(&torsion, &dirs, &groups), "torsion");
        // A second bending mode changes sign between floors, not within one.
        let second = real(&[1.0, 0.95, 0.0, -0.6, -0.55, 0.0]);
        assert_eq!(label(&second, &dirs, &groups), "Y");
        let mixed = real(&[0.5, 0.5, 0.8, 0.6, 0.6, 1.0]);
        assert_eq!(label(&mixed, &dirs, &groups), "mixed");
        let dirs_v = s(&["Y", VERTICAL, VERTICAL]);
        assert_eq!(label(&real(&[0.1, 1.0, 0.8]), &dirs_v, &[]), VERTICAL);
        // Unknown directions give an empty label.
        assert_eq!(label(&real(&[1.0, 0.5]), &[], &[]), "");
    }
}

/// The plan's horizon rule rests on the lowest clear spectral peak: two
/// sines in noise (1.0 Hz at half the amplitude of 3.0 Hz) give the lower
/// one; a 1.0 Hz sine at 2 % of the power of the 3 Hz one (below the 10 %
/// bar) is not a clear peak, so the 3 Hz one is the lowest; no peak in a
/// band holding only noise-free silence.
#[test]
fn lowest_spectral_peak_is_the_lowest_clear_one() {
    use quaketwin::modal::spectrum::lowest_spectral_peak_hz;
    let dt = 0.01;
    let mut rng = Rng::new(5);
    let signal = |a1: f64, rng: &mut Rng| -> Vec<f64> {
        let clean: Vec<f64> = (0..30_000)
            .map(|k| {
                let t = k as f64 * dt;
                a1 * (std::f64::consts::TAU * 1.0 * t).sin()
                    + (std::f64::consts::TAU * 3.0 * t + 0.3).sin()
            })
            .collect();
        add_measurement_noise(&clean, 20.0, rng)
    };
    let both = vec![signal(0.5, &mut rng), signal(0.5, &mut rng)];
    let f = lowest_spectral_peak_hz(&both, dt, 1000, [0.2, 20.0]).unwrap();
    assert!((f - 1.0).abs() <= 0.1, "{f}");
    let weak = vec![signal(0.14, &mut rng)];
    let f = lowest_spectral_peak_hz(&weak, dt, 1000, [0.2, 20.0]).unwrap();
    assert!((f - 3.0).abs() <= 0.1, "{f}");
    let silent = vec![vec![0.0; 30_000]];
    assert_eq!(
        lowest_spectral_peak_hz(&silent, dt, 1000, [0.2, 20.0]),
        None
    );
}

/// A split column (docs/modal.md, "Automatic selection"; `rejoin_twin` in
/// src/modal/selection.rs): the 13.51 Hz mode's column (orders 8–52 at
/// 13.50 Hz) is sent by the greedy linking onto a neighbour that drifts away
/// at orders 54–64 (13.48 → 13.15 Hz), while the mode's own poles at those
/// orders (13.51–13.535 Hz) continue the column of a spurious pole coming
/// down from 14.3 Hz, which is then the twin.  The pattern of the synthetic
/// archive's windows 2026-01-02T16:00 and 2026-01-03T00:00 (mode Y4 off by
/// −0.373 %, Y3 by −0.615 % before the rule).  One mode, its estimate from
/// the mode's poles (within 0.1 % of 13.51 Hz; the drifting tail gave
/// 13.43 Hz, −0.6 %), the twin reported.
#[test]
fn a_split_column_is_rejoined_with_its_twin() {
    use quaketwin::modal::selection::select_automatic;
    use quaketwin::modal::{PhysicalFilters, Pole, SelectionSettings};
    let shape: Vec<c64> = [1.0, 0.8, 0.5, 0.2]
        .iter()
        .map(|&v| c64::new(v, 0.0))
        .collect();
    let pole = |order: usize, f: f64, zeta: f64| Pole {
        order,
        frequency_hz: f,
        damping_ratio: zeta,
        shape: shape.clone(),
        mpc: 1.0,
        mpd_deg: 0.0,
        stable_frequency: true,
        stable_damping: true,
        stable_shape: true,
        physical: true,
        mode: None,
    };
    let orders: Vec<usize> = (2..=64).step_by(2).collect();
    let mut poles = Vec::new();
    for &n in &orders {
        if (8..=52).contains(&n) {
            poles.push(pole(n, 13.50, 0.03));
        }
    }
    let early_twin = [
        14.30, 14.15, 14.02, 13.90, 13.80, 13.72, 13.66, 13.62, 13.60,
    ];
    for (k, f) in early_twin.iter().enumerate() {
        poles.push(pole(36 + 2 * k, *f, 0.03));
    }
    let drift = [13.48, 13.40, 13.38, 13.30, 13.23, 13.15];
    let mode = [13.535, 13.52, 13.522, 13.519, 13.517, 13.51];
    for k in 0..6 {
        poles.push(pole(
            54 + 2 * k,
            drift[k],
            if k == 0 { 0.026 } else { 0.018 },
        ));
        poles.push(pole(54 + 2 * k, mode[k], 0.03));
    }
    poles.sort_by(|a, b| {
        (a.order, a.frequency_hz)
            .partial_cmp(&(b.order, b.frequency_hz))
            .unwrap()
    });
    let s = select_automatic(
        &mut poles,
        &orders,
        &PhysicalFilters::default(),
        50.0,
        &SelectionSettings::default(),
    );
    assert_eq!(s.modes.len(), 1, "{:?}", s.modes);
    let f = s.modes[0].frequency_hz;
    assert!(((f - 13.51) / 13.51).abs() < 0.001, "{f}");
    assert!(
        s.rejected.iter().any(|r| r.reason.contains("twin of the")),
        "{:?}",
        s.rejected
    );
    // The poles behind the estimate are the mode's: none of the drift.
    assert!(poles
        .iter()
        .filter(|p| p.mode == Some(0))
        .all(|p| (p.frequency_hz - 13.51).abs() < 0.05));
}

/// Issue 31 item 3: a weakly excited mode whose column is shorter than the
/// 12-pole rule (the 7-storey building's 8-pole torsion) is promoted when
/// its shapes are coherent (MAC ≥ 0.995) at every order from its first, and
/// flagged as promoted (the modal identification keeps it only for a
/// torsion); the same column with wandering shapes is rejected.
#[test]
fn a_short_coherent_column_is_promoted_and_flagged() {
    use quaketwin::modal::selection::select_automatic;
    use quaketwin::modal::{PhysicalFilters, Pole, SelectionSettings};
    let pole = |order: usize, f: f64, shape: &[f64]| Pole {
        order,
        frequency_hz: f,
        damping_ratio: 0.02,
        shape: shape.iter().map(|&v| c64::new(v, 0.0)).collect(),
        mpc: 1.0,
        mpd_deg: 0.0,
        stable_frequency: true,
        stable_damping: true,
        stable_shape: true,
        physical: true,
        mode: None,
    };
    let orders: Vec<usize> = (2..=42).step_by(2).collect();
    let run = |wander: f64| {
        let mut poles = Vec::new();
        for &n in &orders {
            // The fundamental: a pole at every order from 4.
            if n >= 4 {
                poles.push(pole(n, 1.04, &[1.0, 0.6, 0.9, 0.55]));
            }
            // The torsion: 8 poles, the top 8 orders, opposite ends in
            // opposite phase; `wander` drifts its shape order by order
            // (consecutive poles still link, MAC ≥ 0.99).
            if n >= 28 {
                let k = (n - 28) as f64 / 2.0;
                let d = wander * (k - 3.5);
                poles.push(pole(
                    n,
                    1.60 + 0.0005 * k,
                    &[1.0, 0.5 + d, -0.9, -0.45 + 0.5 * d],
                ));
            }
        }
        poles.sort_by(|a, b| {
            (a.order, a.frequency_hz)
                .partial_cmp(&(b.order, b.frequency_hz))
                .unwrap()
        });
        select_automatic(
            &mut poles,
            &orders,
            &PhysicalFilters::default(),
            50.0,
            &SelectionSettings::default(),
        )
    };
    let coherent = run(0.0);
    let fs: Vec<f64> = coherent.modes.iter().map(|m| m.frequency_hz).collect();
    assert_eq!(fs.len(), 2, "{fs:?}");
    assert!((fs[1] - 1.60).abs() < 0.01, "{fs:?}");
    assert_eq!(coherent.promoted, vec![false, true]);
    // Shapes that drift (consecutive MAC ≥ 0.998, mean MAC with the
    // column's mean shape 0.990 < 0.995): not promoted.
    let wandering = run(0.06);
    assert_eq!(wandering.modes.len(), 1, "{:?}", wandering.modes);
    assert!(wandering
        .rejected
        .iter()
        .any(|r| (r.frequency_hz - 1.60).abs() < 0.01 && r.reason.contains("only 8 poles")));
}
