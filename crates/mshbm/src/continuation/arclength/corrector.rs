//! Corrector: Newton on `R(X) = 0` closed by one scalar equation `g(X) = 0` — Keller's
//! arclength condition `tᵀ(X − X_0) − Δs = 0` for a continuation step (docs/theory.md
//! (T74)), the sphere `‖X − X_0‖² − r² = 0` for a corner escape. Both are Newton's one loop
//! ([`newton::iterate`]) on the bordered system `[R_X; ∂g/∂X] ΔX = −[R; g]`, with full
//! steps.

use super::predictor::predict;

use std::cell::RefCell;

use super::scaled::{bordered_into, dot, max_abs, BorderedStorage, Scaling};
use crate::error::{ErrorKind, Result};
use crate::newton::{self, Iterated, NewtonOptions, NewtonStorage, NewtonSystem};
use crate::problem::{Jacobian, NewtonContraction, PeriodicProblem};

/// Largest ratio of two successive updates of a quadratically contracting Newton: each
/// update at least halves the previous one ([`NewtonContraction::Quadratic`]).
const QUADRATIC_CONTRACTION: f64 = 0.5;

/// Largest change of `ln ω` in one corrector update: a larger one comes from a nearly
/// singular bordered system, and the problem is not evaluated there (a period many orders
/// of magnitude longer can cost the time-domain methods hours).
const MAX_FREQUENCY_UPDATE: f64 = 0.5;

/// Largest distance of a Keller-corrected point from its predictor, relative to the step.
const MAX_CORRECTOR_TRAVEL: f64 = 0.5;

/// The scalar equation `g(X) = 0` that closes `R(X) = 0`.
pub(super) trait ClosingEquation {
    /// `g(X)`.
    fn value(&self, xs: &[f64]) -> f64;
    /// `∂g/∂X`, the border row of the bordered matrix, into `out`.
    fn gradient_into(&self, xs: &[f64], out: &mut Vec<f64>);
    /// Largest accepted `|g(X)|`.
    fn tolerance(&self, xs: &[f64]) -> f64;
}

/// Keller's arclength condition `tᵀ(X − X_0) − Δs = 0` (docs/theory.md (T74)).
pub(super) struct Arclength<'a> {
    pub start: &'a [f64],
    pub tangent: &'a [f64],
    pub ds: f64,
}

impl ClosingEquation for Arclength<'_> {
    fn value(&self, xs: &[f64]) -> f64 {
        let moved = xs.iter().zip(self.start).map(|(x, s)| x - s);
        self.tangent
            .iter()
            .zip(moved)
            .map(|(t, d)| t * d)
            .sum::<f64>()
            - self.ds
    }
    fn gradient_into(&self, _xs: &[f64], out: &mut Vec<f64>) {
        out.clear();
        out.extend_from_slice(self.tangent);
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
        let d = xs.iter().zip(self.center).map(|(x, c)| x - c);
        d.map(|d| d * d).sum::<f64>() - self.radius * self.radius
    }
    fn gradient_into(&self, xs: &[f64], out: &mut Vec<f64>) {
        out.clear();
        out.extend(xs.iter().zip(self.center).map(|(x, c)| 2.0 * (x - c)));
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

/// The bordered system `[R(X); g(X)] = 0` in scaled variables, for [`newton::iterate`].
struct Bordered<'a, P: PeriodicProblem + ?Sized, G: ClosingEquation> {
    problem: &'a mut P,
    sc: &'a Scaling,
    equation: &'a G,
    min_iterations: usize,
    tolerance: f64,
    contraction: NewtonContraction,
    /// Length of the last update (for the contraction check).
    previous_update: f64,
    /// `‖R‖_∞ / ℓ` at the last linearization.
    residual_norm: f64,
    /// The unscaled unknowns, the border row and the problem's linearization (kept by the
    /// corrector from one solve to the next).
    storage: &'a mut BorderedSystemStorage,
}

/// What the bordered system keeps between iterations and solves.
#[derive(Default)]
struct BorderedSystemStorage {
    x: Vec<f64>,
    border: Vec<f64>,
    bordered: BorderedStorage,
}

impl<P: PeriodicProblem + ?Sized, G: ClosingEquation> NewtonSystem for Bordered<'_, P, G> {
    /// `[R_X; ∂g/∂X]` and `[R; g]`; `None` off positive frequencies (a subnormal one, whose
    /// period overflows, included) or where a matrix of the problem is singular.
    fn linearize(&mut self, xs: &[f64], jacobian: &mut Jacobian, f: &mut Vec<f64>) -> Result<bool> {
        let storage = &mut *self.storage;
        let omega = self.sc.unscale_into(xs, &mut storage.x);
        if !(omega.is_normal() && omega > 0.0) {
            return Ok(false);
        }
        self.equation.gradient_into(xs, &mut storage.border);
        let linearized = bordered_into(
            self.problem,
            self.sc,
            &storage.x,
            omega,
            &storage.border,
            &mut storage.bordered,
            jacobian,
            f,
        );
        match linearized {
            Ok(()) => {}
            // a point the method cannot evaluate (a singular system, a frictional law
            // without a periodic state) refuses the step: the step is reduced, and the
            // branch stops with what it found at the smallest step
            Err(e) if matches!(e.kind(), ErrorKind::Singular | ErrorKind::Numerical) => {
                return Ok(false)
            }
            Err(e) => return Err(e),
        }
        self.residual_norm = max_abs(f) / self.sc.length;
        f.push(self.equation.value(xs));
        Ok(true)
    }

    fn converged(&mut self, xs: &[f64], f: &[f64], iterations: usize) -> bool {
        let g = f[f.len() - 1];
        iterations >= self.min_iterations
            && self.residual_norm <= self.tolerance
            && g.abs() <= self.equation.tolerance(xs)
    }

    /// The full step; refused when it changes `ln ω` by more than [`MAX_FREQUENCY_UPDATE`];
    /// with [`NewtonContraction::Quadratic`], refused when it does not halve
    /// the previous one (a corrector working across a grazing event or towards another piece
    /// of the branch; the arclength step will be halved).
    fn advance(&mut self, mut xs: Vec<f64>, _f: &[f64], d: &[f64]) -> Result<Option<Vec<f64>>> {
        if d[d.len() - 1].abs() > MAX_FREQUENCY_UPDATE {
            return Ok(None);
        }
        if self.contraction == NewtonContraction::Quadratic {
            let update = dot(d, d).sqrt();
            if update > QUADRATIC_CONTRACTION * self.previous_update
                && update > 64.0 * f64::EPSILON * (1.0 + max_abs(&xs))
            {
                return Ok(None);
            }
            self.previous_update = update;
        }
        xs.iter_mut().zip(d).for_each(|(a, b)| *a += b);
        Ok(Some(xs))
    }
}

/// Newton on the bordered system, as the method's policy allows it to contract.
pub(super) struct Corrector<'a> {
    pub newton: &'a NewtonOptions,
    pub contraction: NewtonContraction,
    /// Newton's and the bordered system's storage, kept from solve to solve: once the
    /// first point is solved, a corrector iteration allocates nothing beyond what the
    /// problem's [`PeriodicProblem::linearize_into`] does.
    storage: RefCell<(NewtonStorage, BorderedSystemStorage)>,
}

impl<'a> Corrector<'a> {
    pub fn new(newton: &'a NewtonOptions, contraction: NewtonContraction) -> Self {
        Corrector {
            newton,
            contraction,
            storage: Default::default(),
        }
    }
}

impl Corrector<'_> {
    /// Newton on `[R(X); g(X)] = 0` from `xs` ([`newton::iterate`]): converged when
    /// `‖R‖_∞ ≤ tolerance · ℓ` and `|g| ≤ g.tolerance` after at least `min_iterations`
    /// iterations; `None` when it does not converge within the iteration limit, leaves
    /// positive frequencies, meets a singular matrix, or (with
    /// [`NewtonContraction::Quadratic`]) an update does not halve the previous one.
    pub fn solve<P: PeriodicProblem + ?Sized>(
        &self,
        problem: &mut P,
        sc: &Scaling,
        xs: Vec<f64>,
        equation: &impl ClosingEquation,
        min_iterations: usize,
    ) -> Result<Option<Corrected>> {
        let mut storage = self.storage.borrow_mut();
        let (newton_storage, system_storage) = &mut *storage;
        let mut system = Bordered {
            problem,
            sc,
            equation,
            min_iterations,
            tolerance: self.newton.tolerance,
            contraction: self.contraction,
            previous_update: f64::INFINITY,
            residual_norm: f64::NAN,
            storage: system_storage,
        };
        Ok(
            match newton::iterate(
                &mut system,
                xs,
                self.newton.max_iterations,
                newton_storage,
                self.newton.cancel,
            )? {
                Iterated::Converged { y, iterations } => Some(Corrected {
                    xs: y,
                    iterations,
                    residual_norm: system.residual_norm,
                }),
                Iterated::IterationLimit { .. }
                | Iterated::SingularJacobian { .. }
                | Iterated::Stopped => None,
            },
        )
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::tests::Scalar;

    /// `R(x, ω) = x − 1/ω`, which refuses (as the general MS-HBM's integrator does) a
    /// frequency whose period overflows.
    fn reciprocal() -> Scalar<impl FnMut(f64, f64) -> (f64, f64, f64)> {
        Scalar {
            equation: |x, omega| {
                let period = 1.0 / omega;
                assert!(period.is_finite(), "evaluated at ω = {omega:e}");
                (x - period, 1.0, period * period)
            },
            contraction: NewtonContraction::Unchecked,
        }
    }

    /// A corrector iterate at a subnormal frequency (positive, but its period overflows) is
    /// refused like one off the positive frequencies, before the problem sees it.
    #[test]
    fn a_subnormal_frequency_is_refused_before_the_problem_is_evaluated() {
        let sc = Scaling::new(1.0, 1, 1.0);
        let options = NewtonOptions::default();
        let corrector = Corrector::new(&options, NewtonContraction::Unchecked);
        let subnormal: f64 = 1e-320;
        assert!(subnormal > 0.0 && !subnormal.is_normal() && !(1.0 / subnormal).is_finite());
        let start = sc.to_scaled(&[0.0], subnormal);
        let sphere = Sphere {
            center: &start,
            radius: 1.0,
        };
        assert!(corrector
            .solve(&mut reciprocal(), &sc, start.clone(), &sphere, 0)
            .unwrap()
            .is_none());
        // a normal frequency is evaluated as before
        let start = sc.to_scaled(&[1.0], 1.0);
        let sphere = Sphere {
            center: &sc.to_scaled(&[0.0], 1.0),
            radius: 1.0,
        };
        assert!(corrector
            .solve(&mut reciprocal(), &sc, start, &sphere, 0)
            .unwrap()
            .is_some());
    }

    /// `g(X) = X_0 − c`: the unknown held at `c`.
    struct Held(f64);

    impl ClosingEquation for Held {
        fn value(&self, xs: &[f64]) -> f64 {
            xs[0] - self.0
        }
        fn gradient_into(&self, xs: &[f64], out: &mut Vec<f64>) {
            out.clear();
            out.resize(xs.len(), 0.0);
            out[0] = 1.0;
        }
        fn tolerance(&self, _xs: &[f64]) -> f64 {
            1e-12
        }
    }

    /// An update that changes `ln ω` by more than [`MAX_FREQUENCY_UPDATE`] is refused: on
    /// `x = 1/ω` from `(1, 1)` with `x` held at `c`, the first update is `Δ ln ω = 1 − c`.
    /// With `c = 0.9` Newton converges to `ω = 1/0.9`; with `c = 1e-12` (a solution at
    /// `ω = 1e12`, 27.6 in `ln ω` away) the corrector stops instead of evaluating there.
    #[test]
    fn a_corrector_update_far_in_frequency_is_refused() {
        let sc = Scaling::new(1.0, 1, 1.0);
        let options = NewtonOptions::default();
        let corrector = Corrector::new(&options, NewtonContraction::Unchecked);
        let start = sc.to_scaled(&[1.0], 1.0);
        let near = corrector
            .solve(&mut reciprocal(), &sc, start.clone(), &Held(0.9), 0)
            .unwrap()
            .expect("converges");
        let (_, omega) = sc.unscale(&near.xs);
        assert!((omega - 1.0 / 0.9).abs() < 1e-8, "{omega}");
        assert!(corrector
            .solve(&mut reciprocal(), &sc, start, &Held(1e-12), 0)
            .unwrap()
            .is_none());
    }
}
