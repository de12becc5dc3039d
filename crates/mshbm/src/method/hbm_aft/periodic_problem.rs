//! [`HbmAft`] as a [`PeriodicProblem`]: dimension, residual, Jacobian and the periodic
//! solution that Newton and the continuation see.

use super::super::partition::DofLocation;
use super::super::{check_dimension, n_dof_coefficients, periodic_solution, SolutionParts};
use super::HbmAft;
use crate::error::Result;
use crate::harmonic::{n_coefficients, polynomial_extremum};
use crate::problem::{Jacobian, Linearization, PeriodicProblem};
use crate::solution::{ContactSeries, DofResponse, PeriodicSolution};

impl PeriodicProblem for HbmAft {
    /// Stiff penalties (and, with sampled quadrature, a kinked residual): Newton does not
    /// contract quadratically; the branch has isolated corners at grazing contacts.
    fn continuation_policy(&self) -> crate::problem::ContinuationPolicy {
        crate::problem::ContinuationPolicy {
            newton_contraction: crate::problem::NewtonContraction::Unchecked,
            where_arclength_fails: crate::problem::ArclengthFallback::EscapeCorner,
            signals: self.n(),
        }
    }

    fn dimension(&self) -> usize {
        self.n() * n_coefficients(self.harmonics)
    }

    fn length_scale(&self) -> f64 {
        self.partition.length_scale()
    }

    fn initial_guess(&mut self, omega: f64) -> Result<Vec<f64>> {
        self.penalty_homotopy(omega)
    }

    fn residual(&mut self, x: &[f64], omega: f64) -> Result<Vec<f64>> {
        Ok(self.evaluate(x, omega)?.0)
    }

    fn linearize(&mut self, x: &[f64], omega: f64) -> Result<Linearization> {
        let (residual, _, groups) = self.evaluate(x, omega)?;
        let jacobian = self.jacobian_matrix(&groups);
        let d_omega = self.frequency_derivative(x)?;
        Ok(Linearization {
            residual,
            jacobian: Jacobian::Dense(jacobian),
            d_omega,
        })
    }

    /// The monodromy of the penalty system along the orbit (docs/theory.md (T142)); none
    /// with friction (the slider positions would be part of the state; not implemented).
    fn floquet(&mut self, x: &[f64], omega: f64) -> Result<Option<crate::stability::Floquet>> {
        check_dimension(x, self.dimension())?;
        if self.jenkins.is_some() {
            return Ok(None);
        }
        self.penalty_floquet(x, omega).map(Some)
    }

    fn solution(&mut self, x: &[f64], omega: f64, response_dof: usize) -> Result<PeriodicSolution> {
        let location = self.partition.locate_response(&self.system, response_dof)?;
        let (residual, state, _) = self.evaluate(x, omega)?;
        let (n, ncon, ns) = (self.n(), self.n_contacts(), self.sampling.len());
        let h = self.harmonics;
        let nc = n_coefficients(h);
        let extremes = |coef: &[f64]| -> (f64, f64) {
            (
                polynomial_extremum(coef, ns, 1.0),
                polynomial_extremum(coef, ns, -1.0),
            )
        };
        let mut contacts = Vec::with_capacity(ncon);
        for (c, sc) in self.system.contacts.iter().enumerate() {
            let i = self.partition.contact_n_index(&self.system, c);
            let coefficients = n_dof_coefficients(x, n, h, i);
            let (max, min) = extremes(&coefficients);
            contacts.push(ContactSeries {
                dof: self.system.model_dof[sc.w[0].0],
                coefficients,
                displacement: (0..ns).map(|j| state.displacement[j * n + i]).collect(),
                gap: (0..ns).map(|j| state.gap[j * ncon + c]).collect(),
                force: (0..ns).map(|j| state.force[j * ncon + c]).collect(),
                max,
                min,
            });
        }
        let coefficients = match location {
            // a Dirichlet DOF does not move
            DofLocation::Fixed => vec![0.0; nc],
            DofLocation::Nonlinear(i) => n_dof_coefficients(x, n, h, i),
            DofLocation::Linear(l) => self
                .frequency
                .as_ref()
                .expect("prepared")
                .condensed
                .linear_dof_coefficients(x, l)?,
        };
        let (max, min) = if coefficients.iter().all(|&v| v == 0.0) {
            (0.0, 0.0)
        } else {
            extremes(&coefficients)
        };
        Ok(periodic_solution(
            &self.system,
            &self.partition,
            omega,
            SolutionParts {
                method: crate::solution::MethodKind::HbmAft,
                quadrature: self.quadrature,
                harmonics: h,
                taus: &self.sampling.taus,
                residual: &residual,
                contacts,
                frictions: self.friction_series(&state),
                response: DofResponse {
                    dof: response_dof,
                    coefficients,
                    max,
                    min,
                },
            },
        ))
    }
}
