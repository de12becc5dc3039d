//! The library's frequency response diagram ([`mshbm::frd`]): what it reports against
//! independent references (direct linear solves, fresh solves, the penalty method's own
//! penetration, the stability of neighbouring points), what its observer is told, and the
//! settings it refuses.

mod common;

use std::f64::consts::PI;

use mshbm::frd::{
    trace_diagram, trace_frd_branch, BifurcationReport, BranchInfo, BranchReport, FoldReport,
    FrdObserver, FrdPoint, FrdSettings, PointEvent,
};
use mshbm::method::hbm_aft::{HbmAft, HbmAftOptions, Penalty};
use mshbm::method::settings::MethodSettings;
use mshbm::solution::MethodKind;
use mshbm::solve::{solve_periodic, SolveSettings};
use mshbm::MassKind;

/// Records everything it is told.
#[derive(Default)]
struct Recording {
    started: Vec<String>,
    /// Points of the current branch.
    branch_points: usize,
    points: Vec<FrdPoint>,
    folds: Vec<FoldReport>,
    changes: Vec<BifurcationReport>,
    finished: Vec<String>,
}

impl FrdObserver for Recording {
    fn start(&mut self, branch: &BranchInfo) {
        self.started.push(branch.label.clone());
        self.branch_points = 0;
    }
    fn point(&mut self, event: &PointEvent<'_>) -> mshbm::Result<()> {
        let PointEvent { point, points, .. } = *event;
        self.branch_points += 1;
        assert_eq!(points, self.branch_points, "points are counted per branch");
        self.points.push(point.clone());
        Ok(())
    }
    fn fold(&mut self, _branch: &BranchInfo, fold: &FoldReport) {
        self.folds.push(fold.clone());
    }
    fn stability_change(&mut self, _branch: &BranchInfo, change: &BifurcationReport) {
        self.changes.push(change.clone());
    }
    fn finish(&mut self, branch: &BranchReport) {
        self.finished.push(branch.label.clone());
    }
}

/// Below the first contact (the linear amplitude of the bar's end stays under the gap up to
/// ~12 kHz) every point's extremes are ±|z| of the direct dense linear solve of the whole
/// bar with the redistributed mass, and the diagram completes.
#[test]
fn contact_free_points_equal_the_direct_linear_response() {
    let model = common::example_model("clamped_bar.toml", &["damping.first_mode_ratio=0.01"]);
    let settings = FrdSettings::new(2000.0, 10000.0);
    let mut seen = Recording::default();
    let report = trace_diagram(
        &model,
        &[MethodSettings::redistributed(3)],
        &[1, 3],
        &settings,
        &mut seen,
    )
    .unwrap();
    assert!(report.completed());
    assert_eq!(report.branches.len(), 2);
    assert_eq!(seen.started, vec!["H = 1", "H = 3"]);
    assert_eq!(seen.finished, seen.started);
    let total: usize = report.branches.iter().map(|b| b.points.len()).sum();
    assert_eq!(seen.points.len(), total, "every point is observed once");
    for b in &report.branches {
        assert_eq!(b.method, MethodKind::Redistributed);
        assert!(b.points.len() >= 50, "{} points", b.points.len());
        for p in &b.points {
            let (dofs, z) = common::direct_linear_response(
                &model,
                MassKind::Redistributed,
                2.0 * PI * p.frequency_hz,
            );
            let i = dofs.iter().position(|&d| d == 100).unwrap();
            let amplitude = z[i].norm();
            for value in [p.max_qn, -p.min_qn, p.amplitude_h1] {
                assert!(
                    (value - amplitude).abs() <= 1e-8 * amplitude,
                    "{} Hz: {value} vs {amplitude}",
                    p.frequency_hz
                );
            }
        }
    }
}

/// Through the bar's contact onset: every 20th point (and every fold) equals a fresh
/// solve at its frequency started from the contact-free response, where that solve finds
/// the same branch (it may find another where several coexist; at least half must agree);
/// folds are reported once as points flagged `fold` and once as folds.
#[test]
fn points_are_solutions_and_folds_are_reported_once() {
    let model = common::example_model("clamped_bar.toml", &["damping.first_mode_ratio=0.01"]);
    let settings = FrdSettings::new(11000.0, 14000.0);
    let mut seen = Recording::default();
    let traced = trace_frd_branch(
        &model,
        &MethodSettings::redistributed(3),
        &settings,
        false,
        &mut seen,
    )
    .unwrap();
    let report = &traced.report;
    assert!(report.completed, "{}", report.stop);
    assert_eq!(report.stop, "reached 14000 Hz");
    let fold_points = report.points.iter().filter(|p| p.fold).count();
    assert_eq!(fold_points, traced.folds.len());
    assert_eq!(seen.folds.len(), traced.folds.len());
    assert_eq!(traced.branch.folds.len(), traced.folds.len());
    assert_eq!(
        report.points.len(),
        traced.branch.points.len() + traced.branch.folds.len()
    );
    let (mut checked, mut agreed) = (0, 0);
    for p in report.points.iter().step_by(20) {
        let fresh = solve_periodic(
            &model,
            &MethodSettings::redistributed(3),
            p.frequency_hz,
            &SolveSettings {
                stability: false,
                ..SolveSettings::default()
            },
        )
        .unwrap();
        if !fresh.outcome.converged {
            continue;
        }
        checked += 1;
        let r = &fresh.solution.response;
        if (r.max - p.max_qn).abs() <= 1e-7 * p.max_qn.abs().max(1e-3)
            && (r.min - p.min_qn).abs() <= 1e-7 * p.min_qn.abs().max(1e-3)
        {
            agreed += 1;
        }
    }
    assert!(
        checked >= 3 && 2 * agreed >= checked,
        "{agreed} of {checked}"
    );
}

/// HBM-AFT reports the penetration of every point, equal to the penalty method's own
/// penetration over its samples; the MS-HBM reports none.
#[test]
fn penalty_points_report_their_penetration() {
    let model = common::example_model("clamped_bar_gap0.toml", &["damping.first_mode_ratio=0.01"]);
    let options = HbmAftOptions {
        penalty: Penalty::Stiffness(1e7),
        ..HbmAftOptions::new(3)
    };
    let settings = FrdSettings::new(40000.0, 42000.0);
    let traced = trace_frd_branch(
        &model,
        &MethodSettings::HbmAft(options.clone()),
        &settings,
        true,
        &mut Recording::default(),
    )
    .unwrap();
    assert!(
        traced.report.label.starts_with("HBM-AFT kp = 1.000e7"),
        "{}",
        traced.report.label
    );
    assert_eq!(traced.report.penalty, Some(1e7));
    let problem = HbmAft::new(&model, &options).unwrap();
    let points: Vec<&FrdPoint> = traced.report.points.iter().filter(|p| !p.fold).collect();
    assert_eq!(points.len(), traced.branch.points.len());
    for (p, bp) in points.iter().zip(&traced.branch.points) {
        let expected = problem.sample_penetration(&bp.x).unwrap()[0];
        assert_eq!(p.max_penetration, Some(expected));
    }
    assert!(points.iter().any(|p| p.max_penetration.unwrap() > 0.0));
    let ms = trace_frd_branch(
        &model,
        &MethodSettings::redistributed(3),
        &settings,
        false,
        &mut Recording::default(),
    )
    .unwrap();
    assert!(ms.report.points.iter().all(|p| p.max_penetration.is_none()));
}

/// With stability, every reported stability change lies between two neighbouring points
/// whose verdicts differ, and every such pair has a change (the bilinear oscillator, whose
/// branch folds twice: the middle part between the folds is unstable).
#[test]
fn stability_changes_sit_between_points_of_different_verdicts() {
    let model = common::bilinear_oscillator(1.0, 1.0, 3.0, 1.0, 0.1, 0.04);
    let mut settings = FrdSettings::new(0.5 / (2.0 * PI), 2.5 / (2.0 * PI));
    settings.max_step = 0.01;
    settings.stability = true;
    let mut seen = Recording::default();
    let traced = trace_frd_branch(
        &model,
        &MethodSettings::redistributed(5),
        &settings,
        false,
        &mut seen,
    )
    .unwrap();
    assert!(traced.report.completed);
    assert_eq!(traced.folds.len(), 2);
    let points: Vec<&FrdPoint> = traced.report.points.iter().filter(|p| !p.fold).collect();
    let flips: Vec<(f64, f64)> = points
        .windows(2)
        .filter(|w| w[0].stable.unwrap() != w[1].stable.unwrap())
        .map(|w| (w[0].frequency_hz, w[1].frequency_hz))
        .collect();
    assert_eq!(flips.len(), 2, "{flips:?}");
    assert_eq!(traced.bifurcations.len(), flips.len());
    assert_eq!(seen.changes.len(), flips.len());
    for (change, (a, b)) in traced.bifurcations.iter().zip(&flips) {
        let (lo, hi) = (a.min(*b), a.max(*b));
        assert!(
            (lo..=hi).contains(&change.frequency_hz),
            "{} not in [{lo}, {hi}]",
            change.frequency_hz
        );
    }
}

#[test]
fn bad_settings_are_refused_before_any_work() {
    let model = common::example_model("clamped_bar.toml", &["damping.first_mode_ratio=0.01"]);
    let method = MethodSettings::redistributed(3);
    let refused = |settings: FrdSettings, what: &str| {
        let e = trace_frd_branch(&model, &method, &settings, false, &mut Recording::default())
            .err()
            .unwrap_or_else(|| panic!("{what} accepted"));
        assert!(e.to_string().starts_with("invalid "), "{what}: {e}");
    };
    refused(FrdSettings::new(1000.0, 1000.0), "equal frequencies");
    refused(FrdSettings::new(-1000.0, 2000.0), "negative frequency");
    refused(FrdSettings::new(f64::NAN, 2000.0), "NaN frequency");
    let mut s = FrdSettings::new(1000.0, 2000.0);
    s.min_step = 0.1;
    s.initial_step = 0.01;
    refused(s, "min_step > initial_step");
    let mut s = FrdSettings::new(1000.0, 2000.0);
    s.max_turn_deg = 0.0;
    refused(s, "no turn allowed");
    let mut s = FrdSettings::new(1000.0, 2000.0);
    s.response_dof = Some(1000);
    refused(s, "a DOF the model does not have");
    let zero_h = method.with_harmonics(0);
    assert!(zero_h.validate().is_err());
    let bad_penalty = MethodSettings::HbmAft(HbmAftOptions {
        penalty: Penalty::Stiffness(-1.0),
        ..HbmAftOptions::new(3)
    });
    assert!(bad_penalty.build(&model).is_err());
}

/// The folds of the README's main branch before issue 18's speed work
/// (tests/data/bar_h10_folds.txt, with its provenance), in Hz.
fn reference_folds_hz() -> Vec<f64> {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bar_h10_folds.txt");
    std::fs::read_to_string(&path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| l.trim().parse().unwrap())
        .collect()
}

/// The README's main branch (the bar, H = 10, 1 → 100 kHz, 1 % damping), traced with every
/// shortcut of the fast path (kept evaluations, kept receptance columns, band factors,
/// cells passed without a scan, the diagram point's own quadrature): its 98 folds are those
/// traced before those shortcuts existed, to 1e-4 Hz; every point is a solution of a fresh
/// method (Newton started on it meets the tolerance without an update); and every 25th
/// point's extremes equal the fresh method's whole solution's.
#[test]
fn readme_branch_keeps_its_folds_and_every_point_is_a_fresh_solution() {
    let model = common::example_model("clamped_bar.toml", &["damping.first_mode_ratio=0.01"]);
    let method = MethodSettings::redistributed(10);
    let traced = trace_frd_branch(
        &model,
        &method,
        &FrdSettings::new(1000.0, 100000.0),
        false,
        &mut Recording::default(),
    )
    .unwrap();
    assert!(traced.report.completed, "{}", traced.report.stop);
    let folds: Vec<f64> = traced.folds.iter().map(|f| f.frequency_hz).collect();
    let reference = reference_folds_hz();
    assert_eq!(folds.len(), reference.len(), "{folds:?}");
    for (f, r) in folds.iter().zip(&reference) {
        assert!((f - r).abs() <= 1e-4, "fold at {f} Hz, before at {r} Hz");
    }
    let dof = model.contacts[0].dofs[0];
    let points: Vec<&FrdPoint> = traced.report.points.iter().filter(|p| !p.fold).collect();
    assert_eq!(points.len(), traced.branch.points.len());
    let newton = mshbm::newton::NewtonOptions::default();
    for (i, (p, b)) in points.iter().zip(&traced.branch.points).enumerate() {
        let mut fresh = method.build(&model).unwrap().problem;
        let solved = mshbm::newton::solve(fresh.as_mut(), &b.x, b.omega, &newton).unwrap();
        assert!(
            solved.converged && solved.iterations == 0,
            "point {i} at {} Hz: a fresh residual of {:.3e}",
            p.frequency_hz,
            solved.residual_norm
        );
        if i % 25 == 0 {
            let whole = fresh.solution(&b.x, b.omega, dof).unwrap().response;
            let scale = p.max_qn.abs().max(p.min_qn.abs());
            assert!(
                (whole.max - p.max_qn).abs() <= 1e-9 * scale
                    && (whole.min - p.min_qn).abs() <= 1e-9 * scale,
                "point {i} at {} Hz: extremes {} {} against the whole solution's {} {}",
                p.frequency_hz,
                p.max_qn,
                p.min_qn,
                whole.max,
                whole.min
            );
        }
    }
}
