//! Where `solve` starts Newton ([`mshbm::solve::SolveStart`], docs/theory.md (T118)–(T119)),
//! on a 2D plane-stress cantilever assembled independently with numpy
//! (tests/data/cantilever_q4/generate.py) whose ten bottom-face nodes near the tip strike a
//! rigid stop: a stiff contact interface on which Newton from the linear response fails
//! across the resonance.

use std::path::Path;

use mshbm::frd::{trace_frd_branch, FrdObserver, FrdPoint, FrdSettings, PointEvent};
use mshbm::method::settings::MethodSettings;
use mshbm::model::file::load_model;
use mshbm::solve::{solve_periodic, SolvePath, SolveSettings, SolveStart};
use mshbm::Model;

fn cantilever() -> Model {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/cantilever_q4/model.toml");
    load_model(&path, &[]).unwrap()
}

fn settings(start: SolveStart) -> SolveSettings {
    SolveSettings {
        stability: false,
        start,
        ..SolveSettings::default()
    }
}

/// The contact forces of a solution are non-negative, no contact penetrates, and force and
/// gap are complementary at every sample.
fn assert_signorini(s: &mshbm::solution::PeriodicSolution, gap: f64) {
    for c in &s.contacts {
        for (g, f) in c.gap.iter().zip(&c.force) {
            assert!(*g >= -1e-9 * gap, "penetration {g}");
            assert!(*f >= 0.0, "negative force {f}");
            assert!(
                (g * f).abs() <= 1e-9 * gap * f.abs().max(1.0),
                "g λ = {}",
                g * f
            );
        }
    }
}

/// Records the points of an FRD branch.
#[derive(Default)]
struct Points(Vec<FrdPoint>);

impl FrdObserver for Points {
    fn point(&mut self, event: &PointEvent<'_>) -> mshbm::Result<()> {
        let PointEvent { point: p, .. } = *event;
        self.0.push(p.clone());
        Ok(())
    }
}

/// Across the contact resonance (first eigenfrequency 844 Hz with the redistributed mass),
/// Newton from the linear response does not converge at any of five frequencies; the
/// default start converges at every one by continuing the branch from half the frequency,
/// and lands on the branch that an FRD traced from a contact-free frequency passes
/// (a second path: the FRD point nearest in frequency agrees to its interpolation error).
#[test]
fn the_default_start_converges_where_newton_from_the_linear_response_fails() {
    let model = cantilever();
    let method = MethodSettings::redistributed(5);
    let mut frd = FrdSettings::new(400.0, 960.0);
    frd.stability = false;
    let mut branch = Points::default();
    trace_frd_branch(&model, &method, &frd, false, &mut branch).unwrap();
    for f in [700.0, 800.0, 850.0, 900.0, 950.0] {
        let linear = solve_periodic(&model, &method, f, &settings(SolveStart::Linear)).unwrap();
        assert!(
            !linear.outcome.converged,
            "{f} Hz: Newton from the linear response converged"
        );
        let auto = solve_periodic(&model, &method, f, &settings(SolveStart::Auto)).unwrap();
        assert!(auto.outcome.converged, "{f} Hz: {:?}", auto.outcome.reason);
        assert!(auto.solution.residual_norm <= 1e-10);
        assert!(
            matches!(auto.path, SolvePath::Continuation { from_hz, .. } if (from_hz - f / 2.0).abs() < 1e-9 * f),
            "{f} Hz: {:?}",
            auto.path
        );
        assert_signorini(&auto.solution, 0.05);
        // the touching contact's force is positive somewhere: the solution is in contact
        assert!(auto
            .solution
            .contacts
            .iter()
            .any(|c| c.force.iter().any(|&l| l > 0.0)));
        let nearest = branch
            .0
            .iter()
            .min_by(|a, b| {
                (a.frequency_hz - f)
                    .abs()
                    .total_cmp(&(b.frequency_hz - f).abs())
            })
            .unwrap();
        let rel = (nearest.frequency_hz - f).abs() / f;
        assert!(
            rel < 0.02,
            "{f} Hz: nearest FRD point {} Hz",
            nearest.frequency_hz
        );
        let d = (auto.solution.response.max - nearest.max_qn).abs();
        assert!(
            d < 0.05 * nearest.max_qn.abs() + 20.0 * rel * nearest.max_qn.abs(),
            "{f} Hz: max {} against the FRD's {} at {} Hz",
            auto.solution.response.max,
            nearest.max_qn,
            nearest.frequency_hz
        );
    }
}

/// Above the first fold of the contact resonance the branch crosses 1040 Hz three times:
/// a sweep from 500 Hz reports three distinct converged solutions there, all satisfying
/// Signorini's conditions, and says that the branch turned.
#[test]
fn a_sweep_reports_every_solution_it_crosses() {
    let model = cantilever();
    let method = MethodSettings::redistributed(5);
    let s = solve_periodic(
        &model,
        &method,
        1040.0,
        &settings(SolveStart::Sweep {
            from_hz: 500.0,
            to_hz: 1100.0,
        }),
    )
    .unwrap();
    assert!(s.outcome.converged);
    let SolvePath::Continuation { folds, .. } = s.path else {
        panic!("a sweep is a continuation: {:?}", s.path)
    };
    assert!(folds >= 2, "{folds} folds");
    assert_eq!(s.others.len(), 2, "{} other solutions", s.others.len());
    let mut maxima: Vec<f64> = std::iter::once(&s.solution)
        .chain(&s.others)
        .map(|o| {
            assert!(o.converged);
            assert!((o.frequency_hz - 1040.0).abs() < 1e-9);
            assert_signorini(o, 0.05);
            o.response.max
        })
        .collect();
    maxima.sort_by(f64::total_cmp);
    for w in maxima.windows(2) {
        assert!(w[1] - w[0] > 1e-3, "solutions not distinct: {maxima:?}");
    }
}

/// A solution's unknowns start a new solve: at the same frequency Newton has nothing to do;
/// at a neighbouring frequency it converges from there directly, where the linear response
/// does not.
#[test]
fn a_solve_starts_from_an_earlier_solution() {
    let model = cantilever();
    let method = MethodSettings::redistributed(5);
    let first = solve_periodic(&model, &method, 900.0, &settings(SolveStart::Auto)).unwrap();
    let x = first
        .solution
        .unknowns
        .clone()
        .expect("solve keeps the unknowns");
    let again = solve_periodic(
        &model,
        &method,
        900.0,
        &settings(SolveStart::Unknowns(x.clone())),
    )
    .unwrap();
    assert!(again.outcome.converged && again.outcome.iterations <= 1);
    assert_eq!(again.path, SolvePath::Direct);
    let near = solve_periodic(&model, &method, 905.0, &settings(SolveStart::Unknowns(x))).unwrap();
    assert!(near.outcome.converged, "{:?}", near.outcome.reason);
    assert!(
        near.outcome.iterations <= 10,
        "{} iterations",
        near.outcome.iterations
    );
    // unknowns of another number of harmonics are refused with the counts
    let wrong = solve_periodic(
        &model,
        &MethodSettings::redistributed(3),
        900.0,
        &settings(SolveStart::Unknowns(first.solution.unknowns.unwrap())),
    );
    let e = wrong
        .err()
        .expect("a dimension mismatch is an error")
        .to_string();
    assert!(
        e.contains("unknowns") && e.contains("the method has"),
        "{e}"
    );
}

/// A sweep's range must contain the frequency after its start.
#[test]
fn a_sweep_outside_its_range_is_refused() {
    let model = cantilever();
    let method = MethodSettings::redistributed(3);
    for (from_hz, to_hz) in [(1000.0, 1100.0), (500.0, 600.0), (900.0, 900.0)] {
        let e = solve_periodic(
            &model,
            &method,
            900.0,
            &settings(SolveStart::Sweep { from_hz, to_hz }),
        )
        .err()
        .expect("refused");
        assert!(e.to_string().contains("swept range"), "{e}");
    }
}

/// A frequency response diagram that starts where Newton from the linear response fails
/// takes its first point from the same continuation as a solve, and completes.
#[test]
fn a_diagram_starts_where_newton_from_the_linear_response_fails() {
    let model = cantilever();
    let method = MethodSettings::redistributed(5);
    let linear = solve_periodic(&model, &method, 850.0, &settings(SolveStart::Linear)).unwrap();
    assert!(!linear.outcome.converged);
    let mut frd = FrdSettings::new(850.0, 950.0);
    frd.stability = false;
    let mut branch = Points::default();
    let traced = trace_frd_branch(&model, &method, &frd, false, &mut branch).unwrap();
    assert!(traced.report.completed, "{}", traced.report.stop);
    let auto = solve_periodic(&model, &method, 850.0, &settings(SolveStart::Auto)).unwrap();
    let first = &branch.0[0];
    assert!((first.frequency_hz - 850.0).abs() < 1e-9);
    assert!(
        (first.max_qn - auto.solution.response.max).abs() < 1e-9,
        "{} vs {}",
        first.max_qn,
        auto.solution.response.max
    );
}

/// The default start's continuation reports its progress: the branch observer sees every
/// accepted point, numbered 1, 2, …, from the start at half the target to the target, with
/// the target as the frequency it runs to (the CLI prints from it during long solves).
#[test]
fn the_fallback_continuation_reports_every_point() {
    use std::sync::{Arc, Mutex};
    let model = cantilever();
    let f = 900.0;
    let seen: Arc<Mutex<Vec<(f64, usize, f64)>>> = Arc::default();
    let record = seen.clone();
    let s = solve_periodic(
        &model,
        &MethodSettings::redistributed(5),
        f,
        &SolveSettings {
            branch_observer: Some(mshbm::solve::BranchObserver::new(move |hz, n, to| {
                record.lock().unwrap().push((hz, n, to));
                Ok(())
            })),
            ..settings(SolveStart::Auto)
        },
    )
    .unwrap();
    assert!(s.outcome.converged);
    let SolvePath::Continuation { points, .. } = s.path else {
        panic!("{:?}", s.path)
    };
    let seen = seen.lock().unwrap();
    assert_eq!(seen.len(), points);
    assert!(seen
        .iter()
        .enumerate()
        .all(|(k, p)| p.1 == k + 1 && p.2 == f));
    assert!((seen[0].0 - f / 2.0).abs() < 1e-9 * f, "{:?}", seen[0]);
    assert!(
        (seen[points - 1].0 - f).abs() < 1e-9 * f,
        "{:?}",
        seen[points - 1]
    );
}

/// An error from the branch observer stops the fallback continuation at once and is what
/// the solve returns (how the CLI stops a long solve on SIGINT/SIGTERM).
#[test]
fn an_observer_error_stops_the_fallback_continuation() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;
    let calls = Arc::new(AtomicUsize::new(0));
    let counted = calls.clone();
    let result = solve_periodic(
        &cantilever(),
        &MethodSettings::redistributed(5),
        900.0,
        &SolveSettings {
            branch_observer: Some(mshbm::solve::BranchObserver::new(move |_, n, _| {
                counted.fetch_add(1, Ordering::SeqCst);
                if n >= 3 {
                    return Err(mshbm::Error::argument("run", "interrupted by a test"));
                }
                Ok(())
            })),
            ..settings(SolveStart::Auto)
        },
    );
    let Err(e) = result else {
        panic!("the solve went on")
    };
    assert!(e.to_string().contains("interrupted by a test"), "{e}");
    assert_eq!(calls.load(Ordering::SeqCst), 3);
}
