//! Element matrices in global coordinates.
//!
//! Every element routine is pure numerics: coordinates and section data in, stiffness and
//! mass out. Stiffness is built with the element's own E (linear in E), mass with its own ρ
//! (linear in ρ), so the assembly can split them into parameter groups.

pub mod beam2d;
pub mod beam3d;
pub mod q4;
pub mod shell;

/// A small dense square matrix stored row-major (element matrices up to 24×24).
#[derive(Debug, Clone, PartialEq)]
pub struct SmallMatrix {
    pub n: usize,
    pub data: Vec<f64>,
}

impl SmallMatrix {
    pub fn zeros(n: usize) -> Self {
        SmallMatrix {
            n,
            data: vec![0.0; n * n],
        }
    }
    #[inline]
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.data[i * self.n + j]
    }
    #[inline]
    pub fn set(&mut self, i: usize, j: usize, v: f64) {
        self.data[i * self.n + j] = v;
    }
    #[inline]
    pub fn add(&mut self, i: usize, j: usize, v: f64) {
        self.data[i * self.n + j] += v;
    }
    /// Tᵀ · self · T for a square transformation T of the same size.
    pub fn congruence(&self, t: &SmallMatrix) -> SmallMatrix {
        let n = self.n;
        let mut at = SmallMatrix::zeros(n);
        for i in 0..n {
            for k in 0..n {
                let a = self.get(i, k);
                if a == 0.0 {
                    continue;
                }
                for j in 0..n {
                    at.data[i * n + j] += a * t.get(k, j);
                }
            }
        }
        let mut out = SmallMatrix::zeros(n);
        for k in 0..n {
            for i in 0..n {
                let tki = t.get(k, i);
                if tki == 0.0 {
                    continue;
                }
                for j in 0..n {
                    out.data[i * n + j] += tki * at.get(k, j);
                }
            }
        }
        out
    }
    /// self · x
    pub fn mul_vec(&self, x: &[f64]) -> Vec<f64> {
        (0..self.n)
            .map(|i| (0..self.n).map(|j| self.get(i, j) * x[j]).sum())
            .collect()
    }
    pub fn scaled(&self, s: f64) -> SmallMatrix {
        SmallMatrix {
            n: self.n,
            data: self.data.iter().map(|v| v * s).collect(),
        }
    }
    /// Largest |a_ij − a_ji|, for symmetry checks.
    pub fn asymmetry(&self) -> f64 {
        let mut worst: f64 = 0.0;
        for i in 0..self.n {
            for j in 0..i {
                worst = worst.max((self.get(i, j) - self.get(j, i)).abs());
            }
        }
        worst
    }
}

/// Gauss–Legendre points and weights on [−1, 1] for 1 to 4 points.
pub fn gauss_legendre(points: usize) -> (Vec<f64>, Vec<f64>) {
    match points {
        1 => (vec![0.0], vec![2.0]),
        2 => {
            let a = 1.0 / 3f64.sqrt();
            (vec![-a, a], vec![1.0, 1.0])
        }
        3 => {
            let a = (0.6f64).sqrt();
            (vec![-a, 0.0, a], vec![5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0])
        }
        _ => {
            let a = (3.0 / 7.0 - 2.0 / 7.0 * (6.0f64 / 5.0).sqrt()).sqrt();
            let b = (3.0 / 7.0 + 2.0 / 7.0 * (6.0f64 / 5.0).sqrt()).sqrt();
            let wa = (18.0 + 30f64.sqrt()) / 36.0;
            let wb = (18.0 - 30f64.sqrt()) / 36.0;
            (vec![-b, -a, a, b], vec![wb, wa, wa, wb])
        }
    }
}

/// Bilinear shape functions of a 4-node quadrilateral at (ξ, η) and their natural
/// derivatives (nodes at (−1,−1), (1,−1), (1,1), (−1,1)).
pub fn bilinear(xi: f64, eta: f64) -> ([f64; 4], [f64; 4], [f64; 4]) {
    const XI: [f64; 4] = [-1.0, 1.0, 1.0, -1.0];
    const ETA: [f64; 4] = [-1.0, -1.0, 1.0, 1.0];
    let mut n = [0.0; 4];
    let mut dxi = [0.0; 4];
    let mut deta = [0.0; 4];
    for a in 0..4 {
        n[a] = 0.25 * (1.0 + XI[a] * xi) * (1.0 + ETA[a] * eta);
        dxi[a] = 0.25 * XI[a] * (1.0 + ETA[a] * eta);
        deta[a] = 0.25 * ETA[a] * (1.0 + XI[a] * xi);
    }
    (n, dxi, deta)
}

/// Jacobian pieces of a planar 4-node map at (ξ, η): returns (det J, ∂N/∂x, ∂N/∂y, J)
/// with J = [[x_ξ, y_ξ], [x_η, y_η]]; None when the element is inverted or degenerate.
pub fn quad_jacobian(
    xy: &[[f64; 2]; 4],
    xi: f64,
    eta: f64,
) -> Option<(f64, [f64; 4], [f64; 4], [[f64; 2]; 2])> {
    let (_, dxi, deta) = bilinear(xi, eta);
    let mut j = [[0.0; 2]; 2];
    for a in 0..4 {
        j[0][0] += dxi[a] * xy[a][0];
        j[0][1] += dxi[a] * xy[a][1];
        j[1][0] += deta[a] * xy[a][0];
        j[1][1] += deta[a] * xy[a][1];
    }
    let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
    if !(det > 0.0) || !det.is_finite() {
        return None;
    }
    let inv = [
        [j[1][1] / det, -j[0][1] / det],
        [-j[1][0] / det, j[0][0] / det],
    ];
    let mut dx = [0.0; 4];
    let mut dy = [0.0; 4];
    for a in 0..4 {
        dx[a] = inv[0][0] * dxi[a] + inv[0][1] * deta[a];
        dy[a] = inv[1][0] * dxi[a] + inv[1][1] * deta[a];
    }
    Some((det, dx, dy, j))
}
