//! The receptance at the contacts by modal superposition with the exact static part
//! (docs/theory.md (T130)–(T132)): the reduced-basis implementation of [`Receptance`] for
//! large models.
//!
//! With the `m` lowest modes of the structure (mass-normalised, `Φᵀ M Φ = I`,
//! `Φᵀ K Φ = diag(ω_j²)`; the massless contact nodes follow statically, so these are the
//! modes of the redistributed system with every contact open), the dynamic compliance of
//! harmonic `k` at `Ω = kω` is approximated by the **mode-acceleration** sum
//!
//! ```text
//! A_k⁻¹ ≈ K⁻¹ + Φ X_k Φᵀ,    X_k = (diag(ω_j²) − Ω² I + i Ω Φᵀ C Φ)⁻¹ − diag(1/ω_j²),
//! ```
//!
//! so that `R_k = Wᵀ K⁻¹ W + B X_k Bᵀ` with `B = Wᵀ Φ` (`n_c × m`). The static part `K⁻¹` is
//! exact (one sparse Cholesky factor of `K` and `n_c` solves, once); the modal part corrects
//! it for inertia and damping and vanishes at `Ω = 0`. With every mode with mass (`m = n_L`)
//! the sum is exact for any damping with `C_NN = C_NL = 0`; truncated, it is exact in the
//! static limit and its error falls like `(Ω/ω_{m+1})²` relative to the static compliance of
//! the discarded modes. For damping `α M + β_c (K_LL − K_LN K_NN⁻¹ K_NL)` the modal damping
//! `Φᵀ C Φ` is diagonal; otherwise its full `m × m` block is kept (a Galerkin projection).
//!
//! Per frequency and harmonic the cost is one complex `m × m` inverse and the products
//! `B X_k Bᵀ` (`n_c m² + n_c² m`); nothing is factored per frequency. When the modes
//! diagonalise the damping (`Φᵀ C Φ = diag(c_j)` to round-off: mass-proportional damping,
//! or `α M + β_c (K_LL − K_LN K_NN⁻¹ K_NL)`), `Y_k` and `X_k` are diagonal and each harmonic
//! costs `m` complex reciprocals and `n_c² m` products ((T148), docs/theory.md
//! §17 "Diagonal modal damping"); that form also moves to a new frequency in its own
//! storage ([`ReceptanceAtFrequency::refresh`]) and allocates nothing there.
//!
//! The factor of `K` is needed at set-up (the modes, `Wᵀ K⁻¹ W`, `Wᵀ K⁻¹ f_k`) and then only
//! for the whole structure's response (`K⁻¹ r` in [`ReceptanceAtFrequency::response`]). On a
//! 10⁵-DOF solid it is the largest thing the method would hold (1.5 GB against the rest's
//! 1 GB), so it is released after the set-up and formed again on the first whole-structure
//! response, from a copy of `K` (a tenth of its size).

use faer::linalg::solvers::Solve;
use std::sync::{Arc, OnceLock};

use faer::{c64, Mat, MatRef};

use super::partitioned::PartLoad;
use super::receptance::ContactCoordinates;
use crate::error::{Error, Result};
use crate::model::System;
use crate::modes::LowestModes;
use crate::sparse::SparseMatrix;

mod at_frequency;

/// The modal receptance of a structure at its contacts (module docs).
pub struct ModalReceptance {
    basis: Arc<ModalBasis>,
}

/// What [`ModalReceptance`] computes once and shares with every frequency. Everything is
/// real: the modes, `W` and `K` are.
struct ModalBasis {
    contacts: ContactCoordinates,
    load: PartLoad,
    /// The whole stiffness `K`, and its sparse Cholesky factor once a whole-structure
    /// response needs it again (module docs).
    stiffness: SparseMatrix,
    factor: OnceLock<crate::modes::StiffnessFactor>,
    n_dofs: usize,
    /// `ω_j²` (rad²/s²), ascending.
    eigenvalues: Vec<f64>,
    /// `Φ` (`n × m`).
    shapes: Mat<f64>,
    /// `B = Wᵀ Φ` (`n_c × m`).
    contact_shapes: Mat<f64>,
    /// `B` row-major (`n_c × m`), for the term-by-term sums of diagonal damping.
    shape_rows: Vec<f64>,
    /// `Φᵀ C Φ` (`m × m`).
    modal_damping: Mat<f64>,
    /// `c_j`, the diagonal of `Φᵀ C Φ`, when the modes diagonalise the damping
    /// ([`diagonal_of`]); then every `Y_k`, `X_k` is diagonal.
    diagonal_damping: Option<Vec<f64>>,
    /// `Wᵀ K⁻¹ W` (`n_c × n_c`).
    static_receptance: Mat<f64>,
    /// Per loaded harmonic `k ≤ 1`: `Wᵀ K⁻¹ f_k` and `Φᵀ f_k` (the loads are real and do
    /// not depend on the frequency).
    static_load: [Option<StaticLoad>; 2],
    /// The massless block, when `Φ` holds every mode with mass (rows of the response
    /// without `K⁻¹`).
    every_mode: Option<MasslessBlock>,
}

/// With every mode with mass, `K⁻¹ = E + Φ diag(1/ω_j²) Φᵀ` and so
/// `A_k⁻¹ = E + Φ Y_k Φᵀ` (docs/theory.md §17, (T130)), `E` holding `K_cc⁻¹` on the
/// massless DOFs `c` and zeros elsewhere: a row of the response costs `m` products and no
/// solve with `K`.
struct MasslessBlock {
    /// Per DOF, its position among the massless DOFs.
    position: Vec<Option<usize>>,
    /// `K_cc⁻¹` (row-major, massless × massless).
    inverse: Vec<f64>,
    count: usize,
}

impl MasslessBlock {
    /// The block of `system` if `m` modes are every mode with mass; `None` otherwise, or if
    /// `K_cc` is not positive definite.
    fn of(system: &System, m: usize) -> Option<Self> {
        let n = system.n_dofs();
        let massless = crate::modes::massless_dofs(&system.mass);
        if n - massless.len() != m {
            return None;
        }
        let count = massless.len();
        let mut position = vec![None; n];
        massless
            .iter()
            .enumerate()
            .for_each(|(p, &d)| position[d] = Some(p));
        let k_cc = system.stiffness.submatrix(&massless, &massless).to_dense();
        let inverse = k_cc
            .llt(faer::Side::Lower)
            .ok()?
            .solve(Mat::<f64>::identity(count, count));
        Some(MasslessBlock {
            position,
            inverse: (0..count * count)
                .map(|e| inverse[(e / count, e % count)])
                .collect(),
            count,
        })
    }
}

/// The frequency-independent parts of the response to one harmonic of the load.
struct StaticLoad {
    /// `Wᵀ K⁻¹ f_k` (`n_c`).
    contacts: Vec<f64>,
    /// `Φᵀ f_k` (`m`).
    modal: Mat<f64>,
}

/// Off-diagonal entries of `Φᵀ C Φ` up to this fraction of its largest diagonal entry are
/// round-off of damping the modes diagonalise (the modes are `M`-orthonormal to about
/// `10⁻¹⁴`).
const DIAGONAL_DAMPING_TOLERANCE: f64 = 1e-11;

/// The diagonal `c_j` of the modal damping `Φᵀ C Φ` if its off-diagonal entries are
/// round-off ([`DIAGONAL_DAMPING_TOLERANCE`]); `None` otherwise.
fn diagonal_of(modal_damping: &Mat<f64>) -> Option<Vec<f64>> {
    let m = modal_damping.nrows();
    let scale = (0..m)
        .map(|j| modal_damping[(j, j)].abs())
        .fold(0.0, f64::max);
    let coupled = (0..m).any(|j| {
        (0..m).any(|i| i != j && modal_damping[(i, j)].abs() > DIAGONAL_DAMPING_TOLERANCE * scale)
    });
    (!coupled).then(|| (0..m).map(|j| modal_damping[(j, j)]).collect())
}

/// `A M` for a real `A` and a complex `M` (two real products).
fn real_times_complex(a: MatRef<'_, f64>, m: &Mat<c64>) -> Mat<c64> {
    let re = a * Mat::<f64>::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)].re);
    let im = a * Mat::<f64>::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)].im);
    Mat::from_fn(re.nrows(), re.ncols(), |i, j| {
        c64::new(re[(i, j)], im[(i, j)])
    })
}

impl ModalReceptance {
    /// The modal receptance of `system` with its `modes` lowest modes (computed here by
    /// [`crate::modes::lowest_modes`]).
    pub fn new(system: &System, modes: usize) -> Result<Self> {
        let factor = crate::modes::stiffness_factor(&system.stiffness)?;
        let computed = crate::modes::lowest_modes_factored(
            &system.mass,
            &system.stiffness,
            Some(&factor),
            modes,
        )?;
        Self::with_modes_factored(system, computed, factor)
    }

    /// The modal receptance of `system` with every mode with mass
    /// ([`crate::modes::every_mode`], dense and sequential: the same numbers on any number
    /// of threads); exact (T130).
    pub fn every_mode(system: &System) -> Result<Self> {
        let modes = crate::modes::every_mode(&system.mass, &system.stiffness)?;
        Self::with_modes(system, modes)
    }

    /// The modal receptance of `system` with given mass-normalised modes.
    pub fn with_modes(system: &System, modes: LowestModes) -> Result<Self> {
        let factor = crate::modes::stiffness_factor(&system.stiffness)?;
        Self::with_modes_factored(system, modes, factor)
    }

    /// [`ModalReceptance::with_modes`] with the factor of `K` already formed.
    fn with_modes_factored(
        system: &System,
        modes: LowestModes,
        stiffness: crate::modes::StiffnessFactor,
    ) -> Result<Self> {
        let n = system.n_dofs();
        let m = modes.eigenvalues.len();
        if modes.shapes.nrows() != n || modes.shapes.ncols() != m || m == 0 {
            return Err(Error::argument(
                "modes",
                format!(
                    "{} mode shapes of {} DOFs for a system of {n} DOFs",
                    modes.shapes.ncols(),
                    modes.shapes.nrows()
                ),
            ));
        }
        if let Some(j) = modes
            .eigenvalues
            .iter()
            .position(|&l| l.is_nan() || l <= 0.0)
        {
            return Err(Error::argument(
                "modes",
                format!(
                    "mode {j} has ω² = {:e}: the modal receptance needs a held structure",
                    modes.eigenvalues[j]
                ),
            ));
        }
        let contacts = ContactCoordinates::of(system);
        let nc = contacts.len();
        // Wᵀ K⁻¹ W, from K⁻¹ W formed 64 contacts at a time (the whole n × n_c block is a
        // gigabyte on a 10⁵-DOF solid with 10³ contacts)
        let mut static_receptance = Mat::<f64>::zeros(nc, nc);
        let mut start = 0;
        while start < nc {
            let width = 64.min(nc - start);
            let mut kw = Mat::<f64>::zeros(n, width);
            for (c, w) in contacts.w[start..start + width].iter().enumerate() {
                w.iter().for_each(|&(i, v)| kw[(i, c)] += v);
            }
            stiffness.solve_in_place(kw.as_mut());
            for i in 0..nc {
                for c in 0..width {
                    static_receptance[(i, start + c)] = contacts.w[i]
                        .iter()
                        .map(|&(d, v)| v * kw[(d, c)])
                        .sum::<f64>();
                }
            }
            start += width;
        }
        let phi = modes.shapes;
        // Φᵀ C Φ term by term (sequential: the same numbers on any number of threads)
        let mut damped = Mat::<f64>::zeros(n, m);
        for (i, j, v) in system.damping.iter() {
            for c in 0..m {
                damped[(i, c)] += v * phi[(j, c)];
            }
        }
        let modal_damping = crate::dense::sequential_product(phi.transpose(), damped.as_ref());
        let diagonal_damping = diagonal_of(&modal_damping);
        let contact_shapes = Mat::<f64>::from_fn(nc, m, |c, j| {
            contacts.w[c]
                .iter()
                .map(|&(d, v)| v * phi[(d, j)])
                .sum::<f64>()
        });
        let all: Vec<usize> = (0..n).collect();
        let load = PartLoad::restrict(system, &all);
        let static_load = [0, 1].map(|k| {
            let f = load.real(k).filter(|f| f.iter().any(|&x| x != 0.0))?;
            let mut x = Mat::<f64>::from_fn(n, 1, |i, _| f[i]);
            stiffness.solve_in_place(x.as_mut());
            let contacts = (0..nc)
                .map(|c| contacts.w[c].iter().map(|&(d, v)| v * x[(d, 0)]).sum())
                .collect();
            let modal = crate::dense::sequential_product(
                phi.transpose(),
                faer::ColRef::from_slice(f).as_mat(),
            );
            Some(StaticLoad { contacts, modal })
        });
        drop(stiffness);
        Ok(ModalReceptance {
            basis: Arc::new(ModalBasis {
                load,
                contacts,
                stiffness: system.stiffness.clone(),
                factor: OnceLock::new(),
                n_dofs: n,
                eigenvalues: modes.eigenvalues,
                shapes: phi,
                shape_rows: (0..nc * m)
                    .map(|e| contact_shapes[(e / m, e % m)])
                    .collect(),
                contact_shapes,
                modal_damping,
                diagonal_damping,
                static_receptance,
                static_load,
                every_mode: MasslessBlock::of(system, m),
            }),
        })
    }

    /// Number of modes `m`.
    pub fn n_modes(&self) -> usize {
        self.basis.eigenvalues.len()
    }

    /// Whether the modes diagonalise the damping (`Φᵀ C Φ` diagonal to round-off), so that
    /// each harmonic costs `m` reciprocals (module docs).
    pub fn diagonalises_damping(&self) -> bool {
        self.basis.diagonal_damping.is_some()
    }

    /// `ω_j²` (rad²/s²) of the modes, ascending.
    pub fn eigenvalues(&self) -> &[f64] {
        &self.basis.eigenvalues
    }
}
