//! Progress of long single computations on stderr: quiet for the first second, then one line
//! per Newton iteration and at most one per second along a traced branch (the library
//! reports through [`mshbm::newton::NewtonObserver`] and [`mshbm::solve::BranchObserver`];
//! it never prints).

use std::time::{Duration, Instant};

use mshbm::newton::NewtonObserver;
use mshbm::solve::BranchObserver;

/// Solves that end within this time print nothing.
const QUIET_FOR: Duration = Duration::from_secs(1);

/// An observer printing `Newton iteration k: residual r (t s)` on stderr once the solve has
/// run for more than a second (a solve with many harmonics can take minutes).
pub fn newton_progress() -> NewtonObserver {
    let start = Instant::now();
    NewtonObserver::new(move |iteration, residual| {
        let elapsed = start.elapsed();
        if elapsed >= QUIET_FOR {
            crate::note!(
                "Newton iteration {iteration}: residual {residual:.3e} ({:.1} s)",
                elapsed.as_secs_f64()
            );
        }
    })
}

/// An observer of the branch a solve traces (its fallback continuation or `--sweep-from`):
/// once the solve has run for more than a second, one line per second at most,
/// `continuation: point n at f Hz (toward g Hz, t s)`.
pub fn branch_progress() -> BranchObserver {
    let start = Instant::now();
    let last = std::sync::Mutex::new(Duration::ZERO);
    BranchObserver::new(move |hz, points, toward_hz| {
        let elapsed = start.elapsed();
        let Ok(mut last) = last.lock() else { return };
        if elapsed >= QUIET_FOR && elapsed - *last >= Duration::from_secs(1) {
            *last = elapsed;
            crate::note!(
                "continuation: point {points} at {hz:.2} Hz (toward {toward_hz:.2} Hz, {:.1} s)",
                elapsed.as_secs_f64()
            );
        }
    })
}
