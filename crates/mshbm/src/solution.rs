//! A periodic solution as reported to users (`mshbm solve --json`, FRD points).

use serde::{Deserialize, Serialize};

/// The periodic-solution methods (names as in `mshbm --method` and in every output).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum MethodKind {
    /// The redistributed MS-HBM (paper Section 3): massless contact boundary, static
    /// contact per sample, semi-analytical Jacobian.
    #[serde(rename = "redistributed")]
    Redistributed,
    /// The general MS-HBM (paper Section 2): the nonlinear subsystem integrated over one
    /// period by Moreau–Jean time stepping.
    #[serde(rename = "mshbm")]
    General,
    /// The HBM-AFT baseline with penalty contact.
    #[serde(rename = "hbm-aft")]
    HbmAft,
    /// A steady state found by time integration of the whole model (the reference).
    #[serde(rename = "time-integration")]
    TimeIntegration,
}

impl MethodKind {
    /// The name used on the command line and in outputs.
    pub fn name(self) -> &'static str {
        match self {
            MethodKind::Redistributed => "redistributed",
            MethodKind::General => "mshbm",
            MethodKind::HbmAft => "hbm-aft",
            MethodKind::TimeIntegration => "time-integration",
        }
    }
}

impl std::fmt::Display for MethodKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Time series and harmonics of one contact.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ContactSeries {
    /// The contact's (first) DOF, model numbering.
    pub dof: usize,
    /// Fourier coefficients `[a0, a1, b1, …, aH, bH]` of that DOF's displacement.
    pub coefficients: Vec<f64>,
    /// Displacement of the DOF at `time_s`.
    pub displacement: Vec<f64>,
    /// Gap `g = Wᵀ q + g0` at `time_s`.
    pub gap: Vec<f64>,
    /// Contact force `λ ≥ 0` at `time_s`.
    pub force: Vec<f64>,
    /// Max and min of the displacement over the period (of the time signal, not of the
    /// truncated series).
    pub max: f64,
    pub min: f64,
}

/// The state of a frictional contact (docs/theory.md (T151), (T181)).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Hash)]
#[serde(rename_all = "lowercase")]
pub enum ContactState {
    /// Gap open, no force.
    Open,
    /// Closed, the tangential displacement held.
    Stick,
    /// Closed and slipping (a closed contact without friction counts as slipping).
    Slip,
}

impl ContactState {
    /// The name in outputs: `open`, `stick`, `slip`.
    pub fn name(self) -> &'static str {
        match self {
            ContactState::Open => "open",
            ContactState::Stick => "stick",
            ContactState::Slip => "slip",
        }
    }
}

/// The fractions of the period a frictional contact spends in each state (they sum to 1),
/// exact from the located switches (docs/theory.md (T181)).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub struct StateFractions {
    pub stick: f64,
    pub slip: f64,
    pub open: f64,
}

impl StateFractions {
    /// The mean over contacts (`None` without any).
    pub fn mean(fractions: &[StateFractions]) -> Option<StateFractions> {
        if fractions.is_empty() {
            return None;
        }
        let n = fractions.len() as f64;
        Some(StateFractions {
            stick: fractions.iter().map(|f| f.stick).sum::<f64>() / n,
            slip: fractions.iter().map(|f| f.slip).sum::<f64>() / n,
            open: fractions.iter().map(|f| f.open).sum::<f64>() / n,
        })
    }
}

/// Force of one Coulomb friction element over the period: a friction element of the
/// general MS-HBM, or the tangential force of a contact with friction (redistributed
/// MS-HBM; then `frictions[c]` belongs to `contacts[c]`).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct FrictionSeries {
    /// The element's (first) DOF, model numbering.
    pub dof: usize,
    /// Friction force `P_T/h` of the time step ending at each of `time_s` (the first entry
    /// belongs to the last step of the period).
    pub force: Vec<f64>,
    /// Its limit in that step: `μ F_N` (prescribed normal force) or `μ λ_N` (the force of
    /// the coupled contact); `|force| ≤ limit` at every step.
    pub limit: Vec<f64>,
    /// Largest and smallest force over the period.
    pub max: f64,
    pub min: f64,
    /// A contact in space (the Coulomb cone, docs/theory.md (T185)): the friction force
    /// along its second tangent at each instant, `|(force, force2)| ≤ limit` (empty
    /// otherwise; `force`, `max` and `min` are along the first tangent).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub force2: Vec<f64>,
    /// A contact with friction: its state at each of `time_s` (empty for the general
    /// MS-HBM's friction elements).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub state: Vec<ContactState>,
}

/// Harmonics and extremes of the response DOF.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct DofResponse {
    /// Model DOF.
    pub dof: usize,
    pub coefficients: Vec<f64>,
    pub max: f64,
    pub min: f64,
}

/// What a frequency response diagram keeps of a periodic solution
/// ([`crate::problem::PeriodicProblem::diagram_point`]).
#[derive(Clone, Debug, PartialEq)]
pub struct DiagramPoint {
    pub frequency_hz: f64,
    /// The response DOF's harmonics and extremes.
    pub response: DofResponse,
    /// As [`PeriodicSolution::residual_norm`].
    pub residual_norm: f64,
    /// HBM-AFT (penalty contact): the largest penetration `max(−g)` over the contacts and
    /// the time samples.
    pub max_penetration: Option<f64>,
    /// Contacts with friction: as [`PeriodicSolution::dissipated_energy`].
    pub dissipated_energy: Option<f64>,
    /// Contacts with friction: as [`PeriodicSolution::state_fractions`].
    pub state_fractions: Option<Vec<StateFractions>>,
}

impl DiagramPoint {
    /// The point of a whole solution.
    pub fn of(s: &PeriodicSolution) -> Self {
        DiagramPoint {
            frequency_hz: s.frequency_hz,
            response: s.response.clone(),
            residual_norm: s.residual_norm,
            max_penetration: (s.method == MethodKind::HbmAft).then(|| {
                s.contacts
                    .iter()
                    .flat_map(|c| c.gap.iter())
                    .fold(f64::NEG_INFINITY, |m, g| m.max(-g))
            }),
            dissipated_energy: s.dissipated_energy,
            state_fractions: s.state_fractions.clone(),
        }
    }
}

/// One periodic solution.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct PeriodicSolution {
    pub frequency_hz: f64,
    pub harmonics: usize,
    pub samples: usize,
    /// How the Fourier coefficients were computed.
    pub quadrature: crate::harmonic::Quadrature,
    pub method: MethodKind,
    pub converged: bool,
    pub iterations: usize,
    /// `‖R‖_∞` relative to the problem's length scale.
    pub residual_norm: f64,
    /// Sample times over one period (s).
    pub time_s: Vec<f64>,
    /// Model DOFs of the contacts (first DOF of each).
    pub contact_dofs: Vec<usize>,
    pub contacts: Vec<ContactSeries>,
    /// Friction elements (general MS-HBM; empty otherwise).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub frictions: Vec<FrictionSeries>,
    pub response: DofResponse,
    /// Floquet multipliers and stability, when computed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stability: Option<crate::stability::Floquet>,
    /// Why the stability is unknown: the multipliers were asked for and could not be
    /// computed (an eigenvalue problem that did not converge, a monodromy that is not
    /// finite); `stability` is then `None`. `None` when they were computed or not asked for.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stability_unknown: Option<String>,
    /// The method's unknowns `x` (e.g. the harmonics of every contact-node DOF of the
    /// redistributed MS-HBM, eq. 31), so that a later solve can start from this solution
    /// (`mshbm solve --from-solution`); set by [`crate::solve::solve_periodic`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unknowns: Option<Vec<f64>>,
    /// The harmonics `q̂_N` of every contact-node DOF (harmonic-major, coefficient `c` of
    /// `N` DOF `i` at `c·n_N + i`; the paper's unknowns of eq. 31), when the method's own
    /// unknowns are others (the redistributed MS-HBM solves for the free gap,
    /// docs/theory.md §16).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_node_harmonics: Option<Vec<f64>>,
    /// The energy the friction forces dissipate per period (contacts with Coulomb friction,
    /// docs/theory.md §20), in the model's force × length unit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dissipated_energy: Option<f64>,
    /// Contacts with friction: the fractions of the period each contact spends stuck,
    /// slipping and open (docs/theory.md (T181)), in the order of `contact_dofs`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state_fractions: Option<Vec<StateFractions>>,
}

impl PeriodicSolution {
    /// Why this solution cannot start Newton for `method` on `model`
    /// (`mshbm solve --from-solution`), or `None` when it can (a solution of `method`, or a
    /// steady state of the time integration for the redistributed MS-HBM): its unknowns are
    /// those of another method (the HBM-AFT's harmonics of the nonlinear DOFs are not the redistributed
    /// MS-HBM's free gap), or its contacts are not the model's (another model's solution
    /// with as many unknowns would be accepted silently otherwise).
    pub fn unusable_start(&self, model: &crate::Model, method: MethodKind) -> Option<String> {
        // a steady state of the time integration carries the redistributed MS-HBM's
        // unknowns (the contacts' displacements, docs/theory.md (T128)) for this start
        let simulated = self.method == MethodKind::TimeIntegration
            && method == MethodKind::Redistributed
            && self.unknowns.is_some();
        if self.method != method && !simulated {
            return Some(format!(
                "it is a solution of the method {}, not of {method}: its unknowns mean something else",
                self.method
            ));
        }
        self.other_model(model)
    }

    /// Why this solution belongs to another model than `model` (its contacts are not the
    /// model's), or `None`: no start from it, by Newton ([`PeriodicSolution::unusable_start`])
    /// or by a time integration ([`crate::simulation::state_from_solution`]).
    pub fn other_model(&self, model: &crate::Model) -> Option<String> {
        let contacts: Vec<usize> = model.contacts.iter().map(|c| c.dofs[0]).collect();
        if self.contact_dofs != contacts {
            let shown = |v: &[usize]| -> String {
                let head: Vec<String> = v.iter().take(5).map(|d| d.to_string()).collect();
                let more = if v.len() > 5 { ", …" } else { "" };
                format!("{} contacts at DOFs [{}{more}]", v.len(), head.join(", "))
            };
            return Some(format!(
                "it belongs to another model: it has {}, the model {}",
                shown(&self.contact_dofs),
                shown(&contacts)
            ));
        }
        None
    }
}

impl DofResponse {
    /// `√(a1² + b1²)`, the first-harmonic amplitude.
    pub fn amplitude_h1(&self) -> f64 {
        if self.coefficients.len() >= 3 {
            self.coefficients[1].hypot(self.coefficients[2])
        } else {
            0.0
        }
    }
}
