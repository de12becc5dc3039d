//! Issue 40's speed targets for friction on a plane interface (`examples/friction_damper`,
//! docs/theory.md §20), single-threaded (measure pinned: `taskset -c 0 cargo bench …`).
//!
//! Groups (`cargo bench -p mshbm --bench friction_damper -- GROUP`):
//! * `diagram`: the example's diagram at its preload (2 N, μ = 0.1) from 100 to 1500 Hz,
//!   H = 3, as `mshbm frf` traces it (target: at most 10 s);
//! * `iteration`: one corrector iteration at a new frequency (`linearize` at a frequency
//!   that alternates by 1e-7, and the Newton direction), H = 3, at the solutions at 250, 640
//!   and 1000 Hz, with friction (μ = 0.1) and on the same interface without it (no `mu`), on
//!   the example's mesh (5 contact nodes) and on a finer one (80 × 16, 17 contact nodes).
//!   Printed: the ratio per iteration (target: at most 3).

mod common;

use std::collections::BTreeMap;
use std::sync::Mutex;
use std::time::Duration;

use common::{corrector_iteration, hz, median, show, timed, CorrectorStorage};
use criterion::Criterion;
use mshbm::continuation::arclength::StopReason;
use mshbm::frd::{trace_frd_branch, FrdObserver, FrdSettings};
use mshbm::method::redistributed::{RedistributedMsHbm, RedistributedOptions};
use mshbm::method::settings::MethodSettings;
use mshbm::model::file::parse_model;
use mshbm::newton::{solve, NewtonOptions};
use mshbm::problem::PeriodicProblem;
use mshbm::Model;

const HARMONICS: usize = 3;
const DIAGRAM_TARGET_SECONDS: f64 = 10.0;
const ITERATION_TARGET_RATIO: f64 = 3.0;
const ITERATION_HZ: [f64; 3] = [250.0, 640.0, 1000.0];

struct NoObserver;
impl FrdObserver for NoObserver {}

static DIAGRAM: Mutex<Option<(usize, usize, bool)>> = Mutex::new(None);

/// The example with `overrides`; `frictionless` removes its friction coefficient.
fn damper(overrides: &[&str], frictionless: bool) -> Model {
    let path = common::examples().join("friction_damper/model.toml");
    let text = std::fs::read_to_string(&path).expect("the example");
    let text = if frictionless {
        text.lines()
            .filter(|l| !l.trim_start().starts_with("mu ="))
            .collect::<Vec<_>>()
            .join("\n")
    } else {
        text
    };
    let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    parse_model(&text, &path, &o).expect("the example")
}

fn bench_diagram(c: &mut Criterion) {
    let model = damper(&[], false);
    let mut group = c.benchmark_group("diagram");
    group.sample_size(10);
    group.warm_up_time(Duration::from_millis(100));
    group.measurement_time(Duration::from_secs(10));
    group.bench_function("preload_2n", |b| {
        timed(b, "diagram/preload_2n", || {
            let traced = trace_frd_branch(
                &model,
                &MethodSettings::redistributed(HARMONICS),
                &FrdSettings::new(100.0, 1500.0),
                false,
                &mut NoObserver,
            )
            .expect("continuation");
            let b = traced.branch;
            *DIAGRAM.lock().expect("diagram") = Some((
                b.points.len(),
                b.points.iter().map(|p| p.iterations).sum(),
                matches!(b.stop, StopReason::ReachedEnd),
            ));
        });
    });
    group.finish();
    if let (Some(t), Some((points, iterations, reached))) = (
        median("diagram/preload_2n"),
        *DIAGRAM.lock().expect("diagram"),
    ) {
        println!(
            "\nfriction damper 100 → 1500 Hz, H = {HARMONICS}: {points} points, {iterations} Newton \
             iterations{}, {} per run, target ≤ {} — {}",
            if reached { "" } else { ", did NOT reach 1500 Hz" },
            show(t),
            show(DIAGRAM_TARGET_SECONDS),
            if reached && t <= DIAGRAM_TARGET_SECONDS {
                "met"
            } else {
                "missed"
            }
        );
    }
}

/// A method at its solution, with the frequency of the next linearization alternating.
struct Case {
    problem: RedistributedMsHbm,
    x: Vec<f64>,
    omega: f64,
    storage: CorrectorStorage,
}

fn case(label: &str, model: &Model, f: f64) -> Option<Case> {
    let mut problem =
        RedistributedMsHbm::new(model, &RedistributedOptions::new(HARMONICS)).expect("MS-HBM");
    let omega = hz(f);
    let x0 = problem.initial_guess(omega).expect("initial guess");
    let out = solve(&mut problem, &x0, omega, &NewtonOptions::default()).ok()?;
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
    Some(Case {
        problem,
        x: out.x,
        omega,
        storage: CorrectorStorage::default(),
    })
}

fn bench_iteration(c: &mut Criterion) {
    let mut group = c.benchmark_group("iteration");
    group.warm_up_time(Duration::from_millis(200));
    group.measurement_time(Duration::from_secs(2));
    let meshes: [(&str, &[&str]); 2] = [("example", &[]), ("fine", &["solid.divisions=[80, 16]"])];
    let mut pairs = Vec::new();
    for (mesh, overrides) in meshes {
        for f in ITERATION_HZ {
            for (kind, frictionless) in [("friction", false), ("frictionless", true)] {
                let id = format!("{mesh}_{f}hz_{kind}");
                let model = damper(overrides, frictionless);
                let mut slot: Option<Option<Case>> = None;
                group.bench_function(&id, |b| {
                    let case = slot.get_or_insert_with(|| case(&id, &model, f));
                    match case {
                        Some(c) => timed(b, &format!("iteration/{id}"), || {
                            corrector_iteration(&mut c.problem, &c.x, c.omega, &mut c.storage)
                        }),
                        None => b.iter(|| ()),
                    }
                });
            }
            pairs.push((mesh, f));
        }
    }
    group.finish();
    let mut ratios = BTreeMap::new();
    for (mesh, f) in pairs {
        let with = median(&format!("iteration/{mesh}_{f}hz_friction"));
        let without = median(&format!("iteration/{mesh}_{f}hz_frictionless"));
        if let (Some(a), Some(b)) = (with, without) {
            let r = a / b;
            ratios.insert(format!("{mesh} {f} Hz"), r);
            println!(
                "  per corrector iteration, {mesh} mesh at {f} Hz: with friction {} vs without {}: \
                 ratio {r:.1} (target ≤ {ITERATION_TARGET_RATIO}: {})",
                show(a),
                show(b),
                if r <= ITERATION_TARGET_RATIO { "met" } else { "missed" }
            );
        } else {
            println!("  {mesh} mesh at {f} Hz: a solve did not converge; not timed");
        }
    }
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    bench_diagram(&mut c);
    bench_iteration(&mut c);
    c.final_summary();
}
