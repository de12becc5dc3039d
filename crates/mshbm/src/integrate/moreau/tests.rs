//! Friction in the Moreau–Jean scheme against closed-form references.
use crate::integrate::{Integrator, Scheme, Settings};
use crate::model::{Contact, Damping, Friction, FrictionNormal, MassKind, Model};
use crate::sparse::SparseMatrix;

fn model(
    mass: &[f64],
    stiffness: &[(usize, usize, f64)],
    constant: Vec<f64>,
    contacts: Vec<Contact>,
    frictions: Vec<Friction>,
) -> Model {
    let n = mass.len();
    let m: Vec<(usize, usize, f64)> = mass.iter().enumerate().map(|(i, &v)| (i, i, v)).collect();
    Model {
        stiffness_file: None,
        source: "friction unit test".into(),
        input_files: vec![],
        cells: None,
        node_sets: Default::default(),
        node_labels: None,
        interfaces: vec![],
        name: "friction unit test".into(),
        mass: SparseMatrix::from_triplets(n, n, &m),
        stiffness: SparseMatrix::from_triplets(n, n, stiffness),
        damping_matrix: None,
        coordinates: (0..n).map(|i| vec![i as f64]).collect(),
        dofs_per_node: 1,
        dirichlet: vec![],
        contacts,
        frictions,
        harmonic_load: vec![0.0; n],
        constant_load: constant,
        acceleration: None,
        damping: Damping::default(),
    }
}

fn integrator(model: &Model, dt: f64) -> Integrator {
    let system = model.system(MassKind::Consistent).unwrap();
    Integrator::new(
        &system,
        &Settings {
            dt,
            scheme: Scheme::MoreauJean {
                theta: 0.5,
                restitution: 0.0,
            },
            omega: None,
            energy_offset: 0.0,
        },
    )
    .unwrap()
}

fn damper(dof: usize, mu: f64, fnorm: f64) -> Friction {
    Friction {
        dofs: vec![dof],
        w: vec![1.0],
        mu,
        normal: FrictionNormal::Force(fnorm),
    }
}

/// Free vibration of `m x'' + k x = −μ F_N sign(ẋ)`: each half cycle the amplitude
/// drops by exactly `2 μ F_N / k`, and the motion stops in the first reversal inside
/// `|x| ≤ μ F_N / k` (sticks there for ever). Friction force never above `μ F_N`.
#[test]
fn coulomb_damped_oscillator_decays_linearly_and_sticks() {
    let (m, k, mu, fnorm) = (1.0, 1.0, 0.25, 0.4); // μF_N/k = 0.1
    let md = model(
        &[m],
        &[(0, 0, k)],
        vec![0.0],
        vec![],
        vec![damper(0, mu, fnorm)],
    );
    let dt = 2.0 * std::f64::consts::PI / 20000.0;
    let mut it = integrator(&md, dt);
    let x0 = 0.85;
    it.set_state(0.0, &[x0], &[0.0]).unwrap();
    let mut extremes = vec![x0];
    let mut last_v = 0.0f64;
    let mut max_force = 0.0f64;
    for _ in 0..200_000 {
        it.step().unwrap();
        max_force = max_force.max(it.friction_forces()[0].abs());
        let v = it.v()[0];
        if last_v != 0.0 && v * last_v <= 0.0 {
            extremes.push(it.q()[0]);
        }
        if v != 0.0 {
            last_v = v;
        }
    }
    assert!(max_force <= mu * fnorm * (1.0 + 1e-14), "{max_force}");
    // reversals: 0.85, −0.65, 0.45, −0.25, 0.05 (stops: |0.05| < 0.1)
    let expected = [0.85, -0.65, 0.45, -0.25, 0.05];
    assert!(extremes.len() >= expected.len(), "{extremes:?}");
    for (e, x) in expected.iter().zip(&extremes) {
        assert!((e - x).abs() < 2e-3, "extremes {extremes:?}");
    }
    // at rest, sticking: the velocity is exactly zero and the force balances the spring
    assert_eq!(it.v()[0], 0.0);
    assert!((it.q()[0] - 0.05).abs() < 2e-3);
    assert!((it.friction_forces()[0] - k * it.q()[0]).abs() < 1e-9);
}

/// A free mass under a constant force `F`: sticks exactly (`v = 0`) when `F ≤ μ F_N`,
/// accelerates at `(F − μ F_N)/m` otherwise.
#[test]
fn block_on_rough_ground_sticks_or_slides() {
    for (force, expect_acc) in [(0.9, 0.0), (1.5, 0.25)] {
        let md = model(
            &[2.0],
            &[(0, 0, 0.0)],
            vec![force],
            vec![],
            vec![damper(0, 0.5, 2.0)],
        );
        let mut it = integrator(&md, 1e-3);
        for _ in 0..1000 {
            it.step().unwrap();
            assert!(it.friction_forces()[0].abs() <= 1.0 * (1.0 + 1e-14));
        }
        let t = it.time();
        assert!((it.v()[0] - expect_acc * t).abs() < 1e-12, "{}", it.v()[0]);
        if expect_acc == 0.0 {
            assert_eq!(it.q()[0], 0.0);
            assert!((it.friction_forces()[0] + force).abs() < 1e-12);
        } else {
            assert!((it.q()[0] - 0.5 * expect_acc * t * t).abs() < 1e-9);
            assert!((it.friction_forces()[0] + 1.0).abs() < 1e-12);
        }
    }
}

/// Friction coupled to a unilateral contact: a block (DOF 0 tangential, DOF 1 normal)
/// pressed onto the ground by `F_y` and pulled by `F_x`. The normal force is `F_y`, the
/// friction limit `μ F_y`; no friction when the block is lifted off.
#[test]
fn friction_coupled_to_contact() {
    let mu = 0.4;
    for (fx, fy, acc_x) in [(0.3, -1.0, 0.0), (0.6, -1.0, 0.2), (0.6, 1.0, 0.6)] {
        let md = model(
            &[1.0, 1.0],
            &[(0, 0, 0.0), (1, 1, 0.0)],
            vec![fx, fy],
            vec![Contact {
                dofs: vec![1],
                w: vec![1.0],
                gap: 0.0,
                friction: None,
            }],
            vec![Friction {
                dofs: vec![0],
                w: vec![1.0],
                mu,
                normal: FrictionNormal::Contact(0),
            }],
        );
        let mut it = integrator(&md, 1e-3);
        for _ in 0..500 {
            it.step().unwrap();
            assert!(it.friction_forces()[0].abs() <= mu * it.forces()[0] * (1.0 + 1e-12) + 1e-15);
        }
        let t = it.time();
        assert!(
            (it.v()[0] - acc_x * t).abs() < 1e-10,
            "{fx} {fy}: {}",
            it.v()[0]
        );
        if fy < 0.0 {
            assert!((it.forces()[0] + fy).abs() < 1e-10);
            assert!(it.v()[1].abs() < 1e-12);
        } else {
            assert_eq!(it.friction_forces()[0], 0.0);
        }
    }
}

/// Several friction elements: two masses coupled by a spring, each with a friction
/// damper to ground, under constant forces — one sticks, the other slides; the joint
/// solution satisfies both laws exactly (stick: zero slip velocity; slip: force at the
/// limit opposing the motion).
#[test]
fn several_friction_elements_satisfy_their_laws() {
    let k = 100.0;
    let md = model(
        &[1.0, 1.0],
        &[(0, 0, k), (0, 1, -k), (1, 0, -k), (1, 1, k)],
        vec![2.5, 0.0],
        vec![],
        vec![damper(0, 0.5, 2.0), damper(1, 0.5, 4.0)],
    );
    let mut it = integrator(&md, 1e-3);
    let mut slid = false;
    for _ in 0..10000 {
        it.step().unwrap();
        for (f, limit) in [(0, 1.0), (1, 2.0)] {
            let p = it.friction_forces()[f];
            let v = it.v()[f];
            assert!(p.abs() <= limit * (1.0 + 1e-14));
            if v.abs() > 1e-12 {
                // slipping: at the limit, opposing the (post-step) velocity
                assert!((p + limit * v.signum()).abs() < 1e-9, "{f}: p {p} v {v}");
                slid |= f == 0;
            }
        }
    }
    assert!(slid);
    // final state: both stick (total friction capacity 3 > 2.5): mass 0 needs
    // |2.5 − spring| ≤ 1, mass 1 needs |spring| ≤ 2, spring = k (x0 − x1) ∈ [1.5, 2].
    assert!(
        it.v()[0].abs() < 1e-9 && it.v()[1].abs() < 1e-9,
        "{:?} {:?}",
        it.v(),
        it.q()
    );
    let spring = k * (it.q()[0] - it.q()[1]);
    assert!((1.5 - 1e-9..=2.0 + 1e-9).contains(&spring), "{spring}");
}
