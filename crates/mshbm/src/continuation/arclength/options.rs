//! Settings of the continuation and their validation.

use crate::error::{Error, Result};
use crate::newton::NewtonOptions;

/// Settings of the continuation. Step sizes are in the scaled arclength (dimensionless,
/// docs/theory.md (T72), (T75)). What the continuation may assume about the residual is not
/// a setting: the method declares it
/// ([`crate::problem::PeriodicProblem::continuation_policy`]).
#[derive(Clone, Debug)]
pub struct ContinuationOptions {
    /// Start frequency (rad/s; positive, finite).
    pub omega_start: f64,
    /// End frequency (rad/s; positive, finite, not the start); may be below the start
    /// (downward sweep).
    pub omega_end: f64,
    /// First arclength step (default `0.01`; `min_step ≤ initial_step ≤ max_step`).
    pub initial_step: f64,
    /// Smallest arclength step before the branch falls back or stops (default `1e-12`;
    /// positive).
    pub min_step: f64,
    /// Largest arclength step (default `0.1`; finite).
    pub max_step: f64,
    /// Corrector iterations aimed at; fewer grow the step, more shrink it (default 4; at
    /// least 1).
    pub optimal_iterations: usize,
    /// Largest accepted turn of the tangent between two points (degrees; default 20; in
    /// `(0, 180)`).
    pub max_turn_deg: f64,
    /// Corrector tolerance and iteration limit (the tolerance is relative to the problem's
    /// length scale, as in Newton; default: [`NewtonOptions::default`] with 12 iterations).
    pub newton: NewtonOptions,
    /// Largest advance in frequency per step, as `|Δ ln ω|` (a fiftieth of the range by
    /// default, so that even a narrow sweep of a smooth response has points to plot; 0 for
    /// no limit; not negative).
    pub max_frequency_step: f64,
    /// Safety limit on the number of points (default 20 000; at least 1).
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
            max_points: 20_000,
        }
    }

    /// Refuse settings the continuation cannot work with ([`Error::InvalidArgument`], naming
    /// the setting).
    pub fn validate(&self) -> Result<()> {
        let (w0, w1) = (self.omega_start, self.omega_end);
        if !(w0.is_finite() && w1.is_finite() && w0 > 0.0 && w1 > 0.0 && w0 != w1) {
            return Err(Error::argument(
                "frequency range",
                "start and end must be positive and different",
            ));
        }
        for (name, step) in [
            ("initial step", self.initial_step),
            ("smallest step", self.min_step),
            ("largest step", self.max_step),
        ] {
            if !(step.is_finite() && step > 0.0) {
                return Err(Error::argument(
                    format!("continuation {name}"),
                    format!("must be positive and finite, got {step}"),
                ));
            }
        }
        if !(self.min_step <= self.initial_step && self.initial_step <= self.max_step) {
            return Err(Error::argument(
                "continuation steps",
                format!(
                    "must satisfy smallest <= initial <= largest, got {} <= {} <= {}",
                    self.min_step, self.initial_step, self.max_step
                ),
            ));
        }
        if self.optimal_iterations == 0 {
            return Err(Error::argument(
                "optimal corrector iterations",
                "must be at least 1",
            ));
        }
        if !(self.max_turn_deg > 0.0 && self.max_turn_deg < 180.0) {
            return Err(Error::argument(
                "largest tangent turn",
                format!(
                    "must lie strictly between 0 and 180 degrees, got {}",
                    self.max_turn_deg
                ),
            ));
        }
        if self.max_frequency_step.is_nan() || self.max_frequency_step < 0.0 {
            return Err(Error::argument(
                "largest frequency step",
                format!(
                    "must be positive (or 0 for no limit), got {}",
                    self.max_frequency_step
                ),
            ));
        }
        if self.max_points == 0 {
            return Err(Error::argument("point limit", "must be at least 1"));
        }
        self.newton.validate()
    }

    /// Newton at a fixed frequency without a predictor close by (the first point, frequency
    /// steps): the corrector's settings with at least 50 iterations.
    pub(super) fn fixed_frequency_newton(&self) -> NewtonOptions {
        NewtonOptions {
            max_iterations: self.newton.max_iterations.max(50),
            ..self.newton.clone()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refusal(change: impl FnOnce(&mut ContinuationOptions)) -> String {
        let mut options = ContinuationOptions::new(10.0, 20.0);
        change(&mut options);
        match options.validate() {
            Err(e @ Error::InvalidArgument { .. }) => e.to_string(),
            other => panic!("expected an invalid argument, got {other:?}"),
        }
    }

    #[test]
    fn the_defaults_are_valid() {
        ContinuationOptions::new(10.0, 20.0).validate().unwrap();
        ContinuationOptions::new(20.0, 10.0).validate().unwrap();
    }

    #[test]
    fn bad_frequency_ranges_are_refused() {
        for (w0, w1) in [
            (10.0, 10.0),
            (0.0, 10.0),
            (-1.0, 10.0),
            (10.0, f64::INFINITY),
            (f64::NAN, 10.0),
        ] {
            let e = refusal(|o| {
                o.omega_start = w0;
                o.omega_end = w1;
            });
            assert_eq!(
                e,
                "invalid frequency range: start and end must be positive and different"
            );
        }
    }

    #[test]
    fn bad_steps_are_refused() {
        for bad in [0.0, -1e-3, f64::NAN, f64::INFINITY] {
            assert!(refusal(|o| o.initial_step = bad).contains("initial step"));
            assert!(refusal(|o| o.min_step = bad).contains("smallest step"));
            assert!(refusal(|o| o.max_step = bad).contains("largest step"));
        }
        // out of order: min_step > initial_step, initial_step > max_step
        let e = refusal(|o| o.min_step = 0.05);
        assert!(e.contains("smallest <= initial <= largest"), "{e}");
        let e = refusal(|o| o.initial_step = 0.2);
        assert!(e.contains("smallest <= initial <= largest"), "{e}");
    }

    #[test]
    fn bad_turns_iterations_and_limits_are_refused() {
        for bad in [0.0, 180.0, -5.0, 270.0, f64::NAN] {
            assert!(refusal(|o| o.max_turn_deg = bad).contains("tangent turn"));
        }
        assert!(refusal(|o| o.optimal_iterations = 0).contains("optimal corrector iterations"));
        assert!(refusal(|o| o.max_frequency_step = -0.1).contains("frequency step"));
        assert!(refusal(|o| o.max_frequency_step = f64::NAN).contains("frequency step"));
        assert!(refusal(|o| o.max_points = 0).contains("point limit"));
        assert!(refusal(|o| o.newton.tolerance = 0.0).contains("Newton tolerance"));
        assert!(refusal(|o| o.newton.max_iterations = 0).contains("Newton iteration limit"));
        // no frequency limit is a valid setting
        let mut options = ContinuationOptions::new(10.0, 20.0);
        options.max_frequency_step = 0.0;
        options.validate().unwrap();
    }
}
