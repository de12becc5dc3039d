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
//! [`Receptance`] is the interface the redistributed MS-HBM uses;
//! [`super::ExactReceptance`] (`exact_receptance.rs`) implements it with a sparse LU of the
//! whole `A_k` per harmonic and `n_c` solves per harmonic and frequency,
//! [`super::ModalReceptance`] by modes.

use faer::{c64, Mat, MatRef};

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

    /// The DOFs `rows` of [`ReceptanceAtFrequency::response`] into `out` (`rows.len()`),
    /// for a caller that needs a few DOFs (the contact nodes of a diagram point). The
    /// default forms the whole response.
    fn response_rows(
        &self,
        k: usize,
        force: &[c64],
        rows: &[usize],
        out: &mut [c64],
    ) -> Result<()> {
        rows_of_whole_response(self, k, force, rows, out)
    }

    /// `∂(Wᵀ q̂_k)/∂ω = −Wᵀ A_k⁻¹ ∂A_k/∂ω q̂_k` at fixed forces `λ̂_k` (`n_c`), with
    /// `q̂_k = A_k⁻¹ (f_k + W λ̂_k)`, or without the load (`with_load = false`:
    /// `∂R_k/∂ω λ̂_k`).
    fn frequency_derivative(&self, k: usize, force: &[c64], with_load: bool) -> Result<Vec<c64>>;

    /// [`ReceptanceAtFrequency::frequency_derivative`] into `out` (`n_c`), with `scratch`
    /// for its working vectors (so that a receptance that keeps its solved columns
    /// allocates nothing).
    fn frequency_derivative_into(
        &self,
        k: usize,
        force: &[c64],
        with_load: bool,
        out: &mut [c64],
        _scratch: &mut Vec<c64>,
    ) -> Result<()> {
        out.copy_from_slice(&self.frequency_derivative(k, force, with_load)?);
        Ok(())
    }

    /// Redo the per-frequency work at `ω` in this receptance's storage, for the same
    /// harmonics (no allocation); `false` when this receptance cannot (then ask
    /// [`Receptance::at`] for a new one). After an error it is not usable.
    fn refresh(&mut self, _omega: f64) -> Result<bool> {
        Ok(false)
    }
}

/// [`ReceptanceAtFrequency::response_rows`] from the whole response (the default, and the
/// fallback of receptances with a cheaper way for some cases).
pub(crate) fn rows_of_whole_response<R: ReceptanceAtFrequency + ?Sized>(
    receptance: &R,
    k: usize,
    force: &[c64],
    rows: &[usize],
    out: &mut [c64],
) -> Result<()> {
    let q = receptance.response(k, force)?;
    out.iter_mut().zip(rows).for_each(|(o, &r)| *o = q[r]);
    Ok(())
}
