//! Issue 46, item 6: the first SIGTERM stops a long computation within about a second, not
//! at its next write: the library checks the CLI's cancellation request (`Limits::cancel`)
//! in Newton's iterations and the set-up phases, and a command that streams nothing is
//! stopped by the CLI one second after the signal when no checkpoint came first
//! (docs/safety.md, "Interrupts"). Exit status 130; a streamed CSV keeps its rows with an
//! `# incomplete` line.

#![cfg(unix)]

mod common;

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::example;
use common::resources::ChildGuard;

/// Start `mshbm args…`, send SIGTERM after `after`, and return (exit status, seconds from
/// the signal to the exit, stderr). Killed after 30 s if it does not stop.
fn terminate_after(args: &[&str], after: Duration, dir: &std::path::Path) -> (i32, f64, String) {
    let stderr_path = dir.join("stderr.txt");
    let child = Command::new(assert_cmd::cargo::cargo_bin("mshbm"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&stderr_path).unwrap())
        .spawn()
        .unwrap();
    let mut child = ChildGuard::new(child);
    std::thread::sleep(after);
    assert!(
        child.try_wait().is_none(),
        "the run ended before the signal: choose a longer case; stderr: {}",
        std::fs::read_to_string(&stderr_path).unwrap_or_default()
    );
    // SAFETY: signalling our own child.
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGTERM) }, 0);
    let sent = Instant::now();
    let status = loop {
        if sent.elapsed() > Duration::from_secs(30) {
            panic!("still running 30 s after SIGTERM");
        }
        if let Some(status) = child.try_wait() {
            break status;
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let latency = sent.elapsed().as_secs_f64();
    let stderr = std::fs::read_to_string(&stderr_path).unwrap_or_default();
    // killed by a signal: 128 + signal
    let code = status.code().unwrap_or_else(|| {
        use std::os::unix::process::ExitStatusExt;
        128 + status.signal().unwrap_or(0)
    });
    (code, latency, stderr)
}

#[test]
fn sigterm_stops_a_long_solve_within_two_seconds() {
    let dir = tempfile::tempdir().unwrap();
    let model = example("block_3d/model.toml");
    // the 3D plate of the README (about 25 s on one core; the 49 s after SIGTERM)
    let (status, latency, stderr) = terminate_after(
        &[
            "solve",
            model.as_str(),
            "--frequency",
            "1500",
            "--harmonics",
            "1",
            "--quadrature",
            "sampled",
            "--no-stability",
        ],
        Duration::from_secs(2),
        dir.path(),
    );
    assert_eq!(status, 130, "{stderr}");
    assert!(
        latency < 2.0,
        "stopped {latency:.2} s after SIGTERM: {stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn sigterm_stops_modes_of_a_large_model_within_two_seconds() {
    let dir = tempfile::tempdir().unwrap();
    let model = example("block_3d/model.toml");
    let (status, latency, stderr) = terminate_after(
        &[
            "modes",
            model.as_str(),
            "--set",
            "solid.divisions=[48,48,6]",
            "--count",
            "10",
        ],
        Duration::from_secs(2),
        dir.path(),
    );
    assert_eq!(status, 130, "{stderr}");
    assert!(
        latency < 2.0,
        "stopped {latency:.2} s after SIGTERM: {stderr}"
    );
}

/// `frf` streams its CSV, so the CLI never cuts it short: the library's cancellation in
/// Newton's iterations ends the point under way, and the CSV keeps its rows.
#[test]
fn sigterm_stops_a_streaming_frf_inside_its_point() {
    let dir = tempfile::tempdir().unwrap();
    let model = example("block_3d/model.toml");
    let (status, latency, stderr) = terminate_after(
        &[
            "frf",
            model.as_str(),
            "--set",
            "solid.divisions=[16,16,4]",
            "--set",
            "interfaces.0.gap=0.0003",
            "--from",
            "400",
            "--to",
            "600",
            "--harmonics",
            "3",
            "--quadrature",
            "sampled",
            "--output",
            "frf.csv",
        ],
        Duration::from_secs(3),
        dir.path(),
    );
    assert_eq!(status, 130, "{stderr}");
    assert!(
        latency < 2.0,
        "stopped {latency:.2} s after SIGTERM: {stderr}"
    );
    let csv = std::fs::read_to_string(dir.path().join("frf.csv")).unwrap();
    assert!(
        csv.lines()
            .last()
            .unwrap()
            .starts_with("# incomplete: interrupted by SIGTERM after"),
        "{csv}"
    );
}
