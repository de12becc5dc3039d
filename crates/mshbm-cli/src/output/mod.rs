//! The output policy of every command (docs/safety.md, "Outputs"): what may be written
//! where, and how, so that no run destroys a file it was not asked to write.
//!
//! * [`plan`]: every command declares its outputs (and its inputs) before computing; the
//!   plan refuses devices, FIFOs, sockets, directories, missing or read-only directories,
//!   unknown plot extensions, an output that is an input or another output.
//! * [`atomic`]: every file is written to a unique temporary file created exclusively in
//!   the target's directory, synced, renamed over the target, and the directory synced; on
//!   any error the temporary file is removed.
//! * [`stream`]: CSV files written while a run goes on (`frf`, `simulate`), finished with a
//!   comment line saying how the run ended.
//! * [`interrupt`]: SIGINT/SIGTERM set a flag that long runs check.
//! * [`finite`]: no NaN or infinity reaches a CSV or JSON output.
//! * [`stdout`]: writing to stdout reports errors instead of panicking; control characters
//!   are escaped on stdout and stderr, and [`one_line`] escapes input text (a model's
//!   name) wherever it is shown: a line of text, a CSV comment, a plot's title.
//! * [`status`]: the exit statuses (0 done, 1 error, 2 computed but not converged, 130
//!   interrupted).

pub mod atomic;
pub mod finite;
pub mod interrupt;
pub mod plan;
pub mod status;
pub mod stdout;
pub mod stream;

pub use atomic::{write_atomic, write_csv_atomic};
pub use plan::{OutputKind, OutputPlan};

/// Input text (a model's name, a title holding it) as shown on one line of any output:
/// every control character escaped (`\u{1b}`, `\n`), docs/safety.md "Escaped messages".
pub fn one_line(text: &str) -> String {
    mshbm::model::excerpt::escape_controls(text, mshbm::model::excerpt::LineBreaks::Escape)
        .into_owned()
}
