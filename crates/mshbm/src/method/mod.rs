//! Periodic-solution methods, each an implementor of [`crate::problem::PeriodicProblem`].

pub mod hbm_aft;
pub mod redistributed;
pub mod shooting;

use crate::error::{Error, Result};
use crate::harmonic::n_coefficients;

/// Check the settings every method shares: at least one harmonic, and enough samples
/// (`what`: "samples" or "steps per period") to resolve them (`≥ 2H + 1`).
pub(crate) fn check_resolution(harmonics: usize, samples: usize, what: &str) -> Result<()> {
    if harmonics == 0 {
        return Err(Error::argument("harmonics", "must be at least 1"));
    }
    if samples < n_coefficients(harmonics) {
        return Err(Error::argument(
            "samples",
            format!(
                "{samples} {what} cannot resolve {harmonics} harmonics: need at least 2H+1 = {}",
                n_coefficients(harmonics)
            ),
        ));
    }
    Ok(())
}

/// A frequency (rad/s) must be finite and positive; the message is in Hz.
pub(crate) fn check_frequency(omega: f64) -> Result<()> {
    if omega.is_finite() && omega > 0.0 {
        return Ok(());
    }
    Err(Error::argument(
        "frequency",
        format!(
            "must be positive, got {} Hz",
            omega / (2.0 * std::f64::consts::PI)
        ),
    ))
}
