//! Floquet stability of HBM-AFT solutions (docs/theory.md (T142)) on NLvib's example 03 with
//! its penalty spring (`k_p = 100`, `H = 21`), against time integration of the penalty
//! system written here independently of the library (classical Runge–Kutta).

mod common;

use std::f64::consts::PI;

use mshbm::frd::{trace_frd_branch, FrdObserver, FrdSettings, TracedBranch};
use mshbm::harmonic::evaluate_with_slope;
use mshbm::method::hbm_aft::{HbmAftOptions, Penalty};
use mshbm::method::settings::MethodSettings;
use mshbm::problem::PeriodicProblem;
use mshbm::stability::Crossing;

/// Tells nothing.
struct Quiet;
impl FrdObserver for Quiet {}

const PENALTY: f64 = 100.0;
/// Harmonics that resolve the contact phase (about 1/30 of the period, half a period of
/// the penalty spring) well enough for the multipliers; see
/// [`at_21_harmonics_the_contact_phase_is_too_coarse_for_the_multipliers`].
const HARMONICS: usize = 61;
/// Runge–Kutta steps per period (the penalty spring's period is ~0.6 time units, the
/// excitation's ~9).
const STEPS: usize = 4000;

fn method_with(harmonics: usize) -> MethodSettings {
    MethodSettings::HbmAft(HbmAftOptions {
        penalty: Penalty::Stiffness(PENALTY),
        ..HbmAftOptions::new(harmonics)
    })
}

fn model() -> mshbm::Model {
    common::example_model("nlvib_03/model.toml", &[] as &[&str])
}

/// `ż` of example 03 with its penalty spring, `z = (q0, q1, q̇0, q̇1)`: `M = I`,
/// `K = [[1, −1], [−1, 2]]`, `D = 0.03 K`, `0.1 cos Ωt` on mass 1, the spring `k_p` pushing
/// mass 0 back once `q0 > 1`.
fn rate(omega: f64, t: f64, z: [f64; 4]) -> [f64; 4] {
    let [q0, q1, v0, v1] = z;
    let contact = PENALTY * (q0 - 1.0).max(0.0);
    [
        v0,
        v1,
        -(q0 - q1) - 0.03 * (v0 - v1) - contact,
        0.1 * (omega * t).cos() - (2.0 * q1 - q0) - 0.03 * (2.0 * v1 - v0),
    ]
}

/// The state after `periods` periods from `z` at `t = 0` (classical Runge–Kutta).
fn integrate(omega: f64, mut z: [f64; 4], periods: usize) -> [f64; 4] {
    let h = 2.0 * PI / omega / STEPS as f64;
    let add = |z: [f64; 4], k: [f64; 4], s: f64| std::array::from_fn(|i| z[i] + s * k[i]);
    for step in 0..periods * STEPS {
        let t = (step % STEPS) as f64 * h;
        let k1 = rate(omega, t, z);
        let k2 = rate(omega, t + 0.5 * h, add(z, k1, 0.5 * h));
        let k3 = rate(omega, t + 0.5 * h, add(z, k2, 0.5 * h));
        let k4 = rate(omega, t + h, add(z, k3, h));
        z = std::array::from_fn(|i| z[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
    }
    z
}

/// The harmonic-balance orbit's state at `t = 0`.
fn orbit_state(problem: &mut dyn PeriodicProblem, x: &[f64], omega: f64) -> [f64; 4] {
    let mut z = [0.0; 4];
    for dof in 0..2 {
        let c = problem
            .solution(x, omega, dof)
            .unwrap()
            .response
            .coefficients;
        let (q, slope) = evaluate_with_slope(&c, 0.0);
        z[dof] = q;
        z[dof + 2] = omega * slope;
    }
    z
}

fn distance(a: [f64; 4], b: [f64; 4]) -> f64 {
    (0..4).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt()
}

/// Monodromy by central differences of [`integrate`] around `z0`.
fn integrated_monodromy(omega: f64, z0: [f64; 4]) -> faer::Mat<f64> {
    let eps = 1e-6;
    faer::Mat::from_fn(4, 4, |i, j| {
        let (mut plus, mut minus) = (z0, z0);
        plus[j] += eps;
        minus[j] -= eps;
        (integrate(omega, plus, 1)[i] - integrate(omega, minus, 1)[i]) / (2.0 * eps)
    })
}

/// The branch of example 03 from Ω = 0.8 down to 0.5 with the multipliers of every point.
fn trace(harmonics: usize) -> TracedBranch {
    let mut settings = FrdSettings::new(0.8 / (2.0 * PI), 0.5 / (2.0 * PI));
    settings.stability = true;
    let traced = trace_frd_branch(
        &model(),
        &method_with(harmonics),
        &settings,
        false,
        &mut Quiet,
    )
    .unwrap();
    assert!(traced.report.completed, "{}", traced.report.stop);
    traced
}

/// The branch with [`HARMONICS`], traced once for the tests that share it, and a fresh
/// method for the orbits.
fn traced() -> (&'static TracedBranch, Box<dyn PeriodicProblem>) {
    static SHARED: std::sync::OnceLock<TracedBranch> = std::sync::OnceLock::new();
    (
        SHARED.get_or_init(|| trace(HARMONICS)),
        fresh_method(HARMONICS),
    )
}

fn fresh_method(harmonics: usize) -> Box<dyn PeriodicProblem> {
    method_with(harmonics).build(&model()).unwrap().problem
}

/// Which piece of the branch a point is on: below the contact (`Lower`), between the
/// grazing fold and the first fold in contact (`Middle`, the saddle branch), or after it
/// (`Upper`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Piece {
    Lower,
    Middle,
    Upper,
}

fn piece(traced: &TracedBranch, index: usize, max_qn: f64) -> Piece {
    let folds = &traced.branch.folds;
    if max_qn < 1.0 {
        Piece::Lower
    } else if index <= folds[1].after {
        Piece::Middle
    } else {
        Piece::Upper
    }
}

/// The verdict of every point away from grazing (the largest displacement more than
/// 0.2 % past the stop, or below it) and from the unit circle (largest modulus below 0.97 or
/// above 1.1) agrees with time integration of the penalty system started on the orbit: a
/// stable orbit stays (after 300 periods within 0.5 % of the amplitude of where it started),
/// an unstable one leaves (by more than 5 %); on the lower, middle and upper branches.
#[test]
fn verdicts_agree_with_time_integration_started_on_the_orbit() {
    let (traced, mut problem) = traced();
    let points: Vec<_> = traced.report.points.iter().filter(|p| !p.fold).collect();
    let mut checked = Vec::new();
    for (i, (p, b)) in points.iter().zip(&traced.branch.points).enumerate() {
        let mu = p.max_multiplier.unwrap();
        let grazing = (p.max_qn - 1.0).abs() < 2e-3;
        if grazing || (0.97..=1.1).contains(&mu) {
            continue;
        }
        let z0 = orbit_state(problem.as_mut(), &b.x, b.omega);
        let amplitude = p.max_qn.abs().max(p.min_qn.abs());
        let moved = distance(integrate(b.omega, z0, 300), z0) / amplitude;
        let stable = p.stable.unwrap();
        assert!(
            if stable { moved < 5e-3 } else { moved > 5e-2 },
            "point {i} at Ω = {:.5} (max {:.4}): stable = {stable} (largest |μ| {mu:.4}), but the orbit moved by {moved:.3e} of its amplitude in 300 periods",
            b.omega,
            p.max_qn
        );
        checked.push((piece(traced, i, p.max_qn), stable));
    }
    for piece in [Piece::Lower, Piece::Middle, Piece::Upper] {
        for stable in [true, false] {
            let n = checked.iter().filter(|c| **c == (piece, stable)).count();
            if (piece, stable) != (Piece::Lower, false) && (piece, stable) != (Piece::Middle, true)
            {
                assert!(n >= 2, "{piece:?}, stable = {stable}: {n} points checked");
            }
        }
    }
}

/// The largest multiplier equals that of the monodromy of the integrated penalty system
/// (central differences of Runge–Kutta runs from the orbit's state) within 5 % on the
/// lower, middle and stable upper branches, and to 1e-6 where the orbit has no contact
/// (the variational equation is then the linear system's, exactly).
#[test]
fn largest_multiplier_equals_the_integrated_monodromys() {
    let (traced, mut problem) = traced();
    let points: Vec<_> = traced.report.points.iter().filter(|p| !p.fold).collect();
    let mut seen = Vec::new();
    for (i, (p, b)) in points
        .iter()
        .zip(&traced.branch.points)
        .enumerate()
        .step_by(3)
    {
        let piece = piece(traced, i, p.max_qn);
        let grazing = (p.max_qn - 1.0).abs() < 2e-3;
        // the upper branch's period-doubling window near its folds is left to the verdicts
        if grazing || (piece == Piece::Upper && !p.stable.unwrap()) {
            continue;
        }
        let ours = p.max_multiplier.unwrap();
        let z0 = orbit_state(problem.as_mut(), &b.x, b.omega);
        let integrated = integrated_monodromy(b.omega, z0)
            .eigenvalues()
            .unwrap()
            .iter()
            .map(|v| v.norm())
            .fold(0.0, f64::max);
        let tolerance = if piece == Piece::Lower { 1e-6 } else { 5e-2 };
        assert!(
            (ours - integrated).abs() <= tolerance * integrated,
            "point {i} ({piece:?}) at Ω = {:.5}: largest |μ| {ours:.6}, integrated {integrated:.6}",
            b.omega
        );
        seen.push(piece);
    }
    for piece in [Piece::Lower, Piece::Middle, Piece::Upper] {
        assert!(
            seen.iter().filter(|p| **p == piece).count() >= 3,
            "{piece:?}: {seen:?}"
        );
    }
}

/// Period doubling and Neimark–Sacker crossings are labelled, and the motion after each is
/// what the label says: inside the period-doubling window of the upper branch the orbit,
/// integrated from its state, settles on a motion of period 2T; inside the Neimark–Sacker
/// window it settles on neither period T nor 2T (quasi-periodic).
#[test]
fn period_doubling_and_neimark_sacker_are_labelled_where_the_motion_changes() {
    let (traced, mut problem) = traced();
    let at = |kind: Crossing| -> Vec<f64> {
        traced
            .bifurcations
            .iter()
            .filter(|b| b.kind == kind)
            .map(|b| 2.0 * PI * b.frequency_hz)
            .collect()
    };
    let (doubling, neimark_sacker) = (at(Crossing::PeriodDoubling), at(Crossing::NeimarkSacker));
    assert!(doubling.len() >= 2, "{:?}", traced.bifurcations);
    assert!(!neimark_sacker.is_empty(), "{:?}", traced.bifurcations);
    let points: Vec<_> = traced.report.points.iter().filter(|p| !p.fold).collect();
    // a point whose frequency lies in the window between the first two labels of `kind`
    // (or below the one label), unstable, on the upper branch and away from grazing
    let inside = |window: (f64, f64)| {
        points
            .iter()
            .zip(&traced.branch.points)
            .enumerate()
            .find(|(i, (p, b))| {
                piece(traced, *i, p.max_qn) == Piece::Upper
                    && b.omega > window.0
                    && b.omega < window.1
                    && !p.stable.unwrap()
                    && p.max_qn > 1.002
            })
            .map(|(_, (p, b))| (*p, b))
    };
    let settled = |omega: f64, z0: [f64; 4]| {
        let z = integrate(omega, z0, 600);
        let one = integrate(omega, z, 1);
        let two = integrate(omega, one, 1);
        (distance(one, z), distance(two, z))
    };
    let window = (doubling[1].min(doubling[0]), doubling[1].max(doubling[0]));
    let (p, b) = inside(window).expect("a point in the period-doubling window");
    let z0 = orbit_state(problem.as_mut(), &b.x, b.omega);
    let (after_t, after_2t) = settled(b.omega, z0);
    let amplitude = p.max_qn.abs().max(p.min_qn.abs());
    assert!(
        after_2t < 1e-4 * amplitude && after_t > 1e-2 * amplitude,
        "Ω = {:.5} (labels {doubling:?}): moved {after_t:.3e} in T and {after_2t:.3e} in 2T",
        b.omega
    );
    let window = if neimark_sacker.len() >= 2 {
        (
            neimark_sacker[1].min(neimark_sacker[0]),
            neimark_sacker[1].max(neimark_sacker[0]),
        )
    } else {
        (0.0, neimark_sacker[0])
    };
    let (p, b) = inside(window).expect("a point in the Neimark-Sacker window");
    let z0 = orbit_state(problem.as_mut(), &b.x, b.omega);
    let (after_t, after_2t) = settled(b.omega, z0);
    let amplitude = p.max_qn.abs().max(p.min_qn.abs());
    assert!(
        after_t > 1e-3 * amplitude && after_2t > 1e-3 * amplitude,
        "Ω = {:.5} (labels {neimark_sacker:?}): moved {after_t:.3e} in T and {after_2t:.3e} in 2T",
        b.omega
    );
}

/// The acceptance item's `H = 21` does not resolve the contact phase (about 1/30 of the
/// period, half a period of the penalty spring) well enough for the multipliers: their
/// sensitivity to the switching times is large, and the 21-harmonic orbit's are off by
/// ~0.007 rad. On the middle (saddle) branch it reports stable orbits whose integrated
/// monodromy has a multiplier beyond 1.5 (and time integration leaves them), while at
/// [`HARMONICS`] the middle branch agrees ([`largest_multiplier_equals_the_integrated_monodromys`]).
#[test]
fn at_21_harmonics_the_contact_phase_is_too_coarse_for_the_multipliers() {
    let (traced, mut problem) = (trace(21), fresh_method(21));
    let points: Vec<_> = traced.report.points.iter().filter(|p| !p.fold).collect();
    let wrong = points
        .iter()
        .zip(&traced.branch.points)
        .enumerate()
        .filter(|(i, (p, _))| {
            piece(&traced, *i, p.max_qn) == Piece::Middle && p.max_qn > 1.002 && p.stable.unwrap()
        })
        .find(|(_, (_, b))| {
            let z0 = orbit_state(problem.as_mut(), &b.x, b.omega);
            integrated_monodromy(b.omega, z0)
                .eigenvalues()
                .unwrap()
                .iter()
                .any(|v| v.norm() > 1.5)
        });
    assert!(
        wrong.is_some(),
        "H = 21 resolved every middle-branch multiplier"
    );
}
