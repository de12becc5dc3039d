//! The exact receptance `R_k = Wᵀ A_k⁻¹ W` of the whole structure at its contact
//! coordinates (docs/theory.md (T125), (T139)): a sparse or band LU of `A_k` per harmonic
//! and frequency, and the columns `A_k⁻¹ [W | f_k]` solved by blocks.

use std::sync::Arc;

use faer::c64;

use super::banded::BatchSystems;
use super::dynamic_stiffness::{HarmonicFactors, LinearPart, StructuralBlock, SPARSE_SOLVE_BLOCK};
use super::partitioned::PartLoad;
use super::receptance::{
    rows_of_whole_response, ContactCoordinates, Receptance, ReceptanceAtFrequency,
};
use super::ZERO;
use crate::error::Result;
use crate::model::System;

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

    fn block(&mut self, s: usize, count: usize) -> Option<&mut [c64]> {
        let (k, j) = *self.list.get(s)?;
        let run = self.list.get(s..s + count)?;
        let next_to_each_other = run
            .iter()
            .enumerate()
            .all(|(i, &(ki, ji))| ki == k && ji == j + i);
        next_to_each_other.then(|| &mut self.columns[k][j * self.n..(j + count) * self.n])
    }
}

/// Columns `s = 0 … count − 1` of one matrix `A_k`, next to each other (`n` values each):
/// a block of the columns `[W | f_k]` solved at once ([`BatchSystems`]).
struct ColumnBlock<'a> {
    k: usize,
    values: &'a mut [c64],
    n: usize,
}

impl BatchSystems for ColumnBlock<'_> {
    fn count(&self) -> usize {
        self.values.len() / self.n
    }

    fn matrix(&self, _s: usize) -> usize {
        self.k
    }

    fn column(&mut self, s: usize) -> &mut [c64] {
        &mut self.values[s * self.n..(s + 1) * self.n]
    }

    fn block(&mut self, s: usize, count: usize) -> Option<&mut [c64]> {
        self.values.get_mut(s * self.n..(s + count) * self.n)
    }
}

/// Column `c` of `W` (contact `c`'s weights) added into `column` (`n`, zero on entry).
fn contact_column(contacts: &ContactCoordinates, c: usize, column: &mut [c64]) {
    contacts.w[c]
        .iter()
        .for_each(|&(i, v)| column[i] += c64::new(v, 0.0));
}

/// Solved column `j` of `A_k⁻¹ [W | f_k]` gathered at the contacts: column `j` of `R_k`
/// (`r`, `n_c × n_c` row-major) for `j < n_c`, else `Wᵀ A_k⁻¹ f_k` (`load`).
fn gather_column(
    contacts: &ContactCoordinates,
    j: usize,
    column: &[c64],
    gathered: &mut [c64],
    r: &mut [c64],
    load: &mut [c64],
) {
    let nc = contacts.len();
    if j < nc {
        contacts.gather_into(column, gathered);
        (0..nc).for_each(|i| r[i * nc + j] = gathered[i]);
    } else {
        contacts.gather_into(column, load);
    }
}

impl ExactReceptanceAt {
    /// With `factors` at `ω`: `A_k⁻¹ [W | f_k]` per harmonic (the load column only where
    /// `f_k ≠ 0`), and `R_k`, `Wᵀ A_k⁻¹ f_k` gathered from them: solved all in one batch
    /// and kept where they are kept, else a block of [`SPARSE_SOLVE_BLOCK`] columns at a
    /// time, each gathered and dropped (the columns of a 3D interface are `n × n_c` numbers
    /// per harmonic: 0.8 GB on the plate of `examples/block_3d`).
    fn solve_columns(&mut self) -> Result<()> {
        if !self.keep {
            return self.solve_columns_by_blocks();
        }
        let parts = &self.parts;
        let n = parts.structure.n_dofs();
        let nc = parts.contacts.len();
        let harmonics = self.receptance.len() - 1;
        self.columns
            .resize_with(harmonics + 1, || vec![ZERO; n * (nc + 1)]);
        self.solved.clear();
        for (k, block) in self.columns.iter_mut().enumerate() {
            block.fill(ZERO);
            for (c, column) in block.chunks_exact_mut(n).take(nc).enumerate() {
                contact_column(&parts.contacts, c, column);
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
                gather_column(&parts.contacts, j, column, &mut self.gathered, r, load);
            }
        }
        Ok(())
    }

    /// [`Self::solve_columns`] without keeping the columns: per harmonic, blocks of
    /// [`SPARSE_SOLVE_BLOCK`] columns of `[W | f_k]` solved in one scratch block.
    fn solve_columns_by_blocks(&mut self) -> Result<()> {
        let parts = &self.parts;
        let n = parts.structure.n_dofs();
        let nc = parts.contacts.len();
        self.columns = Vec::new();
        let mut scratch = vec![ZERO; n * SPARSE_SOLVE_BLOCK.min(nc + 1)];
        for (k, (r, load)) in self
            .receptance
            .iter_mut()
            .zip(&mut self.load_response)
            .enumerate()
        {
            load.fill(ZERO);
            for first in (0..=nc).step_by(SPARSE_SOLVE_BLOCK) {
                let count = SPARSE_SOLVE_BLOCK.min(nc + 1 - first);
                let values = &mut scratch[..n * count];
                values.fill(ZERO);
                let mut solved = count;
                for (s, column) in values.chunks_exact_mut(n).enumerate() {
                    let j = first + s;
                    if j < nc {
                        contact_column(&parts.contacts, j, column);
                    } else if !parts.load.complex_into(k, column) {
                        solved -= 1; // no load at this harmonic: its response is zero
                    }
                }
                let values = &mut values[..n * solved];
                self.factors
                    .solve_systems_until(&mut ColumnBlock { k, values, n }, parts.cancel)?;
                for (s, column) in values.chunks_exact(n).enumerate() {
                    let j = first + s;
                    gather_column(&parts.contacts, j, column, &mut self.gathered, r, load);
                }
            }
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

    fn example(example: &str, overrides: &[&str]) -> crate::model::Model {
        let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../examples")
            .join(example);
        let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
        crate::model::file::load_model(&file, &overrides).unwrap()
    }

    /// The receptance solved by blocks of columns (a coarse plate of `examples/block_3d`:
    /// 42 contacts, two blocks, sparse factors, the load column in the second) equals the
    /// one from a solve per column, `R_k e_j = Wᵀ A_k⁻¹ w_j` and `Wᵀ A_k⁻¹ f_k`.
    #[test]
    fn columns_solved_by_blocks_equal_columns_solved_one_by_one() {
        let model = example("block_3d/model.toml", &["solid.divisions=[6,6,4]"]);
        let system = model.system(MassKind::Redistributed).unwrap();
        let receptance = ExactReceptance::new(&system).unwrap();
        let (n, nc, harmonics) = (receptance.n_dofs(), receptance.n_contacts(), 2);
        assert!(nc > SPARSE_SOLVE_BLOCK, "{nc} contacts");
        let at = receptance
            .at_keeping(2.0 * std::f64::consts::PI * 1500.0, harmonics, 0)
            .unwrap();
        assert!(
            !at.keep
                && matches!(
                    at.factors.factors,
                    super::super::dynamic_stiffness::Factors::Sparse(_)
                )
        );
        let parts = &receptance.shared;
        let mut loaded_harmonics = 0;
        for k in 0..=harmonics {
            let r = at.receptance(k);
            for j in 0..=nc {
                let mut rhs = vec![ZERO; n];
                if j < nc {
                    parts.contacts.w[j]
                        .iter()
                        .for_each(|&(i, v)| rhs[i] += c64::new(v, 0.0));
                } else if !parts.load.complex_into(k, &mut rhs) {
                    assert!(at.load_response(k).iter().all(|&z| z == ZERO));
                    continue;
                }
                let column = parts.contacts.gather(&at.factors.solve(k, &rhs).unwrap());
                let computed: Vec<c64> = if j < nc {
                    (0..nc).map(|i| r[i * nc + j]).collect()
                } else {
                    loaded_harmonics += 1;
                    at.load_response(k).to_vec()
                };
                assert!(
                    distance(&computed, &column) <= 1e-12 * largest(&column),
                    "k = {k}, column {j}"
                );
            }
        }
        assert!(loaded_harmonics > 0);
    }

    /// The two ways of the exact receptance at one frequency agree: with the solved
    /// columns kept (response and frequency derivative by products, (T139)) and without
    /// them (solved by blocks, response by solves, as for a model too large to keep them),
    /// also after `refresh` moved both to another frequency in their own storage.
    #[test]
    fn kept_columns_and_solves_give_the_same_receptance_and_derivatives() {
        let model = example("clamped_bar.toml", &["damping.first_mode_ratio=0.01"]);
        let omega = 2.0 * std::f64::consts::PI * 30e3;
        let system = model.system(MassKind::Redistributed).unwrap();
        let receptance = ExactReceptance::new(&system).unwrap();
        let harmonics = 3;
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
