//! The variational equation of one phase of constant contact modes with Coulomb friction
//! (docs/theory.md (T182)): the first-order matrix of the linear part, the forcing by the
//! stuck contacts' anchors, and the maps from the state to the load the contact nodes see.

use faer::linalg::solvers::Solve;
use faer::{Mat, MatRef};

use super::ReducedSystem;
use crate::error::{Error, Result};

/// One phase of constant modes in the coordinates of a [`ReducedSystem`], state
/// `z = (w η, η̇)` (`2r`) and the anchors `δa` (`n_a`) held constant (T182):
/// `ż = state z + forcing δa`, and the load on the contact nodes
/// `K_NL δq = load_z z + load_a δa`, `K_NL δq̇ = rate_z z`.
#[derive(Clone, Debug)]
pub struct HeldPhase {
    /// `2r × 2r`.
    pub state: Mat<f64>,
    /// `2r × n_a`.
    pub forcing: Mat<f64>,
    /// `n_N × 2r`.
    pub load_z: Mat<f64>,
    /// `n_N × n_a`.
    pub load_a: Mat<f64>,
    /// `n_N × 2r`.
    pub rate_z: Mat<f64>,
}

impl ReducedSystem {
    /// The phase whose contact-node displacement responds as
    /// `δq_N = −P K_NL δq + Q δa` (`compliance = P`, `n_N × n_N`, not necessarily symmetric;
    /// `held = Q`, `n_N × n_a`), docs/theory.md (T182). The residual coordinates are
    /// condensed with the phase's `P` and `Q`, so `K_ξη ≠ K_ηξᵀ` when a contact slips.
    pub fn held_phase(
        &self,
        compliance: MatRef<'_, f64>,
        held: MatRef<'_, f64>,
    ) -> Result<HeldPhase> {
        let r = self.dimension();
        let n_a = held.ncols();
        let mut p = compliance.to_owned();
        if let Some(d) = &self.compliance_shift {
            p -= d;
        }
        let b_eta = &self.coupling;
        let mut k_eff = &self.minv_stiffness - &self.minv_coupling * (&p * b_eta);
        let mut c_eff = &self.minv_coupling * held;
        // K_NL δq = B η + B_a δa (B_a = 0 without residual coordinates)
        let mut b = b_eta.clone();
        let mut b_a = Mat::<f64>::zeros(b_eta.nrows(), n_a);
        if let Some((k_psi, b_psi)) = &self.residual {
            // ξ = −K_ξξ⁻¹ (K_ξη η + C_ξa δa)
            let k_eta_xi = -(&self.minv_coupling * (&p * b_psi));
            let k_xi_eta = -(b_psi.transpose() * (&p * b_eta));
            let k_xi_xi = k_psi - b_psi.transpose() * (&p * b_psi);
            let c_xi_a = b_psi.transpose() * held;
            let lu = k_xi_xi.full_piv_lu();
            let x_eta = lu.solve(&k_xi_eta);
            let x_a = lu.solve(&c_xi_a);
            let finite = |m: &Mat<f64>| m.col_iter().all(|c| c.iter().all(|v| v.is_finite()));
            if !finite(&x_eta) || !finite(&x_a) {
                return Err(Error::Singular(
                    "the residual stiffness of the reduced stability basis is singular".into(),
                ));
            }
            k_eff -= &k_eta_xi * &x_eta;
            c_eff -= &k_eta_xi * &x_a;
            b -= b_psi * &x_eta;
            b_a = -(b_psi * &x_a);
        }
        let w = self.w_ref;
        let state = self.first_order(&k_eff);
        let forcing = Mat::<f64>::from_fn(
            2 * r,
            n_a,
            |i, j| if i < r { 0.0 } else { -c_eff[(i - r, j)] },
        );
        let n_n = b.nrows();
        let load_z =
            Mat::<f64>::from_fn(n_n, 2 * r, |i, j| if j < r { b[(i, j)] / w } else { 0.0 });
        let rate_z =
            Mat::<f64>::from_fn(n_n, 2 * r, |i, j| if j < r { 0.0 } else { b[(i, j - r)] });
        Ok(HeldPhase {
            state,
            forcing,
            load_z,
            load_a: b_a,
            rate_z,
        })
    }
}
