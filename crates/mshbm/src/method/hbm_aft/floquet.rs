//! Floquet multipliers of an HBM-AFT solution (docs/theory.md (T142)): the monodromy of the
//! penalty system's variational equation along the harmonic-balance orbit.
//!
//! The penalty force `λ_c = k_p,c max(0, −g_c)` is piecewise linear in the displacements, so
//! the variational equation along the orbit is piecewise constant,
//! `M δq̈ + C δq̇ + (K + Σ_{c∈A(t)} k_p,c w_c w_cᵀ) δq = 0`, with `A(t)` the contacts whose gap
//! series `g_c(τ)` of the orbit is negative; the force is continuous across a switch, so no
//! saltation terms. Its monodromy is the exact product of matrix exponentials over the
//! intervals between the roots of the gap series (T81), evaluated by the cyclic modal
//! product of [`crate::stability::PiecewiseLinearSystems`] (T141). This is chosen over
//! Hill's method because it needs no sorting of the `2n(2H+1)` Hill exponents (the
//! truncated Hill matrix has spurious ones, `2n` of which must be picked as physical) and
//! it is exact for the orbit it is given: its only approximation is the orbit's harmonic
//! truncation.
//!
//! It needs a mass on every DOF (the consistent mass, the HBM-AFT's default): a massless DOF
//! (the redistributed mass) makes the first-order form singular.

use super::HbmAft;
use crate::error::{Error, Result};
use crate::harmonic::evaluate;
use crate::sparse::SparseMatrix;
use crate::stability::{Floquet, PiecewiseLinearSystems, ReducedSystem};

/// Largest number of DOFs whose dense first-order monodromy (`2n × 2n`) the HBM-AFT's
/// Floquet analysis forms.
const MAX_PENALTY_STABILITY_DOFS: usize = 1500;

/// The linearised penalty system in first-order form per set of penetrating contacts,
/// built once per model and reused along a diagram.
pub(super) struct PenaltyStability {
    /// `M, C, K` with the coupling `Wᵀ` (contacts × all DOFs): the set `A` enters as the
    /// compliance `−diag(k_p,c [c ∈ A])`, so that `K_eff = K + W K_A Wᵀ`.
    system: ReducedSystem,
    /// The first-order matrices of the sets met so far.
    pieces: PiecewiseLinearSystems,
}

impl HbmAft {
    /// The variational system of the penalty model (built on the first call).
    fn penalty_stability(&mut self) -> Result<&mut PenaltyStability> {
        if self.stability.is_none() {
            let n = self.system.mass.nrows();
            if n > MAX_PENALTY_STABILITY_DOFS {
                return Err(Error::argument(
                    "stability",
                    format!(
                        "the model has {n} DOFs; the HBM-AFT's dense monodromy is limited to {MAX_PENALTY_STABILITY_DOFS}"
                    ),
                ));
            }
            if let Some(dof) = (0..n).find(|&i| self.system.mass.get(i, i) <= 0.0) {
                return Err(Error::argument(
                    "stability",
                    format!(
                        "DOF {dof} has no mass: the HBM-AFT's Floquet analysis needs a mass on every DOF (the consistent mass, its default)"
                    ),
                ));
            }
            let ncon = self.n_contacts();
            let nl_dofs = &self.system.nonlinear_dofs;
            let mut triplets = Vec::new();
            for (i, &dof) in nl_dofs.iter().enumerate() {
                for c in 0..ncon {
                    let w = self.w[i * ncon + c];
                    if w != 0.0 {
                        triplets.push((c, dof, w));
                    }
                }
            }
            let coupling = SparseMatrix::from_triplets(ncon, n, &triplets);
            let system = ReducedSystem::full(
                &self.system.mass,
                &self.system.damping,
                &self.system.stiffness,
                &coupling,
            )?;
            self.stability = Some(PenaltyStability {
                system,
                pieces: PiecewiseLinearSystems::new(),
            });
        }
        Ok(self.stability.as_mut().expect("built above"))
    }

    /// Floquet multipliers of the solution `x` at `ω` (docs/theory.md (T142)).
    pub(super) fn penalty_floquet(&mut self, x: &[f64], omega: f64) -> Result<Floquet> {
        let ncon = self.n_contacts();
        let state = self.contact_state(x);
        let gaps = self.gap_coefficients(x);
        // the switching times of every contact, then the set on each interval between them
        let mut times = vec![0.0, 2.0 * std::f64::consts::PI];
        for (c, g) in gaps.iter().enumerate() {
            for (a, b) in self.penetration_intervals(g, |j| state.gap[j * ncon + c]) {
                times.extend([a, b].map(|t| t.rem_euclid(2.0 * std::f64::consts::PI)));
            }
        }
        times.sort_by(f64::total_cmp);
        times.dedup();
        let penalty = self.penalty.clone();
        let stability = self.penalty_stability()?;
        let mut pieces = Vec::with_capacity(times.len());
        for pair in times.windows(2) {
            let (a, b) = (pair[0], pair[1]);
            if b <= a {
                continue;
            }
            let middle = 0.5 * (a + b);
            let set: Vec<bool> = gaps.iter().map(|g| evaluate(g, middle) < 0.0).collect();
            let system = &stability.system;
            let index = stability.pieces.index_of(&set, || {
                // the set's springs as a negative compliance: K + Σ_{c∈A} k_p,c w_c w_cᵀ
                let compliance: Vec<f64> = (0..ncon * ncon)
                    .map(|k| {
                        let (i, j) = (k / ncon, k % ncon);
                        if i == j && set[i] {
                            -penalty[i]
                        } else {
                            0.0
                        }
                    })
                    .collect();
                system.state_matrix(&compliance)
            })?;
            pieces.push((index, (b - a) / omega));
        }
        let values = stability.pieces.multipliers(&pieces)?;
        Ok(Floquet::from_eigenvalues(values))
    }
}
