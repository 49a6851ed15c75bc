//! The thesis's instantaneous time–frequency Bouc–Wen identification
//! (METHODS.md §4, Eq. 15–31; `crate::hysteresis`) run on a dynamic lab
//! record's measured (displacement, force): the specimen is one DoF of unit
//! mass whose restoring force is the measured force
//! (`DirectionKinematics::from_specimen`), so Eq. 46 needs no mass and no
//! acceleration and the force equation (Eq. 23b–c) is identified directly:
//!
//!   Ḟ = K0 (1 − δ ε) u̇ − |F|^N (β |u̇| sgn F + γ u̇),  ε = ∫ F u̇ dt.
//!
//! Nothing is re-implemented: the STFT products, the N search, the bounded
//! least squares, the F-test of the hysteretic terms, the instantaneous
//! estimates and the model force are `crate::hysteresis::identify_kinematics_outcome`'s.
//! Only a uniform time base is accepted (the STFT needs one). The thesis's
//! model-adequacy check (estimates unstable over time → not identifiable) is
//! reported here, not enforced: a specimen has a single DoF, and the check
//! would otherwise discard the only fit (`stable` says what it found).

use crate::error::{Error, Result};
use crate::hysteresis::{
    identify_kinematics_outcome, BasisForm, DirectionKinematics, FrequencyBand, IdentifySettings,
    KinematicsOutcome, StftLayout,
};

use super::loops::{cycle_energies, nrmse, CycleEnergy};
use super::ParameterEstimate;

/// Relative spread above which an instantaneous estimate is called unstable
/// (the thesis's default `IdentifySettings::stability_threshold`).
pub const STABILITY_THRESHOLD: f64 = 0.1;

/// The instantaneous identification of one dynamic record.
#[derive(Debug, Clone)]
pub struct InstantaneousFit {
    /// K0 (N/m), δ (1/J), β and γ (N^(1−N)/m), N; `std` is the spread
    /// (standard deviation) of the instantaneous estimates over the
    /// informative frames at the scalar N*, NaN without two informative
    /// frames — a measure of time variation, not a standard error.
    pub estimates: Vec<ParameterEstimate>,
    /// F-test of the hysteretic terms against the nested linear model
    /// (`crate::hysteresis::Significance`): F, p, n_eff.
    pub f_statistic: f64,
    pub p_value: f64,
    pub effective_samples: usize,
    /// The hysteretic terms passed the thesis's checks.
    pub significant: bool,
    /// Every relative spread ≤ [`STABILITY_THRESHOLD`] and the spread of N
    /// ≤ 10 × it (the thesis's model-adequacy indicator).
    pub stable: bool,
    /// What the checks said, in words.
    pub verdict: String,
    /// The model's force along the measured kinematics (integral of Eq. 25), N.
    pub fitted_force_n: Vec<f64>,
    pub force_nrmse: f64,
    pub cycles: Vec<CycleEnergy>,
    pub energy_error_per_cycle: Vec<f64>,
    /// Force at which the tangent stiffness of the undegraded model
    /// vanishes on loading, (K0/(β + γ))^(1/N) (N); NaN when β + γ ≤ 0.
    pub saturation_force_n: f64,
    /// ι at the end of the record (Eq. 34, one DoF): 1 − sqrt(1 − δ ε_end).
    pub damage_index_end: f64,
    pub window_len: usize,
    pub frames: usize,
}

/// Identifies a uniformly sampled record by the thesis's method.
pub fn identify_instantaneous(
    displacement_m: &[f64],
    force_n: &[f64],
    sampling_rate_hz: f64,
    cycle_band: f64,
) -> Result<InstantaneousFit> {
    if !(sampling_rate_hz > 0.0 && sampling_rate_hz.is_finite()) {
        return Err(Error::usage(format!(
            "instantaneous identification: sampling rate {sampling_rate_hz} Hz is not a positive number"
        )));
    }
    let kin = DirectionKinematics::from_specimen(displacement_m, force_n, sampling_rate_hz);
    // The integral form (Eq. 27–30): the force is measured, not a twice
    // integrated acceleration, so the form's low-frequency drift (see
    // `IdentifySettings::form`) does not arise, while the jerk form would
    // differentiate the measured force (and its quantisation). The DC bin is
    // left out of Eq. 20 so that a force offset at the start of the record
    // (a hysteretic force already present, a load cell's zero) does not
    // enter: within each window the mean is projected out of every column.
    let layout = StftLayout::for_record(kin.samples())?;
    let bin_hz = sampling_rate_hz / layout.window_len as f64;
    let settings = IdentifySettings {
        form: BasisForm::Integral,
        band: FrequencyBand::above(0.5 * bin_hz),
        // Reported, not enforced (module doc).
        stability_threshold: f64::INFINITY,
        damage_stride: 64,
        ..IdentifySettings::default()
    };
    let (dof, damage_end, window_len, frames) =
        match identify_kinematics_outcome(&kin, "specimen", &settings)? {
            KinematicsOutcome::Identified(d) => {
                let end = d.damage.iota.last().copied().unwrap_or(f64::NAN);
                let (window_len, frames) = (d.window_len, d.frames);
                let dof = d.dofs.into_iter().next().ok_or_else(|| {
                    Error::numerical("instantaneous identification: no DoF identified")
                })?;
                (dof, end, window_len, frames)
            }
            KinematicsOutcome::NoSignificantHysteresis { reason, .. } => {
                return Err(Error::NotIdentifiable {
                    stage: "lab_hysteresis".into(),
                    message: reason,
                    f_test: None,
                })
            }
        };
    let k0 = dof.k0[0];
    let delta = dof.delta[0];
    let spread = |rel: Option<f64>, value: f64| rel.map_or(f64::NAN, |r| r * value.abs());
    let st = dof.stability.as_ref();
    let estimates = vec![
        estimate(
            "initial_stiffness_n_per_m",
            k0,
            spread(st.map(|s| s.k0_rel_std[0]), k0),
            "N/m",
        ),
        estimate(
            "stiffness_degradation_per_j",
            delta,
            spread(st.map(|s| s.k0_delta_rel_std[0]), delta),
            "1/J",
        ),
        estimate(
            "beta",
            dof.beta,
            spread(st.map(|s| s.beta_rel_std), dof.beta),
            "N^(1-N)/m",
        ),
        estimate(
            "gamma",
            dof.gamma,
            spread(st.map(|s| s.gamma_rel_std), dof.gamma),
            "N^(1-N)/m",
        ),
        estimate(
            "n",
            dof.exponent,
            st.map_or(f64::NAN, |s| s.exponent_std),
            "1",
        ),
    ];
    let stable = st.is_some_and(|s| {
        s.k0_rel_std
            .iter()
            .chain(&s.k0_delta_rel_std)
            .chain([&s.beta_rel_std, &s.gamma_rel_std])
            .all(|v| *v <= STABILITY_THRESHOLD)
            && s.exponent_std <= 10.0 * STABILITY_THRESHOLD
    });
    let sig = &dof.significance;
    let verdict = format!(
        "hysteretic terms {} (F = {:.3} on ({}, {}) dof, p = {:.2e}, n_eff = {} non-overlapping windows); instantaneous estimates {} over {} informative frames",
        if dof.hysteresis.significant() { "significant" } else { "not significant" },
        sig.f_statistic,
        sig.numerator_dof,
        sig.denominator_dof,
        sig.p_value,
        sig.effective_samples,
        if stable { "stable" } else { "unstable (spread above 10 %)" },
        st.map_or(0, |s| s.informative_frames),
    );
    let fitted = dof.fit.force_model;
    let cycles = cycle_energies(displacement_m, force_n, &fitted, cycle_band);
    let saturation = if dof.beta + dof.gamma > 0.0 && k0 > 0.0 {
        (k0 / (dof.beta + dof.gamma)).powf(1.0 / dof.exponent)
    } else {
        f64::NAN
    };
    Ok(InstantaneousFit {
        estimates,
        f_statistic: sig.f_statistic,
        p_value: sig.p_value,
        effective_samples: sig.effective_samples,
        significant: dof.hysteresis.significant(),
        stable,
        verdict,
        force_nrmse: nrmse(force_n, &fitted),
        energy_error_per_cycle: cycles.iter().map(CycleEnergy::relative_error).collect(),
        cycles,
        fitted_force_n: fitted,
        saturation_force_n: saturation,
        damage_index_end: damage_end,
        window_len,
        frames,
    })
}

fn estimate(name: &'static str, value: f64, std: f64, units: &'static str) -> ParameterEstimate {
    ParameterEstimate {
        name,
        value,
        std,
        units,
        fixed: false,
    }
}
