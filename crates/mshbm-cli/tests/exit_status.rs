//! Issue 46: the table of exit statuses (docs/safety.md, "Exit status"; `mshbm --help`)
//! tested for every subcommand, one cheap case per status the command can return:
//! 0 done; 1 a usage error (clap's), a model file that does not exist, one that does not
//! parse, a refused output; 2 results written but not what was asked for (`solve` not
//! converged, `frf` branch stopped early, `simulate --steady-state` not periodic); 130
//! SIGTERM. The subcommands are read from `mshbm --help`, so a new one without its rows
//! fails the test. `paper`'s 0 and its 1 for a failed part take a quick paper run (10 s
//! each) and are in `paper_command.rs` (`quick_paper_run_writes_every_figure_with_sane_values`,
//! `a_failing_figure_does_not_lose_the_others`); here its usage error, refused output and
//! SIGTERM.

#![cfg(unix)]

mod common;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::example;
use common::resources::ChildGuard;

/// One row of the table: a command line and the status it must end with.
struct Case {
    /// What the row checks (for the failure message).
    what: &'static str,
    args: Vec<String>,
    expected: i32,
    /// Send SIGTERM this long after the start (the run must still be going), and require
    /// the exit within a second of it.
    sigterm_after: Option<Duration>,
}

fn case(what: &'static str, expected: i32, args: &[&str]) -> Case {
    Case {
        what,
        args: args.iter().map(|s| s.to_string()).collect(),
        expected,
        sigterm_after: None,
    }
}

fn interrupted(what: &'static str, args: &[&str]) -> Case {
    Case {
        sigterm_after: Some(Duration::from_millis(400)),
        ..case(what, 130, args)
    }
}

/// The subcommands `mshbm --help` lists (its `Commands:` block, without `help`).
fn subcommands() -> Vec<String> {
    let out = common::mshbm(&["--help"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    text.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .map(str::to_string)
        .collect()
}

/// Run one case in `dir`: (status, seconds from SIGTERM to the exit if signalled, stderr).
fn run(case: &Case, dir: &Path) -> (i32, Option<f64>, String) {
    let stderr_path = dir.join(format!("stderr-{}.txt", case.what.replace(' ', "_")));
    let child = Command::new(assert_cmd::cargo::cargo_bin("mshbm"))
        .args(&case.args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&stderr_path).unwrap())
        .spawn()
        .unwrap();
    let mut child = ChildGuard::new(child);
    let stderr = || std::fs::read_to_string(&stderr_path).unwrap_or_default();
    let mut sent = None;
    if let Some(after) = case.sigterm_after {
        std::thread::sleep(after);
        assert!(
            child.try_wait().is_none(),
            "{}: {:?} ended before the signal: choose a longer case; stderr: {}",
            case.what,
            case.args,
            stderr()
        );
        // SAFETY: signalling our own child.
        assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGTERM) }, 0);
        sent = Some(Instant::now());
    }
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait() {
            break status;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "{}: {:?} still running after 60 s",
            case.what,
            case.args
        );
        std::thread::sleep(Duration::from_millis(5));
    };
    let code = status.code().unwrap_or_else(|| {
        use std::os::unix::process::ExitStatusExt;
        128 + status.signal().unwrap_or(0)
    });
    (code, sent.map(|s| s.elapsed().as_secs_f64()), stderr())
}

#[test]
fn every_command_exits_with_the_documented_status() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let bar = example("clamped_bar.toml");
    let bar = bar.as_str();
    let cantilever = example("cantilever_stop/model.toml");
    let cantilever = cantilever.as_str();
    std::fs::write(d.join("malformed.toml"), "name = = 3\n").unwrap();
    std::fs::write(d.join("a_file"), "").unwrap();
    // export's files already in the directory: refused without --force
    std::fs::create_dir(d.join("taken")).unwrap();
    std::fs::write(d.join("taken/model.toml"), "").unwrap();
    let (missing, malformed) = ("no_such_model.toml", "malformed.toml");

    let table: Vec<(&str, Vec<Case>)> = vec![
        (
            "modes",
            vec![
                case("modes done", 0, &["modes", bar]),
                case("modes usage", 1, &["modes", bar, "--count", "x"]),
                case("modes missing file", 1, &["modes", missing]),
                case("modes malformed file", 1, &["modes", malformed]),
                interrupted(
                    "modes SIGTERM",
                    &["modes", cantilever, "--set", "solid.divisions=[300,30]"],
                ),
            ],
        ),
        (
            "solve",
            vec![
                case("solve done", 0, &["solve", bar, "--frequency", "30000"]),
                case("solve usage", 1, &["solve", bar]),
                case(
                    "solve missing file",
                    1,
                    &["solve", missing, "--frequency", "30000"],
                ),
                case(
                    "solve malformed file",
                    1,
                    &["solve", malformed, "--frequency", "30000"],
                ),
                case(
                    "solve not converged",
                    2,
                    &[
                        "solve",
                        bar,
                        "--frequency",
                        "30000",
                        "--harmonics",
                        "3",
                        "--start",
                        "linear",
                        "--max-iterations",
                        "1",
                    ],
                ),
                interrupted(
                    "solve SIGTERM",
                    &["solve", bar, "--frequency", "30000", "--harmonics", "300"],
                ),
            ],
        ),
        (
            "frf",
            vec![
                case(
                    "frf done",
                    0,
                    &[
                        "frf",
                        bar,
                        "--from",
                        "29000",
                        "--to",
                        "31000",
                        "--harmonics",
                        "1",
                    ],
                ),
                case(
                    "frf usage",
                    1,
                    &[
                        "frf",
                        bar,
                        "--from",
                        "29000",
                        "--to",
                        "31000",
                        "--threads",
                        "0",
                    ],
                ),
                case(
                    "frf missing file",
                    1,
                    &["frf", missing, "--from", "29000", "--to", "31000"],
                ),
                case(
                    "frf malformed file",
                    1,
                    &["frf", malformed, "--from", "29000", "--to", "31000"],
                ),
                // one corrector iteration and no room to shrink the step: the branch stops
                // where contact starts, the points found are written
                case(
                    "frf incomplete",
                    2,
                    &[
                        "frf",
                        bar,
                        "--from",
                        "1000",
                        "--to",
                        "30000",
                        "--harmonics",
                        "3",
                        "--set",
                        "damping.first_mode_ratio=0.01",
                        "--max-iterations",
                        "1",
                        "--step",
                        "0.05",
                        "--min-step",
                        "0.05",
                        "--max-step",
                        "0.05",
                        "--output",
                        "incomplete.csv",
                    ],
                ),
                interrupted(
                    "frf SIGTERM",
                    &[
                        "frf",
                        bar,
                        "--from",
                        "1000",
                        "--to",
                        "200000",
                        "--harmonics",
                        "10",
                        "--output",
                        "interrupted.csv",
                    ],
                ),
            ],
        ),
        (
            "simulate",
            vec![
                case(
                    "simulate done",
                    0,
                    &["simulate", bar, "--frequency", "30000", "--periods", "2"],
                ),
                case(
                    "simulate usage",
                    1,
                    &["simulate", bar, "--frequency", "30000", "--periods", "x"],
                ),
                case(
                    "simulate missing file",
                    1,
                    &["simulate", missing, "--frequency", "30000"],
                ),
                case(
                    "simulate malformed file",
                    1,
                    &["simulate", malformed, "--frequency", "30000"],
                ),
                case(
                    "simulate not periodic",
                    2,
                    &[
                        "simulate",
                        bar,
                        "--set",
                        "damping.first_mode_ratio=0.01",
                        "--frequency",
                        "30000",
                        "--steady-state",
                        "--periods",
                        "3",
                        "--steps-per-period",
                        "500",
                    ],
                ),
                interrupted(
                    "simulate SIGTERM",
                    &[
                        "simulate",
                        bar,
                        "--frequency",
                        "30000",
                        "--periods",
                        "1000000",
                        "--output",
                        "simulated.csv",
                    ],
                ),
            ],
        ),
        (
            "export",
            vec![
                case("export done", 0, &["export", bar, "--output", "exported"]),
                case("export usage", 1, &["export", bar]),
                case(
                    "export missing file",
                    1,
                    &["export", missing, "--output", "exported2"],
                ),
                case(
                    "export malformed file",
                    1,
                    &["export", malformed, "--output", "exported3"],
                ),
                case(
                    "export refused output",
                    1,
                    &["export", bar, "--output", "taken"],
                ),
                interrupted(
                    "export SIGTERM",
                    &[
                        "export",
                        cantilever,
                        "--set",
                        "solid.divisions=[600,60]",
                        "--output",
                        "exported4",
                    ],
                ),
            ],
        ),
        (
            "paper",
            vec![
                case("paper usage", 1, &["paper", "--format", "jpg"]),
                case("paper refused output", 1, &["paper", "--output", "a_file"]),
                interrupted(
                    "paper SIGTERM",
                    &["paper", "--quick", "--format", "svg", "--output", "figures"],
                ),
            ],
        ),
    ];

    let listed = subcommands();
    let tested: Vec<&str> = table.iter().map(|(c, _)| *c).collect();
    assert_eq!(
        listed, tested,
        "the subcommands of `mshbm --help` and the table's"
    );

    let mut wrong = Vec::new();
    for (command, cases) in &table {
        for c in cases {
            assert_eq!(c.args[0], *command, "{}", c.what);
            let (status, latency, stderr) = run(c, d);
            assert!(!stderr.contains("panicked"), "{}: {stderr}", c.what);
            if status != c.expected {
                wrong.push(format!(
                    "{} ({:?}): status {status}, expected {}; stderr: {stderr}",
                    c.what, c.args, c.expected
                ));
            }
            if status != 0 {
                // every failure says why on stderr
                assert!(stderr.contains("error: "), "{}: {stderr}", c.what);
            }
            if let Some(latency) = latency {
                assert!(
                    latency < 1.0,
                    "{}: stopped {latency:.2} s after SIGTERM: {stderr}",
                    c.what
                );
            }
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}
