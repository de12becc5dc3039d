//! `mshbm frf`: frequency response diagrams by pseudo-arclength continuation, one branch
//! per number of harmonics, streamed to CSV as points are found.

use std::fs::File;
use std::io::{BufWriter, IsTerminal, Write};
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use mshbm::continuation::arclength::{
    trace_branch, Branch, ContinuationOptions, Event, StopReason,
};
use mshbm::Model;
use serde::Serialize;

use super::solve::{Method, MethodArgs, Variant};
use super::ModelArgs;
use crate::plot::{Figure, HLine, Series, Style};

/// Arguments of `mshbm frf`.
#[derive(Args, Debug)]
pub struct FrfArgs {
    #[command(flatten)]
    pub model: ModelArgs,

    /// Start frequency [Hz] (the branch starts from the linear response here).
    #[arg(long = "from", value_name = "HZ")]
    pub from_hz: f64,

    /// End frequency [Hz] (below --from for a downward sweep).
    #[arg(long = "to", value_name = "HZ")]
    pub to_hz: f64,

    /// Numbers of harmonics, comma-separated: one branch each, overlaid in one plot.
    #[arg(long, value_delimiter = ',', default_values_t = vec![5usize])]
    pub harmonics: Vec<usize>,

    #[command(flatten)]
    pub method: MethodArgs,

    /// Initial arclength step (dimensionless: x scaled by the model's length scale, ω by
    /// the start frequency).
    #[arg(long, default_value_t = 0.01)]
    pub step: f64,

    /// Largest arclength step.
    #[arg(long, default_value_t = 0.1)]
    pub max_step: f64,

    /// Smallest arclength step; below it the continuation stops and reports why. Grazing
    /// contacts turn the branch within very short arcs, so this is small.
    #[arg(long, default_value_t = 1e-12)]
    pub min_step: f64,

    /// Largest turn of the tangent between two points [degrees].
    #[arg(long, default_value_t = 20.0)]
    pub max_turn: f64,

    /// CSV file, one row per point (appended as points are found):
    /// frequency_hz,harmonics,max_qn,min_qn,amplitude_h1,residual_norm,newton_iterations,fold,
    /// stable,max_multiplier (the last two empty without --stability).
    #[arg(long, value_name = "FILE")]
    pub output: Option<PathBuf>,

    /// Plot max (and min) displacement vs frequency for each H, folds marked; .svg or .png.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,

    /// Print one JSON object on stdout: {"branches": [...], "folds": [...]}.
    #[arg(long)]
    pub json: bool,

    /// Compute the Floquet multipliers of every point (redistributed MS-HBM; ~50 ms per
    /// point for the paper's bar in the full space, see --stability-modes for large
    /// models): CSV columns stable,max_multiplier, and unstable parts dashed in the plot.
    #[arg(long)]
    pub stability: bool,

    /// With --method hbm-aft: also trace the redistributed MS-HBM (same --samples and
    /// --quadrature) for each H and overlay it in the plot, CSV and JSON — the paper's
    /// Fig. 11: `frf examples/clamped_bar_gap0.toml --set damping.first_mode_ratio=0.01
    /// --from 20000 --to 100000 --method hbm-aft --penalty 1e6,1e7,1e8 --quadrature exact
    /// --overlay-mshbm --plot fig11.png`. With the classical sampled AFT, a stiff penalty
    /// (kp ≳ 10× the contact stiffness) makes branches stop at folds that fall on kinks of
    /// the residual; --quadrature exact integrates the penalty force and avoids that.
    #[arg(long)]
    pub overlay_mshbm: bool,
}

/// One point of the diagram as reported.
#[derive(Clone, Debug, Serialize)]
pub struct FrdPoint {
    pub frequency_hz: f64,
    pub max_qn: f64,
    pub min_qn: f64,
    pub amplitude_h1: f64,
    pub residual_norm: f64,
    pub newton_iterations: usize,
    pub fold: bool,
    /// Stable (all Floquet multipliers inside the unit circle), when computed (--stability).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stable: Option<bool>,
    /// Largest Floquet multiplier modulus, when computed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_multiplier: Option<f64>,
    /// hbm-aft: largest penetration `max(−g)` over the contacts and the AFT samples.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_penetration: Option<f64>,
}

#[derive(Clone, Debug, Serialize)]
pub struct FoldReport {
    pub harmonics: usize,
    /// The branch's label (see [`BranchReport::label`]).
    pub label: String,
    pub frequency_hz: f64,
    pub max_qn: f64,
    pub min_qn: f64,
    pub amplitude_h1: f64,
    /// The branch turns at a kink of a nonsmooth residual rather than at a smooth fold.
    pub at_kink: bool,
}

#[derive(Clone, Debug, Serialize)]
pub struct BranchReport {
    pub harmonics: usize,
    /// "redistributed", "hbm-aft", …
    pub method: String,
    /// e.g. "H = 5", or "HBM-AFT kp = 1.000e7, H = 5" when several configurations run.
    pub label: String,
    /// hbm-aft: penalty stiffness of the (first) contact.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub penalty: Option<f64>,
    pub points: Vec<FrdPoint>,
    /// "reached end", or why the branch stopped.
    pub stop: String,
    pub completed: bool,
    /// Points found by stepping in frequency where the arclength step failed (general
    /// MS-HBM only): a fold between two of them would be jumped over.
    pub frequency_steps: usize,
}

#[derive(Debug, Serialize)]
struct FrdReport {
    branches: Vec<BranchReport>,
    folds: Vec<FoldReport>,
    /// Stability changes between neighbouring points (with --stability).
    bifurcations: Vec<BifurcationReport>,
}

/// What the branches found besides their points.
#[derive(Default)]
pub struct Found {
    pub folds: Vec<FoldReport>,
    pub bifurcations: Vec<BifurcationReport>,
}

/// A multiplier crossing the unit circle between two neighbouring points of a branch.
#[derive(Clone, Debug, Serialize)]
pub struct BifurcationReport {
    pub harmonics: usize,
    pub label: String,
    /// "fold" (+1), "period-doubling" (−1) or "neimark-sacker" (complex pair).
    pub kind: mshbm::stability::Crossing,
    /// Where the largest multiplier modulus passes 1, interpolated between the two points.
    pub frequency_hz: f64,
    pub max_qn: f64,
    pub min_qn: f64,
}

const CSV_HEADER: &str =
    "frequency_hz,harmonics,max_qn,min_qn,amplitude_h1,residual_norm,newton_iterations,fold,stable,max_multiplier";
/// Extra columns when hbm-aft runs (several methods or penalties share the file).
const CSV_METHOD_COLUMNS: &str = ",method,penalty,max_penetration";

fn stop_text(stop: &StopReason, to_hz: f64) -> String {
    match stop {
        StopReason::ReachedEnd => format!("reached {to_hz} Hz"),
        StopReason::LeftRange => "the branch turned back past the start frequency without reaching the end (it may have retraced itself after a sharp turn)".into(),
        StopReason::MaxPoints => "point limit reached".into(),
        StopReason::StartFailed(why) => format!("no solution at the start frequency: {why}"),
        StopReason::Retraced { omega } => format!(
            "stopped at {:.3} Hz: the branch came back onto a fold it had passed (it retraces itself after a sharp turn it could not resolve)",
            omega / (2.0 * std::f64::consts::PI)
        ),
        StopReason::StepTooSmall { omega, reason } => {
            format!("stopped at {:.3} Hz: {reason}", omega / (2.0 * std::f64::consts::PI))
        }
    }
}

/// Receives the points of a branch as they are found (progress display).
pub trait BranchObserver {
    /// A new point of the branch `label`; `points` found so far (including this one) and
    /// the arclength step that led to it.
    fn point(&mut self, label: &str, point: &FrdPoint, points: usize, step: f64);
    /// The branch has ended.
    fn finish(&mut self) {}
}

/// `mshbm frf`'s progress: a bar on a terminal, nothing otherwise.
struct TerminalBar {
    from_hz: f64,
    to_hz: f64,
    bar: Option<ProgressBar>,
}

impl TerminalBar {
    fn new(from_hz: f64, to_hz: f64) -> Self {
        TerminalBar {
            from_hz,
            to_hz,
            bar: None,
        }
    }
}

impl BranchObserver for TerminalBar {
    fn point(&mut self, label: &str, point: &FrdPoint, points: usize, step: f64) {
        if self.bar.is_none() && std::io::stderr().is_terminal() {
            let bar = ProgressBar::new(1000);
            bar.set_style(
                ProgressStyle::with_template("{prefix} [{bar:30}] {msg}")
                    .expect("valid template")
                    .progress_chars("=> "),
            );
            bar.set_prefix(label.to_string());
            self.bar = Some(bar);
        }
        if let Some(bar) = &self.bar {
            let done =
                ((point.frequency_hz - self.from_hz) / (self.to_hz - self.from_hz)).clamp(0.0, 1.0);
            bar.set_position((done * 1000.0) as u64);
            bar.set_message(format!(
                "{:.1} Hz, {points} points, step {step:.1e}",
                point.frequency_hz
            ));
        }
    }

    fn finish(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
    }
}

/// The CSV header of `mshbm frf` (and of the paper's diagrams); `method_columns` adds
/// method,penalty,max_penetration (several methods or penalties share the file).
pub fn frd_csv_header(method_columns: bool) -> String {
    if method_columns {
        format!("{CSV_HEADER}{CSV_METHOD_COLUMNS}")
    } else {
        CSV_HEADER.to_string()
    }
}

/// One CSV row (no newline) of `point` on a branch with `harmonics`; `method`: the method
/// columns (method name, penalty) when the file has them.
pub fn frd_csv_row(
    point: &FrdPoint,
    harmonics: usize,
    method: Option<(&str, Option<f64>)>,
) -> String {
    let extra = match method {
        Some((name, penalty)) => format!(
            ",{name},{},{}",
            penalty.map(|k| format!("{k:.6e}")).unwrap_or_default(),
            point
                .max_penetration
                .map(|p| format!("{p:.6e}"))
                .unwrap_or_default()
        ),
        None => String::new(),
    };
    format!(
        "{:.9},{},{:.12e},{:.12e},{:.12e},{:.3e},{},{},{},{}{extra}",
        point.frequency_hz,
        harmonics,
        point.max_qn,
        point.min_qn,
        point.amplitude_h1,
        point.residual_norm,
        point.newton_iterations,
        point.fold,
        point.stable.map(|b| b.to_string()).unwrap_or_default(),
        point
            .max_multiplier
            .map(|m| format!("{m:.9}"))
            .unwrap_or_default()
    )
}

/// Trace one branch, streaming rows to `csv` and reporting each point to `observer`.
/// `several`: more than one configuration runs (labels name the method; CSV rows carry the
/// method columns). Returns the branch with what it found (folds, stability changes).
#[allow(clippy::too_many_arguments)]
pub fn trace(
    model: &Model,
    args: &FrfArgs,
    harmonics: usize,
    variant: &Variant,
    several: bool,
    csv: &mut Option<BufWriter<File>>,
    found: &mut Found,
    observer: &mut dyn BranchObserver,
) -> Result<(BranchReport, Branch)> {
    let Found {
        folds,
        bifurcations,
    } = found;
    let mut previous: Option<(mshbm::stability::Floquet, f64)> = None;
    let two_pi = 2.0 * std::f64::consts::PI;
    let built = args.method.problem_for(model, harmonics, variant)?;
    let mut problem = built.problem;
    let method_name = match variant.method {
        Method::Redistributed => "redistributed",
        Method::Mshbm => "mshbm",
        Method::HbmAft => "hbm-aft",
    };
    let label = if several {
        format!("{}, H = {harmonics}", built.label)
    } else {
        format!("H = {harmonics}")
    };
    let method_columns = several || variant.method == Method::HbmAft;
    let dof = args.method.response_dof(model)?;
    let mut options = ContinuationOptions::new(two_pi * args.from_hz, two_pi * args.to_hz);
    options.initial_step = args.step;
    options.max_step = args.max_step;
    options.min_step = args.min_step;
    options.max_turn_deg = args.max_turn;
    options.newton = args.method.newton()?;

    let mut points = Vec::new();
    let mut row_error: Option<anyhow::Error> = None;
    let branch = trace_branch(problem.as_mut(), &options, |p, event| {
        let (x, omega, fold, iterations, residual, step) = match &event {
            Event::Point(pt) => (
                &pt.x,
                pt.omega,
                false,
                pt.iterations,
                pt.residual_norm,
                pt.step,
            ),
            Event::Fold(f) => (&f.x, f.omega, true, 0, 0.0, 0.0),
        };
        let s = p.solution(x, omega, dof)?;
        let floquet = if args.stability {
            p.floquet(x, omega)?
        } else {
            None
        };
        if let (Some(now), false) = (&floquet, fold) {
            let hz = omega / (2.0 * std::f64::consts::PI);
            if let Some((before, hz_before)) = &previous {
                for kind in mshbm::stability::crossings(before, now) {
                    let (m0, m1) = (before.max_multiplier - 1.0, now.max_multiplier - 1.0);
                    let t = if m0 * m1 < 0.0 { m0 / (m0 - m1) } else { 0.5 };
                    bifurcations.push(BifurcationReport {
                        harmonics,
                        label: label.clone(),
                        kind,
                        frequency_hz: hz_before + t * (hz - hz_before),
                        max_qn: s.response.max,
                        min_qn: s.response.min,
                    });
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
            max_penetration: (s.method == "hbm-aft").then(|| {
                s.contacts
                    .iter()
                    .flat_map(|c| c.gap.iter())
                    .fold(f64::NEG_INFINITY, |m, g| m.max(-g))
            }),
        };
        if let Event::Fold(f) = &event {
            folds.push(FoldReport {
                harmonics,
                label: label.clone(),
                frequency_hz: point.frequency_hz,
                max_qn: point.max_qn,
                min_qn: point.min_qn,
                amplitude_h1: point.amplitude_h1,
                at_kink: f.at_kink,
            });
        }
        if let Some(w) = csv.as_mut() {
            let method = method_columns.then_some((method_name, built.penalty));
            let r =
                writeln!(w, "{}", frd_csv_row(&point, harmonics, method)).and_then(|_| w.flush());
            if let Err(e) = r {
                row_error.get_or_insert(anyhow::anyhow!("cannot write the CSV: {e}"));
            }
        }
        observer.point(&label, &point, points.len() + 1, step);
        points.push(point);
        Ok(())
    })?;
    observer.finish();
    if let Some(e) = row_error {
        return Err(e);
    }
    let report = BranchReport {
        harmonics,
        method: method_name.to_string(),
        label,
        penalty: built.penalty,
        points,
        stop: stop_text(&branch.stop, args.to_hz),
        completed: branch.stop.is_success(),
        frequency_steps: branch.frequency_steps,
    };
    Ok((report, branch))
}

/// Fig. 9/11-style diagram: max and min of the response vs frequency per branch.
pub fn frd_figure(
    model: &Model,
    branches: &[BranchReport],
    folds: &[FoldReport],
    title: &str,
    y_label: &str,
) -> Figure {
    let mut fig = Figure {
        title: title.to_string(),
        x_label: "frequency [kHz]".into(),
        y_label: y_label.to_string(),
        ..Figure::default()
    };
    for (k, b) in branches.iter().enumerate() {
        // one series per run of equal stability: unstable parts dashed
        let mut runs: Vec<(bool, Vec<&FrdPoint>)> = Vec::new();
        for p in b.points.iter().filter(|p| !p.fold) {
            let unstable = p.stable == Some(false);
            match runs.last_mut() {
                Some((u, pts)) if *u == unstable => pts.push(p),
                _ => {
                    // share the boundary point so the curve stays connected
                    let mut pts: Vec<&FrdPoint> = runs
                        .last()
                        .and_then(|(_, q)| q.last().copied())
                        .into_iter()
                        .collect();
                    pts.push(p);
                    runs.push((unstable, pts));
                }
            }
        }
        let mut labelled = false;
        for (unstable, pts) in &runs {
            let style = if *unstable {
                Style::Dashed
            } else {
                Style::Line
            };
            let label = if labelled {
                String::new()
            } else {
                format!("{} (max, min)", b.label)
            };
            labelled = true;
            for (i, value) in [|p: &FrdPoint| p.max_qn, |p: &FrdPoint| p.min_qn]
                .into_iter()
                .enumerate()
            {
                fig.series.push(Series {
                    label: if i == 0 { label.clone() } else { String::new() },
                    points: pts
                        .iter()
                        .map(|p| (p.frequency_hz / 1e3, value(p)))
                        .collect(),
                    style,
                    color: k,
                });
            }
        }
    }
    if !folds.is_empty() {
        fig.series.push(Series {
            label: "folds".into(),
            points: folds
                .iter()
                .map(|f| (f.frequency_hz / 1e3, f.min_qn))
                .collect(),
            style: Style::Markers,
            color: 7,
        });
    }
    if let Some(c) = model.contacts.first() {
        if c.dofs.len() == 1 {
            fig.hlines.push(HLine {
                label: "gap".into(),
                y: -c.gap / c.w[0],
            });
        }
    }
    fig
}

pub fn run(args: &FrfArgs) -> Result<()> {
    for (name, v) in [("--from", args.from_hz), ("--to", args.to_hz)] {
        if !(v.is_finite() && v > 0.0) {
            bail!("{name} must be a positive number of Hz, got {v}");
        }
    }
    if args.from_hz == args.to_hz {
        bail!("--from and --to must differ");
    }
    if args.harmonics.is_empty() || args.harmonics.contains(&0) {
        bail!("--harmonics must list numbers of harmonics of at least 1");
    }
    if !(args.min_step > 0.0 && args.min_step <= args.step && args.step <= args.max_step) {
        bail!("steps must satisfy 0 < --min-step <= --step <= --max-step");
    }
    let mut variants = args.method.variants()?;
    if args.overlay_mshbm {
        if args.method.method != Method::HbmAft {
            bail!("--overlay-mshbm overlays the MS-HBM on --method hbm-aft; give --method hbm-aft");
        }
        variants.insert(
            0,
            Variant {
                method: Method::Redistributed,
                penalty: None,
            },
        );
    }
    let several = variants.len() > 1;
    let method_columns = variants.iter().any(|v| v.method == Method::HbmAft);
    let model = args.model.load()?;
    args.method.response_dof(&model)?;
    let mut csv = match &args.output {
        Some(path) => {
            let f =
                File::create(path).with_context(|| format!("{}: cannot create", path.display()))?;
            let mut w = BufWriter::new(f);
            writeln!(w, "{}", frd_csv_header(method_columns))?;
            w.flush()?;
            Some(w)
        }
        None => None,
    };
    let mut branches = Vec::new();
    let mut found = Found::default();
    let mut failure: Option<String> = None;
    for variant in &variants {
        for &h in &args.harmonics {
            let before = found.folds.len();
            let mut bar = TerminalBar::new(args.from_hz, args.to_hz);
            let (report, _) = trace(
                &model, args, h, variant, several, &mut csv, &mut found, &mut bar,
            )?;
            if !report.completed && failure.is_none() {
                failure = Some(format!("{}: {}", report.label, report.stop));
            }
            if !args.json {
                let nfolds = found.folds.len() - before;
                let iterations: usize = report.points.iter().map(|p| p.newton_iterations).sum();
                let stepped = match report.frequency_steps {
                    0 => String::new(),
                    n => format!(
                        " ({n} of them by stepping in frequency past corners of the branch, where a fold would be jumped over)"
                    ),
                };
                eprintln!(
                    "{}: {} points{stepped}, {iterations} Newton iterations, {nfolds} folds, {}",
                    report.label,
                    report.points.len(),
                    report.stop
                );
            }
            branches.push(report);
        }
    }
    let Found {
        folds,
        bifurcations,
    } = found;
    if let Some(path) = &args.plot {
        let dof = args.method.response_dof(&model)?;
        let fig = frd_figure(
            &model,
            &branches,
            &folds,
            &format!("Frequency response — {}", model.name),
            &format!("displacement of DOF {dof} (max, min)"),
        );
        fig.save(path)?;
    }
    if args.json {
        println!(
            "{}",
            serde_json::to_string(&FrdReport {
                branches,
                folds,
                bifurcations
            })?
        );
    } else {
        for f in &folds {
            println!(
                "fold ({}): {:.3} Hz, max {:.6e}{}",
                f.label,
                f.frequency_hz,
                f.max_qn,
                if f.at_kink { " (at a kink)" } else { "" }
            );
        }
        for b in &bifurcations {
            println!(
                "stability change ({}): {:?} near {:.3} Hz",
                b.label, b.kind, b.frequency_hz
            );
        }
        if let Some(path) = &args.output {
            eprintln!("points written to {}", path.display());
        }
    }
    if let Some(why) = failure {
        bail!("continuation incomplete — {why}; every point found was written");
    }
    Ok(())
}
