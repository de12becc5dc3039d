//! Time integration with Coulomb friction on massless contact nodes (docs/theory.md §9,
//! (T170)–(T175)) against independent references: the Masing loop of a Jenkins element in
//! closed form, the frictionless scheme (μ = 0), and the redistributed MS-HBM's exact
//! frictional periodic solutions on the friction damper (docs/theory.md §20).

mod common;

use std::f64::consts::PI;
use std::path::Path;
use std::time::Instant;

use common::hz;
use mshbm::integrate::steady_state::{simulate_to_steady_state, Periodicity, SteadyStateOptions};
use mshbm::integrate::{Integrator, Scheme, Settings};
use mshbm::model::{System, SystemContact, SystemContactFriction};
use mshbm::newton::{solve_at_frequency, NewtonOptions};
use mshbm::simulation::state_from_solution;
use mshbm::sparse::SparseMatrix;
use mshbm::MassKind;

fn position_newmark(system: &System, omega: f64, steps_per_period: usize) -> Integrator {
    Integrator::new(
        system,
        &Settings {
            dt: 2.0 * PI / omega / steps_per_period as f64,
            scheme: Scheme::PositionNewmark,
            omega: Some(omega),
            energy_offset: 0.0,
        },
    )
    .unwrap()
}

/// A massless contact node: normal DOF 0 on a spring `k_n`, pressed by `p` against a rigid
/// stop (`g = −q_0`); tangential DOF 1 on a spring `k_t` to a prescribed displacement
/// `A cos ωt` (the load `k_t A cos ωt` on a spring to ground): a Jenkins element.
fn jenkins(kn: f64, kt: f64, p: f64, a: f64, mu: f64) -> System {
    System {
        mass_kind: MassKind::Redistributed,
        mass: SparseMatrix::zeros(2, 2),
        stiffness: SparseMatrix::from_triplets(2, 2, &[(0, 0, kn), (1, 1, kt)]),
        damping: SparseMatrix::zeros(2, 2),
        model_dof: vec![0, 1],
        n_model_dofs: 2,
        nonlinear_dofs: vec![0, 1],
        linear_dofs: vec![],
        contacts: vec![SystemContact {
            w: vec![(0, -1.0)],
            gap: 0.0,
            friction: Some(SystemContactFriction {
                w: vec![(1, 1.0)],
                mu,
                second: None,
            }),
        }],
        frictions: vec![],
        harmonic_load: vec![0.0, kt * a],
        constant_load: vec![p, 0.0],
        alpha: 0.0,
        beta: 0.0,
        beta_condensed: 0.0,
        source: "<Jenkins element>".into(),
        stiffness_file: None,
    }
}

/// The Masing loop (docs/theory.md (T160 i)): the force on the node of a Jenkins element
/// with slip limit `fs` driven by `A cos τ`, in its periodic state.
fn masing(tau: f64, kt: f64, a: f64, fs: f64) -> f64 {
    let tau = tau.rem_euclid(2.0 * PI);
    if tau > PI {
        return -masing(tau - PI, kt, a, fs);
    }
    (-fs + kt * a * (1.0 - tau.cos())).min(fs)
}

#[test]
fn a_jenkins_element_follows_the_masing_loop() {
    let (kn, kt, p, a, mu) = (10.0, 3.0, 2.0, 1.0, 0.4);
    let fs = mu * p;
    let omega = 2.0 * PI * 50.0;
    for n in [64usize, 101, 1001] {
        let mut it = position_newmark(&jenkins(kn, kt, p, a, mu), omega, n);
        let mut error = 0.0f64;
        // the start (T174) is on the loop already: slipping forward at the drive's maximum
        for k in 0..3 * n {
            if k > 0 {
                it.step().unwrap();
            }
            let tau = omega * it.time();
            assert!((it.forces()[0] - p).abs() <= 1e-12 * p);
            let lt = it.tangential_forces()[0];
            assert!(lt.abs() <= fs);
            error = error.max((lt - masing(tau, kt, a, fs)).abs());
        }
        // exact where the drive's reversals are step instants (n even: the catching-up of a
        // play operator); otherwise the reversal's anchor is off by at most the drive's
        // change within half a step at its extremum, k_t A (π/n)²/2
        let bound = if n % 2 == 0 {
            1e-12 * fs
        } else {
            kt * a * (PI / n as f64).powi(2) / 2.0
        };
        assert!(error <= bound, "{n} steps: error {error:e} > {bound:e}");
    }
}

#[test]
fn without_friction_coefficient_the_trajectory_is_the_frictionless_one() {
    let omega = hz(1100.0);
    let n = 512;
    let frictional = common::friction_damper(Some(0.0), &[])
        .system(MassKind::Redistributed)
        .unwrap();
    let frictionless = common::friction_damper(None, &[])
        .system(MassKind::Redistributed)
        .unwrap();
    let mut a = position_newmark(&frictional, omega, n);
    let mut b = position_newmark(&frictionless, omega, n);
    let mut scale = 0.0f64;
    let mut diff = 0.0f64;
    let mut closed = 0;
    for _ in 0..3 * n {
        a.step().unwrap();
        b.step().unwrap();
        for (x, y) in a.q().iter().zip(b.q()) {
            scale = scale.max(y.abs());
            diff = diff.max((x - y).abs());
        }
        for (x, y) in a.forces().iter().zip(b.forces()) {
            assert!((x - y).abs() <= 1e-9 * y.abs().max(1.0), "{x} against {y}");
        }
        assert!(a.tangential_forces().iter().all(|&t| t == 0.0));
        closed += a.forces().iter().filter(|&&f| f > 0.0).count();
    }
    assert!(closed > 0);
    assert!(
        diff <= 1e-10 * scale,
        "trajectories differ by {diff:e} of {scale:e}"
    );
}

/// Issue 40's acceptance: the time integration's periodic steady state agrees with the
/// redistributed MS-HBM's exact frictional periodic solution (H = 20; at 450 Hz H = 15 is still 1 % off) within 0.5 % of the
/// response's peak-to-peak amplitude, below, near and above the friction-damped resonance.
///
/// With the example's damping alone (1 % mass-proportional at the first mode) the
/// simulated response does not repeat (1–8 % per period over 300 periods, at every step
/// size tried: docs/theory.md (T175), BENCHMARKS.md §15); stiffness-proportional damping on
/// the linear block (`damping.beta_linear = 1e-7`, 0.03 % at 1 kHz) damps the high modes the
/// tip face's open/close chatter excites, and the steady state is reached in ten periods.
/// Its resonance is then near 640 Hz.
#[test]
fn the_friction_damper_agrees_with_the_frictional_ms_hbm_across_the_resonance() {
    let model = common::friction_damper(Some(0.1), &["damping.beta_linear=1e-7"]);
    let system = model.system(MassKind::Redistributed).unwrap();
    let dof = 209;
    let n = 2048;
    for f in [450.0, 640.0, 1100.0] {
        let omega = hz(f);
        let start = Instant::now();
        let (sol, out) = solve_at_frequency(
            &mut common::ms_hbm(&model, 20),
            omega,
            dof,
            &NewtonOptions::default(),
        )
        .unwrap();
        assert!(out.converged, "MS-HBM at {f} Hz: {:?}", out.reason);
        let hbm_time = start.elapsed().as_secs_f64();
        // from the MS-HBM's state at t = 0 (T174)
        let (q0, v0) =
            state_from_solution(&system, &model, &sol, omega, Path::new("ms-hbm")).unwrap();
        let mut it = position_newmark(&system, omega, n);
        it.set_state(0.0, &q0, &v0).unwrap();
        let start = Instant::now();
        let steady = simulate_to_steady_state(
            &mut it,
            omega,
            &SteadyStateOptions {
                steps_per_period: n,
                max_periods: 80,
                tolerance: 1e-6,
                harmonics: 10,
                response_dof: dof,
                periodicity: Periodicity::State,
            },
            |_| {},
            |_, _| {},
        )
        .unwrap();
        assert!(
            steady.periodic,
            "{f} Hz: not periodic, change {}",
            steady.period_change
        );
        let ti = &steady.solution.response;
        let (pp_ti, pp_hbm) = (ti.max - ti.min, sol.response.max - sol.response.min);
        let error = (pp_ti - pp_hbm).abs() / pp_hbm;
        println!(
            "{f} Hz: peak-to-peak {pp_ti:.6e} (time integration, {} periods, {:.2} s) against {pp_hbm:.6e} \
             (MS-HBM H = 20, {:.2} s): {:.3} %; max {:.6e} against {:.6e}",
            steady.periods_simulated,
            start.elapsed().as_secs_f64(),
            hbm_time,
            100.0 * error,
            ti.max,
            sol.response.max
        );
        assert!(error <= 5e-3, "{f} Hz: {:.3} % apart", 100.0 * error);
        // the friction forces are reported and inside their cones
        assert_eq!(steady.solution.frictions.len(), 5);
        for fr in &steady.solution.frictions {
            for (t, l) in fr.force.iter().zip(&fr.limit) {
                assert!(t.abs() <= *l);
            }
        }
    }
}
