//! `mshbm solve`: one periodic solution at one frequency.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::{Args, ValueEnum};
use mshbm::continuation::newton::{solve_at_frequency, NewtonOptions};
use mshbm::method::redistributed::quadrature::Quadrature;
use mshbm::method::redistributed::{RedistributedMsHbm, RedistributedOptions};
use mshbm::problem::PeriodicProblem;
use mshbm::solution::PeriodicSolution;
use mshbm::Model;

use super::ModelArgs;
use crate::output::write_atomic;
use crate::plot::{Figure, HLine, Series, Style};

/// Periodic-solution methods.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// MS-HBM with redistributed mass: static contact per sample, semi-analytical Jacobian.
    Redistributed,
}

/// Quadrature of the Fourier coefficients of the contact displacement.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum QuadratureArg {
    /// Closed-form integrals between the located contact switching times (no aliasing).
    Exact,
    /// DFT over the samples (the paper's implementation).
    Sampled,
}

/// Method settings shared by `solve` and `frf`.
#[derive(Args, Debug, Clone)]
pub struct MethodArgs {
    /// Method.
    #[arg(long, value_enum, default_value_t = Method::Redistributed)]
    pub method: Method,

    /// Samples per period NS (≥ 2H+1). Default: max(256, 16·(2H+1)), enough to resolve the
    /// kinks of the contact displacement and to locate the contact switches.
    #[arg(long, value_name = "NS")]
    pub samples: Option<usize>,

    /// Quadrature of the Fourier coefficients of the contact displacement.
    #[arg(long, value_enum, default_value_t = QuadratureArg::Exact)]
    pub quadrature: QuadratureArg,

    /// Newton tolerance: max-norm of the residual relative to the model's length scale
    /// (the largest gap or static deflection of the contact DOFs).
    #[arg(long, default_value_t = 1e-10)]
    pub tolerance: f64,

    /// Newton iteration limit per solution.
    #[arg(long, default_value_t = 50)]
    pub max_iterations: usize,

    /// Model DOF whose response is reported (numbered as in the model file, from 0).
    /// Default: the first contact DOF.
    #[arg(long)]
    pub dof: Option<usize>,
}

impl MethodArgs {
    pub fn newton(&self) -> Result<NewtonOptions> {
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            bail!("--tolerance must be positive, got {}", self.tolerance);
        }
        if self.max_iterations == 0 {
            bail!("--max-iterations must be at least 1");
        }
        Ok(NewtonOptions {
            tolerance: self.tolerance,
            max_iterations: self.max_iterations,
            ..NewtonOptions::default()
        })
    }

    /// Build the method for `harmonics`.
    pub fn problem(&self, model: &Model, harmonics: usize) -> Result<Box<dyn PeriodicProblem>> {
        match self.method {
            Method::Redistributed => {
                let quadrature = match self.quadrature {
                    QuadratureArg::Exact => Quadrature::Exact,
                    QuadratureArg::Sampled => Quadrature::Sampled,
                };
                let options = RedistributedOptions {
                    harmonics,
                    samples: self.samples,
                    quadrature,
                };
                Ok(Box::new(RedistributedMsHbm::new(model, &options)?))
            }
        }
    }

    /// The response DOF (model numbering).
    pub fn response_dof(&self, model: &Model) -> Result<usize> {
        let dof = match self.dof {
            Some(d) => d,
            None => match model.contacts.first() {
                Some(c) => c.dofs[0],
                None => bail!("the model has no contact: give --dof"),
            },
        };
        if dof >= model.n_dofs() {
            bail!(
                "--dof {dof} out of range: the model has DOFs 0..{}",
                model.n_dofs() - 1
            );
        }
        Ok(dof)
    }
}

/// Arguments of `mshbm solve`.
#[derive(Args, Debug)]
pub struct SolveArgs {
    #[command(flatten)]
    pub model: ModelArgs,

    /// Excitation frequency [Hz].
    #[arg(long, value_name = "HZ")]
    pub frequency: f64,

    /// Number of harmonics H of the linear part.
    #[arg(long, default_value_t = 5)]
    pub harmonics: usize,

    #[command(flatten)]
    pub method: MethodArgs,

    /// Print the solution as one JSON object on stdout.
    #[arg(long)]
    pub json: bool,

    /// Write the time series over one period as CSV (time [s], displacement, gap and
    /// force of each contact).
    #[arg(long, value_name = "FILE")]
    pub output: Option<PathBuf>,

    /// Plot the contact displacement over one period with the gap line (the paper's
    /// Fig. 10); .svg or .png.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
}

fn time_series_csv(s: &PeriodicSolution) -> String {
    let mut out = String::from("time_s");
    for (k, c) in s.contacts.iter().enumerate() {
        let _ = write!(out, ",q_dof{},gap_c{k},force_c{k}", c.dof);
    }
    out.push('\n');
    for (j, t) in s.time_s.iter().enumerate() {
        let _ = write!(out, "{t:.12e}");
        for c in &s.contacts {
            let _ = write!(
                out,
                ",{:.12e},{:.12e},{:.12e}",
                c.displacement[j], c.gap[j], c.force[j]
            );
        }
        out.push('\n');
    }
    out
}

/// Fig. 10: contact displacement over one period, with the displacement at which the gap
/// closes.
pub fn period_figure(model: &Model, solutions: &[PeriodicSolution]) -> Figure {
    let mut fig = Figure {
        title: format!(
            "Contact displacement over one period at {:.4} kHz",
            solutions[0].frequency_hz / 1e3
        ),
        x_label: "time [µs]".into(),
        y_label: "contact displacement q_N".into(),
        ..Figure::default()
    };
    for (k, s) in solutions.iter().enumerate() {
        let c = &s.contacts[0];
        fig.series.push(Series {
            label: format!("H = {}", s.harmonics),
            points: s
                .time_s
                .iter()
                .zip(&c.displacement)
                .map(|(t, q)| (t * 1e6, *q))
                .collect(),
            style: Style::Line,
            color: k,
        });
    }
    if let Some(c) = model.contacts.first() {
        if c.dofs.len() == 1 {
            fig.hlines.push(HLine {
                label: format!("gap (q = {:.4})", -c.gap / c.w[0]),
                y: -c.gap / c.w[0],
            });
        }
    }
    fig
}

pub fn run(args: &SolveArgs) -> Result<()> {
    if !(args.frequency.is_finite() && args.frequency > 0.0) {
        bail!(
            "--frequency must be a positive number of Hz, got {}",
            args.frequency
        );
    }
    if args.harmonics == 0 {
        bail!("--harmonics must be at least 1");
    }
    if let Some(ns) = args.method.samples {
        if ns < 2 * args.harmonics + 1 {
            bail!(
                "--samples {ns} is too few for {} harmonics: need at least 2H+1 = {}",
                args.harmonics,
                2 * args.harmonics + 1
            );
        }
    }
    let model = args.model.load()?;
    let dof = args.method.response_dof(&model)?;
    let newton = args.method.newton()?;
    let mut problem = args.method.problem(&model, args.harmonics)?;
    let omega = 2.0 * std::f64::consts::PI * args.frequency;
    let (solution, outcome) = solve_at_frequency(problem.as_mut(), omega, dof, &newton)?;
    if let Some(path) = &args.output {
        write_atomic(path, time_series_csv(&solution).as_bytes())?;
    }
    if let Some(path) = &args.plot {
        period_figure(&model, std::slice::from_ref(&solution)).save(path)?;
    }
    if args.json {
        println!("{}", serde_json::to_string(&solution)?);
    } else {
        println!(
            "{} at {} Hz, H = {}, {} samples, {} quadrature",
            model.name, args.frequency, solution.harmonics, solution.samples, solution.quadrature
        );
        println!(
            "converged: {} after {} Newton iterations (relative residual {:.2e})",
            solution.converged, solution.iterations, solution.residual_norm
        );
        for c in &solution.contacts {
            println!(
                "contact DOF {}: max {:.6e}, min {:.6e}, max force {:.6e}",
                c.dof,
                c.max,
                c.min,
                c.force.iter().fold(0.0f64, |m, v| m.max(*v))
            );
        }
        let r = &solution.response;
        println!(
            "DOF {}: max {:.6e}, min {:.6e}, first-harmonic amplitude {:.6e}",
            r.dof,
            r.max,
            r.min,
            r.amplitude_h1()
        );
    }
    if !outcome.converged {
        bail!(
            "Newton did not converge at {} Hz: {}",
            args.frequency,
            outcome.reason.unwrap_or_else(|| "unknown reason".into())
        );
    }
    Ok(())
}
