//! Four-node plane-stress membrane (Q4), bilinear isoparametric, full 2×2 Gauss integration
//! for stiffness and consistent mass. DoFs ux, uy per node; nodes counter-clockwise.
//! Full integration makes it stiff in in-plane bending (parasitic shear) on coarse meshes; it
//! passes the constant-strain patch test, which is what convergence needs.

use super::{bilinear, gauss_legendre, quad_jacobian, SmallMatrix};

#[derive(Debug, Clone, Copy)]
pub struct PlaneStress {
    pub youngs_modulus: f64,
    pub poisson: f64,
    pub density: f64,
    pub thickness: f64,
}

/// Plane-stress constitutive matrix (σx, σy, τxy) = D (εx, εy, γxy).
pub fn plane_stress_d(e: f64, nu: f64) -> [[f64; 3]; 3] {
    let c = e / (1.0 - nu * nu);
    [
        [c, c * nu, 0.0],
        [c * nu, c, 0.0],
        [0.0, 0.0, c * (1.0 - nu) / 2.0],
    ]
}

/// Membrane stiffness and consistent mass (8×8, DoFs ux1, uy1, …, ux4, uy4) of a planar
/// quadrilateral given in its own 2D coordinates. None for an inverted/degenerate element.
pub fn q4_matrices(xy: &[[f64; 2]; 4], p: &PlaneStress) -> Option<(SmallMatrix, SmallMatrix)> {
    let d = plane_stress_d(p.youngs_modulus, p.poisson);
    let (pts, wts) = gauss_legendre(2);
    let mut k = SmallMatrix::zeros(8);
    let mut m = SmallMatrix::zeros(8);
    for (xi, wxi) in pts.iter().zip(wts.iter()) {
        for (eta, weta) in pts.iter().zip(wts.iter()) {
            let (det, dx, dy, _) = quad_jacobian(xy, *xi, *eta)?;
            let (n, _, _) = bilinear(*xi, *eta);
            let w = wxi * weta * det;
            // Strain-displacement rows for (εx, εy, γxy).
            let mut b = [[0.0; 8]; 3];
            for a in 0..4 {
                b[0][2 * a] = dx[a];
                b[1][2 * a + 1] = dy[a];
                b[2][2 * a] = dy[a];
                b[2][2 * a + 1] = dx[a];
            }
            for i in 0..8 {
                for j in 0..8 {
                    let mut s = 0.0;
                    for r in 0..3 {
                        for c in 0..3 {
                            s += b[r][i] * d[r][c] * b[c][j];
                        }
                    }
                    k.add(i, j, w * p.thickness * s);
                }
            }
            for a in 0..4 {
                for c in 0..4 {
                    let v = w * p.density * p.thickness * n[a] * n[c];
                    m.add(2 * a, 2 * c, v);
                    m.add(2 * a + 1, 2 * c + 1, v);
                }
            }
        }
    }
    Some((k, m))
}
