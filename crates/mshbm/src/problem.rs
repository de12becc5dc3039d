//! The one trait every periodic-solution method implements, so that Newton and
//! continuation are written once (docs/architecture.md; their algorithms are
//! docs/theory.md §10).

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

/// What a method's residual lets the pseudo-arclength continuation assume (docs/theory.md §10):
/// declared by each method ([`PeriodicProblem::continuation_policy`]) so that every caller of
/// [`crate::continuation::arclength::trace_branch`] runs the same algorithm for it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContinuationPolicy {
    /// How Newton's corrector contracts on this residual.
    pub newton_contraction: NewtonContraction,
    /// What the continuation does where the arclength step fails (the step falls below its
    /// smallest value).
    pub where_arclength_fails: ArclengthFallback,
}

/// How Newton contracts on a method's residual (paper eq. 13).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NewtonContraction {
    /// Exact Jacobian of a smooth residual (smooth on each piece): Newton contracts
    /// quadratically, so each corrector update at least halves the previous one, and an
    /// update that does not is a corrector working across a grazing event or towards another
    /// piece of the branch — refused, the arclength step is halved.
    Quadratic,
    /// No quadratic contraction to rely on (a finite-difference Jacobian, a stiff penalty
    /// with a kinked residual): the corrector's updates are not checked.
    Unchecked,
}

/// What the continuation does where the arclength corrector fails down to the smallest
/// step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ArclengthFallback {
    /// The branch has isolated corners (grazing contacts): look for the outgoing piece on
    /// small spheres around the last point (at most once in a row), then stop.
    EscapeCorner,
    /// The residual is piecewise affine at the time-step scale, so the branch is a staircase
    /// of tiny corners the arclength corrector cannot follow while Newton at a fixed
    /// frequency converges: once the arclength step falls below `min_arclength_step`
    /// (scaled arclength; steps below the staircase scale are not tried, nor are corner
    /// escapes), step in frequency instead — Newton at `ω e^{±Δ}` from the last point, `Δ` a
    /// quarter, a sixteenth, a sixty-fourth of the largest frequency step. Such a step cannot
    /// turn at a fold: past one it lands on whatever solution Newton finds (a jump, as in a
    /// sweep experiment).
    StepInFrequency { min_arclength_step: f64 },
}

/// A periodic-solution problem `R(x, ω) = 0` (e.g. the connectivity condition, paper eq. 30,
/// docs/theory.md (T33)).
pub trait PeriodicProblem {
    /// Number of unknowns.
    fn dimension(&self) -> usize;

    /// A length that sets the scale of `x` (e.g. the gap, or the static deflection;
    /// docs/theory.md (T6)): Newton's tolerance and continuation's scaling are relative to it.
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

    /// What the residual lets the continuation assume ([`ContinuationPolicy`]).
    fn continuation_policy(&self) -> ContinuationPolicy;

    /// Floquet multipliers of the solution `x` at `ω`, for methods that provide them.
    fn floquet(&mut self, _x: &[f64], _omega: f64) -> Result<Option<Floquet>> {
        Ok(None)
    }
}

/// A problem whose initial guess is a given point (a continuation started from a known
/// solution, e.g. one reached by another path); everything else is the wrapped method's.
pub struct StartingAt<'a> {
    pub problem: &'a mut dyn PeriodicProblem,
    pub x0: Vec<f64>,
}

impl PeriodicProblem for StartingAt<'_> {
    fn dimension(&self) -> usize {
        self.problem.dimension()
    }
    fn length_scale(&self) -> f64 {
        self.problem.length_scale()
    }
    fn initial_guess(&mut self, _omega: f64) -> Result<Vec<f64>> {
        Ok(self.x0.clone())
    }
    fn residual(&mut self, x: &[f64], omega: f64) -> Result<Vec<f64>> {
        self.problem.residual(x, omega)
    }
    fn linearize(&mut self, x: &[f64], omega: f64) -> Result<Linearization> {
        self.problem.linearize(x, omega)
    }
    fn solution(&mut self, x: &[f64], omega: f64, response_dof: usize) -> Result<PeriodicSolution> {
        self.problem.solution(x, omega, response_dof)
    }
    fn continuation_policy(&self) -> ContinuationPolicy {
        self.problem.continuation_policy()
    }
    fn floquet(&mut self, x: &[f64], omega: f64) -> Result<Option<Floquet>> {
        self.problem.floquet(x, omega)
    }
}
