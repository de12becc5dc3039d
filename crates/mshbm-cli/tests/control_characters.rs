//! Text taken from an input (a model's name, a path) never reaches an output with its
//! control characters: terminal escape sequences in a model file are shown escaped
//! (`\u{1b}[2J`) on stdout and stderr, in CSV comments and in plot titles, and escaped in
//! JSON (docs/safety.md "Escaped messages").

mod common;

use std::path::Path;

use common::{command, examples};

/// A name that clears the screen, sets the terminal's title, rings the bell, and holds
/// DEL, a C1 control (CSI) and a line break, as TOML escapes.
const HOSTILE_TOML: &str = r#""\u001b[2J\u001b]0;pwned\u0007EVIL\u007f\u009b\nX""#;

/// The same name as given to `--set name=…`.
const HOSTILE: &str = "\u{1b}[2J\u{1b}]0;pwned\u{7}EVIL\u{7f}\u{9b}\nX";

/// The clamped bar with the hostile name, in a temporary directory.
fn hostile_bar() -> (tempfile::TempDir, String) {
    let dir = tempfile::tempdir().unwrap();
    let s = std::fs::read_to_string(examples().join("clamped_bar.toml")).unwrap();
    let (first, rest) = s.split_once("\nname = ").expect("the example has a name");
    let (_, rest) = rest.split_once('\n').unwrap();
    let p = dir.path().join("bar.toml");
    std::fs::write(&p, format!("{first}\nname = {HOSTILE_TOML}\n{rest}")).unwrap();
    let p = p.display().to_string();
    (dir, p)
}

/// `bytes` hold no control character but line breaks and tabs: no C0 byte, no DEL, no C1
/// (U+0080–U+009F).
fn assert_no_controls(what: &str, bytes: &[u8]) {
    let text = String::from_utf8_lossy(bytes);
    if let Some(c) = text
        .chars()
        .find(|&c| c.is_control() && c != '\n' && c != '\t')
    {
        panic!("{what} holds the control character {c:?}: {text}");
    }
}

/// Run `mshbm args…` in `dir`; its stdout and stderr hold no control characters; returns
/// (status, stdout).
fn run(dir: &Path, args: &[&str]) -> (Option<i32>, String) {
    let out = command().current_dir(dir).args(args).output().unwrap();
    assert_no_controls(&format!("stdout of {args:?}"), &out.stdout);
    assert_no_controls(&format!("stderr of {args:?}"), &out.stderr);
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
    )
}

fn assert_file_clean(dir: &Path, name: &str) {
    let bytes = std::fs::read(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
    assert_no_controls(name, &bytes);
}

#[test]
fn a_hostile_model_name_is_escaped_on_every_output() {
    let (dir, model) = hostile_bar();
    let d = dir.path();
    let shown = r"\u{1b}[2J\u{1b}]0;pwned\u{7}EVIL\u{7f}\u{9b}\nX";
    // the name from the file, and from --set
    for set in [None, Some(format!("name={HOSTILE}"))] {
        let mut base = vec![model.clone()];
        if let Some(s) = &set {
            base.extend(["--set".to_string(), s.clone()]);
        }
        let with = |extra: &[&str], first: &str| {
            let mut v = vec![first.to_string()];
            v.extend(base.iter().cloned());
            v.extend(extra.iter().map(|s| s.to_string()));
            v
        };
        let args = with(&["--plot", "modes.svg"], "modes");
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (status, stdout) = run(d, &args);
        assert_eq!(status, Some(0), "{args:?}");
        assert_eq!(stdout.lines().next(), Some(shown), "{stdout}");
        assert_file_clean(d, "modes.svg");

        let args = with(&["--json"], "modes");
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (status, stdout) = run(d, &args);
        assert_eq!(status, Some(0), "{args:?}");
        serde_json::from_str::<serde_json::Value>(&stdout).unwrap();

        let solve = [
            "--frequency",
            "30000",
            "--harmonics",
            "3",
            "--output",
            "solve.csv",
            "--contacts-csv",
            "contacts.csv",
            "--plot",
            "solve.svg",
        ];
        let args = with(&solve, "solve");
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (status, stdout) = run(d, &args);
        assert_eq!(status, Some(0), "{args:?}");
        assert!(stdout.starts_with(shown), "{stdout}");
        for f in ["solve.csv", "contacts.csv", "solve.svg"] {
            assert_file_clean(d, f);
        }
        let args = with(
            &["--frequency", "30000", "--harmonics", "3", "--json"],
            "solve",
        );
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (status, stdout) = run(d, &args);
        assert_eq!(status, Some(0), "{args:?}");
        serde_json::from_str::<serde_json::Value>(&stdout).unwrap();
        // not converged: the reason goes to the CSV's comment line, stderr and the title
        let args = with(
            &[
                "--frequency",
                "30000",
                "--harmonics",
                "3",
                "--max-iterations",
                "1",
                "--output",
                "nc.csv",
                "--plot",
                "nc.svg",
            ],
            "solve",
        );
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (status, _) = run(d, &args);
        assert_eq!(status, Some(2), "{args:?}");
        for f in ["nc.csv", "nc.svg"] {
            assert_file_clean(d, f);
        }

        let frf = [
            "--from",
            "29000",
            "--to",
            "31000",
            "--harmonics",
            "1",
            "--output",
            "frf.csv",
            "--plot",
            "frf.svg",
        ];
        let args = with(&frf, "frf");
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (status, _) = run(d, &args);
        assert_eq!(status, Some(0), "{args:?}");
        let svg = std::fs::read_to_string(d.join("frf.svg")).unwrap();
        assert!(svg.contains(shown), "the title shows the name escaped");
        for f in ["frf.csv", "frf.svg"] {
            assert_file_clean(d, f);
        }

        let sim = [
            "--frequency",
            "30000",
            "--periods",
            "1",
            "--output",
            "sim.csv",
            "--plot",
            "sim.svg",
        ];
        let args = with(&sim, "simulate");
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (status, stdout) = run(d, &args);
        assert_eq!(status, Some(0), "{args:?}");
        assert!(stdout.starts_with(shown), "{stdout}");
        for f in ["sim.csv", "sim.svg"] {
            assert_file_clean(d, f);
        }
        let args = with(
            &["--frequency", "30000", "--periods", "1", "--json"],
            "simulate",
        );
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (status, stdout) = run(d, &args);
        assert_eq!(status, Some(0), "{args:?}");
        let json: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        // escaped as JSON (DEL and C1 included), read back intact
        assert_eq!(json["model"], HOSTILE, "{stdout}");
    }
}

#[test]
fn a_hostile_path_is_escaped_in_error_messages() {
    let dir = tempfile::tempdir().unwrap();
    let model = examples().join("clamped_bar.toml").display().to_string();
    for args in [
        vec![
            "solve",
            &model,
            "--frequency",
            "30000",
            "--plot",
            "x\u{1b}[31m.txt",
        ],
        vec!["modes", "no\u{1b}]0;pwned\u{7}such.toml"],
        // a usage error quotes the value clap refused
        vec!["solve", &model, "--frequency", "\u{1b}[2J\u{9b}31m"],
    ] {
        let (status, _) = run(dir.path(), &args);
        assert_eq!(status, Some(1), "{args:?}");
    }
}
