//! What a fitted loop is judged by (numerical code, no I/O): the force NRMSE
//! (Eq. 83 of METHODS.md: RMS error over the measured range), the dissipated
//! energy per displacement cycle, and the specimen's damage indices.

/// One displacement cycle: from one displacement maximum to the next
/// (turning points found with a dead band, so noise and small
/// excursions do not split cycles), with the work ∮ F dx of the measured and
/// of the fitted force over it.
#[derive(Debug, Clone, PartialEq)]
pub struct CycleEnergy {
    pub start: usize,
    pub end: usize,
    /// Peak-to-peak displacement within the cycle (m).
    pub amplitude_m: f64,
    pub measured_j: f64,
    pub fitted_j: f64,
}

impl CycleEnergy {
    /// (fitted − measured) / |measured|.
    pub fn relative_error(&self) -> f64 {
        (self.fitted_j - self.measured_j) / self.measured_j.abs()
    }
}

/// NRMSE of Eq. 83: sqrt(Σ(F − F̂)²/n) / (max F − min F).
pub fn nrmse(measured: &[f64], fitted: &[f64]) -> f64 {
    let n = measured.len().min(fitted.len());
    if n == 0 {
        return f64::NAN;
    }
    let ss: f64 = measured
        .iter()
        .zip(fitted)
        .map(|(a, b)| (a - b) * (a - b))
        .sum();
    let (lo, hi) = measured
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    (ss / n as f64).sqrt() / (hi - lo)
}

/// Work of `force` along `x` between samples `a` and `b` (trapezoid).
pub fn work_between(x: &[f64], force: &[f64], a: usize, b: usize) -> f64 {
    (a + 1..=b)
        .map(|i| 0.5 * (force[i] + force[i - 1]) * (x[i] - x[i - 1]))
        .sum()
}

/// Indices of the displacement maxima: turning points confirmed once the
/// displacement has come back by more than `band_m`.
pub fn displacement_maxima(x: &[f64], band_m: f64) -> Vec<usize> {
    let mut maxima = Vec::new();
    if x.is_empty() {
        return maxima;
    }
    // +1: looking for a maximum; −1: looking for a minimum.
    let mut seeking = 1i8;
    let mut extreme = 0usize;
    for i in 1..x.len() {
        if seeking > 0 {
            if x[i] > x[extreme] {
                extreme = i;
            } else if x[extreme] - x[i] > band_m {
                maxima.push(extreme);
                seeking = -1;
                extreme = i;
            }
        } else if x[i] < x[extreme] {
            extreme = i;
        } else if x[i] - x[extreme] > band_m {
            seeking = 1;
            extreme = i;
        }
    }
    maxima
}

/// The cycles between successive maxima with a dead band of `band_fraction`
/// of the record's displacement range.
pub fn cycle_energies(
    x: &[f64],
    measured: &[f64],
    fitted: &[f64],
    band_fraction: f64,
) -> Vec<CycleEnergy> {
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    let band = (hi - lo) * band_fraction;
    let maxima = displacement_maxima(x, band);
    maxima
        .windows(2)
        .map(|w| {
            let (a, b) = (w[0], w[1]);
            let (clo, chi) = x[a..=b]
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                    (l.min(v), h.max(v))
                });
            CycleEnergy {
                start: a,
                end: b,
                amplitude_m: chi - clo,
                measured_j: work_between(x, measured, a, b),
                fitted_j: work_between(x, fitted, a, b),
            }
        })
        .collect()
}

/// The specimen's damage, from the identified model and the measured loop.
#[derive(Debug, Clone, PartialEq)]
pub struct SpecimenDamage {
    /// F_y = k₀ u_y: where the elastic line meets the post-yield asymptote
    /// α k₀ x + (1 − α) k₀ u_y of Eq. L1.
    pub yield_force_n: f64,
    /// μ = max |x| / u_y.
    pub ductility: f64,
    /// E_h = ∫ F dx of the measured record (J).
    pub hysteretic_energy_j: f64,
    /// E_h / (F_y u_y): dissipated energy in elastic-yield units.
    pub normalised_energy: f64,
    /// Park & Ang (1985): D = δ_max/δ_u + β_PA E_h/(F_y δ_u); None without
    /// the specimen's ultimate displacement δ_u (a test seldom states it).
    pub park_ang: Option<f64>,
    /// The single-DoF form of the stiffness index ι of Eq. 34 (METHODS.md
    /// §4): 1 − ω_end/ω₀ = 1 − sqrt(k_end/k₀) with the identified model's
    /// elastic stiffness at the end of the record,
    /// k_end = k₀ (α + (1 − α)/η_end) (Eq. L2, L4); 0 for the plain model.
    pub stiffness_index: f64,
}

pub fn specimen_damage(
    x: &[f64],
    measured: &[f64],
    k0: f64,
    alpha: f64,
    uy: f64,
    eta_end: f64,
    park_ang_beta: f64,
    ultimate_displacement_m: Option<f64>,
) -> SpecimenDamage {
    let yield_force_n = k0 * uy;
    let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let energy = if x.len() > 1 {
        work_between(x, measured, 0, x.len() - 1)
    } else {
        0.0
    };
    let k_end = k0 * (alpha + (1.0 - alpha) / eta_end.max(1.0));
    SpecimenDamage {
        yield_force_n,
        ductility: peak / uy,
        hysteretic_energy_j: energy,
        normalised_energy: energy / (yield_force_n * uy),
        park_ang: ultimate_displacement_m
            .map(|du| peak / du + park_ang_beta * energy / (yield_force_n * du)),
        stiffness_index: 1.0 - (k_end / k0).sqrt(),
    }
}
