//! Fig. 9: the frequency response diagram of the clamped bar, gap 0.2, by the
//! redistributed MS-HBM with H = 1, 3, 5, 10 (unstable parts dashed), against time
//! integration to a steady state (Moreau–Jean, e_N = 0, consistent mass — the paper's
//! reference) at a set of frequencies. Where the simulation does not become periodic, its
//! last period is drawn with hollow markers and the min–max band of the contact
//! displacement over the last periods as a bar.
//!
//! Branches: `mshbm frf examples/clamped_bar.toml --from 1000 --to 100000 --harmonics H
//! --set damping.first_mode_ratio=0.01 --stability`; time integration: `mshbm simulate
//! examples/clamped_bar.toml --set damping.first_mode_ratio=0.01 --scheme moreau
//! --restitution 0 --frequency F --steady-state --periods P --steps-per-period N`.

use std::cell::RefCell;
use std::fmt::Write as _;
use std::time::Instant;

use anyhow::Result;
use mshbm::integrate::steady_state::{simulate_to_steady_state, Periodicity, SteadyStateOptions};
use mshbm::integrate::{Integrator, Settings};

use super::run::Progress;
use super::{Job, Output};
use mshbm::frd::{
    branch_values_at, trace_frd_branch, BifurcationReport, BranchReport, FoldReport, FrdPoint,
    FrdSettings, TracedBranch,
};
use mshbm::method::settings::MethodSettings;

use super::{models, FigureReport, Setup, DAMPING_OVERRIDE, DAMPING_TEXT};
use crate::commands::frf::{frd_csv_header, frd_csv_row, frd_figure};
use crate::commands::simulate::{scheme_and_mass, SchemeArg, SIMULATE_HARMONICS};
use crate::output::write_csv_atomic;
use crate::plot::{Series, Style};

/// CSV header of fig9_time_integration.csv.
pub const TI_CSV_HEADER: &str = "frequency_hz,periodic,periods_simulated,period_change,max_qn,min_qn,band_periods,band_max_qn,band_min_qn";

/// One traced branch of Fig. 9.
pub(crate) struct Traced9 {
    pub harmonics: usize,
    pub report: BranchReport,
    pub folds: Vec<FoldReport>,
    pub bifurcations: Vec<BifurcationReport>,
    pub seconds: f64,
}

/// One time integration to a steady state.
pub(crate) struct Integration {
    pub frequency_hz: f64,
    pub periodic: bool,
    pub periods_simulated: usize,
    pub period_change: f64,
    pub subharmonic: Option<usize>,
    /// Extremes of the contact DOF over the last period.
    pub max: f64,
    pub min: f64,
    /// Extremes over the last `band_periods` periods.
    pub band_periods: usize,
    pub band_max: f64,
    pub band_min: f64,
    pub seconds: f64,
}

/// What Fig. 9 computes.
pub(crate) struct Plan {
    from_hz: f64,
    to_hz: f64,
    harmonics: Vec<usize>,
    ti_frequencies_hz: Vec<f64>,
    steps_per_period: usize,
    max_periods: usize,
    band_periods: usize,
}

impl Plan {
    pub fn new(setup: &Setup) -> Result<Self> {
        Ok(if setup.quick {
            Plan {
                from_hz: 15_000.0,
                to_hz: 17_000.0,
                harmonics: vec![1, 3, 5, 10],
                ti_frequencies_hz: vec![10_000.0, 16_000.0],
                steps_per_period: 500,
                max_periods: 60,
                band_periods: 10,
            }
        } else {
            Plan {
                from_hz: 1_000.0,
                to_hz: 100_000.0,
                harmonics: vec![1, 3, 5, 10],
                ti_frequencies_hz: (1..=10).map(|k| k as f64 * 10_000.0).collect(),
                steps_per_period: 2000,
                max_periods: 500,
                band_periods: 20,
            }
        })
    }

    fn frf_argv(&self, h: usize) -> Vec<String> {
        [
            "frf",
            models::CLAMPED_BAR_PATH,
            "--from",
            &self.from_hz.to_string(),
            "--to",
            &self.to_hz.to_string(),
            "--harmonics",
            &h.to_string(),
            "--set",
            DAMPING_OVERRIDE,
            "--stability",
        ]
        .map(String::from)
        .to_vec()
    }

    fn simulate_argv(&self, frequency_hz: f64) -> Vec<String> {
        [
            "simulate",
            models::CLAMPED_BAR_PATH,
            "--set",
            DAMPING_OVERRIDE,
            "--scheme",
            "moreau",
            "--restitution",
            "0",
            "--frequency",
            &frequency_hz.to_string(),
            "--steady-state",
            "--periods",
            &self.max_periods.to_string(),
            "--steps-per-period",
            &self.steps_per_period.to_string(),
        ]
        .map(String::from)
        .to_vec()
    }

    /// One job per number of harmonics (the largest first: they take longest).
    pub fn branch_jobs<'a>(&'a self, progress: &'a Progress) -> Vec<Job<'a>> {
        let mut order = self.harmonics.clone();
        order.sort_by_key(|&h| std::cmp::Reverse(h));
        order
            .into_iter()
            .map(|h| Job {
                name: format!("Fig. 9 branch H = {h}"),
                work: Box::new(move || {
                    let t0 = Instant::now();
                    let model = models::load(
                        models::CLAMPED_BAR,
                        models::CLAMPED_BAR_PATH,
                        &[DAMPING_OVERRIDE.to_string()],
                    )?;
                    let mut settings = FrdSettings::new(self.from_hz, self.to_hz);
                    settings.stability = true;
                    let mut observer = progress.branch(format!("Fig. 9 branch H = {h}"));
                    let TracedBranch {
                        report,
                        folds,
                        bifurcations,
                        ..
                    } = trace_frd_branch(
                        &model,
                        &MethodSettings::redistributed(h),
                        &settings,
                        false,
                        &mut observer,
                    )?;
                    progress.line(
                        &format!("Fig. 9 branch H = {h}"),
                        &format!("{} points, {}", report.points.len(), report.stop),
                    );
                    Ok(Output::Branch9(Traced9 {
                        harmonics: h,
                        report,
                        folds,
                        bifurcations,
                        seconds: t0.elapsed().as_secs_f64(),
                    }))
                }),
            })
            .collect()
    }

    /// One job per time-integration frequency (the highest first: most periods to settle).
    pub fn time_integration_jobs<'a>(&'a self, progress: &'a Progress) -> Vec<Job<'a>> {
        let mut order = self.ti_frequencies_hz.clone();
        order.sort_by(|a, b| b.total_cmp(a));
        order
            .into_iter()
            .map(|f| Job {
                name: format!("Fig. 9 time integration {:.1} kHz", f / 1e3),
                work: Box::new(move || {
                    let part = format!("Fig. 9 time integration {:.1} kHz", f / 1e3);
                    Ok(Output::TimeIntegration(self.integrate(f, progress, &part)?))
                }),
            })
            .collect()
    }

    /// Time integration from rest to a steady state (the path of `mshbm simulate
    /// --steady-state`), recording the extremes of the contact DOF per period.
    fn integrate(&self, frequency_hz: f64, progress: &Progress, part: &str) -> Result<Integration> {
        let t0 = Instant::now();
        let model = models::load(
            models::CLAMPED_BAR,
            models::CLAMPED_BAR_PATH,
            &[DAMPING_OVERRIDE.to_string()],
        )?;
        // the simulate command's Moreau-Jean scheme with e_N = 0 (simulate_argv)
        let (scheme, kind) = scheme_and_mass(SchemeArg::Moreau, Some(0.0), None);
        let system = model.system(kind)?;
        let omega = 2.0 * std::f64::consts::PI * frequency_hz;
        let n = self.steps_per_period;
        let mut integrator = Integrator::new(
            &system,
            &Settings {
                dt: 2.0 * std::f64::consts::PI / omega / n as f64,
                scheme,
                omega: Some(omega),
                energy_offset: 0.0,
            },
        )?;
        let contact = integrator.contact_first_dofs()[0];
        let options = SteadyStateOptions {
            steps_per_period: n,
            max_periods: self.max_periods,
            tolerance: Periodicity::State.default_tolerance(),
            harmonics: SIMULATE_HARMONICS,
            response_dof: contact.0,
            periodicity: Periodicity::State,
        };
        // extremes of the contact DOF in the running period, and per finished period
        let extremes = RefCell::new(((f64::INFINITY, f64::NEG_INFINITY), Vec::new()));
        let mut last_line = Instant::now();
        let steady = simulate_to_steady_state(
            &mut integrator,
            omega,
            &options,
            |it| {
                let q = it.q()[contact.1];
                let mut e = extremes.borrow_mut();
                e.0 = (e.0 .0.min(q), e.0 .1.max(q));
            },
            |p, change| {
                let mut e = extremes.borrow_mut();
                let running = std::mem::replace(&mut e.0, (f64::INFINITY, f64::NEG_INFINITY));
                e.1.push(running);
                if last_line.elapsed().as_secs_f64() >= 5.0 {
                    last_line = Instant::now();
                    progress.line(
                        part,
                        &format!("period {p}, period-to-period change {change:.2e}"),
                    );
                }
            },
        )?;
        let per_period = extremes.into_inner().1;
        let band_periods = self.band_periods.min(per_period.len());
        let (band_min, band_max) = per_period[per_period.len() - band_periods..]
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &(a, b)| {
                (lo.min(a), hi.max(b))
            });
        let c = &steady.solution.contacts[0];
        Ok(Integration {
            frequency_hz,
            periodic: steady.periodic,
            periods_simulated: steady.periods_simulated,
            period_change: steady.period_change,
            subharmonic: steady.subharmonic,
            max: c.max,
            min: c.min,
            band_periods,
            band_max,
            band_min,
            seconds: t0.elapsed().as_secs_f64(),
        })
    }

    /// Assemble the figure, its CSV files and its summary from the finished parts.
    pub fn finish(
        &self,
        setup: &Setup,
        branches: Vec<Result<Traced9, (String, String)>>,
        integrations: Vec<Result<Integration, (String, String)>>,
    ) -> FigureReport {
        match self.assemble(setup, branches, integrations) {
            Ok(r) => r,
            Err(e) => FigureReport {
                section: format!("## Fig. 9\n\n**FAILED**: {e:#}\n"),
                files: vec![],
                problems: vec![format!("Fig. 9: {e:#}")],
            },
        }
    }

    fn assemble(
        &self,
        setup: &Setup,
        branches: Vec<Result<Traced9, (String, String)>>,
        integrations: Vec<Result<Integration, (String, String)>>,
    ) -> Result<FigureReport> {
        let mut problems = Vec::new();
        let mut traced: Vec<Traced9> = Vec::new();
        for b in branches {
            match b {
                Ok(t) => traced.push(t),
                Err((name, e)) => problems.push(format!("{name}: FAILED: {e}")),
            }
        }
        traced.sort_by_key(|t| t.harmonics);
        let mut sims: Vec<Integration> = Vec::new();
        for s in integrations {
            match s {
                Ok(t) => sims.push(t),
                Err((name, e)) => problems.push(format!("{name}: FAILED: {e}")),
            }
        }
        sims.sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
        let incomplete: Vec<&Traced9> = traced.iter().filter(|t| !t.report.completed).collect();
        for t in &incomplete {
            problems.push(format!(
                "Fig. 9 branch {} INCOMPLETE: {} (the points up to there are kept)",
                t.report.label, t.report.stop
            ));
        }

        // CSV files
        let frd_csv = "fig9_frd.csv";
        let mut csv = frd_csv_header(false);
        csv.push('\n');
        for t in &traced {
            for p in &t.report.points {
                csv.push_str(&frd_csv_row(p, t.harmonics, None));
                csv.push('\n');
            }
        }
        write_csv_atomic(&setup.file(frd_csv), &csv)?;
        let ti_csv = "fig9_time_integration.csv";
        let mut csv = String::from(TI_CSV_HEADER);
        csv.push('\n');
        for s in &sims {
            let _ = writeln!(
                csv,
                "{:.3},{},{},{:.3e},{:.9e},{:.9e},{},{:.9e},{:.9e}",
                s.frequency_hz,
                s.periodic,
                s.periods_simulated,
                s.period_change,
                s.max,
                s.min,
                s.band_periods,
                s.band_max,
                s.band_min
            );
        }
        write_csv_atomic(&setup.file(ti_csv), &csv)?;

        // figure
        let model = models::load(
            models::CLAMPED_BAR,
            models::CLAMPED_BAR_PATH,
            &[DAMPING_OVERRIDE.to_string()],
        )?;
        let reports: Vec<BranchReport> = traced.iter().map(|t| t.report.clone()).collect();
        let folds: Vec<FoldReport> = traced.iter().flat_map(|t| t.folds.clone()).collect();
        let mut title = "Fig. 9: FRD, gap 0.2, 1 % modal damping of mode 1".to_string();
        for t in &incomplete {
            let reached = t
                .report
                .points
                .iter()
                .map(|p| p.frequency_hz)
                .fold(f64::NEG_INFINITY, f64::max);
            let _ = write!(
                title,
                " — {} INCOMPLETE (to {:.1} kHz)",
                t.report.label,
                reached / 1e3
            );
        }
        let mut fig = frd_figure(
            &model,
            &reports,
            &folds,
            &[],
            &title,
            "contact displacement q_N [mm] (max, min)",
        );
        fig.x_label = "frequency [kHz] (MS-HBM: unstable parts dashed)".into();
        let periodic: Vec<&Integration> = sims.iter().filter(|s| s.periodic).collect();
        let wandering: Vec<&Integration> = sims.iter().filter(|s| !s.periodic).collect();
        if !periodic.is_empty() {
            fig.series.push(Series {
                label: "time integration e_N = 0, periodic (max, min)".into(),
                points: periodic
                    .iter()
                    .flat_map(|s| [(s.frequency_hz / 1e3, s.max), (s.frequency_hz / 1e3, s.min)])
                    .collect(),
                style: Style::Markers,
                color: 5,
            });
        }
        if !wandering.is_empty() {
            fig.series.push(Series {
                label: "time integration, NOT periodic: last period (max, min)".into(),
                points: wandering
                    .iter()
                    .flat_map(|s| [(s.frequency_hz / 1e3, s.max), (s.frequency_hz / 1e3, s.min)])
                    .collect(),
                style: Style::HollowMarkers,
                color: 6,
            });
            fig.series.push(Series {
                label: format!(
                    "time integration, NOT periodic: range over the last {} periods",
                    self.band_periods
                ),
                points: wandering
                    .iter()
                    .flat_map(|s| {
                        [
                            (s.frequency_hz / 1e3, s.band_min),
                            (s.frequency_hz / 1e3, s.band_max),
                        ]
                    })
                    .collect(),
                style: Style::Segments,
                color: 6,
            });
        }
        let image = "fig9_frd";
        fig.save(&setup.image(image))?;

        // summary
        let mut s = format!(
            "## Fig. 9 — frequency response diagram, gap 0.2\n\n\
             Files: `{img}`, `{frd_csv}` (the CSV of `mshbm frf --stability`: `{hdr}`), \
             `{ti_csv}` (`{TI_CSV_HEADER}`).\n\n\
             Max and min of the contact node's displacement q_N over a period vs the excitation \
             frequency ({from:.0}–{to:.0} Hz), redistributed MS-HBM with H = {hs} ({DAMPING_TEXT}), \
             by pseudo-arclength continuation; unstable parts (a Floquet multiplier outside the \
             unit circle) dashed. Reference: time integration from rest (Moreau–Jean θ = ½, \
             e_N = 0, consistent mass, the same damping; {n} steps per period, at most {p} periods, \
             periodic when the state repeats to 1e-6 twice in a row). Equivalent commands:\n\n```sh\n",
            img = setup.image_name(image),
            hdr = frd_csv_header(false),
            from = self.from_hz,
            to = self.to_hz,
            hs = self
                .harmonics
                .iter()
                .map(|h| h.to_string())
                .collect::<Vec<_>>()
                .join(", "),
            n = self.steps_per_period,
            p = self.max_periods,
        );
        for &h in &self.harmonics {
            let _ = writeln!(s, "mshbm {}", self.frf_argv(h).join(" "));
        }
        let _ = writeln!(
            s,
            "mshbm {}   # and the other frequencies\n```\n",
            self.simulate_argv(self.ti_frequencies_hz[0]).join(" ")
        );
        s.push_str("| H | points | folds | unstable points | stability changes | largest abs(q_N) [mm] at | end | time [s] |\n|---|---|---|---|---|---|---|---|\n");
        for t in &traced {
            let pts: Vec<&FrdPoint> = t.report.points.iter().filter(|p| !p.fold).collect();
            let unstable = pts.iter().filter(|p| p.stable == Some(false)).count();
            let peak = pts.iter().fold((0.0f64, 0.0), |(m, f), p| {
                let a = p.min_qn.abs().max(p.max_qn.abs());
                if a > m {
                    (a, p.frequency_hz)
                } else {
                    (m, f)
                }
            });
            let _ = writeln!(
                s,
                "| {} | {} | {} | {unstable} | {} | {:.4} at {:.2} kHz | {} | {:.0} |",
                t.harmonics,
                pts.len(),
                t.folds.len(),
                t.bifurcations.len(),
                peak.0,
                peak.1 / 1e3,
                if t.report.completed {
                    t.report.stop.clone()
                } else {
                    format!("**INCOMPLETE**: {}", t.report.stop)
                },
                t.seconds
            );
        }
        s.push_str("\nTime integration against the MS-HBM at the same frequency (where a branch has several solutions there, the one closest to the simulation's min is listed):\n\n");
        let _ = write!(s, "| f [kHz] | periodic | periods | change | last period max, min [mm] | range over last periods [mm] | time [s] |");
        for t in &traced {
            let _ = write!(s, " H = {} max, min |", t.harmonics);
        }
        s.push_str("\n|---|---|---|---|---|---|---|");
        for _ in &traced {
            s.push_str("---|");
        }
        s.push('\n');
        for sim in &sims {
            let _ = write!(
                s,
                "| {:.1} | {} | {} | {:.1e} | {:.4}, {:.4} | {:.4} … {:.4} | {:.0} |",
                sim.frequency_hz / 1e3,
                if sim.periodic {
                    "yes".to_string()
                } else {
                    match sim.subharmonic {
                        Some(k) => format!("**no** (repeats after {k} periods)"),
                        None => "**no**".to_string(),
                    }
                },
                sim.periods_simulated,
                sim.period_change,
                sim.max,
                sim.min,
                sim.band_min,
                sim.band_max,
                sim.seconds
            );
            for t in &traced {
                match branch_values_at(&t.report.points, sim.frequency_hz, sim.min) {
                    Some(v) => {
                        let _ = write!(
                            s,
                            " {:.4}, {:.4}{} |",
                            v.max,
                            v.min,
                            match v.stable {
                                Some(false) => " u",
                                _ => "",
                            }
                        );
                    }
                    None => s.push_str(" – |"),
                }
            }
            s.push('\n');
        }
        let periodic_count = sims.iter().filter(|s| s.periodic).count();
        // the MS-HBM solution of the largest H that reaches each frequency
        let reference_at = |sim: &Integration| {
            traced.iter().rev().find_map(|t| {
                branch_values_at(&t.report.points, sim.frequency_hz, sim.min)
                    .map(|v| (t.harmonics, v))
            })
        };
        let unstable_where_wandering = sims
            .iter()
            .filter(|sim| !sim.periodic)
            .filter(|sim| matches!(reference_at(sim), Some((_, v)) if v.stable == Some(false)))
            .count();
        let _ = write!(
            s,
            "\n(u: the MS-HBM solution there is unstable, a Floquet multiplier outside the unit \
             circle.) The simulation became periodic at {periodic_count} of {} frequencies. \
             Where it did not, it wanders around the MS-HBM orbit (hollow markers: its last \
             period; bars: the range over its last periods), and at {unstable_where_wandering} \
             of these {} frequencies the MS-HBM solution of the largest H there is unstable, so \
             no simulation can settle onto it. Mass-proportional damping also damps mode k only \
             by ζ₁ω₁/ω_k, so the high modes that each impact excites still ring at the next \
             one. With damping that reaches the high modes (examples/clamped_bar_impact.toml: \
             Rayleigh 1 % at ω₁ and 10ω₁) the simulation becomes periodic.\n\n",
            sims.len(),
            sims.len() - periodic_count,
        );
        for sim in sims.iter().filter(|s| s.periodic) {
            if let Some((h, v)) = reference_at(sim) {
                let _ = writeln!(
                    s,
                    "* {:.1} kHz (periodic): simulation max {:.5}, min {:.5}; MS-HBM H = {h}: max \
                     {:.5}, min {:.5} (difference of the min {}{}).",
                    sim.frequency_hz / 1e3,
                    sim.max,
                    sim.min,
                    v.max,
                    v.min,
                    super::percent(sim.min / v.min - 1.0),
                    if sim.max < 0.2 && v.max < 0.2 {
                        "; no contact: the difference is that of the consistent and the \
                         redistributed mass"
                    } else {
                        ""
                    }
                );
            }
        }
        s.push('\n');
        // where the contact first closes on the way up (all H coincide below)
        let gap = -model.contacts[0].gap / model.contacts[0].w[0];
        let first_contact = traced
            .first()
            .and_then(|t| {
                t.report
                    .points
                    .iter()
                    .find(|p| p.max_qn >= gap * (1.0 - 1e-9))
            })
            .map(|p| format!("below {:.2} kHz", p.frequency_hz / 1e3))
            .unwrap_or_else(|| "in the whole range".into());
        let _ = writeln!(
            s,
            "**Paper**: far from the resonance the contact node does not reach the support and \
             the response is linear, so the MS-HBM is exact there (here: {first_contact}, where \
             all H coincide); near the first eigenfrequency the bar hits the support and higher \
             harmonics contribute; \"with just a few harmonics the MS-HBM provides a very \
             accurate approximation of the FRF\". Compare the H columns above with each other \
             and with the periodic simulations."
        );
        Ok(FigureReport {
            section: s,
            files: vec![setup.image_name(image), frd_csv.into(), ti_csv.into()],
            problems,
        })
    }
}
