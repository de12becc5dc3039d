//! The README's main job at full speed (issue 18): the paper's bar (examples/clamped_bar.toml,
//! gap 0.2 mm, `damping.first_mode_ratio=0.01`) from 1 to 100 kHz, as `mshbm frf` traces it.
//!
//! Groups (`cargo bench -p mshbm --bench bar_diagram -- GROUP`):
//! * `diagram`: `h10`, the H = 10 branch (target: at most 1 s), and `h1_3_5_10`, the four
//!   branches of the README's command one after the other (target: at most 2 s). Printed
//!   after the group: points, Newton iterations and folds per branch, and whether each
//!   target is met (the run is single-threaded; measure it pinned to one core,
//!   `taskset -c 0 cargo bench …`);
//! * `iteration`: one corrector iteration at a new frequency (`linearize` at a frequency
//!   that alternates by 1e-7, and the Newton direction), H = 10, at each method's solution
//!   at 60 kHz, with the same samples per period (the MS-HBM's default, 336): the
//!   redistributed MS-HBM (exact quadrature) against HBM-AFT (consistent mass,
//!   kp = 100 k_c) with the classical sampled AFT and with the exact penalty quadrature.
//!   Printed: the ratios (target: the MS-HBM no slower than HBM-AFT).

mod common;

use std::collections::BTreeMap;
use std::sync::Mutex;
use std::time::Duration;

use common::{corrector_iteration, hz, median, show, timed, CorrectorStorage};
use criterion::Criterion;
use mshbm::continuation::arclength::StopReason;
use mshbm::frd::{trace_frd_branch, FrdObserver, FrdSettings};
use mshbm::harmonic::Quadrature;
use mshbm::method::hbm_aft::{HbmAft, HbmAftOptions};
use mshbm::method::redistributed::{RedistributedMsHbm, RedistributedOptions};
use mshbm::method::settings::MethodSettings;
use mshbm::newton::{solve, NewtonOptions};
use mshbm::problem::PeriodicProblem;
use mshbm::Model;

const FROM_HZ: f64 = 1e3;
const TO_HZ: f64 = 100e3;
/// The README's branches.
const README_HARMONICS: [usize; 4] = [1, 3, 5, 10];
const ITERATION_HARMONICS: usize = 10;
const ITERATION_HZ: f64 = 60e3;

fn fig9_model() -> Model {
    common::example("clamped_bar.toml", &["damping.first_mode_ratio=0.01"])
}

/// Observes nothing: the benchmark counts from the returned branch.
struct NoObserver;
impl FrdObserver for NoObserver {}

/// Points, Newton iterations, folds and how each branch ended.
static COUNTS: Mutex<BTreeMap<usize, (usize, usize, usize, bool)>> = Mutex::new(BTreeMap::new());

/// The branch of `harmonics` over the README's range, as `mshbm frf` traces it.
fn branch(model: &Model, harmonics: usize) {
    let settings = FrdSettings::new(FROM_HZ, TO_HZ);
    let traced = trace_frd_branch(
        model,
        &MethodSettings::redistributed(harmonics),
        &settings,
        false,
        &mut NoObserver,
    )
    .expect("continuation");
    let b = traced.branch;
    COUNTS.lock().expect("counts").insert(
        harmonics,
        (
            b.points.len(),
            b.points.iter().map(|p| p.iterations).sum(),
            b.folds.len(),
            matches!(b.stop, StopReason::ReachedEnd),
        ),
    );
}

fn bench_diagram(c: &mut Criterion) {
    let model = fig9_model();
    let mut group = c.benchmark_group("diagram");
    group.sample_size(10);
    group.warm_up_time(Duration::from_millis(100));
    group.measurement_time(Duration::from_secs(10));
    group.bench_function("h10", |b| {
        timed(b, "diagram/h10", || branch(&model, 10));
    });
    group.bench_function("h1_3_5_10", |b| {
        timed(b, "diagram/h1_3_5_10", || {
            README_HARMONICS.iter().for_each(|&h| branch(&model, h))
        });
    });
    group.finish();
    println!("\nThe README's diagram, 1–100 kHz (redistributed MS-HBM, exact quadrature):");
    for (h, (points, iterations, folds, reached)) in COUNTS.lock().expect("counts").iter() {
        println!(
            "  H = {h:>2}: {points} points, {iterations} Newton iterations, {folds} folds{}",
            if *reached {
                ""
            } else {
                ", did NOT reach 100 kHz"
            }
        );
    }
    for (id, target) in [("diagram/h10", 1.0), ("diagram/h1_3_5_10", 2.0)] {
        if let Some(t) = median(id) {
            println!(
                "  {id}: {} per run, target {} — {}",
                show(t),
                show(target),
                if t <= target { "met" } else { "missed" }
            );
        }
    }
}

/// A method at its solution at [`ITERATION_HZ`], with the frequency of the next
/// linearization alternating.
struct Case {
    problem: Box<dyn PeriodicProblem>,
    x: Vec<f64>,
    omega: f64,
    storage: CorrectorStorage,
}

fn case(label: &str, mut problem: Box<dyn PeriodicProblem>) -> Case {
    let omega = hz(ITERATION_HZ);
    let x0 = problem.initial_guess(omega).expect("initial guess");
    let out = solve(problem.as_mut(), &x0, omega, &NewtonOptions::default()).expect("Newton");
    println!(
        "  {label}: {} unknowns, Newton {} iterations, residual {:.1e}{}",
        out.x.len(),
        out.iterations,
        out.residual_norm,
        if out.converged {
            ""
        } else {
            " (not converged: timed at its last iterate)"
        }
    );
    Case {
        problem,
        x: out.x,
        omega,
        storage: CorrectorStorage::default(),
    }
}

/// Sets a [`Case`] up (on first use: the Newton solve is not timed).
type MakeCase = Box<dyn Fn() -> Case>;

fn bench_iteration(c: &mut Criterion) {
    let model = fig9_model();
    let h = ITERATION_HARMONICS;
    let mut group = c.benchmark_group("iteration");
    group.warm_up_time(Duration::from_millis(200));
    group.measurement_time(Duration::from_secs(3));
    let mut cases: Vec<(&str, MakeCase)> = Vec::new();
    let m = model.clone();
    cases.push((
        "ms_hbm",
        Box::new(move || {
            let p = RedistributedMsHbm::new(&m, &RedistributedOptions::new(h)).expect("MS-HBM");
            case("ms_hbm", Box::new(p))
        }),
    ));
    for (name, quadrature) in [
        ("hbm_aft_sampled", Quadrature::Sampled),
        ("hbm_aft_exact", Quadrature::Exact),
    ] {
        let m = model.clone();
        cases.push((
            name,
            Box::new(move || {
                let options = HbmAftOptions {
                    quadrature,
                    ..HbmAftOptions::new(h)
                };
                case(name, Box::new(HbmAft::new(&m, &options).expect("HBM-AFT")))
            }),
        ));
    }
    for (name, make) in &cases {
        let id = format!("iteration/{name}");
        let mut slot: Option<Case> = None;
        group.bench_function(*name, |b| {
            let c = slot.get_or_insert_with(make);
            timed(b, &id, || {
                corrector_iteration(c.problem.as_mut(), &c.x, c.omega, &mut c.storage)
            });
        });
    }
    group.finish();
    if let Some(ms) = median("iteration/ms_hbm") {
        for name in ["hbm_aft_sampled", "hbm_aft_exact"] {
            if let Some(t) = median(&format!("iteration/{name}")) {
                println!(
                    "  per corrector iteration, H = {h}: MS-HBM {} vs {name} {}: ratio {:.2} (target ≤ 1: {})",
                    show(ms),
                    show(t),
                    ms / t,
                    if ms <= t { "met" } else { "missed" }
                );
            }
        }
    }
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    bench_diagram(&mut c);
    bench_iteration(&mut c);
    c.final_summary();
}
