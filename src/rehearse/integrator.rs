//! Time integration of the hybrid equation of motion, the schemes of pseudo-dynamic testing:
//!
//!   M ẍ + C ẋ + K_N x + L r = f(t),   f(t) = −Σ_d b_d a_d(t),
//!
//! with r the restoring force the load cells measure at the actuated DoFs (Lᵀ x commanded).
//!
//! - **Central difference** (explicit Newmark, γ = 1/2, β = 0; Shing & Mahin 1984, 1987):
//!   (M/Δt² + C/2Δt) x_{n+1} = f_n − K_N x_n − L r_n + 2M/Δt² x_n − (M/Δt² − C/2Δt) x_{n−1};
//!   the command is x_{n+1} itself, r_{n+1} is measured there. Conditionally stable:
//!   ω_max Δt < 2.
//! - **α-OS**, the α-operator-splitting scheme (Nakashima, Ishii & Ando 1990; Combescure &
//!   Pegon 1997): HHT-α with the restoring force split into a measured part at the
//!   predictor and an implicit part through the initial stiffness K_I = L K_P Lᵀ:
//!   x̃_{n+1} = x_n + Δt v_n + Δt²(1/2 − β) a_n,  ṽ_{n+1} = v_n + Δt (1 − γ) a_n,
//!   r(x_{n+1}) ≈ r̃_{n+1} + K_I (x_{n+1} − x̃_{n+1}),  r̃_{n+1} measured at x̃_{n+1},
//!   M a_{n+1} + (1+α)[C v_{n+1} + K_N x_{n+1} + L r̃_{n+1} + K_I (x_{n+1} − x̃_{n+1})]
//!   − α[C v_n + K_N x_n + L r̃_n + K_I (x_n − x̃_n)] = (1+α) f_{n+1} − α f_n,
//!   x_{n+1} = x̃_{n+1} + β Δt² a_{n+1},  v_{n+1} = ṽ_{n+1} + γ Δt a_{n+1},
//!   α ∈ [−1/3, 0], γ = (1 − 2α)/2, β = (1 − α)²/4: unconditionally stable for a specimen
//!   whose tangent stiffness does not exceed K_I (Combescure & Pegon 1997).
//!
//! Dense matrices (the prototype has tens of coordinates), row-major, no I/O.

use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Mat, Par, Side};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Integration scheme.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Scheme {
    CentralDifference,
    AlphaOs,
}

impl Scheme {
    pub fn name(self) -> &'static str {
        match self {
            Scheme::CentralDifference => "central-difference",
            Scheme::AlphaOs => "alpha-os",
        }
    }
}

/// The specimen seen through its actuators: impose the targets at the actuated coordinates,
/// return the measured restoring forces.
pub trait Specimen {
    fn impose(&mut self, targets: &[f64], force: &mut [f64]);
}

/// The hybrid system: n coordinates, the m actuated ones at `offset..offset + m`.
#[derive(Debug, Clone)]
pub struct HybridSystem {
    pub mass: Mat<f64>,
    pub damping: Mat<f64>,
    /// K_N = K̂ − L K_P Lᵀ (numerical part).
    pub numerical_stiffness: Mat<f64>,
    /// K_P (m × m): the specimen's initial stiffness at the actuated coordinates.
    pub ps_stiffness: Mat<f64>,
    pub offset: usize,
}

impl HybridSystem {
    pub fn n(&self) -> usize {
        self.mass.nrows()
    }
    pub fn m(&self) -> usize {
        self.ps_stiffness.nrows()
    }
}

/// Row-major dense n × n matrix for the stepping loops.
struct Dense {
    n: usize,
    v: Vec<f64>,
}

impl Dense {
    fn from(m: &Mat<f64>) -> Self {
        let n = m.nrows();
        Dense {
            n,
            v: (0..n * n).map(|k| m[(k / n, k % n)]).collect(),
        }
    }
    /// y = A x (four partial sums per row, in a fixed order: vectorisable and deterministic).
    fn mul(&self, x: &[f64], y: &mut [f64]) {
        let n = self.n;
        let x = &x[..n];
        for (i, yi) in y.iter_mut().enumerate().take(n) {
            let row = &self.v[i * n..(i + 1) * n];
            let mut acc = [0.0; 4];
            let (rc, rr) = row.split_at(n - n % 4);
            let (xc, xr) = x.split_at(n - n % 4);
            for (a, b) in rc.chunks_exact(4).zip(xc.chunks_exact(4)) {
                for k in 0..4 {
                    acc[k] += a[k] * b[k];
                }
            }
            let tail: f64 = rr.iter().zip(xr).map(|(a, b)| a * b).sum();
            *yi = (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail;
        }
    }
}

/// A⁻¹ of a symmetric positive definite A (Cholesky).
fn spd_inverse(a: &Mat<f64>, what: &str) -> Result<Mat<f64>> {
    let n = a.nrows();
    let llt = a.llt(Side::Lower).map_err(|e| {
        Error::numerical(format!(
            "rehearsal: the {what} matrix is not positive definite ({e:?})"
        ))
    })?;
    let mut x = Mat::<f64>::identity(n, n);
    solve_lower_triangular_in_place(llt.L(), x.as_mut(), Par::Seq);
    Ok(x.transpose() * &x)
}

/// State of one integration.
pub struct Integrator {
    scheme: Scheme,
    dt: f64,
    alpha: f64,
    beta: f64,
    gamma: f64,
    offset: usize,
    m: usize,
    /// Inverse of the effective matrix (CD: M/Δt² + C/2Δt; α-OS: M + (1+α)γΔt C + (1+α)βΔt² K̂).
    p: Dense,
    mass: Dense,
    damping: Dense,
    kn: Dense,
    kp: Dense,
    pub x: Vec<f64>,
    pub v: Vec<f64>,
    x_prev: Vec<f64>,
    a: Vec<f64>,
    /// x_n − x̃_n (α-OS) and the force measured at the last command.
    correction: Vec<f64>,
    force: Vec<f64>,
    work: Vec<f64>,
    rhs: Vec<f64>,
    /// Scratch of the α-OS step (predictors, gathered vectors, forces).
    xt: Vec<f64>,
    vt: Vec<f64>,
    dx: Vec<f64>,
    dv: Vec<f64>,
    ki: Vec<f64>,
    old_force: Vec<f64>,
}

impl Integrator {
    /// From rest under the load `f0` at t = 0. `alpha` only for α-OS (in [−1/3, 0]).
    pub fn new(
        sys: &HybridSystem,
        scheme: Scheme,
        alpha: f64,
        dt: f64,
        f0: &[f64],
    ) -> Result<Self> {
        let n = sys.n();
        if !(-1.0 / 3.0 - 1e-12..=0.0).contains(&alpha) {
            return Err(Error::usage(format!(
                "rehearsal: alpha {alpha} must lie in [-1/3, 0]"
            )));
        }
        let (beta, gamma) = ((1.0 - alpha).powi(2) / 4.0, (1.0 - 2.0 * alpha) / 2.0);
        let mut k_hat = sys.numerical_stiffness.clone();
        for i in 0..sys.m() {
            for j in 0..sys.m() {
                k_hat[(sys.offset + i, sys.offset + j)] += sys.ps_stiffness[(i, j)];
            }
        }
        let eff = match scheme {
            Scheme::CentralDifference => Mat::from_fn(n, n, |i, j| {
                sys.mass[(i, j)] / (dt * dt) + sys.damping[(i, j)] / (2.0 * dt)
            }),
            Scheme::AlphaOs => Mat::from_fn(n, n, |i, j| {
                sys.mass[(i, j)]
                    + (1.0 + alpha) * gamma * dt * sys.damping[(i, j)]
                    + (1.0 + alpha) * beta * dt * dt * k_hat[(i, j)]
            }),
        };
        let p = Dense::from(&spd_inverse(&eff, "effective")?);
        let m_inv = Dense::from(&spd_inverse(&sys.mass, "mass")?);
        let mut a0 = vec![0.0; n];
        m_inv.mul(f0, &mut a0);
        // Central difference starts from x_{−1} = Δt²/2 a_0 (x_0 = v_0 = 0).
        let x_prev = match scheme {
            Scheme::CentralDifference => a0.iter().map(|a| 0.5 * dt * dt * a).collect(),
            Scheme::AlphaOs => vec![0.0; n],
        };
        Ok(Integrator {
            scheme,
            dt,
            alpha,
            beta,
            gamma,
            offset: sys.offset,
            m: sys.m(),
            p,
            mass: Dense::from(&sys.mass),
            damping: Dense::from(&sys.damping),
            kn: Dense::from(&sys.numerical_stiffness),
            kp: Dense::from(&sys.ps_stiffness),
            x: vec![0.0; n],
            v: vec![0.0; n],
            x_prev,
            a: a0,
            correction: vec![0.0; n],
            force: vec![0.0; sys.m()],
            work: vec![0.0; n],
            rhs: vec![0.0; n],
            xt: vec![0.0; n],
            vt: vec![0.0; n],
            dx: vec![0.0; n],
            dv: vec![0.0; n],
            ki: vec![0.0; sys.m()],
            old_force: vec![0.0; sys.m()],
        })
    }

    /// Starts from the static state x_0 with the specimen's measured force r_0 (gravity
    /// pre-load, `gravity` Eq. G1–G2): x and (CD) x_{−1} shift by x_0; the initial
    /// acceleration, from the seismic load at t = 0, is unchanged since K̂ x_0 = f̂_g.
    pub fn preload(&mut self, x0: &[f64], r0: &[f64]) {
        axpy(1.0, x0, &mut self.x);
        axpy(1.0, x0, &mut self.x_prev);
        self.force.copy_from_slice(r0);
    }

    /// The force measured at the last command.
    pub fn measured_force(&self) -> &[f64] {
        &self.force
    }

    /// One step from t_n to t_{n+1} under loads f_n, f_{n+1}; the specimen receives the
    /// command (written into `command`, m values) and returns its force.
    pub fn step(
        &mut self,
        f_n: &[f64],
        f_next: &[f64],
        specimen: &mut impl Specimen,
        command: &mut [f64],
    ) {
        let n = self.x.len();
        let (o, m, dt) = (self.offset, self.m, self.dt);
        match self.scheme {
            Scheme::CentralDifference => {
                // rhs = f_n − K_N x_n − L r_n + 2M/Δt² x_n − (M/Δt² − C/2Δt) x_{n−1}
                self.kn.mul(&self.x, &mut self.rhs);
                for (r, f) in self.rhs.iter_mut().zip(f_n) {
                    *r = f - *r;
                }
                for i in 0..m {
                    self.rhs[o + i] -= self.force[i];
                }
                let tmp: Vec<f64> = (0..n).map(|i| 2.0 * self.x[i] - self.x_prev[i]).collect();
                self.mass.mul(&tmp, &mut self.work);
                for i in 0..n {
                    self.rhs[i] += self.work[i] / (dt * dt);
                }
                self.damping.mul(&self.x_prev, &mut self.work);
                for i in 0..n {
                    self.rhs[i] += self.work[i] / (2.0 * dt);
                }
                let mut next = vec![0.0; n];
                self.p.mul(&self.rhs, &mut next);
                command.copy_from_slice(&next[o..o + m]);
                specimen.impose(command, &mut self.force);
                for ((v, x1), x0) in self.v.iter_mut().zip(&next).zip(&self.x_prev) {
                    *v = (x1 - x0) / (2.0 * dt);
                }
                self.x_prev = std::mem::replace(&mut self.x, next);
            }
            Scheme::AlphaOs => {
                let (al, be, ga) = (self.alpha, self.beta, self.gamma);
                let (mut xt, mut vt) = (std::mem::take(&mut self.xt), std::mem::take(&mut self.vt));
                for i in 0..n {
                    xt[i] = self.x[i] + dt * self.v[i] + dt * dt * (0.5 - be) * self.a[i];
                    vt[i] = self.v[i] + dt * (1.0 - ga) * self.a[i];
                }
                command.copy_from_slice(&xt[o..o + m]);
                self.old_force.copy_from_slice(&self.force);
                specimen.impose(command, &mut self.force);
                // rhs = (1+α) f_{n+1} − α f_n − (1+α)(C ṽ + K_N x̃ + L r̃_{n+1})
                //       + α (C v_n + K_N x_n + L r̃_n + K_I (x_n − x̃_n)),
                // the C and K_N terms gathered: C (α v_n − (1+α) ṽ) + K_N (α x_n − (1+α) x̃).
                for i in 0..n {
                    self.rhs[i] = (1.0 + al) * f_next[i] - al * f_n[i];
                    self.dv[i] = al * self.v[i] - (1.0 + al) * vt[i];
                    self.dx[i] = al * self.x[i] - (1.0 + al) * xt[i];
                }
                self.damping.mul(&self.dv, &mut self.work);
                axpy(1.0, &self.work, &mut self.rhs);
                self.kn.mul(&self.dx, &mut self.work);
                axpy(1.0, &self.work, &mut self.rhs);
                self.kp.mul(&self.correction[o..o + m], &mut self.ki);
                for i in 0..m {
                    self.rhs[o + i] +=
                        -(1.0 + al) * self.force[i] + al * (self.old_force[i] + self.ki[i]);
                }
                self.p.mul(&self.rhs, &mut self.a);
                for i in 0..n {
                    self.correction[i] = be * dt * dt * self.a[i];
                    self.x[i] = xt[i] + self.correction[i];
                    self.v[i] = vt[i] + ga * dt * self.a[i];
                }
                (self.xt, self.vt) = (xt, vt);
            }
        }
    }
}

fn axpy(s: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += s * xi;
    }
}
