//! The general MS-HBM's start where Newton from the pre-solved linear response fails: the
//! paper's bar with mass-proportional damping only (docs/theory.md (T147b),
//! docs/general-mshbm.md §10), against full-system Moreau–Jean integration run to a
//! periodic steady state.

mod common;

use std::f64::consts::PI;

use mshbm::integrate::steady_state::{simulate_to_steady_state, Periodicity, SteadyStateOptions};
use mshbm::integrate::{Integrator, Scheme, Settings};
use mshbm::method::general::{GeneralMsHbm, GeneralOptions};
use mshbm::model::file::load_model;
use mshbm::newton::{solve, solve_at_frequency, NewtonOptions};
use mshbm::problem::PeriodicProblem;
use mshbm::{MassKind, Model};

/// 1 % damping of the first mode, mass-proportional only (`alpha = 2 ζ ω₁`).
const ALPHA: &str = "damping.alpha=7587.745128827051";

fn bar() -> Model {
    load_model(
        &common::examples().join("clamped_bar.toml"),
        &[ALPHA.into()],
    )
    .unwrap()
}

/// The contact DOF's `(min, max)` of full-system Moreau–Jean (θ = 0.6, 1024 steps per
/// period, e_N = 0) run until its harmonics repeat to 1e-4 from period to period.
fn simulated_extremes(model: &Model, f: f64) -> (f64, f64) {
    let omega = 2.0 * PI * f;
    let steps = 1024;
    let system = model.system(MassKind::Consistent).unwrap();
    let mut it = Integrator::new(
        &system,
        &Settings {
            dt: 1.0 / (f * steps as f64),
            scheme: Scheme::MoreauJean {
                theta: 0.6,
                restitution: 0.0,
            },
            omega: Some(omega),
            energy_offset: 0.0,
        },
    )
    .unwrap();
    it.set_contact_anticipation(true);
    let st = simulate_to_steady_state(
        &mut it,
        omega,
        &SteadyStateOptions {
            steps_per_period: steps,
            max_periods: 2000,
            tolerance: 1e-4,
            harmonics: 10,
            response_dof: 100,
            periodicity: Periodicity::Response,
        },
        |_| {},
        |_, _| {},
    )
    .unwrap();
    assert!(st.periodic, "simulation not periodic: {}", st.period_change);
    let c = &st.solution.contacts[0];
    eprintln!(
        "simulation: min {:.6} max {:.6} after {} periods",
        c.min, c.max, st.periods_simulated
    );
    (c.min, c.max)
}

/// Acceptance (issue 43): the paper's bar with 1 % mass-proportional damping of the first
/// mode only, at 30 kHz. Newton from the pre-solved linear response stalls (measured at
/// 2.7e-3, 3.3e-2 and 1.6e-2 at H = 5, 7 and 10 after 50 iterations); the start falls back to the
/// damping homotopy, and Newton converges to 1e-10. Its contact-DOF minimum agrees with
/// the simulation's within 0.5 % at H = 7 and 10; at H = 5 the harmonic truncation of the
/// linear part alone makes it 1.9 % deeper (as with the Rayleigh damping of
/// examples/clamped_bar_impact.toml), so that case is held to 2.5 %. That the H = 5 gap is
/// the truncation and not another orbit: the minimum converges in H onto the simulation's,
/// −0.32436 / −0.31893 / −0.31855 / −0.31854 / −0.31864 mm at H = 5 / 7 / 10 / 15 / 20
/// against −0.31824 mm (docs/general-mshbm.md §10), which H = 7 and 10 check here.
#[test]
fn bar_with_mass_proportional_damping_converges_at_30_khz() {
    let model = bar();
    let f = 30e3;
    let omega = 2.0 * PI * f;
    let (min, max) = simulated_extremes(&model, f);
    for (h, tolerance) in [(5, 0.025), (7, 0.005), (10, 0.005)] {
        let mut problem = GeneralMsHbm::new(&model, &GeneralOptions::new(h)).unwrap();
        let start = problem.presolved_start(omega).unwrap();
        let options = NewtonOptions {
            tolerance: 1e-10,
            ..NewtonOptions::default()
        };
        // the cold Newton fails: the fallback is needed here
        let cold = solve(&mut problem, &start, omega, &options).unwrap();
        assert!(!cold.converged, "H = {h}: {:?}", cold.history);
        let (solution, out) = solve_at_frequency(&mut problem, omega, 100, &options).unwrap();
        eprintln!(
            "H = {h}: cold Newton {:.1e} after {} iterations; with the homotopy ({}) {:.1e} after {} iterations (+{} in the start); min {:.6} max {:.6}",
            cold.residual_norm,
            cold.iterations,
            problem.used_damping_homotopy(),
            out.residual_norm,
            out.iterations,
            problem.guess_iterations(),
            solution.contacts[0].min,
            solution.contacts[0].max
        );
        assert!(out.converged, "H = {h}: {:?}", out.history);
        assert!(problem.used_damping_homotopy());
        // an independent evaluation of the residual at the returned solution
        let r = problem.residual(&out.x, omega).unwrap();
        let norm = r.iter().fold(0.0f64, |m, v| m.max(v.abs())) / problem.length_scale();
        assert!(norm <= 1e-10, "{norm}");
        let c = &solution.contacts[0];
        assert!(
            (c.min - min).abs() <= tolerance * min.abs(),
            "H = {h}: min {} against {min}",
            c.min
        );
        assert!(
            (c.max - 0.2).abs() < 1e-12 && (max - 0.2).abs() < 1e-3,
            "{} {max}",
            c.max
        );
        assert!(c.gap.iter().all(|&g| g >= -1e-12));
        assert!(c.force.iter().any(|&l| l > 0.0));
    }
}
