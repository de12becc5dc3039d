//! `--method hbm-aft`: the JSON of `solve`, the Fig. 11 overlay of `frf`, and clear errors
//! for bad `--penalty`/`--mass` values.

mod common;

use common::{assert_png, example, fails, numbers, success_json, FRD_HEADER};

fn gap0() -> String {
    example("clamped_bar_gap0.toml")
}

const DAMPED: [&str; 2] = ["--set", "damping.first_mode_ratio=0.01"];

#[test]
fn solve_json_reports_the_penalty_solution() {
    let g = gap0();
    for mass in ["consistent", "redistributed"] {
        let mut args = vec![
            "solve",
            &g,
            "--frequency",
            "60000",
            "--method",
            "hbm-aft",
            "--penalty",
            "1e8",
            "--mass",
            mass,
            "--json",
        ];
        args.extend(DAMPED);
        let v = success_json(&args);
        assert_eq!(v["method"], "hbm-aft");
        assert_eq!(v["quadrature"], "sampled");
        assert_eq!(v["converged"], true);
        assert_eq!(v["contact_dofs"], serde_json::json!([100]));
        let c = &v["contacts"][0];
        let ns = v["samples"].as_u64().unwrap() as usize;
        let (gap, force) = (numbers(&c["gap"]), numbers(&c["force"]));
        assert_eq!(gap.len(), ns);
        assert_eq!(c["coefficients"].as_array().unwrap().len(), 11);
        // penalty contact: the gap goes negative where the force acts, force = kp·(−g)
        assert!(gap.iter().any(|&g| g < 0.0), "{mass}: no penetration");
        for (g, f) in gap.iter().zip(&force) {
            assert!(*f >= 0.0);
            assert!(
                (f - 1e8 * (-g).max(0.0)).abs() <= 1e-6 * f.max(1.0),
                "{g} {f}"
            );
        }
        // the bar separates by about 0.32 mm at 60 kHz
        let min = c["min"].as_f64().unwrap();
        assert!(min < -0.3 && min > -0.34, "{mass}: {min}");
    }
}

#[test]
fn frf_overlays_the_ms_hbm_and_several_penalties() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("fig11.csv");
    let png = dir.path().join("fig11.png");
    let g = gap0();
    let mut args = vec![
        "frf",
        &g,
        "--from",
        "55000",
        "--to",
        "60000",
        "--method",
        "hbm-aft",
        "--penalty",
        "1e6,100x",
        "--overlay-mshbm",
        "--json",
    ];
    args.extend(DAMPED);
    let (c, p) = (csv.display().to_string(), png.display().to_string());
    args.extend(["--output", &c, "--plot", &p]);
    let v = success_json(&args);
    let branches = v["branches"].as_array().unwrap();
    let methods: Vec<&str> = branches
        .iter()
        .map(|b| b["method"].as_str().unwrap())
        .collect();
    assert_eq!(methods, ["redistributed", "hbm-aft", "hbm-aft"]);
    assert!(branches[0].get("penalty").is_none());
    assert_eq!(branches[1]["penalty"], 1e6);
    // 100x: 100 times the contact DOF's stiffness EA/h = 1.05e6 N/mm
    let kp = branches[2]["penalty"].as_f64().unwrap();
    assert!((kp / 1.05e8 - 1.0).abs() < 1e-12, "{kp}");
    assert!(branches[2]["label"].as_str().unwrap().contains("HBM-AFT"));
    for b in branches {
        assert_eq!(b["completed"], true, "{}", b["label"]);
        let pts = b["points"].as_array().unwrap();
        assert!(pts.len() > 3);
        let aft = b["method"] == "hbm-aft";
        assert_eq!(pts[0].get("max_penetration").is_some(), aft);
    }
    let text = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(
        rows[0],
        format!("{FRD_HEADER},method,penalty,max_penetration")
    );
    assert!(rows[1..].iter().all(|r| r.split(',').count() == 13));
    assert!(rows.iter().any(|r| r.contains(",hbm-aft,1.000000e6,")));
    assert_png(&png);
}

#[test]
fn bad_penalty_and_mass_options_are_one_clear_error_line() {
    let g = gap0();
    for (extra, expect) in [
        (vec!["--method", "hbm-aft", "--penalty", "-1"], "--penalty"),
        (vec!["--method", "hbm-aft", "--penalty", "0"], "--penalty"),
        (
            vec!["--method", "hbm-aft", "--penalty", "stiff"],
            "--penalty",
        ),
        (vec!["--method", "hbm-aft", "--penalty", "-5x"], "--penalty"),
        (
            vec!["--method", "hbm-aft", "--penalty", "1e6,1e7"],
            "one --penalty",
        ),
        (vec!["--penalty", "1e6"], "hbm-aft"),
        (vec!["--mass", "consistent"], "hbm-aft"),
    ] {
        let mut args = vec!["solve", &g, "--frequency", "60000"];
        args.extend(extra.iter().copied());
        let err = fails(&args);
        assert!(err.contains(expect), "{extra:?}: {err}");
    }
    let err = fails(&[
        "frf",
        &g,
        "--from",
        "55000",
        "--to",
        "60000",
        "--overlay-mshbm",
    ]);
    assert!(err.contains("--method hbm-aft"), "{err}");
}
