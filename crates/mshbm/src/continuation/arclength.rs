//! Pseudo-arclength continuation of periodic solutions in `(x, ω)` (METHODS §7.1), written
//! once over [`PeriodicProblem`].
//!
//! Unknowns are scaled to O(1): `X = [x / ℓ; ln(ω / ω_ref)]` with `ℓ` the problem's length
//! scale and `ω_ref` the start frequency (ω ~ 1e5 rad/s against displacements ~ 0.1 mm
//! otherwise dominate every norm; the logarithm weighs a relative change of frequency the
//! same over the whole sweep). Each step:
//!
//! * predictor `X_p = X_0 + Δs t` along the unit tangent `t` (solved from
//!   `[R_X; t_prevᵀ] t = [0; 1]` and oriented along the secant of the last step, so that a
//!   sharp turn is not mistaken for a reversal);
//! * Keller corrector: Newton on `[R(X); tᵀ(X − X_0) − Δs] = 0`;
//! * step control: `Δs ← Δs · clamp(N_opt / N_it, ½, 2)` within bounds; a failed
//!   corrector, or a tangent that turns by more than `max_turn_deg`, halves `Δs`; below
//!   `min_step` the branch stops with the reason.
//!
//! **Folds** (turning points in ω) are sign changes of the ω-component of the tangent
//! between accepted points. Each is *located* by regula falsi on `t_ω(s) = 0` along the arc
//! (each evaluation a corrector solve). A sign change that does not close to a zero of
//! `t_ω` — a jump of the tangent across a nonsmooth point of the residual, such as the
//! kinks that sampled quadrature produces — is reported with `at_kink = true`: the
//! frequency is still extremal there, but it is a corner, not a smooth fold, and with
//! sampled quadrature it may be an artefact of the sampling (zig-zags near grazing).

use faer::linalg::solvers::Solve;
use faer::Mat;

use crate::continuation::newton::NewtonOptions;
use crate::error::{Error, Result};
use crate::problem::PeriodicProblem;

/// Settings of the continuation. Step sizes are in the scaled arclength (dimensionless).
#[derive(Clone, Debug)]
pub struct ContinuationOptions {
    /// Start frequency (rad/s).
    pub omega_start: f64,
    /// End frequency (rad/s); may be below the start (downward sweep).
    pub omega_end: f64,
    pub initial_step: f64,
    pub min_step: f64,
    pub max_step: f64,
    /// Corrector iterations aimed at; fewer grow the step, more shrink it.
    pub optimal_iterations: usize,
    /// Largest accepted turn of the tangent between two points (degrees).
    pub max_turn_deg: f64,
    /// Corrector tolerance and iteration limit (the tolerance is relative to the problem's
    /// length scale, as in Newton).
    pub newton: NewtonOptions,
    /// Largest advance in frequency per step, as `|Δ ln ω|` (a fiftieth of the range by
    /// default, so that even a narrow sweep of a smooth response has points to plot).
    pub max_frequency_step: f64,
    /// Largest ratio of two successive corrector updates (0.5 by default: Newton with an
    /// exact Jacobian on a smooth piece contracts quadratically, and an update that does not
    /// halve is a corrector working across a grazing event or towards another piece of the
    /// branch). Methods whose Newton is not quadratic (finite-difference Jacobians, stiff
    /// penalties) need `f64::INFINITY` (no check).
    pub max_contraction: f64,
    /// Where the arclength step fails (below `min_step`, no corner escape), step in
    /// frequency instead: Newton at `ω e^{±Δ}` from the last point, `Δ` a quarter, a
    /// sixteenth, a sixty-fourth of `max_frequency_step` (default `false`). For residuals
    /// whose branches are staircases of tiny corners — the general MS-HBM, whose time-stepped
    /// residual is piecewise affine with pieces one time step wide — where Newton at a fixed
    /// frequency converges but the arclength corrector cannot follow the corners. Such a
    /// step cannot turn at a fold: past one it lands on whatever solution Newton finds (a
    /// jump, as in a sweep experiment). [`Branch::frequency_steps`] counts them.
    pub frequency_stepping: bool,
    /// Safety limit on the number of points.
    pub max_points: usize,
}

impl ContinuationOptions {
    /// Defaults for a sweep from `omega_start` to `omega_end` (rad/s).
    pub fn new(omega_start: f64, omega_end: f64) -> Self {
        ContinuationOptions {
            omega_start,
            omega_end,
            initial_step: 0.01,
            min_step: 1e-12,
            max_step: 0.1,
            optimal_iterations: 4,
            max_turn_deg: 20.0,
            newton: NewtonOptions {
                max_iterations: 12,
                ..NewtonOptions::default()
            },
            max_frequency_step: (omega_end / omega_start).ln().abs() / 50.0,
            max_contraction: 0.5,
            frequency_stepping: false,
            max_points: 20_000,
        }
    }
}

/// One accepted point of a branch.
#[derive(Clone, Debug)]
pub struct BranchPoint {
    pub x: Vec<f64>,
    /// Frequency (rad/s).
    pub omega: f64,
    /// Unit tangent in scaled variables (last entry: the ω-component).
    pub tangent: Vec<f64>,
    /// Newton (corrector) iterations spent on this point.
    pub iterations: usize,
    /// `‖R‖_∞ / length_scale` at the point.
    pub residual_norm: f64,
    /// Arclength step that led to it (0 for the first point).
    pub step: f64,
}

/// A located fold (turning point in frequency).
#[derive(Clone, Debug)]
pub struct Fold {
    /// Frequency of the fold (rad/s).
    pub omega: f64,
    /// Solution at the fold.
    pub x: Vec<f64>,
    /// The fold lies between points `after` and `after + 1` of the branch.
    pub after: usize,
    /// The tangent's ω-component jumps over zero instead of passing through it: the
    /// branch turns at a kink of a nonsmooth residual (e.g. sampled quadrature), not at a
    /// smooth fold.
    pub at_kink: bool,
}

/// Why a branch ended.
#[derive(Clone, Debug, PartialEq)]
pub enum StopReason {
    /// The end frequency was reached.
    ReachedEnd,
    /// The branch turned back past the start frequency.
    LeftRange,
    /// The point limit was hit.
    MaxPoints,
    /// No solution at the start frequency.
    StartFailed(String),
    /// The step fell below `min_step` (the corrector kept failing).
    StepTooSmall { omega: f64, reason: String },
    /// The branch came back onto a fold it had already passed: it retraces itself
    /// (typically after an unresolved sharp turn at a grazing contact).
    Retraced { omega: f64 },
}

impl StopReason {
    /// Whether the sweep reached its end frequency (a branch that turns back past the
    /// start frequency has not covered the range the user asked for).
    pub fn is_success(&self) -> bool {
        matches!(self, StopReason::ReachedEnd)
    }
}

/// What the observer is told.
pub enum Event<'a> {
    Point(&'a BranchPoint),
    Fold(&'a Fold),
}

/// A traced branch.
#[derive(Clone, Debug)]
pub struct Branch {
    pub points: Vec<BranchPoint>,
    pub folds: Vec<Fold>,
    pub stop: StopReason,
    /// Points found by stepping in frequency ([`ContinuationOptions::frequency_stepping`]).
    pub frequency_steps: usize,
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn normalized(mut v: Vec<f64>) -> Vec<f64> {
    let n = dot(&v, &v).sqrt();
    v.iter_mut().for_each(|x| *x /= n);
    v
}

/// Scaled unknowns `X = [x / ℓ; ln(ω / ω_ref)]`: displacements relative to the problem's
/// length scale, frequency as a relative (logarithmic) change, so that the weight of the
/// frequency in the arclength is the same at 1 kHz and at 100 kHz and does not depend on
/// where the sweep started.
struct Scaling {
    length: f64,
    omega: f64,
}

impl Scaling {
    fn to_scaled(&self, x: &[f64], omega: f64) -> Vec<f64> {
        let mut s: Vec<f64> = x.iter().map(|v| v / self.length).collect();
        s.push((omega / self.omega).ln());
        s
    }
    fn unscale(&self, s: &[f64]) -> (Vec<f64>, f64) {
        let n = s.len() - 1;
        (
            s[..n].iter().map(|v| v * self.length).collect(),
            self.omega * s[n].exp(),
        )
    }
}

/// The bordered matrix `[R_X; cᵀ]` in scaled variables.
fn bordered<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    sc: &Scaling,
    x: &[f64],
    omega: f64,
    border: &[f64],
) -> Result<(Mat<f64>, Vec<f64>)> {
    let lin = problem.linearize(x, omega)?;
    let n = x.len();
    let mut a = Mat::<f64>::zeros(n + 1, n + 1);
    for i in 0..n {
        for j in 0..n {
            a[(i, j)] = lin.jacobian[(i, j)] * sc.length;
        }
        a[(i, n)] = lin.d_omega[i] * omega; // dω / d ln ω
    }
    for j in 0..=n {
        a[(n, j)] = border[j];
    }
    Ok((a, lin.residual))
}

fn solve_dense(a: &Mat<f64>, rhs: &[f64]) -> Result<Vec<f64>> {
    let n = rhs.len();
    let b = Mat::<f64>::from_fn(n, 1, |i, _| rhs[i]);
    let x = a.partial_piv_lu().solve(&b);
    let x: Vec<f64> = (0..n).map(|i| x[(i, 0)]).collect();
    if x.iter().any(|v| !v.is_finite()) {
        return Err(Error::Singular(
            "the bordered continuation matrix is singular".into(),
        ));
    }
    Ok(x)
}

/// Unit tangent at `(x, ω)`, bordered with `previous` and oriented so that
/// `t · direction > 0` (`direction`: the previous tangent, or better the secant of the
/// last step, which stays a valid orientation across sharp turns).
fn tangent<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    sc: &Scaling,
    x: &[f64],
    omega: f64,
    previous: &[f64],
    direction: &[f64],
) -> Result<Vec<f64>> {
    let (a, _) = bordered(problem, sc, x, omega, previous)?;
    let mut rhs = vec![0.0; x.len() + 1];
    rhs[x.len()] = 1.0;
    let t = normalized(solve_dense(&a, &rhs)?);
    Ok(if dot(&t, direction) < 0.0 {
        t.iter().map(|v| -v).collect()
    } else {
        t
    })
}

/// Largest distance of a corrected point from its predictor, relative to the step.
const MAX_CORRECTOR_TRAVEL: f64 = 0.5;

/// Keller corrector from the predictor `X_0 + Δs t`. Returns the scaled point and the
/// iterations, or `None` when it does not converge.
fn correct<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    sc: &Scaling,
    start: &[f64],
    t: &[f64],
    ds: f64,
    newton: &NewtonOptions,
    max_contraction: f64,
) -> Result<Option<(Vec<f64>, usize, f64)>> {
    let predictor: Vec<f64> = start.iter().zip(t).map(|(a, b)| a + ds * b).collect();
    let mut xs = predictor.clone();
    let mut previous_update = f64::INFINITY;
    for it in 0..=newton.max_iterations {
        let (x, omega) = sc.unscale(&xs);
        if !(omega.is_finite() && omega > 0.0) {
            return Ok(None);
        }
        let (a, r) = match bordered(problem, sc, &x, omega, t) {
            Ok(v) => v,
            Err(Error::Singular(_)) => return Ok(None),
            Err(e) => return Err(e),
        };
        let norm = max_abs(&r) / sc.length;
        let arc = dot(
            t,
            &xs.iter().zip(start).map(|(a, b)| a - b).collect::<Vec<_>>(),
        ) - ds;
        // the arclength equation is linear: after one step it holds to round-off, which
        // is relative to |X|, not to the (possibly tiny) step
        let arc_tolerance = 1e-8 * ds + 64.0 * f64::EPSILON * max_abs(&xs);
        // at least one correction: with a tiny step any predictor meets the residual
        // tolerance, and uncorrected points let the path wander with the noise of the
        // tangent (near grazing contacts the Jacobian is nearly singular)
        if it >= 1 && norm <= newton.tolerance && arc.abs() <= arc_tolerance {
            // the point must lie near the predictor: a corrector that travels further than
            // half the step has left the piece of branch it started on (e.g. jumped across
            // an S of two close folds, or onto a nearby piece born at a grazing contact)
            let travelled = xs
                .iter()
                .zip(&predictor)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
                .sqrt();
            if travelled > MAX_CORRECTOR_TRAVEL * ds {
                return Ok(None);
            }
            return Ok(Some((xs, it, norm)));
        }
        if it == newton.max_iterations {
            break;
        }
        let mut rhs: Vec<f64> = r.iter().map(|v| -v).collect();
        rhs.push(-arc);
        let d = match solve_dense(&a, &rhs) {
            Ok(d) => d,
            Err(_) => return Ok(None),
        };
        // poor contraction: refuse, the step will be halved (see `max_contraction`)
        let update = dot(&d, &d).sqrt();
        if update > max_contraction * previous_update
            && update > 64.0 * f64::EPSILON * (1.0 + max_abs(&xs))
        {
            return Ok(None);
        }
        previous_update = update;
        xs.iter_mut().zip(&d).for_each(|(a, b)| *a += b);
    }
    Ok(None)
}

/// Trace the branch from `omega_start` to `omega_end`, starting from Newton on the
/// problem's initial guess; `on_event` sees every point and fold as it is found (so a
/// caller can stream them) and gets the problem to evaluate solutions.
pub fn trace_branch<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    options: &ContinuationOptions,
    mut on_event: impl FnMut(&mut P, Event<'_>) -> Result<()>,
) -> Result<Branch> {
    let (w0, w1) = (options.omega_start, options.omega_end);
    if !(w0.is_finite() && w1.is_finite() && w0 > 0.0 && w1 > 0.0 && w0 != w1) {
        return Err(Error::argument(
            "frequency range",
            "start and end must be positive and different",
        ));
    }
    let direction = (w1 - w0).signum();
    let sc = Scaling {
        length: problem.length_scale(),
        omega: w0,
    };
    let n = problem.dimension();
    let mut branch = Branch {
        points: Vec::new(),
        folds: Vec::new(),
        stop: StopReason::ReachedEnd,
        frequency_steps: 0,
    };
    // first point: Newton at the start frequency
    let x0 = problem.initial_guess(w0)?;
    let first =
        crate::continuation::newton::solve(problem, &x0, w0, &fixed_frequency_newton(options))?;
    if !first.converged {
        branch.stop = StopReason::StartFailed(first.reason.unwrap_or_default());
        return Ok(branch);
    }
    let mut seed = vec![0.0; n + 1];
    seed[n] = direction;
    let t0 = tangent(problem, &sc, &first.x, w0, &seed, &seed)?;
    let p0 = BranchPoint {
        x: first.x,
        omega: w0,
        tangent: t0,
        iterations: first.iterations,
        residual_norm: first.residual_norm,
        step: 0.0,
    };
    on_event(problem, Event::Point(&p0))?;
    branch.points.push(p0);
    let mut ds = options.initial_step;
    let cos_turn = options.max_turn_deg.to_radians().cos();
    let mut last_escaped = false;
    loop {
        if branch.points.len() >= options.max_points {
            branch.stop = StopReason::MaxPoints;
            return Ok(branch);
        }
        let last = branch.points.last().expect("non-empty").clone();
        let start = sc.to_scaled(&last.x, last.omega);
        // end of the range ahead: land on it exactly
        let predicted_omega = sc.omega * (start[n] + ds * last.tangent[n]).exp();
        if (predicted_omega - w1) * direction >= 0.0 && last.tangent[n] * direction > 0.0 {
            let frac = (w1 - last.omega) / (predicted_omega - last.omega);
            let guess: Vec<f64> = last
                .x
                .iter()
                .zip(&last.tangent)
                .map(|(x, t)| x + frac * ds * t * sc.length)
                .collect();
            let end = crate::continuation::newton::solve(problem, &guess, w1, &options.newton)?;
            if end.converged {
                let t = tangent(problem, &sc, &end.x, w1, &last.tangent, &last.tangent)?;
                let p = BranchPoint {
                    x: end.x,
                    omega: w1,
                    tangent: t,
                    iterations: end.iterations,
                    residual_norm: end.residual_norm,
                    step: frac * ds,
                };
                on_event(problem, Event::Point(&p))?;
                branch.points.push(p);
                branch.stop = StopReason::ReachedEnd;
                return Ok(branch);
            }
        }
        let corrected = correct(
            problem,
            &sc,
            &start,
            &last.tangent,
            ds,
            &options.newton,
            options.max_contraction,
        )?;
        let accepted = match corrected {
            Some((xs, iterations, norm)) => {
                let (x, omega) = sc.unscale(&xs);
                let secant: Vec<f64> = xs.iter().zip(&start).map(|(a, b)| a - b).collect();
                // the corrector must stay near the predictor: a secant far off the tangent
                // means it landed on another part of the curve (e.g. a nearby branch born
                // at a grazing contact), which would make the branch jump or retrace
                let on_branch = dot(&normalized(secant.clone()), &last.tangent) >= 0.5;
                match tangent(problem, &sc, &x, omega, &last.tangent, &secant) {
                    Ok(t)
                        if on_branch
                            && (dot(&t, &last.tangent) >= cos_turn
                                || ds <= options.min_step * 2.0) =>
                    {
                        Some(BranchPoint {
                            x,
                            omega,
                            tangent: t,
                            iterations,
                            residual_norm: norm,
                            step: ds,
                        })
                    }
                    _ => None,
                }
            }
            None => None,
        };
        let Some(point) = accepted else {
            ds *= 0.5;
            // with frequency stepping, steps below the staircase scale are not tried
            // (each failed corrector of a finite-difference method costs dozens of
            // residual evaluations) and neither are corner escapes
            let smallest = if options.frequency_stepping {
                options.min_step.max(FREQUENCY_STEPPING_MIN_STEP)
            } else {
                options.min_step
            };
            if ds < smallest {
                // a corner of the branch (grazing): look for the outgoing piece on small
                // spheres around the last point
                // (at most once in a row: a branch that needs it again straight away is
                // stuck, not at a corner)
                let escaped = if last_escaped || options.frequency_stepping {
                    None
                } else {
                    escape_corner(problem, &sc, &last, options)?
                };
                if let Some(point) = escaped {
                    last_escaped = true;
                    if last.tangent[n] * point.tangent[n] < 0.0 {
                        // ω is extremal at the corner itself
                        let fold = Fold {
                            omega: last.omega,
                            x: last.x.clone(),
                            after: branch.points.len() - 1,
                            at_kink: true,
                        };
                        on_event(problem, Event::Fold(&fold))?;
                        branch.folds.push(fold);
                    }
                    ds = options.min_step.max(1e-6);
                    on_event(problem, Event::Point(&point))?;
                    branch.points.push(point);
                    continue;
                }
                let stepped = if options.frequency_stepping {
                    step_in_frequency(problem, &sc, &last, direction, options)?
                } else {
                    None
                };
                if let Some(point) = stepped {
                    branch.frequency_steps += 1;
                    last_escaped = false;
                    ds = options.initial_step;
                    let omega = point.omega;
                    on_event(problem, Event::Point(&point))?;
                    branch.points.push(point);
                    if omega == w1 {
                        branch.stop = StopReason::ReachedEnd;
                        return Ok(branch);
                    }
                    continue;
                }
                branch.stop = StopReason::StepTooSmall {
                    omega: last.omega,
                    reason: format!(
                        "no continuation point within {} corrector iterations even with the smallest step {:.1e}{} \
                         (a singular point of the branch, e.g. where a contact grazes and the branch turns sharply)",
                        options.newton.max_iterations,
                        smallest,
                        if options.frequency_stepping {
                            ", nor by Newton at a fixed frequency a little ahead"
                        } else {
                            ""
                        }
                    ),
                };
                return Ok(branch);
            }
            continue;
        };
        // fold between `last` and `point`?
        if last.tangent[n] * point.tangent[n] < 0.0 {
            if let Some(fold) = locate_fold(problem, &sc, &last, &start, ds, options)? {
                let fold = Fold {
                    after: branch.points.len() - 1,
                    ..fold
                };
                // a fold met again (same frequency, same solution) means the branch is
                // retracing itself: stop instead of going round
                let seen = branch.folds.iter().any(|f| {
                    (f.omega - fold.omega).abs() <= 1e-7 * fold.omega
                        && f.x
                            .iter()
                            .zip(&fold.x)
                            .all(|(a, b)| (a - b).abs() <= 1e-6 * sc.length)
                });
                on_event(problem, Event::Fold(&fold))?;
                branch.folds.push(fold);
                if seen {
                    branch.stop = StopReason::Retraced { omega: point.omega };
                    return Ok(branch);
                }
            }
        }
        last_escaped = false;
        let ratio = options.optimal_iterations.max(1) as f64 / point.iterations.max(1) as f64;
        ds = (ds * ratio.clamp(0.5, 2.0)).clamp(options.min_step, options.max_step);
        let advance = point.tangent[n].abs();
        if advance * ds > options.max_frequency_step && options.max_frequency_step > 0.0 {
            ds = (options.max_frequency_step / advance).max(options.min_step);
        }
        let omega = point.omega;
        on_event(problem, Event::Point(&point))?;
        branch.points.push(point);
        if (omega - w1) * direction >= 0.0 {
            branch.stop = StopReason::ReachedEnd;
            return Ok(branch);
        }
        if (omega - w0) * direction < 0.0 && (omega - w0).abs() > 1e-3 * w0 {
            branch.stop = StopReason::LeftRange;
            return Ok(branch);
        }
    }
}

/// Newton at a fixed frequency without a predictor close by (the first point, frequency
/// steps): the corrector's settings with at least 50 iterations.
fn fixed_frequency_newton(options: &ContinuationOptions) -> NewtonOptions {
    NewtonOptions {
        max_iterations: options.newton.max_iterations.max(50),
        ..options.newton.clone()
    }
}

/// Smallest arclength step tried before stepping in frequency
/// ([`ContinuationOptions::frequency_stepping`]): well above the corners of the general
/// MS-HBM's staircase branches (≈ 1e-7 apart in scaled units, `method::shooting`).
const FREQUENCY_STEPPING_MIN_STEP: f64 = 1e-4;

/// Newton at a fixed frequency a little ahead of `last` (see
/// [`ContinuationOptions::frequency_stepping`]); the end frequency is not stepped over.
fn step_in_frequency<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    sc: &Scaling,
    last: &BranchPoint,
    direction: f64,
    options: &ContinuationOptions,
) -> Result<Option<BranchPoint>> {
    let largest = if options.max_frequency_step > 0.0 {
        options.max_frequency_step
    } else {
        1e-3
    };
    let start = sc.to_scaled(&last.x, last.omega);
    for fraction in [0.25, 1.0 / 16.0, 1.0 / 64.0] {
        let mut omega = last.omega * (direction * fraction * largest).exp();
        if (omega - options.omega_end) * direction > 0.0 {
            omega = options.omega_end;
        }
        let outcome = match crate::continuation::newton::solve(
            problem,
            &last.x,
            omega,
            &fixed_frequency_newton(options),
        ) {
            Ok(o) => o,
            Err(Error::Singular(_) | Error::Numerical(_)) => continue,
            Err(e) => return Err(e),
        };
        if !outcome.converged {
            continue;
        }
        let secant: Vec<f64> = sc
            .to_scaled(&outcome.x, omega)
            .iter()
            .zip(&start)
            .map(|(a, b)| a - b)
            .collect();
        let step = dot(&secant, &secant).sqrt();
        // bordered with the secant: near a corner the last tangent may be almost
        // orthogonal to the branch
        let border = normalized(secant.clone());
        let Ok(t) = tangent(problem, sc, &outcome.x, omega, &border, &secant) else {
            continue;
        };
        return Ok(Some(BranchPoint {
            x: outcome.x,
            omega,
            tangent: t,
            iterations: outcome.iterations,
            residual_norm: outcome.residual_norm,
            step,
        }));
    }
    Ok(None)
}

/// Regula falsi on the ω-component of the tangent along the arc from `last` (arclength
/// `0`) to the accepted point (arclength `ds`).
fn locate_fold<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    sc: &Scaling,
    last: &BranchPoint,
    start: &[f64],
    ds: f64,
    options: &ContinuationOptions,
) -> Result<Option<Fold>> {
    let n = last.x.len();
    let eval = |problem: &mut P, s: f64| -> Result<Option<(f64, Vec<f64>, f64)>> {
        match correct(
            problem,
            sc,
            start,
            &last.tangent,
            s,
            &options.newton,
            options.max_contraction,
        )? {
            Some((xs, _, _)) => {
                let (x, omega) = sc.unscale(&xs);
                let secant: Vec<f64> = xs.iter().zip(start).map(|(a, b)| a - b).collect();
                let t = tangent(problem, sc, &x, omega, &last.tangent, &secant)?;
                Ok(Some((t[n], x, omega)))
            }
            None => Ok(None),
        }
    };
    // working values fa, fb (scaled by the Illinois rule); true values ta, tb
    let (mut a, mut fa, mut ta) = (0.0, last.tangent[n], last.tangent[n]);
    let Some((fb0, mut xb, mut wb)) = eval(problem, ds)? else {
        return Ok(None);
    };
    let (mut b, mut fb, mut tb) = (ds, fb0, fb0);
    let (mut xa, mut wa) = (last.x.clone(), last.omega);
    let mut side = 0i32;
    for _ in 0..60 {
        if (b - a).abs() <= 1e-10 * ds || ta.abs().min(tb.abs()) < 1e-10 {
            break;
        }
        let s = (a * fb - b * fa) / (fb - fa);
        let s = if s <= a || s >= b { 0.5 * (a + b) } else { s };
        let Some((fs, xs, ws)) = eval(problem, s)? else {
            return Ok(None);
        };
        if fs == 0.0 {
            return Ok(Some(Fold {
                omega: ws,
                x: xs,
                after: 0,
                at_kink: false,
            }));
        }
        if fs * ta > 0.0 {
            (a, fa, ta, xa, wa) = (s, fs, fs, xs, ws);
            if side == -1 {
                fb *= 0.5; // Illinois
            }
            side = -1;
        } else {
            (b, fb, tb, xb, wb) = (s, fs, fs, xs, ws);
            if side == 1 {
                fa *= 0.5;
            }
            side = 1;
        }
    }
    // t_ω through zero: a smooth fold; t_ω jumping over zero: ω is still extremal along
    // the arc, at a kink of the branch (nonsmooth residual)
    let (fold_x, fold_w, gap) = if ta.abs() < tb.abs() {
        (xa, wa, ta.abs())
    } else {
        (xb, wb, tb.abs())
    };
    Ok(Some(Fold {
        omega: fold_w,
        x: fold_x,
        after: 0,
        at_kink: gap > 1e-6,
    }))
}

/// Continue past a corner of the branch: Newton on `[R(X); ‖X − X_0‖² − r²] = 0` for growing
/// radii `r`, from the predictor along the last tangent and from directions turned away
/// from it, accepting the first solution that does not lie on the incoming piece.
fn escape_corner<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    sc: &Scaling,
    last: &BranchPoint,
    options: &ContinuationOptions,
) -> Result<Option<BranchPoint>> {
    let n = last.x.len();
    let x0 = sc.to_scaled(&last.x, last.omega);
    let t = &last.tangent;
    // unit vectors orthogonal to t: the ω axis and the largest x-component axis, projected
    let mut others = Vec::new();
    for axis in [
        n,
        (0..n)
            .max_by(|&a, &b| t[a].abs().total_cmp(&t[b].abs()))
            .unwrap_or(0),
    ] {
        let mut e = vec![0.0; n + 1];
        e[axis] = 1.0;
        let c = dot(&e, t);
        let v: Vec<f64> = e.iter().zip(t).map(|(a, b)| a - c * b).collect();
        if dot(&v, &v) > 1e-6 {
            let v = normalized(v);
            others.push(v.iter().map(|x| -x).collect::<Vec<f64>>());
            others.push(v);
        }
    }
    for radius in [1e-8, 1e-7, 1e-6, 1e-5, 1e-4] {
        let mut starts = vec![t.clone()];
        for v in &others {
            starts.push(normalized(t.iter().zip(v).map(|(a, b)| a + b).collect()));
            starts.push(v.clone());
        }
        for dir in starts {
            let mut xs: Vec<f64> = x0.iter().zip(&dir).map(|(a, b)| a + radius * b).collect();
            for it in 0..=options.newton.max_iterations {
                let (x, omega) = sc.unscale(&xs);
                if !(omega.is_finite() && omega > 0.0) {
                    break;
                }
                let d: Vec<f64> = xs.iter().zip(&x0).map(|(a, b)| a - b).collect();
                let (mut a, r) = match bordered(problem, sc, &x, omega, t) {
                    Ok(v) => v,
                    Err(Error::Singular(_)) => break,
                    Err(e) => return Err(e),
                };
                for j in 0..=n {
                    a[(n, j)] = 2.0 * d[j];
                }
                let sphere = dot(&d, &d) - radius * radius;
                let norm = max_abs(&r) / sc.length;
                if norm <= options.newton.tolerance && sphere.abs() <= 1e-8 * radius * radius {
                    let u = normalized(d.clone());
                    // forward only: a corner sharper than a right angle is not crossed
                    // (it could not be told from a retrace of the incoming piece)
                    if dot(&u, t) < 0.0 {
                        break;
                    }
                    let tn = tangent(problem, sc, &x, omega, t, &d)?;
                    return Ok(Some(BranchPoint {
                        x,
                        omega,
                        tangent: tn,
                        iterations: it,
                        residual_norm: norm,
                        step: radius,
                    }));
                }
                let mut rhs: Vec<f64> = r.iter().map(|v| -v).collect();
                rhs.push(-sphere);
                let Ok(step) = solve_dense(&a, &rhs) else {
                    break;
                };
                xs.iter_mut().zip(&step).for_each(|(a, b)| *a += b);
            }
        }
    }
    Ok(None)
}
