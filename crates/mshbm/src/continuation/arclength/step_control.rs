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

/// Whether the corrected point (secant `secant` from the last point, tangent `t`) continues
/// the branch: the secant stays within 60° of the last tangent (beyond, the corrector landed
/// on another part of the curve, e.g. a nearby branch born at a grazing contact, which would
/// make the branch jump or retrace), and the tangent turns by at most `max_turn_deg` unless
/// the step is already at its smallest.
pub(super) fn continues_branch(
    secant_direction: &[f64],
    last_tangent: &[f64],
    t: &[f64],
    ds: f64,
    options: &ContinuationOptions,
) -> bool {
    let cos_turn = options.max_turn_deg.to_radians().cos();
    dot(secant_direction, last_tangent) >= 0.5
        && (dot(t, last_tangent) >= cos_turn || ds <= options.min_step * 2.0)
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
