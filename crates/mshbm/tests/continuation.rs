//! Pseudo-arclength continuation and fold location against independent references.

mod common;

use std::f64::consts::PI;

use faer::linalg::solvers::Solve;
use faer::Mat;
use mshbm::continuation::arclength::{
    trace_branch, Branch, ContinuationOptions, Event, StopReason,
};
use mshbm::harmonic::Quadrature;
use mshbm::method::redistributed::{RedistributedMsHbm, RedistributedOptions};
use mshbm::model::file::load_model;
use mshbm::newton::{solve, NewtonOptions};
use mshbm::problem::PeriodicProblem;
use mshbm::Model;

const M: f64 = 1.0;
const K: f64 = 1.0;
const KC: f64 = 3.0;
const GAP: f64 = 1.0;

fn oscillator() -> Model {
    // ζ = 2 %, F = 0.1: the linear resonant amplitude 2.5 exceeds the gap 1
    common::bilinear_oscillator(M, K, KC, GAP, 0.1, 0.04)
}

fn method(model: &Model, harmonics: usize) -> RedistributedMsHbm {
    RedistributedMsHbm::new(
        model,
        &RedistributedOptions {
            harmonics,
            samples: None,
            quadrature: Quadrature::Exact,
            receptance: Default::default(),
            jacobian: Default::default(),
        },
    )
    .unwrap()
}

fn trace(p: &mut RedistributedMsHbm, from: f64, to: f64) -> Branch {
    trace_branch(p, &ContinuationOptions::new(from, to), |_, _| Ok(())).unwrap()
}

/// Independent fold reference: parametrise the branch by the phase of the contact DOF
/// (fix b1 = c·a1, solve for x and ω by Newton) and find the extrema of ω(c) by golden
/// section. No arclength, no tangent.
fn phase_parametrised(
    p: &mut RedistributedMsHbm,
    x0: &[f64],
    w0: f64,
    c: f64,
) -> Option<(Vec<f64>, f64)> {
    let n = x0.len();
    let (mut x, mut w) = (x0.to_vec(), w0);
    for _ in 0..60 {
        let lin = p.linearize(&x, w).ok()?;
        let jacobian = lin.jacobian.to_dense();
        let g = x[2] - c * x[1];
        let norm = lin.residual.iter().fold(g.abs(), |m, v| m.max(v.abs()));
        if norm < 1e-13 {
            return Some((x, w));
        }
        let a = Mat::<f64>::from_fn(n + 1, n + 1, |i, j| match (i < n, j < n) {
            (true, true) => jacobian[(i, j)],
            (true, false) => lin.d_omega[i],
            (false, true) => [0.0, -c, 1.0].get(j).copied().unwrap_or(0.0),
            (false, false) => 0.0,
        });
        let rhs = Mat::<f64>::from_fn(n + 1, 1, |i, _| if i < n { -lin.residual[i] } else { -g });
        let d = a.partial_piv_lu().solve(&rhs);
        for j in 0..n {
            x[j] += d[(j, 0)];
        }
        w += d[(n, 0)];
    }
    None
}

#[test]
fn bilinear_oscillator_both_folds_are_passed_and_located() {
    let model = oscillator();
    let mut p = method(&model, 5);
    let branch = trace(&mut p, 0.5, 2.5);
    assert_eq!(branch.stop, StopReason::ReachedEnd);
    assert_eq!(
        branch.folds.len(),
        2,
        "{:?}",
        branch.folds.iter().map(|f| f.omega).collect::<Vec<_>>()
    );
    assert!(branch.folds.iter().all(|f| !f.at_kink));
    let (upper, lower) = (branch.folds[0].omega, branch.folds[1].omega);
    assert!(
        upper > lower,
        "hardening: the jump-down fold lies above the jump-up fold"
    );
    // the branch comes back on the other (lower) branch and reaches the end
    let last = branch.points.last().unwrap();
    assert_eq!(last.omega, 2.5);
    // three solutions between the folds: the branch crosses the mid frequency three times
    let mid = 0.5 * (upper + lower);
    let crossings = branch
        .points
        .windows(2)
        .filter(|w| (w[0].omega - mid) * (w[1].omega - mid) < 0.0)
        .count();
    assert_eq!(crossings, 3);

    // reference folds from the phase parametrisation: extremes of ω along the branch
    let mut refs = Vec::new();
    for fold in &branch.folds {
        let c0 = fold.x[2] / fold.x[1];
        let mut eval = |c: f64| -> f64 {
            // start from the branch point nearest in phase
            let start = branch
                .points
                .iter()
                .min_by(|a, b| {
                    ((a.x[2] / a.x[1]) - c)
                        .abs()
                        .total_cmp(&((b.x[2] / b.x[1]) - c).abs())
                })
                .unwrap();
            phase_parametrised(&mut p, &start.x, start.omega, c)
                .map(|(_, w)| w)
                .unwrap()
        };
        let sign = if fold.omega == upper { 1.0 } else { -1.0 };
        let (mut a, mut d) = (c0 - 0.2 * c0.abs().max(0.05), c0 + 0.2 * c0.abs().max(0.05));
        let g = 0.5 * (5f64.sqrt() - 1.0);
        let (mut b, mut c) = (d - g * (d - a), a + g * (d - a));
        let (mut fb, mut fc) = (sign * eval(b), sign * eval(c));
        for _ in 0..80 {
            if fb > fc {
                d = c;
                c = b;
                fc = fb;
                b = d - g * (d - a);
                fb = sign * eval(b);
            } else {
                a = b;
                b = c;
                fb = fc;
                c = a + g * (d - a);
                fc = sign * eval(c);
            }
        }
        refs.push(sign * fb.max(fc));
    }
    println!("folds (continuation): {upper:.8}, {lower:.8} rad/s; phase-parametrised reference: {refs:?}");
    assert!(
        (upper / refs[0] - 1.0).abs() < 1e-3 && (lower / refs[1] - 1.0).abs() < 1e-3,
        "{upper} {lower} vs {refs:?}"
    );
    // the upper fold lies on the analytic backbone of the undamped bilinear oscillator at
    // the peak amplitude (light damping)
    let peak = branch
        .points
        .iter()
        .map(|pt| p.solution(&pt.x, pt.omega, 0).unwrap().response.max)
        .fold(0.0f64, f64::max);
    let backbone = common::bilinear_backbone(M, K, KC, GAP, peak);
    println!("peak amplitude {peak:.6} at the backbone frequency {backbone:.6} rad/s");
    assert!(
        (upper / backbone - 1.0).abs() < 5e-3,
        "upper fold {upper} vs backbone {backbone}"
    );
}

#[test]
fn downward_sweep_finds_the_same_folds() {
    let model = oscillator();
    let mut p = method(&model, 5);
    let up = trace(&mut p, 0.5, 2.5);
    let down = trace(&mut p, 2.5, 0.5);
    assert_eq!(down.stop, StopReason::ReachedEnd);
    let mut a: Vec<f64> = up.folds.iter().map(|f| f.omega).collect();
    let mut b: Vec<f64> = down.folds.iter().map(|f| f.omega).collect();
    a.sort_by(f64::total_cmp);
    b.sort_by(f64::total_cmp);
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert!((x / y - 1.0).abs() < 1e-8, "{a:?} vs {b:?}");
    }
}

#[test]
fn every_point_is_a_solution_of_a_fresh_problem_and_newton_returns_to_it() {
    let model = oscillator();
    let mut p = method(&model, 5);
    let branch = trace(&mut p, 0.5, 2.5);
    let mut fresh = method(&model, 5);
    let scale = fresh.length_scale();
    for (k, pt) in branch.points.iter().enumerate() {
        let r = fresh.residual(&pt.x, pt.omega).unwrap();
        assert!(r.iter().all(|v| v.abs() <= 1e-9 * scale), "point {k}");
        if k % 5 == 0 {
            // a fresh Newton solve on the same branch (started next to it) lands on it
            let start: Vec<f64> =
                pt.x.iter()
                    .enumerate()
                    .map(|(i, v)| v * (1.0 + 1e-4 * ((i + k) as f64).sin()))
                    .collect();
            let o = solve(&mut fresh, &start, pt.omega, &NewtonOptions::default()).unwrap();
            assert!(o.converged);
            let d =
                o.x.iter()
                    .zip(&pt.x)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            // (near a fold the solution is ill-conditioned: the residual tolerance 1e-10
            // allows larger differences in x there)
            assert!(
                d <= 1e-6 * scale,
                "point {k} at {} rad/s: fresh solve differs by {d:e}",
                pt.omega
            );
        }
    }
}

#[test]
fn paper_bar_frd_completes_below_the_gap_for_h_1_3_5() {
    paper_bar_frd_completes_below_the_gap(&[1, 3, 5]);
}

/// H = 10 alone (the longest branch: near-grazing contacts make sharp folds and close
/// pieces of branch), so that it runs beside the others.
#[test]
fn paper_bar_frd_completes_below_the_gap_for_h_10() {
    paper_bar_frd_completes_below_the_gap(&[10]);
}

fn paper_bar_frd_completes_below_the_gap(harmonics_list: &[usize]) {
    let model = load_model(
        &common::examples().join("clamped_bar.toml"),
        &["damping.first_mode_ratio=0.01".into()],
    )
    .unwrap();
    let gap = model.contacts[0].gap;
    for &harmonics in harmonics_list {
        let mut p = method(&model, harmonics);
        let opts = ContinuationOptions::new(2.0 * PI * 1e3, 2.0 * PI * 1e5);
        let mut max_seen = f64::NEG_INFINITY;
        let mut folds = Vec::new();
        let branch = trace_branch(&mut p, &opts, |p, e| {
            match e {
                Event::Point(pt) => {
                    let s = p.solution(&pt.x, pt.omega, 100)?;
                    max_seen = max_seen.max(s.contacts[0].max);
                    assert!(s.contacts[0].gap.iter().all(|&g| g >= -1e-12 * gap));
                }
                Event::Fold(f) => folds.push((f.omega / (2.0 * PI), f.at_kink)),
            }
            Ok(())
        })
        .unwrap();
        println!(
            "H = {harmonics}: {} points, {} folds {:?}",
            branch.points.len(),
            folds.len(),
            folds
        );
        assert_eq!(branch.stop, StopReason::ReachedEnd, "H = {harmonics}");
        assert!(
            max_seen <= gap * (1.0 + 1e-12),
            "H = {harmonics}: max {max_seen}"
        );
        // exact quadrature: every fold is a smooth fold, none an artefact at a kink
        assert!(
            folds.iter().all(|&(_, kink)| !kink),
            "H = {harmonics}: {folds:?}"
        );
        if harmonics >= 3 {
            assert!(
                !folds.is_empty(),
                "superharmonic resonances fold the branch"
            );
        }
    }
}

/// A sweep started inside the README's range (H = 10, 20 → 40 kHz) follows the branch of
/// the whole sweep from 1 kHz: it reaches 40 kHz with the same folds there, to 1e-7
/// relative. At 30 501.85 Hz the branch folds back alongside itself (the two pieces 1e-6
/// of the amplitude apart); the inner sweep's longer steps there jumped across the fold onto
/// the returning piece, travelled it backwards, and stopped at 30 421.35 Hz having met a
/// fold twice — until the orientation check (docs/theory.md (T73)) refused such a step.
#[test]
fn a_sweep_started_inside_the_range_finds_the_folds_of_the_whole_sweep() {
    let model = load_model(
        &common::examples().join("clamped_bar.toml"),
        &["damping.first_mode_ratio=0.01".into()],
    )
    .unwrap();
    let hz = |f: f64| 2.0 * PI * f;
    let mut whole = method(&model, 10);
    let whole = trace(&mut whole, hz(1e3), hz(1e5));
    let mut inner = method(&model, 10);
    let inner = trace(&mut inner, hz(20e3), hz(40e3));
    assert_eq!(whole.stop, StopReason::ReachedEnd);
    assert_eq!(inner.stop, StopReason::ReachedEnd, "{:?}", inner.stop);
    let within: Vec<f64> = whole
        .folds
        .iter()
        .map(|f| f.omega)
        .filter(|&w| w > hz(20e3) && w < hz(40e3))
        .collect();
    let found: Vec<f64> = inner.folds.iter().map(|f| f.omega).collect();
    assert_eq!(found.len(), within.len(), "{found:?}\nagainst {within:?}");
    assert!(within.len() >= 30, "{}", within.len());
    for (a, b) in found.iter().zip(&within) {
        assert!(
            (a - b).abs() <= 1e-7 * b,
            "{} Hz against {} Hz",
            a / hz(1.0),
            b / hz(1.0)
        );
    }
}

/// The library refuses settings it cannot work with before any Newton solve, naming the
/// setting (the CLI has its own checks, but every caller gets these).
#[test]
fn bad_settings_are_refused_before_any_work() {
    let mut p = method(&oscillator(), 3);
    let refused = |p: &mut RedistributedMsHbm, change: &dyn Fn(&mut ContinuationOptions)| {
        let mut options = ContinuationOptions::new(0.5, 2.5);
        change(&mut options);
        let mut events = 0;
        let e = trace_branch(p, &options, |_, _| {
            events += 1;
            Ok(())
        })
        .expect_err("refused");
        assert_eq!(events, 0);
        assert!(matches!(e, mshbm::Error::InvalidArgument { .. }), "{e}");
        e.to_string()
    };
    assert!(refused(&mut p, &|o| o.omega_end = o.omega_start).contains("frequency range"));
    assert!(refused(&mut p, &|o| o.min_step = 0.0).contains("smallest step"));
    assert!(refused(&mut p, &|o| o.initial_step = 1.0).contains("smallest <= initial <= largest"));
    assert!(refused(&mut p, &|o| o.max_turn_deg = 180.0).contains("tangent turn"));
    assert!(refused(&mut p, &|o| o.newton.tolerance = -1.0).contains("Newton tolerance"));
}

/// `k` uncoupled copies of a problem: the unknowns and residuals of the copies one after
/// the other, with `k` times the signals (docs/theory.md (T72)).
struct Copies<'a> {
    inner: &'a mut RedistributedMsHbm,
    copies: usize,
}

impl Copies<'_> {
    fn each(&mut self, x: &[f64], mut f: impl FnMut(&mut RedistributedMsHbm, &[f64])) {
        let n = self.inner.dimension();
        for c in 0..self.copies {
            f(self.inner, &x[c * n..(c + 1) * n]);
        }
    }
}

impl PeriodicProblem for Copies<'_> {
    fn dimension(&self) -> usize {
        self.copies * self.inner.dimension()
    }
    fn length_scale(&self) -> f64 {
        self.inner.length_scale()
    }
    fn initial_guess(&mut self, omega: f64) -> mshbm::Result<Vec<f64>> {
        Ok(self.inner.initial_guess(omega)?.repeat(self.copies))
    }
    fn residual(&mut self, x: &[f64], omega: f64) -> mshbm::Result<Vec<f64>> {
        let mut out = Vec::new();
        let mut error = None;
        self.each(x, |p, xc| match p.residual(xc, omega) {
            Ok(r) => out.extend(r),
            Err(e) => error = Some(e),
        });
        error.map_or(Ok(out), Err)
    }
    fn linearize(&mut self, x: &[f64], omega: f64) -> mshbm::Result<mshbm::problem::Linearization> {
        let n = self.inner.dimension();
        let total = self.dimension();
        let (mut residual, mut d_omega) = (Vec::new(), Vec::new());
        let mut jacobian = Mat::<f64>::zeros(total, total);
        let mut c = 0;
        let mut error = None;
        self.each(x, |p, xc| match p.linearize(xc, omega) {
            Ok(lin) => {
                let j = lin.jacobian.to_dense();
                for r in 0..n {
                    for s in 0..n {
                        jacobian[(c * n + r, c * n + s)] = j[(r, s)];
                    }
                }
                residual.extend(lin.residual);
                d_omega.extend(lin.d_omega);
                c += 1;
            }
            Err(e) => error = Some(e),
        });
        if let Some(e) = error {
            return Err(e);
        }
        Ok(mshbm::problem::Linearization {
            residual,
            jacobian: mshbm::problem::Jacobian::Dense(jacobian),
            d_omega,
        })
    }
    fn solution(
        &mut self,
        x: &[f64],
        omega: f64,
        response_dof: usize,
    ) -> mshbm::Result<mshbm::solution::PeriodicSolution> {
        let n = self.inner.dimension();
        self.inner.solution(&x[..n], omega, response_dof)
    }
    fn continuation_policy(&self) -> mshbm::problem::ContinuationPolicy {
        let one = self.inner.continuation_policy();
        mshbm::problem::ContinuationPolicy {
            signals: self.copies * one.signals,
            ..one
        }
    }
}

/// The arclength is measured per signal (docs/theory.md (T72)): four uncoupled copies of the
/// bilinear oscillator are traced through the same points as one, across its grazing and
/// with the step limited by the arclength alone (no frequency limit). Measured over all
/// unknowns, the copies' steps would be twice as long in the response, and half as many.
#[test]
fn copies_of_a_contact_are_traced_through_the_same_points_as_one() {
    let model = oscillator();
    let mut options = ContinuationOptions::new(0.5, 0.97);
    options.max_frequency_step = 0.0;
    options.max_step = 0.02;
    let mut one = method(&model, 3);
    let single = trace_branch(&mut one, &options, |_, _| Ok(())).unwrap();
    assert_eq!(single.stop, StopReason::ReachedEnd);
    assert!(single.folds.is_empty());
    assert!(single.points.len() > 20, "{}", single.points.len());
    let mut inner = method(&model, 3);
    let mut copies = Copies {
        inner: &mut inner,
        copies: 4,
    };
    let four = trace_branch(&mut copies, &options, |_, _| Ok(())).unwrap();
    assert_eq!(four.stop, StopReason::ReachedEnd);
    assert_eq!(four.points.len(), single.points.len());
    for (a, b) in single.points.iter().zip(&four.points) {
        assert!(
            (a.omega - b.omega).abs() <= 1e-9 * a.omega,
            "{} against {}",
            a.omega,
            b.omega
        );
    }
}
