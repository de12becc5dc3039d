//! Progress of long single computations on stderr: quiet for the first second, then one line
//! per Newton iteration, at most one per second along a traced branch, and one per second
//! while a set-up phase runs (the library reports through [`mshbm::newton::NewtonObserver`],
//! [`mshbm::solve::BranchObserver`] and [`mshbm::method::SetupObserver`]; it never prints).

use std::time::{Duration, Instant};

use mshbm::method::SetupObserver;
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
        // a signal stops the continuation at its next point (nothing is written then)
        if let Some(signal) = crate::output::interrupt::requested() {
            return Err(mshbm::Error::InvalidArgument {
                name: "run".into(),
                message: format!("interrupted by {signal}"),
            });
        }
        let elapsed = start.elapsed();
        let Ok(mut last) = last.lock() else {
            return Ok(());
        };
        if elapsed >= QUIET_FOR && elapsed - *last >= Duration::from_secs(1) {
            *last = elapsed;
            crate::note!(
                "continuation: point {points} at {hz:.2} Hz (toward {toward_hz:.2} Hz, {:.1} s)",
                elapsed.as_secs_f64()
            );
        }
        Ok(())
    })
}

/// Progress of a run to a periodic steady state after each period: on a terminal the
/// message of its progress `bar`; otherwise (a log, a pipe) once the run has lasted more
/// than a second, one line per second at most,
/// `steady state: period p: period-to-period change c (t s)`.
pub fn period_progress(bar: Option<&indicatif::ProgressBar>) -> impl FnMut(usize, f64) + '_ {
    let start = Instant::now();
    let mut last = Duration::ZERO;
    move |period, change| match bar {
        Some(bar) => bar.set_message(format!("period {period}: change {change:.2e}")),
        None => {
            let elapsed = start.elapsed();
            if elapsed >= QUIET_FOR && elapsed - last >= Duration::from_secs(1) {
                last = elapsed;
                crate::note!(
                    "steady state: period {period}: period-to-period change {change:.2e} ({:.1} s)",
                    elapsed.as_secs_f64()
                );
            }
        }
    }
}

/// The set-up phase running, since when, and whether a watcher prints it.
struct SetupState {
    phase: Option<String>,
    phase_started: Instant,
    watching: bool,
}

/// An observer of a method's set-up: while a phase runs for more than a second (modes of a
/// large model, its factorizations), `set-up: <phase> (t s)` once per second. A watcher
/// thread does the printing (the library is busy inside the phase), started by a set-up's
/// first phase and ended when that set-up is done.
pub fn setup_progress() -> SetupObserver {
    let state = std::sync::Arc::new(std::sync::Mutex::new(SetupState {
        phase: None,
        phase_started: Instant::now(),
        watching: false,
    }));
    SetupObserver::new(move |phase| {
        let Ok(mut s) = state.lock() else { return };
        s.phase = phase.map(str::to_string);
        s.phase_started = Instant::now();
        if phase.is_some() && !s.watching {
            s.watching = true;
            let state = std::sync::Arc::clone(&state);
            std::thread::spawn(move || watch_setup(&state));
        }
    })
}

fn watch_setup(state: &std::sync::Mutex<SetupState>) {
    let mut last: Option<Instant> = None;
    loop {
        std::thread::sleep(Duration::from_millis(100));
        let Ok(mut s) = state.lock() else { return };
        let Some(phase) = &s.phase else {
            s.watching = false;
            return;
        };
        let in_phase = s.phase_started.elapsed();
        if in_phase >= QUIET_FOR && last.is_none_or(|t| t.elapsed() >= Duration::from_secs(1)) {
            last = Some(Instant::now());
            crate::note!("set-up: {phase} ({:.0} s)", in_phase.as_secs_f64());
        }
    }
}
