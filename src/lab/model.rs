//! The Bouc–Wen–Baber–Noori hysteretic spring driven by a displacement history
//! (numerical code, no I/O), in the form of Foliente (1995), after Baber & Noori
//! (1985, 1986); docs/lab-tests.md, Eq. L1–L6:
//!
//!   F = α k₀ x + (1 − α) k₀ u_y z                                     (L1)
//!   dz/dx = h(z) [A − ν |z|ⁿ (β sgn(ẋ z) + γ)] / (η u_y),  A = 1       (L2)
//!   ε = ∫ z dx / u_y   (hysteretic energy / ((1 − α) k₀ u_y²))          (L3)
//!   ν = 1 + δ_ν ε,  η = 1 + δ_η ε                                       (L4)
//!   h(z) = 1 − ζ₁ exp(−((z sgn(ẋ) − q z_u) / ζ₂)²),  z_u = ν^(−1/n)     (L5)
//!   ζ₁ = ζ_s (1 − e^(−p ε)),  ζ₂ = (ψ + δ_ψ ε)(λ + ζ₁)                   (L6)
//!
//! z is dimensionless (the rehearsal's [`BoucWenSpring`] convention: small
//! motions give z ≈ x / u_y). A = 1 and β + γ = 1 fix the two scale
//! redundancies of the model (A against u_y, and (β, γ) against u_y^n): only
//! β/u_yⁿ and γ/u_yⁿ are identifiable from (x, F), so γ = 1 − β and the
//! undegraded z saturates at ±1, i.e. u_y is the displacement scale at which the
//! hysteretic force (1 − α) k₀ u_y is reached. δ_ψ = 0 and λ = 0.5 are fixed
//! (Foliente's typical values; with one specimen they are not separable from ψ).
//!
//! With δ_ν = δ_η = ζ_s = 0 the model is the plain Bouc–Wen spring of
//! `rehearse::specimen` (same u_y, α, β, γ, n). The model is rate
//! independent: time only orders the samples.

use crate::rehearse::specimen::BoucWenSpring;

/// λ of Eq. L6 (fixed).
pub const PINCHING_LAMBDA: f64 = 0.5;

/// Parameters of Eq. L1–L6 (the fixed ones are constants of this module).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BwbnParameters {
    /// k₀ (N/m): initial stiffness.
    pub initial_stiffness_n_per_m: f64,
    /// α: post-yield stiffness ratio.
    pub post_yield_ratio: f64,
    /// u_y (m).
    pub yield_displacement_m: f64,
    /// β (γ = 1 − β).
    pub beta: f64,
    /// n ≥ 1.
    pub n: f64,
    /// δ_ν: strength degradation per unit ε.
    pub strength_degradation: f64,
    /// δ_η: stiffness degradation per unit ε.
    pub stiffness_degradation: f64,
    /// ζ_s: pinching extent, in [0, 1).
    pub pinching_extent: f64,
    /// p: rate of pinching growth with ε.
    pub pinching_rate: f64,
    /// q: where in z the pinching sits (fraction of z_u).
    pub pinching_centre: f64,
    /// ψ: width of the pinched region.
    pub pinching_width: f64,
}

impl BwbnParameters {
    /// The plain Bouc–Wen model (no degradation, no pinching).
    pub fn plain(k0: f64, alpha: f64, uy: f64, beta: f64, n: f64) -> Self {
        BwbnParameters {
            initial_stiffness_n_per_m: k0,
            post_yield_ratio: alpha,
            yield_displacement_m: uy,
            beta,
            n,
            strength_degradation: 0.0,
            stiffness_degradation: 0.0,
            pinching_extent: 0.0,
            pinching_rate: 0.0,
            pinching_centre: 0.0,
            pinching_width: 0.2,
        }
    }
    pub fn gamma(&self) -> f64 {
        1.0 - self.beta
    }
    /// The plain part in the rehearsal's parameterisation.
    pub fn spring(&self) -> BoucWenSpring {
        BoucWenSpring {
            yield_displacement_m: self.yield_displacement_m,
            post_yield_ratio: self.post_yield_ratio,
            beta: self.beta,
            gamma: self.gamma(),
            n: self.n,
        }
    }
    /// The shape parameters z(x) depends on (everything but k₀ and α, which
    /// enter Eq. L1 linearly), in the order of [`SHAPE_NAMES`].
    pub fn shape(&self) -> [f64; 9] {
        [
            self.yield_displacement_m,
            self.beta,
            self.n,
            self.strength_degradation,
            self.stiffness_degradation,
            self.pinching_extent,
            self.pinching_rate,
            self.pinching_centre,
            self.pinching_width,
        ]
    }
    pub fn with_shape(k0: f64, alpha: f64, s: &[f64; 9]) -> Self {
        BwbnParameters {
            initial_stiffness_n_per_m: k0,
            post_yield_ratio: alpha,
            yield_displacement_m: s[0],
            beta: s[1],
            n: s[2],
            strength_degradation: s[3],
            stiffness_degradation: s[4],
            pinching_extent: s[5],
            pinching_rate: s[6],
            pinching_centre: s[7],
            pinching_width: s[8],
        }
    }
}

/// Names of [`BwbnParameters::shape`]'s entries (table rows).
pub const SHAPE_NAMES: [&str; 9] = [
    "yield_displacement_m",
    "beta",
    "n",
    "strength_degradation",
    "stiffness_degradation",
    "pinching_extent",
    "pinching_rate",
    "pinching_centre",
    "pinching_width",
];

/// z(x) and ε(x) at every sample of a displacement history.
#[derive(Debug, Clone, PartialEq)]
pub struct HystereticState {
    pub z: Vec<f64>,
    pub energy: Vec<f64>,
}

/// Integrates Eq. L2–L6 along `x` (z = ε = 0 at the first sample). Each
/// increment is split into ⌈|Δx| / max_substep_m⌉ sub-steps of the midpoint
/// rule; the sub-step bound is a property of the record (not of the
/// parameters) so that z is a smooth function of the parameters (finite
/// difference Jacobians). `shape` as in [`BwbnParameters::shape`].
pub fn hysteretic_state(x: &[f64], shape: &[f64; 9], max_substep_m: f64) -> HystereticState {
    let [uy, beta, n, d_nu, d_eta, zeta_s, p, q, psi] = *shape;
    let gamma = 1.0 - beta;
    let mut z = Vec::with_capacity(x.len());
    let mut energy = Vec::with_capacity(x.len());
    let (mut zc, mut ec) = (0.0f64, 0.0f64);
    let rate = |zv: f64, e: f64, dir: f64| -> (f64, f64) {
        let nu = 1.0 + d_nu * e;
        let eta = 1.0 + d_eta * e;
        let mut h = 1.0;
        if zeta_s > 0.0 {
            let zeta1 = zeta_s * (1.0 - (-p * e).exp());
            let zeta2 = psi * (PINCHING_LAMBDA + zeta1);
            let zu = nu.powf(-1.0 / n);
            let arg = (zv * dir - q * zu) / zeta2;
            h = 1.0 - zeta1 * (-arg * arg).exp();
        }
        let s = if dir * zv >= 0.0 { 1.0 } else { -1.0 };
        let dz = h * (1.0 - nu * zv.abs().powf(n) * (beta * s + gamma)) / (eta * uy);
        (dz, zv / uy)
    };
    let step = max_substep_m.max(f64::MIN_POSITIVE);
    for (i, &xi) in x.iter().enumerate() {
        if i > 0 {
            let dx = xi - x[i - 1];
            if dx != 0.0 && dx.is_finite() {
                let dir = dx.signum();
                let k = ((dx.abs() / step).ceil() as usize).clamp(1, 100_000);
                let hx = dx / k as f64;
                for _ in 0..k {
                    let (dz1, de1) = rate(zc, ec, dir);
                    let zm = zc + 0.5 * hx * dz1;
                    let em = ec + 0.5 * hx * de1;
                    let (dz2, de2) = rate(zm, em, dir);
                    zc += hx * dz2;
                    // Eq. L3 as Foliente writes it: the energy absorbed by the
                    // hysteretic spring (the stored part returns on unloading;
                    // over a closed cycle the sum is the dissipated energy).
                    ec += hx * de2;
                }
            }
        }
        z.push(zc);
        energy.push(ec);
    }
    HystereticState { z, energy }
}

/// The restoring force of Eq. L1 along `x`.
pub fn restoring_force(x: &[f64], params: &BwbnParameters, max_substep_m: f64) -> Vec<f64> {
    let state = hysteretic_state(x, &params.shape(), max_substep_m);
    let k0 = params.initial_stiffness_n_per_m;
    let a = params.post_yield_ratio * k0;
    let b = (1.0 - params.post_yield_ratio) * k0 * params.yield_displacement_m;
    x.iter()
        .zip(&state.z)
        .map(|(xi, zi)| a * xi + b * zi)
        .collect()
}

/// The sub-step bound used for a record: 1/2000 of its displacement range
/// (≥ 50 sub-steps per u_y for any u_y above 2.5 % of the range).
pub fn substep_for(x: &[f64]) -> f64 {
    let (lo, hi) = x
        .iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    let range = hi - lo;
    if range > 0.0 {
        range / 2000.0
    } else {
        1.0
    }
}
