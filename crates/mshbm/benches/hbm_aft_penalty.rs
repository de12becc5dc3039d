//! The cost of a stiff penalty (issue 6; the paper's Fig. 11 remark): one frequency response
//! diagram of the gap-0 bar (1 % modal damping of the first mode, H = 5, 55–75 kHz) by the
//! HBM-AFT (consistent mass) per penalty stiffness kp, against the redistributed MS-HBM
//! (exact quadrature), which has no penalty.
//!
//! `cargo bench -p mshbm --bench hbm_aft_penalty` times one FRD per method and kp (group
//! `penalty`) and then prints, per run, the continuation points, Newton (corrector)
//! iterations, folds and how the branch ended, the time relative to the MS-HBM, and the
//! Newton iterations of one solve at 60 kHz (homotopy in kp + final Newton, and plain Newton
//! from the linear response). The classical sampled AFT is timed for kp = 1e5 and 1e6 only:
//! from kp = 1e7 on its branch stops at a fold on a kink after many tiny steps; its counts
//! are printed from one untimed run (`PENALTY_SAMPLED_ALL=1`, slow).

mod common;

use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::sync::Mutex;
use std::time::Duration;

use common::{hz, median, show, timed};
use criterion::Criterion;
use mshbm::continuation::arclength::StopReason;
use mshbm::frd::{trace_frd_branch, FrdObserver, FrdSettings};
use mshbm::harmonic::Quadrature;
use mshbm::method::hbm_aft::{HbmAft, HbmAftOptions, Penalty};
use mshbm::method::settings::MethodSettings;
use mshbm::newton::{solve, solve_at_frequency, NewtonOptions};
use mshbm::{MassKind, Model};

const FROM_HZ: f64 = 55e3;
const TO_HZ: f64 = 75e3;
const HARMONICS: usize = 5;
const PENALTIES: [f64; 5] = [1e5, 1e6, 1e7, 1e8, 1e9];
/// Penalties for which the sampled AFT's FRD is timed (it stalls above).
const SAMPLED_TIMED: [f64; 2] = [1e5, 1e6];

fn model() -> Model {
    common::example("clamped_bar_gap0.toml", &["damping.first_mode_ratio=0.01"])
}

fn hbm_aft_options(kp: f64, quadrature: Quadrature) -> HbmAftOptions {
    HbmAftOptions {
        harmonics: HARMONICS,
        samples: None,
        mass: MassKind::Consistent,
        penalty: Penalty::Stiffness(kp),
        tangential_penalty: None,
        quadrature,
    }
}

fn hbm_aft(model: &Model, kp: f64, quadrature: Quadrature) -> HbmAft {
    HbmAft::new(model, &hbm_aft_options(kp, quadrature)).expect("HBM-AFT")
}

/// Observes nothing: the counts come from the returned branch.
struct NoObserver;
impl FrdObserver for NoObserver {}

/// What one FRD cost.
#[derive(Clone, Debug)]
struct FrdCount {
    points: usize,
    iterations: usize,
    folds: usize,
    stop: String,
}

/// Counts of the FRDs run, by benchmark id (the last run; all runs of one id are identical).
static COUNTS: Mutex<BTreeMap<String, FrdCount>> = Mutex::new(BTreeMap::new());

/// The FRD of `method` as `mshbm frf` traces it (the library's [`trace_frd_branch`] with
/// the CLI's defaults).
fn frd(model: &Model, method: &MethodSettings) -> FrdCount {
    let traced = trace_frd_branch(
        model,
        method,
        &FrdSettings::new(FROM_HZ, TO_HZ),
        false,
        &mut NoObserver,
    )
    .expect("continuation");
    let folds = traced.folds.len();
    let branch = traced.branch;
    let stop = match &branch.stop {
        StopReason::ReachedEnd => "reached 75 kHz".to_string(),
        StopReason::StepTooSmall { omega, .. } => {
            format!("stopped at {:.1} Hz (step too small)", omega / (2.0 * PI))
        }
        other => format!("{other:?}"),
    };
    FrdCount {
        points: branch.points.len(),
        iterations: branch.points.iter().map(|p| p.iterations).sum(),
        folds,
        stop,
    }
}

fn counted_frd(id: &str, model: &Model, method: &MethodSettings) {
    let count = frd(model, method);
    COUNTS.lock().expect("counts").insert(id.to_string(), count);
}

/// Newton iterations at 60 kHz: (homotopy, final Newton, plain Newton from the linear
/// response or `None` when it does not converge in 50).
fn solve_at_60_khz(p: &mut HbmAft) -> (usize, usize, Option<usize>) {
    let omega = hz(60e3);
    let (_, out) =
        solve_at_frequency(p, omega, 100, &NewtonOptions::default()).expect("solve at 60 kHz");
    let homotopy = p.guess_iterations();
    let x0 = p.linear_response(omega).expect("linear response");
    let raw = solve(p, &x0, omega, &NewtonOptions::default()).expect("solve");
    (
        homotopy,
        out.iterations,
        raw.converged.then_some(raw.iterations),
    )
}

fn id(quadrature: Quadrature, kp: f64) -> String {
    format!("penalty/hbm_aft_{}/{kp:.0e}", quadrature.name())
}

fn bench_penalty(c: &mut Criterion) {
    let m = model();
    let mut group = c.benchmark_group("penalty");
    group.sample_size(10);
    group.warm_up_time(Duration::from_millis(100));
    group.measurement_time(Duration::from_secs(5));
    group.bench_function("ms_hbm", |b| {
        timed(b, "penalty/ms_hbm", || {
            counted_frd(
                "penalty/ms_hbm",
                &m,
                &MethodSettings::redistributed(HARMONICS),
            )
        })
    });
    for kp in PENALTIES {
        let name = id(Quadrature::Exact, kp);
        group.bench_function(name.trim_start_matches("penalty/"), |b| {
            timed(b, &name, || {
                counted_frd(
                    &name,
                    &m,
                    &MethodSettings::HbmAft(hbm_aft_options(kp, Quadrature::Exact)),
                )
            })
        });
    }
    for kp in SAMPLED_TIMED {
        let name = id(Quadrature::Sampled, kp);
        group.bench_function(name.trim_start_matches("penalty/"), |b| {
            timed(b, &name, || {
                counted_frd(
                    &name,
                    &m,
                    &MethodSettings::HbmAft(hbm_aft_options(kp, Quadrature::Sampled)),
                )
            })
        });
    }
    group.finish();
    report(&m);
}

fn report(m: &Model) {
    let Some(reference) = median("penalty/ms_hbm") else {
        return;
    };
    if std::env::var_os("PENALTY_SAMPLED_ALL").is_some() {
        for kp in PENALTIES.iter().filter(|kp| !SAMPLED_TIMED.contains(kp)) {
            counted_frd(
                &id(Quadrature::Sampled, *kp),
                m,
                &MethodSettings::HbmAft(hbm_aft_options(*kp, Quadrature::Sampled)),
            );
        }
    }
    let counts = COUNTS.lock().expect("counts").clone();
    println!(
        "FRD of the gap-0 bar, H = {HARMONICS}, {:.0}–{:.0} kHz, 1 % modal damping (HBM-AFT: consistent mass):",
        FROM_HZ / 1e3,
        TO_HZ / 1e3
    );
    let ms = &counts["penalty/ms_hbm"];
    println!(
        "  MS-HBM (redistributed, exact)         : {:>5} points, {:>5} Newton iterations, {:>2} folds, {}; {}",
        ms.points,
        ms.iterations,
        ms.folds,
        ms.stop,
        show(reference)
    );
    for quadrature in [Quadrature::Exact, Quadrature::Sampled] {
        for kp in PENALTIES {
            let name = id(quadrature, kp);
            let Some(count) = counts.get(&name) else {
                continue;
            };
            let time = median(&name).map_or("untimed".to_string(), |t| {
                format!("{} = {:.1}x the MS-HBM", show(t), t / reference)
            });
            let (homotopy, last, raw) = solve_at_60_khz(&mut hbm_aft(m, kp, quadrature));
            println!(
                "  HBM-AFT {:<7} kp = {kp:.0e} N/mm: {:>5} points, {:>5} Newton iterations, {:>2} folds, {}; {time}; \
                 at 60 kHz: {homotopy} + {last} iterations (homotopy + final), from the linear response: {}",
                quadrature.name(),
                count.points,
                count.iterations,
                count.folds,
                count.stop,
                raw.map_or("no convergence in 50".to_string(), |n| n.to_string())
            );
        }
    }
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    bench_penalty(&mut c);
    c.final_summary();
}
