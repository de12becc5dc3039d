//! A whole frequency response diagram per method (issue 9): the Fig. 9 run on a
//! representative sub-range.
//!
//! **Range.** The README's Fig. 9 run (examples/clamped_bar.toml, gap 0.2 mm,
//! `damping.first_mode_ratio=0.01`) over 1–100 kHz takes about a minute per H; criterion
//! needs ≥ 10 samples, so the benchmark traces **20–40 kHz** (contact onset, grazing folds and
//! the first contact resonance; it contains 8 of the branch's folds at H = 5) with H = 5.
//! `FRD_FROM_HZ` / `FRD_TO_HZ` change the range (e.g. `FRD_FROM_HZ=1000 FRD_TO_HZ=100000`
//! for the whole Fig. 9 range; slow).
//!
//! **Methods** (traced by the library's `trace_frd_branch` with the defaults of
//! `mshbm frf`, each point's solution extracted as the CLI does):
//! * `ms_hbm`: the redistributed MS-HBM, exact quadrature;
//! * `hbm_aft`: HBM-AFT, consistent mass, kp = 100 k_c (the default), exact penalty
//!   quadrature (the classical sampled AFT stops at a fold on a kink at this kp, see
//!   `hbm_aft_penalty`);
//! * `general_ms_hbm`: the general MS-HBM (consistent mass, impacts e_N = 0, 256 Moreau–Jean
//!   steps, corrector tolerance 1e-4, at most [`GENERAL_MAX_POINTS`] points): timed as it
//!   is, with how its branch ended;
//! * time integration: with mass-proportional damping the bar's simulation does not become
//!   periodic (`integrate/steady_state.rs`), so the simulated FRD uses the Rayleigh variant
//!   (`damping.alpha` + `damping.beta_linear`, 1 % at ω₁ and 10 ω₁): a stepped sweep at
//!   1 kHz intervals (each frequency continues from the last state, steady state to 1e-6,
//!   250 Newmark steps per period on the redistributed mass: 1e-4 accurate at 90 kHz, see
//!   `frd_point`), against `ms_hbm_rayleigh`, the MS-HBM's FRD of that same problem.
//!
//! `cargo bench -p mshbm --bench frd` prints per method the points, Newton iterations,
//! folds, how the branch ended, the time per point and the ratio to the MS-HBM.

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
use mshbm::integrate::steady_state::{simulate_to_steady_state, Periodicity, SteadyStateOptions};
use mshbm::integrate::{Integrator, Scheme, Settings};
use mshbm::method::general::GeneralOptions;
use mshbm::method::hbm_aft::HbmAftOptions;
use mshbm::method::settings::MethodSettings;
use mshbm::{MassKind, Model};

const HARMONICS: usize = 5;
const GENERAL_STEPS: usize = 256;
const GENERAL_TOLERANCE: f64 = 1e-4;
const GENERAL_MAX_POINTS: usize = 400;
const SWEEP_STEP_HZ: f64 = 1e3;
const SWEEP_STEPS_PER_PERIOD: usize = 250;

fn range_hz() -> (f64, f64) {
    let read = |name: &str, default: f64| {
        std::env::var(name)
            .ok()
            .map(|v| {
                v.parse::<f64>()
                    .unwrap_or_else(|_| panic!("{name}={v}: not a number"))
            })
            .unwrap_or(default)
    };
    (read("FRD_FROM_HZ", 20e3), read("FRD_TO_HZ", 40e3))
}

fn fig9_model() -> Model {
    common::example("clamped_bar.toml", &["damping.first_mode_ratio=0.01"])
}

fn rayleigh_model() -> Model {
    let o = common::rayleigh_overrides("clamped_bar.toml", &[]);
    let o: Vec<&str> = o.iter().map(|s| s.as_str()).collect();
    common::example("clamped_bar.toml", &o)
}

/// Observes nothing: the benchmark counts from the returned branch.
struct NoObserver;
impl FrdObserver for NoObserver {}

/// What one FRD cost and how it ended.
#[derive(Clone, Debug)]
struct FrdCount {
    points: usize,
    iterations: usize,
    folds: usize,
    ended: String,
}

static COUNTS: Mutex<BTreeMap<String, FrdCount>> = Mutex::new(BTreeMap::new());

fn keep(id: &str, count: FrdCount) {
    COUNTS.lock().expect("counts").insert(id.to_string(), count);
}

/// The FRD of `method` over [`range_hz`] as `mshbm frf` traces it ([`trace_frd_branch`]
/// with the CLI's defaults), with the corrector `tolerance` and at most `max_points`.
fn continuation(
    id: &str,
    model: &Model,
    method: &MethodSettings,
    tolerance: f64,
    max_points: usize,
) {
    let (from, to) = range_hz();
    let mut settings = FrdSettings::new(from, to);
    settings.newton.tolerance = tolerance;
    settings.max_points = max_points;
    let traced =
        trace_frd_branch(model, method, &settings, false, &mut NoObserver).expect("continuation");
    let branch = traced.branch;
    let ended = match &branch.stop {
        StopReason::ReachedEnd => "reached the end".to_string(),
        StopReason::StepTooSmall { omega, .. } => {
            format!("stopped at {:.1} Hz (step too small)", omega / (2.0 * PI))
        }
        StopReason::Retraced { omega } => {
            format!("stopped at {:.1} Hz (retraced)", omega / (2.0 * PI))
        }
        StopReason::StartFailed(reason) => format!("did not start: {reason}"),
        other => format!("{other:?}"),
    };
    keep(
        id,
        FrdCount {
            points: branch.points.len(),
            iterations: branch.points.iter().map(|p| p.iterations).sum(),
            folds: branch.folds.len(),
            ended,
        },
    );
}

/// Stepped sweep by simulation (Rayleigh variant): steady state at each frequency, starting
/// from the last state of the previous one.
fn simulated_sweep(id: &str, model: &Model) {
    let (from, to) = range_hz();
    let system = model.system(MassKind::Redistributed).expect("system");
    let n = SWEEP_STEPS_PER_PERIOD;
    let count = ((to - from) / SWEEP_STEP_HZ).round() as usize + 1;
    let mut state: Option<(Vec<f64>, Vec<f64>)> = None;
    let (mut periods, mut not_periodic) = (0, 0);
    for i in 0..count {
        let f = from + i as f64 * SWEEP_STEP_HZ;
        let mut it = Integrator::new(
            &system,
            &Settings {
                dt: 1.0 / (f * n as f64),
                scheme: Scheme::PositionNewmark,
                omega: Some(hz(f)),
                energy_offset: 0.0,
            },
        )
        .expect("integrator");
        if let Some((q, v)) = &state {
            it.set_state(0.0, q, v).expect("state");
        }
        let st = simulate_to_steady_state(
            &mut it,
            hz(f),
            &SteadyStateOptions {
                steps_per_period: n,
                max_periods: 400,
                tolerance: 1e-6,
                harmonics: HARMONICS,
                response_dof: 100,
                periodicity: Periodicity::State,
            },
            |_| {},
            |_, _| {},
        )
        .expect("simulation");
        periods += st.periods_simulated;
        not_periodic += usize::from(!st.periodic);
        state = Some((it.q().to_vec(), it.v().to_vec()));
    }
    keep(
        id,
        FrdCount {
            points: count,
            iterations: periods,
            folds: 0,
            ended: format!("{not_periodic} of {count} frequencies not periodic in 400 periods"),
        },
    );
}

fn bench_frd(c: &mut Criterion) {
    let fig9 = fig9_model();
    let rayleigh = rayleigh_model();
    let mut group = c.benchmark_group("frd");
    group.sample_size(10);
    group.warm_up_time(Duration::from_millis(100));
    group.measurement_time(Duration::from_secs(5));
    group.bench_function("ms_hbm", |b| {
        timed(b, "frd/ms_hbm", || {
            continuation(
                "frd/ms_hbm",
                &fig9,
                &MethodSettings::redistributed(HARMONICS),
                1e-10,
                20_000,
            )
        })
    });
    group.bench_function("hbm_aft", |b| {
        timed(b, "frd/hbm_aft", || {
            let method = MethodSettings::HbmAft(HbmAftOptions {
                quadrature: Quadrature::Exact,
                ..HbmAftOptions::new(HARMONICS)
            });
            continuation("frd/hbm_aft", &fig9, &method, 1e-10, 20_000)
        })
    });
    group.bench_function("general_ms_hbm", |b| {
        timed(b, "frd/general_ms_hbm", || {
            let method = MethodSettings::General(GeneralOptions {
                steps: Some(GENERAL_STEPS),
                ..GeneralOptions::new(HARMONICS)
            });
            continuation(
                "frd/general_ms_hbm",
                &fig9,
                &method,
                GENERAL_TOLERANCE,
                GENERAL_MAX_POINTS,
            )
        })
    });
    group.bench_function("ms_hbm_rayleigh", |b| {
        timed(b, "frd/ms_hbm_rayleigh", || {
            continuation(
                "frd/ms_hbm_rayleigh",
                &rayleigh,
                &MethodSettings::redistributed(HARMONICS),
                1e-10,
                20_000,
            )
        })
    });
    group.bench_function("time_integration_rayleigh", |b| {
        timed(b, "frd/time_integration_rayleigh", || {
            simulated_sweep("frd/time_integration_rayleigh", &rayleigh)
        })
    });
    group.finish();
    report();
}

fn report() {
    let counts = COUNTS.lock().expect("counts").clone();
    if counts.is_empty() {
        return;
    }
    let (from, to) = range_hz();
    println!(
        "Whole FRD of the bar, {:.0}–{:.0} kHz, H = {HARMONICS} (time per point = time / points):",
        from / 1e3,
        to / 1e3
    );
    for (name, reference, unit) in [
        ("ms_hbm", "ms_hbm", "Newton iterations"),
        ("hbm_aft", "ms_hbm", "Newton iterations"),
        ("general_ms_hbm", "ms_hbm", "Newton iterations"),
        ("ms_hbm_rayleigh", "ms_hbm_rayleigh", "Newton iterations"),
        (
            "time_integration_rayleigh",
            "ms_hbm_rayleigh",
            "periods simulated",
        ),
    ] {
        let id = format!("frd/{name}");
        let (Some(count), Some(t)) = (counts.get(&id), median(&id)) else {
            continue;
        };
        let ratio = median(&format!("frd/{reference}"))
            .map_or(String::new(), |r| format!(", {:.2}x {reference}", t / r));
        let per_point = if count.points > 0 {
            format!("{} per point", show(t / count.points as f64))
        } else {
            "no point".to_string()
        };
        println!(
            "  {name:<26} {:>5} points, {:>6} {unit}, {:>2} folds, {}: {} ({per_point}{ratio})",
            count.points,
            count.iterations,
            count.folds,
            count.ended,
            show(t),
        );
    }
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    bench_frd(&mut c);
    c.final_summary();
}
