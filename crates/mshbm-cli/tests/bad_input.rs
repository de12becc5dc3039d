//! Bad input gets one clear error line naming the file and the field, a non-zero exit,
//! and never a panic.

mod common;

use common::{example, examples, fails, mshbm};

/// A general model in a temporary directory, with the bar's matrices unless replaced.
struct GeneralModel {
    dir: tempfile::TempDir,
}

impl GeneralModel {
    fn new() -> Self {
        let dir = tempfile::tempdir().unwrap();
        for f in [
            "mass.mtx",
            "stiffness.mtx",
            "nodes.txt",
            "harmonic_load.mtx",
            "constant_load.mtx",
            "model.toml",
        ] {
            std::fs::copy(examples().join("bar_matrices").join(f), dir.path().join(f)).unwrap();
        }
        GeneralModel { dir }
    }
    fn write(&self, name: &str, text: &str) {
        std::fs::write(self.dir.path().join(name), text).unwrap();
    }
    fn edit_toml(&self, from: &str, to: &str) {
        let p = self.dir.path().join("model.toml");
        let s = std::fs::read_to_string(&p).unwrap();
        assert!(s.contains(from), "fixture lacks {from}");
        std::fs::write(p, s.replace(from, to)).unwrap();
    }
    fn toml(&self) -> String {
        self.dir.path().join("model.toml").display().to_string()
    }
}

fn bar_with(from: &str, to: &str) -> (tempfile::TempDir, String) {
    let dir = tempfile::tempdir().unwrap();
    let s = std::fs::read_to_string(examples().join("clamped_bar.toml")).unwrap();
    assert!(s.contains(from), "fixture lacks {from}");
    let p = dir.path().join("bar.toml");
    std::fs::write(&p, s.replace(from, to)).unwrap();
    let p = p.display().to_string();
    (dir, p)
}

#[test]
fn missing_model_file() {
    let err = fails(&["modes", "no/such/model.toml"]);
    assert!(err.contains("no/such/model.toml"), "{err}");
}

#[test]
fn malformed_toml() {
    let (_d, p) = bar_with("[bar]", "[bar");
    let err = fails(&["modes", &p]);
    assert!(
        err.contains("bar.toml") && err.contains("malformed TOML"),
        "{err}"
    );
}

#[test]
fn unknown_key() {
    let (_d, p) = bar_with("area = 1.0", "area = 1.0\nwidth = 3.0");
    let err = fails(&["modes", &p]);
    assert!(
        err.contains("bar.toml") && err.contains("width") && err.contains("bar"),
        "{err}"
    );
}

#[test]
fn unknown_key_through_set() {
    let p = example("clamped_bar.toml");
    let err = fails(&["modes", &p, "--set", "contact.gapp=0.1"]);
    assert!(err.contains("gapp"), "{err}");
}

#[test]
fn negative_density() {
    let (_d, p) = bar_with("density = 9e-9", "density = -9e-9");
    let err = fails(&["modes", &p]);
    assert!(
        err.contains("bar.toml") && err.contains("bar.density") && err.contains("positive"),
        "{err}"
    );
}

#[test]
fn non_square_matrix() {
    let m = GeneralModel::new();
    m.write(
        "mass.mtx",
        "%%MatrixMarket matrix coordinate real general\n3 2 1\n1 1 1.0\n",
    );
    let err = fails(&["modes", &m.toml()]);
    assert!(
        err.contains("model.toml") && err.contains("matrices.mass") && err.contains("not square"),
        "{err}"
    );
}

#[test]
fn non_symmetric_matrix() {
    let m = GeneralModel::new();
    let k = std::fs::read_to_string(examples().join("bar_matrices/stiffness.mtx")).unwrap();
    // turn the symmetric file into a general one with one extra off-diagonal entry
    let lines: Vec<&str> = k.lines().collect();
    let mut general = Vec::new();
    for e in &lines[2..] {
        general.push(e.to_string());
        let w: Vec<&str> = e.split_whitespace().collect();
        if w[0] != w[1] {
            general.push(format!("{} {} {}", w[1], w[0], w[2]));
        }
    }
    general.push("1 3 5.0".into());
    let size: Vec<&str> = lines[1].split_whitespace().collect();
    let text = format!(
        "%%MatrixMarket matrix coordinate real general\n{} {} {}\n{}\n",
        size[0],
        size[1],
        general.len(),
        general.join("\n")
    );
    m.write("stiffness.mtx", &text);
    let err = fails(&["modes", &m.toml()]);
    assert!(
        err.contains("matrices.stiffness") && err.contains("not symmetric"),
        "{err}"
    );
}

#[test]
fn size_mismatch_between_matrices_and_coordinates() {
    let m = GeneralModel::new();
    m.write("nodes.txt", "0.0\n0.2\n0.4\n");
    let err = fails(&["modes", &m.toml()]);
    assert!(
        err.contains("model.toml") && err.contains("mesh.coordinates"),
        "{err}"
    );
}

#[test]
fn size_mismatch_between_matrices() {
    let m = GeneralModel::new();
    m.write(
        "mass.mtx",
        "%%MatrixMarket matrix coordinate real symmetric\n3 3 1\n1 1 1.0\n",
    );
    let err = fails(&["modes", &m.toml()]);
    assert!(
        err.contains("matrices.mass") && err.contains("3×3"),
        "{err}"
    );
}

#[test]
fn contact_dof_out_of_range() {
    let m = GeneralModel::new();
    m.edit_toml("dofs = [100]", "dofs = [101]");
    let err = fails(&["modes", &m.toml()]);
    assert!(
        err.contains("contacts[0].dofs") && err.contains("out of range"),
        "{err}"
    );
}

#[test]
fn malformed_matrix_market_line() {
    let m = GeneralModel::new();
    m.write(
        "mass.mtx",
        "%%MatrixMarket matrix coordinate real symmetric\n101 101 1\n1 1 abc\n",
    );
    let err = fails(&["modes", &m.toml()]);
    assert!(err.contains("mass.mtx, line 3"), "{err}");
}

#[test]
fn count_larger_than_the_number_of_dofs() {
    let p = example("clamped_bar.toml");
    let err = fails(&["modes", &p, "--count", "500"]);
    assert!(err.contains("count") && err.contains("500"), "{err}");
}

#[test]
fn bad_override_syntax() {
    let p = example("clamped_bar.toml");
    let err = fails(&["modes", &p, "--set", "contact.gap"]);
    assert!(err.contains("key=value"), "{err}");
}

// --- issue 15: inputs that are huge, special files, outside the model's directory,
// hostile text or degenerate contacts: one clear line, fast, no panic ---

/// `fails` within a time limit, for the reproducers that used to exhaust the machine.
fn fails_fast(args: &[&str]) -> String {
    let start = std::time::Instant::now();
    let err = fails(args);
    assert!(
        start.elapsed().as_secs_f64() < 1.0,
        "{args:?} took {:?}",
        start.elapsed()
    );
    err
}

#[test]
fn huge_bar_elements_are_refused_at_once() {
    let p = example("clamped_bar.toml");
    for n in ["4611686018427387904", "1000000000"] {
        let set = format!("bar.elements={n}");
        let err = fails_fast(&["modes", &p, "--set", &set]);
        assert!(
            err.contains("clamped_bar.toml")
                && err.contains("bar.elements")
                && err.contains("--max-memory"),
            "{err}"
        );
    }
    // the memory budget is the one given
    let err = fails_fast(&["modes", &p, "--max-memory", "0.0001"]);
    assert!(
        err.contains("bar.elements") && err.contains("104.9 KiB"),
        "{err}"
    );
    let p = example("dropped_bar.toml");
    let err = fails_fast(&["simulate", &p, "--set", "bar.elements=1000000000"]);
    assert!(err.contains("bar.elements"), "{err}");
}

#[test]
fn huge_declared_matrix_market_sizes_are_refused_at_once() {
    let m = GeneralModel::new();
    for size in [
        "1000000000 1000000000 1",
        "4294967296 4294967296 1",
        "18446744073709551615 18446744073709551615 1",
        "101 101 18446744073709551615",
    ] {
        // the 70-byte file of the issue
        m.write(
            "stiffness.mtx",
            &format!("%%MatrixMarket matrix coordinate real general\n{size}\n1 1 1.0\n"),
        );
        let err = fails_fast(&["modes", &m.toml()]);
        assert!(err.contains("stiffness.mtx"), "{size}: {err}");
    }
}

#[cfg(unix)]
#[test]
fn devices_and_fifos_as_referenced_files_are_refused_at_once() {
    let m = GeneralModel::new();
    m.edit_toml("\"stiffness.mtx\"", "\"/dev/zero\"");
    let err = fails_fast(&["modes", &m.toml()]);
    assert!(
        err.contains("matrices.stiffness") && err.contains("--allow-outside-paths"),
        "{err}"
    );
    let err = fails_fast(&["modes", &m.toml(), "--allow-outside-paths"]);
    assert!(
        err.contains("matrices.stiffness") && err.contains("not a regular file"),
        "{err}"
    );
    m.edit_toml("\"/dev/zero\"", "\"/dev/urandom\"");
    let err = fails_fast(&["modes", &m.toml(), "--allow-outside-paths"]);
    assert!(err.contains("not a regular file"), "{err}");
    m.edit_toml("\"/dev/urandom\"", "\"stiffness.mtx\"");
    let status = std::process::Command::new("mkfifo")
        .arg(m.dir.path().join("nodes.fifo"))
        .status()
        .unwrap();
    assert!(status.success());
    m.edit_toml("\"nodes.txt\"", "\"nodes.fifo\"");
    let err = fails_fast(&["modes", &m.toml()]);
    assert!(
        err.contains("mesh.coordinates") && err.contains("FIFO"),
        "{err}"
    );
}

#[test]
fn paths_outside_the_model_directory_are_refused() {
    let m = GeneralModel::new();
    m.edit_toml("\"nodes.txt\"", "\"/etc/passwd\"");
    let err = fails_fast(&["modes", &m.toml()]);
    assert!(
        err.contains("model.toml")
            && err.contains("mesh.coordinates")
            && err.contains("\"/etc/passwd\"")
            && err.contains("--allow-outside-paths"),
        "{err}"
    );
    // allowed, the message quotes at most a short escaped excerpt, never a whole line
    #[cfg(unix)]
    if let Ok(passwd) = std::fs::read_to_string("/etc/passwd") {
        let err = fails_fast(&["modes", &m.toml(), "--allow-outside-paths"]);
        let first = passwd.lines().next().unwrap_or_default();
        assert!(first.len() <= 16 || !err.contains(first), "{err}");
    }
    m.edit_toml("\"/etc/passwd\"", "\"../nodes.txt\"");
    let err = fails_fast(&["modes", &m.toml()]);
    assert!(
        err.contains("mesh.coordinates") && err.contains("leads outside"),
        "{err}"
    );
}

#[test]
fn escape_sequences_in_bad_tokens_are_escaped() {
    let m = GeneralModel::new();
    m.write(
        "mass.mtx",
        "%%MatrixMarket matrix coordinate real symmetric\n101 101 1\n1 1 \u{1b}[31m\u{1b}]0;pwned\u{7}\n",
    );
    let out = mshbm(&["modes", &m.toml()]);
    assert!(!out.stderr.contains(&0x1b) && !out.stderr.contains(&0x07));
    let err = fails(&["modes", &m.toml()]);
    assert!(
        err.contains("mass.mtx, line 3") && err.contains("\\u{1b}[31m"),
        "{err}"
    );
}

#[test]
fn degenerate_contacts_are_refused() {
    let m = GeneralModel::new();
    m.edit_toml("dofs = [100]\nw = [-1.0]", "dofs = [3, 3]\nw = [-1.0, 1.0]");
    let err = fails(&["modes", &m.toml()]);
    assert!(
        err.contains("model.toml") && err.contains("contacts[0].w") && err.contains("vanishes"),
        "{err}"
    );
    let m = GeneralModel::new();
    let s = std::fs::read_to_string(m.dir.path().join("model.toml")).unwrap();
    m.write(
        "model.toml",
        &format!("{s}\n[[contacts]]\ndofs = [100]\nw = [-1.0]\ngap = 0.2\n"),
    );
    let err = fails(&["modes", &m.toml()]);
    assert!(
        err.contains("contacts[1]") && err.contains("contacts[0]") && err.contains("singular"),
        "{err}"
    );
}

/// A command line clap refuses is bad input like any other: exit status 1 (2 means
/// "written but not converged"), clap's message on one line and the hint to `--help` on a
/// second, no usage block; values out of range reach the commands' own checks.
#[test]
fn usage_errors_exit_with_1_in_at_most_three_lines() {
    let model = example("clamped_bar.toml");
    let m = model.as_str();
    let solve = |extra: &[&'static str]| {
        let mut v = vec!["solve", m, "--frequency", "30000"];
        v.extend_from_slice(extra);
        v
    };
    let frf = |extra: &[&'static str]| {
        let mut v = vec!["frf", m, "--from", "29000", "--to", "31000"];
        v.extend_from_slice(extra);
        v
    };
    let cases: Vec<Vec<&str>> = vec![
        vec!["solve", m, "--frequency", "-100"],
        solve(&["--max-memory", "0"]),
        solve(&["--max-memory", "nan"]),
        solve(&["--harmonics", "1,,3"]),
        solve(&["--tolerance", "-1"]),
        solve(&["--output", ""]),
        frf(&["--max-step", "-5"]),
        frf(&["--threads", "0"]),
        vec!["paper", "--format", "jpg"],
        vec!["solve", m],
        vec!["modes"],
        vec!["no-such-command"],
    ];
    for args in cases {
        let out = mshbm(&args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
        let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
        assert!(
            (1..=3).contains(&lines.len()) && lines[0].starts_with("error: "),
            "{args:?}: {stderr}"
        );
        assert!(!stderr.contains("Usage:"), "{args:?}: {stderr}");
        assert!(out.stdout.is_empty(), "{args:?}");
    }
    // a negative number is a value, checked by the command
    let err = fails(&["solve", m, "--frequency", "-100"]);
    assert!(err.contains("--frequency") && err.contains("-100"), "{err}");
    // help and version are not errors
    for args in [
        vec!["--help"],
        vec!["--version"],
        vec!["solve", "--help"],
        vec!["help", "frf"],
    ] {
        let out = mshbm(&args);
        assert_eq!(out.status.code(), Some(0), "{args:?}");
        assert!(!out.stdout.is_empty(), "{args:?}");
    }
}

/// Issue 46, item 5: a parameter whose product overflows is named, not the damping it spoils
/// (`--set bar.young=1e308` blamed "stiffness-proportional damping (beta)" with beta = 0).
#[test]
fn overflowing_parameters_are_named() {
    // E·A/h = 1e308 / 0.2 overflows
    let err = fails(&[
        "solve",
        &example("clamped_bar.toml"),
        "--frequency",
        "30000",
        "--set",
        "bar.young=1e308",
    ]);
    assert!(
        err.contains("bar.young") && err.contains("overflows"),
        "{err}"
    );
    assert!(!err.contains("damping"), "{err}");
}

/// Issue 46, item 5: a negative mass diagonal is refused naming the matrix, by `modes`
/// (which blamed the mass redistribution) and by `solve --method hbm-aft` (which solved).
#[test]
fn negative_mass_diagonal_is_refused() {
    let m = GeneralModel::new();
    let mass = std::fs::read_to_string(examples().join("bar_matrices/mass.mtx")).unwrap();
    let negative = mass.replacen("\n2 2 ", "\n2 2 -", 1);
    assert_ne!(negative, mass, "fixture lacks entry (2, 2)");
    m.write("mass.mtx", &negative);
    for args in [
        vec!["modes", "MODEL"],
        vec![
            "solve",
            "MODEL",
            "--frequency",
            "30000",
            "--method",
            "hbm-aft",
        ],
    ] {
        let toml = m.toml();
        let args: Vec<&str> = args
            .iter()
            .map(|a| if *a == "MODEL" { toml.as_str() } else { a })
            .collect();
        let err = fails(&args);
        assert!(
            err.contains("matrices.mass") && err.contains("(2, 2)") && err.contains("negative"),
            "{err}"
        );
    }
}

/// Issue 46, item 5: a stiffness that is not positive definite (here one negative diagonal
/// entry in the bar's K, indefinite; and the dropped bar, which is not held) is refused by
/// `solve` and `frf` naming the model file and what is wrong, not "the stiffness matrix is
/// singular"; a first-mode damping ratio on it names its field.
#[test]
fn indefinite_stiffness_is_refused_naming_the_model() {
    let m = GeneralModel::new();
    let k = std::fs::read_to_string(examples().join("bar_matrices/stiffness.mtx")).unwrap();
    let indefinite = k.replacen("\n51 51 ", "\n51 51 -", 1);
    assert_ne!(indefinite, k, "fixture lacks entry (51, 51)");
    m.write("stiffness.mtx", &indefinite);
    let toml = m.toml();
    let dropped = example("dropped_bar.toml");
    for (args, file) in [
        (vec!["solve", &toml, "--frequency", "30000"], "model.toml"),
        (
            vec![
                "solve",
                &toml,
                "--frequency",
                "30000",
                "--method",
                "hbm-aft",
            ],
            "model.toml",
        ),
        (
            vec!["frf", &toml, "--from", "20000", "--to", "40000"],
            "model.toml",
        ),
        (
            vec!["solve", &dropped, "--frequency", "30000"],
            "dropped_bar.toml",
        ),
    ] {
        let err = fails(&args);
        assert!(
            err.contains(&format!("{file}: the stiffness is not positive definite"))
                && err.contains("not held")
                && err.contains("indefinite")
                && !err.contains("singular"),
            "{args:?}: {err}"
        );
    }
    let err = fails(&[
        "solve",
        &toml,
        "--frequency",
        "30000",
        "--set",
        "damping.first_mode_ratio=0.01",
    ]);
    assert!(
        err.contains("model.toml: field `damping.first_mode_ratio`")
            && err.contains("not positive definite"),
        "{err}"
    );
}

/// Issue 46, item 5: the methods that integrate in time refuse an indefinite stiffness
/// before they start, naming the model file, the field and the matrix file: `simulate`
/// (which ended in "numerical failure: contact LCP ... natural residual NaN", naming
/// nothing) and the general MS-HBM (which panicked in its event location on a NaN gap). A
/// free structure (the dropped bar, `K` singular but not indefinite) is still integrated.
#[test]
fn time_integrations_refuse_an_indefinite_stiffness_naming_the_file() {
    let m = GeneralModel::new();
    let k = std::fs::read_to_string(examples().join("bar_matrices/stiffness.mtx")).unwrap();
    let indefinite = k.replacen("\n51 51 ", "\n51 51 -", 1);
    assert_ne!(indefinite, k, "fixture lacks entry (51, 51)");
    m.write("stiffness.mtx", &indefinite);
    let toml = m.toml();
    for args in [
        vec!["simulate", &toml, "--frequency", "30000", "--periods", "1"],
        vec![
            "simulate",
            &toml,
            "--frequency",
            "30000",
            "--periods",
            "1",
            "--scheme",
            "moreau",
            "--theta",
            "0.6",
        ],
        vec!["solve", &toml, "--frequency", "30000", "--method", "mshbm"],
    ] {
        let out = mshbm(&args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        let err = fails(&args);
        assert!(
            err.contains("model.toml: field `matrices.stiffness`: stiffness.mtx: the stiffness is indefinite")
                && err.contains("negative stiffness"),
            "{args:?}: {err}"
        );
    }
    // a free structure is not indefinite: the dropped bar still falls and bounces
    let out = mshbm(&["simulate", &example("dropped_bar.toml"), "--periods", "1"]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Issue 46, item 5: a `K_NN` (the stiffness of the contact-node DOFs with the rest held)
/// that is not positive definite is refused naming the model file, the field and the
/// matrix file, and says what is wrong (it said "K_NN ... is singular (not positive
/// definite): the contact nodes must not form a free-floating part", naming no file, for
/// a negative stiffness at the contact node).
#[test]
fn a_contact_stiffness_that_is_not_positive_definite_names_the_file() {
    let m = GeneralModel::new();
    let k = std::fs::read_to_string(examples().join("bar_matrices/stiffness.mtx")).unwrap();
    // the contact DOF is the last one (1-based 101; the size line is "101 101 NNZ")
    let at = k
        .rfind("\n101 101 ")
        .expect("fixture lacks entry (101, 101)");
    assert!(
        at > k.find('\n').unwrap(),
        "entry (101, 101) is the size line"
    );
    let negative = format!("{}\n101 101 -{}", &k[..at], &k[at + "\n101 101 ".len()..]);
    m.write("stiffness.mtx", &negative);
    let toml = m.toml();
    for args in [
        vec!["solve", &toml, "--frequency", "30000"],
        vec!["frf", &toml, "--from", "29000", "--to", "31000"],
    ] {
        let err = fails(&args);
        assert!(
            err.contains("model.toml: field `matrices.stiffness`: stiffness.mtx: K_NN")
                && err.contains("not positive definite")
                && err.contains("stiffness is negative"),
            "{args:?}: {err}"
        );
    }
}
