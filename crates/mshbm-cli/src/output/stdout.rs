//! Standard output and error without panics: `println!` panics when stdout cannot be
//! written (`mshbm modes > /dev/full`); these report the error instead. A reader that goes
//! away (`mshbm … | head`) still ends the process quietly through the default SIGPIPE
//! disposition set in `main`.

use std::fmt::Arguments;
use std::io::Write;

use anyhow::{Context, Result};

/// Write one line to stdout and flush it; an error says that stdout could not be written.
pub fn line(args: Arguments<'_>) -> Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_fmt(args)
        .and_then(|_| out.write_all(b"\n"))
        .and_then(|_| out.flush())
        .context("cannot write to standard output")
}

/// Write one line to stderr; errors are ignored (there is nowhere left to report them).
pub fn note(args: Arguments<'_>) {
    let _ = writeln!(std::io::stderr().lock(), "{args}");
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
