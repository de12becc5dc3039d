//! Reference time integration of `M q'' + C q' + K q = f(t) + W λ` with unilateral contacts
//! (docs/theory.md §8 (T59)–(T63) and §9), run for a given time or to a periodic steady state — the paper's
//! baseline for the MS-HBM (Figs. 5 and 9).
//!
//! Two schemes ([`Scheme`]):
//!
//! * **Moreau–Jean θ-scheme** ([`Scheme::MoreauJean`], docs/theory.md (T59)–(T60)): velocity level,
//!   impulses per step, Newton's impact law `0 ≤ U⁺ + e U⁻ ⊥ P ≥ 0` on the contacts that are
//!   closed at the predicted position `q_k + h(1−θ) v_k`. The iteration matrix
//!   `M̂ = M + hθC + h²θ²K` is factored once. With the consistent mass this is the paper's
//!   reference ("original mass matrix, e_N = 0"). On a singular (redistributed) mass it is
//!   only stable for `θ > ½` (docs/theory.md (T68): the massless rows become a trapezoidal average
//!   of an algebraic equation, with a parasitic `(−1)^k` mode), so `θ = ½` is refused there.
//! * **Position-level Newmark** ([`Scheme::PositionNewmark`], docs/theory.md (T67), Khenous-type):
//!   average acceleration (β = ¼, γ = ½) on a mass with a massless contact boundary, with
//!   Signorini imposed on the positions at the end of the step (no impact law):
//!   `Â = (4/h²) M + (2/h) C + K` (factored once, positive definite even for a free body),
//!   `u_free = Â⁻¹ b`, `0 ≤ g = Wᵀ(u_free + Â⁻¹ W λ) + g0 ⊥ λ ≥ 0`. The gap is never
//!   negative and, without damping and forcing, the energy is conserved through the impacts.
//!   Needs every contact DOF massless and damping that does not act on the massless DOFs
//!   (`C_NN = C_NL = 0`, as the redistributed MS-HBM).
//!
//! **Coulomb friction** (docs/theory.md (T63), Moreau–Jean only): friction elements
//! ([`crate::model::Friction`]) add tangential impulses `P_T` along their direction `w_T`
//! with `|P_T| ≤ h μ F_N` (prescribed normal force, always active) or `|P_T| ≤ μ P_N`
//! (normal force of a unilateral contact, active while that contact is in the index set),
//! and the law `P_T ∈ −bound · Sign(γ_T⁺)` on the post-step slip velocity `γ_T⁺ = w_Tᵀ v_{k+1}`
//! (`e_T = 0`). The impulses of one step solve the proximal equations
//! `P_N = prox_{ℝ≥0}(P_N − r ξ_N)`, `P_T = prox_{[−b, b]}(P_T − r γ_T)` by Gauss–Seidel
//! sweeps with `r_i = 1/G_ii` (each row solved exactly given the others, so a single
//! element is exact in one sweep: stick `P_T = −γ_free/G_TT` when `|γ_free/G_TT| ≤ b`, slip
//! `−b sign γ_free` otherwise), then the stick/slip/contact status found is *polished* by
//! one exact linear solve (kept when it satisfies every law), so stick/slip is exact per
//! step. `|P_T| ≤ b` holds exactly (clamped). [`Integrator::friction_forces`] reports
//! `P_T/h`.
//!
//! **Coulomb friction on the contacts** (docs/theory.md (T170)–(T175), position-level scheme
//! only): a contact with friction ([`crate::model::SystemContactFriction`], `mu` of an
//! interface) adds its tangential coordinate `y_T = w_Tᵀ u` to the step's contact problem,
//! `y = y_free + D λ` over normals and tangents, with the incremental Coulomb law
//! `λ_T ∈ −μ λ_N Sign(y_T,k+1 − y_T,k)` (backward Euler of the sweeping process of the
//! MS-HBM's law (T151)); solved by trying the last step's stick/slip/open modes, else block
//! Gauss–Seidel with each contact exact, polished by an exact solve (`coulomb`).
//! [`Integrator::tangential_forces`] reports `λ_T`. The Moreau–Jean scheme refuses it.
//!
//! **Periodic load** ([`Integrator::set_periodic_load`]): a trigonometric polynomial load
//! `Σ_c F_c b_c(ωt)` can be added to `f(t)` — the coupling force of the linear subsystem on
//! the nonlinear one in the general MS-HBM (paper eq. 10).
//!
//! The per-step LCP is solved by the same exact solver as the MS-HBM
//! ([`crate::contact::lcp::LcpSolver`]). Massless DOFs carry no velocity state: after every
//! [`Integrator::set_state`] they are put in static equilibrium with the rest (the static
//! contact problem of eqs. 26–29, [`StaticContact`](crate::contact::static_contact::StaticContact)).
//!
//! **Energy** ([`Integrator::energy`]): `E = ½ vᵀMv + ½ qᵀKq − qᵀ f_const + E_offset`, with `M`
//! the mass in use, `f_const` the constant load (including an acceleration field) and
//! `E_offset` from the settings. For a free body under an acceleration field (the dropped
//! bar) [`fall_energy`] gives the offset that makes the datum "resting on the support"
//! (docs/theory.md (T69): `E = ½vᵀMv + ½uᵀKu + g 1ᵀMu + m g h0`), so `E/E(0)` is the normalised
//! energy of the paper's Fig. 5.
//!
//! [`steady_state`] integrates period by period until the response (or, as an option, the
//! whole state) repeats (docs/theory.md (T97), (T70));
//! [`initial`] builds the initial state of a harmonic solution (e.g. from `mshbm solve`);
//! [`crate::analytic`] has the closed-form references.

mod coulomb;
mod data;
pub mod initial;
mod integrator;
mod moreau;
mod newmark;
mod periodicity;
pub mod steady_state;

pub(crate) use data::{Data, State};
pub use integrator::Integrator;

use crate::error::{Error, Result};
use crate::model::{MassKind, Model, System};

/// The time-stepping scheme.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scheme {
    /// Moreau–Jean θ-scheme with Newton's impact law (docs/theory.md (T59)–(T60)); `theta ∈ [½, 1]`,
    /// `restitution` `e_N ∈ [0, 1]`.
    MoreauJean { theta: f64, restitution: f64 },
    /// Newmark average acceleration with position-level Signorini for a massless contact
    /// boundary (docs/theory.md (T67)).
    PositionNewmark,
}

impl Scheme {
    /// The Moreau–Jean scheme with the defaults θ = ½ (no numerical damping) and `e_N = 0`
    /// where not given.
    pub fn moreau_jean(theta: Option<f64>, restitution: Option<f64>) -> Self {
        Scheme::MoreauJean {
            theta: theta.unwrap_or(0.5),
            restitution: restitution.unwrap_or(0.0),
        }
    }

    /// The mass matrix the scheme integrates: the consistent mass for Moreau–Jean, the
    /// redistributed mass (massless contact boundary) for the position-level Newmark scheme.
    pub fn mass_kind(&self) -> MassKind {
        match self {
            Scheme::MoreauJean { .. } => MassKind::Consistent,
            Scheme::PositionNewmark => MassKind::Redistributed,
        }
    }

    /// The scheme and its mass, in words for reports.
    pub fn description(&self) -> String {
        match *self {
            Scheme::MoreauJean { theta, restitution } => {
                format!("Moreau-Jean (theta = {theta}, e_N = {restitution}), consistent mass")
            }
            Scheme::PositionNewmark => "position-level Newmark, redistributed mass".to_string(),
        }
    }

    /// Short name for reports (`"moreau-jean"`, `"position-newmark"`).
    pub fn name(&self) -> &'static str {
        match self {
            Scheme::MoreauJean { .. } => "moreau-jean",
            Scheme::PositionNewmark => "position-newmark",
        }
    }
}

/// Settings of an [`Integrator`].
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Time step `h > 0`.
    pub dt: f64,
    pub scheme: Scheme,
    /// Angular frequency ω [rad/s] of the harmonic load `F cos ωt`; required when the
    /// system has a non-zero harmonic load, ignored otherwise.
    pub omega: Option<f64>,
    /// Constant added to the energy (e.g. [`fall_energy`]).
    pub energy_offset: f64,
}

/// Energy offset that puts the datum of a free body's potential energy at the first
/// contact: for a model without Dirichlet DOFs under a uniform acceleration `a`, the work
/// of the acceleration load while the body translates rigidly along `a` from `q = 0` until
/// a contact closes (`m |a| h0` for the dropped bar: docs/theory.md (T69)). Zero when the model is
/// held (Dirichlet DOFs), has no acceleration field, or no contact closes along `a`.
pub fn fall_energy(model: &Model, system: &System) -> f64 {
    let Some(acc) = &model.acceleration else {
        return 0.0;
    };
    if !model.dirichlet.is_empty() {
        return 0.0;
    }
    let norm = acc.iter().map(|a| a * a).sum::<f64>().sqrt();
    if norm == 0.0 {
        return 0.0;
    }
    let dpn = model.dofs_per_node;
    // unit translation along a, system numbering (no Dirichlet DOFs: system = model DOFs)
    let d: Vec<f64> = system
        .model_dof
        .iter()
        .map(|&m| acc[m % dpn] / norm)
        .collect();
    let mut distance = f64::INFINITY;
    for c in &system.contacts {
        let rate: f64 = c.w.iter().map(|&(i, w)| w * d[i]).sum();
        if rate < 0.0 && c.gap >= 0.0 {
            distance = distance.min(c.gap / -rate);
        }
    }
    if !distance.is_finite() {
        return 0.0;
    }
    // f_acc = M (1 ⊗ a) = |a| M d;  offset = distance · f_accᵀ d
    let md = system.mass.mul_vec(&d);
    distance * norm * d.iter().zip(&md).map(|(a, b)| a * b).sum::<f64>()
}

/// The parameters of the Moreau–Jean scheme (docs/theory.md (T59)–(T60)): `θ ∈ [½, 1]` and the Newton
/// restitution coefficient `e_N ∈ [0, 1]`.
pub(crate) fn check_moreau_jean(theta: f64, restitution: f64) -> Result<()> {
    if !(theta.is_finite() && (0.5..=1.0).contains(&theta)) {
        return Err(Error::argument(
            "theta",
            format!("must lie in [0.5, 1], got {theta}"),
        ));
    }
    if !(restitution.is_finite() && (0.0..=1.0).contains(&restitution)) {
        return Err(Error::argument(
            "restitution",
            format!("the restitution coefficient must lie in [0, 1], got {restitution}"),
        ));
    }
    Ok(())
}
