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

use std::sync::Arc;

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

    /// `Wᵀ q` (without `g0`) into `out` (`n_c`).
    pub fn gather_into(&self, q: &[c64], out: &mut [c64]) {
        for (o, w) in out.iter_mut().zip(&self.w) {
            *o = w.iter().fold(ZERO, |s, &(i, v)| s + q[i] * v);
        }
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

/// The exact receptance: the whole dynamic stiffness `A_k` factored (a sparse or a band LU,
/// [`LinearPart`]) per harmonic and frequency, `R_k` from `n_c` solves.
///
/// When `K`, `M` and `C` are symmetric, `A_k` is complex symmetric and `Wᵀ A_k⁻¹ = Yᵀ` with
/// `Y = A_k⁻¹ W` (docs/theory.md (T139)); the solved columns `[Y | A_k⁻¹ f_k]` are then kept (up to
/// [`KEPT_COLUMN_VALUES`] numbers), and the whole response `q̂_k = A_k⁻¹ f_k + Y λ̂_k` and
/// the frequency derivative `−Yᵀ ∂A_k/∂ω q̂_k` cost products instead of solves.
pub struct ExactReceptance {
    shared: Arc<ExactParts>,
}

/// What every frequency of an [`ExactReceptance`] shares.
struct ExactParts {
    structure: LinearPart,
    contacts: ContactCoordinates,
    load: PartLoad,
    /// Whether `K`, `M` and `C` are symmetric (so `A_k` is complex symmetric).
    symmetric: bool,
}

/// Largest number of complex values `n (n_c + 1)(H + 1)` of the solved columns an
/// [`ExactReceptance`] keeps per frequency (64 MiB).
pub const KEPT_COLUMN_VALUES: usize = 1 << 22;

impl ExactReceptance {
    /// Analyse the sparsity pattern of `A_k` of the whole `system` (once).
    pub fn new(system: &System) -> Result<Self> {
        let all: Vec<usize> = (0..system.n_dofs()).collect();
        let block =
            StructuralBlock::of(&system.stiffness, &system.mass, &system.damping, &all, &all);
        let symmetric = [&block.stiffness, &block.mass, &block.damping]
            .iter()
            .all(|m| m.iter().all(|(i, j, v)| m.get(j, i) == v));
        Ok(ExactReceptance {
            shared: Arc::new(ExactParts {
                structure: LinearPart::new(block)?,
                contacts: ContactCoordinates::of(system),
                load: PartLoad::restrict(system, &all),
                symmetric,
            }),
        })
    }
}

impl Receptance for ExactReceptance {
    fn n_contacts(&self) -> usize {
        self.shared.contacts.len()
    }

    fn n_dofs(&self) -> usize {
        self.shared.structure.n_dofs()
    }

    fn at(&self, omega: f64, harmonics: usize) -> Result<Box<dyn ReceptanceAtFrequency>> {
        let (n, nc) = (self.n_dofs(), self.n_contacts());
        let parts = &self.shared;
        let factors = parts.structure.factor(omega, harmonics)?;
        let keep = parts.symmetric
            && n.saturating_mul(nc + 1).saturating_mul(harmonics + 1) <= KEPT_COLUMN_VALUES;
        // per harmonic, A_k⁻¹ [W | f_k] column-major (n_c + 1 columns of n; the last stays
        // zero for the harmonics that are not loaded), all solved in one batch
        let mut columns: Vec<Vec<c64>> = Vec::with_capacity(harmonics + 1);
        let mut loaded = Vec::with_capacity(harmonics + 1);
        for k in 0..=harmonics {
            let mut block = vec![ZERO; n * (nc + 1)];
            for (c, w) in parts.contacts.w.iter().enumerate() {
                w.iter()
                    .for_each(|&(i, v)| block[c * n + i] += c64::new(v, 0.0));
            }
            let load = parts.load.complex(k);
            if let Some(f) = &load {
                block[nc * n..].copy_from_slice(f);
            }
            loaded.push(load.is_some());
            columns.push(block);
        }
        {
            let mut systems: Vec<(usize, &mut [c64])> = Vec::new();
            for (k, block) in columns.iter_mut().enumerate() {
                let solved = if loaded[k] { nc + 1 } else { nc };
                systems.extend(block[..solved * n].chunks_exact_mut(n).map(|b| (k, b)));
            }
            factors.solve_batch(&mut systems)?;
        }
        let mut receptance = Vec::with_capacity(harmonics + 1);
        let mut load_response = Vec::with_capacity(harmonics + 1);
        let mut gathered = vec![ZERO; nc];
        for block in &columns {
            let mut r = vec![ZERO; nc * nc];
            for (j, column) in block.chunks_exact(n).enumerate() {
                parts.contacts.gather_into(column, &mut gathered);
                if j < nc {
                    (0..nc).for_each(|i| r[i * nc + j] = gathered[i]);
                } else {
                    load_response.push(gathered.clone());
                }
            }
            receptance.push(r);
        }
        Ok(Box::new(ExactReceptanceAt {
            omega,
            factors,
            receptance,
            load_response,
            columns: keep.then_some(columns),
            parts: Arc::clone(&self.shared),
        }))
    }
}

/// [`ExactReceptance`] at one frequency.
struct ExactReceptanceAt {
    omega: f64,
    factors: HarmonicFactors,
    receptance: Vec<Vec<c64>>,
    load_response: Vec<Vec<c64>>,
    /// Per harmonic, `[Y | A_k⁻¹ f_k]` (`n × (n_c + 1)`, column-major) when `A_k` is
    /// complex symmetric.
    columns: Option<Vec<Vec<c64>>>,
    parts: Arc<ExactParts>,
}

impl ExactReceptanceAt {
    /// `q̂_k = A_k⁻¹ (f_k + W λ̂_k)` (or `A_k⁻¹ W λ̂_k` without the load) from the kept
    /// columns.
    fn combine(columns: &[c64], force: &[c64], with_load: bool) -> Vec<c64> {
        let nc = force.len();
        let n = columns.len() / (nc + 1);
        let mut q: Vec<c64> = if with_load {
            columns[nc * n..].to_vec()
        } else {
            vec![ZERO; n]
        };
        for (c, &l) in force.iter().enumerate() {
            if l != ZERO {
                q.iter_mut()
                    .zip(&columns[c * n..(c + 1) * n])
                    .for_each(|(q, y)| *q += y * l);
            }
        }
        q
    }
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
        if let Some(columns) = &self.columns {
            return Ok(Self::combine(&columns[k], force, true));
        }
        let n = self.parts.structure.n_dofs();
        let mut rhs = self.parts.load.complex(k).unwrap_or_else(|| vec![ZERO; n]);
        self.parts.contacts.scatter_add(force, &mut rhs);
        self.factors.solve(k, &rhs)
    }

    fn frequency_derivative(&self, k: usize, force: &[c64], with_load: bool) -> Result<Vec<c64>> {
        let structure = &self.parts.structure.matrices;
        if let Some(columns) = &self.columns {
            // Wᵀ A_k⁻¹ v = Yᵀ v (A_k complex symmetric)
            let columns = &columns[k];
            let q = Self::combine(columns, force, with_load);
            let mut v = vec![ZERO; q.len()];
            self.parts
                .structure
                .add_derivative_times(k, self.omega, &q, &mut v);
            let n = v.len();
            return Ok((0..force.len())
                .map(|c| {
                    -columns[c * n..(c + 1) * n]
                        .iter()
                        .zip(&v)
                        .fold(ZERO, |s, (y, v)| s + y * v)
                })
                .collect());
        }
        let q = if with_load {
            self.response(k, force)?
        } else {
            let mut rhs = vec![ZERO; structure.nrows()];
            self.parts.contacts.scatter_add(force, &mut rhs);
            self.factors.solve(k, &rhs)?
        };
        let mut v = vec![ZERO; q.len()];
        structure.add_derivative_times(k, self.omega, &q, &mut v);
        let dq = self.factors.solve(k, &v)?;
        Ok(self
            .parts
            .contacts
            .gather(&dq)
            .into_iter()
            .map(|g| -g)
            .collect())
    }
}
