//! The redistributed MS-HBM (paper Sections 3.1–3.2) against independent references:
//! finite differences for the Jacobian and the frequency derivative, the direct linear
//! frequency response, the Signorini conditions, and the sampled vs exact quadrature.

mod common;

use std::path::Path;

use mshbm::harmonic::Quadrature;
use mshbm::newton::{solve, solve_at_frequency, NewtonOptions};
use mshbm::problem::PeriodicProblem;
use mshbm::solution::PeriodicSolution;
use mshbm::{MassKind, Model};

use common::{
    assert_derivatives_match_finite_differences, assert_is_linear_response, direct_linear_response,
    hz, max_abs, ms_hbm_with, solve_and_check_derivatives, try_ms_hbm,
};

fn bar(overrides: &[&str]) -> Model {
    common::example_model("clamped_bar.toml", overrides)
}

fn damped_bar() -> Model {
    bar(&["damping.first_mode_ratio=0.01"])
}

/// The error message of constructing the method on `model` with these settings.
fn construction_error(
    model: &Model,
    harmonics: usize,
    quadrature: Quadrature,
    samples: Option<usize>,
) -> String {
    try_ms_hbm(model, harmonics, quadrature, samples)
        .err()
        .unwrap()
        .to_string()
}

#[test]
fn jacobian_and_frequency_derivative_match_finite_differences_on_the_bar() {
    let model = damped_bar();
    for quadrature in [Quadrature::Exact, Quadrature::Sampled] {
        for (harmonics, f) in [(5, 60e3), (3, 30e3)] {
            let mut p = ms_hbm_with(&model, harmonics, quadrature, None);
            // at the solution and at a point off the solution
            let case = format!("{quadrature:?} H={harmonics} f={f}");
            let sol = solve_and_check_derivatives(&mut p, hz(f), 100, 1e-6, &case);
            assert!(
                sol.contacts[0].force.iter().any(|&l| l > 0.0),
                "the bar must be in contact"
            );
        }
    }
}

#[test]
fn jacobian_and_frequency_derivative_match_finite_differences_with_many_contacts() {
    let model = common::lattice_model(6, 8, 25.0, 5.0);
    for quadrature in [Quadrature::Exact, Quadrature::Sampled] {
        let mut p = ms_hbm_with(&model, 3, quadrature, None);
        let (sol, out) = solve_at_frequency(
            &mut p,
            hz(5.0),
            model.contacts[0].dofs[0],
            &NewtonOptions::default(),
        )
        .unwrap();
        assert!(out.converged);
        let closing: Vec<bool> = sol
            .contacts
            .iter()
            .map(|c| c.force.iter().any(|&l| l > 0.0))
            .collect();
        assert!(
            closing.iter().filter(|&&c| c).count() >= 2 && closing.iter().any(|&c| !c),
            "some contacts active, some not: {closing:?}"
        );
        let case = format!("{quadrature:?}");
        assert_derivatives_match_finite_differences(&mut p, &out.x, hz(5.0), 1e-6, &case);
    }
}

/// Signorini at every sample: gap ≥ −1e-12·scale, force ≥ 0, complementarity.
fn assert_signorini(sol: &PeriodicSolution, scale: f64) {
    for c in &sol.contacts {
        let fmax = max_abs(c.force.iter().copied()).max(1e-300);
        for (g, l) in c.gap.iter().zip(&c.force) {
            assert!(*g >= -1e-12 * scale, "penetration {g}");
            assert!(*l >= 0.0, "negative force {l}");
            assert!(
                (g * l).abs() <= 1e-12 * scale * fmax,
                "complementarity g = {g}, λ = {l}"
            );
        }
    }
}

#[test]
fn bar_at_60_khz_converges_for_1_3_5_10_harmonics_without_penetration() {
    let model = damped_bar();
    let gap = model.contacts[0].gap;
    let mut previous: Option<Vec<f64>> = None;
    let mut changes = Vec::new();
    for harmonics in [1, 3, 5, 10] {
        let mut p = ms_hbm_with(&model, harmonics, Quadrature::Exact, None);
        let (sol, out) =
            solve_at_frequency(&mut p, hz(60e3), 100, &NewtonOptions::default()).unwrap();
        assert!(out.converged, "H = {harmonics}: {:?}", out.reason);
        assert_signorini(&sol, p.length_scale());
        let c = &sol.contacts[0];
        // the paper's Fig. 10 claim: the contact displacement never exceeds the gap
        assert!(
            c.max <= gap * (1.0 + 1e-12),
            "H = {harmonics}: max {}",
            c.max
        );
        assert!(c.displacement.iter().all(|&q| q <= gap * (1.0 + 1e-12)));
        let a = c.coefficients[..3].to_vec();
        println!(
            "H = {harmonics:2}: a0 = {:.6}, a1 = {:.6}, b1 = {:.6}, min = {:.6}",
            a[0], a[1], a[2], c.min
        );
        if let Some(prev) = &previous {
            changes.push(max_abs(prev.iter().zip(&a).map(|(x, y)| x - y)));
        }
        previous = Some(a);
    }
    // the low coefficients settle as H grows
    println!("change of (a0, a1, b1) from H to the next: {changes:?}");
    assert!(changes[2] < changes[0], "{changes:?}");
    assert!(changes[2] < 0.02 * gap.max(0.1) * 10.0, "{changes:?}");
}

#[test]
fn exact_quadrature_converges_quadratically_and_sampled_approaches_it_at_second_order() {
    let model = damped_bar();
    let omega = hz(60e3);
    let mut exact = ms_hbm_with(&model, 5, Quadrature::Exact, Some(512));
    let (_, out) = solve_at_frequency(
        &mut exact,
        omega,
        100,
        &NewtonOptions {
            tolerance: 1e-13,
            ..NewtonOptions::default()
        },
    )
    .unwrap();
    assert!(out.converged);
    let h = &out.history;
    println!("exact quadrature, Newton residual history: {h:?}");
    // quadratic convergence once close: r_{k+1} <= C r_k^2
    let tail: Vec<f64> = h.iter().copied().skip_while(|&r| r > 1e-4).collect();
    assert!(tail.len() >= 3, "{h:?}");
    for w in tail.windows(2) {
        assert!(w[1] <= 1e4 * w[0] * w[0] + 1e-14, "not quadratic: {h:?}");
    }
    // sampled DFT with kinked q_N(t): error O(1/NS²) with a constant that depends on where
    // the kinks fall between samples, so check that d·NS² stays bounded over two decades
    let mut scaled = Vec::new();
    for ns in [64, 128, 200, 256, 512, 800, 1024, 2048, 3000, 4096, 8192] {
        let mut sampled = ms_hbm_with(&model, 5, Quadrature::Sampled, Some(ns));
        let o = solve(
            &mut sampled,
            &out.x,
            omega,
            &NewtonOptions {
                tolerance: 1e-14,
                ..NewtonOptions::default()
            },
        )
        .unwrap();
        assert!(o.converged);
        let d = max_abs(o.x.iter().zip(&out.x).map(|(a, b)| a - b));
        scaled.push((ns, d, d * (ns * ns) as f64));
    }
    println!("(NS, max |x_sampled − x_exact|, that × NS²): {scaled:?}");
    for &(ns, d, dn2) in &scaled {
        assert!(dn2 < 10.0, "NS = {ns}: difference {d:.3e} is not O(1/NS²)");
    }
    assert!(scaled.last().unwrap().1 < 1e-4 * scaled[0].1, "{scaled:?}");
}

#[test]
fn far_from_contact_the_solution_is_the_linear_response() {
    for (model, f, dofs) in [
        (
            bar(&["contact.gap=100", "damping.first_mode_ratio=0.01"]),
            60e3,
            vec![100usize, 50, 99],
        ),
        (
            bar(&["contact.gap=100", "damping.first_mode_ratio=0.01"]),
            21e3,
            vec![100, 50],
        ),
        (
            bar(&["load.amplitude=10", "damping.alpha=300"]),
            60e3,
            vec![100, 30],
        ),
    ] {
        let (model_dof, z) = direct_linear_response(&model, MassKind::Redistributed, hz(f));
        for dof in dofs {
            let mut p = ms_hbm_with(&model, 5, Quadrature::Exact, None);
            let (sol, out) =
                solve_at_frequency(&mut p, hz(f), dof, &NewtonOptions::default()).unwrap();
            assert!(out.converged);
            assert!(sol.contacts[0].force.iter().all(|&l| l == 0.0));
            let zi = z[model_dof.iter().position(|&d| d == dof).unwrap()];
            let c = &sol.response.coefficients;
            let amp = zi.norm();
            assert_is_linear_response(c, zi, 1e-10, &format!("dof {dof}"));
            assert!((sol.response.max - amp).abs() <= 1e-6 * amp);
        }
    }
}

#[test]
fn lattice_far_from_contact_is_linear_too() {
    let model = {
        let mut m = common::lattice_model(6, 8, 25.0, 5.0);
        m.contacts.iter_mut().for_each(|c| c.gap = 10.0);
        m
    };
    let (model_dof, z) = direct_linear_response(&model, MassKind::Redistributed, hz(5.0));
    let mut p = ms_hbm_with(&model, 3, Quadrature::Exact, None);
    for c in &model.contacts {
        let dof = c.dofs[0];
        let (sol, _) = solve_at_frequency(&mut p, hz(5.0), dof, &NewtonOptions::default()).unwrap();
        let zi = z[model_dof.iter().position(|&d| d == dof).unwrap()];
        let co = &sol.response.coefficients;
        assert!(
            (co[1] - zi.re).abs() <= 1e-10 * zi.norm()
                && (co[2] + zi.im).abs() <= 1e-10 * zi.norm()
        );
    }
}

#[test]
fn lattice_solutions_satisfy_signorini() {
    let model = common::lattice_model(6, 8, 25.0, 5.0);
    for quadrature in [Quadrature::Exact, Quadrature::Sampled] {
        let mut p = ms_hbm_with(&model, 3, quadrature, None);
        let (sol, out) = solve_at_frequency(&mut p, hz(5.0), 1, &NewtonOptions::default()).unwrap();
        assert!(out.converged);
        assert_signorini(&sol, p.length_scale());
    }
}

#[test]
fn damping_that_couples_into_the_contact_is_refused() {
    let model = bar(&["damping.beta=1e-7"]);
    let err = construction_error(&model, 3, Quadrature::Exact, None);
    assert!(
        err.contains("C_NN") && err.contains("mass-proportional"),
        "{err}"
    );
}

#[test]
fn bad_settings_are_clear_errors() {
    let model = damped_bar();
    let e = construction_error(&model, 0, Quadrature::Exact, None);
    assert!(e.contains("harmonics"), "{e}");
    let e = construction_error(&model, 5, Quadrature::Sampled, Some(10));
    assert!(e.contains("2H+1"), "{e}");
}

#[test]
fn singular_contact_stiffness_is_reported() {
    // a bar whose contact node is attached to nothing: K_NN = 0
    let mut model = bar(&[]);
    let n = model.n_dofs();
    let t: Vec<(usize, usize, f64)> = model
        .stiffness
        .iter()
        .filter(|&(i, j, _)| i < n - 1 && j < n - 1)
        .collect();
    let mut t2 = t.clone();
    t2.push((n - 2, n - 2, model.stiffness.get(n - 2, n - 2) * 0.5));
    model.stiffness = mshbm::sparse::SparseMatrix::from_triplets(n, n, &t2);
    let e = construction_error(&model, 3, Quadrature::Exact, None);
    assert!(e.contains("K_NN"), "{e}");
}

#[test]
fn iteration_limit_gives_a_non_converged_outcome() {
    let model = damped_bar();
    let mut p = ms_hbm_with(&model, 5, Quadrature::Exact, None);
    let (sol, out) = solve_at_frequency(
        &mut p,
        hz(60e3),
        100,
        &NewtonOptions {
            max_iterations: 1,
            ..NewtonOptions::default()
        },
    )
    .unwrap();
    assert!(!out.converged && !sol.converged);
    assert!(out.reason.unwrap().to_string().contains("1 iterations"));
    let _ = Path::new("");
}

/// Why Newton slows down on refined meshes (docs/theory.md (T122)): without contact the
/// Jacobian of the connectivity residual (T33) is `K_NN⁻¹ D_k` per harmonic, `D_k` the
/// dynamic stiffness of the structure at the contact DOF. For the clamped bar `K_NN = EA/h`
/// and the static stiffness is `EA/L` on every mesh, so the mean harmonic's entry is
/// exactly `h/L = 1/n`, and the smallest singular value falls like `1/n`: the residual of
/// the open phases is `O(h)` while that of the contact phases stays `O(1)`.
#[test]
fn the_contact_free_jacobian_scales_like_the_element_size() {
    for n in [100usize, 1000, 10000] {
        let model = common::example_model(
            "clamped_bar.toml",
            &[
                format!("bar.elements={n}"),
                "contact.gap=100".to_string(),
                "damping.first_mode_ratio=0.01".to_string(),
            ],
        );
        let mut p = common::ms_hbm(&model, 5);
        let omega = common::hz(1000.0);
        let x0 = p.initial_guess(omega).unwrap();
        let jacobian = p.linearize(&x0, omega).unwrap().jacobian.to_dense();
        let mean = jacobian[(0, 0)];
        assert!(
            (mean * n as f64 - 1.0).abs() < 1e-9,
            "n = {n}: mean-harmonic entry {mean} vs 1/n"
        );
        let sv = jacobian.singular_values().unwrap();
        let smallest = sv[sv.len() - 1];
        assert!(
            smallest <= 1.0 / n as f64 && smallest > 0.9 / n as f64,
            "n = {n}: smallest singular value {smallest:.3e}"
        );
    }
}

/// The refined-mesh stall of docs/theory.md (T122) is a matter of the starting point: the
/// unknowns are the contact displacement's harmonics, which mean the same on every mesh, so
/// the solution on a coarser mesh starts Newton inside the (shrinking) region of quadratic
/// convergence on the finer one (nested iteration). From the linear response Newton stalls
/// near 7e-7 on 10⁴ elements (50 iterations, BENCHMARKS.md §4); from the 10³-element
/// solution it converges to 1e-10 in a few iterations, and from that one the bar of 10⁵
/// elements too.
#[test]
fn refined_bars_converge_from_the_coarser_solution() {
    let omega = hz(30e3);
    let mut start: Option<Vec<f64>> = None;
    for elements in [1_000usize, 10_000, 100_000] {
        let count = format!("bar.elements={elements}");
        let model = bar(&[count.as_str(), "damping.first_mode_ratio=0.01"]);
        let mut p = common::ms_hbm(&model, 5);
        let x0 = match &start {
            Some(x) => x.clone(),
            None => p.initial_guess(omega).unwrap(),
        };
        let out = solve(&mut p, &x0, omega, &NewtonOptions::default()).unwrap();
        println!(
            "{elements} elements: {} iterations, residual {:.1e}",
            out.iterations, out.residual_norm
        );
        assert!(
            out.converged && out.residual_norm <= 1e-10,
            "{elements}: {out:?}"
        );
        if start.is_some() {
            assert!(
                out.iterations <= 8,
                "{elements}: {} iterations",
                out.iterations
            );
        }
        start = Some(out.x);
    }
}

/// Nested iteration across harmonics on the refined block (docs/theory.md (T122)): the
/// 16 × 16 × 4 plate at 500 Hz (272 contacts) with H = 5 does not converge from the linear
/// response within 50 iterations (BENCHMARKS.md §8), but does from its H = 3 solution, the
/// added harmonics starting at zero. The H = 3 problem switched to H = 5
/// (`set_harmonics`, no second set-up) is the H = 5 problem set up afresh: the same
/// residual at the start and at the solution.
#[test]
fn the_refined_block_converges_at_h5_from_its_h3_solution() {
    let model = common::example_model(
        "block_3d/model.toml",
        &["solid.divisions=[16,16,4]", "interfaces.0.gap=0.0003"],
    );
    let omega = hz(500.0);
    let mut nested = common::ms_hbm_with(&model, 3, Quadrature::Sampled, None);
    let x0 = nested.initial_guess(omega).unwrap();
    let coarse = solve(&mut nested, &x0, omega, &NewtonOptions::default()).unwrap();
    assert!(coarse.converged, "H = 3: {:?}", coarse.reason);
    nested.set_harmonics(5, None).unwrap();
    assert_eq!((nested.harmonics(), nested.samples()), (5, 256));
    let start = mshbm::harmonic::with_harmonics(&coarse.x, 3, 5).unwrap();
    assert_eq!(start.len(), nested.dimension());
    let out = solve(&mut nested, &start, omega, &NewtonOptions::default()).unwrap();
    println!(
        "H = 5 from H = 3: {} iterations, residual {:.1e}",
        out.iterations, out.residual_norm
    );
    assert!(
        out.converged && out.residual_norm <= 1e-10,
        "{:?}",
        out.reason
    );
    let mut fresh = common::ms_hbm_with(&model, 5, Quadrature::Sampled, None);
    for x in [&start, &out.x] {
        let (a, b) = (
            nested.residual(x, omega).unwrap(),
            fresh.residual(x, omega).unwrap(),
        );
        let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
        let difference = a
            .iter()
            .zip(&b)
            .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
        assert!(
            difference <= 1e-13 * scale.max(nested.length_scale()),
            "{difference:e}"
        );
    }
    // and back: H = 3 again gives the H = 3 residual
    nested.set_harmonics(3, None).unwrap();
    let again = nested.residual(&coarse.x, omega).unwrap();
    let norm = again.iter().fold(0.0f64, |m, v| m.max(v.abs())) / nested.length_scale();
    assert!(norm <= 1e-10, "{norm:e}");
    // sizes that cannot resolve the harmonics are refused, and nothing changes
    assert!(nested.set_harmonics(5, Some(4)).is_err());
    assert_eq!(nested.harmonics(), 3);
}

/// A diagram's point (`PeriodicProblem::diagram_point`, which leaves out the contacts'
/// series and their extremes) is the whole solution's: the same response, extremes and
/// residual, for a contact-node DOF and for a DOF of the structure, on a plate whose face
/// has 20 contacts.
#[test]
fn a_diagram_point_is_that_of_the_whole_solution() {
    use mshbm::method::redistributed::{RedistributedMsHbm, RedistributedOptions};
    use mshbm::solution::DiagramPoint;
    // the diagram point takes a contact-node DOF's signal from the active-set intervals of
    // the exact quadrature, the whole solution from a static contact solve per instant:
    // their extremes agree to round-off
    let same = |point: &DiagramPoint, whole: &DiagramPoint, case: &str| {
        assert_eq!(point.frequency_hz, whole.frequency_hz, "{case}");
        assert_eq!(
            point.response.coefficients, whole.response.coefficients,
            "{case}"
        );
        assert_eq!(point.residual_norm, whole.residual_norm, "{case}");
        let size = whole.response.max.abs().max(whole.response.min.abs());
        for (a, b) in [
            (point.response.max, whole.response.max),
            (point.response.min, whole.response.min),
        ] {
            assert!((a - b).abs() <= 1e-13 * size, "{case}: {a} vs {b}");
        }
    };
    let model = common::example_model(
        "block_3d/model.toml",
        &["solid.divisions=[4,4,4]", "interfaces.0.gap=0.0003"],
    );
    let mut p = RedistributedMsHbm::new(&model, &RedistributedOptions::new(2)).unwrap();
    let omega = common::hz(1000.0);
    let x0 = p.initial_guess(omega).unwrap();
    let out = mshbm::newton::solve(&mut p, &x0, omega, &Default::default()).unwrap();
    assert!(out.converged);
    let contact_dof = model.contacts[0].dofs[0];
    let structure_dof = model.stiffness.nrows() - 1;
    for dof in [contact_dof, structure_dof] {
        let whole = p.solution(&out.x, omega, dof).unwrap();
        let point = p.diagram_point(&out.x, omega, dof).unwrap();
        assert!(!whole.contacts.is_empty());
        same(
            &point,
            &DiagramPoint::of(&whole),
            &format!("block, DOF {dof}"),
        );
        assert!(whole.response.max > whole.response.min, "DOF {dof} moves");
    }
    // the bar's contact DOF on the branch near its first contact resonance, where the
    // receptance amplifies the residual's difference between the two free gaps most
    let model = damped_bar();
    let mut p = ms_hbm_with(&model, 10, Quadrature::Exact, None);
    let dof = model.contacts[0].dofs[0];
    for f in [30.18e3, 60e3] {
        let omega = hz(f);
        let x0 = p.initial_guess(omega).unwrap();
        let out = mshbm::newton::solve(&mut p, &x0, omega, &Default::default()).unwrap();
        assert!(out.converged, "{f} Hz");
        let whole = p.solution(&out.x, omega, dof).unwrap();
        assert!(
            whole.contacts[0].force.iter().any(|&l| l > 0.0),
            "{f} Hz: in contact"
        );
        let point = p.diagram_point(&out.x, omega, dof).unwrap();
        same(&point, &DiagramPoint::of(&whole), &format!("bar at {f} Hz"));
    }
}

/// The method keeps its last evaluation for the next caller at the same point (the
/// tangent and the diagram point of a converged continuation point): asked again at a point
/// after another frequency was prepared in between, it gives what a fresh method gives.
#[test]
fn a_linearization_asked_again_after_another_frequency_is_a_fresh_one() {
    let model = damped_bar();
    let (f1, f2) = (hz(60e3), hz(31e3));
    let mut fresh = ms_hbm_with(&model, 5, Quadrature::Exact, None);
    let x = fresh.initial_guess(f1).unwrap();
    let x: Vec<f64> = x.iter().map(|v| 1.3 * v).collect();
    let reference = fresh.linearize(&x, f1).unwrap();
    let mut p = ms_hbm_with(&model, 5, Quadrature::Exact, None);
    p.linearize(&x, f1).unwrap();
    p.initial_guess(f2).unwrap();
    let other = p.residual(&x, f2).unwrap();
    let again = p.linearize(&x, f1).unwrap();
    assert_ne!(other, again.residual, "the two frequencies differ");
    assert_eq!(reference.residual, again.residual);
    assert_eq!(reference.d_omega, again.d_omega);
    let (a, b) = (reference.jacobian.to_dense(), again.jacobian.to_dense());
    assert_eq!(a, b);
}
