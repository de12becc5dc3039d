//! Tests of the exact and sampled quadratures of one period (`quadrature.rs`).

use super::*;
use crate::sparse::SparseMatrix;
use std::f64::consts::PI;

/// Coefficients `[a_0, a_1, b_1]` of `max(0, −γ)` for `γ(τ) = α (cos(τ − φ) − cos ψ)`:
/// the force of an uncoupled contact of unit compliance with free gap `γ`, closed on
/// `(φ + ψ, φ + 2π − ψ)`; in closed form, from the integrals over that interval.
fn closed_form_force(alpha: f64, phi: f64, psi: f64) -> [f64; 3] {
    let mean = (2.0 * PI - 2.0 * psi) * psi.cos() + 2.0 * psi.sin();
    let first = -(PI - psi) - (2.0 * psi).sin() / 2.0;
    let c1 = alpha * first / PI;
    [alpha * mean / (2.0 * PI), c1 * phi.cos(), c1 * phi.sin()]
}

/// The coefficients `[1, cos τ, sin τ]` of that `γ`.
fn free_gap(alpha: f64, phi: f64, psi: f64) -> [f64; 3] {
    [-alpha * psi.cos(), alpha * phi.cos(), alpha * phi.sin()]
}

/// Two contacts that close 3e-13 apart — the first with a gap ten thousand times
/// flatter — and a third far open. Just after the second switch the first contact's gap
/// is below the LCP's tolerance (relative to the open gap), and an LCP warm-started
/// from the last grid sample's set (the second contact closed, the first open) keeps
/// the first one open there. The set just after must come from the located switches;
/// the forces' coefficients must equal the closed form.
#[test]
fn switches_at_one_instant_keep_every_closed_contact() {
    let nc = 3;
    let k = SparseMatrix::from_triplets(nc, nc, &[(0, 0, 1.0), (1, 1, 1.0), (2, 2, 1.0)]);
    let w: Vec<f64> = (0..nc * nc)
        .map(|e| if e / nc == e % nc { 1.0 } else { 0.0 })
        .collect();
    let mut contact = StaticContact::new(&k, w, vec![0.0; nc]).unwrap();
    let theta = 2.0 * PI * 3.3 / 16.0;
    // (α, φ, ψ): the flat contact closes at θ − 3e-13 and opens at 2π − θ; the steep
    // one closes at θ and stays closed over the last grid sample and τ = 0
    let flat = (1e-4, 0.0, theta - 3e-13);
    let steep = (1.0, theta - 0.5, 0.5);
    let gaps = [
        free_gap(flat.0, flat.1, flat.2),
        free_gap(steep.0, steep.1, steep.2),
        [1.0, 0.0, 0.0],
    ];
    // harmonic-major: coefficient m of contact c at m·n_c + c
    let gamma: Vec<f64> = (0..3 * nc).map(|e| gaps[e % nc][e / nc]).collect();
    let sampling = Sampling::new(1, 16);
    let integration = integrate(&mut contact, &gamma, &sampling, Quadrature::Exact).unwrap();
    let mut lambda = [[0.0; 3]; 3];
    for group in &integration.groups {
        for n in 0..3 {
            let force = group.set.force(&gamma[n * nc..(n + 1) * nc]);
            for (c, l) in lambda.iter_mut().enumerate() {
                for (m, lm) in l.iter_mut().enumerate() {
                    *lm += group.gram[m * 3 + n] * force[c];
                }
            }
        }
    }
    assert_eq!(lambda[2], [0.0; 3], "the third contact stays open");
    for (c, (alpha, phi, psi)) in [flat, steep].into_iter().enumerate() {
        let exact = closed_form_force(alpha, phi, psi);
        for m in 0..3 {
            assert!(
                (lambda[c][m] - exact[m]).abs() <= 1e-12 * alpha,
                "contact {c}, coefficient {m}: {} instead of {}",
                lambda[c][m],
                exact[m]
            );
        }
    }
}

/// The exact quadrature holds the distinct active sets it meets in one period up to its
/// budget and is refused, naming the sampled quadrature, beyond it: with the budget equal
/// to the bytes of the sets of the period (the test above's three contacts, open and
/// closed in turn) it integrates, one byte less is an error; the sampled quadrature has
/// no such budget.
#[test]
fn the_exact_quadrature_refuses_more_active_sets_than_its_budget() {
    let nc = 3;
    let k = SparseMatrix::from_triplets(nc, nc, &[(0, 0, 2.0), (1, 1, 1.0), (2, 2, 1.5)]);
    let w: Vec<f64> = (0..nc * nc)
        .map(|e| if e / nc == e % nc { 1.0 } else { 0.0 })
        .collect();
    let mut contact = StaticContact::new(&k, w, vec![0.0; nc]).unwrap();
    let gaps = [
        free_gap(1.0, 0.3, 0.8),
        free_gap(0.5, 2.0, 1.1),
        free_gap(2.0, 4.0, 0.4),
    ];
    let gamma: Vec<f64> = (0..3 * nc).map(|e| gaps[e % nc][e / nc]).collect();
    let sampling = Sampling::new(1, 16);
    let run = |contact: &mut StaticContact, budget: Option<usize>, quadrature| {
        let mut workspace = QuadratureWorkspace {
            set_budget: budget,
            ..QuadratureWorkspace::default()
        };
        let mut out = Integration::default();
        integrate_into(
            contact,
            &gamma,
            &sampling,
            quadrature,
            &mut out,
            &mut workspace,
        )
        .map(|()| out.groups.iter().map(|g| g.set.bytes()).sum::<usize>())
    };
    let held = run(&mut contact, None, Quadrature::Exact).unwrap();
    let sets = integrate(&mut contact, &gamma, &sampling, Quadrature::Exact)
        .unwrap()
        .groups
        .len();
    assert!(sets >= 4, "{sets} sets");
    assert_eq!(
        run(&mut contact, Some(held), Quadrature::Exact).unwrap(),
        held
    );
    let refused = run(&mut contact, Some(held - 1), Quadrature::Exact).unwrap_err();
    assert!(
        refused.to_string().contains("--quadrature sampled"),
        "{refused}"
    );
    assert!(run(&mut contact, Some(1), Quadrature::Sampled).is_ok());
}
