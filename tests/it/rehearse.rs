//! Rehearsal of a hybrid test (issue 16): `quaketwin::rehearse` on a Craig–Bampton prototype
//! built by hand, whose full model and reference response are known, and on the facade sample.
//!
//! The prototype: an interface DoF x_q carried by the specimen spring k_P (the PS, one
//! actuator) and two NS oscillators hanging from it — a heavy one (m₁ = 1000 kg, the low
//! mode) and a light one (m₂ = 1 kg, the spurious high mode, ≈ 51 Hz). With the interface
//! fixed they are independent, so the fixed-interface modes are φ_i = e_i / √m_i, the
//! constraint mode is the rigid translation (1, 1, 1), and
//!   K̂ = diag(k₁/m₁, k₂/m₂, k_P),  M̂ = [[1, 0, √m₁], [0, 1, √m₂], [√m₁, √m₂, m₁ + m₂ + m_P]],
//!   ψᵀ M r = (√m₁, √m₂, m₁ + m₂ + m_P)
//! exactly: the prototype with both NS modes *is* the full model, whose response (Newmark,
//! `twin::newmark`) is the reference.

use faer::Mat;

use quaketwin::rehearse::model::{ActuatedDof, RehearsalModel, MODEL_SCHEMA};
use quaketwin::rehearse::{rehearse, RehearseSettings, Scheme, ServoKind};
use quaketwin::twin::newmark::{
    newmark_base_excitation, rayleigh_coefficients, BaseExcitation, NewmarkSettings,
};
use quaketwin::twin::sparse::CscMatrix;

const M1: f64 = 1000.0;
const M2: f64 = 1.0;
const MP: f64 = 1.0;
const K: f64 = 39_557.0;

/// Base acceleration: a sine sweep 0.3 → 2.3 Hz under a smooth envelope, 10 s at 200 Hz.
fn ground() -> (f64, Vec<f64>) {
    let dt = 0.005;
    let a = (0..2000)
        .map(|k| {
            let t = k as f64 * dt;
            let env = (t / 2.0).min(1.0) * (1.0 - (t - 6.0).max(0.0) / 4.0).max(0.0);
            2.0 * env * (2.0 * std::f64::consts::PI * (0.3 + 0.1 * t) * t).sin()
        })
        .collect();
    (dt, a)
}

fn rows(m: &Mat<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| (0..m.ncols()).map(|j| m[(i, j)]).collect())
        .collect()
}

/// The hand-made prototype and its full-model reference at x_q.
pub fn two_oscillator_model() -> RehearsalModel {
    oscillator_model(M2, K, MP)
}

/// The same with light-oscillator mass `m2` and stiffness `k2`, interface mass `mp`.
pub fn oscillator_model(m2: f64, k2: f64, mp: f64) -> RehearsalModel {
    oscillator_model_damped(m2, k2, mp, false)
}

/// … and with mass-proportional damping only (a₁ = 0) when `mass_damping`.
pub fn oscillator_model_damped(m2: f64, k2: f64, mp: f64, mass_damping: bool) -> RehearsalModel {
    let (k1, kp) = (K, K);
    let k = Mat::from_fn(3, 3, |i, j| match (i, j) {
        (0, 0) => k1,
        (1, 1) => k2,
        (2, 2) => k1 + k2 + kp,
        (0, 2) | (2, 0) => -k1,
        (1, 2) | (2, 1) => -k2,
        _ => 0.0,
    });
    let m = Mat::from_fn(3, 3, |i, j| if i == j { [M1, m2, mp][i] } else { 0.0 });
    // Rayleigh: 5 % at the first full-model frequency, 1 % at the spurious one.
    let f = |w2: f64| w2.sqrt() / (2.0 * std::f64::consts::PI);
    let f_low = f(k1 * kp / (k1 + kp) / M1);
    let f_high = f(2.62 * k2 / m2);
    let (a0, a1) = rayleigh_coefficients(f_low, f_high, 0.05, 0.01).unwrap();
    let a1 = if mass_damping { 0.0 } else { a1 };
    let (dt, acc) = ground();
    let reference = newmark_base_excitation(
        &CscMatrix::from_dense(k.as_ref()),
        &CscMatrix::from_dense(m.as_ref()),
        &[BaseExcitation {
            influence: vec![1.0; 3],
            load: vec![M1, m2, mp],
            acceleration: acc.clone(),
        }],
        &NewmarkSettings {
            dt,
            rayleigh: (a0, a1),
            record: Some(vec![2]),
        },
    )
    .unwrap();
    let (s1, s2) = (M1.sqrt(), m2.sqrt());
    let k_hat = Mat::from_fn(3, 3, |i, j| {
        if i != j {
            0.0
        } else {
            [k1 / M1, k2 / m2, kp][i]
        }
    });
    let m_hat = Mat::from_fn(3, 3, |i, j| match (i, j) {
        (0, 0) | (1, 1) => 1.0,
        (0, 2) | (2, 0) => s1,
        (1, 2) | (2, 1) => s2,
        (2, 2) => M1 + m2 + mp,
        _ => 0.0,
    });
    let mut model = RehearsalModel {
        schema: MODEL_SCHEMA.into(),
        ns_modes: 2,
        actuators: vec![ActuatedDof {
            actuator: 1,
            node_id: 1,
            direction: "ux".into(),
            control_mode: "displacement".into(),
            nominal_force_n: 0.0,
        }],
        stiffness: rows(&k_hat),
        mass: rows(&m_hat),
        ps_stiffness: vec![vec![kp]],
        rayleigh: [a0, a1],
        dt,
        axes: vec![0],
        loads: vec![vec![s1, s2, M1 + m2 + mp]],
        accelerations: vec![acc],
        observation: vec![vec![0.0, 0.0, 1.0]],
        reference: reference.displacement.clone(),
        reference_substeps: 1,
        frequencies_hz: Vec::new(),
        actuator_band_hz: 1.0,
        time_scale: 1000.0,
        time_scales: vec![25.0, 1000.0],
        gravity: false,
        gravity_load: Vec::new(),
        gravity_direction: String::new(),
        motion_source: "sine sweep".into(),
    };
    model.frequencies_hz = model.eigenfrequencies_hz().unwrap();
    model
}

pub fn settings(scheme: Scheme) -> RehearseSettings {
    RehearseSettings {
        scheme,
        servo: ServoKind::FirstOrder,
        bandwidth_hz: Some(1.0),
        delay_s: 0.005,
        ..RehearseSettings::default()
    }
}

#[test]
fn hand_made_prototype_has_a_spurious_high_mode() {
    let model = two_oscillator_model();
    let f = &model.frequencies_hz;
    assert_eq!(f.len(), 3);
    assert!(f[0] < 1.0 && f[2] > 45.0, "frequencies {f:?}");
    let fewer = model.with_ns_modes(0).unwrap();
    assert!((fewer.top_frequency_hz() - 1.0).abs() < 0.01, "{fewer:?}");
}

#[test]
fn rehearse_stable_inside_the_band_divergent_outside_stable_with_fewer_modes() {
    let model = two_oscillator_model();
    for scheme in [Scheme::AlphaOs, Scheme::CentralDifference] {
        let s = RehearseSettings {
            time_scales: vec![25.0, 1000.0],
            ns_modes: vec![0, 2],
            ..settings(scheme)
        };
        let r = rehearse(&model, &s).unwrap();
        for run in &r.runs {
            eprintln!("{scheme:?} {run:?}");
        }
        let find = |ns: usize, l: f64| {
            r.runs
                .iter()
                .find(|x| x.ns_modes == ns && x.time_scale == l)
                .unwrap()
        };
        // λ = 1000: bandwidth 51 Hz / 1000 = 0.05 Hz, inside the 1 Hz actuator band.
        let safe = find(2, 1000.0);
        assert!(safe.bandwidth_hz < 1.0);
        assert!(safe.stable, "{scheme:?}: {safe:?}");
        let w = safe.response_wnrmse.unwrap();
        assert!(w <= 0.02, "{scheme:?}: response WNRMSE {w}");
        // λ = 25: the spurious mode at 2 Hz in laboratory time, outside the band: diverges.
        let bad = find(2, 25.0);
        assert!(bad.bandwidth_hz > 1.0);
        assert!(!bad.stable, "{scheme:?}: {bad:?}");
        assert!(bad.divergence_time_s.unwrap() < 10.0);
        assert!(bad.response_wnrmse.is_none() && !bad.safe);
        // Without the NS modes the same λ is stable again.
        let fewer = find(0, 25.0);
        assert!(fewer.stable, "{scheme:?}: {fewer:?}");
        // The recommendation: the smallest safe λ with the design's 2 NS modes.
        assert_eq!(r.ns_modes, 2);
        assert_eq!(r.recommended.map(|i| r.runs[i].time_scale), Some(1000.0));
        // Spurious energy: positive and small when safe.
        assert!(safe.energy_error < 0.05, "{scheme:?}: {safe:?}");
    }
}

/// With fewer NS modes the same λ is stable again at an intermediate count, k = design − 1.
/// In the light-oscillator prototype above that cannot show: with its NS mode dropped, the
/// 1 kg oscillator rides on the 1 kg interface and the 1-mode prototype keeps a high interface
/// mode (≈ 32 Hz) that diverges as well. Here the dropped NS oscillator is the heavier part of the
/// interface assembly (m₂ = 3 kg on k₂ = 4 k, interface m_P = 0.1 kg): with it the interface
/// can vibrate between k_P + k₁ and k₂ (the top mode, ≈ 247 Hz), without it the interface mode
/// carries m₂ + m_P (≈ 25 Hz). Damping is mass-proportional only (a₁ = 0: the top mode is not
/// damped out by Rayleigh's stiffness term). At λ = 1000 the 2-mode prototype diverges and the
/// 1-mode one is stable and accurate (WNRMSE against the full model ≤ 1 %: the dropped mode
/// barely participates in the response).
#[test]
fn rehearse_dropping_the_spurious_ns_mode_alone_restores_stability() {
    let model = oscillator_model_damped(3.0, 4.0 * K, 0.1, true);
    let f2 = model.top_frequency_hz();
    let f1 = model.with_ns_modes(1).unwrap().top_frequency_hz();
    assert!(f2 > 200.0 && f1 < 30.0, "top frequencies {f2} {f1} Hz");
    for scheme in [Scheme::AlphaOs, Scheme::CentralDifference] {
        let s = RehearseSettings {
            time_scales: vec![1000.0],
            ns_modes: vec![1, 2],
            ..settings(scheme)
        };
        let r = rehearse(&model, &s).unwrap();
        for run in &r.runs {
            eprintln!("{scheme:?} {run:?}");
        }
        let (one, two) = (&r.runs[0], &r.runs[1]);
        assert_eq!((one.ns_modes, two.ns_modes), (1, 2));
        assert!(
            !two.stable && two.response_wnrmse.is_none(),
            "{scheme:?}: {two:?}"
        );
        assert!(one.stable, "{scheme:?}: {one:?}");
        let w = one.response_wnrmse.unwrap();
        assert!(w <= 0.01, "{scheme:?}: WNRMSE {w}");
    }
}

#[test]
fn rehearse_with_a_perfect_actuator_reproduces_the_full_model() {
    let model = two_oscillator_model();
    for scheme in [Scheme::AlphaOs, Scheme::CentralDifference] {
        let s = RehearseSettings {
            scheme,
            servo: ServoKind::Ideal,
            delay_s: 0.0,
            time_scales: vec![1.0, 100.0],
            ..RehearseSettings::default()
        };
        let r = rehearse(&model, &s).unwrap();
        for run in &r.runs {
            let w = run.response_wnrmse.unwrap();
            assert!(w <= 0.005, "{scheme:?}: WNRMSE {w} at λ {}", run.time_scale);
            assert!(run.tracking_max_m.iter().all(|&e| e == 0.0), "{run:?}");
            assert_eq!(run.energy_error, 0.0);
        }
    }
}

#[test]
fn rehearse_noise_is_seeded_and_tracked() {
    let model = two_oscillator_model();
    let s = RehearseSettings {
        time_scales: vec![1000.0],
        displacement_noise_m: 1e-5,
        force_noise_n: 0.5,
        ..settings(Scheme::AlphaOs)
    };
    let a = rehearse(&model, &s).unwrap();
    let b = rehearse(&model, &s).unwrap();
    assert_eq!(a.runs, b.runs);
    assert_eq!(a.histories, b.histories);
    let other = rehearse(
        &model,
        &RehearseSettings {
            seed: 17,
            ..s.clone()
        },
    )
    .unwrap();
    assert_ne!(a.histories.force, other.histories.force);
    assert!(a.runs[0].stable);
}

#[test]
fn rehearse_refuses_bad_settings_and_models() {
    let model = two_oscillator_model();
    let s = RehearseSettings {
        alpha: -0.5,
        ..RehearseSettings::default()
    };
    let e = rehearse(&model, &s).unwrap_err().to_string();
    assert!(e.contains("alpha"), "{e}");
    let s = RehearseSettings {
        ns_modes: vec![3],
        ..RehearseSettings::default()
    };
    let e = rehearse(&model, &s).unwrap_err().to_string();
    assert!(e.contains("NS modes"), "{e}");
    let mut bad = model.clone();
    bad.reference[0].pop();
    let e = rehearse(&bad, &RehearseSettings::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("reference"), "{e}");
}

/// The facade sample through pipelines/test-design.toml: the run ends with a rehearsal sweep
/// over the design's candidate λ, a recommended λ, and the report shows it.
#[test]
fn facade_pipeline_ends_with_a_rehearsal_sweep_and_a_recommended_time_scale() {
    use quaketwin::vocab::tables::{rehearsal, rehearsal_summary as rs};
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    crate::common::run_sample_pipeline("test-design.toml", "synthetic-facade", &out, &[]);
    let summary = out.join("rehearsal_summary/rehearsal_summary.parquet");
    let lam = crate::common::column_f64(&summary, rs::TIME_SCALE.name);
    assert_eq!(lam.len(), 10, "the design's 10 candidate λ");
    let table = quaketwin::sinks::parquet::ReadTable::open(&summary).unwrap();
    let meta = table.metadata("quaketwin.recommendation").unwrap();
    let rec: serde_json::Value = serde_json::from_str(meta).unwrap();
    let best = rec["time_scale"].as_f64().expect("a recommended λ");
    let batch = &table.batches[0];
    let col = |name: &str| batch.column_by_name(name).unwrap().clone();
    let stable = col(rs::STABLE.name);
    let stable = stable
        .as_any()
        .downcast_ref::<arrow_array::BooleanArray>()
        .unwrap();
    let wn = col(rs::RESPONSE_WNRMSE.name);
    let wn = wn
        .as_any()
        .downcast_ref::<arrow_array::Float64Array>()
        .unwrap();
    // Small λ diverge (the prototype's top mode far outside the actuator band), the
    // recommended one is stable and accurate, and so is every larger λ.
    assert!(!stable.value(0), "λ = {} should diverge", lam[0]);
    let k = lam.iter().position(|&l| l == best).unwrap();
    for (i, l) in lam.iter().enumerate().skip(k) {
        assert!(stable.value(i), "λ = {l} should be stable");
        assert!(wn.value(i) <= 0.05, "λ = {l}: WNRMSE {}", wn.value(i));
    }
    let t = crate::common::column_f64(
        &out.join("rehearsal/rehearsal.parquet"),
        rehearsal::TIME_S.name,
    );
    assert!(t.len() > 1000 && t.iter().all(|v| v.is_finite()));
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("Rehearsal of the hybrid test"));
    assert!(html.contains("Recommended time scale (smallest safe λ)"));
    assert!(
        html.contains(&format!("λ = {best} with")),
        "report names λ = {best}"
    );
}

/// `quaketwin rehearse DESIGN_OUT --out DIR` on a design run, and its errors.
#[test]
fn rehearse_command_reads_a_design_output() {
    let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let design_out = dir.path().join("design");
    let bin = env!("CARGO_BIN_EXE_quaketwin");
    let o = std::process::Command::new(bin)
        .args(["--quiet", "design"])
        .arg(root.join("sample-records/synthetic-facade/design.toml"))
        .arg("--out")
        .arg(&design_out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = dir.path().join("rehearsal");
    let o = std::process::Command::new(bin)
        .args(["--quiet", "rehearse"])
        .arg(&design_out)
        .arg("--out")
        .arg(&out)
        .args([
            "--scheme",
            "central-difference",
            "--time-scales",
            "500,1000",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let lam = crate::common::column_f64(
        &out.join("rehearsal_summary/rehearsal_summary.parquet"),
        quaketwin::vocab::tables::rehearsal_summary::TIME_SCALE.name,
    );
    assert_eq!(lam, vec![500.0, 1000.0]);
    // The facade's design has gravity and force-controlled actuators: pre-load on by default,
    // its vertical force (along the twin's gravity, −y: `uy`) recorded.
    let table = quaketwin::sinks::parquet::ReadTable::open(
        &out.join("rehearsal_summary/rehearsal_summary.parquet"),
    )
    .unwrap();
    let meta = table.metadata("quaketwin.gravity").unwrap();
    eprintln!("facade gravity: {meta}");
    let g: serde_json::Value = serde_json::from_str(meta).unwrap();
    assert_eq!(g["preload"], true, "{meta}");
    assert_eq!(g["direction"], "uy", "{meta}");
    let fc = g["force_controlled_n"].as_f64().unwrap();
    let v = g["vertical_force_n"].as_f64().unwrap();
    assert!(
        fc.is_finite() && fc != 0.0 && v.is_finite() && v != 0.0,
        "{meta}"
    );
    // A directory without a design: exit 1 naming the file; a bad scheme: usage, exit 2.
    let o = std::process::Command::new(bin)
        .args(["rehearse"])
        .arg(dir.path())
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("rehearsal_model.json"), "{err}");
    let o = std::process::Command::new(bin)
        .args(["rehearse"])
        .arg(&design_out)
        .arg("--out")
        .arg(&out)
        .args(["--scheme", "euler"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--scheme euler"));
}

/// A rehearse stage whose params change re-runs alone: the design stage is skipped as up to
/// date and its product, the rehearsal model, is read back from `rehearsal_model.json`. Bad
/// params are usage errors when the pipeline file is read.
#[test]
fn rehearse_stage_reruns_from_the_restored_rehearsal_model() {
    use quaketwin::pipeline::{self, StageOutcome};
    let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let event = root.join("sample-records/synthetic-facade");
    let text = std::fs::read_to_string(root.join("pipelines/test-design.toml")).unwrap();
    let few = text.replace(
        "delay_s = 0.005\n",
        "delay_s = 0.005\ntime_scales = [500.0, 1000.0]\n",
    );
    let p = quaketwin::stages::parse_pipeline(&few, "test-design.toml").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    pipeline::run(&p, &event, &out, true).unwrap();
    let first = std::fs::read(out.join("rehearsal_summary/rehearsal_summary.parquet")).unwrap();
    let one = few.replace("[500.0, 1000.0]", "[1000.0]");
    let p1 = quaketwin::stages::parse_pipeline(&one, "test-design.toml").unwrap();
    let outcomes = pipeline::run(&p1, &event, &out, true).unwrap();
    let of = |name: &str| outcomes.iter().find(|(n, _)| n == name).unwrap().1.clone();
    assert_eq!(of("design"), StageOutcome::Skipped);
    assert!(
        matches!(of("rehearse"), StageOutcome::Ran { .. }),
        "{outcomes:?}"
    );
    let lam = crate::common::column_f64(
        &out.join("rehearsal_summary/rehearsal_summary.parquet"),
        quaketwin::vocab::tables::rehearsal_summary::TIME_SCALE.name,
    );
    assert_eq!(lam, vec![1000.0]);
    // Back to the first settings: the same bytes as the run that had the model in memory.
    let outcomes = pipeline::run(&p, &event, &out, true).unwrap();
    assert!(outcomes
        .iter()
        .any(|(n, o)| n == "rehearse" && matches!(o, StageOutcome::Ran { .. })));
    assert!(
        std::fs::read(out.join("rehearsal_summary/rehearsal_summary.parquet")).unwrap() == first
    );
    // Bad params: usage errors naming the key, when the file is read.
    for (bad, key) in [
        ("scheme = \"euler\"", "euler"),
        ("alpha = -0.9", "alpha"),
        ("lag = 1", "lag"),
    ] {
        let t = text.replace("scheme = \"alpha-os\"", bad);
        let e = quaketwin::stages::parse_pipeline(&t, "test-design.toml").unwrap_err();
        assert_eq!(e.exit_code(), 2, "{e}");
        assert!(e.to_string().contains(key), "{e}");
    }
}

/// The Bouc–Wen specimen: linear for motions far below u_y, bounded hysteretic force and
/// dissipated energy beyond; a nonlinear rehearsal with it stays stable under α-OS.
#[test]
fn rehearse_bouc_wen_specimen_is_hysteretic_and_bounded() {
    use quaketwin::rehearse::specimen::SpecimenModel;
    use quaketwin::rehearse::BoucWenSpring;
    let (k, uy, alpha) = (2.0e5, 1e-3, 0.1);
    let spring = BoucWenSpring {
        yield_displacement_m: uy,
        post_yield_ratio: alpha,
        beta: 0.5,
        gamma: 0.5,
        n: 2.0,
    };
    // Cycles of amplitude 10 u_y: r − α k d = (1 − α) k u_y z with |z| ≤ (β + γ)^(−1/n) = 1.
    let mut s = SpecimenModel::new(vec![k], 1, Some(spring.clone()));
    let (mut r, mut work, mut last_d, mut last_r) = ([0.0], 0.0, 0.0, 0.0);
    for i in 0..=4000 {
        let d = 10.0 * uy * (2.0 * std::f64::consts::PI * i as f64 / 1000.0).sin();
        s.force(&[d], &mut r);
        let hysteretic = r[0] - alpha * k * d;
        assert!(
            hysteretic.abs() <= (1.0 - alpha) * k * uy * (1.0 + 1e-9),
            "{i}: {r:?}"
        );
        work += 0.5 * (r[0] + last_r) * (d - last_d);
        (last_d, last_r) = (d, r[0]);
    }
    assert!(work > 0.0, "a hysteretic loop dissipates: {work}");
    // Far below u_y the spring is the linear specimen (z ≈ d/u_y).
    let mut lin = SpecimenModel::new(
        vec![k],
        1,
        Some(BoucWenSpring {
            yield_displacement_m: 1e3,
            ..spring.clone()
        }),
    );
    lin.force(&[1e-3], &mut r);
    assert!((r[0] - k * 1e-3).abs() <= 1e-9 * k * 1e-3, "{r:?}");

    // A nonlinear rehearsal of the hand-made prototype (peak interface displacement ≈ 5 cm,
    // u_y = 1 cm): stable at λ = 1000 and farther from the linear twin than the linear run.
    let model = two_oscillator_model();
    let linear = RehearseSettings {
        time_scales: vec![1000.0],
        ..settings(Scheme::AlphaOs)
    };
    let nonlinear = RehearseSettings {
        bouc_wen: Some(BoucWenSpring {
            yield_displacement_m: 0.01,
            ..spring
        }),
        ..linear.clone()
    };
    let a = &rehearse(&model, &linear).unwrap().runs[0];
    let b = &rehearse(&model, &nonlinear).unwrap().runs[0];
    assert!(b.stable, "{b:?}");
    assert!(
        b.response_wnrmse.unwrap() > 10.0 * a.response_wnrmse.unwrap(),
        "{a:?} {b:?}"
    );
}
