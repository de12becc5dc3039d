//! Tracing the branches of a frequency response diagram and reporting what they find.

use super::report::{
    describe_stop, BifurcationReport, BranchReport, FoldReport, FrdPoint, FrdReport,
};
use super::settings::{response_dof, FrdSettings};
use crate::continuation::arclength::{trace_branch, Branch, Event};
use crate::error::Result;
use crate::method::settings::MethodSettings;
use crate::model::Model;
use crate::newton::NewtonOptions;
use crate::problem::{PeriodicProblem, StartingAt};
use crate::solution::{DiagramPoint, MethodKind};
use crate::solve::start_by_continuation;
use crate::stability::{crossings, Floquet};

/// Which branch an observer is told about.
#[derive(Clone, Debug)]
pub struct BranchInfo {
    pub harmonics: usize,
    pub method: MethodKind,
    /// See [`BranchReport::label`].
    pub label: String,
    /// HBM-AFT: penalty stiffness of the (first) contact.
    pub penalty: Option<f64>,
}

/// Receives what a diagram finds, as it is found. Every method has a default that does
/// nothing.
/// A point as an [`FrdObserver`] is told it.
#[derive(Clone, Copy, Debug)]
pub struct PointEvent<'a> {
    /// The branch it belongs to.
    pub branch: &'a BranchInfo,
    /// The point.
    pub point: &'a FrdPoint,
    /// The branch's points so far, this one included.
    pub points: usize,
    /// The arclength step that led to it (0 for folds).
    pub step: f64,
}

pub trait FrdObserver {
    /// A branch starts (its method is built).
    fn start(&mut self, _branch: &BranchInfo) {}
    /// A point of the branch — a continuation point, or a located fold (`point.fold`).
    /// An error stops the diagram at once and is returned.
    fn point(&mut self, _event: &PointEvent<'_>) -> Result<()> {
        Ok(())
    }
    /// A fold was located (after its point was reported).
    fn fold(&mut self, _branch: &BranchInfo, _fold: &FoldReport) {}
    /// A multiplier crossed the unit circle between the last two points.
    fn stability_change(&mut self, _branch: &BranchInfo, _change: &BifurcationReport) {}
    /// The branch has ended (reached the end or stopped, [`BranchReport::stop`]).
    fn finish(&mut self, _branch: &BranchReport) {}
}

/// A traced branch: its report, what it found, and the continuation's own record (the
/// unknowns of every point).
pub struct TracedBranch {
    pub report: BranchReport,
    pub folds: Vec<FoldReport>,
    pub bifurcations: Vec<BifurcationReport>,
    pub branch: Branch,
}

/// Trace every method of `methods` for every number of harmonics of `harmonics` (methods
/// outer), in that order. With more than one method the labels name the method
/// ("HBM-AFT kp = 1.000e7, H = 5"), otherwise only `H`. A branch that stops early does not
/// stop the diagram ([`FrdReport::completed`]); an error (bad settings, a method that
/// cannot be built for the model, an observer's error) does.
pub fn trace_diagram(
    model: &Model,
    methods: &[MethodSettings],
    harmonics: &[usize],
    settings: &FrdSettings,
    observer: &mut dyn FrdObserver,
) -> Result<FrdReport> {
    let several = methods.len() > 1;
    let mut report = FrdReport::default();
    for method in methods {
        for &h in harmonics {
            let traced = trace_frd_branch(
                model,
                &method.with_harmonics(h),
                settings,
                several,
                observer,
            )?;
            report.folds.extend(traced.folds);
            report.bifurcations.extend(traced.bifurcations);
            report.branches.push(traced.report);
        }
    }
    Ok(report)
}

/// Trace one branch of `method` from `settings.from_hz` to `settings.to_hz`; `name_method`:
/// the label names the method (several methods share the diagram).
pub fn trace_frd_branch(
    model: &Model,
    method: &MethodSettings,
    settings: &FrdSettings,
    name_method: bool,
    observer: &mut dyn FrdObserver,
) -> Result<TracedBranch> {
    settings.validate()?;
    let dof = response_dof(model, settings.response_dof)?;
    let built = method.build_observed(model, &settings.limits, settings.setup_observer.as_ref())?;
    let harmonics = method.harmonics();
    let info = BranchInfo {
        harmonics,
        method: method.kind(),
        label: if name_method {
            format!("{}, H = {harmonics}", built.label)
        } else {
            format!("H = {harmonics}")
        },
        penalty: built.penalty,
    };
    observer.start(&info);
    let mut problem = built.problem;
    // the method's continuation policy comes with the problem
    let options = settings.continuation();
    // where Newton from the linear response fails at the start frequency, the first point
    // comes from a continuation from below, as for a solve (docs/theory.md (T118))
    let fixed = NewtonOptions {
        max_iterations: options.newton.max_iterations.max(50),
        ..options.newton.clone()
    };
    let linear = problem.initial_guess(options.omega_start)?;
    let direct = crate::newton::solve(problem.as_mut(), &linear, options.omega_start, &fixed)?;
    let started = if direct.converged {
        None
    } else {
        start_by_continuation(problem.as_mut(), options.omega_start, &options.newton)?
    };
    let mut from_elsewhere;
    let problem: &mut dyn PeriodicProblem = match started {
        Some(x0) => {
            from_elsewhere = StartingAt {
                problem: problem.as_mut(),
                x0,
            };
            &mut from_elsewhere
        }
        None => problem.as_mut(),
    };

    let mut points: Vec<FrdPoint> = Vec::new();
    let mut folds = Vec::new();
    let mut bifurcations = Vec::new();
    // the last point's multipliers and frequency [Hz], for stability changes
    let mut previous: Option<(Floquet, f64)> = None;
    let branch = trace_branch(problem, &options, |p, event| {
        let (x, omega, iterations, residual, step) = match &event {
            Event::Point(pt) => (&pt.x, pt.omega, pt.iterations, pt.residual_norm, pt.step),
            Event::Fold(f) => (&f.x, f.omega, 0, 0.0, 0.0),
        };
        let fold = matches!(event, Event::Fold(_));
        let s = p.diagram_point(x, omega, dof)?;
        // a verdict that cannot be computed is "unknown" at this point, not the end of
        // the diagram
        let (floquet, stability_unknown) = if settings.stability {
            match p.floquet(x, omega) {
                Ok(f) => (f, None),
                Err(e) => (None, Some(e.to_string())),
            }
        } else {
            (None, None)
        };
        if let (Some(now), false) = (&floquet, fold) {
            let hz = omega / (2.0 * std::f64::consts::PI);
            if let Some((before, hz_before)) = &previous {
                for change in stability_changes(&info, before, *hz_before, now, hz, &s) {
                    observer.stability_change(&info, &change);
                    bifurcations.push(change);
                }
            }
            previous = Some((now.clone(), hz));
        }
        let point = FrdPoint {
            frequency_hz: s.frequency_hz,
            max_qn: s.response.max,
            min_qn: s.response.min,
            amplitude_h1: s.response.amplitude_h1(),
            residual_norm: if fold { s.residual_norm } else { residual },
            newton_iterations: iterations,
            fold,
            stable: floquet.as_ref().map(|f| f.stable),
            max_multiplier: floquet.as_ref().map(|f| f.max_multiplier),
            stability_unknown,
            max_penetration: s.max_penetration,
            dissipated_energy: s.dissipated_energy,
            state_fractions: s.state_fractions.clone(),
        };
        observer.point(&PointEvent {
            branch: &info,
            point: &point,
            points: points.len() + 1,
            step,
        })?;
        if let Event::Fold(f) = &event {
            let report = FoldReport {
                harmonics,
                label: info.label.clone(),
                frequency_hz: point.frequency_hz,
                max_qn: point.max_qn,
                min_qn: point.min_qn,
                amplitude_h1: point.amplitude_h1,
                at_kink: f.at_kink,
            };
            observer.fold(&info, &report);
            folds.push(report);
        }
        points.push(point);
        Ok(())
    })?;
    let report = BranchReport {
        harmonics,
        method: info.method,
        label: info.label.clone(),
        penalty: info.penalty,
        points,
        stop: describe_stop(&branch.stop, settings.to_hz),
        completed: branch.stop.is_success(),
        frequency_steps: branch.frequency_steps,
        stop_reason: branch.stop.clone(),
    };
    observer.finish(&report);
    Ok(TracedBranch {
        report,
        folds,
        bifurcations,
        branch,
    })
}

/// The crossings of the unit circle between the point at `hz_before` (multipliers
/// `before`) and the solution `now` at `hz`, located where the largest multiplier modulus
/// passes 1 (linear interpolation in frequency; the midpoint when it does not pass 1).
fn stability_changes(
    info: &BranchInfo,
    before: &Floquet,
    hz_before: f64,
    now: &Floquet,
    hz: f64,
    solution: &DiagramPoint,
) -> Vec<BifurcationReport> {
    crossings(before, now)
        .into_iter()
        .map(|kind| {
            let (m0, m1) = (before.max_multiplier - 1.0, now.max_multiplier - 1.0);
            let t = if m0 * m1 < 0.0 { m0 / (m0 - m1) } else { 0.5 };
            BifurcationReport {
                harmonics: info.harmonics,
                label: info.label.clone(),
                kind,
                frequency_hz: hz_before + t * (hz - hz_before),
                max_qn: solution.response.max,
                min_qn: solution.response.min,
            }
        })
        .collect()
}
