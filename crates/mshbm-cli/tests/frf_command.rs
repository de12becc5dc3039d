//! `mshbm frf`: CSV streaming, JSON, plots, several harmonics, and failure reporting.

use std::path::Path;

use assert_cmd::Command;

fn bar() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/clamped_bar.toml")
        .display()
        .to_string()
}

const HEADER: &str =
    "frequency_hz,harmonics,max_qn,min_qn,amplitude_h1,residual_norm,newton_iterations,fold,stable,max_multiplier";

#[test]
fn csv_json_and_plot_for_two_branches() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("frd.csv");
    let png = dir.path().join("frd.png");
    let out = Command::cargo_bin("mshbm")
        .unwrap()
        .args([
            "frf",
            &bar(),
            "--from",
            "15000",
            "--to",
            "25000",
            "--harmonics",
            "1,3",
            "--set",
            "damping.first_mode_ratio=0.01",
            "--json",
        ])
        .args([
            "--output",
            &csv.display().to_string(),
            "--plot",
            &png.display().to_string(),
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    let branches = v["branches"].as_array().unwrap();
    assert_eq!(branches.len(), 2);
    assert_eq!(branches[0]["harmonics"], 1);
    assert_eq!(branches[1]["harmonics"], 3);
    for b in branches {
        let pts = b["points"].as_array().unwrap();
        assert!(pts.len() > 10);
        for key in ["frequency_hz", "max_qn", "min_qn", "amplitude_h1", "fold"] {
            assert!(pts[0].get(key).is_some(), "{key}");
        }
        assert!(pts
            .iter()
            .all(|p| p["max_qn"].as_f64().unwrap() <= 0.2 * (1.0 + 1e-12)));
        let last = pts.last().unwrap()["frequency_hz"].as_f64().unwrap();
        assert!((last - 25000.0).abs() < 1e-6, "{last}");
    }
    // H = 3 folds twice between 22.2 and 22.5 kHz
    let folds = v["folds"].as_array().unwrap();
    assert_eq!(
        folds.iter().filter(|f| f["harmonics"] == 3).count(),
        2,
        "{folds:?}"
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), HEADER);
    let rows: Vec<&str> = lines.collect();
    let points: usize = branches
        .iter()
        .map(|b| b["points"].as_array().unwrap().len())
        .sum();
    assert_eq!(rows.len(), points);
    assert_eq!(
        rows.iter()
            .filter(|r| r.split(',').nth(7) == Some("true"))
            .count(),
        folds.len()
    );
    assert_eq!(&std::fs::read(&png).unwrap()[1..4], b"PNG");
}

#[test]
fn injected_failure_keeps_the_points_and_says_where_it_stopped() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("frd.csv");
    let out = Command::cargo_bin("mshbm")
        .unwrap()
        .args([
            "frf",
            &bar(),
            "--from",
            "1000",
            "--to",
            "30000",
            "--harmonics",
            "3",
            "--set",
            "damping.first_mode_ratio=0.01",
        ])
        // one corrector iteration and no room to shrink the step: fails where contact starts
        .args([
            "--max-iterations",
            "1",
            "--step",
            "0.05",
            "--min-step",
            "0.05",
            "--max-step",
            "0.05",
        ])
        .args(["--output", &csv.display().to_string()])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        stderr.contains("error: continuation incomplete")
            && stderr.contains("stopped at")
            && stderr.contains("Hz"),
        "{stderr}"
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<&str> = text.lines().collect();
    assert_eq!(rows[0], HEADER);
    assert!(
        rows.len() > 2,
        "the points found before the failure are kept"
    );
    // every row is complete
    assert!(rows[1..].iter().all(|r| r.split(',').count() == 10));
}

#[test]
fn bad_ranges_are_clear_errors() {
    for args in [
        ["--from", "0", "--to", "100"],
        ["--from", "100", "--to", "100"],
    ] {
        let out = Command::cargo_bin("mshbm")
            .unwrap()
            .args(["frf", &bar()])
            .args(args)
            .output()
            .unwrap();
        assert!(!out.status.success());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            stderr.starts_with("error: ") && stderr.lines().count() == 1,
            "{stderr}"
        );
    }
}

#[test]
fn stability_columns_are_filled_with_stability() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("frd.csv");
    let out = Command::cargo_bin("mshbm")
        .unwrap()
        .args([
            "frf",
            &bar(),
            "--from",
            "20000",
            "--to",
            "23000",
            "--harmonics",
            "3",
            "--set",
            "damping.first_mode_ratio=0.01",
            "--stability",
            "--json",
        ])
        .args(["--output", &csv.display().to_string()])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let pts = v["branches"][0]["points"].as_array().unwrap();
    for p in pts {
        let stable = p["stable"]
            .as_bool()
            .expect("stable present with --stability");
        let m = p["max_multiplier"].as_f64().unwrap();
        assert_eq!(stable, m < 1.0 - 1e-9);
    }
    // every reported stability change sits between two points whose stability differs
    for b in v["bifurcations"].as_array().unwrap() {
        let f = b["frequency_hz"].as_f64().unwrap();
        assert!(
            ["fold", "period-doubling", "neimark-sacker"].contains(&b["kind"].as_str().unwrap())
        );
        assert!((20000.0..=23000.0).contains(&f), "{f}");
    }
    let text = std::fs::read_to_string(&csv).unwrap();
    for row in text.lines().skip(1) {
        let cols: Vec<&str> = row.split(',').collect();
        assert!(cols[8] == "true" || cols[8] == "false", "{row}");
        assert!(cols[9].parse::<f64>().unwrap() > 0.0);
    }
}
