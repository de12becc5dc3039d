//! `mshbm solve --method mshbm` (general MS-HBM) on the examples: the JSON object and the
//! numbers of the library's acceptance tests (crates/mshbm/tests/general_mshbm.rs).

use std::path::Path;

use assert_cmd::Command;

fn example(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(name)
        .display()
        .to_string()
}

fn solve_json(args: &[&str]) -> serde_json::Value {
    let out = Command::cargo_bin("mshbm")
        .unwrap()
        .arg("solve")
        .args(args)
        .arg("--json")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn friction_oscillator_in_stick_slip() {
    let v = solve_json(&[
        &example("friction_oscillator/model.toml"),
        "--method",
        "mshbm",
        "--frequency",
        "4.25",
        "--harmonics",
        "10",
        "--samples",
        "512",
    ]);
    assert_eq!(v["method"], "mshbm");
    assert_eq!(v["converged"], true);
    assert_eq!(v["samples"], 512);
    // the friction DOF is the default response DOF of a model without contacts
    assert_eq!(v["response"]["dof"], 2);
    let max = v["response"]["max"].as_f64().unwrap();
    // full-system time integration: 8.8634e-5 (tests/general_mshbm.rs)
    assert!((max / 8.8634e-5 - 1.0).abs() < 0.02, "{max}");
}

#[test]
fn bar_with_impacts() {
    let v = solve_json(&[
        &example("clamped_bar_impact.toml"),
        "--method",
        "mshbm",
        "--frequency",
        "30000",
        "--harmonics",
        "10",
        "--samples",
        "1024",
        "--tolerance",
        "1e-4",
    ]);
    assert_eq!(v["converged"], true);
    let c = &v["contacts"][0];
    assert_eq!(c["dof"], 100);
    // full-system Moreau-Jean to steady state: max 0.20003, min -0.31827
    let (max, min) = (c["max"].as_f64().unwrap(), c["min"].as_f64().unwrap());
    assert!((max / 0.20003 - 1.0).abs() < 0.03, "{max}");
    assert!((min / -0.31827 - 1.0).abs() < 0.03, "{min}");
    assert!(c["force"]
        .as_array()
        .unwrap()
        .iter()
        .all(|f| f.as_f64().unwrap() >= 0.0));
}
