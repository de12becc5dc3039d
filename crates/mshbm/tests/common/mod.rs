//! Test models and reference checks shared by the integration tests.
#![allow(dead_code)]

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use faer::linalg::solvers::Solve;
use faer::{c64, Mat};
use mshbm::harmonic::Quadrature;
use mshbm::integrate::initial::state_from_harmonics;
use mshbm::method::redistributed::{RedistributedMsHbm, RedistributedOptions};
use mshbm::model::file::load_model;
use mshbm::model::{Contact, Damping, Model, System};
use mshbm::newton::{solve_at_frequency, NewtonOptions};
use mshbm::problem::PeriodicProblem;
use mshbm::solution::PeriodicSolution;
use mshbm::sparse::SparseMatrix;
use mshbm::MassKind;

pub fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

/// `examples/<file>` with the `--set`-style `overrides` (`key=value`).
pub fn example_model<S: AsRef<str>>(file: &str, overrides: &[S]) -> Model {
    let o: Vec<String> = overrides.iter().map(|s| s.as_ref().to_string()).collect();
    load_model(&examples().join(file), &o).unwrap()
}

/// The paper's bar (examples/clamped_bar.toml) refined to `elements`, with Rayleigh
/// damping acting on the L block only (so that C_NN = C_NL = 0, as the redistributed
/// MS-HBM needs): `C = α M_R + β K_LL` (`damping.alpha`, `damping.beta_linear`) with 1 %
/// modal damping at the first eigenfrequency ω₁ and at 10 ω₁.
pub fn rayleigh_damped_bar(elements: usize) -> Model {
    let refined = format!("bar.elements={elements}");
    let model = example_model("clamped_bar.toml", &[&refined]);
    let system = model.system(MassKind::Redistributed).unwrap();
    let w1 = mshbm::modes::first_angular_frequency(&system.mass, &system.stiffness).unwrap();
    let (zeta, w2) = (0.01, 10.0 * w1);
    example_model(
        "clamped_bar.toml",
        &[
            refined,
            format!("damping.alpha={}", 2.0 * zeta * w1 * w2 / (w1 + w2)),
            format!("damping.beta_linear={}", 2.0 * zeta / (w1 + w2)),
        ],
    )
}

/// Angular frequency (rad/s) of `f` Hz.
pub fn hz(f: f64) -> f64 {
    2.0 * PI * f
}

pub fn max_abs(v: impl IntoIterator<Item = f64>) -> f64 {
    v.into_iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// The redistributed MS-HBM (paper Sections 3.1–3.2) with the exact quadrature and the
/// default samples.
pub fn ms_hbm(model: &Model, harmonics: usize) -> RedistributedMsHbm {
    ms_hbm_with(model, harmonics, Quadrature::Exact, None)
}

/// The redistributed MS-HBM with the given quadrature and samples.
pub fn ms_hbm_with(
    model: &Model,
    harmonics: usize,
    quadrature: Quadrature,
    samples: Option<usize>,
) -> RedistributedMsHbm {
    try_ms_hbm(model, harmonics, quadrature, samples).unwrap()
}

/// Constructing the redistributed MS-HBM, which may refuse the model or the settings.
pub fn try_ms_hbm(
    model: &Model,
    harmonics: usize,
    quadrature: Quadrature,
    samples: Option<usize>,
) -> mshbm::Result<RedistributedMsHbm> {
    RedistributedMsHbm::new(
        model,
        &RedistributedOptions {
            harmonics,
            samples,
            quadrature,
            receptance: Default::default(),
            jacobian: Default::default(),
        },
    )
}

/// A point off the solution `x`: every unknown scaled by `1 + 0.05 sin i`.
/// Central differences of `p`'s residual at `(x, ω)` along `v`, with the step `10⁻⁷` of the
/// problem's length scale: the reference for a Jacobian's action `J v`.
pub fn directional_difference(
    p: &mut dyn mshbm::problem::PeriodicProblem,
    x: &[f64],
    omega: f64,
    v: &[f64],
) -> Vec<f64> {
    let h = 1e-7 * p.length_scale();
    let xp: Vec<f64> = x.iter().zip(v).map(|(a, b)| a + h * b).collect();
    let xm: Vec<f64> = x.iter().zip(v).map(|(a, b)| a - h * b).collect();
    let (rp, rm) = (
        p.residual(&xp, omega).unwrap(),
        p.residual(&xm, omega).unwrap(),
    );
    rp.iter()
        .zip(&rm)
        .map(|(a, b)| (a - b) / (2.0 * h))
        .collect()
}

pub fn perturbed(x: &[f64]) -> Vec<f64> {
    x.iter()
        .enumerate()
        .map(|(i, v)| v * (1.0 + 0.05 * (i as f64).sin()))
        .collect()
}

/// Max relative deviation of the analytic Jacobian and ∂R/∂ω from central differences.
pub fn jacobian_errors(p: &mut impl PeriodicProblem, x: &[f64], omega: f64) -> (f64, f64) {
    let lin = p.linearize(x, omega).unwrap();
    let n = x.len();
    let h = 1e-7 * p.length_scale();
    let mut fd = Mat::<f64>::zeros(n, n);
    for j in 0..n {
        let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
        xp[j] += h;
        xm[j] -= h;
        let (rp, rm) = (
            p.residual(&xp, omega).unwrap(),
            p.residual(&xm, omega).unwrap(),
        );
        for i in 0..n {
            fd[(i, j)] = (rp[i] - rm[i]) / (2.0 * h);
        }
    }
    let entries = |m: &Mat<f64>| -> Vec<f64> {
        (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .map(|(i, j)| m[(i, j)])
            .collect()
    };
    let jac_err = max_abs(
        entries(&fd)
            .iter()
            .zip(entries(&lin.jacobian.to_dense()))
            .map(|(a, b)| a - b),
    );
    let jac_rel = jac_err / max_abs(entries(&fd));
    // |ω ∂R/∂ω| ≪ |R|, so small steps drown in round-off and large ones see the kinks of
    // the switching times: take the best of a few steps
    let mut w_rel = f64::INFINITY;
    for rel in [1e-4, 1e-5, 1e-6, 1e-7] {
        let hw = rel * omega;
        let (rp, rm) = (
            p.residual(x, omega + hw).unwrap(),
            p.residual(x, omega - hw).unwrap(),
        );
        let fd_w: Vec<f64> = (0..n).map(|i| (rp[i] - rm[i]) / (2.0 * hw)).collect();
        let err = max_abs(fd_w.iter().zip(&lin.d_omega).map(|(a, b)| a - b));
        w_rel = w_rel.min(err / max_abs(fd_w.iter().copied()));
    }
    (jac_rel, w_rel)
}

/// The analytic Jacobian and ∂R/∂ω of `p` at `x` agree with central differences
/// ([`jacobian_errors`]) within `tolerance`, relative; `case` names the case on failure.
pub fn assert_derivatives_match_finite_differences(
    p: &mut impl PeriodicProblem,
    x: &[f64],
    omega: f64,
    tolerance: f64,
    case: &str,
) {
    let (ej, ew) = jacobian_errors(p, x, omega);
    assert!(
        ej < tolerance && ew < tolerance,
        "{case}: J err {ej:.2e}, dR/dw err {ew:.2e}"
    );
}

/// Newton for `p` at `omega` from the linear response (response DOF `dof`) converges, and
/// the analytic derivatives agree with central differences within `tolerance` at the
/// solution and at the [`perturbed`] point off it. Returns the solution for the case's own
/// checks.
pub fn solve_and_check_derivatives(
    p: &mut impl PeriodicProblem,
    omega: f64,
    dof: usize,
    tolerance: f64,
    case: &str,
) -> PeriodicSolution {
    let (sol, out) = solve_at_frequency(p, omega, dof, &NewtonOptions::default()).unwrap();
    assert!(out.converged, "{case}: {:?}", out.reason);
    for x in [&out.x, &perturbed(&out.x)] {
        assert_derivatives_match_finite_differences(p, x, omega, tolerance, case);
    }
    sol
}

/// Direct linear frequency response of the full system with `mass` (dense complex solve of
/// `(K − ω² M + iω C) z = f`, the contact-free reference): harmonic 1 of every free DOF,
/// and the system's model numbering.
pub fn direct_linear_response(model: &Model, mass: MassKind, omega: f64) -> (Vec<usize>, Vec<c64>) {
    let s = model.system(mass).unwrap();
    let n = s.n_dofs();
    let a = Mat::<c64>::from_fn(n, n, |i, j| {
        c64::new(
            s.stiffness.get(i, j) - omega * omega * s.mass.get(i, j),
            omega * s.damping.get(i, j),
        )
    });
    let rhs = Mat::<c64>::from_fn(n, 1, |i, _| c64::new(s.harmonic_load[i], 0.0));
    let z = a.partial_piv_lu().solve(&rhs);
    (s.model_dof.clone(), (0..n).map(|i| z[(i, 0)]).collect())
}

/// The response coefficients `c = [a0, a1, b1, a2, …]` are those of the linear response
/// with harmonic-1 phasor `z` (`a1 = Re z`, `b1 = −Im z`, every other one zero), within
/// `tolerance·|z|`; `case` names the case on failure.
pub fn assert_is_linear_response(c: &[f64], z: c64, tolerance: f64, case: &str) {
    let amp = z.norm();
    assert!(
        (c[1] - z.re).abs() <= tolerance * amp && (c[2] + z.im).abs() <= tolerance * amp,
        "{case}: {c:?} vs {z:?}"
    );
    assert!(
        c[0].abs() <= tolerance * amp && c[3..].iter().all(|v| v.abs() <= tolerance * amp),
        "{case}: {c:?}"
    );
}

/// `(q(0), v(0))` of `system` on the periodic solution `sol` at `omega`, from the harmonics
/// of its contact DOFs.
pub fn state_on_orbit(system: &System, omega: f64, sol: &PeriodicSolution) -> (Vec<f64>, Vec<f64>) {
    let known: Vec<(usize, Vec<f64>)> = sol
        .contacts
        .iter()
        .map(|c| (system.system_dof(c.dof).unwrap(), c.coefficients.clone()))
        .collect();
    state_from_harmonics(system, omega, &known).unwrap()
}

/// The lattice lives in the library so that the benchmarks can use it too.
#[allow(unused_imports)]
pub use mshbm::model::lattice::lattice_model;

/// The bilinear oscillator: a mass `m` on a spring `k` to ground, and a massless contact
/// node attached to it by a spring `k_c` that hits a rigid stop after a gap `g`
/// (`g_N = g − q_1`). In contact the stiffness is `k + k_c`: the classic piecewise-linear
/// oscillator whose free frequency depends on the amplitude. Harmonic force `F cos ωt` on
/// the mass; mass-proportional damping `alpha`.
pub fn bilinear_oscillator(m: f64, k: f64, k_c: f64, gap: f64, force: f64, alpha: f64) -> Model {
    Model {
        stiffness_file: None,
        source: PathBuf::from("bilinear oscillator"),
        input_files: vec![],
        cells: None,
        node_sets: Default::default(),
        node_labels: None,
        interfaces: vec![],
        name: "bilinear oscillator".into(),
        mass: SparseMatrix::from_triplets(2, 2, &[(0, 0, m)]),
        stiffness: SparseMatrix::from_triplets(
            2,
            2,
            &[(0, 0, k + k_c), (0, 1, -k_c), (1, 0, -k_c), (1, 1, k_c)],
        ),
        damping_matrix: None,
        coordinates: vec![vec![0.0], vec![1.0]],
        dofs_per_node: 1,
        dirichlet: vec![],
        contacts: vec![Contact {
            dofs: vec![1],
            w: vec![-1.0],
            gap,
            friction: None,
        }],
        harmonic_load: vec![force, 0.0],
        constant_load: vec![0.0, 0.0],
        frictions: vec![],
        acceleration: None,
        damping: Damping {
            alpha,
            ..Damping::default()
        },
    }
}

/// Analytic backbone of the undamped bilinear oscillator: angular frequency of the free
/// periodic motion with maximum displacement `a > gap` (contact phase about the shifted
/// equilibrium `k_c g/(k + k_c)` at `ω₂`, free phase at `ω₁`).
pub fn bilinear_backbone(m: f64, k: f64, k_c: f64, gap: f64, a: f64) -> f64 {
    let (w1, w2) = ((k / m).sqrt(), ((k + k_c) / m).sqrt());
    if a <= gap {
        return w1;
    }
    let qe = k_c * gap / (k + k_c);
    let tc = ((gap - qe) / (a - qe)).acos() / w2;
    let v = (a - qe) * w2 * (w2 * tc).sin();
    let b = (gap * gap + (v / w1).powi(2)).sqrt();
    let period = 2.0 * tc + 2.0 * (std::f64::consts::PI - (gap / b).acos()) / w1;
    2.0 * std::f64::consts::PI / period
}

/// `df/dx` at `x` by Richardson extrapolation of central differences with steps `h` and
/// `h/2` (error O(h⁴)), for a complex vector function.
pub fn richardson_derivative(f: impl Fn(f64) -> Vec<c64>, x: f64, h: f64) -> Vec<c64> {
    let central = |h: f64| -> Vec<c64> {
        f(x + h)
            .iter()
            .zip(f(x - h))
            .map(|(a, b)| (a - b) / (2.0 * h))
            .collect()
    };
    let (coarse, fine) = (central(h), central(0.5 * h));
    fine.iter()
        .zip(&coarse)
        .map(|(f, c)| (f * 4.0 - c) / 3.0)
        .collect()
}

/// `max |a − b| / max |b|` of complex vectors.
pub fn complex_rel_diff(a: &[c64], b: &[c64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let largest = |v: &mut dyn Iterator<Item = c64>| v.fold(0.0f64, |m, x| m.max(x.norm()));
    largest(&mut a.iter().zip(b).map(|(x, y)| x - y)) / largest(&mut b.iter().copied())
}

/// The friction damper example with `mu` replaced (`None`: the line removed) and the
/// overrides `set`.
pub fn friction_damper(mu: Option<f64>, set: &[&str]) -> Model {
    let path = examples().join("friction_damper/model.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let text: String = text
        .lines()
        .filter_map(|line| match (line.starts_with("mu ="), mu) {
            (true, None) => None,
            (true, Some(m)) => Some(format!("mu = {m}")),
            _ => Some(line.to_string()),
        })
        .collect::<Vec<_>>()
        .join("\n");
    let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
    mshbm::model::file::parse_model(&text, Path::new(&path), &set).unwrap()
}

/// The redistributed mass of `m` (docs/theory.md §4): every DOF of every contact node
/// massless, total mass and first and second moments of each component kept to 1e-12,
/// symmetric, no entry outside the consistent pattern, positive definite on the rest.
pub fn assert_redistribution(m: &Model, case: &str) {
    use faer::Side;
    use mshbm::fe::redistribution::{moments, scalar_mass};
    let consistent = m.mass_matrix(MassKind::Consistent).unwrap();
    let redistributed = m.mass_matrix(MassKind::Redistributed).unwrap();
    let d = m.dofs_per_node;
    let contact_nodes: std::collections::HashSet<usize> = m.contact_nodes().into_iter().collect();
    for (i, j, v) in redistributed.iter() {
        if contact_nodes.contains(&(i / d)) || contact_nodes.contains(&(j / d)) {
            assert_eq!(v, 0.0, "{case}: entry ({i}, {j}) of a contact node");
        }
        assert!(
            consistent.is_stored(i, j),
            "{case}: ({i}, {j}) outside the pattern"
        );
        let scale = redistributed.max_abs();
        assert!(
            (v - redistributed.get(j, i)).abs() <= 1e-14 * scale,
            "{case}: not symmetric"
        );
    }
    let (before, after) = (
        moments(&scalar_mass(&consistent, d).unwrap(), &m.coordinates),
        moments(&scalar_mass(&redistributed, d).unwrap(), &m.coordinates),
    );
    let length = m
        .coordinates
        .iter()
        .flatten()
        .fold(0.0f64, |l, x| l.max(x.abs()));
    // an independent evaluation of the same moments, per component, from the DOF matrix
    for c in 0..d {
        let phi = |p: usize, a: usize| if a == 0 { 1.0 } else { m.coordinates[p][a - 1] };
        for a in 0..=d {
            for b in 0..=d {
                let direct: f64 = redistributed
                    .iter()
                    .filter(|&(i, j, _)| i % d == c && j % d == c)
                    .map(|(i, j, v)| phi(i / d, a) * v * phi(j / d, b))
                    .sum();
                let k = a * (d + 1) + b;
                // relative to the moment's natural size: mass × (largest coordinate)^degree
                let degree = i32::from(a > 0) + i32::from(b > 0);
                let scale = before[k].abs().max(before[0] * length.powi(degree));
                assert!((direct - after[k]).abs() <= 1e-12 * scale);
                assert!(
                    (after[k] - before[k]).abs() <= 1e-12 * scale,
                    "{case}: moment ({a}, {b}) {} vs {}",
                    after[k],
                    before[k]
                );
            }
        }
    }
    let keep: Vec<usize> = (0..m.n_dofs())
        .filter(|&i| !contact_nodes.contains(&(i / d)))
        .collect();
    assert!(
        redistributed
            .submatrix(&keep, &keep)
            .to_faer()
            .sp_cholesky(Side::Lower)
            .is_ok(),
        "{case}: not positive definite"
    );
}
