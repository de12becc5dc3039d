//! The redistributed MS-HBM with Coulomb friction in the cone on a 3D interface
//! (docs/theory.md (T185)–(T191), (T219)–(T221)): a 3D cantilever whose tip face is pressed
//! against a rigid pad and driven in both tangential directions. Checked against the
//! frictionless method (μ = 0), central differences of the whole residual, the plane law on
//! the same model where the motion stays in a plane, a rotation of the tangents (the cone is
//! isotropic), and the law's own conditions at every sample.

mod common;

use std::path::Path;

use common::{hz, max_abs, ms_hbm, perturbed};
use mshbm::method::redistributed::friction::cone::{ConeContacts, ConeMode};
use mshbm::model::file::parse_model;
use mshbm::model::interface::interface_tangents;
use mshbm::newton::{solve, solve_at_frequency, NewtonOptions};
use mshbm::problem::PeriodicProblem;
use mshbm::solution::{ContactState, PeriodicSolution};
use mshbm::Model;

/// A steel beam 100 × 10 × 10 mm (10 × 1 × 1 Hex8, Poisson ratio `nu`) clamped at x = 0,
/// its tip face (x = 100, four nodes) pressed by `preload` N against a rigid pad, driven at
/// its top mid-span edge by `(0, −1, −drive_z)` N; `extra` is appended to the interface.
fn damper(mu: Option<f64>, preload: f64, drive_z: f64, nu: f64, extra: &str) -> Model {
    let mu = mu.map(|m| format!("mu = {m}")).unwrap_or_default();
    let text = format!(
        r#"
kind = "solid"
name = "friction damper in space"
[solid]
dimension = 3
size = [100.0, 10.0, 10.0]
divisions = [10, 1, 1]
young = 2.1e5
poisson = {nu}
density = 7.85e-9
clamped = ["x0"]
[[node_sets]]
name = "drive"
box = [[50.0, 50.0], [10.0, 10.0], [0.0, 10.0]]
[[loads]]
set = "x1"
constant = [{preload}, 0.0, 0.0]
[[loads]]
set = "drive"
harmonic = [0.0, -1.0, {minus_z}]
[[interfaces]]
name = "pad"
kind = "obstacle"
set = "x1"
normal = [-1.0, 0.0, 0.0]
gap = 0.0
{mu}
{extra}
[damping]
first_mode_ratio = 0.01
"#,
        minus_z = -drive_z
    );
    parse_model(&text, Path::new("damper3d.toml"), &[]).unwrap()
}

/// The model DOF of the tip's top corner node (y = z = 10), along y.
fn tip_dof(model: &Model) -> usize {
    let node = model
        .coordinates
        .iter()
        .position(|x| {
            (x[0] - 100.0).abs() < 1e-9 && (x[1] - 10.0).abs() < 1e-9 && (x[2] - 10.0).abs() < 1e-9
        })
        .unwrap();
    3 * node + 1
}

fn tight() -> NewtonOptions {
    NewtonOptions {
        tolerance: 1e-12,
        ..NewtonOptions::default()
    }
}

/// Harmonics of the tests: the cone law's Jacobian marches `3n_c(2H+1)` columns.
const H: usize = 2;

/// Newton at `f` Hz for friction `mu`, from the solution for `mu / 2` (itself from the
/// contact-free start): a continuation in μ, as on the plane damper.
fn solve_damper(model: &Model, light: &Model, f: f64) -> (PeriodicSolution, Vec<f64>) {
    let omega = hz(f);
    let (_, start) =
        solve_at_frequency(&mut ms_hbm(light, H), omega, tip_dof(light), &tight()).unwrap();
    assert!(start.converged, "{:?}", start.reason);
    let mut p = ms_hbm(model, H);
    let out = solve(&mut p, &start.x, omega, &tight()).unwrap();
    assert!(out.converged, "{:?}", out.reason);
    let sol = p.solution(&out.x, omega, tip_dof(model)).unwrap();
    (sol, out.x)
}

/// The largest residual entry at `x`, relative to the largest entry of `x` scaled as the
/// residual (`R = (I ⊗ Λ)(φ − λ̂)`, `Λ` the contact stiffness): the residual of the unknowns
/// of one model in another.
fn residual_at(model: &Model, x: &[f64], f: f64) -> f64 {
    let mut p = ms_hbm(model, H);
    let r = p.residual(x, hz(f)).unwrap();
    max_abs(r.iter().copied())
}

#[test]
fn the_tangents_of_a_normal_are_orthonormal_right_handed_and_a_given_one_is_kept() {
    let cross = |a: &[f64], b: &[f64]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let path = Path::new("m.toml");
    for (i, raw) in [
        [1.0, 0.0, 0.0],
        [0.0, 0.0, -1.0],
        [1.0, 1.0, 1.0],
        [0.3, -2.0, 0.7],
        [1e-9, 1.0, -1e-9],
    ]
    .iter()
    .enumerate()
    {
        let norm = dot(raw, raw).sqrt();
        let n: Vec<f64> = raw.iter().map(|v| v / norm).collect();
        let t = interface_tangents(&n, None, path, "interfaces[0].tangent").unwrap();
        assert_eq!(t.len(), 2);
        for (a, b, want) in [
            (&t[0], &t[0], 1.0),
            (&t[1], &t[1], 1.0),
            (&t[0], &t[1], 0.0),
            (&t[0], &n, 0.0),
            (&t[1], &n, 0.0),
        ] {
            assert!((dot(a, b) - want).abs() < 1e-14, "normal {i}");
        }
        // (t₁, t₂, n) right-handed: t₁ × t₂ = n
        let c = cross(&t[0], &t[1]);
        assert!(c.iter().zip(&n).all(|(a, b)| (a - b).abs() < 1e-14));
    }
    // a given first tangent is normalised and kept
    let n = [0.0, 0.0, 1.0];
    let t = interface_tangents(&n, Some(&[0.0, 2.0, 0.0]), path, "f").unwrap();
    assert_eq!(t[0], vec![0.0, 1.0, 0.0]);
    assert_eq!(t[1], vec![-1.0, 0.0, 0.0]);
    // refused: not orthogonal, and a tangent on a plane interface
    let e = interface_tangents(&n, Some(&[0.0, 1.0, 0.1]), path, "interfaces[0].tangent")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("m.toml") && e.contains("interfaces[0].tangent") && e.contains("orthogonal"),
        "{e}"
    );
    let e = interface_tangents(
        &[0.0, 1.0],
        Some(&[1.0, 0.0]),
        path,
        "interfaces[0].tangent",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("3D interfaces only"), "{e}");
}

#[test]
fn bad_cone_input_is_refused_naming_the_field() {
    // a tangent that is not orthogonal to the normal, in the model file
    let text_error = |extra: &str| {
        let text = format!(
            "kind = \"solid\"\nname = \"b\"\n[solid]\ndimension = 3\nsize = [10.0, 10.0, 10.0]\n\
             divisions = [2, 1, 1]\nyoung = 1.0\npoisson = 0.3\ndensity = 1.0\nclamped = [\"x0\"]\n\
             [[interfaces]]\nname = \"pad\"\nkind = \"obstacle\"\nset = \"x1\"\nnormal = [-1.0, 0.0, 0.0]\n\
             gap = 0.0\n{extra}\n"
        );
        parse_model(&text, Path::new("bad.toml"), &[])
            .unwrap_err()
            .to_string()
    };
    let e = text_error("mu = 0.2\ntangent = [1.0, 1.0, 0.0]");
    assert!(
        e.contains("bad.toml") && e.contains("interfaces[0].tangent"),
        "{e}"
    );
    let e = text_error("tangent = [0.0, 1.0, 0.0]");
    assert!(
        e.contains("interfaces[0].tangent") && e.contains("without friction"),
        "{e}"
    );
    // the model as matrices: the second tangents written and read back; then refused with
    // half a second tangent, or one not orthogonal to the first
    let model = damper(Some(0.1), 2.0, 0.6, 0.3, "");
    let dir = std::env::temp_dir().join(format!("mshbm_cone_bad_{}", std::process::id()));
    let path = mshbm::model::export::export_matrices(&model, &dir).unwrap();
    let read = mshbm::model::file::load_model(&path, &[]).unwrap();
    assert_eq!(read.contacts, model.contacts);
    let text = std::fs::read_to_string(&path).unwrap();
    let second = model.contacts[0]
        .friction
        .as_ref()
        .unwrap()
        .second
        .clone()
        .unwrap();
    let first_dof = model.contacts[0].friction.as_ref().unwrap().dofs[0];
    let written = format!("tangent2_dofs = {:?}\ntangent2_w = [-1.0]", second.dofs);
    assert!(text.contains(&written), "{text}");
    for (replacement, field, words) in [
        (
            format!("tangent2_dofs = {:?}", second.dofs),
            "contacts[0].tangent2_w",
            "both",
        ),
        (
            format!("tangent2_dofs = [{first_dof}]\ntangent2_w = [1.0]"),
            "contacts[0].tangent2_w",
            "not orthogonal to the first",
        ),
    ] {
        std::fs::write(&path, text.replacen(&written, &replacement, 1)).unwrap();
        let error = mshbm::model::file::load_model(&path, &[])
            .expect_err(&replacement)
            .to_string();
        assert!(
            error.contains("model.toml") && error.contains(field) && error.contains(words),
            "{replacement}: {error}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_cone_with_zero_friction_equals_the_frictionless_method() {
    let (with, without) = (
        damper(Some(0.0), 2.0, 0.6, 0.3, ""),
        damper(None, 2.0, 0.6, 0.3, ""),
    );
    let dof = tip_dof(&with);
    for f in [300.0, 900.0] {
        let (a, oa) = solve_at_frequency(&mut ms_hbm(&with, H), hz(f), dof, &tight()).unwrap();
        let (b, ob) = solve_at_frequency(&mut ms_hbm(&without, H), hz(f), dof, &tight()).unwrap();
        assert!(
            oa.converged && ob.converged,
            "{:?} {:?}",
            oa.reason,
            ob.reason
        );
        let scale = max_abs(b.response.coefficients.iter().copied());
        for (x, y) in a.response.coefficients.iter().zip(&b.response.coefficients) {
            assert!((x - y).abs() <= 1e-10 * scale, "{f} Hz: {x} against {y}");
        }
        assert!(a
            .frictions
            .iter()
            .all(|fr| fr.force.iter().chain(&fr.force2).all(|&t| t == 0.0)));
        // some contact opens and some closes over the period: not a trivial state
        let states: Vec<ContactState> = a.frictions.iter().flat_map(|f| f.state.clone()).collect();
        assert!(states.contains(&ContactState::Open) && states.contains(&ContactState::Slip));
    }
}

/// The law's conditions at every sample: no penetration, the friction force in the cone,
/// and which states occurred.
fn check_cone(sol: &PeriodicSolution, mu: f64, length: f64) -> (bool, bool, bool) {
    let force_scale = max_abs(sol.contacts.iter().flat_map(|c| c.force.iter().copied()));
    let (mut stuck, mut slipping, mut open) = (false, false, false);
    for (c, fr) in sol.contacts.iter().zip(&sol.frictions) {
        assert_eq!(fr.force2.len(), fr.force.len(), "two tangential components");
        for k in 0..c.force.len() {
            let (normal, gap) = (c.force[k], c.gap[k]);
            let tangential = fr.force[k].hypot(fr.force2[k]);
            assert!(gap >= -1e-9 * length, "penetration {gap}");
            // the indicators of (T153) let a force reach −10⁻¹¹ of its scale before it opens
            assert!(normal >= -1e-9 * force_scale, "normal force {normal}");
            assert!((fr.limit[k] - mu * normal).abs() <= 1e-12 * force_scale);
            assert!(
                tangential <= fr.limit[k] + 1e-9 * force_scale,
                "outside the cone: {tangential} > {}",
                fr.limit[k]
            );
            match fr.state[k] {
                ContactState::Open => open = true,
                ContactState::Stick => stuck = true,
                ContactState::Slip => slipping = true,
            }
            if fr.state[k] == ContactState::Slip {
                assert!((tangential - fr.limit[k]).abs() <= 1e-8 * force_scale);
            }
        }
    }
    (stuck, slipping, open)
}

/// The unknowns of a model whose tangents are turned by `(c, s)` about the normal:
/// per coefficient `[normals; t₁; t₂]`, `(t₁ᵇ, t₂ᵇ) = (c t₁ + s t₂, −s t₁ + c t₂)` in the
/// components of a vector.
fn rotate(x: &[f64], n_c: usize, c: f64, s: f64) -> Vec<f64> {
    let mut y = x.to_vec();
    for block in y.chunks_mut(3 * n_c) {
        for k in 0..n_c {
            let (u, v) = (block[n_c + k], block[2 * n_c + k]);
            block[n_c + k] = c * u + s * v;
            block[2 * n_c + k] = -s * u + c * v;
        }
    }
    y
}

// The acceptance check for the cone on an FE interface (issue 40):
// `cargo test --release --test friction_cone_interface -- --ignored`. Newton stalled at a
// relative residual 1.8e-5 until the direction's variation at the apex followed the
// direction the flow uses (docs/theory.md (T223)), and its outputs showed a contact slipping
// with a negative normal force until they followed the march's steps (T221); it passes in
// about 2.5 min (BENCHMARKS.md §14d), too long for the suite, whose tests above and
// `the_states_at_the_samples_of_the_converged_damper_are_in_the_cone` check the parts.
#[test]
#[ignore = "issue 40's acceptance check of the cone damper, ~2.5 min: cargo test --release --test friction_cone_interface -- --ignored"]
fn a_damper_in_space_converges_in_the_cone_its_jacobian_is_its_central_difference_and_the_tangents_turn_freely(
) {
    let mu = 0.1;
    let f = 250.0;
    let model = damper(Some(mu), 2.0, 0.6, 0.3, "");
    let (sol, x) = solve_damper(&model, &damper(Some(0.5 * mu), 2.0, 0.6, 0.3, ""), f);
    let mut p = ms_hbm(&model, H);
    let (stuck, slipping, open) = check_cone(&sol, mu, p.length_scale());
    assert!(
        stuck && slipping && open,
        "stuck {stuck}, slipping {slipping}, open {open}"
    );
    // the slip is not along one line: both tangential components carry force
    let second = max_abs(sol.frictions.iter().flat_map(|f| f.force2.iter().copied()));
    let first = max_abs(sol.frictions.iter().flat_map(|f| f.force.iter().copied()));
    assert!(
        second > 0.05 * first && first > 0.05 * second,
        "{first} {second}"
    );
    let energy = sol.dissipated_energy.expect("the dissipated energy");
    assert!(energy > 0.0, "{energy}");
    // J v against central differences of the residual (step 10⁻⁵ of the length scale, as
    // the law's own tangent test, docs/theory.md (T191)) along pseudo-random directions, at
    // the solution and off it; and ∂R/∂ω
    let omega = hz(f);
    for point in [x.clone(), perturbed(&x)] {
        let lin = p.linearize(&point, omega).unwrap();
        let dense = lin.jacobian.to_dense();
        let h = 1e-5 * p.length_scale();
        for seed in 1..=3u32 {
            let v: Vec<f64> = (0..point.len())
                .map(|i| ((i as f64 + 1.0) * 0.7548776662 * f64::from(seed)).fract() - 0.5)
                .collect();
            let plus: Vec<f64> = point.iter().zip(&v).map(|(a, b)| a + h * b).collect();
            let minus: Vec<f64> = point.iter().zip(&v).map(|(a, b)| a - h * b).collect();
            let (rp, rm) = (
                p.residual(&plus, omega).unwrap(),
                p.residual(&minus, omega).unwrap(),
            );
            let fd: Vec<f64> = rp
                .iter()
                .zip(&rm)
                .map(|(a, b)| (a - b) / (2.0 * h))
                .collect();
            let jv: Vec<f64> = (0..point.len())
                .map(|i| (0..point.len()).map(|j| dense[(i, j)] * v[j]).sum())
                .collect();
            let error =
                max_abs(fd.iter().zip(&jv).map(|(a, b)| a - b)) / max_abs(fd.iter().copied());
            assert!(
                error < 1e-6,
                "J v, direction {seed}: relative error {error:e}"
            );
        }
        let hw = 1e-5 * omega;
        let (rp, rm) = (
            p.residual(&point, omega + hw).unwrap(),
            p.residual(&point, omega - hw).unwrap(),
        );
        let fd: Vec<f64> = rp
            .iter()
            .zip(&rm)
            .map(|(a, b)| (a - b) / (2.0 * hw))
            .collect();
        let error =
            max_abs(fd.iter().zip(&lin.d_omega).map(|(a, b)| a - b)) / max_abs(fd.iter().copied());
        assert!(error < 1e-5, "∂R/∂ω: relative error {error:e}");
    }
    // the cone is isotropic: with the tangents turned by 30° about the normal the turned
    // unknowns solve the turned model, and the friction forces turn with them
    let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let turned = damper(
        Some(mu),
        2.0,
        0.6,
        0.3,
        &format!("tangent = [0.0, {c}, {}]", -s),
    );
    let n_c = sol.contacts.len();
    let y = rotate(&x, n_c, c, s);
    let scale = max_abs(p.residual(&perturbed(&x), omega).unwrap());
    let r = residual_at(&turned, &y, f);
    assert!(r <= 1e-9 * scale, "turned residual {r:e} (scale {scale:e})");
    let b = ms_hbm(&turned, H)
        .solution(&y, omega, tip_dof(&turned))
        .unwrap();
    let force_scale = max_abs(sol.contacts.iter().flat_map(|c| c.force.iter().copied()));
    for (fa, fb) in sol.frictions.iter().zip(&b.frictions) {
        for k in 0..fa.force.len() {
            let (u, v) = (fa.force[k], fa.force2[k]);
            let (ub, vb) = (c * u + s * v, -s * u + c * v);
            assert!(
                (ub - fb.force[k]).abs() <= 1e-8 * force_scale,
                "{ub} against {}",
                fb.force[k]
            );
            assert!((vb - fb.force2[k]).abs() <= 1e-8 * force_scale);
        }
    }
    let eb = b.dissipated_energy.unwrap();
    assert!(
        (energy - eb).abs() <= 1e-8 * energy,
        "{energy} against {eb}"
    );
}

#[test]
fn motion_in_a_plane_gives_the_plane_laws_solution() {
    // ν = 0, one element through the thickness and a drive uniform in z: the motion stays in
    // the (x, y) plane, the second tangent carries no force, and the cone law's solution
    // solves the plane law on the same model (the second tangents removed)
    let mu = 0.1;
    let f = 250.0;
    let cone = damper(Some(mu), 2.0, 0.0, 0.0, "");
    let (a, x) = solve_damper(&cone, &damper(Some(0.5 * mu), 2.0, 0.0, 0.0, ""), f);
    let (stuck, slipping, open) = check_cone(&a, mu, 100.0);
    assert!(
        stuck && slipping && open,
        "stuck {stuck}, slipping {slipping}, open {open}"
    );
    let mut plane = cone.clone();
    for c in &mut plane.contacts {
        c.friction.as_mut().unwrap().second = None;
    }
    let n_c = a.contacts.len();
    let scale = max_abs(x.iter().copied());
    let in_plane: Vec<f64> = x
        .chunks(3 * n_c)
        .flat_map(|block| {
            assert!(max_abs(block[2 * n_c..].iter().copied()) <= 1e-12 * scale);
            block[..2 * n_c].to_vec()
        })
        .collect();
    let mut p = ms_hbm(&cone, H);
    let residual_scale = max_abs(p.residual(&perturbed(&x), hz(f)).unwrap());
    let r = residual_at(&plane, &in_plane, f);
    assert!(
        r <= 1e-9 * residual_scale,
        "plane residual {r:e} (scale {residual_scale:e})"
    );
    let b = ms_hbm(&plane, H)
        .solution(&in_plane, hz(f), tip_dof(&plane))
        .unwrap();
    let force_scale = max_abs(b.contacts.iter().flat_map(|c| c.force.iter().copied()));
    for (fa, fb) in a.frictions.iter().zip(&b.frictions) {
        let out_of_plane = max_abs(fa.force2.iter().copied());
        // the switches are located to 1e-11 of the scales (friction/cone/mod.rs): the
        // harmonics of λ carry that error amplified by the jump of λ̇ across them (~1e-8)
        assert!(
            out_of_plane <= 1e-7 * force_scale,
            "force along t₂ {out_of_plane:e} (scale {force_scale:e})"
        );
        for (x, y) in fa.force.iter().zip(&fb.force) {
            assert!((x - y).abs() <= 1e-7 * force_scale, "{x} against {y}");
        }
        assert_eq!(fa.state, fb.state);
    }
    // the energies: (T221) by Gauss–Legendre on the cone, (T180) exact on the plane
    let (ea, eb) = (a.dissipated_energy.unwrap(), b.dissipated_energy.unwrap());
    assert!((ea - eb).abs() <= 1e-7 * eb, "{ea} against {eb}");
}

#[test]
fn the_methods_that_model_plane_friction_refuse_the_cone() {
    let model = damper(Some(0.1), 2.0, 0.6, 0.3, "");
    let system = model.system(mshbm::MassKind::Redistributed).unwrap();
    let settings = mshbm::integrate::Settings {
        dt: 1e-6,
        scheme: mshbm::integrate::Scheme::PositionNewmark,
        omega: Some(hz(250.0)),
        energy_offset: 0.0,
    };
    let e = mshbm::integrate::Integrator::new(&system, &settings)
        .err()
        .expect("refused")
        .to_string();
    assert!(e.contains("Coulomb cone"), "{e}");
    // Floquet multipliers with the cone are not implemented: refused, not wrong
    let mut p = ms_hbm(&model, 2);
    let omega = hz(250.0);
    let x = p.initial_guess(omega).unwrap();
    let e = p.floquet(&x, omega).expect_err("refused").to_string();
    assert!(e.contains("Coulomb cone"), "{e}");
}

/// The cone law's input at a Newton iterate of the damper above (μ = 0.1, H = 2; the Delassus
/// matrix of the four tip contacts, their μ and the free gap's coefficients, as the solver
/// passed them; `data/cone_damper_apex.txt`: `H cells n`, then one line each), where a
/// contact slips into opening.
fn damper_law() -> (ConeContacts, usize, usize, Vec<f64>) {
    law_from(include_str!("data/cone_damper_apex.txt"))
}

/// A cone law and its input from a file of the layout of [`damper_law`]'s.
fn law_from(text: &str) -> (ConeContacts, usize, usize, Vec<f64>) {
    let mut lines = text.lines();
    let numbers = |line: Option<&str>| -> Vec<f64> {
        line.unwrap()
            .split(' ')
            .map(|v| v.parse().unwrap())
            .collect()
    };
    let head = numbers(lines.next());
    let delassus = numbers(lines.next());
    let mu = numbers(lines.next());
    let gamma = numbers(lines.next());
    let law = ConeContacts::new(delassus, mu).unwrap();
    (law, head[0] as usize, head[1] as usize, gamma)
}

/// The central difference of the law's periodic forces at `gamma` along `direction`.
fn law_central_difference(
    law: &ConeContacts,
    h: usize,
    cells: usize,
    gamma: &[f64],
    direction: &[f64],
    step: f64,
) -> Vec<f64> {
    let forces = |sign: f64| {
        let g: Vec<f64> = gamma
            .iter()
            .zip(direction)
            .map(|(g, d)| g + sign * step * d)
            .collect();
        law.periodic(h, &g, cells).unwrap().forces
    };
    let (plus, minus) = (forces(1.0), forces(-1.0));
    plus.iter()
        .zip(&minus)
        .map(|(p, m)| (p - m) / (2.0 * step))
        .collect()
}

/// docs/theory.md (T223): where a slipping contact's force reaches the apex before it opens,
/// the slip direction is the stuck force's rate's, and the tangent must vary that direction,
/// not the force's (which made it 10³–10⁴ times its central difference and Newton stall).
#[test]
fn the_cone_laws_derivative_through_an_opening_from_slip_is_its_central_difference() {
    let (law, h, cells, gamma) = damper_law();
    let n = law.contacts();
    let periodic = law.periodic(h, &gamma, cells).unwrap();
    // a contact slips into opening
    let slips_open = periodic.phases.windows(2).any(|w| {
        (0..n).any(|c| w[0].modes[c] == ConeMode::Slip && w[1].modes[c] == ConeMode::Open)
    });
    assert!(slips_open, "no contact slips into opening");
    let scale = max_abs(gamma.iter().copied());
    for seed in 1..=2u32 {
        let direction: Vec<f64> = (0..gamma.len())
            .map(|i| (((i as f64 + 1.0) * 0.7548776662 * f64::from(seed)).fract() - 0.5) * scale)
            .collect();
        let tangent = law
            .tangent(&periodic, std::slice::from_ref(&direction), cells)
            .unwrap();
        let central = law_central_difference(&law, h, cells, &gamma, &direction, 1e-5);
        let error = max_abs(central.iter().zip(&tangent[0]).map(|(c, t)| c - t))
            / max_abs(central.iter().copied());
        assert!(error < 1e-6, "direction {seed}: relative error {error:e}");
    }
}

/// docs/theory.md (T221): the outputs follow the march that gave the forces. At the converged
/// damper (μ = 0.1, H = 2; the law's input at the solution, `data/cone_damper_solution.txt`)
/// a contact slips at the cone's apex with a normal force at round-off, where the slip flow is
/// not unique; integrated again from its phase's start with steps of their own, the outputs
/// took the other branch and reported it slipping with a normal force down to −5.7 N at 38 of
/// the 256 samples.
#[test]
fn the_states_at_the_samples_of_the_converged_damper_are_in_the_cone() {
    let (law, h, cells, gamma) = law_from(include_str!("data/cone_damper_solution.txt"));
    let n = law.contacts();
    let periodic = law.periodic(h, &gamma, cells).unwrap();
    let taus: Vec<f64> = (0..256)
        .map(|k| 2.0 * std::f64::consts::PI * k as f64 / 256.0)
        .collect();
    let states = law.states_at(&periodic, &taus).unwrap();
    let scale = max_abs(states.iter().flat_map(|s| s.lambda.iter().copied()));
    let mut outside = Vec::new();
    for (k, state) in states.iter().enumerate() {
        for c in 0..n {
            let normal = state.lambda[c];
            let tangential = state.lambda[n + c].hypot(state.lambda[2 * n + c]);
            if normal < -1e-9 * scale || tangential > law.mu()[c] * normal + 1e-9 * scale {
                outside.push((k, c, normal, tangential));
            }
            // the forces at an instant agree with the states
            if k % 16 == 0 {
                let force = law.force_at(&periodic, taus[k]).unwrap();
                assert!((force[c] - normal).abs() <= 1e-9 * scale, "force_at at {k}");
            }
        }
    }
    assert!(
        outside.is_empty(),
        "{} samples outside the cone (sample, contact, λ_N, |λ_T|): {:?}",
        outside.len(),
        &outside[..outside.len().min(4)]
    );
}

/// docs/theory.md (T221): the dissipated energy of the converged damper (Gauss–Legendre on
/// the slip phases, the slip speed times `|λ_T|`) against the work of the friction forces
/// summed over 4096 instants, `−Σ λ_T(τ_k+½) · (y_T(τ_k+1) − y_T(τ_k))`, from the states
/// alone (midpoint rule: second order between the switches; 1.4e-6 apart when written).
#[test]
fn the_dissipated_energy_of_the_converged_damper_is_the_friction_forces_work() {
    let (law, h, cells, gamma) = law_from(include_str!("data/cone_damper_solution.txt"));
    let n = law.contacts();
    let periodic = law.periodic(h, &gamma, cells).unwrap();
    let energy = law.dissipated_energy(&periodic).unwrap();
    let samples = 4096;
    let taus: Vec<f64> = (0..2 * samples + 1)
        .map(|k| std::f64::consts::PI * k as f64 / samples as f64)
        .collect();
    let states = law.states_at(&periodic, &taus).unwrap();
    let mut work = 0.0;
    for k in 0..samples {
        let (a, mid, b) = (&states[2 * k], &states[2 * k + 1], &states[2 * k + 2]);
        for c in 0..n {
            for t in [n + c, 2 * n + c] {
                work -= mid.lambda[t] * (b.y[t] - a.y[t]);
            }
        }
    }
    assert!(energy > 0.0, "{energy}");
    let error = (work - energy).abs() / energy;
    assert!(
        error < 1e-5,
        "energy {energy:e}, work {work:e}: relative {error:e}"
    );
}

/// docs/theory.md (T225): a product `S v` is one march of `v` with the anchors' response of
/// the periodic state (its `2|R|` unit anchors marched and `I − P_RR` inverted once): equal
/// to the central difference of the law along `v` and to the dense `S` (T220) times `v`, at
/// the iterate where a contact slips into opening.
#[test]
fn a_product_with_the_laws_derivative_is_one_march_of_its_direction() {
    let (law, h, cells, gamma) = damper_law();
    let periodic = law.periodic(h, &gamma, cells).unwrap();
    let response = law.anchor_response(&periodic, cells).unwrap();
    assert!(
        response.anchors() > 0,
        "no anchor is periodic by the march alone"
    );
    // the dense S from a march of its own (the product replays the primal path of the
    // response's march)
    let dense = law.jacobian(&periodic, cells).unwrap();
    let size = gamma.len();
    let scale = max_abs(gamma.iter().copied());
    let direction: Vec<f64> = (0..size)
        .map(|i| (((i as f64 + 1.0) * 0.5698402910).fract() - 0.5) * scale)
        .collect();
    let product = law
        .tangent_with(
            &periodic,
            &response,
            std::slice::from_ref(&direction),
            cells,
        )
        .unwrap()
        .remove(0);
    // the central difference's truncation error is ~2e-6 at 1e-5, 8e-7 at 1e-6 and 1e-7
    let central = law_central_difference(&law, h, cells, &gamma, &direction, 1e-6);
    let norm = max_abs(central.iter().copied());
    let error = max_abs(central.iter().zip(&product).map(|(c, t)| c - t)) / norm;
    assert!(error < 1e-6, "against central differences {error:e}");
    let s_v: Vec<f64> = dense
        .chunks_exact(size)
        .map(|row| row.iter().zip(&direction).map(|(a, b)| a * b).sum())
        .collect();
    let error = max_abs(s_v.iter().zip(&product).map(|(c, t)| c - t)) / norm;
    assert!(error < 1e-10, "against the dense S {error:e}");
}

/// docs/theory.md (T225), §18: the operator Jacobian with the cone applies `J` by products
/// with `S` (no dense `S` until its preconditioner is refreshed) and gives the dense
/// Jacobian's action; `∂R/∂ω` (one product) is its central difference in ω.
#[test]
fn the_operator_jacobian_with_the_cone_applies_the_dense_jacobian() {
    use mshbm::harmonic::Quadrature;
    use mshbm::method::redistributed::{JacobianForm, RedistributedMsHbm, RedistributedOptions};
    use mshbm::problem::Jacobian;
    let model = damper(Some(0.1), 2.0, 0.6, 0.3, "");
    let with = |jacobian: JacobianForm| {
        RedistributedMsHbm::new(
            &model,
            &RedistributedOptions {
                quadrature: Quadrature::Exact,
                jacobian,
                ..RedistributedOptions::new(H)
            },
        )
        .unwrap()
    };
    let omega = hz(250.0);
    let (mut operator, mut dense) = (with(JacobianForm::Operator), with(JacobianForm::Dense));
    let x = perturbed(&operator.initial_guess(omega).unwrap());
    let a = operator.linearize(&x, omega).unwrap();
    let b = dense.linearize(&x, omega).unwrap();
    let (Jacobian::Operator(op), Jacobian::Dense(m)) = (&a.jacobian, &b.jacobian) else {
        panic!("the forms asked for");
    };
    let n = x.len();
    let v: Vec<f64> = (0..n)
        .map(|i| ((i as f64 + 1.0) * 0.7548776662).fract() - 0.5)
        .collect();
    let mut applied = vec![0.0; n];
    op.apply(&v, &mut applied);
    let expected: Vec<f64> = (0..n)
        .map(|i| (0..n).map(|j| m[(i, j)] * v[j]).sum())
        .collect();
    let error = max_abs(expected.iter().zip(&applied).map(|(e, a)| e - a))
        / max_abs(expected.iter().copied());
    assert!(error < 1e-7, "J v: {error:e}");
    let step = 1e-5 * omega;
    let r = |p: &mut RedistributedMsHbm, w: f64| p.residual(&x, w).unwrap();
    let (plus, minus) = (r(&mut dense, omega + step), r(&mut dense, omega - step));
    let central: Vec<f64> = plus
        .iter()
        .zip(&minus)
        .map(|(p, m)| (p - m) / (2.0 * step))
        .collect();
    let error = max_abs(central.iter().zip(&a.d_omega).map(|(c, d)| c - d))
        / max_abs(central.iter().copied());
    assert!(error < 1e-5, "∂R/∂ω against central differences: {error:e}");
}
