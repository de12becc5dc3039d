//! The exception hierarchy: `MshbmError` → `ModelError` (the model file or arrays),
//! `ArgumentError` (an argument of the call), `NotConvergedError` (Newton, continuation or
//! a numerical failure). Messages are the library's (or the CLI's, for the argument checks
//! the CLI does), so Python users read the same words as CLI users.

use mshbm::Error;
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    mshbm,
    MshbmError,
    PyException,
    "Base class of every error raised by mshbm."
);
create_exception!(
    mshbm,
    ModelError,
    MshbmError,
    "The model is invalid: a file that cannot be read, a malformed field, inconsistent arrays. The message names the file (or `<arrays>`) and the field."
);
create_exception!(
    mshbm,
    ArgumentError,
    MshbmError,
    "An argument of the call (or a `--set`-style override) is invalid."
);
create_exception!(
    mshbm,
    NotConvergedError,
    MshbmError,
    "Newton, the continuation or a numerical algorithm did not converge. When a partial result exists it is in the `result` attribute."
);

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("MshbmError", py.get_type::<MshbmError>())?;
    m.add("ModelError", py.get_type::<ModelError>())?;
    m.add("ArgumentError", py.get_type::<ArgumentError>())?;
    m.add("NotConvergedError", py.get_type::<NotConvergedError>())?;
    Ok(())
}

/// The Python exception of a library error, with the library's message.
pub fn to_py(e: Error) -> PyErr {
    let message = e.to_string();
    match e {
        Error::Io { .. }
        | Error::Toml { .. }
        | Error::Field { .. }
        | Error::MatrixMarket { .. }
        | Error::Redistribution(_)
        | Error::ResourceLimit { .. } => ModelError::new_err(message),
        Error::Override { .. } | Error::InvalidArgument { .. } => ArgumentError::new_err(message),
        Error::Singular(_) | Error::SingularSystem(_) | Error::Numerical(_) => {
            NotConvergedError::new_err(message)
        }
        // Python never asks the library to cancel (`Limits::cancel` stays `NEVER`)
        Error::Cancelled => pyo3::exceptions::PyKeyboardInterrupt::new_err(message),
    }
}

/// `Result<T, mshbm::Error>` → `PyResult<T>`.
pub trait IntoPy<T> {
    fn py_err(self) -> PyResult<T>;
}

impl<T> IntoPy<T> for mshbm::Result<T> {
    fn py_err(self) -> PyResult<T> {
        self.map_err(to_py)
    }
}

/// The library's spelling of option names for Python: the keyword, `keyword='value'`.
pub struct PythonSpelling;

impl mshbm::error::Spelling for PythonSpelling {
    fn option(&self, name: &str) -> String {
        name.to_string()
    }
    fn option_value(&self, name: &str, value: &str) -> String {
        format!("{name}='{value}'")
    }
}

/// A bad option as an `ArgumentError` in Python's spelling, its `argument` attribute the
/// keyword at fault.
pub fn option_error(e: mshbm::error::OptionError) -> PyErr {
    let err = ArgumentError::new_err(e.render(&PythonSpelling));
    Python::attach(|py| match err.value(py).setattr("argument", e.option) {
        Ok(()) => err,
        Err(failed) => failed,
    })
}

/// `Result<T, OptionError>` → `PyResult<T>` in Python's spelling.
pub trait Spelled<T> {
    fn spelled(self) -> PyResult<T>;
}

impl<T> Spelled<T> for std::result::Result<T, mshbm::error::OptionError> {
    fn spelled(self) -> PyResult<T> {
        self.map_err(option_error)
    }
}

/// An `ArgumentError` with `message`.
pub fn argument(message: impl Into<String>) -> PyErr {
    ArgumentError::new_err(message.into())
}
