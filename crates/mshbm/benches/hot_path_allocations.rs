//! Heap allocations in the per-iteration hot path (issue 18's memory target: none once the
//! first point is solved), counted by a global allocator: one corrector iteration at a new
//! frequency (`linearize_into` at a frequency that alternates by 1e-7, and the Newton
//! direction, in storage kept between iterations as a continuation keeps it),
//! H = 10, at each method's solution at 60 kHz on the paper's bar (the unit of
//! `--bench bar_diagram -- iteration`), after ten warm-up iterations. Prints the
//! allocations and bytes per iteration and whether the target is met.
//!
//! `cargo bench -p mshbm --bench hot_path_allocations` (no timing: a count).

mod common;

use common::{corrector_iteration, hz, CorrectorStorage, CountingAllocator};
use mshbm::harmonic::Quadrature;
use mshbm::method::hbm_aft::{HbmAft, HbmAftOptions};
use mshbm::method::redistributed::{RedistributedMsHbm, RedistributedOptions};
use mshbm::newton::{solve, NewtonOptions};
use mshbm::problem::PeriodicProblem;

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator::new();

const HARMONICS: usize = 10;
const FREQUENCY_HZ: f64 = 60e3;
const WARM_UP: usize = 10;
const COUNTED: usize = 100;

/// Allocations per corrector iteration of `problem` at its solution at [`FREQUENCY_HZ`].
fn count(label: &str, mut problem: Box<dyn PeriodicProblem>) {
    let omega = hz(FREQUENCY_HZ);
    let x0 = problem.initial_guess(omega).expect("initial guess");
    let out = solve(problem.as_mut(), &x0, omega, &NewtonOptions::default()).expect("Newton");
    let mut storage = CorrectorStorage::default();
    let mut iteration = || corrector_iteration(problem.as_mut(), &out.x, omega, &mut storage);
    for _ in 0..WARM_UP {
        iteration();
    }
    let (allocations, bytes) = (ALLOCATOR.allocations(), ALLOCATOR.reset_peak());
    let mut peak_growth = 0;
    for _ in 0..COUNTED {
        std::hint::black_box(iteration());
        peak_growth = peak_growth.max(ALLOCATOR.peak().saturating_sub(bytes));
    }
    let per_iteration = (ALLOCATOR.allocations() - allocations) as f64 / COUNTED as f64;
    println!(
        "  {label}: {per_iteration:.1} allocations per corrector iteration (H = {HARMONICS}), \
         peak {peak_growth} bytes above the resting heap — target 0: {}",
        if per_iteration == 0.0 {
            "met"
        } else {
            "missed"
        }
    );
}

fn main() {
    // `-- redistributed` or `-- hbm-aft` counts one method (e.g. under heaptrack).
    let only: Option<String> = std::env::args().skip(1).find(|a| !a.starts_with('-'));
    let wanted = |name: &str| only.as_deref().is_none_or(|o| name.contains(o));
    let model = common::example("clamped_bar.toml", &["damping.first_mode_ratio=0.01"]);
    println!("Heap allocations per corrector iteration, the paper's bar at 60 kHz:");
    if wanted("redistributed") {
        count(
            "redistributed MS-HBM",
            Box::new(
                RedistributedMsHbm::new(&model, &RedistributedOptions::new(HARMONICS))
                    .expect("MS-HBM"),
            ),
        );
    }
    if wanted("hbm-aft") {
        count(
            "HBM-AFT (sampled AFT)",
            Box::new(
                HbmAft::new(
                    &model,
                    &HbmAftOptions {
                        quadrature: Quadrature::Sampled,
                        ..HbmAftOptions::new(HARMONICS)
                    },
                )
                .expect("HBM-AFT"),
            ),
        );
    }
}
