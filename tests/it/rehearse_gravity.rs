//! Gravity pre-load of a rehearsal (issue 16): the hand-made prototype of `rehearse.rs` hung
//! vertically from its specimen spring. Its gravity load is f̂_g = −g ψᵀ M r =
//! −g (√m₁, √m₂, m₁ + m₂ + m_P) (the loads of a base acceleration along the actuated axis),
//! so the static state (Eq. G1) puts the whole weight on the specimen:
//! r_g = k_P q_g = −g (m₁ + m₂ + m_P), exactly.

use quaketwin::rehearse::{rehearse, BoucWenSpring, RehearseSettings, Scheme};

use crate::rehearse::{settings, two_oscillator_model};

/// The prototype with gravity g (m/s², downward along the actuated axis) and a
/// force-controlled actuator.
fn hanging(g: f64) -> quaketwin::rehearse::RehearsalModel {
    let mut model = two_oscillator_model();
    model.gravity = true;
    model.gravity_load = model.loads[0].iter().map(|b| -g * b).collect();
    model.actuators[0].control_mode = "force".into();
    model
}

#[test]
fn rehearse_gravity_preload_carries_the_weight_and_leaves_the_linear_error_unchanged() {
    let weight = -9.81 * (1000.0 + 1.0 + 1.0);
    let model = hanging(9.81);
    for scheme in [Scheme::AlphaOs, Scheme::CentralDifference] {
        let on = RehearseSettings {
            time_scales: vec![1000.0],
            ..settings(scheme)
        };
        // Default: on (the design has gravity and a force-controlled actuator).
        let a = rehearse(&model, &on).unwrap();
        let p = a.preload.as_ref().expect("pre-load applied by default");
        assert!(
            (p.force_controlled_n - weight).abs() <= 1e-9 * weight.abs(),
            "{p:?}"
        );
        assert_eq!(p.vertical_n, p.force_controlled_n);
        // The histories start from the static state: the load cell reads the weight.
        assert!((a.histories.force[0][0] - weight).abs() <= 1e-9 * weight.abs());
        let off = RehearseSettings {
            gravity: Some(false),
            ..on.clone()
        };
        let b = rehearse(&model, &off).unwrap();
        assert!(b.preload.is_none());
        let (wa, wb) = (
            a.runs[0].response_wnrmse.unwrap(),
            b.runs[0].response_wnrmse.unwrap(),
        );
        eprintln!("{scheme:?}: WNRMSE with pre-load {wa}, without {wb}");
        // Linear specimen: superposition, the seismic error is unchanged (rounding only).
        assert!((wa - wb).abs() <= 1e-6 * wb, "{wa} vs {wb}");
        assert!(wb > 1e-4, "the comparison is not trivial: {wb}");
        let (ea, eb) = (a.runs[0].energy_error, b.runs[0].energy_error);
        assert!((ea - eb).abs() <= 1e-6 * eb.max(1e-12), "{ea} vs {eb}");
    }
}

#[test]
fn rehearse_gravity_preload_shifts_a_hysteretic_specimen() {
    // g = 0.2 m/s²: q_g = −0.2 · 1002 / k_P ≈ −5 mm = u_y / 2, the spring partly yielded
    // before the earthquake.
    let model = hanging(0.2);
    let s = RehearseSettings {
        time_scales: vec![1000.0],
        bouc_wen: Some(BoucWenSpring {
            yield_displacement_m: 0.01,
            post_yield_ratio: 0.1,
            beta: 0.5,
            gamma: 0.5,
            n: 2.0,
        }),
        ..settings(Scheme::AlphaOs)
    };
    let a = rehearse(&model, &s).unwrap();
    let b = rehearse(
        &model,
        &RehearseSettings {
            gravity: Some(false),
            ..s.clone()
        },
    )
    .unwrap();
    let (wa, wb) = (
        a.runs[0].response_wnrmse.unwrap(),
        b.runs[0].response_wnrmse.unwrap(),
    );
    eprintln!("Bouc–Wen: WNRMSE with pre-load {wa}, without {wb}");
    assert!(a.runs[0].stable && b.runs[0].stable);
    assert!((wa - wb).abs() > 0.01 * wb, "{wa} vs {wb}");
}

#[test]
fn rehearse_gravity_refused_without_a_gravity_load() {
    let model = two_oscillator_model();
    let s = RehearseSettings {
        gravity: Some(true),
        time_scales: vec![1000.0],
        ..settings(Scheme::AlphaOs)
    };
    let e = rehearse(&model, &s).unwrap_err().to_string();
    assert!(e.contains("gravity"), "{e}");
    // Default off without a gravity state.
    let r = rehearse(&model, &RehearseSettings { gravity: None, ..s }).unwrap();
    assert!(r.preload.is_none());
}
