//! Issue 15, "Outputs can destroy files": every reproducer of the issue as a test. Outputs
//! that are devices, FIFOs, the model file or another output are refused before computing,
//! in one line naming the option and the path, within 1 s of CPU and 200 MB; a symlink
//! planted at the old predictable temporary name redirects nothing; `export` does not
//! overwrite without `--force`; an error leaves no temporary file; a full stdout is an
//! error, not a panic; an interrupted `frf` keeps its points with an `# incomplete` line; a
//! solve that does not converge says so in every output and exits with status 2.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::resources::{run_measured, wait_with_usage, ChildGuard, Measured};
use common::*;

/// The paper's bar, small (10 elements) and damped, copied into `dir` as `model.toml`.
fn small_model(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(examples().join("clamped_bar.toml"))
        .unwrap()
        .replace("elements = 100 ", "elements = 10 ")
        .replace("alpha = 0.0 ", "alpha = 7587.745 ");
    let path = dir.join("model.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// `mshbm args…` measured (CPU, memory) with its outputs in `dir`.
fn measured(dir: &Path, args: &[&str]) -> Measured {
    let mut c = Command::new(assert_cmd::cargo::cargo_bin("mshbm"));
    c.args(args).current_dir(dir);
    let scratch = tempfile::tempdir().unwrap();
    run_measured(c, scratch.path())
}

/// `solve` of the small model at 60 kHz with H = 3, plus `extra`.
fn solve_args<'a>(model: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec!["solve", model, "--frequency", "60000", "--harmonics", "3"];
    args.extend_from_slice(extra);
    args
}

/// Files in `dir` whose name marks a temporary output.
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.') && n.ends_with(".tmp"))
        .collect()
}

fn is_root() -> bool {
    // SAFETY: geteuid has no preconditions.
    unsafe { libc::geteuid() == 0 }
}

fn c_path(p: &Path) -> std::ffi::CString {
    use std::os::unix::ffi::OsStrExt;
    std::ffi::CString::new(p.as_os_str().as_bytes()).unwrap()
}

#[test]
fn a_character_device_as_output_stays_a_device() {
    use std::os::unix::fs::FileTypeExt;
    if !is_root() {
        println!("note: not root, cannot mknod a copy of /dev/null; case skipped");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let model = small_model(dir.path());
    let device = dir.path().join("null");
    // SAFETY: valid path; a character device 1:3 (/dev/null's numbers) in a temp dir.
    let rc = unsafe {
        libc::mknod(
            c_path(&device).as_ptr(),
            libc::S_IFCHR | 0o666,
            libc::makedev(1, 3),
        )
    };
    assert_eq!(rc, 0, "mknod");
    let m = model.display().to_string();
    let d = device.display().to_string();
    measured(dir.path(), &solve_args(&m, &["--output", &d])).assert_clean_refusal(&[
        "--output",
        &d,
        "character device",
    ]);
    let sim = [
        "simulate",
        m.as_str(),
        "--frequency",
        "60000",
        "--periods",
        "2",
        "--output",
        &d,
    ];
    measured(dir.path(), &sim).assert_clean_refusal(&["--output", "character device"]);
    let kind = std::fs::symlink_metadata(&device).unwrap().file_type();
    assert!(kind.is_char_device(), "the device was replaced: {kind:?}");
    assert!(temporaries(dir.path()).is_empty());
}

#[test]
fn a_fifo_as_output_is_refused_without_blocking() {
    let dir = tempfile::tempdir().unwrap();
    let model = small_model(dir.path());
    let fifo = dir.path().join("pipe.csv");
    // SAFETY: valid path.
    assert_eq!(unsafe { libc::mkfifo(c_path(&fifo).as_ptr(), 0o644) }, 0);
    let (m, f) = (model.display().to_string(), fifo.display().to_string());
    // a blocked open would hang here: the CPU limit is checked on a finished run, so the
    // child is spawned with a deadline as well
    let mut child = ChildGuard::new(
        Command::new(assert_cmd::cargo::cargo_bin("mshbm"))
            .args(solve_args(&m, &["--output", &f]))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let start = Instant::now();
    while child.try_wait().is_none() {
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "blocked on the FIFO"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    measured(dir.path(), &solve_args(&m, &["--output", &f]))
        .assert_clean_refusal(&["--output", "FIFO"]);
    let kind = std::fs::symlink_metadata(&fifo).unwrap().file_type();
    use std::os::unix::fs::FileTypeExt;
    assert!(kind.is_fifo());
}

#[test]
fn a_symlink_planted_at_the_old_temporary_name_redirects_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let model = small_model(dir.path());
    let victim = dir.path().join("victim.txt");
    std::fs::write(&victim, "precious").unwrap();
    std::os::unix::fs::symlink(&victim, dir.path().join(".out.csv.tmp")).unwrap();
    let m = model.display().to_string();
    let out = measured(dir.path(), &solve_args(&m, &["--output", "out.csv"]));
    assert_eq!(out.status, 0, "{}", out.stderr);
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "precious");
    let csv = std::fs::read_to_string(dir.path().join("out.csv")).unwrap();
    assert!(csv.starts_with("time_s,q_dof10,gap_c0,force_c0\n"), "{csv}");
    // the planted link is left alone and no temporary file of ours remains
    assert_eq!(temporaries(dir.path()), vec![".out.csv.tmp".to_string()]);
}

#[test]
fn an_output_that_is_the_model_file_is_refused_and_the_model_kept() {
    let dir = tempfile::tempdir().unwrap();
    let model = small_model(dir.path());
    let before = std::fs::read(&model).unwrap();
    let m = model.display().to_string();
    // the same file by its own path, by another spelling, through a hard link
    let other_spelling = dir.path().join(".").join("model.toml");
    let hard_link = dir.path().join("link.csv");
    std::fs::hard_link(&model, &hard_link).unwrap();
    for path in [model.clone(), other_spelling, hard_link] {
        let p = path.display().to_string();
        measured(dir.path(), &solve_args(&m, &["--output", &p])).assert_clean_refusal(&[
            "--output",
            &p,
            "model file",
        ]);
    }
    let sim = [
        "simulate",
        &m,
        "--frequency",
        "60000",
        "--periods",
        "1",
        "--output",
        &m,
    ];
    measured(dir.path(), &sim).assert_clean_refusal(&["--output", "model file"]);
    assert_eq!(std::fs::read(&model).unwrap(), before);
    // the solution a simulation starts from is an input too
    let start = dir.path().join("start.json");
    std::fs::write(&start, "{}").unwrap();
    let st = start.display().to_string();
    let sim = [
        "simulate",
        &m,
        "--from-solution",
        &st,
        "--periods",
        "1",
        "--output",
        &st,
    ];
    measured(dir.path(), &sim).assert_clean_refusal(&["--output", "--from-solution"]);
    assert_eq!(std::fs::read_to_string(&start).unwrap(), "{}");
}

#[test]
fn an_output_that_is_a_file_the_model_reads_is_refused_and_kept() {
    // a matrices model reads M, K and load vectors; none of them may be an output
    let dir = tempfile::tempdir().unwrap();
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/bar_matrices");
    for entry in std::fs::read_dir(&source).unwrap() {
        let entry = entry.unwrap();
        std::fs::copy(entry.path(), dir.path().join(entry.file_name())).unwrap();
    }
    let model = dir.path().join("model.toml").display().to_string();
    let mass = dir.path().join("mass.mtx");
    let before = std::fs::read(&mass).unwrap();
    let m = mass.display().to_string();
    measured(dir.path(), &solve_args(&model, &["--output", &m]))
        .assert_clean_refusal(&["--output", "a file the model reads"]);
    let frf = [
        "frf", &model, "--from", "1000", "--to", "2000", "--output", &m,
    ];
    measured(dir.path(), &frf).assert_clean_refusal(&["--output", "a file the model reads"]);
    assert_eq!(std::fs::read(&mass).unwrap(), before);
}

#[test]
fn an_output_equal_to_another_output_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let model = small_model(dir.path());
    let m = model.display().to_string();
    measured(
        dir.path(),
        &solve_args(&m, &["--output", "x.svg", "--plot", "x.svg"]),
    )
    .assert_clean_refusal(&["--plot x.svg", "--output x.svg"]);
    assert!(!dir.path().join("x.svg").exists());
}

#[test]
fn export_refuses_to_overwrite_without_force() {
    let dir = tempfile::tempdir().unwrap();
    let model = small_model(dir.path());
    let m = model.display().to_string();
    let out = measured(dir.path(), &["export", &m, "--output", "exported"]);
    assert_eq!(out.status, 0, "{}", out.stderr);
    let exported = dir.path().join("exported/model.toml");
    let first = std::fs::read_to_string(&exported).unwrap();
    std::fs::write(dir.path().join("exported/mass.mtx"), "edited").unwrap();
    measured(dir.path(), &["export", &m, "--output", "exported"])
        .assert_clean_refusal(&["--output", "exists", "--force"]);
    assert_eq!(
        std::fs::read_to_string(dir.path().join("exported/mass.mtx")).unwrap(),
        "edited"
    );
    let out = measured(
        dir.path(),
        &["export", &m, "--output", "exported", "--force"],
    );
    assert_eq!(out.status, 0, "{}", out.stderr);
    assert_eq!(std::fs::read_to_string(&exported).unwrap(), first);
    assert!(
        std::fs::read_to_string(dir.path().join("exported/mass.mtx"))
            .unwrap()
            .starts_with("%%MatrixMarket")
    );
    // the export reads back
    let back = measured(
        dir.path(),
        &["modes", "exported/model.toml", "--count", "2", "--json"],
    );
    assert_eq!(back.status, 0, "{}", back.stderr);
    assert!(temporaries(&dir.path().join("exported")).is_empty());
}

#[test]
fn bad_plot_paths_are_refused_before_computing() {
    let dir = tempfile::tempdir().unwrap();
    let model = small_model(dir.path());
    let m = model.display().to_string();
    // a wide diagram would take many seconds of CPU: the refusal comes first
    for (plot, words) in [
        ("missing/frd.png", ["--plot", "does not exist"]),
        ("frd.txt", ["--plot", ".svg or .png"]),
    ] {
        let args = [
            "frf",
            &m,
            "--from",
            "1000",
            "--to",
            "100000",
            "--harmonics",
            "1,3,5,10",
            "--output",
            "frd.csv",
            "--json",
            "--plot",
            plot,
        ];
        measured(dir.path(), &args).assert_clean_refusal(&words);
    }
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, vec!["model.toml".to_string()], "nothing was created");
}

#[test]
fn an_error_after_the_output_was_opened_leaves_no_temporary_file() {
    // the CSV is opened before the diagram starts; the method then cannot be built
    // (too few samples for H = 5) and the run fails: no file under either name
    let dir = tempfile::tempdir().unwrap();
    let model = small_model(dir.path());
    let m = model.display().to_string();
    let args = [
        "frf",
        &m,
        "--from",
        "1000",
        "--to",
        "2000",
        "--harmonics",
        "5",
        "--samples",
        "4",
        "--output",
        "frd.csv",
    ];
    let out = measured(dir.path(), &args);
    assert_ne!(out.status, 0);
    assert!(!out.stderr.contains("panicked"), "{}", out.stderr);
    assert!(
        temporaries(dir.path()).is_empty(),
        "{:?}",
        temporaries(dir.path())
    );
    assert!(!dir.path().join("frd.csv").exists());
}

#[test]
#[allow(clippy::zombie_processes)] // reaped by wait4 in wait_with_usage
fn a_full_standard_output_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let model = small_model(dir.path());
    let m = model.display().to_string();
    for args in [
        vec!["modes", m.as_str(), "--count", "3"],
        vec!["modes", m.as_str(), "--count", "3", "--json"],
        solve_args(&m, &["--json"]),
    ] {
        let mut c = Command::new(assert_cmd::cargo::cargo_bin("mshbm"));
        c.args(&args);
        let full = std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap();
        let err = dir.path().join("stderr.txt");
        let child = c
            .stdin(Stdio::null())
            .stdout(full)
            .stderr(std::fs::File::create(&err).unwrap())
            .spawn()
            .unwrap();
        let (status, (cpu, rss)) = wait_with_usage(child.id() as i32);
        let stderr = std::fs::read_to_string(&err).unwrap();
        assert_eq!(status, 1, "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(
            stderr.contains("cannot write to standard output"),
            "{stderr}"
        );
        assert!(cpu < 1.0 && rss < 200.0, "{cpu} s, {rss} MB");
    }
}

/// The data rows of a CSV text and its final `#` line.
fn rows_and_status(text: &str) -> (Vec<&str>, &str) {
    let lines: Vec<&str> = text.lines().collect();
    let status = lines.last().copied().unwrap_or_default();
    let rows = lines[1..]
        .iter()
        .copied()
        .filter(|l| !l.starts_with('#'))
        .collect();
    (rows, status)
}

#[test]
fn an_interrupted_frf_keeps_its_points_marked_incomplete() {
    let dir = tempfile::tempdir().unwrap();
    let model = small_model(dir.path());
    let m = model.display().to_string();
    let child = ChildGuard::new(
        Command::new(assert_cmd::cargo::cargo_bin("mshbm"))
            .args([
                "frf",
                &m,
                "--from",
                "1000",
                "--to",
                "300000",
                "--harmonics",
                "10",
                "--max-step",
                "0.01",
                "--output",
                "frd.csv",
                "--json",
            ])
            .current_dir(dir.path())
            .stdin(Stdio::null())
            .stdout(std::fs::File::create(dir.path().join("stdout.txt")).unwrap())
            .stderr(std::fs::File::create(dir.path().join("stderr.txt")).unwrap())
            .spawn()
            .unwrap(),
    );
    // wait for a few rows in the temporary file, then SIGINT
    let start = Instant::now();
    loop {
        let rows = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| {
                let n = p.file_name().unwrap().to_string_lossy().into_owned();
                n.starts_with(".frd.csv.") && n.ends_with(".tmp")
            })
            .map(|p| {
                std::fs::read_to_string(p)
                    .unwrap_or_default()
                    .lines()
                    .count()
            })
            .max()
            .unwrap_or(0);
        if rows >= 6 {
            break;
        }
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "no rows appeared in the temporary CSV"
        );
        assert!(!dir.path().join("frd.csv").exists(), "finished too early");
        std::thread::sleep(Duration::from_millis(5));
    }
    // SAFETY: signalling our own child.
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGINT) }, 0);
    let (status, _) = child.wait();
    let stderr = std::fs::read_to_string(dir.path().join("stderr.txt")).unwrap();
    assert_eq!(status, 130, "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        stderr.contains("interrupted by SIGINT") && stderr.contains("frd.csv"),
        "{stderr}"
    );
    let text = std::fs::read_to_string(dir.path().join("frd.csv")).unwrap();
    assert!(text.starts_with(FRD_HEADER), "{text}");
    let (rows, last) = rows_and_status(&text);
    assert!(rows.len() >= 5, "{text}");
    assert!(rows.iter().all(|r| r.split(',').count() == 10), "{text}");
    assert_eq!(
        last,
        format!(
            "# incomplete: interrupted by SIGINT after {} points",
            rows.len()
        )
    );
    assert!(temporaries(dir.path()).is_empty());
    // the JSON of an incomplete diagram is not written
    assert_eq!(
        std::fs::read_to_string(dir.path().join("stdout.txt")).unwrap(),
        ""
    );
}

#[test]
fn a_finished_frf_says_so_in_its_last_line() {
    let dir = tempfile::tempdir().unwrap();
    let model = small_model(dir.path());
    let m = model.display().to_string();
    let out = measured(
        dir.path(),
        &[
            "frf",
            &m,
            "--from",
            "20000",
            "--to",
            "30000",
            "--harmonics",
            "1,3",
            "--output",
            "frd.csv",
            "--json",
        ],
    );
    assert_eq!(out.status, 0, "{}", out.stderr);
    let v: serde_json::Value = serde_json::from_str(&out.stdout).unwrap();
    let points: usize = v["branches"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| b["points"].as_array().unwrap().len())
        .sum();
    let text = std::fs::read_to_string(dir.path().join("frd.csv")).unwrap();
    let (rows, last) = rows_and_status(&text);
    assert_eq!(rows.len(), points);
    assert_eq!(
        last,
        format!("# finished: {points} points, every branch complete")
    );
}

#[test]
fn a_solve_that_does_not_converge_is_marked_everywhere_and_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let model = small_model(dir.path());
    let m = model.display().to_string();
    let out = measured(
        dir.path(),
        &solve_args(
            &m,
            &[
                "--start",
                "linear",
                "--max-iterations",
                "1",
                "--json",
                "--output",
                "period.csv",
            ],
        ),
    );
    assert_eq!(out.status, 2, "{}", out.stderr);
    assert!(!out.stderr.contains("panicked"));
    assert_eq!(out.stderr.lines().count(), 1, "{}", out.stderr);
    assert!(out.stderr.starts_with("error: Newton did not converge"));
    let v: serde_json::Value = serde_json::from_str(&out.stdout).unwrap();
    assert_eq!(v["converged"], false);
    assert_eq!(v["iterations"], 1);
    let text = std::fs::read_to_string(dir.path().join("period.csv")).unwrap();
    let last = text.lines().last().unwrap();
    assert!(
        last.starts_with("# not converged: Newton did not converge"),
        "{last}"
    );
    // the plain-text report says so too
    let out = measured(
        dir.path(),
        &solve_args(&m, &["--start", "linear", "--max-iterations", "1"]),
    );
    assert_eq!(out.status, 2);
    assert!(out.stdout.contains("converged: false"), "{}", out.stdout);
    // and a converged solve is unmarked with status 0
    let out = measured(dir.path(), &solve_args(&m, &["--output", "ok.csv"]));
    assert_eq!(out.status, 0, "{}", out.stderr);
    let text = std::fs::read_to_string(dir.path().join("ok.csv")).unwrap();
    assert!(!text.contains('#'));
}

#[test]
fn an_interrupted_simulation_keeps_its_steps_marked_incomplete() {
    let dir = tempfile::tempdir().unwrap();
    let model = small_model(dir.path());
    let m = model.display().to_string();
    let child = ChildGuard::new(
        Command::new(assert_cmd::cargo::cargo_bin("mshbm"))
            .args([
                "simulate",
                &m,
                "--frequency",
                "30000",
                "--periods",
                "1000000",
                "--output",
                "s.csv",
            ])
            .current_dir(dir.path())
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(dir.path().join("stderr.txt")).unwrap())
            .spawn()
            .unwrap(),
    );
    let start = Instant::now();
    while temporaries(dir.path()).is_empty() {
        assert!(start.elapsed() < Duration::from_secs(30));
        std::thread::sleep(Duration::from_millis(5));
    }
    std::thread::sleep(Duration::from_millis(200));
    // SAFETY: signalling our own child.
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGTERM) }, 0);
    let (status, _) = child.wait();
    let stderr = std::fs::read_to_string(dir.path().join("stderr.txt")).unwrap();
    assert_eq!(status, 130, "{stderr}");
    let text = std::fs::read_to_string(dir.path().join("s.csv")).unwrap();
    let (rows, last) = rows_and_status(&text);
    assert!(!rows.is_empty());
    assert!(rows
        .iter()
        .all(|r| r.split(',').all(|x| x.parse::<f64>().is_ok())));
    assert_eq!(
        last,
        format!(
            "# incomplete: interrupted by SIGTERM after {} rows",
            rows.len()
        )
    );
    assert!(temporaries(dir.path()).is_empty());
}

#[test]
fn a_symlink_to_a_regular_file_is_followed_and_a_directory_refused() {
    let dir = tempfile::tempdir().unwrap();
    let model = small_model(dir.path());
    let m = model.display().to_string();
    // the link stays a link, the file it points to is replaced
    std::fs::create_dir(dir.path().join("results")).unwrap();
    let real = dir.path().join("results/period.csv");
    std::fs::write(&real, "old").unwrap();
    let link = dir.path().join("period.csv");
    std::os::unix::fs::symlink(&real, &link).unwrap();
    let out = measured(dir.path(), &solve_args(&m, &["--output", "period.csv"]));
    assert_eq!(out.status, 0, "{}", out.stderr);
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert!(std::fs::read_to_string(&real)
        .unwrap()
        .starts_with("time_s,"));
    // a link to a directory, a dangling link and a directory are refused
    std::os::unix::fs::symlink(dir.path().join("results"), dir.path().join("to_dir.csv")).unwrap();
    std::os::unix::fs::symlink(dir.path().join("nothing"), dir.path().join("dangling.csv"))
        .unwrap();
    for (path, words) in [
        ("to_dir.csv", "symbolic link to a directory"),
        ("dangling.csv", "symbolic link to nothing"),
        ("results", "is a directory"),
    ] {
        measured(dir.path(), &solve_args(&m, &["--output", path]))
            .assert_clean_refusal(&["--output", path, words]);
    }
    assert!(temporaries(dir.path()).is_empty());
    assert!(temporaries(&dir.path().join("results")).is_empty());
}
