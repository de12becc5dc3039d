//! SIGINT and SIGTERM: the first signal sets a flag that long runs check at their natural
//! checkpoints (`frf` after each point, `simulate` after each step, every command before
//! it writes a file) and that the library checks inside its long computations (Newton's
//! iterations, a method's set-up phases, the eigensolvers' phases: [`cancel`], given to
//! the library as `Limits::cancel`); they then finish what they stream with an "incomplete"
//! marker, write nothing else and exit with status 130. A command that streams no CSV and
//! reaches no checkpoint within [`GRACE`] of the signal (an assembly, a dense product) is stopped
//! then, as by a second signal. A second signal removes every temporary output file still
//! registered and exits at once.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use anyhow::Result;

use super::status::{Interrupted, INTERRUPTED};

/// The first signal received (0: none).
static SIGNAL: AtomicI32 = AtomicI32::new(0);

/// Set by the first signal: the library's cancellation request (`Limits::cancel`).
static CANCEL: AtomicBool = AtomicBool::new(false);

/// Whether the command streams a CSV (`frf`, `simulate`): then it is never stopped by the
/// watchdog, whose exit would lose the rows found; its own checkpoints finish the file.
static STREAMING: AtomicBool = AtomicBool::new(false);

/// How long a command that streams nothing has, after the first signal, to stop at a
/// checkpoint of its own before it is stopped at once.
pub const GRACE: Duration = Duration::from_millis(500);

/// Temporary files being written, removed by a second signal.
static TEMPORARIES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The library's cancellation request: set by the first SIGINT or SIGTERM.
pub fn cancel() -> mshbm::limits::Cancel {
    mshbm::limits::Cancel::on(&CANCEL)
}

/// The command streams a CSV from now on (the watchdog leaves it to its checkpoints).
pub(super) fn streaming() {
    STREAMING.store(true, Ordering::SeqCst);
}

/// After the first signal: stop the process once [`GRACE`] has passed, unless the command
/// streams a CSV or has ended by then.
fn watchdog(signal: i32) {
    let start = Instant::now();
    while start.elapsed() < GRACE {
        std::thread::sleep(Duration::from_millis(20));
    }
    if STREAMING.load(Ordering::SeqCst) {
        return;
    }
    remove_temporaries();
    crate::note!(
        "error: interrupted by {}: stopped {:.1} s after the signal, inside a computation that cannot stop itself sooner; nothing more was written (temporary files removed)",
        name(signal),
        start.elapsed().as_secs_f64()
    );
    std::process::exit(i32::from(INTERRUPTED));
}

/// Install the handlers (once, at start-up): a thread waits for the signals.
#[cfg(unix)]
pub fn install() -> Result<()> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    use signal_hook::iterator::Signals;
    let mut signals = Signals::new([SIGINT, SIGTERM])?;
    std::thread::spawn(move || {
        for signal in signals.forever() {
            if SIGNAL
                .compare_exchange(0, signal, Ordering::SeqCst, Ordering::SeqCst)
                .is_ok()
            {
                CANCEL.store(true, Ordering::SeqCst);
                std::thread::spawn(move || watchdog(signal));
            } else {
                remove_temporaries();
                crate::note!(
                    "error: interrupted twice by {}: temporary files removed, stopped at once",
                    name(signal)
                );
                std::process::exit(i32::from(INTERRUPTED));
            }
        }
    });
    Ok(())
}

#[cfg(not(unix))]
pub fn install() -> Result<()> {
    Ok(())
}

fn name(signal: i32) -> &'static str {
    #[cfg(unix)]
    {
        match signal {
            signal_hook::consts::SIGINT => "SIGINT",
            signal_hook::consts::SIGTERM => "SIGTERM",
            _ => "a signal",
        }
    }
    #[cfg(not(unix))]
    {
        let _ = signal;
        "a signal"
    }
}

/// The name of the signal that asked the run to stop, if any.
pub fn requested() -> Option<&'static str> {
    match SIGNAL.load(Ordering::SeqCst) {
        0 => None,
        s => Some(name(s)),
    }
}

/// An [`Interrupted`] error when a signal asked the run to stop; `what` says what happens
/// to the outputs (e.g. "nothing was written").
pub fn check(what: &str) -> Result<()> {
    match requested() {
        Some(signal) => Err(Interrupted(format!("interrupted by {signal}: {what}")).into()),
        None => Ok(()),
    }
}

/// Register a temporary file (removed by a second signal).
pub(super) fn register(path: &Path) {
    if let Ok(mut list) = TEMPORARIES.lock() {
        list.push(path.to_path_buf());
    }
}

/// Forget a temporary file (renamed into place, or removed).
pub(super) fn unregister(path: &Path) {
    if let Ok(mut list) = TEMPORARIES.lock() {
        list.retain(|p| p != path);
    }
}

/// Remove every registered temporary file.
pub fn remove_temporaries() {
    // `try_lock`: the lock may be held by the thread this one is about to stop
    let paths = match TEMPORARIES.try_lock() {
        Ok(mut list) => std::mem::take(&mut *list),
        Err(_) => return,
    };
    for p in paths {
        let _ = std::fs::remove_file(p);
    }
}

/// Stop the process at once with `status` after removing every registered temporary file,
/// printing `message` as the error line: for callbacks that cannot return an error (a
/// time integration's step observer).
pub fn exit_now(status: u8, message: &str) -> ! {
    remove_temporaries();
    crate::note!("error: {message}");
    std::process::exit(i32::from(status))
}
