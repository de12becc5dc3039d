//! The one trait every periodic-solution method implements, so that Newton and
//! continuation are written once (DESIGN.md).

use faer::Mat;

use crate::error::Result;
use crate::solution::PeriodicSolution;
use crate::stability::Floquet;

/// Residual, Jacobian and frequency derivative at one point.
pub struct Linearization {
    pub residual: Vec<f64>,
    /// `∂R/∂x` (`dimension × dimension`).
    pub jacobian: Mat<f64>,
    /// `∂R/∂ω` (ω in rad/s).
    pub d_omega: Vec<f64>,
}

/// A periodic-solution problem `R(x, ω) = 0` (e.g. the connectivity condition, eq. 30).
pub trait PeriodicProblem {
    /// Number of unknowns.
    fn dimension(&self) -> usize;

    /// A length that sets the scale of `x` (e.g. the gap, or the static deflection): Newton's
    /// tolerance and continuation's scaling are relative to it.
    fn length_scale(&self) -> f64;

    /// A starting point at `ω` (the contact-free linear response).
    fn initial_guess(&mut self, omega: f64) -> Result<Vec<f64>>;

    /// `R(x, ω)`.
    fn residual(&mut self, x: &[f64], omega: f64) -> Result<Vec<f64>>;

    /// `R`, `∂R/∂x` and `∂R/∂ω`.
    fn linearize(&mut self, x: &[f64], omega: f64) -> Result<Linearization>;

    /// The periodic solution described by `x` at `ω`, with the time series of the contacts
    /// and of the model DOF `response_dof`. Newton statistics are left at their defaults.
    fn solution(&mut self, x: &[f64], omega: f64, response_dof: usize) -> Result<PeriodicSolution>;

    /// Floquet multipliers of the solution `x` at `ω`, for methods that provide them.
    fn floquet(&mut self, _x: &[f64], _omega: f64) -> Result<Option<Floquet>> {
        Ok(None)
    }
}
