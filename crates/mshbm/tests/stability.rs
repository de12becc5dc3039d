//! Floquet multipliers of redistributed MS-HBM solutions (METHODS §7.2) against
//! independent references: the damped eigenvalues of the linear system, and the folds of
//! the frequency response diagram.

mod common;

use std::f64::consts::PI;

use faer::linalg::solvers::Solve;
use faer::{c64, Mat};
use mshbm::continuation::arclength::{trace_branch, ContinuationOptions};
use mshbm::continuation::newton::{solve_at_frequency, NewtonOptions};
use mshbm::method::redistributed::quadrature::Quadrature;
use mshbm::method::redistributed::{RedistributedMsHbm, RedistributedOptions};
use mshbm::model::file::load_model;
use mshbm::problem::PeriodicProblem;
use mshbm::MassKind;

#[test]
fn linear_limit_multipliers_are_exponentials_of_the_damped_eigenvalues() {
    let model = load_model(
        &common::examples().join("clamped_bar.toml"),
        &[
            "bar.elements=20".into(),
            "contact.gap=100".into(),
            "damping.first_mode_ratio=0.01".into(),
        ],
    )
    .unwrap();
    let f = 30e3;
    let omega = 2.0 * PI * f;
    let mut p = RedistributedMsHbm::new(
        &model,
        &RedistributedOptions {
            harmonics: 3,
            samples: None,
            quadrature: Quadrature::Exact,
        },
    )
    .unwrap();
    let (_, out) = solve_at_frequency(&mut p, omega, 20, &NewtonOptions::default()).unwrap();
    assert!(out.converged);
    let floquet = p.floquet(&out.x, omega).unwrap().unwrap();

    // independent reference: eigenvalues s_k of the first-order form of the contact-free
    // system with the massless DOF condensed statically, multipliers exp(s_k T)
    let s = model.system(MassKind::Redistributed).unwrap();
    let (l, nset) = (&s.linear_dofs, &s.nonlinear_dofs);
    let dense =
        |a: &mshbm::sparse::SparseMatrix, r: &[usize], c: &[usize]| a.submatrix(r, c).to_dense();
    let k_nn = dense(&s.stiffness, nset, nset);
    let k_nl = dense(&s.stiffness, nset, l);
    let k_ln = dense(&s.stiffness, l, nset);
    let k_eff = dense(&s.stiffness, l, l) - &k_ln * k_nn.partial_piv_lu().solve(&k_nl);
    let m = dense(&s.mass, l, l);
    let c = dense(&s.damping, l, l);
    let nl = l.len();
    let mk = m.partial_piv_lu().solve(&k_eff);
    let mc = m.partial_piv_lu().solve(&c);
    // balanced first-order form (z = (w q, q̇)): accurate eigenvalues of a stiff system
    let w = 1e7;
    let a = Mat::<f64>::from_fn(2 * nl, 2 * nl, |i, j| match (i < nl, j < nl) {
        (true, true) => 0.0,
        (true, false) => w * f64::from(u8::from(j - nl == i)),
        (false, true) => -mk[(i - nl, j)] / w,
        (false, false) => -mc[(i - nl, j - nl)],
    });
    let period = 1.0 / f;
    let reference: Vec<c64> = a
        .eigenvalues()
        .unwrap()
        .iter()
        .map(|s| (s * period).exp())
        .collect();
    assert_eq!(floquet.multipliers.len(), reference.len());
    let mut worst = 0.0f64;
    for mu in &floquet.multipliers {
        let mu = c64::new(mu[0], mu[1]);
        let d = reference
            .iter()
            .map(|r| (r - mu).norm())
            .fold(f64::INFINITY, f64::min);
        worst = worst.max(d);
    }
    println!(
        "max |μ − exp(s_k T)| = {worst:.2e}; largest |μ| = {}",
        floquet.max_multiplier
    );
    assert!(worst < 1e-8, "{worst}");
    // mass-proportional damping: every mode decays at α/2, so |μ| = exp(−αT/2) for all
    let expected = (-s.alpha * period / 2.0).exp();
    assert!((floquet.max_multiplier - expected).abs() < 1e-8);
    assert!(floquet.stable);
}

#[test]
fn stability_changes_at_the_folds_of_the_bilinear_oscillator() {
    let model = common::bilinear_oscillator(1.0, 1.0, 3.0, 1.0, 0.1, 0.04);
    for harmonics in [5, 10] {
        let mut p = RedistributedMsHbm::new(
            &model,
            &RedistributedOptions {
                harmonics,
                samples: None,
                quadrature: Quadrature::Exact,
            },
        )
        .unwrap();
        let mut options = ContinuationOptions::new(0.5, 2.5);
        options.max_step = 0.01;
        let branch = trace_branch(&mut p, &options, |_, _| Ok(())).unwrap();
        assert_eq!(branch.folds.len(), 2);
        let mut stable = Vec::new();
        let mut largest_real = Vec::new();
        for pt in &branch.points {
            let f = p.floquet(&pt.x, pt.omega).unwrap().unwrap();
            stable.push(f.stable);
            largest_real.push(
                f.multipliers
                    .iter()
                    .filter(|m| m[1].abs() < 1e-12)
                    .map(|m| m[0])
                    .fold(f64::NEG_INFINITY, f64::max),
            );
        }
        let changes: Vec<usize> = (1..stable.len())
            .filter(|&k| stable[k] != stable[k - 1])
            .collect();
        // one change per fold: stable below the upper fold, unstable on the middle branch,
        // stable again after the lower fold
        assert_eq!(changes.len(), 2, "H = {harmonics}: changes at {changes:?}");
        assert!(stable[0] && !stable[changes[0]] && stable[stable.len() - 1]);
        let mid = (changes[0] + changes[1]) / 2;
        assert!(
            largest_real[mid] > 1.0,
            "a real multiplier outside the unit circle: {}",
            largest_real[mid]
        );
        for (c, fold) in changes.iter().zip(&branch.folds) {
            // a real multiplier crosses +1 between points c-1 and c; on a turning point ω
            // is flat, so compare frequencies
            let (w0, w1) = (branch.points[c - 1].omega, branch.points[*c].omega);
            let (m0, m1) = (largest_real[c - 1], largest_real[*c]);
            assert!(
                (m0 - 1.0) * (m1 - 1.0) <= 0.0,
                "the multiplier crosses +1: {m0} → {m1}"
            );
            let crossing = w0 + (1.0 - m0) / (m1 - m0) * (w1 - w0);
            let rel = crossing / fold.omega - 1.0;
            println!("H = {harmonics}: fold at {:.8}, multiplier +1 at {crossing:.8} (relative {rel:.1e})", fold.omega);
            // the monodromy is that of the H-truncated approximation, so the crossing
            // approaches the fold as H grows rather than sitting exactly on it
            assert!(
                rel.abs() < if harmonics == 5 { 2e-3 } else { 5e-4 },
                "H = {harmonics}: {rel}"
            );
        }
    }
}

/// The fixed-interface modes of the reduced stability basis (subspace iteration,
/// `modes::lowest_modes`) against the dense symmetric solver and the continuum: the L-part
/// of the clamped bar with the contact DOF held is a fixed–fixed bar, `f_k = k c/(2L)`.
#[test]
fn subspace_iteration_finds_the_fixed_interface_modes() {
    let model = load_model(
        &common::examples().join("clamped_bar.toml"),
        &["bar.elements=400".into()],
    )
    .unwrap();
    let s = model.system(MassKind::Redistributed).unwrap();
    let l = &s.linear_dofs;
    let (m, k) = (s.mass.submatrix(l, l), s.stiffness.submatrix(l, l));
    let dense = mshbm::modes::eigenfrequencies_hz(&m, &k, 80).unwrap();
    let c = (2.1e5f64 / 9e-9).sqrt();
    for count in [10, 80] {
        let modes = mshbm::modes::lowest_modes(&m, &k, count).unwrap();
        for (i, lam) in modes.eigenvalues.iter().enumerate() {
            let f = lam.sqrt() / (2.0 * PI);
            assert!(
                (f / dense[i] - 1.0).abs() < 1e-9,
                "mode {i}: {f} vs {}",
                dense[i]
            );
        }
        let continuum = c / 40.0;
        assert!((modes.eigenvalues[0].sqrt() / (2.0 * PI) / continuum - 1.0).abs() < 1e-3);
        // mass-normalised and K-orthogonal: ΦᵀMΦ = I, ΦᵀKΦ = Λ
        let phi = &modes.shapes;
        let mm = phi.transpose() * (m.to_faer() * phi);
        let kk = phi.transpose() * (k.to_faer() * phi);
        for i in 0..count {
            for j in 0..count {
                let (e_m, e_k) = if i == j {
                    (1.0, modes.eigenvalues[i])
                } else {
                    (0.0, 0.0)
                };
                assert!((mm[(i, j)] - e_m).abs() < 1e-9, "M {i} {j}");
                assert!(
                    (kk[(i, j)] - e_k).abs() < 1e-9 * modes.eigenvalues[count - 1],
                    "K {i} {j}"
                );
            }
        }
    }
}

/// The reduced basis (fixed-interface modes + statically condensed interface correction)
/// against the full L-space on the refined bar (400 elements, 399 L-DOFs, H = 5, 1 % at the
/// first mode with Rayleigh damping on L as in tests/time_integration.rs): the largest
/// multiplier modulus approaches the full space's as the basis grows, and the verdict
/// (stable) is the same from 20 modes on. The convergence is slow (the switching of the
/// contact excites all modes, see `ReducedSystem`).
#[test]
fn reduced_basis_multipliers_converge_to_the_full_space() {
    use mshbm::stability::StabilityOptions;
    let model = rayleigh_damped_bar(400);
    let f = 30e3;
    let omega = 2.0 * PI * f;
    let mut p = RedistributedMsHbm::new(
        &model,
        &RedistributedOptions {
            harmonics: 5,
            samples: None,
            quadrature: Quadrature::Exact,
        },
    )
    .unwrap();
    let (_, out) = solve_at_frequency(&mut p, omega, 20, &NewtonOptions::default()).unwrap();
    assert!(out.converged);
    p.set_stability_options(StabilityOptions {
        modes: Some(usize::MAX),
    })
    .unwrap();
    let full = p.floquet(&out.x, omega).unwrap().unwrap();
    assert_eq!(full.multipliers.len(), 2 * 399);
    let mut errors = Vec::new();
    for m in [10, 20, 40, 80, 160] {
        p.set_stability_options(StabilityOptions { modes: Some(m) })
            .unwrap();
        let reduced = p.floquet(&out.x, omega).unwrap().unwrap();
        assert_eq!(reduced.multipliers.len(), 2 * m);
        let e = reduced.max_multiplier - full.max_multiplier;
        println!(
            "m = {m:3}: max |μ| = {:.6} (full {:.6}), difference {e:+.4}",
            reduced.max_multiplier, full.max_multiplier
        );
        if m >= 20 {
            assert_eq!(reduced.stable, full.stable, "m = {m}");
        }
        errors.push(e.abs());
    }
    for w in errors.windows(2) {
        assert!(w[1] < w[0], "errors {errors:?} do not decrease");
    }
    assert!(*errors.last().unwrap() < 0.12, "{errors:?}");
}

/// The paper's bar refined to `elements`, 1 % damping at the first mode and at ten times
/// it (mass-proportional `alpha` plus `beta_linear` on the L-part's stiffness).
fn rayleigh_damped_bar(elements: usize) -> mshbm::Model {
    let path = common::examples().join("clamped_bar.toml");
    let model = load_model(&path, &[format!("bar.elements={elements}")]).unwrap();
    let system = model.system(MassKind::Redistributed).unwrap();
    let w1 = mshbm::modes::first_angular_frequency(&system.mass, &system.stiffness).unwrap();
    let (zeta, w2) = (0.01, 10.0 * w1);
    load_model(
        &path,
        &[
            format!("bar.elements={elements}"),
            format!("damping.alpha={}", 2.0 * zeta * w1 * w2 / (w1 + w2)),
            format!("damping.beta_linear={}", 2.0 * zeta / (w1 + w2)),
        ],
    )
    .unwrap()
}

#[test]
#[ignore]
fn survey_reduced_basis() {
    use mshbm::stability::StabilityOptions;
    for (label, extra) in [
        ("mass", vec!["damping.first_mode_ratio=0.01".to_string()]),
        (
            "rayleigh",
            vec![
                "damping.alpha=6895".to_string(),
                "damping.beta_linear=2.4e-9".to_string(),
            ],
        ),
    ] {
        let mut o = vec!["bar.elements=400".to_string()];
        o.extend(extra);
        let model = load_model(&common::examples().join("clamped_bar.toml"), &o).unwrap();
        for f in [30e3, 60e3, 90e3] {
            let omega = 2.0 * PI * f;
            let mut p = RedistributedMsHbm::new(
                &model,
                &RedistributedOptions {
                    harmonics: 5,
                    samples: None,
                    quadrature: Quadrature::Exact,
                },
            )
            .unwrap();
            let (_, out) =
                solve_at_frequency(&mut p, omega, 20, &NewtonOptions::default()).unwrap();
            println!("{label} {f}: converged {}", out.converged);
            let t = std::time::Instant::now();
            p.set_stability_options(StabilityOptions {
                modes: Some(100000),
            })
            .unwrap();
            let full = p.floquet(&out.x, omega).unwrap().unwrap();
            println!("full {:?} {:?}", t.elapsed(), &full.multipliers[..4]);
            for m in [2, 5, 10, 20, 40, 80, 160, 398] {
                let t = std::time::Instant::now();
                p.set_stability_options(StabilityOptions { modes: Some(m) })
                    .unwrap();
                let r = p.floquet(&out.x, omega).unwrap().unwrap();
                println!(
                    "m={m} {:?} max {:.8} (full {:.8}) {:?}",
                    t.elapsed(),
                    r.max_multiplier,
                    full.max_multiplier,
                    &r.multipliers[..2]
                );
            }
        }
    }
}
