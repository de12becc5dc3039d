//! Newton's method with Armijo backtracking on `½‖R‖²` (paper eq. 13; the residual of the
//! redistributed MS-HBM is piecewise affine with sampled quadrature, METHODS §5.5, so the
//! full step is not always a descent step).

use faer::linalg::solvers::Solve;
use faer::Mat;

use crate::error::{Error, Result};
use crate::problem::PeriodicProblem;

/// Newton settings. Norms are max-norms relative to the problem's length scale.
#[derive(Clone, Debug)]
pub struct NewtonOptions {
    /// Converged when `‖R‖_∞ ≤ tolerance · length_scale`.
    pub tolerance: f64,
    pub max_iterations: usize,
    /// Smallest line-search step factor.
    pub min_step: f64,
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
    /// Why it stopped, when it did not converge.
    pub reason: Option<String>,
}

fn max_norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

fn sum_squares(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum()
}

/// Solve `J d = −R` densely.
pub fn newton_direction(jacobian: &Mat<f64>, residual: &[f64]) -> Result<Vec<f64>> {
    let n = residual.len();
    let rhs = Mat::<f64>::from_fn(n, 1, |i, _| -residual[i]);
    let d = jacobian.partial_piv_lu().solve(&rhs);
    let d: Vec<f64> = (0..n).map(|i| d[(i, 0)]).collect();
    if d.iter().any(|v| !v.is_finite()) {
        return Err(Error::Singular("the Jacobian is singular".into()));
    }
    Ok(d)
}

/// Solve `R(x, ω) = 0` for `x` at fixed `ω`, starting from `x0`.
pub fn solve<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    x0: &[f64],
    omega: f64,
    options: &NewtonOptions,
) -> Result<NewtonOutcome> {
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
                reason: Some(format!(
                    "no convergence in {} iterations (relative residual {norm:.3e})",
                    options.max_iterations
                )),
            });
        }
        let d = match newton_direction(&lin.jacobian, &lin.residual) {
            Ok(d) => d,
            Err(e) => {
                return Ok(NewtonOutcome {
                    x,
                    converged: false,
                    iterations,
                    residual_norm: norm,
                    history,
                    reason: Some(e.to_string()),
                })
            }
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
