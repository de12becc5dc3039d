//! Newton's method with Armijo backtracking on `½‖R‖²` (paper eq. 13; the residual of the
//! redistributed MS-HBM is piecewise affine with sampled quadrature, METHODS §5.5, so the
//! full step is not always a descent step).

use faer::linalg::solvers::Solve;
use faer::Mat;

use crate::error::{Error, Result, SingularSystem};
use crate::problem::PeriodicProblem;

/// Newton settings. Norms are max-norms relative to the problem's length scale.
#[derive(Clone, Debug)]
pub struct NewtonOptions {
    /// Converged when `‖R‖_∞ ≤ tolerance · length_scale` (default `1e-10`; must be positive).
    pub tolerance: f64,
    /// Largest number of Newton iterations (default 50; at least 1).
    pub max_iterations: usize,
    /// Smallest line-search step factor (default `1/1024`; in `(0, 1]`).
    pub min_step: f64,
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

impl Default for NewtonOptions {
    fn default() -> Self {
        NewtonOptions {
            tolerance: 1e-10,
            max_iterations: 50,
            min_step: 1.0 / 1024.0,
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

/// Solve `A y = b` densely (LU with partial pivoting, faer), `b_i = rhs(i)`; `None` when the
/// solution is not finite (`A` singular). The one linear solve of Newton's method and of the
/// continuation's bordered systems.
pub(crate) fn dense_solve(a: &Mat<f64>, n: usize, rhs: impl Fn(usize) -> f64) -> Option<Vec<f64>> {
    let b = Mat::<f64>::from_fn(n, 1, |i, _| rhs(i));
    let y = a.partial_piv_lu().solve(&b);
    let y: Vec<f64> = (0..n).map(|i| y[(i, 0)]).collect();
    y.iter().all(|v| v.is_finite()).then_some(y)
}

/// Solve `J d = −R` densely.
pub fn newton_direction(jacobian: &Mat<f64>, residual: &[f64]) -> Result<Vec<f64>> {
    dense_solve(jacobian, residual.len(), |i| -residual[i])
        .ok_or(Error::SingularSystem(SingularSystem::Jacobian))
}

/// Solve `R(x, ω) = 0` for `x` at fixed `ω`, starting from `x0`.
pub fn solve<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    x0: &[f64],
    omega: f64,
    options: &NewtonOptions,
) -> Result<NewtonOutcome> {
    options.validate()?;
    let scale = problem.length_scale();
    let mut x = x0.to_vec();
    let mut lin = problem.linearize(&x, omega)?;
    let mut norm = max_norm(&lin.residual) / scale;
    let mut history = vec![norm];
    let mut iterations = 0;
    while norm > options.tolerance {
        if iterations >= options.max_iterations {
            return Ok(NewtonOutcome {
                x,
                converged: false,
                iterations,
                residual_norm: norm,
                history,
                reason: Some(NewtonFailure::IterationLimit {
                    max_iterations: options.max_iterations,
                    residual_norm: norm,
                }),
            });
        }
        let Some(d) = dense_solve(&lin.jacobian, lin.residual.len(), |i| -lin.residual[i]) else {
            return Ok(NewtonOutcome {
                x,
                converged: false,
                iterations,
                residual_norm: norm,
                history,
                reason: Some(NewtonFailure::SingularJacobian),
            });
        };
        let phi0 = sum_squares(&lin.residual);
        let mut t = 1.0;
        let mut best: Option<(f64, Vec<f64>)> = None;
        loop {
            let trial: Vec<f64> = x.iter().zip(&d).map(|(a, b)| a + t * b).collect();
            let r = problem.residual(&trial, omega)?;
            let phi = sum_squares(&r);
            if best.as_ref().is_none_or(|(p, _)| phi < *p) {
                best = Some((phi, trial.clone()));
            }
            if phi <= (1.0 - 1e-4 * t) * phi0 || t <= options.min_step {
                break;
            }
            t *= 0.5;
        }
        let (_, next) = best.expect("at least one trial");
        x = next;
        iterations += 1;
        lin = problem.linearize(&x, omega)?;
        norm = max_norm(&lin.residual) / scale;
        history.push(norm);
    }
    Ok(NewtonOutcome {
        x,
        converged: true,
        iterations,
        residual_norm: norm,
        history,
        reason: None,
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
    let x0 = problem.initial_guess(omega)?;
    let outcome = solve(problem, &x0, omega, options)?;
    let mut solution = problem.solution(&outcome.x, omega, response_dof)?;
    solution.converged = outcome.converged;
    solution.iterations = outcome.iterations;
    solution.residual_norm = outcome.residual_norm;
    Ok((solution, outcome))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::{ArclengthFallback, ContinuationPolicy, Linearization, NewtonContraction};
    use crate::solution::PeriodicSolution;

    /// `R(x, ω) = a x − ω` in one unknown (`a = 0`: singular Jacobian).
    struct Line {
        a: f64,
    }

    impl PeriodicProblem for Line {
        fn dimension(&self) -> usize {
            1
        }
        fn length_scale(&self) -> f64 {
            1.0
        }
        fn initial_guess(&mut self, _omega: f64) -> Result<Vec<f64>> {
            Ok(vec![0.0])
        }
        fn residual(&mut self, x: &[f64], omega: f64) -> Result<Vec<f64>> {
            Ok(vec![self.a * x[0] - omega])
        }
        fn linearize(&mut self, x: &[f64], omega: f64) -> Result<Linearization> {
            Ok(Linearization {
                residual: self.residual(x, omega)?,
                jacobian: Mat::from_fn(1, 1, |_, _| self.a),
                d_omega: vec![-1.0],
            })
        }
        fn solution(&mut self, _x: &[f64], _omega: f64, _dof: usize) -> Result<PeriodicSolution> {
            unimplemented!("not needed by Newton")
        }
        fn continuation_policy(&self) -> ContinuationPolicy {
            ContinuationPolicy {
                newton_contraction: NewtonContraction::Quadratic,
                where_arclength_fails: ArclengthFallback::EscapeCorner,
            }
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
            solve(&mut Line { a: 2.0 }, &[0.0], 1.0, &bad),
            Err(Error::InvalidArgument { .. })
        ));
    }

    #[test]
    fn failures_are_typed_and_read_as_before() {
        // a = 2: x = ω / 2 in one step
        let out = solve(&mut Line { a: 2.0 }, &[0.0], 3.0, &NewtonOptions::default()).unwrap();
        assert!(out.converged && out.reason.is_none());
        assert_eq!(out.x, vec![1.5]);
        // a = 0: no direction
        let out = solve(&mut Line { a: 0.0 }, &[0.0], 3.0, &NewtonOptions::default()).unwrap();
        assert!(!out.converged);
        assert_eq!(out.reason, Some(NewtonFailure::SingularJacobian));
        assert_eq!(out.reason.unwrap().to_string(), "the Jacobian is singular");
        let e = newton_direction(&Mat::zeros(1, 1), &[1.0]).unwrap_err();
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
