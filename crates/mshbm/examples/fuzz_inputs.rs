//! The fuzz campaign of the library's readers (issue 46; docs/safety.md "No panics"): the
//! mutation fuzzer of `tests/fuzz/mod.rs` run long, in process, on six targets (model
//! files, Matrix Market files, contact and gap tables, `--set` overrides, Gmsh meshes,
//! `--from-solution` JSON). Each input must return `Ok` or `Err`: a panic is a finding (the input is saved
//! and the campaign goes on), an input running longer than the time limit ends the
//! campaign with status 3 naming it (a watchdog thread), and so does an input whose peak
//! resident memory exceeds the memory limit (measured per input: the peak is reset before
//! each one). Run by `tools/fuzz-inputs`.
//!
//! ```text
//! cargo run --release -p mshbm --example fuzz_inputs -- [--target NAME|all] [--cases N]
//!     [--seed S] [--first CASE] [--budget-mib MIB] [--time-limit S] [--peak-limit-mib MIB]
//!     [--findings DIR] [--show]
//! ```
//!
//! Case `c` of seed `s` is always the same input: `--first c --cases 1 --show` replays it
//! and prints it.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

#[path = "../tests/fuzz/mod.rs"]
mod fuzz;

use fuzz::{peak_rss, reset_peak_rss, show, Harness, Rng, Watchdog, TARGETS};

struct Options {
    targets: Vec<String>,
    cases: u64,
    seed: u64,
    first: u64,
    budget_mib: u64,
    time_limit: Duration,
    peak_limit: u64,
    findings: PathBuf,
    show: bool,
}

fn options() -> Options {
    let mut o = Options {
        targets: TARGETS.iter().map(|t| t.to_string()).collect(),
        cases: 100_000,
        seed: 0x005E_ED15,
        first: 0,
        budget_mib: 1024,
        time_limit: Duration::from_secs(10),
        peak_limit: 2 << 30,
        findings: PathBuf::from("fuzz-findings"),
        show: false,
    };
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < args.len() {
        let value = args.get(i + 1).cloned().unwrap_or_default();
        let number = || -> u64 {
            value
                .parse()
                .unwrap_or_else(|_| panic!("{}: not a number: {value:?}", args[i]))
        };
        if args[i] == "--show" {
            o.show = true;
            i += 1;
            continue;
        }
        match args[i].as_str() {
            "--target" if value != "all" => o.targets = vec![value.clone()],
            "--target" => {}
            "--cases" => o.cases = number(),
            "--seed" => o.seed = number(),
            "--first" => o.first = number(),
            "--budget-mib" => o.budget_mib = number(),
            "--time-limit" => o.time_limit = Duration::from_secs(number()),
            "--peak-limit-mib" => o.peak_limit = number() << 20,
            "--findings" => o.findings = PathBuf::from(&value),
            other => panic!("unknown option {other:?} (see the example's docs)"),
        }
        i += 2;
    }
    o
}

fn main() {
    let o = options();
    // panics are findings, counted and saved, not printed one by one
    let last_panic: Arc<Mutex<String>> = Arc::default();
    let hook_panic = last_panic.clone();
    std::panic::set_hook(Box::new(move |info| {
        *hook_panic.lock().unwrap_or_else(|e| e.into_inner()) = info.to_string();
    }));
    let scratch = std::env::temp_dir().join(format!("mshbm-fuzz-inputs-{}", std::process::id()));
    let harness = Harness::new(&scratch, o.budget_mib << 20);
    harness.check_seeds();
    let watchdog = Watchdog::new(o.time_limit);
    let per_input_peak = reset_peak_rss();
    println!(
        "seed {}, cases {}..{}, memory budget {} MiB, time limit {:?}, peak limit {} MiB ({})",
        o.seed,
        o.first,
        o.first + o.cases,
        o.budget_mib,
        o.time_limit,
        o.peak_limit >> 20,
        if per_input_peak {
            "peak resident memory per input"
        } else {
            "peak resident memory of the whole run: /proc/self/clear_refs not writable"
        }
    );
    let mut failed = false;
    for target in &o.targets {
        let start = Instant::now();
        let (mut accepted, mut refused, mut panics) = (0u64, 0u64, 0u64);
        let mut slowest = (Duration::ZERO, 0u64);
        let mut highest = (0u64, 0u64);
        for case in o.first..o.first + o.cases {
            let mut rng = Rng::for_target_case(o.seed, target, case);
            let input = harness.input(target, &mut rng);
            if o.show {
                println!("{target} case {case}: {}", show(&input.bytes));
            }
            if per_input_peak {
                reset_peak_rss();
            }
            watchdog.begin(target, case, o.seed, &input.bytes);
            let t = Instant::now();
            let outcome = catch_unwind(AssertUnwindSafe(|| harness.run(&input)));
            let took = t.elapsed();
            watchdog.end();
            if took > slowest.0 {
                slowest = (took, case);
            }
            let peak = peak_rss().unwrap_or(0);
            if peak > highest.0 {
                highest = (peak, case);
            }
            match outcome {
                Ok(true) => accepted += 1,
                Ok(false) => refused += 1,
                Err(_) => {
                    panics += 1;
                    failed = true;
                    std::fs::create_dir_all(&o.findings).unwrap();
                    let file = o.findings.join(format!("{target}-{case}.bin"));
                    std::fs::write(&file, &input.bytes).unwrap();
                    let message = last_panic.lock().unwrap_or_else(|e| e.into_inner()).clone();
                    println!(
                        "PANIC: target {target} case {case}: {message}\n  input {} (saved as {})",
                        show(&input.bytes),
                        file.display()
                    );
                }
            }
            if peak > o.peak_limit {
                println!(
                    "PEAK: target {target} case {case}: {} MiB resident, more than {} MiB, on input {}",
                    peak >> 20,
                    o.peak_limit >> 20,
                    show(&input.bytes)
                );
                std::process::exit(4);
            }
        }
        println!(
            "{target}: {} inputs in {:.1} s: {accepted} accepted, {refused} refused, {panics} panics; slowest {:.3} s (case {}), highest peak {} MiB (case {})",
            o.cases,
            start.elapsed().as_secs_f64(),
            slowest.0.as_secs_f64(),
            slowest.1,
            highest.0 >> 20,
            highest.1
        );
    }
    let _ = std::fs::remove_dir_all(&scratch);
    if failed {
        std::process::exit(1);
    }
}
