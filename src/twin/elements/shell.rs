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
use nalgebra::{Matrix3, SMatrix, Vector2, Vector3};

use super::{bilinear, gauss_legendre, quad_map, rotate_to_global, unit, QUAD_CORNERS};

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

/// Mean-plane axes (rows e1, e2, e3) and local 2D coordinates of the four nodes.
pub fn shell_frame(p: &[Vector3<f64>; 4]) -> Option<(Matrix3<f64>, [Vector2<f64>; 4])> {
    let e3 = unit((p[2] - p[0]).cross(&(p[3] - p[1])))?;
    // Mean direction of the edges 1→2 and 4→3, projected onto the plane.
    let v = (p[1] + p[2] - p[0] - p[3]) * 0.5;
    let e1 = unit(v - e3 * v.dot(&e3))?;
    let e2 = e3.cross(&e1);
    let centre = (p[0] + p[1] + p[2] + p[3]) * 0.25;
    let xy = p.map(|node| {
        let d = node - centre;
        Vector2::new(d.dot(&e1), d.dot(&e2))
    });
    let axes = Matrix3::from_rows(&[e1.transpose(), e2.transpose(), e3.transpose()]);
    Some((axes, xy))
}

/// Rows of the covariant transverse shear strains (γ_ξ, γ_η) over the 12 plate DoFs
/// (w, θx, θy per node) at a natural point: γ = ∇w + β with β = (θy, −θx).
fn covariant_shear_rows(xy: &[Vector2<f64>; 4], xi: f64, eta: f64) -> SMatrix<f64, 2, 12> {
    let (n, dxi, deta) = bilinear(xi, eta);
    let (mut x_xi, mut y_xi, mut x_eta, mut y_eta) = (0.0, 0.0, 0.0, 0.0);
    for a in 0..4 {
        x_xi += dxi[a] * xy[a].x;
        y_xi += dxi[a] * xy[a].y;
        x_eta += deta[a] * xy[a].x;
        y_eta += deta[a] * xy[a].y;
    }
    let mut rows = SMatrix::<f64, 2, 12>::zeros();
    for a in 0..4 {
        rows[(0, 3 * a)] = dxi[a];
        rows[(0, 3 * a + 1)] = -n[a] * y_xi;
        rows[(0, 3 * a + 2)] = n[a] * x_xi;
        rows[(1, 3 * a)] = deta[a];
        rows[(1, 3 * a + 1)] = -n[a] * y_eta;
        rows[(1, 3 * a + 2)] = n[a] * x_eta;
    }
    rows
}

/// Plate part in local coordinates: 12×12 over (w, θx, θy) per node; bending + MITC4 shear.
pub fn mitc4_plate_stiffness(
    xy: &[Vector2<f64>; 4],
    e: f64,
    nu: f64,
    t: f64,
    kappa: f64,
) -> Option<SMatrix<f64, 12, 12>> {
    let db = plane_stress_d(e, nu) * (t * t * t / 12.0);
    let g = e / (2.0 * (1.0 + nu));
    let ds = kappa * g * t;
    // MITC4 tying points: γ_ξ at B(0,−1) and D(0,1), γ_η at A(−1,0) and C(1,0).
    let gxi_b = covariant_shear_rows(xy, 0.0, -1.0).row(0).into_owned();
    let gxi_d = covariant_shear_rows(xy, 0.0, 1.0).row(0).into_owned();
    let geta_a = covariant_shear_rows(xy, -1.0, 0.0).row(1).into_owned();
    let geta_c = covariant_shear_rows(xy, 1.0, 0.0).row(1).into_owned();
    let (pts, wts) = gauss_legendre(2);
    let mut k = SMatrix::<f64, 12, 12>::zeros();
    for (xi, wxi) in pts.iter().zip(wts.iter()) {
        for (eta, weta) in pts.iter().zip(wts.iter()) {
            let map = quad_map(xy, *xi, *eta)?;
            let w = wxi * weta * map.det;
            // Bending: κx = ∂θy/∂x, κy = −∂θx/∂y, κxy = ∂θy/∂y − ∂θx/∂x.
            let mut bb = SMatrix::<f64, 3, 12>::zeros();
            for a in 0..4 {
                bb[(0, 3 * a + 2)] = map.dx[a];
                bb[(1, 3 * a + 1)] = -map.dy[a];
                bb[(2, 3 * a + 1)] = -map.dx[a];
                bb[(2, 3 * a + 2)] = map.dy[a];
            }
            // MITC4 assumed covariant shear, then Cartesian: [γx; γy] = J⁻¹ [γξ; γη].
            let mut covariant = SMatrix::<f64, 2, 12>::zeros();
            covariant.set_row(
                0,
                &(gxi_b * (0.5 * (1.0 - eta)) + gxi_d * (0.5 * (1.0 + eta))),
            );
            covariant.set_row(
                1,
                &(geta_a * (0.5 * (1.0 - xi)) + geta_c * (0.5 * (1.0 + xi))),
            );
            let bs = map.inverse_jacobian * covariant;
            k += (bb.transpose() * db * bb + bs.transpose() * bs * ds) * w;
        }
    }
    Some(k)
}

/// Global 24×24 stiffness and mass of the flat shell.
pub fn shell4_matrices(
    p: &[Vector3<f64>; 4],
    s: &ShellSection,
) -> Option<(SMatrix<f64, 24, 24>, SMatrix<f64, 24, 24>)> {
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
    let mut kl = SMatrix::<f64, 24, 24>::zeros();
    let mut ml = SMatrix::<f64, 24, 24>::zeros();
    for a in 0..4 {
        for b in 0..4 {
            kl.fixed_view_mut::<2, 2>(6 * a, 6 * b)
                .copy_from(&km.fixed_view::<2, 2>(2 * a, 2 * b));
            ml.fixed_view_mut::<2, 2>(6 * a, 6 * b)
                .copy_from(&mm.fixed_view::<2, 2>(2 * a, 2 * b));
            kl.fixed_view_mut::<3, 3>(6 * a + 2, 6 * b + 2)
                .copy_from(&kp.fixed_view::<3, 3>(3 * a, 3 * b));
            // Transverse translation mass equals the in-plane one.
            ml[(6 * a + 2, 6 * b + 2)] = mm[(2 * a, 2 * b)];
        }
    }
    // Element area and nodal tributary areas ∫N_a dA.
    let (pts, wts) = gauss_legendre(2);
    let mut tributary = [0.0; 4];
    for (xi, wxi) in pts.iter().zip(wts.iter()) {
        for (eta, weta) in pts.iter().zip(wts.iter()) {
            let map = quad_map(&xy, *xi, *eta)?;
            let (n, _, _) = bilinear(*xi, *eta);
            for a in 0..4 {
                tributary[a] += wxi * weta * map.det * n[a];
            }
        }
    }
    let area: f64 = tributary.iter().sum();
    let rotary = s.density * s.thickness.powi(3) / 12.0;
    for a in 0..4 {
        for r in 3..6 {
            ml[(6 * a + r, 6 * a + r)] += rotary * tributary[a];
        }
    }
    // Drilling penalty: d_a = θz,a − ½(∂v/∂x − ∂u/∂y) at node a; k += k_d dᵀd.
    let g = s.youngs_modulus / (2.0 * (1.0 + s.poisson));
    let kd = DRILLING_PENALTY * g * s.thickness * area / 4.0;
    for (a, &(xi_a, eta_a)) in QUAD_CORNERS.iter().enumerate() {
        let map = quad_map(&xy, xi_a, eta_a)?;
        let mut row = SMatrix::<f64, 1, 24>::zeros();
        row[6 * a + 5] = 1.0;
        for b in 0..4 {
            row[6 * b] += 0.5 * map.dy[b];
            row[6 * b + 1] -= 0.5 * map.dx[b];
        }
        kl += row.transpose() * row * kd;
    }
    Some((rotate_to_global(&kl, &axes), rotate_to_global(&ml, &axes)))
}
