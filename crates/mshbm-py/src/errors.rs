//! The exception hierarchy: `MshbmError` → `ModelError` (the model file or arrays; also a
//! `ValueError`), `ArgumentError` (an argument of the call; also a `ValueError`, its
//! `argument` attribute the keyword at fault when one is), `NotConvergedError` (Newton,
//! continuation or a numerical failure; also a `RuntimeError`). Messages are the library's
//! (its request layer words the option errors for both front ends, `mshbm::request`), so
//! Python users read the same words as CLI users, options spelled as Python keywords.

use mshbm::Error;
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyTuple, PyType};

create_exception!(
    mshbm,
    MshbmError,
    PyException,
    "Base class of every error raised by mshbm."
);

static MODEL_ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();
static ARGUMENT_ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();
static NOT_CONVERGED_ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();

/// `class NAME(MshbmError, BUILTIN)` with `doc`, in the module `mshbm`.
fn subclass(
    py: Python<'_>,
    name: &str,
    builtin: Bound<'_, PyType>,
    doc: &str,
) -> PyResult<Py<PyType>> {
    let namespace = PyDict::new(py);
    namespace.set_item("__doc__", doc)?;
    namespace.set_item("__module__", "mshbm")?;
    let bases = PyTuple::new(py, [py.get_type::<MshbmError>(), builtin])?;
    let class = py.get_type::<PyType>().call1((name, bases, namespace))?;
    Ok(class.cast_into::<PyType>()?.unbind())
}

/// The classes, made once per interpreter.
fn classes(py: Python<'_>) -> PyResult<[&Py<PyType>; 3]> {
    Ok([
        MODEL_ERROR.get_or_try_init(py, || subclass(py, "ModelError", py.get_type::<PyValueError>(),
            "The model is invalid: a file that cannot be read, a malformed field, inconsistent arrays. The message names the file (or `<arrays>`) and the field."))?,
        ARGUMENT_ERROR.get_or_try_init(py, || {
            let class = subclass(py, "ArgumentError", py.get_type::<PyValueError>(),
                "An argument of the call (or a `--set`-style override) is invalid; `argument` names the keyword at fault (None when the message names it otherwise).")?;
            class.bind(py).setattr("argument", py.None())?;
            Ok::<_, PyErr>(class)
        })?,
        NOT_CONVERGED_ERROR.get_or_try_init(py, || subclass(py, "NotConvergedError", py.get_type::<PyRuntimeError>(),
            "Newton, the continuation or a numerical algorithm did not converge. When a partial result exists it is in the `result` attribute."))?,
    ])
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("MshbmError", py.get_type::<MshbmError>())?;
    let [model, argument, not_converged] = classes(py)?;
    m.add("ModelError", model.bind(py))?;
    m.add("ArgumentError", argument.bind(py))?;
    m.add("NotConvergedError", not_converged.bind(py))?;
    Ok(())
}

/// An exception of the class `which` (0 model, 1 argument, 2 not converged) with
/// `message`.
fn raise(which: usize, message: String) -> PyErr {
    Python::attach(|py| match classes(py) {
        Ok(classes) => PyErr::from_type(classes[which].bind(py).clone(), message),
        Err(e) => e,
    })
}

/// A `ModelError` with `message`.
pub fn model_error(message: impl Into<String>) -> PyErr {
    raise(0, message.into())
}

/// A `NotConvergedError` with `message`.
pub fn not_converged(message: impl Into<String>) -> PyErr {
    raise(2, message.into())
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
        | Error::ResourceLimit { .. } => model_error(message),
        Error::Override { .. } | Error::InvalidArgument { .. } => argument(message),
        Error::Singular(_) | Error::SingularSystem(_) | Error::Numerical(_) => {
            not_converged(message)
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
    let err = argument(e.render(&PythonSpelling));
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
    raise(1, message.into())
}
