//! Quasi-direct instantaneous identification of the degrading Bouc-Wen chain,
//! DoF by DoF from the top (Table 15; Eq. 6–20, 27–31 of METHODS.md §4).
//!
//! For one DoF and a trial exponent N the unknowns enter linearly: per STFT
//! frame j the products G_j (Eq. 15 integrated over the band) are formed, the
//! cumulative sums H(t_j) = Σ_{j' ≤ j} G_j' and b(t_j) (Eq. 20) give one bounded
//! least-squares problem per frame (Eq. 19 under Eq. 47). The last frame is the
//! scalar estimate (t = te); earlier frames are the instantaneous (cumulative)
//! estimates. J(N) (Eq. 31) is the weighted residual at the solution.
//!
//! N search on [N_min, N_max] at `exponent_resolution`: a coarse grid (J is
//! not convex in N), then the best `refine_candidates` local minima are
//! refined by successively finer grids (steps ÷5) down to the resolution.
//! Every trial N is cached; trial batches run in parallel (rayon).
//! The scalar parameters at the chosen N are re-solved on the weighted design
//! matrix by QR (same problem, better conditioned than the normal equations).
//!
//! The parts: [`super::settings`], [`super::dof`] (one DoF), the N search of
//! `exponent_search`, [`super::instantaneous`] and [`super::significance`].

use rayon::prelude::*;

use crate::error::{Error, Result};

use super::basis::{
    cumulative_cubic, hysteretic_rate, BasisForm, DirectionKinematics, DirectionRecords,
    DofParameters, DofProblem,
};
use super::damage::{damage_index, DamageSeries};
use super::dof::{identify_dof, DofIdentification};
use super::settings::{validate_settings, IdentifySettings};
use super::stft::{FrameTransformer, StftLayout, Transform};
use crate::vocab::ProcessingHistory;

/// Result of one direction.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionIdentification {
    pub direction: String,
    pub sampling_rate_hz: f64,
    /// Time of the first sample identified from the record's start, s (the
    /// identification window's start, `super::window`); the times of
    /// `damage`, of the instantaneous estimates and of `hysteresis_fit/hysteresis_fit.parquet`
    /// count from the record's start.
    pub start_s: f64,
    pub form: BasisForm,
    pub window_len: usize,
    pub hop: usize,
    pub frames: usize,
    /// DoF 1 first.
    pub dofs: Vec<DofIdentification>,
    /// Full symmetric K0 (unidentified couplings of `Tridiagonal` are 0).
    pub k0_matrix: Vec<Vec<f64>>,
    /// Full K0∘δ (antisymmetric off the diagonal).
    pub k0_delta_matrix: Vec<Vec<f64>>,
    pub masses: Vec<f64>,
    /// Segment of each DoF (`L0-L1`, `L1-L3`…: from the instrumented level
    /// below to the DoF's own); `L<d−1>-L<d>` unless the caller knows the levels.
    pub segments: Vec<String>,
    pub damage: DamageSeries,
    /// Declared processing plus this stage's steps and settings.
    pub processing: ProcessingHistory,
}

/// Identifies one direction from its records (Table 15, steps A–C).
pub fn identify_direction(
    records: &DirectionRecords,
    settings: &IdentifySettings,
) -> Result<DirectionIdentification> {
    validate_settings(settings)?;
    let kin =
        DirectionKinematics::from_records(records, settings.min_samples, settings.velocity_drift)?;
    identify_kinematics(&kin, &records.direction, settings)
}

/// Identifies several directions in parallel (they are independent, Ch. 4.2).
pub fn identify_directions(
    records: &[DirectionRecords],
    settings: &IdentifySettings,
) -> Result<Vec<DirectionIdentification>> {
    records
        .par_iter()
        .map(|r| identify_direction(r, settings))
        .collect()
}

/// What the identification of one direction's kinematics found.
#[derive(Debug, Clone, PartialEq)]
pub enum KinematicsOutcome {
    /// At least one DoF has significant hysteretic terms (the others, if any,
    /// carry the nested model: `DofIdentification::hysteresis`).
    Identified(Box<DirectionIdentification>),
    /// Every DoF was tested and none has significant hysteretic terms: the
    /// test saw no hysteresis beyond the nested model. Not a finding of a
    /// linear, undamaged response (`reason` says what the test cannot see).
    NoSignificantHysteresis {
        reason: String,
        /// (F, p) of the DoF with the smallest p-value.
        f_test: Option<(f64, f64)>,
        /// Every DoF, carried by its nested model (DoF 1 first).
        dofs: Vec<DofIdentification>,
    },
}

/// What the F-test cannot see, appended to a "no significant hysteresis"
/// outcome (docs/hysteresis.md, "What the F-test can and cannot see").
pub const F_TEST_BLIND_SPOTS: &str = "this is not a finding of a linear, undamaged response: the test \
     weighs β, γ, N against a nested model that keeps the energy-driven stiffness degradation K0·δ, so a storey \
     that softened without wide loops is absorbed by K0·δ; one yielding storey inside a segment of several \
     (uninstrumented levels lumped) is diluted by its elastic storeys; and n_eff counts non-overlapping STFT \
     windows only (compare the frequency drop of the modal stage and the measured loops)";

/// Identification from already-derived kinematics; a direction without
/// significant hysteresis at any DoF is `Error::NotIdentifiable` (see
/// [`identify_kinematics_outcome`] to tell it from the other reasons).
pub fn identify_kinematics(
    kin: &DirectionKinematics,
    direction: &str,
    settings: &IdentifySettings,
) -> Result<DirectionIdentification> {
    match identify_kinematics_outcome(kin, direction, settings)? {
        KinematicsOutcome::Identified(d) => Ok(*d),
        KinematicsOutcome::NoSignificantHysteresis { reason, f_test, .. } => {
            Err(Error::NotIdentifiable {
                stage: "hysteresis".into(),
                message: reason,
                f_test,
            })
        }
    }
}

/// Identification from already-derived kinematics (Table 15): DoF by DoF
/// from the top; a DoF whose hysteretic terms are not significant carries
/// its nested model and the DoFs below are still identified, so a linear
/// upper segment does not hide a yielding lower one.
pub fn identify_kinematics_outcome(
    kin: &DirectionKinematics,
    direction: &str,
    settings: &IdentifySettings,
) -> Result<KinematicsOutcome> {
    validate_settings(settings)?;
    let fs = kin.sampling_rate_hz;
    let n = kin.samples();
    let layout = match settings.window_len {
        Some(len) => StftLayout::with_window(n, len)?,
        None => StftLayout::for_record(n)?,
    };
    if layout.frames() < 4 {
        return Err(Error::usage(format!(
            "hysteresis: only {} STFT frames; use a shorter window",
            layout.frames()
        )));
    }
    let transformer = FrameTransformer::new(&layout, settings.transform, settings.band, fs)?;
    let dofs = kin.dofs();
    let mut identified: Vec<DofIdentification> = Vec::with_capacity(dofs);
    // Table 15: from d = D down to 1; `above` holds DoFs d+1..D in order.
    for d in (0..dofs).rev() {
        let above: Vec<DofParameters> = identified
            .iter()
            .rev()
            .map(|r| r.parameters.clone())
            .collect();
        let problem = DofProblem::new(kin, d, &above, settings.form, settings.stiffness_pattern)?;
        let result = identify_dof(&problem, &transformer, settings, fs, direction)?;
        identified.push(result);
    }
    identified.reverse();
    if !identified.iter().any(|d| d.hysteresis.significant()) {
        let reasons: Vec<String> = identified
            .iter()
            .rev()
            .filter_map(|d| match &d.hysteresis {
                super::dof::HystereticTerms::NotSignificant { reason } => Some(reason.clone()),
                super::dof::HystereticTerms::Significant => None,
            })
            .collect();
        let f_test = identified
            .iter()
            .filter(|d| d.significance.denominator_dof > 0)
            .min_by(|a, b| a.significance.p_value.total_cmp(&b.significance.p_value))
            .map(|d| (d.significance.f_statistic, d.significance.p_value));
        return Ok(KinematicsOutcome::NoSignificantHysteresis {
            reason: format!(
                "direction {direction}: no significant hysteresis at any DoF, so β, γ, N are not identifiable from this record ({}); {F_TEST_BLIND_SPOTS}",
                reasons.join("; ")
            ),
            f_test,
            dofs: identified,
        });
    }
    // Frame times count from the window's start: from the record's start.
    for dof in identified.iter_mut() {
        for e in dof.instantaneous.iter_mut() {
            e.time_s += kin.start_s;
        }
        if let Some(st) = dof.stability.as_mut() {
            st.onset_s += kin.start_s;
        }
    }
    // Model adequacy: estimates unstable over time at every DoF. Seen on a
    // linear building with 40 dB noise (every DoF unstable, N at its bound).
    // Over the DoFs with significant hysteretic terms (the others have no
    // instantaneous estimates).
    if identified
        .iter()
        .filter(|f| f.hysteresis.significant())
        .all(|f| f.stability.as_ref().map(|st| !st.stable).unwrap_or(false))
    {
        return Err(Error::NotIdentifiable {
            stage: "hysteresis".into(),
            message: format!(
                "direction {direction}: the parameter estimates are unstable over time at every DoF with significant \
                 hysteretic terms (model-adequacy check): not identifiable from this record"
            ),
            f_test: None,
        });
    }
    let (k0, k0_delta) = stiffness_matrices(&identified);
    fit_restoring_forces(kin, &mut identified, &k0, &k0_delta);
    let mut damage = damage_index(
        &k0,
        &k0_delta,
        &kin.masses,
        &kin.energy_upper,
        fs,
        settings.damage_stride,
    )?;
    damage.time_s.iter_mut().for_each(|t| *t += kin.start_s);
    let processing = processing(kin, settings, &layout, fs);
    Ok(KinematicsOutcome::Identified(Box::new(
        DirectionIdentification {
            direction: direction.to_string(),
            sampling_rate_hz: fs,
            start_s: kin.start_s,
            form: settings.form,
            window_len: layout.window_len,
            hop: layout.hop,
            frames: layout.frames(),
            dofs: identified,
            k0_matrix: k0,
            k0_delta_matrix: k0_delta,
            masses: kin.masses.clone(),
            segments: (0..dofs)
                .map(|d| super::lumping::segment_label(&[d as i32, d as i32 + 1], 1))
                .collect(),
            damage,
            processing,
        },
    )))
}

/// K0 and K0∘δ of the direction (lower triangle identified, mirrored by Eq. 23 symmetry;
/// K0∘δ antisymmetric off the diagonal).
fn stiffness_matrices(identified: &[DofIdentification]) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let dofs = identified.len();
    let mut k0 = vec![vec![0.0; dofs]; dofs];
    let mut k0_delta = vec![vec![0.0; dofs]; dofs];
    for (d, dof) in identified.iter().enumerate() {
        for (i, &r) in dof.parameters.coupled.iter().enumerate() {
            k0[d][r] = dof.parameters.k0[i];
            k0[r][d] = dof.parameters.k0[i];
            k0_delta[d][r] = dof.parameters.k0_delta[i];
            if r != d {
                k0_delta[r][d] = -dof.parameters.k0_delta[i];
            }
        }
    }
    (k0, k0_delta)
}

/// Fills each DoF's `fit` with the record's restoring force, the model's along the
/// recorded kinematics (integral of Eq. 25 with every identified parameter) and the
/// inter-storey drift; and its loop energies E_rec = ∫ V_d dΔu_d (records) and
/// E_h = ∫ h_d dΔu_d (the identified hysteretic storey force h_d = ∫ BW_d dτ).
fn fit_restoring_forces(
    kin: &DirectionKinematics,
    identified: &mut [DofIdentification],
    k0: &[Vec<f64>],
    k0_delta: &[Vec<f64>],
) {
    let dofs = identified.len();
    let n = kin.samples();
    let params: Vec<DofParameters> = identified.iter().map(|d| d.parameters.clone()).collect();
    let hysteretic: Vec<Vec<f64>> = (0..dofs)
        .map(|d| cumulative_cubic(&hysteretic_rate(kin, d, &params[d]), kin.dt()))
        .collect();
    for d in 0..dofs {
        let mut force = vec![0.0; n];
        for r in 0..dofs {
            let rate: Vec<f64> = (0..n)
                .map(|k| -kin.energy(d, r, k) * kin.relative_velocity[r][k])
                .collect();
            let degradation = cumulative_cubic(&rate, kin.dt());
            for k in 0..n {
                force[k] +=
                    k0[d][r] * kin.relative_displacement[r][k] + k0_delta[d][r] * degradation[k];
            }
        }
        for k in 0..n {
            force[k] += hysteretic[d][k]
                - if d + 1 < dofs {
                    hysteretic[d + 1][k]
                } else {
                    0.0
                };
        }
        let drift = kin.storey_drift(d);
        identified[d].energy_record_j = super::energy::work(&kin.storey_shear[d], &drift);
        identified[d].energy_hysteretic_j = if identified[d].hysteresis.significant() {
            super::energy::work(&hysteretic[d], &drift)
        } else {
            0.0
        };
        identified[d].fit.force_model = force;
        identified[d].fit.force_record = kin.restoring_force[d].clone();
        identified[d].fit.storey_drift = drift;
    }
}

/// The stage's processing history: the kinematics' steps plus the identification settings.
fn processing(
    kin: &DirectionKinematics,
    settings: &IdentifySettings,
    layout: &StftLayout,
    fs: f64,
) -> ProcessingHistory {
    let mut processing = kin.processing.clone();
    processing.push(
        "hysteresis_identification",
        serde_json::json!({
            "form": settings.form.name(),
            "transform": match settings.transform { Transform::Parseval => "parseval_time_domain", Transform::Fft => "fft" },
            "band_hz": [settings.band.low_hz, if settings.band.high_hz.is_finite() { settings.band.high_hz } else { fs / 2.0 }],
            "window": "symmetric hamming",
            "window_len": layout.window_len,
            "hop": layout.hop,
            "frames": layout.frames(),
            "exponent_range": [settings.exponent_min, settings.exponent_max],
            "exponent_resolution": settings.exponent_resolution,
            "coarse_step": settings.coarse_step,
            "constraints": "K0_dd >= 0, beta >= 0, -beta <= gamma <= beta (Eq. 47)",
        }),
    );
    processing
}
