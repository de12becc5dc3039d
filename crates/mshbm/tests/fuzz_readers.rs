//! Fuzz test of the model reader and the Matrix Market reader: a committed seed corpus
//! (the example models, small Matrix Market files and hand-made edge cases under
//! `tests/fuzz_corpus/`) is mutated by a deterministic generator (byte flips, insertions,
//! deletions, duplicated lines, numbers replaced by extreme values), and every input must
//! give `Ok` or `Err` — never a panic — within 1 s, with a small memory budget.
//!
//! `MSHBM_FUZZ_CASES` sets the number of inputs (default 10 000), `MSHBM_FUZZ_SEED` the
//! generator's seed (default fixed, so a failure is reproducible).

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use mshbm::limits::Limits;
use mshbm::model::file::{load_model_with, parse_model_with};
use mshbm::model::matrix_market::parse_matrix_with;
use mshbm::model::LoadOptions;

/// The longest an input may take.
const TIME_LIMIT: Duration = Duration::from_secs(1);

/// xorshift64*: a small deterministic generator (Vigna 2016).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Replacements for a number (or any token) of a seed.
const TOKENS: &[&str] = &[
    "0",
    "-1",
    "1",
    "2",
    "1e308",
    "-1e308",
    "1e-320",
    "18446744073709551615",
    "18446744073709551616",
    "4294967296",
    "4611686018427387904",
    "9223372036854775807",
    "1000000000",
    "nan",
    "inf",
    "-inf",
    "-0.0",
    "\"\u{1b}[31m\"",
    "\"../../etc/passwd\"",
    "\"/dev/zero\"",
    "[]",
    "[[]]",
    "{}",
    "\"\"",
    "true",
    "ü",
    "\u{0}",
    "%",
    "\n",
];

/// One to four mutations of `seed`.
fn mutate(seed: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut s = seed.to_vec();
    for _ in 0..1 + rng.below(4) {
        let at = rng.below(s.len() + 1);
        match rng.below(6) {
            // flip a bit
            0 if !s.is_empty() => {
                let i = rng.below(s.len());
                s[i] ^= 1 << rng.below(8);
            }
            // insert random bytes
            1 => {
                let bytes: Vec<u8> = (0..1 + rng.below(4)).map(|_| rng.next() as u8).collect();
                s.splice(at..at, bytes);
            }
            // delete a range
            2 if !s.is_empty() => {
                let end = (at + 1 + rng.below(16)).min(s.len());
                let start = at.min(end.saturating_sub(1));
                s.drain(start..end);
            }
            // duplicate a line
            3 => {
                let start = s[..at]
                    .iter()
                    .rposition(|&b| b == b'\n')
                    .map_or(0, |p| p + 1);
                let end = s[at..]
                    .iter()
                    .position(|&b| b == b'\n')
                    .map_or(s.len(), |p| at + p + 1);
                let line = s[start..end].to_vec();
                s.splice(end..end, line);
            }
            // replace a number (or the token at a random place) by an extreme value
            _ => {
                let digits: Vec<usize> = (0..s.len()).filter(|&i| s[i].is_ascii_digit()).collect();
                let i = if digits.is_empty() {
                    at
                } else {
                    digits[rng.below(digits.len())]
                };
                let is_num =
                    |b: u8| b.is_ascii_alphanumeric() || b == b'.' || b == b'-' || b == b'+';
                let mut start = i.min(s.len());
                while start > 0 && is_num(s[start - 1]) {
                    start -= 1;
                }
                let mut end = start;
                while end < s.len() && is_num(s[end]) {
                    end += 1;
                }
                let token = TOKENS[rng.below(TOKENS.len())].as_bytes().to_vec();
                s.splice(start..end, token);
            }
        }
    }
    s
}

fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_corpus")
}

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

fn files_in(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
}

/// Where the referenced files of a seed model live: the bar's Matrix Market files (101
/// DOFs) or the friction oscillator's (3 DOFs, inline coordinates).
#[derive(Clone, Copy)]
enum Folder {
    Bar,
    Chain,
}

/// A scratch directory with both sets of referenced files, removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new() -> Self {
        let root = std::env::temp_dir().join(format!("mshbm-fuzz-{}", std::process::id()));
        for (sub, from) in [
            ("bar", examples().join("bar_matrices")),
            ("chain", examples().join("friction_oscillator")),
            ("data", examples().join("bar_matrices")),
            ("data_nodes", examples().join("bar_matrices")),
        ] {
            std::fs::create_dir_all(root.join(sub)).unwrap();
            for f in files_in(&from) {
                std::fs::copy(&f, root.join(sub).join(f.file_name().unwrap())).unwrap();
            }
        }
        Scratch(root)
    }
    fn folder(&self, f: Folder) -> PathBuf {
        self.0.join(match f {
            Folder::Bar => "bar",
            Folder::Chain => "chain",
        })
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn options() -> LoadOptions {
    LoadOptions {
        limits: Limits {
            memory_bytes: 16 << 20,
            file_bytes: 1 << 20,
            cancel: Default::default(),
        },
        allow_outside_paths: false,
    }
}

/// An input for the failure message: escaped, at most 2000 characters.
fn show(input: &[u8]) -> String {
    let text = String::from_utf8_lossy(input);
    let shown: String = text.chars().take(2000).collect();
    format!("{shown:?}")
}

/// Run `f` on `input`: no panic and within [`TIME_LIMIT`], or fail naming the input.
fn check(case: usize, what: &str, input: &[u8], f: impl FnOnce()) {
    let start = Instant::now();
    let outcome = catch_unwind(AssertUnwindSafe(f));
    let took = start.elapsed();
    assert!(
        outcome.is_ok(),
        "case {case}: the {what} panicked on input {}",
        show(input)
    );
    assert!(
        took <= TIME_LIMIT,
        "case {case}: the {what} took {took:?} on input {}",
        show(input)
    );
}

#[test]
fn model_and_matrix_market_readers_never_panic() {
    let cases: usize = std::env::var("MSHBM_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10_000);
    let seed: u64 = std::env::var("MSHBM_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0x005E_ED15);
    let mut rng = Rng(seed | 1);
    let scratch = Scratch::new();
    let options = options();

    let mut models: Vec<(Vec<u8>, Folder)> = Vec::new();
    let mut model_files = files_in(&corpus().join("models"));
    model_files.extend(
        files_in(&examples())
            .into_iter()
            .filter(|p| p.extension().is_some_and(|e| e == "toml")),
    );
    model_files.push(examples().join("bar_matrices/model.toml"));
    model_files.push(examples().join("friction_oscillator/model.toml"));
    for p in model_files {
        let text = std::fs::read(&p).unwrap();
        let folder = if String::from_utf8_lossy(&text).contains("coordinates = [") {
            Folder::Chain
        } else {
            Folder::Bar
        };
        models.push((text, folder));
    }
    let mut matrices: Vec<Vec<u8>> = files_in(&corpus().join("matrices"))
        .iter()
        .map(|p| std::fs::read(p).unwrap())
        .collect();
    for f in [
        "mass.mtx",
        "stiffness.mtx",
        "harmonic_load.mtx",
        "nodes.txt",
    ] {
        matrices.push(std::fs::read(examples().join("bar_matrices").join(f)).unwrap());
    }

    let (mut ok, mut err) = (0usize, 0usize);
    let mut count = |r: bool| if r { ok += 1 } else { err += 1 };
    for case in 0..cases {
        if case % 2 == 0 {
            // a model file: parsed from text, and every eighth one read from disk as the
            // CLI reads it (bounded read, UTF-8 check)
            let (seed, folder) = &models[rng.below(models.len())];
            let input = mutate(seed, &mut rng);
            let path = scratch.folder(*folder).join("fuzzed.toml");
            let mut result = false;
            if case % 16 == 0 {
                std::fs::write(&path, &input).unwrap();
                check(case, "model reader", &input, || {
                    result = load_model_with(&path, &[], &options).is_ok();
                });
            } else {
                let text = String::from_utf8_lossy(&input);
                check(case, "model parser", &input, || {
                    result = parse_model_with(&text, &path, &[], &options).is_ok();
                });
            }
            count(result);
        } else {
            // a Matrix Market file: parsed directly, and every other one also as the
            // stiffness (or, for text that is not Matrix Market, the coordinates) of a model
            let input = mutate(&matrices[rng.below(matrices.len())], &mut rng);
            let text = String::from_utf8_lossy(&input).into_owned();
            let mut result = false;
            check(case, "Matrix Market reader", &input, || {
                result = parse_matrix_with(&text, Path::new("fuzzed.mtx"), &options.limits).is_ok();
            });
            count(result);
            if case % 4 == 1 {
                let (folder, name) = if text.starts_with("%%") {
                    ("data", "stiffness.mtx")
                } else {
                    ("data_nodes", "nodes.txt")
                };
                std::fs::write(scratch.0.join(folder).join(name), &input).unwrap();
                let model = scratch.0.join(folder).join("model.toml");
                check(case, "model reader with a fuzzed data file", &input, || {
                    let _ = load_model_with(&model, &[], &options);
                });
            }
        }
    }
    // the mutations must leave some inputs valid and make most invalid, or the test
    // would not exercise both paths
    assert!(
        ok > cases / 100 && err > cases / 10,
        "{ok} accepted, {err} refused of {cases}"
    );
}
