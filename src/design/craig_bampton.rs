//! Craig–Bampton reduced hybrid prototype and hybrid bandwidth (METHODS §6, Eq. 60–68).
//!
//! The twin's free DoFs split into NS-interior DoFs i (not in the PS) and the PS DoFs. The PS
//! is represented by a basis u_PS = T_P q_P without fixed-interface modes (Eq. 87's T: its
//! coordinates are the actuator-controlled DoFs and the rigid-body amplitudes — or any other
//! PS basis, e.g. Guyan onto interface + masters). The NS contributes fixed-interface normal
//! modes Φ of (K_ii − ω² M_ii) φ = 0 (Eq. 65–66) and constraint modes −K_ii⁻¹ K_iP (Eq. 64),
//! here applied to T_P so that interface compatibility holds exactly:
//!     ψ = [[Φ, −K_ii⁻¹ K_iP T_P], [0, T_P]]  (rows: NS interior, PS),
//! K̂ = ψᵀ K ψ, M̂ = ψᵀ M ψ (Eq. 67–68) with the assembled twin's K and M. Only interface
//! columns of K_iP are non-zero, since NS-interior DoFs couple to the PS through the interface.
//! Fixed-interface modes are computed densely (NS interiors up to a few thousand DoFs).

use faer::{Mat, MatRef};

use super::partition::Partition;
use crate::error::Error;
use crate::twin::eigen::dense_modes;
use crate::twin::sparse::CscMatrix;
use crate::twin::statics::solve_spd;
use crate::Result;

/// Hybrid-system bandwidth (METHODS §6): highest prototype frequency / time scale λ.
pub fn hybrid_bandwidth_hz(highest_frequency_hz: f64, time_scale: f64) -> f64 {
    highest_frequency_hz / time_scale
}

#[derive(Debug, Clone)]
pub struct Prototype {
    pub ns_modes: usize,
    pub stiffness: Mat<f64>,
    pub mass: Mat<f64>,
    /// All eigenfrequencies of the reduced prototype, ascending (Hz).
    pub frequencies_hz: Vec<f64>,
    /// The Craig–Bampton basis ψ over the twin's free DoFs (n × (ns_modes + n_q)): columns
    /// 0..ns_modes the NS fixed-interface modes, then the PS coordinates (Eq. 60–64). Loads
    /// of the full model reduce as ψᵀ f (the rehearsal's base-excitation loads).
    pub basis: Mat<f64>,
}

impl Prototype {
    pub fn highest_frequency_hz(&self) -> f64 {
        self.frequencies_hz.last().copied().unwrap_or(0.0)
    }
}

/// Assemble the reduced prototype with `ns_modes` fixed-interface NS modes and the PS basis
/// `ps_basis` (n_PS × n_q, PS DoF order). `k`, `m`: the twin's assembled free-DoF matrices.
pub fn craig_bampton_prototype(
    k: &CscMatrix,
    m: &CscMatrix,
    partition: &Partition,
    ps_basis: MatRef<'_, f64>,
    ns_modes: usize,
) -> Result<Prototype> {
    let n = k.n;
    if ps_basis.nrows() != partition.n_ps() {
        return Err(Error::usage(
            "Craig–Bampton: the PS basis does not match the PS DoFs",
        ));
    }
    let mut in_ps = vec![false; n];
    for &f in &partition.ps_free {
        if f >= n {
            return Err(Error::usage("Craig–Bampton: PS DoF outside the twin"));
        }
        in_ps[f] = true;
    }
    let interior: Vec<usize> = (0..n).filter(|&i| !in_ps[i]).collect();
    let ni = interior.len();
    let nq = ps_basis.ncols();
    if ns_modes > ni {
        return Err(Error::usage(format!(
            "Craig–Bampton: {ns_modes} NS modes requested, the NS interior has {ni} DoFs"
        )));
    }
    let k_ii = k.principal_submatrix(&interior);
    // Constraint modes applied to T_P (Eq. 64): −K_ii⁻¹ (K_iP T_P).
    let k_ip = k.dense_block(&interior, &partition.ps_free);
    let kt = &k_ip * ps_basis;
    let rhs: Vec<Vec<f64>> = (0..nq)
        .map(|j| (0..ni).map(|i| -kt[(i, j)]).collect())
        .collect();
    let constraint = solve_spd(&k_ii, &rhs).map_err(|f| {
        Error::numerical(format!(
            "Craig–Bampton: the NS interior stiffness is singular ({f:?}); the NS needs supports"
        ))
    })?;
    let phi = if ns_modes > 0 {
        let kd = k_ii.to_dense();
        let md = m.principal_submatrix(&interior).to_dense();
        dense_modes(kd.as_ref(), md.as_ref(), ns_modes)
            .map_err(|f| {
                Error::numerical(format!(
                    "Craig–Bampton: fixed-interface modes failed ({f:?})"
                ))
            })?
            .shapes
    } else {
        Mat::zeros(ni, 0)
    };
    let nc = ns_modes + nq;
    let mut psi = Mat::<f64>::zeros(n, nc);
    for (r, &i) in interior.iter().enumerate() {
        for j in 0..ns_modes {
            psi[(i, j)] = phi[(r, j)];
        }
        for j in 0..nq {
            psi[(i, ns_modes + j)] = constraint[j][r];
        }
    }
    for (p, &f) in partition.ps_free.iter().enumerate() {
        for j in 0..nq {
            psi[(f, ns_modes + j)] = ps_basis[(p, j)];
        }
    }
    let stiffness = sparse_congruence(k, psi.as_ref());
    let mass = sparse_congruence(m, psi.as_ref());
    let modes = dense_modes(stiffness.as_ref(), mass.as_ref(), nc).map_err(|f| {
        Error::numerical(format!(
            "Craig–Bampton: prototype eigenproblem failed ({f:?}); is the PS basis rank deficient?"
        ))
    })?;
    Ok(Prototype {
        ns_modes,
        stiffness,
        mass,
        frequencies_hz: modes.frequencies_hz(),
        basis: psi,
    })
}

/// ψᵀ A ψ for sparse A, symmetrised.
fn sparse_congruence(a: &CscMatrix, psi: MatRef<'_, f64>) -> Mat<f64> {
    let (n, nc) = (psi.nrows(), psi.ncols());
    let mut ap = Mat::<f64>::zeros(n, nc);
    let mut x = vec![0.0; n];
    let mut y = vec![0.0; n];
    for j in 0..nc {
        for i in 0..n {
            x[i] = psi[(i, j)];
        }
        a.mul_vec(&x, &mut y);
        for i in 0..n {
            ap[(i, j)] = y[i];
        }
    }
    let mut r = psi.transpose() * &ap;
    for i in 0..nc {
        for j in 0..i {
            let s = 0.5 * (r[(i, j)] + r[(j, i)]);
            r[(i, j)] = s;
            r[(j, i)] = s;
        }
    }
    r
}

#[derive(Debug, Clone)]
pub struct HybridSettings {
    /// Accurate band of the actuators (Hz): 2 for standard equipment, 10 for outstanding.
    pub actuator_band_hz: f64,
    /// Full-model frequencies up to this value must be reproduced by the prototype.
    pub band_of_interest_hz: f64,
    /// Relative frequency tolerance of that reproduction.
    pub accuracy: f64,
    /// NS fixed-interface mode counts tried, in increasing order, up to this.
    pub max_ns_modes: usize,
    /// Candidate time scales λ, ascending (the smallest fitting one is recommended).
    pub time_scales: Vec<f64>,
}

impl Default for HybridSettings {
    fn default() -> Self {
        HybridSettings {
            actuator_band_hz: 2.0,
            band_of_interest_hz: 10.0,
            accuracy: 0.01,
            max_ns_modes: 20,
            time_scales: vec![1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0, 1000.0],
        }
    }
}

#[derive(Debug, Clone)]
pub struct HybridRecommendation {
    pub prototype: Prototype,
    /// (full-model frequency, prototype frequency, relative error) inside the band of interest.
    pub matched: Vec<(f64, f64, f64)>,
    pub time_scale: f64,
    pub bandwidth_hz: f64,
}

/// The fewest NS fixed-interface modes whose prototype reproduces every full-model frequency
/// below the band of interest within `accuracy` (paired in ascending order), and the smallest
/// candidate λ with bandwidth ≤ the actuator band. Errors when no mode count or no λ fits.
pub fn recommend_hybrid(
    k: &CscMatrix,
    m: &CscMatrix,
    partition: &Partition,
    ps_basis: MatRef<'_, f64>,
    full_frequencies_hz: &[f64],
    settings: &HybridSettings,
) -> Result<HybridRecommendation> {
    let targets: Vec<f64> = full_frequencies_hz
        .iter()
        .copied()
        .filter(|&f| f <= settings.band_of_interest_hz)
        .collect();
    if targets.is_empty() {
        return Err(Error::usage(format!(
            "hybrid design: no full-model frequency below {} Hz",
            settings.band_of_interest_hz
        )));
    }
    let mut best_error = f64::INFINITY;
    for ns_modes in 0..=settings.max_ns_modes {
        let Ok(prototype) = craig_bampton_prototype(k, m, partition, ps_basis, ns_modes) else {
            continue;
        };
        if prototype.frequencies_hz.len() < targets.len() {
            continue;
        }
        let matched: Vec<(f64, f64, f64)> = targets
            .iter()
            .zip(&prototype.frequencies_hz)
            .map(|(&f, &p)| (f, p, (p - f).abs() / f))
            .collect();
        let worst = matched.iter().fold(0.0_f64, |a, x| a.max(x.2));
        best_error = best_error.min(worst);
        if worst <= settings.accuracy {
            let top = prototype.highest_frequency_hz();
            let Some(&time_scale) = settings
                .time_scales
                .iter()
                .find(|&&l| hybrid_bandwidth_hz(top, l) <= settings.actuator_band_hz)
            else {
                return Err(Error::numerical(format!(
                    "hybrid design: the prototype's highest frequency {top:.2} Hz exceeds the actuator band {} Hz at every candidate time scale",
                    settings.actuator_band_hz
                )));
            };
            return Ok(HybridRecommendation {
                bandwidth_hz: hybrid_bandwidth_hz(top, time_scale),
                prototype,
                matched,
                time_scale,
            });
        }
    }
    Err(Error::numerical(format!(
        "hybrid design: up to {} NS modes the prototype misses the full-model frequencies below {} Hz by {:.2} % at best (target {:.2} %); enrich the PS basis",
        settings.max_ns_modes,
        settings.band_of_interest_hz,
        100.0 * best_error,
        100.0 * settings.accuracy
    )))
}
