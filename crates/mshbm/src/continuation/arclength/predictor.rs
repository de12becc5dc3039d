//! Predictor: the unit tangent of the branch, oriented along the secant of the last step, and
//! the point ahead along it (docs/theory.md (T73)–(T74)).

use super::scaled::{bordered, dot, normalized, solve_bordered, Scaling};
use crate::error::Result;
use crate::problem::PeriodicProblem;

/// Unit tangent at `(x, ω)` (docs/theory.md (T73)), solved from
/// `[R_X; previousᵀ] t = [0; 1]` and oriented so that `t · direction > 0` (`direction`: the
/// previous tangent, or better the secant of the last step, which stays a valid orientation
/// across sharp turns).
pub(super) fn tangent<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    sc: &Scaling,
    x: &[f64],
    omega: f64,
    previous: &[f64],
    direction: &[f64],
) -> Result<Vec<f64>> {
    let (a, _) = bordered(problem, sc, x, omega, previous)?;
    let n = x.len();
    let t = normalized(solve_bordered(&a, |i| if i == n { 1.0 } else { 0.0 })?);
    Ok(if dot(&t, direction) < 0.0 {
        t.iter().map(|v| -v).collect()
    } else {
        t
    })
}

/// The predictor `X_0 + Δs t` in scaled variables.
pub(super) fn predict(start: &[f64], t: &[f64], ds: f64) -> Vec<f64> {
    start.iter().zip(t).map(|(a, b)| a + ds * b).collect()
}
