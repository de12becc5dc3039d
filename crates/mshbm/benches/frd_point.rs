//! One FRD point of the paper's bar at matched accuracy, by every method (issue 9):
//! redistributed MS-HBM, HBM-AFT (penalty), general MS-HBM, and time integration to a
//! periodic steady state.
//!
//! **Problem.** examples/clamped_bar.toml (gap 0.2 mm) with the Rayleigh damping of
//! `tests/time_integration.rs` (1 % at ω₁ and 10 ω₁: `damping.alpha` and
//! `damping.beta_linear`), at 90 kHz, where the simulation becomes periodic (with
//! mass-proportional damping alone it does not, see `integrate/steady_state.rs`).
//!
//! **Accuracy.** The quantity compared is the contact DOF's minimum displacement over the
//! period; each method must reach it to [`TOLERANCE`] (1 %) of the converged answer of *its
//! own mass model*:
//! * massless contact boundary (redistributed mass): the MS-HBM with H = 40 (which the
//!   Newmark simulation on the same mass matches to ~1e-4, printed);
//! * consistent mass with impacts (e_N = 0): Moreau–Jean (θ = 0.6) with 2000 steps per
//!   period run to steady state (a converged simulation; the two mass models differ by ~1 %
//!   here, printed).
//!
//! The resolution of each method is chosen in the setup, before timing: the smallest `H` (or
//! steps per period) of a ladder that meets the tolerance. The general MS-HBM is not
//! calibrated (one solve costs seconds and its Newton often stalls at a small residual with
//! impacts, see `method/general/`): it runs with H = 10, 256 steps, tolerance 1e-5, and its
//! error is printed as measured.
//!
//! **Timed**: one cold solve at the frequency, from each method's own start (the linear
//! response; the kp homotopy for the HBM-AFT; rest for the simulation), including the
//! per-frequency factorization; building the method (mass redistribution, partition) is
//! not timed.
//!
//! `cargo bench -p mshbm --bench frd_point` prints the table of settings, errors, times and
//! time ratios to the redistributed MS-HBM.

mod common;

use std::cell::OnceCell;
use std::time::{Duration, Instant};

use common::{hz, median, show, timed_with_setup};
use criterion::Criterion;
use mshbm::harmonic::Quadrature;
use mshbm::integrate::steady_state::{simulate_to_steady_state, Periodicity, SteadyStateOptions};
use mshbm::integrate::{Integrator, Scheme, Settings};
use mshbm::method::general::{GeneralMsHbm, GeneralOptions};
use mshbm::method::hbm_aft::{HbmAft, HbmAftOptions};
use mshbm::method::redistributed::{RedistributedMsHbm, RedistributedOptions};
use mshbm::newton::{solve_at_frequency, NewtonOptions};
use mshbm::{MassKind, Model};

const FREQUENCY_HZ: f64 = 90e3;
/// Relative accuracy of the contact DOF's minimum displacement.
const TOLERANCE: f64 = 1e-2;
/// The contact DOF of the bar (node 100).
const CONTACT_DOF: usize = 100;
const HARMONIC_LADDER: [usize; 9] = [1, 2, 3, 5, 7, 10, 15, 20, 30];
const STEPS_LADDER: [usize; 5] = [125, 250, 500, 1000, 2000];
const MOREAU_THETA: f64 = 0.6;
const GENERAL_HARMONICS: usize = 10;
const GENERAL_STEPS: usize = 256;
const GENERAL_TOLERANCE: f64 = 1e-5;

fn model() -> Model {
    let o = common::rayleigh_overrides("clamped_bar.toml", &[]);
    let o: Vec<&str> = o.iter().map(|s| s.as_str()).collect();
    common::example("clamped_bar.toml", &o)
}

fn ms_hbm(model: &Model, harmonics: usize) -> RedistributedMsHbm {
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
    .expect("MS-HBM")
}

/// The classical HBM-AFT with its defaults: consistent mass, sampled AFT, kp = 100 k_c.
fn hbm_aft(model: &Model, harmonics: usize) -> HbmAft {
    HbmAft::new(model, &HbmAftOptions::new(harmonics)).expect("HBM-AFT")
}

fn general(model: &Model) -> GeneralMsHbm {
    GeneralMsHbm::new(
        model,
        &GeneralOptions {
            steps: Some(GENERAL_STEPS),
            ..GeneralOptions::new(GENERAL_HARMONICS)
        },
    )
    .expect("general MS-HBM")
}

/// Contact DOF's minimum from a Newton solve at the frequency (`None`: no convergence).
fn solve_min(problem: &mut dyn mshbm::problem::PeriodicProblem, tolerance: f64) -> Option<f64> {
    let options = NewtonOptions {
        tolerance,
        ..NewtonOptions::default()
    };
    let (solution, outcome) =
        solve_at_frequency(problem, hz(FREQUENCY_HZ), CONTACT_DOF, &options).expect("solve");
    outcome.converged.then(|| solution.contacts[0].min)
}

/// The integrator for a simulation from rest on `kind` mass with `steps` per period.
fn integrator(model: &Model, kind: MassKind, steps: usize) -> Integrator {
    let system = model.system(kind).expect("system");
    let scheme = match kind {
        MassKind::Redistributed => Scheme::PositionNewmark,
        MassKind::Consistent => Scheme::MoreauJean {
            theta: MOREAU_THETA,
            restitution: 0.0,
        },
    };
    let mut it = Integrator::new(
        &system,
        &Settings {
            dt: 1.0 / (FREQUENCY_HZ * steps as f64),
            scheme,
            omega: Some(hz(FREQUENCY_HZ)),
            energy_offset: 0.0,
        },
    )
    .expect("integrator");
    if kind == MassKind::Consistent {
        it.set_contact_anticipation(true);
    }
    it
}

/// Contact DOF's minimum of the simulated steady state (`None`: not periodic in 400 periods).
fn simulate_min(mut it: Integrator, steps: usize) -> Option<(f64, usize)> {
    let st = simulate_to_steady_state(
        &mut it,
        hz(FREQUENCY_HZ),
        &SteadyStateOptions {
            steps_per_period: steps,
            max_periods: 400,
            tolerance: 1e-6,
            harmonics: 10,
            response_dof: CONTACT_DOF,
            periodicity: Periodicity::State,
        },
        |_| {},
        |_, _| {},
    )
    .expect("simulation");
    st.periodic
        .then(|| (st.solution.contacts[0].min, st.periods_simulated))
}

fn relative(a: f64, reference: f64) -> f64 {
    (a - reference).abs() / reference.abs()
}

/// A method's calibrated setting and the error it reaches.
struct Setting {
    label: String,
    resolution: usize,
    error: f64,
}

struct Calibration {
    reference_redistributed: f64,
    reference_consistent: f64,
    newmark_vs_ms_hbm: f64,
    ms_hbm: Setting,
    hbm_aft: Setting,
    general: Setting,
    newmark: Setting,
    moreau: Setting,
}

/// The smallest entry of `ladder` whose error meets the tolerance (else the last one).
fn smallest(ladder: &[usize], mut error: impl FnMut(usize) -> f64) -> (usize, f64) {
    let mut last = (ladder[0], f64::INFINITY);
    for &r in ladder {
        let e = error(r);
        last = (r, e);
        if e <= TOLERANCE {
            break;
        }
    }
    last
}

fn calibrate(m: &Model) -> Calibration {
    let start = Instant::now();
    let reference_redistributed = solve_min(&mut ms_hbm(m, 40), 1e-10).expect("MS-HBM, H = 40");
    let (reference_consistent, _) = simulate_min(integrator(m, MassKind::Consistent, 2000), 2000)
        .expect("Moreau-Jean with 2000 steps becomes periodic");
    let newmark_2000 = simulate_min(integrator(m, MassKind::Redistributed, 2000), 2000)
        .expect("Newmark becomes periodic")
        .0;
    let (h, e) = smallest(&HARMONIC_LADDER, |h| {
        solve_min(&mut ms_hbm(m, h), 1e-10)
            .map_or(f64::INFINITY, |v| relative(v, reference_redistributed))
    });
    let ms = Setting {
        label: format!("H = {h}, exact quadrature"),
        resolution: h,
        error: e,
    };
    let (h, e) = smallest(&HARMONIC_LADDER, |h| {
        solve_min(&mut hbm_aft(m, h), 1e-10)
            .map_or(f64::INFINITY, |v| relative(v, reference_consistent))
    });
    let aft = Setting {
        label: format!("H = {h}, consistent mass, sampled AFT, kp = 100 k_c"),
        resolution: h,
        error: e,
    };
    let general_error = solve_min(&mut general(m), GENERAL_TOLERANCE)
        .map_or(f64::INFINITY, |v| relative(v, reference_consistent));
    let gen = Setting {
        label: format!(
            "H = {GENERAL_HARMONICS}, {GENERAL_STEPS} steps, tolerance {GENERAL_TOLERANCE:.0e} (not calibrated)"
        ),
        resolution: GENERAL_HARMONICS,
        error: general_error,
    };
    let simulated = |kind: MassKind, reference: f64| {
        smallest(&STEPS_LADDER, |n| {
            simulate_min(integrator(m, kind, n), n)
                .map_or(f64::INFINITY, |(v, _)| relative(v, reference))
        })
    };
    let (n, e) = simulated(MassKind::Redistributed, reference_redistributed);
    let newmark = Setting {
        label: format!("{n} steps/period, redistributed mass (Newmark), from rest"),
        resolution: n,
        error: e,
    };
    let (n, e) = simulated(MassKind::Consistent, reference_consistent);
    let moreau = Setting {
        label: format!(
            "{n} steps/period, consistent mass (Moreau-Jean, θ = {MOREAU_THETA}), from rest"
        ),
        resolution: n,
        error: e,
    };
    println!(
        "frd_point: calibrated in {:.1} s; contact DOF min at {:.0} kHz: MS-HBM H = 40 {reference_redistributed:.6} mm, \
         Moreau-Jean (consistent, 2000 steps) {reference_consistent:.6} mm (mass models differ by {:.2e})",
        start.elapsed().as_secs_f64(),
        FREQUENCY_HZ / 1e3,
        relative(reference_consistent, reference_redistributed)
    );
    Calibration {
        reference_redistributed,
        reference_consistent,
        newmark_vs_ms_hbm: relative(newmark_2000, reference_redistributed),
        ms_hbm: ms,
        hbm_aft: aft,
        general: gen,
        newmark,
        moreau,
    }
}

fn bench_frd_point(c: &mut Criterion) {
    let m = model();
    let calibration: OnceCell<Calibration> = OnceCell::new();
    let cal = || calibration.get_or_init(|| calibrate(&m));
    let mut group = c.benchmark_group("frd_point");
    group.sample_size(10);
    group.warm_up_time(Duration::from_millis(200));
    group.measurement_time(Duration::from_secs(3));
    group.bench_function("ms_hbm", |b| {
        let h = cal().ms_hbm.resolution;
        timed_with_setup(
            b,
            "frd_point/ms_hbm",
            || ms_hbm(&m, h),
            |mut p| solve_min(&mut p, 1e-10),
        );
    });
    group.bench_function("hbm_aft", |b| {
        let h = cal().hbm_aft.resolution;
        timed_with_setup(
            b,
            "frd_point/hbm_aft",
            || hbm_aft(&m, h),
            |mut p| solve_min(&mut p, 1e-10),
        );
    });
    group.bench_function("general_ms_hbm", |b| {
        cal();
        timed_with_setup(
            b,
            "frd_point/general_ms_hbm",
            || general(&m),
            |mut p| solve_min(&mut p, GENERAL_TOLERANCE),
        );
    });
    group.bench_function("time_integration_newmark", |b| {
        let n = cal().newmark.resolution;
        timed_with_setup(
            b,
            "frd_point/time_integration_newmark",
            || integrator(&m, MassKind::Redistributed, n),
            |it| simulate_min(it, n),
        );
    });
    group.bench_function("time_integration_moreau", |b| {
        let n = cal().moreau.resolution;
        timed_with_setup(
            b,
            "frd_point/time_integration_moreau",
            || integrator(&m, MassKind::Consistent, n),
            |it| simulate_min(it, n),
        );
    });
    group.finish();

    let Some(cal) = calibration.get() else {
        return;
    };
    let Some(reference) = median("frd_point/ms_hbm") else {
        return;
    };
    println!(
        "One FRD point of the bar at {:.0} kHz (Rayleigh damping), contact DOF min to {:.0} % of its mass model's converged value \
         (redistributed {:.6} mm, consistent {:.6} mm; Newmark with 2000 steps vs MS-HBM H = 40: {:.1e}):",
        FREQUENCY_HZ / 1e3,
        TOLERANCE * 100.0,
        cal.reference_redistributed,
        cal.reference_consistent,
        cal.newmark_vs_ms_hbm
    );
    for (name, setting) in [
        ("ms_hbm", &cal.ms_hbm),
        ("hbm_aft", &cal.hbm_aft),
        ("general_ms_hbm", &cal.general),
        ("time_integration_newmark", &cal.newmark),
        ("time_integration_moreau", &cal.moreau),
    ] {
        let Some(t) = median(&format!("frd_point/{name}")) else {
            continue;
        };
        println!(
            "  {name:<25} {:<75} error {:.1e}{}  {:>10}  ratio to MS-HBM {:.1}x",
            setting.label,
            setting.error,
            if setting.error <= TOLERANCE {
                ""
            } else {
                " (misses the tolerance)"
            },
            show(t),
            t / reference
        );
    }
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    bench_frd_point(&mut c);
    c.final_summary();
}
