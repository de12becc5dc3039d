//! `mshbm frf`: frequency response diagrams by pseudo-arclength continuation, one branch
//! per number of harmonics, streamed to CSV as points are found.

use std::io::IsTerminal;
use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use mshbm::frd::{
    trace_diagram, BifurcationReport, BranchReport, FoldReport, FrdObserver, FrdPoint, FrdSettings,
    PointEvent,
};
use mshbm::method::settings::MethodSettings;
use mshbm::request::FrdRequest;
use mshbm::solution::{MethodKind, StateFractions};
use mshbm::stability::Crossing;
use mshbm::Model;

use super::solve::MethodArgs;
use super::{ModelArgs, Spelled};
use crate::output::finite::to_json;
use crate::output::status::{Interrupted, NotConverged};
use crate::output::stream::StreamedCsv;
use crate::output::{interrupt, OutputKind, OutputPlan};
use crate::plot::{Figure, HLine, Series, Style};

/// Arguments of `mshbm frf`.
#[derive(Args, Debug)]
pub struct FrfArgs {
    #[command(flatten)]
    pub model: ModelArgs,

    /// Start frequency [Hz] (the branch starts from the linear response here).
    #[arg(long = "from", value_name = "HZ", allow_negative_numbers = true)]
    pub from_hz: f64,

    /// End frequency [Hz] (below --from for a downward sweep).
    #[arg(long = "to", value_name = "HZ", allow_negative_numbers = true)]
    pub to_hz: f64,

    /// Numbers of harmonics, comma-separated: one branch each, overlaid in one plot.
    #[arg(long, value_delimiter = ',', default_values_t = vec![mshbm::request::method::DEFAULT_HARMONICS])]
    pub harmonics: Vec<usize>,

    #[command(flatten)]
    pub method: MethodArgs,

    /// Initial arclength step (dimensionless: x scaled by the model's length scale, ω by
    /// the start frequency).
    #[arg(long, default_value_t = mshbm::frd::DEFAULT_INITIAL_STEP, allow_negative_numbers = true)]
    pub step: f64,

    /// Largest arclength step.
    #[arg(long, default_value_t = mshbm::frd::DEFAULT_MAX_STEP, allow_negative_numbers = true)]
    pub max_step: f64,

    /// Smallest arclength step; below it the continuation stops and reports why. Grazing
    /// contacts turn the branch within very short arcs, so this is small.
    #[arg(long, default_value_t = mshbm::frd::DEFAULT_MIN_STEP, allow_negative_numbers = true)]
    pub min_step: f64,

    /// Largest turn of the tangent between two points [degrees].
    #[arg(long, default_value_t = mshbm::frd::DEFAULT_MAX_TURN_DEG, allow_negative_numbers = true)]
    pub max_turn: f64,

    /// CSV file, one row per point (streamed to a temporary file beside it as points are
    /// found, renamed into place when the run ends):
    /// frequency_hz,harmonics,max_qn,min_qn,amplitude_h1,residual_norm,newton_iterations,fold,
    /// stable,max_multiplier (the last two empty without --stability; `unknown` and empty
    /// where the multipliers could not be computed); with friction on the contacts also
    /// dissipated_energy,stick,slip,open (the energy the friction dissipates per period and
    /// the fractions of the period stuck, slipping and open, averaged over the contacts;
    /// per contact in --json). The last line says
    /// how the run ended: `# finished: ...` or `# incomplete: ...` (a branch stopped early,
    /// or SIGINT/SIGTERM).
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

const CSV_HEADER: &str =
    "frequency_hz,harmonics,max_qn,min_qn,amplitude_h1,residual_norm,newton_iterations,fold,stable,max_multiplier";
/// Extra columns when hbm-aft runs (several methods or penalties share the file).
const CSV_METHOD_COLUMNS: &str = ",method,penalty,max_penetration";
/// Extra columns for contacts with friction: the energy dissipated per period and the
/// fractions of the period in stick, slip and open, averaged over the contacts (per contact
/// in `--json`).
const CSV_FRICTION_COLUMNS: &str = ",dissipated_energy,stick,slip,open";

/// The friction columns of a row (empty cells where the point has none).
fn frd_csv_friction_cells(point: &FrdPoint) -> String {
    let energy = point
        .dissipated_energy
        .map(|e| format!("{e:.9e}"))
        .unwrap_or_default();
    match point
        .state_fractions
        .as_deref()
        .and_then(StateFractions::mean)
    {
        Some(f) => format!(",{energy},{:.9},{:.9},{:.9}", f.stick, f.slip, f.open),
        None => format!(",{energy},,,"),
    }
}

/// What `mshbm frf` does with a diagram as it is found: rows streamed to the CSV, a
/// progress bar on a terminal (elsewhere a line every ten seconds), one summary line per
/// branch on stderr.
struct FrfOutput {
    from_hz: f64,
    to_hz: f64,
    bar: Option<ProgressBar>,
    csv: Option<StreamedCsv>,
    /// Points found (all branches).
    points: usize,
    /// The signal that stopped the diagram.
    interrupted: Option<&'static str>,
    /// The CSV rows carry the method columns (several methods or penalties).
    method_columns: bool,
    /// The CSV rows carry the friction columns (contacts with friction).
    friction_columns: bool,
    /// One summary line per branch on stderr (not with --json).
    summaries: bool,
    /// When stderr is not a terminal (a log file, a batch job): when the last progress line
    /// was printed.
    last_line: Option<std::time::Instant>,
}

/// How often `mshbm frf` prints a progress line where it cannot draw a bar.
const PROGRESS_LINE_EVERY: std::time::Duration = std::time::Duration::from_secs(10);

impl FrdObserver for FrfOutput {
    fn point(&mut self, event: &PointEvent<'_>) -> mshbm::Result<()> {
        let PointEvent {
            branch,
            point,
            points,
            step,
            ..
        } = *event;
        self.points += 1;
        if let Some(csv) = self.csv.as_mut() {
            let method = self
                .method_columns
                .then_some((branch.method.name(), branch.penalty));
            // a write error (full disk, NaN) stops the diagram at once
            let mut row = frd_csv_row(point, branch.harmonics, method);
            if self.friction_columns {
                row.push_str(&frd_csv_friction_cells(point));
            }
            csv.row(&row).map_err(|e| {
                // the message names the file already: keep it once
                let text = format!("{e:#}");
                let prefix = format!("{}: ", csv.path().display());
                let message = text.strip_prefix(&prefix).unwrap_or(&text).to_string();
                mshbm::Error::io(csv.path(), message)
            })?;
        }
        if let Some(signal) = interrupt::requested() {
            self.interrupted = Some(signal);
            return Err(mshbm::Error::InvalidArgument {
                name: "run".into(),
                message: format!("interrupted by {signal}"),
            });
        }
        if self.bar.is_none() && std::io::stderr().is_terminal() {
            let bar = ProgressBar::new(1000);
            bar.set_style(
                ProgressStyle::with_template("{prefix} [{bar:30}] {msg}")
                    .expect("valid template")
                    .progress_chars("=> "),
            );
            bar.set_prefix(branch.label.clone());
            self.bar = Some(bar);
        }
        if self.bar.is_none() && self.summaries {
            let now = std::time::Instant::now();
            let last = *self.last_line.get_or_insert(now);
            if now - last >= PROGRESS_LINE_EVERY {
                self.last_line = Some(now);
                crate::note!(
                    "{}: point {points} at {:.2} Hz (toward {:.2} Hz), step {step:.1e}",
                    branch.label,
                    point.frequency_hz,
                    self.to_hz
                );
            }
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
        Ok(())
    }

    fn finish(&mut self, report: &BranchReport) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
        if self.summaries {
            let folds = report.points.iter().filter(|p| p.fold).count();
            let iterations: usize = report.points.iter().map(|p| p.newton_iterations).sum();
            let stepped = match report.frequency_steps {
                0 => String::new(),
                n => format!(
                    " ({n} of them by stepping in frequency past corners of the branch, where a fold would be jumped over)"
                ),
            };
            crate::note!(
                "{}: {} points{stepped}, {iterations} Newton iterations, {folds} folds, {}",
                report.label,
                report.points.len(),
                report.stop
            );
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
/// A frequency [Hz] with `decimals` decimals, or in scientific notation with 12 digits when
/// that would hide it (below 10⁻³ Hz: `frf --from 1e-300` wrote `0.000000000` in every
/// row).
pub fn hz_text(hz: f64, decimals: usize) -> String {
    if hz == 0.0 || hz.abs() >= 1e-3 {
        format!("{hz:.decimals$}")
    } else {
        format!("{hz:.12e}")
    }
}

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
        "{},{},{:.12e},{:.12e},{:.12e},{:.3e},{},{},{},{}{extra}",
        hz_text(point.frequency_hz, 9),
        harmonics,
        point.max_qn,
        point.min_qn,
        point.amplitude_h1,
        point.residual_norm,
        point.newton_iterations,
        point.fold,
        match (point.stable, &point.stability_unknown) {
            (Some(b), _) => b.to_string(),
            (None, Some(_)) => "unknown".into(),
            (None, None) => String::new(),
        },
        point
            .max_multiplier
            .map(|m| format!("{m:.9}"))
            .unwrap_or_default()
    )
}

/// Fig. 9/11-style diagram: max and min of the response vs frequency per branch.
pub fn frd_figure(
    model: &Model,
    branches: &[BranchReport],
    folds: &[FoldReport],
    bifurcations: &[BifurcationReport],
    title: &str,
    y_label: &str,
) -> Figure {
    // kHz for the structures of the paper, Hz for slow (or dimensionless) models
    let highest = branches
        .iter()
        .flat_map(|b| b.points.iter().map(|p| p.frequency_hz))
        .fold(0.0f64, f64::max);
    let (per_unit, unit) = if highest >= 1e3 {
        (1e3, "kHz")
    } else {
        (1.0, "Hz")
    };
    let mut fig = Figure {
        title: title.to_string(),
        x_label: format!("frequency [{unit}]"),
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
                        .map(|p| (p.frequency_hz / per_unit, value(p)))
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
                .map(|f| (f.frequency_hz / per_unit, f.min_qn))
                .collect(),
            style: Style::Markers,
            color: 7,
        });
    }
    // the bifurcations that are not folds, where the stability changes
    for (kind, color) in [(Crossing::PeriodDoubling, 3), (Crossing::NeimarkSacker, 4)] {
        let at: Vec<(f64, f64)> = bifurcations
            .iter()
            .filter(|b| b.kind == kind)
            .flat_map(|b| {
                let f = b.frequency_hz / per_unit;
                [(f, b.max_qn), (f, b.min_qn)]
            })
            .collect();
        if !at.is_empty() {
            fig.series.push(Series {
                label: crossing_name(kind).into(),
                points: at,
                style: Style::HollowMarkers,
                color,
            });
        }
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

/// The library's request of `mshbm frf` (its checks and defaults:
/// [`mshbm::request::FrdRequest`]).
fn frd_request(args: &FrfArgs) -> FrdRequest {
    FrdRequest {
        harmonics: args.harmonics.clone(),
        method: args.method.request(),
        step: args.step,
        max_step: args.max_step,
        min_step: args.min_step,
        max_turn: args.max_turn,
        stability: args.stability,
        overlay_mshbm: args.overlay_mshbm,
        ..FrdRequest::new(args.from_hz, args.to_hz)
    }
}

/// The library's settings of `mshbm frf`.
pub fn frd_settings(args: &FrfArgs, model: &Model) -> Result<FrdSettings> {
    let mut settings = frd_request(args)
        .settings(model, args.model.limits())
        .spelled()?;
    settings.setup_observer = Some(crate::progress::setup_progress());
    Ok(settings)
}

/// The methods of `mshbm frf` (one per `--penalty`, the MS-HBM first with
/// `--overlay-mshbm`), each with one `--harmonics` value that the diagram replaces per
/// branch.
pub fn frd_methods(args: &FrfArgs) -> Result<Vec<MethodSettings>> {
    frd_request(args).methods().spelled()
}

pub fn run(args: &FrfArgs) -> Result<()> {
    let methods = frd_methods(args)?;
    let model = args.model.load()?;
    OutputPlan::new()
        .input("the model file", &args.model.model)
        .inputs("a file the model reads", &model.input_files)
        .output("--output", args.output.as_deref(), OutputKind::Data)
        .output("--plot", args.plot.as_deref(), OutputKind::Plot)
        .check()?;
    let settings = frd_settings(args, &model)?;
    let method_columns = methods.iter().any(|m| m.kind() == MethodKind::HbmAft);
    let friction_columns = model.has_contact_friction();
    let mut header = frd_csv_header(method_columns);
    if friction_columns {
        header.push_str(CSV_FRICTION_COLUMNS);
    }
    let csv = match &args.output {
        Some(path) => Some(StreamedCsv::create(path, &header, true)?),
        None => None,
    };
    let mut output = FrfOutput {
        from_hz: args.from_hz,
        to_hz: args.to_hz,
        bar: None,
        csv,
        points: 0,
        interrupted: None,
        method_columns,
        friction_columns,
        summaries: !args.json,
        last_line: None,
    };
    let traced = trace_diagram(&model, &methods, &args.harmonics, &settings, &mut output);
    if let Some(bar) = output.bar.take() {
        bar.finish_and_clear();
    }
    let report = match traced {
        Ok(report) => report,
        Err(e) => {
            // the observer saw the signal, or the library stopped inside a point
            let Some(signal) = output.interrupted.or_else(interrupt::requested) else {
                // an error (a write error included): the temporary CSV is removed
                return Err(e.into());
            };
            let points = output.points;
            let written = match output.csv.take() {
                Some(csv) => {
                    let path = csv.path().display().to_string();
                    csv.finish(&format!(
                        "incomplete: interrupted by {signal} after {points} points"
                    ))?;
                    format!("the {points} points found were written to {path}, marked incomplete")
                }
                None => format!("{points} points were found"),
            };
            return Err(Interrupted(format!(
                "interrupted by {signal}: {written}; no plot or JSON was written"
            ))
            .into());
        }
    };
    let failure = report
        .branches
        .iter()
        .find(|b| !b.completed)
        .map(|b| format!("{}: {}", b.label, b.stop));
    let json = if args.json {
        Some(to_json("standard output", &report)?)
    } else {
        None
    };
    let unknown = stability_unknown_lines(&report.branches);
    if let Some(mut csv) = output.csv.take() {
        for line in &unknown {
            csv.comment(line)?;
        }
        // where the stability changes, with how (a fold, a period doubling, a
        // Neimark–Sacker bifurcation), between the two points of different verdicts
        for b in &report.bifurcations {
            csv.comment(&format!(
                "bifurcation ({}): {} near {} Hz, max {:.6e}, min {:.6e}",
                b.label,
                crossing_name(b.kind),
                hz_text(b.frequency_hz, 9),
                b.max_qn,
                b.min_qn
            ))?;
        }
        let status = match &failure {
            Some(why) => format!("incomplete: branch {why}"),
            None => format!("finished: {} points, every branch complete", output.points),
        };
        csv.finish(&status)?;
    }
    if let Some(path) = &args.plot {
        let dof = args.method.request().response_dof(&model).spelled()?;
        let fig = frd_figure(
            &model,
            &report.branches,
            &report.folds,
            &report.bifurcations,
            &format!("Frequency response — {}", model.name),
            &format!("displacement of DOF {dof} (max, min)"),
        );
        fig.save(path)?;
    }
    if let Some(json) = json {
        crate::outln!("{json}")?;
    } else {
        for f in &report.folds {
            crate::outln!(
                "fold ({}): {} Hz, max {:.6e}{}",
                f.label,
                hz_text(f.frequency_hz, 3),
                f.max_qn,
                if f.at_kink { " (at a kink)" } else { "" }
            )?;
        }
        for line in &unknown {
            crate::outln!("{line}")?;
        }
        for b in &report.bifurcations {
            crate::outln!(
                "stability change ({}): {} near {} Hz",
                b.label,
                crossing_name(b.kind),
                hz_text(b.frequency_hz, 3)
            )?;
        }
        if let Some(path) = &args.output {
            crate::note!("points written to {}", path.display());
        }
    }
    if let Some(why) = failure {
        return Err(NotConverged(format!(
            "continuation incomplete — {why}; every point found was written"
        ))
        .into());
    }
    Ok(())
}

/// One line per branch with points whose stability is unknown (asked for, not computable):
/// how many, and the first with its reason.
fn stability_unknown_lines(branches: &[mshbm::frd::BranchReport]) -> Vec<String> {
    branches
        .iter()
        .filter_map(|b| {
            let mut unknown = b.points.iter().filter_map(|p| {
                p.stability_unknown
                    .as_ref()
                    .map(|why| (p.frequency_hz, why))
            });
            let (hz, why) = unknown.next()?;
            Some(format!(
                "stability unknown ({}): {} of {} points, first at {} Hz: {why}",
                b.label,
                1 + unknown.count(),
                b.points.len(),
                hz_text(hz, 3)
            ))
        })
        .collect()
}

/// How a multiplier crosses the unit circle, for people.
pub fn crossing_name(kind: Crossing) -> &'static str {
    match kind {
        Crossing::Fold => "fold",
        Crossing::PeriodDoubling => "period doubling",
        Crossing::NeimarkSacker => "Neimark-Sacker",
    }
}
