//! `mshbm solve --method mshbm` (general MS-HBM) on the examples: the JSON object and the
//! numbers of the library's acceptance tests (crates/mshbm/tests/general_mshbm.rs).

mod common;

use common::{assert_success, example, mshbm, success_json};

/// `solve --method mshbm --json` of the friction oscillator in stick–slip (4.25 Hz, H = 10,
/// 512 steps), the run two tests below read.
fn friction_oscillator_json() -> serde_json::Value {
    solve_json(&[
        &example("friction_oscillator/model.toml"),
        "--method",
        "mshbm",
        "--frequency",
        "4.25",
        "--harmonics",
        "10",
        "--samples",
        "512",
    ])
}

fn solve_json(args: &[&str]) -> serde_json::Value {
    let mut all = vec!["solve"];
    all.extend_from_slice(args);
    all.push("--json");
    success_json(&all)
}

#[test]
fn friction_oscillator_in_stick_slip() {
    let v = friction_oscillator_json();
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

/// `solve --json` of the general MS-HBM reports the friction force of every step with its
/// limit (never exceeded: issue 7), and the Floquet multipliers (issue 8).
#[test]
fn friction_forces_and_multipliers_in_the_json() {
    let v = friction_oscillator_json();
    let f = &v["frictions"][0];
    assert_eq!(f["dof"], 2);
    let force: Vec<f64> = f["force"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let limit: Vec<f64> = f["limit"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!(force.len(), 512);
    // μ F_N = 0.3 N (examples/friction_oscillator/model.toml) at every step
    assert!(limit.iter().all(|&l| l == 0.3));
    assert!(force.iter().zip(&limit).all(|(p, l)| p.abs() <= *l));
    // stick-slip: some steps at the limit, some strictly inside
    assert!(force.iter().any(|p| p.abs() == 0.3));
    assert!(force.iter().any(|p| p.abs() < 0.29));
    assert_eq!(f["max"].as_f64().unwrap(), 0.3);
    // multipliers: 2 per DOF of the whole model, stable (the simulation started on this
    // orbit settles: tests/general_mshbm.rs, floquet_verdict_agrees_with_time_integration)
    let st = &v["stability"];
    assert_eq!(st["multipliers"].as_array().unwrap().len(), 6);
    assert_eq!(st["stable"], true);
    let largest = st["max_multiplier"].as_f64().unwrap();
    assert!((largest - 0.81).abs() < 0.02, "{largest}");
}

/// `frf --method mshbm` traces the bar with impacts over 89–91 kHz (H = 3): every point
/// converged to 1e-10, the contact DOF reaches the support without penetrating, and the
/// minimum near 90 kHz is that of full-system time integration (−0.23205 mm at H = 10,
/// tests/general_mshbm.rs) within 3 %. (Event-driven, the continuation's last arclength
/// point may pass the end frequency by a fraction of its step.)
#[test]
fn frf_traces_the_bar_with_impacts() {
    let dir = std::env::temp_dir().join(format!("mshbm_general_frf_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let csv = dir.join("frd.csv");
    let model = example("clamped_bar_impact.toml");
    let csv_path = csv.display().to_string();
    let out = mshbm(&[
        "frf",
        &model,
        "--method",
        "mshbm",
        "--from",
        "89000",
        "--to",
        "91000",
        "--harmonics",
        "3",
        "--samples",
        "512",
        "--output",
        &csv_path,
    ]);
    assert_success(&out);
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            l.split(',')
                .map(|v| v.parse::<f64>().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    assert!(rows.len() >= 5, "{text}");
    let f: Vec<f64> = rows.iter().map(|r| r[col("frequency_hz")]).collect();
    assert_eq!(f[0], 89000.0);
    let last = *f.last().unwrap();
    assert!((91000.0..91010.0).contains(&last), "{last}");
    assert!(f.windows(2).all(|w| w[1] > w[0]));
    for r in &rows {
        assert!(r[col("residual_norm")] <= 1e-10);
        assert!((r[col("max_qn")] - 0.2).abs() < 1e-12);
    }
    let near = rows
        .iter()
        .min_by(|a, b| (a[0] - 90000.0).abs().total_cmp(&(b[0] - 90000.0).abs()))
        .unwrap();
    let min = near[col("min_qn")];
    assert!((min / -0.23205 - 1.0).abs() < 0.03, "{min}");
    let _ = std::fs::remove_dir_all(&dir);
}
