//! Wall time of `mshbm paper` (every figure of the paper, Fig. 9 with Floquet stability on
//! every point) against issue 18's target of 60 s on 2 cores: one run of the release
//! binary, its parts on as many threads as the machine has cores. Prints the time and
//! whether the target is met, and exits with status 1 when it is missed.
//!
//! `cargo bench -p mshbm-cli --bench paper_wall` (no repetitions: one run takes a minute;
//! close other work first, the machines are shared).

use std::process::{Command, ExitCode};
use std::time::Instant;

const TARGET_SECONDS: f64 = 60.0;

fn main() -> ExitCode {
    let out = tempfile::tempdir().expect("a temporary directory");
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let start = Instant::now();
    let status = Command::new(env!("CARGO_BIN_EXE_mshbm"))
        .args(["paper", "--output"])
        .arg(out.path())
        .stderr(std::process::Stdio::null())
        .status()
        .expect("mshbm runs");
    let seconds = start.elapsed().as_secs_f64();
    let met = status.success() && seconds <= TARGET_SECONDS;
    println!(
        "mshbm paper on {cores} cores: {seconds:.1} s wall ({}) — target ≤ {TARGET_SECONDS} s on 2 cores: {}",
        if status.success() { "every figure complete" } else { "FAILED" },
        if met { "met" } else { "missed" }
    );
    if met {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
