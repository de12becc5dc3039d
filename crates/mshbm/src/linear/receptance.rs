//! The receptance of a structure at its contacts, per harmonic and frequency
//! (docs/theory.md (T125)): the condensation of the whole linear structure onto the
//! contact coordinates `g = Wᵀ q + g0`.
//!
//! For harmonic `k` the whole structure (with the redistributed mass, its massless contact
//! nodes included) responds to the contact forces `λ̂_k` by
//! `q̂_k = A_k⁻¹ (f_k + W λ̂_k)`, `A_k(ω) = K − (kω)² M + i kω C` (docs/theory.md (T13)), so
//! its contact coordinates are affine in the forces:
//!
//! ```text
//! Wᵀ q̂_k = Wᵀ A_k⁻¹ f_k + R_k λ̂_k,        R_k = Wᵀ A_k⁻¹ W    (n_c × n_c, complex symmetric).
//! ```
//!
//! At fixed forces the frequency derivative is
//! `∂(Wᵀ q̂_k)/∂ω = −Wᵀ A_k⁻¹ ∂A_k/∂ω q̂_k` with `∂A_k/∂ω = −2k²ω M + i k C` (T14).
//!
//! [`Receptance`] is the interface the redistributed MS-HBM uses; [`ExactReceptance`]
//! implements it with a sparse LU of the whole `A_k` per harmonic and `n_c` solves per
//! harmonic and frequency.

use faer::{c64, Mat, MatRef};

use super::dynamic_stiffness::{HarmonicFactors, LinearPart, StructuralBlock};
use super::partitioned::PartLoad;
use super::ZERO;
use crate::error::Result;
use crate::model::System;

/// The contact coordinates of a system: `g_c = Σ_j w_cj q_j + g0_c`, each contact a few
/// `(system DOF, weight)` pairs.
#[derive(Clone, Debug)]
pub struct ContactCoordinates {
    pub w: Vec<Vec<(usize, f64)>>,
}

impl ContactCoordinates {
    /// The contacts of `system`.
    pub fn of(system: &System) -> Self {
        ContactCoordinates {
            w: system.contacts.iter().map(|c| c.w.clone()).collect(),
        }
    }

    pub fn len(&self) -> usize {
        self.w.len()
    }

    pub fn is_empty(&self) -> bool {
        self.w.is_empty()
    }

    /// `Wᵀ q` (without `g0`).
    pub fn gather(&self, q: &[c64]) -> Vec<c64> {
        self.w
            .iter()
            .map(|w| w.iter().fold(ZERO, |s, &(i, v)| s + q[i] * v))
            .collect()
    }

    /// `out += W λ`.
    pub fn scatter_add(&self, force: &[c64], out: &mut [c64]) {
        for (w, &l) in self.w.iter().zip(force) {
            for &(i, v) in w {
                out[i] += l * v;
            }
        }
    }
}

/// The receptance of a structure at its contacts (module docs): [`Receptance::at`] does the
/// per-frequency work once.
pub trait Receptance: Send + Sync {
    /// Number of contacts `n_c`.
    fn n_contacts(&self) -> usize;

    /// Number of DOFs of the structure.
    fn n_dofs(&self) -> usize;

    /// The receptance at `ω` (rad/s) for the harmonics `k = 0..=harmonics`.
    fn at(&self, omega: f64, harmonics: usize) -> Result<Box<dyn ReceptanceAtFrequency>>;

    /// The frequency-independent parts of a receptance of the form
    /// `R_k = R_s + B X_k Bᵀ` (docs/theory.md (T130)), if it has that form; then
    /// [`ReceptanceAtFrequency::modal_correction`] gives `X_k`.
    fn static_plus_low_rank(&self) -> Option<StaticPlusLowRank<'_>> {
        None
    }
}

/// `R_s` (`n_c × n_c`, symmetric positive definite) and `B` (`n_c × m`, real) of a
/// receptance `R_k = R_s + B X_k Bᵀ` (docs/theory.md (T130)).
pub struct StaticPlusLowRank<'a> {
    pub static_receptance: MatRef<'a, f64>,
    pub contact_shapes: MatRef<'a, f64>,
}

/// The receptance at one frequency `ω` for the harmonics `k = 0..=H` (module docs). Complex
/// amplitudes are `z = a − i b` for `a cos kτ + b sin kτ` (docs/theory.md (T11)).
pub trait ReceptanceAtFrequency: Send + Sync {
    /// `ω` (rad/s).
    fn omega(&self) -> f64;

    /// `H`.
    fn harmonics(&self) -> usize;

    /// `R_k = Wᵀ A_k⁻¹ W` (`n_c × n_c`, row-major).
    fn receptance(&self, k: usize) -> &[c64];

    /// `X_k` (`m × m`) of a receptance `R_k = R_s + B X_k Bᵀ`
    /// ([`Receptance::static_plus_low_rank`]); `None` for other receptances.
    fn modal_correction(&self, _k: usize) -> Option<&Mat<c64>> {
        None
    }

    /// `Wᵀ A_k⁻¹ f_k`, the contact coordinates of the response to the load alone (`n_c`).
    fn load_response(&self, k: usize) -> &[c64];

    /// `q̂_k = A_k⁻¹ (f_k + W λ̂_k)`, every DOF of the structure.
    fn response(&self, k: usize, force: &[c64]) -> Result<Vec<c64>>;

    /// `∂(Wᵀ q̂_k)/∂ω = −Wᵀ A_k⁻¹ ∂A_k/∂ω q̂_k` at fixed forces `λ̂_k` (`n_c`), with
    /// `q̂_k = A_k⁻¹ (f_k + W λ̂_k)`, or without the load (`with_load = false`:
    /// `∂R_k/∂ω λ̂_k`).
    fn frequency_derivative(&self, k: usize, force: &[c64], with_load: bool) -> Result<Vec<c64>>;
}

/// The exact receptance: the whole dynamic stiffness `A_k` factored by a sparse LU per
/// harmonic and frequency, `R_k` from `n_c` solves.
pub struct ExactReceptance {
    structure: LinearPart,
    contacts: ContactCoordinates,
    load: PartLoad,
}

impl ExactReceptance {
    /// Analyse the sparsity pattern of `A_k` of the whole `system` (once).
    pub fn new(system: &System) -> Result<Self> {
        let all: Vec<usize> = (0..system.n_dofs()).collect();
        let block =
            StructuralBlock::of(&system.stiffness, &system.mass, &system.damping, &all, &all);
        Ok(ExactReceptance {
            structure: LinearPart::new(block)?,
            contacts: ContactCoordinates::of(system),
            load: PartLoad::restrict(system, &all),
        })
    }
}

impl Receptance for ExactReceptance {
    fn n_contacts(&self) -> usize {
        self.contacts.len()
    }

    fn n_dofs(&self) -> usize {
        self.structure.n_dofs()
    }

    fn at(&self, omega: f64, harmonics: usize) -> Result<Box<dyn ReceptanceAtFrequency>> {
        let (n, nc) = (self.n_dofs(), self.n_contacts());
        let factors = self.structure.factor(omega, harmonics)?;
        let mut receptance = Vec::with_capacity(harmonics + 1);
        let mut load_response = Vec::with_capacity(harmonics + 1);
        for k in 0..=harmonics {
            // A_k⁻¹ [W | f_k]
            let mut rhs = Mat::<c64>::zeros(n, nc + 1);
            for (c, w) in self.contacts.w.iter().enumerate() {
                w.iter().for_each(|&(i, v)| rhs[(i, c)] += c64::new(v, 0.0));
            }
            if let Some(f) = self.load.complex(k) {
                (0..n).for_each(|i| rhs[(i, nc)] = f[i]);
            }
            factors.solve_in_place(k, &mut rhs)?;
            let mut r = vec![ZERO; nc * nc];
            for j in 0..=nc {
                let column: Vec<c64> = (0..n).map(|i| rhs[(i, j)]).collect();
                let g = self.contacts.gather(&column);
                if j < nc {
                    (0..nc).for_each(|i| r[i * nc + j] = g[i]);
                } else {
                    load_response.push(g);
                }
            }
            receptance.push(r);
        }
        Ok(Box::new(ExactReceptanceAt {
            omega,
            factors,
            receptance,
            load_response,
            structure: self.structure.matrices.clone(),
            contacts: self.contacts.clone(),
            load: self.load.clone(),
        }))
    }
}

/// [`ExactReceptance`] at one frequency.
struct ExactReceptanceAt {
    omega: f64,
    factors: HarmonicFactors,
    receptance: Vec<Vec<c64>>,
    load_response: Vec<Vec<c64>>,
    structure: StructuralBlock,
    contacts: ContactCoordinates,
    load: PartLoad,
}

impl ReceptanceAtFrequency for ExactReceptanceAt {
    fn omega(&self) -> f64 {
        self.omega
    }

    fn harmonics(&self) -> usize {
        self.receptance.len() - 1
    }

    fn receptance(&self, k: usize) -> &[c64] {
        &self.receptance[k]
    }

    fn load_response(&self, k: usize) -> &[c64] {
        &self.load_response[k]
    }

    fn response(&self, k: usize, force: &[c64]) -> Result<Vec<c64>> {
        let n = self.structure.nrows();
        let mut rhs = self.load.complex(k).unwrap_or_else(|| vec![ZERO; n]);
        self.contacts.scatter_add(force, &mut rhs);
        self.factors.solve(k, &rhs)
    }

    fn frequency_derivative(&self, k: usize, force: &[c64], with_load: bool) -> Result<Vec<c64>> {
        let q = if with_load {
            self.response(k, force)?
        } else {
            let mut rhs = vec![ZERO; self.structure.nrows()];
            self.contacts.scatter_add(force, &mut rhs);
            self.factors.solve(k, &rhs)?
        };
        let mut v = vec![ZERO; q.len()];
        self.structure
            .add_derivative_times(k, self.omega, &q, &mut v);
        let dq = self.factors.solve(k, &v)?;
        Ok(self.contacts.gather(&dq).into_iter().map(|g| -g).collect())
    }
}
