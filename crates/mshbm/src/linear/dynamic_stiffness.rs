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
//! frequency refactors numerically ([`LinearPart::factor`]). A block whose DOFs are numbered
//! along a slender structure (a bar, a beam: at most [`BANDED_BANDWIDTH`] diagonals off the
//! main one) is factored as a band matrix ([`super::banded`]), with no symbolic phase; any
//! other by faer's sparse LU.

use faer::linalg::solvers::Solve;
use faer::prelude::{Reborrow, ReborrowMut};
use faer::sparse::linalg::solvers::{Lu, SymbolicLu};
use faer::{c64, Mat};

use super::banded::{band_position, bandwidths, BandedLu, BatchSystems};
use crate::error::{Error, Result};
use crate::sparse::SparseMatrix;

/// Largest `kl + ku` (diagonals off the main one) for which `A_k(ω)` is factored as a band
/// matrix: its factorization costs `O(n kl (kl + ku))`, less than the sparse LU's analysis
/// and allocations for the chains and beams that have such a band.
pub const BANDED_BANDWIDTH: usize = 16;

/// Columns of one sparse factor solved together (when the caller stores them as one
/// block, [`BatchSystems::block`]): the supernodal triangular solves then run as matrix
/// products; the solve's scratch is about `n × SPARSE_SOLVE_BLOCK` complex numbers.
pub(crate) const SPARSE_SOLVE_BLOCK: usize = 32;

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
    analysis: Analysis,
    mass_values: Vec<f64>,
    damping_values: Vec<f64>,
    stiffness_values: Vec<f64>,
}

/// How `A_k(ω)` is factored.
enum Analysis {
    /// faer's sparse LU with this symbolic analysis.
    Sparse(SymbolicLu<usize>),
    /// A band LU with `kl` sub- and `ku` superdiagonals; the pattern's `(row, column)` in its
    /// storage order.
    Banded {
        kl: usize,
        ku: usize,
        positions: Vec<usize>,
    },
}

/// The factors of `A_k(ω)`, `k = 0..=H`.
pub(super) enum Factors {
    /// One sparse LU per harmonic.
    Sparse(Vec<Lu<usize, c64>>),
    /// The band LUs of every harmonic, side by side.
    Banded(Box<BandedLu>),
}

/// The factored `A_k(ω)` for `k = 0..=H`.
pub struct HarmonicFactors {
    pub omega: f64,
    pub(super) factors: Factors,
    /// `kω` per harmonic (kept, so that factoring again allocates nothing).
    frequencies: Vec<f64>,
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
        let (kl, ku) = bandwidths(pattern.iter().map(|(i, j, _)| (i, j)));
        let analysis = if kl + ku <= BANDED_BANDWIDTH {
            Analysis::Banded {
                kl,
                ku,
                positions: pattern
                    .iter()
                    .map(|(i, j, _)| band_position(kl, ku, i, j))
                    .collect(),
            }
        } else {
            Analysis::Sparse(
                SymbolicLu::try_new(pattern.faer_symbolic().as_ref()).map_err(|e| {
                    Error::Numerical(format!("sparse LU analysis of the linear part: {e:?}"))
                })?,
            )
        };
        Ok(LinearPart {
            mass_values: matrices.mass.values_on_pattern(&pattern),
            damping_values: matrices.damping.values_on_pattern(&pattern),
            stiffness_values: matrices.stiffness.values_on_pattern(&pattern),
            matrices,
            pattern,
            analysis,
        })
    }

    pub fn n_dofs(&self) -> usize {
        self.matrices.nrows()
    }

    /// `out += ∂A_k/∂ω x` ([`StructuralBlock::add_derivative_times`]) over the analysed
    /// pattern, whose mass and damping values are stored side by side.
    pub fn add_derivative_times(&self, k: usize, omega: f64, x: &[c64], out: &mut [c64]) {
        let kf = k as f64;
        let (col_ptr, row_idx) = (self.pattern.col_ptr(), self.pattern.row_idx());
        for (j, &xj) in x.iter().enumerate() {
            for e in col_ptr[j]..col_ptr[j + 1] {
                let d = c64::new(
                    -2.0 * kf * kf * omega * self.mass_values[e],
                    kf * self.damping_values[e],
                );
                out[row_idx[e]] += d * xj;
            }
        }
    }

    /// Factor `A_k(ω)` for `k = 0..=harmonics`.
    pub fn factor(&self, omega: f64, harmonics: usize) -> Result<HarmonicFactors> {
        self.factor_cancellable(omega, harmonics, crate::limits::Cancel::NEVER)
    }

    /// [`LinearPart::factor`] stopped by `cancel` ([`LinearPart::factor_into_cancellable`]).
    pub fn factor_cancellable(
        &self,
        omega: f64,
        harmonics: usize,
        cancel: crate::limits::Cancel,
    ) -> Result<HarmonicFactors> {
        let mut factors = HarmonicFactors {
            omega,
            factors: Factors::Sparse(Vec::new()),
            frequencies: Vec::new(),
        };
        self.factor_into_cancellable(omega, harmonics, &mut factors, cancel)?;
        Ok(factors)
    }

    /// [`LinearPart::factor`] into the storage of earlier factors (band factors of the same
    /// sizes are refactored in place, with no allocation).
    pub fn factor_into(
        &self,
        omega: f64,
        harmonics: usize,
        factors: &mut HarmonicFactors,
    ) -> Result<()> {
        self.factor_into_cancellable(omega, harmonics, factors, crate::limits::Cancel::NEVER)
    }

    /// [`LinearPart::factor_into`] that `cancel` stops: each sparse LU (seconds on a 3D
    /// model, and faer's cannot check a request) is waited for cancellably
    /// ([`crate::limits::Cancel::wait_for`]). The band factors of small models are not.
    pub fn factor_into_cancellable(
        &self,
        omega: f64,
        harmonics: usize,
        factors: &mut HarmonicFactors,
        cancel: crate::limits::Cancel,
    ) -> Result<()> {
        factors.omega = omega;
        let value = |e: usize, kw: f64| {
            c64::new(
                self.stiffness_values[e] - kw * kw * self.mass_values[e],
                kw * self.damping_values[e],
            )
        };
        match &self.analysis {
            Analysis::Banded { kl, ku, positions } => {
                let n = self.n_dofs();
                let lanes = harmonics + 1;
                if !matches!(&factors.factors, Factors::Banded(b) if b.fits(n, *kl, *ku, lanes)) {
                    factors.factors = Factors::Banded(Box::new(BandedLu::new(n, *kl, *ku, lanes)));
                }
                let Factors::Banded(batch) = &mut factors.factors else {
                    unreachable!("made banded above")
                };
                // a zero pivot leaves non-finite solutions, which the solves report
                factors.frequencies.clear();
                factors
                    .frequencies
                    .extend((0..lanes).map(|k| k as f64 * omega));
                batch.factor_dynamic_stiffness(
                    positions,
                    &self.stiffness_values,
                    &self.mass_values,
                    &self.damping_values,
                    &factors.frequencies,
                );
            }
            Analysis::Sparse(symbolic) => {
                let mut lus = Vec::with_capacity(harmonics + 1);
                for k in 0..=harmonics {
                    let kw = k as f64 * omega;
                    let values: Vec<c64> = (0..self.stiffness_values.len())
                        .map(|e| value(e, kw))
                        .collect();
                    let a = faer::sparse::SparseColMat::new(self.pattern.faer_symbolic(), values);
                    let symbolic = symbolic.clone();
                    let lu =
                        cancel.wait_for(move || Lu::try_new_with_symbolic(symbolic, a.as_ref()))?;
                    lus.push(lu.map_err(|e| {
                        Error::Numerical(format!(
                            "sparse LU of the dynamic stiffness (harmonic {k}): {e:?}"
                        ))
                    })?);
                }
                factors.factors = Factors::Sparse(lus);
            }
        }
        Ok(())
    }
}

impl HarmonicFactors {
    /// Solve `A_k X = RHS` in place. Fails when the result is not finite (the frequency
    /// `kω` hits an undamped eigenfrequency of the linear part).
    pub fn solve_in_place(&self, k: usize, rhs: &mut faer::MatMut<'_, c64>) -> Result<()> {
        match &self.factors {
            Factors::Sparse(lus) => lus[k].solve_in_place(rhs.rb_mut()),
            Factors::Banded(batch) => {
                for j in 0..rhs.ncols() {
                    let column = rhs
                        .rb_mut()
                        .col_mut(j)
                        .try_as_col_major_mut()
                        .expect("contiguous columns");
                    batch.solve_batch(&mut [(k, column.as_slice_mut())]);
                }
            }
        }
        let rhs = rhs.rb();
        self.check_finite(
            k,
            (0..rhs.ncols()).flat_map(|j| (0..rhs.nrows()).map(move |i| rhs[(i, j)])),
        )
    }

    /// Solve `A_k x = b` in place for one right-hand side.
    pub fn solve_slice_in_place(&self, k: usize, b: &mut [c64]) -> Result<()> {
        self.solve_batch(&mut [(k, b)])
    }

    /// Solve `A_k x = b` in place for each `(k, b)` of `systems` (band factors: in one
    /// pass across the systems, [`BandedLu::solve_batch`]).
    pub fn solve_batch(&self, systems: &mut [(usize, &mut [c64])]) -> Result<()> {
        self.solve_systems(systems)
    }

    /// [`HarmonicFactors::solve_batch`] for any collection of right-hand sides (the
    /// harmonic of each is its matrix).
    pub fn solve_systems<S: BatchSystems + ?Sized>(&self, systems: &mut S) -> Result<()> {
        self.solve_systems_until(systems, crate::limits::Cancel::NEVER)
    }

    /// [`HarmonicFactors::solve_systems`], checking the caller's request to stop before
    /// each sparse solve (hundreds of columns of a large structure take seconds).
    pub fn solve_systems_until<S: BatchSystems + ?Sized>(
        &self,
        systems: &mut S,
        cancel: crate::limits::Cancel,
    ) -> Result<()> {
        match &self.factors {
            Factors::Banded(batch) => batch.solve_systems(systems),
            Factors::Sparse(lus) => {
                let mut s = 0;
                while s < systems.count() {
                    cancel.check()?;
                    let k = systems.matrix(s);
                    let n = systems.column(s).len();
                    // the longest run of columns of A_k stored as one block, up to
                    // SPARSE_SOLVE_BLOCK
                    let mut count = (systems.count() - s).min(SPARSE_SOLVE_BLOCK);
                    while count > 1 && systems.block(s, count).is_none() {
                        count /= 2;
                    }
                    let b = match systems.block(s, count) {
                        Some(b) if count > 1 => b,
                        _ => {
                            count = 1;
                            systems.column(s)
                        }
                    };
                    lus[k].solve_in_place(faer::MatMut::from_column_major_slice_mut(b, n, count));
                    s += count;
                }
            }
        }
        for s in 0..systems.count() {
            let k = systems.matrix(s);
            self.check_finite(k, systems.column(s).iter().copied())?;
        }
        Ok(())
    }

    /// An error when a solution of `A_k x = b` is not finite.
    fn check_finite(&self, k: usize, mut values: impl Iterator<Item = c64>) -> Result<()> {
        if values.any(|v| !(v.re.is_finite() && v.im.is_finite())) {
            return Err(Error::Singular(format!(
                "the dynamic stiffness of the linear part is singular at harmonic {k} (k·f = {:.6} Hz is an eigenfrequency of the structure with the contact DOFs held; add damping or move the frequency)",
                k as f64 * self.omega / (2.0 * std::f64::consts::PI)
            )));
        }
        Ok(())
    }

    /// Solve `A_k x = rhs` for one right-hand side.
    pub fn solve(&self, k: usize, rhs: &[c64]) -> Result<Vec<c64>> {
        let mut x = rhs.to_vec();
        self.solve_slice_in_place(k, &mut x)?;
        Ok(x)
    }

    pub fn harmonics(&self) -> usize {
        match &self.factors {
            Factors::Sparse(lus) => lus.len() - 1,
            Factors::Banded(batch) => batch.lanes() - 1,
        }
    }
}
