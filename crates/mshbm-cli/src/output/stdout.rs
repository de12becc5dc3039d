//! Standard output and error without panics: `println!` panics when stdout cannot be
//! written (`mshbm modes > /dev/full`); these report the error instead. A reader that goes
//! away (`mshbm … | head`) still ends the process quietly through the default SIGPIPE
//! disposition set in `main`.
//!
//! Both escape every control character but `\n` and `\t` (`\u{1b}`, docs/safety.md
//! "Escaped messages"): whatever a message quotes of an input (a model's name, a path, a
//! parser's message), no terminal escape sequence reaches the terminal.

use std::fmt::Arguments;
use std::io::Write;

use anyhow::{Context, Result};
use mshbm::model::excerpt::{escape_controls, LineBreaks};

/// The text of `args` with control characters escaped (lines and tabs kept).
fn shown(args: Arguments<'_>) -> String {
    let text = args.to_string();
    match escape_controls(&text, LineBreaks::Keep) {
        std::borrow::Cow::Borrowed(_) => text,
        std::borrow::Cow::Owned(escaped) => escaped,
    }
}

/// Write one line to stdout and flush it; an error says that stdout could not be written.
pub fn line(args: Arguments<'_>) -> Result<()> {
    let text = shown(args);
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())
        .and_then(|_| out.write_all(b"\n"))
        .and_then(|_| out.flush())
        .context("cannot write to standard output")
}

/// Write one line to stderr; errors are ignored (there is nowhere left to report them).
pub fn note(args: Arguments<'_>) {
    let _ = writeln!(std::io::stderr().lock(), "{}", shown(args));
}

/// `outln!(...)`: like `println!`, but returns an error (use with `?`) instead of panicking.
#[macro_export]
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::output::stdout::line(format_args!($($arg)*))
    };
}

/// `note!(...)`: like `eprintln!`, but never panics.
#[macro_export]
macro_rules! note {
    ($($arg:tt)*) => {
        $crate::output::stdout::note(format_args!($($arg)*))
    };
}
