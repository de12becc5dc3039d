//! The reusable exact solver [`LcpSolver`] of the static contact problem: its state, public
//! entry points, the evaluation of one active set and the final clamping. The two algorithms
//! it runs are in `active_set` and `pivoting`.

use super::residual::{compute_gap, natural_residual, positive_part, residual_tolerance};
use super::{LcpError, LcpMatrix, LcpSolution, SINGULAR_PIVOT_REL_TOL};

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
    pub(super) matrix: LcpMatrix,
    pub(super) diagonal: Vec<f64>,
    /// Active set of the last successful solve: the initial guess of [`LcpSolver::solve`].
    warm_start: Vec<bool>,
    /// Iteration limit of the active-set method (the tests set it to 0 to force the
    /// fallback).
    pub(super) max_active_set_iterations: usize,
    /// Limit on the active sets evaluated by the pivoting fallback.
    pub(super) max_murty_pivots: usize,
    pub(super) work: Workspace,
}

/// Scratch space of [`LcpSolver`], reused between calls.
#[derive(Clone, Debug)]
pub(super) struct Workspace {
    /// Current active set.
    pub(super) active: Vec<bool>,
    /// Next active set of the active-set iteration.
    pub(super) next_active: Vec<bool>,
    /// Indices of the active contacts, in increasing order.
    pub(super) active_indices: Vec<usize>,
    /// Principal block `D_AA`, row-major.
    pub(super) block: Vec<f64>,
    /// Right-hand side `−q_A`.
    pub(super) block_rhs: Vec<f64>,
    /// Contact forces `λ` of the current active set.
    pub(super) contact_force: Vec<f64>,
    /// Gaps `w = D λ + q` of the current active set.
    pub(super) gap: Vec<f64>,
    /// `λ_A`, the solution of the active block.
    pub(super) block_force: Vec<f64>,
}

/// Outcome of evaluating one active set.
pub(super) struct Iterate {
    /// Largest `|min(Dᵢᵢ λᵢ, wᵢ)|`.
    pub(super) residual: f64,
    /// Tolerance for `residual` and for the sign tests.
    pub(super) tolerance: f64,
}

impl Iterate {
    pub(super) fn is_solution(&self) -> bool {
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
                block_force: Vec::with_capacity(n),
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

    /// [`LcpSolver::solve`], returning only the active set (nothing is allocated; for
    /// one contact, or for several once the solver's workspace has grown).
    pub fn solve_active(&mut self, q: &[f64]) -> Result<&[bool], LcpError> {
        self.work.active.clone_from(&self.warm_start);
        self.run_from_current_guess(q)?;
        Ok(&self.work.active)
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
        self.clamp(iterate);
        Ok(self.solution(pivots))
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
        let pivots = self.run_from_current_guess(q)?;
        Ok(self.solution(pivots))
    }

    /// [`LcpSolver::solve_from_current_guess`] leaving the clamped solution in the
    /// workspace; the number of pivots.
    fn run_from_current_guess(&mut self, q: &[f64]) -> Result<usize, LcpError> {
        self.check_q(q)?;
        let mut pivots = 0;
        let iterate = match self.primal_dual_active_set(q, &mut pivots) {
            Some(iterate) => iterate,
            None => self.murty(q, &mut pivots)?,
        };
        self.clamp(iterate);
        Ok(pivots)
    }

    /// The clamped solution in the workspace.
    fn solution(&self, pivots: usize) -> LcpSolution {
        let work = &self.work;
        LcpSolution {
            lambda: work.contact_force.clone(),
            w: work.gap.clone(),
            active: work.active.clone(),
            pivots,
        }
    }

    /// Clamps the accepted iterate to an exactly complementary solution and stores its
    /// active set as the next warm start.
    fn clamp(&mut self, iterate: Iterate) {
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
    }
}

impl Workspace {
    /// Evaluates the active set `self.active`: solves `D_AA λ_A = −q_A`, sets `λ_I = 0` and
    /// `w = D λ + q`, and returns the natural residual and its tolerance.
    pub(super) fn evaluate(
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
        crate::dense::solve_small_lu_into(
            &self.block,
            &self.block_rhs,
            SINGULAR_PIVOT_REL_TOL,
            &mut self.block_force,
        )
        .map_err(|singular| LcpError::Singular {
            block_size,
            contact: self.active_indices[singular.column],
        })?;
        self.contact_force.fill(0.0);
        for (&i, &force) in self.active_indices.iter().zip(&self.block_force) {
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
