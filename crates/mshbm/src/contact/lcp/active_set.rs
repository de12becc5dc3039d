//! Primal–dual active-set iteration for the static contact problem (step 1 of the
//! algorithm of [`LcpSolver`]).

use super::solver::Iterate;
use super::LcpSolver;

impl LcpSolver {
    /// Primal–dual active-set iteration from `self.work.active`. Returns the accepted
    /// iterate, or `None` when it hit a singular block, stalled or ran out of iterations.
    pub(super) fn primal_dual_active_set(
        &mut self,
        q: &[f64],
        pivots: &mut usize,
    ) -> Option<Iterate> {
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
}
