//! Running the parts of `mshbm paper` as jobs on a few threads, with progress lines on
//! stderr.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use anyhow::{anyhow, Result};

use mshbm::frd::{FrdObserver, PointEvent};

/// A named part producing a `T`; the name starts with "Fig. N" (see [`figure_of`]).
pub(crate) struct Job<'a, T> {
    pub name: String,
    pub work: Box<dyn FnOnce() -> Result<T> + Send + 'a>,
}

/// The figure number in a job name "Fig. N …".
pub(crate) fn figure_of(name: &str) -> u32 {
    name.strip_prefix("Fig. ")
        .and_then(|r| r.split(|c: char| !c.is_ascii_digit()).next())
        .and_then(|n| n.parse().ok())
        .unwrap_or(0)
}

/// The 1-minute load average (Linux), to qualify the measured run time on a shared machine.
pub(crate) fn load_average() -> Option<f64> {
    std::fs::read_to_string("/proc/loadavg")
        .ok()?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// CPU time (user + system) of this process so far [s], all threads: unlike the wall
/// clock, it does not depend on what else runs on the machine.
#[cfg(unix)]
pub(crate) fn cpu_seconds() -> Option<f64> {
    let mut usage = std::mem::MaybeUninit::<libc::rusage>::zeroed();
    // SAFETY: getrusage fills the struct it is given; RUSAGE_SELF is always valid.
    let rc = unsafe { libc::getrusage(libc::RUSAGE_SELF, usage.as_mut_ptr()) };
    if rc != 0 {
        return None;
    }
    // SAFETY: initialised by the successful call above.
    let usage = unsafe { usage.assume_init() };
    let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    Some(seconds(usage.ru_utime) + seconds(usage.ru_stime))
}

#[cfg(not(unix))]
pub(crate) fn cpu_seconds() -> Option<f64> {
    None
}

/// Progress lines on stderr, prefixed by the elapsed time.
pub(crate) struct Progress {
    start: Instant,
}

impl Progress {
    pub fn new() -> Self {
        Progress {
            start: Instant::now(),
        }
    }

    pub fn elapsed(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    pub fn line(&self, part: &str, message: &str) {
        crate::note!("[{:7.1} s] {part}: {message}", self.elapsed());
    }

    /// An observer of one continuation branch that prints where it is every few seconds.
    pub fn branch<'a>(&'a self, part: String) -> BranchLines<'a> {
        BranchLines {
            progress: self,
            part,
            last: Instant::now(),
            every: Duration::from_secs(5),
        }
    }
}

/// Progress of one branch: frequency reached and points found, every few seconds.
pub(crate) struct BranchLines<'a> {
    progress: &'a Progress,
    part: String,
    last: Instant,
    every: Duration,
}

impl FrdObserver for BranchLines<'_> {
    fn point(&mut self, event: &PointEvent<'_>) -> mshbm::Result<()> {
        let PointEvent { point, points, .. } = *event;
        if self.last.elapsed() >= self.every {
            self.last = Instant::now();
            self.progress.line(
                &self.part,
                &format!(
                    "{:.3} kHz reached, {points} points",
                    point.frequency_hz / 1e3
                ),
            );
        }
        Ok(())
    }
}

/// The result of one job: its name, its output and how long it ran [s].
pub(crate) type Done<T> = (String, Result<T>, f64);

/// Where a job's result and time wait for the job's turn in the output.
type Slot<T> = Mutex<Option<(Result<T>, f64)>>;

/// Run `jobs` on `threads` threads in the given order (put the longest first); a job that
/// fails or panics gives an error in its slot and the others go on. Results in job order.
pub(crate) fn run_jobs<T: Send>(
    jobs: Vec<Job<'_, T>>,
    threads: usize,
    progress: &Progress,
) -> Vec<Done<T>> {
    let names: Vec<String> = jobs.iter().map(|j| j.name.clone()).collect();
    let queue: Vec<Mutex<Option<Job<T>>>> = jobs.into_iter().map(|j| Mutex::new(Some(j))).collect();

    let results: Vec<Slot<T>> = (0..queue.len()).map(|_| Mutex::new(None)).collect();
    let next = AtomicUsize::new(0);
    std::thread::scope(|scope| {
        for _ in 0..threads.max(1).min(queue.len().max(1)) {
            scope.spawn(|| {
                // the parts are the parallelism: the library's parallel kernels (faer's, the
                // general MS-HBM's columns) run on a pool of this one thread; on the shared
                // pool they would contend with the other parts, mostly spinning
                let own_pool = (threads > 1)
                    .then(|| rayon::ThreadPoolBuilder::new().num_threads(1).build().ok())
                    .flatten();
                let run = |job: Job<T>| match &own_pool {
                    Some(pool) => pool.install(|| catch_unwind(AssertUnwindSafe(job.work))),
                    None => catch_unwind(AssertUnwindSafe(job.work)),
                };
                loop {
                    let i = next.fetch_add(1, Ordering::SeqCst);
                    if i >= queue.len() {
                        break;
                    }
                    let Some(job) = queue[i].lock().map(|mut j| j.take()).ok().flatten() else {
                        continue;
                    };
                    let t0 = Instant::now();
                    progress.line(&job.name, "started");
                    let name = job.name.clone();
                    let result =
                        run(job).unwrap_or_else(|_| Err(anyhow!("internal error (panic)")));
                    match &result {
                        Ok(_) => progress.line(
                            &name,
                            &format!("finished in {:.1} s", t0.elapsed().as_secs_f64()),
                        ),
                        Err(e) => progress.line(&name, &format!("FAILED: {e:#}")),
                    }
                    if let Ok(mut slot) = results[i].lock() {
                        *slot = Some((result, t0.elapsed().as_secs_f64()));
                    }
                }
            });
        }
    });
    names
        .into_iter()
        .zip(results)
        .map(|(name, slot)| {
            let (r, seconds) = slot
                .into_inner()
                .ok()
                .flatten()
                .unwrap_or_else(|| (Err(anyhow!("not run")), 0.0));
            (name, r, seconds)
        })
        .collect()
}
