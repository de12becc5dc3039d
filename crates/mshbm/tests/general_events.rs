//! The event-driven general MS-HBM (docs/theory.md (T143)–(T146)): its sensitivity
//! Jacobian against central finite differences of its residual, at solutions with impacts
//! and at the linear responses Newton starts from. (Its solutions against full-system
//! Moreau–Jean integration: `tests/general_mshbm.rs`.)

mod common;

use std::f64::consts::PI;

use mshbm::method::general::{GeneralMsHbm, GeneralOptions, PeriodIntegration};
use mshbm::model::file::load_model;
use mshbm::newton::{solve, NewtonOptions};
use mshbm::problem::PeriodicProblem;
use mshbm::Model;

/// Largest entry of `J − D` relative to the largest entry of `J`, `D` the central
/// differences of the residual with steps `ε ℓ`.
fn jacobian_error(problem: &mut GeneralMsHbm, x: &[f64], omega: f64, eps: f64) -> f64 {
    let lin = problem.linearize(x, omega).unwrap();
    let jac = lin.jacobian.to_dense();
    let dim = x.len();
    let h = eps * problem.length_scale();
    let (mut worst, mut largest) = (0.0f64, 0.0f64);
    for j in 0..dim {
        let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
        xp[j] += h;
        xm[j] -= h;
        let rp = problem.residual(&xp, omega).unwrap();
        let rm = problem.residual(&xm, omega).unwrap();
        for i in 0..dim {
            let d = (rp[i] - rm[i]) / (2.0 * h);
            worst = worst.max((d - jac[(i, j)]).abs());
            largest = largest.max(jac[(i, j)].abs());
        }
    }
    worst / largest
}

/// Newton from the initial guess (the pre-solved linear response) at `f` Hz with Newton's
/// restitution `e_N`; the Jacobian's error there and at the solution.
fn check(model: &Model, harmonics: usize, f: f64, restitution: f64) -> (f64, f64) {
    let mut options = GeneralOptions::new(harmonics);
    options.integration = PeriodIntegration::EventDriven;
    options.restitution = restitution;
    let mut problem = GeneralMsHbm::new(model, &options).unwrap();
    let omega = 2.0 * PI * f;
    let x0 = problem.initial_guess(omega).unwrap();
    let out = solve(&mut problem, &x0, omega, &NewtonOptions::default()).unwrap();
    assert!(out.converged, "{f} Hz: {:?}", out.history);
    // the solution has impacts: the contact DOF reaches the stop (between two samples for
    // example 03, whose impacts release at once)
    let tr = problem.trajectory(&out.x, omega).unwrap();
    let closest = tr
        .gap_series(0)
        .iter()
        .fold(f64::INFINITY, |m, &g| m.min(g));
    // (a bounce leaves the stop at once, within half a sample interval ≈ 3.6e-3 here)
    let near = if restitution > 0.0 { 1e-2 } else { 1e-4 };
    assert!(
        closest < near * problem.length_scale(),
        "{f} Hz: smallest gap {closest}"
    );
    let at_solution = jacobian_error(&mut problem, &out.x, omega, 1e-6);
    let at_guess = jacobian_error(&mut problem, &x0, omega, 1e-6);
    eprintln!(
        "{f} Hz, e_N = {restitution}: {} Newton iterations to {:.1e}; Jacobian error {at_solution:.2e} at the solution, {at_guess:.2e} at the start",
        out.iterations, out.residual_norm
    );
    (at_solution, at_guess)
}

/// Acceptance (issue 19): the sensitivity Jacobian equals central finite differences to
/// 1e-6 relative away from grazing — NLvib's example 03 with a rigid stop (impacts with
/// immediate release) and the paper's bar with impacts (impacts followed by a contact
/// phase: the closed set's flow and the release), and example 03 with the restitution
/// `e_N = 0.9` (the critical time's bounce, docs/theory.md (T147)); measured 1e-10 … 1e-8.
#[test]
fn sensitivity_jacobian_equals_central_differences() {
    let nlvib = load_model(&common::examples().join("nlvib_03/model.toml"), &[]).unwrap();
    let bar = load_model(&common::examples().join("clamped_bar_impact.toml"), &[]).unwrap();
    for (model, harmonics, f, restitution) in [
        (&nlvib, 21, 0.62 / (2.0 * PI), 0.0),
        (&nlvib, 21, 0.64 / (2.0 * PI), 0.0),
        (&nlvib, 21, 0.64 / (2.0 * PI), 0.9),
        (&bar, 5, 30e3, 0.0),
        (&bar, 5, 60e3, 0.0),
    ] {
        let (at_solution, at_guess) = check(model, harmonics, f, restitution);
        assert!(at_solution < 1e-6 && at_guess < 1e-6, "{f} Hz");
    }
}

/// Acceptance (issue 19): the bar with impacts at 30 kHz converges to 1e-10 (the
/// time-stepped residual stalls near 1e-4 there, docs/general-mshbm.md §3), and frictionless
/// models are event-driven by default.
#[test]
fn bar_with_impacts_converges_at_30_khz() {
    let bar = load_model(&common::examples().join("clamped_bar_impact.toml"), &[]).unwrap();
    let mut problem = GeneralMsHbm::new(&bar, &GeneralOptions::new(10)).unwrap();
    assert!(problem.is_event_driven());
    let omega = 2.0 * PI * 30e3;
    let x0 = problem.initial_guess(omega).unwrap();
    let out = solve(&mut problem, &x0, omega, &NewtonOptions::default()).unwrap();
    assert!(
        out.converged && out.residual_norm <= 1e-10,
        "{:?}",
        out.history
    );
}

/// NLvib's example 03 with a rigid stop (H = 21) swept from `from` to `to` rad/s; checks that
/// hold for either direction, returned with the branch for the direction's own checks:
/// the sweep reaches its end; it passes the fold of the upper branch, above Ω = 0.66 where
/// full-system time integration settles on an impacting motion
/// (tests/general_mshbm.rs, `nlvib_03_with_a_rigid_stop_agrees_with_time_integration`), and
/// the grazing corner where the impacting middle branch meets the branch without contact
/// (a fold at a kink: both leave it towards higher frequencies); **every** point passes a
/// fresh problem's residual check to 1e-9 and stays off the stop (no sample of its
/// trajectory penetrates by more than 1e-9: the critical time's window, docs/theory.md
/// (T147), hides no impact); points with impacts and points without are both present.
fn sweep_nlvib_03(from: f64, to: f64) -> mshbm::continuation::arclength::Branch {
    use mshbm::frd::{trace_frd_branch, FrdObserver, FrdSettings};
    use mshbm::method::settings::MethodSettings;
    let model = load_model(&common::examples().join("nlvib_03/model.toml"), &[]).unwrap();
    let options = GeneralOptions::new(21);
    let settings = FrdSettings::new(from / (2.0 * PI), to / (2.0 * PI));
    struct Silent;
    impl FrdObserver for Silent {}
    let method = MethodSettings::General(options.clone());
    let branch = trace_frd_branch(&model, &method, &settings, false, &mut Silent)
        .unwrap()
        .branch;
    eprintln!(
        "Ω {from} → {to}: {} points, folds {:?}, {} frequency steps, stop {:?}",
        branch.points.len(),
        branch
            .folds
            .iter()
            .map(|f| (f.omega, f.at_kink))
            .collect::<Vec<_>>(),
        branch.frequency_steps,
        branch.stop
    );
    assert!(branch.stop.is_success(), "{:?}", branch.stop);
    assert!(branch.folds.iter().any(|f| f.omega > 0.66 && !f.at_kink));
    // the grazing corner: where the branch without contact reaches the stop (its linear
    // response has amplitude 1 there; `grazing_frequency` below)
    let grazing = grazing_frequency(&model, (0.62, 0.8));
    assert!(
        branch
            .folds
            .iter()
            .any(|f| f.at_kink && (f.omega - grazing).abs() < 1e-6 * grazing),
        "no kink fold at the grazing frequency {grazing}"
    );
    let mut fresh = GeneralMsHbm::new(&model, &options).unwrap();
    let scale = fresh.length_scale();
    let (mut impacting, mut free) = (0, 0);
    for p in &branch.points {
        let r = fresh.residual(&p.x, p.omega).unwrap();
        let norm = r.iter().fold(0.0f64, |m, v| m.max(v.abs())) / scale;
        assert!(norm <= 1e-9, "Ω = {}: residual {norm:.1e}", p.omega);
        let tr = fresh.trajectory(&p.x, p.omega).unwrap();
        let gap = tr.gap_series(0).iter().fold(f64::MAX, |m, &v| m.min(v));
        assert!(gap >= -1e-9, "Ω = {}: penetrates by {:.1e}", p.omega, -gap);
        if gap < 1e-6 {
            impacting += 1;
        } else {
            free += 1;
        }
    }
    assert!(
        impacting >= 3 && free >= 3,
        "{impacting} with impacts, {free} without"
    );
    branch
}

/// The frequency (rad/s) within `range` at which the linear response of example 03 (no
/// stop) has amplitude 1 at the first mass: where a branch without contact grazes the
/// stop. From the model's matrices, by bisection on the 2 × 2 complex dynamic stiffness.
fn grazing_frequency(model: &Model, range: (f64, f64)) -> f64 {
    let system = model.system(mshbm::model::MassKind::Consistent).unwrap();
    let [k, m, d] = [&system.stiffness, &system.mass, &system.damping].map(|a| {
        let dense = a.to_dense();
        [
            [dense[(0, 0)], dense[(0, 1)]],
            [dense[(1, 0)], dense[(1, 1)]],
        ]
    });
    let amplitude = |w: f64| -> f64 {
        // (K − w² M + i w D) z = (0, 0.1)
        let a = |i: usize, j: usize| (k[i][j] - w * w * m[i][j], w * d[i][j]);
        let mul = |x: (f64, f64), y: (f64, f64)| (x.0 * y.0 - x.1 * y.1, x.0 * y.1 + x.1 * y.0);
        let det = {
            let (p, q) = (mul(a(0, 0), a(1, 1)), mul(a(0, 1), a(1, 0)));
            (p.0 - q.0, p.1 - q.1)
        };
        // z_0 = −a01 · 0.1 / det
        let num = a(0, 1);
        (num.0.hypot(num.1) * 0.1) / det.0.hypot(det.1)
    };
    let (mut lo, mut hi) = range;
    let above_at_lo = amplitude(lo) > 1.0;
    assert!(above_at_lo != (amplitude(hi) > 1.0));
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if (amplitude(mid) > 1.0) == above_at_lo {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Continuation through grazing from the side without impacts (issue 19's acceptance):
/// example 03 from Ω = 0.8 down to 0.5 follows the branch without contact to the grazing
/// corner, turns there onto the impacting middle branch, passes the upper branch's fold
/// and goes down the upper branch past its own grazing (Ω ≈ 0.582, where the impacts stop)
/// to 0.5.
#[test]
fn nlvib_03_downward_sweep_passes_grazing_from_the_side_without_impacts() {
    let branch = sweep_nlvib_03(0.8, 0.5);
    assert_eq!(branch.frequency_steps, 0);
    // below the upper branch's grazing the motion stays off the stop, as the linear
    // response does
    let model = load_model(&common::examples().join("nlvib_03/model.toml"), &[]).unwrap();
    let lower = grazing_frequency(&model, (0.5, 0.618));
    let mut fresh = GeneralMsHbm::new(&model, &GeneralOptions::new(21)).unwrap();
    let below: Vec<_> = branch
        .points
        .iter()
        .filter(|p| p.omega < lower * (1.0 - 1e-3))
        .collect();
    assert!(below.len() >= 3);
    for p in below {
        let tr = fresh.trajectory(&p.x, p.omega).unwrap();
        let gap = tr.gap_series(0).iter().fold(f64::MAX, |m, &v| m.min(v));
        assert!(gap > 1e-6, "Ω = {}: gap {gap:.1e}", p.omega);
    }
}

/// The same branch traced upward from the impacting upper branch at Ω = 0.62: the upper
/// branch's fold, the middle branch back to the grazing corner, past it the branch without
/// contact to Ω = 0.8.
#[test]
fn nlvib_03_upward_sweep_passes_grazing_from_the_impacting_side() {
    let branch = sweep_nlvib_03(0.62, 0.8);
    assert_eq!(branch.frequency_steps, 0);
}

/// Acceptance (issue 19): the bar with impacts (consistent mass, `e_N = 0`, H = 5) swept
/// from 1 to 100 kHz completes. Checked against references independent of the sweep:
/// - the primary grazing — where the linear response's amplitude at the contact DOF
///   reaches the gap (a dense solve) — is a fold at a kink, to 1e-6;
/// - the ends, where the stop is not reached, are the linear response's amplitude to 1e-8;
/// - every 25th point solves a fresh problem's residual to 1e-9 and penetrates the stop by
///   no more than 1e-9 of the gap at its samples, and the points between the grazings touch
///   it.
///
/// Past the primary grazing the contact node re-impacts after its critical impact; before
/// the unarmed contact's peak was located (docs/theory.md (T147a)) the re-impact vanished
/// where it crossed the end of the first scan step and the sweep stopped at 12 418.888 Hz
/// (docs/general-mshbm.md §9).
#[test]
fn bar_with_impacts_sweeps_from_1_to_100_khz() {
    use mshbm::continuation::arclength::StopReason;
    use mshbm::frd::{trace_frd_branch, FrdObserver, FrdSettings};
    use mshbm::method::settings::MethodSettings;
    let bar = load_model(&common::examples().join("clamped_bar_impact.toml"), &[]).unwrap();
    let grazing = bar_grazing_hz(&bar, (12e3, 13e3));
    let options = GeneralOptions::new(5);
    struct Silent;
    impl FrdObserver for Silent {}
    let branch = trace_frd_branch(
        &bar,
        &MethodSettings::General(options.clone()),
        &FrdSettings::new(1e3, 100e3),
        false,
        &mut Silent,
    )
    .unwrap()
    .branch;
    let hz = |w: f64| w / (2.0 * PI);
    assert!(
        matches!(branch.stop, StopReason::ReachedEnd),
        "{:?} after {} points",
        branch.stop,
        branch.points.len()
    );
    assert!(
        branch
            .folds
            .iter()
            .any(|f| f.at_kink && (hz(f.omega) - grazing).abs() < 1e-6 * grazing),
        "no kink fold at the grazing {grazing} Hz"
    );
    // the ends: the linear response (first harmonic of the contact DOF, harmonic-major
    // unknowns with one N-DOF)
    let mut fresh = GeneralMsHbm::new(&bar, &options).unwrap();
    assert_eq!(fresh.dimension(), 2 * 5 + 1 + 2 + 1);
    for p in [&branch.points[0], branch.points.last().unwrap()] {
        let amplitude = p.x[1].hypot(p.x[2]);
        let linear = bar_linear_amplitude(&bar, hz(p.omega));
        assert!(
            (amplitude - linear).abs() < 1e-8 * linear,
            "{} Hz: amplitude {amplitude}, linear {linear}",
            hz(p.omega)
        );
    }
    let scale = fresh.length_scale();
    let gap = bar.contacts[0].gap;
    let mut touching = 0;
    for p in branch.points.iter().step_by(25) {
        let r = fresh.residual(&p.x, p.omega).unwrap();
        let norm = r.iter().fold(0.0f64, |m, v| m.max(v.abs())) / scale;
        assert!(norm <= 1e-9, "{} Hz: residual {norm:.1e}", hz(p.omega));
        let tr = fresh.trajectory(&p.x, p.omega).unwrap();
        let smallest = tr.gap_series(0).iter().fold(f64::MAX, |m, &v| m.min(v));
        assert!(
            smallest >= -1e-9 * gap,
            "{} Hz: smallest gap {smallest:e}",
            hz(p.omega)
        );
        if hz(p.omega) > grazing && hz(p.omega) < 90e3 {
            // (samples straddle the contact phases; between them the node is near the stop)
            touching += usize::from(smallest < 1e-2 * gap);
        }
    }
    let between = branch
        .points
        .iter()
        .step_by(25)
        .filter(|p| hz(p.omega) > grazing && hz(p.omega) < 90e3)
        .count();
    assert!(
        touching * 10 >= between * 9,
        "{touching} of {between} points between the grazings touch the stop"
    );
}

/// The frequency (Hz) within `range` at which the bar's linear response (no stop) has the
/// amplitude of the gap at its contact DOF ([`bar_linear_amplitude`]), by bisection.
fn bar_grazing_hz(model: &Model, range: (f64, f64)) -> f64 {
    let amplitude = |f: f64| bar_linear_amplitude(model, f);
    let gap = model.contacts[0].gap;
    let (mut lo, mut hi) = range;
    assert!(amplitude(lo) < gap && amplitude(hi) > gap);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if amplitude(mid) < gap {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The amplitude at the contact DOF of the bar's linear response (no stop) at `f` Hz:
/// `(K − ω²M + iωC) u = F` solved densely as a real system of twice the size.
fn bar_linear_amplitude(model: &Model, f: f64) -> f64 {
    use faer::linalg::solvers::Solve;
    let system = model.system(mshbm::model::MassKind::Consistent).unwrap();
    let (k, m, c) = (
        system.stiffness.to_dense(),
        system.mass.to_dense(),
        system.damping.to_dense(),
    );
    let n = k.nrows();
    let w = 2.0 * PI * f;
    let a = faer::Mat::<f64>::from_fn(2 * n, 2 * n, |i, j| {
        let (r, s) = (i % n, j % n);
        let stiff = k[(r, s)] - w * w * m[(r, s)];
        match (i / n, j / n) {
            (0, 0) | (1, 1) => stiff,
            (0, 1) => -w * c[(r, s)],
            _ => w * c[(r, s)],
        }
    });
    let rhs =
        faer::Mat::<f64>::from_fn(
            2 * n,
            1,
            |i, _| {
                if i < n {
                    system.harmonic_load[i]
                } else {
                    0.0
                }
            },
        );
    let u = a.partial_piv_lu().solve(&rhs);
    let (re, im) = system.contacts[0]
        .w
        .iter()
        .fold((0.0, 0.0), |(re, im), &(dof, weight)| {
            (re + weight * u[(dof, 0)], im + weight * u[(n + dof, 0)])
        });
    re.hypot(im)
}

/// The event-driven initial guess is pre-solved without the critical time
/// ([`mshbm::method::general::PRESOLVE_ITERATIONS`]): on the undamped bar at 90 kHz
/// (H = 1), whose linear response penetrates the stop deeply, Newton with the critical time
/// from the linear response alone ended at 2.4e-3 after 50 iterations; from the pre-solved
/// guess it converges (7 iterations measured), as without the critical time.
#[test]
fn undamped_bar_converges_from_the_presolved_guess() {
    let model = load_model(&common::examples().join("clamped_bar.toml"), &[]).unwrap();
    for f in [60000.0, 90000.0] {
        let mut p = GeneralMsHbm::new(&model, &GeneralOptions::new(1)).unwrap();
        let omega = 2.0 * PI * f;
        let x0 = p.initial_guess(omega).unwrap();
        assert_eq!(x0.len(), p.dimension());
        let out = solve(&mut p, &x0, omega, &NewtonOptions::default()).unwrap();
        eprintln!(
            "{f} Hz: {} iterations to {:.1e}",
            out.iterations, out.residual_norm
        );
        assert!(
            out.converged && out.residual_norm <= 1e-10,
            "{f} Hz: {out:?}"
        );
        let mut fresh = GeneralMsHbm::new(&model, &GeneralOptions::new(1)).unwrap();
        let r = fresh.residual(&out.x, omega).unwrap();
        let norm = r.iter().fold(0.0f64, |m, v| m.max(v.abs())) / fresh.length_scale();
        assert!(norm <= 1e-10);
    }
}
