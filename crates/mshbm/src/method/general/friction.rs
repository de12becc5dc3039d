//! Friction in the general MS-HBM: the limit `μ F_N` or `μ λ_N` of a friction element, and
//! the selection of the stuck position (docs/theory.md (T64)) when an element sticks over
//! the whole period.

use super::{GeneralMsHbm, Trajectory};
use crate::model::FrictionNormal;

impl GeneralMsHbm {
    /// Limit `μ F_N` or `μ λ_N` of friction element `f` in step row `j` of `tr`.
    pub(super) fn friction_limit(&self, tr: &Trajectory, f: usize, j: usize) -> f64 {
        let fr = &self.subsystem.frictions[f];
        match fr.normal {
            FrictionNormal::Force(p) => fr.mu * p,
            FrictionNormal::Contact(c) => fr.mu * tr.contact_forces(j)[c].max(0.0),
        }
    }

    /// Friction elements that stick in every step of `tr` (force strictly inside its
    /// limit), each with the N-DOF of its largest direction entry. For such an element the
    /// stuck position is undetermined: every constant position in the stick range is a
    /// periodic solution, `q(T) − q(0)` is identically zero along that family and the
    /// Jacobian is singular. [`Self::residual_with`] replaces that DOF's position
    /// periodicity row by the mean friction force over the period (divided by `K_ii`, a
    /// length): the selected member is the one whose stuck position the linear part alone
    /// determines (the friction force then only balances the oscillating part, and the
    /// mean position is that of the friction-free static response).
    pub(super) fn stuck_frictions(&self, tr: &Trajectory) -> Vec<(usize, usize)> {
        let mut out: Vec<(usize, usize)> = Vec::new();
        for (f, fr) in self.subsystem.frictions.iter().enumerate() {
            let stuck = (0..self.steps).all(|j| {
                let limit = self.friction_limit(tr, f, j);
                limit > 0.0 && tr.friction_forces(j)[f].abs() < limit * (1.0 - 1e-9)
            });
            let dof =
                fr.w.iter()
                    .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
                    .map(|&(d, _)| d);
            if let (true, Some(d)) = (stuck, dof) {
                if !out.iter().any(|&(_, e)| e == d) {
                    out.push((f, d));
                }
            }
        }
        out
    }
}
