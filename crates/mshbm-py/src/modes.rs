//! `modes`: eigenfrequencies of the consistent and the redistributed model, as
//! `mshbm modes` (library: `Model::compare_masses_within`).

use pyo3::prelude::*;

use crate::convert::to_python;
use crate::errors::to_py;
use crate::model::NativeModel;
use crate::threads::interruptible;

/// The first `count` eigenfrequencies [Hz] of both masses and their relative difference:
/// a dict with `original_hz`, `redistributed_hz`, `relative_error`, `norm`.
#[pyfunction]
#[pyo3(signature = (model, count=30, *, threads=None))]
pub fn modes(
    py: Python<'_>,
    model: &NativeModel,
    count: usize,
    threads: Option<usize>,
) -> PyResult<Py<PyAny>> {
    let m = &model.model;
    let report = interruptible(py, threads, |cancel| {
        let limits = mshbm::limits::Limits {
            cancel,
            ..model.limits
        };
        m.compare_masses_within(count, &limits)
    })?
    .map_err(|e| {
        // the CLI's context: "MODEL: eigenfrequencies: …"
        let err = to_py(e);
        let message = format!(
            "{}: eigenfrequencies: {}",
            m.source.display(),
            err.value(py)
        );
        PyErr::from_type(err.get_type(py), message)
    })?;
    to_python(py, &report)
}
