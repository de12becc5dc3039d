//! Periodic-solution methods, each an implementor of [`crate::problem::PeriodicProblem`].

pub mod general;
pub mod hbm_aft;
pub mod memory;
pub(crate) mod partition;
pub mod redistributed;
pub mod settings;

use faer::c64;

use crate::error::{Error, Result};
use crate::harmonic::{checked_coefficients, n_coefficients, Quadrature};
use crate::model::System;
use crate::solution::{ContactSeries, DofResponse, FrictionSeries, MethodKind, PeriodicSolution};
use partition::Partition;

pub(crate) use crate::linear::{complex_harmonic, store_harmonic};

/// Reports the phases of a method's set-up (a progress display for large models, where
/// modes or factorizations take seconds to minutes): called with `Some(phase)` when a phase
/// starts and with `None` when the set-up is done. The library never prints.
#[derive(Clone)]
pub struct SetupObserver(pub std::sync::Arc<SetupCallback>);

/// What a [`SetupObserver`] calls: `Some(phase)` at a phase's start, `None` when done.
pub type SetupCallback = dyn Fn(Option<&str>) + Send + Sync;

impl SetupObserver {
    /// An observer calling `f`.
    pub fn new(f: impl Fn(Option<&str>) + Send + Sync + 'static) -> Self {
        SetupObserver(std::sync::Arc::new(f))
    }

    /// A phase starts (no-op without an observer).
    pub(crate) fn phase(observer: Option<&SetupObserver>, phase: impl FnOnce() -> String) {
        if let Some(o) = observer {
            (o.0)(Some(&phase()));
        }
    }

    /// The set-up is done.
    pub(crate) fn done(observer: Option<&SetupObserver>) {
        if let Some(o) = observer {
            (o.0)(None);
        }
    }
}

impl std::fmt::Debug for SetupObserver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SetupObserver")
    }
}

/// Check the settings every method shares: at least one harmonic, and enough samples
/// (`what`: "samples" or "steps per period") to resolve them (`≥ 2H + 1`).
pub(crate) fn check_resolution(harmonics: usize, samples: usize, what: &str) -> Result<()> {
    if harmonics == 0 {
        return Err(Error::argument("harmonics", "must be at least 1"));
    }
    let Some(needed) = checked_coefficients(harmonics) else {
        return Err(Error::argument(
            "harmonics",
            format!("{harmonics} harmonics is too many: 2H+1 overflows"),
        ));
    };
    if samples < needed {
        return Err(Error::argument(
            "samples",
            format!(
                "{samples} {what} cannot resolve {harmonics} harmonics: need at least 2H+1 = {needed}"
            ),
        ));
    }
    Ok(())
}

/// A default time resolution for `H` harmonics: `max(at_least, per_coefficient (2H + 1))`
/// samples or steps per period, far above the `2H + 1` needed (docs/theory.md (T10) and §6,
/// (T44): resolve the
/// nonsmooth time signal, not just the harmonics).
pub(crate) fn default_resolution(
    harmonics: usize,
    per_coefficient: usize,
    at_least: usize,
) -> usize {
    // saturated: an absurd H then fails the memory estimate, not the arithmetic
    checked_coefficients(harmonics)
        .map_or(usize::MAX, |c| per_coefficient.saturating_mul(c))
        .max(at_least)
}

/// Default number of samples per period of the harmonic-balance methods (the redistributed
/// MS-HBM and HBM-AFT) for `H` harmonics: `max(256, 16 (2H + 1))`, enough to resolve the
/// kinks of `q_N(t)` (sampled quadrature) and to locate the switching times (exact
/// quadrature).
pub fn default_samples(harmonics: usize) -> usize {
    default_resolution(harmonics, 16, 256)
}

/// A frequency (rad/s) must be finite and positive; the message is in Hz.
pub(crate) fn check_frequency(omega: f64) -> Result<()> {
    if omega.is_finite() && omega > 0.0 {
        return Ok(());
    }
    Err(Error::argument(
        "frequency",
        format!(
            "must be positive, got {} Hz",
            omega / (2.0 * std::f64::consts::PI)
        ),
    ))
}

/// The method-specific parts of a [`PeriodicSolution`]; [`periodic_solution`] adds what the
/// methods share.
pub(crate) struct SolutionParts<'a> {
    pub method: MethodKind,
    /// The quadrature of the Fourier coefficients (`"exact"`, `"sampled"`).
    pub quadrature: Quadrature,
    pub harmonics: usize,
    /// Phases `τ_j = ω t_j` of the time series (their number is the reported `samples`).
    pub taus: &'a [f64],
    /// The residual `R(x, ω)` at the solution.
    pub residual: &'a [f64],
    pub contacts: Vec<ContactSeries>,
    pub frictions: Vec<FrictionSeries>,
    pub response: DofResponse,
}

/// The [`PeriodicSolution`] of `parts` at `ω` for `system`: times `t_j = τ_j/ω`, the contacts'
/// model DOFs, `‖R‖_∞` relative to the partition's length scale; Newton statistics and
/// stability are left at their defaults ([`crate::problem::PeriodicProblem::solution`]).
pub(crate) fn periodic_solution(
    system: &System,
    partition: &Partition,
    omega: f64,
    parts: SolutionParts,
) -> PeriodicSolution {
    PeriodicSolution {
        frequency_hz: omega / (2.0 * std::f64::consts::PI),
        harmonics: parts.harmonics,
        samples: parts.taus.len(),
        quadrature: parts.quadrature,
        method: parts.method,
        converged: false,
        iterations: 0,
        residual_norm: parts.residual.iter().fold(0.0f64, |m, v| m.max(v.abs()))
            / partition.length_scale(),
        time_s: parts.taus.iter().map(|t| t / omega).collect(),
        contact_dofs: system
            .contacts
            .iter()
            .map(|c| system.model_dof[c.w[0].0])
            .collect(),
        contacts: parts.contacts,
        frictions: parts.frictions,
        response: parts.response,
        stability: None,
        stability_unknown: None,
        unknowns: None,
        contact_node_harmonics: None,
        dissipated_energy: None,
        state_fractions: None,
    }
}

/// The response of a Dirichlet DOF (it does not move): zero coefficients and extremes.
pub(crate) fn fixed_response(dof: usize, harmonics: usize) -> DofResponse {
    DofResponse {
        dof,
        coefficients: vec![0.0; n_coefficients(harmonics)],
        max: 0.0,
        min: 0.0,
    }
}

/// The Fourier coefficients `[a0, a1, b1, …]` of `N`-DOF `i` in the harmonic-major
/// unknowns `x` (coefficient `c` at `c·n + i`, docs/theory.md (T8); `n` = number of `N`
/// DOFs).
pub(crate) fn n_dof_coefficients(x: &[f64], n: usize, harmonics: usize, i: usize) -> Vec<f64> {
    (0..n_coefficients(harmonics))
        .map(|c| x[c * n + i])
        .collect()
}

/// The complex zero.
pub(crate) fn zero() -> c64 {
    c64::new(0.0, 0.0)
}

/// The unknowns `x` must have the problem's dimension.
pub(crate) fn check_dimension(x: &[f64], dimension: usize) -> Result<()> {
    if x.len() != dimension {
        return Err(Error::argument(
            "x",
            format!("expected {dimension} unknowns, got {}", x.len()),
        ));
    }
    Ok(())
}
