//! Eigen-decomposition of a symmetric tridiagonal matrix by the implicit QL method with
//! Wilkinson-type shifts (the classical tql2/tqli algorithm). Used for the small Lanczos
//! matrices, where a general dense eigensolver costs far more than the whole Lanczos step.

/// Eigenvalues (ascending) and eigenvectors (`vectors[k]` is the k-th eigenvector) of the
/// tridiagonal matrix with diagonal `diag` and off-diagonal `off` (len n − 1). None if the
/// iteration does not converge (60 sweeps per eigenvalue).
pub fn tridiagonal_eigen(diag: &[f64], off: &[f64]) -> Option<(Vec<f64>, Vec<Vec<f64>>)> {
    tridiagonal_eigen_rows(diag, off, true)
}

/// As `tridiagonal_eigen`, but when `all_rows` is false only the last component of each
/// eigenvector is computed (`vectors[k]` then has length 1), which is all the Lanczos
/// residual estimate needs.
pub fn tridiagonal_eigen_rows(
    diag: &[f64],
    off: &[f64],
    all_rows: bool,
) -> Option<(Vec<f64>, Vec<Vec<f64>>)> {
    let n = diag.len();
    let mut d = diag.to_vec();
    let mut e = vec![0.0; n];
    for i in 0..n.saturating_sub(1) {
        e[i] = off.get(i).copied().unwrap_or(0.0);
    }
    // z[k][j]: component k of eigenvector j (only the last k when !all_rows).
    let first_row = if all_rows { 0 } else { n.saturating_sub(1) };
    let mut z: Vec<Vec<f64>> = (first_row..n)
        .map(|k| {
            let mut row = vec![0.0; n];
            row[k] = 1.0;
            row
        })
        .collect();
    for l in 0..n {
        let mut iterations = 0;
        loop {
            let mut m = l;
            while m + 1 < n {
                let dd = d[m].abs() + d[m + 1].abs();
                if e[m].abs() <= f64::EPSILON * dd {
                    break;
                }
                m += 1;
            }
            if m == l {
                break;
            }
            iterations += 1;
            if iterations > 60 {
                return None;
            }
            let mut g = (d[l + 1] - d[l]) / (2.0 * e[l]);
            let mut r = g.hypot(1.0);
            g = d[m] - d[l] + e[l] / (g + if g >= 0.0 { r.abs() } else { -r.abs() });
            let (mut s, mut c, mut p) = (1.0, 1.0, 0.0);
            let mut underflow = false;
            let mut i = m;
            while i > l {
                i -= 1;
                let f = s * e[i];
                let b = c * e[i];
                r = f.hypot(g);
                e[i + 1] = r;
                if r == 0.0 {
                    d[i + 1] -= p;
                    e[m] = 0.0;
                    underflow = true;
                    break;
                }
                s = f / r;
                c = g / r;
                g = d[i + 1] - p;
                r = (d[i] - g) * s + 2.0 * c * b;
                p = s * r;
                d[i + 1] = g + p;
                g = c * r - b;
                for row in z.iter_mut() {
                    let f = row[i + 1];
                    row[i + 1] = s * row[i] + c * f;
                    row[i] = c * row[i] - s * f;
                }
            }
            if underflow {
                continue;
            }
            d[l] -= p;
            e[l] = g;
            e[m] = 0.0;
        }
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| d[a].total_cmp(&d[b]));
    let values = order.iter().map(|&j| d[j]).collect();
    let vectors = order
        .iter()
        .map(|&j| z.iter().map(|row| row[j]).collect())
        .collect();
    Some((values, vectors))
}
