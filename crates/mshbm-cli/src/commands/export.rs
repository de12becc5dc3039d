//! `mshbm export`: write a model as Matrix Market matrices plus a `kind = "matrices"`
//! model file, e.g. to take the built-in bar into another tool or to start a general model.
//! Existing files are never overwritten unless `--force`; each file is written atomically.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;
use mshbm::model::export::{export_files, EXPORTED_MODEL_FILE};

use super::ModelArgs;
use crate::output::{write_atomic, OutputKind, OutputPlan};

/// Arguments of `mshbm export`.
#[derive(Args, Debug)]
pub struct ExportArgs {
    #[command(flatten)]
    pub model: ModelArgs,

    /// Directory to write model.toml, mass.mtx, stiffness.mtx, load vectors and nodes.txt
    /// into (created if needed; its parent must exist).
    #[arg(long, value_name = "DIR")]
    pub output: PathBuf,

    /// Overwrite files of an earlier export in the directory (refused otherwise).
    #[arg(long)]
    pub force: bool,
}

pub fn run(args: &ExportArgs) -> Result<()> {
    let model = args.model.load()?;
    let dir = &args.output;
    match std::fs::symlink_metadata(dir) {
        Ok(m) if m.is_dir() => {}
        Ok(_) if std::fs::metadata(dir).is_ok_and(|m| m.is_dir()) => {}
        Ok(_) => bail!("--output {}: is not a directory", dir.display()),
        Err(_) => {
            let parent = crate::output::plan::directory_of(dir);
            if !parent.is_dir() {
                bail!(
                    "--output {}: the directory {} does not exist",
                    dir.display(),
                    parent.display()
                );
            }
            std::fs::create_dir(dir).with_context(|| {
                format!("--output {}: cannot create the directory", dir.display())
            })?;
        }
    }
    let files = export_files(&model);
    let mut plan = OutputPlan::new();
    plan.input("the model file", &args.model.model);
    plan.inputs("a file the model reads", &model.input_files);
    for f in &files {
        let path = dir.join(f.name);
        if args.force {
            plan.output("--output", Some(&path), OutputKind::Text);
        } else {
            plan.output_new("--output", &path, OutputKind::Text);
        }
    }
    plan.check()?;
    for f in &files {
        write_atomic(&dir.join(f.name), f.contents.as_bytes(), OutputKind::Text)?;
    }
    crate::note!("wrote {}", dir.join(EXPORTED_MODEL_FILE).display());
    Ok(())
}
