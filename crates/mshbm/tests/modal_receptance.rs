//! The modal receptance at the contacts (docs/theory.md (T130)–(T132)) against the exact one
//! (a sparse LU of the whole structure, itself checked against dense solves in
//! `tests/condensation.rs`): equal with every mode, converging in the number of modes,
//! its frequency derivative against finite differences, and the periodic solutions of the
//! redistributed MS-HBM on both paths.

mod common;

use faer::c64;
use mshbm::harmonic::Quadrature;
use mshbm::linear::{ExactReceptance, ModalReceptance, Receptance, ReceptanceAtFrequency};
use mshbm::method::redistributed::{ReceptanceChoice, RedistributedMsHbm, RedistributedOptions};
use mshbm::newton::{solve as newton_solve, NewtonOptions};
use mshbm::problem::PeriodicProblem;
use mshbm::MassKind;

use common::{example_model, hz, rayleigh_damped_bar};

const HARMONICS: usize = 3;

use common::complex_rel_diff as rel_diff;

fn forces(nc: usize) -> Vec<c64> {
    (0..nc)
        .map(|c| c64::new(0.3 + 0.1 * c as f64, -0.2 * c as f64))
        .collect()
}

/// The largest relative difference of every quantity of two receptances at `omega`.
fn receptance_difference(
    a: &dyn ReceptanceAtFrequency,
    b: &dyn ReceptanceAtFrequency,
    nc: usize,
) -> f64 {
    let force = forces(nc);
    let mut worst = 0.0f64;
    for k in 0..=a.harmonics() {
        worst = worst.max(rel_diff(a.receptance(k), b.receptance(k)));
        if k <= 1 {
            worst = worst.max(rel_diff(a.load_response(k), b.load_response(k)));
        }
        let (qa, qb) = (
            a.response(k, &force).unwrap(),
            b.response(k, &force).unwrap(),
        );
        worst = worst.max(rel_diff(&qa, &qb));
        if k > 0 {
            for with_load in [true, false] {
                let da = a.frequency_derivative(k, &force, with_load).unwrap();
                let db = b.frequency_derivative(k, &force, with_load).unwrap();
                worst = worst.max(rel_diff(&da, &db));
            }
        }
    }
    worst
}

/// (T130) with every mode with mass is exact, for mass-proportional, condensed-stiffness
/// (diagonal modal damping, (T148)) and `beta_linear` damping (full modal damping block),
/// with the modes of the block Krylov method and of the dense condensed eigenproblem.
#[test]
fn with_every_mode_the_modal_receptance_is_the_exact_one() {
    for (label, overrides) in [
        ("alpha", vec!["damping.alpha=3000"]),
        (
            "alpha + beta_condensed",
            vec!["damping.alpha=3000", "damping.beta_condensed=2e-8"],
        ),
        ("beta_linear", vec!["damping.beta_linear=2e-8"]),
    ] {
        let mut all = vec!["bar.elements=30"];
        all.extend(overrides);
        let model = example_model("clamped_bar.toml", &all);
        let system = model.system(MassKind::Redistributed).unwrap();
        let massive = system.n_dofs() - mshbm::modes::massless_dofs(&system.mass).len();
        // the modes by the block Krylov method, and by condensation and a dense eigensolver
        let krylov = ModalReceptance::new(&system, massive).unwrap();
        let condensed = ModalReceptance::every_mode(&system).unwrap();
        assert_eq!(condensed.n_modes(), massive);
        let exact = ExactReceptance::new(&system).unwrap();
        for (modes, modal) in [("Krylov", krylov), ("condensed", condensed)] {
            assert_eq!(
                modal.diagonalises_damping(),
                label != "beta_linear",
                "{label}"
            );
            for f in [5e3, 30e3, 71e3] {
                let omega = hz(f);
                let (a, b) = (
                    modal.at(omega, HARMONICS).unwrap(),
                    exact.at(omega, HARMONICS).unwrap(),
                );
                let e = receptance_difference(a.as_ref(), b.as_ref(), system.contacts.len());
                println!("{label}, {f} Hz: modal (all {massive} modes, {modes}) vs exact {e:.1e}");
                assert!(e < 1e-9, "{label} at {f} Hz ({modes}): {e:e}");
            }
        }
    }
}

/// (T131): truncated, the modal receptance is exact at the static harmonic and converges to
/// the exact one as modes are added: below `|Ω² − iΩ c_{m+1}| / ω_{m+1}²` (`Ω = Hω`,
/// `c_j = α + β_c ω_j²`) for damping that the modes diagonalise (`alpha`, `beta_condensed`),
/// more slowly (the dropped damping coupling) for `beta_linear`, which they do not.
#[test]
fn the_truncated_modal_receptance_converges_in_the_number_of_modes() {
    let bar = rayleigh_damped_bar(400);
    let (alpha, beta) = (bar.damping.alpha, bar.damping.beta_linear);
    for (diagonal, damping) in [
        (
            true,
            vec![
                format!("damping.alpha={alpha}"),
                format!("damping.beta_condensed={beta}"),
            ],
        ),
        (
            false,
            vec![
                format!("damping.alpha={alpha}"),
                format!("damping.beta_linear={beta}"),
            ],
        ),
    ] {
        let mut overrides = vec!["bar.elements=400".to_string()];
        overrides.extend(damping);
        let model = example_model("clamped_bar.toml", &overrides);
        let system = model.system(MassKind::Redistributed).unwrap();
        let exact = ExactReceptance::new(&system).unwrap();
        let omega = hz(30e3);
        let b = exact.at(omega, HARMONICS).unwrap();
        let nc = system.contacts.len();
        let computed = mshbm::modes::lowest_modes(&system.mass, &system.stiffness, 81).unwrap();
        let mut previous = f64::INFINITY;
        for m in [5, 10, 20, 40, 80] {
            let truncated = mshbm::modes::LowestModes {
                eigenvalues: computed.eigenvalues[..m].to_vec(),
                shapes: computed.shapes.subcols(0, m).to_owned(),
                solver: computed.solver,
            };
            let modal = ModalReceptance::with_modes(&system, truncated).unwrap();
            let a = modal.at(omega, HARMONICS).unwrap();
            let e0 = rel_diff(a.receptance(0), b.receptance(0));
            assert!(e0 < 1e-11, "static harmonic, {m} modes: {e0:e}");
            let e = (1..=HARMONICS)
                .map(|k| rel_diff(a.receptance(k), b.receptance(k)))
                .fold(0.0f64, f64::max);
            let whole = receptance_difference(a.as_ref(), b.as_ref(), nc);
            // the first discarded mode
            let next = computed.eigenvalues[m].sqrt();
            let big = HARMONICS as f64 * omega;
            let c = alpha + beta * next * next;
            let estimate = c64::new(big * big, -big * c).norm() / (next * next);
            println!(
                "{} damping, {m} modes (f_m+1 = {:.0} Hz): R_k error {e:.2e} (response and derivative {whole:.2e}), estimate (T131) {estimate:.2e}",
                if diagonal { "diagonal" } else { "coupled" },
                next / (2.0 * std::f64::consts::PI),
            );
            assert!(e < previous, "{m} modes: {e:e} not below {previous:e}");
            if diagonal {
                assert!(
                    e < 2.0 * estimate,
                    "{m} modes: {e:e} above the estimate {estimate:e}"
                );
            }
            previous = e;
        }
        assert!(previous < 1e-2, "80 modes: {previous:e}");
    }
}

/// (T132): the analytic ω-derivative is that of the truncated receptance (Richardson
/// extrapolated central differences of the modal receptance itself), for a full modal
/// damping block (`beta_linear`) and for diagonal modal damping (`alpha + beta_condensed`,
/// term by term).
#[test]
fn the_modal_frequency_derivative_matches_finite_differences() {
    let diagonal = example_model(
        "clamped_bar.toml",
        &[
            "bar.elements=100",
            "damping.alpha=3000",
            "damping.beta_condensed=2e-8",
        ],
    );
    for (model, diagonalised) in [(rayleigh_damped_bar(100), false), (diagonal, true)] {
        let system = model.system(MassKind::Redistributed).unwrap();
        let modal = ModalReceptance::new(&system, 12).unwrap();
        assert_eq!(modal.diagonalises_damping(), diagonalised);
        let nc = system.contacts.len();
        let force = forces(nc);
        let omega = hz(40e3);
        let at = modal.at(omega, HARMONICS).unwrap();
        for k in 1..=HARMONICS {
            for with_load in [true, false] {
                let gather = |omega: f64| -> Vec<c64> {
                    let a = modal.at(omega, HARMONICS).unwrap();
                    let mut v = a.receptance(k)[..nc * nc]
                        .chunks(nc)
                        .map(|row| row.iter().zip(&force).map(|(r, l)| r * l).sum::<c64>())
                        .collect::<Vec<_>>();
                    if with_load {
                        v.iter_mut()
                            .zip(a.load_response(k))
                            .for_each(|(x, y)| *x += y);
                    }
                    v
                };
                let fd = common::richardson_derivative(gather, omega, 1e-4 * omega);
                let analytic = at.frequency_derivative(k, &force, with_load).unwrap();
                let e = rel_diff(&analytic, &fd);
                println!(
                    "diagonal {diagonalised}, harmonic {k} (load {with_load}): ∂(Wᵀq)/∂ω vs differences {e:.1e}"
                );
                assert!(e < 1e-7, "harmonic {k}, load {with_load}: {e:e}");
            }
        }
    }
}

/// With diagonal modal damping the receptance moves to a new frequency in its own storage
/// (`refresh`) and equals one formed there anew; with a full damping block it declines
/// (the method then asks for a new one).
#[test]
fn a_refreshed_modal_receptance_equals_a_new_one() {
    for (overrides, diagonalised) in [
        (vec!["bar.elements=40", "damping.alpha=3000"], true),
        (vec!["bar.elements=40", "damping.beta_linear=2e-8"], false),
    ] {
        let model = example_model("clamped_bar.toml", &overrides);
        let system = model.system(MassKind::Redistributed).unwrap();
        let modal = ModalReceptance::new(&system, 10).unwrap();
        assert_eq!(modal.diagonalises_damping(), diagonalised, "{overrides:?}");
        let mut moved = modal.at(hz(20e3), HARMONICS).unwrap();
        // X_k as a matrix, formed at the old frequency, must not survive the move
        moved.modal_correction(2).unwrap();
        let refreshed = moved.refresh(hz(55e3)).unwrap();
        assert_eq!(refreshed, diagonalised, "{overrides:?}");
        if !refreshed {
            continue;
        }
        let fresh = modal.at(hz(55e3), HARMONICS).unwrap();
        assert_eq!(moved.omega(), fresh.omega());
        let e = receptance_difference(moved.as_ref(), fresh.as_ref(), system.contacts.len());
        assert!(e <= 1e-14, "{e:e}");
        for k in 0..=HARMONICS {
            let (a, b) = (
                moved.modal_correction(k).unwrap(),
                fresh.modal_correction(k).unwrap(),
            );
            assert!(
                (a - b).norm_max() <= 1e-14 * b.norm_max().max(1e-300),
                "X_{k}"
            );
        }
    }
}

fn solve(model: &mshbm::Model, receptance: ReceptanceChoice, f: f64) -> (Vec<f64>, f64) {
    solve_with(model, receptance, f, 5, Quadrature::Exact)
}

/// [`solve`] with `harmonics`.
fn solve_with(
    model: &mshbm::Model,
    receptance: ReceptanceChoice,
    f: f64,
    harmonics: usize,
    quadrature: Quadrature,
) -> (Vec<f64>, f64) {
    let mut p = RedistributedMsHbm::new(
        model,
        &RedistributedOptions {
            receptance,
            quadrature,
            ..RedistributedOptions::new(harmonics)
        },
    )
    .unwrap();
    let omega = hz(f);
    let x0 = p.initial_guess(omega).unwrap();
    let out = newton_solve(&mut p, &x0, omega, &NewtonOptions::default()).unwrap();
    assert!(
        out.converged,
        "{receptance:?} at {f} Hz: residual {:e}",
        out.residual_norm
    );
    // the modal path's Jacobian is that of its residual: quadratic convergence
    let (jac, _) = common::jacobian_errors(&mut p, &common::perturbed(&out.x), omega);
    assert!(
        jac < 1e-5,
        "{receptance:?}: Jacobian vs differences {jac:e}"
    );
    let scale = common::max_abs(out.x.iter().copied());
    (out.x, scale)
}

/// The periodic solutions of the redistributed MS-HBM with the modal receptance converge to
/// those with the exact one; with every mode they are equal (Newton's tolerance).
#[test]
fn modal_solutions_converge_to_the_exact_ones() {
    let model = example_model(
        "clamped_bar.toml",
        &["bar.elements=60", "damping.first_mode_ratio=0.01"],
    );
    let system = model.system(MassKind::Redistributed).unwrap();
    let massive = system.n_dofs() - mshbm::modes::massless_dofs(&system.mass).len();
    for f in [30e3, 60e3] {
        let (exact, scale) = solve(&model, ReceptanceChoice::Exact, f);
        let mut previous = f64::INFINITY;
        for modes in [5, 10, 20, massive] {
            let (modal, _) = solve(&model, ReceptanceChoice::Modal { modes }, f);
            let e = exact
                .iter()
                .zip(&modal)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
                / scale;
            println!("{f} Hz, {modes} modes: max |v_modal − v_exact| / max |v| = {e:.2e}");
            assert!(e <= previous * 1.01 + 1e-12, "{f} Hz, {modes} modes: {e:e}");
            previous = e;
        }
        assert!(previous < 1e-8, "{f} Hz, every mode: {previous:e}");
    }
}

/// On a face of contacts the modal path solves with the static-plus-low-rank maps
/// (docs/theory.md (T136): `R_k⁻¹` by the Woodbury identity, no dense inverse), the exact
/// path with dense inverses of its receptance: with every mode the periodic solutions of the
/// plate (20 contacts, H = 2) are equal, and the contacts do act (the solution is not the
/// linear response).
#[test]
fn on_a_contact_face_every_mode_gives_the_exact_solution() {
    let model = example_model(
        "block_3d/model.toml",
        &["solid.divisions=[4,4,4]", "interfaces.0.gap=0.0003"],
    );
    let system = model.system(MassKind::Redistributed).unwrap();
    let massive = system.n_dofs() - mshbm::modes::massless_dofs(&system.mass).len();
    for f in [500.0, 1000.0] {
        // the sampled quadrature: Newton reaches 1e-17 with it, so the solutions are pinned
        // well below the bound (the exact quadrature's root location stops Newton near
        // 1e-12, which the smallest singular value 8.5e-5 of J turns into 1e-5 of v)
        let sampled = Quadrature::Sampled;
        let (exact, scale) = solve_with(&model, ReceptanceChoice::Exact, f, 2, sampled);
        let modal_choice = ReceptanceChoice::Modal { modes: massive };
        let (modal, _) = solve_with(&model, modal_choice, f, 2, sampled);
        let e = common::max_abs(exact.iter().zip(&modal).map(|(a, b)| a - b)) / scale;
        let mut linear = RedistributedMsHbm::new(&model, &RedistributedOptions::new(2)).unwrap();
        let free = linear.initial_guess(hz(f)).unwrap();
        let contact = common::max_abs(exact.iter().zip(&free).map(|(a, b)| a - b)) / scale;
        println!("{f} Hz: modal (all {massive} modes) vs exact {e:.1e}; contact changes v by {contact:.2}");
        assert!(
            contact > 0.05,
            "{f} Hz: the contacts barely act ({contact:e})"
        );
        assert!(e < 3e-8, "{f} Hz: {e:e}");
    }
}

/// Bad choices are refused with the number of modes the model allows.
#[test]
fn too_many_modes_are_refused() {
    let model = example_model("clamped_bar.toml", &["bar.elements=20"]);
    let err = RedistributedMsHbm::new(
        &model,
        &RedistributedOptions {
            receptance: ReceptanceChoice::Modal { modes: 500 },
            ..RedistributedOptions::new(3)
        },
    )
    .err()
    .expect("500 modes of a 20-element bar");
    let text = err.to_string();
    assert!(text.contains("500") && text.contains("modes"), "{text}");
}

/// The set-up tells its observer each phase, the receptance's included, and then that it
/// is done (the CLI prints the phases that run for more than a second).
#[test]
fn the_set_up_reports_its_phases() {
    use mshbm::method::SetupObserver;
    use std::sync::{Arc, Mutex};
    let model = example_model("clamped_bar.toml", &["bar.elements=20"]);
    for (receptance, expected) in [
        (ReceptanceChoice::Exact, "the exact receptance"),
        (
            ReceptanceChoice::Modal { modes: 5 },
            "the modal receptance: the 5 lowest modes",
        ),
    ] {
        let seen: Arc<Mutex<Vec<Option<String>>>> = Arc::default();
        let record = Arc::clone(&seen);
        let observer = SetupObserver::new(move |phase| {
            record.lock().unwrap().push(phase.map(str::to_string));
        });
        RedistributedMsHbm::within_observed(
            &model,
            &RedistributedOptions {
                receptance,
                ..RedistributedOptions::new(3)
            },
            &mshbm::limits::Limits::default(),
            Some(&observer),
        )
        .unwrap();
        let seen = seen.lock().unwrap().clone();
        println!("{seen:?}");
        assert_eq!(seen.len(), 4, "{seen:?}");
        assert!(
            seen[0].as_deref().unwrap().starts_with("the system"),
            "{seen:?}"
        );
        assert!(
            seen[1]
                .as_deref()
                .unwrap()
                .starts_with("the static contact problem"),
            "{seen:?}"
        );
        assert!(
            seen[2].as_deref().unwrap().starts_with(expected),
            "{seen:?}"
        );
        assert_eq!(seen[3], None, "the set-up ends with None");
    }
}

/// `ReceptanceChoice::Auto` weighs the cost of the exact receptance by the fill of the
/// stiffness factor, not by the DOFs alone: a bar of 30 000 elements (more DOFs than
/// `MODAL_RECEPTANCE_DOFS`, two factor values per DOF) keeps the exact receptance, which
/// costs a fraction of a second per frequency there, where 200 modes took minutes.
#[test]
fn auto_keeps_the_exact_receptance_of_a_slender_model() {
    use mshbm::method::redistributed::{MODAL_RECEPTANCE_DOFS, MODAL_RECEPTANCE_FILL};
    let model = example_model(
        "clamped_bar.toml",
        &["bar.elements=30000", "damping.first_mode_ratio=0.01"],
    );
    let system = model.system(mshbm::MassKind::Redistributed).unwrap();
    assert!(system.n_dofs() > MODAL_RECEPTANCE_DOFS);
    let fill = mshbm::sparse::cholesky_fill(&system.stiffness).unwrap();
    assert!(
        fill <= MODAL_RECEPTANCE_FILL * system.n_dofs(),
        "fill {fill}"
    );
    let seen = setup_phases(&model, 3);
    assert!(
        seen.iter().any(|p| p.starts_with("the exact receptance")),
        "{seen:?}"
    );
}

/// `ReceptanceChoice::Auto` on a small model: every mode when the modes diagonalise the
/// damping (the README's bar, 1 % mass-proportional damping), and then the periodic
/// solution is the exact receptance's (to Newton's tolerance); the exact receptance when
/// they do not (`beta_linear`, a full modal damping block).
#[test]
fn auto_takes_every_mode_of_a_small_model_whose_modes_diagonalise_its_damping() {
    use mshbm::method::redistributed::EVERY_MODE_DOFS;
    for (damping, every_mode) in [
        ("damping.first_mode_ratio=0.01", true),
        ("damping.beta_linear=2e-8", false),
    ] {
        let model = example_model("clamped_bar.toml", &[damping]);
        let system = model.system(MassKind::Redistributed).unwrap();
        let massive = system.n_dofs() - mshbm::modes::massless_dofs(&system.mass).len();
        assert!(massive <= EVERY_MODE_DOFS);
        let seen = setup_phases(&model, 5);
        assert!(
            seen.iter()
                .any(|p| p.starts_with("the modal receptance with every mode")),
            "{seen:?}"
        );
        let exact_phase = seen.iter().any(|p| p.starts_with("the exact receptance"));
        assert_eq!(exact_phase, !every_mode, "{damping}: {seen:?}");
        if every_mode {
            for f in [30e3, 60e3] {
                let e = auto_against_exact(&model, f);
                println!("{f} Hz: every mode vs exact {e:.1e}");
                assert!(e < 1e-9, "{f} Hz: {e:e}");
            }
        }
    }
}

/// The largest difference between the periodic solutions at `f` Hz with the receptance
/// `Auto` picks and with the exact one, relative to the solution's scale.
fn auto_against_exact(model: &mshbm::Model, f: f64) -> f64 {
    let (a, scale) = solve(model, ReceptanceChoice::Auto, f);
    let (b, _) = solve(model, ReceptanceChoice::Exact, f);
    a.iter()
        .zip(&b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
        / scale
}

/// `ReceptanceChoice::Auto` on a model above [`EVERY_MODE_DOFS`]: every mode when the
/// damping is mass-proportional, which the modes diagonalise for certain (the bar with 600
/// elements, 599 DOFs with mass), with the exact receptance's periodic solution; with
/// damping that is not (`beta_linear`; `beta_condensed`, which the modes would diagonalise
/// too but which the check on the matrices does not recognise), the exact receptance
/// without a modal analysis first (no every-mode phase: nothing is computed to be thrown
/// away).
#[test]
fn auto_takes_every_mode_of_a_mid_sized_model_with_mass_proportional_damping() {
    use mshbm::method::redistributed::{EVERY_MODE_DOFS, EVERY_MODE_MASS_PROPORTIONAL_DOFS};
    for (damping, every_mode) in [
        ("damping.first_mode_ratio=0.01", true),
        ("damping.beta_linear=2e-8", false),
        ("damping.beta_condensed=2e-9", false),
    ] {
        let model = example_model("clamped_bar.toml", &["bar.elements=600", damping]);
        let system = model.system(MassKind::Redistributed).unwrap();
        let massive = system.n_dofs() - mshbm::modes::massless_dofs(&system.mass).len();
        assert!(massive > EVERY_MODE_DOFS && massive <= EVERY_MODE_MASS_PROPORTIONAL_DOFS);
        let seen = setup_phases(&model, 3);
        let every_phase = seen
            .iter()
            .any(|p| p.starts_with("the modal receptance with every mode"));
        let exact_phase = seen.iter().any(|p| p.starts_with("the exact receptance"));
        assert_eq!(
            (every_phase, exact_phase),
            (every_mode, !every_mode),
            "{damping}: {seen:?}"
        );
        if every_mode {
            let e = auto_against_exact(&model, 60e3);
            println!("every mode vs exact {e:.1e}");
            assert!(e < 1e-9, "{e:e}");
        }
    }
}

/// `response_rows` (the contact nodes and a response DOF of a diagram point) equals those
/// rows of the whole response: for the exact receptance (kept columns), for every mode
/// (`A_k⁻¹ = E + Φ Y_k Φᵀ`, no solve with `K`) with diagonal and with full modal damping,
/// and for a truncated basis (the whole response).
#[test]
fn response_rows_are_rows_of_the_whole_response() {
    for overrides in [
        vec!["bar.elements=40", "damping.alpha=3000"],
        vec!["bar.elements=40", "damping.beta_linear=2e-8"],
    ] {
        let model = example_model("clamped_bar.toml", &overrides);
        let system = model.system(MassKind::Redistributed).unwrap();
        let massive = system.n_dofs() - mshbm::modes::massless_dofs(&system.mass).len();
        let receptances: Vec<(&str, Box<dyn Receptance>)> = vec![
            ("exact", Box::new(ExactReceptance::new(&system).unwrap())),
            (
                "every mode",
                Box::new(ModalReceptance::every_mode(&system).unwrap()),
            ),
            (
                "every mode (Krylov)",
                Box::new(ModalReceptance::new(&system, massive).unwrap()),
            ),
            (
                "8 modes",
                Box::new(ModalReceptance::new(&system, 8).unwrap()),
            ),
        ];
        let nc = system.contacts.len();
        let mut rows = system.nonlinear_dofs.clone();
        rows.extend([0, system.n_dofs() / 2, system.n_dofs() - 1]);
        for (name, receptance) in receptances {
            let at = receptance.at(hz(47e3), HARMONICS).unwrap();
            for k in 0..=HARMONICS {
                let force = forces(nc);
                let whole = at.response(k, &force).unwrap();
                let mut out = vec![c64::new(f64::NAN, 0.0); rows.len()];
                at.response_rows(k, &force, &rows, &mut out).unwrap();
                let expected: Vec<c64> = rows.iter().map(|&r| whole[r]).collect();
                let e = rel_diff(&out, &expected);
                assert!(e < 1e-10, "{overrides:?} {name}, k = {k}: {e:e}");
            }
        }
    }
}

/// The README's H = 10 branch (the paper's bar, 1 % mass-proportional damping, 1 → 100 kHz)
/// traced with the receptance `Auto` picks (every mode, (T148)) is the exact receptance's:
/// the same points (same count, frequencies and extremes to 1e-8 relative, the same Newton
/// iterations) and the same 98 folds.
#[test]
fn every_mode_traces_the_readme_branch_of_the_exact_receptance() {
    use mshbm::frd::{trace_frd_branch, FrdObserver, FrdSettings};
    use mshbm::method::settings::MethodSettings;
    use mshbm::stability::StabilityOptions;
    struct Quiet;
    impl FrdObserver for Quiet {}
    let model = example_model("clamped_bar.toml", &["damping.first_mode_ratio=0.01"]);
    let trace = |receptance| {
        let method = MethodSettings::Redistributed {
            options: RedistributedOptions {
                receptance,
                ..RedistributedOptions::new(10)
            },
            stability: StabilityOptions::default(),
        };
        trace_frd_branch(
            &model,
            &method,
            &FrdSettings::new(1e3, 100e3),
            false,
            &mut Quiet,
        )
        .unwrap()
    };
    let (every, exact) = (
        trace(ReceptanceChoice::Auto),
        trace(ReceptanceChoice::Exact),
    );
    assert!(every.report.completed && exact.report.completed);
    assert_eq!(every.folds.len(), 98);
    assert_eq!(every.folds.len(), exact.folds.len());
    let (a, b) = (&every.report.points, &exact.report.points);
    assert_eq!(a.len(), b.len());
    let close = |x: f64, y: f64, scale: f64| (x - y).abs() <= 1e-8 * scale;
    for (p, q) in a.iter().zip(b) {
        assert!(
            close(p.frequency_hz, q.frequency_hz, q.frequency_hz),
            "{p:?} vs {q:?}"
        );
        assert!(
            close(p.max_qn, q.max_qn, 0.2) && close(p.min_qn, q.min_qn, 0.2),
            "{p:?} vs {q:?}"
        );
        assert_eq!((p.newton_iterations, p.fold), (q.newton_iterations, q.fold));
    }
}

/// The phases the redistributed MS-HBM's set-up reports for `model` at `harmonics`.
fn setup_phases(model: &mshbm::Model, harmonics: usize) -> Vec<String> {
    use mshbm::method::SetupObserver;
    use std::sync::{Arc, Mutex};
    let seen: Arc<Mutex<Vec<String>>> = Arc::default();
    let record = Arc::clone(&seen);
    let observer = SetupObserver::new(move |phase| {
        if let Some(p) = phase {
            record.lock().unwrap().push(p.to_string());
        }
    });
    RedistributedMsHbm::within_observed(
        model,
        &RedistributedOptions::new(harmonics),
        &mshbm::limits::Limits::default(),
        Some(&observer),
    )
    .unwrap();
    let seen = seen.lock().unwrap().clone();
    seen
}
