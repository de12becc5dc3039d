//! One module per subcommand; each turns parsed arguments into library calls and output.

pub mod export;
pub mod frf;
pub mod modes;
pub mod paper;
pub mod simulate;
pub mod solve;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::Args;
use mshbm::solution::PeriodicSolution;

/// Arguments shared by every command that reads a model.
#[derive(Args, Debug, Clone)]
pub struct ModelArgs {
    /// Model file (TOML): `kind = "bar"` (the paper's clamped bar), `kind = "dropped_bar"`
    /// (a free bar falling onto a support) or `kind = "matrices"` (Matrix Market M, K,
    /// optional C, with contacts and friction elements). See examples/.
    pub model: PathBuf,

    /// Override one field of the model file by its dotted path, e.g.
    /// `--set contact.gap=0` or `--set damping.first_mode_ratio=0.01`. Repeatable.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub overrides: Vec<String>,

    /// Allow paths in the model file (matrices, load vectors, coordinates) that leave the
    /// model file's directory tree (`..`, absolute paths, symbolic links pointing out).
    /// Refused by default, so that a model file from elsewhere cannot make the program
    /// read arbitrary files.
    #[arg(long)]
    pub allow_outside_paths: bool,

    /// Memory budget [GiB] that a model and a computation may plan to use; larger ones are
    /// refused before anything is allocated. Default: the memory this process may use, the
    /// smallest of three quarters of the machine's physical memory, the memory available
    /// now (MemAvailable), `ulimit -v` (RLIMIT_AS) and `-d` (RLIMIT_DATA) less what is
    /// mapped already, and the cgroup's memory limit.
    #[arg(long, value_name = "GIB", value_parser = parse_memory_gib, allow_negative_numbers = true)]
    pub max_memory: Option<f64>,
}

/// `--max-memory`: a finite positive number of GiB.
fn parse_memory_gib(text: &str) -> std::result::Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(g) if g.is_finite() && g > 0.0 => Ok(g),
        _ => Err(format!(
            "expected a positive number of GiB, got {}",
            mshbm::model::excerpt::excerpt(text)
        )),
    }
}

impl ModelArgs {
    /// The resource limits of this run (`--max-memory`), for the model and the solvers.
    pub fn limits(&self) -> mshbm::limits::Limits {
        // the first SIGINT/SIGTERM asks the library to stop (docs/safety.md, "Interrupts")
        let limits = mshbm::limits::Limits {
            cancel: crate::output::interrupt::cancel(),
            ..mshbm::limits::Limits::default()
        };
        match self.max_memory {
            Some(gib) => limits.with_memory_gib(gib),
            None => limits,
        }
    }

    /// How the model file is read (`--max-memory`, `--allow-outside-paths`).
    pub fn load_options(&self) -> mshbm::model::LoadOptions {
        mshbm::model::LoadOptions {
            limits: self.limits(),
            allow_outside_paths: self.allow_outside_paths,
        }
    }

    /// Read the model with its overrides and options.
    pub fn load(&self) -> Result<mshbm::Model> {
        Ok(mshbm::model::file::load_model_with(
            &self.model,
            &self.overrides,
            &self.load_options(),
        )?)
    }
}

/// Largest `--from-solution` file: 256 MiB (the JSON of a solution of the 3D plate with
/// 1056 contacts is a few megabytes).
pub const MAX_SOLUTION_FILE_BYTES: u64 = 256 << 20;

/// Memory of reading a solution per byte of its JSON: the text and the parsed arrays.
const SOLUTION_BYTES_PER_FILE_BYTE: u64 = 3;

/// A periodic solution written by `mshbm solve --json` (the start of `simulate` or `solve`
/// `--from-solution`), read bounded: a regular file of at most
/// [`MAX_SOLUTION_FILE_BYTES`] whose reading fits the memory budget of `limits`.
pub(crate) fn read_solution(
    path: &Path,
    limits: &mshbm::limits::Limits,
) -> Result<PeriodicSolution> {
    let text = mshbm::limits::read_bounded(
        path,
        limits,
        MAX_SOLUTION_FILE_BYTES.min(limits.file_bytes),
        "the limit of a --from-solution file",
        SOLUTION_BYTES_PER_FILE_BYTE,
    )?;
    serde_json::from_str(&text).with_context(|| {
        format!(
            "{}: not a periodic solution (JSON of `mshbm solve --json`)",
            path.display()
        )
    })
}

/// The CLI's spelling of the library's option names ([`mshbm::request`]): `--name-with-
/// dashes`, a value after a space; `from_hz`, `to_hz` are `--from`, `--to`, a start solution
/// is `--from-solution`.
pub struct CliSpelling;

impl mshbm::error::Spelling for CliSpelling {
    fn option(&self, name: &str) -> String {
        match name {
            "from_hz" => "--from".into(),
            "to_hz" => "--to".into(),
            "start_solution" => "--from-solution".into(),
            _ => format!("--{}", name.replace('_', "-")),
        }
    }
    fn option_value(&self, name: &str, value: &str) -> String {
        format!("{} {value}", self.option(name))
    }
}

/// A bad option, in the CLI's spelling.
pub fn option_error(e: mshbm::error::OptionError) -> anyhow::Error {
    anyhow::anyhow!("{}", e.render(&CliSpelling))
}

/// `Result<T, OptionError>` → `anyhow::Result<T>` in the CLI's spelling.
pub trait Spelled<T> {
    fn spelled(self) -> Result<T>;
}

impl<T> Spelled<T> for std::result::Result<T, mshbm::error::OptionError> {
    fn spelled(self) -> Result<T> {
        self.map_err(option_error)
    }
}
