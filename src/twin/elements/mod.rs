//! Element matrices in global coordinates.
//!
//! Every element routine is pure numerics: coordinates and section data in, stiffness and
//! mass out. Stiffness is built with the element's own E (linear in E), mass with its own ρ
//! (linear in ρ), so the assembly can split them into parameter groups.
//!
//! Element algebra uses nalgebra's fixed-size types (`Vector3` geometry, `Matrix3` frames,
//! `SMatrix<f64, 12, 12>` and friends for element matrices): the sizes are known at compile
//! time, live on the stack and the products are unrolled. faer stays the home of everything
//! large (assembled sparse systems, eigen-solutions, reductions).

pub mod beam2d;
pub mod beam3d;
pub mod q4;
pub mod shell;

use nalgebra::{DMatrix, Matrix2, Matrix3, SMatrix, Vector2, Vector3};

/// An element matrix as handed to the assembly: square, of the element's size (1×1 for a
/// grounded spring up to 24×24 for a shell), so elements of every kind share one scatter.
pub type ElementMatrix = DMatrix<f64>;

/// Fixed-size element stiffness and mass, moved to the dynamic type the assembly takes.
pub fn to_element_matrices<const N: usize>(
    (stiffness, mass): (SMatrix<f64, N, N>, SMatrix<f64, N, N>),
) -> (ElementMatrix, ElementMatrix) {
    (
        DMatrix::from_column_slice(N, N, stiffness.as_slice()),
        DMatrix::from_column_slice(N, N, mass.as_slice()),
    )
}

/// k_global = Tᵀ k_local T for T = diag(R, R, …): the congruence of a local element matrix
/// with a block-diagonal rotation whose 3×3 block R has the local axes as rows (a node's
/// translations and rotations rotate alike). Done block by block, k_g[IJ] = Rᵀ k_l[IJ] R,
/// which skips the zero blocks of T.
pub fn rotate_to_global<const N: usize>(
    k_local: &SMatrix<f64, N, N>,
    axes: &Matrix3<f64>,
) -> SMatrix<f64, N, N> {
    debug_assert!(N % 3 == 0, "rotation blocks are 3×3");
    let axes_t = axes.transpose();
    let mut k_global = SMatrix::<f64, N, N>::zeros();
    for i in (0..N).step_by(3) {
        for j in (0..N).step_by(3) {
            let block = axes_t * k_local.fixed_view::<3, 3>(i, j) * axes;
            k_global.fixed_view_mut::<3, 3>(i, j).copy_from(&block);
        }
    }
    k_global
}

/// The unit vector along `v`, or None for a zero, infinite or NaN vector.
pub fn unit(v: Vector3<f64>) -> Option<Vector3<f64>> {
    let n = v.norm();
    (n > 0.0 && n.is_finite()).then(|| v / n)
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

/// Natural coordinates of the four corner nodes of a quadrilateral, counter-clockwise.
pub const QUAD_CORNERS: [(f64, f64); 4] = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];

/// Bilinear shape functions of a 4-node quadrilateral at (ξ, η) and their natural
/// derivatives (nodes at [`QUAD_CORNERS`]).
pub fn bilinear(xi: f64, eta: f64) -> ([f64; 4], [f64; 4], [f64; 4]) {
    let mut n = [0.0; 4];
    let mut dxi = [0.0; 4];
    let mut deta = [0.0; 4];
    for (a, &(xi_a, eta_a)) in QUAD_CORNERS.iter().enumerate() {
        n[a] = 0.25 * (1.0 + xi_a * xi) * (1.0 + eta_a * eta);
        dxi[a] = 0.25 * xi_a * (1.0 + eta_a * eta);
        deta[a] = 0.25 * eta_a * (1.0 + xi_a * xi);
    }
    (n, dxi, deta)
}

/// The isoparametric map of a planar quadrilateral at one natural point.
pub struct QuadMap {
    /// det J (area scale), positive.
    pub det: f64,
    /// ∂N_a/∂x and ∂N_a/∂y of the four shape functions.
    pub dx: [f64; 4],
    pub dy: [f64; 4],
    /// J⁻¹ with J = [[x_ξ, y_ξ], [x_η, y_η]]: maps natural derivatives to Cartesian ones.
    pub inverse_jacobian: Matrix2<f64>,
}

/// The map of a planar 4-node element at (ξ, η); None when it is inverted or degenerate.
pub fn quad_map(xy: &[Vector2<f64>; 4], xi: f64, eta: f64) -> Option<QuadMap> {
    let (_, dxi, deta) = bilinear(xi, eta);
    let mut j = Matrix2::<f64>::zeros();
    for a in 0..4 {
        j[(0, 0)] += dxi[a] * xy[a].x;
        j[(0, 1)] += dxi[a] * xy[a].y;
        j[(1, 0)] += deta[a] * xy[a].x;
        j[(1, 1)] += deta[a] * xy[a].y;
    }
    let det = j.determinant();
    if !(det > 0.0) || !det.is_finite() {
        return None;
    }
    let inverse_jacobian = j.try_inverse()?;
    let mut dx = [0.0; 4];
    let mut dy = [0.0; 4];
    for a in 0..4 {
        let d = inverse_jacobian * Vector2::new(dxi[a], deta[a]);
        dx[a] = d.x;
        dy[a] = d.y;
    }
    Some(QuadMap {
        det,
        dx,
        dy,
        inverse_jacobian,
    })
}
