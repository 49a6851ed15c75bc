//! Four-node plane-stress membrane (Q4), bilinear isoparametric, full 2×2 Gauss integration
//! for stiffness and consistent mass. DoFs ux, uy per node; nodes counter-clockwise.
//! Full integration makes it stiff in in-plane bending (parasitic shear) on coarse meshes; it
//! passes the constant-strain patch test, which is what convergence needs.

use nalgebra::{Matrix3, SMatrix, Vector2, Vector4};

use super::{bilinear, gauss_legendre, quad_map};

#[derive(Debug, Clone, Copy)]
pub struct PlaneStress {
    pub youngs_modulus: f64,
    pub poisson: f64,
    pub density: f64,
    pub thickness: f64,
}

/// Plane-stress constitutive matrix (σx, σy, τxy) = D (εx, εy, γxy).
pub fn plane_stress_d(e: f64, nu: f64) -> Matrix3<f64> {
    let c = e / (1.0 - nu * nu);
    #[rustfmt::skip]
    let d = Matrix3::new(
        c, c * nu, 0.0,
        c * nu, c, 0.0,
        0.0, 0.0, c * (1.0 - nu) / 2.0,
    );
    d
}

/// Membrane stiffness and consistent mass (8×8, DoFs ux1, uy1, …, ux4, uy4) of a planar
/// quadrilateral given in its own 2D coordinates: k = ∫ t Bᵀ D B dA, m = ∫ ρ t NᵀN dA.
/// None for an inverted/degenerate element.
pub fn q4_matrices(
    xy: &[Vector2<f64>; 4],
    p: &PlaneStress,
) -> Option<(SMatrix<f64, 8, 8>, SMatrix<f64, 8, 8>)> {
    let d = plane_stress_d(p.youngs_modulus, p.poisson);
    let (pts, wts) = gauss_legendre(2);
    let mut k = SMatrix::<f64, 8, 8>::zeros();
    let mut m = SMatrix::<f64, 8, 8>::zeros();
    for (xi, wxi) in pts.iter().zip(wts.iter()) {
        for (eta, weta) in pts.iter().zip(wts.iter()) {
            let map = quad_map(xy, *xi, *eta)?;
            let (n, _, _) = bilinear(*xi, *eta);
            let w = wxi * weta * map.det;
            // Strain-displacement rows for (εx, εy, γxy).
            let mut b = SMatrix::<f64, 3, 8>::zeros();
            for a in 0..4 {
                b[(0, 2 * a)] = map.dx[a];
                b[(1, 2 * a + 1)] = map.dy[a];
                b[(2, 2 * a)] = map.dy[a];
                b[(2, 2 * a + 1)] = map.dx[a];
            }
            k += b.transpose() * d * b * (w * p.thickness);
            let n = Vector4::from(n);
            let scalar_mass = n * n.transpose() * (w * p.density * p.thickness);
            for a in 0..4 {
                for c in 0..4 {
                    m[(2 * a, 2 * c)] += scalar_mass[(a, c)];
                    m[(2 * a + 1, 2 * c + 1)] += scalar_mass[(a, c)];
                }
            }
        }
    }
    Some((k, m))
}
