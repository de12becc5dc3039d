//! A small compressed-sparse-column matrix of `f64` that the models are stored in.
//!
//! It owns the few operations the models need (assembly from triplets, sub-blocks by index
//! sets, products, linear combinations, symmetry checks) and converts to `faer` for
//! factorizations. Row indices within a column are sorted and unique; explicit zeros that a
//! file stores are kept, because they are part of the sparsity pattern that mass
//! redistribution must preserve.

use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use faer::Mat;

use crate::error::{Error, Result};

mod cholesky;

pub(crate) use cholesky::SparseCholesky;
pub use cholesky::{cholesky_fill, schur_complement};

/// Compressed sparse column matrix.
#[derive(Clone, Debug, PartialEq)]
pub struct SparseMatrix {
    nrows: usize,
    ncols: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
}

impl SparseMatrix {
    /// Assemble from `(row, col, value)` triplets; duplicates are summed.
    ///
    /// # Panics
    /// If an index is out of range (callers validate user indices first) or the matrix
    /// cannot be allocated; [`SparseMatrix::try_from_triplets`] reports these as errors.
    pub fn from_triplets(nrows: usize, ncols: usize, triplets: &[(usize, usize, f64)]) -> Self {
        Self::try_from_triplets(nrows, ncols, triplets).unwrap_or_else(|e| panic!("{e}"))
    }

    /// Bytes that [`SparseMatrix::try_from_triplets`] needs at its peak for `ncols`
    /// columns and `entries` triplets, the triplets themselves included: the triplets and
    /// their sorted copy (24 bytes each), row indices and values (16 bytes per entry) and
    /// the column pointers (`8 (ncols + 1)`); `None` on overflow.
    pub fn assembly_bytes(ncols: usize, entries: usize) -> Option<u64> {
        let per_entry = 2 * std::mem::size_of::<(usize, usize, f64)>() as u64 + 16;
        (entries as u64)
            .checked_mul(per_entry)?
            .checked_add((ncols as u64).checked_add(1)?.checked_mul(8)?)
    }

    /// Assemble from `(row, col, value)` triplets (duplicates are summed), with an error
    /// instead of a panic when an index is out of range, the sizes overflow or the memory
    /// cannot be allocated.
    pub fn try_from_triplets(
        nrows: usize,
        ncols: usize,
        triplets: &[(usize, usize, f64)],
    ) -> Result<Self> {
        if let Some(&(i, j, _)) = triplets.iter().find(|&&(i, j, _)| i >= nrows || j >= ncols) {
            return Err(Error::argument(
                "triplet",
                format!("({i}, {j}) out of range of the {nrows}×{ncols} matrix"),
            ));
        }
        let no_memory = || {
            Error::argument(
                "matrix size",
                format!(
                    "cannot allocate a sparse {nrows}×{ncols} matrix with {} entries",
                    triplets.len()
                ),
            )
        };
        let pointers = ncols.checked_add(1).ok_or_else(no_memory)?;
        let mut sorted: Vec<(usize, usize, f64)> = Vec::new();
        sorted
            .try_reserve_exact(triplets.len())
            .map_err(|_| no_memory())?;
        sorted.extend_from_slice(triplets);
        sorted.sort_by_key(|a| (a.1, a.0));
        let mut col_ptr: Vec<usize> = Vec::new();
        col_ptr
            .try_reserve_exact(pointers)
            .map_err(|_| no_memory())?;
        col_ptr.resize(pointers, 0);
        let mut row_idx = Vec::new();
        row_idx
            .try_reserve_exact(sorted.len())
            .map_err(|_| no_memory())?;
        let mut values: Vec<f64> = Vec::new();
        values
            .try_reserve_exact(sorted.len())
            .map_err(|_| no_memory())?;
        let mut last: Option<(usize, usize)> = None;
        for (i, j, v) in sorted {
            if last == Some((i, j)) {
                *values.last_mut().expect("entry exists") += v;
            } else {
                row_idx.push(i);
                values.push(v);
                col_ptr[j + 1] += 1;
                last = Some((i, j));
            }
        }
        for j in 0..ncols {
            col_ptr[j + 1] += col_ptr[j];
        }
        Ok(SparseMatrix {
            nrows,
            ncols,
            col_ptr,
            row_idx,
            values,
        })
    }

    /// Convert a dense matrix, keeping entries with `|a_ij| > 0`.
    pub fn from_dense(a: &Mat<f64>) -> Self {
        let mut t = Vec::new();
        for j in 0..a.ncols() {
            for i in 0..a.nrows() {
                let v = a[(i, j)];
                if v != 0.0 {
                    t.push((i, j, v));
                }
            }
        }
        Self::from_triplets(a.nrows(), a.ncols(), &t)
    }

    /// The `n × n` zero matrix (empty pattern).
    pub fn zeros(nrows: usize, ncols: usize) -> Self {
        Self::from_triplets(nrows, ncols, &[])
    }

    pub fn nrows(&self) -> usize {
        self.nrows
    }

    pub fn ncols(&self) -> usize {
        self.ncols
    }

    /// Number of stored entries (including stored zeros).
    pub fn nnz(&self) -> usize {
        self.values.len()
    }

    /// Entry `(i, j)`, zero when not stored.
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let range = self.col_ptr[j]..self.col_ptr[j + 1];
        match self.row_idx[range.clone()].binary_search(&i) {
            Ok(k) => self.values[range.start + k],
            Err(_) => 0.0,
        }
    }

    /// The column pointers of the compressed-column storage (`ncols + 1`).
    pub fn col_ptr(&self) -> &[usize] {
        &self.col_ptr
    }

    /// The row index of each stored entry, column by column.
    pub fn row_idx(&self) -> &[usize] {
        &self.row_idx
    }

    /// Whether `(i, j)` is in the stored pattern.
    pub fn is_stored(&self, i: usize, j: usize) -> bool {
        let range = self.col_ptr[j]..self.col_ptr[j + 1];
        self.row_idx[range].binary_search(&i).is_ok()
    }

    /// All stored entries as `(row, col, value)`, column by column.
    pub fn iter(&self) -> impl Iterator<Item = (usize, usize, f64)> + '_ {
        (0..self.ncols).flat_map(move |j| {
            (self.col_ptr[j]..self.col_ptr[j + 1])
                .map(move |k| (self.row_idx[k], j, self.values[k]))
        })
    }

    /// The triplets of this matrix.
    pub fn triplets(&self) -> Vec<(usize, usize, f64)> {
        self.iter().collect()
    }

    /// `y = A x`.
    pub fn mul_vec(&self, x: &[f64]) -> Vec<f64> {
        assert_eq!(x.len(), self.ncols);
        let mut y = vec![0.0; self.nrows];
        for (i, j, v) in self.iter() {
            y[i] += v * x[j];
        }
        y
    }

    /// `Y = A X` for a block of columns `X`, reading `A` once: the block is held row-major
    /// (each stored entry of `A` meets one contiguous row of `X`), where a product column by
    /// column reads `A` once per column (the modes' block Krylov space multiplies `K` and `M`
    /// by 16 vectors at a time).
    pub fn mul_block(&self, x: faer::MatRef<'_, f64>) -> Mat<f64> {
        assert_eq!(x.nrows(), self.ncols);
        let b = x.ncols();
        let mut xr = vec![0.0; self.ncols * b];
        for c in 0..b {
            for j in 0..self.ncols {
                xr[j * b + c] = x[(j, c)];
            }
        }
        let mut yr = vec![0.0; self.nrows * b];
        for j in 0..self.ncols {
            let xj = &xr[j * b..(j + 1) * b];
            for k in self.col_ptr[j]..self.col_ptr[j + 1] {
                let v = self.values[k];
                let i = self.row_idx[k];
                yr[i * b..(i + 1) * b]
                    .iter_mut()
                    .zip(xj)
                    .for_each(|(y, x)| *y += v * x);
            }
        }
        Mat::from_fn(self.nrows, b, |i, c| yr[i * b + c])
    }

    /// `y += alpha A x` without allocation (the time integrators' per-step products);
    /// columns where `x` is zero are skipped.
    pub fn mul_add(&self, alpha: f64, x: &[f64], y: &mut [f64]) {
        assert_eq!(x.len(), self.ncols);
        assert_eq!(y.len(), self.nrows);
        for (j, &xj) in x.iter().enumerate() {
            if xj == 0.0 {
                continue;
            }
            let s = alpha * xj;
            for k in self.col_ptr[j]..self.col_ptr[j + 1] {
                y[self.row_idx[k]] += self.values[k] * s;
            }
        }
    }

    /// The quadratic form `xᵀ A x` (e.g. twice a kinetic or strain energy).
    pub fn quadratic_form(&self, x: &[f64]) -> f64 {
        assert_eq!(x.len(), self.ncols);
        let mut s = 0.0;
        for (j, &xj) in x.iter().enumerate() {
            if xj == 0.0 {
                continue;
            }
            let mut col = 0.0;
            for k in self.col_ptr[j]..self.col_ptr[j + 1] {
                col += self.values[k] * x[self.row_idx[k]];
            }
            s += col * xj;
        }
        s
    }

    /// `alpha A + beta B` (patterns united).
    pub fn linear_combination(alpha: f64, a: &SparseMatrix, beta: f64, b: &SparseMatrix) -> Self {
        assert_eq!((a.nrows, a.ncols), (b.nrows, b.ncols));
        let mut t: Vec<(usize, usize, f64)> = a.iter().map(|(i, j, v)| (i, j, alpha * v)).collect();
        t.extend(b.iter().map(|(i, j, v)| (i, j, beta * v)));
        Self::from_triplets(a.nrows, a.ncols, &t)
    }

    /// `alpha A`.
    pub fn scaled(&self, alpha: f64) -> Self {
        let mut out = self.clone();
        out.values.iter_mut().for_each(|v| *v *= alpha);
        out
    }

    /// The sub-block `A[rows, cols]` (rows and cols are index lists of this matrix).
    pub fn submatrix(&self, rows: &[usize], cols: &[usize]) -> Self {
        let mut row_map = vec![usize::MAX; self.nrows];
        for (k, &r) in rows.iter().enumerate() {
            row_map[r] = k;
        }
        let mut t = Vec::new();
        for (jn, &j) in cols.iter().enumerate() {
            for k in self.col_ptr[j]..self.col_ptr[j + 1] {
                let i = row_map[self.row_idx[k]];
                if i != usize::MAX {
                    t.push((i, jn, self.values[k]));
                }
            }
        }
        Self::from_triplets(rows.len(), cols.len(), &t)
    }

    /// Dense copy.
    pub fn to_dense(&self) -> Mat<f64> {
        let mut a = Mat::zeros(self.nrows, self.ncols);
        for (i, j, v) in self.iter() {
            a[(i, j)] += v;
        }
        a
    }

    /// Largest absolute stored value (0 for an empty matrix).
    pub fn max_abs(&self) -> f64 {
        self.values.iter().fold(0.0, |m, v| m.max(v.abs()))
    }

    /// The first entry `(i, j)` with `|a_ij - a_ji| > tol * max|a|`, if any.
    pub fn asymmetry(&self, rel_tol: f64) -> Option<(usize, usize)> {
        if self.nrows != self.ncols {
            return Some((0, 0));
        }
        let tol = rel_tol * self.max_abs();
        self.iter()
            .find(|&(i, j, v)| (v - self.get(j, i)).abs() > tol)
            .map(|(i, j, _)| (i, j))
    }

    /// Conversion to a `faer` sparse matrix, for factorizations.
    pub fn to_faer(&self) -> SparseColMat<usize, f64> {
        SparseColMat::new(self.faer_symbolic(), self.values.clone())
    }

    /// The `faer` sparsity structure of this matrix.
    pub fn faer_symbolic(&self) -> SymbolicSparseColMat<usize> {
        SymbolicSparseColMat::new_checked(
            self.nrows,
            self.ncols,
            self.col_ptr.clone(),
            None,
            self.row_idx.clone(),
        )
    }

    /// The values of `self` at the stored entries of `pattern` (zero where `self` has no
    /// entry), aligned with `pattern`'s storage order.
    pub fn values_on_pattern(&self, pattern: &SparseMatrix) -> Vec<f64> {
        pattern.iter().map(|(i, j, _)| self.get(i, j)).collect()
    }

    /// The union of the sparsity patterns of `matrices` (values zero).
    pub fn union_pattern(nrows: usize, ncols: usize, matrices: &[&SparseMatrix]) -> Self {
        let t: Vec<(usize, usize, f64)> = matrices
            .iter()
            .flat_map(|m| m.iter().map(|(i, j, _)| (i, j, 0.0)))
            .collect();
        Self::from_triplets(nrows, ncols, &t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The block product equals faer's dense product, on an unsymmetric, rectangular matrix
    /// with an empty column.
    #[test]
    fn the_block_product_is_the_dense_product() {
        let a = SparseMatrix::from_triplets(
            4,
            5,
            &[
                (0, 0, 2.0),
                (3, 0, -1.0),
                (1, 1, 0.5),
                (2, 3, 4.0),
                (0, 3, 1.5),
                (3, 4, -3.0),
            ],
        );
        let x = Mat::<f64>::from_fn(5, 3, |i, j| (i as f64 + 1.0) * (j as f64 - 0.7));
        let exact = a.to_dense() * &x;
        let block = a.mul_block(x.as_ref());
        assert_eq!((block.nrows(), block.ncols()), (4, 3));
        for i in 0..4 {
            for j in 0..3 {
                assert!((block[(i, j)] - exact[(i, j)]).abs() <= 1e-14, "{i} {j}");
            }
        }
    }

    /// `A − Bᵀ C⁻¹ B` against the dense formula (faer LU inverse) on a spring chain split
    /// into `L = {0, 1, 3}` and `N = {2, 4}`; a `C` that is not positive definite is refused.
    #[test]
    fn schur_complement_matches_the_dense_formula() {
        // chain 0–1–2–3–4 of springs 1, 2, 3, 4, grounded at 0 by 5
        let k = [(0, 1, 1.0), (1, 2, 2.0), (2, 3, 3.0), (3, 4, 4.0)];
        let mut t = vec![(0, 0, 5.0)];
        for &(i, j, v) in &k {
            t.extend([(i, i, v), (j, j, v), (i, j, -v), (j, i, -v)]);
        }
        let full = SparseMatrix::from_triplets(5, 5, &t);
        let (l, n) = ([0, 1, 3], [2, 4]);
        let (a, b, c) = (
            full.submatrix(&l, &l),
            full.submatrix(&n, &l),
            full.submatrix(&n, &n),
        );
        let s = schur_complement(&a, &b, &c).unwrap().to_dense();
        let (bd, cd) = (b.to_dense(), c.to_dense());
        let c_inv_b = faer::linalg::solvers::Solve::solve(&cd.partial_piv_lu(), &bd);
        let reference = a.to_dense() - bd.transpose() * &c_inv_b;
        for i in 0..3 {
            for j in 0..3 {
                assert!((s[(i, j)] - reference[(i, j)]).abs() < 1e-13, "({i}, {j})");
            }
        }
        // node 4 hangs on node 3 only: relaxed, it adds nothing to node 3's stiffness
        // (series 2–3 between nodes 1 and 3 through node 2: 2·3/5)
        assert!((s[(2, 2)] - 1.2).abs() < 1e-13, "{}", s[(2, 2)]);
        let singular = SparseMatrix::from_triplets(2, 2, &[(0, 0, 1.0), (1, 1, -1.0)]);
        assert!(schur_complement(&a, &b, &singular).is_none());
    }

    #[test]
    fn triplets_sum_duplicates_and_blocks_extract() {
        let a = SparseMatrix::from_triplets(
            3,
            3,
            &[(0, 0, 1.0), (2, 1, 2.0), (0, 0, 3.0), (1, 2, 5.0)],
        );
        assert_eq!(a.get(0, 0), 4.0);
        assert_eq!(a.get(2, 1), 2.0);
        assert_eq!(a.get(1, 1), 0.0);
        assert_eq!(a.nnz(), 3);
        let b = a.submatrix(&[2, 0], &[1, 0]);
        assert_eq!(b.get(0, 0), 2.0);
        assert_eq!(b.get(1, 1), 4.0);
        assert_eq!(a.mul_vec(&[1.0, 1.0, 1.0]), vec![4.0, 5.0, 2.0]);
        assert_eq!(a.asymmetry(1e-12), Some((2, 1)));
        let f = a.to_faer();
        assert_eq!(f.to_dense()[(1, 2)], 5.0);
    }

    #[test]
    fn huge_declared_sizes_are_errors_not_panics() {
        // `ncols + 1` overflows: an error, not an index panic
        let err = SparseMatrix::try_from_triplets(1, usize::MAX, &[]).unwrap_err();
        assert!(err.to_string().contains("cannot allocate"), "{err}");
        // 2^61 column pointers cannot be allocated: an error, not an abort
        let err = SparseMatrix::try_from_triplets(1, 1 << 61, &[]).unwrap_err();
        assert!(err.to_string().contains("cannot allocate"), "{err}");
        let err = SparseMatrix::try_from_triplets(2, 2, &[(2, 0, 1.0)]).unwrap_err();
        assert!(err.to_string().contains("out of range"), "{err}");
        assert_eq!(SparseMatrix::assembly_bytes(usize::MAX, 0), None);
        assert_eq!(SparseMatrix::assembly_bytes(0, usize::MAX), None);
        // 3 columns, 2 entries: 2 (24 + 24 + 16) + 4·8 bytes
        assert_eq!(SparseMatrix::assembly_bytes(3, 2), Some(2 * 64 + 32));
    }

    #[test]
    fn products_without_allocation_match_mul_vec() {
        let a = SparseMatrix::from_triplets(
            3,
            3,
            &[
                (0, 0, 2.0),
                (1, 0, -1.0),
                (0, 1, -1.0),
                (1, 1, 2.0),
                (2, 2, 0.0),
                (2, 1, 3.0),
            ],
        );
        let x = [1.0, -2.0, 0.5];
        let mut y = vec![1.0, 1.0, 1.0];
        a.mul_add(-2.0, &x, &mut y);
        let ax = a.mul_vec(&x);
        for i in 0..3 {
            assert_eq!(y[i], 1.0 - 2.0 * ax[i]);
        }
        let xax: f64 = x.iter().zip(&ax).map(|(a, b)| a * b).sum();
        assert!((a.quadratic_form(&x) - xax).abs() <= 1e-15 * xax.abs());
    }

    #[test]
    fn sparse_cholesky_solves_and_refuses_indefinite() {
        // the 1D Laplacian: A x = b with x = (1, 2, 3)
        let a = SparseMatrix::from_triplets(
            3,
            3,
            &[
                (0, 0, 2.0),
                (1, 0, -1.0),
                (0, 1, -1.0),
                (1, 1, 2.0),
                (2, 1, -1.0),
                (1, 2, -1.0),
                (2, 2, 2.0),
            ],
        );
        let mut x = a.mul_vec(&[1.0, 2.0, 3.0]);
        SparseCholesky::new(&a, "A").unwrap().solve(&mut x);
        for (xi, want) in x.iter().zip([1.0, 2.0, 3.0]) {
            assert!((xi - want).abs() < 1e-14, "{x:?}");
        }
        let b = SparseMatrix::from_triplets(2, 2, &[(0, 0, 1.0), (1, 1, -1.0)]);
        let err = SparseCholesky::new(&b, "B").err().expect("indefinite");
        assert!(
            err.to_string().contains("B is not positive definite"),
            "{err}"
        );
    }
}
