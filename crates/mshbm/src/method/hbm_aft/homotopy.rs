//! The initial guess of the HBM-AFT for a stiff penalty: a homotopy in the penalty stiffness
//! from the linear response (docs/theory.md §7).

use super::HbmAft;
use crate::error::Result;

impl HbmAft {
    /// Newton iterations spent by the last [`crate::problem::PeriodicProblem::initial_guess`]
    /// (the penalty homotopy; 0 when it returned the linear response).
    pub fn guess_iterations(&self) -> usize {
        self.guess_iterations
    }

    /// Starting point at `ω` for a stiff penalty. From the linear response directly, Newton
    /// on the kinked residual of a stiff penalty (`k_p ≳ 10 k_c` on the paper's bar) cycles
    /// between contact states of the samples, so this is a homotopy in the penalty, as a
    /// user would do by hand (docs/theory.md (T55)): Newton solutions for penalties growing
    /// tenfold from `0.1 k_c`,
    /// each started from the previous one (a stage that fails is retried with a smaller
    /// increase). It returns the solution of the stage *before* `k_p`, once the step from
    /// it to `k_p` has been seen to converge: the caller's Newton then repeats that last
    /// step, so its iteration count shows the cost at `k_p`, and it converges. If the
    /// homotopy gets stuck, the last converged point is returned.
    pub fn penalty_homotopy(&mut self, omega: f64) -> Result<Vec<f64>> {
        self.guess_iterations = 0;
        let linear = self.linear_response(omega)?;
        let start = self
            .penalty
            .iter()
            .zip(&self.contact_stiffness)
            .map(|(kp, kc)| 0.1 * kc / kp)
            .fold(1.0f64, f64::min);
        if start >= 1.0 || self.sample_penetration(&linear)?.iter().all(|&p| p <= 0.0) {
            return Ok(linear);
        }
        let target = self.penalty.clone();
        // the Jenkins elements' tangential penalties (docs/theory.md (T161)) grow with them
        let tangential = self.jenkins.as_ref().map(|j| j.stiffness.clone());
        let options = crate::newton::NewtonOptions {
            tolerance: 1e-10,
            max_iterations: 50,
            ..Default::default()
        };
        // (factor, solution) of the last converged stage; the linear response is "stage 0"
        let (mut current, mut x) = (0.0f64, linear);
        let mut next = start;
        let mut ratio = 10.0f64;
        let result = loop {
            self.penalty = target.iter().map(|kp| kp * next).collect();
            if let (Some(j), Some(kt)) = (self.jenkins.as_mut(), &tangential) {
                j.stiffness = kt.iter().map(|k| k * next).collect();
            }
            let out = match crate::newton::solve(self, &x, omega, &options) {
                Ok(o) => o,
                Err(e) => break Err(e),
            };
            self.guess_iterations += out.iterations;
            if out.converged {
                if next >= 1.0 {
                    break Ok(());
                }
                (current, x) = (next, out.x);
            } else {
                ratio = ratio.sqrt();
                if ratio < 1.2 || current == 0.0 {
                    break Ok(());
                }
            }
            next = (current * ratio).min(1.0);
        };
        self.penalty = target;
        if let (Some(j), Some(kt)) = (self.jenkins.as_mut(), tangential) {
            j.stiffness = kt;
        }
        result.map(|_| x)
    }
}
