//! Newton's method with Armijo backtracking on `½‖R‖²` (paper eq. 13, docs/theory.md (T71);
//! the residual of the redistributed MS-HBM is piecewise affine with sampled quadrature,
//! docs/theory.md §5 "Nondifferentiability", so the full step is not always a descent
//! step).

use crate::error::{Error, Result, SingularSystem};
use crate::limits::Cancel;
use crate::problem::{Jacobian, Linearization, PeriodicProblem};

/// Newton settings. Norms are max-norms relative to the problem's length scale.
#[derive(Clone, Debug)]
pub struct NewtonOptions {
    /// Converged when `‖R‖_∞ ≤ tolerance · length_scale` (default `1e-10`; must be positive).
    pub tolerance: f64,
    /// Largest number of Newton iterations (default 50; at least 1).
    pub max_iterations: usize,
    /// Smallest line-search step factor (default `1/1024`; in `(0, 1]`).
    pub min_step: f64,
    /// The caller's request to stop, checked at every iteration and line-search trial
    /// ([`Error::Cancelled`]; default: never). [`crate::solve::solve_periodic`] and
    /// [`crate::frd::trace_diagram`] set it from their `limits.cancel` when it is unset.
    pub cancel: Cancel,
}

impl NewtonOptions {
    /// Refuse settings Newton cannot work with ([`Error::InvalidArgument`]).
    pub fn validate(&self) -> Result<()> {
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(Error::argument(
                "Newton tolerance",
                format!("must be positive and finite, got {}", self.tolerance),
            ));
        }
        if self.max_iterations == 0 {
            return Err(Error::argument(
                "Newton iteration limit",
                "must be at least 1",
            ));
        }
        if !(self.min_step > 0.0 && self.min_step <= 1.0) {
            return Err(Error::argument(
                "Newton line-search step",
                format!(
                    "the smallest step factor must lie in (0, 1], got {}",
                    self.min_step
                ),
            ));
        }
        Ok(())
    }
}

/// Watches the iterations of one Newton solve ([`solve_observed`]): called with the
/// iteration number (0 for the start) and `‖R‖_∞` relative to the length scale at each
/// iterate. The library never prints; a caller may show progress from here.
#[derive(Clone)]
pub struct NewtonObserver(pub std::sync::Arc<dyn Fn(usize, f64) + Send + Sync>);

impl NewtonObserver {
    /// An observer calling `f(iteration, relative residual)`.
    pub fn new(f: impl Fn(usize, f64) + Send + Sync + 'static) -> Self {
        NewtonObserver(std::sync::Arc::new(f))
    }
}

impl std::fmt::Debug for NewtonObserver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("NewtonObserver")
    }
}

impl Default for NewtonOptions {
    fn default() -> Self {
        NewtonOptions {
            tolerance: 1e-10,
            max_iterations: 50,
            min_step: 1.0 / 1024.0,
            cancel: Cancel::NEVER,
        }
    }
}

/// Why Newton stopped without converging. `Display` gives the sentence the CLI prints.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NewtonFailure {
    /// `max_iterations` iterations did not reach the tolerance; `residual_norm` is the
    /// relative residual `‖R‖_∞ / length_scale` at the last iterate.
    IterationLimit {
        max_iterations: usize,
        residual_norm: f64,
    },
    /// The Jacobian at the current iterate is singular (no Newton direction).
    SingularJacobian,
}

impl std::fmt::Display for NewtonFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NewtonFailure::IterationLimit {
                max_iterations,
                residual_norm,
            } => write!(
                f,
                "no convergence in {max_iterations} iterations (relative residual {residual_norm:.3e})"
            ),
            NewtonFailure::SingularJacobian => SingularSystem::Jacobian.fmt(f),
        }
    }
}

/// Outcome of a Newton solve (not converging is an outcome, not an error).
#[derive(Clone, Debug)]
pub struct NewtonOutcome {
    pub x: Vec<f64>,
    pub converged: bool,
    pub iterations: usize,
    /// `‖R‖_∞ / length_scale` at `x`.
    pub residual_norm: f64,
    /// Relative residual after each iteration (index 0: the start).
    pub history: Vec<f64>,
    /// Why it stopped, when it did not converge (`None` exactly when `converged`).
    pub reason: Option<NewtonFailure>,
}

fn max_norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

fn sum_squares(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum()
}

/// Solve `J d = −R` ([`Jacobian::solve`]).
pub fn newton_direction(jacobian: &Jacobian, residual: &[f64]) -> Result<Vec<f64>> {
    jacobian
        .solve(|i| -residual[i])
        .ok_or(Error::SingularSystem(SingularSystem::Jacobian))
}

/// [`newton_direction`] into `direction`, a dense Jacobian factored in `lu`'s storage.
pub fn newton_direction_into(
    jacobian: &Jacobian,
    residual: &[f64],
    lu: &mut crate::dense::DenseLu,
    direction: &mut Vec<f64>,
) -> Result<()> {
    if jacobian.solve_into(|i| -residual[i], lu, direction) {
        Ok(())
    } else {
        Err(Error::SingularSystem(SingularSystem::Jacobian))
    }
}

/// A square system `F(y) = 0` that [`iterate`] solves: the residual at a fixed frequency
/// ([`solve`]), or the continuation's bordered systems (its corrector).
pub(crate) trait NewtonSystem {
    /// The Jacobian `∂F/∂y` and `F(y)` into `jacobian` and `f` (their storage reused where
    /// it can be), or `false` where the system cannot be evaluated (Newton then stops,
    /// [`Iterated::Stopped`]).
    fn linearize(&mut self, y: &[f64], jacobian: &mut Jacobian, f: &mut Vec<f64>) -> Result<bool>;
    /// Whether `y`, with `F(y) = f`, is converged after `iterations` iterations.
    fn converged(&mut self, y: &[f64], f: &[f64], iterations: usize) -> bool;
    /// The next iterate from `y` along the Newton direction `d` (`J d = −F`): a line search,
    /// or the full step; `None` refuses the step (Newton stops, [`Iterated::Stopped`]).
    fn advance(&mut self, y: Vec<f64>, f: &[f64], d: &[f64]) -> Result<Option<Vec<f64>>>;
}

/// How [`iterate`] ended.
pub(crate) enum Iterated {
    Converged {
        y: Vec<f64>,
        iterations: usize,
    },
    /// `max_iterations` iterations without convergence; `y`: the last iterate.
    IterationLimit {
        y: Vec<f64>,
        iterations: usize,
    },
    /// The Jacobian at `y` is singular.
    SingularJacobian {
        y: Vec<f64>,
        iterations: usize,
    },
    /// The system could not be evaluated at an iterate, or refused a step.
    Stopped,
}

/// The storage of [`iterate`]: the Newton system's Jacobian and value, the factors and
/// the direction. Kept from one solve to the next (the continuation keeps one for its
/// corrector), an iteration allocates nothing in it once grown.
pub(crate) struct NewtonStorage {
    jacobian: Jacobian,
    f: Vec<f64>,
    lu: crate::dense::DenseLu,
    direction: Vec<f64>,
}

impl Default for NewtonStorage {
    fn default() -> Self {
        NewtonStorage {
            jacobian: Jacobian::Dense(faer::Mat::zeros(0, 0)),
            f: Vec::new(),
            lu: Default::default(),
            direction: Vec::new(),
        }
    }
}

/// Newton's method (paper eq. 13): from `y`, linearize, stop when converged, else solve
/// `J d = −F` and advance, at most `max_iterations` times, in `storage`. The one Newton
/// loop of the library: [`solve`] and the continuation's corrector differ only in their
/// [`NewtonSystem`].
pub(crate) fn iterate(
    system: &mut impl NewtonSystem,
    mut y: Vec<f64>,
    max_iterations: usize,
    storage: &mut NewtonStorage,
    cancel: Cancel,
) -> Result<Iterated> {
    for iterations in 0..=max_iterations {
        cancel.check()?;
        let NewtonStorage {
            jacobian,
            f,
            lu,
            direction,
        } = storage;
        if !system.linearize(&y, jacobian, f)? {
            return Ok(Iterated::Stopped);
        }
        if system.converged(&y, f, iterations) {
            return Ok(Iterated::Converged { y, iterations });
        }
        if iterations == max_iterations {
            return Ok(Iterated::IterationLimit { y, iterations });
        }
        if !jacobian.solve_into(|i| -f[i], lu, direction) {
            return Ok(Iterated::SingularJacobian { y, iterations });
        }
        match system.advance(y, f, direction)? {
            Some(next) => y = next,
            None => return Ok(Iterated::Stopped),
        }
    }
    unreachable!("the last iteration returns")
}

/// `R(x, ω) = 0` at a fixed `ω`, with Armijo backtracking on `½‖R‖²` (docs/theory.md (T71)).
struct AtFrequency<'a, P: PeriodicProblem + ?Sized> {
    problem: &'a mut P,
    omega: f64,
    scale: f64,
    options: &'a NewtonOptions,
    /// `‖R‖_∞ / scale` at each iterate.
    history: Vec<f64>,
    observer: Option<&'a NewtonObserver>,
    /// The problem's linearization (its storage swapped with Newton's).
    linearization: Linearization,
}

impl<P: PeriodicProblem + ?Sized> NewtonSystem for AtFrequency<'_, P> {
    fn linearize(&mut self, x: &[f64], jacobian: &mut Jacobian, f: &mut Vec<f64>) -> Result<bool> {
        let lin = &mut self.linearization;
        self.problem.linearize_into(x, self.omega, lin)?;
        std::mem::swap(jacobian, &mut lin.jacobian);
        std::mem::swap(f, &mut lin.residual);
        Ok(true)
    }

    fn converged(&mut self, _x: &[f64], residual: &[f64], _iterations: usize) -> bool {
        let norm = max_norm(residual) / self.scale;
        if let Some(observer) = self.observer {
            (observer.0)(self.history.len(), norm);
        }
        self.history.push(norm);
        // as the loop `while norm > tolerance` always read: a NaN norm stops it, as converged
        norm <= self.options.tolerance || norm.is_nan()
    }

    fn advance(&mut self, x: Vec<f64>, residual: &[f64], d: &[f64]) -> Result<Option<Vec<f64>>> {
        let phi0 = sum_squares(residual);
        let mut t = 1.0;
        let mut best: Option<(f64, Vec<f64>)> = None;
        loop {
            self.options.cancel.check()?;
            let trial: Vec<f64> = x.iter().zip(d).map(|(a, b)| a + t * b).collect();
            let r = self.problem.residual(&trial, self.omega)?;
            let phi = sum_squares(&r);
            if best.as_ref().is_none_or(|(p, _)| phi < *p) {
                best = Some((phi, trial.clone()));
            }
            if phi <= (1.0 - 1e-4 * t) * phi0 || t <= self.options.min_step {
                break;
            }
            t *= 0.5;
        }
        Ok(best.map(|(_, next)| next))
    }
}

/// Solve `R(x, ω) = 0` for `x` at fixed `ω`, starting from `x0`.
pub fn solve<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    x0: &[f64],
    omega: f64,
    options: &NewtonOptions,
) -> Result<NewtonOutcome> {
    solve_observed(problem, x0, omega, options, None)
}

/// [`solve`], reporting every iterate's residual to `observer`.
pub fn solve_observed<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    x0: &[f64],
    omega: f64,
    options: &NewtonOptions,
    observer: Option<&NewtonObserver>,
) -> Result<NewtonOutcome> {
    options.validate()?;
    let mut system = AtFrequency {
        scale: problem.length_scale(),
        problem,
        omega,
        options,
        history: Vec::new(),
        observer,
        linearization: Linearization::empty(),
    };
    let end = iterate(
        &mut system,
        x0.to_vec(),
        options.max_iterations,
        &mut NewtonStorage::default(),
        options.cancel,
    )?;
    let history = system.history;
    let norm = *history.last().expect("at least the start is evaluated");
    let (x, iterations, reason) = match end {
        Iterated::Converged { y, iterations } => (y, iterations, None),
        Iterated::IterationLimit { y, iterations } => (
            y,
            iterations,
            Some(NewtonFailure::IterationLimit {
                max_iterations: options.max_iterations,
                residual_norm: norm,
            }),
        ),
        Iterated::SingularJacobian { y, iterations } => {
            (y, iterations, Some(NewtonFailure::SingularJacobian))
        }
        Iterated::Stopped => unreachable!("a fixed-frequency problem is evaluated or errs"),
    };
    Ok(NewtonOutcome {
        x,
        converged: reason.is_none(),
        iterations,
        residual_norm: norm,
        history,
        reason,
    })
}

/// Solve at one frequency from the problem's initial guess (the contact-free linear
/// response) and return the solution with Newton's statistics, together with the outcome.
pub fn solve_at_frequency<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    omega: f64,
    response_dof: usize,
    options: &NewtonOptions,
) -> Result<(crate::solution::PeriodicSolution, NewtonOutcome)> {
    solve_at_frequency_observed(problem, omega, response_dof, options, None)
}

/// [`solve_at_frequency`], reporting every Newton iterate to `observer`.
pub fn solve_at_frequency_observed<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    omega: f64,
    response_dof: usize,
    options: &NewtonOptions,
    observer: Option<&NewtonObserver>,
) -> Result<(crate::solution::PeriodicSolution, NewtonOutcome)> {
    let x0 = problem.initial_guess(omega)?;
    let outcome = solve_observed(problem, &x0, omega, options, observer)?;
    let mut solution = problem.solution(&outcome.x, omega, response_dof)?;
    solution.converged = outcome.converged;
    solution.iterations = outcome.iterations;
    solution.residual_norm = outcome.residual_norm;
    Ok((solution, outcome))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::tests::Scalar;
    use crate::problem::NewtonContraction;

    /// `R(x, ω) = a x − ω` in one unknown (`a = 0`: singular Jacobian).
    fn line(a: f64) -> Scalar<impl FnMut(f64, f64) -> (f64, f64, f64)> {
        Scalar {
            equation: move |x, omega| (a * x - omega, a, -1.0),
            contraction: NewtonContraction::Quadratic,
        }
    }

    #[test]
    fn bad_settings_are_refused() {
        let message = |options: NewtonOptions| match options.validate() {
            Err(e @ Error::InvalidArgument { .. }) => e.to_string(),
            other => panic!("expected an invalid argument, got {other:?}"),
        };
        NewtonOptions::default().validate().unwrap();
        for tolerance in [0.0, -1e-10, f64::NAN, f64::INFINITY] {
            let e = message(NewtonOptions {
                tolerance,
                ..NewtonOptions::default()
            });
            assert!(e.starts_with("invalid Newton tolerance: "), "{e}");
        }
        let e = message(NewtonOptions {
            max_iterations: 0,
            ..NewtonOptions::default()
        });
        assert_eq!(e, "invalid Newton iteration limit: must be at least 1");
        for min_step in [0.0, -0.5, 1.5, f64::NAN] {
            let e = message(NewtonOptions {
                min_step,
                ..NewtonOptions::default()
            });
            assert!(e.starts_with("invalid Newton line-search step: "), "{e}");
        }
        // solve refuses them too, before evaluating anything
        let bad = NewtonOptions {
            max_iterations: 0,
            ..NewtonOptions::default()
        };
        assert!(matches!(
            solve(&mut line(2.0), &[0.0], 1.0, &bad),
            Err(Error::InvalidArgument { .. })
        ));
    }

    #[test]
    fn failures_are_typed_and_read_as_before() {
        // a = 2: x = ω / 2 in one step
        let out = solve(&mut line(2.0), &[0.0], 3.0, &NewtonOptions::default()).unwrap();
        assert!(out.converged && out.reason.is_none());
        assert_eq!(out.x, vec![1.5]);
        // a = 0: no direction
        let out = solve(&mut line(0.0), &[0.0], 3.0, &NewtonOptions::default()).unwrap();
        assert!(!out.converged);
        assert_eq!(out.reason, Some(NewtonFailure::SingularJacobian));
        assert_eq!(out.reason.unwrap().to_string(), "the Jacobian is singular");
        let e = newton_direction(&Jacobian::Dense(faer::Mat::zeros(1, 1)), &[1.0]).unwrap_err();
        assert!(matches!(e, Error::SingularSystem(SingularSystem::Jacobian)));
        assert_eq!(e.kind(), crate::error::ErrorKind::Singular);
        assert_eq!(e.to_string(), "the Jacobian is singular");
        let limit = NewtonFailure::IterationLimit {
            max_iterations: 50,
            residual_norm: 8.662e-3,
        };
        assert_eq!(
            limit.to_string(),
            "no convergence in 50 iterations (relative residual 8.662e-3)"
        );
        assert_eq!(
            Error::SingularSystem(SingularSystem::BorderedMatrix).to_string(),
            "the bordered continuation matrix is singular"
        );
    }
}
