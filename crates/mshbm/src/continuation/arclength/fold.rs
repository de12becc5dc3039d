//! Fold location: regula falsi (Illinois) on the ω-component of the tangent along the arc,
//! each evaluation a Keller corrector solve (docs/theory.md (T76)); and the check that a
//! fold was met before.

use super::branch::{BranchPoint, Fold};
use super::corrector::Corrector;
use super::predictor::tangent;
use super::scaled::{difference, Scaling};
use crate::error::Result;
use crate::problem::PeriodicProblem;

/// Regula falsi on the ω-component of the tangent along the arc from `last` (arclength
/// `0`, scaled point `start`) to the accepted point `accepted` (arclength `ds`, the Keller
/// corrector's point from `last` with that step). `None` when a corrector solve on the way
/// fails. `after` is left at 0 for the caller.
pub(super) fn locate_fold<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    sc: &Scaling,
    corrector: &Corrector<'_>,
    last: &BranchPoint,
    start: &[f64],
    accepted: &BranchPoint,
) -> Result<Option<Fold>> {
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
