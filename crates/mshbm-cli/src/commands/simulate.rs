//! `mshbm simulate`: reference time integration (Moreau–Jean or position-level Newmark on
//! the redistributed mass), for a given time or to a periodic steady state.

use std::fmt::Write as _;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use mshbm::analytic::DroppedBarSolution;
use mshbm::integrate::steady_state::{simulate_to_steady_state, Periodicity, SteadyState};
use mshbm::integrate::{fall_energy, Integrator, Scheme, Settings};
use mshbm::model::dropped_bar::DroppedBarParameters;
use mshbm::model::file::load_dropped_bar_with;
use mshbm::request::simulate::not_periodic;
use mshbm::request::{SchemeKind, SimulateRequest, StartSolution};
use mshbm::simulation::{reference_period, state_from_solution, TransientStatistics};
use mshbm::{MassKind, Model};

use super::{ModelArgs, Spelled};
use crate::output::finite::to_json;
use crate::output::interrupt;
use crate::output::status::{NotConverged, ERROR, INTERRUPTED};
use crate::output::stream::StreamedCsv;
use crate::output::{OutputKind, OutputPlan};
use crate::plot::{Figure, HLine, Series, Style};

/// Time-stepping schemes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SchemeArg {
    /// Moreau–Jean θ-scheme on the consistent mass with Newton's impact law
    /// (--restitution, --theta): the paper's reference (e_N = 0).
    Moreau,
    /// Newmark average acceleration on the redistributed mass (massless contact boundary)
    /// with Signorini imposed on positions at the end of each step: no impact law, the gap
    /// never goes negative, energy is kept through impacts. The model the MS-HBM solves.
    Redistributed,
}

/// What must repeat from period to period for a steady state (`--periodicity`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PeriodicityArg {
    /// The reported response: the harmonics 0..H (--harmonics) of the displacements of the
    /// --dof and the contact DOFs repeat, relative to their largest displacement
    /// (docs/theory.md (T97); default --tolerance 1e-3). High modes that ring without
    /// moving these harmonics do not count.
    Response,
    /// The whole state: displacements and velocities (divided by ω) of every DOF with mass
    /// repeat, relative to the largest displacement amplitude (docs/theory.md (T70);
    /// default --tolerance 1e-6).
    State,
}

impl PeriodicityArg {
    fn periodicity(self) -> Periodicity {
        match self {
            PeriodicityArg::Response => Periodicity::Response,
            PeriodicityArg::State => Periodicity::State,
        }
    }
}

/// Default `--harmonics` of the steady state's Fourier coefficients (also those of
/// `mshbm paper`'s Fig. 9).
pub const SIMULATE_HARMONICS: usize = mshbm::request::simulate::DEFAULT_HARMONICS;

/// Arguments of `mshbm simulate`.
#[derive(Args, Debug)]
pub struct SimulateArgs {
    #[command(flatten)]
    pub model: ModelArgs,

    /// Frequency of the harmonic load F cos(2π f t) [Hz]. Required for models with a
    /// harmonic load; for free problems it only sets the period that --periods and
    /// --steps-per-period refer to (default period: the closed-form period of a dropped bar,
    /// otherwise the first eigenperiod).
    #[arg(long, value_name = "HZ", allow_negative_numbers = true)]
    pub frequency: Option<f64>,

    /// Length of the run in periods (default: 2 for free problems, 20 for forced ones).
    /// With --steady-state: the period limit (default 1000).
    #[arg(
        long,
        value_name = "P",
        conflicts_with = "duration",
        allow_negative_numbers = true
    )]
    pub periods: Option<f64>,

    /// Length of the run [s] (instead of --periods).
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub duration: Option<f64>,

    /// Time steps per period (default: 2000 for forced problems and with --steady-state,
    /// 8000 for free ones).
    #[arg(long, value_name = "N", conflicts_with = "dt")]
    pub steps_per_period: Option<usize>,

    /// Time step [s] (instead of --steps-per-period).
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub dt: Option<f64>,

    /// Time-stepping scheme. Default: `redistributed` for models with contacts (the
    /// position-level scheme on the redistributed mass, exact Signorini, no impact law —
    /// velocity-level θ = 1/2 on a singular mass is unstable); `moreau` with θ = 1/2 (the
    /// trapezoidal rule) for models without contacts.
    #[arg(long, value_enum)]
    pub scheme: Option<SchemeArg>,

    /// Restitution coefficient e_N in [0, 1] of Newton's impact law (--scheme moreau;
    /// default 0).
    #[arg(long, value_name = "E", allow_negative_numbers = true)]
    pub restitution: Option<f64>,

    /// θ in [0.5, 1] of the Moreau–Jean scheme (--scheme moreau; default 0.5, no numerical
    /// damping; θ > 0.5 dissipates).
    #[arg(long, value_name = "T", allow_negative_numbers = true)]
    pub theta: Option<f64>,

    /// Integrate period by period until the response repeats (--periodicity) to --tolerance
    /// twice in a row, then report the last period like `mshbm solve` with the measured
    /// period-to-period scatter (exit status 2 if it does not become periodic within
    /// --periods). The period is that of --frequency (required, also without load).
    #[arg(long)]
    pub steady_state: bool,

    /// Steady state: what must repeat from period to period.
    #[arg(long, value_enum, default_value_t = PeriodicityArg::Response)]
    pub periodicity: PeriodicityArg,

    /// Steady state: largest period-to-period change (--periodicity) counted as a repeat
    /// (default: 1e-3 for the response, 1e-6 for the state).
    #[arg(long, allow_negative_numbers = true)]
    pub tolerance: Option<f64>,

    /// Steady state: number of harmonics H of the reported Fourier coefficients.
    #[arg(long, default_value_t = SIMULATE_HARMONICS)]
    pub harmonics: usize,

    /// Steady state: model DOF whose response is reported (default: the first contact DOF).
    #[arg(long)]
    pub dof: Option<usize>,

    /// Start from a periodic solution (JSON of `mshbm solve --json` or of
    /// `mshbm simulate --steady-state --json`): its contact-DOF harmonics give the initial
    /// state (the other DOFs from the linear equations in the frequency domain). Its
    /// frequency is used unless --frequency is given (it must then agree).
    #[arg(long, value_name = "FILE.json")]
    pub from_solution: Option<PathBuf>,

    /// Write every step as CSV: time [s], gap and force of each contact (force = impulse/dt
    /// for Moreau–Jean), total energy, and (free problems) energy normalised by its initial
    /// value.
    #[arg(long, value_name = "FILE.csv")]
    pub output: Option<PathBuf>,

    /// Plot the gap and the (normalised) energy over time (the paper's Fig. 5; the closed
    /// form is overlaid for a dropped bar with integer kappa); .svg or .png.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,

    /// Print one JSON object on stdout: with --steady-state the same object as
    /// `mshbm solve --json` (method "time-integration") plus "periodic", "periodicity",
    /// "tolerance", "period_change", "period_scatter", "periods_simulated" (with the
    /// redistributed scheme also "unknowns", the redistributed MS-HBM's, so that
    /// `solve --from-solution` can start from it); otherwise a summary of the run.
    #[arg(long)]
    pub json: bool,
}

/// Everything recorded per step.
pub(crate) struct Recorder {
    csv: Option<StreamedCsv>,
    line: String,
    /// Extremes, contact fraction and energy range of the run.
    pub stats: TransientStatistics,
    plot_every: u64,
    /// Every `plot_every`-th step: time, gap per contact, (normalised) energy.
    pub plot_time: Vec<f64>,
    pub plot_gaps: Vec<Vec<f64>>,
    pub plot_energy: Vec<f64>,
    progress: ProgressBar,
}

impl Recorder {
    /// A recorder for `contacts` contacts, keeping every `plot_every`-th step in memory,
    /// optionally streaming every step to `csv`.
    fn new(
        contacts: usize,
        energy_norm: Option<f64>,
        plot_every: u64,
        csv: Option<StreamedCsv>,
        progress: ProgressBar,
    ) -> Self {
        Recorder {
            csv,
            line: String::new(),
            stats: TransientStatistics::new(contacts, energy_norm),
            plot_every: plot_every.max(1),
            plot_time: Vec::new(),
            plot_gaps: vec![Vec::new(); contacts],
            plot_energy: Vec::new(),
            progress,
        }
    }

    /// Record the integrator's current step. The step observer cannot return an error, so
    /// a write error or a SIGINT/SIGTERM ends the process here: on a signal the CSV is
    /// finished with an `# incomplete` line and kept (status 130); on a write error its
    /// temporary file is removed (status 1).
    fn record(&mut self, it: &Integrator) {
        if let Some(signal) = interrupt::requested() {
            self.progress.finish_and_clear();
            let steps = self.stats.steps;
            let written = match self.csv.take() {
                Some(csv) => {
                    let path = csv.path().display().to_string();
                    let rows = csv.rows();
                    match csv.finish(&format!(
                        "incomplete: interrupted by {signal} after {rows} rows"
                    )) {
                        Ok(()) => format!(
                            "the {rows} rows recorded were written to {path}, marked incomplete"
                        ),
                        Err(e) => format!("{e:#}"),
                    }
                }
                None => format!("{steps} steps were done"),
            };
            interrupt::exit_now(
                INTERRUPTED,
                &format!("interrupted by {signal}: {written}; nothing else was written"),
            );
        }
        let step = self.stats.steps;
        let shown = self.stats.record(it);
        let e = self.stats.energy_last;
        let en = self.stats.energy_norm.map(|e0| e / e0);
        if let Some(csv) = &mut self.csv {
            let line = &mut self.line;
            line.clear();
            let _ = write!(line, "{:.12e}", it.time());
            for (&g, &f) in it.gaps().iter().zip(it.forces()) {
                let _ = write!(line, ",{g:.12e},{f:.12e}");
            }
            let _ = write!(line, ",{e:.12e}");
            if let Some(en) = en {
                let _ = write!(line, ",{en:.12e}");
            }
            if let Err(e) = csv.row(line) {
                self.progress.finish_and_clear();
                drop(self.csv.take());
                interrupt::exit_now(ERROR, &format!("{e:#}; the run was stopped"));
            }
        }
        if step % self.plot_every == 0 {
            self.plot_time.push(it.time());
            for (c, &g) in it.gaps().iter().enumerate() {
                self.plot_gaps[c].push(g);
            }
            self.plot_energy.push(shown);
        }
        if self.stats.steps % 1024 == 0 {
            self.progress.set_position(self.stats.steps);
        }
    }
}

/// The scheme and the mass it integrates: Moreau–Jean (default θ = ½, e_N = 0) on the
/// consistent mass, or position-level Newmark on the redistributed mass.
pub(crate) fn scheme_and_mass(
    arg: SchemeArg,
    restitution: Option<f64>,
    theta: Option<f64>,
) -> (Scheme, MassKind) {
    let scheme = match arg {
        SchemeArg::Moreau => Scheme::moreau_jean(theta, restitution),
        SchemeArg::Redistributed => Scheme::PositionNewmark,
    };
    (scheme, scheme.mass_kind())
}

/// Integrate a free (unforced) problem for `steps` steps of `dt` from rest, recording every
/// step in memory (`mshbm simulate` without --steady-state, for one scheme): the runs of
/// the paper's Fig. 5.
pub(crate) fn transient_run(
    model: &Model,
    scheme_arg: SchemeArg,
    restitution: Option<f64>,
    dt: f64,
    steps: u64,
) -> Result<Recorder> {
    let (scheme, kind) = scheme_and_mass(scheme_arg, restitution, None);
    let system = model.system(kind)?;
    let mut integrator = Integrator::new(
        &system,
        &Settings {
            dt,
            scheme,
            omega: None,
            energy_offset: fall_energy(model, &system),
        },
    )?;
    let e0 = integrator.energy();
    let mut rec = Recorder::new(
        system.contacts.len(),
        (e0 > 0.0).then_some(e0),
        steps / 20_000,
        None,
        ProgressBar::hidden(),
    );
    rec.record(&integrator);
    integrator.run(steps as usize, |it| rec.record(it))?;
    Ok(rec)
}

/// The library's request of `mshbm simulate` (its checks and defaults:
/// [`mshbm::request::SimulateRequest`]), without its start solution.
fn simulate_request(args: &SimulateArgs) -> SimulateRequest {
    SimulateRequest {
        frequency: args.frequency,
        periods: args.periods,
        duration: args.duration,
        steps_per_period: args.steps_per_period,
        dt: args.dt,
        scheme: args.scheme.map(|s| match s {
            SchemeArg::Moreau => SchemeKind::Moreau,
            SchemeArg::Redistributed => SchemeKind::Redistributed,
        }),
        restitution: args.restitution,
        theta: args.theta,
        steady_state: args.steady_state,
        periodicity: args.periodicity.periodicity(),
        tolerance: args.tolerance,
        harmonics: args.harmonics,
        dof: args.dof,
        start_solution: None,
    }
}

pub fn run(args: &SimulateArgs) -> Result<()> {
    let mut request = simulate_request(args);
    request.validate().spelled()?;

    // --- model, scheme, system ---
    let model = args.model.load()?;
    let mut plan = OutputPlan::new();
    plan.input("the model file", &args.model.model);
    plan.inputs("a file the model reads", &model.input_files);
    if let Some(p) = &args.from_solution {
        plan.input("the --from-solution file", p);
    }
    plan.output("--output", args.output.as_deref(), OutputKind::Data)
        .output("--plot", args.plot.as_deref(), OutputKind::Plot)
        .check()?;
    let dropped: Option<DroppedBarParameters> = load_dropped_bar_with(
        &args.model.model,
        &args.model.overrides,
        &args.model.load_options(),
    )?;
    let analytic: Option<DroppedBarSolution> = dropped.as_ref().and_then(|p| p.analytic().ok());
    if let Some(path) = &args.from_solution {
        request.start_solution = Some(StartSolution {
            source: path.display().to_string(),
            solution: super::read_solution(path, &args.model.limits())?,
        });
    }
    let run_plan = request.plan(&model).spelled()?;
    let forced = run_plan.forced;
    let scheme = run_plan.scheme;
    let system = model.system(scheme.mass_kind())?;

    // --- time grid ---
    let period = reference_period(&system, run_plan.frequency, dropped.as_ref());
    let grid = request.grid(&run_plan, period).spelled()?;
    let dt = grid.dt;
    let steady_options =
        request.steady_state_options(&run_plan, &grid, &system, &args.model.limits())?;

    // --- integrator ---
    let mut integrator = Integrator::new(
        &system,
        &Settings {
            dt,
            scheme,
            omega: grid.load_omega,
            energy_offset: fall_energy(&model, &system),
        },
    )?;
    if let (Some(start), Some(w)) = (&request.start_solution, run_plan.omega()) {
        let path = args
            .from_solution
            .as_deref()
            .expect("read from --from-solution");
        let (q, v) = state_from_solution(&system, &model, &start.solution, w, path)?;
        integrator.set_state(0.0, &q, &v)?;
    }

    // --- recording ---
    let nc = system.contacts.len();
    let e0 = integrator.energy();
    let energy_norm = (!forced && e0 > 0.0).then_some(e0);
    let csv = match &args.output {
        Some(path) => {
            let mut header = String::from("time_s");
            for c in 0..nc {
                let _ = write!(header, ",gap_c{c},force_c{c}");
            }
            header.push_str(",energy");
            if energy_norm.is_some() {
                header.push_str(",energy_normalized");
            }
            Some(StreamedCsv::create(path, &header, false)?)
        }
        None => None,
    };
    let total_steps = grid.total_steps();
    let terminal = std::io::stderr().is_terminal();
    let progress = if terminal {
        let bar = ProgressBar::new(total_steps);
        bar.set_style(
            ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} steps {msg}")
                .expect("valid template")
                .progress_chars("=> "),
        );
        bar
    } else {
        ProgressBar::hidden()
    };
    let mut rec = Recorder::new(nc, energy_norm, total_steps / 20_000, csv, progress.clone());
    rec.record(&integrator);

    // --- run ---
    let steady: Option<SteadyState> = if let Some(options) = steady_options {
        let w = run_plan.omega().expect("a steady state has a frequency");
        Some(simulate_to_steady_state(
            &mut integrator,
            w,
            &options,
            |it| rec.record(it),
            crate::progress::period_progress(terminal.then_some(&progress)),
        )?)
    } else {
        integrator.run(grid.steps as usize, |it| rec.record(it))?;
        None
    };
    progress.finish_and_clear();
    let json = match (&steady, args.json) {
        (Some(s), true) => Some(to_json("standard output", s)?),
        _ => None,
    };
    if let Some(csv) = rec.csv.take() {
        let rows = csv.rows();
        let status = match &steady {
            Some(s) if !s.periodic => format!(
                "finished: {rows} rows; NOT periodic within {} periods (period-to-period scatter {:.2e}, --periodicity {})",
                s.periods_simulated,
                s.period_scatter,
                s.periodicity.name()
            ),
            _ => format!("finished: {rows} rows"),
        };
        csv.finish(&status)?;
    }

    // --- plot ---
    if let Some(path) = &args.plot {
        plot(path, &model, &rec, analytic.as_ref(), steady.as_ref())?;
    }

    // --- report ---
    let scheme_name = scheme.description();
    match &steady {
        Some(s) => report_steady(&model, &scheme_name, s, json)?,
        None => report_transient(args, &model, &scheme_name, &rec, dt, e0, analytic.as_ref())?,
    }
    if let Some(why) = steady.as_ref().and_then(not_periodic) {
        return Err(NotConverged(why.render(&super::CliSpelling)).into());
    }
    Ok(())
}

/// What the periodicity criterion of `s` compares, in words: "the harmonics 0..10 of DOF
/// 100" or "the state of every DOF with mass".
fn compared(s: &SteadyState) -> String {
    match s.periodicity {
        Periodicity::Response => {
            let sol = &s.solution;
            let mut dofs = sol.contact_dofs.clone();
            if !dofs.contains(&sol.response.dof) {
                dofs.insert(0, sol.response.dof);
            }
            let list: Vec<String> = dofs.iter().map(|d| d.to_string()).collect();
            format!(
                "the harmonics 0..{} of DOF{} {}",
                sol.harmonics,
                if dofs.len() == 1 { "" } else { "s" },
                list.join(", ")
            )
        }
        Periodicity::State => "the state of every DOF with mass".to_string(),
    }
}

fn report_steady(model: &Model, scheme: &str, s: &SteadyState, json: Option<String>) -> Result<()> {
    if let Some(json) = json {
        crate::outln!("{json}")?;
        return Ok(());
    }
    let sol = &s.solution;
    crate::outln!(
        "{} at {} Hz: {scheme}, {} steps per period",
        crate::output::one_line(&model.name),
        sol.frequency_hz,
        sol.samples
    )?;
    let scale = match s.periodicity {
        Periodicity::Response => "of their largest displacement",
        Periodicity::State => "of the largest displacement amplitude",
    };
    if s.periodic {
        crate::outln!(
            "periodic after {} periods: {} changed by at most {:.2e} {scale} per period over the last 2 periods \
             (period-to-period scatter < tolerance {:.1e}, --periodicity {})",
            s.periods_simulated,
            compared(s),
            s.period_scatter,
            s.tolerance,
            s.periodicity.name()
        )?;
    } else {
        crate::outln!(
            "NOT periodic after {} periods: {} changed by up to {:.2e} {scale} per period over the last 2 periods \
             (period-to-period scatter >= tolerance {:.1e}, --periodicity {}); \
             the response may be quasi-periodic or chaotic, and the last period below is not a steady state",
            s.periods_simulated,
            compared(s),
            s.period_scatter,
            s.tolerance,
            s.periodicity.name()
        )?;
        if let Some(k) = s.subharmonic {
            crate::outln!("the response repeats after {k} periods (a subharmonic response)")?;
        }
    }
    for c in &sol.contacts {
        crate::outln!(
            "contact DOF {}: max {:.6e}, min {:.6e}, max force {:.6e}, a0 {:.6e}, a1 {:.6e}, b1 {:.6e}",
            c.dof,
            c.max,
            c.min,
            c.force.iter().fold(0.0f64, |m, v| m.max(*v)),
            c.coefficients[0],
            c.coefficients[1],
            c.coefficients[2]
        )?;
    }
    let r = &sol.response;
    crate::outln!(
        "DOF {}: max {:.6e}, min {:.6e}, first-harmonic amplitude {:.6e}",
        r.dof,
        r.max,
        r.min,
        r.amplitude_h1()
    )?;
    Ok(())
}

fn report_transient(
    args: &SimulateArgs,
    model: &Model,
    scheme: &str,
    rec: &Recorder,
    dt: f64,
    e0: f64,
    analytic: Option<&DroppedBarSolution>,
) -> Result<()> {
    let st = &rec.stats;
    let steps = st.steps - 1;
    let t_end = rec
        .plot_time
        .last()
        .copied()
        .unwrap_or(0.0)
        .max(steps as f64 * dt);
    if args.json {
        // `json!` would turn a NaN into null: check the numbers themselves
        crate::output::finite::check_json(
            "standard output",
            &(&st.min_gap, &st.max_force, e0, st.energy_last),
        )?;
        if st.energy_norm.is_some() {
            crate::output::finite::check_json("standard output", &st.energy_range)?;
        }
        let contacts: Vec<serde_json::Value> = (0..st.min_gap.len())
            .map(|c| {
                serde_json::json!({
                    "contact": c,
                    "dof": model.contacts[c].dofs[0],
                    "min_gap": st.min_gap[c],
                    "max_force": st.max_force[c],
                    "closed_fraction": st.closed_fraction(c),
                })
            })
            .collect();
        let mut v = serde_json::json!({
            "model": model.name,
            "scheme": scheme,
            "dt_s": dt,
            "steps": steps,
            "duration_s": steps as f64 * dt,
            "contacts": contacts,
            "energy_initial": e0,
            "energy_final": st.energy_last,
        });
        if st.energy_norm.is_some() {
            v["energy_normalized_min"] = st.energy_range.0.into();
            v["energy_normalized_max"] = st.energy_range.1.into();
        }
        if let Some(a) = analytic {
            v["analytic_period_s"] = a.period().into();
            v["analytic_contact_duration_s"] = a.contact_duration().into();
        }
        crate::outln!("{}", to_json("standard output", &v)?)?;
        return Ok(());
    }
    crate::outln!(
        "{}: {scheme}, dt = {dt:.4e} s, {steps} steps, t = 0 .. {t_end:.6e} s",
        crate::output::one_line(&model.name)
    )?;
    for c in 0..st.min_gap.len() {
        crate::outln!(
            "contact {c} (DOF {}): min gap {:.6e}, max force {:.6e}, closed in {:.1}% of the steps",
            model.contacts[c].dofs[0],
            st.min_gap[c],
            st.max_force[c],
            100.0 * st.closed_fraction(c)
        )?;
    }
    match st.energy_norm {
        Some(_) => crate::outln!(
            "energy: initial {e0:.6e}, final {:.6e}; normalised energy in [{:.6}, {:.6}]",
            st.energy_last,
            st.energy_range.0,
            st.energy_range.1
        )?,
        None => crate::outln!("energy: initial {e0:.6e}, final {:.6e}", st.energy_last)?,
    }
    if let Some(a) = analytic {
        crate::outln!(
            "closed form (dropped bar, kappa = {:.0}): period {:.6e} s, each contact lasts 2L/c = {:.6e} s",
            a.kappa(),
            a.period(),
            a.contact_duration()
        )?;
    }
    Ok(())
}

/// The gap and the (normalised) energy over time of one or more runs (labelled; the
/// closed form is overlaid when known): the paper's Fig. 5.
pub(crate) fn transient_figures(
    model: &Model,
    runs: &[(&str, &Recorder)],
    analytic: Option<&DroppedBarSolution>,
) -> [Figure; 2] {
    let mut gap = Figure {
        title: format!("{}: contact gap", model.name),
        x_label: "time [s]".into(),
        y_label: "gap".into(),
        ..Figure::default()
    };
    let several = runs.len() > 1;
    let mut color = 0;
    for (name, rec) in runs {
        for (c, g) in rec.plot_gaps.iter().enumerate().take(8) {
            let contact = format!("gap, contact {c} (DOF {})", model.contacts[c].dofs[0]);
            gap.series.push(Series {
                label: if several {
                    format!("{name}: {contact}")
                } else {
                    contact
                },
                points: rec
                    .plot_time
                    .iter()
                    .copied()
                    .zip(g.iter().copied())
                    .collect(),
                style: Style::Line,
                color,
            });
            color += 1;
        }
    }
    let first = runs[0].1;
    if let Some(a) = analytic {
        gap.series.push(Series {
            label: "closed form (docs/theory.md §12)".into(),
            points: first.plot_time.iter().map(|&t| (t, a.gap(t))).collect(),
            style: Style::Dashed,
            color: 7,
        });
    }
    gap.hlines.push(HLine {
        label: "support (gap = 0)".into(),
        y: 0.0,
    });
    let normalised = first.stats.energy_norm.is_some();
    let mut energy = Figure {
        title: if normalised {
            "Total energy, normalised by its initial value".into()
        } else {
            "Total energy".into()
        },
        x_label: "time [s]".into(),
        y_label: if normalised {
            "E / E(0)".into()
        } else {
            "energy".into()
        },
        series: Vec::new(),
        hlines: Vec::new(),
    };
    for (k, (name, rec)) in runs.iter().enumerate() {
        energy.series.push(Series {
            label: if several {
                (*name).to_string()
            } else {
                String::new()
            },
            points: rec
                .plot_time
                .iter()
                .copied()
                .zip(rec.plot_energy.iter().copied())
                .collect(),
            style: Style::Line,
            color: if several { k } else { 1 },
        });
    }
    [gap, energy]
}

fn plot(
    path: &Path,
    model: &Model,
    rec: &Recorder,
    analytic: Option<&DroppedBarSolution>,
    steady: Option<&SteadyState>,
) -> Result<()> {
    let [gap, energy] = transient_figures(model, &[("", rec)], analytic);
    let mut figures = vec![gap, energy];
    if let Some(s) = steady {
        let sol = &s.solution;
        let mut last = Figure {
            title: format!(
                "Last period at {:.4} kHz ({})",
                sol.frequency_hz / 1e3,
                if s.periodic {
                    "periodic"
                } else {
                    "NOT periodic"
                }
            ),
            x_label: "time in the period [µs]".into(),
            y_label: "contact displacement".into(),
            ..Figure::default()
        };
        for (c, series) in sol.contacts.iter().enumerate().take(8) {
            last.series.push(Series {
                label: format!("DOF {}", series.dof),
                points: sol
                    .time_s
                    .iter()
                    .zip(&series.displacement)
                    .map(|(t, q)| (t * 1e6, *q))
                    .collect(),
                style: Style::Line,
                color: c,
            });
        }
        figures.push(last);
    }
    Figure::save_stacked(&figures, path)
}
