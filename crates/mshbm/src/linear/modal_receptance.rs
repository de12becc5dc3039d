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
use super::receptance::{ContactCoordinates, Receptance, ReceptanceAtFrequency, StaticPlusLowRank};
use super::ZERO;
use crate::error::{Error, Result};
use crate::model::System;
use crate::modes::LowestModes;
use crate::sparse::SparseMatrix;

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
    /// `Φᵀ C Φ` (`m × m`).
    modal_damping: Mat<f64>,
    /// `Wᵀ K⁻¹ W` (`n_c × n_c`).
    static_receptance: Mat<f64>,
    /// Per loaded harmonic `k ≤ 1`: `Wᵀ K⁻¹ f_k` and `Φᵀ f_k` (the loads are real and do
    /// not depend on the frequency).
    static_load: [Option<StaticLoad>; 2],
}

/// The frequency-independent parts of the response to one harmonic of the load.
struct StaticLoad {
    /// `Wᵀ K⁻¹ f_k` (`n_c`).
    contacts: Vec<f64>,
    /// `Φᵀ f_k` (`m`).
    modal: Mat<f64>,
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
        let modal_damping = phi.transpose() * (system.damping.to_faer() * &phi);
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
            let modal = phi.transpose() * faer::ColRef::from_slice(f).as_mat();
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
                contact_shapes,
                modal_damping,
                static_receptance,
                static_load,
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
    /// `K⁻¹ r` for a complex `r` (real and imaginary parts solved together), factoring `K`
    /// again on the first call.
    fn static_solve(&self, r: &[c64]) -> Result<Vec<c64>> {
        let factor = match self.factor.get() {
            Some(f) => f,
            None => {
                let f = crate::modes::stiffness_factor(&self.stiffness)?;
                self.factor.get_or_init(|| f)
            }
        };
        let mut x = Mat::<f64>::from_fn(r.len(), 2, |i, j| if j == 0 { r[i].re } else { r[i].im });
        factor.solve_in_place(x.as_mut());
        Ok((0..r.len())
            .map(|i| c64::new(x[(i, 0)], x[(i, 1)]))
            .collect())
    }

    /// `Bᵀ λ` for complex contact forces `λ` (`m × 1`).
    fn project_forces(&self, force: &[c64]) -> Mat<c64> {
        let f = Mat::<c64>::from_fn(force.len(), 1, |i, _| force[i]);
        real_times_complex(self.contact_shapes.transpose(), &f)
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
        let m = self.n_modes();
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
                c64::new(diagonal, big_omega * b.modal_damping[(i, j)])
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
            // Wᵀ A_k⁻¹ f_k = Wᵀ K⁻¹ f_k + B X_k Φᵀ f_k
            let load_response = match b.static_load.get(k).and_then(Option::as_ref) {
                Some(s) => {
                    let correction = real_times_complex(
                        b.contact_shapes.as_ref(),
                        &(&x * Mat::<c64>::from_fn(m, 1, |j, _| c64::new(s.modal[(j, 0)], 0.0))),
                    );
                    s.contacts
                        .iter()
                        .enumerate()
                        .map(|(c, &v)| c64::new(v, 0.0) + correction[(c, 0)])
                        .collect()
                }
                None => vec![ZERO; self.n_contacts()],
            };
            harmonic.push(ModalHarmonic {
                receptance: std::sync::OnceLock::new(),
                load_response,
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

    fn static_plus_low_rank(&self) -> Option<StaticPlusLowRank<'_>> {
        Some(StaticPlusLowRank {
            static_receptance: self.basis.static_receptance.as_ref(),
            contact_shapes: self.basis.contact_shapes.as_ref(),
        })
    }
}

/// One harmonic of [`ModalReceptance`] at one frequency.
struct ModalHarmonic {
    /// `R_k = Wᵀ K⁻¹ W + B X_k Bᵀ` (row-major), formed on first use: the redistributed
    /// MS-HBM works with the parts instead (docs/theory.md (T136)).
    receptance: std::sync::OnceLock<Vec<c64>>,
    load_response: Vec<c64>,
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
    /// `Φᵀ r` for `r = f_k + W λ̂_k` (`with_load`) or `r = W λ̂_k`: `Bᵀ λ̂_k (+ Φᵀ f_k)`.
    fn projection(&self, k: usize, force: &[c64], with_load: bool) -> Mat<c64> {
        let b = &*self.basis;
        let mut z = b.project_forces(force);
        if let (Some(s), true) = (b.static_load.get(k).and_then(Option::as_ref), with_load) {
            (0..z.nrows()).for_each(|j| z[(j, 0)] += c64::new(s.modal[(j, 0)], 0.0));
        }
        z
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
        let h = &self.harmonic[k];
        h.receptance.get_or_init(|| {
            let b = &*self.basis;
            let nc = b.contacts.len();
            let bx = real_times_complex(b.contact_shapes.as_ref(), &h.correction);
            let (re, im) = (
                Mat::<f64>::from_fn(nc, bx.ncols(), |i, j| bx[(i, j)].re),
                Mat::<f64>::from_fn(nc, bx.ncols(), |i, j| bx[(i, j)].im),
            );
            let re = &b.static_receptance + &re * b.contact_shapes.transpose();
            let im = &im * b.contact_shapes.transpose();
            (0..nc * nc)
                .map(|e| c64::new(re[(e / nc, e % nc)], im[(e / nc, e % nc)]))
                .collect()
        })
    }

    fn load_response(&self, k: usize) -> &[c64] {
        &self.harmonic[k].load_response
    }

    fn modal_correction(&self, k: usize) -> Option<&Mat<c64>> {
        Some(&self.harmonic[k].correction)
    }

    /// `q̂_k ≈ K⁻¹ r + Φ X_k Φᵀ r` with `r = f_k + W λ̂_k` (T130).
    fn response(&self, k: usize, force: &[c64]) -> Result<Vec<c64>> {
        let b = &*self.basis;
        let mut r = match b.load.complex(k) {
            Some(f) => f,
            None => vec![ZERO; b.n_dofs],
        };
        b.contacts.scatter_add(force, &mut r);
        let z = self.projection(k, force, true);
        let mut q = b.static_solve(&r)?;
        let modal = real_times_complex(b.shapes.as_ref(), &(&self.harmonic[k].correction * &z));
        q.iter_mut()
            .enumerate()
            .for_each(|(i, v)| *v += modal[(i, 0)]);
        Ok(q)
    }

    /// `∂(Wᵀ q̂_k)/∂ω = B ∂Y_k/∂ω Φᵀ r`, `∂Y_k/∂ω = −Y_k (−2k²ω I + i k Φᵀ C Φ) Y_k`: the
    /// derivative of the modal receptance itself (T132), so that Newton's Jacobian is that
    /// of the residual it solves.
    fn frequency_derivative(&self, k: usize, force: &[c64], with_load: bool) -> Result<Vec<c64>> {
        let b = &*self.basis;
        let nc = b.contacts.len();
        if k == 0 {
            return Ok(vec![ZERO; nc]);
        }
        let z = self.projection(k, force, with_load);
        let y = &self.harmonic[k].dynamic_compliance;
        let kf = k as f64;
        let m = b.modal_damping.nrows();
        let mut da = Mat::<c64>::from_fn(m, m, |i, j| c64::new(0.0, kf * b.modal_damping[(i, j)]));
        (0..m).for_each(|j| da[(j, j)] -= c64::new(2.0 * kf * kf * self.omega, 0.0));
        let dy_z = y * (&da * (y * &z));
        let out = real_times_complex(b.contact_shapes.as_ref(), &dy_z);
        Ok((0..nc).map(|c| -out[(c, 0)]).collect())
    }
}
