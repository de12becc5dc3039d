//! One module per subcommand; each turns parsed arguments into library calls and output.

pub mod export;
pub mod frf;
pub mod modes;
pub mod paper;
pub mod simulate;
pub mod solve;

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

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
}

impl ModelArgs {
    /// Read the model with its overrides.
    pub fn load(&self) -> Result<mshbm::Model> {
        Ok(mshbm::model::file::load_model(
            &self.model,
            &self.overrides,
        )?)
    }
}
