//! `solve`: one periodic solution, as `mshbm solve` (library: `solve::solve_periodic`).

use mshbm::solution::{MethodKind, PeriodicSolution};
use mshbm::solve::{solve_periodic, SolvePath, SolveSettings, SolveStart, Solved};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::to_python;
use crate::errors::{argument, IntoPy};
use crate::methods::MethodArgs;
use crate::model::NativeModel;
use crate::threads::with_threads;

/// Where Newton starts, as `--start`, `--from-solution` and `--sweep-from/--sweep-to`.
/// A start solution (the JSON of `Solution.to_json()`, as `--from-solution` reads it) is
/// refused, as by the CLI, when it belongs to another method or model
/// (`PeriodicSolution::unusable_start`).
fn solve_start(
    model: &mshbm::Model,
    method: MethodKind,
    harmonics: usize,
    frequency: f64,
    start: &str,
    start_solution: Option<&str>,
    sweep: (Option<f64>, Option<f64>),
) -> PyResult<SolveStart> {
    if let Some(json) = start_solution {
        if sweep.0.is_some() {
            return Err(argument(
                "give either a start solution or sweep_from, not both",
            ));
        }
        let s: PeriodicSolution = serde_json::from_str(json)
            .map_err(|e| argument(format!("start: not a periodic solution: {e}")))?;
        if let Some(why) = s.unusable_start(model, method) {
            return Err(argument(format!(
                "start: cannot start from this solution: {why}"
            )));
        }
        let Some(x) = s.unknowns else {
            return Err(argument(
                "the start solution has no unknowns (solve it again)",
            ));
        };
        let Some(x) = mshbm::harmonic::with_harmonics(&x, s.harmonics, harmonics) else {
            return Err(argument(format!(
                "the start solution's {} unknowns are not a whole number of {}-harmonic signals",
                x.len(),
                s.harmonics
            )));
        };
        return Ok(SolveStart::Unknowns(x));
    }
    if let Some(from) = sweep.0 {
        if !(from.is_finite() && from > 0.0) {
            return Err(argument(format!(
                "sweep_from must be a positive number of Hz, got {from}"
            )));
        }
        let f = frequency;
        let to = sweep.1.unwrap_or(if from < f { 1.5 * f } else { f / 1.5 });
        if !(to.is_finite() && to > 0.0) {
            return Err(argument(format!(
                "sweep_to must be a positive number of Hz, got {to}"
            )));
        }
        if !((from < f && f <= to) || (to <= f && f < from)) {
            return Err(argument(format!("frequency {f} Hz must lie between sweep_from {from} Hz (excluded) and sweep_to {to} Hz")));
        }
        return Ok(SolveStart::Sweep {
            from_hz: from,
            to_hz: to,
        });
    }
    if sweep.1.is_some() {
        return Err(argument("sweep_to needs sweep_from"));
    }
    match start {
        "auto" => Ok(SolveStart::Auto),
        "linear" => Ok(SolveStart::Linear),
        other => Err(argument(format!(
            "start={other:?}: expected 'auto' or 'linear' (or a Solution to start from)"
        ))),
    }
}

/// One periodic solution (module docs). Returns a dict: `solution` (the fields of
/// `mshbm solve --json`), `label`, `path`, `others`, `stability_error`, and
/// `not_converged` (the CLI's message, or None).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (model, frequency, harmonics=5, *, method="redistributed", samples=None,
    quadrature=None, mass=None, penalty=Vec::new(), tolerance=1e-10, max_iterations=50,
    dof=None, stability_modes=None, receptance="auto", receptance_modes=None, jacobian="auto", stability=true, start="auto", start_solution=None,
    sweep_from=None, sweep_to=None, threads=None))]
pub fn solve(
    py: Python<'_>,
    model: &NativeModel,
    frequency: f64,
    harmonics: usize,
    method: &str,
    samples: Option<usize>,
    quadrature: Option<&str>,
    mass: Option<&str>,
    penalty: Vec<String>,
    tolerance: f64,
    max_iterations: usize,
    dof: Option<usize>,
    stability_modes: Option<usize>,
    receptance: &str,
    receptance_modes: Option<usize>,
    jacobian: &str,
    stability: bool,
    start: &str,
    start_solution: Option<String>,
    sweep_from: Option<f64>,
    sweep_to: Option<f64>,
    threads: Option<usize>,
) -> PyResult<Py<PyAny>> {
    if !(frequency.is_finite() && frequency > 0.0) {
        return Err(argument(format!(
            "frequency must be a positive number of Hz, got {frequency}"
        )));
    }
    if harmonics == 0 {
        return Err(argument("harmonics must be at least 1"));
    }
    let args = MethodArgs::new(
        method,
        samples,
        quadrature,
        mass,
        penalty,
        tolerance,
        max_iterations,
        dof,
        stability_modes,
        receptance,
        receptance_modes,
        jacobian,
    )?;
    args.check_samples(harmonics)?;
    let method = args.single_method(harmonics)?;
    let m = &model.model;
    let settings = SolveSettings {
        newton: args.newton()?,
        stability,
        response_dof: Some(args.response_dof(m)?),
        limits: model.limits,
        observer: None,
        start: solve_start(
            m,
            method.kind(),
            harmonics,
            frequency,
            start,
            start_solution.as_deref(),
            (sweep_from, sweep_to),
        )?,
        branch_observer: None,
        setup_observer: None,
    };
    let Solved {
        solution,
        label,
        outcome,
        stability_error,
        path,
        others,
    } = py
        .detach(|| with_threads(threads, || solve_periodic(m, &method, frequency, &settings)))?
        .py_err()?;
    let d = PyDict::new(py);
    d.set_item("solution", to_python(py, &solution)?)?;
    d.set_item("label", label)?;
    d.set_item("stability_error", stability_error.map(|e| e.to_string()))?;
    let p = PyDict::new(py);
    match path {
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
    d.set_item("others", to_python(py, &others)?)?;
    let not_converged = (!outcome.converged).then(|| {
        format!(
            "Newton did not converge at {frequency} Hz: {}",
            outcome
                .reason
                .as_ref()
                .map_or_else(|| "unknown reason".into(), |r| r.to_string())
        )
    });
    d.set_item("not_converged", not_converged)?;
    Ok(d.into_any().unbind())
}
