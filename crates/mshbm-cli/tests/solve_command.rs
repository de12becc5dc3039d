//! `mshbm solve`: the JSON object, CSV and plot outputs, and clear errors.

mod common;

use std::path::PathBuf;
use std::process::Output;

use common::{assert_success, example, mshbm, one_error_line, stdout_json, SOLVE_FIELDS};

fn bar() -> String {
    example("clamped_bar.toml")
}

/// `mshbm solve args…`.
fn run(args: &[&str]) -> Output {
    let mut all = vec!["solve"];
    all.extend_from_slice(args);
    mshbm(&all)
}

#[test]
fn json_object_has_every_field() {
    let out = run(&[
        &bar(),
        "--frequency",
        "60000",
        "--harmonics",
        "5",
        "--set",
        "damping.first_mode_ratio=0.01",
        "--json",
    ]);
    assert_success(&out);
    let v = stdout_json(&out);
    for key in SOLVE_FIELDS {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    assert_eq!(v["method"], "redistributed");
    assert_eq!(v["quadrature"], "exact");
    assert_eq!(v["converged"], true);
    assert_eq!(v["contact_dofs"], serde_json::json!([100]));
    let c = &v["contacts"][0];
    assert_eq!(c["coefficients"].as_array().unwrap().len(), 11);
    let ns = v["samples"].as_u64().unwrap() as usize;
    assert_eq!(c["displacement"].as_array().unwrap().len(), ns);
    assert_eq!(v["time_s"].as_array().unwrap().len(), ns);
    assert!(c["force"]
        .as_array()
        .unwrap()
        .iter()
        .all(|f| f.as_f64().unwrap() >= 0.0));
    assert!(c["max"].as_f64().unwrap() <= 0.2 * (1.0 + 1e-12));
    assert_eq!(v["response"]["dof"], 100);
    assert_eq!(v["response"]["coefficients"], c["coefficients"]);
}

#[test]
fn response_of_another_dof_and_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let csv: PathBuf = dir.path().join("period.csv");
    let svg = dir.path().join("fig10.svg");
    let out = run(&[
        &bar(),
        "--frequency",
        "60000",
        "--harmonics",
        "3",
        "--quadrature",
        "sampled",
        "--samples",
        "400",
        "--set",
        "damping.alpha=7587.7",
        "--dof",
        "50",
        "--json",
        "--output",
        &csv.display().to_string(),
        "--plot",
        &svg.display().to_string(),
    ]);
    assert_success(&out);
    let v = stdout_json(&out);
    assert_eq!(v["response"]["dof"], 50);
    assert_eq!(v["samples"], 400);
    assert_eq!(v["quadrature"], "sampled");
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), "time_s,q_dof100,gap_c0,force_c0");
    assert_eq!(lines.count(), 400);
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
}

#[test]
fn too_few_samples_is_an_error() {
    let out = run(&[
        &bar(),
        "--frequency",
        "60000",
        "--harmonics",
        "5",
        "--samples",
        "10",
    ]);
    let err = one_error_line(&out);
    assert!(err.contains("2H+1"), "{err}");
}

#[test]
fn zero_harmonics_is_an_error() {
    let err = one_error_line(&run(&[&bar(), "--frequency", "60000", "--harmonics", "0"]));
    assert!(err.contains("harmonics"), "{err}");
}

#[test]
fn non_convergence_is_reported_with_the_solution_and_a_non_zero_exit() {
    let out = run(&[
        &bar(),
        "--frequency",
        "60000",
        "--set",
        "damping.first_mode_ratio=0.01",
        "--start",
        "linear",
        "--max-iterations",
        "1",
        "--json",
    ]);
    let err = one_error_line(&out);
    assert!(
        err.contains("did not converge") && err.contains("60000"),
        "{err}"
    );
    let v = stdout_json(&out);
    assert_eq!(v["converged"], false);
}

#[test]
fn stiffness_proportional_damping_is_refused_with_the_reason() {
    let err = one_error_line(&run(&[
        &bar(),
        "--frequency",
        "60000",
        "--set",
        "damping.beta=1e-8",
    ]));
    assert!(
        err.contains("C_NN") && err.contains("damping.alpha"),
        "{err}"
    );
}

#[test]
fn dof_out_of_range_is_an_error() {
    let err = one_error_line(&run(&[&bar(), "--frequency", "60000", "--dof", "101"]));
    assert!(err.contains("--dof"), "{err}");
}

/// `--from-solution` starts Newton from the unknowns that `solve --json` writes: at the same
/// frequency Newton has nothing left to do; a solution with another number of harmonics
/// starts Newton with harmonics added or dropped, a malformed one is refused naming the
/// file; the file is an input that no output may overwrite.
#[test]
fn a_solve_starts_from_an_earlier_solution() {
    let dir = tempfile::tempdir().unwrap();
    let first = run(&[
        &bar(),
        "--frequency",
        "60000",
        "--set",
        "damping.first_mode_ratio=0.01",
        "--no-stability",
        "--json",
    ]);
    assert_success(&first);
    let v = stdout_json(&first);
    // H = 5 on the bar's one contact node (1 DOF): 11 unknowns
    assert_eq!(v["unknowns"].as_array().unwrap().len(), 11);
    let file = dir.path().join("solution.json");
    std::fs::write(&file, &first.stdout).unwrap();
    let f = file.display().to_string();
    let again = run(&[
        &bar(),
        "--frequency",
        "60000",
        "--set",
        "damping.first_mode_ratio=0.01",
        "--no-stability",
        "--from-solution",
        &f,
        "--json",
    ]);
    assert_success(&again);
    let w = stdout_json(&again);
    assert_eq!(w["iterations"], 0);
    // the same coefficients; the extremes found by a search over the period to round-off
    assert_eq!(w["response"]["coefficients"], v["response"]["coefficients"]);
    let min = |x: &serde_json::Value| x["response"]["min"].as_f64().unwrap();
    assert!((min(&w) - min(&v)).abs() < 1e-12, "{} {}", min(&w), min(&v));
    let near = run(&[
        &bar(),
        "--frequency",
        "60500",
        "--set",
        "damping.first_mode_ratio=0.01",
        "--no-stability",
        "--from-solution",
        &f,
    ]);
    assert_success(&near);
    // another H: the H = 5 solution padded with zero harmonics starts Newton at H = 10
    let other_h = run(&[
        &bar(),
        "--frequency",
        "60000",
        "--set",
        "damping.first_mode_ratio=0.01",
        "--no-stability",
        "--harmonics",
        "10",
        "--from-solution",
        &f,
        "--json",
    ]);
    assert_success(&other_h);
    assert_eq!(
        stdout_json(&other_h)["unknowns"].as_array().unwrap().len(),
        21
    );
    // unknowns that are no whole number of signals are refused naming the file
    let mut broken = v.clone();
    broken["unknowns"].as_array_mut().unwrap().pop();
    let broken_file = dir.path().join("broken.json");
    std::fs::write(&broken_file, broken.to_string()).unwrap();
    let err = one_error_line(&run(&[
        &bar(),
        "--frequency",
        "60000",
        "--from-solution",
        &broken_file.display().to_string(),
    ]));
    assert!(
        err.contains("broken.json") && err.contains("whole number"),
        "{err}"
    );
    // another method's solution (the HBM-AFT's unknowns mean something else) and another
    // model's (its contacts elsewhere) are refused, naming the file and the reason
    let mut aft = v.clone();
    aft["method"] = "hbm-aft".into();
    let aft_file = dir.path().join("aft.json");
    std::fs::write(&aft_file, aft.to_string()).unwrap();
    let err = one_error_line(&run(&[
        &bar(),
        "--frequency",
        "60000",
        "--from-solution",
        &aft_file.display().to_string(),
    ]));
    assert!(
        err.contains("aft.json") && err.contains("method hbm-aft, not of redistributed"),
        "{err}"
    );
    let mut other = v.clone();
    other["contact_dofs"] = serde_json::json!([7]);
    let other_file = dir.path().join("other.json");
    std::fs::write(&other_file, other.to_string()).unwrap();
    let err = one_error_line(&run(&[
        &bar(),
        "--frequency",
        "60000",
        "--from-solution",
        &other_file.display().to_string(),
    ]));
    assert!(
        err.contains("other.json") && err.contains("another model") && err.contains("DOFs [7]"),
        "{err}"
    );
    let overwrite = run(&[
        &bar(),
        "--frequency",
        "60000",
        "--from-solution",
        &f,
        "--output",
        &f,
    ]);
    let err = one_error_line(&overwrite);
    assert!(err.contains("--from-solution"), "{err}");
    assert_eq!(
        std::fs::read(&file).unwrap(),
        first.stdout,
        "the input was kept"
    );
}

/// `--sweep-from` traces the branch and says how many solutions it met; a frequency outside
/// the swept range is refused before anything is computed.
#[test]
fn a_sweep_lists_the_solutions_it_met() {
    let model = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../mshbm/tests/data/cantilever_q4/model.toml")
        .display()
        .to_string();
    let out = run(&[
        &model,
        "--frequency",
        "1040",
        "--sweep-from",
        "500",
        "--sweep-to",
        "1100",
        "--no-stability",
    ]);
    assert_success(&out);
    assert!(
        out_text(&out.stderr).contains("3 periodic solutions coexist at 1040 Hz"),
        "{}",
        out_text(&out.stderr)
    );
    assert!(out_text(&out.stderr).contains("solution 3:"));
    let out = run(&[
        &model,
        "--frequency",
        "1040",
        "--sweep-from",
        "1100",
        "--sweep-to",
        "1200",
    ]);
    let err = one_error_line(&out);
    assert!(
        err.contains("--frequency 1040 Hz must lie between"),
        "{err}"
    );
}

fn out_text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// `--contacts-csv` writes one row per contact and time sample with the interface's name,
/// the node and its position along the interface, equal to the JSON series; `--contact-map`
/// draws a force and a gap panel per interface; neither may overwrite an input.
#[test]
fn contact_state_along_an_interface() {
    let dir = tempfile::tempdir().unwrap();
    let model = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/cantilever_stop/model.toml")
        .display()
        .to_string();
    let csv = dir.path().join("contacts.csv");
    let map = dir.path().join("map.png");
    let out = run(&[
        &model,
        "--frequency",
        "600",
        "--harmonics",
        "3",
        "--no-stability",
        "--json",
        "--contacts-csv",
        &csv.display().to_string(),
        "--contact-map",
        &map.display().to_string(),
    ]);
    assert_success(&out);
    let v = stdout_json(&out);
    let samples = v["time_s"].as_array().unwrap().len();
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "interface,contact,nodes,position,time_s,gap,force"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 10 * samples);
    for (r, row) in rows.iter().enumerate() {
        let (c, j) = (r / samples, r % samples);
        assert_eq!(row[0], "stop");
        assert_eq!(row[1], c.to_string());
        let series = &v["contacts"][c];
        // the contact's DOF is u_y of its node (2 DOFs per node)
        assert_eq!(
            row[2].parse::<u64>().unwrap() * 2 + 1,
            series["dof"].as_u64().unwrap()
        );
        let num = |k: usize| row[k].parse::<f64>().unwrap();
        assert!(num(3) >= 88.0 && num(3) <= 100.0);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-11 * b.abs().max(1e-3);
        assert!(close(num(5), series["gap"][j].as_f64().unwrap()), "row {r}");
        assert!(
            close(num(6), series["force"][j].as_f64().unwrap()),
            "row {r}"
        );
    }
    let png = std::fs::read(&map).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    // IHDR: width and height, big-endian, after the signature and the chunk header
    let be = |k: usize| u32::from_be_bytes(png[k..k + 4].try_into().unwrap());
    assert_eq!((be(16), be(20)), (1000, 840), "two panels of 420 px");
    let clash = run(&[&model, "--frequency", "600", "--contacts-csv", &model]);
    let err = one_error_line(&clash);
    assert!(err.contains("--contacts-csv"), "{err}");
}

#[test]
fn the_operator_jacobian_reaches_the_dense_solution() {
    // the 4 × 4 × 4 plate of examples/block_3d (20 contacts): GMRES on the Jacobian's
    // action against the dense LU (docs/theory.md §18)
    let model = example("block_3d/model.toml");
    let coefficients = |jacobian: &str| -> Vec<f64> {
        let out = run(&[
            &model,
            "--frequency",
            "500",
            "--harmonics",
            "3",
            "--set",
            "solid.divisions=[4,4,4]",
            "--set",
            "interfaces.0.gap=0.0003",
            "--jacobian",
            jacobian,
            "--json",
        ]);
        assert_success(&out);
        let v = stdout_json(&out);
        assert_eq!(v["converged"], true, "{jacobian}");
        v["contacts"]
            .as_array()
            .unwrap()
            .iter()
            .flat_map(|c| c["coefficients"].as_array().unwrap().clone())
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let (dense, operator) = (coefficients("dense"), coefficients("operator"));
    let size = dense.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let diff = dense
        .iter()
        .zip(&operator)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(size > 0.0 && diff <= 1e-9 * size, "{diff:e} of {size:e}");
}

#[test]
fn the_jacobian_form_belongs_to_the_redistributed_method() {
    let out = run(&[
        &bar(),
        "--frequency",
        "60000",
        "--method",
        "hbm-aft",
        "--jacobian",
        "operator",
    ]);
    assert_eq!(
        one_error_line(&out).trim_end(),
        "error: --jacobian applies to --method redistributed only"
    );
}
