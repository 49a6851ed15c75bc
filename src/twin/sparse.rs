//! Sparse symmetric matrices for the twin: a plain CSC store (both triangles) and the
//! affine family K(θ) = K0 + Σ_g θ_g K_g on one shared pattern.

use faer::sparse::{SparseColMat, Triplet};
use faer::Mat;

use crate::error::Error;

/// Compressed sparse column matrix (square), both triangles stored.
#[derive(Debug, Clone, PartialEq)]
pub struct CscMatrix {
    pub n: usize,
    pub col_ptr: Vec<usize>,
    pub row_idx: Vec<usize>,
    pub values: Vec<f64>,
}

/// Merge (row, col, value) triplets into a union pattern: returns (col_ptr, row_idx) and, per
/// input list, values aligned to the pattern (duplicates summed).
pub fn union_pattern(
    n: usize,
    lists: &[&[(usize, usize, f64)]],
) -> (Vec<usize>, Vec<usize>, Vec<Vec<f64>>) {
    let mut keys: Vec<(usize, usize)> = lists
        .iter()
        .flat_map(|l| l.iter().map(|&(r, c, _)| (c, r)))
        .collect();
    keys.sort_unstable();
    keys.dedup();
    let mut col_ptr = vec![0usize; n + 1];
    for &(c, _) in &keys {
        col_ptr[c + 1] += 1;
    }
    for c in 0..n {
        col_ptr[c + 1] += col_ptr[c];
    }
    let row_idx: Vec<usize> = keys.iter().map(|&(_, r)| r).collect();
    let values = lists
        .iter()
        .map(|list| {
            let mut v = vec![0.0; row_idx.len()];
            for &(r, c, x) in list.iter() {
                let slice = &row_idx[col_ptr[c]..col_ptr[c + 1]];
                if let Ok(pos) = slice.binary_search(&r) {
                    v[col_ptr[c] + pos] += x;
                }
            }
            v
        })
        .collect();
    (col_ptr, row_idx, values)
}

impl CscMatrix {
    pub fn from_triplets(n: usize, triplets: &[(usize, usize, f64)]) -> Self {
        let (col_ptr, row_idx, mut values) = union_pattern(n, &[triplets]);
        CscMatrix {
            n,
            col_ptr,
            row_idx,
            values: values.pop().unwrap_or_default(),
        }
    }
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }
    /// y = A x
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) {
        y.iter_mut().for_each(|v| *v = 0.0);
        for c in 0..self.n {
            let xc = x[c];
            if xc == 0.0 {
                continue;
            }
            for p in self.col_ptr[c]..self.col_ptr[c + 1] {
                y[self.row_idx[p]] += self.values[p] * xc;
            }
        }
    }
    pub fn diagonal(&self) -> Vec<f64> {
        let mut d = vec![0.0; self.n];
        for c in 0..self.n {
            for p in self.col_ptr[c]..self.col_ptr[c + 1] {
                if self.row_idx[p] == c {
                    d[c] += self.values[p];
                }
            }
        }
        d
    }
    pub fn to_dense(&self) -> Mat<f64> {
        let mut m = Mat::<f64>::zeros(self.n, self.n);
        for c in 0..self.n {
            for p in self.col_ptr[c]..self.col_ptr[c + 1] {
                m[(self.row_idx[p], c)] += self.values[p];
            }
        }
        m
    }
    pub fn from_dense(a: faer::MatRef<'_, f64>) -> Self {
        let mut t = Vec::new();
        for c in 0..a.ncols() {
            for r in 0..a.nrows() {
                let v = a[(r, c)];
                if v != 0.0 {
                    t.push((r, c, v));
                }
            }
        }
        CscMatrix::from_triplets(a.nrows(), &t)
    }
    /// faer sparse matrix (lower triangle only, for `sp_cholesky(Side::Lower)`).
    pub fn to_faer_lower(&self) -> crate::Result<SparseColMat<usize, f64>> {
        let mut t = Vec::with_capacity(self.nnz() / 2 + self.n);
        for c in 0..self.n {
            for p in self.col_ptr[c]..self.col_ptr[c + 1] {
                let r = self.row_idx[p];
                if r >= c {
                    t.push(Triplet::new(r, c, self.values[p]));
                }
            }
        }
        SparseColMat::try_new_from_triplets(self.n, self.n, &t)
            .map_err(|e| Error::numerical(format!("building a sparse matrix: {e:?}")))
    }
    /// Sub-matrix A[rows, cols] (dense), for condensation and partitions.
    pub fn dense_block(&self, rows: &[usize], cols: &[usize]) -> Mat<f64> {
        let mut pos = vec![usize::MAX; self.n];
        for (i, &r) in rows.iter().enumerate() {
            if r < self.n {
                pos[r] = i;
            }
        }
        let mut m = Mat::<f64>::zeros(rows.len(), cols.len());
        for (j, &c) in cols.iter().enumerate() {
            if c >= self.n {
                continue;
            }
            for p in self.col_ptr[c]..self.col_ptr[c + 1] {
                let i = pos[self.row_idx[p]];
                if i != usize::MAX {
                    m[(i, j)] += self.values[p];
                }
            }
        }
        m
    }
    /// The principal sub-matrix A[idx, idx] as sparse.
    pub fn principal_submatrix(&self, idx: &[usize]) -> CscMatrix {
        let mut pos = vec![usize::MAX; self.n];
        for (i, &r) in idx.iter().enumerate() {
            if r < self.n {
                pos[r] = i;
            }
        }
        let mut t = Vec::new();
        for (j, &c) in idx.iter().enumerate() {
            if c >= self.n {
                continue;
            }
            for p in self.col_ptr[c]..self.col_ptr[c + 1] {
                let i = pos[self.row_idx[p]];
                if i != usize::MAX {
                    t.push((i, j, self.values[p]));
                }
            }
        }
        CscMatrix::from_triplets(idx.len(), &t)
    }
}

/// A(θ) = A0 + Σ_g θ_g A_g, all on one pattern.
#[derive(Debug, Clone)]
pub struct AffineMatrix {
    pub n: usize,
    pub col_ptr: Vec<usize>,
    pub row_idx: Vec<usize>,
    pub base: Vec<f64>,
    pub terms: Vec<Vec<f64>>,
}

impl AffineMatrix {
    /// From triplet lists: `base` and one list per parameter.
    pub fn from_triplets(
        n: usize,
        base: &[(usize, usize, f64)],
        terms: &[Vec<(usize, usize, f64)>],
    ) -> Self {
        let mut lists: Vec<&[(usize, usize, f64)]> = vec![base];
        lists.extend(terms.iter().map(|t| t.as_slice()));
        let (col_ptr, row_idx, mut values) = union_pattern(n, &lists);
        let base_values = values.remove(0);
        AffineMatrix {
            n,
            col_ptr,
            row_idx,
            base: base_values,
            terms: values,
        }
    }
    /// From concrete matrices of equal size (patterns may differ).
    pub fn from_matrices(base: &CscMatrix, terms: &[CscMatrix]) -> Self {
        let to_t = |m: &CscMatrix| -> Vec<(usize, usize, f64)> {
            let mut t = Vec::with_capacity(m.nnz());
            for c in 0..m.n {
                for p in m.col_ptr[c]..m.col_ptr[c + 1] {
                    t.push((m.row_idx[p], c, m.values[p]));
                }
            }
            t
        };
        let term_t: Vec<_> = terms.iter().map(to_t).collect();
        AffineMatrix::from_triplets(base.n, &to_t(base), &term_t)
    }
    /// Concrete values at θ (θ.len() must equal the number of terms).
    pub fn at(&self, theta: &[f64]) -> CscMatrix {
        let mut values = self.base.clone();
        for (term, &t) in self.terms.iter().zip(theta) {
            for (v, x) in values.iter_mut().zip(term) {
                *v += t * x;
            }
        }
        CscMatrix {
            n: self.n,
            col_ptr: self.col_ptr.clone(),
            row_idx: self.row_idx.clone(),
            values,
        }
    }
    /// Dense matrix at θ, without building the sparse copy.
    pub fn dense_at(&self, theta: &[f64]) -> Mat<f64> {
        let mut m = Mat::<f64>::zeros(self.n, self.n);
        for c in 0..self.n {
            for p in self.col_ptr[c]..self.col_ptr[c + 1] {
                let mut v = self.base[p];
                for (term, &t) in self.terms.iter().zip(theta) {
                    v += t * term[p];
                }
                m[(self.row_idx[p], c)] = v;
            }
        }
        m
    }
}

/// v(θ) = v0 + Σ_g θ_g v_g.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AffineVector {
    pub base: Vec<f64>,
    pub terms: Vec<Vec<f64>>,
}

impl AffineVector {
    pub fn at(&self, theta: &[f64]) -> Vec<f64> {
        let mut v = self.base.clone();
        for (term, &t) in self.terms.iter().zip(theta) {
            for (x, y) in v.iter_mut().zip(term) {
                *x += t * y;
            }
        }
        v
    }
}
