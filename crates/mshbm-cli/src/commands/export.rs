//! `mshbm export`: write a model as Matrix Market matrices plus a `kind = "matrices"`
//! model file, e.g. to take the built-in bar into another tool or to start a general model.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

use super::ModelArgs;

/// Arguments of `mshbm export`.
#[derive(Args, Debug)]
pub struct ExportArgs {
    #[command(flatten)]
    pub model: ModelArgs,

    /// Directory to write model.toml, mass.mtx, stiffness.mtx, load vectors and nodes.txt into.
    #[arg(long, value_name = "DIR")]
    pub output: PathBuf,
}

pub fn run(args: &ExportArgs) -> Result<()> {
    let model = args.model.load()?;
    let path = mshbm::model::export::export_matrices(&model, &args.output)?;
    eprintln!("wrote {}", path.display());
    Ok(())
}
