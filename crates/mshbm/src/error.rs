//! Typed errors of the library. Every error that comes from user data names where the bad
//! value came from (file and field, or file and line), so the CLI can print one clear line.

use std::path::{Path, PathBuf};

/// Result alias used throughout the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong in the library.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("{}: {message}", file.display())]
    Io { file: PathBuf, message: String },

    /// A model file is not valid TOML.
    #[error("{}: malformed TOML: {message}", file.display())]
    Toml { file: PathBuf, message: String },

    /// A field of a model file (or of a programmatic model) has a bad value.
    #[error("{}: field `{field}`: {message}", file.display())]
    Field {
        file: PathBuf,
        field: String,
        message: String,
    },

    /// A Matrix Market file is malformed.
    #[error("{}, line {line}: {message}", file.display())]
    MatrixMarket {
        file: PathBuf,
        line: usize,
        message: String,
    },

    /// A `--set key=value` override could not be applied.
    #[error("override `{assignment}`: {message}")]
    Override { assignment: String, message: String },

    /// A parameter passed by the caller (not from a model file) is invalid.
    #[error("invalid {name}: {message}")]
    InvalidArgument { name: String, message: String },

    /// Mass redistribution failed (degenerate moment system, or the result is not
    /// positive definite on the DOFs that keep mass).
    #[error("mass redistribution: {0}")]
    Redistribution(String),

    /// A matrix that must be positive definite (or invertible) is not.
    #[error("{0}")]
    Singular(String),

    /// A computation or an input would need more memory than the limit allows
    /// ([`crate::limits::Limits`]); nothing was allocated.
    #[error("{what} would need {needed}, more than the memory limit of {limit} (raise it with --max-memory GIB, or `Limits::memory_bytes` in the library)")]
    ResourceLimit {
        what: String,
        needed: String,
        limit: String,
    },

    /// A numerical algorithm failed for a reason that is not the user's input.
    #[error("numerical failure: {0}")]
    Numerical(String),

    /// The linear system of a Newton step (or of the continuation's bordered system) is
    /// singular at the current point.
    #[error("{0}")]
    SingularSystem(SingularSystem),

    /// The caller asked the computation to stop ([`crate::limits::Cancel`]).
    #[error("cancelled")]
    Cancelled,
}

/// Which linear system of Newton's method or of the continuation is singular.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SingularSystem {
    /// The Jacobian `∂R/∂x` of a Newton step at a fixed frequency.
    Jacobian,
    /// The bordered matrix `[R_X; cᵀ]` of the continuation (tangent or corrector,
    /// docs/theory.md (T73)–(T74)).
    BorderedMatrix,
}

impl std::fmt::Display for SingularSystem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            SingularSystem::Jacobian => "the Jacobian is singular",
            SingularSystem::BorderedMatrix => "the bordered continuation matrix is singular",
        })
    }
}

/// What an error says about the point where it happened, for iterations that visit points
/// (Newton, continuation) and may try another point instead of giving up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorKind {
    /// A matrix is singular (or not positive definite) at this point: another point may
    /// do ([`Error::Singular`], [`Error::SingularSystem`]).
    Singular,
    /// A numerical algorithm (an LCP, an eigenvalue solver, ...) failed at this point
    /// ([`Error::Numerical`]).
    Numerical,
    /// The input is wrong (a file, a field, an argument, the model's mass): no other point
    /// helps.
    Input,
}

impl Error {
    /// What the error says about the point where it happened ([`ErrorKind`]).
    pub fn kind(&self) -> ErrorKind {
        match self {
            Error::Singular(_) | Error::SingularSystem(_) => ErrorKind::Singular,
            Error::Numerical(_) => ErrorKind::Numerical,
            Error::Io { .. }
            | Error::Toml { .. }
            | Error::Field { .. }
            | Error::MatrixMarket { .. }
            | Error::Override { .. }
            | Error::InvalidArgument { .. }
            | Error::Redistribution(_)
            | Error::ResourceLimit { .. } => ErrorKind::Input,
            // no other point helps either: the caller wants no more points
            Error::Cancelled => ErrorKind::Input,
        }
    }

    /// A field error for `file`.
    pub fn field(file: &Path, field: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Field {
            file: file.to_path_buf(),
            field: field.into(),
            message: message.into(),
        }
    }

    /// An I/O error for `file`.
    pub fn io(file: &Path, err: impl std::fmt::Display) -> Self {
        Error::Io {
            file: file.to_path_buf(),
            message: err.to_string(),
        }
    }

    /// An invalid caller-supplied argument.
    pub fn argument(name: impl Into<String>, message: impl Into<String>) -> Self {
        Error::InvalidArgument {
            name: name.into(),
            message: message.into(),
        }
    }
}

/// A bad option of a command's request ([`crate::request`]): the option at fault and a
/// message that names options without any front end's syntax, as `⟨name⟩` or
/// `⟨name=value⟩` (snake_case names, e.g. `⟨max_iterations⟩`, `⟨receptance=modal⟩`). Each
/// front end renders it in its own spelling ([`OptionError::render`]): the CLI as
/// `--max-iterations`, `--receptance modal`; Python as `max_iterations`,
/// `receptance='modal'`; `Display` (and the conversion into [`Error`]) as
/// `max_iterations`, `receptance = modal`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OptionError {
    /// The option at fault (snake_case).
    pub option: &'static str,
    template: String,
}

/// How a front end writes an option, and an option with a value, in its messages.
pub trait Spelling {
    /// The option `name` (snake_case) as the front end's user types it.
    fn option(&self, name: &str) -> String;
    /// The option `name` set to `value`.
    fn option_value(&self, name: &str, value: &str) -> String;
}

/// The library's own spelling: `name`, `name = value`.
pub struct PlainSpelling;

impl Spelling for PlainSpelling {
    fn option(&self, name: &str) -> String {
        name.to_string()
    }
    fn option_value(&self, name: &str, value: &str) -> String {
        format!("{name} = {value}")
    }
}

impl OptionError {
    /// An error of `option` with `template` (options named as `⟨name⟩`, `⟨name=value⟩`).
    pub fn new(option: &'static str, template: impl Into<String>) -> Self {
        OptionError {
            option,
            template: template.into(),
        }
    }

    /// The message with options named as `⟨name⟩` / `⟨name=value⟩`.
    pub fn template(&self) -> &str {
        &self.template
    }

    /// The message in a front end's spelling.
    pub fn render(&self, spelling: &dyn Spelling) -> String {
        let mut out = String::with_capacity(self.template.len());
        let mut rest = self.template.as_str();
        while let Some(open) = rest.find('⟨') {
            out.push_str(&rest[..open]);
            let after = &rest[open + '⟨'.len_utf8()..];
            let Some(close) = after.find('⟩') else {
                out.push_str(&rest[open..]);
                return out;
            };
            let inner = &after[..close];
            match inner.split_once('=') {
                Some((name, value)) => out.push_str(&spelling.option_value(name, value)),
                None => out.push_str(&spelling.option(inner)),
            }
            rest = &after[close + '⟩'.len_utf8()..];
        }
        out.push_str(rest);
        out
    }
}

impl std::fmt::Display for OptionError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.render(&PlainSpelling))
    }
}

impl std::error::Error for OptionError {}

impl From<OptionError> for Error {
    fn from(e: OptionError) -> Self {
        Error::InvalidArgument {
            name: e.option.to_string(),
            message: e.to_string(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Dashes;
    impl Spelling for Dashes {
        fn option(&self, name: &str) -> String {
            format!("--{}", name.replace('_', "-"))
        }
        fn option_value(&self, name: &str, value: &str) -> String {
            format!("{} {value}", self.option(name))
        }
    }

    #[test]
    fn an_option_error_is_rendered_in_each_spelling() {
        let e = OptionError::new(
            "receptance_modes",
            "⟨receptance_modes⟩ needs ⟨receptance=modal⟩ (got 3 ⟨x⟩)",
        );
        assert_eq!(
            e.render(&Dashes),
            "--receptance-modes needs --receptance modal (got 3 --x)"
        );
        assert_eq!(
            e.to_string(),
            "receptance_modes needs receptance = modal (got 3 x)"
        );
        // an unclosed bracket is kept as written
        assert_eq!(
            OptionError::new("a", "⟨a⟩ and ⟨b").render(&Dashes),
            "--a and ⟨b"
        );
        let e: Error = e.into();
        assert!(matches!(e, Error::InvalidArgument { ref name, .. } if name == "receptance_modes"));
    }
}
