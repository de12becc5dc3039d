//! Sparse Cholesky factorisation of a [`SparseMatrix`]: the fill of the factor, a factor
//! solved many times without allocation, and the Schur complement of a block.

use faer::Mat;

use super::SparseMatrix;
use crate::error::{Error, Result};

/// The symbolic analysis (fill-reducing ordering, structure of `L`) of the sparse Cholesky
/// factor of `m`, shared by [`cholesky_fill`] and [`SparseCholesky`].
fn symbolic_cholesky(
    m: faer::sparse::SymbolicSparseColMatRef<'_, usize>,
    what: &str,
) -> Result<faer::sparse::linalg::cholesky::SymbolicCholesky<usize>> {
    faer::sparse::linalg::cholesky::factorize_symbolic_cholesky(
        m,
        faer::Side::Lower,
        Default::default(),
        Default::default(),
    )
    .map_err(|e| Error::Numerical(format!("sparse Cholesky analysis of {what}: {e:?}")))
}

/// The number of nonzeros of the sparse Cholesky factor of `a` (the ordering of
/// [`SparseCholesky`]): the symbolic analysis only, which measures what factoring and
/// solving with `a` cost (a bar's factor has about two values per DOF, a 3D solid's
/// hundreds).
pub fn cholesky_fill(a: &SparseMatrix) -> Result<usize> {
    Ok(symbolic_cholesky(a.faer_symbolic().as_ref(), "a stiffness matrix")?.len_val())
}

/// A sparse symmetric positive definite matrix factored once by faer's sparse Cholesky
/// (`L Lᵀ`), solved many times. Uses faer's low-level API so that a solve needs no
/// allocation and runs sequentially (the per-step systems of the time integrators are small;
/// thread start-up would dominate).
pub(crate) struct SparseCholesky {
    symbolic: faer::sparse::linalg::cholesky::SymbolicCholesky<usize>,
    values: Vec<f64>,
    buf: Mat<f64>,
    mem: faer::dyn_stack::MemBuffer,
    /// `A⁻¹` (row-major) of a matrix of at most [`DENSE_INVERSE_SIZE`] rows: a solve is then
    /// one small product (the time integrators of a few nonlinear DOFs solve once per step).
    dense_inverse: Option<Vec<f64>>,
}

/// Largest size whose inverse a [`SparseCholesky`] keeps dense.
const DENSE_INVERSE_SIZE: usize = 8;

impl SparseCholesky {
    /// Factor `a` (its lower triangle is used); `what` names it in the error when it is not
    /// positive definite.
    pub(crate) fn new(a: &SparseMatrix, what: &str) -> Result<Self> {
        use faer::dyn_stack::{MemBuffer, MemStack};
        let not_pd = || Error::Singular(format!("{what} is not positive definite"));
        let m = a.to_faer();
        let symbolic = symbolic_cholesky(m.symbolic(), what)?;
        let mut values = vec![0.0; symbolic.len_val()];
        let par = faer::Par::Seq;
        let mut mem =
            MemBuffer::new(symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default()));
        symbolic
            .factorize_numeric_llt::<f64>(
                &mut values,
                m.as_ref(),
                faer::Side::Lower,
                Default::default(),
                par,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .map_err(|_| not_pd())?;
        let mem = MemBuffer::new(symbolic.solve_in_place_scratch::<f64>(1, par));
        let mut factor = SparseCholesky {
            symbolic,
            values,
            buf: Mat::zeros(a.nrows(), 1),
            mem,
            dense_inverse: None,
        };
        let n = a.nrows();
        if n <= DENSE_INVERSE_SIZE {
            let mut inverse = vec![0.0; n * n];
            let mut column = vec![0.0; n];
            for j in 0..n {
                column
                    .iter_mut()
                    .enumerate()
                    .for_each(|(i, v)| *v = f64::from(u8::from(i == j)));
                factor.solve(&mut column);
                for (i, v) in column.iter().enumerate() {
                    inverse[i * n + j] = *v;
                }
            }
            factor.dense_inverse = Some(inverse);
        }
        Ok(factor)
    }

    /// `x ← A⁻¹ x`.
    pub(crate) fn solve(&mut self, x: &mut [f64]) {
        use faer::dyn_stack::MemStack;
        use faer::sparse::linalg::cholesky::LltRef;
        if let Some(inverse) = &self.dense_inverse {
            let n = x.len();
            let mut y = [0.0; DENSE_INVERSE_SIZE];
            for (i, yi) in y[..n].iter_mut().enumerate() {
                *yi = crate::dense::dot(&inverse[i * n..(i + 1) * n], x);
            }
            x.copy_from_slice(&y[..n]);
            return;
        }
        for (i, v) in x.iter().enumerate() {
            self.buf[(i, 0)] = *v;
        }
        LltRef::new(&self.symbolic, &self.values).solve_in_place_with_conj(
            faer::Conj::No,
            self.buf.as_mut(),
            faer::Par::Seq,
            MemStack::new(&mut self.mem),
        );
        for (i, v) in x.iter_mut().enumerate() {
            *v = self.buf[(i, 0)];
        }
    }
}

/// The Schur complement `S = A − Bᵀ C⁻¹ B` of a symmetric block matrix `[[A, Bᵀ], [B, C]]`
/// with `C` positive definite (`A` `n × n`, `B` `m × n`, `C` `m × m`): for a stiffness
/// partitioned into `L` (`A = K_LL`) and `N` (`C = K_NN`, `B = K_NL`) DOFs, the stiffness of
/// `L` when `N` follows statically (docs/theory.md (T121)). `S − A` is nonzero only among the
/// columns of `B` that hold entries; that block is formed densely (one sparse Cholesky of
/// `C`, one solve per such column, one product). `None` when `C` is not positive
/// definite.
pub fn schur_complement(
    a: &SparseMatrix,
    b: &SparseMatrix,
    c: &SparseMatrix,
) -> Option<SparseMatrix> {
    let n = a.nrows();
    let mut coupled_position = vec![usize::MAX; n];
    let mut coupled = Vec::new();
    for (_, j, _) in b.iter() {
        if coupled_position[j] == usize::MAX {
            coupled_position[j] = coupled.len();
            coupled.push(j);
        }
    }
    let mut triplets = a.triplets();
    if !coupled.is_empty() {
        let mut b_coupled = Mat::<f64>::zeros(b.nrows(), coupled.len());
        for (i, j, v) in b.iter() {
            b_coupled[(i, coupled_position[j])] += v;
        }
        let llt = c.to_faer().sp_cholesky(faer::Side::Lower).ok()?;
        let mut z = b_coupled.clone();
        faer::linalg::solvers::SolveCore::solve_in_place_with_conj(
            &llt,
            faer::Conj::No,
            z.as_mut(),
        );
        let correction = b_coupled.transpose() * &z;
        for (p, &i) in coupled.iter().enumerate() {
            for (q, &j) in coupled.iter().enumerate() {
                triplets.push((i, j, -correction[(p, q)]));
            }
        }
    }
    Some(SparseMatrix::from_triplets(n, n, &triplets))
}
