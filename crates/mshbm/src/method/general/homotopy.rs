//! The event-driven start where Newton from the pre-solved linear response fails: a
//! homotopy in an added stiffness-proportional damping (docs/theory.md (T147b),
//! docs/general-mshbm.md §10).
//!
//! With light damping of the nonlinear subsystem's own mode (the contact node's ringing
//! after a release, above the harmonics of the linear part), Newton's iterates wander into
//! regions where secondary impacts come and go, and it stalls there (the paper's bar with
//! mass-proportional damping only: 2.7e-3 after 50 iterations at 30 kHz, H = 5). With that
//! mode damped, the same orbit is found from the linear response. So the model is solved
//! with the damping `β_h s K` added, `β_h = 2 ζ_h / ω_N` (`ω_N` the fastest mode of the
//! nonlinear subsystem with every contact open, `ζ_h` = [`HOMOTOPY_RATIO`]), for
//! `s = 1, ½, ¼, …` down to [`HOMOTOPY_LEVELS`] halvings, each stage from the previous
//! one; from every stage that converges Newton is tried on the model itself, and the first
//! stage from which it converges is the start. The caller's Newton repeats that last step,
//! so its iteration count is the cost at the model itself.

use super::{set_flow::SetFlow, GeneralMsHbm};
use crate::error::Result;
use crate::newton::{solve, NewtonOptions};
use crate::problem::PeriodicProblem;

/// Damping ratio `ζ_h` that the added damping gives the nonlinear subsystem's fastest mode
/// at the homotopy's first stage (`s = 1`).
pub const HOMOTOPY_RATIO: f64 = 0.1;

/// Stages of the homotopy after the first: `s = 2^{-1} … 2^{-HOMOTOPY_LEVELS}`.
pub const HOMOTOPY_LEVELS: usize = 8;

/// Newton iterations per attempt (the cold trial, each stage and each try on the model).
const ATTEMPT_ITERATIONS: usize = 50;

impl GeneralMsHbm {
    /// Newton iterations spent by the last [`PeriodicProblem::initial_guess`] after the
    /// pre-solve: the trial from the pre-solved start and, where it failed, the damping
    /// homotopy's stages and tries.
    pub fn guess_iterations(&self) -> usize {
        self.guess_iterations
    }

    /// Whether the last [`PeriodicProblem::initial_guess`] fell back to the damping
    /// homotopy (the trial from the pre-solved start did not converge).
    pub fn used_damping_homotopy(&self) -> bool {
        self.used_homotopy
    }

    /// `β_h = 2 ζ_h / ω_N` of the added damping `β_h s K` (see the module docs), `None`
    /// without a free mode.
    fn homotopy_beta(&self) -> Result<Option<f64>> {
        let sub = self.dense.as_ref().expect("event-driven");
        let fastest = SetFlow::new(sub, &[])?.fastest();
        Ok((fastest > 0.0).then(|| 2.0 * HOMOTOPY_RATIO / fastest))
    }

    /// The event-driven start at `ω` from the pre-solved start `x0`: `x0` itself when
    /// Newton converges from it, else the damping homotopy's stage from which it converges,
    /// else `x0` (the caller's Newton then fails as it would have).
    pub(super) fn robust_start(&mut self, x0: Vec<f64>, omega: f64) -> Result<Vec<f64>> {
        self.guess_iterations = 0;
        self.used_homotopy = false;
        let options = NewtonOptions {
            tolerance: 1e-10,
            max_iterations: ATTEMPT_ITERATIONS,
            ..Default::default()
        };
        let cold = solve(self, &x0, omega, &options)?;
        self.guess_iterations += cold.iterations;
        if cold.converged {
            return Ok(x0);
        }
        let (Some(source), Some(beta_h)) = (self.source.clone(), self.homotopy_beta()?) else {
            return Ok(x0);
        };
        self.used_homotopy = true;
        let (model, settings, limits) = &*source;
        let mut previous: Option<Vec<f64>> = None;
        for level in 0..=HOMOTOPY_LEVELS {
            let s = 0.5f64.powi(level as i32);
            let mut damped = model.clone();
            damped.damping.beta += s * beta_h;
            let mut stage = GeneralMsHbm::within(&damped, settings, limits)?;
            let start = match &previous {
                Some(x) => x.clone(),
                None => stage.presolved_start(omega)?,
            };
            if start.len() != self.dimension() {
                return Ok(x0);
            }
            let out = solve(&mut stage, &start, omega, &options)?;
            self.guess_iterations += out.iterations;
            if !out.converged {
                continue;
            }
            let attempt = solve(self, &out.x, omega, &options)?;
            self.guess_iterations += attempt.iterations;
            if attempt.converged {
                return Ok(out.x);
            }
            previous = Some(out.x);
        }
        Ok(x0)
    }
}
