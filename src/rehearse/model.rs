//! The hybrid system a rehearsal runs: the Craig–Bampton prototype split into its numerical
//! part and the specimen (PS) seen through the actuators, the base-excitation loads, the
//! design's base motion and the full twin's reference at the actuated DoFs.
//!
//! Coordinates x = [η_1 … η_s, q_1 … q_m, q_r…] (Eq. 60–68): NS fixed-interface modal
//! amplitudes, the m actuated (master) DoFs, the PS rigid-body amplitudes. The prototype's
//! stiffness splits as K̂ = K̂_N + L K_P Lᵀ, where L selects the actuated coordinates and
//! K_P = T_mᵀ K_PS T_m is the specimen's stiffness condensed onto them (T_m: the actuated
//! columns of the PS basis u_PS = T q, Eq. 85–87; the rigid columns carry no PS stiffness).
//! In the laboratory K_P q_m is the force the actuators measure; the rest of K̂ and all of M̂,
//! Ĉ = a0 M̂ + a1 K̂ are numerical (PsD testing: inertia and damping computed).
//!
//! Dropping NS modes: the columns of ψ are the NS modes in ascending order, then the PS
//! coordinates, and the constraint modes do not depend on the number of NS modes, so the
//! prototype with s' < s modes is the principal submatrix without rows/columns s'..s.

use faer::Mat;
use serde::{Deserialize, Serialize};

use crate::design::craig_bampton::HybridSettings;
use crate::design::plan::{BaseMotion, TestDesign};
use crate::error::{Error, Result};
use crate::twin::eigen::dense_modes;
use crate::twin::newmark::{newmark_base_excitation, NewmarkSettings};
use crate::twin::Twin;

/// Schema tag of `rehearsal_model.json`.
pub const MODEL_SCHEMA: &str = "quaketwin.rehearsal_model/1";

/// One actuated DoF of the design.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActuatedDof {
    pub actuator: usize,
    pub node_id: i64,
    pub direction: String,
    /// `displacement` or `force` (the design's control mode).
    pub control_mode: String,
    /// Nominal gravity force (N), 0 without gravity.
    pub nominal_force_n: f64,
}

/// Everything a rehearsal needs (the design stage writes it as `rehearsal_model.json`).
/// Matrices are row-major `Vec<Vec<f64>>`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RehearsalModel {
    pub schema: String,
    /// NS fixed-interface modes of the prototype (its first coordinates).
    pub ns_modes: usize,
    pub actuators: Vec<ActuatedDof>,
    /// K̂, M̂ of the prototype (n_c × n_c).
    pub stiffness: Vec<Vec<f64>>,
    pub mass: Vec<Vec<f64>>,
    /// K_P: the specimen's stiffness at the actuated coordinates (m × m).
    pub ps_stiffness: Vec<Vec<f64>>,
    /// Rayleigh coefficients (a0, a1): Ĉ = a0 M̂ + a1 K̂.
    pub rayleigh: [f64; 2],
    /// Base motion: step (s), per component the twin axis, the reduced load ψᵀ b (the
    /// effective force is −Σ_d ψᵀ b_d a_d(t)) and the accelerations (m/s²).
    pub dt: f64,
    pub axes: Vec<usize>,
    pub loads: Vec<Vec<f64>>,
    pub accelerations: Vec<Vec<f64>>,
    /// Rows of ψ at the actuated PS DoFs (m × n_c): their total displacement relative to
    /// the base (actuated deformation plus rigid-body motion).
    pub observation: Vec<Vec<f64>>,
    /// The full twin's displacement at the actuated DoFs (m × steps, at the motion's steps).
    pub reference: Vec<Vec<f64>>,
    /// Newmark steps per motion step of that reference (see [`fine_reference`]).
    pub reference_substeps: usize,
    /// Prototype eigenfrequencies (Hz), the design's actuator band, recommended λ and
    /// candidate λ.
    pub frequencies_hz: Vec<f64>,
    pub actuator_band_hz: f64,
    pub time_scale: f64,
    pub time_scales: Vec<f64>,
    /// Whether the design includes the gravity state (nominal forces).
    pub gravity: bool,
    /// The prototype's gravity load f̂_g = ψᵀ f_g (n_c; f_g the twin's gravity load, its
    /// gravity vector the vertical; `gravity::static_state`); empty without gravity.
    #[serde(default)]
    pub gravity_load: Vec<f64>,
    /// The actuator direction (`ux`, `uy`, `uz`) along the twin's gravity vector (its
    /// largest component): the vertical; empty without gravity.
    #[serde(default)]
    pub gravity_direction: String,
    /// Where the base motion came from.
    pub motion_source: String,
}

fn rows(m: &Mat<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| (0..m.ncols()).map(|j| m[(i, j)]).collect())
        .collect()
}

/// Dense matrix from rows (checked square/consistent by [`RehearsalModel::validate`]).
pub fn mat(rows: &[Vec<f64>]) -> Mat<f64> {
    let n = rows.len();
    let c = rows.first().map(|r| r.len()).unwrap_or(0);
    Mat::from_fn(n, c, |i, j| rows[i][j])
}

impl RehearsalModel {
    /// The rehearsal model of a design: the recommended prototype, its loads ψᵀ b under
    /// `motion`, the specimen's condensed stiffness and the reference at the actuated DoFs;
    /// `hybrid`: the design's `[hybrid]` settings (actuator band, candidate λ).
    pub fn from_design(
        twin: &Twin,
        design: &TestDesign,
        motion: &BaseMotion,
        hybrid: &HybridSettings,
    ) -> Result<Self> {
        let proto = &design.hybrid.prototype;
        let psi = &proto.basis;
        let s = proto.ns_modes;
        let n_m = design.actuators.len();
        let nc = psi.ncols();
        let ps_basis = &design.interface.map * &design.basis.transformation;
        if ps_basis.ncols() + s != nc || n_m > ps_basis.ncols() {
            return Err(Error::numerical(
                "rehearsal model: the PS basis does not match the prototype",
            ));
        }
        let t_m = ps_basis.subcols(0, n_m);
        let k_p = t_m.transpose() * &design.partition.ps_stiffness * t_m;
        let mut loads = Vec::new();
        let mut axes = Vec::new();
        for c in &motion.components {
            let e = twin
                .system
                .base_excitation(&[], c.axis, c.acceleration.clone())?;
            let b = Mat::from_fn(e.load.len(), 1, |i, _| e.load[i]);
            let reduced = psi.transpose() * &b;
            loads.push((0..nc).map(|i| reduced[(i, 0)]).collect());
            axes.push(c.axis);
        }
        let observation = design
            .actuators
            .iter()
            .map(|a| {
                (0..nc)
                    .map(|j| {
                        if j < s {
                            0.0
                        } else {
                            ps_basis[(a.ps_position, j - s)]
                        }
                    })
                    .collect()
            })
            .collect();
        let (reference, reference_substeps) = fine_reference(twin, design, motion, hybrid)?;
        let gravity = design.actuators.iter().any(|a| a.nominal_force != 0.0);
        let g = twin.system.gravity;
        let vertical = (0..3).fold(0, |b, i| if g[i].abs() > g[b].abs() { i } else { b });
        let gravity_direction = if gravity && g[vertical] != 0.0 {
            ["ux", "uy", "uz"][vertical].to_string()
        } else {
            String::new()
        };
        let gravity_load = if gravity {
            let fg = twin.system.gravity_load(&[]);
            let reduced = psi.transpose() * Mat::from_fn(fg.len(), 1, |i, _| fg[i]);
            (0..nc).map(|i| reduced[(i, 0)]).collect()
        } else {
            Vec::new()
        };
        let h = &design.hybrid;
        Ok(RehearsalModel {
            schema: MODEL_SCHEMA.into(),
            ns_modes: s,
            actuators: design
                .actuators
                .iter()
                .map(|a| ActuatedDof {
                    actuator: a.actuator,
                    node_id: a.node_id,
                    direction: a.direction.clone(),
                    control_mode: a.control.name().into(),
                    nominal_force_n: a.nominal_force,
                })
                .collect(),
            stiffness: rows(&proto.stiffness),
            mass: rows(&proto.mass),
            ps_stiffness: rows(&k_p),
            rayleigh: [design.rayleigh.0, design.rayleigh.1],
            dt: motion.dt,
            axes,
            loads,
            accelerations: motion
                .components
                .iter()
                .map(|c| c.acceleration.clone())
                .collect(),
            observation,
            reference,
            reference_substeps,
            frequencies_hz: proto.frequencies_hz.clone(),
            actuator_band_hz: hybrid.actuator_band_hz,
            time_scale: h.time_scale,
            time_scales: hybrid.time_scales.clone(),
            gravity,
            gravity_load,
            gravity_direction,
            motion_source: motion.source.clone(),
        })
    }

    pub fn n_coordinates(&self) -> usize {
        self.stiffness.len()
    }

    pub fn steps(&self) -> usize {
        self.accelerations.first().map(|a| a.len()).unwrap_or(0)
    }

    /// Checks shapes and values; `source` names the file in errors.
    pub fn validate(&self, source: &str) -> Result<()> {
        let bad = |what: String| Err(Error::usage(format!("{source}: {what}")));
        if self.schema != MODEL_SCHEMA {
            return bad(format!(
                "schema `{}`, expected `{MODEL_SCHEMA}`",
                self.schema
            ));
        }
        let n = self.n_coordinates();
        let m = self.actuators.len();
        let square = |a: &[Vec<f64>], k: usize| a.len() == k && a.iter().all(|r| r.len() == k);
        if n == 0 || !square(&self.stiffness, n) || !square(&self.mass, n) {
            return bad("`stiffness` and `mass` must be square and of the same size".into());
        }
        if m == 0 || !square(&self.ps_stiffness, m) || self.ns_modes + m > n {
            return bad(format!(
                "`ps_stiffness` must be {m} × {m} (one row per actuator) and fit the prototype"
            ));
        }
        if self.loads.len() != self.accelerations.len()
            || self.loads.len() != self.axes.len()
            || self.loads.is_empty()
            || self.loads.iter().any(|l| l.len() != n)
        {
            return bad("`loads`, `axes` and `accelerations` must have one entry per base component, each load of the prototype's size".into());
        }
        let steps = self.steps();
        if steps < 2 || self.accelerations.iter().any(|a| a.len() != steps) {
            return bad("base components must have the same number (≥ 2) of samples".into());
        }
        if self.observation.len() != m || self.observation.iter().any(|r| r.len() != n) {
            return bad("`observation` must have one row per actuator over the prototype".into());
        }
        if self.reference.len() != m || self.reference.iter().any(|r| r.len() != steps) {
            return bad(
                "`reference` must have one history per actuator, one value per step".into(),
            );
        }
        if ![self.dt, self.actuator_band_hz, self.time_scale]
            .into_iter()
            .all(super::positive)
        {
            return bad("`dt`, `actuator_band_hz` and `time_scale` must be positive".into());
        }
        if !self.gravity_load.is_empty() && self.gravity_load.len() != n {
            return bad("`gravity_load` must be empty or of the prototype's size".into());
        }
        let finite = |a: &[Vec<f64>]| a.iter().flatten().all(|v| v.is_finite());
        if !(finite(&self.stiffness)
            && finite(&self.mass)
            && finite(&self.ps_stiffness)
            && finite(&self.loads)
            && finite(&self.accelerations)
            && finite(&self.observation)
            && finite(&self.reference)
            && self.rayleigh.iter().all(|v| v.is_finite())
            && self.gravity_load.iter().all(|v| v.is_finite()))
        {
            return bad("non-finite values".into());
        }
        Ok(())
    }

    /// The same hybrid system with only the first `ns` NS modes (principal submatrix).
    pub fn with_ns_modes(&self, ns: usize) -> Result<RehearsalModel> {
        if ns > self.ns_modes {
            return Err(Error::usage(format!(
                "rehearsal: {ns} NS modes requested, the design's prototype has {}",
                self.ns_modes
            )));
        }
        let keep: Vec<usize> = (0..ns).chain(self.ns_modes..self.n_coordinates()).collect();
        let sub = |a: &[Vec<f64>]| -> Vec<Vec<f64>> {
            keep.iter()
                .map(|&i| keep.iter().map(|&j| a[i][j]).collect())
                .collect()
        };
        let cols = |a: &[Vec<f64>]| -> Vec<Vec<f64>> {
            a.iter()
                .map(|r| keep.iter().map(|&j| r[j]).collect())
                .collect()
        };
        let mut out = RehearsalModel {
            ns_modes: ns,
            stiffness: sub(&self.stiffness),
            mass: sub(&self.mass),
            loads: cols(&self.loads),
            observation: cols(&self.observation),
            gravity_load: if self.gravity_load.is_empty() {
                Vec::new()
            } else {
                keep.iter().map(|&j| self.gravity_load[j]).collect()
            },
            ..self.clone()
        };
        out.frequencies_hz = out.eigenfrequencies_hz()?;
        Ok(out)
    }

    /// The same hybrid system under the first `steps` samples of its base motion (and of the
    /// reference): a test logged over part of the motion is compared over that part.
    pub fn truncated(&self, steps: usize) -> Result<RehearsalModel> {
        if !(2..=self.steps()).contains(&steps) {
            return Err(Error::usage(format!(
                "rehearsal: {steps} base-motion steps requested, the design's motion has {} (at least 2 are needed)",
                self.steps()
            )));
        }
        let cut =
            |a: &[Vec<f64>]| -> Vec<Vec<f64>> { a.iter().map(|r| r[..steps].to_vec()).collect() };
        Ok(RehearsalModel {
            accelerations: cut(&self.accelerations),
            reference: cut(&self.reference),
            ..self.clone()
        })
    }

    /// Eigenfrequencies of (K̂, M̂), ascending (Hz).
    pub fn eigenfrequencies_hz(&self) -> Result<Vec<f64>> {
        let k = mat(&self.stiffness);
        let m = mat(&self.mass);
        let n = k.nrows();
        let modes = dense_modes(k.as_ref(), m.as_ref(), n).map_err(|f| {
            Error::numerical(format!("rehearsal: prototype eigenproblem failed ({f:?})"))
        })?;
        Ok(modes.frequencies_hz())
    }

    /// Highest prototype frequency (Hz).
    pub fn top_frequency_hz(&self) -> f64 {
        self.frequencies_hz.last().copied().unwrap_or(0.0)
    }
}

/// The reference of a rehearsal: the full twin's response at the actuated DoFs (Newmark,
/// average acceleration, the design's Rayleigh damping), integrated with the motion
/// linearly interpolated onto n sub-steps so that ω Δt ≤ 0.1 at the highest full-model
/// frequency inside the band of interest (period error (ωΔt)²/12 ≤ 0.1 %), sampled back at
/// the motion's steps. The design's own reference runs at the motion's step, which is enough
/// for its POD but not for a response comparison: on the facade sample (50 Hz motion,
/// f₁ = 15.8 Hz) ω₁Δt ≈ 2, a period error of about a third.
pub fn fine_reference(
    twin: &Twin,
    design: &TestDesign,
    motion: &BaseMotion,
    hybrid: &HybridSettings,
) -> Result<(Vec<Vec<f64>>, usize)> {
    let f = design
        .full_frequencies_hz
        .iter()
        .copied()
        .filter(|&f| f <= hybrid.band_of_interest_hz)
        .fold(
            design.full_frequencies_hz.first().copied().unwrap_or(0.0),
            f64::max,
        );
    let n = ((2.0 * std::f64::consts::PI * f * motion.dt / 0.1).ceil() as usize).clamp(1, 1000);
    let fine = |a: &[f64]| -> Vec<f64> {
        let mut out = Vec::with_capacity(a.len().saturating_sub(1) * n + 1);
        for w in a.windows(2) {
            out.extend((0..n).map(|j| w[0] + (w[1] - w[0]) * j as f64 / n as f64));
        }
        out.extend(a.last());
        out
    };
    let sys = &twin.system;
    let excitations = motion
        .components
        .iter()
        .map(|c| sys.base_excitation(&[], c.axis, fine(&c.acceleration)))
        .collect::<Result<Vec<_>>>()?;
    let dofs: Vec<usize> = design
        .actuators
        .iter()
        .map(|a| design.partition.ps_free[a.ps_position])
        .collect();
    let response = newmark_base_excitation(
        &sys.stiffness_at(&[]),
        &sys.mass_at(&[]),
        &excitations,
        &NewmarkSettings {
            dt: motion.dt / n as f64,
            rayleigh: design.rayleigh,
            record: Some(dofs),
        },
    )?;
    let reference = response
        .displacement
        .iter()
        .map(|h| h.iter().step_by(n).copied().collect())
        .collect();
    Ok((reference, n))
}
