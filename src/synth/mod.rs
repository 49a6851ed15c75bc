//! Synthetic truth: a linear shear building with classical (modal) damping,
//! simulated exactly at the sample instants, plus a seeded ground-motion
//! generator and measurement noise.  Used to test identification stages
//! against known frequencies, damping ratios and mode shapes, and to build
//! the bundled sample events.
//!
//! Model (METHODS §0 conventions): lumped masses m_1..m_n on levels 1..n,
//! storey stiffness k_i between levels i−1 and i (level 0 = base),
//! M ü + C u̇ + K u = f(t) − M 1 a_g(t), with u relative to the base.
//! Damping is given per mode (ζ_j), i.e. C = M Φ diag(2 ζ_j ω_j) Φᵀ M.
//!
//! Simulation: the equations are decoupled with the mass-normalised modes
//! (q̈_j + 2ζ_jω_j q̇_j + ω_j² q_j = p_j, p = Φᵀ(f − M 1 a_g)) and each mode's
//! 2×2 state equation is discretised by the exact zero-order-hold formula
//! x[k+1] = e^{A Δt} x[k] + A⁻¹(e^{A Δt} − I) B p[k] with the closed-form
//! exponential of an under-damped oscillator.  For inputs held constant over
//! each sample step this is exact (no integration error).
//! [`plan`] is the same model with rigid floors moving in plan (x, y, θ per
//! floor, eccentric masses: torsion), simulated by the same recursion.
//! The numerical code of this file, [`plan`] and [`ground_motion`] is free of I/O;
//! [`fourteen_channel`] is the 14-channel event of the modal benchmarks.
//! [`event`] and [`facade`] write the bundled sample events (`quaketwin synth`);
//! [`realistic`] the building benchmarks written as the networks publish them
//! (through [`smc_writer`] and [`csmip_writer`]), one of them a yielding
//! building integrated by [`yielding`].

pub mod archive;
pub mod csmip_writer;
pub mod event;
pub mod facade;
pub mod five_storey;
pub mod fourteen_channel;
pub mod ground_motion;
pub mod hybrid_log;
pub mod lab_specimen;
pub mod plan;
pub mod realistic;
pub mod smc_writer;
pub mod yielding;

use crate::rng::Rng;
pub use fourteen_channel::{fourteen_channel_event, seven_storey_plan_building};
pub use ground_motion::{
    synthetic_ground_motion, Envelope, GroundMotionSpec, Sampling, Shaping, WhiteNoise,
};
pub use plan::{PlanBuilding, PlanModes, PlanResponse, Sensor};

use crate::error::{Error, Result};
use crate::vocab::{Channel, Record, Role, SourceRef, Units};
use faer::{Mat, Side};

/// Linear shear building with modal damping.
#[derive(Debug, Clone, PartialEq)]
pub struct ShearBuilding {
    /// Lumped mass of levels 1..n (kg), bottom to top.
    pub masses_kg: Vec<f64>,
    /// Stiffness of storeys 1..n (N/m); storey i joins level i−1 and level i.
    pub storey_stiffness_n_per_m: Vec<f64>,
    /// Modal damping ratio of each mode in ascending frequency order (0.02 = 2 %).
    /// A single value applies to every mode.
    pub damping_ratios: Vec<f64>,
}

/// Truth modal properties of a [`ShearBuilding`], modes in ascending frequency.
#[derive(Debug, Clone, PartialEq)]
pub struct BuildingModes {
    /// Undamped natural frequencies f_j (Hz).
    pub frequencies_hz: Vec<f64>,
    /// Circular frequencies ω_j (rad/s).
    pub circular_frequencies: Vec<f64>,
    /// Modal damping ratios ζ_j.
    pub damping_ratios: Vec<f64>,
    /// Mass-normalised shapes: `shapes[j][i]` is mode j at level i+1, φ_jᵀ M φ_j = 1;
    /// sign fixed so that the top level is non-negative.
    pub shapes: Vec<Vec<f64>>,
    /// Participation factors Γ_j = φ_jᵀ M 1 (base excitation).
    pub participation: Vec<f64>,
}

/// Response of the building sampled at `dt`.  Vectors indexed
/// `[level − 1][sample]` for floors.
#[derive(Debug, Clone, PartialEq)]
pub struct Response {
    pub dt: f64,
    /// Base (ground) acceleration, m/s² (all zeros for ambient excitation).
    pub base_acceleration: Vec<f64>,
    /// Absolute floor accelerations ü_rel + a_g, m/s² (what building sensors record).
    pub absolute_acceleration: Vec<Vec<f64>>,
    /// Floor displacements relative to the base, m.
    pub relative_displacement: Vec<Vec<f64>>,
    /// Floor forces applied (ambient case), N; empty for base excitation.
    pub floor_forces: Vec<Vec<f64>>,
}

impl ShearBuilding {
    /// Uniform building: `n` levels of equal mass, equal storey stiffness, one damping ratio for all modes.
    pub fn uniform(
        n: usize,
        mass_kg: f64,
        storey_stiffness_n_per_m: f64,
        damping_ratio: f64,
    ) -> Self {
        ShearBuilding {
            masses_kg: vec![mass_kg; n],
            storey_stiffness_n_per_m: vec![storey_stiffness_n_per_m; n],
            damping_ratios: vec![damping_ratio],
        }
    }

    pub fn levels(&self) -> usize {
        self.masses_kg.len()
    }

    fn validate(&self) -> Result<()> {
        let n = self.masses_kg.len();
        if n == 0 {
            return Err(Error::usage(
                "shear building: no levels (masses_kg is empty)",
            ));
        }
        if self.storey_stiffness_n_per_m.len() != n {
            return Err(Error::usage(format!(
                "shear building: {} masses but {} storey stiffnesses",
                n,
                self.storey_stiffness_n_per_m.len()
            )));
        }
        if self
            .masses_kg
            .iter()
            .chain(&self.storey_stiffness_n_per_m)
            .any(|v| !(v.is_finite() && *v > 0.0))
        {
            return Err(Error::usage(
                "shear building: masses and stiffnesses must be finite and positive",
            ));
        }
        if !(self.damping_ratios.len() == 1 || self.damping_ratios.len() == n) {
            return Err(Error::usage(format!(
                "shear building: give one damping ratio or one per mode ({n}), got {}",
                self.damping_ratios.len()
            )));
        }
        if self
            .damping_ratios
            .iter()
            .any(|z| !(z.is_finite() && (0.0..1.0).contains(z)))
        {
            return Err(Error::usage(
                "shear building: damping ratios must lie in [0, 1)",
            ));
        }
        Ok(())
    }

    /// Tridiagonal stiffness matrix K (N/m) of the shear building.
    pub fn stiffness_matrix(&self) -> Vec<Vec<f64>> {
        let n = self.masses_kg.len();
        let k = &self.storey_stiffness_n_per_m;
        let mut kk = vec![vec![0.0; n]; n];
        for i in 0..n {
            kk[i][i] = k.get(i).copied().unwrap_or(0.0) + k.get(i + 1).copied().unwrap_or(0.0);
            if i + 1 < n {
                kk[i][i + 1] = -k[i + 1];
                kk[i + 1][i] = -k[i + 1];
            }
        }
        kk
    }

    /// Undamped modes: K φ = ω² M φ ([`diagonal_mass_modes`]), the top level
    /// non-negative, participation for base motion Γ_j = φ_jᵀ M 1.
    pub fn modes(&self) -> Result<BuildingModes> {
        self.validate()?;
        diagonal_mass_modes(
            &self.masses_kg,
            &self.stiffness_matrix(),
            &self.damping_ratios,
            &vec![1.0; self.levels()],
        )
    }

    /// Response to a base (ground) acceleration history `base_acceleration` (m/s²)
    /// sampled at `dt`, starting at rest.
    pub fn simulate_base_motion(&self, base_acceleration: &[f64], dt: f64) -> Result<Response> {
        check_dt(dt)?;
        if base_acceleration.iter().any(|v| !v.is_finite()) {
            return Err(Error::usage("base acceleration contains non-finite values"));
        }
        let modes = self.modes()?;
        let n = self.levels();
        // Modal load p_j = −Γ_j a_g (φᵀ M 1 a_g with the minus of the effective load).
        let (disp, rel_acc) = simulate_modal(&modes, dt, base_acceleration.len(), |j, k| {
            -modes.participation[j] * base_acceleration[k]
        });
        let absolute_acceleration = (0..n)
            .map(|i| {
                rel_acc[i]
                    .iter()
                    .zip(base_acceleration)
                    .map(|(r, a)| r + a)
                    .collect()
            })
            .collect();
        Ok(Response {
            dt,
            base_acceleration: base_acceleration.to_vec(),
            absolute_acceleration,
            relative_displacement: disp,
            floor_forces: Vec::new(),
        })
    }

    /// Response to independent Gaussian white-noise forces at every floor
    /// (ambient excitation), standard deviation `force_std_n` (N), held over
    /// each sample step; `n_samples` samples at `dt`.  The first
    /// `warm_up` samples of the simulation are discarded (start-up transient).
    pub fn simulate_ambient(
        &self,
        n_samples: usize,
        dt: f64,
        force_std_n: f64,
        rng: &mut Rng,
    ) -> Result<Response> {
        check_dt(dt)?;
        if !(force_std_n.is_finite() && force_std_n > 0.0) {
            return Err(Error::usage(
                "ambient force standard deviation must be positive",
            ));
        }
        let modes = self.modes()?;
        let (disp, acc, forces) = ambient_response(
            &modes,
            n_samples,
            dt,
            &vec![force_std_n; self.levels()],
            rng,
        );
        Ok(Response {
            dt,
            base_acceleration: vec![0.0; n_samples],
            absolute_acceleration: acc,
            relative_displacement: disp,
            floor_forces: forces,
        })
    }
}

/// Undamped modes of K φ = ω² M φ for a diagonal mass matrix M = diag(`masses`)
/// (kg, or kg·m² for a rotation), solved as a symmetric eigenproblem after
/// the Cholesky factorisation of M, L = diag √m: (L⁻¹ K L⁻ᵀ) ψ = ω² ψ,
/// φ = L⁻ᵀ ψ, which is mass-normalised when ψ is unit.  Modes in ascending
/// frequency, each signed so that its last degree of freedom is non-negative;
/// `damping_ratios` one value or one per mode; participation Γ_j = φ_jᵀ M r
/// for the influence vector r = `influence` (the DoFs' motion under a unit
/// base displacement).
fn diagonal_mass_modes(
    masses: &[f64],
    kk: &[Vec<f64>],
    damping_ratios: &[f64],
    influence: &[f64],
) -> Result<BuildingModes> {
    let n = masses.len();
    let inv_sqrt_m: Vec<f64> = masses.iter().map(|m| 1.0 / m.sqrt()).collect();
    let a = Mat::<f64>::from_fn(n, n, |i, j| inv_sqrt_m[i] * kk[i][j] * inv_sqrt_m[j]);
    let eig = a
        .self_adjoint_eigen(Side::Lower)
        .map_err(|e| Error::numerical(format!("building eigenproblem: {e:?}")))?;
    let lambdas = eig.S().column_vector();
    let psi = eig.U();
    let mut frequencies_hz = Vec::with_capacity(n);
    let mut circular = Vec::with_capacity(n);
    let mut shapes = Vec::with_capacity(n);
    let mut participation = Vec::with_capacity(n);
    for j in 0..n {
        let omega = lambdas[j].max(0.0).sqrt();
        let mut phi: Vec<f64> = (0..n).map(|i| psi[(i, j)] * inv_sqrt_m[i]).collect();
        if phi[n - 1] < 0.0 {
            phi.iter_mut().for_each(|v| *v = -*v);
        }
        participation.push(
            phi.iter()
                .zip(masses)
                .zip(influence)
                .map(|((p, m), r)| p * m * r)
                .sum(),
        );
        circular.push(omega);
        frequencies_hz.push(omega / std::f64::consts::TAU);
        shapes.push(phi);
    }
    let damping_ratios = (0..n)
        .map(|j| damping_ratios[if damping_ratios.len() == 1 { 0 } else { j }])
        .collect();
    Ok(BuildingModes {
        frequencies_hz,
        circular_frequencies: circular,
        damping_ratios,
        shapes,
        participation,
    })
}

/// Time histories `[dof][sample]`.
type Histories = Vec<Vec<f64>>;

/// Response to independent Gaussian white-noise loads on every degree of
/// freedom (ambient excitation), standard deviation `load_std[i]` on DoF i,
/// held over each sample step: (displacements, relative accelerations,
/// loads), each `[dof][sample]`, `n_samples` long.  A start-up stretch of ten
/// times the slowest decay time 1/(ζω) is simulated first and discarded, so
/// the output is stationary.
fn ambient_response(
    modes: &BuildingModes,
    n_samples: usize,
    dt: f64,
    load_std: &[f64],
    rng: &mut Rng,
) -> (Histories, Histories, Histories) {
    let slowest_decay_s = modes
        .circular_frequencies
        .iter()
        .zip(&modes.damping_ratios)
        .map(|(w, z)| 1.0 / (z.max(1e-3) * w.max(1e-9)))
        .fold(0.0, f64::max);
    let warm_up = ((10.0 * slowest_decay_s / dt).ceil() as usize).min(10 * n_samples.max(1));
    let total = n_samples + warm_up;
    let forces: Vec<Vec<f64>> = load_std
        .iter()
        .map(|&std| rng.normal_vec(total, std))
        .collect();
    let (disp, acc) = simulate_modal(modes, dt, total, |j, k| {
        forces
            .iter()
            .zip(&modes.shapes[j])
            .map(|(f, phi)| phi * f[k])
            .sum::<f64>()
    });
    let cut = |v: Vec<Vec<f64>>| {
        v.into_iter()
            .map(|row| row[warm_up..].to_vec())
            .collect::<Vec<_>>()
    };
    (cut(disp), cut(acc), cut(forces))
}

impl Response {
    /// Records as a monitored building would deliver them: the base channel
    /// (level 0, role input) and one absolute-acceleration channel per floor
    /// (role output), in m/s², ids `{prefix}L0` … `{prefix}Ln`.
    pub fn to_records(&self, prefix: &str) -> Vec<Record> {
        let rate = 1.0 / self.dt;
        let make = |level: usize, samples: &[f64]| {
            Record::new(
                synthetic_channel(&format!("{prefix}L{level}"), rate, level),
                samples.to_vec(),
            )
        };
        let mut out = vec![make(0, &self.base_acceleration)];
        for (i, acc) in self.absolute_acceleration.iter().enumerate() {
            out.push(make(i + 1, acc));
        }
        out
    }
}

/// A synthetic acceleration channel (m/s²) at `level`: role input at the
/// base (level 0), output above.
fn synthetic_channel(id: &str, rate_hz: f64, level: usize) -> Channel {
    let source = SourceRef {
        file: "synthetic".into(),
        member: None,
        column: None,
        format: "synth".into(),
    };
    let mut ch = Channel::new(id, Units::MPerS2, rate_hz, source);
    ch.level = Some(level as i32);
    ch.role = if level == 0 {
        Role::Input
    } else {
        Role::Output
    };
    ch
}

fn check_dt(dt: f64) -> Result<()> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(Error::usage(format!(
            "sampling interval must be positive, got {dt}"
        )));
    }
    Ok(())
}

/// Exact zero-order-hold discretisation of one oscillator
/// q̈ + 2ζω q̇ + ω² q = p, state x = [q, q̇]:
/// returns (A_d = e^{AΔt}, B_d = A⁻¹(A_d − I) B) with B = [0, 1]ᵀ.
/// Closed form of the exponential for 0 ≤ ζ < 1 (ω_d = ω√(1−ζ²)).
pub fn sdof_zoh(omega: f64, zeta: f64, dt: f64) -> ([[f64; 2]; 2], [f64; 2]) {
    let wd = omega * (1.0 - zeta * zeta).sqrt();
    let decay = (-zeta * omega * dt).exp();
    let (s, c) = (wd * dt).sin_cos();
    let zw = zeta * omega;
    let ad = [
        [decay * (c + zw / wd * s), decay * s / wd],
        [-decay * omega * omega / wd * s, decay * (c - zw / wd * s)],
    ];
    // A⁻¹ = (1/ω²) [[−2ζω, −1], [ω², 0]];  (A_d − I) B = [ad01, ad11 − 1].
    let bd = [
        (-2.0 * zw * ad[0][1] - (ad[1][1] - 1.0)) / (omega * omega),
        ad[0][1],
    ];
    (ad, bd)
}

/// Runs every mode with the exact ZOH recursion and sums the modal
/// contributions: u = Σ φ_j q_j, ü_rel = Σ φ_j q̈_j with
/// q̈_j = p_j − 2ζ_jω_j q̇_j − ω_j² q_j (the instantaneous equation of motion).
fn simulate_modal(
    modes: &BuildingModes,
    dt: f64,
    n_samples: usize,
    modal_load: impl Fn(usize, usize) -> f64,
) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let n = modes.shapes.len();
    let mut disp = vec![vec![0.0; n_samples]; n];
    let mut acc = vec![vec![0.0; n_samples]; n];
    for j in 0..n {
        let omega = modes.circular_frequencies[j];
        let zeta = modes.damping_ratios[j];
        let (ad, bd) = sdof_zoh(omega, zeta, dt);
        let phi = &modes.shapes[j];
        let (mut q, mut qd) = (0.0, 0.0);
        for k in 0..n_samples {
            let p = modal_load(j, k);
            let qdd = p - 2.0 * zeta * omega * qd - omega * omega * q;
            for i in 0..n {
                disp[i][k] += phi[i] * q;
                acc[i][k] += phi[i] * qdd;
            }
            let q_next = ad[0][0] * q + ad[0][1] * qd + bd[0] * p;
            qd = ad[1][0] * q + ad[1][1] * qd + bd[1] * p;
            q = q_next;
        }
    }
    (disp, acc)
}

/// Adds Gaussian measurement noise to `signal` at signal-to-noise ratio
/// `snr_db` (power ratio, SNR = 20 log10(rms_signal / σ_noise)).  The input is not modified.
pub fn add_measurement_noise(signal: &[f64], snr_db: f64, rng: &mut Rng) -> Vec<f64> {
    let rms = (signal.iter().map(|v| v * v).sum::<f64>() / signal.len().max(1) as f64).sqrt();
    let sigma = rms / 10f64.powf(snr_db / 20.0);
    signal.iter().map(|v| v + sigma * rng.normal()).collect()
}
