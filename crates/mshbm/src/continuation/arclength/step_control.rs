//! Step control: the arclength step `Δs` after success and failure, its bounds, the turn
//! check of an accepted point, and where the sweep ends (docs/theory.md (T75)).

use super::branch::{BranchPoint, StopReason};
use super::options::ContinuationOptions;
use super::scaled::{dot, Scaling};

/// The step after a failed (or refused) corrector: halved.
pub(super) fn shrink(ds: f64) -> f64 {
    ds * 0.5
}

/// The step after an accepted point: `Δs · clamp(N_opt / N_it, ½, 2)` (docs/theory.md
/// (T75)) within `[min_step, max_step]`, and no longer than `max_frequency_step` in `ln ω`
/// along the point's tangent.
pub(super) fn next_step(ds: f64, point: &BranchPoint, options: &ContinuationOptions) -> f64 {
    let n = point.tangent.len() - 1;
    let ratio = options.optimal_iterations.max(1) as f64 / point.iterations.max(1) as f64;
    let mut ds = (ds * ratio.clamp(0.5, 2.0)).clamp(options.min_step, options.max_step);
    let advance = point.tangent[n].abs();
    if advance * ds > options.max_frequency_step && options.max_frequency_step > 0.0 {
        ds = (options.max_frequency_step / advance).max(options.min_step);
    }
    ds
}

/// What is checked of a corrected point before it is accepted.
pub(super) struct StepCheck<'a> {
    /// The unit secant from the last point.
    pub secant_direction: &'a [f64],
    pub last_tangent: &'a [f64],
    /// The new point's tangent, oriented along the secant.
    pub tangent: &'a [f64],
    /// The sign of `det [R_X; tᵀ]` changed from the last point (docs/theory.md (T73)).
    pub reversed: bool,
}

/// Whether the corrected point continues the branch:
/// - the secant stays within 60° of the last tangent (beyond, the corrector landed on
///   another part of the curve, e.g. a nearby branch born at a grazing contact, which would
///   make the branch jump or retrace);
/// - the tangent turns by at most `max_turn_deg`;
/// - the orientation `det [R_X; tᵀ]` kept its sign (a change means the point lies on the
///   piece that comes back from a fold the step jumped across).
///
/// The last two are waived once the step is at its smallest: at a corner of a nonsmooth
/// residual the tangent and the orientation may change across the corner itself.
pub(super) fn continues_branch(
    step: &StepCheck<'_>,
    ds: f64,
    options: &ContinuationOptions,
) -> bool {
    let cos_turn = options.max_turn_deg.to_radians().cos();
    let smallest = ds <= options.min_step * 2.0;
    dot(step.secant_direction, step.last_tangent) >= 0.5
        && (smallest || (dot(step.tangent, step.last_tangent) >= cos_turn && !step.reversed))
}

/// Where a sweep from `omega_start` towards `omega_end` stands.
pub(super) struct Range {
    pub start: f64,
    pub end: f64,
    /// `+1` upwards, `−1` downwards.
    pub direction: f64,
}

impl Range {
    pub fn new(options: &ContinuationOptions) -> Self {
        let (start, end) = (options.omega_start, options.omega_end);
        Range {
            start,
            end,
            direction: (end - start).signum(),
        }
    }

    /// When the predictor from `last` with step `ds` reaches or passes the end frequency
    /// while the branch advances towards it: the fraction of the step that lands on it.
    pub fn end_ahead(
        &self,
        sc: &Scaling,
        last: &BranchPoint,
        start: &[f64],
        ds: f64,
    ) -> Option<f64> {
        let n = start.len() - 1;
        let predicted_omega = sc.omega * (start[n] + ds * last.tangent[n]).exp();
        ((predicted_omega - self.end) * self.direction >= 0.0
            && last.tangent[n] * self.direction > 0.0)
            .then(|| (self.end - last.omega) / (predicted_omega - last.omega))
    }

    /// The stop after an accepted arclength point at `omega`, if any: the end is reached, or
    /// the branch has turned back past the start (beyond a relative tolerance of 1e-3).
    pub fn stop_at(&self, omega: f64) -> Option<StopReason> {
        if (omega - self.end) * self.direction >= 0.0 {
            return Some(StopReason::ReachedEnd);
        }
        if (omega - self.start) * self.direction < 0.0
            && (omega - self.start).abs() > 1e-3 * self.start
        {
            return Some(StopReason::LeftRange);
        }
        None
    }
}
