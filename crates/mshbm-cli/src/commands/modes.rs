//! `mshbm modes`: eigenfrequencies of the consistent and the redistributed model (the
//! paper's Fig. 8).

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use mshbm::modes::MassComparison;

use super::ModelArgs;
use crate::output::finite::{check_json, to_json};
use crate::output::{OutputKind, OutputPlan};
use crate::plot::{Figure, Series, Style};

/// Arguments of `mshbm modes`.
#[derive(Args, Debug)]
pub struct ModesArgs {
    #[command(flatten)]
    pub model: ModelArgs,

    /// Number of eigenfrequencies (lowest first), with all contacts open and the
    /// Dirichlet DOFs fixed.
    #[arg(long, default_value_t = 30)]
    pub count: usize,

    /// Print one JSON object on stdout instead of a table:
    /// {"original_hz": [...], "redistributed_hz": [...], "relative_error": [...],
    /// "norm": "frobenius" or "mass-weighted"}.
    #[arg(long)]
    pub json: bool,

    /// Write the relative error of the redistributed eigenfrequencies vs mode number
    /// (the paper's Fig. 8); format by extension, .svg or .png.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,

    /// Write the mode shapes of the consistent mass (contacts open) for ParaView into this
    /// directory (created if missing): `mode_0000.vtu …` (point data `mode_shape`, scaled
    /// to a largest displacement of 1 in the model's length unit) and `mode.pvd`, whose
    /// time steps are the eigenfrequencies [Hz].
    #[arg(long, value_name = "DIR")]
    pub vtk: Option<PathBuf>,
}

/// Fig. 8: relative error of the redistributed eigenfrequencies vs mode number.
pub fn relative_error_figure(report: &MassComparison) -> Figure {
    Figure {
        title: "Eigenfrequency shift by mass redistribution (Fig. 8)".into(),
        x_label: "mode number".into(),
        y_label: "f_redistributed / f_original − 1".into(),
        series: vec![Series {
            label: "redistributed vs consistent mass".into(),
            points: report
                .relative_error
                .iter()
                .enumerate()
                .map(|(k, &e)| ((k + 1) as f64, e))
                .collect(),
            style: Style::LineAndMarkers,
            color: 0,
        }],
        hlines: vec![],
    }
}

pub fn run(args: &ModesArgs) -> Result<()> {
    let model = args.model.load()?;
    let vtk_files = match &args.vtk {
        Some(dir) => {
            crate::vtk::check_collection_memory(
                &format!("--count {} with --vtk", args.count),
                dir,
                args.count,
                &model,
                &args.model.limits(),
            )?;
            std::fs::create_dir_all(dir)
                .with_context(|| format!("--vtk {}: cannot create the directory", dir.display()))?;
            Some(crate::vtk::collection_paths(dir, "mode", args.count))
        }
        None => None,
    };
    let mut plan = OutputPlan::new();
    if let Some((files, pvd)) = &vtk_files {
        for f in files.iter().chain(std::iter::once(pvd)) {
            plan.output("--vtk", Some(f), OutputKind::Text);
        }
    }
    plan.input("the model file", &args.model.model)
        .inputs("a file the model reads", &model.input_files)
        .output("--plot", args.plot.as_deref(), OutputKind::Plot)
        .check()?;
    let report = model.compare_masses_within(args.count, &args.model.limits());
    // a signal stops the eigensolver (the library's `Cancelled`): report the interruption
    crate::output::interrupt::check("nothing was written")?;
    let report =
        report.with_context(|| format!("{}: eigenfrequencies", args.model.model.display()))?;
    // the table and the plot show the same numbers as the JSON: none may be NaN
    check_json("the eigenfrequencies", &report)?;
    if let Some(path) = &args.plot {
        relative_error_figure(&report).save(path)?;
    }
    if let Some((files, pvd)) = &vtk_files {
        write_mode_shapes(&model, args.count, files, pvd)?;
    }
    if args.json {
        crate::outln!("{}", to_json("standard output", &report)?)?;
    } else {
        crate::outln!("{}", crate::output::one_line(&model.name))?;
        crate::outln!(
            "{:>5} {:>18} {:>18} {:>14}",
            "mode",
            "original_hz",
            "redistributed_hz",
            "rel_error"
        )?;
        for k in 0..report.original_hz.len() {
            crate::outln!(
                "{:>5} {:>18.3} {:>18.3} {:>14.3e}",
                k + 1,
                report.original_hz[k],
                report.redistributed_hz[k],
                report.relative_error[k]
            )?;
        }
        if report.norm == mshbm::fe::redistribution::RedistributionNorm::MassWeighted {
            crate::note!(
                "the redistributed mass is the closest in the mass-weighted norm: the paper's Frobenius norm leaves it indefinite on this mesh (docs/theory.md §4)"
            );
        }
        if let Some(path) = &args.plot {
            crate::note!("plot written to {}", path.display());
        }
    }
    Ok(())
}

/// The mode shapes of the consistent mass with the contacts open, one `.vtu` each.
fn write_mode_shapes(
    model: &mshbm::Model,
    count: usize,
    files: &[PathBuf],
    pvd: &std::path::Path,
) -> Result<()> {
    let system = model.system(mshbm::MassKind::Consistent)?;
    let modes = mshbm::modes::lowest_modes(&system.mass, &system.stiffness, count)
        .context("mode shapes")?;
    crate::vtk::write_collection(files, pvd, |k| {
        let mut shape = vec![0.0; model.n_dofs()];
        for (s, &d) in system.model_dof.iter().enumerate() {
            shape[d] = modes.shapes[(s, k)];
        }
        let largest = shape.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if largest > 0.0 {
            shape.iter_mut().for_each(|v| *v /= largest);
        }
        let hz = modes.eigenvalues[k].sqrt() / (2.0 * std::f64::consts::PI);
        Ok((
            hz,
            crate::vtk::unstructured_grid(model, &[("mode_shape", &shape)])?,
        ))
    })
}
