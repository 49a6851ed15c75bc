//! Forward model of the in-series degrading Bouc-Wen shear chain (Eq. 21–23 of
//! METHODS.md §4, shear-chain reading of Eq. 23c), integrated with classical
//! fourth-order Runge–Kutta and a fixed number of sub-steps per input sample.
//!
//! State per direction, D DoFs numbered 1..D from the base up (index 0 = DoF 1):
//! relative displacements u_d, relative velocities u̇_d, restoring forces f_d and
//! the energy integrals ε_ab(t) = ∫₀ᵗ f_b u̇_a dτ for a ≤ b (Eq. 23d; the lower
//! triangle follows from ε_ba = −ε_ab).
//!
//! Equations (Eq. 21–23):
//! - m_d ü_d + f_d = −m_d a(t)
//! - ḟ_d = Σ_r K_dr(t) u̇_r + BW_d − BW_{d+1},  BW_{D+1} = 0
//! - K_dr(t) = K0_dr (1 − δ_dr ε_dr(t))
//! - BW_d = β_d (u̇_{d−1} − u̇_d) |V_d|^{N_d} sign[(u̇_d − u̇_{d−1}) V_d]
//!   + γ_d (u̇_{d−1} − u̇_d) |V_d|^{N_d},  V_d = Σ_{r ≥ d} f_r (storey shear)
//!
//! The base acceleration is a sampled signal; between samples it is taken as
//! linear in time (the continuous "true" excitation of a synthetic test).

use crate::error::{Error, Result};

/// Index of the energy integral ε_ab (a ≤ b, 0-based) in packed upper-triangular storage.
pub fn packed_upper_index(a: usize, b: usize, dofs: usize) -> usize {
    debug_assert!(a <= b && b < dofs);
    a * dofs - a * (a + 1) / 2 + b
}

/// The signed energy term ε_dr(t) (Eq. 23d) from packed upper storage
/// `upper[packed_upper_index(a, b)] = ∫ f_b u̇_a` (a ≤ b): ε_dr = upper(d, r) if
/// d ≤ r, else −upper(r, d).
pub fn signed_energy(upper: &[f64], d: usize, r: usize, dofs: usize) -> f64 {
    if d <= r {
        upper[packed_upper_index(d, r, dofs)]
    } else {
        -upper[packed_upper_index(r, d, dofs)]
    }
}

/// Parameters of one direction's degrading Bouc-Wen chain (SI units).
#[derive(Debug, Clone, PartialEq)]
pub struct BoucWenChain {
    /// Lumped masses m_d, kg (index 0 = DoF 1, the lowest).
    pub masses: Vec<f64>,
    /// Initial stiffness matrix K0 (symmetric), N/m.
    pub k0: Vec<Vec<f64>>,
    /// Degradation coefficients δ_dr, 1/J; δ_rd = −δ_dr for d ≠ r (Eq. 23).
    pub delta: Vec<Vec<f64>>,
    /// Bouc-Wen β_d, units N^(1−N_d)/m.
    pub beta: Vec<f64>,
    /// Bouc-Wen γ_d, same units as β_d.
    pub gamma: Vec<f64>,
    /// Bouc-Wen exponents N_d.
    pub exponent: Vec<f64>,
}

impl BoucWenChain {
    /// A shear chain: storey stiffnesses k_d give K0_dd = k_d + k_{d+1},
    /// K0_{d,d+1} = −k_{d+1}. `delta` is given for the lower triangle
    /// (`delta[d][r]`, r ≤ d) and mirrored antisymmetrically.
    pub fn shear(
        masses: Vec<f64>,
        storey_stiffness: &[f64],
        delta_lower: &[Vec<f64>],
        beta: Vec<f64>,
        gamma: Vec<f64>,
        exponent: Vec<f64>,
    ) -> Result<Self> {
        let dofs = masses.len();
        if storey_stiffness.len() != dofs || delta_lower.len() != dofs {
            return Err(Error::usage(
                "shear chain: masses, storey stiffnesses and δ rows must have one entry per DoF",
            ));
        }
        let mut k0 = vec![vec![0.0; dofs]; dofs];
        for d in 0..dofs {
            k0[d][d] = storey_stiffness[d] + storey_stiffness.get(d + 1).copied().unwrap_or(0.0);
            if d + 1 < dofs {
                k0[d][d + 1] = -storey_stiffness[d + 1];
                k0[d + 1][d] = -storey_stiffness[d + 1];
            }
        }
        let mut delta = vec![vec![0.0; dofs]; dofs];
        for d in 0..dofs {
            for r in 0..=d {
                let value = delta_lower[d].get(r).copied().unwrap_or(0.0);
                delta[d][r] = value;
                if r != d {
                    delta[r][d] = -value;
                }
            }
        }
        let chain = BoucWenChain {
            masses,
            k0,
            delta,
            beta,
            gamma,
            exponent,
        };
        chain.validate()?;
        Ok(chain)
    }

    pub fn dofs(&self) -> usize {
        self.masses.len()
    }

    /// Checks sizes, positivity, the symmetry K0_dr = K0_rd, the antisymmetry
    /// δ_dr = −δ_rd and Eq. 47 (β ≥ 0, −β ≤ γ ≤ β).
    pub fn validate(&self) -> Result<()> {
        let n = self.masses.len();
        let bad = |m: &str| Err(Error::usage(format!("Bouc-Wen chain: {m}")));
        if n == 0 {
            return bad("no DoF");
        }
        if self.k0.len() != n
            || self.delta.len() != n
            || self.k0.iter().chain(&self.delta).any(|row| row.len() != n)
        {
            return bad("K0 and δ must be D×D");
        }
        if self.beta.len() != n || self.gamma.len() != n || self.exponent.len() != n {
            return bad("β, γ, N need one value per DoF");
        }
        for d in 0..n {
            if !(self.masses[d] > 0.0 && self.masses[d].is_finite()) {
                return bad("masses must be positive");
            }
            if !(self.exponent[d] >= 1.0 && self.exponent[d].is_finite()) {
                return bad("exponents N must be ≥ 1");
            }
            if !(self.beta[d] >= 0.0 && self.gamma[d].abs() <= self.beta[d]) {
                return bad("need β ≥ 0 and −β ≤ γ ≤ β (Eq. 47)");
            }
            for r in 0..n {
                if (self.k0[d][r] - self.k0[r][d]).abs() > 1e-12 * self.k0[d][d].abs().max(1.0) {
                    return bad("K0 must be symmetric");
                }
                if r != d && (self.delta[d][r] + self.delta[r][d]).abs() > 1e-15 {
                    return bad("δ must satisfy δ_dr = −δ_rd");
                }
            }
        }
        Ok(())
    }

    /// Right-hand side of Eq. 21–23 for the packed state
    /// `[u (D), u̇ (D), f (D), ε_ab (a ≤ b, D(D+1)/2)]` under base acceleration `a_g`.
    fn rhs(&self, a_g: f64, state: &[f64], out: &mut [f64], shear: &mut [f64], bw: &mut [f64]) {
        let n = self.dofs();
        let (u_dot, rest) = out.split_at_mut(n);
        let (v_dot, rest) = rest.split_at_mut(n);
        let (f_dot, e_dot) = rest.split_at_mut(n);
        let v = &state[n..2 * n];
        let f = &state[2 * n..3 * n];
        let energy = &state[3 * n..];
        // Storey shears V_d = Σ_{r ≥ d} f_r.
        let mut acc = 0.0;
        for d in (0..n).rev() {
            acc += f[d];
            shear[d] = acc;
        }
        // Hysteretic rates BW_d (shear-chain reading of Eq. 23c):
        // β(u̇_{d−1} − u̇_d)|V|^N sign[(u̇_d − u̇_{d−1})V] = −β |Δu̇| |V|^N sign V.
        for d in 0..n {
            let drift_rate = v[d] - if d > 0 { v[d - 1] } else { 0.0 };
            let vd = shear[d];
            // |V|^N = 0 at V = 0 (N ≥ 1), so signum(0) = 1 is harmless.
            let power = vd.abs().powf(self.exponent[d]);
            bw[d] = -power
                * (self.beta[d] * drift_rate.abs() * vd.signum() + self.gamma[d] * drift_rate);
        }
        for d in 0..n {
            u_dot[d] = v[d];
            v_dot[d] = -f[d] / self.masses[d] - a_g;
            let mut rate = 0.0;
            for r in 0..n {
                let stiffness =
                    self.k0[d][r] * (1.0 - self.delta[d][r] * signed_energy(energy, d, r, n));
                rate += stiffness * v[r];
            }
            f_dot[d] = rate + bw[d] - if d + 1 < n { bw[d + 1] } else { 0.0 };
        }
        for a in 0..n {
            for b in a..n {
                e_dot[packed_upper_index(a, b, n)] = f[b] * v[a];
            }
        }
    }

    /// Integrates the chain from rest under the sampled base acceleration
    /// `base_acceleration` (m/s², sampling rate `sampling_rate_hz`), with
    /// `substeps` RK4 steps per sample interval, and returns every state at
    /// the sample instants.
    pub fn simulate(
        &self,
        base_acceleration: &[f64],
        sampling_rate_hz: f64,
        substeps: usize,
    ) -> Result<ChainResponse> {
        self.validate()?;
        if !(sampling_rate_hz > 0.0 && sampling_rate_hz.is_finite()) || substeps == 0 {
            return Err(Error::usage(
                "forward model: sampling rate must be positive and substeps ≥ 1",
            ));
        }
        let n = self.dofs();
        let samples = base_acceleration.len();
        let pairs = n * (n + 1) / 2;
        let width = 3 * n + pairs;
        let mut state = vec![0.0; width];
        let mut response = ChainResponse {
            sampling_rate_hz,
            relative_displacement: vec![Vec::with_capacity(samples); n],
            relative_velocity: vec![Vec::with_capacity(samples); n],
            restoring_force: vec![Vec::with_capacity(samples); n],
            absolute_acceleration: vec![Vec::with_capacity(samples); n],
            energy_upper: vec![Vec::with_capacity(samples); pairs],
        };
        let record = |resp: &mut ChainResponse, s: &[f64]| {
            for d in 0..n {
                resp.relative_displacement[d].push(s[d]);
                resp.relative_velocity[d].push(s[n + d]);
                resp.restoring_force[d].push(s[2 * n + d]);
                // Eq. 21: absolute acceleration a + ü_d = −f_d / m_d.
                resp.absolute_acceleration[d].push(-s[2 * n + d] / self.masses[d]);
            }
            for p in 0..pairs {
                resp.energy_upper[p].push(s[3 * n + p]);
            }
        };
        if samples == 0 {
            return Ok(response);
        }
        record(&mut response, &state);
        let h = 1.0 / (sampling_rate_hz * substeps as f64);
        let (mut k1, mut k2, mut k3, mut k4, mut tmp) = (
            vec![0.0; width],
            vec![0.0; width],
            vec![0.0; width],
            vec![0.0; width],
            vec![0.0; width],
        );
        let (mut shear, mut bw) = (vec![0.0; n], vec![0.0; n]);
        for k in 0..samples - 1 {
            let (a0, a1) = (base_acceleration[k], base_acceleration[k + 1]);
            for s in 0..substeps {
                // Linear excitation within the sample interval.
                let at = |frac: f64| a0 + (a1 - a0) * frac;
                let x0 = s as f64 / substeps as f64;
                let xh = (s as f64 + 0.5) / substeps as f64;
                let x1 = (s as f64 + 1.0) / substeps as f64;
                self.rhs(at(x0), &state, &mut k1, &mut shear, &mut bw);
                for i in 0..width {
                    tmp[i] = state[i] + 0.5 * h * k1[i];
                }
                self.rhs(at(xh), &tmp, &mut k2, &mut shear, &mut bw);
                for i in 0..width {
                    tmp[i] = state[i] + 0.5 * h * k2[i];
                }
                self.rhs(at(xh), &tmp, &mut k3, &mut shear, &mut bw);
                for i in 0..width {
                    tmp[i] = state[i] + h * k3[i];
                }
                self.rhs(at(x1), &tmp, &mut k4, &mut shear, &mut bw);
                for i in 0..width {
                    state[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
                }
            }
            if state.iter().any(|x| !x.is_finite()) {
                return Err(Error::numerical(format!(
                    "forward Bouc-Wen model diverged at sample {} (t = {:.3} s)",
                    k + 1,
                    (k + 1) as f64 / sampling_rate_hz
                )));
            }
            record(&mut response, &state);
        }
        Ok(response)
    }
}

/// Sampled response of a chain: everything a synthetic "record" needs and the
/// exact energy integrals for a reference damage index.
#[derive(Debug, Clone, PartialEq)]
pub struct ChainResponse {
    pub sampling_rate_hz: f64,
    /// u_d(t) relative to the base, m; `[dof][sample]`.
    pub relative_displacement: Vec<Vec<f64>>,
    /// u̇_d(t), m/s.
    pub relative_velocity: Vec<Vec<f64>>,
    /// f_d(t), N.
    pub restoring_force: Vec<Vec<f64>>,
    /// a(t) + ü_d(t) = −f_d/m_d, m/s² (what a floor accelerometer records).
    pub absolute_acceleration: Vec<Vec<f64>>,
    /// ε_ab(t) = ∫ f_b u̇_a for a ≤ b in packed order (`packed_upper_index`), J.
    pub energy_upper: Vec<Vec<f64>>,
}

impl ChainResponse {
    /// Every `step`-th sample (point sampling, as a slower recorder would see
    /// the same continuous motion).
    pub fn subsample(&self, step: usize) -> ChainResponse {
        let step = step.max(1);
        let pick = |rows: &Vec<Vec<f64>>| {
            rows.iter()
                .map(|r| r.iter().step_by(step).copied().collect())
                .collect()
        };
        ChainResponse {
            sampling_rate_hz: self.sampling_rate_hz / step as f64,
            relative_displacement: pick(&self.relative_displacement),
            relative_velocity: pick(&self.relative_velocity),
            restoring_force: pick(&self.restoring_force),
            absolute_acceleration: pick(&self.absolute_acceleration),
            energy_upper: pick(&self.energy_upper),
        }
    }
}
