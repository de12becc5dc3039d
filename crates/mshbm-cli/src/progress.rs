//! Progress of long single computations on stderr: quiet for the first second, then one line
//! per Newton iteration (the library reports iterations through
//! [`mshbm::newton::NewtonObserver`]; it never prints).

use std::time::{Duration, Instant};

use mshbm::newton::NewtonObserver;

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
