//! Newmark average-acceleration integration (γ = 1/2, β = 1/4: unconditionally stable, no
//! numerical damping) of M ü + C u̇ + K u = −M Σ_d r_d a_d(t) under base acceleration, u
//! relative to the base, with Rayleigh damping C = a0 M + a1 K. The effective stiffness
//! K + (γ/(βΔt)) C + (1/(βΔt²)) M is factored once (sparse Cholesky); each step is one solve.

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};

use super::sparse::{AffineMatrix, CscMatrix};
use crate::error::Error;
use crate::Result;

/// Rayleigh coefficients (a0, a1) giving damping ratios ζ1 at f1 and ζ2 at f2 (Hz):
/// ζ(ω) = a0/(2ω) + a1 ω/2.
pub fn rayleigh_coefficients(f1: f64, f2: f64, zeta1: f64, zeta2: f64) -> Result<(f64, f64)> {
    let (w1, w2) = (
        2.0 * std::f64::consts::PI * f1,
        2.0 * std::f64::consts::PI * f2,
    );
    if !(w1 > 0.0 && w2 > 0.0 && (w2 - w1).abs() > 1e-12 * w2) {
        return Err(Error::usage(format!(
            "Rayleigh damping needs two distinct positive frequencies, got {f1} and {f2} Hz"
        )));
    }
    let den = w2 * w2 - w1 * w1;
    let a0 = 2.0 * w1 * w2 * (zeta1 * w2 - zeta2 * w1) / den;
    let a1 = 2.0 * (zeta2 * w2 - zeta1 * w1) / den;
    Ok((a0, a1))
}

/// One base-acceleration component: kinematic influence r (free DoFs, for absolute
/// accelerations), effective force pattern b = M̃ r̃ (the mass times a unit rigid translation
/// of all nodes, supports included, so consistent-mass coupling to supports counts; equals
/// M r when no mass couples to supports) and samples a(t_k). Build it with
/// `TwinSystem::base_excitation`.
#[derive(Debug, Clone)]
pub struct BaseExcitation {
    pub influence: Vec<f64>,
    pub load: Vec<f64>,
    pub acceleration: Vec<f64>,
}

#[derive(Debug, Clone)]
pub struct NewmarkSettings {
    pub dt: f64,
    /// Rayleigh mass and stiffness coefficients (a0, a1).
    pub rayleigh: (f64, f64),
    /// Free DoFs whose histories are recorded (all when None).
    pub record: Option<Vec<usize>>,
}

/// Histories at the recorded DoFs: `displacement[j][k]` is DoF `dofs[j]` at step k.
#[derive(Debug, Clone)]
pub struct NewmarkResponse {
    pub dt: f64,
    pub dofs: Vec<usize>,
    pub displacement: Vec<Vec<f64>>,
    pub velocity: Vec<Vec<f64>>,
    /// Relative acceleration ü.
    pub acceleration: Vec<Vec<f64>>,
    /// Absolute acceleration ü + Σ_d r_d a_d.
    pub absolute_acceleration: Vec<Vec<f64>>,
}

/// Integrate from rest. All excitations must have the same number of samples.
pub fn newmark_base_excitation(
    k: &CscMatrix,
    m: &CscMatrix,
    excitations: &[BaseExcitation],
    settings: &NewmarkSettings,
) -> Result<NewmarkResponse> {
    let n = k.n;
    let dt = settings.dt;
    if !(dt > 0.0 && dt.is_finite()) {
        return Err(Error::usage(format!(
            "Newmark: time step must be positive, is {dt}"
        )));
    }
    let steps = excitations
        .first()
        .map(|e| e.acceleration.len())
        .unwrap_or(0);
    for (i, e) in excitations.iter().enumerate() {
        if e.acceleration.len() != steps || e.influence.len() != n || e.load.len() != n {
            return Err(Error::usage(format!(
                "Newmark: excitation {i} has {} samples and {} influence entries (expected {steps} and {n})",
                e.acceleration.len(),
                e.influence.len()
            )));
        }
        if e.acceleration.iter().any(|v| !v.is_finite()) {
            return Err(Error::usage(format!(
                "Newmark: excitation {i} has non-finite samples"
            )));
        }
    }
    let dofs: Vec<usize> = settings.record.clone().unwrap_or_else(|| (0..n).collect());
    if let Some(&bad) = dofs.iter().find(|&&d| d >= n) {
        return Err(Error::usage(format!(
            "Newmark: recorded DoF {bad} outside 0..{n}"
        )));
    }
    let (a0, a1) = settings.rayleigh;
    let (gamma, beta) = (0.5, 0.25);
    // C = a0 M + a1 K and K̂ = K + c1 C + c0 M on the union pattern.
    let c0 = 1.0 / (beta * dt * dt);
    let c1 = gamma / (beta * dt);
    let family = AffineMatrix::from_matrices(k, &[m.clone()]);
    let c = family
        .at(&[a0])
        .values
        .iter()
        .zip(family.base.iter())
        .map(|(v, kv)| v - kv + a1 * kv)
        .collect::<Vec<_>>();
    let c = CscMatrix {
        n,
        col_ptr: family.col_ptr.clone(),
        row_idx: family.row_idx.clone(),
        values: c,
    };
    let khat = family.at(&[c0 + c1 * a0]);
    let khat = CscMatrix {
        values: khat
            .values
            .iter()
            .zip(family.base.iter())
            .map(|(v, kv)| v + c1 * a1 * kv)
            .collect(),
        ..khat
    };
    let lower = khat.to_faer_lower()?;
    let llt = lower.sp_cholesky(Side::Lower).map_err(|e| {
        Error::numerical(format!(
            "Newmark: effective stiffness is not positive definite ({e:?})"
        ))
    })?;
    // Kinematic ground acceleration on the free DoFs (Σ r a) and effective force (−Σ b a).
    let ground = |step: usize| -> Vec<f64> {
        let mut g = vec![0.0; n];
        for e in excitations {
            let a = e.acceleration[step];
            if a != 0.0 {
                for (gi, ri) in g.iter_mut().zip(&e.influence) {
                    *gi += ri * a;
                }
            }
        }
        g
    };
    let force = |step: usize| -> Vec<f64> {
        let mut p = vec![0.0; n];
        for e in excitations {
            let a = e.acceleration[step];
            if a != 0.0 {
                for (pi, bi) in p.iter_mut().zip(&e.load) {
                    *pi -= bi * a;
                }
            }
        }
        p
    };
    let mut u = vec![0.0; n];
    let mut v = vec![0.0; n];
    // Initial acceleration from rest: M ü0 = p0 (solved when M is positive definite; with
    // massless DoFs fall back to the kinematic value ü0 = −r a0, exact when b = M r).
    let p0 = force(0);
    let mut acc: Vec<f64> = ground(0).iter().map(|x| -x).collect();
    if p0.iter().any(|v| *v != 0.0) {
        if let Ok(ml) = m.to_faer_lower().and_then(|ml| {
            ml.sp_cholesky(Side::Lower)
                .map_err(|e| Error::numerical(format!("{e:?}")))
        }) {
            let mut r0 = Mat::<f64>::zeros(n, 1);
            for i in 0..n {
                r0[(i, 0)] = p0[i];
            }
            ml.solve_in_place(r0.as_mut());
            acc = (0..n).map(|i| r0[(i, 0)]).collect();
        }
    }
    let mut out = NewmarkResponse {
        dt,
        dofs: dofs.clone(),
        displacement: vec![Vec::with_capacity(steps); dofs.len()],
        velocity: vec![Vec::with_capacity(steps); dofs.len()],
        acceleration: vec![Vec::with_capacity(steps); dofs.len()],
        absolute_acceleration: vec![Vec::with_capacity(steps); dofs.len()],
    };
    let record = |u: &[f64], v: &[f64], a: &[f64], g: &[f64], out: &mut NewmarkResponse| {
        for (j, &d) in dofs.iter().enumerate() {
            out.displacement[j].push(u[d]);
            out.velocity[j].push(v[d]);
            out.acceleration[j].push(a[d]);
            out.absolute_acceleration[j].push(a[d] + g[d]);
        }
    };
    if steps > 0 {
        record(&u, &v, &acc, &ground(0), &mut out);
    }
    let mut rhs = Mat::<f64>::zeros(n, 1);
    let mut tmp_m = vec![0.0; n];
    let mut tmp_c = vec![0.0; n];
    let mut xm = vec![0.0; n];
    let mut xc = vec![0.0; n];
    for step in 1..steps {
        let g = ground(step);
        let p = force(step);
        // p̂ = p + M (c0 u + v/(βΔt) + (1/(2β) − 1) ü) + C (c1 u + (γ/β − 1) v + Δt(γ/(2β) − 1) ü).
        for i in 0..n {
            xm[i] = c0 * u[i] + v[i] / (beta * dt) + (0.5 / beta - 1.0) * acc[i];
            xc[i] = c1 * u[i]
                + (gamma / beta - 1.0) * v[i]
                + dt * (gamma / (2.0 * beta) - 1.0) * acc[i];
        }
        m.mul_vec(&xm, &mut tmp_m);
        c.mul_vec(&xc, &mut tmp_c);
        for i in 0..n {
            rhs[(i, 0)] = p[i] + tmp_m[i] + tmp_c[i];
        }
        llt.solve_in_place(rhs.as_mut());
        for i in 0..n {
            let un = rhs[(i, 0)];
            let an = c0 * (un - u[i]) - v[i] / (beta * dt) - (0.5 / beta - 1.0) * acc[i];
            let vn = v[i] + dt * ((1.0 - gamma) * acc[i] + gamma * an);
            u[i] = un;
            v[i] = vn;
            acc[i] = an;
        }
        record(&u, &v, &acc, &g, &mut out);
    }
    Ok(out)
}
