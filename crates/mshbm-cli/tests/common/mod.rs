//! Plumbing shared by the CLI tests: where the examples are, running the `mshbm` binary,
//! and the checks every test makes of its exit (success with stderr shown on failure, or
//! one clear `error: ` line and no panic) and of its JSON output.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Output;

use assert_cmd::Command;

/// The repository's `examples/` folder.
pub fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

/// Path of `examples/<name>` as a command-line argument.
pub fn example(name: &str) -> String {
    examples().join(name).display().to_string()
}

/// The `mshbm` binary, to add arguments that are paths.
pub fn command() -> Command {
    Command::cargo_bin("mshbm").unwrap()
}

/// Run `mshbm args…` to completion.
pub fn mshbm(args: &[&str]) -> Output {
    command().args(args).output().unwrap()
}

/// The run succeeded (its stderr is the message otherwise).
pub fn assert_success(out: &Output) {
    assert!(
        out.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The run's stdout as the one JSON object it must be.
pub fn stdout_json(out: &Output) -> serde_json::Value {
    serde_json::from_slice(&out.stdout).expect("stdout is exactly one JSON object")
}

/// Run `mshbm args…`, expect success, return its JSON object.
pub fn success_json(args: &[&str]) -> serde_json::Value {
    let out = mshbm(args);
    assert_success(&out);
    stdout_json(&out)
}

/// A failed run that printed exactly one non-blank stderr line, starting with `error: `,
/// and no panic; returns stderr.
pub fn one_error_line(out: &Output) -> String {
    checked_error_line(out, "")
}

/// Run `mshbm args…` and expect [`one_error_line`]; the arguments name the case in the
/// failure messages.
pub fn fails(args: &[&str]) -> String {
    checked_error_line(&mshbm(args), &format!(" for {args:?}"))
}

fn checked_error_line(out: &Output, case: &str) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(
        !out.status.success(),
        "expected failure{case}; stderr: {stderr}"
    );
    assert!(!stderr.contains("panicked"), "panic{case}: {stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(
        lines.len(),
        1,
        "expected one error line{case}, got: {stderr}"
    );
    assert!(lines[0].starts_with("error: "), "{stderr}");
    stderr
}

/// A JSON array of numbers as `f64`s.
pub fn numbers(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// The file starts with the PNG signature.
pub fn assert_png(path: &Path) {
    assert_eq!(
        &std::fs::read(path).unwrap()[1..4],
        b"PNG",
        "{}",
        path.display()
    );
}

/// The fields of the object of `mshbm solve --json`, which `mshbm simulate --steady-state
/// --json` shares.
pub const SOLVE_FIELDS: [&str; 12] = [
    "frequency_hz",
    "harmonics",
    "samples",
    "quadrature",
    "method",
    "converged",
    "iterations",
    "residual_norm",
    "time_s",
    "contact_dofs",
    "contacts",
    "response",
];

/// The CSV header of `mshbm frf` (the MS-HBM branches alone).
pub const FRD_HEADER: &str = "frequency_hz,harmonics,max_qn,min_qn,amplitude_h1,residual_norm,newton_iterations,fold,stable,max_multiplier";

pub mod resources;
