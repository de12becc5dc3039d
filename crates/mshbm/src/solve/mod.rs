//! One periodic solution at one frequency (`mshbm solve`), then the Floquet multipliers where
//! the method provides them (docs/theory.md §11).
//!
//! Where Newton starts is a [`SolveStart`] (docs/theory.md §10, "Starting a solve",
//! (T118)–(T119)):
//!
//! * from the contact-free linear response (docs/theory.md (T71)) — the paper's start, and
//!   the first try of the default;
//! * when that fails (stiff contact interfaces: the residual's slope changes by the ratio of
//!   the interface's local stiffness to the structure's at every contact switch, and Newton
//!   from far away cycles between pieces), the default continues the branch in frequency
//!   from a lower frequency where Newton from the linear response converges
//!   ([`continuation`]): each corrector starts next to a solution, as along a frequency
//!   response diagram;
//! * from the unknowns of a given solution (possibly at another frequency);
//! * a sweep: the branch is traced over a frequency range, and every solution at the target
//!   frequency it crosses is reported (several coexist where the branch folds).

mod continuation;

pub use continuation::{start_by_continuation, BranchObserver, ContinuationStart, Crossings};

use crate::error::{Error, Result};
use crate::frd::response_dof;
use crate::limits::Limits;
use crate::method::settings::MethodSettings;
use crate::method::SetupObserver;
use crate::model::Model;
use crate::newton::{solve_observed, NewtonObserver, NewtonOptions, NewtonOutcome};
use crate::problem::PeriodicProblem;
use crate::solution::PeriodicSolution;

/// Where Newton starts (module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub enum SolveStart {
    /// The linear response; if Newton does not converge from it, continuation in frequency
    /// from the highest of `f/2, f/4, …, f/64` at which Newton from the linear response
    /// converges (docs/theory.md (T118)).
    #[default]
    Auto,
    /// The linear response only.
    Linear,
    /// The method's unknowns of a previous solution ([`PeriodicSolution::unknowns`]).
    Unknowns(Vec<f64>),
    /// Trace the branch from `from_hz` (Newton from the linear response there) to `to_hz`
    /// and report every solution at the target frequency the branch crosses
    /// (docs/theory.md (T119)).
    Sweep { from_hz: f64, to_hz: f64 },
}

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
    /// Where Newton starts (default [`SolveStart::Auto`]).
    pub start: SolveStart,
    /// Called at every accepted point of a branch the solve traces (the fallback of
    /// [`SolveStart::Auto`], [`SolveStart::Sweep`]): progress of long continuations.
    pub branch_observer: Option<BranchObserver>,
    /// Told the phases of the method's set-up (progress on large models).
    pub setup_observer: Option<SetupObserver>,
}

impl Default for SolveSettings {
    fn default() -> Self {
        SolveSettings {
            newton: NewtonOptions::default(),
            stability: true,
            response_dof: None,
            limits: Limits::default(),
            observer: None,
            start: SolveStart::Auto,
            branch_observer: None,
            setup_observer: None,
        }
    }
}

/// How the solution was reached.
#[derive(Clone, Debug, PartialEq)]
pub enum SolvePath {
    /// Newton from the start ([`SolveStart::Linear`], [`SolveStart::Unknowns`], or the
    /// first try of [`SolveStart::Auto`]).
    Direct,
    /// Continuation in frequency from `from_hz` ([`SolveStart::Auto`] after Newton from the
    /// linear response failed, or [`SolveStart::Sweep`]): `points` accepted points, `folds`
    /// turning points passed on the way (where the branch turns, several solutions coexist).
    Continuation {
        from_hz: f64,
        points: usize,
        folds: usize,
    },
}

/// What one solve gives: the solution (with its multipliers when computed), the method's
/// label and Newton's outcome. Not converging is an outcome here, not an error.
pub struct Solved {
    pub solution: PeriodicSolution,
    pub label: String,
    pub outcome: NewtonOutcome,
    /// Why the multipliers of a converged solution could not be computed, if they could not
    /// (the solution's stability is then unknown, `PeriodicSolution::stability_unknown`).
    pub stability_error: Option<Error>,
    /// How the solution was reached.
    pub path: SolvePath,
    /// Other solutions at the same frequency met on the way (a sweep that crosses the
    /// target frequency more than once), in the order the branch met them, with their
    /// multipliers when computed.
    pub others: Vec<PeriodicSolution>,
}

impl Solved {
    /// Why the solution at `frequency_hz` (the one asked for) is not converged (`None`
    /// when it is): "Newton did not converge at F Hz: REASON", the sentence every front
    /// end reports.
    pub fn not_converged(&self, frequency_hz: f64) -> Option<String> {
        (!self.outcome.converged).then(|| {
            format!(
                "Newton did not converge at {frequency_hz} Hz: {}",
                self.outcome
                    .reason
                    .as_ref()
                    .map_or_else(|| "unknown reason".into(), |r| r.to_string())
            )
        })
    }
}

/// Solve `method` for `model` at `frequency_hz`, starting as `settings.start` says.
pub fn solve_periodic(
    model: &Model,
    method: &MethodSettings,
    frequency_hz: f64,
    settings: &SolveSettings,
) -> Result<Solved> {
    let positive = |name: &str, hz: f64| {
        if hz.is_finite() && hz > 0.0 {
            Ok(())
        } else {
            Err(Error::argument(
                name,
                format!("must be a positive number of Hz, got {hz}"),
            ))
        }
    };
    positive("frequency", frequency_hz)?;
    if let SolveStart::Sweep { from_hz, to_hz } = settings.start {
        positive("sweep start", from_hz)?;
        positive("sweep end", to_hz)?;
        let (lo, hi) = (from_hz.min(to_hz), from_hz.max(to_hz));
        if !(lo < frequency_hz && frequency_hz <= hi) {
            return Err(Error::argument(
                "sweep",
                format!("the frequency {frequency_hz} Hz must lie in the swept range from {from_hz} to {to_hz} Hz, after its start"),
            ));
        }
    }
    // Newton stops when the caller asks (the limits' request, unless Newton has its own)
    let settings = &SolveSettings {
        newton: NewtonOptions {
            cancel: settings.newton.cancel.or(settings.limits.cancel),
            ..settings.newton.clone()
        },
        ..settings.clone()
    };
    let dof = response_dof(model, settings.response_dof)?;
    let built = method.build_observed(model, &settings.limits, settings.setup_observer.as_ref())?;
    let mut problem = built.problem;
    let problem = problem.as_mut();
    let omega = 2.0 * std::f64::consts::PI * frequency_hz;
    let (outcome, path, others) = find(problem, omega, settings)?;
    let mut solution = solution_at(problem, &outcome.x, omega, dof)?;
    solution.converged = outcome.converged;
    solution.iterations = outcome.iterations;
    solution.residual_norm = outcome.residual_norm;
    let mut stability_error = None;
    settings.limits.cancel.check()?;
    if outcome.converged && settings.stability {
        match problem.floquet(&outcome.x, omega) {
            Ok(st) => solution.stability = st,
            Err(e) => {
                solution.stability_unknown = Some(e.to_string());
                stability_error = Some(e);
            }
        }
    }
    let mut other_solutions = Vec::with_capacity(others.len());
    for x in others {
        let mut s = solution_at(problem, &x, omega, dof)?;
        s.converged = true;
        if settings.stability {
            match problem.floquet(&x, omega) {
                Ok(st) => s.stability = st,
                Err(e) => s.stability_unknown = Some(e.to_string()),
            }
        }
        other_solutions.push(s);
    }
    Ok(Solved {
        solution,
        label: built.label,
        outcome,
        stability_error,
        path,
        others: other_solutions,
    })
}

/// The reported solution of `x`, with the unknowns kept for a later start.
fn solution_at(
    problem: &mut dyn PeriodicProblem,
    x: &[f64],
    omega: f64,
    dof: usize,
) -> Result<PeriodicSolution> {
    let mut s = problem.solution(x, omega, dof)?;
    s.unknowns = Some(x.to_vec());
    Ok(s)
}

/// Newton's outcome at `omega`, how it was reached, and the unknowns of other solutions
/// met on the way.
fn find(
    problem: &mut dyn PeriodicProblem,
    omega: f64,
    settings: &SolveSettings,
) -> Result<(NewtonOutcome, SolvePath, Vec<Vec<f64>>)> {
    let observer = settings.observer.as_ref();
    let direct = |problem: &mut dyn PeriodicProblem, x0: Vec<f64>| {
        solve_observed(problem, &x0, omega, &settings.newton, observer)
    };
    match &settings.start {
        SolveStart::Linear => {
            let x0 = problem.initial_guess(omega)?;
            Ok((direct(problem, x0)?, SolvePath::Direct, vec![]))
        }
        SolveStart::Unknowns(x0) => {
            if x0.len() != problem.dimension() {
                return Err(Error::argument(
                    "starting solution",
                    format!(
                        "has {} unknowns, the method has {} (a solution of another method, number of harmonics or model)",
                        x0.len(),
                        problem.dimension()
                    ),
                ));
            }
            Ok((direct(problem, x0.clone())?, SolvePath::Direct, vec![]))
        }
        SolveStart::Auto => {
            let x0 = problem.initial_guess(omega)?;
            let first = direct(problem, x0)?;
            if first.converged {
                return Ok((first, SolvePath::Direct, vec![]));
            }
            match continuation::from_below(
                problem,
                omega,
                &settings.newton,
                settings.branch_observer.as_ref(),
            )? {
                Some(found) => Ok((found.outcome, found.path, vec![])),
                None => Ok((first, SolvePath::Direct, vec![])),
            }
        }
        SolveStart::Sweep { from_hz, to_hz } => {
            let two_pi = 2.0 * std::f64::consts::PI;
            let crossings = continuation::sweep(
                problem,
                two_pi * from_hz,
                two_pi * to_hz,
                omega,
                &settings.newton,
                settings.branch_observer.as_ref(),
            )?;
            let path = SolvePath::Continuation {
                from_hz: *from_hz,
                points: crossings.points,
                folds: crossings.folds,
            };
            let mut solutions = crossings.solutions.into_iter();
            match solutions.next() {
                Some(first) => Ok((first, path, solutions.map(|o| o.x).collect())),
                None => Err(Error::argument(
                    "sweep",
                    format!(
                        "the branch from {from_hz} Hz did not reach {} Hz ({})",
                        omega / two_pi,
                        crossings.stop
                    ),
                )),
            }
        }
    }
}
