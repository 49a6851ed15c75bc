//! Two-node Timoshenko beam in space (DoFs ux, uy, uz, rx, ry, rz per node).
//!
//! Local axes: x from node 1 to node 2; a reference vector `vxz` lying in the local x–z
//! plane fixes the rest (y = vxz × x, z = x × y; the OpenSees convention). Default `vxz`:
//! global Z, or global X when the element is parallel to Z.
//! Bending about local z (deflection v, rotation θz) uses Iz; bending about local y
//! (deflection w, rotation θy = −dw/dx) uses Iy; both with the exact Timoshenko stiffness and
//! the consistent mass of `beam2d`. Axial and torsion are linear (torsional inertia ρ(Iy+Iz)).

use super::beam2d::{timoshenko_bending_mass, timoshenko_bending_stiffness};
use nalgebra::{Matrix3, SMatrix, Vector3};

use super::rotate_to_global;

#[derive(Debug, Clone, Copy)]
pub struct BeamSection3d {
    pub youngs_modulus: f64,
    pub poisson: f64,
    pub density: f64,
    pub area: f64,
    pub iy: f64,
    pub iz: f64,
    /// Torsion constant J.
    pub torsion: f64,
    pub shear_factor: f64,
}

/// Local axes (rows: x, y, z in global coordinates) and the length, or None for a
/// zero-length element or a reference vector parallel to the element.
pub fn beam_axes(
    p1: Vector3<f64>,
    p2: Vector3<f64>,
    vxz: Option<Vector3<f64>>,
) -> Option<(Matrix3<f64>, f64)> {
    let d = p2 - p1;
    let l = d.norm();
    if !(l > 0.0) || !l.is_finite() {
        return None;
    }
    let ex = d / l;
    let reference = vxz.unwrap_or(if ex.z.abs() > 0.999 {
        Vector3::x()
    } else {
        Vector3::z()
    });
    let y = reference.cross(&ex);
    let ny = y.norm();
    if !(ny > 1e-9 * reference.norm()) {
        return None;
    }
    let ey = y / ny;
    let ez = ex.cross(&ey);
    Some((
        Matrix3::from_rows(&[ex.transpose(), ey.transpose(), ez.transpose()]),
        l,
    ))
}

/// Global 12×12 stiffness and consistent mass.
pub fn beam3d_matrices(
    p1: Vector3<f64>,
    p2: Vector3<f64>,
    vxz: Option<Vector3<f64>>,
    s: &BeamSection3d,
) -> Option<(SMatrix<f64, 12, 12>, SMatrix<f64, 12, 12>)> {
    let (axes, l) = beam_axes(p1, p2, vxz)?;
    let g = s.youngs_modulus / (2.0 * (1.0 + s.poisson));
    let phi_of = |i: f64| 12.0 * s.youngs_modulus * i / (s.shear_factor * g * s.area * l * l);
    let mut kl = SMatrix::<f64, 12, 12>::zeros();
    let mut ml = SMatrix::<f64, 12, 12>::zeros();
    // Axial (0, 6) and torsion (3, 9): two-node bars.
    let bars = [
        (
            [0usize, 6usize],
            s.youngs_modulus * s.area / l,
            s.density * s.area * l / 6.0,
        ),
        (
            [3, 9],
            g * s.torsion / l,
            s.density * (s.iy + s.iz) * l / 6.0,
        ),
    ];
    for (dofs, k, m) in bars {
        for a in 0..2 {
            for b in 0..2 {
                kl[(dofs[a], dofs[b])] += if a == b { k } else { -k };
                ml[(dofs[a], dofs[b])] += if a == b { 2.0 * m } else { m };
            }
        }
    }
    // Bending in the x–y plane: (v1, θz1, v2, θz2), θz = dv/dx for Φ = 0.
    let phi_z = phi_of(s.iz);
    let kz = timoshenko_bending_stiffness(s.youngs_modulus * s.iz, phi_z, l);
    let mz = timoshenko_bending_mass(s.density * s.area, s.density * s.iz, phi_z, l);
    let dofs_z = [1usize, 5, 7, 11];
    // Bending in the x–z plane: (w, −θy) plays the role of (v, θz).
    let phi_y = phi_of(s.iy);
    let ky = timoshenko_bending_stiffness(s.youngs_modulus * s.iy, phi_y, l);
    let my = timoshenko_bending_mass(s.density * s.area, s.density * s.iy, phi_y, l);
    let dofs_y = [2usize, 4, 8, 10];
    let sign_y = [1.0, -1.0, 1.0, -1.0];
    for a in 0..4 {
        for b in 0..4 {
            kl[(dofs_z[a], dofs_z[b])] += kz[(a, b)];
            ml[(dofs_z[a], dofs_z[b])] += mz[(a, b)];
            kl[(dofs_y[a], dofs_y[b])] += sign_y[a] * sign_y[b] * ky[(a, b)];
            ml[(dofs_y[a], dofs_y[b])] += sign_y[a] * sign_y[b] * my[(a, b)];
        }
    }
    Some((rotate_to_global(&kl, &axes), rotate_to_global(&ml, &axes)))
}
