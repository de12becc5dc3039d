//! One evaluation of the residual (T128) and of its frequency derivative (T129), written
//! into storage that the next evaluation reuses: once the first point is solved, a corrector
//! iteration at a new frequency allocates nothing (for the dense maps of few contacts and a
//! receptance that refreshes in place, [`crate::linear::ReceptanceAtFrequency::refresh`]).

use std::rc::Rc;

use faer::{c64, Mat};

use super::frequency_maps::Map;
use super::frictional::PeriodicFriction;
use super::jacobian::{assemble_forces_into, times_each_coefficient_into};
use super::quadrature::{integrate, integrate_into, Integration, QuadratureWorkspace};
use super::RedistributedMsHbm;
use crate::error::Result;
use crate::linear::{complex_harmonic_into, store_harmonic};
use crate::method::check_dimension;
use crate::problem::PeriodicProblem;

/// One evaluation of the residual (T128) at `(v, ω)`, with what linearizations added.
pub(super) struct Evaluation {
    pub v: Vec<f64>,
    pub omega: f64,
    pub residual: Vec<f64>,
    pub integration: Rc<Integration>,
    /// The structure's force `φ` (T128).
    pub phi: Vec<f64>,
    /// `λ̂`.
    pub forces: Vec<f64>,
    /// The periodic frictional contact (docs/theory.md §20), when the contacts have friction.
    pub friction: Option<Rc<PeriodicFriction>>,
    /// `∂R/∂ω`, once a linearization asked for it.
    pub d_omega: Option<Vec<f64>>,
    /// The dense Jacobian, once a linearization formed it.
    pub dense_jacobian: Option<Mat<f64>>,
}

impl Evaluation {
    fn empty() -> Self {
        Evaluation {
            v: Vec::new(),
            omega: f64::NAN,
            residual: Vec::new(),
            integration: Rc::new(Integration::default()),
            phi: Vec::new(),
            forces: Vec::new(),
            friction: None,
            d_omega: None,
            dense_jacobian: None,
        }
    }
}

/// The working vectors of an evaluation, and the storage of the last one's frequency
/// derivative and Jacobian, kept for the next.
#[derive(Default)]
pub(super) struct EvaluationScratch {
    /// The free gap `u` (T128).
    free_gap: Vec<f64>,
    by_forces: Vec<f64>,
    d_phi: Vec<f64>,
    mismatch: Vec<f64>,
    derivative: Vec<f64>,
    psi: Vec<f64>,
    d_psi: Vec<f64>,
    s_d_psi: Vec<f64>,
    harmonic: Vec<c64>,
    harmonic_derivative: Vec<c64>,
    receptance: Vec<c64>,
    forces: Vec<f64>,
    quadrature: QuadratureWorkspace,
    /// The storage of an earlier evaluation's `∂R/∂ω` and dense Jacobian.
    pub spare_d_omega: Option<Vec<f64>>,
    pub spare_jacobian: Option<Mat<f64>>,
}

/// `out = a − b`, resized.
fn difference_into(a: &[f64], b: &[f64], out: &mut Vec<f64>) {
    out.clear();
    out.extend(a.iter().zip(b).map(|(a, b)| a - b));
}

impl RedistributedMsHbm {
    /// The evaluation at `(v, ω)`: the last one when it was at that point (a continuation
    /// asks for the residual, the tangent and the diagram point of one converged point, and
    /// the fold location repeats corrector steps), else a new one in the last one's storage.
    pub(super) fn evaluation(&mut self, v: &[f64], omega: f64) -> Result<&mut Evaluation> {
        check_dimension(v, self.dimension())?;
        // the callers use the prepared frequency too (another may have been prepared since)
        self.prepare(omega)?;
        let hit = self
            .last_evaluation
            .as_ref()
            .is_some_and(|e| e.omega.to_bits() == omega.to_bits() && e.v == v);
        if !hit {
            let mut scratch = std::mem::take(&mut self.scratch);
            let mut evaluation = match self.last_evaluation.take() {
                Some(mut e) => {
                    scratch.spare_d_omega = e.d_omega.take().or(scratch.spare_d_omega);
                    scratch.spare_jacobian = e.dense_jacobian.take().or(scratch.spare_jacobian);
                    e
                }
                None => Evaluation::empty(),
            };
            let evaluated = self.evaluate_into(v, omega, &mut evaluation, &mut scratch);
            self.scratch = scratch;
            evaluated?;
            self.last_evaluation = Some(evaluation);
        }
        Ok(self.last_evaluation.as_mut().expect("evaluated"))
    }

    /// The residual (T128) at `(v, ω)` into `e`: the structure's force `φ` and the free gap
    /// `u` ([`RedistributedMsHbm::force_and_free_gap_into`]), the period's active-set
    /// decomposition of `u`, the forces `λ̂` and `R = (I ⊗ Λ)(φ − λ̂)`.
    fn evaluate_into(
        &mut self,
        v: &[f64],
        omega: f64,
        e: &mut Evaluation,
        s: &mut EvaluationScratch,
    ) -> Result<()> {
        let n = self.n();
        e.v.clear();
        e.v.extend_from_slice(v);
        e.omega = omega;
        self.force_and_free_gap_into(v, &mut e.phi, s);
        if let Some(law) = &self.friction {
            // (T155)–(T158): the periodic frictional contact of the free gap
            let periodic = law.periodic(self.harmonics, &s.free_gap, self.sampling.len())?;
            e.forces.clear();
            e.forces.extend_from_slice(periodic.forces());
            e.friction = Some(Rc::new(periodic));
            difference_into(&e.phi, &e.forces, &mut s.mismatch);
            e.residual.resize(v.len(), 0.0);
            times_each_coefficient_into(n, &self.residual_scale, &s.mismatch, &mut e.residual);
            return Ok(());
        }
        e.friction = None;
        match Rc::get_mut(&mut e.integration) {
            Some(integration) => integrate_into(
                &mut self.contact,
                &s.free_gap,
                &self.sampling,
                self.quadrature,
                integration,
                &mut s.quadrature,
            )?,
            None => {
                e.integration = Rc::new(integrate(
                    &mut self.contact,
                    &s.free_gap,
                    &self.sampling,
                    self.quadrature,
                )?)
            }
        }
        e.forces.resize(v.len(), 0.0);
        let harmonics = self.harmonics;
        assemble_forces_into(
            n,
            harmonics,
            &e.integration,
            &s.free_gap,
            &mut e.forces,
            &mut s.forces,
        );
        difference_into(&e.phi, &e.forces, &mut s.mismatch);
        e.residual.resize(v.len(), 0.0);
        times_each_coefficient_into(n, &self.residual_scale, &s.mismatch, &mut e.residual);
        Ok(())
    }

    /// `v − Wᵀ A_k⁻¹ f_k` per harmonic (the displacement the contact forces must make) into
    /// `out`.
    pub(super) fn displacement_by_forces_into(&self, v: &[f64], out: &mut Vec<f64>) {
        let n = self.n();
        let f = self.prepared();
        out.clear();
        out.resize(v.len(), 0.0);
        for k in 0..=self.harmonics {
            store_harmonic(f.receptance.load_response(k), n, k, out);
        }
        out.iter_mut().zip(v).for_each(|(o, v)| *o = v - *o);
    }

    /// The structure's force `φ = R⁻¹ (v − Wᵀ A⁻¹ f)` into `phi` and the free gap
    /// `u = g0 δ_k0 + v − D φ` of the unknowns `v` (T128) into the scratch's (the free gap
    /// (T126) with `v = Wᵀ q̂`).
    fn force_and_free_gap_into(&self, v: &[f64], phi: &mut Vec<f64>, s: &mut EvaluationScratch) {
        let n = self.n();
        self.displacement_by_forces_into(v, &mut s.by_forces);
        let f = self.prepared();
        phi.resize(v.len(), 0.0);
        f.matrices.apply_into(Map::Inverse, n, &s.by_forces, phi);
        s.d_phi.resize(v.len(), 0.0);
        f.matrices
            .apply_into(Map::Scaled, n, &s.by_forces, &mut s.d_phi);
        difference_into(v, &s.d_phi, &mut s.free_gap);
        s.free_gap
            .iter_mut()
            .zip(self.contact.initial_gap())
            .for_each(|(u, g0)| *u += g0);
    }

    /// `∂R/∂ω` at fixed `v` (docs/theory.md (T129)) into `out`: with
    /// `ψ_k = R_k⁻¹ ∂(Wᵀ q̂_k)/∂ω |_φ` (the derivative of (T125) at the structure's force
    /// `φ`, zero for `k = 0`), `∂φ/∂ω = −ψ`, `∂u/∂ω = D ψ` and
    /// `∂R/∂ω = −(I ⊗ Λ) (ψ + S (I ⊗ D) ψ)`.
    pub(super) fn frequency_derivative_into(
        &self,
        phi: &[f64],
        integration: &Integration,
        friction: Option<&PeriodicFriction>,
        out: &mut Vec<f64>,
        s: &mut EvaluationScratch,
    ) -> Result<()> {
        let n = self.n();
        let f = self.prepared();
        let len = phi.len();
        s.derivative.clear();
        s.derivative.resize(len, 0.0);
        s.harmonic.resize(n, c64::new(0.0, 0.0));
        s.harmonic_derivative.resize(n, c64::new(0.0, 0.0));
        for k in 1..=self.harmonics {
            complex_harmonic_into(phi, n, k, &mut s.harmonic);
            f.receptance.frequency_derivative_into(
                k,
                &s.harmonic,
                true,
                &mut s.harmonic_derivative,
                &mut s.receptance,
            )?;
            store_harmonic(&s.harmonic_derivative, n, k, &mut s.derivative);
        }
        s.psi.resize(len, 0.0);
        f.matrices
            .apply_into(Map::Inverse, n, &s.derivative, &mut s.psi);
        s.d_psi.resize(len, 0.0);
        times_each_coefficient_into(n, self.contact.delassus(), &s.psi, &mut s.d_psi);
        s.s_d_psi.resize(len, 0.0);
        match friction {
            // S = dλ̂/dγ̂ of the frictional law (T158), one product (T225)
            Some(law) => s.s_d_psi = law.product(&s.d_psi, self.operator_jacobian)?,
            None => assemble_forces_into(
                n,
                self.harmonics,
                integration,
                &s.d_psi,
                &mut s.s_d_psi,
                &mut s.forces,
            ),
        }
        // ψ + S D ψ, in the mismatch's storage
        s.mismatch.clear();
        s.mismatch
            .extend(s.psi.iter().zip(&s.s_d_psi).map(|(a, b)| a + b));
        out.resize(len, 0.0);
        times_each_coefficient_into(n, &self.residual_scale, &s.mismatch, out);
        out.iter_mut().for_each(|v| *v = -*v);
        Ok(())
    }
}
