//! The Floquet analysis never hangs and never reports a verdict it could not compute: on a
//! bar 10²⁶–10¹⁰⁷ times too heavy (every multiplier 1, the monodromy nearly defective)
//! the default stability step spun for hours in faer's multishift QR; on a bar 10²⁰⁰ times
//! too light the monodromy overflows and the verdict is "unknown", with its reason, while
//! the solution is still reported (docs/safety.md, "Floquet multipliers").

mod common;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::example;

/// How long a run may take (it takes milliseconds).
const DEADLINE: Duration = Duration::from_secs(5);

/// Run `mshbm args…` in `dir` with a deadline: killed (SIGKILL; SIGTERM only asks it to
/// stop at its next write) and the test failed when it does not end in time. Returns
/// (exit status, stdout, stderr).
fn run_with_deadline(dir: &Path, args: &[&str]) -> (i32, String, String) {
    let stdout = dir.join("stdout.txt");
    let stderr = dir.join("stderr.txt");
    let mut child = Command::new(assert_cmd::cargo::cargo_bin("mshbm"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&stdout).unwrap())
        .stderr(std::fs::File::create(&stderr).unwrap())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > DEADLINE {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{args:?} did not end within {DEADLINE:?}");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let code = status.code().expect("exited, not killed by a signal");
    (
        code,
        std::fs::read_to_string(stdout).unwrap(),
        std::fs::read_to_string(stderr).unwrap(),
    )
}

#[test]
fn a_nearly_defective_monodromy_ends_with_a_verdict() {
    let dir = tempfile::tempdir().unwrap();
    let model = example("clamped_bar.toml");
    for density in ["4.5399273763614794e+26", "5.871237073272992e+107"] {
        let set = format!("bar.density={density}");
        let solve = [
            "solve",
            &model,
            "--set",
            &set,
            "--frequency",
            "30000",
            "--harmonics",
            "1",
        ];
        let (code, stdout, stderr) = run_with_deadline(dir.path(), &solve);
        assert!(matches!(code, 0..=2), "{density}: {code}: {stderr}");
        assert_eq!(code, 0, "{density}: {stderr}");
        // undamped: every multiplier on the unit circle
        assert!(
            stdout.contains("largest Floquet multiplier modulus 1.000000"),
            "{density}: {stdout}"
        );
        let mut json = solve.to_vec();
        json.push("--json");
        let (code, stdout, stderr) = run_with_deadline(dir.path(), &json);
        assert_eq!(code, 0, "{density}: {stderr}");
        let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        assert!(v["stability"]["max_multiplier"].is_number(), "{stdout}");

        let frf = [
            "frf",
            &model,
            "--set",
            &set,
            "--from",
            "29000",
            "--to",
            "31000",
            "--harmonics",
            "1",
            "--stability",
            "--output",
            "frf.csv",
        ];
        let (code, _, stderr) = run_with_deadline(dir.path(), &frf);
        assert!(matches!(code, 0..=2), "{density}: {code}: {stderr}");
        let csv = std::fs::read_to_string(dir.path().join("frf.csv")).unwrap();
        let rows: Vec<&str> = csv.lines().filter(|l| !l.starts_with('#')).collect();
        assert!(rows.len() > 2, "{csv}");
        // every point has a verdict: `stable` and `max_multiplier` filled
        assert!(
            rows[1..].iter().all(|r| {
                let c: Vec<&str> = r.split(',').collect();
                matches!(c[8], "true" | "false") && c[9].parse::<f64>().is_ok()
            }),
            "{csv}"
        );
    }
}

#[test]
fn a_verdict_that_cannot_be_computed_is_unknown_with_its_reason() {
    let dir = tempfile::tempdir().unwrap();
    let model = example("clamped_bar.toml");
    // a bar 10²⁰⁰ times too light: the monodromy over a period overflows
    let solve = [
        "solve",
        &model,
        "--set",
        "bar.density=1e-200",
        "--frequency",
        "30000",
        "--harmonics",
        "1",
    ];
    let (code, stdout, stderr) = run_with_deadline(dir.path(), &solve);
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains("converged: true")
            && stdout.contains("stability unknown: ")
            && stdout.contains("not finite")
            && !stdout.contains("inf"),
        "{stdout}"
    );
    let mut json = solve.to_vec();
    json.push("--json");
    let (code, stdout, stderr) = run_with_deadline(dir.path(), &json);
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert!(v["converged"].as_bool().unwrap());
    assert!(v.get("stability").is_none(), "{stdout}");
    assert!(
        v["stability_unknown"]
            .as_str()
            .is_some_and(|s| s.contains("not finite")),
        "{stdout}"
    );

    let frf = [
        "frf",
        &model,
        "--set",
        "bar.density=1e-200",
        "--from",
        "29000",
        "--to",
        "31000",
        "--harmonics",
        "1",
        "--stability",
        "--output",
        "frf.csv",
    ];
    let (code, stdout, stderr) = run_with_deadline(dir.path(), &frf);
    assert_eq!(code, 0, "the diagram goes on: {stderr}");
    assert!(stdout.contains("stability unknown (H = 1): "), "{stdout}");
    let csv = std::fs::read_to_string(dir.path().join("frf.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().filter(|l| !l.starts_with('#')).collect();
    assert!(rows.len() > 2, "{csv}");
    // the `stable` column says "unknown", `max_multiplier` is empty
    assert!(rows[1..].iter().all(|r| r.ends_with(",unknown,")), "{csv}");
    assert!(
        csv.lines()
            .any(|l| l.starts_with("# stability unknown (H = 1): ")),
        "{csv}"
    );
}
