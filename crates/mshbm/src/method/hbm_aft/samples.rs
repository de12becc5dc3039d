//! The state of the HBM-AFT's samples at one iterate: the penalty law's gaps, forces and
//! displacements (`penalty.rs`), the Jenkins elements' sliders (`jenkins.rs`, (T162)) and the
//! groups of samples with the same active penalty springs.

/// Contact state of the samples at one `x`.
pub(super) struct ContactState {
    /// Penalty force `λ_c(τ_j)` (`j·n_c + c`).
    pub(super) force: Vec<f64>,
    /// Gap `g_c(τ_j)` (`j·n_c + c`).
    pub(super) gap: Vec<f64>,
    /// `q_N(τ_j)` (`j·n + i`).
    pub(super) displacement: Vec<f64>,
    /// The Jenkins elements of the frictional contacts (docs/theory.md (T162)); `None`
    /// without friction.
    pub(super) slider: Option<SliderState>,
}

/// Samples (sampled quadrature) or intervals (exact) over which the same penalty springs act:
/// the penalty force there is `−K_A q_N − s_A`, and its Fourier coefficients `−(Γ_A ⊗ K_A) x −
/// Γ_A[:,0] ⊗ s_A`.
pub(super) struct PenaltyGroup {
    /// `Γ_A` (`(2H+1)²`, row-major).
    pub(super) gram: Vec<f64>,
    /// `K_A = Σ_{c∈A} k_p,c w_c w_cᵀ` (`n × n`, row-major).
    pub(super) stiffness: Vec<f64>,
}

/// The state of the slider of one contact at one sample (T162).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SliderMode {
    /// No friction limit (the contact is open, or `μ = 0`): the slider follows, `λ_T = 0`.
    Free,
    /// The slider holds: `λ_T = −k_t (u_T − a)` with `|λ_T| ≤ μ λ_N`.
    Stick,
    /// The slider is dragged forward (`a = u_T − μλ_N/k_t`): `λ_T = −μ λ_N`.
    SlipPositive,
    /// The slider is dragged back (`a = u_T + μλ_N/k_t`): `λ_T = +μ λ_N`.
    SlipNegative,
}

/// One term `weight · α_sᵀ dq_s` of the derivative of a stuck slider's position (T165).
#[derive(Clone, Debug)]
pub(super) struct AnchorTerm {
    pub(super) sample: usize,
    pub(super) weight: f64,
    /// `α_s` (`n`).
    pub(super) alpha: Vec<f64>,
}

/// A maximal run of stuck samples of one contact and the derivative of its slider position.
#[derive(Clone, Debug)]
pub(super) struct StickRun {
    pub(super) contact: usize,
    pub(super) samples: Vec<usize>,
    pub(super) anchor: Vec<AnchorTerm>,
}

/// The Jenkins elements at the samples.
pub(super) struct SliderState {
    /// `λ_T,c(τ_j)` (`j·n_c + c`).
    pub(super) force: Vec<f64>,
    /// `μ_c λ_N,c(τ_j)` (`j·n_c + c`).
    pub(super) limit: Vec<f64>,
    pub(super) modes: Vec<SliderMode>,
    pub(super) runs: Vec<StickRun>,
}
