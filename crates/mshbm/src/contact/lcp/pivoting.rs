//! Murty's least-index principal pivoting method for the static contact problem, the
//! fallback of [`LcpSolver`] (step 2 of its algorithm); finite for P-matrices.

use super::solver::Iterate;
use super::{LcpError, LcpSolver};

impl LcpSolver {
    /// Murty's least-index principal pivoting from the empty active set.
    pub(super) fn murty(&mut self, q: &[f64], pivots: &mut usize) -> Result<Iterate, LcpError> {
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
}
