//! The memory estimate of a model ([`MODEL_BYTES_PER_DOF`]) against what loading a model
//! and building its system really allocate, measured by a counting global allocator (an
//! independent measurement), and the limit it enforces: a bar just under the memory
//! budget loads, one just over is refused before anything is allocated.
//!
//! One test in its own binary, so that no other test allocates while the peak is measured.

use std::alloc::{GlobalAlloc, Layout, System as SystemAllocator};
use std::sync::atomic::{AtomicUsize, Ordering};

use mshbm::limits::Limits;
use mshbm::model::file::{load_model_with, parse_model_with};
use mshbm::model::{LoadOptions, MassKind, MODEL_BYTES_PER_DOF};

/// Counts the bytes currently allocated and their peak since the last reset.
struct Counting;

static CURRENT: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = SystemAllocator.alloc(layout);
        if !p.is_null() {
            let now = CURRENT.fetch_add(layout.size(), Ordering::SeqCst) + layout.size();
            PEAK.fetch_max(now, Ordering::SeqCst);
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        SystemAllocator.dealloc(ptr, layout);
        CURRENT.fetch_sub(layout.size(), Ordering::SeqCst);
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

fn bar_text(elements: usize) -> String {
    format!(
        "kind = \"bar\"\n[bar]\nelements = {elements}\nlength = 20.0\ndensity = 9e-9\nyoung = 2.1e5\narea = 1.0\n[load]\namplitude = 4000.0\nposition = 10.0\n[contact]\ngap = 0.2\n"
    )
}

fn options(memory_bytes: u64) -> LoadOptions {
    LoadOptions {
        limits: Limits {
            memory_bytes,
            file_bytes: 1 << 20,
            cancel: Default::default(),
        },
        allow_outside_paths: false,
    }
}

/// Peak bytes allocated while reading a bar of `elements` elements and building both its
/// systems (consistent and redistributed mass), above what was allocated before.
fn measured_peak(elements: usize) -> usize {
    let text = bar_text(elements);
    let path = std::path::Path::new("bar.toml");
    let base = CURRENT.load(Ordering::SeqCst);
    PEAK.store(base, Ordering::SeqCst);
    let model = parse_model_with(&text, path, &[], &options(u64::MAX)).unwrap();
    let consistent = model.system(MassKind::Consistent).unwrap();
    let redistributed = model.system(MassKind::Redistributed).unwrap();
    let peak = PEAK.load(Ordering::SeqCst) - base;
    drop((consistent, redistributed, model));
    peak
}

#[test]
fn model_memory_estimate_bounds_the_measured_peak_and_is_enforced() {
    for elements in [2_000, 20_000] {
        let peak = measured_peak(elements);
        let estimate = (elements as u64 + 1) * MODEL_BYTES_PER_DOF;
        // an upper bound, but not a wild one (a bar of 10^6 elements must stay loadable on
        // a machine that could hold it)
        assert!(
            peak as u64 <= estimate && estimate <= 3 * peak as u64,
            "{elements} elements: measured peak {peak} B, estimate {estimate} B"
        );
    }

    // the limit, with a small budget: just under loads, just over is refused at once
    let budget = 64 << 20;
    let fits = (budget / MODEL_BYTES_PER_DOF - 1) as usize; // nodes = elements + 1
    let path = std::path::Path::new("bar.toml");
    let model = parse_model_with(&bar_text(fits), path, &[], &options(budget)).unwrap();
    assert_eq!(model.n_dofs(), fits + 1);
    for elements in [fits + 1, 1_000_000_000, 4_611_686_018_427_387_904] {
        let start = std::time::Instant::now();
        let base = CURRENT.load(Ordering::SeqCst);
        PEAK.store(base, Ordering::SeqCst);
        let err = parse_model_with(&bar_text(elements), path, &[], &options(budget)).unwrap_err();
        let text = err.to_string();
        assert!(
            text.contains("bar.toml")
                && text.contains("bar.elements")
                && text.contains("memory limit")
                && text.contains("--max-memory"),
            "{text}"
        );
        assert!(
            PEAK.load(Ordering::SeqCst) - base < 1 << 20,
            "refused only after allocating"
        );
        assert!(
            start.elapsed().as_millis() < 100,
            "{elements}: slow refusal"
        );
    }
    // the `--set` route through a file
    let dir = tempfile_dir();
    let file = dir.join("bar.toml");
    std::fs::write(&file, bar_text(100)).unwrap();
    let err = load_model_with(
        &file,
        &["bar.elements=4611686018427387904".to_string()],
        &LoadOptions::default(),
    )
    .unwrap_err();
    assert!(err.to_string().contains("more than 2^64 bytes"), "{err}");
    let model = load_model_with(&file, &[], &LoadOptions::default()).unwrap();
    assert_eq!(model.input_files, vec![file.canonicalize().unwrap()]);
    std::fs::remove_dir_all(&dir).unwrap();
}

fn tempfile_dir() -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("mshbm-input-limits-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
