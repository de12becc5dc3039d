//! `mshbm modes`: JSON shape and values, plots, `--set`.

mod common;

use common::{assert_png, assert_success, example, mshbm, numbers, one_error_line, success_json};

/// `mshbm modes args… --json`, which must succeed.
fn modes_json(args: &[&str]) -> serde_json::Value {
    let mut all = vec!["modes"];
    all.extend_from_slice(args);
    all.push("--json");
    success_json(&all)
}

#[test]
fn json_has_the_three_lists_the_norm_and_the_papers_first_frequency() {
    let p = example("clamped_bar.toml");
    let v = modes_json(&[&p, "--count", "30"]);
    let obj = v.as_object().unwrap();
    assert_eq!(obj.len(), 4);
    // one contact node: the paper's Frobenius norm keeps the mass positive definite
    assert_eq!(v["norm"], "frobenius");
    let get = |k: &str| numbers(&v[k]);
    let (o, r, e) = (
        get("original_hz"),
        get("redistributed_hz"),
        get("relative_error"),
    );
    assert_eq!((o.len(), r.len(), e.len()), (30, 30, 30));
    assert!((r[0] - 60335.0).abs() < 1.0);
    for k in 0..30 {
        assert!((e[k] - (r[k] / o[k] - 1.0)).abs() < 1e-15);
    }
}

#[test]
fn general_model_gives_the_same_json_as_the_bar() {
    let a = modes_json(&[&example("clamped_bar.toml"), "--count", "10"]);
    let b = modes_json(&[&example("bar_matrices/model.toml"), "--count", "10"]);
    for key in ["original_hz", "redistributed_hz"] {
        for (x, y) in a[key]
            .as_array()
            .unwrap()
            .iter()
            .zip(b[key].as_array().unwrap())
        {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            assert!((x / y - 1.0).abs() < 1e-10);
        }
    }
}

#[test]
fn plots_are_written_as_svg_and_png() {
    let dir = tempfile::tempdir().unwrap();
    let p = example("clamped_bar.toml");
    for name in ["fig8.svg", "fig8.png"] {
        let file = dir.path().join(name);
        assert_success(&mshbm(&[
            "modes",
            &p,
            "--count",
            "30",
            "--plot",
            &file.display().to_string(),
        ]));
        if name.ends_with(".png") {
            assert_png(&file);
        } else {
            assert!(String::from_utf8_lossy(&std::fs::read(&file).unwrap()).contains("<svg"));
        }
    }
}

#[test]
fn set_overrides_work_on_the_example() {
    let p = example("clamped_bar.toml");
    let v = modes_json(&[
        &p,
        "--count",
        "2",
        "--set",
        "contact.gap=0",
        "--set",
        "damping.alpha=7587.7",
    ]);
    assert!((v["redistributed_hz"][0].as_f64().unwrap() - 60335.0).abs() < 1.0);
}

/// A free structure has no eigenfrequencies to compare: one line naming the model file and
/// the rigid-body mode, never a 0 Hz mode with a NaN relative error.
#[test]
fn modes_of_a_free_bar_is_one_clear_error() {
    let out = mshbm(&["modes", &example("dropped_bar.toml"), "--json"]);
    let line = one_error_line(&out);
    assert!(
        line.contains("dropped_bar.toml") && line.contains("rigid-body mode"),
        "{line}"
    );
    assert!(out.stdout.is_empty());
}

/// A long bar takes the sparse eigensolver (the dense one needed 68 s and 1.2 GB for 5000
/// elements and panicked at 200 000), and its plan is checked against `--max-memory`.
#[test]
fn modes_of_a_long_bar_are_sparse_and_within_the_budget() {
    let json = success_json(&[
        "modes",
        &example("clamped_bar.toml"),
        "--set",
        "bar.elements=20000",
        "--count",
        "3",
        "--json",
    ]);
    let f = numbers(&json["original_hz"]);
    // clamped–free continuum: (2k − 1) c / (4L), c = sqrt(E/ρ), L = 20 mm
    let c = (2.1e5f64 / 9e-9).sqrt();
    for (k, fk) in f.iter().enumerate() {
        let exact = (2 * k + 1) as f64 * c / 80.0;
        assert!(
            (fk / exact - 1.0).abs() < 1e-6,
            "mode {}: {fk} vs {exact}",
            k + 1
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let mut command = std::process::Command::new(assert_cmd::cargo::cargo_bin("mshbm"));
    command.args([
        "modes",
        &example("clamped_bar.toml"),
        "--set",
        "bar.elements=20000",
        "--max-memory",
        "0.06",
    ]);
    common::resources::run_measured(command, dir.path())
        .assert_clean_refusal(&["20000 DOFs", "memory limit"]);
}
