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
