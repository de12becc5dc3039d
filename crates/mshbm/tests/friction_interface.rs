//! The redistributed MS-HBM with Coulomb friction on a plane interface (docs/theory.md §20):
//! a cantilever whose tip face is pressed against a rigid pad (a friction damper). Checked
//! against the frictionless method (μ = 0), central differences of the whole residual, and
//! the law's own conditions at every sample (no penetration, forces in the cone).

mod common;

use std::path::Path;

use common::{assert_derivatives_match_finite_differences, hz, ms_hbm, perturbed};
use mshbm::model::file::parse_model;
use mshbm::newton::{solve, solve_at_frequency, NewtonOptions};
use mshbm::problem::PeriodicProblem;
use mshbm::Model;

/// A steel cantilever (100 × 10 mm, 20 × 4 Q4) whose tip face (x = 100, five nodes) is
/// pressed by `preload` N against a rigid pad, excited at its top mid-span.
fn damper(mu: Option<f64>, preload: f64) -> Model {
    let mu = mu.map(|m| format!("mu = {m}")).unwrap_or_default();
    let text = format!(
        r#"
kind = "solid"
name = "friction damper"
[solid]
dimension = 2
size = [100.0, 10.0]
divisions = [20, 4]
young = 2.1e5
poisson = 0.3
density = 7.85e-9
thickness = 1.0
plane = "stress"
clamped = ["x0"]
[[node_sets]]
name = "drive"
box = [[50.0, 50.0], [10.0, 10.0]]
[[loads]]
set = "x1"
constant = [{preload}, 0.0]
[[loads]]
set = "drive"
harmonic = [0.0, -1.0]
[[interfaces]]
name = "pad"
kind = "obstacle"
set = "x1"
normal = [-1.0, 0.0]
gap = 0.0
{mu}
[damping]
first_mode_ratio = 0.01
"#
    );
    parse_model(&text, Path::new("damper.toml"), &[]).unwrap()
}

/// The model DOF of the tip's top node, vertical.
fn tip_dof(model: &Model) -> usize {
    let node = model
        .coordinates
        .iter()
        .position(|x| (x[0] - 100.0).abs() < 1e-9 && (x[1] - 10.0).abs() < 1e-9)
        .unwrap();
    2 * node + 1
}

#[test]
fn without_friction_coefficient_the_frictional_path_equals_the_frictionless_method() {
    let (with, without) = (damper(Some(0.0), 5.0), damper(None, 5.0));
    let dof = tip_dof(&with);
    // converged far below the default tolerance, so that the two solutions' difference is
    // that of the methods, not of where Newton stopped
    let tight = NewtonOptions {
        tolerance: 1e-13,
        ..NewtonOptions::default()
    };
    for f in [300.0, 800.0] {
        let (a, oa) = solve_at_frequency(&mut ms_hbm(&with, 3), hz(f), dof, &tight).unwrap();
        let (b, ob) = solve_at_frequency(&mut ms_hbm(&without, 3), hz(f), dof, &tight).unwrap();
        assert!(oa.converged && ob.converged);
        let scale = b
            .response
            .coefficients
            .iter()
            .fold(0.0f64, |s, v| s.max(v.abs()));
        for (x, y) in a.response.coefficients.iter().zip(&b.response.coefficients) {
            assert!((x - y).abs() <= 1e-10 * scale, "{f} Hz: {x} against {y}");
        }
        let force_scale = b
            .contacts
            .iter()
            .flat_map(|c| c.force.iter())
            .fold(0.0f64, |s, v| s.max(v.abs()));
        for (ca, cb) in a.contacts.iter().zip(&b.contacts) {
            for (x, y) in ca.force.iter().zip(&cb.force) {
                // the frictionless series solve the static problem for the response's load, the
                // frictional ones are the law's state for the unknowns: they differ by the
                // (converged) residual
                assert!(
                    (x - y).abs() <= 1e-6 * force_scale,
                    "normal force {x} against {y}"
                );
            }
        }
        assert!(a
            .frictions
            .iter()
            .all(|fr| fr.force.iter().all(|&t| t == 0.0)));
    }
}

#[test]
fn a_friction_damper_converges_with_stick_and_slip_and_its_jacobian_equals_central_differences() {
    // the tip face pressed by 2 N, μ = 0.1, below the first resonance: the five contacts
    // stick, slip both ways and (the face tilts) lift off over the period
    // (Newton from the contact-free response converges for μ = 0.05, not for 0.1: the
    // start at 0.1 is the solution at 0.05, a continuation in μ)
    let omega = hz(250.0);
    let light = damper(Some(0.05), 2.0);
    let (_, start) = solve_at_frequency(
        &mut ms_hbm(&light, 3),
        omega,
        tip_dof(&light),
        &NewtonOptions::default(),
    )
    .unwrap();
    assert!(start.converged, "μ = 0.05: {:?}", start.reason);
    let model = damper(Some(0.1), 2.0);
    let dof = tip_dof(&model);
    let mut p = ms_hbm(&model, 3);
    let out = solve(&mut p, &start.x, omega, &NewtonOptions::default()).unwrap();
    assert!(out.converged, "{:?}", out.reason);
    let sol = p.solution(&out.x, omega, dof).unwrap();
    let mu = 0.1;
    let (mut stuck, mut slipping, mut open) = (false, false, false);
    let force_scale = sol
        .contacts
        .iter()
        .flat_map(|c| c.force.iter())
        .fold(0.0f64, |s, v| s.max(v.abs()));
    for (c, fr) in sol.contacts.iter().zip(&sol.frictions) {
        for ((&normal, &gap), (&tangential, &limit)) in c
            .force
            .iter()
            .zip(&c.gap)
            .zip(fr.force.iter().zip(&fr.limit))
        {
            assert!(gap >= -1e-9 * p.length_scale(), "penetration {gap}");
            assert!(normal >= 0.0);
            assert!((limit - mu * normal).abs() <= 1e-12 * force_scale);
            assert!(
                tangential.abs() <= limit + 1e-9 * force_scale,
                "outside the cone: {tangential} > {limit}"
            );
            open |= normal == 0.0;
            stuck |= normal > 0.0 && tangential.abs() < 0.99 * limit;
            slipping |= normal > 0.0 && (tangential.abs() - limit).abs() <= 1e-9 * force_scale;
        }
    }
    assert!(
        stuck && slipping && open,
        "stuck {stuck}, slipping {slipping}, open {open}"
    );
    // the energy the friction dissipates: positive, and (at a periodic solution) the work of
    // the excitation less that of the structure's damping is not checked here
    let energy = sol
        .dissipated_energy
        .expect("frictional solutions report the dissipated energy");
    assert!(energy > 0.0, "dissipated energy {energy}");
    // (∂R/∂ω's central differences reach 5e-6 at best here: the residual's curvature in ω)
    for x in [&out.x, &perturbed(&out.x)] {
        assert_derivatives_match_finite_differences(&mut p, x, omega, 1e-5, "friction damper");
    }
}

/// A heavy preload (20 N, μ = 0.1) at 100 Hz: the three middle contacts stick all period
/// (centred in their cones, (T157)) while the outer two slip. The fixed point of the
/// contact state cycled here before its Newton was safeguarded and every peak of (T157)
/// refined (docs/theory.md (T156)–(T157)).
#[test]
fn contacts_stuck_all_period_beside_slipping_ones_reach_their_periodic_state() {
    let model = damper(Some(0.1), 20.0);
    let dof = tip_dof(&model);
    let mut p = ms_hbm(&model, 3);
    let (_, out) = solve_at_frequency(&mut p, hz(100.0), dof, &NewtonOptions::default()).unwrap();
    assert!(out.converged, "{:?}", out.reason);
    let sol = p.solution(&out.x, hz(100.0), dof).unwrap();
    let fractions = sol
        .state_fractions
        .expect("frictional solutions report fractions");
    let stuck_all_period = fractions.iter().filter(|f| f.stick == 1.0).count();
    let slipping = fractions.iter().filter(|f| f.slip > 0.0).count();
    assert_eq!((stuck_all_period, slipping), (3, 2), "{fractions:?}");
    for fr in &sol.frictions {
        for (t, l) in fr.force.iter().zip(&fr.limit) {
            assert!(t.abs() <= l * (1.0 + 1e-9), "outside the cone: {t} > {l}");
        }
    }
}

#[test]
fn the_memory_plan_counts_the_frictional_law() {
    use mshbm::limits::Limits;
    use mshbm::method::redistributed::{RedistributedMsHbm, RedistributedOptions};
    // H = 40, 2048 samples on 5 contacts: the law's dense derivatives (3 × 810 × 815 × 8 B,
    // 16 MB) and the phases' anchor sensitivities (2048 × 5 × 815 × 8 B, 67 MB) are most of
    // the plan; the same model without friction fits in 40 MB, with friction it does not
    let limits = Limits::default().with_memory_gib(0.04);
    let options = RedistributedOptions {
        samples: Some(2048),
        ..RedistributedOptions::new(40)
    };
    assert!(RedistributedMsHbm::within(&damper(None, 2.0), &options, &limits).is_ok());
    let refused = RedistributedMsHbm::within(&damper(Some(0.1), 2.0), &options, &limits)
        .err()
        .expect("refused within 40 MB");
    assert!(refused.to_string().contains("friction"), "{refused}");
}

/// Friction on the contacts of a `kind = "matrices"` model (`mu`, `tangent_dofs`,
/// `tangent_w`): the damper exported as Matrix Market matrices and read back has the same
/// contacts and frictions, and the same periodic solution as the solid model.
#[test]
fn the_damper_as_matrices_with_friction_on_its_contacts_gives_the_same_solution() {
    let model = damper(Some(0.1), 20.0);
    let dir = std::env::temp_dir().join(format!("mshbm_damper_export_{}", std::process::id()));
    let path = mshbm::model::export::export_matrices(&model, &dir).unwrap();
    let back = mshbm::model::file::load_model(&path, &[]).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    assert!(text.contains("tangent_dofs"), "{text}");
    assert_eq!(back.contacts, model.contacts);
    let dof = tip_dof(&model);
    let solution = |m: &Model| {
        let mut p = ms_hbm(m, 3);
        let (_, out) =
            solve_at_frequency(&mut p, hz(100.0), dof, &NewtonOptions::default()).unwrap();
        assert!(out.converged, "{:?}", out.reason);
        p.solution(&out.x, hz(100.0), dof).unwrap()
    };
    let (a, b) = (solution(&model), solution(&back));
    let scale = a
        .response
        .coefficients
        .iter()
        .fold(0.0f64, |s, v| s.max(v.abs()));
    for (x, y) in a.response.coefficients.iter().zip(&b.response.coefficients) {
        assert!((x - y).abs() <= 1e-10 * scale, "{x} against {y}");
    }
    assert_eq!(a.state_fractions, b.state_fractions);
}

/// A matrices model's contact friction is checked: each bad field named (the damper
/// exported, its first contact's friction replaced).
#[test]
fn bad_friction_on_a_matrices_contact_is_refused_naming_the_field() {
    let model = damper(Some(0.1), 2.0);
    let dir = std::env::temp_dir().join(format!("mshbm_damper_bad_{}", std::process::id()));
    let path = mshbm::model::export::export_matrices(&model, &dir).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    // the first contact: normal DOF 40 (node 20, x), tangent DOF 41 (y)
    let first = "mu = 0.1\ntangent_dofs = [41]\ntangent_w = [-1.0]";
    assert!(text.contains(first), "{text}");
    for (replacement, field, words) in [
        (
            "mu = 0.3",
            "contacts[0].tangent_dofs",
            "missing: tangent_dofs, tangent_w",
        ),
        (
            "mu = -0.3\ntangent_dofs = [41]\ntangent_w = [1.0]",
            "contacts[0].mu",
            "finite and ≥ 0",
        ),
        (
            "mu = 0.3\ntangent_dofs = [40, 41]\ntangent_w = [0.6, 0.8]",
            "contacts[0].tangent_w",
            "not orthogonal",
        ),
        (
            "mu = 0.3\ntangent_dofs = [41]\ntangent_w = [2.0]",
            "contacts[0].tangent_w",
            "norm",
        ),
        (
            "mu = 0.3\ntangent_dofs = [999999]\ntangent_w = [1.0]",
            "contacts[0].tangent_dofs",
            "",
        ),
    ] {
        std::fs::write(&path, text.replacen(first, replacement, 1)).unwrap();
        let error = mshbm::model::file::load_model(&path, &[])
            .expect_err(replacement)
            .to_string();
        assert!(
            error.contains("model.toml") && error.contains(field) && error.contains(words),
            "{replacement}: {error}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A friction coefficient per node (`mu_file`): equal coefficients give the model of `mu`;
/// a missing node, a node off the interface, a negative coefficient and `mu` with
/// `mu_file` are refused naming the file, the line or the node.
#[test]
fn a_friction_coefficient_per_node_from_a_file() {
    let dir = std::env::temp_dir().join(format!("mshbm_mu_file_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let uniform = damper(Some(0.1), 2.0);
    let nodes: Vec<usize> = uniform
        .contacts
        .iter()
        .map(|c| c.dofs[0] / uniform.dofs_per_node)
        .collect();
    assert_eq!(nodes.len(), 5);
    let model_text = |extra: &str| {
        let text = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/friction_damper/model.toml"),
        )
        .unwrap();
        text.replace("mu = 0.1 ", &format!("{extra} "))
    };
    let load = |extra: &str, table: &str| {
        std::fs::write(dir.join("mu.csv"), table).unwrap();
        let path = dir.join("model.toml");
        std::fs::write(&path, model_text(extra)).unwrap();
        mshbm::model::file::load_model(&path, &["loads.0.constant=[2.0, 0.0]".into()])
    };
    let table = |mus: &[f64]| -> String {
        nodes
            .iter()
            .zip(mus)
            .map(|(n, m)| format!("{n}, {m}\n"))
            .collect()
    };
    let same = load("mu_file = \"mu.csv\"", &table(&[0.1; 5])).unwrap();
    assert_eq!(same.contacts, uniform.contacts);
    let varied = load("mu_file = \"mu.csv\"", &table(&[0.1, 0.2, 0.3, 0.4, 0.5])).unwrap();
    let mus: Vec<f64> = varied
        .contacts
        .iter()
        .map(|c| c.friction.as_ref().unwrap().mu)
        .collect();
    assert_eq!(mus, [0.1, 0.2, 0.3, 0.4, 0.5]);
    for (extra, text, words) in [
        (
            "mu_file = \"mu.csv\"",
            table(&[0.1; 4]),
            "has no friction coefficient for node",
        ),
        (
            "mu_file = \"mu.csv\"",
            table(&[0.1; 5]) + "7, 0.1\n",
            "line 6: node 7 is not a node of the interface",
        ),
        (
            "mu_file = \"mu.csv\"",
            table(&[0.1, 0.1, -0.1, 0.1, 0.1]),
            "line 3",
        ),
        (
            "mu = 0.1\nmu_file = \"mu.csv\"",
            table(&[0.1; 5]),
            "not both",
        ),
    ] {
        let error = load(extra, &text).expect_err(extra).to_string();
        assert!(
            error.contains("interfaces[0].mu_file") && error.contains(words),
            "{extra} / {text}: {error}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The operator form of the Jacobian with friction (docs/theory.md (T133) with `S` of
/// (T158)): its action against central differences of the residual along directions and
/// against the dense matrix (two codes: a product with `S` per application, and `S` times
/// the complement's blocks by matrix products), and Newton with it (GMRES preconditioned by
/// the factors of an earlier Jacobian) against the dense LU path.
#[test]
fn the_operator_jacobian_with_friction_applies_the_jacobian_and_newton_reaches_the_dense_solution()
{
    use mshbm::harmonic::Quadrature;
    use mshbm::method::redistributed::{JacobianForm, RedistributedMsHbm, RedistributedOptions};
    use mshbm::problem::Jacobian;
    let with = |model: &Model, jacobian: JacobianForm| {
        RedistributedMsHbm::new(
            model,
            &RedistributedOptions {
                quadrature: Quadrature::Exact,
                jacobian,
                ..RedistributedOptions::new(3)
            },
        )
        .unwrap()
    };
    let omega = hz(250.0);
    let light = damper(Some(0.05), 2.0);
    let mut p = with(&light, JacobianForm::Operator);
    let x0 = p.initial_guess(omega).unwrap();
    let dense_start = solve(
        &mut with(&light, JacobianForm::Dense),
        &x0,
        omega,
        &NewtonOptions::default(),
    )
    .unwrap();
    let operator_start = solve(&mut p, &x0, omega, &NewtonOptions::default()).unwrap();
    assert!(dense_start.converged && operator_start.converged);
    let max_abs = |v: &mut dyn Iterator<Item = f64>| v.fold(0.0f64, |s, x| s.max(x.abs()));
    let err = max_abs(
        &mut dense_start
            .x
            .iter()
            .zip(&operator_start.x)
            .map(|(a, b)| a - b),
    ) / max_abs(&mut dense_start.x.iter().copied());
    assert!(err < 1e-9, "μ = 0.05: operator vs dense Newton {err:.2e}");
    // μ = 0.1 from μ = 0.05's solution (a continuation in μ), on both paths
    let model = damper(Some(0.1), 2.0);
    let mut dense = with(&model, JacobianForm::Dense);
    let mut operator = with(&model, JacobianForm::Operator);
    let a = solve(&mut dense, &dense_start.x, omega, &NewtonOptions::default()).unwrap();
    let b = solve(
        &mut operator,
        &dense_start.x,
        omega,
        &NewtonOptions::default(),
    )
    .unwrap();
    assert!(a.converged && b.converged, "{:?} {:?}", a.reason, b.reason);
    let err =
        max_abs(&mut a.x.iter().zip(&b.x).map(|(p, q)| p - q)) / max_abs(&mut a.x.iter().copied());
    assert!(err < 1e-9, "μ = 0.1: operator vs dense Newton {err:.2e}");
    // the action at a perturbed point (stick, slip and open phases)
    let x = perturbed(&a.x);
    let lin = operator.linearize(&x, omega).unwrap();
    let Jacobian::Operator(op) = &lin.jacobian else {
        panic!("JacobianForm::Operator gives an operator with friction too");
    };
    let matrix = dense.linearize(&x, omega).unwrap().jacobian;
    let n = x.len();
    for seed in 0..3 {
        let v: Vec<f64> = (0..n)
            .map(|i| ((i * 7 + seed * 3) as f64 * 0.61).sin())
            .collect();
        let mut jv = vec![0.0; n];
        op.apply(&v, &mut jv);
        let by_matrix = matrix.apply(&v);
        let err = max_abs(&mut by_matrix.iter().zip(&jv).map(|(p, q)| p - q))
            / max_abs(&mut by_matrix.iter().copied());
        assert!(err < 1e-12, "direction {seed}: action vs matrix {err:.2e}");
        let fd = common::directional_difference(&mut operator, &x, omega, &v);
        let err = common::max_abs(fd.iter().zip(&jv).map(|(p, q)| p - q))
            / common::max_abs(fd.iter().copied());
        assert!(
            err < 1e-6,
            "direction {seed}: action vs central differences {err:.2e}"
        );
    }
}
