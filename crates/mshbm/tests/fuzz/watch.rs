//! What `catch_unwind` cannot catch: an input that runs too long (a watchdog thread) and
//! one whose peak resident memory is too large (`VmHWM`, reset per input).

use super::show;

/// A thread that ends the process (status 3) when one input runs longer than its limit,
/// naming the target, the case and the input: a hang is a finding that `catch_unwind`
/// cannot catch.
pub struct Watchdog {
    state: std::sync::Arc<std::sync::Mutex<Option<Running>>>,
}

struct Running {
    target: String,
    case: u64,
    seed: u64,
    started: std::time::Instant,
    input: Vec<u8>,
}

impl Watchdog {
    pub fn new(limit: std::time::Duration) -> Self {
        let state = std::sync::Arc::new(std::sync::Mutex::new(None::<Running>));
        let watched = state.clone();
        std::thread::spawn(move || loop {
            std::thread::sleep(std::time::Duration::from_millis(50));
            let guard = watched.lock().unwrap_or_else(|e| e.into_inner());
            if let Some(r) = guard.as_ref() {
                if r.started.elapsed() > limit {
                    eprintln!(
                        "HANG: target {} case {} (seed {}) still running after {:?} on input {}",
                        r.target,
                        r.case,
                        r.seed,
                        limit,
                        show(&r.input)
                    );
                    std::process::exit(3);
                }
            }
        });
        Watchdog { state }
    }

    /// An input starts.
    pub fn begin(&self, target: &str, case: u64, seed: u64, input: &[u8]) {
        *self.state.lock().unwrap_or_else(|e| e.into_inner()) = Some(Running {
            target: target.to_string(),
            case,
            seed,
            started: std::time::Instant::now(),
            input: input.to_vec(),
        });
    }

    /// The input ended.
    pub fn end(&self) {
        *self.state.lock().unwrap_or_else(|e| e.into_inner()) = None;
    }
}

/// The process's peak resident set since the last [`reset_peak_rss`] [bytes], from
/// `VmHWM` of `/proc/self/status` (`None` where there is none).
pub fn peak_rss() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Reset the peak resident set to the current one (writing 5 to
/// `/proc/self/clear_refs`), so that [`peak_rss`] measures the next input alone; `false`
/// where that is not possible.
pub fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}
