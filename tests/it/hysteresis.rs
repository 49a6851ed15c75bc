//! Tests of the Bouc-Wen identification and damage index (METHODS.md §4).
//!
//! Synthetic truth: the forward model of `quaketwin::hysteresis::forward`
//! (RK4, 4 sub-steps per 1 ms sample) driven by a seeded synthetic ground
//! motion. Every parameter is stated where it is used. Run with
//! `--nocapture` to see the achieved accuracy figures.

use std::sync::OnceLock;

use quaketwin::hysteresis::basis::{cumulative_cubic, DofProblem};
use quaketwin::hysteresis::stft::{frame_products, FrameRepresentation, FrameTransformer};
use quaketwin::hysteresis::*;
use quaketwin::rng::SplitMix64;
use quaketwin::synth::{synthetic_ground_motion, GroundMotionSpec};
use quaketwin::vocab::ProcessingHistory;
use quaketwin::Error;

/// Ground motion of every identification test: `GroundMotionSpec::strong_50s`
/// = seed 7, 50 s at 1000 Hz, PGA 3.5 m/s², Kanai–Tajimi 2.5 Hz / ζ 0.6,
/// Clough–Penzien high-pass 0.3 Hz / 0.7, low-pass 25 Hz (4th order), envelope
/// rising quadratically to 3 s, flat to 15 s, then exp(−0.2 (t − 15)).
fn ground_spec() -> GroundMotionSpec {
    let spec = GroundMotionSpec::strong_50s(7, 1000.0, 3.5);
    assert_eq!(spec.duration_s, 50.0);
    assert_eq!(spec.ground_frequency_hz, 2.5);
    spec
}

/// 1-DoF: m = 1e5 kg, K0 = 4e7 N/m (f0 = 3.18 Hz), δ = 6e-7 1/J,
/// β = 0.05, γ = 0.025 (N^(1−N)/m), N = 1.6 → yield shear (K0/(β+γ))^(1/N) ≈ 2.8e5 N,
/// ductility ≈ 7 under the ground motion above.
fn one_dof_chain() -> BoucWenChain {
    BoucWenChain::shear(
        vec![1e5],
        &[4e7],
        &[vec![6e-7]],
        vec![0.05],
        vec![0.025],
        vec![1.6],
    )
    .unwrap()
}

/// 2-DoF shear chain: m = [1e5, 1e5] kg, storey stiffness [6e7, 4e7] N/m
/// (K0 = [[1e8, −4e7], [−4e7, 4e7]], modes 2.25 and 5.51 Hz),
/// δ11 = 4e-7, δ21 = −1e-6 (δ12 = +1e-6), δ22 = 4e-7 1/J,
/// β = [0.4, 2e-5], γ = [0.2, 1e-5], N = [1.4, 2.2].
pub(crate) fn two_dof_chain() -> BoucWenChain {
    BoucWenChain::shear(
        vec![1e5, 1e5],
        &[6e7, 4e7],
        &[vec![4e-7], vec![-1e-6, 4e-7]],
        vec![0.4, 2e-5],
        vec![0.2, 1e-5],
        vec![1.4, 2.2],
    )
    .unwrap()
}

struct Synthetic {
    chain: BoucWenChain,
    /// Base acceleration at 1000 Hz.
    ground: Vec<f64>,
    /// Response at 1000 Hz.
    response: ChainResponse,
}

impl Synthetic {
    fn new(chain: BoucWenChain) -> Self {
        let ground = synthetic_ground_motion(&ground_spec()).unwrap();
        let response = chain.simulate(&ground, 1000.0, 4).unwrap();
        Synthetic {
            chain,
            ground,
            response,
        }
    }
    /// Records point-sampled every `step` ms (step 4 → 250 Hz).
    fn records(&self, step: usize) -> (DirectionRecords, ChainResponse) {
        let response = self.response.subsample(step);
        let base: Vec<f64> = self.ground.iter().step_by(step).copied().collect();
        let records = DirectionRecords {
            direction: "X".into(),
            source: "synthetic-event".into(),
            sampling_rate_hz: response.sampling_rate_hz,
            base: Some(BaseRecord {
                channel: "base-X".into(),
                acceleration: base,
            }),
            floors: (0..self.chain.dofs())
                .map(|d| FloorRecord {
                    channel: format!("floor{}-X", d + 1),
                    absolute_acceleration: response.absolute_acceleration[d].clone(),
                    mass_kg: Some(self.chain.masses[d]),
                    relative_velocity: None,
                    relative_displacement: None,
                })
                .collect(),
            declared_processing: ProcessingHistory::default(),
        };
        (records, response)
    }
}

fn one_dof() -> &'static Synthetic {
    static CELL: OnceLock<Synthetic> = OnceLock::new();
    CELL.get_or_init(|| Synthetic::new(one_dof_chain()))
}

fn two_dof() -> &'static Synthetic {
    static CELL: OnceLock<Synthetic> = OnceLock::new();
    CELL.get_or_init(|| Synthetic::new(two_dof_chain()))
}

struct Tolerances {
    exponent_abs: f64,
    k0_rel: f64,
    /// None: not required (250 Hz, METHODS §4 known weakness).
    k0_delta_rel: Option<f64>,
    beta_gamma_rel: Option<f64>,
    iota_abs: f64,
}

const AT_1000_HZ: Tolerances = Tolerances {
    exponent_abs: 0.01,
    k0_rel: 0.01,
    k0_delta_rel: Some(0.05),
    beta_gamma_rel: Some(0.03),
    iota_abs: 0.001,
};
const AT_250_HZ: Tolerances = Tolerances {
    exponent_abs: 0.02,
    k0_rel: 0.04,
    k0_delta_rel: None,
    beta_gamma_rel: None,
    iota_abs: 0.005,
};

fn rel(a: f64, b: f64) -> f64 {
    (a / b - 1.0).abs()
}

/// Compares an identification with the chain's truth; prints the achieved figures.
fn check(
    label: &str,
    synthetic: &Synthetic,
    step: usize,
    settings: &IdentifySettings,
    tol: &Tolerances,
) -> DirectionIdentification {
    let chain = &synthetic.chain;
    let (records, response) = synthetic.records(step);
    let id = identify_direction(&records, settings).unwrap();
    let truth = damage_index_of_chain(chain, &response, 1).unwrap();
    let (iota_true, iota_id) = (truth.final_iota().unwrap(), id.damage.final_iota().unwrap());
    eprintln!(
        "[{label}] window {} frames {} | final ι true {iota_true:.5} identified {iota_id:.5}",
        id.window_len, id.frames
    );
    // "Yielding strongly, final ι a few percent."
    assert!(
        iota_true > 0.01 && iota_true < 0.1,
        "{label}: final ι {iota_true} is not a few percent"
    );
    assert!(
        (iota_id - iota_true).abs() <= tol.iota_abs,
        "{label}: final ι {iota_id} vs {iota_true}"
    );
    for (d, dof) in id.dofs.iter().enumerate() {
        let n_err = (dof.exponent - chain.exponent[d]).abs();
        let (b_err, g_err) = (rel(dof.beta, chain.beta[d]), rel(dof.gamma, chain.gamma[d]));
        eprintln!(
            "[{label}] DoF {}: N {:.3} (true {}, err {n_err:.3}) β err {:.2}% γ err {:.2}% J_rel {:.2e}",
            dof.dof,
            dof.exponent,
            chain.exponent[d],
            100.0 * b_err,
            100.0 * g_err,
            dof.cost_relative
        );
        assert!(
            n_err <= tol.exponent_abs,
            "{label}: N_{} = {} vs {}",
            d + 1,
            dof.exponent,
            chain.exponent[d]
        );
        if let Some(t) = tol.beta_gamma_rel {
            assert!(
                b_err <= t && g_err <= t,
                "{label}: β/γ of DoF {} off by {b_err}, {g_err}",
                d + 1
            );
        }
        for (i, &r1) in dof.coupled.iter().enumerate() {
            let r = r1 - 1;
            let (k_true, kd_true) = (chain.k0[d][r], chain.k0[d][r] * chain.delta[d][r]);
            let (k_err, kd_err) = (rel(dof.k0[i], k_true), rel(dof.k0_delta[i], kd_true));
            eprintln!(
                "[{label}]   K0_{}{} err {:.3}%  K0·δ err {:.2}%",
                d + 1,
                r1,
                100.0 * k_err,
                100.0 * kd_err
            );
            assert!(
                k_err <= tol.k0_rel,
                "{label}: K0_{}{} = {} vs {k_true}",
                d + 1,
                r1,
                dof.k0[i]
            );
            if let Some(t) = tol.k0_delta_rel {
                assert!(
                    kd_err <= t,
                    "{label}: K0δ_{}{} = {} vs {kd_true}",
                    d + 1,
                    r1,
                    dof.k0_delta[i]
                );
            }
        }
    }
    id
}

fn fast_settings(form: BasisForm) -> IdentifySettings {
    IdentifySettings {
        form,
        instantaneous: false,
        ..IdentifySettings::default()
    }
}

// ---------------------------------------------------------------- accuracy

#[test]
fn one_dof_1000hz_jerk_form_with_instantaneous_estimates() {
    let settings = IdentifySettings::default(); // jerk form, full band, N on [1, 10] at 0.001
    assert_eq!(settings.form, BasisForm::Jerk);
    let id = check("1-DoF 1000 Hz jerk", one_dof(), 1, &settings, &AT_1000_HZ);
    let dof = &id.dofs[0];
    // Instantaneous (cumulative) estimates end at the scalar estimate and are
    // stable once the response yields.
    let last = dof.instantaneous.last().unwrap();
    assert!(
        (last.exponent - dof.exponent).abs() <= 0.002,
        "last N(t) {} vs scalar {}",
        last.exponent,
        dof.exponent
    );
    assert!(rel(last.k0[0], dof.k0[0]) < 1e-3);
    let stability = dof.stability.as_ref().unwrap();
    eprintln!("[1-DoF 1000 Hz jerk] stability {stability:?}");
    assert!(stability.stable && stability.informative_frames > 10);
    assert!(
        stability.onset_s > 3.0 && stability.onset_s < 20.0,
        "onset {}",
        stability.onset_s
    );
    // The early (pre-yield) frames are flagged non-informative.
    assert!(!dof.instantaneous[0].informative);
    // Non-convex J(N): the coarse curve is reported on [1, 10].
    assert_eq!(dof.cost_curve.first().unwrap().0, 1.0);
    assert!((dof.cost_curve.last().unwrap().0 - 10.0).abs() < 1e-12);
}

#[test]
fn one_dof_1000hz_integral_form() {
    check(
        "1-DoF 1000 Hz integral",
        one_dof(),
        1,
        &fast_settings(BasisForm::Integral),
        &AT_1000_HZ,
    );
}

#[test]
fn two_dof_1000hz_jerk_form() {
    check(
        "2-DoF 1000 Hz jerk",
        two_dof(),
        1,
        &fast_settings(BasisForm::Jerk),
        &AT_1000_HZ,
    );
}

#[test]
fn two_dof_1000hz_integral_form() {
    check(
        "2-DoF 1000 Hz integral",
        two_dof(),
        1,
        &fast_settings(BasisForm::Integral),
        &AT_1000_HZ,
    );
}

#[test]
fn one_dof_250hz() {
    check(
        "1-DoF 250 Hz jerk",
        one_dof(),
        4,
        &fast_settings(BasisForm::Jerk),
        &AT_250_HZ,
    );
}

#[test]
fn two_dof_250hz_with_instantaneous_estimates() {
    let id = check(
        "2-DoF 250 Hz jerk",
        two_dof(),
        4,
        &IdentifySettings::default(),
        &AT_250_HZ,
    );
    // 12 500 samples → the thesis's window of 220 samples.
    assert_eq!((id.window_len, id.hop), (220, 110));
    for dof in &id.dofs {
        assert!(
            dof.stability.as_ref().is_some_and(|s| s.stable),
            "DoF {} unstable",
            dof.dof
        );
    }
}

/// The integral form over the full band does not meet the 250 Hz tolerance on
/// N (drift of the twice-integrated displacement, see `IdentifySettings::form`);
/// with the frequency integral of Eq. 20 starting above the two drift bins
/// (band [1.5 Hz, fs/2], Δf = 1.14 Hz) it does.
#[test]
fn two_dof_250hz_integral_form_above_drift_bins() {
    let settings = IdentifySettings {
        band: FrequencyBand::above(1.5),
        ..fast_settings(BasisForm::Integral)
    };
    check(
        "2-DoF 250 Hz integral band ≥ 1.5 Hz",
        two_dof(),
        4,
        &settings,
        &AT_250_HZ,
    );
}

/// The explicit FFT path gives the same identification as the Parseval path.
#[test]
fn fft_and_parseval_paths_agree_in_identification() {
    let (records, _) = one_dof().records(4);
    let parseval = identify_direction(&records, &fast_settings(BasisForm::Jerk)).unwrap();
    let fft = identify_direction(
        &records,
        &IdentifySettings {
            transform: Transform::Fft,
            ..fast_settings(BasisForm::Jerk)
        },
    )
    .unwrap();
    let (a, b) = (&parseval.dofs[0], &fft.dofs[0]);
    assert_eq!(a.exponent, b.exponent);
    assert!(
        rel(a.k0[0], b.k0[0]) < 1e-9 && rel(a.beta, b.beta) < 1e-7 && rel(a.cost, b.cost) < 1e-7
    );
}

// ---------------------------------------------------------------- STFT / Parseval

#[test]
fn window_length_makes_frames_match_bins() {
    let layout = StftLayout::for_record(12_500).unwrap();
    assert_eq!((layout.window_len, layout.hop), (220, 110)); // METHODS §4: w = 220 for 12 500 samples
                                                             // 112 full frames (+1 zero-padded frame covering the last 70 samples) vs 111 bins.
    assert_eq!(layout.frames(), 113);
    let w = hamming_symmetric(5);
    assert!(
        (w[0] - 0.08).abs() < 1e-15 && (w[2] - 1.0).abs() < 1e-15 && (w[4] - 0.08).abs() < 1e-15
    );
}

/// Full band: STFT-integrated products (Eq. 15, 20; trapezoid over the bins)
/// equal window-weighted time-domain sums; with a low cut, Parseval on the
/// remaining bins (projection) equals the FFT path.
#[test]
fn parseval_equivalence_of_stft_and_time_domain_products() {
    let fs = 250.0;
    let n = 3001;
    let mut rng = SplitMix64::new(3);
    let signals: Vec<Vec<f64>> = (0..3)
        .map(|s| {
            (0..n)
                .map(|k| {
                    (k as f64 * 0.01 * (s + 1) as f64).sin() + rng.next_gaussian() + 0.3 * s as f64
                })
                .collect()
        })
        .collect();
    let layout = StftLayout::for_record(n).unwrap();
    for band in [
        FrequencyBand::full(),
        FrequencyBand::above(1.5),
        FrequencyBand::above(10.0),
    ] {
        let time = FrameTransformer::new(&layout, Transform::Parseval, band, fs).unwrap();
        let fft = FrameTransformer::new(&layout, Transform::Fft, band, fs).unwrap();
        let reps_t: Vec<FrameRepresentation> = signals.iter().map(|s| time.represent(s)).collect();
        let reps_f: Vec<FrameRepresentation> = signals.iter().map(|s| fft.represent(s)).collect();
        let rt: Vec<&FrameRepresentation> = reps_t.iter().collect();
        let rf: Vec<&FrameRepresentation> = reps_f.iter().collect();
        let gt = frame_products(&rt, &rt, layout.frames());
        let gf = frame_products(&rf, &rf, layout.frames());
        let scale = gt.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let worst = gt
            .iter()
            .zip(&gf)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(
            worst <= 1e-11 * scale,
            "band {band:?}: max difference {worst} (scale {scale})"
        );
    }
    // Cumulative over all frames = Σ_n W[n] x_i x_k with the Parseval weights.
    let time =
        FrameTransformer::new(&layout, Transform::Parseval, FrequencyBand::full(), fs).unwrap();
    let (a, b) = (time.represent(&signals[0]), time.represent(&signals[1]));
    let total: f64 = frame_products(&[&a], &[&b], layout.frames()).iter().sum();
    let weights = layout.time_weights();
    let direct: f64 = (0..n)
        .map(|k| weights[k] * signals[0][k] * signals[1][k])
        .sum();
    assert!((total - direct).abs() <= 1e-10 * direct.abs());
    // A band that stops below fs/2 is refused on the Parseval path.
    assert!(FrameTransformer::new(
        &layout,
        Transform::Parseval,
        FrequencyBand {
            low_hz: 0.0,
            high_hz: 50.0
        },
        fs
    )
    .is_err());
}

// ---------------------------------------------------------------- solver

/// Basis functions of the top DoF of the 2-DoF chain (jerk form, N = 2.2),
/// sampled from the 250 Hz records: 6 columns spanning many magnitudes.
fn sampled_basis() -> Vec<Vec<f64>> {
    let (records, _) = two_dof().records(4);
    let kin = DirectionKinematics::from_records(&records, 1024, VelocityDrift::None).unwrap();
    let problem = DofProblem::new(&kin, 1, &[], BasisForm::Jerk, StiffnessPattern::Full).unwrap();
    let mut columns = problem.fixed_columns.clone();
    columns.extend(problem.nonlinear_columns(2.2));
    columns
}

#[test]
fn bounded_solver_recovers_known_parameters_to_1e_8() {
    let columns = sampled_basis();
    let refs: Vec<&[f64]> = columns.iter().map(|c| c.as_slice()).collect();
    // p = [K0_21, K0_22, K0δ_21, K0δ_22, s, t]; constraints K0_22 ≥ 0, s ≥ 0, t ≥ 0.
    let constrained = [1, 4, 5];
    let weights: Vec<f64> = (0..columns[0].len())
        .map(|k| 1.0 + (k % 7) as f64)
        .collect();
    for p_true in [
        [-4e7, 4e7, 40.0, 16.0, 3.0e5, 1.0e5],
        [-4e7, 4e7, 40.0, 16.0, 3.0e5, 0.0],
    ] {
        let target: Vec<f64> = (0..columns[0].len())
            .map(|k| refs.iter().zip(&p_true).map(|(c, p)| c[k] * p).sum())
            .collect();
        for w in [None, Some(weights.as_slice())] {
            let solution = bounded_lsq_columns(&refs, &target, w, &constrained).unwrap();
            for (i, (p, t)) in solution.p.iter().zip(&p_true).enumerate() {
                let err = if *t == 0.0 {
                    p.abs() / p_true[4]
                } else {
                    rel(*p, *t)
                };
                assert!(err <= 1e-8, "p[{i}] = {p} vs {t} (relative error {err:e})");
            }
        }
        // Gram form (normal equations, used for the cumulative estimates): the
        // condition number is squared, so only ~1e-5 is guaranteed here.
        let dim = refs.len();
        let h: Vec<f64> = (0..dim * dim)
            .map(|x| {
                refs[x / dim]
                    .iter()
                    .zip(refs[x % dim])
                    .map(|(a, b)| a * b)
                    .sum()
            })
            .collect();
        let b: Vec<f64> = refs
            .iter()
            .map(|c| c.iter().zip(&target).map(|(a, y)| a * y).sum())
            .collect();
        let yy: f64 = target.iter().map(|y| y * y).sum();
        let gram = bounded_lsq_gram(&h, &b, yy, &constrained).unwrap();
        for (p, t) in gram.p.iter().zip(&p_true) {
            let err = if *t == 0.0 {
                p.abs() / p_true[4]
            } else {
                rel(*p, *t)
            };
            assert!(err <= 1e-5, "Gram: {p} vs {t}");
        }
    }
}

/// When the unconstrained optimum violates Eq. 47 the solver returns the
/// constrained minimum: the bound is active and the KKT conditions hold.
#[test]
fn bounded_solver_enforces_eq47_with_kkt_conditions() {
    let columns = sampled_basis();
    let refs: Vec<&[f64]> = columns.iter().map(|c| c.as_slice()).collect();
    // t = −1e5 < 0 is infeasible (γ > β).
    let p_true = [-4e7, 4e7, 40.0, 16.0, 3.0e5, -1.0e5];
    let target: Vec<f64> = (0..columns[0].len())
        .map(|k| refs.iter().zip(&p_true).map(|(c, p)| c[k] * p).sum())
        .collect();
    let solution = bounded_lsq_columns(&refs, &target, None, &[1, 4, 5]).unwrap();
    assert_eq!(solution.active, vec![5]);
    assert_eq!(solution.p[5], 0.0);
    // Gradient g = Aᵀ(Ap − y): zero on free variables, ≥ 0 on the active bound.
    let residual: Vec<f64> = (0..target.len())
        .map(|k| {
            refs.iter()
                .zip(&solution.p)
                .map(|(c, p)| c[k] * p)
                .sum::<f64>()
                - target[k]
        })
        .collect();
    let gradient: Vec<f64> = refs
        .iter()
        .map(|c| c.iter().zip(&residual).map(|(a, r)| a * r).sum())
        .collect();
    let column_norm = |i: usize| refs[i].iter().map(|x| x * x).sum::<f64>().sqrt();
    let residual_norm = residual.iter().map(|x| x * x).sum::<f64>().sqrt();
    for (i, g) in gradient.iter().enumerate().take(5) {
        assert!(
            g.abs() <= 1e-8 * column_norm(i) * residual_norm,
            "free gradient {i}: {g}"
        );
    }
    assert!(gradient[5] > 0.0);
}

// ---------------------------------------------------------------- forward model

/// Linear limit (β = γ = δ = 0): undamped oscillator m = 1e5 kg, k = 4e7 N/m
/// (ω0 = 20 rad/s) under a(t) = 2 sin(7 t) m/s² from rest has
/// u(t) = A/(ω0² − Ω²) (Ω/ω0 sin ω0 t − sin Ω t).
#[test]
fn forward_model_matches_closed_form_linear_oscillator() {
    let chain = BoucWenChain::shear(
        vec![1e5],
        &[4e7],
        &[vec![0.0]],
        vec![0.0],
        vec![0.0],
        vec![2.0],
    )
    .unwrap();
    let fs = 1000.0;
    let (amp, omega, omega0) = (2.0, 7.0, 20.0);
    let ground: Vec<f64> = (0..10_000)
        .map(|k| amp * (omega * k as f64 / fs).sin())
        .collect();
    let response = chain.simulate(&ground, fs, 4).unwrap();
    let mut worst: f64 = 0.0;
    for (k, u) in response.relative_displacement[0].iter().enumerate() {
        let t = k as f64 / fs;
        let exact = amp / (omega0 * omega0 - omega * omega)
            * (omega / omega0 * (omega0 * t).sin() - (omega * t).sin());
        worst = worst.max((u - exact).abs());
    }
    let peak = amp / (omega0 * omega0 - omega * omega) * (1.0 + omega / omega0);
    assert!(worst <= 1e-5 * peak, "max error {worst} m (peak {peak} m)");
    // Eq. 21: the recorded absolute acceleration is −f/m.
    assert!(
        (response.absolute_acceleration[0][500] + response.restoring_force[0][500] / 1e5).abs()
            < 1e-12
    );
}

#[test]
fn forward_model_rejects_parameters_outside_eq47() {
    assert!(BoucWenChain::shear(
        vec![1e5],
        &[4e7],
        &[vec![0.0]],
        vec![0.1],
        vec![0.2],
        vec![2.0]
    )
    .is_err());
    assert!(BoucWenChain::shear(
        vec![1e5],
        &[4e7],
        &[vec![0.0]],
        vec![0.1],
        vec![0.0],
        vec![0.5]
    )
    .is_err());
}

#[test]
fn synthetic_ground_motion_is_deterministic_and_scaled() {
    let spec = ground_spec();
    let a = synthetic_ground_motion(&spec).unwrap();
    let b = synthetic_ground_motion(&spec).unwrap();
    assert_eq!(a, b);
    assert_eq!(a.len(), 50_000);
    let peak = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    assert!((peak - 3.5).abs() < 1e-12);
    let other = synthetic_ground_motion(&GroundMotionSpec { seed: 8, ..spec }).unwrap();
    assert_ne!(a, other);
    // Envelope: quiet start, decayed tail.
    assert!(a[..100].iter().all(|x| x.abs() < 0.01 * peak));
    assert!(a[49_000..].iter().all(|x| x.abs() < 0.05 * peak));
}

/// The four-point cumulative rule integrates a cubic exactly.
#[test]
fn cubic_cumulative_rule_is_exact_for_cubics() {
    let dt = 0.01;
    let x: Vec<f64> = (0..50)
        .map(|k| (k as f64 * dt).powi(3) - 2.0 * (k as f64 * dt))
        .collect();
    let integral = cumulative_cubic(&x, dt);
    for (k, v) in integral.iter().enumerate() {
        let t = k as f64 * dt;
        assert!((v - (t.powi(4) / 4.0 - t * t)).abs() < 1e-14);
    }
}

// ---------------------------------------------------------------- damage index

/// 1-DoF: ι = 1 − ω(t)/ω(0) = 1 − sqrt(1 − δ ε). With δ ε = 0.19, ι = 0.1.
/// 2-DoF: against the closed-form 2×2 eigen-solution.
#[test]
fn damage_index_matches_closed_forms() {
    let delta = 1e-6;
    let energy = vec![vec![0.0, 0.5 * 0.19 / delta, 0.19 / delta]];
    let series = damage_index(&[vec![4e7]], &[vec![4e7 * delta]], &[1e5], &energy, 1.0, 1).unwrap();
    assert!((series.iota[2] - 0.1).abs() < 1e-12);
    assert_eq!(series.participation[0][2], 1.0);

    // K0 = [[1e8, −4e7], [−4e7, 4e7]], K0δ = [[40, −30], [30, 16]] (antisymmetric
    // off-diagonal), energies ε11 = 1e5, ε12 = ∫f2 u̇1 = 2e4, ε22 = 1.5e5, m = [1e5, 2e5].
    let k0 = vec![vec![1e8, -4e7], vec![-4e7, 4e7]];
    let k0_delta = vec![vec![40.0, -30.0], vec![30.0, 16.0]];
    let masses = [1e5, 2e5];
    let energy = vec![vec![0.0, 1e5], vec![0.0, 2e4], vec![0.0, 1.5e5]];
    let series = damage_index(&k0, &k0_delta, &masses, &energy, 1.0, 1).unwrap();
    // K(t) by hand: K11 = 1e8 − 40·1e5, K12 = −4e7 − (−30)(2e4) (ε12 = +2e4), K22 = 4e7 − 16·1.5e5.
    let k_t = [[1e8 - 4e6, -4e7 + 6e5], [-4e7 + 6e5, 4e7 - 2.4e6]];
    let modes = |k: [[f64; 2]; 2]| {
        // A = M^{-1/2} K M^{-1/2}; eigenpairs of a symmetric 2×2.
        let a = [
            [
                k[0][0] / masses[0],
                k[0][1] / (masses[0] * masses[1]).sqrt(),
            ],
            [0.0, k[1][1] / masses[1]],
        ];
        let (p, q, r) = (a[0][0], a[0][1], a[1][1]);
        let mean = 0.5 * (p + r);
        let rad = (0.25 * (p - r).powi(2) + q * q).sqrt();
        let mut out = Vec::new();
        for lambda in [mean - rad, mean + rad] {
            let v = [q, lambda - p];
            let norm = (v[0] * v[0] + v[1] * v[1]).sqrt();
            let gamma = (v[0] * masses[0].sqrt() + v[1] * masses[1].sqrt()) / norm;
            out.push((lambda.sqrt(), gamma * gamma));
        }
        out
    };
    let (before, after) = (modes([[1e8, -4e7], [-4e7, 4e7]]), modes(k_t));
    let total: f64 = after.iter().map(|m| m.1).sum();
    let expected: f64 = (0..2)
        .map(|s| after[s].1 / total * (1.0 - after[s].0 / before[s].0))
        .sum();
    assert!(
        (series.iota[1] - expected).abs() < 1e-12,
        "{} vs {expected}",
        series.iota[1]
    );
    assert!((series.omega_ratio[0][1] - after[0].0 / before[0].0).abs() < 1e-12);
    assert_eq!(series.iota[0], 0.0);
    assert_eq!(series.indefinite_steps, 0);
}

// ---------------------------------------------------------------- reduced masses

/// Thesis Table 16 / Eq. 36b: m_rf = 487 300, m_ff = 929 430, m_uf = 836 370 kg,
/// f_FE = 6.79 Hz (X), 4.86 Hz (Y), K_red as printed → thesis σ = (0.999, 0.735).
/// The printed K_red are rounded to two digits, which moves the optimum by a
/// few grid steps: we get (0.997, 0.732).
#[test]
fn reduced_masses_reproduce_thesis_table_16() {
    let two_pi = 2.0 * std::f64::consts::PI;
    let targets = [
        ReducedMassTarget {
            stiffness: [[7.8e9, -3.1e9], [-3.1e9, 3.1e9]],
            omega_fe: two_pi * 6.79,
        },
        ReducedMassTarget {
            stiffness: [[4.9e9, -2.2e9], [-2.2e9, 2.2e9]],
            omega_fe: two_pi * 4.86,
        },
    ];
    let result = reduced_lumped_masses([929_430.0, 836_370.0], 487_300.0, &targets, 0.001).unwrap();
    assert!(
        (result.sigma1 - 0.999).abs() <= 0.005 && (result.sigma2 - 0.735).abs() <= 0.005,
        "{result:?}"
    );
    assert!(
        (result.m1 + result.m2 - (929_430.0 + 836_370.0 + result.sigma1 * 487_300.0)).abs() < 1e-6
    );
}

/// Synthetic: masses built with σ = (0.42, 0.613) give the target pulsations exactly.
#[test]
fn reduced_masses_recover_known_sigma() {
    let (ma, mb, mu) = (9e5, 8e5, 5e5);
    let (s1, s2) = (0.42, 0.613);
    let total = ma + mb + s1 * mu;
    let (kx, ky) = (
        [[7.8e9, -3.1e9], [-3.1e9, 3.1e9]],
        [[4.9e9, -2.2e9], [-2.2e9, 2.2e9]],
    );
    let targets = [
        ReducedMassTarget {
            stiffness: kx,
            omega_fe: first_pulsation_2dof(&kx, s2 * total, (1.0 - s2) * total).unwrap(),
        },
        ReducedMassTarget {
            stiffness: ky,
            omega_fe: first_pulsation_2dof(&ky, s2 * total, (1.0 - s2) * total).unwrap(),
        },
    ];
    let result = reduced_lumped_masses([ma, mb], mu, &targets, 0.001).unwrap();
    assert!(
        (result.sigma1 - s1).abs() < 1e-9 && (result.sigma2 - s2).abs() < 1e-9,
        "{result:?}"
    );
    assert!(result.cost < 1e-6);
}

// ---------------------------------------------------------------- bad input

fn short_records() -> DirectionRecords {
    let (mut records, _) = one_dof().records(4);
    records.base.as_mut().unwrap().acceleration.truncate(4000);
    records.floors[0].absolute_acceleration.truncate(4000);
    records
}

#[test]
fn missing_base_channel_is_an_input_error() {
    let mut records = short_records();
    records.base = None;
    match identify_direction(&records, &IdentifySettings::default()) {
        Err(Error::Input { location, message }) => {
            assert_eq!(location.file, "synthetic-event");
            assert!(message.contains("no base"), "{message}");
        }
        other => panic!("expected an input error, got {other:?}"),
    }
}

#[test]
fn missing_mass_is_an_input_error_naming_the_channel() {
    let mut records = short_records();
    records.floors[0].mass_kg = None;
    match identify_direction(&records, &IdentifySettings::default()) {
        Err(Error::Input { location, message }) => {
            assert_eq!(location.channel.as_deref(), Some("floor1-X"));
            assert!(message.contains("mass"), "{message}");
        }
        other => panic!("expected an input error, got {other:?}"),
    }
}

#[test]
fn short_mismatched_or_non_finite_records_are_input_errors() {
    let mut records = short_records();
    records.base.as_mut().unwrap().acceleration.truncate(500);
    records.floors[0].absolute_acceleration.truncate(500);
    let err = identify_direction(&records, &IdentifySettings::default()).unwrap_err();
    assert!(
        matches!(&err, Error::Input { message, .. } if message.contains("500 samples")),
        "{err}"
    );

    let mut records = short_records();
    records.floors[0].absolute_acceleration.pop();
    let err = identify_direction(&records, &IdentifySettings::default()).unwrap_err();
    assert!(
        matches!(&err, Error::Input { location, .. } if location.channel.as_deref() == Some("floor1-X")),
        "{err}"
    );

    let mut records = short_records();
    records.floors[0].absolute_acceleration[123] = f64::NAN;
    let err = identify_direction(&records, &IdentifySettings::default()).unwrap_err();
    assert!(
        matches!(&err, Error::Input { message, .. } if message.contains("sample 123")),
        "{err}"
    );
}

/// A linear elastic structure (β = γ = 0, δ = 0; m = 1e5 kg, K0 = 4e7 N/m)
/// under the same 250 Hz ground motion: the nonlinear parameters are reported
/// as not identifiable instead of returning noise.
#[test]
fn non_yielding_response_is_not_identifiable() {
    let chain = BoucWenChain::shear(
        vec![1e5],
        &[4e7],
        &[vec![0.0]],
        vec![0.0],
        vec![0.0],
        vec![1.6],
    )
    .unwrap();
    let synthetic = Synthetic::new(chain);
    let (records, _) = synthetic.records(4);
    match identify_direction(&records, &fast_settings(BasisForm::Jerk)) {
        Err(Error::NotIdentifiable { stage, message, .. }) => {
            assert_eq!(stage, "hysteresis");
            assert!(
                message.contains("not identifiable") && message.contains("DoF 1"),
                "{message}"
            );
        }
        other => panic!("expected NotIdentifiable, got {other:?}"),
    }
}

// ---------------------------------------------------------------- processing, determinism

#[test]
fn processing_is_recorded_and_results_are_deterministic() {
    let (mut records, _) = one_dof().records(4);
    records
        .declared_processing
        .push("units_to_si", serde_json::json!({ "factor": 1.0 }));
    let settings = fast_settings(BasisForm::Jerk);
    let a = identify_direction(&records, &settings).unwrap();
    let b = identify_direction(&records, &settings).unwrap();
    assert_eq!(a, b);
    let steps: Vec<&str> = a.processing.steps.iter().map(|s| s.step.as_str()).collect();
    assert_eq!(steps[0], "units_to_si");
    for wanted in [
        "hysteresis_relative_acceleration",
        "hysteresis_integrate",
        "hysteresis_restoring_force",
        "hysteresis_identification",
    ] {
        assert!(steps.contains(&wanted), "{steps:?}");
    }
    // Inputs untouched and the fit series cover the record.
    assert_eq!(records.floors[0].absolute_acceleration.len(), 12_500);
    let fit = &a.dofs[0].fit;
    assert_eq!(
        (
            fit.target.len(),
            fit.model.len(),
            fit.force_model.len(),
            fit.storey_drift.len()
        ),
        (12_500, 12_500, 12_500, 12_500)
    );
    // The model force along the recorded kinematics follows the recorded force.
    let (_, response) = one_dof().records(4);
    let peak = response.restoring_force[0]
        .iter()
        .fold(0.0f64, |m, x| m.max(x.abs()));
    let worst = fit
        .force_model
        .iter()
        .zip(&response.restoring_force[0])
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(
        worst < 0.02 * peak,
        "model force off by {worst} N (peak {peak} N)"
    );
}

#[test]
fn two_directions_identify_in_parallel() {
    let (x, _) = one_dof().records(4);
    let y = DirectionRecords {
        direction: "Y".into(),
        ..x.clone()
    };
    let both = identify_directions(&[x, y], &fast_settings(BasisForm::Jerk)).unwrap();
    assert_eq!(both.len(), 2);
    assert_eq!(both[1].direction, "Y");
    assert_eq!(both[0].dofs[0].exponent, both[1].dofs[0].exponent);
}

/// Records from an ingested event: units converted, masses from the manifest
/// by level; a missing base channel stays `None` and becomes an input error.
#[test]
fn direction_records_from_event() {
    use quaketwin::vocab::{Channel, Event, Record, SourceRef, Structure, Units};
    let channel = |id: &str, level: i32, units: Units| {
        let mut c = Channel::new(
            id,
            units,
            250.0,
            SourceRef {
                file: format!("{id}.csv"),
                ..SourceRef::default()
            },
        );
        c.level = Some(level);
        c
    };
    let samples: Vec<f64> = (0..2000).map(|k| (k as f64 * 0.05).sin()).collect();
    let event = Event {
        name: "ev1".into(),
        structure: Some(Structure {
            masses_kg: vec![2e5, 1e5],
            ..Structure::default()
        }),
        records: vec![
            Record::new(channel("B", 0, Units::CmPerS2), samples.clone()),
            Record::new(channel("F1", 1, Units::MPerS2), samples.clone()),
            Record::new(channel("F2", 2, Units::G), samples.clone()),
        ],
        ..Event::default()
    };
    let records = DirectionRecords::from_event(&event, "X", "B", &["F1", "F2"], None).unwrap();
    assert_eq!(records.sampling_rate_hz, 250.0);
    assert!((records.base.as_ref().unwrap().acceleration[10] - 0.01 * samples[10]).abs() < 1e-15);
    assert!((records.floors[1].absolute_acceleration[10] - 9.80665 * samples[10]).abs() < 1e-12);
    assert_eq!(
        (records.floors[0].mass_kg, records.floors[1].mass_kg),
        (Some(2e5), Some(1e5))
    );
    let no_base =
        DirectionRecords::from_event(&event, "X", "missing", &["F1", "F2"], None).unwrap();
    let err = identify_direction(&no_base, &IdentifySettings::default()).unwrap_err();
    assert!(
        matches!(&err, Error::Input { location, .. } if location.file == "ev1"),
        "{err}"
    );
    let err = DirectionRecords::from_event(&event, "X", "B", &["F1", "nope"], None).unwrap_err();
    assert!(
        matches!(&err, Error::Input { location, .. } if location.channel.as_deref() == Some("nope")),
        "{err}"
    );
}

// ---------------------------------------------------------------- drift control

/// A constant acceleration offset c adds c·t to the integrated velocity; a
/// free vibration (no viscous damping in Eq. 21) keeps ringing to the end of
/// the record. The drift estimate must see c and not the ringing.
#[test]
fn end_drift_rate_separates_drift_from_ringing() {
    use quaketwin::hysteresis::basis::end_drift_rate;
    let (fs, n) = (250.0, 12_500);
    let dt = 1.0 / fs;
    let c = 2e-4; // m/s² offset
    let amplitude = 0.05; // m/s ringing at 2.3 Hz, phase 1.1 rad
    let v: Vec<f64> = (0..n)
        .map(|k| {
            let t = k as f64 * dt;
            c * t + amplitude * (2.0 * std::f64::consts::PI * 2.3 * t + 1.1).sin()
        })
        .collect();
    let rate = end_drift_rate(&v, dt);
    // The last sample alone would give c + amplitude·sin(…)/T ≈ c ± 1e-3.
    let naive = v[n - 1] / ((n - 1) as f64 * dt);
    eprintln!("drift rate: true {c:e}, Hann-window {rate:e}, last-sample {naive:e}");
    assert!((rate - c).abs() < 2e-6, "estimated {rate} vs {c}");
    assert!((naive - c).abs() > 50.0 * (rate - c).abs());
}

fn sample_truth() -> toml::Table {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/sample-records/synthetic-2storey-yielding/truth.toml"
    );
    std::fs::read_to_string(path).unwrap().parse().unwrap()
}

/// `velocity_drift = "endpoint_ramp"` on the noise-free yielding sample
/// (250 Hz, 2 storeys): N within ±0.01 of the truth, final ι within 0.001.
/// The first version subtracted the ramp through the last velocity sample,
/// which is a free-vibration value (the undamped model keeps ringing), and
/// biased N by +0.065 and ι ×3.5.
#[test]
fn endpoint_ramp_does_not_bias_the_noise_free_yielding_sample() {
    use quaketwin::hysteresis::basis::{cumulative_cubic, end_drift_rate};
    use quaketwin::sinks::hysteresis_tables::DirectionOutcome;
    use quaketwin::stages::hysteresis::{identify_event_at, HysteresisParams};
    let dir = std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/sample-records/synthetic-2storey-yielding"
    ));
    let event = quaketwin::event_folder::load(dir).unwrap().event;
    // What the drift control sees: last velocity sample vs windowed estimate.
    let records =
        DirectionRecords::from_event(&event, "X", "B-X", &["F1-X", "F2-X"], None).unwrap();
    let dt = 1.0 / records.sampling_rate_hz;
    for f in &records.floors {
        let rel: Vec<f64> = f
            .absolute_acceleration
            .iter()
            .zip(&records.base.as_ref().unwrap().acceleration)
            .map(|(a, b)| a - b)
            .collect();
        let v = cumulative_cubic(&rel, dt);
        let peak = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        eprintln!(
            "{}: peak |v| {peak:.4} m/s, last v {:.3e} m/s, windowed drift at end {:.3e} m/s",
            f.channel,
            v[v.len() - 1],
            end_drift_rate(&v, dt) * (v.len() - 1) as f64 * dt
        );
    }
    let truth = sample_truth();
    let n_true: Vec<f64> = truth["exponent_n"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_float().unwrap())
        .collect();
    let iota_true = truth["final_damage_index"].as_float().unwrap();
    let params = HysteresisParams {
        velocity_drift: quaketwin::hysteresis::VelocityDrift::EndpointRamp,
        instantaneous: false,
        ..HysteresisParams::default()
    };
    let (outcomes, masses) = identify_event_at(&event, Some(dir), &params).unwrap();
    assert_eq!(masses[0].source, "event.toml structure.masses_kg");
    let DirectionOutcome::Identified(id) = &outcomes[0] else {
        panic!("not identified");
    };
    let iota = id.damage.final_iota().unwrap();
    eprintln!(
        "endpoint_ramp: N {:?} (true {n_true:?}), final ι {iota:.5} (true {iota_true:.5})",
        id.dofs.iter().map(|d| d.exponent).collect::<Vec<_>>()
    );
    for (d, dof) in id.dofs.iter().enumerate() {
        assert!(
            (dof.exponent - n_true[d]).abs() <= 0.01,
            "N{} = {} vs {}",
            d + 1,
            dof.exponent,
            n_true[d]
        );
    }
    assert!((iota - iota_true).abs() <= 0.001, "ι {iota} vs {iota_true}");
}

// ---------------------------------------------------------------- identifiability

/// The F distribution's survival function against tabulated critical values.
#[test]
fn f_survival_matches_tables() {
    use quaketwin::stats::f_survival;
    // F_{0.05}(3, 50) = 2.790, F_{0.01}(3, 50) = 4.199, F_{0.001}(3, 20) = 8.098.
    for (f, d1, d2, p) in [
        (2.790, 3.0, 50.0, 0.05),
        (4.199, 3.0, 50.0, 0.01),
        (8.098, 3.0, 20.0, 0.001),
    ] {
        let got = f_survival(f, d1, d2);
        assert!(
            (got / p - 1.0).abs() < 0.01,
            "P(F({d1},{d2}) > {f}) = {got}, table {p}"
        );
    }
    assert_eq!(f_survival(0.0, 3.0, 50.0), 1.0);
}

/// Adds Gaussian noise of `fraction` × the channel's RMS to every channel (seeded).
fn with_noise(records: &DirectionRecords, fraction: f64, seed: u64) -> DirectionRecords {
    let mut rng = SplitMix64::new(seed);
    let mut noisy = |x: &[f64]| -> Vec<f64> {
        let rms = (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt();
        x.iter()
            .map(|v| v + fraction * rms * rng.next_gaussian())
            .collect()
    };
    let mut out = records.clone();
    let base = noisy(&records.base.as_ref().unwrap().acceleration);
    out.base.as_mut().unwrap().acceleration = base;
    for f in out.floors.iter_mut() {
        f.absolute_acceleration = noisy(&f.absolute_acceleration);
    }
    out
}

/// Yielding 1-DoF (above, 250 Hz): the hysteretic columns are overwhelmingly
/// significant against the nested linear model, noise-free and with 5 % RMS
/// white noise on every channel (seed 11).
#[test]
fn yielding_response_is_identifiable_with_and_without_noise() {
    let (records, _) = one_dof().records(4);
    let settings = fast_settings(BasisForm::Jerk);
    for (label, rec) in [
        ("noise-free", records.clone()),
        ("5 % noise", with_noise(&records, 0.05, 11)),
    ] {
        let id = identify_direction(&rec, &settings).unwrap_or_else(|e| panic!("{label}: {e}"));
        let dof = &id.dofs[0];
        let s = &dof.significance;
        eprintln!(
            "[{label}] N {:.3} F {:.3e} on ({}, {}) p {:.2e} J_lin/J {:.2}",
            dof.exponent,
            s.f_statistic,
            s.numerator_dof,
            s.denominator_dof,
            s.p_value,
            s.linear_cost / dof.cost
        );
        // Significant at the default α = 1e-3 (noise-free p ≈ 1e-127, 5 %
        // noise p ≈ 4e-6 with J_lin/J ≈ 1.7: the jerk form differentiates the
        // record, so white noise dominates the residual).
        assert!(
            s.p_value < settings.significance_level,
            "{label}: p = {}",
            s.p_value
        );
        // N: within 0.01 noise-free; with 5 % noise the jerk form's amplified
        // noise biases it (measured +0.117), so only 0.15 is claimed there.
        let tol = if label == "noise-free" { 0.01 } else { 0.15 };
        assert!(
            (dof.exponent - 1.6).abs() <= tol,
            "{label}: N {}",
            dof.exponent
        );
    }
}

/// A linear elastic 1-DoF (m = 1e5 kg, K0 = 4e7 N/m, β = γ = δ = 0) with 5 %
/// RMS noise on every channel: not identifiable (the reason is one of the
/// criteria of `identify_dof`).
#[test]
fn noisy_linear_response_is_not_identifiable() {
    let chain = BoucWenChain::shear(
        vec![1e5],
        &[4e7],
        &[vec![0.0]],
        vec![0.0],
        vec![0.0],
        vec![1.6],
    )
    .unwrap();
    let synthetic = Synthetic::new(chain);
    let (records, _) = synthetic.records(4);
    let noisy = with_noise(&records, 0.05, 12);
    match identify_direction(&noisy, &fast_settings(BasisForm::Jerk)) {
        Err(Error::NotIdentifiable { message, .. }) => {
            eprintln!("linear + noise: {message}");
            assert!(message.contains("not identifiable"), "{message}");
        }
        Ok(id) => panic!(
            "identified N = {}, significance {:?}",
            id.dofs[0].exponent, id.dofs[0].significance
        ),
        Err(e) => panic!("unexpected error {e}"),
    }
}

/// The per-frame products accumulate eight right-hand rows side by side (issue 18); each
/// G_j[i][k] must still be the plain dot product of the two frames, bit for bit (11 right
/// rows: one block of eight and a remainder of three).
#[test]
fn frame_products_are_the_dot_products_bit_for_bit() {
    let mut rng = quaketwin::rng::Rng::new(18);
    let (frames, width) = (7, 53);
    let reps: Vec<FrameRepresentation> = (0..11)
        .map(|_| FrameRepresentation {
            width,
            values: (0..frames * width).map(|_| rng.normal() * 1e3).collect(),
        })
        .collect();
    let left: Vec<&FrameRepresentation> = reps[..2].iter().collect();
    let right: Vec<&FrameRepresentation> = reps.iter().collect();
    let g = frame_products(&left, &right, frames);
    for j in 0..frames {
        for (i, l) in left.iter().enumerate() {
            for (k, r) in right.iter().enumerate() {
                let dot: f64 = l.frame(j).iter().zip(r.frame(j)).map(|(x, y)| x * y).sum();
                let got = g[(j * left.len() + i) * right.len() + k];
                assert_eq!(got.to_bits(), dot.to_bits(), "frame {j}, {i} × {k}");
            }
        }
    }
}
