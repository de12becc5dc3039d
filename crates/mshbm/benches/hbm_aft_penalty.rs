//! The cost of a stiff penalty (the paper's Fig. 11 remark): one frequency response diagram
//! of the gap-0 bar (1 % modal damping, H = 5, 55–75 kHz, consistent mass) by the HBM-AFT
//! per penalty stiffness kp, against the redistributed MS-HBM.
//!
//! `cargo bench -p mshbm --bench hbm_aft_penalty` first prints, per kp, the continuation
//! points, Newton (corrector) iterations, folds and how the branch ended, and the Newton
//! iterations of one solve at 60 kHz; then divan times one FRD per kp.

use std::f64::consts::PI;
use std::path::Path;

use mshbm::continuation::arclength::{trace_branch, ContinuationOptions, Event};
use mshbm::continuation::newton::{solve, solve_at_frequency, NewtonOptions};
use mshbm::method::hbm_aft::{HbmAft, HbmAftOptions, Penalty, Quadrature};
use mshbm::method::redistributed::quadrature::Quadrature as MsQuadrature;
use mshbm::method::redistributed::{RedistributedMsHbm, RedistributedOptions};
use mshbm::model::file::load_model;
use mshbm::problem::PeriodicProblem;
use mshbm::{MassKind, Model};

const FROM_HZ: f64 = 55e3;
const TO_HZ: f64 = 75e3;
const HARMONICS: usize = 5;

fn model() -> Model {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/clamped_bar_gap0.toml");
    load_model(&path, &["damping.first_mode_ratio=0.01".to_string()]).expect("example model")
}

fn hbm_aft(model: &Model, kp: f64, quadrature: Quadrature) -> HbmAft {
    HbmAft::new(
        model,
        &HbmAftOptions {
            harmonics: HARMONICS,
            samples: None,
            mass: MassKind::Consistent,
            penalty: Penalty::Stiffness(kp),
            quadrature,
        },
    )
    .expect("HBM-AFT")
}

fn ms_hbm(model: &Model) -> RedistributedMsHbm {
    RedistributedMsHbm::new(
        model,
        &RedistributedOptions {
            harmonics: HARMONICS,
            samples: None,
            quadrature: MsQuadrature::Exact,
        },
    )
    .expect("MS-HBM")
}

/// (points, corrector iterations, folds, how it ended)
fn frd(problem: &mut dyn PeriodicProblem) -> (usize, usize, usize, String) {
    let options = ContinuationOptions::new(2.0 * PI * FROM_HZ, 2.0 * PI * TO_HZ);
    let mut folds = 0;
    let branch = trace_branch(problem, &options, |_, e| {
        if let Event::Fold(_) = e {
            folds += 1;
        }
        Ok(())
    })
    .expect("continuation");
    let iterations = branch.points.iter().map(|p| p.iterations).sum();
    let stop = match &branch.stop {
        mshbm::continuation::arclength::StopReason::StepTooSmall { omega, .. } => {
            format!("stopped at {:.1} Hz (step too small)", omega / (2.0 * PI))
        }
        other => format!("{other:?}"),
    };
    (branch.points.len(), iterations, folds, stop)
}

fn report() {
    let m = model();
    let omega = 2.0 * PI * 60e3;
    println!(
        "FRD of the gap-0 bar, H = {HARMONICS}, {:.0}–{:.0} kHz, consistent mass:",
        FROM_HZ / 1e3,
        TO_HZ / 1e3
    );
    let (points, iterations, folds, stop) = frd(&mut ms_hbm(&m));
    println!("  MS-HBM (redistributed, exact): {points} points, {iterations} Newton iterations, {folds} folds, {stop}");
    for quadrature in [Quadrature::Sampled, Quadrature::Exact] {
        for kp in [1e5, 1e6, 1e7, 1e8, 1e9] {
            let mut p = hbm_aft(&m, kp, quadrature);
            let (points, iterations, folds, stop) = frd(&mut p);
            // one solve at 60 kHz: homotopy + final Newton, and Newton from the linear response
            let (_, out) =
                solve_at_frequency(&mut p, omega, 100, &NewtonOptions::default()).expect("solve");
            let homotopy = p.guess_iterations();
            let x0 = p.linear_response(omega).expect("linear response");
            let raw = solve(&mut p, &x0, omega, &NewtonOptions::default()).expect("solve");
            println!(
                "  HBM-AFT {:<7} kp = {kp:.0e} N/mm: {points:>5} points, {iterations:>5} Newton iterations, {folds:>2} folds, {stop}; \
                 at 60 kHz: {homotopy} + {} iterations (homotopy + final), from the linear response: {}",
                quadrature.name(),
                out.iterations,
                if raw.converged {
                    format!("{}", raw.iterations)
                } else {
                    "no convergence in 50".to_string()
                }
            );
        }
    }
}

fn main() {
    report();
    divan::main();
}

#[divan::bench(sample_count = 3, sample_size = 1)]
fn ms_hbm_frd(bencher: divan::Bencher) {
    let m = model();
    bencher.bench_local(|| frd(&mut ms_hbm(&m)));
}

#[divan::bench(args = [1e6, 1e7, 1e8, 1e9], sample_count = 3, sample_size = 1)]
fn hbm_aft_exact_frd(bencher: divan::Bencher, kp: f64) {
    let m = model();
    bencher.bench_local(|| frd(&mut hbm_aft(&m, kp, Quadrature::Exact)));
}

/// The classical AFT; from kp = 1e7 on its branch stops at a fold at a kink (see the report).
#[divan::bench(args = [1e5, 1e6], sample_count = 3, sample_size = 1)]
fn hbm_aft_sampled_frd(bencher: divan::Bencher, kp: f64) {
    let m = model();
    bencher.bench_local(|| frd(&mut hbm_aft(&m, kp, Quadrature::Sampled)));
}
