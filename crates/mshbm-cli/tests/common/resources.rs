//! Running `mshbm` as a child whose CPU time and peak memory are measured by the kernel
//! (`wait4`'s rusage), not by the wall clock, so that a loaded machine does not decide a
//! test: the acceptance of issue 15 is "a clean error within 1 s and 200 MB".

use std::fs::File;
use std::path::Path;
use std::process::{Command, Stdio};

/// What a measured run did.
pub struct Measured {
    /// Exit status, or `128 + signal` when killed by a signal.
    pub status: i32,
    pub stdout: String,
    pub stderr: String,
    /// User + system CPU time [s].
    pub cpu_seconds: f64,
    /// Peak resident memory [MB].
    pub max_rss_mb: f64,
}

/// Run `command` to completion (stdout and stderr into files in `scratch`, stdin empty)
/// and measure it.
#[allow(clippy::zombie_processes)] // reaped by wait4 in wait_with_usage
pub fn run_measured(mut command: Command, scratch: &Path) -> Measured {
    let out_path = scratch.join("measured.stdout");
    let err_path = scratch.join("measured.stderr");
    let child = command
        .stdin(Stdio::null())
        .stdout(File::create(&out_path).unwrap())
        .stderr(File::create(&err_path).unwrap())
        .spawn()
        .unwrap();
    let (status, usage) = wait_with_usage(child.id() as i32);
    let measured = Measured {
        status,
        stdout: std::fs::read_to_string(&out_path).unwrap_or_default(),
        stderr: std::fs::read_to_string(&err_path).unwrap_or_default(),
        cpu_seconds: usage.0,
        max_rss_mb: usage.1,
    };
    let _ = std::fs::remove_file(out_path);
    let _ = std::fs::remove_file(err_path);
    measured
}

/// Reap `pid`: (exit status or 128 + signal, (CPU seconds, peak RSS in MB)).
pub fn wait_with_usage(pid: i32) -> (i32, (f64, f64)) {
    let mut status = 0;
    let mut usage = std::mem::MaybeUninit::<libc::rusage>::zeroed();
    // SAFETY: `pid` is our child; wait4 fills `status` and `usage`.
    let rc = unsafe { libc::wait4(pid, &mut status, 0, usage.as_mut_ptr()) };
    assert_eq!(rc, pid, "wait4 failed");
    // SAFETY: initialised by the successful call.
    let usage = unsafe { usage.assume_init() };
    let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    let code = if libc::WIFEXITED(status) {
        libc::WEXITSTATUS(status)
    } else {
        128 + libc::WTERMSIG(status)
    };
    (
        code,
        (
            seconds(usage.ru_utime) + seconds(usage.ru_stime),
            usage.ru_maxrss as f64 / 1024.0,
        ),
    )
}

impl Measured {
    /// A refusal as the issue asks: non-zero status, one `error: ` line on stderr that
    /// contains each of `words`, no panic, within 1 s of CPU and 200 MB.
    pub fn assert_clean_refusal(&self, words: &[&str]) {
        assert_ne!(self.status, 0, "expected failure; stderr: {}", self.stderr);
        assert!(!self.stderr.contains("panicked"), "{}", self.stderr);
        let lines: Vec<&str> = self
            .stderr
            .lines()
            .filter(|l| !l.trim().is_empty())
            .collect();
        assert_eq!(lines.len(), 1, "one error line: {}", self.stderr);
        assert!(lines[0].starts_with("error: "), "{}", self.stderr);
        for w in words {
            assert!(lines[0].contains(w), "{w:?} in {}", self.stderr);
        }
        assert!(
            self.cpu_seconds < 1.0,
            "CPU time {} s: {}",
            self.cpu_seconds,
            self.stderr
        );
        assert!(
            self.max_rss_mb < 200.0,
            "peak memory {} MB",
            self.max_rss_mb
        );
    }
}

/// A spawned child that is killed (and reaped) when the guard is dropped before
/// [`ChildGuard::wait`] — a failing test leaves no process behind.
pub struct ChildGuard(Option<std::process::Child>);

impl ChildGuard {
    pub fn new(child: std::process::Child) -> Self {
        ChildGuard(Some(child))
    }

    pub fn id(&self) -> u32 {
        self.0.as_ref().map_or(0, |c| c.id())
    }

    /// Whether the child has ended (reaped then: the status is returned).
    pub fn try_wait(&mut self) -> Option<std::process::ExitStatus> {
        let status = self.0.as_mut()?.try_wait().ok().flatten();
        if status.is_some() {
            self.0 = None;
        }
        status
    }

    /// Reap the child: (exit status or 128 + signal, (CPU seconds, peak RSS in MB)).
    #[allow(clippy::zombie_processes)] // reaped by wait4 in wait_with_usage
    pub fn wait(mut self) -> (i32, (f64, f64)) {
        let child = self.0.take().expect("not reaped");
        wait_with_usage(child.id() as i32)
    }
}

impl Drop for ChildGuard {
    fn drop(&mut self) {
        if let Some(mut c) = self.0.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}
