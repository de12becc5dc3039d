//! The solvers' memory plans (`mshbm::method::memory`, `mshbm::method::redistributed::memory_plan`) against what a solve really
//! allocates, measured by a counting global allocator (an independent measurement), and
//! the limits they enforce: a solve whose plan exceeds the budget is refused before it
//! allocates, with an error naming what was asked (docs/safety.md, "Resource limits of the
//! solvers").
//!
//! Its own test binary, so that no other test allocates while a peak is measured; every
//! test takes one lock so that they never overlap.

use std::alloc::{GlobalAlloc, Layout, System as SystemAllocator};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use mshbm::harmonic::Sampling;
use mshbm::limits::{Limits, GIB};
use mshbm::method::default_samples;
use mshbm::method::redistributed;
use mshbm::method::settings::MethodSettings;
use mshbm::model::bar::BarParameters;
use mshbm::solve::{solve_periodic, SolveSettings};
use mshbm::{Error, MassKind, Model};

struct Counting;

static CURRENT: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
static MEASURING: Mutex<()> = Mutex::new(());

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

fn bar(elements: usize) -> Model {
    let mut p = BarParameters::paper();
    p.elements = elements;
    p.build(Path::new("bar")).unwrap()
}

fn small(memory_bytes: u64) -> Limits {
    Limits {
        memory_bytes,
        file_bytes: GIB,
        cancel: Default::default(),
    }
}

/// One Newton solve from the linear response (the plan is the method's; the default start's
/// fallback, a continuation in frequency, also keeps the points of its branch).
fn no_stability(limits: Limits) -> SolveSettings {
    SolveSettings {
        stability: false,
        limits,
        start: mshbm::solve::SolveStart::Linear,
        ..SolveSettings::default()
    }
}

/// The plan of the redistributed MS-HBM is an upper bound of the real peak of a solve,
/// within a small factor: neither a refusal of what fits nor a promise that does not hold.
///
/// faer's dense products keep one packing workspace per thread (64 MiB, allocated once
/// and reused, touched only as far as used): a fixed cost of the process, not of the
/// problem. The measurement runs faer sequentially on this thread and allocates that
/// workspace by a first solve, so that the peaks below are the problem's own.
#[test]
fn the_redistributed_plan_bounds_the_measured_peak_of_a_solve() {
    let _one = MEASURING.lock().unwrap_or_else(|e| e.into_inner());
    faer::set_global_parallelism(faer::Par::Seq);
    for elements in [100, 1000] {
        let model = bar(elements);
        let warm_up = solve_periodic(
            &model,
            &MethodSettings::redistributed(80),
            30_000.0,
            &no_stability(Limits::default()),
        );
        drop(warm_up);
        check_plan_against_peaks(&model);
    }
}

fn check_plan_against_peaks(model: &Model) {
    let system = model.system(MassKind::Redistributed).unwrap();
    for harmonics in [5, 20, 80] {
        let samples = default_samples(harmonics);
        let plan = redistributed::memory_plan(&system, harmonics, samples)
            .total()
            .unwrap();
        let method = MethodSettings::redistributed(harmonics);
        let base = CURRENT.load(Ordering::SeqCst);
        PEAK.store(base, Ordering::SeqCst);
        let solved = solve_periodic(model, &method, 30_000.0, &no_stability(Limits::default()));
        let peak = (PEAK.load(Ordering::SeqCst) - base) as u64;
        drop(solved);
        assert!(
            peak <= plan && plan <= 4 * peak,
            "{} DOFs, H = {harmonics}: measured peak {peak} B, plan {plan} B",
            system.n_dofs()
        );
    }
}

/// A budget below the plan refuses before allocating (the peak stays far below the
/// plan), and the error names the method, the harmonics and the samples.
#[test]
fn a_solve_over_the_budget_is_refused_before_it_allocates() {
    let _one = MEASURING.lock().unwrap_or_else(|e| e.into_inner());
    let model = bar(100);
    let system = model.system(MassKind::Redistributed).unwrap();
    let harmonics = 120;
    let samples = default_samples(harmonics);
    let plan = redistributed::memory_plan(&system, harmonics, samples)
        .total()
        .unwrap();
    let base = CURRENT.load(Ordering::SeqCst);
    PEAK.store(base, Ordering::SeqCst);
    let err = solve_periodic(
        &model,
        &MethodSettings::redistributed(harmonics),
        30_000.0,
        &no_stability(small(plan / 2)),
    )
    .err()
    .expect("refused");
    let peak = (PEAK.load(Ordering::SeqCst) - base) as u64;
    assert!(matches!(err, Error::ResourceLimit { .. }), "{err}");
    let text = err.to_string();
    assert!(
        text.contains("120 harmonics") && text.contains(&format!("{samples} samples")),
        "{text}"
    );
    assert!(
        peak < plan / 10,
        "allocated {peak} B of a refused plan of {plan} B"
    );
    // the same solve within a budget of the plan runs
    let solved = solve_periodic(
        &model,
        &MethodSettings::redistributed(harmonics),
        30_000.0,
        &no_stability(small(plan)),
    );
    assert!(solved.is_ok(), "{:?}", solved.err().map(|e| e.to_string()));
}

/// Sizes that overflow are refused, not wrapped: `2H + 1` and the samples' basis.
#[test]
fn overflowing_sizes_are_errors() {
    let _one = MEASURING.lock().unwrap_or_else(|e| e.into_inner());
    assert_eq!(Sampling::memory_bytes(usize::MAX / 2 + 1, 10), None);
    assert_eq!(Sampling::memory_bytes(5, usize::MAX), None);
    let err = Sampling::within(5, usize::MAX, &Limits::default())
        .err()
        .unwrap();
    assert!(err.to_string().contains("more than 2^64"), "{err}");
    let model = bar(10);
    for method in [
        MethodSettings::redistributed(usize::MAX / 4),
        MethodSettings::redistributed(5).with_harmonics(1 << 40),
    ] {
        let err = method
            .build_within(&model, &Limits::default())
            .err()
            .unwrap();
        assert!(matches!(err, Error::ResourceLimit { .. }), "{err}");
    }
}

/// On a long bar the default Floquet basis would take minutes; it is skipped with a
/// reason that says how to ask for it, and the solve itself is unaffected.
#[test]
fn the_default_stability_of_a_very_large_bar_is_skipped_with_a_reason() {
    let _one = MEASURING.lock().unwrap_or_else(|e| e.into_inner());
    let model = bar(25_000);
    let method = MethodSettings::redistributed(3);
    let mut built = method.build_within(&model, &Limits::default()).unwrap();
    let omega = 2.0 * std::f64::consts::PI * 30_000.0;
    let x = built.problem.initial_guess(omega).unwrap();
    let err = built.problem.floquet(&x, omega).expect_err("skipped");
    let text = err.to_string();
    assert!(text.contains("--stability-modes"), "{text}");
}
