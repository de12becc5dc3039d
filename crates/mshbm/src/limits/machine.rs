//! What the machine and the process allow (the default memory budget of
//! [`super::Limits`]): the physical and available memory from `/proc/meminfo`, the resource
//! limits `RLIMIT_AS` and `RLIMIT_DATA`, the cgroup's memory limit and the dense kernels'
//! workspace.

use super::FALLBACK_MEMORY_BYTES;

/// The machine's physical memory from `/proc/meminfo` (`MemTotal`), `None` elsewhere.
pub fn physical_memory_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    kib_field(&text, "MemTotal:")
}

/// The share of the machine's physical memory the default budget leaves to a computation:
/// the rest stays with the system and the other programs.
pub const MACHINE_SHARE: f64 = 0.75;

/// The memory the machine can give now: the smaller of [`MACHINE_SHARE`] of its physical
/// memory (`MemTotal`) and the memory available without swapping (`MemAvailable`, which
/// counts what other programs hold), from `/proc/meminfo`; `None` elsewhere.
pub fn usable_machine_memory_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let share = (kib_field(&text, "MemTotal:")? as f64 * MACHINE_SHARE) as u64;
    Some(kib_field(&text, "MemAvailable:").map_or(share, |a| a.min(share)))
}

/// The memory this process may use, the default budget: the smallest of what the machine
/// can give now ([`usable_machine_memory_bytes`]: three quarters of its physical memory, or
/// less where other programs hold more of it; 8 GiB when unknown), what is left of the
/// address space under
/// `RLIMIT_AS` (`ulimit -v`, `prlimit --as`) and of the data segment under `RLIMIT_DATA`
/// (the limit less what the process maps already, `VmSize` or `VmData`), and the memory
/// limit of the process's cgroup (`memory.max` of cgroup v2, `memory.limit_in_bytes` of
/// v1). A budget taken from the machine alone let a run under `ulimit -v` abort on an
/// allocation instead of being refused by its memory plan, and the whole physical memory
/// as the budget let a run whose plan fell short grow until the kernel's OOM killer ended
/// it and other programs with it.
pub fn available_memory_bytes() -> u64 {
    let mut budget = usable_machine_memory_bytes().unwrap_or(FALLBACK_MEMORY_BYTES);
    for limit in [address_space_left(), cgroup_memory_limit()]
        .into_iter()
        .flatten()
    {
        budget = budget.min(limit);
    }
    budget
}

/// A `kB` field of a `/proc` file (`MemTotal:`, `VmSize:`) in bytes.
pub(super) fn kib_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// What `RLIMIT_AS` and `RLIMIT_DATA` leave of the address space and the data segment.
#[cfg(unix)]
fn address_space_left() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let mut left: Option<u64> = None;
    for (resource, used) in [
        (libc::RLIMIT_AS, kib_field(&status, "VmSize:")),
        (libc::RLIMIT_DATA, kib_field(&status, "VmData:")),
    ] {
        let mut limit = libc::rlimit {
            rlim_cur: 0,
            rlim_max: 0,
        };
        // SAFETY: getrlimit writes the one struct it is given.
        if unsafe { libc::getrlimit(resource, &mut limit) } != 0
            || limit.rlim_cur == libc::RLIM_INFINITY
        {
            continue;
        }
        // `rlim_t` is `u64` here and narrower or signed on other platforms
        #[allow(clippy::unnecessary_cast)]
        let mut rest = (limit.rlim_cur as u64).saturating_sub(used.unwrap_or(0));
        if resource == libc::RLIMIT_AS {
            // the address space the dense kernels reserve on their first product, touched
            // only as far as used: faer's packing workspace, twice the last-level cache
            // (960 MiB on a machine reporting a 480 MiB L3)
            rest = rest.saturating_sub(dense_workspace_bytes());
        }
        left = Some(left.map_or(rest, |l| l.min(rest)));
    }
    left
}

#[cfg(not(unix))]
fn address_space_left() -> Option<u64> {
    None
}

/// The address space the dense matrix products reserve on the main thread: twice the
/// last-level cache (`/sys/devices/system/cpu/cpu0/cache/index3/size`, 32 MiB when
/// unknown). Rayon's threads reserve as much when a product runs in parallel (large
/// matrices); that is not counted, as the docs of the memory plans say.
#[cfg(unix)]
fn dense_workspace_bytes() -> u64 {
    let l3 = std::fs::read_to_string("/sys/devices/system/cpu/cpu0/cache/index3/size")
        .ok()
        .and_then(|t| {
            let t = t.trim();
            let (number, unit) =
                t.split_at(t.find(|c: char| !c.is_ascii_digit()).unwrap_or(t.len()));
            let n: u64 = number.parse().ok()?;
            Some(match unit {
                "K" => n << 10,
                "M" => n << 20,
                "G" => n << 30,
                _ => n,
            })
        })
        .unwrap_or(32 << 20);
    l3.saturating_mul(2)
}

/// The memory limit of this process's cgroup (v2 `memory.max`, v1
/// `memory.limit_in_bytes`), `None` without one.
fn cgroup_memory_limit() -> Option<u64> {
    let read = |path: &str| -> Option<u64> {
        let text = std::fs::read_to_string(path).ok()?;
        text.trim().parse().ok() // "max" (no limit) does not parse
    };
    let own = std::fs::read_to_string("/proc/self/cgroup").unwrap_or_default();
    let mut candidates: Vec<String> = Vec::new();
    for line in own.lines() {
        let mut parts = line.splitn(3, ':');
        let (_, controllers, path) = (parts.next(), parts.next(), parts.next());
        let (Some(controllers), Some(path)) = (controllers, path) else {
            continue;
        };
        let path = path.trim_end_matches('/');
        if controllers.is_empty() {
            candidates.push(format!("/sys/fs/cgroup{path}/memory.max"));
        } else if controllers.split(',').any(|c| c == "memory") {
            candidates.push(format!("/sys/fs/cgroup/memory{path}/memory.limit_in_bytes"));
        }
    }
    candidates.push("/sys/fs/cgroup/memory.max".into());
    candidates.push("/sys/fs/cgroup/memory/memory.limit_in_bytes".into());
    candidates.iter().filter_map(|p| read(p)).min()
}
