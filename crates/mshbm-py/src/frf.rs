//! `frf`: a frequency response diagram, as `mshbm frf` (library: `frd::trace_diagram`),
//! with an optional Python callback per point that can stop the diagram; what was found
//! before the stop is returned with the reason.

use mshbm::frd::{
    trace_diagram, BifurcationReport, BranchInfo, BranchReport, FoldReport, FrdObserver, FrdPoint,
    PointEvent,
};
use mshbm::request::FrdRequest;
use mshbm::solution::StateFractions;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyList};

use crate::convert::{array, to_python};
use crate::errors::{to_py, Spelled};
use crate::methods::MethodKeywords;
use crate::model::NativeModel;
use crate::threads::interruptible;

/// One branch as found so far.
struct Found {
    info: BranchInfo,
    points: Vec<FrdPoint>,
    stop: String,
    completed: bool,
    frequency_steps: usize,
}

/// Collects every point, fold and stability change as it is found (so that a diagram
/// stopped by the callback still returns them), checks Ctrl-C and calls the callback.
struct Collector {
    callback: Option<Py<PyAny>>,
    branches: Vec<Found>,
    folds: Vec<FoldReport>,
    bifurcations: Vec<BifurcationReport>,
    /// Set when the callback returned False.
    stopped: Option<String>,
    /// The callback's exception, or KeyboardInterrupt.
    error: Option<PyErr>,
}

fn point_dict<'py>(py: Python<'py>, event: &PointEvent<'_>) -> PyResult<Bound<'py, PyDict>> {
    let (branch, p) = (event.branch, event.point);
    let d = PyDict::new(py);
    d.set_item("label", &branch.label)?;
    d.set_item("harmonics", branch.harmonics)?;
    d.set_item("method", branch.method.name())?;
    d.set_item("penalty", branch.penalty)?;
    d.set_item("frequency_hz", p.frequency_hz)?;
    d.set_item("max_qn", p.max_qn)?;
    d.set_item("min_qn", p.min_qn)?;
    d.set_item("amplitude_h1", p.amplitude_h1)?;
    d.set_item("residual_norm", p.residual_norm)?;
    d.set_item("newton_iterations", p.newton_iterations)?;
    d.set_item("fold", p.fold)?;
    d.set_item("stable", p.stable)?;
    d.set_item("max_multiplier", p.max_multiplier)?;
    d.set_item("max_penetration", p.max_penetration)?;
    d.set_item("dissipated_energy", p.dissipated_energy)?;
    d.set_item("points", event.points)?;
    d.set_item("step", event.step)?;
    Ok(d)
}

impl FrdObserver for Collector {
    fn start(&mut self, branch: &BranchInfo) {
        self.branches.push(Found {
            info: branch.clone(),
            points: Vec::new(),
            stop: "running".into(),
            completed: false,
            frequency_steps: 0,
        });
    }

    fn point(&mut self, event: &PointEvent<'_>) -> mshbm::Result<()> {
        if let Some(b) = self.branches.last_mut() {
            b.points.push(event.point.clone());
        }
        let stop = Python::attach(|py| -> PyResult<Option<String>> {
            py.check_signals()?;
            let Some(cb) = &self.callback else {
                return Ok(None);
            };
            let answer = cb.call1(py, (point_dict(py, event)?,))?;
            let answer = answer.bind(py);
            Ok(
                (answer.is_instance_of::<PyBool>() && !answer.is_truthy()?).then(|| {
                    format!(
                        "stopped by the callback at {} Hz ({}, {} points)",
                        event.point.frequency_hz, event.branch.label, event.points
                    )
                }),
            )
        });
        let message = match stop {
            Ok(None) => return Ok(()),
            Ok(Some(why)) => {
                self.stopped = Some(why.clone());
                why
            }
            Err(e) => {
                self.error = Some(e);
                "the callback raised an exception".into()
            }
        };
        Err(mshbm::Error::argument("callback", message))
    }

    fn fold(&mut self, _branch: &BranchInfo, fold: &FoldReport) {
        self.folds.push(fold.clone());
    }

    fn stability_change(&mut self, _branch: &BranchInfo, change: &BifurcationReport) {
        self.bifurcations.push(change.clone());
    }

    fn finish(&mut self, report: &BranchReport) {
        if let Some(b) = self.branches.last_mut() {
            b.points = report.points.clone();
            b.stop = report.stop.clone();
            b.completed = report.completed;
            b.frequency_steps = report.frequency_steps;
        }
    }
}

/// A branch as columns: numpy arrays per field of the CLI's CSV (`stable`: 1.0, 0.0, or
/// NaN when not computed; `max_multiplier`, `max_penetration`: NaN when not computed).
fn branch_dict<'py>(py: Python<'py>, b: Found) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("harmonics", b.info.harmonics)?;
    d.set_item("method", b.info.method.name())?;
    d.set_item("label", &b.info.label)?;
    d.set_item("penalty", b.info.penalty)?;
    d.set_item("stop", &b.stop)?;
    d.set_item("completed", b.completed)?;
    d.set_item("frequency_steps", b.frequency_steps)?;
    let p = &b.points;
    let col = |f: fn(&FrdPoint) -> f64| array(py, p.iter().map(f).collect());
    d.set_item("frequency_hz", col(|p| p.frequency_hz))?;
    d.set_item("max_qn", col(|p| p.max_qn))?;
    d.set_item("min_qn", col(|p| p.min_qn))?;
    d.set_item("amplitude_h1", col(|p| p.amplitude_h1))?;
    d.set_item("residual_norm", col(|p| p.residual_norm))?;
    d.set_item(
        "newton_iterations",
        PyArray1::from_vec(py, p.iter().map(|p| p.newton_iterations as i64).collect()),
    )?;
    d.set_item(
        "fold",
        PyArray1::from_vec(py, p.iter().map(|p| p.fold).collect()),
    )?;
    d.set_item(
        "stable",
        col(|p| p.stable.map_or(f64::NAN, |s| if s { 1.0 } else { 0.0 })),
    )?;
    d.set_item(
        "max_multiplier",
        col(|p| p.max_multiplier.unwrap_or(f64::NAN)),
    )?;
    d.set_item(
        "max_penetration",
        col(|p| p.max_penetration.unwrap_or(f64::NAN)),
    )?;
    d.set_item(
        "dissipated_energy",
        col(|p| p.dissipated_energy.unwrap_or(f64::NAN)),
    )?;
    let means: Vec<Option<StateFractions>> = p
        .iter()
        .map(|p| p.state_fractions.as_deref().and_then(StateFractions::mean))
        .collect();
    let mean_col = |f: fn(&StateFractions) -> f64| {
        array(
            py,
            means
                .iter()
                .map(|m| m.as_ref().map_or(f64::NAN, f))
                .collect(),
        )
    };
    d.set_item("stick", mean_col(|f| f.stick))?;
    d.set_item("slip", mean_col(|f| f.slip))?;
    d.set_item("open", mean_col(|f| f.open))?;
    // per point and contact: [stick, slip, open]
    let per_contact: Option<Vec<Vec<[f64; 3]>>> = p
        .iter()
        .map(|p| {
            p.state_fractions.as_ref().map(|fs| {
                fs.iter()
                    .map(|f| [f.stick, f.slip, f.open])
                    .collect::<Vec<_>>()
            })
        })
        .collect();
    match per_contact {
        Some(rows) if !rows.is_empty() => {
            let contacts = rows[0].len();
            let flat: Vec<f64> = rows.iter().flatten().flatten().copied().collect();
            let array = PyArray1::from_vec(py, flat).reshape([rows.len(), contacts, 3])?;
            d.set_item("state_fractions", array)?;
        }
        _ => d.set_item("state_fractions", py.None())?,
    }
    Ok(d)
}

/// The frequency response diagram (module docs). Returns a dict: `branches` (one dict of
/// columns per branch), `folds`, `bifurcations`, `completed`, `stop_reason`,
/// `stopped_by_callback`. `None` keywords take the library's defaults (`FrdRequest`).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (model, from_hz, to_hz, harmonics=None, *, method=None,
    samples=None, quadrature=None, mass=None, penalty=Vec::new(), tangential_penalty=None,
    tolerance=None, max_iterations=None, dof=None, stability_modes=None, receptance=None,
    receptance_modes=None, jacobian=None, step=None, max_step=None, min_step=None,
    max_turn=None, stability=None, overlay_mshbm=None, max_points=None, callback=None,
    threads=None))]
pub fn frf(
    py: Python<'_>,
    model: &NativeModel,
    from_hz: f64,
    to_hz: f64,
    harmonics: Option<Vec<usize>>,
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
    step: Option<f64>,
    max_step: Option<f64>,
    min_step: Option<f64>,
    max_turn: Option<f64>,
    stability: Option<bool>,
    overlay_mshbm: Option<bool>,
    max_points: Option<usize>,
    callback: Option<Py<PyAny>>,
    threads: Option<usize>,
) -> PyResult<Py<PyAny>> {
    let d = FrdRequest::new(from_hz, to_hz);
    let request = FrdRequest {
        harmonics: harmonics.unwrap_or(d.harmonics.clone()),
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
        step: step.unwrap_or(d.step),
        max_step: max_step.unwrap_or(d.max_step),
        min_step: min_step.unwrap_or(d.min_step),
        max_turn: max_turn.unwrap_or(d.max_turn),
        stability: stability.unwrap_or(d.stability),
        overlay_mshbm: overlay_mshbm.unwrap_or(d.overlay_mshbm),
        max_points: max_points.unwrap_or(d.max_points),
        ..FrdRequest::new(from_hz, to_hz)
    };
    let methods = request.methods().spelled()?;
    let m = &model.model;
    let mut settings = request.settings(m, model.limits).spelled()?;
    let harmonics = request.harmonics;
    let mut collector = Collector {
        callback,
        branches: Vec::new(),
        folds: Vec::new(),
        bifurcations: Vec::new(),
        stopped: None,
        error: None,
    };
    let traced = interruptible(py, threads, |cancel| {
        settings.limits.cancel = cancel;
        trace_diagram(m, &methods, &harmonics, &settings, &mut collector)
    })?;
    if let Some(e) = collector.error.take() {
        return Err(e);
    }
    let stopped_by_callback = collector.stopped.is_some();
    if let Err(e) = traced {
        let Some(why) = collector.stopped.clone() else {
            return Err(to_py(e));
        };
        if let Some(b) = collector.branches.last_mut() {
            b.stop = why;
        }
    }
    let stop_reason = collector
        .branches
        .iter()
        .find(|b| !b.completed)
        .map(|b| format!("{}: {}", b.info.label, b.stop));
    let d = PyDict::new(py);
    d.set_item("completed", stop_reason.is_none())?;
    d.set_item("stop_reason", stop_reason)?;
    d.set_item("stopped_by_callback", stopped_by_callback)?;
    d.set_item("folds", to_python(py, &collector.folds)?)?;
    d.set_item("bifurcations", to_python(py, &collector.bifurcations)?)?;
    let branches = PyList::empty(py);
    for b in collector.branches {
        branches.append(branch_dict(py, b)?)?;
    }
    d.set_item("branches", branches)?;
    Ok(d.into_any().unbind())
}
