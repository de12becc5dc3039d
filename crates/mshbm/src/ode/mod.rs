//! Explicit Runge–Kutta integration of ordinary differential equations `ẋ = f(t, x)`:
//! Dormand and Prince's 8th-order pair DOP853 with Hairer's error estimate (a 5th- and a
//! 3rd-order embedded solution combined), one step at a time. The caller owns the step
//! sequence, so that it can shorten a step to land on an event (the friction cone's slip
//! flow, docs/theory.md (T187)–(T188)); [`Dop853::next_step`] proposes the next length.

mod tableau;

use crate::error::{Error, Result};
use tableau::{A, B, C, E3_LESS, E5};

/// Error tolerances of a step: component `i` may err by `absolute + relative · |x_i|`.
#[derive(Clone, Copy, Debug)]
pub struct Tolerance {
    pub relative: f64,
    pub absolute: f64,
}

/// The stages of DOP853 for systems of one dimension, reused from step to step.
#[derive(Clone, Debug)]
pub struct Dop853 {
    stages: Vec<Vec<f64>>,
    work: Vec<f64>,
}

/// Factor by which a step may grow or shrink at most, and the safety factor on the
/// asymptotic estimate.
const MAX_GROWTH: f64 = 10.0;
const MIN_GROWTH: f64 = 0.2;
const SAFETY: f64 = 0.9;

impl Dop853 {
    /// Stages for systems of `dimension` unknowns.
    pub fn new(dimension: usize) -> Self {
        Dop853 {
            stages: vec![vec![0.0; dimension]; 12],
            work: vec![0.0; dimension],
        }
    }

    /// The number of unknowns.
    pub fn dimension(&self) -> usize {
        self.work.len()
    }

    /// One step of length `h` from `x` at `t` into `x_new`; returns the error norm of the
    /// step relative to `tolerance` (the step is acceptable when it is at most 1). `f`
    /// writes `ẋ` into its third argument.
    pub fn step<F>(
        &mut self,
        f: &mut F,
        t: f64,
        x: &[f64],
        h: f64,
        x_new: &mut [f64],
        tolerance: Tolerance,
    ) -> Result<f64>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<()>,
    {
        let n = self.dimension();
        if x.len() != n || x_new.len() != n {
            return Err(Error::Numerical(format!(
                "DOP853: a state of {} and {} unknowns for a system of {n}",
                x.len(),
                x_new.len()
            )));
        }
        for s in 0..12 {
            self.work.copy_from_slice(x);
            for (j, &a) in A[s].iter().enumerate().take(s) {
                if a != 0.0 {
                    for (w, k) in self.work.iter_mut().zip(&self.stages[j]) {
                        *w += h * a * k;
                    }
                }
            }
            let (work, stages) = (&self.work, &mut self.stages);
            f(t + C[s] * h, work, &mut stages[s])?;
        }
        x_new.copy_from_slice(x);
        for (s, &b) in B.iter().enumerate() {
            if b != 0.0 {
                for (y, k) in x_new.iter_mut().zip(&self.stages[s]) {
                    *y += h * b * k;
                }
            }
        }
        // Hairer's estimate: |h| ‖e5‖² / √(n (‖e5‖² + 0.01 ‖e3‖²)), each component scaled
        let (mut e5_sq, mut e3_sq) = (0.0, 0.0);
        for i in 0..n {
            let scale = tolerance.absolute + tolerance.relative * x[i].abs().max(x_new[i].abs());
            let mut e5 = 0.0;
            let mut e3 = 0.0;
            for s in 0..12 {
                let k = self.stages[s][i];
                e5 += E5[s] * k;
                e3 += B[s] * k;
            }
            for &(s, less) in &E3_LESS {
                e3 -= less * self.stages[s][i];
            }
            e5_sq += (e5 / scale).powi(2);
            e3_sq += (e3 / scale).powi(2);
        }
        if !(e5_sq.is_finite() && e3_sq.is_finite()) || x_new.iter().any(|v| !v.is_finite()) {
            return Err(Error::Numerical(format!(
                "DOP853: the state is not finite after a step of {h:e} from t = {t}"
            )));
        }
        if e5_sq == 0.0 && e3_sq == 0.0 {
            return Ok(0.0);
        }
        Ok(h.abs() * e5_sq / (n as f64 * (e5_sq + 0.01 * e3_sq)).sqrt())
    }

    /// The length of the next step after one of length `h` with error norm `error`
    /// (the step's order is 8: the error scales as `h⁸`).
    pub fn next_step(h: f64, error: f64) -> f64 {
        let factor = if error == 0.0 {
            MAX_GROWTH
        } else {
            (SAFETY * error.powf(-1.0 / 8.0)).clamp(MIN_GROWTH, MAX_GROWTH)
        };
        h * factor
    }

    /// Integrate over `span` (`span.start < span.end`) with steps of at most `max_step`,
    /// starting with `h0`; `x` holds the start on entry and the end on return. Returns the
    /// steps taken.
    pub fn integrate<F>(
        &mut self,
        f: &mut F,
        span: std::ops::Range<f64>,
        x: &mut [f64],
        (h0, max_step): (f64, f64),
        tolerance: Tolerance,
    ) -> Result<usize>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<()>,
    {
        let (t0, t1) = (span.start, span.end);
        let mut t = t0;
        let mut h = h0.min(max_step).min(t1 - t0);
        let mut next = vec![0.0; x.len()];
        let mut steps = 0;
        while t < t1 {
            let last = t + h >= t1;
            let length = if last { t1 - t } else { h };
            let error = self.step(f, t, x, length, &mut next, tolerance)?;
            if error <= 1.0 {
                x.copy_from_slice(&next);
                t = if last { t1 } else { t + length };
                steps += 1;
            }
            h = Self::next_step(length, error).min(max_step);
            if h <= f64::EPSILON * t.abs().max(1.0) {
                return Err(Error::Numerical(format!(
                    "DOP853: the step fell below round-off at t = {t}"
                )));
            }
        }
        Ok(steps)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The harmonic oscillator `ẍ = −x` over many periods against `cos t`, `−sin t`.
    #[test]
    fn the_oscillator_matches_its_closed_form() {
        let mut f = |_t: f64, x: &[f64], dx: &mut [f64]| {
            dx[0] = x[1];
            dx[1] = -x[0];
            Ok(())
        };
        let mut ode = Dop853::new(2);
        let mut x = [1.0, 0.0];
        let tol = Tolerance {
            relative: 1e-13,
            absolute: 1e-13,
        };
        let t1: f64 = 20.0;
        let steps = ode
            .integrate(&mut f, 0.0..t1, &mut x, (0.1, 1.0), tol)
            .unwrap();
        assert!((x[0] - t1.cos()).abs() < 1e-11, "{}", x[0] - t1.cos());
        assert!((x[1] + t1.sin()).abs() < 1e-11, "{}", x[1] + t1.sin());
        assert!(steps < 400, "{steps} steps");
    }

    /// Halving a fixed step divides the error of `ẋ = t² cos(x)`-like smooth problems by
    /// about 2⁸: the pair is of order 8 (here `ẋ = x` from 1 to `e`).
    #[test]
    fn the_step_is_of_order_eight() {
        let f = |_t: f64, x: &[f64], dx: &mut [f64]| {
            dx[0] = x[0];
            Ok(())
        };
        let loose = Tolerance {
            relative: 1.0,
            absolute: 1.0,
        };
        let error = |steps: usize| {
            let mut ode = Dop853::new(1);
            let (mut x, mut next) = ([1.0], [0.0]);
            let h = 1.0 / steps as f64;
            for k in 0..steps {
                ode.step(&mut f.clone(), k as f64 * h, &x, h, &mut next, loose)
                    .unwrap();
                x = next;
            }
            (x[0] - 1f64.exp()).abs()
        };
        let (e1, e2) = (error(2), error(4));
        let order = (e1 / e2).log2();
        assert!(
            (order - 8.0).abs() < 0.6,
            "observed order {order} ({e1:e}, {e2:e})"
        );
    }
}
