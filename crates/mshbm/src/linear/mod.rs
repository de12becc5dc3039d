//! The linear subsystem in the frequency domain (paper eqs. 6–8, 25): the dynamic stiffness
//! of the L-part per harmonic, factored once per frequency.
//!
//! For harmonic `k`, with the complex amplitude `z = a − i b` of `a cos kτ + b sin kτ`, the
//! real 2×2 block of eq. (8) is equivalent to the complex symmetric matrix
//! `A_k(ω) = K − (kω)² M + i kω C` (`A_0 = K`). The sparsity pattern is analysed once
//! ([`LinearPart::new`]); each frequency refactors numerically ([`LinearPart::factor`]).

use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Lu, SymbolicLu};
use faer::{c64, Mat};

use crate::error::{Error, Result};
use crate::sparse::SparseMatrix;

/// Mass, damping and stiffness of the linear part, with the analysed sparsity pattern.
pub struct LinearPart {
    pub mass: SparseMatrix,
    pub damping: SparseMatrix,
    pub stiffness: SparseMatrix,
    pattern: SparseMatrix,
    symbolic: SymbolicLu<usize>,
    mass_values: Vec<f64>,
    damping_values: Vec<f64>,
    stiffness_values: Vec<f64>,
}

/// The factored `A_k(ω)` for `k = 0..=H`.
pub struct HarmonicFactors {
    pub omega: f64,
    factors: Vec<Lu<usize, c64>>,
}

impl LinearPart {
    pub fn new(mass: SparseMatrix, damping: SparseMatrix, stiffness: SparseMatrix) -> Result<Self> {
        let n = stiffness.nrows();
        let pattern = SparseMatrix::union_pattern(n, n, &[&mass, &damping, &stiffness]);
        let symbolic = SymbolicLu::try_new(pattern.faer_symbolic().as_ref()).map_err(|e| {
            Error::Numerical(format!("sparse LU analysis of the linear part: {e:?}"))
        })?;
        Ok(LinearPart {
            mass_values: mass.values_on_pattern(&pattern),
            damping_values: damping.values_on_pattern(&pattern),
            stiffness_values: stiffness.values_on_pattern(&pattern),
            mass,
            damping,
            stiffness,
            pattern,
            symbolic,
        })
    }

    pub fn n_dofs(&self) -> usize {
        self.stiffness.nrows()
    }

    /// Factor `A_k(ω)` for `k = 0..=harmonics`.
    pub fn factor(&self, omega: f64, harmonics: usize) -> Result<HarmonicFactors> {
        let factors = (0..=harmonics)
            .map(|k| {
                let kw = k as f64 * omega;
                let values: Vec<c64> = (0..self.stiffness_values.len())
                    .map(|e| {
                        c64::new(
                            self.stiffness_values[e] - kw * kw * self.mass_values[e],
                            kw * self.damping_values[e],
                        )
                    })
                    .collect();
                let a = faer::sparse::SparseColMat::new(self.pattern.faer_symbolic(), values);
                Lu::try_new_with_symbolic(self.symbolic.clone(), a.as_ref()).map_err(|e| {
                    Error::Numerical(format!(
                        "sparse LU of the dynamic stiffness (harmonic {k}): {e:?}"
                    ))
                })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(HarmonicFactors { omega, factors })
    }
}

impl HarmonicFactors {
    /// Solve `A_k X = RHS` in place. Fails when the result is not finite (the frequency
    /// `kω` hits an undamped eigenfrequency of the linear part).
    pub fn solve_in_place(&self, k: usize, rhs: &mut Mat<c64>) -> Result<()> {
        self.factors[k].solve_in_place(rhs.as_mut());
        if rhs
            .col_iter()
            .any(|c| c.iter().any(|v| !(v.re.is_finite() && v.im.is_finite())))
        {
            return Err(Error::Singular(format!(
                "the dynamic stiffness of the linear part is singular at harmonic {k} (k·f = {:.6} Hz is an eigenfrequency of the structure with the contact DOFs held; add damping or move the frequency)",
                k as f64 * self.omega / (2.0 * std::f64::consts::PI)
            )));
        }
        Ok(())
    }

    pub fn harmonics(&self) -> usize {
        self.factors.len() - 1
    }
}

/// `dA_k/dω = −2k²ω M + i k C` applied to a complex vector.
pub fn dynamic_stiffness_derivative_times(
    part: &LinearPart,
    k: usize,
    omega: f64,
    x: &[c64],
) -> Vec<c64> {
    let kf = k as f64;
    let mut out = vec![c64::new(0.0, 0.0); x.len()];
    for (i, j, m) in part.mass.iter() {
        out[i] += x[j] * (-2.0 * kf * kf * omega * m);
    }
    for (i, j, c) in part.damping.iter() {
        out[i] += x[j] * c64::new(0.0, kf * c);
    }
    out
}

/// Fourier coefficients (harmonic-major, `c·n + i`) of the load on the N-DOFs
/// `b(τ) = −K_NL q_L(τ) + f_N(τ)` for the N-coefficients `x`, given per harmonic `k`
/// `G_k = K_NL A_k⁻¹ K_LN` (`n × n`, row-major) and `u0_k = K_NL A_k⁻¹ f_L,k`, so that
/// `K_NL q̂_L,k = u0_k − G_k z_k` with `z_k = a_k − i b_k` (eqs. 6/25). `constant_n` and
/// `harmonic_n` are the constant and `cos ωt` loads on N.
pub fn interface_load_coefficients(
    g: &[Vec<c64>],
    u0: &[Vec<c64>],
    constant_n: &[f64],
    harmonic_n: &[f64],
    x: &[f64],
) -> Vec<f64> {
    let n = constant_n.len();
    let harmonics = g.len() - 1;
    let mut b = vec![0.0; n * (2 * harmonics + 1)];
    for (i, mean) in b.iter_mut().enumerate().take(n) {
        *mean =
            -u0[0][i].re + constant_n[i] + (0..n).map(|j| g[0][i * n + j].re * x[j]).sum::<f64>();
    }
    for k in 1..=harmonics {
        let (ci, si) = ((2 * k - 1) * n, 2 * k * n);
        let gk = &g[k];
        for i in 0..n {
            let mut bc = -u0[k][i].re;
            let mut bs = u0[k][i].im;
            if k == 1 {
                bc += harmonic_n[i];
            }
            for j in 0..n {
                let (gr, gi) = (gk[i * n + j].re, gk[i * n + j].im);
                let (a, s) = (x[ci + j], x[si + j]);
                bc += gr * a + gi * s;
                bs += -gi * a + gr * s;
            }
            b[ci + i] = bc;
            b[si + i] = bs;
        }
    }
    b
}
