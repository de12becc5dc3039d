//! `simulate`: reference time integration, as `mshbm simulate` (library: `integrate`,
//! `integrate::steady_state`, `simulation`), with its time grid and defaults.

use mshbm::integrate::steady_state::simulate_to_steady_state;
use mshbm::integrate::{fall_energy, Integrator, Settings};
use mshbm::model::LoadOptions;
use mshbm::request::simulate::not_periodic;
use mshbm::request::{choose, SimulateRequest, StartSolution};
use mshbm::simulation::{reference_period, state_from_solution};
use mshbm::solution::PeriodicSolution;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{array, to_python};
use crate::errors::{argument, IntoPy, MshbmError, PythonSpelling, Spelled};
use crate::methods::chosen;
use crate::model::{NativeModel, Source};
use crate::threads::interruptible;

/// What a run records at every step.
#[derive(Default)]
struct Record {
    time: Vec<f64>,
    gaps: Vec<f64>,
    forces: Vec<f64>,
    energy: Vec<f64>,
}

impl Record {
    fn push(&mut self, it: &Integrator) {
        self.time.push(it.time());
        self.gaps.extend_from_slice(it.gaps());
        self.forces.extend_from_slice(it.forces());
        self.energy.push(it.energy());
    }
}

/// A time integration (module docs). Returns a dict: `time_s`, `gaps` and `forces` (one
/// row per recorded step, one column per contact), `energy`, `dt`, `scheme`, and with
/// `steady_state` the fields of `mshbm simulate --steady-state --json` under
/// `steady_state`, and `not_periodic` (the CLI's message, or None). `None` keywords take
/// the library's defaults (`SimulateRequest`).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (model, frequency=None, *, periods=None, duration=None,
    steps_per_period=None, dt=None, scheme=None, restitution=None, theta=None,
    steady_state=false, periodicity=None, tolerance=None, harmonics=None, dof=None,
    start_solution=None, record=true, threads=None))]
pub fn simulate(
    py: Python<'_>,
    model: &NativeModel,
    frequency: Option<f64>,
    periods: Option<f64>,
    duration: Option<f64>,
    steps_per_period: Option<usize>,
    dt: Option<f64>,
    scheme: Option<&str>,
    restitution: Option<f64>,
    theta: Option<f64>,
    steady_state: bool,
    periodicity: Option<&str>,
    tolerance: Option<f64>,
    harmonics: Option<usize>,
    dof: Option<usize>,
    start_solution: Option<String>,
    record: bool,
    threads: Option<usize>,
) -> PyResult<Py<PyAny>> {
    let defaults = SimulateRequest::default();
    let mut request = SimulateRequest {
        frequency,
        periods,
        duration,
        steps_per_period,
        dt,
        scheme: scheme.map(|s| choose("scheme", s)).transpose().spelled()?,
        restitution,
        theta,
        steady_state,
        periodicity: chosen("periodicity", periodicity, defaults.periodicity)?,
        tolerance,
        harmonics: harmonics.unwrap_or(defaults.harmonics),
        dof,
        start_solution: None,
    };
    request.validate().spelled()?;

    // --- model, scheme, system ---
    let m = &model.model;
    let dropped = match &model.source {
        Source::Toml {
            path, overrides, ..
        } if path.exists() => mshbm::model::file::load_dropped_bar_with(
            path,
            overrides,
            &LoadOptions {
                limits: model.limits,
                allow_outside_paths: model.allow_outside_paths,
            },
        )
        .py_err()?,
        _ => None,
    };
    if let Some(json) = start_solution {
        let solution: PeriodicSolution = serde_json::from_str(&json)
            .map_err(|e| argument(format!("start_solution: not a periodic solution: {e}")))?;
        request.start_solution = Some(StartSolution {
            source: "the start solution".into(),
            solution,
        });
    }
    let plan = request.plan(m).spelled()?;
    let scheme = plan.scheme;

    let run = |cancel| -> PyResult<(
        Record,
        f64,
        Option<mshbm::integrate::steady_state::SteadyState>,
    )> {
        let system = m.system_cancellable(scheme.mass_kind(), cancel).py_err()?;
        // --- time grid ---
        let period = reference_period(&system, plan.frequency, dropped.as_ref());
        let grid = request.grid(&plan, period).spelled()?;
        let steady_options = request
            .steady_state_options(&plan, &grid, &system, &model.limits)
            .py_err()?;
        let mut integrator = Integrator::new(
            &system,
            &Settings {
                dt: grid.dt,
                scheme,
                omega: grid.load_omega,
                energy_offset: fall_energy(m, &system),
            },
        )
        .py_err()?;
        integrator.cancel_on(cancel);
        if let (Some(start), Some(w)) = (&request.start_solution, plan.omega()) {
            let (q, v) = state_from_solution(
                &system,
                m,
                &start.solution,
                w,
                std::path::Path::new("the start solution"),
            )
            .py_err()?;
            integrator.set_state(0.0, &q, &v).py_err()?;
        }
        let mut rec = Record::default();
        let mut on_step = |it: &Integrator| {
            if record {
                rec.push(it)
            }
        };
        on_step(&integrator);
        let steady = match steady_options {
            Some(options) => Some(
                simulate_to_steady_state(
                    &mut integrator,
                    plan.omega().expect("a steady state has a frequency"),
                    &options,
                    on_step,
                    |_, _| {},
                )
                .py_err()?,
            ),
            None => {
                integrator.run(grid.steps as usize, on_step).py_err()?;
                None
            }
        };
        Ok((rec, grid.dt, steady))
    };
    let (rec, dt, steady) = interruptible(py, threads, run)??;

    let d = PyDict::new(py);
    let nc = m.contacts.len();
    let rows = rec.time.len();
    let table = |v: Vec<f64>| -> PyResult<Py<PyAny>> {
        Ok(PyArray1::from_vec(py, v)
            .reshape([rows, nc])
            .map_err(|e| MshbmError::new_err(e.to_string()))?
            .into_any()
            .unbind())
    };
    d.set_item("gaps", table(rec.gaps)?)?;
    d.set_item("forces", table(rec.forces)?)?;
    d.set_item("time_s", array(py, rec.time))?;
    d.set_item("energy", array(py, rec.energy))?;
    d.set_item("dt", dt)?;
    d.set_item("scheme", scheme.description())?;
    let not_periodic = steady
        .as_ref()
        .and_then(not_periodic)
        .map(|e| e.render(&PythonSpelling));
    d.set_item("not_periodic", not_periodic)?;
    d.set_item(
        "steady_state",
        match &steady {
            Some(s) => to_python(py, s)?,
            None => py.None(),
        },
    )?;
    Ok(d.into_any().unbind())
}
