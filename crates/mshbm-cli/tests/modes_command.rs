//! `mshbm modes`: JSON shape and values, plots, `--set`.

mod common;

use common::{assert_png, assert_success, example, mshbm, numbers, success_json};

/// `mshbm modes args… --json`, which must succeed.
fn modes_json(args: &[&str]) -> serde_json::Value {
    let mut all = vec!["modes"];
    all.extend_from_slice(args);
    all.push("--json");
    success_json(&all)
}

#[test]
fn json_has_the_three_lists_and_the_papers_first_frequency() {
    let p = example("clamped_bar.toml");
    let v = modes_json(&[&p, "--count", "30"]);
    let obj = v.as_object().unwrap();
    assert_eq!(obj.len(), 3);
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
