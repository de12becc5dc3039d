//! The HBM-AFT with elastic dry friction (a Jenkins element per frictional contact,
//! docs/theory.md §21) against independent references: central differences of the residual,
//! the closed-form Masing loop of a Jenkins element under a harmonic displacement, the
//! redistributed MS-HBM's exact Coulomb friction on a massless node behind a spring (the same
//! truncated problem), and the MS-HBM on the friction damper as the penalties grow.

mod common;

use std::f64::consts::PI;
use std::path::PathBuf;

use common::{assert_derivatives_match_finite_differences, example_model, hz, ms_hbm, perturbed};
use mshbm::harmonic::Quadrature;
use mshbm::method::hbm_aft::{HbmAft, HbmAftOptions, Penalty};
use mshbm::model::{Contact, ContactFriction, Damping, Model};
use mshbm::newton::{solve, solve_at_frequency, NewtonOptions};
use mshbm::problem::PeriodicProblem;
use mshbm::solution::PeriodicSolution;
use mshbm::sparse::SparseMatrix;
use mshbm::MassKind;

/// Parameters of the Jenkins oscillator: a mass `m` on a spring `k` to ground, damped by
/// `alpha m`, driven by `force cos ωt`, held by a Jenkins element of stiffness `kt` and slip
/// limit `mu · normal`.
#[derive(Clone, Copy)]
struct Oscillator {
    m: f64,
    k: f64,
    kt: f64,
    mu: f64,
    normal: f64,
    force: f64,
    alpha: f64,
}

const OSCILLATOR: Oscillator = Oscillator {
    m: 1.0,
    k: 1.0,
    kt: 1.0,
    mu: 0.3,
    normal: 1.0,
    force: 1.0,
    alpha: 0.05,
};

/// Stiffness of the normal DOFs (to ground) in the oscillator models.
const K_NORMAL: f64 = 10.0;

#[allow(clippy::too_many_arguments)] // the oscillators' parts, named where they are built
fn model(
    name: &str,
    mass: Vec<(usize, usize, f64)>,
    stiffness: Vec<(usize, usize, f64)>,
    contact: Contact,
    harmonic_load: Vec<f64>,
    constant_load: Vec<f64>,
    dirichlet: Vec<usize>,
    alpha: f64,
) -> Model {
    Model {
        stiffness_file: None,
        source: PathBuf::from(name),
        input_files: vec![],
        cells: None,
        node_sets: Default::default(),
        node_labels: None,
        interfaces: vec![],
        name: name.into(),
        mass: SparseMatrix::from_triplets(4, 4, &mass),
        stiffness: SparseMatrix::from_triplets(4, 4, &stiffness),
        damping_matrix: None,
        coordinates: vec![vec![0.0, 0.0], vec![1.0, 0.0]],
        dofs_per_node: 2,
        dirichlet,
        contacts: vec![contact],
        harmonic_load,
        constant_load,
        frictions: vec![],
        acceleration: None,
        damping: Damping {
            alpha,
            ..Damping::default()
        },
    }
}

/// The MS-HBM side: the mass (DOF 0; DOF 1 fixed) is tied by the spring `kt` to a massless
/// contact node (DOF 2 tangential, DOF 3 normal) pressed by `normal` on a rigid Coulomb plane
/// (`g = −q_3`); the node's normal DOF has a spring `K_NORMAL` to ground, unstretched at
/// contact, so the normal force is `normal` at every instant.
fn massless_node(o: Oscillator) -> Model {
    model(
        "Jenkins oscillator with a massless contact node",
        vec![(0, 0, o.m), (1, 1, o.m)],
        vec![
            (0, 0, o.k + o.kt),
            (0, 2, -o.kt),
            (2, 0, -o.kt),
            (2, 2, o.kt),
            (1, 1, o.k),
            (3, 3, K_NORMAL),
        ],
        Contact {
            dofs: vec![3],
            w: vec![-1.0],
            gap: 0.0,
            friction: Some(ContactFriction {
                dofs: vec![2],
                w: vec![1.0],
                mu: o.mu,
                second: None,
            }),
        },
        vec![o.force, 0.0, 0.0, 0.0],
        vec![0.0, 0.0, 0.0, o.normal],
        vec![1],
        o.alpha,
    )
}

/// The HBM-AFT side: the same mass (DOF 0) carries the contact itself, tangentially, with a
/// normal DOF 1 (spring `K_NORMAL`) pressed on the plane with the penalty `kp`; the load is
/// chosen so that the penalty force is `normal` (`λ_N = kp P/(K_NORMAL + kp)`). Node 1 (DOFs
/// 2, 3) is a detached mass on springs that keeps the linear part non-empty.
fn jenkins_on_the_mass(o: Oscillator, kp: f64) -> Model {
    let preload = o.normal * (K_NORMAL + kp) / kp;
    model(
        "Jenkins oscillator with a Jenkins element",
        vec![(0, 0, o.m), (1, 1, o.m), (2, 2, o.m), (3, 3, o.m)],
        vec![(0, 0, o.k), (1, 1, K_NORMAL), (2, 2, o.k), (3, 3, o.k)],
        Contact {
            dofs: vec![1],
            w: vec![-1.0],
            gap: 0.0,
            friction: Some(ContactFriction {
                dofs: vec![0],
                w: vec![1.0],
                mu: o.mu,
                second: None,
            }),
        },
        vec![o.force, 0.0, 0.0, 0.0],
        vec![0.0, preload, 0.0, 0.0],
        vec![],
        o.alpha,
    )
}

fn aft(model: &Model, harmonics: usize, samples: usize, kp: f64, kt: f64) -> HbmAft {
    HbmAft::new(
        model,
        &HbmAftOptions {
            samples: Some(samples),
            penalty: Penalty::Stiffness(kp),
            tangential_penalty: Some(Penalty::Stiffness(kt)),
            ..HbmAftOptions::new(harmonics)
        },
    )
    .unwrap()
}

fn tight() -> NewtonOptions {
    NewtonOptions {
        tolerance: 1e-13,
        max_iterations: 100,
        ..NewtonOptions::default()
    }
}

/// `max |a − b| / max |b|` of the response coefficients of two solutions.
fn response_difference(a: &PeriodicSolution, b: &PeriodicSolution) -> f64 {
    let (ca, cb) = (&a.response.coefficients, &b.response.coefficients);
    let scale = cb.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    ca.iter()
        .zip(cb)
        .fold(0.0f64, |s, (x, y)| s.max((x - y).abs()))
        / scale
}

fn first_harmonic_amplitude(s: &PeriodicSolution) -> f64 {
    let c = &s.response.coefficients;
    c[1].hypot(c[2])
}

/// (T168): the MS-HBM's massless node behind the spring `k_t`, with rigid normal contact and
/// rigid Coulomb friction under a constant normal force, is a Jenkins element of stiffness
/// `k_t` and limit `μN` on the mass; both methods balance the first `H` harmonics of its force
/// along the same truncated displacement, so they solve the same equations. The sampled AFT
/// approaches the MS-HBM's exact quadrature like `N_s⁻²` (T167) and passes 1e-8 at 2^16
/// samples.
#[test]
fn the_jenkins_element_on_the_mass_is_the_ms_hbm_massless_node_behind_a_spring() {
    let o = OSCILLATOR;
    let (h, omega) = (5, 1.2);
    let (reference, out) =
        solve_at_frequency(&mut ms_hbm(&massless_node(o), h), omega, 0, &tight()).unwrap();
    assert!(out.converged, "{:?}", out.reason);
    let kp = 100.0 * K_NORMAL;
    let model = jenkins_on_the_mass(o, kp);
    let mut errors = Vec::new();
    for samples in [1024, 4096, 16384, 65536] {
        let mut p = aft(&model, h, samples, kp, o.kt);
        let (sol, out) = solve_at_frequency(&mut p, omega, 0, &tight()).unwrap();
        assert!(out.converged, "{samples} samples: {:?}", out.reason);
        // the element sticks and slips both ways
        let f = &sol.frictions[0];
        let limit = o.mu * o.normal;
        assert!(f.limit.iter().all(|l| (l - limit).abs() < 1e-12 * limit));
        assert!(f.force.iter().any(|t| t.abs() < 0.5 * limit));
        assert!(f.force.iter().any(|t| (t - limit).abs() < 1e-12));
        assert!(f.force.iter().any(|t| (t + limit).abs() < 1e-12));
        errors.push(response_difference(&sol, &reference));
    }
    println!("equivalence, relative difference at 1024 … 65536 samples: {errors:?}");
    for pair in errors.windows(2) {
        assert!(pair[1] < pair[0] / 8.0, "not O(N_s⁻²): {errors:?}");
    }
    assert!(errors[3] < 1e-8, "{errors:?}");
}

/// (T167): under `u = U cos(τ − φ)` and a constant normal force `N` the Jenkins force is the
/// Masing loop, with first harmonic `a₁ = −(k_t U/π)(τ₁ − ½ sin 2τ₁)`,
/// `b₁ = (4F_s/π)(1 − F_s/(k_t U))` (`F_s = μN`, `cos τ₁ = 1 − 2F_s/(k_t U)`) before the shift
/// by `φ`. The AFT's force coefficients, read off the residual as `−k_ref (R_μ − R_0)`, reach it
/// like `N_s⁻²`.
#[test]
fn the_sampled_jenkins_force_converges_to_the_masing_loop() {
    let o = OSCILLATOR;
    let (h, kp, amplitude, phase) = (3, 100.0 * K_NORMAL, 2.0, 0.3f64);
    let fs = o.mu * o.normal;
    let ratio = fs / (o.kt * amplitude);
    let tau1 = (1.0 - 2.0 * ratio).acos();
    let (a1, b1) = (
        -(o.kt * amplitude / PI) * (tau1 - 0.5 * (2.0 * tau1).sin()),
        4.0 * fs / PI * (1.0 - ratio),
    );
    // shifted by φ: Λ(τ − φ)
    let expected = [
        a1 * phase.cos() - b1 * phase.sin(),
        a1 * phase.sin() + b1 * phase.cos(),
    ];
    let with = jenkins_on_the_mass(o, kp);
    let without = jenkins_on_the_mass(Oscillator { mu: 0.0, ..o }, kp);
    let mut errors = Vec::new();
    for samples in [64, 256, 1024, 4096, 16384] {
        let mut pw = aft(&with, h, samples, kp, o.kt);
        let mut p0 = aft(&without, h, samples, kp, o.kt);
        let n = pw.system().nonlinear_dofs.len();
        let (tangential, normal) = (0, 1);
        assert_eq!(pw.system().nonlinear_dofs[..2], [0, 1]);
        let mut x = vec![0.0; pw.dimension()];
        x[normal] = o.normal / kp; // λ_N = k_p (−g) = N
        x[n + tangential] = amplitude * phase.cos();
        x[2 * n + tangential] = amplitude * phase.sin();
        let (rw, r0) = (pw.residual(&x, 1.0).unwrap(), p0.residual(&x, 1.0).unwrap());
        let k_ref = pw.reference_stiffness();
        let force = |m: usize| -k_ref * (rw[m * n + tangential] - r0[m * n + tangential]);
        assert!(force(0).abs() < 1e-12, "mean {}", force(0));
        let error = (force(1) - expected[0]).hypot(force(2) - expected[1]) / fs;
        errors.push(error);
    }
    println!("Masing loop, first harmonic error / F_s at 64 … 16384 samples: {errors:?}");
    // every step of ×4 gains at least 3.5 (the first is pre-asymptotic), and from 256 samples
    // on `error · N_s²` stays within a factor 3 (its constant depends on where the loop's kinks
    // fall between samples)
    for pair in errors.windows(2) {
        assert!(pair[1] < pair[0] / 3.5, "{errors:?}");
    }
    let scaled: Vec<f64> = errors[1..]
        .iter()
        .zip([256.0f64, 1024.0, 4096.0, 16384.0])
        .map(|(e, n)| e * n * n)
        .collect();
    let (low, high) = scaled
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(l, h), &s| (l.min(s), h.max(s)));
    assert!(high < 3.0 * low, "error · N_s²: {scaled:?}");
    assert!(errors[4] < 1e-7, "{errors:?}");
}

/// (T165), (T166): the analytic Jacobian of the sampled Jenkins forces against central
/// differences on the friction damper (five contacts that stick, slip both ways and lift off),
/// at an HBM-AFT solution and off it.
#[test]
fn the_jacobian_with_stick_slip_and_lift_off_equals_central_differences() {
    let model = example_model("friction_damper/model.toml", &[] as &[&str]);
    let (dof, h, omega) = (209, 3, hz(540.0));
    // the MS-HBM's unknowns are the same contact-node harmonics: a start close to the AFT's
    let (_, start) = solve_at_frequency(&mut ms_hbm(&model, h), omega, dof, &tight()).unwrap();
    assert!(start.converged);
    let mut p = HbmAft::new(
        &model,
        &HbmAftOptions {
            mass: MassKind::Redistributed,
            penalty: Penalty::Relative(1.0),
            tangential_penalty: Some(Penalty::Relative(1.0)),
            ..HbmAftOptions::new(h)
        },
    )
    .unwrap();
    let out = solve(&mut p, &start.x, omega, &NewtonOptions::default()).unwrap();
    assert!(out.converged, "{:?}", out.reason);
    let sol = p.solution(&out.x, omega, dof).unwrap();
    let (mut stuck, mut slipping, mut open) = (false, false, false);
    for fr in &sol.frictions {
        for (&t, &limit) in fr.force.iter().zip(&fr.limit) {
            open |= limit == 0.0;
            stuck |= limit > 0.0 && t.abs() < 0.99 * limit;
            slipping |= limit > 0.0 && t.abs() == limit;
        }
    }
    assert!(
        stuck && slipping && open,
        "stuck {stuck}, slipping {slipping}, open {open}"
    );
    assert_eq!(sol.frictions.len(), 5);
    for x in [&out.x, &perturbed(&out.x)] {
        assert_derivatives_match_finite_differences(&mut p, x, omega, 1e-6, "Jenkins damper");
    }
}

/// (T169): as `k_p, k_t → ∞` at fixed `H` the HBM-AFT does *not* tend to the MS-HBM. Its
/// contact node is a truncated series, which cannot rest during a stick phase, so its limit is
/// harmonic balance with rigid Coulomb friction on the truncated displacement; the MS-HBM's
/// massless node sticks exactly (non-harmonic). On the same model (the massless node behind a
/// spring, redistributed mass on both sides) the AFT's amplitude moves monotonically with the
/// penalty towards a limit whose distance from the MS-HBM shrinks like `1/H`, while the MS-HBM
/// is converged in `H` to 1e-4 already at `H = 3`.
#[test]
fn growing_penalties_tend_to_a_limit_that_differs_from_the_ms_hbm_by_the_truncation() {
    let o = OSCILLATOR;
    let omega = 1.2;
    let model = massless_node(o);
    let mut gaps = Vec::new();
    let mut ms_amplitudes = Vec::new();
    for h in [3usize, 7, 15, 31] {
        let (reference, out) =
            solve_at_frequency(&mut ms_hbm(&model, h), omega, 0, &tight()).unwrap();
        assert!(out.converged);
        let a0 = first_harmonic_amplitude(&reference);
        ms_amplitudes.push(a0);
        let mut x = out.x;
        let mut relative = Vec::new();
        for k in [1e1, 1e2, 1e3, 1e4, 1e5, 1e6] {
            let mut p = HbmAft::new(
                &model,
                &HbmAftOptions {
                    mass: MassKind::Redistributed,
                    samples: Some(4096),
                    penalty: Penalty::Stiffness(k * K_NORMAL),
                    tangential_penalty: Some(Penalty::Stiffness(k * o.kt)),
                    ..HbmAftOptions::new(h)
                },
            )
            .unwrap();
            let out = solve(&mut p, &x, omega, &NewtonOptions::default()).unwrap();
            assert!(out.converged, "H = {h}, k = {k:e}: {:?}", out.reason);
            let sol = p.solution(&out.x, omega, 0).unwrap();
            relative.push(first_harmonic_amplitude(&sol) / a0 - 1.0);
            x = out.x;
        }
        println!("H = {h}: AFT amplitude / MS-HBM − 1 at k = 1e1 … 1e6 × (K_N, k_t): {relative:?}");
        for pair in relative.windows(2) {
            assert!(pair[1] < pair[0], "H = {h}: not monotone: {relative:?}");
        }
        let steps: Vec<f64> = relative.windows(2).map(|p| p[0] - p[1]).collect();
        assert!(
            steps[4] < 0.5 * steps[2],
            "H = {h}: no limit in sight: {relative:?}"
        );
        gaps.push(-relative[5]);
    }
    println!("gap of the stiffest AFT at H = 3, 7, 15, 31: {gaps:?}; MS-HBM {ms_amplitudes:?}");
    let spread = ms_amplitudes
        .iter()
        .fold(0.0f64, |s, a| s.max((a / ms_amplitudes[3] - 1.0).abs()));
    assert!(spread < 2e-4, "{ms_amplitudes:?}");
    for pair in gaps.windows(2) {
        assert!(pair[1] < 0.7 * pair[0] && pair[1] > 0.0, "{gaps:?}");
    }
}

#[test]
fn bad_friction_settings_are_clear_errors() {
    let o = OSCILLATOR;
    let model = jenkins_on_the_mass(o, 1e3);
    let err = |options: HbmAftOptions| HbmAft::new(&model, &options).err().unwrap().to_string();
    for kt in [-1.0, 0.0, f64::NAN, f64::INFINITY] {
        for penalty in [Penalty::Stiffness(kt), Penalty::Relative(kt)] {
            let e = err(HbmAftOptions {
                tangential_penalty: Some(penalty),
                ..HbmAftOptions::new(3)
            });
            assert!(
                e.contains("tangential penalty") && e.contains("positive"),
                "{e}"
            );
        }
    }
    let e = err(HbmAftOptions {
        quadrature: Quadrature::Exact,
        ..HbmAftOptions::new(3)
    });
    assert!(
        e.contains("exact quadrature") && e.contains("sampled"),
        "{e}"
    );
    // the default k_t is the contact's normal penalty
    let p = HbmAft::new(&model, &HbmAftOptions::new(3)).unwrap();
    assert_eq!(p.tangential_penalties(), p.penalties());
    // a relative tangential penalty is a multiple of the stiffness along the tangent (k)
    let p = HbmAft::new(
        &model,
        &HbmAftOptions {
            tangential_penalty: Some(Penalty::Relative(50.0)),
            ..HbmAftOptions::new(3)
        },
    )
    .unwrap();
    assert!((p.tangential_penalties()[0] - 50.0 * o.k).abs() < 1e-12);
    // no Floquet multipliers with friction (the slider would be part of the state)
    let mut p = aft(&model, 3, 256, 1e3, o.kt);
    let x = vec![0.0; p.dimension()];
    assert!(p.floquet(&x, 1.0).unwrap().is_none());
}
