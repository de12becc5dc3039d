//! The friction oscillator's diagram (issue 19's cost target): the general MS-HBM on
//! `examples/friction_oscillator/model.toml` from 2 to 40 Hz, H = 10, as `mshbm frf
//! --method mshbm` traces it (its continuation settings; the diagram points' own solutions
//! are left out), on every core (the finite-difference Jacobian's period integrations run in
//! parallel). One run: it prints the wall time, the points, the Newton iterations and the
//! period integrations (residual evaluations) per point, and whether the target (at most
//! 20 s on 2 cores) is met; it exits with status 1 when it is missed.
//!
//! `cargo bench -p mshbm --bench friction_diagram`

mod common;

use std::process::ExitCode;
use std::time::Instant;

use mshbm::continuation::arclength::{trace_branch, StopReason};
use mshbm::frd::FrdSettings;
use mshbm::method::general::{GeneralMsHbm, GeneralOptions};
use mshbm::problem::{ContinuationPolicy, Linearization, PeriodicProblem};
use mshbm::solution::PeriodicSolution;
use mshbm::stability::Floquet;
use mshbm::Result;

const TARGET_SECONDS: f64 = 20.0;

/// The general MS-HBM, counting its period integrations: one per residual, `dim + 2` per
/// linearization (the point, one per finite-difference column, one for ∂R/∂ω).
struct Counting {
    inner: GeneralMsHbm,
    integrations: usize,
}

impl PeriodicProblem for Counting {
    fn dimension(&self) -> usize {
        self.inner.dimension()
    }
    fn length_scale(&self) -> f64 {
        self.inner.length_scale()
    }
    fn initial_guess(&mut self, omega: f64) -> Result<Vec<f64>> {
        self.inner.initial_guess(omega)
    }
    fn residual(&mut self, x: &[f64], omega: f64) -> Result<Vec<f64>> {
        self.integrations += 1;
        self.inner.residual(x, omega)
    }
    fn linearize(&mut self, x: &[f64], omega: f64) -> Result<Linearization> {
        self.integrations += self.inner.dimension() + 2;
        self.inner.linearize(x, omega)
    }
    fn solution(&mut self, x: &[f64], omega: f64, dof: usize) -> Result<PeriodicSolution> {
        self.inner.solution(x, omega, dof)
    }
    fn continuation_policy(&self) -> ContinuationPolicy {
        self.inner.continuation_policy()
    }
    fn floquet(&mut self, x: &[f64], omega: f64) -> Result<Option<Floquet>> {
        self.inner.floquet(x, omega)
    }
}

fn main() -> ExitCode {
    let model = common::example("friction_oscillator/model.toml", &[]);
    let mut problem = Counting {
        inner: GeneralMsHbm::new(&model, &GeneralOptions::new(10)).expect("general MS-HBM"),
        integrations: 0,
    };
    let options = FrdSettings::new(2.0, 40.0).continuation();
    let start = Instant::now();
    let branch = trace_branch(&mut problem, &options, |_, _| Ok(())).expect("the diagram");
    let seconds = start.elapsed().as_secs_f64();
    let points = branch.points.len();
    let iterations: usize = branch.points.iter().map(|p| p.iterations).sum();
    let complete = branch.stop == StopReason::ReachedEnd;
    let met = complete && seconds <= TARGET_SECONDS;
    println!(
        "friction oscillator 2 -> 40 Hz, H = 10, on {} cores: {seconds:.1} s wall, {points} points \
         ({} by frequency steps), {iterations} Newton iterations ({:.2} per point), {} period \
         integrations ({:.1} per point){} — target ≤ {TARGET_SECONDS} s on 2 cores: {}",
        std::thread::available_parallelism().map_or(1, |n| n.get()),
        branch.frequency_steps,
        iterations as f64 / points as f64,
        problem.integrations,
        problem.integrations as f64 / points as f64,
        if complete { "" } else { ", INCOMPLETE" },
        if met { "met" } else { "missed" }
    );
    if met {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
