//! How many threads a call may use: `threads=None` runs on rayon's global pool (all
//! cores), `threads=n` on a pool of `n` threads built for the call, so that a study running
//! one diagram per worker does not oversubscribe the cores. The library's parallel parts
//! (rayon, and faer, which runs its parallel kernels on the current rayon pool) all run in
//! that pool. Every call can be stopped by Ctrl-C on Python's main thread ([`interruptible`]).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::time::Duration;

use mshbm::limits::Cancel;
use pyo3::prelude::*;

use crate::errors::argument;

/// Run `f` on `threads` threads (all cores when `None`).
pub fn with_threads<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> PyResult<T> {
    match threads {
        None => Ok(f()),
        Some(0) => Err(argument(
            "threads must be at least 1 (or None for all cores)",
        )),
        Some(n) => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| argument(format!("threads={n}: cannot start the thread pool: {e}")))?;
            Ok(pool.install(f))
        }
    }
}

/// The stop request of the calls made on Python's main thread, the only thread Python
/// delivers Ctrl-C to. Such calls never overlap: each waits for its computation, which runs
/// on a helper thread (a callback of it, run there, that calls mshbm again is not on the
/// main thread).
static MAIN_THREAD_STOP: AtomicBool = AtomicBool::new(false);

/// How often the main thread looks for Ctrl-C while a computation runs.
const SIGNAL_POLL: Duration = Duration::from_millis(20);

/// Run `f` with the GIL released on `threads` threads ([`with_threads`]), handing it the stop
/// request it passes to the library (`Limits::cancel`, `Integrator::cancel_on`). On Python's
/// main thread the computation runs on a helper thread while this one checks for signals
/// every [`SIGNAL_POLL`]: a `KeyboardInterrupt` (or another signal handler's exception)
/// sets the request, waits for the library to stop at its next check, and is raised —
/// whatever the computation returned. On any other thread `f` runs here with a request that
/// never stops (Python delivers signals to the main thread only).
pub fn interruptible<T: Send>(
    py: Python<'_>,
    threads: Option<usize>,
    f: impl FnOnce(Cancel) -> T + Send,
) -> PyResult<T> {
    let threading = py.import("threading")?;
    let main = threading
        .call_method0("current_thread")?
        .is(&threading.call_method0("main_thread")?);
    if !main {
        return py.detach(|| with_threads(threads, || f(Cancel::NEVER)));
    }
    MAIN_THREAD_STOP.store(false, Ordering::SeqCst);
    let cancel = Cancel::on(&MAIN_THREAD_STOP);
    let (outcome, signal) = py.detach(|| {
        std::thread::scope(|scope| {
            let (done, finished) = mpsc::channel::<()>();
            let worker = scope.spawn(move || {
                let result = with_threads(threads, || f(cancel));
                let _ = done.send(());
                result
            });
            let mut signal = None;
            while let Err(RecvTimeoutError::Timeout) = finished.recv_timeout(SIGNAL_POLL) {
                if signal.is_none() {
                    if let Err(e) = Python::attach(|py| py.check_signals()) {
                        MAIN_THREAD_STOP.store(true, Ordering::SeqCst);
                        signal = Some(e);
                    }
                }
            }
            (worker.join(), signal)
        })
    });
    match (outcome, signal) {
        (_, Some(e)) => Err(e),
        (Ok(result), None) => result,
        (Err(panic), None) => std::panic::resume_unwind(panic),
    }
}
