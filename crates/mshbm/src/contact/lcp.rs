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

/// Reference solution by brute force over all `2ⁿ` active sets, for tests and as a
/// reference. Returns the candidate with the smallest natural residual if it satisfies the
/// same tolerance as [`LcpSolver`], with rounding-level negative forces set to zero; `None`
/// when no active set qualifies (which cannot happen for a well-conditioned P-matrix).
///
/// # Panics
/// If `q.len() != matrix.n()` or `matrix.n() > 16`.
pub fn solve_by_enumeration(matrix: &LcpMatrix, q: &[f64]) -> Option<Vec<f64>> {
    let n = matrix.n();
    assert_eq!(q.len(), n, "solve_by_enumeration: q has the wrong length");
    assert!(
        n <= ENUMERATION_MAX_SIZE,
        "solve_by_enumeration: n = {n} exceeds {ENUMERATION_MAX_SIZE}"
    );
    let diagonal = matrix.diagonal();
    let mut best: Option<(f64, Vec<f64>, Vec<bool>)> = None;
    for mask in 0u32..(1u32 << n) {
        let active: Vec<bool> = (0..n).map(|i| mask & (1 << i) != 0).collect();
        let active_indices: Vec<usize> = (0..n).filter(|&i| active[i]).collect();
        let block: Vec<f64> = active_indices
            .iter()
            .flat_map(|&i| active_indices.iter().map(move |&j| matrix.get(i, j)))
            .collect();
        let rhs: Vec<f64> = active_indices.iter().map(|&i| -q[i]).collect();
        let Some(block_force) = crate::dense::solve_small(&block, &rhs, SINGULAR_PIVOT_REL_TOL)
        else {
            continue;
        };
        let mut contact_force = vec![0.0; n];
        for (&i, &force) in active_indices.iter().zip(&block_force) {
            contact_force[i] = force;
        }
        let mut gap = vec![0.0; n];
        let term_scale = compute_gap(matrix, q, &active_indices, &contact_force, &mut gap);
        let tolerance = residual_tolerance(term_scale);
        let ratio = natural_residual(&diagonal, &contact_force, &gap) / tolerance;
        if !ratio.is_nan()
            && best
                .as_ref()
                .is_none_or(|(best_ratio, ..)| ratio < *best_ratio)
        {
            best = Some((ratio, contact_force, active));
        }
    }
    let (ratio, mut contact_force, active) = best?;
    if ratio > 1.0 {
        return None;
    }
    for (force, &is_active) in contact_force.iter_mut().zip(&active) {
        *force = if is_active {
            positive_part(*force)
        } else {
            0.0
        };
    }
    Some(contact_force)
}

/// Reusable exact solver of the static contact problem, eqs. (26)–(29), for a fixed
/// Delassus matrix `D` and varying `q`.
///
/// It keeps scratch space (no heap allocation per call apart from the returned
/// [`LcpSolution`]) and the active set of the previous solve, which [`LcpSolver::solve`]
/// uses as the initial guess. For slowly varying `q` (consecutive time samples) the guess is
/// usually already right and a solve costs one factorisation of the active block.
///
/// # Algorithm
/// 1. Primal–dual active-set iteration (semismooth Newton on `min(Dᵢᵢ λᵢ, wᵢ) = 0`): for the
///    current active set `A` solve `D_AA λ_A = −q_A`, set `λ_I = 0`, `w = D λ + q`; stop when
///    the natural residual meets the tolerance, otherwise take
///    `A ← { i : Dᵢᵢ λᵢ − wᵢ > 0 }`. At most `2n + 10` iterations, since the iteration can
///    cycle for general positive definite `D`.
/// 2. Otherwise Murty's least-index principal pivoting method from the empty active set:
///    flip the least index that is infeasible (`λᵢ < 0` in `A`, or `wᵢ < 0` outside `A`).
///    It terminates for P-matrices (at most `2ⁿ` active sets in exact arithmetic; here at
///    most `1000 + 20 n`, beyond which [`LcpError::NoConvergence`] is returned).
/// 3. Accept if `|min(Dᵢᵢ λᵢ, wᵢ)| ≤ 10⁻¹² · s` for all `i`, with `s` the largest
///    `|qᵢ| + Σⱼ |Dᵢⱼ λⱼ|` (the magnitude of the terms of `w`, so the test is invariant to
///    the units of `λ` and `w`). Then clamp: `λᵢ = 0` for inactive and `wᵢ = 0` for active
///    contacts, and rounding-level negative values to zero.
#[derive(Clone, Debug)]
pub struct LcpSolver {
    matrix: LcpMatrix,
    diagonal: Vec<f64>,
    /// Active set of the last successful solve: the initial guess of [`LcpSolver::solve`].
    warm_start: Vec<bool>,
    /// Iteration limit of the active-set method (the tests set it to 0 to force the
    /// fallback).
    max_active_set_iterations: usize,
    /// Limit on the active sets evaluated by the pivoting fallback.
    max_murty_pivots: usize,
    work: Workspace,
}

/// Scratch space of [`LcpSolver`], reused between calls.
#[derive(Clone, Debug)]
struct Workspace {
    /// Current active set.
    active: Vec<bool>,
    /// Next active set of the active-set iteration.
    next_active: Vec<bool>,
    /// Indices of the active contacts, in increasing order.
    active_indices: Vec<usize>,
    /// Principal block `D_AA`, row-major.
    block: Vec<f64>,
    /// Right-hand side `−q_A`.
    block_rhs: Vec<f64>,
    /// Contact forces `λ` of the current active set.
    contact_force: Vec<f64>,
    /// Gaps `w = D λ + q` of the current active set.
    gap: Vec<f64>,
}

/// Outcome of evaluating one active set.
struct Iterate {
    /// Largest `|min(Dᵢᵢ λᵢ, wᵢ)|`.
    residual: f64,
    /// Tolerance for `residual` and for the sign tests.
    tolerance: f64,
}

impl Iterate {
    fn is_solution(&self) -> bool {
        self.residual <= self.tolerance
    }
}

impl LcpSolver {
    /// Creates a solver for the matrix `D`; the first [`LcpSolver::solve`] starts from all
    /// contacts inactive.
    pub fn new(matrix: LcpMatrix) -> Self {
        let n = matrix.n();
        Self {
            diagonal: matrix.diagonal(),
            warm_start: vec![false; n],
            max_active_set_iterations: 2 * n + 10,
            max_murty_pivots: 1000 + 20 * n,
            work: Workspace {
                active: vec![false; n],
                next_active: vec![false; n],
                active_indices: Vec::with_capacity(n),
                block: Vec::with_capacity(n * n),
                block_rhs: Vec::with_capacity(n),
                contact_force: vec![0.0; n],
                gap: vec![0.0; n],
            },
            matrix,
        }
    }

    /// The matrix `D`.
    pub fn matrix(&self) -> &LcpMatrix {
        &self.matrix
    }

    /// Solves LCP(D, q) with the active set of the previous successful solve as the initial
    /// guess (all contacts inactive on the first call). On success the new active set becomes
    /// the guess of the next call; on failure the guess is left unchanged.
    ///
    /// # Panics
    /// If `q.len() != self.matrix().n()`.
    pub fn solve(&mut self, q: &[f64]) -> Result<LcpSolution, LcpError> {
        self.work.active.clone_from(&self.warm_start);
        self.solve_from_current_guess(q)
    }

    /// Solves LCP(D, q) with `active_guess` as the initial active set. On success the final
    /// active set becomes the guess of the next [`LcpSolver::solve`].
    ///
    /// # Panics
    /// If `q` or `active_guess` does not have length `self.matrix().n()`.
    pub fn solve_from(
        &mut self,
        q: &[f64],
        active_guess: &[bool],
    ) -> Result<LcpSolution, LcpError> {
        assert_eq!(
            active_guess.len(),
            self.matrix.n(),
            "LcpSolver::solve_from: active_guess has the wrong length"
        );
        self.work.active.copy_from_slice(active_guess);
        self.solve_from_current_guess(q)
    }

    /// Murty's least-index principal pivoting method alone, from the empty active set
    /// (exposed for tests of the fallback).
    #[cfg_attr(not(test), allow(dead_code))]
    pub(crate) fn solve_murty(&mut self, q: &[f64]) -> Result<LcpSolution, LcpError> {
        self.check_q(q)?;
        let mut pivots = 0;
        let iterate = self.murty(q, &mut pivots)?;
        self.finish(iterate, pivots)
    }

    /// Validates `q`: panics on a wrong length, reports non-finite entries.
    fn check_q(&self, q: &[f64]) -> Result<(), LcpError> {
        assert_eq!(
            q.len(),
            self.matrix.n(),
            "LcpSolver: q has length {}, expected {}",
            q.len(),
            self.matrix.n()
        );
        if q.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(LcpError::NoConvergence {
                pivots: 0,
                residual: f64::NAN,
                tolerance: f64::NAN,
            })
        }
    }

    /// Active-set iteration from `self.work.active`, then the pivoting fallback if needed.
    fn solve_from_current_guess(&mut self, q: &[f64]) -> Result<LcpSolution, LcpError> {
        self.check_q(q)?;
        let mut pivots = 0;
        let iterate = match self.primal_dual_active_set(q, &mut pivots) {
            Some(iterate) => iterate,
            None => self.murty(q, &mut pivots)?,
        };
        self.finish(iterate, pivots)
    }

    /// Primal–dual active-set iteration from `self.work.active`. Returns the accepted
    /// iterate, or `None` when it hit a singular block, stalled or ran out of iterations.
    fn primal_dual_active_set(&mut self, q: &[f64], pivots: &mut usize) -> Option<Iterate> {
        for _ in 0..self.max_active_set_iterations {
            *pivots += 1;
            let iterate = self.work.evaluate(&self.matrix, &self.diagonal, q).ok()?;
            if iterate.is_solution() {
                return Some(iterate);
            }
            let work = &mut self.work;
            for (((next, &force), &gap), &d) in work
                .next_active
                .iter_mut()
                .zip(&work.contact_force)
                .zip(&work.gap)
                .zip(&self.diagonal)
            {
                // Ties (`Dᵢᵢ λᵢ = wᵢ`) go to the inactive set.
                *next = d * force - gap > 0.0;
            }
            if work.next_active == work.active {
                // A fixed point that fails the residual test: the block solve is too
                // inaccurate; let the fallback decide.
                return None;
            }
            std::mem::swap(&mut work.active, &mut work.next_active);
        }
        None
    }

    /// Murty's least-index principal pivoting from the empty active set.
    fn murty(&mut self, q: &[f64], pivots: &mut usize) -> Result<Iterate, LcpError> {
        self.work.active.fill(false);
        let mut murty_pivots = 0;
        loop {
            *pivots += 1;
            murty_pivots += 1;
            let iterate = self.work.evaluate(&self.matrix, &self.diagonal, q)?;
            let work = &mut self.work;
            let least_infeasible = (0..self.matrix.n()).find(|&i| {
                if work.active[i] {
                    self.diagonal[i] * work.contact_force[i] < -iterate.tolerance
                } else {
                    work.gap[i] < -iterate.tolerance
                }
            });
            match least_infeasible {
                None if iterate.is_solution() => return Ok(iterate),
                None => {
                    return Err(LcpError::NoConvergence {
                        pivots: *pivots,
                        residual: iterate.residual,
                        tolerance: iterate.tolerance,
                    })
                }
                Some(_) if murty_pivots >= self.max_murty_pivots => {
                    return Err(LcpError::NoConvergence {
                        pivots: *pivots,
                        residual: iterate.residual,
                        tolerance: iterate.tolerance,
                    })
                }
                Some(contact) => work.active[contact] = !work.active[contact],
            }
        }
    }

    /// Clamps the accepted iterate to an exactly complementary solution, stores its active
    /// set as the next warm start and returns it.
    fn finish(&mut self, iterate: Iterate, pivots: usize) -> Result<LcpSolution, LcpError> {
        debug_assert!(iterate.is_solution());
        let work = &mut self.work;
        for ((force, gap), &is_active) in work
            .contact_force
            .iter_mut()
            .zip(work.gap.iter_mut())
            .zip(&work.active)
        {
            if is_active {
                *force = positive_part(*force);
                *gap = 0.0;
            } else {
                *force = 0.0;
                *gap = positive_part(*gap);
            }
        }
        self.warm_start.clone_from(&work.active);
        Ok(LcpSolution {
            lambda: work.contact_force.clone(),
            w: work.gap.clone(),
            active: work.active.clone(),
            pivots,
        })
    }
}

impl Workspace {
    /// Evaluates the active set `self.active`: solves `D_AA λ_A = −q_A`, sets `λ_I = 0` and
    /// `w = D λ + q`, and returns the natural residual and its tolerance.
    fn evaluate(
        &mut self,
        matrix: &LcpMatrix,
        diagonal: &[f64],
        q: &[f64],
    ) -> Result<Iterate, LcpError> {
        self.active_indices.clear();
        self.active_indices.extend(
            self.active
                .iter()
                .enumerate()
                .filter(|(_, &a)| a)
                .map(|(i, _)| i),
        );
        let block_size = self.active_indices.len();
        self.block.clear();
        self.block_rhs.clear();
        for &i in &self.active_indices {
            let row = matrix.row(i);
            self.block
                .extend(self.active_indices.iter().map(|&j| row[j]));
            self.block_rhs.push(-q[i]);
        }
        let block_force =
            crate::dense::solve_small_lu(&self.block, &self.block_rhs, SINGULAR_PIVOT_REL_TOL)
                .map_err(|singular| LcpError::Singular {
                    block_size,
                    contact: self.active_indices[singular.column],
                })?;
        self.contact_force.fill(0.0);
        for (&i, &force) in self.active_indices.iter().zip(&block_force) {
            self.contact_force[i] = force;
        }
        let term_scale = compute_gap(
            matrix,
            q,
            &self.active_indices,
            &self.contact_force,
            &mut self.gap,
        );
        Ok(Iterate {
            residual: natural_residual(diagonal, &self.contact_force, &self.gap),
            tolerance: residual_tolerance(term_scale),
        })
    }
}

/// `gap = D λ + q` using only the columns of the active contacts (`λ` is zero elsewhere).
/// Returns the largest term magnitude `|qᵢ| + Σⱼ |Dᵢⱼ λⱼ|`, the scale of rounding in `gap`.
fn compute_gap(
    matrix: &LcpMatrix,
    q: &[f64],
    active_indices: &[usize],
    contact_force: &[f64],
    gap: &mut [f64],
) -> f64 {
    let mut term_scale = 0.0f64;
    for (i, (gap_i, &q_i)) in gap.iter_mut().zip(q).enumerate() {
        let row = matrix.row(i);
        let mut sum = q_i;
        let mut magnitude = q_i.abs();
        for &j in active_indices {
            let term = row[j] * contact_force[j];
            sum += term;
            magnitude += term.abs();
        }
        *gap_i = sum;
        term_scale = term_scale.max(magnitude);
    }
    term_scale
}

/// Largest natural residual `|min(Dᵢᵢ λᵢ, wᵢ)|`; NaN if any entry is NaN. It is zero exactly
/// at solutions; the diagonal puts forces into gap units.
fn natural_residual(diagonal: &[f64], contact_force: &[f64], gap: &[f64]) -> f64 {
    let mut largest = 0.0f64;
    for ((&d, &force), &gap_i) in diagonal.iter().zip(contact_force).zip(gap) {
        let scaled_force = d * force;
        let residual = if scaled_force < gap_i {
            scaled_force.abs()
        } else {
            gap_i.abs()
        };
        if residual.is_nan() || scaled_force.is_nan() {
            return f64::NAN;
        }
        largest = largest.max(residual);
    }
    largest
}

/// Residual tolerance for terms of magnitude `term_scale` (always positive).
fn residual_tolerance(term_scale: f64) -> f64 {
    RESIDUAL_REL_TOL * term_scale.max(f64::MIN_POSITIVE)
}

/// `max(x, 0)` returning `+0.0` (never `-0.0`).
fn positive_part(x: f64) -> f64 {
    if x > 0.0 {
        x
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use proptest::test_runner::TestCaseError;

    /// `D = B Bᵀ + 0.1 I` from the row-major entries of `B`.
    fn spd_matrix(n: usize, b_entries: &[f64]) -> LcpMatrix {
        let mut data = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                let b_i = &b_entries[i * n..(i + 1) * n];
                let b_j = &b_entries[j * n..(j + 1) * n];
                let mut entry: f64 = b_i.iter().zip(b_j).map(|(x, y)| x * y).sum();
                if i == j {
                    entry += 0.1;
                }
                data[i * n + j] = entry;
            }
        }
        LcpMatrix::new(n, data)
    }

    fn scaled(matrix: &LcpMatrix, factor: f64) -> LcpMatrix {
        LcpMatrix::new(matrix.n(), matrix.data.iter().map(|v| v * factor).collect())
    }

    /// Random problem: `n`, entries of `B`, `q` and an initial active set.
    fn problem() -> impl Strategy<Value = (usize, Vec<f64>, Vec<f64>, Vec<bool>)> {
        (1usize..=8).prop_flat_map(|n| {
            (
                Just(n),
                prop::collection::vec(-1.0..1.0f64, n * n),
                prop::collection::vec(-2.0..2.0f64, n),
                prop::collection::vec(any::<bool>(), n),
            )
        })
    }

    /// Exact feasibility and complementarity, `w = D λ + q`, agreement with enumeration.
    fn check_solution(
        matrix: &LcpMatrix,
        q: &[f64],
        solution: &LcpSolution,
    ) -> Result<(), TestCaseError> {
        let n = matrix.n();
        prop_assert_eq!(solution.lambda.len(), n);
        prop_assert_eq!(solution.w.len(), n);
        prop_assert_eq!(solution.active.len(), n);
        let mut term_scale = 1.0f64;
        for (i, &q_i) in q.iter().enumerate() {
            let (force, gap) = (solution.lambda[i], solution.w[i]);
            prop_assert!(force >= 0.0, "lambda[{}] = {:e} < 0", i, force);
            prop_assert!(gap >= 0.0, "w[{}] = {:e} < 0", i, gap);
            prop_assert!(
                force * gap == 0.0,
                "lambda[{}] * w[{}] = {:e}",
                i,
                i,
                force * gap
            );
            if solution.active[i] {
                prop_assert!(gap == 0.0);
            } else {
                prop_assert!(force == 0.0);
            }
            let magnitude = q_i.abs()
                + (0..n)
                    .map(|j| (matrix.get(i, j) * solution.lambda[j]).abs())
                    .sum::<f64>();
            term_scale = term_scale.max(magnitude);
        }
        for (i, &q_i) in q.iter().enumerate() {
            let expected = q_i
                + (0..n)
                    .map(|j| matrix.get(i, j) * solution.lambda[j])
                    .sum::<f64>();
            prop_assert!(
                (solution.w[i] - expected).abs() <= 1e-10 * term_scale,
                "w[{}] = {:e}, D lambda + q = {:e}",
                i,
                solution.w[i],
                expected
            );
        }
        let reference = solve_by_enumeration(matrix, q);
        prop_assert!(reference.is_some(), "enumeration found no solution");
        let reference = reference.unwrap();
        let force_scale = reference.iter().fold(1.0f64, |s, v| s.max(v.abs()));
        for (i, (&force, &expected)) in solution.lambda.iter().zip(&reference).enumerate() {
            prop_assert!(
                (force - expected).abs() <= 1e-9 * force_scale,
                "lambda[{}] = {:e}, enumeration {:e}",
                i,
                force,
                expected
            );
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]

        #[test]
        fn cold_start_matches_enumeration((n, b, q, _guess) in problem()) {
            let matrix = spd_matrix(n, &b);
            let mut solver = LcpSolver::new(matrix.clone());
            let solution = solver.solve(&q).unwrap();
            check_solution(&matrix, &q, &solution)?;
            // Re-solving the same q from the stored active set takes one evaluation.
            let again = solver.solve(&q).unwrap();
            prop_assert_eq!(again.pivots, 1);
            prop_assert_eq!(again.lambda, solution.lambda);
            prop_assert_eq!(again.w, solution.w);
            prop_assert_eq!(again.active, solution.active);
        }

        #[test]
        fn random_warm_start_matches_enumeration((n, b, q, guess) in problem()) {
            let matrix = spd_matrix(n, &b);
            let mut solver = LcpSolver::new(matrix.clone());
            let solution = solver.solve_from(&q, &guess).unwrap();
            check_solution(&matrix, &q, &solution)?;
        }

        #[test]
        fn murty_matches_enumeration((n, b, q, _guess) in problem()) {
            let matrix = spd_matrix(n, &b);
            let mut solver = LcpSolver::new(matrix.clone());
            let solution = solver.solve_murty(&q).unwrap();
            check_solution(&matrix, &q, &solution)?;
        }

        #[test]
        fn fallback_path_matches_enumeration((n, b, q, guess) in problem()) {
            let matrix = spd_matrix(n, &b);
            let mut solver = LcpSolver::new(matrix.clone());
            solver.max_active_set_iterations = 0;
            let solution = solver.solve_from(&q, &guess).unwrap();
            check_solution(&matrix, &q, &solution)?;
            // The fallback's active set is the warm start of the next call.
            solver.max_active_set_iterations = 10;
            prop_assert_eq!(solver.solve(&q).unwrap().pivots, 1);
        }

        #[test]
        fn badly_scaled_problems_match_enumeration(
            (n, b, q, guess) in problem(),
            stiffness_exponent in -3i32..=8,
            gap_exponent in -9i32..=2,
        ) {
            let matrix = scaled(&spd_matrix(n, &b), 10f64.powi(stiffness_exponent));
            let q: Vec<f64> = q.iter().map(|v| v * 10f64.powi(gap_exponent)).collect();
            let mut solver = LcpSolver::new(matrix.clone());
            let solution = solver.solve_from(&q, &guess).unwrap();
            check_solution(&matrix, &q, &solution)?;
        }
    }

    #[test]
    fn single_contact_matches_closed_form() {
        for &d in &[0.1, 1.0, 3.7, 1e6] {
            let mut solver = LcpSolver::new(LcpMatrix::new(1, vec![d]));
            for k in -20..=20 {
                let q = 0.173 * f64::from(k);
                let (force, gap) = solve_scalar(d, q);
                assert!(force >= 0.0 && gap >= 0.0 && force * gap == 0.0);
                let solution = solver.solve(&[q]).unwrap();
                assert!((solution.lambda[0] - force).abs() <= 1e-15 * force.abs());
                assert_eq!(solution.w[0], gap);
                if q != 0.0 {
                    // At q = 0 both sets are solutions; the warm start decides.
                    assert_eq!(solution.active[0], q < 0.0);
                }
            }
        }
        assert_eq!(solve_scalar(2.0, -4.0), (2.0, 0.0));
        assert_eq!(solve_scalar(2.0, 4.0), (0.0, 4.0));
        assert_eq!(solve_scalar(2.0, -0.0), (0.0, 0.0));
    }

    #[test]
    fn empty_problem_returns_empty_solution() {
        let mut solver = LcpSolver::new(LcpMatrix::new(0, Vec::new()));
        let solution = solver.solve(&[]).unwrap();
        assert!(solution.lambda.is_empty() && solution.w.is_empty() && solution.active.is_empty());
        let solution = solver.solve_from(&[], &[]).unwrap();
        assert!(solution.lambda.is_empty() && solution.w.is_empty() && solution.active.is_empty());
        assert_eq!(
            solve_by_enumeration(&LcpMatrix::new(0, Vec::new()), &[]),
            Some(vec![])
        );
    }

    #[test]
    fn zero_q_gives_zero_force() {
        let matrix = spd_matrix(3, &[0.3, -0.2, 0.5, 0.1, 0.9, -0.4, -0.7, 0.2, 0.6]);
        let mut solver = LcpSolver::new(matrix);
        let solution = solver.solve_from(&[0.0; 3], &[true; 3]).unwrap();
        assert_eq!(solution.lambda, vec![0.0; 3]);
        assert_eq!(solution.w, vec![0.0; 3]);
    }

    /// Small deterministic generator for the sequence test (xorshift64*).
    struct Xorshift(u64);

    impl Xorshift {
        /// Uniform in `[-1, 1)`.
        fn next_symmetric(&mut self) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            let bits = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11;
            2.0 * (bits as f64 / (1u64 << 53) as f64) - 1.0
        }
    }

    #[test]
    fn warm_started_sequence_matches_enumeration() {
        let n = 10;
        let mut rng = Xorshift(0x9e37_79b9_7f4a_7c15);
        let b: Vec<f64> = (0..n * n).map(|_| rng.next_symmetric()).collect();
        let matrix = spd_matrix(n, &b);
        let q0: Vec<f64> = (0..n).map(|_| 0.5 * rng.next_symmetric()).collect();
        let q1: Vec<f64> = (0..n).map(|_| 2.0 * rng.next_symmetric()).collect();
        let mut warm = LcpSolver::new(matrix.clone());
        let mut cold = LcpSolver::new(matrix.clone());
        let (mut warm_pivots, mut cold_pivots) = (0, 0);
        let mut active_set_changes = 0;
        let mut previous_active: Option<Vec<bool>> = None;
        for step in 0..200 {
            let t = 4.0 * std::f64::consts::PI * f64::from(step) / 200.0;
            let q: Vec<f64> = q0.iter().zip(&q1).map(|(a, b)| a + t.cos() * b).collect();
            let solution = warm.solve(&q).unwrap();
            check_solution(&matrix, &q, &solution).unwrap();
            warm_pivots += solution.pivots;
            cold_pivots += cold.solve_from(&q, &[false; 10]).unwrap().pivots;
            if previous_active
                .as_ref()
                .is_some_and(|p| *p != solution.active)
            {
                active_set_changes += 1;
            }
            previous_active = Some(solution.active);
        }
        assert!(
            active_set_changes > 0,
            "the sequence should open and close contacts"
        );
        assert!(
            warm_pivots < cold_pivots,
            "warm start: {warm_pivots} pivots, cold start: {cold_pivots}"
        );
    }

    #[test]
    fn singular_matrix_is_reported() {
        let mut solver = LcpSolver::new(LcpMatrix::new(2, vec![1.0, 1.0, 1.0, 1.0]));
        let error = solver.solve(&[-1.0, -2.0]).unwrap_err();
        assert!(
            matches!(
                error,
                LcpError::Singular {
                    block_size: 2,
                    contact: 1
                }
            ),
            "{error}"
        );
    }

    #[test]
    fn non_finite_q_is_reported() {
        let mut solver = LcpSolver::new(LcpMatrix::new(1, vec![1.0]));
        let error = solver.solve(&[f64::NAN]).unwrap_err();
        assert!(
            matches!(error, LcpError::NoConvergence { pivots: 0, .. }),
            "{error}"
        );
        // The failed call leaves a usable solver behind.
        assert_eq!(solver.solve(&[-2.0]).unwrap().lambda, vec![2.0]);
    }
}
