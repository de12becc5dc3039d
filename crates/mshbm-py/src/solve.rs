//! `solve`: one periodic solution, as `mshbm solve` (library: `solve::solve_periodic`);
//! the keywords are translated into the library's `SolveRequest`, which holds every
//! default and check.

use mshbm::request::{SolveRequest, StartSolution};
use mshbm::simulation::field_harmonics;
use mshbm::solution::PeriodicSolution;
use mshbm::solve::{solve_periodic, SolvePath};
use numpy::PyArray2;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::to_python;
use crate::errors::{argument, IntoPy, Spelled};
use crate::methods::{chosen, MethodKeywords};
use crate::model::NativeModel;
use crate::threads::interruptible;

/// One periodic solution (module docs). Returns a dict: `solution` (the fields of
/// `mshbm solve --json`), `label`, `path`, `others`, `stability_error`, and
/// `not_converged` (the CLI's message, or None). `None` keywords take the library's
/// defaults. A start solution (the JSON of `Solution.to_json()`, as `--from-solution`
/// reads it) is refused, as by the CLI, when it belongs to another method or model.
/// `field=True` adds `field_harmonics`: the Fourier coefficients `[a0, a1, b1, …]` of every
/// model DOF (rows; Dirichlet DOFs zero), the field `mshbm solve --vtk` writes.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (model, frequency, harmonics=None, *, method=None, samples=None,
    quadrature=None, mass=None, penalty=Vec::new(), tangential_penalty=None, tolerance=None,
    max_iterations=None, dof=None, stability_modes=None, receptance=None,
    receptance_modes=None, jacobian=None, stability=None, start=None,
    start_solution=None, sweep_from=None, sweep_to=None, field=false, threads=None))]
pub fn solve(
    py: Python<'_>,
    model: &NativeModel,
    frequency: f64,
    harmonics: Option<usize>,
    method: Option<&str>,
    samples: Option<usize>,
    quadrature: Option<&str>,
    mass: Option<&str>,
    penalty: Vec<String>,
    tangential_penalty: Option<String>,
    tolerance: Option<f64>,
    max_iterations: Option<usize>,
    dof: Option<usize>,
    stability_modes: Option<usize>,
    receptance: Option<&str>,
    receptance_modes: Option<usize>,
    jacobian: Option<&str>,
    stability: Option<bool>,
    start: Option<&str>,
    start_solution: Option<String>,
    sweep_from: Option<f64>,
    sweep_to: Option<f64>,
    field: bool,
    threads: Option<usize>,
) -> PyResult<Py<PyAny>> {
    let defaults = SolveRequest::new(frequency);
    let mut request = SolveRequest {
        harmonics: harmonics.unwrap_or(defaults.harmonics),
        method: MethodKeywords {
            method,
            samples,
            quadrature,
            mass,
            penalty,
            tangential_penalty,
            tolerance,
            max_iterations,
            dof,
            stability_modes,
            receptance,
            receptance_modes,
            jacobian,
        }
        .request()?,
        stability: stability.unwrap_or(defaults.stability),
        start: chosen("start", start, defaults.start)?,
        sweep_from,
        sweep_to,
        ..defaults
    };
    let method = request.method().spelled()?;
    if let Some(json) = start_solution {
        let solution: PeriodicSolution = serde_json::from_str(&json)
            .map_err(|e| argument(format!("start: not a periodic solution: {e}")))?;
        request.start_solution = Some(StartSolution {
            source: "start".into(),
            solution,
        });
    }
    let m = &model.model;
    let mut settings = request.settings(m, model.limits).spelled()?;
    let (solved, field) = interruptible(py, threads, |cancel| -> mshbm::Result<_> {
        settings.limits.cancel = cancel;
        let solved = solve_periodic(m, &method, frequency, &settings)?;
        // every model DOF's harmonics, as `mshbm solve --vtk` evaluates them
        let field = match field {
            true => {
                let system = m.system_cancellable(method.mass_kind(), cancel)?;
                let omega = 2.0 * std::f64::consts::PI * solved.solution.frequency_hz;
                let source = std::path::Path::new("the solution");
                Some(field_harmonics(
                    &system,
                    m,
                    &solved.solution,
                    omega,
                    source,
                )?)
            }
            false => None,
        };
        Ok((solved, field))
    })?
    .py_err()?;
    let d = PyDict::new(py);
    if let Some(field) = field {
        let array = PyArray2::from_vec2(py, &field)
            .map_err(|e| crate::errors::MshbmError::new_err(e.to_string()))?;
        d.set_item("field_harmonics", array)?;
    }
    d.set_item("solution", to_python(py, &solved.solution)?)?;
    d.set_item("label", &solved.label)?;
    d.set_item(
        "stability_error",
        solved.stability_error.as_ref().map(|e| e.to_string()),
    )?;
    let p = PyDict::new(py);
    match solved.path {
        SolvePath::Direct => p.set_item("kind", "direct")?,
        SolvePath::Continuation {
            from_hz,
            points,
            folds,
        } => {
            p.set_item("kind", "continuation")?;
            p.set_item("from_hz", from_hz)?;
            p.set_item("points", points)?;
            p.set_item("folds", folds)?;
        }
    }
    d.set_item("path", p)?;
    d.set_item("others", to_python(py, &solved.others)?)?;
    d.set_item("not_converged", solved.not_converged(frequency))?;
    Ok(d.into_any().unbind())
}
