//! `mshbm`: periodic solutions and frequency response diagrams of mechanical systems with
//! unilateral contact (Mixed Shooting–Harmonic Balance Method). All numerics live in the
//! `mshbm` library; this binary parses arguments, reports progress and writes files.

mod commands;
mod contact_map;
mod output;
mod plot;
mod progress;
mod vtk;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Periodic solutions of mechanical systems with unilateral contact (MS-HBM).
///
/// Units are those of the model file (the paper's bar: mm, t, s, N, MPa); frequencies are
/// always in Hz. DOFs are numbered from 0.
#[derive(Parser, Debug)]
///
/// Exit status: 0 done; 1 error; 2 results written but not converged (Newton), not
/// periodic (simulate --steady-state) or a continuation branch stopped early — every
/// output says so; 130 interrupted by SIGINT/SIGTERM (streamed CSVs are kept with an
/// `# incomplete` line).
#[command(name = "mshbm", version)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Eigenfrequencies [Hz] of the consistent and the redistributed (massless contact
    /// boundary) model and their relative difference (the paper's Fig. 8).
    Modes(commands::modes::ModesArgs),
    /// One periodic solution at one frequency (MS-HBM); time series, harmonics and extremes
    /// of the contacts (the paper's Fig. 10 with --plot).
    Solve(commands::solve::SolveArgs),
    /// Frequency response diagram by pseudo-arclength continuation, with folds located
    /// (the paper's Figs. 9 and 11); one branch per number of harmonics.
    Frf(commands::frf::FrfArgs),
    /// Reference time integration (Moreau–Jean, or position-level Newmark on the
    /// redistributed mass): gap, contact force and energy over time (the paper's Fig. 5),
    /// or the periodic steady state in the form of `mshbm solve` (Fig. 9's reference).
    Simulate(commands::simulate::SimulateArgs),
    /// Write the model as Matrix Market matrices and a `kind = "matrices"` model file.
    Export(commands::export::ExportArgs),
    /// The paper's figures 5, 8, 9, 10, 11 by one command: images, their CSV data and a
    /// summary.md comparing the key numbers with the paper (a few minutes on 2 cores).
    Paper(commands::paper::PaperArgs),
}

fn main() -> ExitCode {
    // behave like other Unix tools when the reader of stdout goes away (`mshbm … | head`):
    // end quietly instead of panicking on a broken pipe
    #[cfg(unix)]
    // SAFETY: restoring the default SIGPIPE disposition at start-up, before any thread exists.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    if let Err(e) = output::interrupt::install() {
        crate::note!("error: cannot install the SIGINT/SIGTERM handlers: {e:#}");
        return ExitCode::from(output::status::ERROR);
    }
    let result = match &cli.command {
        Command::Modes(args) => commands::modes::run(args),
        Command::Solve(args) => commands::solve::run(args),
        Command::Frf(args) => commands::frf::run(args),
        Command::Simulate(args) => commands::simulate::run(args),
        Command::Export(args) => commands::export::run(args),
        Command::Paper(args) => commands::paper::run(args),
    };
    // exit statuses: docs/safety.md and `output::status` (0, 1 error, 2 not converged,
    // 130 interrupted)
    if let Err(e) = &result {
        crate::note!("error: {e:#}");
    }
    ExitCode::from(output::status::exit_status(&result))
}
