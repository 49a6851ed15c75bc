//! Two-node Timoshenko beam in the x–y plane (DoFs ux, uy, rz per node).
//!
//! Stiffness: the exact two-node Timoshenko element (interdependent interpolation,
//! Friedman & Kosmatka 1993), which is free of shear locking:
//! k = EI / ((1+Φ) L³) · [[12, 6L, −12, 6L], [6L, (4+Φ)L², −6L, (2−Φ)L²], …],
//! Φ = 12 EI / (κ G A L²).
//! Consistent mass: ∫ ρA N_wᵀN_w + ρI N_θᵀN_θ dx with the same interdependent shape
//! functions (translational and rotary inertia), integrated by 4-point Gauss (exact for the
//! degree-6 integrand). Axial: linear bar, EA/L and ρAL/6·[[2,1],[1,2]].

use super::{gauss_legendre, SmallMatrix};

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
pub fn timoshenko_bending_stiffness(ei: f64, phi: f64, length: f64) -> [[f64; 4]; 4] {
    let l = length;
    let c = ei / ((1.0 + phi) * l * l * l);
    [
        [12.0 * c, 6.0 * l * c, -12.0 * c, 6.0 * l * c],
        [
            6.0 * l * c,
            (4.0 + phi) * l * l * c,
            -6.0 * l * c,
            (2.0 - phi) * l * l * c,
        ],
        [-12.0 * c, -6.0 * l * c, 12.0 * c, -6.0 * l * c],
        [
            6.0 * l * c,
            (2.0 - phi) * l * l * c,
            -6.0 * l * c,
            (4.0 + phi) * l * l * c,
        ],
    ]
}

/// Consistent bending mass (w1, θ1, w2, θ2): ∫ (ρA N_wᵀN_w + ρI N_θᵀN_θ) dx.
pub fn timoshenko_bending_mass(rho_a: f64, rho_i: f64, phi: f64, length: f64) -> [[f64; 4]; 4] {
    let mut m = [[0.0; 4]; 4];
    let (points, weights) = gauss_legendre(4);
    for (p, w) in points.iter().zip(weights.iter()) {
        let xi = 0.5 * (p + 1.0);
        let scale = 0.5 * w * length;
        let (nw, nt) = timoshenko_shape_functions(xi, length, phi);
        for a in 0..4 {
            for b in 0..4 {
                m[a][b] += scale * (rho_a * nw[a] * nw[b] + rho_i * nt[a] * nt[b]);
            }
        }
    }
    m
}

/// Global 6×6 stiffness and consistent mass of a 2D Timoshenko beam between `p1` and `p2`
/// (x, y). DoF order: ux1, uy1, rz1, ux2, uy2, rz2.
pub fn beam2d_matrices(
    p1: [f64; 2],
    p2: [f64; 2],
    s: &BeamSection2d,
) -> Option<(SmallMatrix, SmallMatrix)> {
    let dx = p2[0] - p1[0];
    let dy = p2[1] - p1[1];
    let l = (dx * dx + dy * dy).sqrt();
    if !(l > 0.0) || !l.is_finite() {
        return None;
    }
    let (c, s_) = (dx / l, dy / l);
    let phi = s.shear_parameter(l);
    let kb = timoshenko_bending_stiffness(s.youngs_modulus * s.inertia, phi, l);
    let mb = timoshenko_bending_mass(s.density * s.area, s.density * s.inertia, phi, l);
    let ka = s.youngs_modulus * s.area / l;
    let ma = s.density * s.area * l / 6.0;
    // Local DoFs (u1, v1, θ1, u2, v2, θ2).
    let mut kl = SmallMatrix::zeros(6);
    let mut ml = SmallMatrix::zeros(6);
    let axial = [0usize, 3];
    let bend = [1usize, 2, 4, 5];
    for (a, &ia) in axial.iter().enumerate() {
        for (b, &ib) in axial.iter().enumerate() {
            let sign = if a == b { 1.0 } else { -1.0 };
            kl.add(ia, ib, sign * ka);
            ml.add(ia, ib, if a == b { 2.0 * ma } else { ma });
        }
    }
    for (a, &ia) in bend.iter().enumerate() {
        for (b, &ib) in bend.iter().enumerate() {
            kl.add(ia, ib, kb[a][b]);
            ml.add(ia, ib, mb[a][b]);
        }
    }
    // Rotation local → global: u = c·ux + s·uy, v = −s·ux + c·uy, θ unchanged.
    let mut t = SmallMatrix::zeros(6);
    for node in 0..2 {
        let o = 3 * node;
        t.set(o, o, c);
        t.set(o, o + 1, s_);
        t.set(o + 1, o, -s_);
        t.set(o + 1, o + 1, c);
        t.set(o + 2, o + 2, 1.0);
    }
    Some((kl.congruence(&t), ml.congruence(&t)))
}
