//! Floquet multipliers of periodic solutions (docs/theory.md §11).
//!
//! A periodic solution is asymptotically stable when every Floquet multiplier (eigenvalue
//! of the monodromy matrix, the linearised map over one period) lies inside the unit circle
//! (docs/theory.md (T79)). A real multiplier leaving through +1 is a fold (turning point of
//! the FRD), through −1 a period doubling, a complex pair a Neimark–Sacker bifurcation.

use faer::linalg::solvers::Solve;
use faer::{c64, Mat};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::sparse::SparseMatrix;

mod held;
mod piecewise;

pub use held::HeldPhase;

pub use piecewise::{piecewise_monodromy, PiecewiseLinearSystems, RealModalForm};

/// Floquet multipliers of one periodic solution.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Floquet {
    /// Multipliers as `[re, im]` pairs, largest modulus first.
    pub multipliers: Vec<[f64; 2]>,
    /// Largest modulus.
    pub max_multiplier: f64,
    /// All multipliers inside the unit circle (to `1e-9`).
    pub stable: bool,
}

impl Floquet {
    /// From the eigenvalues of a monodromy matrix.
    pub fn from_eigenvalues(mut values: Vec<c64>) -> Self {
        values.sort_by(|a, b| b.norm().total_cmp(&a.norm()));
        let max_multiplier = values.first().map_or(0.0, |v| v.norm());
        Floquet {
            multipliers: values.iter().map(|v| [v.re, v.im]).collect(),
            max_multiplier,
            stable: max_multiplier < 1.0 - 1e-9,
        }
    }
}

/// Largest linear part analysed in the full basis by default ([`StabilityOptions::modes`]
/// `= None`); larger ones use [`DEFAULT_STABILITY_MODES`] fixed-interface modes.
pub const FULL_BASIS_DEFAULT_LIMIT: usize = 200;

/// Fixed-interface modes of the default reduced basis (see [`ReducedSystem`]).
pub const DEFAULT_STABILITY_MODES: usize = 100;

/// Largest subspace block `n_L × 2m` (values) that the *default* reduced basis computes:
/// its fixed-interface modes come from a subspace iteration whose cost grows as
/// `n_L (2m)²` per iteration. At this size (the bar with 20 000 elements and the default
/// 100 modes) the Floquet analysis takes about 10 s, fifty times the solve itself; the
/// 200 000-element bar would take minutes. Above it the default skips the stability with a
/// note; an explicit number of modes is computed whenever it fits the memory limit.
pub const DEFAULT_REDUCED_BLOCK_LIMIT: usize = 4_000_000;

/// Dense matrices alive at once in the full-space Floquet analysis, in units of `n_L²`
/// values: `M̄`, its LU, `K_LL`, `C`, `M̄⁻¹K`, `M̄⁻¹C` (6), the first-order matrix per active
/// set and its exponential (2 × 4), the complex modal exponential (2 × 8 real).
const FULL_SPACE_MATRICES: u64 = 30;

/// Subspace blocks of `n_L × 2m` alive at once in the reduced basis (iterate, `M X`,
/// `K⁻¹ M X`, its thin QR, `K Y`, `M Y`, Ritz vectors, static modes); measured on the bar
/// with 20 000 elements: 266 MB above the solve for blocks of 32 MB.
const REDUCED_BASIS_BLOCKS: u64 = 8;

/// Bytes of the full-space Floquet analysis of a linear part of `n_linear` DOFs.
pub fn full_space_bytes(n_linear: usize) -> Option<u64> {
    crate::limits::dense_f64_bytes(n_linear, n_linear)?.checked_mul(FULL_SPACE_MATRICES)
}

/// Bytes of the reduced basis of `modes` fixed-interface modes of a linear part of
/// `n_linear` DOFs (the subspace iteration's blocks of `n_linear × 2·modes`).
pub fn reduced_basis_bytes(n_linear: usize, modes: usize) -> Option<u64> {
    crate::limits::dense_f64_bytes(n_linear, modes.checked_mul(2)?)?
        .checked_mul(REDUCED_BASIS_BLOCKS)
}

/// Settings of the Floquet analysis of the redistributed MS-HBM.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StabilityOptions {
    /// Number of fixed-interface modes of the reduced basis ([`ReducedSystem`]), or the
    /// full L-space when this is at least the number of L-DOFs. `None`: the full space up to
    /// [`FULL_BASIS_DEFAULT_LIMIT`] L-DOFs, [`DEFAULT_STABILITY_MODES`] modes above.
    pub modes: Option<usize>,
}

impl StabilityOptions {
    /// The number of fixed-interface modes to use for a linear part of `n_linear` DOFs, or
    /// `None` for the full space.
    pub fn modes_for(&self, n_linear: usize) -> Option<usize> {
        match self.modes {
            Some(m) if m < n_linear => Some(m),
            Some(_) => None,
            None if n_linear <= FULL_BASIS_DEFAULT_LIMIT => None,
            None => Some(DEFAULT_STABILITY_MODES.min(n_linear)),
        }
    }
}

/// The linearised L-system of the redistributed MS-HBM (docs/theory.md (T80)),
/// `M̄ q̈ + C q̇ + (K_LL − K_LN P_A(t) K_NL) q = 0` (the sensitivity `∂q_N/∂q_L = −P_A K_NL`
/// of (T39)), in the coordinates of the Floquet
/// analysis: the full L-space, or a reduced basis ([`ReducedSystem::reduced`]).
///
/// **Reduced basis** (modal truncation with static correction, the "mode-acceleration"
/// idea applied per active set): `q = Φ_m η + Ψ̃ ξ`, with `Φ_m` the `m` lowest
/// fixed-interface modes (`K_LL φ = ω² M̄_LL φ` with the contact DOFs held, mass-normalised)
/// and `Ψ̃` the part of the static interface response `Ψ = K_LL⁻¹ K_LN` that is
/// `M̄`-orthogonal to `Φ_m` (then also `K_LL`-orthogonal: `Φᵀ K_LL Ψ̃ = Λ Φᵀ M̄ Ψ̃ = 0`). The
/// modal coordinates `η` carry the inertia; the residual coordinates `ξ` (the quasi-static
/// response of the discarded modes) are given no mass and no damping and are condensed
/// statically for every active set, like the contact DOFs themselves:
/// `K_r(A) = K_ηη(A) − K_ηξ(A) K_ξξ(A)⁻¹ K_ξη(A)` with the blocks of
/// `[Φ, Ψ̃]ᵀ (K_LL − K_LN P_A K_NL) [Φ, Ψ̃]`, and
/// `η̈ + Φᵀ C Φ η̇ + K_r(A(t)) η = 0` (docs/theory.md (T82)). For mass-proportional and for
/// Rayleigh damping (`C = α M̄ + β K_LL`) the dropped coupling `Φᵀ C Ψ̃` vanishes. Every
/// active set's stiffness differs from `K_LL` only through `K_LN`, so the static correction
/// makes each `K_eff(A)` exact in the static limit (the reduced static response to loads in
/// the span of `M̄ Φ_m` and of the interface is exact).
///
/// **Truncation error.** The reduced system has `2m` multipliers instead of `2 n_L`; the
/// multipliers of the discarded modes are not computed. Between two switches the discarded
/// modes follow slow motions quasi-statically (relative error of order `(ω/ω_{m+1})²`, the
/// mode-acceleration argument), but every switch of the active set is a jump of the
/// stiffness at the interface, which excites all modes; what the full model does with that
/// energy in the discarded modes (dissipate it where the damping grows with frequency, or
/// let it ring) is missing from the reduced one. The multipliers therefore converge only
/// algebraically in `m`, and in general from above (less dissipation). Measured on the
/// 400-element bar at 30 kHz, `H = 5`, Rayleigh damping (`tests/stability.rs`,
/// `reduced_basis_multipliers_converge_to_the_full_space`): largest modulus 0.70, 0.58,
/// 0.40, 0.20, 0.057 for `m` = 10, 20, 40, 80, 160 against 0.017 in the full space. With
/// mass-proportional damping alone (every mode decays at the same rate) the error at
/// `m` = 80–160 was 0.016–0.04 and not monotone (survey in the same file). The stable/unstable
/// verdict agreed with the full space from `m = 20` on in all six cases of the survey
/// (30, 60, 90 kHz, both dampings), but an instability of a discarded mode (a parametric
/// resonance of a high, lightly damped mode) would be missed: use the full space when the
/// verdict matters and the model allows it. (Keeping `Ψ̃` as a dynamic coordinate instead
/// gives one spurious "residual mode" that the contact switches on and off and that
/// resonates parametrically: on the bar it produced multipliers up to 5.8 where the full
/// space has 0.95.)
#[derive(Clone, Debug)]
pub struct ReducedSystem {
    /// `M⁻¹ C` in the coordinates (`r × r`; in the modal coordinates `M = I`).
    minv_damping: Mat<f64>,
    /// `M⁻¹ K_LL`.
    minv_stiffness: Mat<f64>,
    /// `M⁻¹ K_LN` (`r × n_N`).
    minv_coupling: Mat<f64>,
    /// `K_NL` (`n_N × r`).
    coupling: Mat<f64>,
    /// Residual (statically condensed) coordinates: `Ψ̃ᵀ K_LL Ψ̃` and `K_NL Ψ̃`.
    residual: Option<(Mat<f64>, Mat<f64>)>,
    /// Balancing frequency of the first-order form (~ the highest frequency).
    w_ref: f64,
    /// Fixed-interface modes in the basis (`None`: full space).
    modes: Option<usize>,
    /// `K_NN⁻¹` (`n_N × n_N`) when the basis is built on the relaxed interface: the
    /// active-set compliance enters as `P_A − K_NN⁻¹` (see [`InterfaceModes`]).
    compliance_shift: Option<Mat<f64>>,
}

/// The interface condition of the modes of a reduced Floquet basis (docs/theory.md (T82),
/// (T121)). The basis is `[Φ_m, Ψ̃]` with `Φ_m` the lowest modes of `(K_b, M̄)` and `Ψ̃` the
/// part of `K_b⁻¹ K_LN` that is `M̄`-orthogonal to them, so that `Φ_mᵀ K_b Ψ̃ = 0`; the
/// dropped damping coupling `Φ_mᵀ C Ψ̃` vanishes when `C = α M̄ + β K_b`. Every active set
/// is `K_eff(A) = K_b − K_LN (P_A − D) K_NL` with `D = 0` (held) or `K_NN⁻¹` (relaxed).
#[derive(Clone, Copy, Debug)]
pub enum InterfaceModes<'a> {
    /// `K_b = K_LL`, the contact DOFs held: exact coupling for `α M̄ + β_L K_LL`.
    Held,
    /// `K_b = S = K_LL − K_LN K_NN⁻¹ K_NL`, the contact DOFs following statically: exact
    /// coupling for `α M̄ + β_c S` (`damping.beta_condensed`), whose damping ratios are
    /// then those of the modes themselves.
    Relaxed {
        /// `K_NN`.
        k_nn: &'a SparseMatrix,
    },
}

impl ReducedSystem {
    /// The full L-space, dense.
    pub fn full(
        mass: &SparseMatrix,
        damping: &SparseMatrix,
        stiffness: &SparseMatrix,
        k_nl: &SparseMatrix,
    ) -> Result<Self> {
        let lu = mass.to_dense().partial_piv_lu();
        let minv_stiffness = lu.solve(stiffness.to_dense());
        Ok(Self::balanced(
            lu.solve(damping.to_dense()),
            minv_stiffness,
            lu.solve(k_nl.to_dense().transpose()),
            k_nl.to_dense(),
            None,
            None,
        ))
    }

    /// The basis of `modes` interface modes (held or relaxed, [`InterfaceModes`]) with the
    /// statically condensed interface correction (see the type's docs). `stiffness = K_LL`
    /// must be positive definite (the structure held with the contact DOFs fixed, true when
    /// the whole structure is held).
    pub fn reduced(
        mass: &SparseMatrix,
        damping: &SparseMatrix,
        stiffness: &SparseMatrix,
        k_nl: &SparseMatrix,
        modes: usize,
        interface: InterfaceModes,
    ) -> Result<Self> {
        // the base stiffness K_b: K_LL itself (borrowed) or the Schur complement S
        let (stiffness, compliance_shift) = match interface {
            InterfaceModes::Held => (std::borrow::Cow::Borrowed(stiffness), None),
            InterfaceModes::Relaxed { k_nn } => {
                let not_pd = || {
                    Error::Singular(
                        "the stiffness of the contact DOFs with the rest held (K_NN) is not positive definite".into(),
                    )
                };
                let s =
                    crate::sparse::schur_complement(stiffness, k_nl, k_nn).ok_or_else(not_pd)?;
                let llt = k_nn
                    .to_faer()
                    .sp_cholesky(faer::Side::Lower)
                    .map_err(|_| not_pd())?;
                let mut inverse = Mat::<f64>::identity(k_nn.nrows(), k_nn.ncols());
                llt.solve_in_place(inverse.as_mut());
                (std::borrow::Cow::Owned(s), Some(inverse))
            }
        };
        let stiffness: &SparseMatrix = &stiffness;
        // one factor of K_LL for the modes and for Ψ
        let llt = crate::modes::stiffness_factor(stiffness).map_err(|_| {
            Error::Singular(
                "the stiffness of the linear part with the contact DOFs held (K_LL) is not positive definite".into(),
            )
        })?;
        let modes = crate::modes::lowest_modes_factored(mass, stiffness, Some(&llt), modes)?;
        let phi = &modes.shapes;
        // Ψ = K_LL⁻¹ K_LN, then its part M̄-orthogonal to Φ
        let mut psi = k_nl.to_dense().transpose().to_owned();
        llt.solve_in_place(psi.as_mut());
        // K-norm scale of Ψ (ΨᵀK_LLΨ = K_NL Ψ): what is left after removing the modes'
        // part is measured against it
        let scale = {
            let g = k_nl.to_faer() * &psi;
            (0..g.nrows()).fold(0.0f64, |m, i| m.max(g[(i, i)].abs()))
        };
        let m_phi = mass.to_faer() * phi;
        let psi = &psi - phi * (m_phi.transpose() * &psi);
        let psi = independent_columns(&psi, &(stiffness.to_faer() * &psi), scale);
        let coupling = k_nl.to_faer() * phi;
        let residual = (psi.ncols() > 0).then(|| {
            let k_psi = psi.transpose() * (stiffness.to_faer() * &psi);
            (k_psi, k_nl.to_faer() * &psi)
        });
        // Φᵀ M̄ Φ = I, Φᵀ K_LL Φ = Λ
        let lambda = Mat::<f64>::from_fn(phi.ncols(), phi.ncols(), |i, j| {
            if i == j {
                modes.eigenvalues[i]
            } else {
                0.0
            }
        });
        let mut reduced = Self::balanced(
            phi.transpose() * (damping.to_faer() * phi),
            lambda,
            coupling.transpose().to_owned(),
            coupling,
            residual,
            Some(phi.ncols()),
        );
        reduced.compliance_shift = compliance_shift;
        Ok(reduced)
    }

    fn balanced(
        minv_damping: Mat<f64>,
        minv_stiffness: Mat<f64>,
        minv_coupling: Mat<f64>,
        coupling: Mat<f64>,
        residual: Option<(Mat<f64>, Mat<f64>)>,
        modes: Option<usize>,
    ) -> Self {
        let r = minv_stiffness.nrows();
        // the largest column sum of M̄⁻¹ K bounds the largest ω². Balanced at that frequency
        // however low it is (it was clamped at 1 rad/s: a bar 5·10¹⁹ times too heavy then
        // had blocks 1 and 10⁻²⁰ apart, no modal form and a nearly defective monodromy,
        // issue 46); 1 only for a structure without stiffness
        let w_ref = (0..r)
            .map(|j| (0..r).map(|i| minv_stiffness[(i, j)].abs()).sum::<f64>())
            .fold(0.0f64, f64::max)
            .sqrt();
        let w_ref = if w_ref.is_normal() { w_ref } else { 1.0 };
        ReducedSystem {
            minv_damping,
            minv_stiffness,
            minv_coupling,
            coupling,
            residual,
            w_ref,
            modes,
            compliance_shift: None,
        }
    }

    /// Number of (dynamic) coordinates `r`: the first-order system has `2r`.
    pub fn dimension(&self) -> usize {
        self.minv_stiffness.nrows()
    }

    /// Fixed-interface modes in the basis (`None`: the full space).
    pub fn modes(&self) -> Option<usize> {
        self.modes
    }

    /// `M⁻¹ K_eff(A)` in the coordinates for the active set with compliance `P_A`
    /// (`n_N × n_N`, row-major), the residual coordinates condensed.
    pub fn effective_stiffness(&self, compliance: &[f64]) -> Result<Mat<f64>> {
        let n = self.coupling.nrows();
        let mut p = Mat::<f64>::from_fn(n, n, |i, j| compliance[i * n + j]);
        if let Some(d) = &self.compliance_shift {
            p -= d;
        }
        let mut k_eff = &self.minv_stiffness - &self.minv_coupling * (&p * &self.coupling);
        if let Some((k_psi, b_psi)) = &self.residual {
            // K_ηξ = −B_ηᵀ P B_ξ, K_ξξ = Ψ̃ᵀ K_LL Ψ̃ − B_ξᵀ P B_ξ (η has unit mass)
            let k_eta_xi = -(&self.minv_coupling * (&p * b_psi));
            let k_xi_xi = k_psi - b_psi.transpose() * (&p * b_psi);
            let lu = k_xi_xi.full_piv_lu();
            let x = lu.solve(k_eta_xi.transpose());
            if x.col_iter().any(|c| c.iter().any(|v| !v.is_finite())) {
                return Err(Error::Singular(
                    "the residual stiffness of the reduced stability basis is singular".into(),
                ));
            }
            k_eff -= &k_eta_xi * x;
        }
        Ok(k_eff)
    }

    /// First-order matrix for the active set with compliance `P_A` (`n_N × n_N`,
    /// row-major): state `z = (w η, η̇)` with `w` ~ the highest frequency, which balances
    /// the blocks (a similarity: multipliers unchanged) and keeps exponentials accurate.
    pub fn state_matrix(&self, compliance: &[f64]) -> Result<Mat<f64>> {
        let k_eff = self.effective_stiffness(compliance)?;
        Ok(self.first_order(&k_eff))
    }

    /// The balanced first-order matrix `[[0, w I], [−K/w, −M⁻¹C]]` of the stiffness `k_eff`
    /// (`M⁻¹ K` in the coordinates), state `z = (w η, η̇)`.
    fn first_order(&self, k_eff: &Mat<f64>) -> Mat<f64> {
        let r = self.dimension();
        let w = self.w_ref;
        Mat::<f64>::from_fn(2 * r, 2 * r, |i, j| match (i < r, j < r) {
            (true, true) => 0.0,
            (true, false) => {
                if j - r == i {
                    w
                } else {
                    0.0
                }
            }
            (false, true) => -k_eff[(i - r, j)] / w,
            (false, false) => -self.minv_damping[(i - r, j - r)],
        })
    }
}

/// A basis of the span of the columns of `v` (given `K v`), `K`-orthonormal; directions
/// whose squared `K`-norm is below `1e-10 scale` (linearly dependent columns, or a static
/// response already in the span of the modes) are dropped.
fn independent_columns(v: &Mat<f64>, kv: &Mat<f64>, scale: f64) -> Mat<f64> {
    let gram = v.transpose() * kv;
    let gram = (&gram + gram.transpose()) * 0.5;
    let Ok(eig) = gram.self_adjoint_eigen(faer::Side::Lower) else {
        return Mat::zeros(v.nrows(), 0);
    };
    let keep: Vec<usize> = (0..gram.nrows())
        .filter(|&i| eig.S()[i] > 1e-10 * scale)
        .collect();
    let u = eig.U();
    let whiten = Mat::<f64>::from_fn(gram.nrows(), keep.len(), |i, j| {
        u[(i, keep[j])] / eig.S()[keep[j]].sqrt()
    });
    v * whiten
}

/// How a multiplier leaves (or enters) the unit circle between two neighbouring solutions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Crossing {
    /// A real multiplier through +1 (fold, or branch point).
    Fold,
    /// A real multiplier through −1 (period doubling).
    PeriodDoubling,
    /// A complex pair through the unit circle (Neimark–Sacker, quasi-periodic motion).
    NeimarkSacker,
}

/// Numbers of multipliers outside the unit circle: (real positive, real negative, complex).
pub fn outside_counts(f: &Floquet) -> (usize, usize, usize) {
    let tol = 1e-9;
    let mut counts = (0, 0, 0);
    for m in &f.multipliers {
        if m[0].hypot(m[1]) <= 1.0 + tol {
            continue;
        }
        if m[1].abs() > 1e-9 * m[0].hypot(m[1]) {
            counts.2 += 1;
        } else if m[0] > 0.0 {
            counts.0 += 1;
        } else {
            counts.1 += 1;
        }
    }
    counts
}

/// The crossings of the unit circle between two neighbouring solutions of a branch.
pub fn crossings(before: &Floquet, after: &Floquet) -> Vec<Crossing> {
    let (a, b) = (outside_counts(before), outside_counts(after));
    let mut out = Vec::new();
    if a.0 != b.0 {
        out.push(Crossing::Fold);
    }
    if a.1 != b.1 {
        out.push(Crossing::PeriodDoubling);
    }
    if a.2 != b.2 {
        out.push(Crossing::NeimarkSacker);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn floquet(values: &[(f64, f64)]) -> Floquet {
        Floquet::from_eigenvalues(values.iter().map(|&(re, im)| c64::new(re, im)).collect())
    }

    #[test]
    fn crossings_are_classified_by_where_the_multiplier_leaves() {
        let inside = floquet(&[(0.9, 0.0), (-0.5, 0.0), (0.3, 0.4), (0.3, -0.4)]);
        assert!(inside.stable);
        assert_eq!(
            crossings(
                &inside,
                &floquet(&[(1.1, 0.0), (-0.5, 0.0), (0.3, 0.4), (0.3, -0.4)])
            ),
            vec![Crossing::Fold]
        );
        assert_eq!(
            crossings(
                &inside,
                &floquet(&[(0.9, 0.0), (-1.2, 0.0), (0.3, 0.4), (0.3, -0.4)])
            ),
            vec![Crossing::PeriodDoubling]
        );
        assert_eq!(
            crossings(
                &inside,
                &floquet(&[(0.9, 0.0), (-0.5, 0.0), (0.6, 0.9), (0.6, -0.9)])
            ),
            vec![Crossing::NeimarkSacker]
        );
        assert!(crossings(&inside, &inside).is_empty());
    }
}
