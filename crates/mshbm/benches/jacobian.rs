//! The Jacobian of the redistributed MS-HBM per Newton iteration: semi-analytical (paper
//! eqs. 32–44, `PeriodicProblem::linearize`, which also returns `R` and `∂R/∂ω`) against
//! forward finite differences of the same residual (`dimension + 1` residual evaluations,
//! `∂R/∂x` only, serial — the step the general MS-HBM takes, there in parallel).
//!
//! Point: the paper's bar (gap 0.2 mm, 1 % modal damping of the first mode), converged
//! solution at 60 kHz (in contact), exact quadrature, default samples, H = 1, 5, 10, 20.
//! The frequency is fixed, so the per-frequency factorization is cached on both sides.
//!
//! `cargo bench -p mshbm --bench jacobian` prints, per H, the two median times, their ratio,
//! and the largest difference between the two Jacobians (relative to the largest entry).

mod common;

use common::{hz, median, show, timed};
use criterion::{BenchmarkId, Criterion};
use mshbm::harmonic::Quadrature;
use mshbm::method::redistributed::{RedistributedMsHbm, RedistributedOptions};
use mshbm::newton::{solve_at_frequency, NewtonOptions};
use mshbm::problem::PeriodicProblem;

const HARMONICS: [usize; 4] = [1, 5, 10, 20];
const FREQUENCY_HZ: f64 = 60e3;

struct Point {
    problem: RedistributedMsHbm,
    x: Vec<f64>,
    omega: f64,
}

fn converged_point(harmonics: usize) -> Point {
    let model = common::example("clamped_bar.toml", &["damping.first_mode_ratio=0.01"]);
    let mut problem = RedistributedMsHbm::new(
        &model,
        &RedistributedOptions {
            harmonics,
            samples: None,
            quadrature: Quadrature::Exact,
            receptance: Default::default(),
            jacobian: Default::default(),
        },
    )
    .expect("MS-HBM");
    let omega = hz(FREQUENCY_HZ);
    let (_, out) = solve_at_frequency(&mut problem, omega, 100, &NewtonOptions::default())
        .expect("solve at 60 kHz");
    assert!(out.converged, "H = {harmonics}: no convergence at 60 kHz");
    Point {
        problem,
        x: out.x,
        omega,
    }
}

/// Forward differences `(R(x + h e_j) − R(x)) / h`, `h = 1e-7 · max(|x_j|, ℓ)` (column-major).
fn finite_difference_jacobian(p: &mut Point) -> Vec<Vec<f64>> {
    let r0 = p.problem.residual(&p.x, p.omega).expect("residual");
    let scale = p.problem.length_scale();
    (0..p.x.len())
        .map(|j| {
            let mut xp = p.x.clone();
            xp[j] += 1e-7 * p.x[j].abs().max(scale);
            let h = xp[j] - p.x[j];
            let r = p.problem.residual(&xp, p.omega).expect("residual");
            r.iter().zip(&r0).map(|(a, b)| (a - b) / h).collect()
        })
        .collect()
}

fn bench_jacobian(c: &mut Criterion) {
    let mut group = c.benchmark_group("jacobian");
    group.sample_size(20);
    group.warm_up_time(std::time::Duration::from_millis(500));
    group.measurement_time(std::time::Duration::from_secs(3));
    // set up lazily: a criterion filter may skip a benchmark
    let mut points: Vec<Option<Point>> = HARMONICS.iter().map(|_| None).collect();
    for (i, &h) in HARMONICS.iter().enumerate() {
        let id = format!("jacobian/semi_analytical/{h}");
        group.bench_function(BenchmarkId::new("semi_analytical", h), |b| {
            let p = points[i].get_or_insert_with(|| converged_point(h));
            timed(b, &id, || {
                p.problem.linearize(&p.x, p.omega).expect("linearize")
            });
        });
        let id = format!("jacobian/finite_differences/{h}");
        group.bench_function(BenchmarkId::new("finite_differences", h), |b| {
            let p = points[i].get_or_insert_with(|| converged_point(h));
            timed(b, &id, || finite_difference_jacobian(p));
        });
    }
    group.finish();

    for (i, &h) in HARMONICS.iter().enumerate() {
        let (Some(sa), Some(fd)) = (
            median(&format!("jacobian/semi_analytical/{h}")),
            median(&format!("jacobian/finite_differences/{h}")),
        ) else {
            continue;
        };
        let p = points[i].as_mut().expect("ran");
        let exact = p
            .problem
            .linearize(&p.x, p.omega)
            .expect("linearize")
            .jacobian
            .to_dense();
        let fd_jac = finite_difference_jacobian(p);
        let largest = (0..p.x.len())
            .flat_map(|r| (0..p.x.len()).map(move |c| (r, c)))
            .fold(0.0f64, |m, (r, c)| m.max(exact[(r, c)].abs()));
        let diff = fd_jac.iter().enumerate().fold(0.0f64, |m, (c, col)| {
            col.iter()
                .enumerate()
                .fold(m, |m, (r, v)| m.max((v - exact[(r, c)]).abs()))
        });
        println!(
            "ratio finite differences / semi-analytical at H = {h:>2} ({} unknowns): {:.1}x \
             ({} vs {}; Jacobians differ by {:.1e} of the largest entry)",
            p.x.len(),
            fd / sa,
            show(fd),
            show(sa),
            diff / largest
        );
    }
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    bench_jacobian(&mut c);
    c.final_summary();
}
