//! Pseudo-arclength continuation of periodic solutions in `(x, ω)` (docs/theory.md §10,
//! (T72)–(T77)), written once over [`PeriodicProblem`].
//!
//! Unknowns are scaled to O(1) (docs/theory.md (T72)): `X = [x / (ℓ √s); ln(ω / ω_ref)]`
//! with `ℓ` the problem's length scale, `s` the signals its unknowns hold (the contacts;
//! [`crate::problem::ContinuationPolicy::signals`]: a step is the same change of the
//! response on one contact and on a thousand) and `ω_ref` the start frequency (ω ~ 1e5
//! rad/s against displacements ~ 0.1 mm otherwise dominate every norm; the logarithm weighs
//! a relative change of frequency the same over the whole sweep). Each step:
//!
//! * predictor `X_p = X_0 + Δs t` along the unit tangent `t` (solved from
//!   `[R_X; t_prevᵀ] t = [0; 1]` and oriented along the secant of the last step, so that a
//!   sharp turn is not mistaken for a reversal; docs/theory.md (T73));
//! * Keller corrector: Newton on `[R(X); tᵀ(X − X_0) − Δs] = 0` (docs/theory.md (T74));
//! * step control: `Δs ← Δs · clamp(N_opt / N_it, ½, 2)` within bounds (docs/theory.md
//!   (T75)); a failed corrector, a tangent that turns by more than `max_turn_deg`, or an
//!   orientation `sign det [R_X; tᵀ]` that flips (a jump across a fold onto the returning
//!   piece, docs/theory.md (T73a)) halves `Δs`; below the smallest step the method's fallback is tried (a corner escape,
//!   or stepping in frequency, docs/theory.md (T77);
//!   [`crate::problem::ArclengthFallback`]), and when it finds nothing the branch stops
//!   with the reason.
//!
//! What the residual lets the continuation assume (whether Newton contracts quadratically,
//! which fallback) is declared by the method, [`PeriodicProblem::continuation_policy`], so
//! every caller runs the same algorithm for a method.
//!
//! The parts: `options` (settings and their validation), `predictor` (tangent),
//! `corrector` (the bordered Newton: Keller's arclength condition, or a sphere), `step_control`
//! (`Δs`, turn check, range), `fallback` (corner escape, frequency stepping), `fold` (fold
//! location), `branch` (what is produced).
//!
//! **Folds** (turning points in ω) are sign changes of the ω-component of the tangent
//! between accepted points. Each is *located* by regula falsi on `t_ω(s) = 0` along the arc
//! (each evaluation a corrector solve; docs/theory.md (T76)). A sign change that does not
//! close to a zero of `t_ω` — a jump of the tangent across a nonsmooth point of the
//! residual, such as the kinks that sampled quadrature produces — is reported with
//! `at_kink = true`: the frequency is still extremal there, but it is a corner, not a
//! smooth fold, and with sampled quadrature it may be an artefact of the sampling
//! (zig-zags near grazing).

mod branch;
mod corrector;
mod fallback;
mod fold;
mod options;
mod predictor;
mod scaled;
mod step_control;

pub use branch::{Branch, BranchPoint, Event, Fold, StepFailure, StopReason};
pub use options::ContinuationOptions;

use crate::error::{ErrorKind, Result};
use crate::newton;
use crate::problem::PeriodicProblem;
use corrector::Corrector;
use fallback::{Fallback, Rescue};
use fold::{locate_fold, seen_before};
use predictor::oriented_tangent;
use scaled::{difference, normalized, Scaling};
use step_control::{continues_branch, next_step, shrink, Range, StepCheck};

/// Trace the branch from `omega_start` to `omega_end`, starting from Newton on the
/// problem's initial guess; `on_event` sees every point and fold as it is found (so a
/// caller can stream them) and gets the problem to evaluate solutions. Settings are
/// validated first ([`ContinuationOptions::validate`]); the method's
/// [`PeriodicProblem::continuation_policy`] chooses the corrector's contraction check and
/// the fallback where the arclength step fails.
pub fn trace_branch<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    options: &ContinuationOptions,
    on_event: impl FnMut(&mut P, Event<'_>) -> Result<()>,
) -> Result<Branch> {
    options.validate()?;
    let policy = problem.continuation_policy();
    let range = Range::new(options);
    let sc = Scaling::new(problem.length_scale(), policy.signals, range.start);
    let corrector = Corrector::new(&options.newton, policy.newton_contraction);
    let mut fallback = Fallback::new(policy.where_arclength_fails);
    let mut trace = Trace::new(on_event);
    match first_point(problem, &sc, &range, options)? {
        Ok(first) => trace.point(problem, first)?,
        Err(failure) => return Ok(trace.stop(StopReason::StartFailed(failure))),
    }
    let mut ds = options.initial_step;
    loop {
        if trace.branch.points.len() >= options.max_points {
            return Ok(trace.stop(StopReason::MaxPoints));
        }
        let last = trace.branch.points.last().expect("non-empty").clone();
        let start = sc.to_scaled(&last.x, last.omega);
        // end of the range ahead: land on it exactly
        if let Some(end) = land_on_end(problem, &sc, &range, &last, &start, ds, options)? {
            trace.point(problem, end)?;
            return Ok(trace.stop(StopReason::ReachedEnd));
        }
        let Some(point) = arclength_step(problem, &sc, &corrector, &last, &start, ds, options)?
        else {
            ds = shrink(ds);
            let smallest = fallback.smallest_step(options);
            if ds >= smallest {
                continue;
            }
            let Some(rescue) =
                fallback.rescue(problem, &sc, &corrector, &last, range.direction, options)?
            else {
                let reason = StepFailure::NoContinuationPoint {
                    corrector_iterations: options.newton.max_iterations,
                    smallest_step: smallest,
                    frequency_stepping: fallback.steps_in_frequency(),
                };
                return Ok(trace.stop(StopReason::StepTooSmall {
                    omega: last.omega,
                    reason,
                }));
            };
            ds = rescue.next_step(options);
            match rescue {
                Rescue::Corner(point) => {
                    let n = point.tangent.len() - 1;
                    if last.tangent[n] * point.tangent[n] < 0.0 {
                        // ω is extremal at the corner itself
                        let fold = Fold {
                            omega: last.omega,
                            x: last.x.clone(),
                            after: trace.branch.points.len() - 1,
                            at_kink: true,
                        };
                        trace.fold(problem, fold)?;
                    }
                    trace.point(problem, point)?;
                }
                Rescue::FrequencyStep(point) => {
                    trace.branch.frequency_steps += 1;
                    let at_end = point.omega == range.end;
                    trace.point(problem, point)?;
                    if at_end {
                        return Ok(trace.stop(StopReason::ReachedEnd));
                    }
                }
            }
            continue;
        };
        // fold between `last` and `point`?
        let n = point.tangent.len() - 1;
        if last.tangent[n] * point.tangent[n] < 0.0 {
            let fold = Fold {
                after: trace.branch.points.len() - 1,
                ..locate_fold(problem, &sc, &corrector, &last, &start, &point)?
            };
            // a fold met again (same frequency, same solution) means the branch is
            // retracing itself: stop instead of going round
            let seen = seen_before(&trace.branch.folds, &fold, &sc);
            trace.fold(problem, fold)?;
            if seen {
                return Ok(trace.stop(StopReason::Retraced { omega: point.omega }));
            }
        }
        fallback.arclength_step_accepted();
        ds = next_step(ds, &point, options);
        let omega = point.omega;
        trace.point(problem, point)?;
        if let Some(stop) = range.stop_at(omega) {
            return Ok(trace.stop(stop));
        }
    }
}

/// The branch being traced, and the observer that sees each point and fold as it is added.
struct Trace<F> {
    branch: Branch,
    on_event: F,
}

impl<F> Trace<F> {
    fn new(on_event: F) -> Self {
        Trace {
            branch: Branch {
                points: Vec::new(),
                folds: Vec::new(),
                stop: StopReason::ReachedEnd,
                frequency_steps: 0,
            },
            on_event,
        }
    }

    fn point<P: ?Sized>(&mut self, problem: &mut P, point: BranchPoint) -> Result<()>
    where
        F: FnMut(&mut P, Event<'_>) -> Result<()>,
    {
        (self.on_event)(problem, Event::Point(&point))?;
        self.branch.points.push(point);
        Ok(())
    }

    fn fold<P: ?Sized>(&mut self, problem: &mut P, fold: Fold) -> Result<()>
    where
        F: FnMut(&mut P, Event<'_>) -> Result<()>,
    {
        (self.on_event)(problem, Event::Fold(&fold))?;
        self.branch.folds.push(fold);
        Ok(())
    }

    fn stop(self, stop: StopReason) -> Branch {
        Branch {
            stop,
            ..self.branch
        }
    }
}

/// The first point: Newton at the start frequency from the problem's initial guess, with
/// the tangent that points towards the end frequency; or why Newton failed.
fn first_point<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    sc: &Scaling,
    range: &Range,
    options: &ContinuationOptions,
) -> Result<Result<BranchPoint, newton::NewtonFailure>> {
    let n = problem.dimension();
    let x0 = problem.initial_guess(range.start)?;
    let first = newton::solve(problem, &x0, range.start, &options.fixed_frequency_newton())?;
    if !first.converged {
        return Ok(Err(first
            .reason
            .expect("Newton says why it did not converge")));
    }
    let mut seed = vec![0.0; n + 1];
    seed[n] = range.direction;
    let (t0, determinant_sign) =
        oriented_tangent(problem, sc, &first.x, range.start, &seed, &seed)?;
    Ok(Ok(BranchPoint {
        x: first.x,
        omega: range.start,
        tangent: t0,
        iterations: first.iterations,
        residual_norm: first.residual_norm,
        step: 0.0,
        determinant_sign,
    }))
}

/// When the predictor from `last` reaches the end frequency: Newton at the end frequency
/// from the linear interpolation of the predictor there; `None` when the end is not ahead
/// or Newton does not converge.
fn land_on_end<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    sc: &Scaling,
    range: &Range,
    last: &BranchPoint,
    start: &[f64],
    ds: f64,
    options: &ContinuationOptions,
) -> Result<Option<BranchPoint>> {
    let Some(frac) = range.end_ahead(sc, last, start, ds) else {
        return Ok(None);
    };
    let guess: Vec<f64> = last
        .x
        .iter()
        .zip(&last.tangent)
        .map(|(x, t)| x + frac * ds * t * sc.unknowns)
        .collect();
    let end = newton::solve(problem, &guess, range.end, &options.newton)?;
    if !end.converged {
        return Ok(None);
    }
    let (t, determinant_sign) =
        oriented_tangent(problem, sc, &end.x, range.end, &last.tangent, &last.tangent)?;
    Ok(Some(BranchPoint {
        x: end.x,
        omega: range.end,
        tangent: t,
        iterations: end.iterations,
        residual_norm: end.residual_norm,
        step: frac * ds,
        determinant_sign,
    }))
}

/// One arclength step from `last` (scaled point `start`): predictor, Keller corrector, and
/// the checks that the point continues the branch; `None` when any of them fails.
fn arclength_step<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    sc: &Scaling,
    corrector: &Corrector<'_>,
    last: &BranchPoint,
    start: &[f64],
    ds: f64,
    options: &ContinuationOptions,
) -> Result<Option<BranchPoint>> {
    let Some(corrected) = corrector.keller(problem, sc, start, &last.tangent, ds)? else {
        return Ok(None);
    };
    let (x, omega) = sc.unscale(&corrected.xs);
    let secant = difference(&corrected.xs, start);
    let secant_direction = normalized(secant.clone());
    let (t, determinant_sign) =
        match oriented_tangent(problem, sc, &x, omega, &last.tangent, &secant) {
            Ok(t) => t,
            Err(e) if e.kind() == ErrorKind::Singular => return Ok(None),
            Err(e) => return Err(e),
        };
    let step = StepCheck {
        secant_direction: &secant_direction,
        last_tangent: &last.tangent,
        tangent: &t,
        reversed: matches!(
            (last.determinant_sign, determinant_sign),
            (Some(a), Some(b)) if a != b
        ),
    };
    if !continues_branch(&step, ds, options) {
        return Ok(None);
    }
    Ok(Some(BranchPoint {
        x,
        omega,
        tangent: t,
        iterations: corrected.iterations,
        residual_norm: corrected.residual_norm,
        step: ds,
        determinant_sign,
    }))
}
