//! What the continuation does where the arclength step fails, as the method's policy
//! declares ([`ArclengthFallback`]): escape a corner of the branch, or step in frequency.

use super::branch::BranchPoint;
use super::corrector::{Corrector, Sphere};
use super::options::ContinuationOptions;
use super::predictor::{oriented_tangent, predict};
use super::scaled::{difference, dot, normalized, Scaling};
use crate::error::{ErrorKind, Result};
use crate::newton;
use crate::problem::{ArclengthFallback, NewtonContraction, PeriodicProblem};

/// Radii of the spheres searched for the outgoing piece of a corner (scaled arclength).
const CORNER_RADII: [f64; 5] = [1e-8, 1e-7, 1e-6, 1e-5, 1e-4];

/// Arclength step after a corner escape (at least `min_step`): the middle of the radii.
const STEP_AFTER_CORNER: f64 = 1e-6;

/// Frequency steps tried, as fractions of the largest frequency step.
const FREQUENCY_STEP_FRACTIONS: [f64; 3] = [0.25, 1.0 / 16.0, 1.0 / 64.0];

/// Largest frequency step `|Δ ln ω|` when the options set no limit.
const FREQUENCY_STEP_WITHOUT_LIMIT: f64 = 1e-3;

/// A point found by a fallback.
pub(super) enum Rescue {
    /// The first point of the outgoing piece past a corner of the branch.
    Corner(BranchPoint),
    /// A solution at a fixed frequency a little ahead.
    FrequencyStep(BranchPoint),
}

impl Rescue {
    /// The arclength step to continue with after this point.
    pub fn next_step(&self, options: &ContinuationOptions) -> f64 {
        match self {
            Rescue::Corner(_) => options.min_step.max(STEP_AFTER_CORNER),
            Rescue::FrequencyStep(_) => options.initial_step,
        }
    }
}

/// The fallback of a method's policy, with its state along the branch.
pub(super) enum Fallback {
    /// Corner escape, at most once in a row: a branch that needs it again straight away is
    /// stuck, not at a corner.
    EscapeCorner { escaped_last: bool },
    /// Frequency stepping below `min_arclength_step`.
    StepInFrequency { min_arclength_step: f64 },
}

impl Fallback {
    pub fn new(policy: ArclengthFallback) -> Self {
        match policy {
            ArclengthFallback::EscapeCorner => Fallback::EscapeCorner {
                escaped_last: false,
            },
            ArclengthFallback::StepInFrequency { min_arclength_step } => {
                Fallback::StepInFrequency { min_arclength_step }
            }
        }
    }

    /// The smallest arclength step tried before falling back: `min_step`, or with frequency
    /// stepping at least the policy's `min_arclength_step` (each failed corrector of a
    /// finite-difference method costs dozens of residual evaluations, and steps below the
    /// staircase scale cannot succeed).
    pub fn smallest_step(&self, options: &ContinuationOptions) -> f64 {
        match self {
            Fallback::EscapeCorner { .. } => options.min_step,
            Fallback::StepInFrequency { min_arclength_step } => {
                options.min_step.max(*min_arclength_step)
            }
        }
    }

    /// Whether this fallback steps in frequency (for the stop reason).
    pub fn steps_in_frequency(&self) -> bool {
        matches!(self, Fallback::StepInFrequency { .. })
    }

    /// An arclength step succeeded.
    pub fn arclength_step_accepted(&mut self) {
        if let Fallback::EscapeCorner { escaped_last } = self {
            *escaped_last = false;
        }
    }

    /// Look for a point past `last` where the arclength step failed; `direction`: `+1` for
    /// an upward sweep, `−1` downward.
    pub fn rescue<P: PeriodicProblem + ?Sized>(
        &mut self,
        problem: &mut P,
        sc: &Scaling,
        corrector: &Corrector<'_>,
        last: &BranchPoint,
        direction: f64,
        options: &ContinuationOptions,
    ) -> Result<Option<Rescue>> {
        match self {
            Fallback::EscapeCorner { escaped_last } => {
                if *escaped_last {
                    return Ok(None);
                }
                let escaped = escape_corner(problem, sc, corrector, last)?;
                *escaped_last = escaped.is_some();
                Ok(escaped.map(Rescue::Corner))
            }
            Fallback::StepInFrequency { .. } => {
                Ok(step_in_frequency(problem, sc, last, direction, options)?
                    .map(Rescue::FrequencyStep))
            }
        }
    }
}

/// Continue past a corner of the branch: Newton on `[R(X); ‖X − X_0‖² − r²] = 0` for growing
/// radii `r`, from the predictor along the last tangent and from directions turned away
/// from it, accepting the first solution that does not lie on the incoming piece.
fn escape_corner<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    sc: &Scaling,
    corrector: &Corrector<'_>,
    last: &BranchPoint,
) -> Result<Option<BranchPoint>> {
    // Newton on a sphere starts off the branch, on the far side of a corner: its updates
    // are not held to the quadratic contraction of the arclength corrector
    let corrector = Corrector::new(corrector.newton, NewtonContraction::Unchecked);
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
    for radius in CORNER_RADII {
        let mut starts = vec![t.clone()];
        for v in &others {
            starts.push(normalized(t.iter().zip(v).map(|(a, b)| a + b).collect()));
            starts.push(v.clone());
        }
        // and turned back, for a corner sharper than a right angle (accepted below only
        // when its orientation tells it from the incoming piece)
        if last.determinant_sign.is_some() {
            for v in &others {
                starts.push(normalized(t.iter().zip(v).map(|(a, b)| b - a).collect()));
            }
        }
        let sphere = Sphere {
            center: &x0,
            radius,
        };
        for dir in starts {
            let Some(corrected) =
                corrector.solve(problem, sc, predict(&x0, &dir, radius), &sphere, 1)?
            else {
                continue;
            };
            let d = difference(&corrected.xs, &x0);
            let (x, omega) = sc.unscale(&corrected.xs);
            let (tn, determinant_sign) = match oriented_tangent(problem, sc, &x, omega, t, &d) {
                Ok(found) => found,
                Err(e) if e.kind() == ErrorKind::Singular => continue,
                Err(e) => return Err(e),
            };
            // a point behind the corner's plane is the outgoing piece of a corner sharper
            // than a right angle only when it keeps the orientation (T73a): the incoming
            // piece travelled back has it reversed. Without an orientation (matrix-free
            // Jacobians) such a point cannot be told from a retrace and is not taken
            let backwards = dot(&normalized(d.clone()), t) < 0.0;
            let same_orientation = matches!(
                (last.determinant_sign, determinant_sign),
                (Some(a), Some(b)) if a == b
            );
            if backwards && !same_orientation {
                continue;
            }
            return Ok(Some(BranchPoint {
                x,
                omega,
                tangent: tn,
                iterations: corrected.iterations,
                residual_norm: corrected.residual_norm,
                step: radius,
                determinant_sign,
            }));
        }
    }
    Ok(None)
}

/// Newton at a fixed frequency `ω e^{±Δ}` a little ahead of `last` (docs/theory.md (T77)),
/// `Δ` the fractions [`FREQUENCY_STEP_FRACTIONS`] of the largest frequency step; the end
/// frequency is not stepped over.
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
        FREQUENCY_STEP_WITHOUT_LIMIT
    };
    let start = sc.to_scaled(&last.x, last.omega);
    for fraction in FREQUENCY_STEP_FRACTIONS {
        let mut omega = last.omega * (direction * fraction * largest).exp();
        if (omega - options.omega_end) * direction > 0.0 {
            omega = options.omega_end;
        }
        let outcome =
            match newton::solve(problem, &last.x, omega, &options.fixed_frequency_newton()) {
                Ok(o) => o,
                // the problem cannot be evaluated there (a singular matrix, a failed LCP):
                // try a smaller step
                Err(e) if matches!(e.kind(), ErrorKind::Singular | ErrorKind::Numerical) => {
                    continue
                }
                Err(e) => return Err(e),
            };
        if !outcome.converged {
            continue;
        }
        let secant = difference(&sc.to_scaled(&outcome.x, omega), &start);
        let step = dot(&secant, &secant).sqrt();
        // bordered with the secant: near a corner the last tangent may be almost
        // orthogonal to the branch
        let border = normalized(secant.clone());
        let (t, determinant_sign) =
            match oriented_tangent(problem, sc, &outcome.x, omega, &border, &secant) {
                Ok(t) => t,
                Err(e) if e.kind() == ErrorKind::Singular => continue,
                Err(e) => return Err(e),
            };
        return Ok(Some(BranchPoint {
            x: outcome.x,
            omega,
            tangent: t,
            iterations: outcome.iterations,
            residual_norm: outcome.residual_norm,
            step,
            determinant_sign,
        }));
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::super::{trace_branch, ContinuationOptions, StopReason};
    use crate::problem::tests::Scalar;
    use crate::problem::NewtonContraction;

    /// `|x − 1| = c (1 − ω)`: a V whose two pieces meet at `ω = 1` at an angle of
    /// `2 atan c` (11° for `c = 0.1` in the scaled variables), a kink fold sharper than a
    /// right angle. Swept upwards, the branch reaches the corner on the piece `x < 1` and
    /// leaves it on `x > 1`, back down in frequency, until it passes below the start. The
    /// corner escape tells the outgoing piece from the incoming one travelled back by the
    /// orientation (T73a): both pieces keep `sign det [R_X; tᵀ]`, the retrace reverses it.
    /// Without that test the escape took only points ahead of the corner's plane and the
    /// branch stopped at the corner.
    #[test]
    fn a_corner_sharper_than_a_right_angle_is_crossed_by_its_orientation() {
        let c = 0.1;
        let mut p = Scalar {
            equation: move |x: f64, w: f64| {
                ((x - 1.0).abs() - c * (1.0 - w), (x - 1.0).signum(), c)
            },
            contraction: NewtonContraction::Quadratic,
        };
        let mut options = ContinuationOptions::new(0.5, 2.0);
        options.max_step = 0.02;
        // Newton from x = 0 lands on the piece x < 1 at ω = 0.5
        let mut events = Vec::new();
        let branch = trace_branch(&mut p, &options, |_, e| {
            if let super::super::Event::Fold(f) = e {
                events.push((f.omega, f.at_kink));
            }
            Ok(())
        })
        .unwrap();
        assert!(
            matches!(branch.stop, StopReason::LeftRange),
            "{:?}",
            branch.stop
        );
        assert_eq!(events.len(), 1, "{events:?}");
        assert!(
            (events[0].0 - 1.0).abs() < 1e-6 && events[0].1,
            "{events:?}"
        );
        let after: Vec<_> = branch.points.iter().filter(|p| p.x[0] > 1.0).collect();
        assert!(after.len() > 10, "{}", after.len());
        for q in after {
            assert!(((q.x[0] - 1.0) - c * (1.0 - q.omega)).abs() < 1e-9);
        }
    }
}
