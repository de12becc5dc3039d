//! `mshbm solve`: one periodic solution at one frequency.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use mshbm::harmonic::Quadrature;
use mshbm::method::redistributed::JacobianForm;
use mshbm::method::settings::MethodSettings;
use mshbm::request::method::{DEFAULT_HARMONICS, DEFAULT_MAX_ITERATIONS, DEFAULT_TOLERANCE};
use mshbm::request::{MethodRequest, ReceptanceKind, SolveRequest, StartKind, StartSolution};
use mshbm::solution::{MethodKind, PeriodicSolution};
use mshbm::solve::{solve_periodic, SolvePath, SolveSettings, Solved};
use mshbm::{MassKind, Model};

use super::{ModelArgs, Spelled};
use crate::output::finite::to_json;
use crate::output::status::NotConverged;
use crate::output::stream::comment_text;
use crate::output::{write_csv_atomic, OutputKind, OutputPlan};
use crate::plot::{Figure, HLine, Series, Style};

/// Periodic-solution methods.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// MS-HBM with redistributed mass: static contact per sample, semi-analytical Jacobian.
    Redistributed,
    /// General MS-HBM (paper Section 2): consistent mass, the contact and friction DOFs
    /// integrated over one period. Without friction: event-driven (impacts and releases
    /// located to round-off, Newton's impact law, a smooth residual with its Jacobian from
    /// sensitivities; Newton converges to 1e-10, e.g. the bar with impacts at 30 kHz);
    /// contact 0's impact time is an unknown, so `frf` passes its grazing as a corner, but
    /// stops where another impact in the period grazes (a square-root singularity of the
    /// period map). With friction:
    /// Moreau–Jean time stepping with a finite-difference Jacobian; its residual is
    /// piecewise affine at the scale of one step, so `frf` steps in frequency past the
    /// corners of a branch (a fold there is jumped over; the summary counts such points).
    /// `--samples` = DFT samples and time steps per period (default max(512, 32·(2H+1))).
    /// Floquet multipliers from the whole model's Moreau–Jean period map.
    Mshbm,
    /// Baseline: classical harmonic balance with the alternating frequency–time method and
    /// penalty contact kp·max(0, −g) (the paper's Fig. 11), condensed exactly onto the
    /// contact DOFs; consistent mass unless --mass redistributed; --penalty sets kp.
    HbmAft,
}

/// Mass matrix of `--method hbm-aft`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MassArg {
    /// The consistent mass of the model (the classical method).
    Consistent,
    /// The redistributed mass with a massless contact boundary, as the MS-HBM uses.
    Redistributed,
}

/// Quadrature of the Fourier coefficients of the contact displacement.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum QuadratureArg {
    /// Closed-form integrals between the located contact switching times (no aliasing).
    Exact,
    /// DFT over the samples (the paper's implementation).
    Sampled,
}

/// How the receptance at the contacts is computed (redistributed MS-HBM).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ReceptanceArg {
    /// Every mode (exact) up to 200 DOFs with mass when the modes diagonalise the damping,
    /// and up to 2000 with mass-proportional damping; modal (200 modes, at most half the
    /// DOFs with mass) above 20000 DOFs with a stiffness factor of more than 40 values per
    /// DOF (3D solids); exact otherwise.
    Auto,
    /// A sparse LU of the whole dynamic stiffness per harmonic and frequency.
    Exact,
    /// The lowest --receptance-modes modes plus the exact static compliance.
    Modal,
}

/// How Newton's linear systems are solved (redistributed MS-HBM).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum JacobianArg {
    /// Dense below 1000 unknowns, the operator from there.
    Auto,
    /// The dense Jacobian and its LU.
    Dense,
    /// GMRES on the Jacobian's action, preconditioned by an earlier Jacobian's factors.
    Operator,
}

/// Method settings shared by `solve` and `frf`.
#[derive(Args, Debug, Clone)]
pub struct MethodArgs {
    /// Method.
    #[arg(long, value_enum, default_value_t = Method::Redistributed)]
    pub method: Method,

    /// Samples per period NS (≥ 2H+1). Default: max(256, 16·(2H+1)), enough to resolve the
    /// kinks of the contact displacement and to locate the contact switches.
    #[arg(long, value_name = "NS")]
    pub samples: Option<usize>,

    /// Quadrature of the Fourier coefficients of the contact displacement (hbm-aft: of the
    /// penalty force). Default: exact for redistributed; sampled for hbm-aft (the classical
    /// AFT), where exact integrates the force between the located penetration times and
    /// gives a smooth residual, so that continuation passes folds at stiff penalties.
    #[arg(long, value_enum)]
    pub quadrature: Option<QuadratureArg>,

    /// Mass matrix of --method hbm-aft: consistent (default, the classical method) or
    /// redistributed (massless contact boundary, as the MS-HBM), to separate the effect of
    /// the contact treatment from that of the mass. The MS-HBM methods fix their mass.
    #[arg(long, value_enum)]
    pub mass: Option<MassArg>,

    /// Penalty stiffness kp of --method hbm-aft (contact force kp·max(0, −g)): a stiffness
    /// [force/length, e.g. 1e8 N/mm], or a multiple of the contact DOF's own stiffness
    /// written with a trailing x (e.g. 100x). Default: 100x (the paper's bar has
    /// K_NN = EA/h = 1.05e6 N/mm, so kp = 1.05e8 N/mm). The result depends on kp;
    /// stiffer is closer to exact contact but costs Newton iterations and continuation
    /// steps. frf takes a comma-separated list and traces one branch per kp.
    #[arg(
        long,
        value_name = "KP",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub penalty: Vec<String>,

    /// Tangential penalty kt of --method hbm-aft on contacts with friction (`mu` of an
    /// interface): the spring of the Jenkins element in series with the Coulomb slider
    /// (docs/theory.md (T161)), a stiffness [force/length] or a multiple of the structure's
    /// stiffness along the contact's tangent written with a trailing x. Default: kt = kp.
    #[arg(long, value_name = "KT", allow_hyphen_values = true)]
    pub tangential_penalty: Option<String>,

    /// Newton tolerance: max-norm of the residual relative to the model's length scale
    /// (the largest gap or static deflection of the contact DOFs).
    #[arg(long, default_value_t = DEFAULT_TOLERANCE, allow_negative_numbers = true)]
    pub tolerance: f64,

    /// Newton iteration limit per solution.
    #[arg(long, default_value_t = DEFAULT_MAX_ITERATIONS)]
    pub max_iterations: usize,

    /// Model DOF whose response is reported (numbered as in the model file, from 0).
    /// Default: the first contact DOF.
    #[arg(long)]
    pub dof: Option<usize>,

    /// Floquet multipliers (redistributed MS-HBM) in a reduced basis of N fixed-interface
    /// modes of the linear part plus the statically condensed interface correction; N at
    /// least the number of linear DOFs means the full space. Default: the full space up to
    /// 200 linear DOFs, 100 modes above. The reduced multipliers converge slowly with N
    /// (the contact switching excites all modes); see the README section on stability.
    #[arg(long, value_name = "N")]
    pub stability_modes: Option<usize>,

    /// Receptance of the structure at its contacts (redistributed MS-HBM,
    /// docs/theory.md (T125), (T130)): exact (a sparse LU of the whole structure per
    /// harmonic and frequency) or modal (the lowest modes plus the exact static compliance;
    /// one modal analysis at set-up, then no factorization per frequency). Default: auto
    /// (every mode, which is exact, for up to 200 DOFs with mass when the modes
    /// diagonalise the damping and up to 2000 with mass-proportional damping; else exact,
    /// or 200 modes for large 3D models).
    #[arg(long, value_enum, default_value_t = ReceptanceArg::Auto)]
    pub receptance: ReceptanceArg,

    /// Modes of --receptance modal (default 200, at most the DOFs with mass).
    #[arg(long, value_name = "N")]
    pub receptance_modes: Option<usize>,

    /// Newton's linear systems (redistributed MS-HBM, docs/theory.md §18): dense (form the
    /// Jacobian, LU) or operator (GMRES on its action, preconditioned by the factors of an
    /// earlier Jacobian; for many contacts times harmonics). Default: auto (the operator
    /// from 1000 unknowns).
    #[arg(long, value_enum, default_value_t = JacobianArg::Auto)]
    pub jacobian: JacobianArg,
}

impl MethodArgs {
    /// The library's request of these options (its checks and defaults:
    /// [`mshbm::request::MethodRequest`]).
    pub fn request(&self) -> MethodRequest {
        MethodRequest {
            method: match self.method {
                Method::Redistributed => MethodKind::Redistributed,
                Method::Mshbm => MethodKind::General,
                Method::HbmAft => MethodKind::HbmAft,
            },
            samples: self.samples,
            quadrature: self.quadrature.map(|q| match q {
                QuadratureArg::Exact => Quadrature::Exact,
                QuadratureArg::Sampled => Quadrature::Sampled,
            }),
            mass: self.mass.map(|m| match m {
                MassArg::Consistent => MassKind::Consistent,
                MassArg::Redistributed => MassKind::Redistributed,
            }),
            penalty: self.penalty.clone(),
            tangential_penalty: self.tangential_penalty.clone(),
            tolerance: self.tolerance,
            max_iterations: self.max_iterations,
            dof: self.dof,
            stability_modes: self.stability_modes,
            receptance: match self.receptance {
                ReceptanceArg::Auto => ReceptanceKind::Auto,
                ReceptanceArg::Exact => ReceptanceKind::Exact,
                ReceptanceArg::Modal => ReceptanceKind::Modal,
            },
            receptance_modes: self.receptance_modes,
            jacobian: match self.jacobian {
                JacobianArg::Auto => JacobianForm::Auto,
                JacobianArg::Dense => JacobianForm::Dense,
                JacobianArg::Operator => JacobianForm::Operator,
            },
        }
    }
}

/// Arguments of `mshbm solve`.
#[derive(Args, Debug)]
pub struct SolveArgs {
    #[command(flatten)]
    pub model: ModelArgs,

    /// Excitation frequency [Hz].
    #[arg(long, value_name = "HZ", allow_negative_numbers = true)]
    pub frequency: f64,

    /// Number of harmonics H of the linear part.
    #[arg(long, default_value_t = DEFAULT_HARMONICS)]
    pub harmonics: usize,

    #[command(flatten)]
    pub method: MethodArgs,

    /// Skip the Floquet multipliers (stability), computed by default for methods that
    /// provide them (the redistributed MS-HBM; see --stability-modes for large models).
    #[arg(long)]
    pub no_stability: bool,

    /// Print the solution as one JSON object on stdout.
    #[arg(long)]
    pub json: bool,

    /// Write the time series over one period as CSV (time [s], displacement, gap and
    /// force of each contact). A solution that did not converge ends with a line
    /// `# not converged: ...` (and the exit status is 2).
    #[arg(long, value_name = "FILE")]
    pub output: Option<PathBuf>,

    /// Plot the contact displacement over one period with the gap line (the paper's
    /// Fig. 10); .svg or .png.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,

    /// Write the contact state along each contact interface as CSV, one row per contact
    /// and time sample: interface, contact index, node(s), position along the interface,
    /// time [s], gap, force (a model without interfaces: every contact, by index).
    #[arg(long, value_name = "FILE")]
    pub contacts_csv: Option<PathBuf>,

    /// Draw the contact state along each interface over one period (position × time /
    /// period, coloured by the contact force and, in a second panel, by the gap); .svg or
    /// .png.
    #[arg(long, value_name = "FILE")]
    pub contact_map: Option<PathBuf>,

    /// Write the deformed mesh over one period for ParaView into this directory (created if
    /// missing): `solution_0000.vtu …` (point data `displacement`, every DOF of the model,
    /// from the solution's harmonics extended to the whole model) and `solution.pvd`, whose
    /// time steps are the sample times [s].
    #[arg(long, value_name = "DIR")]
    pub vtk: Option<PathBuf>,

    /// Time samples over the period written by --vtk.
    #[arg(long, value_name = "N", default_value_t = 32, requires = "vtk")]
    pub vtk_samples: usize,

    /// Start Newton from this solution instead of the linear response: the `--json` output
    /// of an earlier `solve` of the same model and method, at this or another frequency and
    /// with any number of harmonics (added ones start at zero, surplus ones are dropped), or
    /// of `simulate --steady-state --json` (redistributed scheme) for the redistributed
    /// MS-HBM.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["sweep_from", "start"])]
    pub from_solution: Option<PathBuf>,

    /// Where Newton starts: auto (the contact-free linear response; if Newton does not
    /// converge from it, the branch is continued in frequency from f/2, or f/4, … f/64,
    /// whichever is the highest at which Newton converges, up to f) or linear (the linear
    /// response only, the paper's start).
    #[arg(long, value_enum, default_value_t = StartArg::Auto)]
    pub start: StartArg,

    /// Trace the branch from this frequency [Hz] (Newton from the linear response there) to
    /// --sweep-to, and report every solution at --frequency the branch crosses: where the
    /// branch folds, several solutions coexist (e.g. above a resonance bent by contact,
    /// where the contact-free solution coexists with contacting ones). The first one met
    /// is written; the others are listed.
    #[arg(
        long,
        value_name = "HZ",
        conflicts_with = "start",
        allow_negative_numbers = true
    )]
    pub sweep_from: Option<f64>,

    /// End of the sweep [Hz] (default: 1.5 × --frequency, or --frequency / 1.5 when the
    /// sweep starts above it).
    #[arg(
        long,
        value_name = "HZ",
        requires = "sweep_from",
        allow_negative_numbers = true
    )]
    pub sweep_to: Option<f64>,
}

/// `--start` values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum StartArg {
    /// The linear response, then continuation from a lower frequency if Newton fails.
    Auto,
    /// The linear response only.
    Linear,
}

/// The time series over one period as CSV: time_s, then q_dof{d},gap_c{k},force_c{k} per
/// contact.
pub fn time_series_csv(s: &PeriodicSolution) -> String {
    let mut out = String::from("time_s");
    for (k, c) in s.contacts.iter().enumerate() {
        let _ = write!(out, ",q_dof{},gap_c{k},force_c{k}", c.dof);
    }
    out.push('\n');
    for (j, t) in s.time_s.iter().enumerate() {
        let _ = write!(out, "{t:.12e}");
        for c in &s.contacts {
            let _ = write!(
                out,
                ",{:.12e},{:.12e},{:.12e}",
                c.displacement[j], c.gap[j], c.force[j]
            );
        }
        out.push('\n');
    }
    out
}

/// Fig. 10: contact displacement over one period, with the displacement at which the gap
/// closes.
pub fn period_figure(model: &Model, solutions: &[PeriodicSolution]) -> Figure {
    let mut fig = Figure {
        title: format!(
            "Contact displacement over one period at {:.4} kHz",
            solutions[0].frequency_hz / 1e3
        ),
        x_label: "time [µs]".into(),
        y_label: "contact displacement q_N".into(),
        ..Figure::default()
    };
    for (k, s) in solutions.iter().enumerate() {
        let c = &s.contacts[0];
        fig.series.push(Series {
            label: format!("H = {}", s.harmonics),
            points: s
                .time_s
                .iter()
                .zip(&c.displacement)
                .map(|(t, q)| (t * 1e6, *q))
                .collect(),
            style: Style::Line,
            color: k,
        });
    }
    if let Some(c) = model.contacts.first() {
        if c.dofs.len() == 1 {
            fig.hlines.push(HLine {
                label: format!("gap (q = {:.4})", -c.gap / c.w[0]),
                y: -c.gap / c.w[0],
            });
        }
    }
    fig
}

/// The deformed mesh over one period (`--vtk`): the solution's harmonics on every DOF of
/// the model, evaluated at `--vtk-samples` times.
fn write_vtk(
    model: &Model,
    method: &MethodSettings,
    solution: &PeriodicSolution,
    files: &[PathBuf],
    pvd: &std::path::Path,
) -> Result<()> {
    let system = model.system(method.mass_kind())?;
    let omega = 2.0 * std::f64::consts::PI * solution.frequency_hz;
    let field = mshbm::simulation::field_harmonics(
        &system,
        model,
        solution,
        omega,
        std::path::Path::new("the solution"),
    )?;
    let h = solution.harmonics;
    let period = 1.0 / solution.frequency_hz;
    let count = files.len();
    crate::vtk::write_collection(files, pvd, |j| {
        let t = period * j as f64 / count as f64;
        let displacement: Vec<f64> = field
            .iter()
            .map(|c| {
                c[0] + (1..=h)
                    .map(|k| {
                        let phase = k as f64 * omega * t;
                        c[2 * k - 1] * phase.cos() + c[2 * k] * phase.sin()
                    })
                    .sum::<f64>()
            })
            .collect();
        Ok((
            t,
            crate::vtk::unstructured_grid(model, &[("displacement", &displacement)])?,
        ))
    })
}

/// Bytes of text per contact and sample in `--contacts-csv` (a row of seven columns) and
/// in `--output` (three numbers of 20 characters), and per sample of a plot's series.
const CONTACTS_CSV_ROW_BYTES: u64 = 160;
const OUTPUT_CSV_BYTES_PER_CONTACT: u64 = 64;
const PLOT_BYTES_PER_SAMPLE: u64 = 64;

/// Check, before solving, that the outputs built in memory (each CSV is formed whole, then
/// written atomically) fit the memory budget: they grow with the samples (`--samples`) and
/// the contacts. The method's own plan counts its arrays; this counts the text.
fn check_output_memory(args: &SolveArgs, model: &Model) -> Result<()> {
    let samples = args.method.request().samples_for(args.harmonics) as u64;
    let contacts = model.contacts.len().max(1) as u64;
    let per_sample = |option: &str, bytes: u64| (option.to_string(), samples.checked_mul(bytes));
    let mut outputs = Vec::new();
    if args.output.is_some() {
        outputs.push(per_sample(
            "--output",
            contacts
                .saturating_mul(OUTPUT_CSV_BYTES_PER_CONTACT)
                .saturating_add(24),
        ));
    }
    if args.contacts_csv.is_some() {
        outputs.push(per_sample(
            "--contacts-csv",
            contacts.saturating_mul(CONTACTS_CSV_ROW_BYTES),
        ));
    }
    if args.contact_map.is_some() {
        outputs.push(per_sample(
            "--contact-map",
            contacts.saturating_mul(PLOT_BYTES_PER_SAMPLE),
        ));
    }
    if args.plot.is_some() {
        outputs.push(per_sample("--plot", PLOT_BYTES_PER_SAMPLE));
    }
    let limits = args.model.limits();
    for (option, bytes) in outputs {
        limits.check_memory(
            &format!("{option} ({samples} samples × {contacts} contacts)"),
            bytes,
        )?;
    }
    Ok(())
}

/// `", stable"` / `", unstable"` when the multipliers are known.
fn stability_word(s: &PeriodicSolution) -> &'static str {
    match &s.stability {
        Some(st) if st.stable => ", stable",
        Some(_) => ", unstable",
        None => "",
    }
}

/// The library's request of `mshbm solve`, without its start solution.
fn solve_request(args: &SolveArgs) -> SolveRequest {
    SolveRequest {
        harmonics: args.harmonics,
        method: args.method.request(),
        stability: !args.no_stability,
        start: match args.start {
            StartArg::Auto => StartKind::Auto,
            StartArg::Linear => StartKind::Linear,
        },
        sweep_from: args.sweep_from,
        sweep_to: args.sweep_to,
        ..SolveRequest::new(args.frequency)
    }
}

/// The library's settings of `mshbm solve` (`--from-solution` read here).
pub fn solve_settings(args: &SolveArgs, model: &Model) -> Result<SolveSettings> {
    let mut request = solve_request(args);
    if let Some(path) = &args.from_solution {
        request.start_solution = Some(StartSolution {
            source: path.display().to_string(),
            solution: super::read_solution(path, &args.model.limits())?,
        });
    }
    Ok(SolveSettings {
        observer: Some(crate::progress::newton_progress()),
        branch_observer: Some(crate::progress::branch_progress()),
        setup_observer: Some(crate::progress::setup_progress()),
        ..request.settings(model, args.model.limits()).spelled()?
    })
}

pub fn run(args: &SolveArgs) -> Result<()> {
    let method = solve_request(args).method().spelled()?;
    let model = args.model.load()?;
    let vtk_files = match &args.vtk {
        Some(dir) => {
            if args.vtk_samples == 0 {
                bail!("--vtk-samples must be at least 1");
            }
            crate::vtk::check_collection_memory(
                &format!("--vtk-samples {}", args.vtk_samples),
                dir,
                args.vtk_samples,
                &model,
                &args.model.limits(),
            )?;
            std::fs::create_dir_all(dir)
                .with_context(|| format!("--vtk {}: cannot create the directory", dir.display()))?;
            Some(crate::vtk::collection_paths(
                dir,
                "solution",
                args.vtk_samples,
            ))
        }
        None => None,
    };
    check_output_memory(args, &model)?;
    let mut plan = OutputPlan::new();
    if let Some((files, pvd)) = &vtk_files {
        for f in files.iter().chain(std::iter::once(pvd)) {
            plan.output("--vtk", Some(f), OutputKind::Text);
        }
    }
    if let Some(p) = &args.from_solution {
        plan.input("the --from-solution file", p);
    }
    plan.input("the model file", &args.model.model)
        .inputs("a file the model reads", &model.input_files)
        .output("--output", args.output.as_deref(), OutputKind::Data)
        .output("--plot", args.plot.as_deref(), OutputKind::Plot)
        .output(
            "--contacts-csv",
            args.contacts_csv.as_deref(),
            OutputKind::Data,
        )
        .output(
            "--contact-map",
            args.contact_map.as_deref(),
            OutputKind::Plot,
        )
        .check()?;
    let solved = solve_periodic(
        &model,
        &method,
        args.frequency,
        &solve_settings(args, &model)?,
    );
    // a signal stops a long fallback continuation (its observer returns an error): report
    // the interruption, not that error
    crate::output::interrupt::check("nothing was written")?;
    let solved = solved?;
    let not_converged = solved.not_converged(args.frequency);
    let Solved {
        solution,
        label,
        stability_error,
        path,
        others,
        ..
    } = solved;
    if let Some(e) = stability_error {
        crate::note!("note: stability not computed: {e}");
    }
    if let SolvePath::Continuation {
        from_hz,
        points,
        folds,
    } = path
    {
        crate::note!(
            "note: reached by continuation in frequency from {} Hz ({points} points, {folds} fold{} on the way{})",
            (from_hz * 1e6).round() / 1e6,
            if folds == 1 { "" } else { "s" },
            if folds > 0 {
                ": the branch turns, so several solutions coexist over part of the range"
            } else {
                ""
            }
        );
    }
    if !others.is_empty() {
        crate::note!(
            "note: {} periodic solutions coexist at {} Hz on the traced branch; written: the first met (response max {:.6e}, min {:.6e}{}); the others:",
            others.len() + 1,
            args.frequency,
            solution.response.max,
            solution.response.min,
            stability_word(&solution)
        );
        for (k, o) in others.iter().enumerate() {
            crate::note!(
                "  solution {}: response max {:.6e}, min {:.6e}, largest contact force {:.6e}{}",
                k + 2,
                o.response.max,
                o.response.min,
                o.contacts
                    .iter()
                    .flat_map(|c| c.force.iter())
                    .fold(0.0f64, |m, v| m.max(*v)),
                stability_word(o)
            );
        }
    }
    let json = if args.json {
        Some(to_json("standard output", &solution)?)
    } else {
        None
    };
    if let Some(path) = &args.output {
        let mut csv = time_series_csv(&solution);
        if let Some(why) = &not_converged {
            csv.push_str(&format!("# not converged: {}\n", comment_text(why)));
        }
        write_csv_atomic(path, &csv)?;
    }
    if let Some(path) = &args.contacts_csv {
        let mut csv = crate::contact_map::contacts_csv(&model, &solution);
        if let Some(why) = &not_converged {
            csv.push_str(&format!("# not converged: {}\n", comment_text(why)));
        }
        write_csv_atomic(path, &csv)?;
    }
    if let Some(path) = &args.contact_map {
        crate::contact_map::save_contact_map(&model, &solution, path)?;
    }
    if let Some((files, pvd)) = &vtk_files {
        write_vtk(&model, &method, &solution, files, pvd)?;
    }
    if let Some(path) = &args.plot {
        let mut fig = period_figure(&model, std::slice::from_ref(&solution));
        if not_converged.is_some() {
            fig.title.push_str(" — NOT CONVERGED");
        }
        fig.save(path)?;
    }
    if let Some(json) = json {
        crate::outln!("{json}")?;
    } else {
        crate::outln!(
            "{} at {} Hz, H = {}, {} samples, {} quadrature, {label}",
            crate::output::one_line(&model.name),
            args.frequency,
            solution.harmonics,
            solution.samples,
            solution.quadrature
        )?;
        crate::outln!(
            "converged: {} after {} Newton iterations (relative residual {:.2e})",
            solution.converged,
            solution.iterations,
            solution.residual_norm
        )?;
        if let Some(st) = &solution.stability {
            crate::outln!(
                "{}: largest Floquet multiplier modulus {:.6}",
                if st.stable { "stable" } else { "unstable" },
                st.max_multiplier
            )?;
        } else if let Some(why) = &solution.stability_unknown {
            crate::outln!("stability unknown: {why}")?;
        }
        for c in &solution.contacts {
            crate::outln!(
                "contact DOF {}: max {:.6e}, min {:.6e}, max force {:.6e}",
                c.dof,
                c.max,
                c.min,
                c.force.iter().fold(0.0f64, |m, v| m.max(*v))
            )?;
            if solution.method == MethodKind::HbmAft {
                crate::outln!(
                    "  penalty contact: max penetration −g {:.6e} (at the samples)",
                    c.gap.iter().fold(f64::NEG_INFINITY, |m, g| m.max(-g))
                )?;
            }
        }
        let r = &solution.response;
        crate::outln!(
            "DOF {}: max {:.6e}, min {:.6e}, first-harmonic amplitude {:.6e}",
            r.dof,
            r.max,
            r.min,
            r.amplitude_h1()
        )?;
    }
    if let Some(why) = not_converged {
        return Err(NotConverged(format!(
            "{why}; every output is marked as not converged (exit status 2)"
        ))
        .into());
    }
    Ok(())
}
