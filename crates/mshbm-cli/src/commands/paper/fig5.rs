//! Fig. 5: the bar dropped onto a rigid support — gap and normalised energy over time for
//! Newton's impact law with e_N = 0 and e_N = 1 (Moreau–Jean, consistent mass) and for the
//! redistributed mass (position-level Newmark, no impact law), with the closed-form
//! solution (docs/theory.md (T90)). The runs are those of
//! `mshbm simulate examples/dropped_bar.toml --scheme moreau --restitution 0|1` and
//! `--scheme redistributed`.

use std::fmt::Write as _;

use anyhow::{bail, Result};
use mshbm::analytic::DroppedBarSolution;
use mshbm::model::dropped_bar::DroppedBarParameters;
use mshbm::simulation::contact_intervals;

use super::{models, FigureReport, Setup};
use super::{Job, Output};
use crate::commands::simulate::{transient_figures, transient_run, SchemeArg};
use crate::output::write_csv_atomic;
use crate::plot::Figure;

/// The three contact descriptions of the paper's Fig. 5.
const RUNS: [(&str, &str, SchemeArg, Option<f64>); 3] = [
    (
        "e_N = 0",
        "Moreau-Jean theta = 1/2, consistent mass, e_N = 0",
        SchemeArg::Moreau,
        Some(0.0),
    ),
    (
        "e_N = 1",
        "Moreau-Jean theta = 1/2, consistent mass, e_N = 1",
        SchemeArg::Moreau,
        Some(1.0),
    ),
    (
        "m_red",
        "redistributed mass, position-level Newmark (no impact law)",
        SchemeArg::Redistributed,
        None,
    ),
];

/// CSV header of fig5_dropped_bar.csv.
pub const CSV_HEADER: &str = "time_s,gap_closed_form,gap_e0,gap_e1,gap_mred,energy_normalized_e0,energy_normalized_e1,energy_normalized_mred";

pub(crate) fn job(setup: &Setup) -> Job<'_> {
    Job {
        name: "Fig. 5 (dropped bar)".into(),
        work: Box::new(move || Ok(Output::Figure(5, figure(setup)?))),
    }
}

fn figure(setup: &Setup) -> Result<FigureReport> {
    let mut params = DroppedBarParameters::nondimensional();
    let steps_per_period: u64 = if setup.quick {
        params.elements = 20;
        2000
    } else {
        8000
    };
    let periods = 2u64;
    let model = params.build(std::path::Path::new(models::DROPPED_BAR_PATH))?;
    let analytic: DroppedBarSolution = params.analytic()?;
    let period = analytic.period();
    let dt = period / steps_per_period as f64;
    let steps = periods * steps_per_period;
    let mut recs = Vec::new();
    for (_, _, scheme, restitution) in RUNS {
        recs.push(transient_run(&model, scheme, restitution, dt, steps)?);
    }
    let n = recs[0].plot_time.len();
    if recs.iter().any(|r| r.plot_time.len() != n) {
        bail!("the three runs were recorded on different time grids");
    }
    let time = &recs[0].plot_time;

    // CSV: one row per recorded step, the three runs side by side
    let mut csv = String::from(CSV_HEADER);
    csv.push('\n');
    for (j, &t) in time.iter().enumerate() {
        let _ = write!(csv, "{t:.9e},{:.9e}", analytic.gap(t));
        for r in &recs {
            let _ = write!(csv, ",{:.9e}", r.plot_gaps[0][j]);
        }
        for r in &recs {
            let _ = write!(csv, ",{:.9e}", r.plot_energy[j]);
        }
        csv.push('\n');
    }
    let csv_name = "fig5_dropped_bar.csv";
    write_csv_atomic(&setup.file(csv_name), &csv)?;

    let runs: Vec<(&str, &_)> = RUNS.iter().zip(&recs).map(|(r, rec)| (r.0, rec)).collect();
    let [mut gap, mut energy] = transient_figures(&model, &runs, Some(&analytic));
    gap.title = format!(
        "Fig. 5: dropped bar ({} elements, κ = {:.0}, undamped): gap of the lower end",
        params.elements,
        analytic.kappa()
    );
    energy.title = "Fig. 5: total energy / initial energy".into();
    let image = "fig5_dropped_bar";
    Figure::save_stacked(&[gap, energy], &setup.image(image))?;

    // key numbers
    let contact = analytic.contact_duration();
    let scallop = analytic.gravity() * analytic.length().powi(2) / analytic.wave_speed().powi(2);
    let tolerance = 1e-3 * scallop;
    let first_period = time.iter().take_while(|&&t| t <= period).count();
    let mut table = String::from(
        "| contact description | first contact: start, duration | closed time per period | E/E0 at T | E/E0 at 2T | max abs(gap − closed form), 1st period |\n|---|---|---|---|---|---|\n",
    );
    let starts = analytic.contact_starts();
    let _ = writeln!(
        table,
        "| closed form | {:.4}, {:.4} (= 2L/c) | {:.4} | 1 | 1 | 0 |",
        starts[0],
        contact,
        2.0 * contact
    );
    for ((name, description, _, _), r) in RUNS.iter().zip(&recs) {
        let (intervals, total) = contact_intervals(time, &r.plot_gaps[0], tolerance);
        let first = intervals
            .first()
            .map(|(s, d)| format!("{s:.4}, {d:.4}"))
            .unwrap_or_else(|| "none".into());
        let energy_at = |k: usize| r.plot_energy[(k * (n - 1) / periods as usize).min(n - 1)];
        let max_error = (0..first_period)
            .map(|j| (r.plot_gaps[0][j] - analytic.gap(time[j])).abs())
            .fold(0.0f64, f64::max);
        let _ = writeln!(
            table,
            "| {name} ({description}) | {first} ({} closed intervals in {periods} periods) | {:.4} | {:.6} | {:.6} | {max_error:.4} |",
            intervals.len(),
            total / periods as f64,
            energy_at(1),
            energy_at(2),
        );
    }
    let section = format!(
        "## Fig. 5 — dropped bar: contact descriptions in the time domain\n\n\
         Files: `{img}`, `{csv_name}` (columns `{CSV_HEADER}`; energies are E/E(0)).\n\n\
         A free elastic bar ({el} two-node elements, nondimensional L = c = g = ρ = E = A = 1, \
         released with its lower end at h0 = {h0} so that κ = v0·c/(g·L) = {kappa:.0}; \
         closed-form period T = 4(κ+1)L/c = {period}) falls onto a rigid support. Time step \
         T/{steps_per_period}, {periods} periods, no damping. Equivalent single runs: \
         `mshbm simulate {path} --scheme moreau --restitution 0` (and `1`), \
         `mshbm simulate {path} --scheme redistributed`.\n\n\
         {table}\n\
         \"Closed\" means gap ≤ {tolerance:.0e} (10⁻³ of the flight-phase scallop depth gL²/c²).\n\n\
         **Paper**: after the impact the bar stays on the support while the shock wave travels \
         up and down the bar (2L/c = {contact} here); with e_N = 1 energy is conserved \"but the \
         contact is never established for a time interval of non-zero size\"; with e_N = 0 \"the \
         contact is closed for the whole contact time but at each collision of the node, the \
         system loses energy\"; the m_red curve \"provides accurate results\", its deviation \
         growing with time from the discretisation ({el_paper} elements). Compare the rows \
         above: the number of closed intervals and the closed time of e_N = 1, the energy loss \
         of e_N = 0, and the contact duration and energy of m_red.\n",
        img = setup.image_name(image),
        el = params.elements,
        h0 = params.height,
        kappa = analytic.kappa(),
        path = models::DROPPED_BAR_PATH,
        el_paper = 100,
    );
    Ok(FigureReport {
        section,
        files: vec![setup.image_name(image), csv_name.into()],
        problems: vec![],
    })
}
