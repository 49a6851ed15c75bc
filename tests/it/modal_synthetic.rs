//! Issue 13 "Must show", synthetic part: the 5-storey shear building over
//! seeds with DEFAULT settings (only the method chosen), 20 dB noise.
//! Figures are printed (run with `--nocapture`).

use crate::modal::{
    ambient_input_seeded, earthquake_base_motion, earthquake_input_with_noise, five_storey,
};
use quaketwin::modal::{identify, Method, ModalInput, ModalSettings, Mode};
use quaketwin::synth::{BuildingModes, ShearBuilding};

/// Signed errors of one identification against the truth: per truth mode,
/// `(Δf/f, Δζ)` of the identified mode nearest in frequency (each used
/// once), `None` when no identified mode lies within 10 %.
fn errors_against_truth(truth: &BuildingModes, modes: &[Mode]) -> Vec<Option<(f64, f64)>> {
    let mut used = vec![false; modes.len()];
    truth
        .frequencies_hz
        .iter()
        .zip(&truth.damping_ratios)
        .map(|(&f, &z)| {
            let best = (0..modes.len()).filter(|&i| !used[i]).min_by(|&a, &b| {
                (modes[a].frequency_hz - f)
                    .abs()
                    .total_cmp(&(modes[b].frequency_hz - f).abs())
            })?;
            let df = modes[best].frequency_hz / f - 1.0;
            (df.abs() < 0.1).then(|| {
                used[best] = true;
                (df, modes[best].damping_ratio - z)
            })
        })
        .collect()
}

/// Per-mode spread over seeds of one method on one kind of record.
struct Spread {
    /// `errors[seed][mode]`.
    errors: Vec<Vec<Option<(f64, f64)>>>,
    /// Number of modes selected per seed.
    counts: Vec<usize>,
}

fn run_seeds(seeds: &[u64], method: Method, input: impl Fn(u64) -> ModalInput) -> Spread {
    let truth = five_storey().modes().unwrap();
    let settings = ModalSettings {
        method,
        ..Default::default()
    };
    let mut spread = Spread {
        errors: Vec::new(),
        counts: Vec::new(),
    };
    for &seed in seeds {
        let result = identify(&input(seed), &settings).unwrap();
        let errors = errors_against_truth(&truth, &result.modes);
        eprintln!(
            "  {} seed {seed:2}: {} modes; Δf/f, Δζ per mode: {}",
            method.name(),
            result.modes.len(),
            errors
                .iter()
                .map(|e| e.map_or("missed".into(), |(f, z)| format!("{f:+.1e} {z:+.4}")))
                .collect::<Vec<_>>()
                .join(" | ")
        );
        spread.counts.push(result.modes.len());
        spread.errors.push(errors);
    }
    spread
}

fn mean_std(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let s = if v.len() > 1 {
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    } else {
        0.0
    };
    (m, s)
}

/// Worst |Δf/f| and |Δζ| per mode (infinite when a mode was missed), after
/// printing the table: mean, std and worst per mode, and `bound[j]` (a
/// reference scatter of Δf/f, printed when given).
fn report(title: &str, seeds: &[u64], spread: &Spread, bound: Option<&[f64]>) -> Vec<(f64, f64)> {
    let truth = five_storey().modes().unwrap();
    eprintln!(
        "{title}: seeds {seeds:?}, modes selected per seed {:?}",
        spread.counts
    );
    eprintln!("mode  f_true  ζ_true | found | Δf/f mean   std      worst   | Δζ mean    std     worst  | bound σ(Δf/f)");
    let mut worst = Vec::new();
    for j in 0..truth.frequencies_hz.len() {
        let found: Vec<(f64, f64)> = spread.errors.iter().filter_map(|e| e[j]).collect();
        let df: Vec<f64> = found.iter().map(|e| e.0).collect();
        let dz: Vec<f64> = found.iter().map(|e| e.1).collect();
        let (mf, sf) = mean_std(&df);
        let (mz, sz) = mean_std(&dz);
        let complete = found.len() == seeds.len();
        let wf = if complete {
            df.iter().fold(0.0f64, |a, x| a.max(x.abs()))
        } else {
            f64::INFINITY
        };
        let wz = if complete {
            dz.iter().fold(0.0f64, |a, x| a.max(x.abs()))
        } else {
            f64::INFINITY
        };
        eprintln!(
            "{}  {:6.3}  {:.3}  | {:2}/{} | {mf:+.2e} {sf:.2e} {wf:.2e} | {mz:+.5} {sz:.5} {wz:.5} | {}",
            j + 1,
            truth.frequencies_hz[j],
            truth.damping_ratios[j],
            found.len(),
            seeds.len(),
            bound.map_or(String::from("-"), |b| format!("{:.2e}", b[j])),
        );
        worst.push((wf, wz));
    }
    worst
}

/// Asymptotic Cramér–Rao bound of the relative frequency scatter of one mode
/// observed without noise for `duration_s` under white-noise forcing:
/// the oscillator q̈ + a₁q̇ + a₀q = w (a₁ = 2ζω, a₀ = ω²) has Fisher
/// information per unit time E[[q̇², qq̇], [qq̇, q²]]/σ_w² = diag(1/(2a₁),
/// 1/(2a₀a₁)), so T·var(â₀) → 2a₀a₁ and var(ω̂)/ω² = var(â₀)/(4a₀²) =
/// ζ/(ωT).  Measurement noise and the other modes only add scatter, so no
/// estimator on these records can do much better than this.
fn single_mode_frequency_bound(truth: &BuildingModes, duration_s: f64) -> Vec<f64> {
    truth
        .circular_frequencies
        .iter()
        .zip(&truth.damping_ratios)
        .map(|(w, z)| (z / (w * duration_s)).sqrt())
        .collect()
}

/// Cramér–Rao lower bound of the relative frequency scatter σ(ω̂_j)/ω_j of
/// each mode of the earthquake case `seed` at `snr_db`.  Output-error model:
/// floor c records y_c = a_g + Σ_j φ_cj Γ_j r_j(t; ω_j, ζ_j) + n_c, with r_j the
/// relative acceleration of a unit-mass oscillator (ω_j, ζ_j) under a_g and
/// n_c white, σ_c = rms(y_c)·10^(−snr/20) (as `add_measurement_noise`).  The
/// base motion is taken as exactly known and every parameter but (ω_j, ζ_j)
/// as known: each simplification can only lower the bound.  Fisher
/// information of Gaussian noise I = Σ_c Σ_t ∇y_c ∇y_cᵀ / σ_c² with
/// ∇ = ∂/∂(ω_j, ζ_j) by central differences; var(ω̂_j) ≥ (I⁻¹)_ωω.
fn io_frequency_bound(seed: u64, snr_db: f64) -> Vec<f64> {
    let building = five_storey();
    let truth = building.modes().unwrap();
    let (ag, dt) = earthquake_base_motion(seed);
    let response = building.simulate_base_motion(&ag, dt).unwrap();
    let sigma2: Vec<f64> = response
        .absolute_acceleration
        .iter()
        .map(|y| y.iter().map(|v| v * v).sum::<f64>() / y.len() as f64 / 10f64.powf(snr_db / 10.0))
        .collect();
    // Relative acceleration of the unit-mass oscillator (k = ω²).
    let relative = |omega: f64, zeta: f64| -> Vec<f64> {
        let sdof = ShearBuilding {
            masses_kg: vec![1.0],
            storey_stiffness_n_per_m: vec![omega * omega],
            damping_ratios: vec![zeta],
        };
        let r = sdof.simulate_base_motion(&ag, dt).unwrap();
        r.absolute_acceleration[0]
            .iter()
            .zip(&ag)
            .map(|(a, g)| a - g)
            .collect()
    };
    (0..truth.frequencies_hz.len())
        .map(|j| {
            let (w, z) = (truth.circular_frequencies[j], truth.damping_ratios[j]);
            let (hw, hz) = (1e-5 * w, 1e-5 * z);
            let diff = |a: Vec<f64>, b: Vec<f64>, h: f64| -> Vec<f64> {
                a.iter().zip(&b).map(|(x, y)| (x - y) / (2.0 * h)).collect()
            };
            let dw = diff(relative(w + hw, z), relative(w - hw, z), hw);
            let dz = diff(relative(w, z + hz), relative(w, z - hz), hz);
            let (mut iww, mut iwz, mut izz) = (0.0, 0.0, 0.0);
            for (c, s2) in sigma2.iter().enumerate() {
                let g2 = (truth.shapes[j][c] * truth.participation[j]).powi(2) / s2;
                iww += g2 * dw.iter().map(|v| v * v).sum::<f64>();
                iwz += g2 * dw.iter().zip(&dz).map(|(a, b)| a * b).sum::<f64>();
                izz += g2 * dz.iter().map(|v| v * v).sum::<f64>();
            }
            let var_w = izz / (iww * izz - iwz * iwz);
            var_w.sqrt() / w
        })
        .collect()
}

/// P(|Z| ≤ x) for a standard normal Z: erf(x/√2), Abramowitz & Stegun 7.1.26
/// (absolute error < 1.5e-7).
fn normal_within(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.3275911 * x / std::f64::consts::SQRT_2);
    let poly = t
        * (0.254829592
            + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))));
    1.0 - poly * (-(x * x) / 2.0).exp()
}

const STUDY_SEEDS: [u64; 10] = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10];

/// Probability that an unbiased estimator whose errors are normal with the
/// standard deviations `sigma[seed][mode]` keeps every |Δf/f| within `tol`.
fn chance_all_within(sigma: &[Vec<f64>], tol: f64) -> f64 {
    sigma
        .iter()
        .flatten()
        .map(|s| normal_within(tol / s))
        .product()
}

/// Root mean square over seeds of `sigma[seed][mode]`, per mode.
fn rms_over_seeds(sigma: &[Vec<f64>]) -> Vec<f64> {
    (0..sigma[0].len())
        .map(|j| (sigma.iter().map(|s| s[j] * s[j]).sum::<f64>() / sigma.len() as f64).sqrt())
        .collect()
}

/// The issue-13 criterion over 10 seeds (the Must-show study):
/// earthquake with the base as input, `io`: |Δf/f| ≤ 1e-3 and |Δζ| ≤ 0.005
/// for all five modes; ambient 600 s, `ssi-cov`: |Δf/f| ≤ 2e-3 (and
/// |Δζ| ≤ 0.005).  Default settings (only the method chosen), 20 dB noise on
/// every channel.  The table gives per mode the mean, standard deviation and
/// worst error over the seeds and a lower bound of the frequency scatter
/// (io: [`io_frequency_bound`], rms over the seeds; ssi-cov:
/// [`single_mode_frequency_bound`]), and the chance that an unbiased
/// estimator AT that bound meets the criterion on all 10 seeds.
///
/// Fails at present (issue 13, measured on the seeds 1–10): io misses the
/// 12.4 Hz mode on seed 10 and exceeds 1e-3 on modes 3–5; ssi-cov exceeds
/// 2e-3 on modes 2–5 — see the printed table.
///
/// Run: `cargo test --release --test it modal_synthetic::ten_seed_study -- --ignored --nocapture`
#[test]
#[ignore]
fn ten_seed_study_five_storey_default_settings() {
    let truth = five_storey().modes().unwrap();
    let quake = run_seeds(&STUDY_SEEDS, Method::Io, |s| {
        earthquake_input_with_noise(s, 20.0)
    });
    let quake_sigma: Vec<Vec<f64>> = STUDY_SEEDS
        .iter()
        .map(|&s| io_frequency_bound(s, 20.0))
        .collect();
    let quake_worst = report(
        "earthquake 40 s, 200 Hz, io, 20 dB",
        &STUDY_SEEDS,
        &quake,
        Some(&rms_over_seeds(&quake_sigma)),
    );
    eprintln!(
        "chance that an unbiased estimator at the bound keeps all five modes within 1e-3 on the 10 seeds: {:.3}",
        chance_all_within(&quake_sigma, 1e-3)
    );
    let ambient = run_seeds(&STUDY_SEEDS, Method::SsiCov, ambient_input_seeded);
    let bound = single_mode_frequency_bound(&truth, 600.0);
    let ambient_worst = report(
        "ambient 600 s, 100 Hz, ssi-cov, 20 dB",
        &STUDY_SEEDS,
        &ambient,
        Some(&bound),
    );
    eprintln!(
        "chance that an unbiased estimator at the bound keeps all five modes within 2e-3 on the 10 seeds: {:.3}",
        chance_all_within(&vec![bound; STUDY_SEEDS.len()], 2e-3)
    );
    let mut failures = Vec::new();
    for (kind, worst, tol_f) in [
        ("io", &quake_worst, 1e-3),
        ("ssi-cov", &ambient_worst, 2e-3),
    ] {
        for (j, &(wf, wz)) in worst.iter().enumerate() {
            if !(wf <= tol_f && wz <= 0.005) {
                failures.push(format!(
                    "{kind} mode {}: worst |Δf/f| {wf:.2e} (≤ {tol_f:.0e}), worst |Δζ| {wz:.4} (≤ 0.005)",
                    j + 1
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The first three seeds of the study, both cases, default settings, 20 dB:
/// every one of the five modes is selected (nothing else: exactly five),
/// within 1 % in frequency (the mode is found, not mistaken for another:
/// the closest two, 10.6 and 12.4 Hz, are 17 % apart) and within the 0.005 in damping.
/// The frequency criterion (1e-3 io, 2e-3 ssi-cov) is asserted by
/// the ignored study above, which fails at present.
#[test]
fn five_storey_default_settings_find_the_five_modes_on_three_seeds() {
    let seeds = &STUDY_SEEDS[..3];
    let quake = run_seeds(seeds, Method::Io, |s| earthquake_input_with_noise(s, 20.0));
    let ambient = run_seeds(seeds, Method::SsiCov, ambient_input_seeded);
    for (kind, spread) in [("io", &quake), ("ssi-cov", &ambient)] {
        assert_eq!(
            spread.counts,
            vec![5; seeds.len()],
            "{kind}: modes selected per seed"
        );
        for (seed, errors) in seeds.iter().zip(&spread.errors) {
            for (j, e) in errors.iter().enumerate() {
                let (df, dz) =
                    e.unwrap_or_else(|| panic!("{kind} seed {seed}: mode {} missed", j + 1));
                assert!(
                    df.abs() <= 0.01 && dz.abs() <= 0.005,
                    "{kind} seed {seed} mode {}: Δf/f {df:.2e}, Δζ {dz:.4}",
                    j + 1
                );
            }
        }
    }
}

// ------------------------------------------------------- weakly excited torsion

use quaketwin::modal::{identify_event, ChannelChoice, ModalResult};
use quaketwin::rng::Rng;
use quaketwin::synth::{
    add_measurement_noise, synthetic_ground_motion, GroundMotionSpec, PlanBuilding, PlanModes,
    PlanResponse, Sensor,
};
use quaketwin::vocab::{Axis, Event};

/// Five storeys of 30 m × 20 m in plan: uniform floors of 600 t with the
/// polar inertia of a uniform slab, J = m (30² + 20²)/12; storey
/// stiffnesses giving ≈ 1.0 Hz along X, 1.25 Hz along Y and 1.6 Hz in
/// torsion (the proportions of the 7-storey building of issue 13); the
/// centre of mass 5 % of the plan dimensions off the centre of stiffness
/// (e = (1.5, 1.0) m, the accidental eccentricity of Eurocode 8); 2 %
/// damping in every mode.
fn eccentric_building() -> PlanBuilding {
    let n = 5;
    let m = 6.0e5;
    PlanBuilding {
        masses_kg: vec![m; n],
        rotational_inertia_kg_m2: vec![m * (30.0f64.powi(2) + 20.0f64.powi(2)) / 12.0; n],
        mass_eccentricity_m: [1.5, 1.0],
        storey_stiffness_x_n_per_m: vec![2.92e8; n],
        storey_stiffness_y_n_per_m: vec![4.57e8; n],
        storey_torsional_stiffness_n_m_per_rad: vec![8.1e10; n],
        damping_ratios: vec![0.02],
    }
}

/// Two opposite corners of floors 3 and 5 (roof), X and Y at each (8
/// outputs); X and Y at the base centre (inputs).
fn corner_sensors() -> Vec<Sensor> {
    let mut sensors = Vec::new();
    for (axis, name) in [(Axis::X, "X"), (Axis::Y, "Y")] {
        sensors.push(Sensor {
            id: format!("B-{name}"),
            level: 0,
            position_m: [0.0, 0.0],
            axis,
        });
    }
    for level in [3, 5] {
        for (corner, position_m) in [("SW", [-15.0, -10.0]), ("NE", [15.0, 10.0])] {
            for (axis, name) in [(Axis::X, "X"), (Axis::Y, "Y")] {
                sensors.push(Sensor {
                    id: format!("L{level}-{corner}-{name}"),
                    level,
                    position_m,
                    axis,
                });
            }
        }
    }
    sensors
}

/// The event the sensors record, with `snr_db` of noise on every channel;
/// without the base sensors when `base` is false (ambient: no base motion).
fn plan_event(response: &PlanResponse, base: bool, snr_db: f64, seed: u64) -> Event {
    let mut rng = Rng::new(seed);
    let sensors: Vec<Sensor> = corner_sensors()
        .into_iter()
        .filter(|s| base || s.level > 0)
        .collect();
    let mut records = response.to_records(&sensors).unwrap();
    for r in records.iter_mut() {
        r.samples = add_measurement_noise(&r.samples, snr_db, &mut rng).into();
    }
    Event {
        name: "eccentric-5storey".into(),
        records,
        ..Default::default()
    }
}

/// The truth (first) torsional mode: the lowest mode with most of its
/// kinetic energy in floor rotation: (frequency, damping ratio).
fn torsional_mode(truth: &PlanModes) -> (f64, f64) {
    let j = (0..truth.rotation_share.len())
        .find(|&j| truth.rotation_share[j] > 0.5)
        .expect("the building has a torsional mode");
    (truth.modes.frequencies_hz[j], truth.modes.damping_ratios[j])
}

fn print_result(kind: &str, truth: &PlanModes, result: &ModalResult) {
    let t: Vec<String> = (0..truth.modes.frequencies_hz.len())
        .map(|j| {
            format!(
                "{:.3} Hz ({:.0} % rot.)",
                truth.modes.frequencies_hz[j],
                100.0 * truth.rotation_share[j]
            )
        })
        .collect();
    eprintln!("{kind}: truth {}", t.join(", "));
    eprintln!(
        "{kind}: block rows {}, decimation {}, orders ≤ {:?}",
        result.block_rows,
        result.decimation,
        result.orders.last()
    );
    for m in &result.modes {
        eprintln!(
            "  mode {:.4} Hz ζ {:.4} {:8} orders {}–{} poles {} MPC {:.3}",
            m.frequency_hz,
            m.damping_ratio,
            m.direction,
            m.order_min,
            m.order_max,
            m.pole_count,
            m.mpc
        );
    }
    for c in &result.rejected {
        eprintln!(
            "  rejected {:.4} Hz ζ {:.4} orders {}–{} poles {}: {}",
            c.frequency_hz, c.damping_ratio, c.order_min, c.order_max, c.poles, c.reason
        );
    }
    for w in &result.warnings {
        eprintln!("  warning: {w}");
    }
}

/// Identifies `event` with default settings but the method, prints the
/// result and asserts that a selected mode is labelled torsion within 1 % of
/// the truth torsional frequency (the nearest other modes, X₁ and Y₁, are
/// more than 20 % away) and within the 0.005 of its damping ratio.
fn identify_torsion(kind: &str, method: Method, truth: &PlanModes, event: &Event) {
    let settings = ModalSettings {
        method,
        ..Default::default()
    };
    let result = identify_event(event, &settings, &ChannelChoice::default()).unwrap();
    print_result(kind, truth, &result);
    let (f, zeta) = torsional_mode(truth);
    let found = result
        .modes
        .iter()
        .find(|m| (m.frequency_hz / f - 1.0).abs() <= 0.01);
    let m = found.unwrap_or_else(|| {
        panic!(
            "{kind}: no mode within 1 % of the torsion at {f:.4} Hz; rejected columns {:?}; warnings {:?}",
            result
                .rejected
                .iter()
                .map(|c| (c.frequency_hz, c.poles, c.reason.clone()))
                .collect::<Vec<_>>(),
            result.warnings
        )
    });
    assert_eq!(
        m.direction, "torsion",
        "{kind}: the {:.4} Hz mode is labelled {:?}",
        m.frequency_hz, m.direction
    );
    assert!(
        (m.damping_ratio - zeta).abs() <= 0.005,
        "{kind}: torsion ζ {:.4} for {zeta}",
        m.damping_ratio
    );
}

/// Ambient vibration, 600 s at 100 Hz, white-noise forces along X and Y at
/// every floor's centre of mass and no torque (the torsion is excited only
/// through the eccentricity), 20 dB noise; `ssi-cov` with default settings.
///
/// Failed before the plan's horizon rule (issue 13): the block rows were
/// 18 (the cost bound 150 / 8 outputs), a horizon of 0.18 s against the
/// 1.0 s fundamental period, and the orders stopped at 42 while the torsion
/// column only starts at order 36: X₁ and Y₁ gave no column and the torsion
/// (7 poles) was rejected for its length.  Now the block rows reach half a
/// period of the lowest spectral peak (50) and the orders go to 8 per output
/// (64): measured, 14 of the 15 modes of the building, the torsion at
/// 1.6330 Hz (truth 1.6282 Hz, ζ 1.56 % for 2 %), orders 48–64.
#[test]
fn weak_torsion_ambient_is_selected_and_labelled() {
    let building = eccentric_building();
    let truth = building.modes().unwrap();
    let mut rng = Rng::new(13);
    let response = building
        .simulate_ambient(60_000, 0.01, 1.0e4, 0.0, &mut rng)
        .unwrap();
    let event = plan_event(&response, false, 20.0, 14);
    identify_torsion("ambient ssi-cov", Method::SsiCov, &truth, &event);
}

/// Earthquake, 40 s at 200 Hz, independent base motions along X and Y
/// (the inputs), 20 dB noise; `io` with default settings.  (Measured: the
/// torsion at 1.6272 Hz for 1.628 Hz, labelled torsion; on five more seed
/// sets 1.6265–1.6309 Hz.)
#[test]
fn weak_torsion_earthquake_is_selected_and_labelled() {
    let building = eccentric_building();
    let truth = building.modes().unwrap();
    let spec = |seed| GroundMotionSpec {
        seed,
        ..Default::default()
    };
    let (gx, gy) = (
        synthetic_ground_motion(&spec(21)).unwrap(),
        synthetic_ground_motion(&spec(22)).unwrap(),
    );
    let response = building
        .simulate_base_motion(&gx, &gy, spec(21).dt())
        .unwrap();
    let event = plan_event(&response, true, 20.0, 23);
    identify_torsion("earthquake io", Method::Io, &truth, &event);
}
