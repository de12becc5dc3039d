//! Where a slow solve spends its time: the redistributed MS-HBM (its defaults,
//! `MethodSettings::redistributed(H)`) on MODEL at F Hz, one residual and one linearisation
//! at the method's initial guess timed, then Newton (tolerance 1e-12, at most ITERATIONS
//! iterations) with the time of every iteration; the last iterate is written as
//! `solve --json`'s `harmonics`, `frequency_hz` and `unknowns` to OUT (if given), which
//! `jacobian_probe` reads.
//!
//! ```text
//! cargo run --release -p mshbm --example newton_timing -- MODEL.toml F H [ITERATIONS [OUT.json]]
//! ```

use std::time::Instant;

use mshbm::method::settings::MethodSettings;
use mshbm::model::file::load_model;
use mshbm::newton::{solve_observed, NewtonObserver, NewtonOptions};

fn fail(message: impl std::fmt::Display) -> ! {
    eprintln!("{message}");
    std::process::exit(1)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if !(4..=6).contains(&args.len()) {
        eprintln!("usage: newton_timing MODEL.toml F H [ITERATIONS [OUT.json]]");
        std::process::exit(2);
    }
    let model = load_model(std::path::Path::new(&args[1]), &[]).unwrap_or_else(|e| fail(e));
    let number = |i: usize, what: &str| -> f64 {
        args[i]
            .parse()
            .unwrap_or_else(|_| fail(format!("{what}: not a number: {}", args[i])))
    };
    let hz = number(2, "F");
    let harmonics = number(3, "H") as usize;
    let iterations = if args.len() > 4 {
        number(4, "ITERATIONS") as usize
    } else {
        5
    };
    let omega = 2.0 * std::f64::consts::PI * hz;
    let mut problem = MethodSettings::redistributed(harmonics)
        .build(&model)
        .unwrap_or_else(|e| fail(e))
        .problem;
    let x0 = problem.initial_guess(omega).unwrap_or_else(|e| fail(e));
    let clock = Instant::now();
    let r = problem.residual(&x0, omega).unwrap_or_else(|e| fail(e));
    let norm = r.iter().map(|a| a * a).sum::<f64>().sqrt();
    println!(
        "residual at the initial guess: {:.3} s (|R| = {norm:e})",
        clock.elapsed().as_secs_f64()
    );
    let clock = Instant::now();
    problem.linearize(&x0, omega).unwrap_or_else(|e| fail(e));
    println!(
        "linearisation at the initial guess: {:.3} s",
        clock.elapsed().as_secs_f64()
    );
    let start = Instant::now();
    let observer = NewtonObserver::new(move |k, r| {
        println!(
            "Newton iteration {k}: relative residual {r:e} ({:.1} s)",
            start.elapsed().as_secs_f64()
        )
    });
    let options = NewtonOptions {
        tolerance: 1e-12,
        max_iterations: iterations,
        ..NewtonOptions::default()
    };
    let outcome = solve_observed(problem.as_mut(), &x0, omega, &options, Some(&observer))
        .unwrap_or_else(|e| fail(e));
    println!(
        "converged: {} after {} iterations (relative residual {:e})",
        outcome.converged, outcome.iterations, outcome.residual_norm
    );
    if let Some(out) = args.get(5) {
        let json = serde_json::json!({
            "harmonics": harmonics,
            "frequency_hz": hz,
            "unknowns": outcome.x,
        });
        std::fs::write(out, json.to_string()).unwrap_or_else(|e| fail(format!("{out}: {e}")));
    }
}
