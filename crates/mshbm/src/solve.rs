//! One periodic solution at one frequency (`mshbm solve`): Newton from the contact-free
//! response (docs/theory.md (T71)), then the Floquet multipliers where the method provides
//! them (docs/theory.md §11).

use crate::error::{Error, Result};
use crate::frd::response_dof;
use crate::limits::Limits;
use crate::method::settings::MethodSettings;
use crate::model::Model;
use crate::newton::{solve_at_frequency_observed, NewtonObserver, NewtonOptions, NewtonOutcome};
use crate::solution::PeriodicSolution;

/// Settings of one solve, with their defaults.
#[derive(Clone, Debug)]
pub struct SolveSettings {
    /// Default: tolerance 1e-10 relative to the length scale, 50 iterations.
    pub newton: NewtonOptions,
    /// Compute the Floquet multipliers of a converged solution (default `true`).
    pub stability: bool,
    /// The model DOF the solution reports (`None`: as [`response_dof`]).
    pub response_dof: Option<usize>,
    /// The memory budget the method (and its Floquet analysis) is checked against before
    /// it allocates (default: the machine's memory, [`Limits::default`]).
    pub limits: Limits,
    /// Called at every Newton iterate (a progress display for long solves).
    pub observer: Option<NewtonObserver>,
}

impl Default for SolveSettings {
    fn default() -> Self {
        SolveSettings {
            newton: NewtonOptions::default(),
            stability: true,
            response_dof: None,
            limits: Limits::default(),
            observer: None,
        }
    }
}

/// What one solve gives: the solution (with its multipliers when computed), the method's
/// label and Newton's outcome. Not converging is an outcome here, not an error.
pub struct Solved {
    pub solution: PeriodicSolution,
    pub label: String,
    pub outcome: NewtonOutcome,
    /// Why the multipliers of a converged solution could not be computed, if they could not.
    pub stability_error: Option<Error>,
}

/// Solve `method` for `model` at `frequency_hz` from the contact-free linear response.
pub fn solve_periodic(
    model: &Model,
    method: &MethodSettings,
    frequency_hz: f64,
    settings: &SolveSettings,
) -> Result<Solved> {
    if !(frequency_hz.is_finite() && frequency_hz > 0.0) {
        return Err(Error::argument(
            "frequency",
            format!("must be a positive number of Hz, got {frequency_hz}"),
        ));
    }
    let dof = response_dof(model, settings.response_dof)?;
    let built = method.build_within(model, &settings.limits)?;
    let mut problem = built.problem;
    let omega = 2.0 * std::f64::consts::PI * frequency_hz;
    let (mut solution, outcome) = solve_at_frequency_observed(
        problem.as_mut(),
        omega,
        dof,
        &settings.newton,
        settings.observer.as_ref(),
    )?;
    let mut stability_error = None;
    if outcome.converged && settings.stability {
        match problem.floquet(&outcome.x, omega) {
            Ok(st) => solution.stability = st,
            Err(e) => stability_error = Some(e),
        }
    }
    Ok(Solved {
        solution,
        label: built.label,
        outcome,
        stability_error,
    })
}
