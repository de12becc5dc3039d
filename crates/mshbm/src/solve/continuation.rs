//! Solves that follow the branch in frequency (docs/theory.md (T118)–(T119)): the default's
//! fallback, which continues from a lower frequency up to the target, and the sweep, which
//! collects every solution at the target frequency that the branch crosses.

use super::SolvePath;
use crate::continuation::arclength::{trace_branch, ContinuationOptions, Event, StopReason};
use crate::error::Result;
use crate::frd::describe_stop;
use crate::newton::{solve, NewtonOptions, NewtonOutcome};
use crate::problem::PeriodicProblem;

/// Two solutions closer than this (max-norm relative to the length scale) are one.
const SAME_SOLUTION: f64 = 1e-6;

/// The starts the fallback tries, as fractions of the target frequency: `2^-k` for
/// `k = 1 … 6`, below the contact resonance, where Newton from the linear response converges.
/// (A start close to the target shortens the path only where Newton fails in a narrow band:
/// measured on the cracked beam at 765 Hz, 2455 points from 15/16 of it against 2639 from
/// half of it.)
fn start_fractions() -> impl Iterator<Item = f64> {
    (1..=6).map(|k| 0.5f64.powi(k))
}

/// The solution at the target found by continuation, and how.
pub struct ContinuationStart {
    pub outcome: NewtonOutcome,
    pub path: SolvePath,
}

/// The solutions at a target frequency met by a sweep.
pub struct Crossings {
    /// Converged solutions at the target, distinct, in the order the branch met them.
    pub solutions: Vec<NewtonOutcome>,
    /// Accepted points of the traced branch.
    pub points: usize,
    /// Turning points of the branch.
    pub folds: usize,
    /// Why the branch ended, as a sentence.
    pub stop: String,
}

fn options(omega_from: f64, omega_to: f64, newton: &NewtonOptions) -> ContinuationOptions {
    let mut options = ContinuationOptions::new(omega_from, omega_to);
    options.newton.tolerance = newton.tolerance;
    options
}

/// Watches the branch a solve traces ([`crate::solve::SolveStart::Auto`]'s fallback and
/// [`crate::solve::SolveStart::Sweep`]): called at each accepted point with its frequency
/// [Hz], the number of points so far and the frequency the branch runs to [Hz]. The
/// library never prints; a caller may show progress from here. An error it returns stops
/// the solve at once and is returned (a caller's interruption).
#[derive(Clone)]
#[allow(clippy::type_complexity)]
pub struct BranchObserver(pub std::sync::Arc<dyn Fn(f64, usize, f64) -> Result<()> + Send + Sync>);

impl BranchObserver {
    /// An observer calling `f(frequency_hz, points, toward_hz)`.
    pub fn new(f: impl Fn(f64, usize, f64) -> Result<()> + Send + Sync + 'static) -> Self {
        BranchObserver(std::sync::Arc::new(f))
    }
}

impl std::fmt::Debug for BranchObserver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("BranchObserver")
    }
}

/// `trace_branch` from `omega_from` to `omega_to`, calling `observer` at each accepted
/// point and `on_point` with it.
fn trace_observed(
    problem: &mut dyn PeriodicProblem,
    omega_from: f64,
    omega_to: f64,
    newton: &NewtonOptions,
    observer: Option<&BranchObserver>,
    mut on_point: impl FnMut(&crate::continuation::arclength::BranchPoint),
) -> Result<crate::continuation::arclength::Branch> {
    let hz = |w: f64| w / (2.0 * std::f64::consts::PI);
    let mut count = 0;
    trace_branch(
        problem,
        &options(omega_from, omega_to, newton),
        |_, event| {
            if let Event::Point(p) = event {
                count += 1;
                if let Some(o) = observer {
                    (o.0)(hz(p.omega), count, hz(omega_to))?;
                }
                on_point(p);
            }
            Ok(())
        },
    )
}

/// Continue the branch up to `omega` from the first of `ω/2, ω/4, …, ω/64` at which Newton
/// from the linear response converges (docs/theory.md (T118));
/// `None` when no start converges or every branch from a converged start stops before
/// `omega`.
pub(super) fn from_below(
    problem: &mut dyn PeriodicProblem,
    omega: f64,
    newton: &NewtonOptions,
    observer: Option<&BranchObserver>,
) -> Result<Option<ContinuationStart>> {
    for fraction in start_fractions() {
        let omega_from = omega * fraction;
        let branch = trace_observed(problem, omega_from, omega, newton, observer, |_| {})?;
        match branch.stop {
            StopReason::StartFailed(_) => continue,
            StopReason::ReachedEnd => {
                let last = branch
                    .points
                    .last()
                    .expect("a branch that reached its end has points");
                let outcome = NewtonOutcome {
                    x: last.x.clone(),
                    converged: true,
                    iterations: branch.points.iter().map(|p| p.iterations).sum(),
                    residual_norm: last.residual_norm,
                    history: vec![last.residual_norm],
                    reason: None,
                };
                return Ok(Some(ContinuationStart {
                    outcome,
                    path: SolvePath::Continuation {
                        from_hz: omega_from / (2.0 * std::f64::consts::PI),
                        points: branch.points.len(),
                        folds: branch.folds.len(),
                    },
                }));
            }
            // stopped on the way (a singular point): a start further away may pass elsewhere
            _ => continue,
        }
    }
    Ok(None)
}

/// Trace the branch from `omega_from` to `omega_to` and solve at `omega` wherever the
/// branch crosses it: Newton at `omega` from the linear interpolation between the two
/// points on either side (docs/theory.md (T119)).
pub(super) fn sweep(
    problem: &mut dyn PeriodicProblem,
    omega_from: f64,
    omega_to: f64,
    omega: f64,
    newton: &NewtonOptions,
    observer: Option<&BranchObserver>,
) -> Result<Crossings> {
    let mut points: Vec<(f64, Vec<f64>)> = Vec::new();
    let branch = trace_observed(problem, omega_from, omega_to, newton, observer, |p| {
        points.push((p.omega, p.x.clone()))
    })?;
    let scale = problem.length_scale();
    let mut solutions: Vec<NewtonOutcome> = Vec::new();
    for pair in points.windows(2) {
        let ((w0, x0), (w1, x1)) = (&pair[0], &pair[1]);
        // a crossing, counted once: the point after it may lie on the target, the one before not
        if *w0 == omega || (w0 - omega) * (w1 - omega) > 0.0 {
            continue;
        }
        let r = (omega - w0) / (w1 - w0);
        let guess: Vec<f64> = x0.iter().zip(x1).map(|(a, b)| a + r * (b - a)).collect();
        let found = solve(problem, &guess, omega, newton)?;
        let known = solutions.iter().any(|s| {
            s.x.iter()
                .zip(&found.x)
                .all(|(a, b)| (a - b).abs() <= SAME_SOLUTION * scale)
        });
        if found.converged && !known {
            solutions.push(found);
        }
    }
    Ok(Crossings {
        solutions,
        points: points.len(),
        folds: branch.folds.len(),
        stop: describe_stop(&branch.stop, omega_to / (2.0 * std::f64::consts::PI)),
    })
}

/// A solution at `omega` where Newton from the linear response does not converge, by
/// continuation from below (docs/theory.md (T118)); `None` when none is found. Used by the
/// frequency response diagram for its first point.
pub fn start_by_continuation(
    problem: &mut dyn PeriodicProblem,
    omega: f64,
    newton: &NewtonOptions,
) -> Result<Option<Vec<f64>>> {
    Ok(from_below(problem, omega, newton, None)?.map(|found| found.outcome.x))
}
