//! Resource limits: how much memory a computation may plan to use and how large an input
//! file may be. Every size that comes from user input (elements, DOFs, harmonics, samples,
//! declared matrix sizes, file lengths) is checked against these limits with checked
//! arithmetic **before** anything is allocated, so that a tiny input cannot exhaust the
//! machine; the error says what was asked, what it would need and how to raise the limit.

use std::io::Read;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::error::{Error, Result};

mod machine;
pub use machine::{
    available_memory_bytes, physical_memory_bytes, usable_machine_memory_bytes, MACHINE_SHARE,
};

/// Bytes in a gibibyte.
pub const GIB: u64 = 1 << 30;

/// Memory assumed when the machine's memory cannot be read (not Linux).
const FALLBACK_MEMORY_BYTES: u64 = 8 * GIB;

/// Default largest input file (Matrix Market file, coordinates, vectors).
pub const DEFAULT_MAX_FILE_BYTES: u64 = GIB;

/// Largest model file (TOML) that is read: 4 MiB. A model file describes a model and names
/// the files that hold its data (matrices, coordinates, contacts); the TOML parser needs
/// about 50 times the file's size (measured: 700 MB for a 13 MB array), so a larger file is
/// refused before it is parsed, naming the file.
pub const MAX_MODEL_FILE_BYTES: u64 = 4 << 20;

/// Peak memory of parsing a TOML model file per byte of the file (measured: 52 bytes).
pub const TOML_BYTES_PER_FILE_BYTE: u64 = 64;

/// The name of the helper thread on which [`Cancel::wait_for`] runs a call that cannot
/// check the request itself (visible in `/proc/PID/task/*/comm`).
pub const UNINTERRUPTIBLE_THREAD: &str = "mshbm-uninterr";

/// A request to stop a long computation, given by the caller (the CLI sets it on SIGINT or
/// SIGTERM; the library knows nothing of signals). Long loops (Newton's iterations and line
/// search, the set-up phases of a method, the iterations of an eigensolver) check it and
/// return [`Error::Cancelled`]. The default never cancels.
#[derive(Clone, Copy, Default)]
pub struct Cancel(Option<&'static AtomicBool>);

impl Cancel {
    /// Never cancels.
    pub const NEVER: Cancel = Cancel(None);

    /// Cancels once `flag` is set.
    pub fn on(flag: &'static AtomicBool) -> Self {
        Cancel(Some(flag))
    }

    /// Whether the caller asked to stop.
    pub fn requested(&self) -> bool {
        self.0.is_some_and(|f| f.load(Ordering::Relaxed))
    }

    /// [`Error::Cancelled`] once the caller asked to stop.
    pub fn check(&self) -> Result<()> {
        if self.requested() {
            Err(Error::Cancelled)
        } else {
            Ok(())
        }
    }

    /// Run `work`, a long call that cannot check this request itself (a sparse
    /// factorization of a 3D model takes tens of seconds), so that the caller can stop
    /// waiting for it: with a request that can cancel, `work` runs on a helper thread named
    /// [`UNINTERRUPTIBLE_THREAD`] while this thread checks the request every 20 ms and
    /// returns [`Error::Cancelled`] as soon as it is set. The abandoned call then finishes
    /// on its own thread and its result is dropped (a process that exits on the
    /// cancellation, as the CLI does, ends it at once). [`Cancel::NEVER`] runs `work` here.
    pub fn wait_for<T: Send + 'static>(
        self,
        work: impl FnOnce() -> T + Send + 'static,
    ) -> Result<T> {
        if self.0.is_none() {
            return Ok(work());
        }
        self.check()?;
        let (send, receive) = std::sync::mpsc::sync_channel(1);
        std::thread::Builder::new()
            .name(UNINTERRUPTIBLE_THREAD.into())
            // the main thread's stack size: a factorization may recurse
            .stack_size(8 << 20)
            .spawn(move || {
                // the receiver is gone when the caller stopped waiting
                let _ = send.send(work());
            })
            .map_err(|e| Error::Numerical(format!("cannot start a helper thread: {e}")))?;
        loop {
            match receive.recv_timeout(std::time::Duration::from_millis(20)) {
                Ok(result) => return Ok(result),
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => self.check()?,
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                    return Err(Error::Numerical(
                        "a helper thread ended without a result (it panicked)".into(),
                    ))
                }
            }
        }
    }

    /// This request, or `other` when this one never cancels.
    pub fn or(self, other: Cancel) -> Cancel {
        if self.0.is_some() {
            self
        } else {
            other
        }
    }
}

impl PartialEq for Cancel {
    fn eq(&self, other: &Self) -> bool {
        match (self.0, other.0) {
            (None, None) => true,
            (Some(a), Some(b)) => std::ptr::eq(a, b),
            _ => false,
        }
    }
}

impl Eq for Cancel {}

impl std::fmt::Debug for Cancel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.0 {
            None => f.write_str("Cancel::NEVER"),
            Some(flag) => write!(f, "Cancel({})", flag.load(Ordering::Relaxed)),
        }
    }
}

/// The limits a computation is checked against. The defaults are the memory this process
/// may use ([`available_memory_bytes`]: the smallest of the machine's physical memory, the
/// `RLIMIT_AS`/`RLIMIT_DATA` resource limits and the cgroup's memory limit) and 1 GiB per
/// input file; the CLI raises or lowers the memory with `--max-memory`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Largest memory [bytes] a computation may plan to allocate.
    pub memory_bytes: u64,
    /// Largest input file [bytes] that is read.
    pub file_bytes: u64,
    /// The caller's request to stop (default: never).
    pub cancel: Cancel,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            memory_bytes: available_memory_bytes(),
            file_bytes: DEFAULT_MAX_FILE_BYTES,
            cancel: Cancel::NEVER,
        }
    }
}

impl Limits {
    /// Limits with the memory budget set to `gib` gibibytes (file limit unchanged).
    pub fn with_memory_gib(self, gib: f64) -> Self {
        Limits {
            memory_bytes: (gib.max(0.0) * GIB as f64) as u64,
            ..self
        }
    }

    /// Check that `what` (e.g. "the dense Jacobian of 4000 unknowns"), estimated to need
    /// `bytes` (`None` when the estimate itself overflowed), fits the memory budget.
    pub fn check_memory(&self, what: &str, bytes: Option<u64>) -> Result<()> {
        match bytes {
            Some(b) if b <= self.memory_bytes => Ok(()),
            _ => Err(Error::ResourceLimit {
                what: what.to_string(),
                needed: bytes.map_or_else(|| "more than 2^64 bytes".to_string(), human_bytes),
                limit: human_bytes(self.memory_bytes),
            }),
        }
    }

    /// Check the memory of `count` items of `item_bytes` bytes each (`count · item_bytes`
    /// with checked arithmetic).
    pub fn check_items(&self, what: &str, count: u64, item_bytes: u64) -> Result<()> {
        self.check_memory(what, count.checked_mul(item_bytes))
    }
}

/// Bytes of `rows × cols` dense `f64` entries, `None` on overflow.
pub fn dense_f64_bytes(rows: usize, cols: usize) -> Option<u64> {
    (rows as u64).checked_mul(cols as u64)?.checked_mul(8)
}

/// A byte count for messages: "1.5 GiB", "12.0 MiB", "800 B".
pub fn human_bytes(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["KiB", "MiB", "GiB", "TiB", "PiB"];
    if bytes < 1024 {
        return format!("{bytes} B");
    }
    let mut value = bytes as f64 / 1024.0;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    format!("{value:.1} {}", UNITS[unit])
}

/// Read a text input file: only regular files (never a device, FIFO or directory, which
/// could be endless or block), at most `limits.file_bytes` bytes, valid UTF-8.
///
/// The path is checked with `stat` before it is opened, so a device or a FIFO is refused
/// without opening it (opening a FIFO for reading blocks until a writer appears); the file
/// is then opened non-blocking and checked again, so a FIFO swapped in between cannot
/// block the read either.
pub fn read_text_file(path: &Path, limits: &Limits) -> Result<String> {
    read_bounded(path, limits, limits.file_bytes, "the input file limit", 1)
}

/// Read a model file (TOML) as [`read_text_file`] reads any input, refusing one larger than
/// [`MAX_MODEL_FILE_BYTES`] (or `limits.file_bytes`, if smaller), and one whose parsing
/// ([`TOML_BYTES_PER_FILE_BYTE`] per byte) would not fit the memory budget.
pub fn read_model_file(path: &Path, limits: &Limits) -> Result<String> {
    read_bounded(
        path,
        limits,
        MAX_MODEL_FILE_BYTES.min(limits.file_bytes),
        "the limit of a model file (TOML; large data belongs in the files the model names: Matrix Market matrices, coordinates, contacts)",
        TOML_BYTES_PER_FILE_BYTE,
    )
}

/// Read a text file of at most `max_bytes` bytes (`limit_name` in the message), whose
/// reading and processing take `bytes_per_byte` bytes of memory per byte of the file
/// (checked against the memory budget before anything is read).
pub fn read_bounded(
    path: &Path,
    limits: &Limits,
    max_bytes: u64,
    limit_name: &str,
    bytes_per_byte: u64,
) -> Result<String> {
    let bytes = read_bounded_bytes(path, limits, max_bytes, limit_name, bytes_per_byte)?;
    String::from_utf8(bytes).map_err(|e| {
        Error::io(
            path,
            format!(
                "not UTF-8 text (invalid byte at offset {})",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

/// Read a file as [`read_text_file`] does, as bytes (a binary mesh), without the UTF-8
/// check.
pub fn read_binary_file(path: &Path, limits: &Limits) -> Result<Vec<u8>> {
    read_bounded_bytes(path, limits, limits.file_bytes, "the input file limit", 1)
}

/// The bytes of [`read_bounded`], before its UTF-8 check.
fn read_bounded_bytes(
    path: &Path,
    limits: &Limits,
    max_bytes: u64,
    limit_name: &str,
    bytes_per_byte: u64,
) -> Result<Vec<u8>> {
    let before = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if !before.is_file() {
        return Err(Error::io(path, not_regular(&before)));
    }
    let file = open_nonblocking(path).map_err(|e| Error::io(path, e))?;
    let meta = file.metadata().map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(Error::io(path, not_regular(&meta)));
    }
    if meta.len() > max_bytes {
        return Err(Error::io(
            path,
            format!(
                "{} is larger than {limit_name} of {}",
                human_bytes(meta.len()),
                human_bytes(max_bytes)
            ),
        ));
    }
    limits.check_memory(
        &format!("reading {}", path.display()),
        meta.len().checked_mul(bytes_per_byte.max(1)),
    )?;
    let mut bytes = Vec::new();
    bytes.try_reserve_exact(meta.len() as usize).map_err(|_| {
        Error::io(
            path,
            format!(
                "cannot allocate {} to read the file",
                human_bytes(meta.len())
            ),
        )
    })?;
    // bounded even if the file grows while it is read
    file.take(max_bytes + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > max_bytes {
        return Err(Error::io(
            path,
            "the file grew beyond the input file limit while it was read",
        ));
    }
    Ok(bytes)
}

/// Why a file that is not a regular file is refused.
fn not_regular(meta: &std::fs::Metadata) -> String {
    let kind = if meta.is_dir() {
        "a directory"
    } else {
        special_file_kind(meta)
    };
    format!("not a regular file ({kind}); only regular files are read")
}

#[cfg(unix)]
fn special_file_kind(meta: &std::fs::Metadata) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    let t = meta.file_type();
    if t.is_fifo() {
        "a FIFO"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else if t.is_socket() {
        "a socket"
    } else {
        "a special file"
    }
}

#[cfg(not(unix))]
fn special_file_kind(_meta: &std::fs::Metadata) -> &'static str {
    "a special file"
}

/// Open for reading without blocking on a FIFO (`O_NONBLOCK`; reads of regular files
/// are not affected) and without making a terminal the controlling one (`O_NOCTTY`).
#[cfg(unix)]
fn open_nonblocking(path: &Path) -> std::io::Result<std::fs::File> {
    use std::os::unix::fs::OpenOptionsExt;
    std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY)
        .open(path)
}

#[cfg(not(unix))]
fn open_nonblocking(path: &Path) -> std::io::Result<std::fs::File> {
    std::fs::File::open(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A request set while a long call runs ends the wait at once with `Cancelled` (the
    /// call finishes on its helper thread); an unset one returns the call's result, and
    /// `NEVER` runs it on the caller's thread.
    #[test]
    fn waiting_for_an_uninterruptible_call_stops_on_the_request() {
        static FLAG: AtomicBool = AtomicBool::new(false);
        let cancel = Cancel::on(&FLAG);
        assert_eq!(cancel.wait_for(|| 7).unwrap(), 7);
        let caller = std::thread::current().id();
        assert!(Cancel::NEVER
            .wait_for(move || std::thread::current().id() == caller)
            .unwrap());
        let setter = std::thread::spawn(|| {
            std::thread::sleep(std::time::Duration::from_millis(100));
            FLAG.store(true, Ordering::SeqCst);
        });
        let start = std::time::Instant::now();
        let result = cancel.wait_for(|| std::thread::sleep(std::time::Duration::from_secs(5)));
        let waited = start.elapsed().as_secs_f64();
        setter.join().unwrap();
        assert!(matches!(result, Err(Error::Cancelled)), "{result:?}");
        assert!(waited < 1.0, "waited {waited} s");
        // a request already set does not start the call
        assert!(matches!(cancel.wait_for(|| 1), Err(Error::Cancelled)));
    }

    /// The default budget leaves a quarter of the machine's memory and what other programs
    /// hold: at most three quarters of `MemTotal`, and at most `MemAvailable` (read before
    /// and after, which moves while other programs run).
    #[test]
    fn the_default_budget_leaves_part_of_the_machine() {
        let available = || {
            let text = std::fs::read_to_string("/proc/meminfo").unwrap();
            machine::kib_field(&text, "MemAvailable:").unwrap()
        };
        let Some(total) = physical_memory_bytes() else {
            return; // not Linux
        };
        let before = available();
        let budget = available_memory_bytes();
        let after = available();
        assert!(
            budget as f64 <= MACHINE_SHARE * total as f64,
            "{budget} of {total}"
        );
        assert!(budget <= before.max(after), "{budget} > {before}, {after}");
        assert!(Limits::default().memory_bytes <= (MACHINE_SHARE * total as f64) as u64);
    }

    #[test]
    fn memory_check_names_what_and_overflow() {
        let limits = Limits {
            memory_bytes: GIB,
            file_bytes: GIB,
            cancel: Cancel::NEVER,
        };
        assert!(limits.check_items("x", 1 << 20, 8).is_ok());
        let err = limits
            .check_items("the dense matrix", 1 << 40, 8)
            .unwrap_err();
        let text = err.to_string();
        assert!(
            text.contains("the dense matrix") && text.contains("8.0 TiB"),
            "{text}"
        );
        let err = limits.check_items("huge", u64::MAX, 8).unwrap_err();
        assert!(err.to_string().contains("more than 2^64"), "{err}");
        assert_eq!(dense_f64_bytes(usize::MAX, 2), None);
    }

    #[test]
    fn reading_refuses_devices_and_large_files() {
        let limits = Limits {
            memory_bytes: GIB,
            file_bytes: 16,
            cancel: Cancel::NEVER,
        };
        #[cfg(unix)]
        {
            let err = read_text_file(Path::new("/dev/zero"), &limits).unwrap_err();
            assert!(err.to_string().contains("not a regular file"), "{err}");
        }
        let dir = std::env::temp_dir().join(format!("mshbm-limits-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let big = dir.join("big.txt");
        std::fs::write(&big, "0123456789abcdefXYZ").unwrap();
        let err = read_text_file(&big, &limits).unwrap_err();
        assert!(err.to_string().contains("limit"), "{err}");
        let small = dir.join("small.txt");
        std::fs::write(&small, "ok").unwrap();
        assert_eq!(read_text_file(&small, &limits).unwrap(), "ok");
        let err = read_text_file(&dir, &limits).unwrap_err();
        assert!(err.to_string().contains("a directory"), "{err}");
        #[cfg(unix)]
        {
            // a FIFO without a writer: refused at once, never opened (opening would block)
            let fifo = dir.join("fifo");
            let made = std::process::Command::new("mkfifo")
                .arg(&fifo)
                .status()
                .unwrap();
            assert!(made.success());
            let start = std::time::Instant::now();
            let err = read_text_file(&fifo, &limits).unwrap_err();
            assert!(err.to_string().contains("a FIFO"), "{err}");
            assert!(start.elapsed().as_millis() < 500, "{:?}", start.elapsed());
            // opened non-blocking, a FIFO is refused by the second check as well
            let file = open_nonblocking(&fifo).unwrap();
            assert!(!file.metadata().unwrap().is_file());
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
