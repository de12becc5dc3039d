//! Fold location: regula falsi (Illinois) on the ω-component of the tangent along the arc,
//! each evaluation a Keller corrector solve (docs/theory.md (T76)); and the check that a
//! fold was met before.

use super::branch::{BranchPoint, Fold};
use super::corrector::Corrector;
use super::predictor::tangent;
use super::scaled::{difference, Scaling};
use crate::error::Result;
use crate::problem::PeriodicProblem;

/// How much steeper than across the whole step `t_ω` must change across the final bracket
/// for a fold to count as a kink (a jump of the tangent). The bracket ends 1e-10 of the step
/// wide when the search converges, so a jump shows a ratio near 1e10; a smooth fold, a
/// ratio near 1 (up to the curvature's variation along one step).
const KINK_RATE_RATIO: f64 = 100.0;

/// Regula falsi on the ω-component of the tangent along the arc from `last` (arclength
/// `0`, scaled point `start`) to the accepted point `accepted` (arclength `ds`, the Keller
/// corrector's point from `last` with that step). When a corrector solve on the way fails,
/// the fold is reported at the better end of the bracket found so far (the sign change of
/// `t_ω` is certain; only its place is less precise). `after` is left at 0 for the caller.
pub(super) fn locate_fold<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    sc: &Scaling,
    corrector: &Corrector<'_>,
    last: &BranchPoint,
    start: &[f64],
    accepted: &BranchPoint,
) -> Result<Fold> {
    let ds = accepted.step;
    let n = last.x.len();
    let eval = |problem: &mut P, s: f64| -> Result<Option<(f64, Vec<f64>, f64)>> {
        match corrector.keller(problem, sc, start, &last.tangent, s)? {
            Some(corrected) => {
                let (x, omega) = sc.unscale(&corrected.xs);
                let secant = difference(&corrected.xs, start);
                let t = tangent(problem, sc, &x, omega, &last.tangent, &secant)?;
                Ok(Some((t[n], x, omega)))
            }
            None => Ok(None),
        }
    };
    // working values fa, fb (scaled by the Illinois rule); true values ta, tb
    let (mut a, mut fa, mut ta) = (0.0, last.tangent[n], last.tangent[n]);
    // the accepted point is the corrector's at ds: its tangent is known
    let (fb0, mut xb, mut wb) = (accepted.tangent[n], accepted.x.clone(), accepted.omega);
    let (mut b, mut fb, mut tb) = (ds, fb0, fb0);
    let (mut xa, mut wa) = (last.x.clone(), last.omega);
    let mut side = 0i32;
    for _ in 0..60 {
        if (b - a).abs() <= 1e-10 * ds || ta.abs().min(tb.abs()) < 1e-10 {
            break;
        }
        let s = (a * fb - b * fa) / (fb - fa);
        let middle = 0.5 * (a + b);
        let s = if s <= a || s >= b { middle } else { s };
        // regula falsi may ask for a point a hair from one end, where near the fold the
        // corrector's move is round-off of a nearly singular Jacobian and can exceed its
        // tiny step: the middle of the bracket is tried then. When that fails too, the
        // search ends: the fold lies within the bracket found so far, and is reported at
        // its better end
        let evaluated = match eval(problem, s)? {
            None if s != middle => eval(problem, middle)?.map(|e| (middle, e)),
            other => other.map(|e| (s, e)),
        };
        let Some((s, (fs, xs, ws))) = evaluated else {
            break;
        };
        if fs == 0.0 {
            return Ok(Fold {
                omega: ws,
                x: xs,
                after: 0,
                at_kink: false,
            });
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
    // t_ω through zero: a smooth fold (where ∂R/∂x is singular, (T78)); t_ω jumping over zero: ω is still extremal along
    // the arc, at a kink of the branch (nonsmooth residual). A jump is a change of t_ω
    // across the final bracket that is not small, and far steeper there than across the
    // whole step: at a smooth fold t_ω changes at a rate of the order of the curvature on
    // both scales, at a kink its change stays finite as the bracket shrinks to nothing
    let (fold_x, fold_w, gap) = if ta.abs() < tb.abs() {
        (xa, wa, ta.abs())
    } else {
        (xb, wb, tb.abs())
    };
    let rate_in_bracket = (tb - ta).abs() / (b - a).max(f64::MIN_POSITIVE);
    let rate_over_step = (fb0 - last.tangent[n]).abs() / ds;
    Ok(Fold {
        omega: fold_w,
        x: fold_x,
        after: 0,
        at_kink: gap > 1e-6 && rate_in_bracket > KINK_RATE_RATIO * rate_over_step,
    })
}

/// Whether `fold` (same frequency, same solution) was met before: the branch retraces
/// itself.
pub(super) fn seen_before(folds: &[Fold], fold: &Fold, sc: &Scaling) -> bool {
    folds.iter().any(|f| {
        (f.omega - fold.omega).abs() <= 1e-7 * fold.omega
            && f.x
                .iter()
                .zip(&fold.x)
                .all(|(a, b)| (a - b).abs() <= 1e-6 * sc.length)
    })
}
