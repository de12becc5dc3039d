//! [`ModalReceptance`] at one frequency: the modal basis's solves and projections, the
//! compliance of each harmonic (full or diagonal modal damping) and the responses built
//! from it.

use std::sync::{Arc, OnceLock};

use faer::linalg::solvers::Solve;
use faer::{c64, Mat};

use super::super::receptance::{Receptance, ReceptanceAtFrequency, StaticPlusLowRank};
use super::super::ZERO;
use super::{real_times_complex, ModalBasis, ModalReceptance};
use crate::error::{Error, Result};

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

    /// One harmonic `k` at `ω` with diagonal damping `c_j` ((T148)), written
    /// into its storage: `y_j = 1/(ω_j² − Ω² + iΩ c_j)`, `x_j = y_j − 1/ω_j²` formed as
    /// `(Ω² − iΩ c_j) y_j / ω_j²` (no cancellation where `Ω ≪ ω_j`),
    /// `R_k = R_s + Σ_j b_j b_jᵀ x_j` and `Wᵀ A_k⁻¹ f_k = Wᵀ K⁻¹ f_k + Σ_j b_j x_j (Φᵀ f_k)_j`
    /// (`b_j` the columns of `B`).
    fn fill_diagonal(
        &self,
        damping: &[f64],
        k: usize,
        omega: f64,
        harmonic: &mut ModalHarmonic,
    ) -> Result<()> {
        let ModalCompliance::Diagonal {
            dynamic,
            correction,
            receptance,
            correction_matrix,
        } = &mut harmonic.compliance
        else {
            unreachable!("fill_diagonal on the diagonal form only")
        };
        let big = k as f64 * omega;
        for (j, (&w2, &c)) in self.eigenvalues.iter().zip(damping).enumerate() {
            let (re, im) = (w2 - big * big, big * c);
            let norm = re * re + im * im;
            let y = c64::new(re / norm, -im / norm);
            if !(y.re.is_finite() && y.im.is_finite()) {
                return Err(undamped_resonance(k, omega));
            }
            dynamic[j] = y;
            correction[j] = c64::new(big * big, -big * c) * y * (1.0 / w2);
        }
        let (nc, m) = (self.contacts.len(), self.eigenvalues.len());
        for a in 0..nc {
            let row_a = &self.shape_rows[a * m..(a + 1) * m];
            for b in a..nc {
                let row_b = &self.shape_rows[b * m..(b + 1) * m];
                let sum = (0..m).fold(ZERO, |s, j| s + correction[j] * (row_a[j] * row_b[j]));
                let r = sum + c64::new(self.static_receptance[(a, b)], 0.0);
                receptance[a * nc + b] = r;
                receptance[b * nc + a] = r;
            }
        }
        match self.static_load.get(k).and_then(Option::as_ref) {
            Some(s) => {
                for (c, out) in harmonic.load_response.iter_mut().enumerate() {
                    let row = &self.shape_rows[c * m..(c + 1) * m];
                    let sum =
                        (0..m).fold(ZERO, |t, j| t + correction[j] * (row[j] * s.modal[(j, 0)]));
                    *out = c64::new(s.contacts[c], 0.0) + sum;
                }
            }
            None => harmonic.load_response.fill(ZERO),
        }
        // X_k as a matrix is formed again on request
        correction_matrix.take();
        Ok(())
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
        let nc = self.n_contacts();
        let b = &*self.basis;
        let mut harmonic = Vec::with_capacity(harmonics + 1);
        for k in 0..=harmonics {
            if let Some(damping) = &b.diagonal_damping {
                let mut h = ModalHarmonic {
                    load_response: vec![ZERO; nc],
                    compliance: ModalCompliance::Diagonal {
                        dynamic: vec![ZERO; m],
                        correction: vec![ZERO; m],
                        receptance: vec![ZERO; nc * nc],
                        correction_matrix: OnceLock::new(),
                    },
                };
                b.fill_diagonal(damping, k, omega, &mut h)?;
                harmonic.push(h);
                continue;
            }
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
                return Err(undamped_resonance(k, omega));
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
                None => vec![ZERO; nc],
            };
            harmonic.push(ModalHarmonic {
                load_response,
                compliance: ModalCompliance::Full {
                    receptance: OnceLock::new(),
                    dynamic: y,
                    correction: x,
                },
            });
        }
        Ok(Box::new(ModalReceptanceAt {
            omega,
            harmonic,
            basis: Arc::clone(&self.basis),
        }))
    }

    /// `R_s` and `B`; not offered when the modes diagonalise the damping and there are at
    /// least as many modes as contacts: then forming `R_k` (`n_c² m`) and its inverse
    /// (`n_c³`) costs less than the `m × m` inverse of (T136) per harmonic.
    fn static_plus_low_rank(&self) -> Option<StaticPlusLowRank<'_>> {
        if self.basis.diagonal_damping.is_some() && self.n_modes() >= self.n_contacts() {
            return None;
        }
        Some(StaticPlusLowRank {
            static_receptance: self.basis.static_receptance.as_ref(),
            contact_shapes: self.basis.contact_shapes.as_ref(),
        })
    }
}

fn undamped_resonance(k: usize, omega: f64) -> Error {
    Error::Singular(format!(
        "the modal dynamic stiffness of harmonic {k} at {omega:.6e} rad/s is singular (an undamped resonance)"
    ))
}

/// One harmonic of [`ModalReceptance`] at one frequency.
struct ModalHarmonic {
    load_response: Vec<c64>,
    compliance: ModalCompliance,
}

/// `Y_k`, `X_k = Y_k − diag(1/ω_j²)` and `R_k` of one harmonic.
enum ModalCompliance {
    /// A full `Φᵀ C Φ`: `Y_k`, `X_k` (`m × m`); `R_k = Wᵀ K⁻¹ W + B X_k Bᵀ` (row-major)
    /// formed on first use, since the redistributed MS-HBM works with the parts instead
    /// (docs/theory.md (T136)).
    Full {
        receptance: OnceLock<Vec<c64>>,
        dynamic: Mat<c64>,
        correction: Mat<c64>,
    },
    /// A diagonal `Φᵀ C Φ`: the diagonals of `Y_k` and `X_k`, `R_k` (row-major), and `X_k`
    /// as a matrix formed on request ([`ReceptanceAtFrequency::modal_correction`]).
    Diagonal {
        dynamic: Vec<c64>,
        correction: Vec<c64>,
        receptance: Vec<c64>,
        correction_matrix: OnceLock<Mat<c64>>,
    },
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

    /// `X_k z` (`m × 1`).
    fn correction_times(&self, k: usize, z: &Mat<c64>) -> Mat<c64> {
        match &self.harmonic[k].compliance {
            ModalCompliance::Full { correction, .. } => correction * z,
            ModalCompliance::Diagonal { correction, .. } => {
                Mat::from_fn(z.nrows(), 1, |j, _| correction[j] * z[(j, 0)])
            }
        }
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
        match &self.harmonic[k].compliance {
            ModalCompliance::Diagonal { receptance, .. } => receptance,
            ModalCompliance::Full {
                receptance,
                correction,
                ..
            } => receptance.get_or_init(|| {
                let b = &*self.basis;
                let nc = b.contacts.len();
                let bx = real_times_complex(b.contact_shapes.as_ref(), correction);
                let (re, im) = (
                    Mat::<f64>::from_fn(nc, bx.ncols(), |i, j| bx[(i, j)].re),
                    Mat::<f64>::from_fn(nc, bx.ncols(), |i, j| bx[(i, j)].im),
                );
                let re = &b.static_receptance + &re * b.contact_shapes.transpose();
                let im = &im * b.contact_shapes.transpose();
                (0..nc * nc)
                    .map(|e| c64::new(re[(e / nc, e % nc)], im[(e / nc, e % nc)]))
                    .collect()
            }),
        }
    }

    fn load_response(&self, k: usize) -> &[c64] {
        &self.harmonic[k].load_response
    }

    fn modal_correction(&self, k: usize) -> Option<&Mat<c64>> {
        Some(match &self.harmonic[k].compliance {
            ModalCompliance::Full { correction, .. } => correction,
            ModalCompliance::Diagonal {
                correction,
                correction_matrix,
                ..
            } => correction_matrix.get_or_init(|| {
                let m = correction.len();
                Mat::from_fn(m, m, |i, j| if i == j { correction[i] } else { ZERO })
            }),
        })
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
        let modal = real_times_complex(b.shapes.as_ref(), &self.correction_times(k, &z));
        q.iter_mut()
            .enumerate()
            .for_each(|(i, v)| *v += modal[(i, 0)]);
        Ok(q)
    }

    /// With every mode, `q̂_i = (E r)_i + Σ_j φ_ij (Y_k Φᵀ r)_j` (T149) (no solve with `K`;
    /// [`MasslessBlock`]); otherwise the whole response.
    fn response_rows(
        &self,
        k: usize,
        force: &[c64],
        rows: &[usize],
        out: &mut [c64],
    ) -> Result<()> {
        let b = &*self.basis;
        let Some(block) = &b.every_mode else {
            return super::super::receptance::rows_of_whole_response(self, k, force, rows, out);
        };
        let z = self.projection(k, force, true);
        let yz = match &self.harmonic[k].compliance {
            ModalCompliance::Full { dynamic, .. } => dynamic * &z,
            ModalCompliance::Diagonal { dynamic, .. } => {
                Mat::from_fn(z.nrows(), 1, |j, _| dynamic[j] * z[(j, 0)])
            }
        };
        // r on the massless DOFs: f_k + W λ̂_k there
        let mut massless_force = vec![ZERO; block.count];
        if let Some(f) = b.load.real(k) {
            for (d, p) in block.position.iter().enumerate() {
                if let Some(p) = p {
                    massless_force[*p] += c64::new(f[d], 0.0);
                }
            }
        }
        for (w, &l) in b.contacts.w.iter().zip(force) {
            for &(d, v) in w {
                if let Some(p) = block.position[d] {
                    massless_force[p] += l * v;
                }
            }
        }
        for (o, &r) in out.iter_mut().zip(rows) {
            let modal = (0..yz.nrows()).fold(ZERO, |s, j| s + yz[(j, 0)] * b.shapes[(r, j)]);
            let massless = block.position[r].map_or(ZERO, |p| {
                (0..block.count).fold(ZERO, |s, q| {
                    s + massless_force[q] * block.inverse[p * block.count + q]
                })
            });
            *o = modal + massless;
        }
        Ok(())
    }

    /// `∂(Wᵀ q̂_k)/∂ω = B ∂Y_k/∂ω Φᵀ r`, `∂Y_k/∂ω = −Y_k (−2k²ω I + i k Φᵀ C Φ) Y_k`: the
    /// derivative of the modal receptance itself (T132), so that Newton's Jacobian is that
    /// of the residual it solves.
    fn frequency_derivative(&self, k: usize, force: &[c64], with_load: bool) -> Result<Vec<c64>> {
        let mut out = vec![ZERO; force.len()];
        self.frequency_derivative_into(k, force, with_load, &mut out, &mut Vec::new())?;
        Ok(out)
    }

    /// [`ReceptanceAtFrequency::frequency_derivative`]; with diagonal damping term by term (T148),
    /// `−Σ_j b_j y_j² (−2k²ω + i k c_j) (Φᵀ r)_j`, without allocating.
    fn frequency_derivative_into(
        &self,
        k: usize,
        force: &[c64],
        with_load: bool,
        out: &mut [c64],
        _scratch: &mut Vec<c64>,
    ) -> Result<()> {
        let b = &*self.basis;
        let nc = b.contacts.len();
        out.fill(ZERO);
        if k == 0 {
            return Ok(());
        }
        let kf = k as f64;
        match &self.harmonic[k].compliance {
            ModalCompliance::Diagonal { dynamic, .. } => {
                let damping = b.diagonal_damping.as_deref().expect("diagonal damping");
                let m = dynamic.len();
                let load = b
                    .static_load
                    .get(k)
                    .and_then(Option::as_ref)
                    .filter(|_| with_load);
                for (j, (&y, &c)) in dynamic.iter().zip(damping).enumerate() {
                    // (Φᵀ r)_j = (Bᵀ λ̂_k)_j (+ (Φᵀ f_k)_j)
                    let mut z = load.map_or(ZERO, |s| c64::new(s.modal[(j, 0)], 0.0));
                    for (cf, &l) in force.iter().enumerate() {
                        z += l * b.shape_rows[cf * m + j];
                    }
                    let t = y * y * c64::new(-2.0 * kf * kf * self.omega, kf * c) * z;
                    for (cf, o) in out.iter_mut().enumerate() {
                        *o -= t * b.shape_rows[cf * m + j];
                    }
                }
            }
            ModalCompliance::Full { dynamic: y, .. } => {
                let z = self.projection(k, force, with_load);
                let m = b.modal_damping.nrows();
                let mut da =
                    Mat::<c64>::from_fn(m, m, |i, j| c64::new(0.0, kf * b.modal_damping[(i, j)]));
                (0..m).for_each(|j| da[(j, j)] -= c64::new(2.0 * kf * kf * self.omega, 0.0));
                let dy_z = y * (&da * (y * &z));
                let product = real_times_complex(b.contact_shapes.as_ref(), &dy_z);
                (0..nc).for_each(|c| out[c] = -product[(c, 0)]);
            }
        }
        Ok(())
    }

    /// With diagonal damping every harmonic is formed again in its storage (nothing is
    /// allocated); a full `Φᵀ C Φ` asks for a new receptance.
    fn refresh(&mut self, omega: f64) -> Result<bool> {
        let b = &*self.basis;
        let Some(damping) = &b.diagonal_damping else {
            return Ok(false);
        };
        for (k, harmonic) in self.harmonic.iter_mut().enumerate() {
            b.fill_diagonal(damping, k, omega, harmonic)?;
        }
        self.omega = omega;
        Ok(true)
    }
}
