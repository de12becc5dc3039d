//! `simulate`: reference time integration, as `mshbm simulate` (library: `integrate`,
//! `integrate::steady_state`, `simulation`), with its time grid and defaults.

use mshbm::integrate::steady_state::{simulate_to_steady_state, Periodicity, SteadyStateOptions};
use mshbm::integrate::{fall_energy, Integrator, Scheme, Settings};
use mshbm::model::LoadOptions;
use mshbm::simulation::{reference_period, state_from_solution};
use mshbm::solution::PeriodicSolution;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{array, to_python};
use crate::errors::{argument, IntoPy, MshbmError};
use crate::model::{NativeModel, Source};
use crate::threads::with_threads;

fn positive(name: &str, v: f64) -> PyResult<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(argument(format!(
            "{name} must be a positive number, got {v}"
        )))
    }
}

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
/// `steady_state`, and `not_periodic` (the CLI's message, or None).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (model, frequency=None, *, periods=None, duration=None,
    steps_per_period=None, dt=None, scheme=None, restitution=None, theta=None,
    steady_state=false, periodicity="response", tolerance=None, harmonics=10, dof=None,
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
    periodicity: &str,
    tolerance: Option<f64>,
    harmonics: usize,
    dof: Option<usize>,
    start_solution: Option<String>,
    record: bool,
    threads: Option<usize>,
) -> PyResult<Py<PyAny>> {
    // --- arguments that need no model (the checks of `mshbm simulate`) ---
    if let Some(f) = frequency {
        positive("frequency [Hz]", f)?;
    }
    if let Some(p) = periods {
        positive("periods", p)?;
    }
    if let Some(d) = duration {
        positive("duration [s]", d)?;
    }
    if let Some(dt) = dt {
        positive("dt [s]", dt)?;
    }
    if periods.is_some() && duration.is_some() {
        return Err(argument("give periods or duration, not both"));
    }
    if steps_per_period.is_some() && dt.is_some() {
        return Err(argument("give steps_per_period or dt, not both"));
    }
    if steps_per_period == Some(0) {
        return Err(argument("steps_per_period must be at least 1"));
    }
    if let Some(e) = restitution {
        if !(e.is_finite() && (0.0..=1.0).contains(&e)) {
            return Err(argument(format!("restitution must lie in [0, 1], got {e}")));
        }
    }
    if let Some(t) = theta {
        if !(t.is_finite() && (0.5..=1.0).contains(&t)) {
            return Err(argument(format!(
                "theta must lie in [0.5, 1] (theta < 0.5 is unstable), got {t}"
            )));
        }
    }
    let periodicity = match periodicity {
        "response" => Periodicity::Response,
        "state" => Periodicity::State,
        other => {
            return Err(argument(format!(
                "periodicity={other:?}: expected 'response' or 'state'"
            )))
        }
    };
    let tolerance = match tolerance {
        Some(t) => positive("tolerance", t)?,
        None => periodicity.default_tolerance(),
    };
    if harmonics == 0 {
        return Err(argument("harmonics must be at least 1"));
    }
    if steady_state {
        if duration.is_some() {
            return Err(argument(
                "steady_state runs whole periods: give periods (the period limit), not duration",
            ));
        }
        if dt.is_some() {
            return Err(argument("steady_state needs a whole number of steps per period: give steps_per_period, not dt"));
        }
        if let Some(p) = periods {
            if p.fract() != 0.0 {
                return Err(argument(format!(
                    "periods must be a whole number with steady_state, got {p}"
                )));
            }
            if periodicity == Periodicity::Response && p < 2.0 {
                return Err(argument(format!("periods must be at least 2 with steady_state and periodicity='response' (it compares whole periods), got {p}")));
            }
        }
    }

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
    let forced = m.harmonic_load.iter().any(|&f| f != 0.0);
    let start: Option<PeriodicSolution> = match &start_solution {
        Some(json) => Some(
            serde_json::from_str(json)
                .map_err(|e| argument(format!("start_solution: not a periodic solution: {e}")))?,
        ),
        None => None,
    };
    let frequency = match (&start, frequency) {
        (Some(s), Some(f)) => {
            if ((f - s.frequency_hz) / f).abs() > 1e-9 {
                return Err(argument(format!(
                    "frequency {f} Hz differs from the frequency of the start solution ({} Hz)",
                    s.frequency_hz
                )));
            }
            Some(f)
        }
        (Some(s), None) => Some(positive(
            "frequency of the start solution [Hz]",
            s.frequency_hz,
        )?),
        (None, f) => f,
    };
    if forced && frequency.is_none() {
        return Err(argument(
            "the model has a harmonic load: give its frequency [Hz]",
        ));
    }
    if steady_state && frequency.is_none() {
        return Err(argument(
            "steady_state needs frequency [Hz]: the period of the steady state (also without load)",
        ));
    }
    let scheme_name = scheme.unwrap_or(if m.contacts.is_empty() {
        "moreau"
    } else {
        "redistributed"
    });
    let scheme = match scheme_name {
        "moreau" => Scheme::moreau_jean(theta, restitution),
        "redistributed" => {
            if restitution.is_some() || theta.is_some() {
                return Err(argument("restitution and theta belong to scheme='moreau'; the redistributed scheme has no impact law"));
            }
            Scheme::PositionNewmark
        }
        other => {
            return Err(argument(format!(
                "scheme={other:?}: expected 'moreau' or 'redistributed'"
            )))
        }
    };
    let response_dof = match dof {
        Some(d) if d >= m.n_dofs() => {
            return Err(argument(format!(
                "dof {d} out of range: the model has DOFs 0..{}",
                m.n_dofs() - 1
            )))
        }
        Some(d) => Some(d),
        None => m.contacts.first().map(|c| c.dofs[0]),
    };
    if steady_state && response_dof.is_none() {
        return Err(argument("the model has no contact: give dof"));
    }

    let run = || -> PyResult<(Record, f64, Option<mshbm::integrate::steady_state::SteadyState>)> {
        let system = m.system(scheme.mass_kind()).py_err()?;
        // --- time grid ---
        let period = reference_period(&system, frequency, dropped.as_ref());
        let default_steps_per_period = if forced || steady_state { 2000 } else { 8000 };
        let dt = match (dt, period) {
            (Some(dt), _) => dt,
            (None, Some(t)) => t / steps_per_period.unwrap_or(default_steps_per_period) as f64,
            (None, None) => {
                return Err(argument("no reference period for this model (free structure): give dt [s] and duration [s]"))
            }
        };
        let steps = match (duration, periods, period) {
            (Some(d), _, _) => (d / dt).round(),
            (None, Some(p), Some(t)) => (p * t / dt).round(),
            (None, None, Some(t)) => ((if forced { 20.0 } else { 2.0 }) * t / dt).round(),
            (None, _, None) => {
                return Err(argument("no reference period for this model: give duration [s]"))
            }
        };
        if !(1.0..1e12).contains(&steps) {
            return Err(argument(format!("the run would have {steps} steps of dt = {dt:e} s")));
        }
        let omega = frequency.map(|f| 2.0 * std::f64::consts::PI * f);
        let mut integrator = Integrator::new(
            &system,
            &Settings {
                dt,
                scheme,
                omega: if forced || steady_state { omega } else { None },
                energy_offset: fall_energy(m, &system),
            },
        )
        .py_err()?;
        if let Some(solution) = &start {
            let w = omega.expect("frequency of the solution");
            let (q, v) = state_from_solution(
                &system,
                m,
                solution,
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
        let steady = if steady_state {
            let options = SteadyStateOptions {
                steps_per_period: steps_per_period.unwrap_or(default_steps_per_period),
                max_periods: periods.map_or(1000, |p| p as usize),
                tolerance,
                harmonics,
                response_dof: response_dof.expect("checked"),
                periodicity,
            };
            Some(
                simulate_to_steady_state(
                    &mut integrator,
                    omega.expect("checked"),
                    &options,
                    on_step,
                    |_, _| {},
                )
                .py_err()?,
            )
        } else {
            integrator.run(steps as usize, on_step).py_err()?;
            None
        };
        Ok((rec, dt, steady))
    };
    let (rec, dt, steady) = py.detach(|| with_threads(threads, run))??;

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
    let not_periodic = steady.as_ref().filter(|s| !s.periodic).map(|s| {
        format!(
            "the response did not become periodic within {} periods: period-to-period scatter {:.2e} >= tolerance {:.1e} (periodicity '{}')",
            s.periods_simulated,
            s.period_scatter,
            s.tolerance,
            s.periodicity.name()
        )
    });
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
