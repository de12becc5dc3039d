//! The per-iteration hot path of the redistributed MS-HBM on the paper's bar allocates
//! nothing once the first point is solved (issue 18's memory target), and the storage it
//! reuses carries nothing over: counted by this binary's global allocator (the only test
//! here, so no other thread allocates meanwhile).

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use common::{example_model, hz};
use mshbm::dense::DenseLu;
use mshbm::method::redistributed::{ReceptanceChoice, RedistributedMsHbm, RedistributedOptions};
use mshbm::newton::{newton_direction_into, solve, NewtonOptions};
use mshbm::problem::{Jacobian, Linearization, PeriodicProblem};

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn dense(j: &Jacobian) -> &faer::Mat<f64> {
    match j {
        Jacobian::Dense(m) => m,
        Jacobian::Operator(_) => panic!("the bar's Jacobian is dense"),
    }
}

fn relative_difference(a: &[f64], b: &[f64]) -> f64 {
    let size = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let e = a
        .iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    e / size
}

/// Corrector iterations at a new frequency each (60 kHz, H = 10, the README's 1 % damping,
/// the solution's neighbourhood): `linearize_into` and the Newton direction in kept
/// storage allocate nothing after the first; and each linearization equals a fresh
/// problem's at the same point (nothing stale in the reused storage: the receptance
/// refreshed in place, the integration, the scratch vectors). Both receptances that refresh
/// in place: the one `Auto` picks for the bar (every mode, diagonal modal damping) and the
/// exact one (band LU of the whole structure).
#[test]
fn a_corrector_iteration_at_a_new_frequency_allocates_nothing() {
    for receptance in [ReceptanceChoice::Auto, ReceptanceChoice::Exact] {
        corrector_iterations_allocate_nothing(receptance);
    }
}

fn corrector_iterations_allocate_nothing(receptance: ReceptanceChoice) {
    let model = example_model("clamped_bar.toml", &["damping.first_mode_ratio=0.01"]);
    let mut options = RedistributedOptions::new(10);
    options.receptance = receptance;
    let mut problem = RedistributedMsHbm::new(&model, &options).unwrap();
    let omega = hz(60e3);
    let x0 = problem.initial_guess(omega).unwrap();
    let solved = solve(&mut problem, &x0, omega, &NewtonOptions::default()).unwrap();
    assert!(solved.converged);
    let mut linearization = Linearization::empty();
    let mut lu = DenseLu::default();
    let mut direction = Vec::new();
    // points around the solution (some sampled differently, so that the active sets and
    // switching times move) at frequencies that all differ
    let point = |i: usize| -> (Vec<f64>, f64) {
        let x: Vec<f64> = solved
            .x
            .iter()
            .enumerate()
            .map(|(m, v)| v * (1.0 + 1e-3 * ((i * 7 + m) as f64).sin()))
            .collect();
        (x, omega * (1.0 + 1e-4 * i as f64))
    };
    let mut iterate = |x: &[f64], omega: f64| {
        problem
            .linearize_into(x, omega, &mut linearization)
            .unwrap();
        newton_direction_into(
            &linearization.jacobian,
            &linearization.residual,
            &mut lu,
            &mut direction,
        )
        .unwrap();
    };
    let points: Vec<(Vec<f64>, f64)> = (0..12).map(point).collect();
    let (x, w) = &points[0];
    iterate(x, *w);
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    for (x, w) in &points[1..] {
        iterate(x, *w);
    }
    let allocations = ALLOCATIONS.load(Ordering::Relaxed) - before;
    assert_eq!(
        allocations, 0,
        "allocations in 11 corrector iterations ({receptance:?})"
    );
    // the last iteration's linearization against a fresh problem's
    let (x, w) = points.last().unwrap();
    let mut fresh = RedistributedMsHbm::new(&model, &options).unwrap();
    let reference = fresh.linearize(x, *w).unwrap();
    assert!(relative_difference(&linearization.residual, &reference.residual) <= 1e-13);
    assert!(relative_difference(&linearization.d_omega, &reference.d_omega) <= 1e-13);
    let (a, b) = (dense(&linearization.jacobian), dense(&reference.jacobian));
    let flat = |m: &faer::Mat<f64>| -> Vec<f64> {
        (0..m.ncols())
            .flat_map(|j| (0..m.nrows()).map(move |i| m[(i, j)]))
            .collect()
    };
    assert!(relative_difference(&flat(a), &flat(b)) <= 1e-13);
    let expected = reference
        .jacobian
        .solve(|i| -reference.residual[i])
        .unwrap();
    assert!(relative_difference(&direction, &expected) <= 1e-10);
}
