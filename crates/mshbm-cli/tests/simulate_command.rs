//! `mshbm simulate`: the JSON object of a steady state (the same as `mshbm solve --json`),
//! the CSV and plot outputs, starting from a solution file, and clear errors.

mod common;

use std::path::PathBuf;
use std::process::Output;

use common::{
    assert_success, example, fails, mshbm, one_error_line, stdout_json, success_json, SOLVE_FIELDS,
};

fn simulate(args: &[&str]) -> Output {
    let mut all = vec!["simulate"];
    all.extend_from_slice(args);
    mshbm(&all)
}

fn tmp(dir: &tempfile::TempDir, name: &str) -> PathBuf {
    dir.path().join(name)
}

/// A run that does not become periodic within its period limit prints the object with
/// `"periodic": false` and the change, and exits non-zero with one error line.
#[test]
fn steady_state_json_has_the_solve_fields_and_says_when_not_periodic() {
    let out = simulate(&[
        &example("clamped_bar.toml"),
        "--set",
        "damping.first_mode_ratio=0.01",
        "--frequency",
        "30000",
        "--steady-state",
        "--periods",
        "3",
        "--steps-per-period",
        "500",
        "--json",
    ]);
    let stderr = one_error_line(&out);
    assert!(stderr.contains("did not become periodic"), "{stderr}");
    // status 2: computed and written, but not a steady state (README, docs/safety.md)
    assert_eq!(out.status.code(), Some(2));
    let v = stdout_json(&out);
    for key in SOLVE_FIELDS {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    assert_eq!(v["method"], "time-integration");
    assert_eq!(v["quadrature"], "sampled");
    assert_eq!(v["periodic"], false);
    assert_eq!(v["converged"], false);
    assert_eq!(v["periods_simulated"], 3);
    assert_eq!(v["samples"], 500);
    assert_eq!(v["harmonics"], 10);
    assert!(v["period_change"].as_f64().unwrap() > 1e-6);
    assert_eq!(v["contact_dofs"], serde_json::json!([100]));
    let c = &v["contacts"][0];
    assert_eq!(c["coefficients"].as_array().unwrap().len(), 21);
    assert_eq!(c["displacement"].as_array().unwrap().len(), 500);
    assert_eq!(v["time_s"].as_array().unwrap().len(), 500);
    assert!(c["gap"]
        .as_array()
        .unwrap()
        .iter()
        .all(|g| g.as_f64().unwrap() >= 0.0));
}

/// `mshbm solve --json` → `mshbm simulate --from-solution`: a linear case (the gap is never
/// reached) starts on its orbit and is periodic within a few periods (up to the time
/// discretization error; from rest it takes hundreds); the frequency comes from the file
/// and both objects describe the same orbit.
#[test]
fn from_solution_starts_on_the_orbit() {
    let dir = tempfile::tempdir().unwrap();
    let model = example("clamped_bar.toml");
    let model_settings = [
        "--set",
        "damping.first_mode_ratio=0.01",
        "--set",
        "contact.gap=100",
    ];
    let mut args = vec!["solve", model.as_str(), "--frequency", "45000", "--json"];
    args.extend_from_slice(&model_settings);
    let solved = mshbm(&args);
    assert_success(&solved);
    let file = tmp(&dir, "solution.json");
    std::fs::write(&file, &solved.stdout).unwrap();
    let mut args = vec![
        model.as_str(),
        "--from-solution",
        file.to_str().unwrap(),
        "--steady-state",
        "--steps-per-period",
        "4000",
        "--periods",
        "20",
        "--json",
    ];
    args.extend_from_slice(&model_settings);
    let out = simulate(&args);
    assert_success(&out);
    let s = stdout_json(&solved);
    let v = stdout_json(&out);
    assert_eq!(v["periodic"], true);
    assert_eq!(v["frequency_hz"], s["frequency_hz"]);
    // from rest this takes hundreds of periods (1 % damping of the first mode)
    assert!(
        v["periods_simulated"].as_u64().unwrap() <= 5,
        "{}",
        v["periods_simulated"]
    );
    let (a, b) = (
        &v["contacts"][0]["coefficients"],
        &s["contacts"][0]["coefficients"],
    );
    let amp = b[1].as_f64().unwrap().hypot(b[2].as_f64().unwrap());
    for k in 0..3 {
        let d = (a[k].as_f64().unwrap() - b[k].as_f64().unwrap()).abs();
        assert!(d < 1e-4 * amp, "coefficient {k}: {} vs {}", a[k], b[k]);
    }
    // a different --frequency than the file's is refused
    let mut args = vec![
        model.as_str(),
        "--from-solution",
        file.to_str().unwrap(),
        "--frequency",
        "46000",
    ];
    args.extend_from_slice(&model_settings);
    let stderr = one_error_line(&simulate(&args));
    assert!(stderr.contains("differs"), "{stderr}");
}

#[test]
fn csv_has_a_header_and_one_row_per_step() {
    let dir = tempfile::tempdir().unwrap();
    let csv = tmp(&dir, "drop.csv");
    let out = simulate(&[
        &example("dropped_bar.toml"),
        "--periods",
        "0.25",
        "--steps-per-period",
        "4000",
        "--output",
        csv.to_str().unwrap(),
    ]);
    assert_success(&out);
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    assert_eq!(
        lines.next().unwrap(),
        "time_s,gap_c0,force_c0,energy,energy_normalized"
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 1001);
    assert_eq!(rows[0][0], 0.0);
    assert_eq!(rows[0][1], 4.5);
    assert_eq!(rows[0][4], 1.0);
    // a quarter period (4 time units): free fall until t = 3, then in contact
    let last = rows.last().unwrap();
    assert!((last[0] - 4.0).abs() < 1e-12);
    assert_eq!(last[1], 0.0);
    assert!(last[2] > 0.0);
    assert!(rows.iter().all(|r| (r[4] - 1.0).abs() < 1e-3));
    // no temporary file left behind
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

#[test]
fn plot_and_text_summary() {
    let dir = tempfile::tempdir().unwrap();
    let svg = tmp(&dir, "fig5.svg");
    let out = simulate(&[
        &example("dropped_bar.toml"),
        "--scheme",
        "moreau",
        "--restitution",
        "1",
        "--periods",
        "0.5",
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert_success(&out);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("Moreau-Jean (theta = 0.5, e_N = 1)"),
        "{stdout}"
    );
    assert!(stdout.contains("2L/c"), "{stdout}");
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.contains("<svg") && text.contains("closed form"));
}

#[test]
fn transient_json_summary() {
    let out = simulate(&[&example("dropped_bar.toml"), "--periods", "0.5", "--json"]);
    assert_success(&out);
    let v = stdout_json(&out);
    assert_eq!(v["steps"], 4000);
    assert_eq!(v["contacts"][0]["min_gap"], 0.0);
    assert!((v["energy_initial"].as_f64().unwrap() - 4.5).abs() < 1e-12);
    assert!((v["analytic_contact_duration_s"].as_f64().unwrap() - 2.0).abs() < 1e-12);
}

#[test]
fn bad_input_gives_one_clear_error() {
    let bar = example("clamped_bar.toml");
    let drop = example("dropped_bar.toml");
    for (args, expected) in [
        (
            vec![drop.as_str(), "--scheme", "moreau", "--restitution", "2"],
            "--restitution",
        ),
        (
            vec![drop.as_str(), "--scheme", "moreau", "--theta", "0.3"],
            "--theta",
        ),
        (vec![drop.as_str(), "--theta", "0.6"], "--scheme moreau"),
        (vec![bar.as_str()], "--frequency"),
        (vec![bar.as_str(), "--frequency", "0"], "--frequency"),
        (vec![drop.as_str(), "--steady-state"], "--frequency"),
        (
            vec![drop.as_str(), "--steps-per-period", "0"],
            "--steps-per-period",
        ),
        (
            vec![
                bar.as_str(),
                "--frequency",
                "30000",
                "--steady-state",
                "--dt",
                "1e-8",
            ],
            "--steps-per-period",
        ),
        (
            vec![
                bar.as_str(),
                "--frequency",
                "30000",
                "--from-solution",
                "/nonexistent.json",
            ],
            "nonexistent.json",
        ),
        (
            vec![
                bar.as_str(),
                "--frequency",
                "30000",
                "--set",
                "damping.beta=1e-9",
            ],
            "damping",
        ),
        (
            vec![drop.as_str(), "--set", "drop.height=2"],
            "exactly one of `height` and `kappa`",
        ),
        (
            vec![drop.as_str(), "--set", "drop.gravity=-1"],
            "drop.gravity",
        ),
        (vec![drop.as_str(), "--set", "drop.wind=1"], "wind"),
    ] {
        let stderr = one_error_line(&simulate(&args));
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
    }
}

/// Issue 15's acceptance case on the command line: the bar at 30 kHz with
/// `damping.alpha = 7587.745` on the redistributed scheme is periodic by the default
/// criterion (exit 0; the JSON says which criterion, its tolerance and the measured
/// scatter), its contact-DOF minimum is that of `mshbm solve --harmonics 10` within 1 %,
/// and the text report states the scatter. The whole-state criterion stays available and
/// refuses the same run within 20 periods.
#[test]
fn steady_state_of_the_30_khz_bar_is_periodic_by_its_response() {
    let bar = example("clamped_bar.toml");
    let common = [
        bar.as_str(),
        "--set",
        "damping.alpha=7587.745",
        "--frequency",
        "30000",
    ];
    let run = |extra: &[&str]| {
        let mut args = vec!["simulate"];
        args.extend_from_slice(&common);
        args.extend_from_slice(&["--steady-state", "--scheme", "redistributed"]);
        args.extend_from_slice(extra);
        mshbm(&args)
    };
    let out = run(&["--json"]);
    assert_success(&out);
    let v = stdout_json(&out);
    assert_eq!(v["periodic"], true);
    assert_eq!(v["converged"], true);
    assert_eq!(v["periodicity"], "response");
    assert_eq!(v["tolerance"], 1e-3);
    assert_eq!(v["samples"], 2000);
    let scatter = v["period_scatter"].as_f64().unwrap();
    assert!(scatter > 0.0 && scatter < 1e-3, "scatter {scatter}");
    assert!(v["period_change"].as_f64().unwrap() <= scatter);
    let mut args = vec!["solve"];
    args.extend_from_slice(&common);
    args.extend_from_slice(&["--harmonics", "10", "--json"]);
    let hb = success_json(&args);
    let (min_ti, min_hb) = (
        v["contacts"][0]["min"].as_f64().unwrap(),
        hb["contacts"][0]["min"].as_f64().unwrap(),
    );
    assert!(
        (min_ti - min_hb).abs() < 0.01 * min_hb.abs(),
        "min {min_ti} vs solve {min_hb}"
    );

    let out = run(&[]);
    assert_success(&out);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("periodic after") && text.contains("the harmonics 0..10 of DOF 100"),
        "{text}"
    );
    assert!(text.contains(&format!("{scatter:.2e}")), "{text}");

    let out = run(&["--periodicity", "state", "--periods", "20", "--json"]);
    let stderr = one_error_line(&out);
    assert!(
        stderr.contains("did not become periodic") && stderr.contains("--periodicity state"),
        "{stderr}"
    );
    let v = stdout_json(&out);
    assert_eq!(v["periodic"], false);
    assert_eq!(v["periodicity"], "state");
    assert_eq!(v["tolerance"], 1e-6);
    assert!(v["period_scatter"].as_f64().unwrap() > 1e-6);
}

/// Without load the steady state is the bar at rest, found at once with the default
/// steps per period (this used to fail with an internal error about the time step).
#[test]
fn steady_state_without_load_is_rest() {
    for periodicity in ["response", "state"] {
        let v = success_json(&[
            "simulate",
            &example("clamped_bar.toml"),
            "--set",
            "load.amplitude=0",
            "--frequency",
            "30000",
            "--steady-state",
            "--periodicity",
            periodicity,
            "--json",
        ]);
        assert_eq!(v["periodic"], true, "{periodicity}");
        assert_eq!(v["samples"], 2000);
        assert!(v["periods_simulated"].as_u64().unwrap() <= 3);
        assert_eq!(v["period_scatter"], 0.0);
        assert_eq!(v["contacts"][0]["max"], 0.0);
        assert_eq!(v["contacts"][0]["min"], 0.0);
    }
}

/// Bad steady-state settings: one clear line naming the option.
#[test]
fn bad_steady_state_settings_give_one_clear_error() {
    let bar = example("clamped_bar.toml");
    for (extra, expected) in [
        (vec!["--periods", "1"], "--periods"),
        (vec!["--tolerance", "0"], "--tolerance"),
    ] {
        let mut args = vec![
            "simulate",
            bar.as_str(),
            "--frequency",
            "30000",
            "--steady-state",
        ];
        args.extend_from_slice(&extra);
        let stderr = fails(&args);
        assert!(stderr.contains(expected), "{extra:?}: {stderr}");
    }
}

/// On a 2D solid every contact node has two DOFs; the solution's `unknowns` give both, so
/// that the simulation starts on the orbit: below the contact resonance of the cantilever
/// (no contact at 600 Hz) it is periodic within a few periods and equals the MS-HBM.
#[test]
fn from_solution_starts_a_2d_solid_on_the_orbit() {
    let dir = tempfile::tempdir().unwrap();
    let model = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/cantilever_stop/model.toml")
        .display()
        .to_string();
    let solved = mshbm(&[
        "solve",
        &model,
        "--frequency",
        "600",
        "--no-stability",
        "--json",
    ]);
    assert_success(&solved);
    let file = tmp(&dir, "solution.json");
    std::fs::write(&file, &solved.stdout).unwrap();
    let out = simulate(&[
        &model,
        "--from-solution",
        file.to_str().unwrap(),
        "--scheme",
        "redistributed",
        "--steady-state",
        "--steps-per-period",
        "512",
        "--periods",
        "20",
        "--json",
    ]);
    assert_success(&out);
    let (s, v) = (stdout_json(&solved), stdout_json(&out));
    assert_eq!(v["periodic"], true);
    assert!(v["periods_simulated"].as_u64().unwrap() <= 5);
    let max = |x: &serde_json::Value| x["response"]["max"].as_f64().unwrap();
    assert!(
        (max(&v) / max(&s) - 1.0).abs() < 1e-4,
        "{} vs {}",
        max(&v),
        max(&s)
    );
}

/// Issue 46, item 5: `simulate --from-solution` refuses another model's solution (its
/// `contact_dofs` are not the model's), naming the file, the field and both contact sets;
/// it extended it silently and exited with 0. A solution of another method of the same
/// model still starts it (its contact-node harmonics mean the same).
#[test]
fn from_solution_of_another_model_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let model = example("clamped_bar.toml");
    let solved = mshbm(&[
        "solve",
        model.as_str(),
        "--frequency",
        "30000",
        "--harmonics",
        "3",
        "--json",
    ]);
    assert_success(&solved);
    let mut other = stdout_json(&solved);
    other["contact_dofs"] = serde_json::json!([7]);
    let file = tmp(&dir, "other.json");
    std::fs::write(&file, other.to_string()).unwrap();
    let err = fails(&[
        "simulate",
        model.as_str(),
        "--periods",
        "1",
        "--from-solution",
        file.to_str().unwrap(),
    ]);
    assert!(
        err.contains("other.json: field `contact_dofs`")
            && err.contains("another model")
            && err.contains("DOFs [7]")
            && err.contains("DOFs [100]"),
        "{err}"
    );
    let same = tmp(&dir, "same.json");
    std::fs::write(&same, &solved.stdout).unwrap();
    let out = simulate(&[
        model.as_str(),
        "--periods",
        "1",
        "--from-solution",
        same.to_str().unwrap(),
    ]);
    assert_success(&out);
}

/// A run to a steady state written to a log (stderr not a terminal) shows its progress:
/// after its first second, a line per second at most with the period and its
/// period-to-period change (here a run of 1000 periods with an unreachable tolerance,
/// several seconds on the shared 2-core machine).
#[test]
fn a_long_steady_state_run_shows_its_progress_in_a_log() {
    let out = simulate(&[
        &example("clamped_bar.toml"),
        "--set",
        "damping.first_mode_ratio=0.01",
        "--frequency",
        "30000",
        "--steady-state",
        "--periods",
        "1000",
        "--steps-per-period",
        "2000",
        "--tolerance",
        "1e-300",
    ]);
    assert_eq!(out.status.code(), Some(2), "not periodic: status 2");
    let stderr = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("steady state: period "))
        .collect();
    assert!(!lines.is_empty(), "no progress line in {stderr}");
    assert!(lines[0].contains("period-to-period change"), "{}", lines[0]);
    assert!(stderr.contains("did not become periodic"), "{stderr}");
}

/// `mshbm simulate --steady-state --json` (redistributed scheme) → `mshbm solve
/// --from-solution`, as `solve --help` documents: the simulated steady state carries the
/// redistributed MS-HBM's unknowns, Newton starts from them and reaches the solution that
/// Newton from the linear response reaches (the bar at 30 kHz with contact, H = 3).
#[test]
fn a_simulated_steady_state_starts_newton() {
    let dir = tempfile::tempdir().unwrap();
    let model = example("clamped_bar.toml");
    let sets = [
        "--set",
        "damping.first_mode_ratio=0.01",
        "--set",
        "damping.beta_linear=1e-8",
    ];
    let mut args = vec![
        model.as_str(),
        "--frequency",
        "30000",
        "--steady-state",
        "--scheme",
        "redistributed",
        "--harmonics",
        "3",
        "--periods",
        "60",
        "--json",
    ];
    args.extend_from_slice(&sets);
    let simulated = simulate(&args);
    assert_success(&simulated);
    let steady = stdout_json(&simulated);
    assert_eq!(steady["method"], "time-integration");
    assert_eq!(steady["periodic"], true);
    let file = tmp(&dir, "steady.json");
    std::fs::write(&file, &simulated.stdout).unwrap();

    let solve = |start: &[&str]| -> serde_json::Value {
        let mut args = vec![
            "solve",
            model.as_str(),
            "--frequency",
            "30000",
            "--harmonics",
            "3",
            "--no-stability",
            "--json",
        ];
        args.extend_from_slice(start);
        args.extend_from_slice(&sets);
        let out = mshbm(&args);
        assert_success(&out);
        stdout_json(&out)
    };
    let from_steady = solve(&["--from-solution", file.to_str().unwrap()]);
    let direct = solve(&["--start", "linear"]);
    assert_eq!(from_steady["converged"], true);
    let force = |v: &serde_json::Value| -> f64 {
        v["contacts"][0]["force"]
            .as_array()
            .unwrap()
            .iter()
            .fold(0.0f64, |m, f| m.max(f.as_f64().unwrap()))
    };
    assert!(
        force(&direct) > 0.0 && force(&steady) > 0.0,
        "the bar touches the stop"
    );
    let (a, b) = (
        from_steady["unknowns"].as_array().unwrap(),
        direct["unknowns"].as_array().unwrap(),
    );
    let scale = b
        .iter()
        .fold(0.0f64, |m, v| m.max(v.as_f64().unwrap().abs()));
    assert!(scale > 0.0);
    for (x, y) in a.iter().zip(b) {
        let d = (x.as_f64().unwrap() - y.as_f64().unwrap()).abs();
        assert!(d <= 1e-8 * scale, "{x} vs {y} (scale {scale:e})");
    }
    // the simulation's contact displacements already satisfy the MS-HBM's equations to
    // its time-discretization error: Newton needs few iterations from them
    assert!(
        from_steady["iterations"].as_u64().unwrap() <= direct["iterations"].as_u64().unwrap(),
        "{} from the steady state, {} from the linear response",
        from_steady["iterations"],
        direct["iterations"]
    );
}
