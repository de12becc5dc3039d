//! The complex dynamic stiffness per harmonic (complex form of the real 2×2 blocks of paper
//! eq. 8; docs/theory.md (T11)–(T14)) and its sparse LU factorization on the linear part.
//!
//! For harmonic `k`, with the complex amplitude `z = a − i b` of `a cos kτ + b sin kτ`, the
//! real block `[[K − (kω)² M, kω C], [−kω C, K − (kω)² M]]` of eq. (8) acting on `(a, b)` is
//! equivalent to the complex symmetric matrix (docs/theory.md (T12)–(T14))
//!
//! ```text
//! A_k(ω) = K − (kω)² M + i kω C        (A_0 = K),
//! ∂A_k/∂ω = −2k²ω M + i k C.
//! ```
//!
//! [`StructuralBlock`] applies both to complex vectors for one block (`K`, `M`, `C` of the
//! same rows and columns) of a partitioned system; [`LinearPart`] factors `A_k(ω)` of the
//! square `LL` block: the sparsity pattern is analysed once ([`LinearPart::new`]), each
//! frequency refactors numerically ([`LinearPart::factor`]).

use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Lu, SymbolicLu};
use faer::{c64, Mat};

use crate::error::{Error, Result};
use crate::sparse::SparseMatrix;

/// Stiffness `K`, mass `M` and damping `C` of one block (the same rows and columns of each)
/// of a structural system, with the dynamic stiffness `A_k(ω) = K − (kω)² M + i kω C` of
/// harmonic `k` and its frequency derivative `∂A_k/∂ω = −2k²ω M + i k C` (docs/theory.md
/// (T13)–(T14)).
#[derive(Clone, Debug)]
pub struct StructuralBlock {
    pub stiffness: SparseMatrix,
    pub mass: SparseMatrix,
    pub damping: SparseMatrix,
}

impl StructuralBlock {
    /// # Panics
    /// If the three matrices do not have the same shape.
    pub fn new(stiffness: SparseMatrix, mass: SparseMatrix, damping: SparseMatrix) -> Self {
        let shape = (stiffness.nrows(), stiffness.ncols());
        assert!(
            (mass.nrows(), mass.ncols()) == shape && (damping.nrows(), damping.ncols()) == shape,
            "K, M and C of a block must have the same shape"
        );
        StructuralBlock {
            stiffness,
            mass,
            damping,
        }
    }

    /// The block `[rows, cols]` of the system matrices `K`, `M`, `C`.
    pub fn of(
        stiffness: &SparseMatrix,
        mass: &SparseMatrix,
        damping: &SparseMatrix,
        rows: &[usize],
        cols: &[usize],
    ) -> Self {
        StructuralBlock::new(
            stiffness.submatrix(rows, cols),
            mass.submatrix(rows, cols),
            damping.submatrix(rows, cols),
        )
    }

    pub fn nrows(&self) -> usize {
        self.stiffness.nrows()
    }

    pub fn ncols(&self) -> usize {
        self.stiffness.ncols()
    }

    /// `out += A_k(ω) x` with `A_k(ω) = K − (kω)² M + i kω C`.
    pub fn add_times(&self, k: usize, omega: f64, x: &[c64], out: &mut [c64]) {
        let kw = k as f64 * omega;
        for (i, j, v) in self.stiffness.iter() {
            out[i] += x[j] * v;
        }
        for (i, j, v) in self.mass.iter() {
            out[i] -= x[j] * (kw * kw * v);
        }
        for (i, j, v) in self.damping.iter() {
            out[i] += x[j] * c64::new(0.0, kw * v);
        }
    }

    /// `out += ∂A_k/∂ω x` with `∂A_k/∂ω = −2k²ω M + i k C`.
    pub fn add_derivative_times(&self, k: usize, omega: f64, x: &[c64], out: &mut [c64]) {
        let kf = k as f64;
        for (i, j, v) in self.mass.iter() {
            out[i] -= x[j] * (2.0 * kf * kf * omega * v);
        }
        for (i, j, v) in self.damping.iter() {
            out[i] += x[j] * c64::new(0.0, kf * v);
        }
    }

    /// `A_k(ω)` as a dense complex matrix.
    pub fn dense(&self, k: usize, omega: f64) -> Mat<c64> {
        let kw = k as f64 * omega;
        let mut a = Mat::<c64>::zeros(self.nrows(), self.ncols());
        for (i, j, v) in self.stiffness.iter() {
            a[(i, j)] += c64::new(v, 0.0);
        }
        for (i, j, v) in self.mass.iter() {
            a[(i, j)] -= c64::new(kw * kw * v, 0.0);
        }
        for (i, j, v) in self.damping.iter() {
            a[(i, j)] += c64::new(0.0, kw * v);
        }
        a
    }
}

/// The square block of the linear part with the analysed sparsity pattern of its dynamic
/// stiffness `A_k(ω)`.
pub struct LinearPart {
    /// `K`, `M`, `C` of the linear part.
    pub matrices: StructuralBlock,
    pattern: SparseMatrix,
    symbolic: SymbolicLu<usize>,
    mass_values: Vec<f64>,
    damping_values: Vec<f64>,
    stiffness_values: Vec<f64>,
}

/// The factored `A_k(ω)` for `k = 0..=H`.
pub struct HarmonicFactors {
    pub omega: f64,
    factors: Vec<Lu<usize, c64>>,
}

impl LinearPart {
    /// Analyse the sparsity pattern of `A_k` (the union of those of `K`, `M`, `C`).
    pub fn new(matrices: StructuralBlock) -> Result<Self> {
        let n = matrices.nrows();
        let pattern = SparseMatrix::union_pattern(
            n,
            n,
            &[&matrices.mass, &matrices.damping, &matrices.stiffness],
        );
        let symbolic = SymbolicLu::try_new(pattern.faer_symbolic().as_ref()).map_err(|e| {
            Error::Numerical(format!("sparse LU analysis of the linear part: {e:?}"))
        })?;
        Ok(LinearPart {
            mass_values: matrices.mass.values_on_pattern(&pattern),
            damping_values: matrices.damping.values_on_pattern(&pattern),
            stiffness_values: matrices.stiffness.values_on_pattern(&pattern),
            matrices,
            pattern,
            symbolic,
        })
    }

    pub fn n_dofs(&self) -> usize {
        self.matrices.nrows()
    }

    /// Factor `A_k(ω)` for `k = 0..=harmonics`.
    pub fn factor(&self, omega: f64, harmonics: usize) -> Result<HarmonicFactors> {
        let factors = (0..=harmonics)
            .map(|k| {
                let kw = k as f64 * omega;
                let values: Vec<c64> = (0..self.stiffness_values.len())
                    .map(|e| {
                        c64::new(
                            self.stiffness_values[e] - kw * kw * self.mass_values[e],
                            kw * self.damping_values[e],
                        )
                    })
                    .collect();
                let a = faer::sparse::SparseColMat::new(self.pattern.faer_symbolic(), values);
                Lu::try_new_with_symbolic(self.symbolic.clone(), a.as_ref()).map_err(|e| {
                    Error::Numerical(format!(
                        "sparse LU of the dynamic stiffness (harmonic {k}): {e:?}"
                    ))
                })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(HarmonicFactors { omega, factors })
    }
}

impl HarmonicFactors {
    /// Solve `A_k X = RHS` in place. Fails when the result is not finite (the frequency
    /// `kω` hits an undamped eigenfrequency of the linear part).
    pub fn solve_in_place(&self, k: usize, rhs: &mut Mat<c64>) -> Result<()> {
        self.factors[k].solve_in_place(rhs.as_mut());
        if rhs
            .col_iter()
            .any(|c| c.iter().any(|v| !(v.re.is_finite() && v.im.is_finite())))
        {
            return Err(Error::Singular(format!(
                "the dynamic stiffness of the linear part is singular at harmonic {k} (k·f = {:.6} Hz is an eigenfrequency of the structure with the contact DOFs held; add damping or move the frequency)",
                k as f64 * self.omega / (2.0 * std::f64::consts::PI)
            )));
        }
        Ok(())
    }

    /// Solve `A_k x = rhs` for one right-hand side.
    pub fn solve(&self, k: usize, rhs: &[c64]) -> Result<Vec<c64>> {
        let mut x = Mat::<c64>::from_fn(rhs.len(), 1, |i, _| rhs[i]);
        self.solve_in_place(k, &mut x)?;
        Ok((0..rhs.len()).map(|i| x[(i, 0)]).collect())
    }

    pub fn harmonics(&self) -> usize {
        self.factors.len() - 1
    }
}
