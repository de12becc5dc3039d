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
//! `B X_k Bᵀ` (`n_c m² + n_c² m`); nothing is factored per frequency.

use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::Llt;
use std::sync::Arc;

use faer::{c64, Mat};

use super::partitioned::PartLoad;
use super::receptance::{ContactCoordinates, Receptance, ReceptanceAtFrequency};
use super::ZERO;
use crate::error::{Error, Result};
use crate::model::System;
use crate::modes::LowestModes;

/// The modal receptance of a structure at its contacts (module docs).
pub struct ModalReceptance {
    basis: Arc<ModalBasis>,
}

/// What [`ModalReceptance`] computes once and shares with every frequency.
struct ModalBasis {
    contacts: ContactCoordinates,
    load: PartLoad,
    /// Sparse Cholesky factor of the whole stiffness `K`.
    stiffness: Llt<usize, f64>,
    n_dofs: usize,
    /// `ω_j²` (rad²/s²), ascending.
    eigenvalues: Vec<f64>,
    /// `Φ` (`n × m`).
    shapes: Mat<c64>,
    /// `B = Wᵀ Φ` (`n_c × m`).
    contact_shapes: Mat<c64>,
    /// `Φᵀ C Φ` (`m × m`).
    modal_damping: Mat<c64>,
    /// `Wᵀ K⁻¹ W` (`n_c × n_c`).
    static_receptance: Mat<c64>,
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
        let mut static_receptance = Mat::<c64>::zeros(nc, nc);
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
                    let g = contacts.w[i]
                        .iter()
                        .map(|&(d, v)| v * kw[(d, c)])
                        .sum::<f64>();
                    static_receptance[(i, start + c)] = c64::new(g, 0.0);
                }
            }
            start += width;
        }
        let phi = &modes.shapes;
        let damping_phi = system.damping.to_faer() * phi;
        let modal_damping = phi.transpose() * &damping_phi;
        let complex = |a: &Mat<f64>| {
            Mat::<c64>::from_fn(a.nrows(), a.ncols(), |i, j| c64::new(a[(i, j)], 0.0))
        };
        let contact_shapes = Mat::<c64>::from_fn(nc, m, |c, j| {
            let g = contacts.w[c]
                .iter()
                .map(|&(d, v)| v * phi[(d, j)])
                .sum::<f64>();
            c64::new(g, 0.0)
        });
        let all: Vec<usize> = (0..n).collect();
        Ok(ModalReceptance {
            basis: Arc::new(ModalBasis {
                load: PartLoad::restrict(system, &all),
                contacts,
                stiffness,
                n_dofs: n,
                eigenvalues: modes.eigenvalues,
                shapes: complex(phi),
                contact_shapes,
                modal_damping: complex(&modal_damping),
                static_receptance,
            }),
        })
    }

    /// Number of modes `m`.
    pub fn n_modes(&self) -> usize {
        self.basis.eigenvalues.len()
    }

    /// `ω_j²` (rad²/s²) of the modes, ascending.
    pub fn eigenvalues(&self) -> &[f64] {
        &self.basis.eigenvalues
    }
}

impl ModalBasis {
    /// `K⁻¹ r` for a complex `r` (real and imaginary parts solved together).
    fn static_solve(&self, r: &[c64]) -> Vec<c64> {
        let mut x = Mat::<f64>::from_fn(r.len(), 2, |i, j| if j == 0 { r[i].re } else { r[i].im });
        self.stiffness.solve_in_place(x.as_mut());
        (0..r.len())
            .map(|i| c64::new(x[(i, 0)], x[(i, 1)]))
            .collect()
    }

    /// `Φᵀ r`.
    fn project(&self, r: &[c64]) -> Mat<c64> {
        self.shapes.transpose() * faer::ColRef::from_slice(r).as_mat()
    }
}

impl Receptance for ModalReceptance {
    fn n_contacts(&self) -> usize {
        self.basis.contacts.len()
    }

    fn n_dofs(&self) -> usize {
        self.basis.n_dofs
    }

    fn at(&self, omega: f64, harmonics: usize) -> Result<Box<dyn ReceptanceAtFrequency>> {
        let (m, nc) = (self.n_modes(), self.n_contacts());
        let b = &*self.basis;
        let mut harmonic = Vec::with_capacity(harmonics + 1);
        for k in 0..=harmonics {
            let big_omega = k as f64 * omega;
            // Y_k = (diag(ω_j²) − Ω² I + i Ω Φᵀ C Φ)⁻¹
            let a = Mat::<c64>::from_fn(m, m, |i, j| {
                let diagonal = if i == j {
                    b.eigenvalues[i] - big_omega * big_omega
                } else {
                    0.0
                };
                c64::new(diagonal, 0.0) + c64::new(0.0, big_omega) * b.modal_damping[(i, j)]
            });
            let y = a.partial_piv_lu().solve(Mat::<c64>::identity(m, m));
            if y.col_iter()
                .any(|c| c.iter().any(|v| !v.re.is_finite() || !v.im.is_finite()))
            {
                return Err(Error::Singular(format!(
                    "the modal dynamic stiffness of harmonic {k} at {:.6e} rad/s is singular (an undamped resonance)",
                    omega
                )));
            }
            let mut x = y.clone();
            (0..m).for_each(|j| x[(j, j)] -= c64::new(1.0 / b.eigenvalues[j], 0.0));
            let bx = &b.contact_shapes * &x;
            let receptance = &b.static_receptance + &bx * b.contact_shapes.transpose();
            let load = b.load.complex(k);
            let (load_response, modal_load) = match &load {
                Some(f) => {
                    let p = b.project(f);
                    let s = b.contacts.gather(&b.static_solve(f));
                    let correction = &bx * &p;
                    let lr = (0..nc).map(|c| s[c] + correction[(c, 0)]).collect();
                    (lr, Some(p))
                }
                None => (vec![ZERO; nc], None),
            };
            harmonic.push(ModalHarmonic {
                receptance: (0..nc * nc).map(|e| receptance[(e / nc, e % nc)]).collect(),
                load_response,
                modal_load,
                load,
                dynamic_compliance: y,
                correction: x,
            });
        }
        Ok(Box::new(ModalReceptanceAt {
            omega,
            harmonic,
            basis: Arc::clone(&self.basis),
        }))
    }
}

/// One harmonic of [`ModalReceptance`] at one frequency.
#[derive(Clone)]
struct ModalHarmonic {
    receptance: Vec<c64>,
    load_response: Vec<c64>,
    /// `Φᵀ f_k` and `f_k` (if harmonic `k` is loaded).
    modal_load: Option<Mat<c64>>,
    load: Option<Vec<c64>>,
    /// `Y_k` and `X_k = Y_k − diag(1/ω_j²)`.
    dynamic_compliance: Mat<c64>,
    correction: Mat<c64>,
}

/// [`ModalReceptance`] at one frequency.
struct ModalReceptanceAt {
    omega: f64,
    harmonic: Vec<ModalHarmonic>,
    basis: Arc<ModalBasis>,
}

impl ModalReceptanceAt {
    /// `r = f_k + W λ̂_k` (`with_load`) or `W λ̂_k`, and its modal projection `Φᵀ r`.
    fn load_and_projection(
        &self,
        k: usize,
        force: &[c64],
        with_load: bool,
    ) -> (Vec<c64>, Mat<c64>) {
        let b = &*self.basis;
        let h = &self.harmonic[k];
        let mut r = match (&h.load, with_load) {
            (Some(f), true) => f.clone(),
            _ => vec![ZERO; b.n_dofs],
        };
        b.contacts.scatter_add(force, &mut r);
        // Φᵀ W λ̂ = Bᵀ λ̂
        let mut z = b.contact_shapes.transpose() * faer::ColRef::from_slice(force).as_mat();
        if let (Some(p), true) = (&h.modal_load, with_load) {
            z += p;
        }
        (r, z)
    }
}

impl ReceptanceAtFrequency for ModalReceptanceAt {
    fn omega(&self) -> f64 {
        self.omega
    }

    fn harmonics(&self) -> usize {
        self.harmonic.len() - 1
    }

    fn receptance(&self, k: usize) -> &[c64] {
        &self.harmonic[k].receptance
    }

    fn load_response(&self, k: usize) -> &[c64] {
        &self.harmonic[k].load_response
    }

    /// `q̂_k ≈ K⁻¹ r + Φ X_k Φᵀ r` with `r = f_k + W λ̂_k` (T130).
    fn response(&self, k: usize, force: &[c64]) -> Result<Vec<c64>> {
        let b = &*self.basis;
        let (r, z) = self.load_and_projection(k, force, true);
        let mut q = b.static_solve(&r);
        let modal = &b.shapes * (&self.harmonic[k].correction * &z);
        q.iter_mut()
            .enumerate()
            .for_each(|(i, v)| *v += modal[(i, 0)]);
        Ok(q)
    }

    /// `∂(Wᵀ q̂_k)/∂ω = B ∂Y_k/∂ω Φᵀ r`, `∂Y_k/∂ω = −Y_k (−2k²ω I + i k Φᵀ C Φ) Y_k`: the
    /// derivative of the modal receptance itself (T131), so that Newton's Jacobian is that
    /// of the residual it solves.
    fn frequency_derivative(&self, k: usize, force: &[c64], with_load: bool) -> Result<Vec<c64>> {
        let b = &*self.basis;
        let nc = b.contacts.len();
        if k == 0 {
            return Ok(vec![ZERO; nc]);
        }
        let (_, z) = self.load_and_projection(k, force, with_load);
        let y = &self.harmonic[k].dynamic_compliance;
        let kf = k as f64;
        let m = b.modal_damping.nrows();
        let mut da = Mat::<c64>::from_fn(m, m, |i, j| c64::new(0.0, kf) * b.modal_damping[(i, j)]);
        (0..m).for_each(|j| da[(j, j)] -= c64::new(2.0 * kf * kf * self.omega, 0.0));
        let dy_z = y * (&da * (y * &z));
        let out = &b.contact_shapes * &dy_z;
        Ok((0..nc).map(|c| -out[(c, 0)]).collect())
    }
}
