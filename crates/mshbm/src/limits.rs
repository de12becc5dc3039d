//! Resource limits: how much memory a computation may plan to use and how large an input
//! file may be. Every size that comes from user input (elements, DOFs, harmonics, samples,
//! declared matrix sizes, file lengths) is checked against these limits with checked
//! arithmetic **before** anything is allocated, so that a tiny input cannot exhaust the
//! machine; the error says what was asked, what it would need and how to raise the limit.

use std::io::Read;
use std::path::Path;

use crate::error::{Error, Result};

/// Bytes in a gibibyte.
pub const GIB: u64 = 1 << 30;

/// Memory assumed when the machine's memory cannot be read (not Linux).
const FALLBACK_MEMORY_BYTES: u64 = 8 * GIB;

/// Default largest input file (model file, Matrix Market file, coordinates, vectors).
pub const DEFAULT_MAX_FILE_BYTES: u64 = GIB;

/// The limits a computation is checked against. The defaults are the machine's physical
/// memory and 1 GiB per input file; the CLI raises or lowers them with `--max-memory`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Largest memory [bytes] a computation may plan to allocate.
    pub memory_bytes: u64,
    /// Largest input file [bytes] that is read.
    pub file_bytes: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            memory_bytes: physical_memory_bytes().unwrap_or(FALLBACK_MEMORY_BYTES),
            file_bytes: DEFAULT_MAX_FILE_BYTES,
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

/// The machine's physical memory from `/proc/meminfo` (`MemTotal`), `None` elsewhere.
pub fn physical_memory_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// Read a text input file: only regular files (never a device, FIFO or directory, which
/// could be endless or block), at most `limits.file_bytes` bytes, valid UTF-8.
///
/// The path is checked with `stat` before it is opened, so a device or a FIFO is refused
/// without opening it (opening a FIFO for reading blocks until a writer appears); the file
/// is then opened non-blocking and checked again, so a FIFO swapped in between cannot
/// block the read either.
pub fn read_text_file(path: &Path, limits: &Limits) -> Result<String> {
    let before = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if !before.is_file() {
        return Err(Error::io(path, not_regular(&before)));
    }
    let file = open_nonblocking(path).map_err(|e| Error::io(path, e))?;
    let meta = file.metadata().map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(Error::io(path, not_regular(&meta)));
    }
    if meta.len() > limits.file_bytes {
        return Err(Error::io(
            path,
            format!(
                "{} is larger than the input file limit of {}",
                human_bytes(meta.len()),
                human_bytes(limits.file_bytes)
            ),
        ));
    }
    let mut bytes = Vec::new();
    bytes
        .try_reserve_exact(meta.len() as usize)
        .map_err(|_| Error::io(path, "cannot allocate memory to read the file"))?;
    // bounded even if the file grows while it is read
    file.take(limits.file_bytes + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > limits.file_bytes {
        return Err(Error::io(
            path,
            "the file grew beyond the input file limit while it was read",
        ));
    }
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

    #[test]
    fn memory_check_names_what_and_overflow() {
        let limits = Limits {
            memory_bytes: GIB,
            file_bytes: GIB,
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
