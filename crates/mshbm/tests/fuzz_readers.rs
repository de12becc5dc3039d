//! Smoke run of the fuzz campaign (`tests/fuzz/mod.rs`; the campaign itself,
//! ≥ 10⁵ inputs per target, is `tools/fuzz-inputs`): the model reader, the Matrix Market
//! reader, the contact and gap tables a model names, `--set` overrides, Gmsh meshes, Abaqus input files and
//! `--from-solution` JSON, and (a second test, 10⁵ inputs) Abaqus and Harwell–Boeing
//! matrices and binary Gmsh meshes, each fed inputs mutated from a committed seed corpus
//! (`tests/fuzz_corpus/` and the examples) by a deterministic generator. Every input must
//! give `Ok` or `Err` — never a panic — within 2 s (a watchdog ends the run after 10 s),
//! with a memory budget of 16 MiB.
//!
//! `MSHBM_FUZZ_CASES` multiplies the number of inputs (default 1), `MSHBM_FUZZ_SEED` sets
//! the generator's seed (default fixed, so a failure is reproducible).

mod fuzz;

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::{Duration, Instant};

use fuzz::{show, Harness, Rng, Watchdog};

/// The longest an input may take.
const TIME_LIMIT: Duration = Duration::from_secs(2);

fn env(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Run `cases` inputs of `target`: no panic, each within [`TIME_LIMIT`], and some inputs
/// accepted and some refused (or the target would not exercise both paths).
fn campaign(harness: &Harness, watchdog: &Watchdog, target: &str, cases: u64) {
    let seed = env("MSHBM_FUZZ_SEED", 0x005E_ED15);
    let (mut ok, mut err) = (0u64, 0u64);
    for case in 0..cases {
        let mut rng = Rng::for_target_case(seed, target, case);
        let input = harness.input(target, &mut rng);
        watchdog.begin(target, case, seed, &input.bytes);
        let start = Instant::now();
        let outcome = catch_unwind(AssertUnwindSafe(|| harness.run(&input)));
        let took = start.elapsed();
        watchdog.end();
        match outcome {
            Ok(true) => ok += 1,
            Ok(false) => err += 1,
            Err(_) => panic!(
                "{target}, case {case}: the reader panicked on input {}",
                show(&input.bytes)
            ),
        }
        assert!(
            took <= TIME_LIMIT,
            "{target}, case {case}: took {took:?} on input {}",
            show(&input.bytes)
        );
    }
    assert!(
        ok > 0 && err > cases / 10,
        "{target}: {ok} accepted, {err} refused of {cases}"
    );
}

#[test]
fn every_reader_returns_ok_or_err_on_mutated_inputs() {
    let scale = env("MSHBM_FUZZ_CASES", 1);
    let scratch = tempfile_dir("readers");
    let harness = Harness::new(&scratch, 16 << 20);
    harness.check_seeds();
    let watchdog = Watchdog::new(Duration::from_secs(10));
    for (target, cases) in [
        ("model", 4000),
        ("matrix", 4000),
        ("tables", 1000),
        ("overrides", 1000),
        ("mesh", 2000),
        ("inp", 2000),
        ("solution", 300),
    ] {
        campaign(&harness, &watchdog, target, cases * scale);
    }
    let _ = std::fs::remove_dir_all(&scratch);
}

/// The readers of the commercial codes' matrix formats and of binary Gmsh meshes: 10⁵
/// inputs in all, one target after the other (run in parallel, they slowed the test
/// above beyond its time limit per input on a loaded machine), each reader's ok/err
/// balance checked as above.
#[test]
fn matrix_format_and_binary_mesh_readers_return_ok_or_err_on_mutated_inputs() {
    let scale = env("MSHBM_FUZZ_CASES", 1);
    let scratch = tempfile_dir("formats");
    let harness = Harness::new(&scratch, 16 << 20);
    harness.check_format_seeds();
    let watchdog = Watchdog::new(Duration::from_secs(10));
    for (target, cases) in [
        ("abaqus_matrix", 40_000),
        ("harwell_boeing", 40_000),
        ("binary_mesh", 20_000),
    ] {
        campaign(&harness, &watchdog, target, cases * scale);
    }
    let _ = std::fs::remove_dir_all(&scratch);
}

fn tempfile_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("mshbm-fuzz-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
