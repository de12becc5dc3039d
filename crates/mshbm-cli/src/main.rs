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
    #[cfg(unix)]
    out_of_memory_net();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return usage_error(&e),
    };
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
        if output::status::is_cancelled(e) {
            crate::note!(
                "error: interrupted by {}: nothing more was written",
                output::interrupt::requested().unwrap_or("a signal")
            );
        } else {
            crate::note!("error: {e:#}");
        }
    }
    ExitCode::from(output::status::exit_status(&result))
}

/// The last resort when an allocation fails anyway (the memory plans and the budget,
/// docs/safety.md, are meant to refuse first): Rust's allocator prints `memory allocation
/// of N bytes failed` and aborts; the abort is turned into an error line, the temporary
/// files are removed and the process exits with status 1 instead of dying by SIGABRT.
#[cfg(unix)]
fn out_of_memory_net() {
    extern "C" fn on_abort(_: libc::c_int) {
        const MESSAGE: &[u8] = b"error: out of memory or an internal failure (the line above says which); stopped, temporary files removed. If an allocation failed, lower the model or the options, or give --max-memory GIB below the memory this process may use\n";
        // SAFETY: write(2) and _exit(2) are async-signal-safe; the temporary files are
        // removed best effort (the failed allocation holds no lock of the allocator)
        unsafe {
            libc::write(2, MESSAGE.as_ptr().cast(), MESSAGE.len());
        }
        output::interrupt::remove_temporaries();
        unsafe { libc::_exit(i32::from(output::status::ERROR)) }
    }
    // SAFETY: installing a handler at start-up; SA_RESETHAND: an abort inside the handler
    // ends the process as before
    unsafe {
        let mut action: libc::sigaction = std::mem::zeroed();
        action.sa_sigaction = on_abort as extern "C" fn(libc::c_int) as usize;
        action.sa_flags = libc::SA_RESETHAND;
        libc::sigemptyset(&mut action.sa_mask);
        libc::sigaction(libc::SIGABRT, &action, std::ptr::null_mut());
    }
}

/// A command line clap refused, or `--help`/`--version`. Help and version are printed as
/// clap prints them (exit status 0; the help shown for a missing subcommand exits with 1).
/// A usage error is bad input: exit status 1 like every other (status 2 means "written but
/// not converged", docs/safety.md), and clap's message without its usage block, on one
/// line, with the hint to `--help` on a second.
fn usage_error(e: &clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    match e.kind() {
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
            let _ = e.print();
            ExitCode::from(output::status::SUCCESS)
        }
        ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            let _ = e.print();
            ExitCode::from(output::status::ERROR)
        }
        _ => {
            for line in usage_error_lines(&e.render().to_string()) {
                crate::note!("{line}");
            }
            ExitCode::from(output::status::ERROR)
        }
    }
}

/// The lines of clap's rendered error worth showing: blank lines and the `Usage:` block
/// dropped, indented lines (a list of missing arguments, possible values, a tip) joined to
/// the line they belong to.
fn usage_error_lines(rendered: &str) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    let mut in_usage = false;
    for line in rendered.lines() {
        let indented = line.starts_with(char::is_whitespace);
        if line.trim().is_empty() {
            in_usage = false;
        } else if line.starts_with("Usage:") {
            in_usage = true;
        } else if in_usage && indented {
            // the usage's continuation lines
        } else if let (true, Some(last)) = (indented, lines.last_mut()) {
            let line = line.trim();
            last.push_str(if line.starts_with("tip:") { "; " } else { " " });
            last.push_str(line);
        } else {
            in_usage = false;
            lines.push(line.trim_end().to_string());
        }
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::usage_error_lines;

    #[test]
    fn usage_errors_keep_the_message_and_the_hint() {
        let rendered = "error: the following required arguments were not provided:\n  --frequency <HZ>\n\nUsage: mshbm solve --frequency <HZ> <MODEL>\n\nFor more information, try '--help'.\n";
        assert_eq!(
            usage_error_lines(rendered),
            [
                "error: the following required arguments were not provided: --frequency <HZ>",
                "For more information, try '--help'."
            ]
        );
        let rendered = "error: unexpected argument '--thread' found\n\n  tip: a similar argument exists: '--threads'\n\nUsage: mshbm frf [OPTIONS] --from <HZ> --to <HZ> <MODEL>\n\nFor more information, try '--help'.\n";
        assert_eq!(
            usage_error_lines(rendered),
            [
                "error: unexpected argument '--thread' found; tip: a similar argument exists: '--threads'",
                "For more information, try '--help'."
            ]
        );
        let rendered = "error: invalid value 'jpg' for '--format <FORMAT>'\n  [possible values: png, svg]\n\nFor more information, try '--help'.\n";
        assert_eq!(
            usage_error_lines(rendered),
            [
                "error: invalid value 'jpg' for '--format <FORMAT>' [possible values: png, svg]",
                "For more information, try '--help'."
            ]
        );
    }
}
