//! `mshbm frf`: CSV streaming, JSON, plots, several harmonics, and failure reporting.

mod common;

use std::path::Path;
use std::process::Output;

use common::{assert_png, assert_success, example, mshbm, stdout_json, FRD_HEADER};

fn bar() -> String {
    example("clamped_bar.toml")
}

/// `mshbm frf` on the paper's bar with 1 % damping of the first mode from `from` to `to`
/// Hz with `harmonics`, the CSV written to `csv`, and `extra` options.
fn frf_damped_bar(from: &str, to: &str, harmonics: &str, csv: &Path, extra: &[&str]) -> Output {
    let (bar, csv) = (bar(), csv.display().to_string());
    let mut args = vec![
        "frf",
        &bar,
        "--from",
        from,
        "--to",
        to,
        "--harmonics",
        harmonics,
        "--set",
        "damping.first_mode_ratio=0.01",
        "--output",
        &csv,
    ];
    args.extend_from_slice(extra);
    mshbm(&args)
}

#[test]
fn csv_json_and_plot_for_two_branches() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("frd.csv");
    let png = dir.path().join("frd.png");
    let png_arg = png.display().to_string();
    let out = frf_damped_bar(
        "15000",
        "25000",
        "1,3",
        &csv,
        &["--json", "--plot", &png_arg],
    );
    assert_success(&out);
    let v = stdout_json(&out);
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
    // `#` lines are comments: the last one says how the run ended
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    assert_eq!(lines.next().unwrap(), FRD_HEADER);
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
    assert_png(&png);
}

#[test]
fn injected_failure_keeps_the_points_and_says_where_it_stopped() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("frd.csv");
    // one corrector iteration and no room to shrink the step: fails where contact starts
    let out = frf_damped_bar(
        "1000",
        "30000",
        "3",
        &csv,
        &[
            "--max-iterations",
            "1",
            "--step",
            "0.05",
            "--min-step",
            "0.05",
            "--max-step",
            "0.05",
        ],
    );
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
    let rows: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(rows[0], FRD_HEADER);
    assert!(
        rows.len() > 2,
        "the points found before the failure are kept"
    );
    // every row is complete
    assert!(rows[1..].iter().all(|r| r.split(',').count() == 10));
}

#[test]
fn bad_ranges_are_clear_errors() {
    let bar = bar();
    for range in [
        ["--from", "0", "--to", "100"],
        ["--from", "100", "--to", "100"],
    ] {
        let mut args = vec!["frf", bar.as_str()];
        args.extend(range);
        let out = mshbm(&args);
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
    let out = frf_damped_bar("20000", "23000", "3", &csv, &["--stability", "--json"]);
    assert_success(&out);
    let v = stdout_json(&out);
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
    for row in text.lines().skip(1).filter(|l| !l.starts_with('#')) {
        let cols: Vec<&str> = row.split(',').collect();
        assert!(cols[8] == "true" || cols[8] == "false", "{row}");
        assert!(cols[9].parse::<f64>().unwrap() > 0.0);
    }
}

/// HBM-AFT with stability on NLvib's example 03 (penalty spring 100, 61 harmonics): the
/// CSV lists each bifurcation as a comment line before the status line (the same ones as
/// the JSON, with their kinds: folds, period doublings and Neimark–Sacker bifurcations),
/// and the plot is drawn with them. Their physical meaning is tested in
/// `crates/mshbm/tests/hbm_aft_stability.rs`.
#[test]
fn hbm_aft_bifurcations_are_written_to_the_csv_and_the_json() {
    let dir = tempfile::tempdir().unwrap();
    let (csv, png) = (dir.path().join("frd.csv"), dir.path().join("frd.png"));
    let (model, csv_arg, png_arg) = (
        example("nlvib_03/model.toml"),
        csv.display().to_string(),
        png.display().to_string(),
    );
    let out = mshbm(&[
        "frf",
        &model,
        "--method",
        "hbm-aft",
        "--penalty",
        "100",
        "--harmonics",
        "61",
        "--from",
        "0.1273240",
        "--to",
        "0.0795775",
        "--stability",
        "--json",
        "--output",
        &csv_arg,
        "--plot",
        &png_arg,
    ]);
    assert_success(&out);
    let v = stdout_json(&out);
    let kinds: Vec<&str> = v["bifurcations"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| b["kind"].as_str().unwrap())
        .collect();
    for kind in ["fold", "period-doubling", "neimark-sacker"] {
        assert!(kinds.contains(&kind), "{kinds:?}");
    }
    let text = std::fs::read_to_string(&csv).unwrap();
    let comments: Vec<&str> = text
        .lines()
        .filter(|l| l.starts_with("# bifurcation"))
        .collect();
    assert_eq!(comments.len(), kinds.len(), "{text}");
    for (line, kind) in comments.iter().zip(&kinds) {
        let words = |s: &str| s.to_lowercase().replace('-', " ");
        assert!(words(line).contains(&words(kind)), "{line} vs {kind}");
    }
    assert!(text.lines().last().unwrap().starts_with("# finished"));
    assert_png(&png);
}

/// The friction damper of the README (`examples/friction_damper`, Coulomb friction on a
/// plane interface, docs/theory.md §20): its diagram through the friction-damped resonance
/// completes, every point converged, and `solve` reports the friction forces within the
/// cone and the energy they dissipate.
#[test]
fn the_friction_damper_diagram_completes() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("frd.csv");
    let model = example("friction_damper/model.toml");
    let csv_arg = csv.display().to_string();
    let out = mshbm(&[
        "frf",
        &model,
        "--from",
        "100",
        "--to",
        "1500",
        "--harmonics",
        "3",
        "--dof",
        "209",
        "--output",
        &csv_arg,
    ]);
    assert_success(&out);
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.contains("# finished"), "{text}");
    let rows = text.lines().filter(|l| !l.starts_with('#')).count();
    assert!(rows > 50, "{rows} rows");
    // the friction columns: energy and the mean state fractions (summing to 1) per point
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    assert!(
        header.ends_with(&["dissipated_energy", "stick", "slip", "open"]),
        "{header:?}"
    );
    let (mut stuck, mut slipping) = (0.0f64, 0.0f64);
    for line in text.lines().skip(1).filter(|l| !l.starts_with('#')) {
        let cells: Vec<f64> = line
            .rsplit(',')
            .take(4)
            .map(|c| c.parse().unwrap())
            .collect();
        let (open, slip, stick, energy) = (cells[0], cells[1], cells[2], cells[3]);
        assert!(energy >= 0.0, "{line}");
        assert!((stick + slip + open - 1.0).abs() <= 1e-6, "{line}");
        stuck = stuck.max(stick);
        slipping = slipping.max(slip);
    }
    assert!(
        stuck > 0.01 && slipping > 0.1,
        "stick {stuck}, slip {slipping}"
    );
    let contacts_csv = dir.path().join("contacts.csv");
    let contacts_arg = contacts_csv.display().to_string();
    let out = mshbm(&[
        "solve",
        &model,
        "--frequency",
        "1100",
        "--harmonics",
        "3",
        "--json",
        "--contacts-csv",
        &contacts_arg,
    ]);
    assert_success(&out);
    let json = stdout_json(&out);
    // each sample's state agrees with its forces: open without force, slip on the cone,
    // stick inside it
    let text = std::fs::read_to_string(&contacts_csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "interface,contact,nodes,position,time_s,gap,force,state,tangential_force,limit"
    );
    let mut met = std::collections::HashSet::new();
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        let number = |k: usize| cells[k].parse::<f64>().unwrap();
        let (normal, tangential, limit) = (number(6), number(8), number(9));
        match cells[7] {
            "open" => assert!(normal == 0.0 && tangential == 0.0, "{line}"),
            "slip" => assert!(
                (tangential.abs() - limit).abs() <= 1e-9 * limit.max(1e-300),
                "{line}"
            ),
            "stick" => assert!(
                normal > 0.0 && tangential.abs() <= limit * (1.0 + 1e-9),
                "{line}"
            ),
            other => panic!("state {other}"),
        }
        met.insert(cells[7].to_string());
    }
    assert!(met.contains("stick") && met.contains("slip"), "{met:?}");
    let fractions = json["state_fractions"].as_array().expect("state fractions");
    assert_eq!(fractions.len(), 5);
    for f in fractions {
        let sum: f64 = ["stick", "slip", "open"]
            .iter()
            .map(|k| f[k].as_f64().unwrap())
            .sum();
        assert!((sum - 1.0).abs() <= 1e-12, "{f}");
    }
    let frictions = json["frictions"].as_array().expect("friction series");
    assert_eq!(frictions.len(), 5);
    for f in frictions {
        let (force, limit) = (
            f["force"].as_array().unwrap(),
            f["limit"].as_array().unwrap(),
        );
        for (t, l) in force.iter().zip(limit) {
            let (t, l) = (t.as_f64().unwrap(), l.as_f64().unwrap());
            assert!(
                t.abs() <= l + 1e-9,
                "friction force {t} outside the cone {l}"
            );
        }
    }
    assert!(json["dissipated_energy"].as_f64().unwrap() > 0.0);
}

/// Issue 46, item 5: frequencies far below 1 Hz are written with their digits, not as
/// `0.000000000` in every row.
#[test]
fn tiny_frequencies_keep_their_digits() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("tiny.csv");
    let out = common::command()
        .args([
            "frf",
            &common::example("clamped_bar.toml"),
            "--from",
            "1e-300",
            "--to",
            "1e-299",
            "--harmonics",
            "1",
            "--output",
        ])
        .arg(&csv)
        .output()
        .unwrap();
    common::assert_success(&out);
    let text = std::fs::read_to_string(&csv).unwrap();
    let frequencies: Vec<f64> = text
        .lines()
        .skip(1)
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert!(frequencies.len() > 2, "{text}");
    for f in &frequencies {
        assert!((1e-300..=1.0000001e-299).contains(f), "{f:e} in {text}");
    }
}
