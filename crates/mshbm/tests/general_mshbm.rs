//! The general MS-HBM (paper Section 2, METHODS §3.4) against independent references:
//! full-system Moreau–Jean time integration run to a periodic steady state, the linear
//! response from a direct dense complex solve, and the friction limit.

mod common;

use std::f64::consts::PI;

use faer::linalg::solvers::Solve;
use faer::{c64, Mat};
use mshbm::continuation::newton::{solve_at_frequency, NewtonOptions};
use mshbm::integrate::steady_state::{simulate_to_steady_state, SteadyState, SteadyStateOptions};
use mshbm::integrate::{Integrator, Scheme, Settings};
use mshbm::method::shooting::{GeneralMsHbm, GeneralOptions};
use mshbm::model::file::load_model;
use mshbm::model::{Damping, Friction, FrictionNormal};
use mshbm::solution::PeriodicSolution;
use mshbm::sparse::SparseMatrix;
use mshbm::{MassKind, Model};

/// The paper's Fig. 1 kind of system: a chain of `n` masses `m` and springs `k` (the first
/// to ground), Rayleigh damping `alpha M`, harmonic force `F cos ωt` on mass 0 and a
/// Coulomb element `μ F_N` to ground on the last mass.
fn friction_chain(n: usize, friction_limit: f64) -> Model {
    // SI units: m = 1 kg, k = 1e4 N/m, F = 1 N; 2 % damping at the first mode (mass
    // proportional). With n = 3 the first eigenfrequency is 2 sin(π/14) √(k/m) = 7.09 Hz.
    let (m, k, force) = (1.0, 1.0e4, 1.0);
    let mut kt = Vec::new();
    for i in 0..n {
        // spring i joins mass i−1 (or ground) and mass i
        kt.push((i, i, k));
        if i > 0 {
            kt.push((i - 1, i - 1, k));
            kt.push((i - 1, i, -k));
            kt.push((i, i - 1, -k));
        }
    }
    let mt: Vec<(usize, usize, f64)> = (0..n).map(|i| (i, i, m)).collect();
    let mut harmonic_load = vec![0.0; n];
    harmonic_load[0] = force;
    Model {
        source: "friction chain (test)".into(),
        name: "friction chain".into(),
        mass: SparseMatrix::from_triplets(n, n, &mt),
        stiffness: SparseMatrix::from_triplets(n, n, &kt),
        damping_matrix: None,
        coordinates: (0..n).map(|i| vec![i as f64]).collect(),
        dofs_per_node: 1,
        dirichlet: vec![],
        contacts: vec![],
        frictions: vec![Friction {
            dofs: vec![n - 1],
            w: vec![1.0],
            mu: 1.0,
            normal: FrictionNormal::Force(friction_limit),
        }],
        harmonic_load,
        constant_load: vec![0.0; n],
        acceleration: None,
        damping: Damping {
            first_mode_ratio: Some(0.02),
            ..Damping::default()
        },
    }
}

/// The paper's bar (examples/clamped_bar.toml) with Rayleigh damping `alpha M + beta K`
/// (consistent mass, full stiffness: C_NN ≠ 0 is fine for the general MS-HBM), 1 % modal
/// damping at the first eigenfrequency ω₁ and at 10 ω₁.
fn rayleigh_bar() -> Model {
    let model = load_model(&common::examples().join("clamped_bar.toml"), &[]).unwrap();
    let system = model.system(MassKind::Consistent).unwrap();
    let w1 = mshbm::modes::first_angular_frequency(&system.mass, &system.stiffness).unwrap();
    let (zeta, w2) = (0.01, 10.0 * w1);
    let alpha = 2.0 * zeta * w1 * w2 / (w1 + w2);
    let beta = 2.0 * zeta / (w1 + w2);
    load_model(
        &common::examples().join("clamped_bar.toml"),
        &[
            format!("damping.alpha={alpha}"),
            format!("damping.beta={beta}"),
        ],
    )
    .unwrap()
}

struct Run {
    problem: GeneralMsHbm,
    solution: PeriodicSolution,
    x: Vec<f64>,
    omega: f64,
}

/// The general MS-HBM at `f` Hz from the linear response, Newton to `tolerance`.
fn general(model: &Model, f: f64, harmonics: usize, steps: usize, tolerance: f64) -> Run {
    let mut problem = GeneralMsHbm::new(
        model,
        &GeneralOptions {
            steps: Some(steps),
            ..GeneralOptions::new(harmonics)
        },
    )
    .unwrap();
    let options = NewtonOptions {
        tolerance,
        ..NewtonOptions::default()
    };
    let dof = model
        .frictions
        .first()
        .map_or_else(|| model.contacts[0].dofs[0], |f| f.dofs[0]);
    let omega = 2.0 * PI * f;
    let (solution, out) = solve_at_frequency(&mut problem, omega, dof, &options).unwrap();
    assert!(
        out.converged,
        "general MS-HBM at {f} Hz: {:?} {:?}",
        out.history, out.reason
    );
    Run {
        problem,
        solution,
        x: out.x,
        omega,
    }
}

/// Full-system Moreau–Jean (consistent mass, e_N = 0) run to a periodic steady state; the
/// friction forces of every step are checked against `friction_limit`.
fn steady(
    model: &Model,
    f: f64,
    steps: usize,
    theta: f64,
    response_dof: usize,
    friction_limit: f64,
) -> SteadyState {
    let omega = 2.0 * PI * f;
    let system = model.system(MassKind::Consistent).unwrap();
    let mut it = Integrator::new(
        &system,
        &Settings {
            dt: 1.0 / (f * steps as f64),
            scheme: Scheme::MoreauJean {
                theta,
                restitution: 0.0,
            },
            omega: Some(omega),
            energy_offset: 0.0,
        },
    )
    .unwrap();
    it.set_contact_anticipation(true);
    let mut worst = 0.0f64;
    let st = simulate_to_steady_state(
        &mut it,
        omega,
        &SteadyStateOptions {
            steps_per_period: steps,
            max_periods: 2000,
            tolerance: 1e-6,
            harmonics: 10,
            response_dof,
        },
        |it| {
            for p in it.friction_forces() {
                worst = worst.max(p.abs());
            }
        },
        |_, _| {},
    )
    .unwrap();
    assert!(
        worst <= friction_limit * (1.0 + 1e-12),
        "{worst} > {friction_limit}"
    );
    st
}

fn first_frequency_hz(model: &Model) -> f64 {
    let system = model.system(MassKind::Consistent).unwrap();
    mshbm::modes::first_angular_frequency(&system.mass, &system.stiffness).unwrap() / (2.0 * PI)
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// Acceptance: the friction oscillator at several frequencies across its resonance — in
/// stick–slip below and above it, in pure slip at it — with H = 10 agrees with full-system
/// Moreau–Jean integration run to steady state within 2 % on the friction DOF's max and min;
/// connectivity and periodicity residuals are below tolerance, and the friction force never
/// exceeds its limit at any step (MS-HBM and simulation).
#[test]
fn friction_oscillator_agrees_with_time_integration_across_resonance() {
    let limit = 0.3;
    let model = friction_chain(3, limit);
    let f1 = first_frequency_hz(&model);
    assert!((f1 - 7.09).abs() < 0.01, "{f1}");
    let steps = 512;
    let mut stick_slip = 0;
    for ratio in [0.6, 0.9, 1.0, 1.1, 1.4] {
        let f = ratio * f1;
        let mut run = general(&model, f, 10, steps, 1e-9);
        let (connectivity, periodicity) = run.problem.residual_parts(&run.x, run.omega).unwrap();
        assert!(
            connectivity < 1e-9 && periodicity < 1e-9,
            "{connectivity} {periodicity}"
        );
        let tr = run.problem.trajectory(&run.x, run.omega).unwrap();
        let forces: Vec<f64> = tr.friction_forces.iter().map(|p| p[0]).collect();
        assert!(forces.iter().all(|p| p.abs() <= limit * (1.0 + 1e-12)));
        let stick = forces
            .iter()
            .filter(|p| p.abs() < limit * (1.0 - 1e-9))
            .count();
        if stick > 0 && stick < steps {
            stick_slip += 1;
        }
        let st = steady(&model, f, steps, 0.5, 2, limit);
        assert!(
            st.periodic,
            "simulation at {f} Hz not periodic: {}",
            st.period_change
        );
        let (a, b) = (&run.solution.response, &st.solution.response);
        eprintln!(
            "{f:.3} Hz: MS-HBM max {:.6e} min {:.6e}; simulation max {:.6e} min {:.6e} ({} periods); stick {stick}/{steps} steps",
            a.max, a.min, b.max, b.min, st.periods_simulated
        );
        assert_eq!(a.dof, 2);
        assert!(
            rel(a.max, b.max) < 0.02 && rel(a.min, b.min) < 0.02,
            "{f} Hz: MS-HBM max/min {} {}, simulation {} {}",
            a.max,
            a.min,
            b.max,
            b.min
        );
    }
    assert!(
        stick_slip >= 3,
        "only {stick_slip} frequencies in stick-slip"
    );
}

/// Linear response `(K − (kω)² M + i kω C) z = f_k` by a direct dense complex solve of the
/// whole system (the independent reference), for system DOF `dof`: coefficients
/// `[a0, a1, b1]`.
fn direct_linear_response(model: &Model, omega: f64, dof: usize) -> [f64; 3] {
    let system = model.system(MassKind::Consistent).unwrap();
    let (m, c, k) = (
        system.mass.to_dense(),
        system.damping.to_dense(),
        system.stiffness.to_dense(),
    );
    let n = system.n_dofs();
    let solve = |w: f64, f: &[f64]| -> c64 {
        let a = Mat::<c64>::from_fn(n, n, |i, j| {
            c64::new(k[(i, j)] - w * w * m[(i, j)], w * c[(i, j)])
        });
        let rhs = Mat::<c64>::from_fn(n, 1, |i, _| c64::new(f[i], 0.0));
        a.partial_piv_lu().solve(&rhs)[(dof, 0)]
    };
    let z0 = solve(0.0, &system.constant_load);
    let z1 = solve(omega, &system.harmonic_load);
    [z0.re, z1.re, -z1.im]
}

/// Acceptance: with no nonlinearity active the general MS-HBM gives the linear response
/// (to the accuracy of the trapezoidal rule on the N-subsystem): the friction oscillator
/// with μ = 0, and the bar with a gap that never closes.
#[test]
fn without_active_nonlinearity_equals_the_linear_response() {
    let mut chain = friction_chain(3, 0.3);
    chain.frictions[0].mu = 0.0;
    let f1 = first_frequency_hz(&chain);
    let mut bar = rayleigh_bar();
    bar.contacts[0].gap = 50.0;
    for (model, f, dof) in [
        (&chain, 0.8 * f1, 2),
        (&chain, 1.2 * f1, 2),
        (&bar, 30e3, 99),
    ] {
        let run = general(model, f, 5, 512, 1e-10);
        let n = run.problem.n_nonlinear();
        assert_eq!(n, 1);
        let reference = direct_linear_response(model, run.omega, dof);
        let amplitude = reference[1].hypot(reference[2]);
        let x = &run.x;
        for (c, r) in reference.iter().enumerate() {
            assert!(
                (x[c] - r).abs() < 1e-3 * amplitude,
                "{f} Hz coefficient {c}: {} vs {r}",
                x[c]
            );
        }
        // higher harmonics vanish
        #[allow(clippy::needless_range_loop)]
        for c in 3..11 {
            assert!(
                x[c].abs() < 1e-6 * amplitude,
                "{f} Hz coefficient {c}: {}",
                x[c]
            );
        }
    }
}

/// Acceptance: the paper's bar with its consistent mass, unilateral contact with the
/// Newton impact law (e_N = 0), gap 0.2 mm and 1 % damping (Rayleigh, at ω₁ and 10 ω₁): the
/// general MS-HBM agrees with full-system Moreau–Jean integration within 3 % on the
/// contact DOF's max and min at 30 and 90 kHz, where the simulation becomes periodic.
///
/// The simulation uses θ = 0.6: with θ = ½ (trapezoidal rule) the stiff, overdamped high
/// modes of the consistent-mass bar have amplification → −1 and keep alternating, so the
/// state never repeats to 1e-6 at 90 kHz (a grid artefact that shrinks with the step).
#[test]
fn bar_with_impacts_agrees_with_time_integration() {
    let model = rayleigh_bar();
    let steps = 1024;
    for f in [30e3, 90e3] {
        let mut run = general(&model, f, 10, steps, 1e-4);
        let (connectivity, periodicity) = run.problem.residual_parts(&run.x, run.omega).unwrap();
        assert!(
            connectivity < 1e-4 && periodicity < 1e-4,
            "{connectivity} {periodicity}"
        );
        let st = steady(&model, f, steps, 0.6, 100, 0.0);
        assert!(
            st.periodic,
            "simulation at {f} Hz not periodic: {}",
            st.period_change
        );
        let (a, b) = (&run.solution.contacts[0], &st.solution.contacts[0]);
        eprintln!(
            "{f} Hz: MS-HBM max {:.6e} min {:.6e}; simulation max {:.6e} min {:.6e} ({} periods); residuals {connectivity:.1e} {periodicity:.1e}",
            a.max, a.min, b.max, b.min, st.periods_simulated
        );
        assert_eq!((a.dof, b.dof), (100, 100));
        assert!(
            rel(a.max, b.max) < 0.03 && rel(a.min, b.min) < 0.03,
            "{f} Hz: MS-HBM max/min {} {}, simulation {} {}",
            a.max,
            a.min,
            b.max,
            b.min
        );
        // the contact is hit: the DOF reaches the support, and the force is never negative
        assert!(a.max > 0.19 && a.force.iter().all(|&l| l >= 0.0));
        assert!(a.force.iter().any(|&l| l > 0.0));
        let _ = run.problem.trajectory(&run.x, run.omega).unwrap();
    }
}

/// examples/friction_oscillator is the chain of these tests (μ F_N = 0.3 N), read through
/// the `[[frictions]]` table of a `kind = "matrices"` model.
#[test]
fn friction_oscillator_example_is_the_tested_chain() {
    let example = load_model(
        &common::examples().join("friction_oscillator/model.toml"),
        &[],
    )
    .unwrap();
    let chain = friction_chain(3, 0.3);
    let (a, b) = (
        example.system(MassKind::Consistent).unwrap(),
        chain.system(MassKind::Consistent).unwrap(),
    );
    for (x, y) in [
        (&a.mass, &b.mass),
        (&a.stiffness, &b.stiffness),
        (&a.damping, &b.damping),
    ] {
        let (x, y) = (x.to_dense(), y.to_dense());
        for i in 0..3 {
            for j in 0..3 {
                assert!((x[(i, j)] - y[(i, j)]).abs() <= 1e-12 * (1.0 + y[(i, j)].abs()));
            }
        }
    }
    assert_eq!(a.harmonic_load, b.harmonic_load);
    assert_eq!(a.nonlinear_dofs, vec![2]);
    let f = &example.frictions[0];
    assert_eq!((f.dofs.clone(), f.mu * 1.0), (vec![2], 0.3));
    assert_eq!(f.normal, FrictionNormal::Force(1.0));
    // a friction element needs exactly one normal-force source
    let bad = load_model(
        &common::examples().join("friction_oscillator/model.toml"),
        &["frictions.0.contact=0".to_string()],
    )
    .unwrap_err()
    .to_string();
    assert!(bad.contains("frictions[0]"), "{bad}");
    // the redistributed mass refuses friction
    assert!(example.system(MassKind::Redistributed).is_err());
}

/// examples/clamped_bar_impact.toml is the bar of `bar_with_impacts_agrees_with_time_integration`.
#[test]
fn clamped_bar_impact_example_has_one_percent_rayleigh_damping() {
    let example = load_model(&common::examples().join("clamped_bar_impact.toml"), &[]).unwrap();
    let reference = rayleigh_bar();
    assert!(rel(example.damping.alpha, reference.damping.alpha) < 1e-6);
    assert!(rel(example.damping.beta, reference.damping.beta) < 1e-6);
    assert_eq!(example.contacts, reference.contacts);
}

/// Friction elements survive `mshbm export` (the `[[frictions]]` table), with both kinds of
/// normal force.
#[test]
fn friction_elements_survive_export() {
    let mut model = load_model(
        &common::examples().join("friction_oscillator/model.toml"),
        &[],
    )
    .unwrap();
    model.contacts.push(mshbm::model::Contact {
        dofs: vec![1],
        w: vec![-1.0],
        gap: 0.5,
    });
    model.frictions.push(Friction {
        dofs: vec![0, 1],
        w: vec![1.0, -1.0],
        mu: 0.2,
        normal: FrictionNormal::Contact(0),
    });
    model.validate().unwrap();
    let dir = std::env::temp_dir().join(format!("mshbm_friction_export_{}", std::process::id()));
    let path = mshbm::model::export::export_matrices(&model, &dir).unwrap();
    let back = load_model(&path, &[]).unwrap();
    assert_eq!(back.frictions, model.frictions);
    assert_eq!(back.contacts, model.contacts);
    let _ = std::fs::remove_dir_all(&dir);
}
