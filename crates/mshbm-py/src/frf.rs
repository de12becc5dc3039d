//! `frf`: a frequency response diagram, as `mshbm frf` (library: `frd::trace_diagram`),
//! with an optional Python callback per point that can stop the diagram; what was found
//! before the stop is returned with the reason.

use mshbm::frd::{
    trace_diagram, BifurcationReport, BranchInfo, BranchReport, FoldReport, FrdObserver, FrdPoint,
    FrdSettings,
};
use mshbm::method::settings::MethodSettings;
use mshbm::solution::StateFractions;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyList};

use crate::convert::{array, to_python};
use crate::errors::{argument, to_py};
use crate::methods::{Method, MethodArgs};
use crate::model::NativeModel;
use crate::threads::with_threads;

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

fn point_dict<'py>(
    py: Python<'py>,
    branch: &BranchInfo,
    p: &FrdPoint,
    points: usize,
    step: f64,
) -> PyResult<Bound<'py, PyDict>> {
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
    d.set_item("points", points)?;
    d.set_item("step", step)?;
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

    fn point(
        &mut self,
        branch: &BranchInfo,
        point: &FrdPoint,
        points: usize,
        step: f64,
    ) -> mshbm::Result<()> {
        if let Some(b) = self.branches.last_mut() {
            b.points.push(point.clone());
        }
        let stop = Python::attach(|py| -> PyResult<Option<String>> {
            py.check_signals()?;
            let Some(cb) = &self.callback else {
                return Ok(None);
            };
            let answer = cb.call1(py, (point_dict(py, branch, point, points, step)?,))?;
            let answer = answer.bind(py);
            Ok(
                (answer.is_instance_of::<PyBool>() && !answer.is_truthy()?).then(|| {
                    format!(
                        "stopped by the callback at {} Hz ({}, {points} points)",
                        point.frequency_hz, branch.label
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
/// `stopped_by_callback`.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (model, from_hz, to_hz, harmonics=vec![5], *, method="redistributed",
    samples=None, quadrature=None, mass=None, penalty=Vec::new(), tolerance=1e-10,
    max_iterations=50, dof=None, stability_modes=None, receptance="auto", receptance_modes=None, jacobian="auto", step=0.01, max_step=0.1,
    min_step=1e-12, max_turn=20.0, stability=false, overlay_mshbm=false, max_points=None,
    callback=None, threads=None))]
pub fn frf(
    py: Python<'_>,
    model: &NativeModel,
    from_hz: f64,
    to_hz: f64,
    harmonics: Vec<usize>,
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
    step: f64,
    max_step: f64,
    min_step: f64,
    max_turn: f64,
    stability: bool,
    overlay_mshbm: bool,
    max_points: Option<usize>,
    callback: Option<Py<PyAny>>,
    threads: Option<usize>,
) -> PyResult<Py<PyAny>> {
    // the checks of `mshbm frf`, in its order
    for (name, v) in [("from_hz", from_hz), ("to_hz", to_hz)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(argument(format!(
                "{name} must be a positive number of Hz, got {v}"
            )));
        }
    }
    if from_hz == to_hz {
        return Err(argument("from_hz and to_hz must differ"));
    }
    if harmonics.is_empty() || harmonics.contains(&0) {
        return Err(argument(
            "harmonics must list numbers of harmonics of at least 1",
        ));
    }
    if !(min_step > 0.0 && min_step <= step && step <= max_step) {
        return Err(argument(
            "steps must satisfy 0 < min_step <= step <= max_step",
        ));
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
    let h = harmonics[0];
    let mut methods: Vec<MethodSettings> = args.methods(h)?;
    if overlay_mshbm {
        if args.method != Method::HbmAft {
            return Err(argument(
                "overlay_mshbm overlays the MS-HBM on method='hbm-aft'; give method='hbm-aft'",
            ));
        }
        let mut mshbm_args = args.clone();
        mshbm_args.method = Method::Redistributed;
        mshbm_args.penalty.clear();
        mshbm_args.mass = None;
        methods.insert(0, mshbm_args.single_method(h)?);
    }
    let m = &model.model;
    let mut settings = FrdSettings::new(from_hz, to_hz);
    settings.initial_step = step;
    settings.max_step = max_step;
    settings.min_step = min_step;
    settings.max_turn_deg = max_turn;
    settings.newton = args.newton()?;
    settings.stability = stability;
    settings.response_dof = Some(args.response_dof(m)?);
    settings.limits = model.limits;
    if let Some(n) = max_points {
        settings.max_points = n;
    }
    let mut collector = Collector {
        callback,
        branches: Vec::new(),
        folds: Vec::new(),
        bifurcations: Vec::new(),
        stopped: None,
        error: None,
    };
    let traced = py.detach(|| {
        with_threads(threads, || {
            trace_diagram(m, &methods, &harmonics, &settings, &mut collector)
        })
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
