//! `mshbm._native`: the Python extension of mshbm. A thin translation layer: it turns
//! Python arguments into the library's typed settings (with the defaults of the CLI),
//! calls the same library functions as the `mshbm` commands with the GIL released, and
//! turns the results into dicts of numpy arrays. No numerics live here; the pure-Python
//! package `mshbm` (python/mshbm) wraps these functions in classes.

mod convert;
mod errors;
mod frf;
mod methods;
mod model;
mod modes;
mod simulate;
mod solve;
mod threads;

use pyo3::prelude::*;

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    m.add_class::<model::NativeModel>()?;
    m.add_function(wrap_pyfunction!(solve::solve, m)?)?;
    m.add_function(wrap_pyfunction!(frf::frf, m)?)?;
    m.add_function(wrap_pyfunction!(modes::modes, m)?)?;
    m.add_function(wrap_pyfunction!(simulate::simulate, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
