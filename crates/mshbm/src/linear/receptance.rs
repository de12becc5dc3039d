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

use super::banded::BatchSystems;
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
    /// The caller's request to stop, checked between the columns' solves.
    cancel: crate::limits::Cancel,
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
                cancel: crate::limits::Cancel::NEVER,
            }),
        })
    }

    /// This receptance, its columns' solves stopping at the caller's request (`cancel`).
    pub fn cancellable(mut self, cancel: crate::limits::Cancel) -> Self {
        if let Some(parts) = Arc::get_mut(&mut self.shared) {
            parts.cancel = cancel;
        }
        self
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
        Ok(Box::new(self.at_keeping(
            omega,
            harmonics,
            KEPT_COLUMN_VALUES,
        )?))
    }
}

impl ExactReceptance {
    /// The receptance at `ω`, keeping the solved columns when `A_k` is complex symmetric
    /// and they hold at most `kept_values` numbers.
    fn at_keeping(
        &self,
        omega: f64,
        harmonics: usize,
        kept_values: usize,
    ) -> Result<ExactReceptanceAt> {
        let (n, nc) = (self.n_dofs(), self.n_contacts());
        let parts = &self.shared;
        let keep = parts.symmetric
            && n.saturating_mul(nc + 1).saturating_mul(harmonics + 1) <= kept_values;
        let mut at = ExactReceptanceAt {
            omega,
            factors: parts
                .structure
                .factor_cancellable(omega, harmonics, parts.cancel)?,
            receptance: vec![vec![ZERO; nc * nc]; harmonics + 1],
            load_response: vec![vec![ZERO; nc]; harmonics + 1],
            columns: Vec::new(),
            keep,
            solved: Vec::with_capacity((harmonics + 1) * (nc + 1)),
            gathered: vec![ZERO; nc],
            parts: Arc::clone(&self.shared),
        };
        at.solve_columns()?;
        Ok(at)
    }
}

/// [`ExactReceptance`] at one frequency.
struct ExactReceptanceAt {
    omega: f64,
    factors: HarmonicFactors,
    receptance: Vec<Vec<c64>>,
    /// Per harmonic, `Wᵀ A_k⁻¹ f_k` (zero without load).
    load_response: Vec<Vec<c64>>,
    /// Per harmonic, `[Y | A_k⁻¹ f_k]` (`n × (n_c + 1)`, column-major; the last column
    /// zero for a harmonic without load); empty between solves when not kept.
    columns: Vec<Vec<c64>>,
    /// Whether `A_k` is complex symmetric and the columns are kept for the response and the
    /// frequency derivative (docs/theory.md (T139)).
    keep: bool,
    /// `(harmonic, column)` of the columns solved (reused).
    solved: Vec<(usize, usize)>,
    gathered: Vec<c64>,
    parts: Arc<ExactParts>,
}

/// The columns `[W | f_k]` of every harmonic that are solved, as one batch
/// ([`BatchSystems`]).
struct SolvedColumns<'a> {
    columns: &'a mut [Vec<c64>],
    list: &'a [(usize, usize)],
    n: usize,
}

impl BatchSystems for SolvedColumns<'_> {
    fn count(&self) -> usize {
        self.list.len()
    }

    fn matrix(&self, s: usize) -> usize {
        self.list[s].0
    }

    fn column(&mut self, s: usize) -> &mut [c64] {
        let (k, j) = self.list[s];
        &mut self.columns[k][j * self.n..(j + 1) * self.n]
    }
}

impl ExactReceptanceAt {
    /// With `factors` at `ω`: `A_k⁻¹ [W | f_k]` per harmonic (the load column only where
    /// `f_k ≠ 0`), solved in one batch, and `R_k`, `Wᵀ A_k⁻¹ f_k` gathered from them.
    fn solve_columns(&mut self) -> Result<()> {
        let parts = &self.parts;
        let n = parts.structure.n_dofs();
        let nc = parts.contacts.len();
        let harmonics = self.receptance.len() - 1;
        // columns that are not kept were released after the last solve
        self.columns
            .resize_with(harmonics + 1, || vec![ZERO; n * (nc + 1)]);
        self.solved.clear();
        for (k, block) in self.columns.iter_mut().enumerate() {
            block.fill(ZERO);
            for (c, w) in parts.contacts.w.iter().enumerate() {
                w.iter()
                    .for_each(|&(i, v)| block[c * n + i] += c64::new(v, 0.0));
            }
            let loaded = parts.load.complex_into(k, &mut block[nc * n..]);
            let solved = if loaded { nc + 1 } else { nc };
            self.solved.extend((0..solved).map(|j| (k, j)));
        }
        self.factors.solve_systems_until(
            &mut SolvedColumns {
                columns: &mut self.columns,
                list: &self.solved,
                n,
            },
            parts.cancel,
        )?;
        let blocks = self.columns.iter().zip(&mut self.receptance);
        for ((block, r), load) in blocks.zip(&mut self.load_response) {
            for (j, column) in block.chunks_exact(n).enumerate() {
                if j < nc {
                    parts.contacts.gather_into(column, &mut self.gathered);
                    (0..nc).for_each(|i| r[i * nc + j] = self.gathered[i]);
                } else {
                    parts.contacts.gather_into(column, load);
                }
            }
        }
        if !self.keep {
            // too large to keep (KEPT_COLUMN_VALUES): only the gathered numbers stay
            self.columns = Vec::new();
        }
        Ok(())
    }

    /// `q̂_k = A_k⁻¹ (f_k + W λ̂_k)` (or `A_k⁻¹ W λ̂_k` without the load) from the
    /// columns of harmonic `k`, into `q` (`n`).
    fn combine_into(&self, k: usize, force: &[c64], with_load: bool, q: &mut [c64]) {
        let columns = &self.columns[k];
        let n = q.len();
        let nc = force.len();
        if with_load {
            q.copy_from_slice(&columns[nc * n..]);
        } else {
            q.fill(ZERO);
        }
        for (c, &l) in force.iter().enumerate() {
            if l != ZERO {
                q.iter_mut()
                    .zip(&columns[c * n..(c + 1) * n])
                    .for_each(|(q, y)| *q += y * l);
            }
        }
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

    fn refresh(&mut self, omega: f64) -> Result<bool> {
        let harmonics = self.harmonics();
        self.parts.structure.factor_into_cancellable(
            omega,
            harmonics,
            &mut self.factors,
            self.parts.cancel,
        )?;
        self.omega = omega;
        self.solve_columns()?;
        Ok(true)
    }

    fn response(&self, k: usize, force: &[c64]) -> Result<Vec<c64>> {
        let n = self.parts.structure.n_dofs();
        let mut q = vec![ZERO; n];
        if self.keep {
            self.combine_into(k, force, true, &mut q);
            return Ok(q);
        }
        self.parts.load.complex_into(k, &mut q);
        self.parts.contacts.scatter_add(force, &mut q);
        self.factors.solve_slice_in_place(k, &mut q)?;
        Ok(q)
    }

    /// With the columns kept, each row is `(A_k⁻¹ f_k)_i + Σ_c Y_ic λ̂_c` (T139).
    fn response_rows(
        &self,
        k: usize,
        force: &[c64],
        rows: &[usize],
        out: &mut [c64],
    ) -> Result<()> {
        if !self.keep {
            return rows_of_whole_response(self, k, force, rows, out);
        }
        let n = self.parts.structure.n_dofs();
        let columns = &self.columns[k];
        let load = &columns[force.len() * n..];
        for (o, &r) in out.iter_mut().zip(rows) {
            *o = force
                .iter()
                .enumerate()
                .fold(load[r], |s, (c, &l)| s + columns[c * n + r] * l);
        }
        Ok(())
    }

    fn frequency_derivative_into(
        &self,
        k: usize,
        force: &[c64],
        with_load: bool,
        out: &mut [c64],
        scratch: &mut Vec<c64>,
    ) -> Result<()> {
        let n = self.parts.structure.n_dofs();
        scratch.clear();
        scratch.resize(2 * n, ZERO);
        let (q, v) = scratch.split_at_mut(n);
        if self.keep {
            self.combine_into(k, force, with_load, q);
        } else {
            if with_load {
                self.parts.load.complex_into(k, q);
            }
            self.parts.contacts.scatter_add(force, q);
            self.factors.solve_slice_in_place(k, q)?;
        }
        self.parts
            .structure
            .add_derivative_times(k, self.omega, q, v);
        if self.keep {
            // Wᵀ A_k⁻¹ v = Yᵀ v (A_k complex symmetric)
            let columns = &self.columns[k];
            for (c, o) in out.iter_mut().enumerate() {
                *o = -columns[c * n..(c + 1) * n]
                    .iter()
                    .zip(v.iter())
                    .fold(ZERO, |s, (y, v)| s + y * v);
            }
            return Ok(());
        }
        self.factors.solve_slice_in_place(k, v)?;
        self.parts.contacts.gather_into(v, out);
        out.iter_mut().for_each(|o| *o = -*o);
        Ok(())
    }

    fn frequency_derivative(&self, k: usize, force: &[c64], with_load: bool) -> Result<Vec<c64>> {
        let mut out = vec![ZERO; force.len()];
        self.frequency_derivative_into(k, force, with_load, &mut out, &mut Vec::new())?;
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::MassKind;

    fn largest(v: &[c64]) -> f64 {
        v.iter().map(|z| z.norm()).fold(0.0, f64::max)
    }

    fn distance(a: &[c64], b: &[c64]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).norm())
            .fold(0.0, f64::max)
    }

    /// The two ways of the exact receptance at one frequency agree: with the solved
    /// columns kept (response and frequency derivative by products, (T139)) and without
    /// them (by solves, as for a model too large to keep them), also after `refresh` moved
    /// both to another frequency in their own storage.
    #[test]
    fn kept_columns_and_solves_give_the_same_receptance_and_derivatives() {
        let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../examples/clamped_bar.toml");
        let model =
            crate::model::file::load_model(&file, &["damping.first_mode_ratio=0.01".to_string()])
                .unwrap();
        let system = model.system(MassKind::Redistributed).unwrap();
        let receptance = ExactReceptance::new(&system).unwrap();
        let harmonics = 3;
        let omega = 2.0 * std::f64::consts::PI * 30e3;
        let mut kept = receptance
            .at_keeping(omega, harmonics, KEPT_COLUMN_VALUES)
            .unwrap();
        let mut solved = receptance.at_keeping(omega, harmonics, 0).unwrap();
        assert!(kept.keep && !solved.keep && solved.columns.is_empty());
        let force = [c64::new(0.3, -0.2)];
        for frequency in [omega, 1.3 * omega] {
            if frequency != omega {
                assert!(kept.refresh(frequency).unwrap());
                assert!(solved.refresh(frequency).unwrap());
            }
            for k in 0..=harmonics {
                let (a, b) = (kept.receptance(k), solved.receptance(k));
                assert!(distance(a, b) <= 1e-12 * largest(a), "R_{k}");
                let (a, b) = (
                    kept.response(k, &force).unwrap(),
                    solved.response(k, &force).unwrap(),
                );
                assert!(distance(&a, &b) <= 1e-10 * largest(&a), "q_{k}");
                for with_load in [true, false] {
                    let a = kept.frequency_derivative(k, &force, with_load).unwrap();
                    let b = solved.frequency_derivative(k, &force, with_load).unwrap();
                    assert!(
                        distance(&a, &b) <= 1e-9 * largest(&a).max(1e-300),
                        "∂/∂ω, k = {k}, load {with_load}: {a:?} vs {b:?}"
                    );
                }
            }
        }
    }
}
