//! Shared by the benchmarks: models, a record of the measured times (so that a benchmark can
//! print ratios and fitted exponents of times measured in the same run), a log–log fit, a
//! counting allocator for peak heap memory and allocations, and the corrector iteration the
//! per-iteration benchmarks time.
#![allow(dead_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use criterion::{black_box, Bencher};
use mshbm::model::file::load_model;
use mshbm::{MassKind, Model};

/// What [`corrector_iteration`] keeps from one iteration to the next, as a continuation
/// does: the linearization's and the Newton direction's storage, and the frequency flip.
pub struct CorrectorStorage {
    flip: bool,
    linearization: mshbm::problem::Linearization,
    lu: mshbm::dense::DenseLu,
    direction: Vec<f64>,
}

impl Default for CorrectorStorage {
    fn default() -> Self {
        CorrectorStorage {
            flip: false,
            linearization: mshbm::problem::Linearization::empty(),
            lu: Default::default(),
            direction: Vec::new(),
        }
    }
}

/// One corrector iteration of a continuation at a new frequency: `linearize_into` at
/// `omega` or at `omega (1 + 1e-7)`, alternating (so each call is at a new frequency and
/// includes the per-frequency work), and the Newton direction, in `storage`. Returns the
/// direction's first entry.
pub fn corrector_iteration(
    problem: &mut dyn mshbm::problem::PeriodicProblem,
    x: &[f64],
    omega: f64,
    storage: &mut CorrectorStorage,
) -> f64 {
    storage.flip = !storage.flip;
    let omega = if storage.flip {
        omega * (1.0 + 1e-7)
    } else {
        omega
    };
    problem
        .linearize_into(x, omega, &mut storage.linearization)
        .expect("linearize");
    mshbm::newton::newton_direction_into(
        &storage.linearization.jacobian,
        &storage.linearization.residual,
        &mut storage.lu,
        &mut storage.direction,
    )
    .expect("direction");
    storage.direction[0]
}

pub fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

/// An example model with `--set`-style overrides.
pub fn example(file: &str, overrides: &[&str]) -> Model {
    let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    load_model(&examples().join(file), &o).expect("example model")
}

/// Hz → rad/s.
pub fn hz(f: f64) -> f64 {
    2.0 * PI * f
}

/// Rayleigh damping of the bar that makes its steady states periodic (as in
/// `tests/time_integration.rs`): 1 % modal damping at ω₁ and at 10 ω₁, `alpha` on the
/// mass and `beta_linear` on the linear part's stiffness only (so `C_NN = C_NL = 0` and the
/// redistributed MS-HBM accepts it). ω₁ of the redistributed mass.
pub fn rayleigh_overrides(file: &str, extra: &[&str]) -> Vec<String> {
    let model = example(file, extra);
    let system = model.system(MassKind::Redistributed).expect("system");
    let w1 = mshbm::modes::first_angular_frequency(&system.mass, &system.stiffness)
        .expect("first eigenfrequency");
    let (zeta, w2) = (0.01, 10.0 * w1);
    let alpha = 2.0 * zeta * w1 * w2 / (w1 + w2);
    let beta = 2.0 * zeta / (w1 + w2);
    let mut o: Vec<String> = extra.iter().map(|s| s.to_string()).collect();
    o.push(format!("damping.alpha={alpha}"));
    o.push(format!("damping.beta_linear={beta}"));
    o
}

static TIMES: Mutex<BTreeMap<String, Vec<f64>>> = Mutex::new(BTreeMap::new());

/// Time `routine` under criterion and record the time per call (seconds) under `id`, so that
/// [`median`] can read it back after the group (criterion does not return its estimates).
pub fn timed<O>(b: &mut Bencher, id: &str, mut routine: impl FnMut() -> O) {
    b.iter_custom(|iters| {
        let start = Instant::now();
        for _ in 0..iters {
            black_box(routine());
        }
        let elapsed = start.elapsed();
        record(id, elapsed, iters);
        elapsed
    });
}

/// Like [`timed`], with a per-call setup that is not timed.
pub fn timed_with_setup<S, O>(
    b: &mut Bencher,
    id: &str,
    mut setup: impl FnMut() -> S,
    mut routine: impl FnMut(S) -> O,
) {
    b.iter_custom(|iters| {
        let mut elapsed = Duration::ZERO;
        for _ in 0..iters {
            let input = setup();
            let start = Instant::now();
            black_box(routine(input));
            elapsed += start.elapsed();
        }
        record(id, elapsed, iters);
        elapsed
    });
}

fn record(id: &str, elapsed: Duration, iters: u64) {
    TIMES
        .lock()
        .expect("times")
        .entry(id.to_string())
        .or_default()
        .push(elapsed.as_secs_f64() / iters.max(1) as f64);
}

/// Median time per call (seconds) of the samples recorded under `id` in this run, if it ran
/// (a criterion filter may have skipped it).
pub fn median(id: &str) -> Option<f64> {
    let times = TIMES.lock().expect("times");
    let mut v = times.get(id)?.clone();
    if v.is_empty() {
        return None;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    Some(v[v.len() / 2])
}

/// A time in the most readable unit.
pub fn show(seconds: f64) -> String {
    if seconds >= 1.0 {
        format!("{seconds:.2} s")
    } else if seconds >= 1e-3 {
        format!("{:.2} ms", seconds * 1e3)
    } else {
        format!("{:.1} µs", seconds * 1e6)
    }
}

/// Least-squares exponent `p` of `y ≈ c xᵖ` (slope in log–log), with at least two points.
pub fn fit_exponent(points: &[(f64, f64)]) -> Option<f64> {
    if points.len() < 2 {
        return None;
    }
    let n = points.len() as f64;
    let (lx, ly): (Vec<f64>, Vec<f64>) = points.iter().map(|&(x, y)| (x.ln(), y.ln())).unzip();
    let (mx, my) = (lx.iter().sum::<f64>() / n, ly.iter().sum::<f64>() / n);
    let sxy: f64 = lx.iter().zip(&ly).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = lx.iter().map(|x| (x - mx) * (x - mx)).sum();
    Some(sxy / sxx)
}

/// Print `label: x → time` for the recorded ids, the fitted exponent over all of them and
/// between the two largest (the asymptotic rate); ids that did not run are left out.
pub fn report_growth(title: &str, variable: &str, ids: &[(f64, String)]) {
    let points: Vec<(f64, f64)> = ids
        .iter()
        .filter_map(|(x, id)| median(id).map(|t| (*x, t)))
        .collect();
    if points.is_empty() {
        return;
    }
    println!("{title}:");
    for (x, t) in &points {
        println!("  {variable} = {x:>8}: {}", show(*t));
    }
    if let Some(p) = fit_exponent(&points) {
        print!("  fitted growth: time ~ {variable}^{p:.2}");
        match fit_exponent(&points[points.len().saturating_sub(2)..]) {
            Some(q) if points.len() > 2 => println!(" (between the two largest: ^{q:.2})"),
            _ => println!(),
        }
    }
}

/// A global allocator that counts the bytes in use, their peak and the allocations made
/// (install it with `#[global_allocator]` in the benchmark that reports memory).
pub struct CountingAllocator {
    current: AtomicUsize,
    peak: AtomicUsize,
    allocations: AtomicUsize,
}

impl CountingAllocator {
    pub const fn new() -> Self {
        CountingAllocator {
            current: AtomicUsize::new(0),
            peak: AtomicUsize::new(0),
            allocations: AtomicUsize::new(0),
        }
    }

    /// Allocations (and reallocations) made so far.
    pub fn allocations(&self) -> usize {
        self.allocations.load(Ordering::Relaxed)
    }

    /// Restart the peak at the bytes in use now; returns them.
    pub fn reset_peak(&self) -> usize {
        let now = self.current.load(Ordering::SeqCst);
        self.peak.store(now, Ordering::SeqCst);
        now
    }

    pub fn peak(&self) -> usize {
        self.peak.load(Ordering::SeqCst)
    }

    fn add(&self, bytes: usize) {
        self.allocations.fetch_add(1, Ordering::Relaxed);
        let now = self.current.fetch_add(bytes, Ordering::SeqCst) + bytes;
        self.peak.fetch_max(now, Ordering::SeqCst);
    }

    fn sub(&self, bytes: usize) {
        self.current.fetch_sub(bytes, Ordering::SeqCst);
    }
}

unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = System.alloc(layout);
        if !p.is_null() {
            self.add(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = System.alloc_zeroed(layout);
        if !p.is_null() {
            self.add(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout);
        self.sub(layout.size());
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = System.realloc(ptr, layout, new_size);
        if !p.is_null() {
            self.sub(layout.size());
            self.add(new_size);
        }
        p
    }
}

/// Peak resident set size of the process so far (VmHWM, Linux), in bytes.
pub fn peak_rss() -> Option<usize> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: usize = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}
