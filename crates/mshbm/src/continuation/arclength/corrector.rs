//! Corrector: Newton on `R(X) = 0` closed by one scalar equation `g(X) = 0` — Keller's
//! arclength condition `tᵀ(X − X_0) − Δs = 0` for a continuation step (METHODS §7.1), the
//! sphere `‖X − X_0‖² − r² = 0` for a corner escape. One loop for both: full Newton steps
//! on the bordered system `[R_X; ∂g/∂X] ΔX = −[R; g]`, solved by Newton's linear solve.

use super::predictor::predict;
use super::scaled::{bordered, difference, dot, max_abs, solve_bordered, Scaling};
use crate::continuation::newton::NewtonOptions;
use crate::error::{ErrorKind, Result};
use crate::problem::{NewtonContraction, PeriodicProblem};

/// Largest ratio of two successive updates of a quadratically contracting Newton: each
/// update at least halves the previous one ([`NewtonContraction::Quadratic`]).
const QUADRATIC_CONTRACTION: f64 = 0.5;

/// Largest distance of a Keller-corrected point from its predictor, relative to the step.
const MAX_CORRECTOR_TRAVEL: f64 = 0.5;

/// The scalar equation `g(X) = 0` that closes `R(X) = 0`.
pub(super) trait ClosingEquation {
    /// `g(X)`.
    fn value(&self, xs: &[f64]) -> f64;
    /// `∂g/∂X`, the border row of the bordered matrix.
    fn gradient(&self, xs: &[f64]) -> Vec<f64>;
    /// Largest accepted `|g(X)|`.
    fn tolerance(&self, xs: &[f64]) -> f64;
}

/// Keller's arclength condition `tᵀ(X − X_0) − Δs = 0`.
pub(super) struct Arclength<'a> {
    pub start: &'a [f64],
    pub tangent: &'a [f64],
    pub ds: f64,
}

impl ClosingEquation for Arclength<'_> {
    fn value(&self, xs: &[f64]) -> f64 {
        dot(self.tangent, &difference(xs, self.start)) - self.ds
    }
    fn gradient(&self, _xs: &[f64]) -> Vec<f64> {
        self.tangent.to_vec()
    }
    /// The arclength equation is linear: after one step it holds to round-off, which is
    /// relative to `|X|`, not to the (possibly tiny) step.
    fn tolerance(&self, xs: &[f64]) -> f64 {
        1e-8 * self.ds + 64.0 * f64::EPSILON * max_abs(xs)
    }
}

/// The sphere `‖X − X_0‖² − r² = 0` around `X_0`.
pub(super) struct Sphere<'a> {
    pub center: &'a [f64],
    pub radius: f64,
}

impl ClosingEquation for Sphere<'_> {
    fn value(&self, xs: &[f64]) -> f64 {
        let d = difference(xs, self.center);
        dot(&d, &d) - self.radius * self.radius
    }
    fn gradient(&self, xs: &[f64]) -> Vec<f64> {
        difference(xs, self.center)
            .iter()
            .map(|d| 2.0 * d)
            .collect()
    }
    fn tolerance(&self, _xs: &[f64]) -> f64 {
        1e-8 * self.radius * self.radius
    }
}

/// A converged point of the bordered Newton, in scaled variables.
pub(super) struct Corrected {
    pub xs: Vec<f64>,
    pub iterations: usize,
    /// `‖R‖_∞ / length_scale`.
    pub residual_norm: f64,
}

/// Newton on the bordered system, as the method's policy allows it to contract.
pub(super) struct Corrector<'a> {
    pub newton: &'a NewtonOptions,
    pub contraction: NewtonContraction,
}

impl Corrector<'_> {
    /// Newton on `[R(X); g(X)] = 0` from `xs`: converged when `‖R‖_∞ ≤ tolerance · ℓ` and
    /// `|g| ≤ g.tolerance` after at least `min_iterations` iterations; `None` when it does
    /// not converge within the iteration limit, leaves positive frequencies, meets a
    /// singular matrix, or (with [`NewtonContraction::Quadratic`]) an update does not halve
    /// the previous one.
    pub fn solve<P: PeriodicProblem + ?Sized>(
        &self,
        problem: &mut P,
        sc: &Scaling,
        mut xs: Vec<f64>,
        equation: &impl ClosingEquation,
        min_iterations: usize,
    ) -> Result<Option<Corrected>> {
        let mut previous_update = f64::INFINITY;
        for it in 0..=self.newton.max_iterations {
            let (x, omega) = sc.unscale(&xs);
            if !(omega.is_finite() && omega > 0.0) {
                return Ok(None);
            }
            let (a, r) = match bordered(problem, sc, &x, omega, &equation.gradient(&xs)) {
                Ok(v) => v,
                Err(e) if e.kind() == ErrorKind::Singular => return Ok(None),
                Err(e) => return Err(e),
            };
            let g = equation.value(&xs);
            let norm = max_abs(&r) / sc.length;
            if it >= min_iterations
                && norm <= self.newton.tolerance
                && g.abs() <= equation.tolerance(&xs)
            {
                return Ok(Some(Corrected {
                    xs,
                    iterations: it,
                    residual_norm: norm,
                }));
            }
            if it == self.newton.max_iterations {
                break;
            }
            let n = r.len();
            let Ok(d) = solve_bordered(&a, |i| if i < n { -r[i] } else { -g }) else {
                return Ok(None);
            };
            if self.contraction == NewtonContraction::Quadratic {
                // poor contraction: a corrector working across a grazing event or towards
                // another piece of the branch; refused, the step will be halved
                let update = dot(&d, &d).sqrt();
                if update > QUADRATIC_CONTRACTION * previous_update
                    && update > 64.0 * f64::EPSILON * (1.0 + max_abs(&xs))
                {
                    return Ok(None);
                }
                previous_update = update;
            }
            xs.iter_mut().zip(&d).for_each(|(a, b)| *a += b);
        }
        Ok(None)
    }

    /// Keller corrector from the predictor `X_0 + Δs t`: the scaled point, or `None` when it
    /// does not converge or lands further than half the step from the predictor.
    pub fn keller<P: PeriodicProblem + ?Sized>(
        &self,
        problem: &mut P,
        sc: &Scaling,
        start: &[f64],
        t: &[f64],
        ds: f64,
    ) -> Result<Option<Corrected>> {
        let predictor = predict(start, t, ds);
        let equation = Arclength {
            start,
            tangent: t,
            ds,
        };
        // at least one correction: with a tiny step any predictor meets the residual
        // tolerance, and uncorrected points let the path wander with the noise of the
        // tangent (near grazing contacts the Jacobian is nearly singular)
        let Some(corrected) = self.solve(problem, sc, predictor.clone(), &equation, 1)? else {
            return Ok(None);
        };
        // the point must lie near the predictor: a corrector that travels further than
        // half the step has left the piece of branch it started on (e.g. jumped across an
        // S of two close folds, or onto a nearby piece born at a grazing contact)
        let travelled = corrected
            .xs
            .iter()
            .zip(&predictor)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            .sqrt();
        if travelled > MAX_CORRECTOR_TRAVEL * ds {
            return Ok(None);
        }
        Ok(Some(corrected))
    }
}
