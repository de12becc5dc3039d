//! How the redistributed MS-HBM's cost per FRD point grows (issue 9) with the number of
//! harmonics, of samples per period, of contact DOFs and of total DOFs; and the peak heap
//! memory of the largest cases.
//!
//! **Unit measured: one corrector iteration of the continuation at a new frequency** —
//! `linearize` (residual, semi-analytical Jacobian, `∂R/∂ω`) at a frequency different from
//! the previous call, so the per-frequency work is included (H + 1 sparse complex
//! factorizations of the linear part and the condensed `G_k`; in pseudo-arclength
//! continuation ω changes at every corrector iteration), plus the dense Newton direction.
//! An FRD point costs a few of these (the continuation aims at 4; the `frd` benchmark reports
//! the real time per point). Each case is evaluated at the point Newton reaches from the
//! linear response at the case's frequency (printed: iterations and final residual; on the
//! refined bars Newton stalls near 1e-6, which is reported rather than hidden).
//!
//! Groups (`cargo bench -p mshbm --bench scaling -- GROUP`):
//! * `harmonics`: the paper's bar (gap 0.2 mm, 1 % modal damping), 60 kHz, H = 1 … 40,
//!   default samples, exact quadrature;
//! * `samples`: the same bar, H = 5, N_s = 64 … 4096, exact and sampled quadrature;
//! * `contacts`: the planar lattice of `mshbm::model::lattice` (8 cells high, nx cells wide:
//!   nx + 1 contacts, 2(nx + 1) contact-node DOFs, 18(nx + 1) DOFs), force 10 on every node
//!   of the second row, H = 3, 5 Hz (every contact closes during the period);
//! * `elements`: the bar refined to 10², 10³, 10⁴, 10⁵ elements, H = 5, 30 kHz;
//! * `block`: the plate of `examples/block_3d` meshed n × n × 4 (n = 4, 8, 16: n(n + 1)
//!   contacts, 3n(n + 1) contact-node DOFs), 0.3 µm above the foundation, H = 5, sampled
//!   quadrature, 500 Hz;
//! * `block-modal`: the same plates and 32 × 32 × 4, the same unit, with the modal receptance
//!   (100 modes), the path `ReceptanceChoice::Auto` takes for large solids. From 1000
//!   unknowns Newton's systems are operators (docs/theory.md §18): the unit then includes
//!   GMRES with the factors kept from an earlier iteration, as along a continuation, and no
//!   LU (a continuation forms them again when GMRES slows; that cost is not in the unit);
//! * `receptance`: the 16 × 16 × 4 plate with the exact and the modal receptance (100
//!   modes), H = 5: what the per-frequency work of each costs in a corrector iteration;
//! * `newton-system`: a continuation step (Newton from the solution at 500 Hz to the one at
//!   501.5 Hz) on the plate n × n × 4 (n = 8, 16, 24), H = 3, with the dense LU and with the
//!   operator Jacobian (docs/theory.md §18); prints the ratio per size.
//!
//! After each group the fitted exponent of `time ~ variableᵖ` is printed; after the
//! `elements` group, the peak memory of building the method and solving at one frequency for
//! the two largest bars and the largest case of the other groups (heap, counting
//! allocator), and the peak resident set size of the whole process (VmHWM).

mod common;

use std::time::Duration;

use common::{
    corrector_iteration, hz, median, report_growth, timed, CorrectorStorage, CountingAllocator,
};
use criterion::{BenchmarkId, Criterion};
use mshbm::harmonic::Quadrature;
use mshbm::method::redistributed::{
    JacobianForm, ReceptanceChoice, RedistributedMsHbm, RedistributedOptions,
};
use mshbm::model::lattice::lattice_model;
use mshbm::newton::{solve, NewtonOptions};
use mshbm::problem::PeriodicProblem;
use mshbm::Model;

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator::new();

const HARMONICS: [usize; 6] = [1, 2, 5, 10, 20, 40];
const SAMPLES: [usize; 7] = [64, 128, 256, 512, 1024, 2048, 4096];
const LATTICE_WIDTHS: [usize; 5] = [4, 8, 16, 32, 64];
const LATTICE_HEIGHT: usize = 8;
const LATTICE_FORCE: f64 = 10.0;
const ELEMENTS: [usize; 4] = [100, 1_000, 10_000, 100_000];
const BLOCK_DIVISIONS: [usize; 3] = [4, 8, 16];
/// The `block-modal` plates: the `block` ones and 32 × 32 × 4 (1056 contacts, 3168
/// contact-node DOFs, 11 616 unknowns at H = 5), which only the modal path reaches.
const BLOCK_MODAL_DIVISIONS: [usize; 4] = [4, 8, 16, 32];
const BLOCK_HARMONICS: usize = 5;
const NEWTON_SYSTEM_DIVISIONS: [usize; 3] = [8, 16, 24];
const NEWTON_SYSTEM_HARMONICS: usize = 3;

/// A method at the point Newton reaches at `omega` from the linear response.
struct Case {
    problem: RedistributedMsHbm,
    x: Vec<f64>,
    omega: f64,
    /// Alternates the frequency between calls (so each call is at a new frequency).
    storage: CorrectorStorage,
}

fn bar(overrides: &[&str]) -> Model {
    let mut o = vec!["damping.first_mode_ratio=0.01"];
    o.extend_from_slice(overrides);
    common::example("clamped_bar.toml", &o)
}

/// The lattice with the harmonic force on every interior node of the row below the clamped
/// top (instead of one node), so that the contacts across the whole width close.
fn lattice(width: usize) -> Model {
    let mut model = lattice_model(width, LATTICE_HEIGHT, LATTICE_FORCE, 5.0);
    let nodes_x = width + 1;
    for i in 1..width {
        model.harmonic_load[2 * ((LATTICE_HEIGHT - 1) * nodes_x + i) + 1] = -LATTICE_FORCE;
    }
    model
}

/// The plate of `examples/block_3d` meshed `n × n × 4`, 0.3 µm above the foundation.
fn block(n: usize) -> Model {
    let divisions = format!("solid.divisions=[{n},{n},4]");
    common::example(
        "block_3d/model.toml",
        &[divisions.as_str(), "interfaces.0.gap=0.0003"],
    )
}

fn case(
    model: &Model,
    harmonics: usize,
    samples: Option<usize>,
    quadrature: Quadrature,
    frequency_hz: f64,
    label: &str,
) -> Case {
    case_with(
        model,
        &RedistributedOptions {
            harmonics,
            samples,
            quadrature,
            receptance: Default::default(),
            jacobian: Default::default(),
        },
        frequency_hz,
        label,
    )
}

fn case_with(
    model: &Model,
    options: &RedistributedOptions,
    frequency_hz: f64,
    label: &str,
) -> Case {
    let mut problem = RedistributedMsHbm::new(model, options).expect("MS-HBM");
    let omega = hz(frequency_hz);
    let x0 = problem.initial_guess(omega).expect("linear response");
    let out = solve(
        &mut problem,
        &x0,
        omega,
        &NewtonOptions {
            max_iterations: 50,
            ..NewtonOptions::default()
        },
    )
    .expect("Newton");
    let solution = problem
        .solution(&out.x, omega, model.contacts[0].dofs[0])
        .expect("solution");
    let closing = solution
        .contacts
        .iter()
        .filter(|c| c.force.iter().any(|&l| l > 0.0))
        .count();
    println!(
        "  {label}: {} unknowns; Newton from the linear response: {} iterations, residual {:.1e}{}; {closing} of {} contacts close",
        out.x.len(),
        out.iterations,
        out.residual_norm,
        if out.converged { "" } else { " (not converged)" },
        solution.contacts.len()
    );
    Case {
        problem,
        x: out.x,
        omega,
        storage: CorrectorStorage::default(),
    }
}

fn bench_case(
    group: &mut criterion::BenchmarkGroup<criterion::measurement::WallTime>,
    name: &str,
    parameter: usize,
    make: impl Fn() -> Case,
) -> String {
    let id = format!("{name}/{parameter}");
    let mut slot: Option<Case> = None;
    group.bench_function(BenchmarkId::new(name, parameter), |b| {
        let c = slot.get_or_insert_with(&make);
        timed(b, &id, || {
            corrector_iteration(&mut c.problem, &c.x, c.omega, &mut c.storage)
        });
    });
    id
}

fn configure(group: &mut criterion::BenchmarkGroup<criterion::measurement::WallTime>) {
    group.sample_size(10);
    group.warm_up_time(Duration::from_millis(200));
    group.measurement_time(Duration::from_secs(2));
}

fn bench_harmonics(c: &mut Criterion) {
    let model = bar(&[]);
    let mut group = c.benchmark_group("harmonics");
    configure(&mut group);
    let ids: Vec<(f64, String)> = HARMONICS
        .iter()
        .map(|&h| {
            let id = bench_case(&mut group, "harmonics", h, || {
                case(
                    &model,
                    h,
                    None,
                    Quadrature::Exact,
                    60e3,
                    &format!("H = {h}"),
                )
            });
            (h as f64, id)
        })
        .collect();
    group.finish();
    report_growth(
        "time per corrector iteration vs harmonics (bar, 60 kHz, exact quadrature)",
        "H",
        &ids,
    );
}

fn bench_samples(c: &mut Criterion) {
    let model = bar(&[]);
    let mut group = c.benchmark_group("samples");
    configure(&mut group);
    for quadrature in [Quadrature::Exact, Quadrature::Sampled] {
        let name = format!("samples_{}", quadrature.name());
        let ids: Vec<(f64, String)> = SAMPLES
            .iter()
            .map(|&n| {
                let id = bench_case(&mut group, &name, n, || {
                    case(
                        &model,
                        5,
                        Some(n),
                        quadrature,
                        60e3,
                        &format!("{} quadrature, N_s = {n}", quadrature.name()),
                    )
                });
                (n as f64, id)
            })
            .collect();
        report_growth(
            &format!(
                "time per corrector iteration vs samples (bar, H = 5, 60 kHz, {} quadrature)",
                quadrature.name()
            ),
            "N_s",
            &ids,
        );
    }
    group.finish();
}

fn bench_contacts(c: &mut Criterion) {
    let mut group = c.benchmark_group("contacts");
    configure(&mut group);
    let ids: Vec<(f64, String)> = LATTICE_WIDTHS
        .iter()
        .map(|&w| {
            let id = bench_case(&mut group, "contacts", 2 * (w + 1), || {
                case(
                    &lattice(w),
                    3,
                    None,
                    Quadrature::Exact,
                    5.0,
                    &format!(
                        "lattice {w} x {LATTICE_HEIGHT}: {} contacts, {} contact-node DOFs, {} DOFs",
                        w + 1,
                        2 * (w + 1),
                        2 * (w + 1) * (LATTICE_HEIGHT + 1)
                    ),
                )
            });
            ((2 * (w + 1)) as f64, id)
        })
        .collect();
    group.finish();
    report_growth(
        "time per corrector iteration vs contact-node DOFs (lattice, H = 3, 5 Hz)",
        "n_N",
        &ids,
    );
}

fn bench_block(c: &mut Criterion) {
    let mut group = c.benchmark_group("block");
    configure(&mut group);
    let ids: Vec<(f64, String)> = BLOCK_DIVISIONS
        .iter()
        .map(|&n| {
            let n_n = 3 * n * (n + 1);
            let id = bench_case(&mut group, "block", n_n, || {
                case(
                    &block(n),
                    BLOCK_HARMONICS,
                    None,
                    Quadrature::Sampled,
                    500.0,
                    &format!(
                        "plate {n} x {n} x 4: {} contacts, {n_n} contact-node DOFs, H = {BLOCK_HARMONICS}",
                        n * (n + 1)
                    ),
                )
            });
            (n_n as f64, id)
        })
        .collect();
    group.finish();
    report_growth(
        "time per corrector iteration vs contact-node DOFs (plate, H = 5, 500 Hz)",
        "n_N",
        &ids,
    );
}

/// The `block` group with the modal receptance (100 modes) and `Auto` Newton systems: what a
/// corrector iteration costs on the path `Auto` takes for large models, without the exact
/// receptance's factorizations per frequency.
fn bench_block_modal(c: &mut Criterion) {
    let mut group = c.benchmark_group("block-modal");
    configure(&mut group);
    let ids: Vec<(f64, String)> = BLOCK_MODAL_DIVISIONS
        .iter()
        .map(|&n| {
            let n_n = 3 * n * (n + 1);
            let id = bench_case(&mut group, "block-modal", n_n, || {
                case_with(
                    &block(n),
                    &RedistributedOptions {
                        quadrature: Quadrature::Sampled,
                        receptance: ReceptanceChoice::Modal { modes: 100 },
                        ..RedistributedOptions::new(BLOCK_HARMONICS)
                    },
                    500.0,
                    &format!(
                        "plate {n} x {n} x 4, modal receptance (100 modes): {} contacts, {n_n} contact-node DOFs, H = {BLOCK_HARMONICS}",
                        n * (n + 1)
                    ),
                )
            });
            (n_n as f64, id)
        })
        .collect();
    group.finish();
    report_growth(
        "time per corrector iteration vs contact-node DOFs (plate, modal receptance, H = 5, 500 Hz)",
        "n_N",
        &ids,
    );
}

fn bench_receptance(c: &mut Criterion) {
    let mut group = c.benchmark_group("receptance");
    configure(&mut group);
    let n = BLOCK_DIVISIONS[BLOCK_DIVISIONS.len() - 1];
    for (label, receptance) in [
        ("exact", ReceptanceChoice::Exact),
        ("modal-100", ReceptanceChoice::Modal { modes: 100 }),
    ] {
        let id = format!("receptance/{label}");
        let mut slot: Option<Case> = None;
        group.bench_function(label, |b| {
            let c = slot.get_or_insert_with(|| {
                case_with(
                    &block(n),
                    &RedistributedOptions {
                        quadrature: Quadrature::Sampled,
                        receptance,
                        ..RedistributedOptions::new(BLOCK_HARMONICS)
                    },
                    500.0,
                    &format!("plate {n} x {n} x 4, {label} receptance"),
                )
            });
            timed(b, &id, || {
                corrector_iteration(&mut c.problem, &c.x, c.omega, &mut c.storage)
            });
        });
    }
    group.finish();
}

fn bench_elements(c: &mut Criterion) {
    let mut group = c.benchmark_group("elements");
    configure(&mut group);
    let ids: Vec<(f64, String)> = ELEMENTS
        .iter()
        .map(|&e| {
            let id = bench_case(&mut group, "elements", e, || {
                case(
                    &bar(&[&format!("bar.elements={e}")]),
                    5,
                    None,
                    Quadrature::Exact,
                    30e3,
                    &format!("bar with {e} elements"),
                )
            });
            (e as f64, id)
        })
        .collect();
    group.finish();
    report_growth(
        "time per corrector iteration vs elements (bar, H = 5, 30 kHz)",
        "elements",
        &ids,
    );
}

/// Peak heap (counting allocator) while building the method and solving at one frequency
/// (the setup of a case). The case is run once before the measurement: the first dense
/// products of a process make dependencies allocate one-off buffers (about 1–2 GiB on the
/// benchmark machine, almost all of it never touched: the RSS grows by a few MiB) that would
/// otherwise be charged to whichever case comes first.
fn peak_memory(label: &str, make: impl Fn() -> Case) {
    drop(make());
    let before = ALLOCATOR.reset_peak();
    let c = make();
    let peak = ALLOCATOR.peak() - before;
    drop(c);
    println!(
        "  peak heap, {label}: {:.1} MiB",
        peak as f64 / (1024.0 * 1024.0)
    );
}

fn report_memory(filter_ran: bool) {
    if !filter_ran {
        return;
    }
    println!("peak memory (build the method + Newton at one frequency):");
    // the two largest bars: how the memory grows with the elements
    for &e in &ELEMENTS[ELEMENTS.len() - 2..] {
        peak_memory(&format!("bar with {e} elements, H = 5"), || {
            case(
                &bar(&[&format!("bar.elements={e}")]),
                5,
                None,
                Quadrature::Exact,
                30e3,
                &format!("bar with {e} elements"),
            )
        });
    }
    let h = *HARMONICS.last().expect("cases");
    peak_memory(&format!("bar, H = {h}"), || {
        case(
            &bar(&[]),
            h,
            None,
            Quadrature::Exact,
            60e3,
            &format!("H = {h}"),
        )
    });
    let w = *LATTICE_WIDTHS.last().expect("cases");
    peak_memory(&format!("lattice {w} x {LATTICE_HEIGHT}, H = 3"), || {
        case(&lattice(w), 3, None, Quadrature::Exact, 5.0, "lattice")
    });
    if let Some(rss) = common::peak_rss() {
        println!(
            "  peak RSS of the whole benchmark process (VmHWM): {:.1} MiB",
            rss as f64 / (1024.0 * 1024.0)
        );
    }
}

/// Newton from the solution at 500 Hz to the one at 501.5 Hz (a continuation step) on the
/// plate n × n × 4, H = 3, with the dense LU and with the operator Jacobian (GMRES
/// preconditioned by the factors of an earlier Jacobian, docs/theory.md §18).
fn bench_newton_system(c: &mut Criterion) {
    let mut group = c.benchmark_group("newton-system");
    configure(&mut group);
    let mut pairs = Vec::new();
    for n in NEWTON_SYSTEM_DIVISIONS {
        for (label, jacobian) in [
            ("dense", JacobianForm::Dense),
            ("operator", JacobianForm::Operator),
        ] {
            let id = format!("newton-system/{label}/{n}");
            let mut slot: Option<Case> = None;
            group.bench_function(BenchmarkId::new(label, n), |b| {
                let c = slot.get_or_insert_with(|| {
                    case_with(
                        &block(n),
                        &RedistributedOptions {
                            quadrature: Quadrature::Sampled,
                            jacobian,
                            ..RedistributedOptions::new(NEWTON_SYSTEM_HARMONICS)
                        },
                        500.0,
                        &format!(
                            "plate {n} x {n} x 4, H = {NEWTON_SYSTEM_HARMONICS}, {label} Jacobian"
                        ),
                    )
                });
                let target = c.omega * 1.003;
                timed(b, &id, || {
                    let out = solve(&mut c.problem, &c.x, target, &NewtonOptions::default())
                        .expect("Newton");
                    assert!(out.converged, "the continuation step converges");
                    out.iterations
                });
            });
            if label == "dense" {
                pairs.push((n, id));
            }
        }
    }
    group.finish();
    for (n, dense) in pairs {
        if let (Some(d), Some(o)) = (
            median(&dense),
            median(&format!("newton-system/operator/{n}")),
        ) {
            println!(
                "plate {n} x {n} x 4, H = {NEWTON_SYSTEM_HARMONICS}: continuation step dense {d:.3} s, operator {o:.3} s, ratio operator / dense {:.2}",
                o / d
            );
        }
    }
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    bench_harmonics(&mut c);
    bench_samples(&mut c);
    bench_contacts(&mut c);
    bench_elements(&mut c);
    bench_block(&mut c);
    bench_block_modal(&mut c);
    bench_receptance(&mut c);
    bench_newton_system(&mut c);
    // memory only when the elements group ran (it holds the largest case)
    report_memory(median(&format!("elements/{}", ELEMENTS[ELEMENTS.len() - 1])).is_some());
    c.final_summary();
}
