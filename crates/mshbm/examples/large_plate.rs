//! The set-up and the first Newton solves of the redistributed MS-HBM on a refinement of
//! `examples/block_3d`, timed phase by phase with the peak resident memory (Linux `VmHWM`):
//! the measurement of BENCHMARKS.md §9 ("A 10⁵-DOF solid with 10³ contacts").
//!
//! ```text
//! cargo run --release -p mshbm --example large_plate -- NX NZ H FREQUENCY_HZ [ITERATIONS [QUADRATURE]]
//! cargo run --release -p mshbm --example large_plate -- 32 30 1 1500 50 sampled
//! cargo run --release -p mshbm --example large_plate -- 32 30 5 1500
//! ```
//!
//! The plate is meshed `NX × NX × NZ`. Newton starts from the linear response at the
//! frequency (for `H > 1` at `H = 1` first, then at `H` from that solution: the nested start
//! of docs/theory.md (T122)) and, when it converges, makes three continuation-sized steps
//! (+0.2 % each), each from the last solution. At the end it checks issue 17's targets for
//! a 10⁵-DOF model (set-up ≤ 2 min, a step ≤ 10 s, peak memory ≤ 4 GB) and exits with
//! status 1 when one is not met. One core by default; `MSHBM_THREADS=N` lets faer use `N`
//! threads.

use std::time::Instant;

use mshbm::harmonic::Quadrature;
use mshbm::method::redistributed::{RedistributedMsHbm, RedistributedOptions};
use mshbm::method::SetupObserver;
use mshbm::model::file::load_model;
use mshbm::newton::{solve, NewtonOptions};
use mshbm::problem::PeriodicProblem;

/// Peak and current resident memory of this process.
fn memory() -> String {
    std::fs::read_to_string("/proc/self/status")
        .map(|s| {
            s.lines()
                .filter(|l| l.starts_with("VmHWM") || l.starts_with("VmRSS"))
                .map(|l| l.split_whitespace().collect::<Vec<_>>().join(" "))
                .collect::<Vec<_>>()
                .join(", ")
        })
        .unwrap_or_default()
}

fn main() {
    // one core unless MSHBM_THREADS asks for more (the issue's target is the one-core figure)
    let threads: usize = std::env::var("MSHBM_THREADS")
        .ok()
        .and_then(|t| t.parse().ok())
        .unwrap_or(1);
    faer::set_global_parallelism(if threads > 1 {
        faer::Par::rayon(threads)
    } else {
        faer::Par::Seq
    });
    let args: Vec<String> = std::env::args().collect();
    let arg = |i: usize| -> &str {
        args.get(i)
            .map(String::as_str)
            .expect("arguments: NX NZ H FREQUENCY_HZ [ITERATIONS [QUADRATURE]]")
    };
    let (nx, nz, h): (usize, usize, usize) = (
        arg(1).parse().unwrap(),
        arg(2).parse().unwrap(),
        arg(3).parse().unwrap(),
    );
    let f: f64 = arg(4).parse().unwrap();
    let iterations: usize = args.get(5).map_or(50, |s| s.parse().unwrap());
    let quadrature = match args.get(6).map_or("exact", String::as_str) {
        "exact" => Quadrature::Exact,
        "sampled" => Quadrature::Sampled,
        other => panic!("QUADRATURE is exact or sampled, got {other}"),
    };
    let model_file =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/block_3d/model.toml");
    let start = Instant::now();
    let model =
        load_model(&model_file, &[format!("solid.divisions=[{nx},{nx},{nz}]")]).expect("model");
    println!("model: {:.1?} ({})", start.elapsed(), memory());
    let start = Instant::now();
    let setup_start = start;
    let observer = SetupObserver::new(move |phase| {
        println!(
            "  {:>6.1?}  {}  ({})",
            start.elapsed(),
            phase.unwrap_or("done"),
            memory()
        )
    });
    let mut problem = RedistributedMsHbm::within_observed(
        &model,
        &RedistributedOptions {
            quadrature,
            ..RedistributedOptions::new(h)
        },
        &mshbm::limits::Limits::default(),
        Some(&observer),
    )
    .expect("set-up");
    let setup = setup_start.elapsed().as_secs_f64();
    let omega = 2.0 * std::f64::consts::PI * f;
    let options = NewtonOptions {
        max_iterations: iterations,
        ..NewtonOptions::default()
    };
    // nested start across harmonics (docs/theory.md (T122)): Newton at H = 1 from the
    // linear response, then at H from that solution, the added harmonics zero
    let mut x0 = None;
    if h > 1 {
        let start = Instant::now();
        problem.set_harmonics(1, None).expect("H = 1");
        let linear = problem.initial_guess(omega).expect("linear response");
        let out = solve(&mut problem, &linear, omega, &options).expect("Newton");
        println!(
            "Newton at H = 1 from the linear response: {:.1?}, {} iterations, residual {:.1e}{} ({})",
            start.elapsed(),
            out.iterations,
            out.residual_norm,
            if out.converged { "" } else { ", not converged" },
            memory()
        );
        problem.set_harmonics(h, None).expect("H");
        x0 = mshbm::harmonic::with_harmonics(&out.x, 1, h);
    }
    let start = Instant::now();
    let x0 = match x0 {
        Some(x) => x,
        None => problem.initial_guess(omega).expect("linear response"),
    };
    let out = solve(&mut problem, &x0, omega, &options).expect("Newton");
    println!(
        "Newton at H = {h} ({} unknowns): {:.1?}, {} iterations, residual {:.1e}{} ({})",
        x0.len(),
        start.elapsed(),
        out.iterations,
        out.residual_norm,
        if out.converged { "" } else { ", not converged" },
        memory()
    );
    let mut slowest_step = f64::INFINITY;
    let mut all_converged = out.converged;
    if out.converged {
        slowest_step = 0.0;
        let mut x = out.x;
        for step in [1.002, 1.004, 1.006] {
            let start = Instant::now();
            let next = solve(&mut problem, &x, omega * step, &options).expect("Newton");
            slowest_step = slowest_step.max(start.elapsed().as_secs_f64());
            all_converged &= next.converged;
            println!(
                "step to {:.1} Hz: {:.2?}, {} iterations, residual {:.1e} ({})",
                f * step,
                start.elapsed(),
                next.iterations,
                next.residual_norm,
                memory()
            );
            x = next.x;
        }
    }
    // issue 17's targets for a 10⁵-DOF model with 10³ contact DOFs: set-up ≤ 2 min, a
    // point (Newton from the previous one) ≤ 10 s, peak memory ≤ 4 GB
    let peak_gb = peak_bytes() as f64 / 1e9;
    let targets = [
        ("set-up <= 120 s", setup <= 120.0, format!("{setup:.1} s")),
        (
            "continuation step <= 10 s",
            all_converged && slowest_step <= 10.0,
            format!("{slowest_step:.2} s"),
        ),
        (
            "peak memory <= 4 GB",
            peak_gb <= 4.0,
            format!("{peak_gb:.2} GB"),
        ),
    ];
    for (what, met, value) in &targets {
        println!(
            "target {what}: {value}, {}",
            if *met { "met" } else { "NOT MET" }
        );
    }
    if targets.iter().any(|t| !t.1) {
        std::process::exit(1);
    }
}

/// Peak resident memory of this process (Linux `VmHWM`), bytes.
fn peak_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}
