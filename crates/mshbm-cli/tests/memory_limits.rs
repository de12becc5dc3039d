//! Issue 46, item 2: what allocates in proportion to an argument or an input is checked
//! against the memory budget before it is allocated, and the default budget follows
//! `ulimit -v` (RLIMIT_AS): each case exits with status 1 and one `error:` line naming the
//! option or the file, never by SIGABRT. The cases under `prlimit --as` run where util-linux's
//! `prlimit` exists (skipped with a printed reason otherwise).

mod common;

use std::path::Path;
use std::process::Command;

use common::example;
use common::resources::run_measured;

/// The cap of the acceptance: 1.5 GB of address space.
const CAP: &str = "--as=1572864000";

fn binary() -> std::path::PathBuf {
    assert_cmd::cargo::cargo_bin("mshbm")
}

/// `mshbm args…` measured.
fn mshbm(args: &[&str], scratch: &Path) -> common::resources::Measured {
    let mut c = Command::new(binary());
    c.args(args);
    run_measured(c, scratch)
}

/// `prlimit <limit> mshbm args…` measured, `None` (with the reason printed) without
/// `prlimit`.
fn capped(limit: &str, args: &[&str], scratch: &Path) -> Option<common::resources::Measured> {
    let available = Command::new("prlimit")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !available {
        eprintln!("skipped: `prlimit` (util-linux) is not installed");
        return None;
    }
    let mut c = Command::new("prlimit");
    c.arg(limit).arg(binary()).args(args);
    Some(run_measured(c, scratch))
}

/// A file of `bytes` bytes starting with `head`, the rest a hole (no disk used).
fn sparse_file(path: &Path, head: &[u8], bytes: u64) {
    std::fs::write(path, head).unwrap();
    std::fs::OpenOptions::new()
        .write(true)
        .open(path)
        .unwrap()
        .set_len(bytes)
        .unwrap();
}

#[test]
fn vtk_samples_beyond_the_budget_are_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let vtk = dir.path().join("vtk");
    let vtk_arg = vtk.display().to_string();
    let bar = example("clamped_bar.toml");
    let args = [
        "solve",
        bar.as_str(),
        "--frequency",
        "30000",
        "--vtk",
        vtk_arg.as_str(),
        "--vtk-samples",
        "100000000",
    ];
    let m = mshbm(&args, dir.path());
    m.assert_clean_refusal(&["--vtk-samples 100000000", "memory limit"]);
    assert_eq!(m.status, 1);
    let mut low = args.to_vec();
    low.extend(["--max-memory", "1"]);
    let m = mshbm(&low, dir.path());
    m.assert_clean_refusal(&["--vtk-samples 100000000", "1.0 GiB"]);
    assert_eq!(m.status, 1);
    assert!(!vtk.exists(), "nothing created before the refusal");
    if let Some(m) = capped(CAP, &args, dir.path()) {
        m.assert_clean_refusal(&["--vtk-samples 100000000"]);
        assert_eq!(m.status, 1);
    }
    // `modes --vtk` with a count beyond the budget, likewise
    let m = mshbm(
        &[
            "modes",
            bar.as_str(),
            "--count",
            "100000000",
            "--vtk",
            vtk_arg.as_str(),
            "--max-memory",
            "1",
        ],
        dir.path(),
    );
    m.assert_clean_refusal(&["--count 100000000"]);
    assert_eq!(m.status, 1);
}

#[test]
fn a_huge_model_file_is_refused_by_its_size() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("model.toml");
    sparse_file(&model, b"kind = \"bar\"\nname = \"", 1 << 30);
    let arg = model.display().to_string();
    let m = mshbm(&["modes", arg.as_str()], dir.path());
    m.assert_clean_refusal(&["model.toml", "limit of a model file", "4.0 MiB"]);
    assert_eq!(m.status, 1);
    if let Some(m) = capped(CAP, &["modes", arg.as_str()], dir.path()) {
        m.assert_clean_refusal(&["model.toml"]);
        assert_eq!(m.status, 1);
    }
}

#[test]
fn a_huge_matrix_market_file_is_refused_within_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    for f in std::fs::read_dir(common::examples().join("bar_matrices")).unwrap() {
        let f = f.unwrap().path();
        std::fs::copy(&f, dir.path().join(f.file_name().unwrap())).unwrap();
    }
    // the whole gibibyte on the header's line (no line break): the reader never copies it
    sparse_file(
        &dir.path().join("stiffness.mtx"),
        b"%%MatrixMarket matrix coordinate real general",
        1 << 30,
    );
    let model = dir.path().join("model.toml").display().to_string();
    let m = mshbm(
        &["modes", model.as_str(), "--max-memory", "0.5"],
        dir.path(),
    );
    m.assert_clean_refusal(&["stiffness.mtx", "memory limit"]);
    assert_eq!(m.status, 1);
    if let Some(m) = capped(CAP, &["modes", model.as_str()], dir.path()) {
        assert_eq!(m.status, 1, "{}", m.stderr);
        assert!(m.stderr.contains("stiffness.mtx"), "{}", m.stderr);
        assert!(!m.stderr.contains("panicked"), "{}", m.stderr);
    }
}

#[test]
fn a_huge_from_solution_file_is_refused_by_its_size() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("solution.json");
    sparse_file(&json, b"{\"frequency_hz\": ", 2 << 30);
    let json_arg = json.display().to_string();
    let bar = example("clamped_bar.toml");
    for command in ["solve", "simulate"] {
        let mut args = vec![command, bar.as_str(), "--from-solution", json_arg.as_str()];
        if command == "solve" {
            args.extend(["--frequency", "30000"]);
        }
        let m = mshbm(&args, dir.path());
        m.assert_clean_refusal(&["solution.json", "--from-solution", "256.0 MiB"]);
        assert_eq!(m.status, 1);
        if let Some(m) = capped(CAP, &args, dir.path()) {
            m.assert_clean_refusal(&["solution.json"]);
            assert_eq!(m.status, 1);
        }
    }
}

/// The case: under `ulimit -v` of 1 GiB the default budget is what is left of the
/// address space, and the 2D solid of 10⁵ elements is refused by its plan (it aborted).
#[test]
fn the_default_budget_follows_the_address_space_limit() {
    let dir = tempfile::tempdir().unwrap();
    let model = example("cantilever_stop/model.toml");
    let Some(m) = capped(
        "--as=1073741824",
        &[
            "modes",
            model.as_str(),
            "--set",
            "solid.divisions=[1000,100]",
        ],
        dir.path(),
    ) else {
        return;
    };
    m.assert_clean_refusal(&["memory limit"]);
    assert_eq!(m.status, 1);
}

#[test]
fn samples_beyond_the_budget_of_the_outputs_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("contacts.csv").display().to_string();
    let bar = example("clamped_bar.toml");
    // a plan the method accepts, outputs it would not hold: refused before solving
    let m = mshbm(
        &[
            "solve",
            bar.as_str(),
            "--frequency",
            "30000",
            "--harmonics",
            "1",
            "--samples",
            "2000000",
            "--contacts-csv",
            csv.as_str(),
            "--max-memory",
            "0.2",
        ],
        dir.path(),
    );
    assert_eq!(m.status, 1, "{}", m.stderr);
    assert!(m.stderr.contains("memory limit"), "{}", m.stderr);
    assert!(!m.stderr.contains("panicked"), "{}", m.stderr);
}
