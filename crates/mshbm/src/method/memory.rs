//! Memory estimates of the periodic-solution methods, checked against
//! [`Limits`] **before** a method allocates anything that grows with the number of
//! harmonics `H`, samples `N_s` or DOFs (docs/safety.md, "Resource limits of the solvers").
//!
//! Each method lists the arrays that dominate its peak: the Fourier basis at the samples
//! (`N_s × (2H+1)`), the dense Newton Jacobian of `n_N (2H+1)` unknowns (with the copies
//! Newton's LU and the continuation's bordered system make), the Gram blocks of the exact
//! quadrature (`(2H+1)²` per active set), the condensed compliances per harmonic and the
//! sparse factors of the linear part per harmonic. All sizes use checked arithmetic; an
//! overflow is an estimate of "more than 2⁶⁴ bytes". Measured against the peak resident
//! memory of `mshbm solve` on the bar (docs/safety.md), the estimates are within a factor
//! of about 1.5 of the real peak.

use crate::error::Result;
use crate::harmonic::checked_coefficients;
use crate::limits::Limits;
use crate::model::{System, MODEL_BYTES_PER_DOF};

/// Copies of the dense Jacobian alive at once: the Jacobian, the LU factor of Newton's
/// solve and the continuation's bordered matrix; with the operator Jacobian (docs/theory.md
/// §18), the factors kept as its preconditioner, the dense Jacobian of a refresh and its
/// new factors.
const JACOBIAN_COPIES: u64 = 3;

/// Fill factor assumed for the sparse LU of the linear part per harmonic (a banded or
/// well-ordered FE matrix; a lower bound for 3D meshes).
const FACTOR_FILL: u64 = 4;

/// A list of named allocations whose sizes are estimated before anything is allocated.
#[derive(Debug, Default)]
pub struct MemoryPlan {
    items: Vec<(String, Option<u64>)>,
}

pub(crate) fn mul(values: &[u64]) -> Option<u64> {
    values.iter().try_fold(1u64, |acc, &v| acc.checked_mul(v))
}

impl MemoryPlan {
    pub fn new() -> Self {
        MemoryPlan::default()
    }

    /// Add `what` needing `bytes` (`None`: the estimate overflowed).
    pub fn add(&mut self, what: impl Into<String>, bytes: Option<u64>) {
        self.items.push((what.into(), bytes));
    }

    /// Add the product of `factors` (elements × bytes per element, …).
    pub fn add_product(&mut self, what: impl Into<String>, factors: &[u64]) {
        self.add(what, mul(factors));
    }

    /// Total bytes, `None` on overflow.
    pub fn total(&self) -> Option<u64> {
        self.items
            .iter()
            .try_fold(0u64, |acc, (_, b)| acc.checked_add((*b)?))
    }

    /// The largest item (an overflowed one counts as the largest).
    pub fn largest(&self) -> Option<&str> {
        self.items
            .iter()
            .max_by_key(|(_, b)| b.unwrap_or(u64::MAX))
            .map(|(w, _)| w.as_str())
    }

    /// Check the total against `limits`; the error names `subject` and the largest item.
    pub fn check(&self, subject: &str, limits: &Limits) -> Result<()> {
        let what = match self.largest() {
            Some(largest) => format!("{subject} (mostly {largest})"),
            None => subject.to_string(),
        };
        limits.check_memory(&what, self.total())
    }
}

/// `2H + 1` as `u64` (saturated: an overflow makes every product overflow too).
pub(crate) fn coefficients(harmonics: usize) -> u64 {
    checked_coefficients(harmonics).map_or(u64::MAX, |c| c as u64)
}

/// The parts every harmonic-balance method shares: the Fourier basis at `samples`, the
/// dense Jacobian of `unknowns`, and the per-harmonic condensation of the linear part of
/// `system` onto its `n_n` nonlinear DOFs (`G_k`, `u0_k` and a sparse LU per harmonic).
pub(crate) fn shared(
    plan: &mut MemoryPlan,
    system: &System,
    harmonics: usize,
    samples: usize,
    unknowns: Option<u64>,
    interface: Interface,
) {
    let nc = coefficients(harmonics);
    let s = samples as u64;
    plan.add_product(
        "the system's matrices, partition and condensation",
        &[system.n_dofs() as u64, MODEL_BYTES_PER_DOF],
    );
    plan.add_product(
        format!("the Fourier basis at {samples} samples × {harmonics} harmonics"),
        &[s, nc.saturating_add(1), 8],
    );
    plan.add(
        format!("the dense Jacobian of the harmonic balance ({harmonics} harmonics)"),
        unknowns.and_then(|u| mul(&[u, u, 8, JACOBIAN_COPIES])),
    );
    let per_harmonic = (harmonics as u64).saturating_add(1);
    let nnz = system.stiffness.nnz() as u64;
    plan.add_product(
        format!("the sparse factors of the linear part for {harmonics} harmonics"),
        &[per_harmonic, nnz, 16, FACTOR_FILL],
    );
    plan.add(
        "the condensed interface stiffness per harmonic",
        mul(&[
            per_harmonic,
            interface.size,
            interface.size.saturating_add(1),
            16,
            interface.matrices,
        ]),
    );
}

/// What the linear part is condensed onto: `size` coordinates, `matrices` dense complex
/// `size × size` matrices per harmonic.
pub(crate) struct Interface {
    pub(crate) size: u64,
    pub(crate) matrices: u64,
}

impl Interface {
    /// The `N` DOFs, `G_k` per harmonic (HBM-AFT, the general MS-HBM).
    fn nonlinear_dofs(system: &System) -> Self {
        Interface {
            size: system.nonlinear_dofs.len() as u64,
            matrices: 1,
        }
    }
}

/// HBM-AFT with `H` harmonics and `N_s` samples: unknowns `n_N (2H+1)`, `H̃_k` per harmonic,
/// per-sample displacements and forces of the alternating frequency–time step.
pub fn hbm_aft(system: &System, harmonics: usize, samples: usize) -> MemoryPlan {
    let mut plan = MemoryPlan::new();
    let nc = coefficients(harmonics);
    let n_n = system.nonlinear_dofs.len() as u64;
    shared(
        &mut plan,
        system,
        harmonics,
        samples,
        n_n.checked_mul(nc),
        Interface::nonlinear_dofs(system),
    );
    plan.add_product(
        format!("the time signals at {samples} samples"),
        &[samples as u64, n_n, 8, 4],
    );
    plan
}

/// The general MS-HBM with `H` harmonics and `N_s` steps per period: unknowns
/// `n_N (2H+3)`, the trajectory of the nonlinear subsystem (positions, velocities, gaps and
/// forces per step).
pub fn general(system: &System, harmonics: usize, steps: usize) -> MemoryPlan {
    let mut plan = MemoryPlan::new();
    let nc = coefficients(harmonics);
    let n_n = system.nonlinear_dofs.len() as u64;
    let unknowns = nc.checked_add(2).and_then(|c| c.checked_mul(n_n));
    shared(
        &mut plan,
        system,
        harmonics,
        steps,
        unknowns,
        Interface::nonlinear_dofs(system),
    );
    let per_step = mul(&[n_n, 2])
        .and_then(|v| v.checked_add(system.contacts.len() as u64 * 2))
        .and_then(|v| v.checked_add(system.frictions.len() as u64));
    plan.add(
        format!("the trajectory at {steps} steps per period"),
        per_step.and_then(|p| mul(&[steps as u64, p, 8, 2])),
    );
    plan
}
