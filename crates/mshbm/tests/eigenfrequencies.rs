//! Eigenfrequencies of the paper's bar against the continuum (analytic) values, and the
//! effect of mass redistribution against the paper's 60335 Hz.

use std::path::{Path, PathBuf};

use mshbm::model::bar::BarParameters;
use mshbm::model::file::load_model;
use mshbm::modes::{eigenfrequencies_hz, first_angular_frequency};
use mshbm::MassKind;

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

fn bar_frequencies(elements: usize, kind: MassKind, count: usize) -> Vec<f64> {
    let mut p = BarParameters::paper();
    p.elements = elements;
    let s = p.build(Path::new("bar")).unwrap().system(kind).unwrap();
    eigenfrequencies_hz(&s.mass, &s.stiffness, count).unwrap()
}

/// Clamped–free bar: f_k = (2k − 1) c / (4L).
fn continuum_hz(k: usize) -> f64 {
    let p = BarParameters::paper();
    (2 * k - 1) as f64 * p.wave_speed() / (4.0 * p.length)
}

#[test]
fn consistent_first_eigenfrequency_matches_continuum() {
    let f = bar_frequencies(100, MassKind::Consistent, 1)[0];
    let exact = continuum_hz(1);
    assert!(
        (f / exact - 1.0).abs() < 1e-4,
        "f1 = {f}, continuum {exact}"
    );
}

#[test]
fn consistent_eigenfrequencies_converge_at_second_order() {
    let coarse = bar_frequencies(100, MassKind::Consistent, 10);
    let fine = bar_frequencies(200, MassKind::Consistent, 10);
    let finer = bar_frequencies(400, MassKind::Consistent, 10);
    for k in 0..10 {
        let exact = continuum_hz(k + 1);
        let (e1, e2, e3) = (coarse[k] - exact, fine[k] - exact, finer[k] - exact);
        // consistent mass over-estimates; error ~ h^2, so halving h divides it by 4
        assert!(
            e1 > 0.0 && e2 > 0.0 && e3 > 0.0,
            "mode {}: errors {e1} {e2} {e3}",
            k + 1
        );
        for ratio in [e1 / e2, e2 / e3] {
            assert!(
                (ratio - 4.0).abs() < 0.1,
                "mode {}: error ratio {ratio}",
                k + 1
            );
        }
    }
}

#[test]
fn redistributed_first_eigenfrequency_is_the_papers() {
    let f = bar_frequencies(100, MassKind::Redistributed, 1)[0];
    assert!((f - 60335.0).abs() < 1.0, "f1 = {f} Hz, paper: 60335 Hz");
}

#[test]
fn redistribution_shift_of_the_first_30_modes_is_small() {
    // The paper's Fig. 8 claim: the shift is negligible (well under 1 %).
    let a = bar_frequencies(100, MassKind::Consistent, 30);
    let b = bar_frequencies(100, MassKind::Redistributed, 30);
    for k in 0..30 {
        let rel = b[k] / a[k] - 1.0;
        assert!(rel.abs() < 5e-3, "mode {}: {rel}", k + 1);
    }
}

#[test]
fn matrices_model_of_the_bar_equals_the_built_in_bar() {
    let built_in = load_model(&examples().join("clamped_bar.toml"), &[]).unwrap();
    let general = load_model(&examples().join("bar_matrices/model.toml"), &[]).unwrap();
    for kind in [MassKind::Consistent, MassKind::Redistributed] {
        let a = built_in.system(kind).unwrap();
        let b = general.system(kind).unwrap();
        let fa = eigenfrequencies_hz(&a.mass, &a.stiffness, 30).unwrap();
        let fb = eigenfrequencies_hz(&b.mass, &b.stiffness, 30).unwrap();
        for (x, y) in fa.iter().zip(&fb) {
            assert!((x / y - 1.0).abs() < 1e-10, "{kind:?}: {x} vs {y}");
        }
        assert_eq!(a.harmonic_load, b.harmonic_load);
        assert_eq!(a.contacts, b.contacts);
        assert_eq!(a.nonlinear_dofs, b.nonlinear_dofs);
    }
}

#[test]
fn first_mode_damping_ratio_sets_alpha_from_the_first_eigenfrequency() {
    let overrides = ["damping.first_mode_ratio=0.01".to_string()];
    let model = load_model(&examples().join("clamped_bar.toml"), &overrides).unwrap();
    for kind in [MassKind::Consistent, MassKind::Redistributed] {
        let s = model.system(kind).unwrap();
        // independent reference: the dense eigen solver
        let f1 = eigenfrequencies_hz(&s.mass, &s.stiffness, 1).unwrap()[0];
        let expected = 2.0 * 0.01 * 2.0 * std::f64::consts::PI * f1;
        assert!(
            (s.alpha / expected - 1.0).abs() < 1e-9,
            "{kind:?}: alpha {} vs {expected}",
            s.alpha
        );
        let w1 = first_angular_frequency(&s.mass, &s.stiffness).unwrap();
        assert!((w1 / (2.0 * std::f64::consts::PI * f1) - 1.0).abs() < 1e-10);
    }
}

#[test]
fn overrides_change_gap_and_damping() {
    let path = examples().join("clamped_bar.toml");
    let m = load_model(
        &path,
        &["contact.gap=0".into(), "damping.alpha=7587.7".into()],
    )
    .unwrap();
    assert_eq!(m.contacts[0].gap, 0.0);
    assert_eq!(m.damping.alpha, 7587.7);
    let s = m.system(MassKind::Redistributed).unwrap();
    let expected = s.mass.get(10, 10) * 7587.7;
    assert!((s.damping.get(10, 10) - expected).abs() <= 1e-15 * expected.abs());
    let g0 = load_model(&examples().join("clamped_bar_gap0.toml"), &[]).unwrap();
    assert_eq!(g0.contacts[0].gap, 0.0);
}

/// The sparse path (subspace iteration on the whole model, above `DENSE_EIGEN_LIMIT` DOFs
/// with mass) against the dense path on the same bar, with both masses: the redistributed
/// one has a massless DOF, which the dense path condenses statically and the sparse path
/// does not need to.
#[test]
fn sparse_and_dense_eigenfrequencies_agree_on_both_masses() {
    let elements = 1200;
    assert!(elements <= mshbm::modes::DENSE_EIGEN_LIMIT);
    for kind in [MassKind::Consistent, MassKind::Redistributed] {
        let mut p = BarParameters::paper();
        p.elements = elements;
        let s = p.build(Path::new("bar")).unwrap().system(kind).unwrap();
        let dense = eigenfrequencies_hz(&s.mass, &s.stiffness, 20).unwrap();
        let sparse = mshbm::modes::lowest_modes(&s.mass, &s.stiffness, 20).unwrap();
        for (k, (&d, &lam)) in dense.iter().zip(&sparse.eigenvalues).enumerate() {
            let f = lam.sqrt() / (2.0 * std::f64::consts::PI);
            assert!(
                (f / d - 1.0).abs() < 1e-9,
                "{kind:?} mode {}: sparse {f}, dense {d}",
                k + 1
            );
        }
    }
}

/// A bar far above the dense limit (20 000 elements: a dense path would need 19 GB and
/// minutes) against the continuum: the FE error of the consistent mass is
/// `(k h)²/24`-small, below 1e-6 for the first five modes.
#[test]
fn a_long_bar_takes_the_sparse_path_and_matches_the_continuum() {
    let f = bar_frequencies(20_000, MassKind::Consistent, 5);
    for (k, &fk) in f.iter().enumerate() {
        let exact = continuum_hz(k + 1);
        assert!(
            (fk / exact - 1.0).abs() < 1e-6,
            "mode {}: {fk} vs {exact}",
            k + 1
        );
    }
}

/// A stiffness that is not positive definite with the Dirichlet DOFs fixed is an error,
/// never 0 Hz or NaN: a free bar (the dropped bar: one rigid-body mode), and an indefinite
/// stiffness, on both paths.
#[test]
fn singular_and_indefinite_stiffness_are_refused() {
    let model = mshbm::model::file::load_model(&examples().join("dropped_bar.toml"), &[]).unwrap();
    let err = model.compare_masses(3).unwrap_err().to_string();
    assert!(err.contains("1 rigid-body mode"), "{err}");

    // springs k = 1, -1 between ground and two unit masses (dense path), and a long chain
    // with one negative spring (sparse path)
    let m = mshbm::sparse::SparseMatrix::from_triplets(2, 2, &[(0, 0, 1.0), (1, 1, 1.0)]);
    let k = mshbm::sparse::SparseMatrix::from_triplets(2, 2, &[(0, 0, 1.0), (1, 1, -1.0)]);
    let err = eigenfrequencies_hz(&m, &k, 1).unwrap_err().to_string();
    assert!(err.contains("indefinite"), "{err}");
    let n = mshbm::modes::DENSE_EIGEN_LIMIT + 10;
    let m = mshbm::sparse::SparseMatrix::from_triplets(
        n,
        n,
        &(0..n).map(|i| (i, i, 1.0)).collect::<Vec<_>>(),
    );
    let k = mshbm::sparse::SparseMatrix::from_triplets(
        n,
        n,
        &(0..n)
            .map(|i| (i, i, if i == n / 2 { -1.0 } else { 1.0 + i as f64 }))
            .collect::<Vec<_>>(),
    );
    let err = eigenfrequencies_hz(&m, &k, 3).unwrap_err().to_string();
    assert!(err.contains("not positive definite"), "{err}");
}

/// The eigensolver plans its memory before allocating: a budget below the plan refuses
/// with the number of DOFs named.
#[test]
fn eigenfrequencies_over_the_memory_budget_are_refused() {
    let mut p = BarParameters::paper();
    p.elements = 20_000;
    let s = p
        .build(Path::new("bar"))
        .unwrap()
        .system(MassKind::Consistent)
        .unwrap();
    let limits = mshbm::limits::Limits {
        memory_bytes: 1 << 20,
        file_bytes: 1 << 20,
        cancel: Default::default(),
    };
    let err =
        mshbm::modes::eigenfrequencies_hz_within(&s.mass, &s.stiffness, 30, &limits).unwrap_err();
    assert!(matches!(err, mshbm::Error::ResourceLimit { .. }), "{err}");
    assert!(err.to_string().contains("20000 DOFs"), "{err}");
}

/// The block Krylov path of `lowest_modes` on a 3D plate (clustered bending and in-plane
/// modes, massless contact nodes after redistribution) against the dense path: the
/// eigenfrequencies, and the shapes' residuals and mass orthonormality.
#[test]
fn the_block_krylov_modes_of_a_plate_match_the_dense_ones() {
    let model = load_model(
        &examples().join("block_3d/model.toml"),
        &["solid.divisions=[8,8,4]".to_string()],
    )
    .unwrap();
    for kind in [MassKind::Consistent, MassKind::Redistributed] {
        let s = model.system(kind).unwrap();
        let count = 60;
        let dense = eigenfrequencies_hz(&s.mass, &s.stiffness, count).unwrap();
        let modes = mshbm::modes::lowest_modes(&s.mass, &s.stiffness, count).unwrap();
        assert_eq!(
            modes.solver,
            mshbm::modes::ModeSolver::BlockKrylov,
            "{kind:?}"
        );
        for (k, (&d, &lam)) in dense.iter().zip(&modes.eigenvalues).enumerate() {
            let f = lam.sqrt() / (2.0 * std::f64::consts::PI);
            assert!(
                (f / d - 1.0).abs() < 1e-9,
                "{kind:?} mode {}: {f} vs {d}",
                k + 1
            );
        }
        let (k, m) = (s.stiffness.to_faer(), s.mass.to_faer());
        let (kp, mp) = (&k * &modes.shapes, &m * &modes.shapes);
        let gram = modes.shapes.transpose() * &mp;
        for i in 0..count {
            for j in 0..count {
                let expected = if i == j { 1.0 } else { 0.0 };
                assert!(
                    (gram[(i, j)] - expected).abs() < 1e-9,
                    "{kind:?} ΦᵀMΦ[{i},{j}]"
                );
            }
            let lam = modes.eigenvalues[i];
            let residual: f64 = (0..kp.nrows())
                .map(|r| (kp[(r, i)] - lam * mp[(r, i)]).powi(2))
                .sum();
            let size: f64 = (0..kp.nrows()).map(|r| (lam * mp[(r, i)]).powi(2)).sum();
            assert!(
                residual.sqrt() <= 1e-7 * size.sqrt(),
                "{kind:?} mode {i}: residual"
            );
        }
    }
}
