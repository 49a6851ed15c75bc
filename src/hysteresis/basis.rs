//! From records to the linear-in-p problem of one DoF (METHODS.md §4):
//! relative kinematics, restoring forces (Eq. 46), energy integrals (Eq. 23d),
//! basis functions n_i(t) and the record n_e(t) in the integral form
//! (Eq. 27–30) and in the jerk form (Appendix, Eq. A7–A10).

use crate::error::{Error, Location, Result};
use crate::numeric::cumulative_trapezoid;
use crate::vocab::{Event, ProcessingHistory, Record};

use super::forward::packed_upper_index;

/// Cumulative integral from 0 with the four-point (cubic) rule: interval
/// [k, k+1] gets Δt/24 (−x[k−1] + 13x[k] + 13x[k+1] − x[k+2]) (one-sided cubic
/// weights on the first and last interval). Its gain error on a sinusoid is
/// O((ωΔt)⁴) instead of the trapezoid's (ωΔt)²/12 — at 250 Hz and 5 Hz that is
/// ~1e-5 instead of 1.6e-3 per integration, which matters because the
/// restoring force of a yielding storey is a small difference of K0·u and the
/// hysteretic integral.
pub fn cumulative_cubic(x: &[f64], dt: f64) -> Vec<f64> {
    let n = x.len();
    if n < 4 {
        return cumulative_trapezoid(x, dt);
    }
    let mut out = Vec::with_capacity(n);
    let mut acc = 0.0;
    out.push(0.0);
    for k in 0..n - 1 {
        let area = if k == 0 {
            9.0 * x[0] + 19.0 * x[1] - 5.0 * x[2] + x[3]
        } else if k + 2 >= n {
            x[k - 2] - 5.0 * x[k - 1] + 19.0 * x[k] + 9.0 * x[k + 1]
        } else {
            -x[k - 1] + 13.0 * x[k] + 13.0 * x[k + 1] - x[k + 2]
        };
        acc += dt / 24.0 * area;
        out.push(acc);
    }
    out
}

/// Central difference (one-sided at the ends) — the discrete time derivative
/// applied to the record in the jerk form.
pub fn matched_derivative(x: &[f64], dt: f64) -> Vec<f64> {
    let n = x.len();
    (0..n)
        .map(|k| match (k, n) {
            (_, 0 | 1) => 0.0,
            (0, _) => (x[1] - x[0]) / dt,
            (k, n) if k == n - 1 => (x[k] - x[k - 1]) / dt,
            (k, _) => (x[k + 1] - x[k - 1]) / (2.0 * dt),
        })
        .collect()
}

/// The averaging that the central difference of a trapezoidal integral
/// implies on its integrand: (x[k−1] + 2x[k] + x[k+1])/4 inside, (x[0] + x[1])/2
/// at the ends. Applying `matched_derivative` to the record and this to the
/// basis integrands makes both sides of A7 the same discrete operator of the
/// integral form; otherwise the difference operator's gain sin(ωΔt)/(ωΔt)
/// would bias K0 by (ωΔt)²/6 (≈ 1.6 % for a 5 Hz mode at 250 Hz).
pub fn matched_average(x: &[f64]) -> Vec<f64> {
    let n = x.len();
    (0..n)
        .map(|k| match (k, n) {
            (_, 0) => 0.0,
            (_, 1) => x[0],
            (0, _) => 0.5 * (x[0] + x[1]),
            (k, n) if k == n - 1 => 0.5 * (x[k - 1] + x[k]),
            (k, _) => 0.25 * (x[k - 1] + 2.0 * x[k] + x[k + 1]),
        })
        .collect()
}

/// Base (ground) record of one direction.
#[derive(Debug, Clone, PartialEq)]
pub struct BaseRecord {
    pub channel: String,
    /// Absolute base acceleration a(t), m/s².
    pub acceleration: Vec<f64>,
}

/// One floor (DoF) of the chain, d = 1..D from the base up.
#[derive(Debug, Clone, PartialEq)]
pub struct FloorRecord {
    pub channel: String,
    /// Absolute acceleration a + ü_d as recorded, m/s².
    pub absolute_acceleration: Vec<f64>,
    /// Lumped (possibly reduced, Eq. 35) mass of the DoF, kg.
    pub mass_kg: Option<f64>,
    /// Relative velocity u̇_d (m/s) if the caller integrated it (e.g. with its
    /// own drift control); otherwise integrated here.
    pub relative_velocity: Option<Vec<f64>>,
    /// Relative displacement u_d (m), same rule.
    pub relative_displacement: Option<Vec<f64>>,
}

/// Everything the stage needs for one horizontal direction.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionRecords {
    /// Direction label ("X", "Y", an azimuth…), used in messages and outputs.
    pub direction: String,
    /// File or event the records come from (error locations).
    pub source: String,
    pub sampling_rate_hz: f64,
    /// The base channel; `None` is reported as an input error.
    pub base: Option<BaseRecord>,
    pub floors: Vec<FloorRecord>,
    /// What the caller did to the signals before this stage (echoed in the result).
    pub declared_processing: ProcessingHistory,
}

impl DirectionRecords {
    /// Gathers one direction from an ingested event: `base_channel` (absolute
    /// ground acceleration) and `floor_channels` (DoF 1..D from the base up),
    /// converted to m/s² with each channel's units. Masses come from `masses`
    /// (one per floor, e.g. reduced masses, Eq. 35) or else from the manifest's
    /// `structure.masses_kg` at the channel's level (1-based); a floor without
    /// either is left `None` and reported by the identification.
    pub fn from_event(
        event: &Event,
        direction: &str,
        base_channel: &str,
        floor_channels: &[&str],
        masses: Option<&[f64]>,
    ) -> Result<Self> {
        Self::from_event_window(event, direction, base_channel, floor_channels, masses, None)
    }

    /// As [`DirectionRecords::from_event`], with samples `window` of every
    /// channel only (`None`: all of them; the identification window,
    /// `super::window`).  Parked samples are read a channel at a time and not
    /// kept.
    pub fn from_event_window(
        event: &Event,
        direction: &str,
        base_channel: &str,
        floor_channels: &[&str],
        masses: Option<&[f64]>,
        window: Option<std::ops::Range<usize>>,
    ) -> Result<Self> {
        let find = |id: &str| -> Result<&Record> {
            event.record(id).ok_or_else(|| {
                Error::input(
                    Location::file(event.name.clone()).with_channel(id.to_string()),
                    format!("direction {direction}: channel {id} is not in the event"),
                )
            })
        };
        let si = |record: &Record| -> Result<Vec<f64>> {
            let channel = &record.channel;
            let here = Location::file(channel.source.file.clone()).with_channel(channel.id.clone());
            let here = match &channel.source.member {
                Some(m) => here.with_member(m.clone()),
                None => here,
            };
            if !channel.units.is_acceleration() {
                return Err(Error::input(
                    here,
                    format!("units {} are not an acceleration", channel.units),
                ));
            }
            let factor = channel.units.to_si_factor().ok_or_else(|| {
                Error::input(
                    here.clone(),
                    "counts without a known sensitivity cannot be converted to m/s²",
                )
            })?;
            let range = window.clone().unwrap_or(0..record.samples.len());
            let samples = record.samples.get_range(range.start, range.len())?;
            Ok(samples.iter().map(|x| x * factor).collect())
        };
        let base = find(base_channel).ok();
        let fs = base.map(|b| b.channel.sampling_rate_hz).or_else(|| {
            floor_channels
                .first()
                .and_then(|id| event.record(id))
                .map(|r| r.channel.sampling_rate_hz)
        });
        let fs = fs.unwrap_or(0.0);
        if let Some(masses) = masses {
            if masses.len() != floor_channels.len() {
                return Err(Error::usage(format!(
                    "direction {direction}: {} masses for {} floor channels",
                    masses.len(),
                    floor_channels.len()
                )));
            }
        }
        let mut floors = Vec::with_capacity(floor_channels.len());
        for (d, id) in floor_channels.iter().enumerate() {
            let record = find(id)?;
            if (record.channel.sampling_rate_hz - fs).abs() > 1e-9 * fs {
                return Err(Error::input(
                    Location::file(record.channel.source.file.clone())
                        .with_channel(record.channel.id.clone()),
                    format!(
                        "sampling rate {} Hz differs from the base channel's {fs} Hz",
                        record.channel.sampling_rate_hz
                    ),
                ));
            }
            let mass = match masses {
                Some(m) => Some(m[d]),
                None => event.structure.as_ref().and_then(|s| {
                    let level = usize::try_from(record.channel.level?).ok()?;
                    s.masses_kg.get(level.checked_sub(1)?).copied()
                }),
            };
            floors.push(FloorRecord {
                channel: id.to_string(),
                absolute_acceleration: si(record)?,
                mass_kg: mass,
                relative_velocity: None,
                relative_displacement: None,
            });
        }
        let base = match base {
            Some(record) => Some(BaseRecord {
                channel: base_channel.to_string(),
                acceleration: si(record)?,
            }),
            None => None,
        };
        Ok(DirectionRecords {
            direction: direction.to_string(),
            source: event.name.clone(),
            sampling_rate_hz: fs,
            base,
            floors,
            declared_processing: event.history.clone(),
        })
    }
}

/// Drift control applied when this stage integrates velocities itself.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VelocityDrift {
    /// Plain trapezoidal integration from rest (synthetic or already-corrected data).
    #[default]
    None,
    /// Remove the velocity drift of a constant relative-acceleration offset c
    /// (v_drift(t) = c·t; keeps residual displacements). c is estimated from
    /// the *Hann-weighted mean* of the integrated velocity over the last 10 %
    /// of the record (≥ 16 samples), not from its last sample: the model of
    /// Eq. 21 has no viscous damping, so at small amplitude a structure keeps
    /// ringing to the end of the record and its last velocity sample is an
    /// oscillation value, not a drift. (The first version used v[n−1] and, on
    /// the noise-free yielding sample, subtracted a ramp of the size of that
    /// free vibration: N +0.065, ι ×3.5.) The Hann-weighted mean of a sinusoid
    /// spanning m cycles is ≈ 1/(π m (m² − 1)) of its amplitude, so ringing
    /// leaks negligibly while a genuine drift c·t is measured exactly.
    EndpointRamp,
}

impl VelocityDrift {
    pub fn name(&self) -> &'static str {
        match self {
            VelocityDrift::None => "none",
            VelocityDrift::EndpointRamp => "endpoint_ramp",
        }
    }
}

/// Constant relative-acceleration offset c (m/s²) that best explains the
/// velocity at the end of the record as a drift v = c·t: the Hann-weighted
/// mean of v over the last 10 % of the samples (at least 16) divided by the
/// same weighted mean of t (see `VelocityDrift::EndpointRamp`).
pub fn end_drift_rate(velocity: &[f64], dt: f64) -> f64 {
    let n = velocity.len();
    if n < 2 {
        return 0.0;
    }
    let len = (n / 10).max(16).min(n);
    let start = n - len;
    let (mut wv, mut wt) = (0.0, 0.0);
    for (i, v) in velocity[start..].iter().enumerate() {
        // Hann weights sampled at mid-points (positive on every sample).
        let w = 0.5 - 0.5 * (2.0 * std::f64::consts::PI * (i as f64 + 0.5) / len as f64).cos();
        wv += w * v;
        wt += w * (start + i) as f64 * dt;
    }
    if wt > 0.0 {
        wv / wt
    } else {
        0.0
    }
}

/// Relative kinematics and forces of one direction, all SI, `[dof][sample]`.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionKinematics {
    pub sampling_rate_hz: f64,
    /// Time of the first sample from the record's start, s: the start of the
    /// identification window (`super::window`); 0 for the whole record.
    pub start_s: f64,
    pub masses: Vec<f64>,
    pub base_acceleration: Vec<f64>,
    pub absolute_acceleration: Vec<Vec<f64>>,
    pub relative_velocity: Vec<Vec<f64>>,
    pub relative_displacement: Vec<Vec<f64>>,
    /// f_d = −m_d (a + ü_d) (Eq. 46, no viscous damping assumed).
    pub restoring_force: Vec<Vec<f64>>,
    /// Storey shear V_d = Σ_{r ≥ d} f_r.
    pub storey_shear: Vec<Vec<f64>>,
    /// Inter-storey drift rate u̇_d − u̇_{d−1} (u̇_0 = 0).
    pub drift_velocity: Vec<Vec<f64>>,
    /// ε_ab(t) = ∫ f_b u̇_a for a ≤ b, packed (`packed_upper_index`).
    pub energy_upper: Vec<Vec<f64>>,
    /// Declared processing plus the steps of this stage.
    pub processing: ProcessingHistory,
}

impl DirectionKinematics {
    pub fn dofs(&self) -> usize {
        self.masses.len()
    }
    pub fn samples(&self) -> usize {
        self.base_acceleration.len()
    }
    pub fn dt(&self) -> f64 {
        1.0 / self.sampling_rate_hz
    }
    /// Inter-storey drift u_d − u_{d−1} of DoF `d` (u_0 = 0: the base), per sample.
    pub fn storey_drift(&self, d: usize) -> Vec<f64> {
        let u = &self.relative_displacement;
        match d {
            0 => u[0].clone(),
            _ => u[d].iter().zip(&u[d - 1]).map(|(a, b)| a - b).collect(),
        }
    }
    /// Signed energy term ε_dr(t) at sample k (Eq. 23d).
    pub fn energy(&self, d: usize, r: usize, k: usize) -> f64 {
        let dofs = self.dofs();
        if d <= r {
            self.energy_upper[packed_upper_index(d, r, dofs)][k]
        } else {
            -self.energy_upper[packed_upper_index(r, d, dofs)][k]
        }
    }

    /// The kinematics of one specimen whose restoring force is measured (a
    /// laboratory test, `crate::lab::instantaneous`): one DoF of unit mass
    /// whose "absolute acceleration" is −F, so that Eq. 46 returns F itself
    /// and the storey shear is F; the base is at rest. The velocity is the
    /// central difference of the measured displacement (`matched_derivative`,
    /// the operator the jerk form applies to the record), and ε = ∫ F u̇ dt
    /// (Eq. 23d). No mass or acceleration enters: the force equation
    /// (Eq. 23b–c) is then identified on the measured force directly.
    pub fn from_specimen(displacement_m: &[f64], force_n: &[f64], sampling_rate_hz: f64) -> Self {
        let n = displacement_m.len().min(force_n.len());
        let dt = 1.0 / sampling_rate_hz;
        let velocity = matched_derivative(&displacement_m[..n], dt);
        let force = force_n[..n].to_vec();
        let power: Vec<f64> = force.iter().zip(&velocity).map(|(f, v)| f * v).collect();
        let mut processing = ProcessingHistory::default();
        processing.push(
            "hysteresis_specimen_kinematics",
            serde_json::json!({
                "rule": "one DoF of unit mass: f = measured force, u = measured displacement, u_dot = central difference of u",
            }),
        );
        DirectionKinematics {
            sampling_rate_hz,
            start_s: 0.0,
            masses: vec![1.0],
            base_acceleration: vec![0.0; n],
            absolute_acceleration: vec![force.iter().map(|f| -f).collect()],
            relative_velocity: vec![velocity.clone()],
            relative_displacement: vec![displacement_m[..n].to_vec()],
            restoring_force: vec![force.clone()],
            storey_shear: vec![force],
            drift_velocity: vec![velocity],
            energy_upper: vec![cumulative_trapezoid(&power, dt)],
            processing,
        }
    }

    /// Validates the records and derives the kinematics. Absolute floor
    /// accelerations become relative ones with the base channel (METHODS §0);
    /// velocities and displacements are integrated (trapezoid, from rest) unless
    /// supplied; every step is appended to the processing history.
    pub fn from_records(
        records: &DirectionRecords,
        min_samples: usize,
        drift: VelocityDrift,
    ) -> Result<Self> {
        let here = |channel: &str| {
            Location::file(records.source.clone()).with_channel(channel.to_string())
        };
        let direction = &records.direction;
        let fs = records.sampling_rate_hz;
        if !(fs > 0.0 && fs.is_finite()) {
            return Err(Error::input(
                Location::file(records.source.clone()),
                format!("direction {direction}: sampling rate {fs} Hz is not a positive number"),
            ));
        }
        let Some(base) = &records.base else {
            return Err(Error::input(
                Location::file(records.source.clone()),
                format!(
                    "direction {direction}: no base (input) channel; the Bouc-Wen stage needs the ground acceleration to form \
                     relative accelerations and the load −m a(t) of Eq. 21"
                ),
            ));
        };
        if records.floors.is_empty() {
            return Err(Error::input(
                here(&base.channel),
                format!("direction {direction}: no floor (output) channel to identify"),
            ));
        }
        let n = base.acceleration.len();
        if n < min_samples.max(16) {
            return Err(Error::input(
                here(&base.channel),
                format!(
                    "direction {direction}: record has {n} samples ({:.2} s); Bouc-Wen identification needs at least {}",
                    n as f64 / fs,
                    min_samples.max(16)
                ),
            ));
        }
        let check_finite = |channel: &str, what: &str, x: &[f64]| -> Result<()> {
            match x.iter().position(|v| !v.is_finite()) {
                Some(k) => Err(Error::input(
                    here(channel),
                    format!("{what}: non-finite value at sample {k}"),
                )),
                None => Ok(()),
            }
        };
        check_finite(&base.channel, "base acceleration", &base.acceleration)?;
        let dofs = records.floors.len();
        let dt = 1.0 / fs;
        let mut history = records.declared_processing.clone();
        let mut masses = Vec::with_capacity(dofs);
        let mut absolute = Vec::with_capacity(dofs);
        let mut velocity = Vec::with_capacity(dofs);
        let mut displacement = Vec::with_capacity(dofs);
        let mut integrated = Vec::new();
        for (d, floor) in records.floors.iter().enumerate() {
            let mass = match floor.mass_kg {
                Some(m) if m > 0.0 && m.is_finite() => m,
                Some(m) => {
                    return Err(Error::input(
                        here(&floor.channel),
                        format!("DoF {}: mass {m} kg is not positive", d + 1),
                    ));
                }
                None => {
                    return Err(Error::input(
                        here(&floor.channel),
                        format!(
                            "direction {direction}, DoF {}: lumped mass missing; restoring forces f_d = −m_d (a + ü_d) (Eq. 46) need it \
                             (give it in the manifest, take it from the twin, or use reduced masses, Eq. 35)",
                            d + 1
                        ),
                    ));
                }
            };
            if floor.absolute_acceleration.len() != n {
                return Err(Error::input(
                    here(&floor.channel),
                    format!(
                        "DoF {}: {} samples but the base channel {} has {n}",
                        d + 1,
                        floor.absolute_acceleration.len(),
                        base.channel
                    ),
                ));
            }
            check_finite(
                &floor.channel,
                "floor acceleration",
                &floor.absolute_acceleration,
            )?;
            // METHODS §0: ü_rel,d = ü_abs,d − a_base.
            let relative: Vec<f64> = floor
                .absolute_acceleration
                .iter()
                .zip(&base.acceleration)
                .map(|(a, b)| a - b)
                .collect();
            let v = match &floor.relative_velocity {
                Some(v) if v.len() == n => {
                    check_finite(&floor.channel, "relative velocity", v)?;
                    v.clone()
                }
                Some(v) => {
                    return Err(Error::input(
                        here(&floor.channel),
                        format!("relative velocity has {} samples, expected {n}", v.len()),
                    ));
                }
                None => {
                    integrated.push(floor.channel.clone());
                    let mut v = cumulative_cubic(&relative, dt);
                    if drift == VelocityDrift::EndpointRamp {
                        let rate = end_drift_rate(&v, dt);
                        for (k, x) in v.iter_mut().enumerate() {
                            *x -= rate * k as f64 * dt;
                        }
                    }
                    v
                }
            };
            let u = match &floor.relative_displacement {
                Some(u) if u.len() == n => {
                    check_finite(&floor.channel, "relative displacement", u)?;
                    u.clone()
                }
                Some(u) => {
                    return Err(Error::input(
                        here(&floor.channel),
                        format!(
                            "relative displacement has {} samples, expected {n}",
                            u.len()
                        ),
                    ));
                }
                None => cumulative_cubic(&v, dt),
            };
            masses.push(mass);
            absolute.push(floor.absolute_acceleration.clone());
            velocity.push(v);
            displacement.push(u);
        }
        history.push_for(
            "hysteresis_relative_acceleration",
            records.floors.iter().map(|f| f.channel.clone()).collect(),
            serde_json::json!({ "base_channel": base.channel, "rule": "a_rel = a_abs - a_base" }),
        );
        if !integrated.is_empty() {
            history.push_for(
                "hysteresis_integrate",
                integrated,
                serde_json::json!({
                    "method": "cumulative four-point cubic rule from rest",
                    "velocity_drift": drift.name(),
                    "velocity_drift_rule": match drift {
                        VelocityDrift::None => "none",
                        VelocityDrift::EndpointRamp => "v -= c t, c = Hann-weighted mean of v over the last 10 % / same mean of t",
                    },
                }),
            );
        }
        let restoring: Vec<Vec<f64>> = absolute
            .iter()
            .zip(&masses)
            .map(|(a, m)| a.iter().map(|x| -m * x).collect())
            .collect();
        history.push(
            "hysteresis_restoring_force",
            serde_json::json!({ "rule": "f_d = -m_d (a + u_dd) (Eq. 46)", "masses_kg": masses }),
        );
        let mut shear = vec![vec![0.0; n]; dofs];
        for d in (0..dofs).rev() {
            for k in 0..n {
                shear[d][k] = restoring[d][k] + if d + 1 < dofs { shear[d + 1][k] } else { 0.0 };
            }
        }
        let drift_velocity: Vec<Vec<f64>> = (0..dofs)
            .map(|d| {
                (0..n)
                    .map(|k| velocity[d][k] - if d > 0 { velocity[d - 1][k] } else { 0.0 })
                    .collect()
            })
            .collect();
        let mut energy_upper = vec![Vec::new(); dofs * (dofs + 1) / 2];
        for a in 0..dofs {
            for b in a..dofs {
                let power: Vec<f64> = (0..n).map(|k| restoring[b][k] * velocity[a][k]).collect();
                energy_upper[packed_upper_index(a, b, dofs)] = cumulative_trapezoid(&power, dt);
            }
        }
        Ok(DirectionKinematics {
            sampling_rate_hz: fs,
            start_s: 0.0,
            masses,
            base_acceleration: base.acceleration.clone(),
            absolute_acceleration: absolute,
            relative_velocity: velocity,
            relative_displacement: displacement,
            restoring_force: restoring,
            storey_shear: shear,
            drift_velocity,
            energy_upper,
            processing: history,
        })
    }
}

/// Which version of the basis functions (Table 15, step A.a.i).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BasisForm {
    /// Eq. 27–30: restoring force against time integrals of the rates.
    Integral,
    /// Eq. A7–A10: total jerk against the rates themselves (default, see
    /// `IdentifySettings::form`).
    #[default]
    Jerk,
}

impl BasisForm {
    pub fn name(&self) -> &'static str {
        match self {
            BasisForm::Integral => "integral",
            BasisForm::Jerk => "jerk",
        }
    }
}

/// Which stiffness couplings K0_dr are unknowns (r ≤ d).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StiffnessPattern {
    /// Every r ≤ d, as written in Eq. 28 / METHODS §4.
    #[default]
    Full,
    /// Only r ∈ {d−1, d} (a pure shear chain has a tridiagonal K0).
    Tridiagonal,
}

impl StiffnessPattern {
    pub fn couples(&self, d: usize, r: usize) -> bool {
        match self {
            StiffnessPattern::Full => true,
            StiffnessPattern::Tridiagonal => d.abs_diff(r) <= 1,
        }
    }
}

/// Identified parameters of one DoF, in the form the known side of lower DoFs needs.
#[derive(Debug, Clone, PartialEq)]
pub struct DofParameters {
    /// DoFs r (0-based, ≤ d) whose K0_dr, K0_dr·δ_dr were identified.
    pub coupled: Vec<usize>,
    pub k0: Vec<f64>,
    pub k0_delta: Vec<f64>,
    pub exponent: f64,
    /// Reference shear V_ref used to scale |V|^N (|V/V_ref|^N ≤ 1).
    pub shear_ref: f64,
    /// β·V_ref^N and γ·V_ref^N (scaled; avoids overflow for large N).
    pub beta_scaled: f64,
    pub gamma_scaled: f64,
}

impl DofParameters {
    /// β in SI units (N^(1−N)/m).
    pub fn beta(&self) -> f64 {
        self.beta_scaled / self.shear_ref.powf(self.exponent)
    }
    pub fn gamma(&self) -> f64 {
        self.gamma_scaled / self.shear_ref.powf(self.exponent)
    }
}

/// The linear-in-p problem of one DoF d (Eq. 28–30 or A8–A10) with the
/// N-independent columns built; N-dependent columns come from `nonlinear_columns`.
#[derive(Debug, Clone)]
pub struct DofProblem {
    pub dof: usize,
    pub form: BasisForm,
    /// DoFs r of the unknown K0_dr (ascending; the last is d itself).
    pub coupled: Vec<usize>,
    /// Columns K_r (one per coupled r) then P_r (one per coupled r).
    pub fixed_columns: Vec<Vec<f64>>,
    /// The record n_e(t) (Eq. 30 or A10).
    pub target: Vec<f64>,
    /// ln|V_d/V_ref| (−∞ where V_d = 0).
    log_shear: Vec<f64>,
    /// −(|Δu̇| sign V + Δu̇)/m_d: multiplies |V/V_ref|^N in the loading column.
    loading_factor: Vec<f64>,
    /// −(|Δu̇| sign V − Δu̇)/m_d: unloading column.
    unloading_factor: Vec<f64>,
    pub shear_ref: f64,
    pub mass: f64,
    dt: f64,
}

/// Hysteretic rate integrands of DoF `d` with scaled parameters:
/// BW_d(t) = β'(−|Δu̇| sgn V z) + γ'(−Δu̇ z), z = |V/V_ref|^N (shear-chain Eq. 23c).
pub fn hysteretic_rate(kin: &DirectionKinematics, d: usize, params: &DofParameters) -> Vec<f64> {
    let shear = &kin.storey_shear[d];
    let drift = &kin.drift_velocity[d];
    (0..kin.samples())
        .map(|k| {
            let z = (shear[k].abs() / params.shear_ref).powf(params.exponent);
            -z * (params.beta_scaled * drift[k].abs() * shear[k].signum()
                + params.gamma_scaled * drift[k])
        })
        .collect()
}

impl DofProblem {
    /// Builds the problem of DoF `d` (0-based) given the parameters already
    /// identified for the DoFs above it (`above[r - d - 1]` for r > d).
    pub fn new(
        kin: &DirectionKinematics,
        d: usize,
        above: &[DofParameters],
        form: BasisForm,
        pattern: StiffnessPattern,
    ) -> Result<Self> {
        let dofs = kin.dofs();
        let n = kin.samples();
        let dt = kin.dt();
        let mass = kin.masses[d];
        if above.len() != dofs - d - 1 {
            return Err(Error::numerical(
                "DoF problem: parameters of the DoFs above are missing",
            ));
        }
        let coupled: Vec<usize> = (0..=d).filter(|&r| pattern.couples(d, r)).collect();
        // Rate integrands (A9) of the K and P columns and the known side.
        let k_rate =
            |r: usize| -> Vec<f64> { kin.relative_velocity[r].iter().map(|v| v / mass).collect() };
        let p_rate = |r: usize| -> Vec<f64> {
            (0..n)
                .map(|k| -kin.energy(d, r, k) * kin.relative_velocity[r][k] / mass)
                .collect()
        };
        // Known rate: BW_{d+1} − Σ_{r>d} (K0_dr u̇_r − K0_dr δ_dr ε_dr u̇_r), /m_d.
        let mut known_rate = vec![0.0; n];
        let mut known_displacement_part = vec![0.0; n];
        if d + 1 < dofs {
            let upper = &above[0];
            let bw = hysteretic_rate(kin, d + 1, upper);
            for k in 0..n {
                known_rate[k] += bw[k] / mass;
            }
        }
        for r in d + 1..dofs {
            let owner = &above[r - d - 1];
            // K0_dr = K0_rd and K0_dr δ_dr = −K0_rd δ_rd, identified at DoF r.
            let Some(pos) = owner.coupled.iter().position(|&c| c == d) else {
                continue;
            };
            let k0 = owner.k0[pos];
            let k0_delta = -owner.k0_delta[pos];
            for k in 0..n {
                let v = kin.relative_velocity[r][k];
                // −[K0_dr v_r + K0_dr δ_dr (−ε_dr v_r)]/m_d: displacement part kept apart
                // so that the integral form uses u_r itself (as the K column does).
                known_rate[k] -= k0_delta * (-kin.energy(d, r, k) * v) / mass;
                known_displacement_part[k] -= k0 * kin.relative_displacement[r][k] / mass;
                if form == BasisForm::Jerk {
                    known_rate[k] -= k0 * v / mass;
                }
            }
        }
        let record = kin.absolute_acceleration[d]
            .iter()
            .map(|a| -a)
            .collect::<Vec<f64>>(); // g_d (Eq. 24b)
        let (fixed_columns, target) = match form {
            BasisForm::Integral => {
                let mut columns: Vec<Vec<f64>> = coupled
                    .iter()
                    .map(|&r| {
                        kin.relative_displacement[r]
                            .iter()
                            .map(|u| u / mass)
                            .collect()
                    })
                    .collect();
                columns.extend(
                    coupled
                        .iter()
                        .map(|&r| cumulative_trapezoid(&p_rate(r), dt)),
                );
                let known = cumulative_trapezoid(&known_rate, dt);
                let target: Vec<f64> = (0..n)
                    .map(|k| record[k] + known[k] + known_displacement_part[k])
                    .collect();
                (columns, target)
            }
            BasisForm::Jerk => {
                let mut columns: Vec<Vec<f64>> = coupled
                    .iter()
                    .map(|&r| matched_average(&k_rate(r)))
                    .collect();
                columns.extend(coupled.iter().map(|&r| matched_average(&p_rate(r))));
                let jerk = matched_derivative(&record, dt);
                let known = matched_average(&known_rate);
                let target: Vec<f64> = (0..n).map(|k| jerk[k] + known[k]).collect();
                (columns, target)
            }
        };
        let shear = &kin.storey_shear[d];
        let shear_ref = shear.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if !(shear_ref > 0.0) {
            return Err(Error::NotIdentifiable {
                stage: "hysteresis".into(),
                message: format!(
                    "DoF {}: storey shear is identically zero; nothing to identify",
                    d + 1
                ),
                f_test: None,
            });
        }
        let log_shear: Vec<f64> = shear.iter().map(|v| (v.abs() / shear_ref).ln()).collect();
        let drift = &kin.drift_velocity[d];
        let loading_factor = (0..n)
            .map(|k| -(drift[k].abs() * shear[k].signum() + drift[k]) / mass)
            .collect();
        let unloading_factor = (0..n)
            .map(|k| -(drift[k].abs() * shear[k].signum() - drift[k]) / mass)
            .collect();
        Ok(DofProblem {
            dof: d,
            form,
            coupled,
            fixed_columns,
            target,
            log_shear,
            loading_factor,
            unloading_factor,
            shear_ref,
            mass,
            dt,
        })
    }

    /// Number of N-independent unknowns (K0_dr and K0_dr·δ_dr).
    pub fn fixed_count(&self) -> usize {
        self.fixed_columns.len()
    }

    /// The two N-dependent columns for exponent `n_exp`: loading
    /// (coefficient s = (β+γ)/2·V_ref^N) and unloading (t = (β−γ)/2·V_ref^N)
    /// forms of n_{2D+1}, n_{2D+2} (Eq. 29 / A9), so that Eq. 47 is s, t ≥ 0.
    pub fn nonlinear_columns(&self, n_exp: f64) -> [Vec<f64>; 2] {
        let n = self.log_shear.len();
        let mut loading = Vec::with_capacity(n);
        let mut unloading = Vec::with_capacity(n);
        for k in 0..n {
            let z = (n_exp * self.log_shear[k]).exp();
            loading.push(self.loading_factor[k] * z);
            unloading.push(self.unloading_factor[k] * z);
        }
        match self.form {
            BasisForm::Integral => [
                cumulative_trapezoid(&loading, self.dt),
                cumulative_trapezoid(&unloading, self.dt),
            ],
            BasisForm::Jerk => [matched_average(&loading), matched_average(&unloading)],
        }
    }

    /// Maps the solver's p = [K0_dr…, K0δ…, s, t] to the DoF parameters.
    pub fn parameters(&self, p: &[f64], n_exp: f64) -> DofParameters {
        let c = self.coupled.len();
        let (s, t) = (p[2 * c], p[2 * c + 1]);
        DofParameters {
            coupled: self.coupled.clone(),
            k0: p[..c].to_vec(),
            k0_delta: p[c..2 * c].to_vec(),
            exponent: n_exp,
            shear_ref: self.shear_ref,
            beta_scaled: s + t,
            gamma_scaled: s - t,
        }
    }
}
