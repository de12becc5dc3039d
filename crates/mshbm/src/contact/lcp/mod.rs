//! Exact solver for the static contact problem, written as a linear complementarity problem.
//!
//! At every time sample the method has to find the contact forces `λ` of the unilateral
//! contacts given the contact-free part of the gaps. This is the static contact problem of
//! the paper, eqs. (26)–(29): find `λ ∈ ℝⁿ` with
//!
//! ```text
//! λ ≥ 0,   w = D λ + q ≥ 0,   λᵢ wᵢ = 0 for all i,
//! ```
//!
//! where `D` is the (symmetric positive definite) Delassus matrix and `w` are the gaps. The
//! paper states it in prox form, `λ = prox_{ℝ≥0}(λ − r (D λ + q))` for any `r > 0`; that
//! equation is the definition, and any exact method that satisfies it is acceptable. Because
//! `D` is positive definite (hence a P-matrix) the solution is unique.
//!
//! [`LcpSolver`] solves it exactly (up to rounding) by a primal–dual active-set iteration
//! (a semismooth Newton method on `min(λ, C w) = 0` with `C = diag(D)⁻¹`, i.e. the prox
//! equation with `rᵢ = 1/Dᵢᵢ`), warm-started from the active set of the previous call, and
//! falls back to Murty's least-index principal pivoting method, which is finite for
//! P-matrices, when the active-set iteration does not converge. The returned solution is
//! clamped to be exactly feasible and exactly complementary.
//!
//! The module is cut by idea: the problem and its solution types are here,
//! [`solve_by_enumeration`] (the brute-force reference) in `enumeration`, the reusable
//! [`LcpSolver`] in `solver`, with its two algorithms in `active_set` (primal–dual
//! active-set iteration) and `pivoting` (Murty's least-index method), and the optimality
//! test shared by all of them in `residual`.

mod active_set;
mod enumeration;
mod pivoting;
mod residual;
mod solver;
#[cfg(test)]
mod tests;

pub use enumeration::solve_by_enumeration;
pub use solver::LcpSolver;

/// Relative tolerance of the optimality test: the natural residual `|min(Dᵢᵢ λᵢ, wᵢ)|` must
/// be at most this times the magnitude of the terms of `w = D λ + q`.
const RESIDUAL_REL_TOL: f64 = 1e-12;

/// A pivot of a principal block below this times the block's largest entry means the block
/// is numerically singular.
const SINGULAR_PIVOT_REL_TOL: f64 = 1e-14;

/// Largest `n` accepted by [`solve_by_enumeration`].
const ENUMERATION_MAX_SIZE: usize = 16;

/// Dense symmetric positive definite LCP matrix (the Delassus matrix `D` of eqs. (26)–(29)),
/// stored row-major as `n × n`.
///
/// Symmetry is not checked; the solver only relies on `D` being a P-matrix (all principal
/// minors positive), which every symmetric positive definite matrix is.
#[derive(Clone, Debug, PartialEq)]
pub struct LcpMatrix {
    n: usize,
    data: Vec<f64>,
}

impl LcpMatrix {
    /// Wraps the row-major entries of an `n × n` matrix.
    ///
    /// # Panics
    /// If `data.len() != n * n`.
    pub fn new(n: usize, data: Vec<f64>) -> Self {
        assert_eq!(
            data.len(),
            n * n,
            "LcpMatrix::new: expected {n}×{n} = {} entries, got {}",
            n * n,
            data.len()
        );
        Self { n, data }
    }

    /// Number of contacts (rows and columns).
    pub fn n(&self) -> usize {
        self.n
    }

    /// Entry `D[i, j]`.
    pub fn get(&self, i: usize, j: usize) -> f64 {
        assert!(
            i < self.n && j < self.n,
            "LcpMatrix::get: index out of range"
        );
        self.data[i * self.n + j]
    }

    /// Row `i` as a slice.
    fn row(&self, i: usize) -> &[f64] {
        &self.data[i * self.n..(i + 1) * self.n]
    }

    /// The diagonal `Dᵢᵢ`.
    fn diagonal(&self) -> Vec<f64> {
        (0..self.n).map(|i| self.data[i * self.n + i]).collect()
    }
}

/// Result of one solve of the static contact problem.
///
/// The solution is exactly feasible and exactly complementary: `contact_force ≥ 0`,
/// `gap ≥ 0` and `lambda[i] * w[i] == 0.0` hold without tolerance. `w` equals `D λ + q` up
/// to rounding (gaps of active contacts and forces of inactive ones are set to exactly zero,
/// and rounding-level negative values to zero).
#[derive(Clone, Debug, PartialEq)]
pub struct LcpSolution {
    /// Contact forces `λ`.
    pub lambda: Vec<f64>,
    /// Gaps `w = D λ + q`.
    pub w: Vec<f64>,
    /// Active (closed) contacts: `w[i] == 0` where `active[i]`, `lambda[i] == 0` elsewhere.
    pub active: Vec<bool>,
    /// Number of active sets evaluated (one linear solve of a principal block each), summed
    /// over the active-set iteration and the pivoting fallback.
    pub pivots: usize,
}

/// Failure of [`LcpSolver`].
#[derive(Debug, thiserror::Error)]
pub enum LcpError {
    /// A principal block `D_AA` is numerically singular, so `D` is not positive definite
    /// (not a P-matrix) to working precision.
    #[error(
        "contact LCP: the {block_size}×{block_size} block of active contacts is numerically \
         singular at contact {contact}; the Delassus matrix is not positive definite"
    )]
    Singular {
        /// Size of the singular principal block.
        block_size: usize,
        /// Contact (row/column of `D`) at which elimination found no usable pivot.
        contact: usize,
    },

    /// No exactly complementary solution was found: the pivoting limit was hit, the final
    /// residual exceeds the tolerance, or `q` (or `D`) contains non-finite values (then
    /// `residual` is NaN and `pivots` is 0 for non-finite `q`).
    #[error(
        "contact LCP: no complementary solution after {pivots} pivots \
         (natural residual {residual:e}, tolerance {tolerance:e})"
    )]
    NoConvergence {
        /// Active sets evaluated before giving up.
        pivots: usize,
        /// Largest `|min(Dᵢᵢ λᵢ, wᵢ)|` of the last iterate.
        residual: f64,
        /// Tolerance the residual had to meet.
        tolerance: f64,
    },
}

/// Closed-form solution of the static contact problem for a single contact (`n = 1`):
/// `λ = max(0, −q/d)`. Returns `(lambda, w)` with `w = d λ + q`, set exactly to zero when the
/// contact is closed.
///
/// `d` must be positive (the 1×1 Delassus matrix).
pub fn solve_scalar(d: f64, q: f64) -> (f64, f64) {
    debug_assert!(d > 0.0, "solve_scalar: d = {d} must be positive");
    if q >= 0.0 {
        // `+ 0.0` turns a `-0.0` gap into `+0.0`.
        (0.0, q + 0.0)
    } else {
        (-q / d, 0.0)
    }
}
