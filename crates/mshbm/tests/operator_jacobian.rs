//! The operator form of the redistributed MS-HBM's Jacobian (docs/theory.md §18) against
//! independent references: its action against central differences of the residual, Newton
//! and the continuation with it against the dense LU path.

mod common;

use mshbm::continuation::arclength::{trace_branch, ContinuationOptions, StopReason};
use mshbm::harmonic::Quadrature;
use mshbm::method::redistributed::{JacobianForm, RedistributedMsHbm, RedistributedOptions};
use mshbm::model::lattice::lattice_model;
use mshbm::newton::{solve, NewtonOptions};
use mshbm::problem::{Jacobian, PeriodicProblem};
use mshbm::Model;

use common::{hz, max_abs};

/// The lattice of `tests/redistributed.rs`: 7 contacts, every one closing at 5 Hz.
fn lattice() -> Model {
    lattice_model(6, 8, 25.0, 5.0)
}

fn method(model: &Model, quadrature: Quadrature, jacobian: JacobianForm) -> RedistributedMsHbm {
    RedistributedMsHbm::new(
        model,
        &RedistributedOptions {
            quadrature,
            jacobian,
            ..RedistributedOptions::new(3)
        },
    )
    .unwrap()
}

/// The solution at `f` Hz (Newton from the linear response).
fn solution(p: &mut RedistributedMsHbm, f: f64) -> Vec<f64> {
    let x0 = p.initial_guess(hz(f)).unwrap();
    let out = solve(p, &x0, hz(f), &NewtonOptions::default()).unwrap();
    assert!(out.converged, "{out:?}");
    out.x
}

#[test]
fn the_operator_applies_the_jacobian_of_the_residual() {
    let model = lattice();
    for quadrature in [Quadrature::Exact, Quadrature::Sampled] {
        let mut p = method(&model, quadrature, JacobianForm::Operator);
        let x = common::perturbed(&solution(&mut p, 5.0));
        let omega = hz(5.0);
        let lin = p.linearize(&x, omega).unwrap();
        let Jacobian::Operator(op) = &lin.jacobian else {
            panic!("JacobianForm::Operator gives an operator");
        };
        let n = x.len();
        for seed in 0..3 {
            let v: Vec<f64> = (0..n)
                .map(|i| ((i * 7 + seed * 3) as f64 * 0.61).sin())
                .collect();
            let mut jv = vec![0.0; n];
            op.apply(&v, &mut jv);
            let fd = common::directional_difference(&mut p, &x, omega, &v);
            let err = max_abs(fd.iter().zip(&jv).map(|(a, b)| a - b)) / max_abs(fd.iter().copied());
            assert!(
                err < 1e-6,
                "{quadrature:?}, direction {seed}: relative error {err:.2e}"
            );
        }
        // the action (per-harmonic products and the force maps' sums) and the dense form's
        // matrix (block products over the closed rows) are two codes of (T129): they agree
        let dense = method(&model, quadrature, JacobianForm::Dense)
            .linearize(&x, omega)
            .unwrap()
            .jacobian;
        let v: Vec<f64> = (0..n).map(|i| 1.0 + (i as f64 * 0.37).cos()).collect();
        let by_matrix = dense.apply(&v);
        let mut by_action = vec![0.0; n];
        op.apply(&v, &mut by_action);
        let err = max_abs(by_matrix.iter().zip(&by_action).map(|(a, b)| a - b))
            / max_abs(by_matrix.iter().copied());
        assert!(err < 1e-12, "{quadrature:?}: {err:.2e}");
    }
}

#[test]
fn newton_with_the_operator_reaches_the_dense_solution() {
    let model = lattice();
    for f in [4.0, 5.0, 6.0] {
        let dense = solution(
            &mut method(&model, Quadrature::Exact, JacobianForm::Dense),
            f,
        );
        let operator = solution(
            &mut method(&model, Quadrature::Exact, JacobianForm::Operator),
            f,
        );
        let err = max_abs(dense.iter().zip(&operator).map(|(a, b)| a - b))
            / max_abs(dense.iter().copied());
        assert!(err < 1e-9, "{f} Hz: {err:.2e}");
    }
}

#[test]
fn a_continuation_with_the_operator_passes_the_same_folds_as_the_dense_one() {
    // the hardening bilinear oscillator of tests/continuation.rs: two folds between 0.5 and
    // 2.5 rad/s, where the Jacobian is singular and only the bordered system is regular
    let model = common::bilinear_oscillator(1.0, 1.0, 3.0, 1.0, 0.1, 0.04);
    let options = ContinuationOptions::new(0.5, 2.5);
    let mut branches = Vec::new();
    for form in [JacobianForm::Dense, JacobianForm::Operator] {
        let mut p = RedistributedMsHbm::new(
            &model,
            &RedistributedOptions {
                jacobian: form,
                ..RedistributedOptions::new(5)
            },
        )
        .unwrap();
        let branch = trace_branch(&mut p, &options, |_, _| Ok(())).unwrap();
        assert_eq!(branch.stop, StopReason::ReachedEnd, "{form:?}");
        branches.push((p, branch));
    }
    let (_, operator) = branches.pop().unwrap();
    let (mut p, dense) = branches.pop().unwrap();
    assert_eq!(dense.folds.len(), 2);
    assert_eq!(operator.folds.len(), 2);
    for (a, b) in dense.folds.iter().zip(&operator.folds) {
        assert!(
            (a.omega / b.omega - 1.0).abs() < 1e-8,
            "{} vs {}",
            a.omega,
            b.omega
        );
    }
    // every point of the operator's branch solves the dense path's problem
    let scale = p.length_scale();
    for point in &operator.points {
        let r = p.residual(&point.x, point.omega).unwrap();
        assert!(
            max_abs(r.iter().copied()) <= 1e-9 * scale,
            "{} rad/s",
            point.omega
        );
    }
    let ratio = operator.points.len() as f64 / dense.points.len() as f64;
    assert!(
        (0.8..1.25).contains(&ratio),
        "{} vs {} points",
        operator.points.len(),
        dense.points.len()
    );
}
