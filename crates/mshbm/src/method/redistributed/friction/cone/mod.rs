//! Coulomb friction in the cone of a 3D interface (docs/theory.md (T185)–(T192)): contacts
//! with a normal and two tangential coordinates, ordered `[normals; first tangents; second
//! tangents]`. The state of every closed contact with friction is its tangential displacement
//! `a_c ∈ ℝ²`, held while the contact sticks and moved by the slip flow (T187) while it slips;
//! the forces of a set of closed contacts are affine in the free gap and those displacements
//! (T186). A phase without slip is exact; a phase with slip is integrated by DOP853 with the
//! Fourier integrals of the displacements carried along (T189). Switches (T188) are located
//! by bisection on the length of the step from its start; the slipping contacts are put back
//! on the cone after every step. The periodic state is the fixed point of the period's
//! march (T190).
//!
//! Its derivative along directions of the free gap is the tangent-linear march of
//! `tangent.rs` (T191), (T214)–(T218).

use std::collections::HashMap;
use std::f64::consts::PI;
use std::rc::Rc;

use faer::Mat;

use crate::contact::lcp::{LcpMatrix, LcpSolver};
use crate::dense::solve_small_lu_columns;
use crate::error::{Error, Result};
use crate::harmonic::{add_interval_gram, basis_into, n_coefficients};
use crate::ode::{Dop853, Tolerance};
use crate::roots::find_sign_change_with_slope;

/// The state of one contact of the cone law (T185).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ConeMode {
    /// Gap open, no force.
    Open,
    /// Closed, the tangential displacement held.
    Stick,
    /// Closed and slipping (for `μ = 0`: closed with no tangential force).
    Slip,
}

/// Contacts with Coulomb friction in the cone: the Delassus matrix of the normal and the two
/// tangential coordinates and the friction coefficients.
#[derive(Clone, Debug)]
pub struct ConeContacts {
    n: usize,
    /// `3n × 3n`, row-major, coordinates `[normals; t₁; t₂]`.
    delassus: Vec<f64>,
    mu: Vec<f64>,
}

/// One interval of constant modes.
#[derive(Clone, Debug)]
pub struct ConePhase {
    pub start: f64,
    pub end: f64,
    pub modes: Vec<ConeMode>,
    /// Tangential displacements at the start (`2n`: first tangents, then second).
    pub anchors: Vec<f64>,
    /// The contact and the indicator whose root ended the phase (none for the last).
    event: Option<(usize, march::Watch)>,
    /// The ends of the march's accepted steps through the phase (the last is `end`; empty
    /// without slip), and after each the slipping contacts' displacements (two per slipping
    /// contact, in their order): the outputs at an instant start from these (T221), so that
    /// they follow the march's path where the slip flow is not unique (a contact slipping
    /// at the cone's apex with a normal force at round-off).
    grid: Vec<f64>,
    track: Vec<f64>,
}

/// The periodic contact forces of a free-gap signal.
#[derive(Clone, Debug)]
pub struct ConePeriodic {
    pub harmonics: usize,
    /// `λ̂`, harmonic-major, `3n` per coefficient.
    pub forces: Vec<f64>,
    /// The period cut at the mode changes, in order.
    pub phases: Vec<ConePhase>,
    /// Marches of one period the fixed point needed.
    pub passes: usize,
    /// Integration steps of the last march: accepted, and tried while locating switches.
    pub steps: usize,
    pub trial_steps: usize,
    gamma: Vec<f64>,
}

/// Relative tolerance of the indicators (T153).
const INDICATOR_TOLERANCE: f64 = 1e-11;
/// Relative tolerance of the slip flow's integration (T188).
const FLOW_TOLERANCE: f64 = 1e-12;
/// Passes of one period before the fixed point is given up.
const MAX_PASSES: usize = 400;
/// Pairs of start and end of the period's march that Anderson mixing combines (T224).
const MIXING_MEMORY: usize = 5;
/// Mode changes in one period before the march is given up (a chattering contact).
const MAX_EVENTS_PER_CONTACT: usize = 1000;

mod flow;
mod fourier;
mod march;
mod mixing;
mod outputs;
mod rates;
mod tangent;

pub use outputs::ConeState;
pub use tangent::AnchorResponse;

use march::March;

impl ConeContacts {
    /// `delassus` is `3n × 3n` row-major in the coordinates `[normals; t₁; t₂]`, `mu` the `n`
    /// friction coefficients (finite, non-negative).
    pub fn new(delassus: Vec<f64>, mu: Vec<f64>) -> Result<Self> {
        let n = mu.len();
        if delassus.len() != 9 * n * n {
            return Err(Error::Numerical(format!(
                "friction cone: a Delassus matrix of {} entries for {n} contacts ({} expected)",
                delassus.len(),
                9 * n * n
            )));
        }
        if let Some(c) = mu.iter().position(|m| !(m.is_finite() && *m >= 0.0)) {
            return Err(Error::Numerical(format!(
                "friction cone: contact {c} has the friction coefficient {}, not a finite \
                 non-negative number",
                mu[c]
            )));
        }
        if delassus.iter().any(|v| !v.is_finite()) {
            return Err(Error::Numerical(
                "friction cone: the Delassus matrix is not finite".into(),
            ));
        }
        Ok(ConeContacts { n, delassus, mu })
    }

    pub fn contacts(&self) -> usize {
        self.n
    }

    pub fn mu(&self) -> &[f64] {
        &self.mu
    }

    fn d(&self, i: usize, j: usize) -> f64 {
        self.delassus[i * 3 * self.n + j]
    }

    /// The frictionless state at `τ = 0` (T156): the normal LCP on `D_NN`, closed contacts
    /// stuck at their tangential displacement.
    fn initial_state(&self, gamma0: &[f64]) -> Result<(Vec<ConeMode>, Vec<f64>)> {
        let n = self.n;
        let dnn: Vec<f64> = (0..n * n).map(|k| self.d(k / n, k % n)).collect();
        let solution = LcpSolver::new(LcpMatrix::new(n, dnn))
            .solve(&gamma0[..n])
            .map_err(|e| Error::Numerical(format!("friction cone: initial state: {e}")))?;
        let modes = (0..n)
            .map(|c| match (solution.active[c], self.mu[c] > 0.0) {
                (false, _) => ConeMode::Open,
                (true, true) => ConeMode::Stick,
                (true, false) => ConeMode::Slip,
            })
            .collect();
        let anchors = (0..2 * n)
            .map(|t| {
                gamma0[n + t]
                    + (0..n)
                        .map(|k| self.d(n + t, k) * solution.lambda[k])
                        .sum::<f64>()
            })
            .collect();
        Ok((modes, anchors))
    }

    /// The periodic contact forces for the free gap with coefficients `gamma` (harmonic-major,
    /// `3n` per coefficient, `harmonics` harmonics), integration steps at most one of `cells`
    /// cells of the period (a switch that comes and goes within one step is not seen), the
    /// state at `τ = 0` repeated until periodic (T190).
    pub fn periodic(&self, harmonics: usize, gamma: &[f64], cells: usize) -> Result<ConePeriodic> {
        let (n, m) = (self.n, 3 * self.n);
        let ncoef = n_coefficients(harmonics);
        if gamma.len() != m * ncoef {
            return Err(Error::Numerical(format!(
                "friction cone: {} free-gap coefficients, {} expected",
                gamma.len(),
                m * ncoef
            )));
        }
        if gamma.iter().any(|v| !v.is_finite()) {
            return Err(Error::Numerical(
                "friction cone: the free gap is not finite".into(),
            ));
        }
        let mut march = March::new(self, harmonics, gamma, cells.max(1));
        let mut g0 = vec![0.0; m];
        march.gamma_at(0.0, &mut g0, None);
        let (mut modes0, mut anchors0) = self.initial_state(&g0)?;
        let scale = march.gamma_scale.max(f64::MIN_POSITIVE);
        let mut mixing = mixing::Anderson::new(MIXING_MEMORY);
        for pass in 1..=MAX_PASSES {
            march.steps = 0;
            march.trial_steps = 0;
            let out = march.run(&modes0, &anchors0)?;
            let (modes_end, anchors_end) = out.end;
            let converged = modes_end == modes0
                && (0..n).all(|c| {
                    modes0[c] == ConeMode::Open
                        || self.mu[c] == 0.0
                        || ((anchors_end[c] - anchors0[c]).abs() <= 1e-12 * scale
                            && (anchors_end[n + c] - anchors0[n + c]).abs() <= 1e-12 * scale)
                });
            if converged {
                return Ok(ConePeriodic {
                    harmonics,
                    forces: out.forces,
                    phases: out.phases,
                    passes: pass,
                    steps: march.steps,
                    trial_steps: march.trial_steps,
                    gamma: gamma.to_vec(),
                });
            }
            // the next start: mixed from the last passes while the modes at τ = 0 repeat
            // (the closed contacts with friction: their anchors are the unknowns) (T224)
            let unknowns: Vec<usize> = (0..n)
                .filter(|&c| modes0[c] != ConeMode::Open && self.mu[c] > 0.0)
                .flat_map(|c| [c, n + c])
                .collect();
            let mut next = anchors_end.clone();
            if modes_end == modes0 && !unknowns.is_empty() {
                let x: Vec<f64> = unknowns.iter().map(|&r| anchors0[r]).collect();
                let g: Vec<f64> = unknowns.iter().map(|&r| anchors_end[r]).collect();
                for (r, v) in unknowns.iter().zip(mixing.next(&x, &g)) {
                    next[*r] = v;
                }
            } else {
                mixing.reset();
            }
            modes0 = modes_end;
            anchors0 = next;
        }
        Err(Error::Numerical(format!(
            "friction cone: the contact state did not become periodic in {MAX_PASSES} periods"
        )))
    }

    /// The forces (`3n`) at `τ` of a periodic state, the slip flow integrated from the
    /// march's last step before `τ` (T221).
    pub fn force_at(&self, periodic: &ConePeriodic, tau: f64) -> Result<Vec<f64>> {
        let tau = tau.rem_euclid(2.0 * PI);
        let phase = periodic
            .phases
            .iter()
            .find(|p| p.start <= tau && tau <= p.end)
            .or(periodic.phases.last())
            .ok_or_else(|| Error::Numerical("friction cone: no phases".into()))?;
        let mut march = March::new(self, periodic.harmonics, &periodic.gamma, 64);
        let anchors = march.flow_to(phase, tau)?;
        let closed = march.closed(&phase.modes)?;
        Ok(march.evaluate(tau, &phase.modes, &anchors, &closed)?.lambda)
    }
}

#[cfg(test)]
mod tangent_tests;
#[cfg(test)]
mod tests;
