//! Exit statuses of `mshbm`: 0 when the command did what it was asked, 1 on an error
//! (nothing, or only what is said, was written), 2 when the results were computed and
//! written but are not what was asked for (Newton did not converge, the simulation did not
//! become periodic, a continuation branch stopped early), 130 when interrupted by SIGINT
//! or SIGTERM. The errors below carry the non-default statuses through `anyhow`.

use std::fmt;

/// Exit status of a command that completed.
pub const SUCCESS: u8 = 0;
/// Exit status of an error.
pub const ERROR: u8 = 1;
/// Exit status of results computed and written but not converged (or not periodic, or a
/// branch that stopped early): every output says so.
pub const NOT_CONVERGED: u8 = 2;
/// Exit status of a run interrupted by SIGINT or SIGTERM (128 + 2, the shell's convention).
pub const INTERRUPTED: u8 = 130;

/// The results were written but are not converged; the message says why and where.
#[derive(Debug)]
pub struct NotConverged(pub String);

impl fmt::Display for NotConverged {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for NotConverged {}

/// The run was interrupted by a signal; the message says what was written.
#[derive(Debug)]
pub struct Interrupted(pub String);

impl fmt::Display for Interrupted {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Interrupted {}

/// The exit status of a command's result.
pub fn exit_status(result: &anyhow::Result<()>) -> u8 {
    match result {
        Ok(()) => SUCCESS,
        Err(e) if e.downcast_ref::<Interrupted>().is_some() || is_cancelled(e) => INTERRUPTED,
        Err(e) if e.downcast_ref::<NotConverged>().is_some() => NOT_CONVERGED,
        Err(_) => ERROR,
    }
}

/// The library stopped because the run was interrupted (`mshbm::Error::Cancelled`, the
/// answer to `Limits::cancel`).
pub fn is_cancelled(e: &anyhow::Error) -> bool {
    matches!(
        e.downcast_ref::<mshbm::Error>(),
        Some(mshbm::Error::Cancelled)
    )
}
