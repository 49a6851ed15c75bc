//! Four-node flat shell for walls and slabs: Q4 membrane + MITC4 Mindlin plate + drilling
//! penalty. DoFs ux, uy, uz, rx, ry, rz per node (global axes).
//!
//! - Membrane: the plane-stress Q4 of `q4` (2×2 Gauss).
//! - Plate: Mindlin–Reissner with bilinear w and rotations; bending 2×2 Gauss; transverse
//!   shear by MITC4 (Bathe & Dvorkin 1986): covariant shear strains sampled at the edge
//!   mid-points A(−1,0), B(0,−1), C(1,0), D(0,1) and interpolated linearly, which removes
//!   shear locking and passes the constant-curvature patch test.
//! - Drilling: the in-plane rotation θz gets a penalty k_d Σ_nodes (θz,a − ω_a)² / 2 with ω_a
//!   = ½(∂v/∂x − ∂u/∂y) of the membrane field at node a, k_d = 1e-3·G·t·A/4. It vanishes
//!   for rigid-body motion, so a free shell keeps its six rigid-body modes, and keeps flat
//!   assemblies non-singular.
//! - Mass: consistent ρt∫NᵀN for translations; rotary inertia ρt³/12 lumped on θx, θy, θz.
//! - Geometry: a flat mean plane (normal from the diagonals' cross product); warped
//!   elements are projected onto it (warping is ignored).

use super::q4::{plane_stress_d, q4_matrices, PlaneStress};
use super::{bilinear, gauss_legendre, quad_jacobian, SmallMatrix};

#[derive(Debug, Clone, Copy)]
pub struct ShellSection {
    pub youngs_modulus: f64,
    pub poisson: f64,
    pub density: f64,
    pub thickness: f64,
    /// Transverse shear correction (5/6).
    pub shear_factor: f64,
}

/// Relative drilling penalty.
pub const DRILLING_PENALTY: f64 = 1e-3;

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn unit(a: [f64; 3]) -> Option<[f64; 3]> {
    let n = dot(a, a).sqrt();
    if n > 0.0 && n.is_finite() {
        Some([a[0] / n, a[1] / n, a[2] / n])
    } else {
        None
    }
}

/// Mean-plane axes (rows e1, e2, e3) and local 2D coordinates of the four nodes.
pub fn shell_frame(p: &[[f64; 3]; 4]) -> Option<([[f64; 3]; 3], [[f64; 2]; 4])> {
    let e3 = unit(cross(sub(p[2], p[0]), sub(p[3], p[1])))?;
    let v = [
        0.5 * (p[1][0] + p[2][0] - p[0][0] - p[3][0]),
        0.5 * (p[1][1] + p[2][1] - p[0][1] - p[3][1]),
        0.5 * (p[1][2] + p[2][2] - p[0][2] - p[3][2]),
    ];
    let vn = dot(v, e3);
    let e1 = unit([v[0] - vn * e3[0], v[1] - vn * e3[1], v[2] - vn * e3[2]])?;
    let e2 = cross(e3, e1);
    let c = [
        0.25 * (p[0][0] + p[1][0] + p[2][0] + p[3][0]),
        0.25 * (p[0][1] + p[1][1] + p[2][1] + p[3][1]),
        0.25 * (p[0][2] + p[1][2] + p[2][2] + p[3][2]),
    ];
    let mut xy = [[0.0; 2]; 4];
    for a in 0..4 {
        let d = sub(p[a], c);
        xy[a] = [dot(d, e1), dot(d, e2)];
    }
    Some(([e1, e2, e3], xy))
}

/// Plate part in local coordinates: 12×12 over (w, θx, θy) per node; bending + MITC4 shear.
pub fn mitc4_plate_stiffness(
    xy: &[[f64; 2]; 4],
    e: f64,
    nu: f64,
    t: f64,
    kappa: f64,
) -> Option<SmallMatrix> {
    let db = plane_stress_d(e, nu);
    let bend_scale = t * t * t / 12.0;
    let g = e / (2.0 * (1.0 + nu));
    let ds = kappa * g * t;
    // Covariant shear rows at a natural point: γ_ξ and γ_η as rows over the 12 DoFs.
    let covariant_rows = |xi: f64, eta: f64| -> ([f64; 12], [f64; 12]) {
        let (n, dxi, deta) = bilinear(xi, eta);
        let (mut x_xi, mut y_xi, mut x_eta, mut y_eta) = (0.0, 0.0, 0.0, 0.0);
        for a in 0..4 {
            x_xi += dxi[a] * xy[a][0];
            y_xi += dxi[a] * xy[a][1];
            x_eta += deta[a] * xy[a][0];
            y_eta += deta[a] * xy[a][1];
        }
        let mut r_xi = [0.0; 12];
        let mut r_eta = [0.0; 12];
        // γ = ∇w + β with β = (θy, −θx).
        for a in 0..4 {
            r_xi[3 * a] = dxi[a];
            r_xi[3 * a + 1] = -n[a] * y_xi;
            r_xi[3 * a + 2] = n[a] * x_xi;
            r_eta[3 * a] = deta[a];
            r_eta[3 * a + 1] = -n[a] * y_eta;
            r_eta[3 * a + 2] = n[a] * x_eta;
        }
        (r_xi, r_eta)
    };
    let (gxi_b, _) = covariant_rows(0.0, -1.0);
    let (gxi_d, _) = covariant_rows(0.0, 1.0);
    let (_, geta_a) = covariant_rows(-1.0, 0.0);
    let (_, geta_c) = covariant_rows(1.0, 0.0);
    let (pts, wts) = gauss_legendre(2);
    let mut k = SmallMatrix::zeros(12);
    for (xi, wxi) in pts.iter().zip(wts.iter()) {
        for (eta, weta) in pts.iter().zip(wts.iter()) {
            let (det, dx, dy, j) = quad_jacobian(xy, *xi, *eta)?;
            let w = wxi * weta * det;
            // Bending: κx = ∂θy/∂x, κy = −∂θx/∂y, κxy = ∂θy/∂y − ∂θx/∂x.
            let mut bb = [[0.0; 12]; 3];
            for a in 0..4 {
                bb[0][3 * a + 2] = dx[a];
                bb[1][3 * a + 1] = -dy[a];
                bb[2][3 * a + 1] = -dx[a];
                bb[2][3 * a + 2] = dy[a];
            }
            // MITC4 assumed covariant shear, then Cartesian: [γx; γy] = J⁻¹ [γξ; γη].
            let mut gxi = [0.0; 12];
            let mut geta = [0.0; 12];
            for i in 0..12 {
                gxi[i] = 0.5 * (1.0 - eta) * gxi_b[i] + 0.5 * (1.0 + eta) * gxi_d[i];
                geta[i] = 0.5 * (1.0 - xi) * geta_a[i] + 0.5 * (1.0 + xi) * geta_c[i];
            }
            let detj = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            let inv = [
                [j[1][1] / detj, -j[0][1] / detj],
                [-j[1][0] / detj, j[0][0] / detj],
            ];
            let mut bs = [[0.0; 12]; 2];
            for i in 0..12 {
                bs[0][i] = inv[0][0] * gxi[i] + inv[0][1] * geta[i];
                bs[1][i] = inv[1][0] * gxi[i] + inv[1][1] * geta[i];
            }
            for i in 0..12 {
                for jj in 0..12 {
                    let mut s = 0.0;
                    for r in 0..3 {
                        for c in 0..3 {
                            s += bb[r][i] * db[r][c] * bb[c][jj];
                        }
                    }
                    let shear = bs[0][i] * bs[0][jj] + bs[1][i] * bs[1][jj];
                    k.add(i, jj, w * (bend_scale * s + ds * shear));
                }
            }
        }
    }
    Some(k)
}

/// Global 24×24 stiffness and mass of the flat shell.
pub fn shell4_matrices(p: &[[f64; 3]; 4], s: &ShellSection) -> Option<(SmallMatrix, SmallMatrix)> {
    let (axes, xy) = shell_frame(p)?;
    let ps = PlaneStress {
        youngs_modulus: s.youngs_modulus,
        poisson: s.poisson,
        density: s.density,
        thickness: s.thickness,
    };
    let (km, mm) = q4_matrices(&xy, &ps)?;
    let kp = mitc4_plate_stiffness(
        &xy,
        s.youngs_modulus,
        s.poisson,
        s.thickness,
        s.shear_factor,
    )?;
    // Local DoFs per node: u v w θx θy θz at offsets 0..5.
    let mut kl = SmallMatrix::zeros(24);
    let mut ml = SmallMatrix::zeros(24);
    for a in 0..4 {
        for b in 0..4 {
            for r in 0..2 {
                for c in 0..2 {
                    kl.add(6 * a + r, 6 * b + c, km.get(2 * a + r, 2 * b + c));
                    ml.add(6 * a + r, 6 * b + c, mm.get(2 * a + r, 2 * b + c));
                }
            }
            for r in 0..3 {
                for c in 0..3 {
                    kl.add(6 * a + 2 + r, 6 * b + 2 + c, kp.get(3 * a + r, 3 * b + c));
                }
            }
            // Transverse translation mass equals the in-plane one.
            ml.add(6 * a + 2, 6 * b + 2, mm.get(2 * a, 2 * b));
        }
    }
    // Element area and nodal tributary areas ∫N_a dA.
    let (pts, wts) = gauss_legendre(2);
    let mut tributary = [0.0; 4];
    for (xi, wxi) in pts.iter().zip(wts.iter()) {
        for (eta, weta) in pts.iter().zip(wts.iter()) {
            let (det, _, _, _) = quad_jacobian(&xy, *xi, *eta)?;
            let (n, _, _) = bilinear(*xi, *eta);
            for a in 0..4 {
                tributary[a] += wxi * weta * det * n[a];
            }
        }
    }
    let area: f64 = tributary.iter().sum();
    let rotary = s.density * s.thickness.powi(3) / 12.0;
    for a in 0..4 {
        for r in 3..6 {
            ml.add(6 * a + r, 6 * a + r, rotary * tributary[a]);
        }
    }
    // Drilling penalty: d_a = θz,a − ½(∂v/∂x − ∂u/∂y) at node a.
    let g = s.youngs_modulus / (2.0 * (1.0 + s.poisson));
    let kd = DRILLING_PENALTY * g * s.thickness * area / 4.0;
    const XI: [f64; 4] = [-1.0, 1.0, 1.0, -1.0];
    const ETA: [f64; 4] = [-1.0, -1.0, 1.0, 1.0];
    for a in 0..4 {
        let (_, dx, dy, _) = quad_jacobian(&xy, XI[a], ETA[a])?;
        let mut row = [0.0; 24];
        row[6 * a + 5] = 1.0;
        for b in 0..4 {
            row[6 * b] += 0.5 * dy[b];
            row[6 * b + 1] -= 0.5 * dx[b];
        }
        for i in 0..24 {
            if row[i] == 0.0 {
                continue;
            }
            for j in 0..24 {
                kl.add(i, j, kd * row[i] * row[j]);
            }
        }
    }
    let mut t = SmallMatrix::zeros(24);
    for block in 0..8 {
        for r in 0..3 {
            for c in 0..3 {
                t.set(3 * block + r, 3 * block + c, axes[r][c]);
            }
        }
    }
    Some((kl.congruence(&t), ml.congruence(&t)))
}
