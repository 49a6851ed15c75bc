//! Two-node Timoshenko beam in the x–y plane (DoFs ux, uy, rz per node).
//!
//! Stiffness: the exact two-node Timoshenko element (interdependent interpolation,
//! Friedman & Kosmatka 1993), which is free of shear locking:
//! k = EI / ((1+Φ) L³) · [[12, 6L, −12, 6L], [6L, (4+Φ)L², −6L, (2−Φ)L²], …],
//! Φ = 12 EI / (κ G A L²).
//! Consistent mass: ∫ ρA N_wᵀN_w + ρI N_θᵀN_θ dx with the same interdependent shape
//! functions (translational and rotary inertia), integrated by 4-point Gauss (exact for the
//! degree-6 integrand). Axial: linear bar, EA/L and ρAL/6·[[2,1],[1,2]].

use nalgebra::{Matrix3, Matrix4, Matrix6, Vector2, Vector4};

use super::{gauss_legendre, rotate_to_global};

/// Section and material data of a beam, with E and ρ separable so that stiffness is linear
/// in E (for parameter groups) and mass linear in ρ.
#[derive(Debug, Clone, Copy)]
pub struct BeamSection2d {
    pub youngs_modulus: f64,
    pub poisson: f64,
    pub density: f64,
    pub area: f64,
    pub inertia: f64,
    /// Shear correction factor κ (5/6 for a rectangle). κ = 0 or ∞ is not allowed;
    /// use a very large value to approach Euler–Bernoulli.
    pub shear_factor: f64,
}

impl BeamSection2d {
    pub fn shear_modulus(&self) -> f64 {
        self.youngs_modulus / (2.0 * (1.0 + self.poisson))
    }
    /// Φ = 12 EI / (κ G A L²); depends on E only through E/G = 2(1+ν).
    pub fn shear_parameter(&self, length: f64) -> f64 {
        12.0 * self.youngs_modulus * self.inertia
            / (self.shear_factor * self.shear_modulus() * self.area * length * length)
    }
}

/// Interdependent Timoshenko shape functions at ξ = x/L ∈ [0,1]: (N_w[4], N_θ[4]) for the
/// DoFs (w1, θ1, w2, θ2), θ positive counter-clockwise (θ = dw/dx for Φ = 0).
pub fn timoshenko_shape_functions(xi: f64, length: f64, phi: f64) -> ([f64; 4], [f64; 4]) {
    let l = length;
    let c = 1.0 / (1.0 + phi);
    let (x, x2, x3) = (xi, xi * xi, xi * xi * xi);
    let nw = [
        c * (2.0 * x3 - 3.0 * x2 - phi * x + 1.0 + phi),
        c * l * (x3 - (2.0 + phi / 2.0) * x2 + (1.0 + phi / 2.0) * x),
        -c * (2.0 * x3 - 3.0 * x2 - phi * x),
        c * l * (x3 - (1.0 - phi / 2.0) * x2 - (phi / 2.0) * x),
    ];
    let nt = [
        6.0 * c / l * (x2 - x),
        c * (3.0 * x2 - (4.0 + phi) * x + 1.0 + phi),
        -6.0 * c / l * (x2 - x),
        c * (3.0 * x2 - (2.0 - phi) * x),
    ];
    (nw, nt)
}

/// Bending stiffness (w1, θ1, w2, θ2) of the exact Timoshenko element.
pub fn timoshenko_bending_stiffness(ei: f64, phi: f64, length: f64) -> Matrix4<f64> {
    let l = length;
    let c = ei / ((1.0 + phi) * l * l * l);
    Matrix4::new(
        12.0 * c,
        6.0 * l * c,
        -12.0 * c,
        6.0 * l * c,
        6.0 * l * c,
        (4.0 + phi) * l * l * c,
        -6.0 * l * c,
        (2.0 - phi) * l * l * c,
        -12.0 * c,
        -6.0 * l * c,
        12.0 * c,
        -6.0 * l * c,
        6.0 * l * c,
        (2.0 - phi) * l * l * c,
        -6.0 * l * c,
        (4.0 + phi) * l * l * c,
    )
}

/// Consistent bending mass (w1, θ1, w2, θ2): ∫ (ρA N_wᵀN_w + ρI N_θᵀN_θ) dx.
pub fn timoshenko_bending_mass(rho_a: f64, rho_i: f64, phi: f64, length: f64) -> Matrix4<f64> {
    let mut m = Matrix4::zeros();
    let (points, weights) = gauss_legendre(4);
    for (p, w) in points.iter().zip(weights.iter()) {
        let xi = 0.5 * (p + 1.0);
        let scale = 0.5 * w * length;
        let (nw, nt) = timoshenko_shape_functions(xi, length, phi);
        let (nw, nt) = (Vector4::from(nw), Vector4::from(nt));
        m += (nw * nw.transpose() * rho_a + nt * nt.transpose() * rho_i) * scale;
    }
    m
}

/// Global 6×6 stiffness and consistent mass of a 2D Timoshenko beam between `p1` and `p2`
/// (x, y). DoF order: ux1, uy1, rz1, ux2, uy2, rz2.
pub fn beam2d_matrices(
    p1: Vector2<f64>,
    p2: Vector2<f64>,
    s: &BeamSection2d,
) -> Option<(Matrix6<f64>, Matrix6<f64>)> {
    let d = p2 - p1;
    let l = d.norm();
    if !(l > 0.0) || !l.is_finite() {
        return None;
    }
    let (c, s_) = (d.x / l, d.y / l);
    let phi = s.shear_parameter(l);
    let kb = timoshenko_bending_stiffness(s.youngs_modulus * s.inertia, phi, l);
    let mb = timoshenko_bending_mass(s.density * s.area, s.density * s.inertia, phi, l);
    let ka = s.youngs_modulus * s.area / l;
    let ma = s.density * s.area * l / 6.0;
    // Local DoFs (u1, v1, θ1, u2, v2, θ2).
    let mut kl = Matrix6::zeros();
    let mut ml = Matrix6::zeros();
    let axial = [0usize, 3];
    let bend = [1usize, 2, 4, 5];
    for (a, &ia) in axial.iter().enumerate() {
        for (b, &ib) in axial.iter().enumerate() {
            let sign = if a == b { 1.0 } else { -1.0 };
            kl[(ia, ib)] += sign * ka;
            ml[(ia, ib)] += if a == b { 2.0 * ma } else { ma };
        }
    }
    for (a, &ia) in bend.iter().enumerate() {
        for (b, &ib) in bend.iter().enumerate() {
            kl[(ia, ib)] += kb[(a, b)];
            ml[(ia, ib)] += mb[(a, b)];
        }
    }
    // Local axes of the node DoFs (u, v, θ): u = c·ux + s·uy, v = −s·ux + c·uy, θ unchanged.
    #[rustfmt::skip]
    let axes = Matrix3::new(
        c, s_, 0.0,
        -s_, c, 0.0,
        0.0, 0.0, 1.0,
    );
    Some((rotate_to_global(&kl, &axes), rotate_to_global(&ml, &axes)))
}
