//! What the continuation produces: points, folds, and why the branch ended.

use crate::newton::NewtonFailure;

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
    /// The sign of `det [R_X; tᵀ]` with the tangent (docs/theory.md (T73)), constant along
    /// a smooth piece of the branch; `None` for a matrix-free Jacobian.
    pub determinant_sign: Option<f64>,
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
    /// No solution at the start frequency: why Newton failed there.
    StartFailed(NewtonFailure),
    /// The step fell below its smallest value (the corrector kept failing) and the method's
    /// fallback found no point either.
    StepTooSmall { omega: f64, reason: StepFailure },
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

/// Why no step could be taken from the last point ([`StopReason::StepTooSmall`]).
/// `Display` gives the sentence the CLI prints.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StepFailure {
    /// The Keller corrector did not converge within `corrector_iterations` iterations (or
    /// was refused) down to the smallest arclength step `smallest_step`, and the fallback of
    /// the method's policy found nothing; `frequency_stepping`: that fallback was Newton at
    /// fixed frequencies a little ahead
    /// ([`crate::problem::ArclengthFallback::StepInFrequency`]).
    NoContinuationPoint {
        corrector_iterations: usize,
        smallest_step: f64,
        frequency_stepping: bool,
    },
}

impl std::fmt::Display for StepFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StepFailure::NoContinuationPoint {
                corrector_iterations,
                smallest_step,
                frequency_stepping,
            } => write!(
                f,
                "no continuation point within {corrector_iterations} corrector iterations even with the smallest step {smallest_step:.1e}{} \
                 (a singular point of the branch, e.g. where a contact grazes and the branch turns sharply)",
                if *frequency_stepping {
                    ", nor by Newton at a fixed frequency a little ahead"
                } else {
                    ""
                }
            ),
        }
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
    /// Points found by stepping in frequency
    /// ([`crate::problem::ArclengthFallback::StepInFrequency`]).
    pub frequency_steps: usize,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_failures_read_as_before() {
        let plain = StepFailure::NoContinuationPoint {
            corrector_iterations: 12,
            smallest_step: 1e-12,
            frequency_stepping: false,
        };
        assert_eq!(
            plain.to_string(),
            "no continuation point within 12 corrector iterations even with the smallest step 1.0e-12 \
             (a singular point of the branch, e.g. where a contact grazes and the branch turns sharply)"
        );
        let stepping = StepFailure::NoContinuationPoint {
            corrector_iterations: 50,
            smallest_step: 1e-4,
            frequency_stepping: true,
        };
        assert_eq!(
            stepping.to_string(),
            "no continuation point within 50 corrector iterations even with the smallest step 1.0e-4, \
             nor by Newton at a fixed frequency a little ahead (a singular point of the branch, e.g. \
             where a contact grazes and the branch turns sharply)"
        );
    }
}
