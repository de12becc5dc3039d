//! How many threads a call may use: `threads=None` runs on rayon's global pool (all
//! cores), `threads=n` on a pool of `n` threads built for the call, so that a study running
//! one diagram per worker does not oversubscribe the cores. The library's parallel parts
//! (rayon, and faer, which runs its parallel kernels on the current rayon pool) all run in
//! that pool.

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
