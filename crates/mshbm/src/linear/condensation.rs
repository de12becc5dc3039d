//! Condensation of the linear part onto the nonlinear DOFs, per frequency (paper eqs. 6 and
//! 25, in complex form).
//!
//! For harmonic `k` the linear part responds to the amplitudes `z_k = a_k − i b_k` of the
//! `N` DOFs (the harmonic `k` of `x = q̂_N`) by eq. (6), docs/theory.md (T17):
//!
//! ```text
//! q̂_L,k = A_LL,k⁻¹ (f_L,k − A_LN,k z_k),
//! ```
//!
//! and the force it exerts on `N` is affine in `z_k` (docs/theory.md (T19)–(T20)):
//!
//! ```text
//! A_NL,k q̂_L,k = u0_k − G_k z_k,   G_k = A_NL,k A_LL,k⁻¹ A_LN,k,   u0_k = A_NL,k A_LL,k⁻¹ f_L,k
//! ```
//!
//! (`G_k` is `n_N × n_N`; with the redistributed mass `M_NL = C_NL = 0` and it reduces to
//! `K_NL A_LL,k⁻¹ K_LN`, eq. 25). The `N` equations then read (docs/theory.md (T23))
//!
//! ```text
//! H̃_k z_k = F̃_k + λ̂_N,k,   H̃_k = A_NN,k − G_k,   F̃_k = f_N,k − u0_k,
//! ```
//!
//! and the load on `N` that the MS-HBM's nonlinear subsystem sees is
//! `B_k(x) = f_N,k − A_NL,k q̂_L,k = f_N,k − u0_k + G_k z_k` (eq. 10 with the derivatives of
//! `q_L` taken in the frequency domain). Its frequency derivative at fixed `x` follows from
//! `∂q̂_L,k/∂ω = −A_LL,k⁻¹ (∂A_LL,k/∂ω q̂_L,k + ∂A_LN,k/∂ω z_k)` (docs/theory.md (T22),
//! (T24)):
//!
//! ```text
//! ∂(A_NL,k q̂_L,k)/∂ω = ∂u0_k/∂ω − ∂G_k/∂ω z_k
//!                     = ∂A_NL,k/∂ω q̂_L,k + A_NL,k ∂q̂_L,k/∂ω,      ∂B_k/∂ω = −that.
//! ```
//!
//! [`Condensation`] is the interface the periodic-solution methods use; [`ExactCondensation`]
//! implements it with a sparse LU of `A_LL,k` per harmonic. Another implementation (e.g. a
//! reduced basis of fixed-interface modes with a static correction) only needs to provide
//! `G_k`, `u0_k`, `q̂_L,k` and the derivative above; the methods need no change.

use std::sync::Arc;

use faer::{c64, Mat};

use super::dynamic_stiffness::{HarmonicFactors, LinearPart};
use super::partitioned::PartitionedSystem;
use super::{complex_harmonic, store_harmonic, ZERO};
use crate::error::Result;
use crate::harmonic::n_coefficients;

/// A condensation of the linear part of a [`PartitionedSystem`] onto its `N` DOFs (module
/// docs): [`Condensation::at`] does the per-frequency work once.
pub trait Condensation: Send + Sync {
    /// The partitioned system it condenses.
    fn system(&self) -> &PartitionedSystem;

    /// The condensation at `ω` (rad/s) for the harmonics `k = 0..=harmonics`.
    fn at(&self, omega: f64, harmonics: usize) -> Result<Box<dyn CondensedFrequency>>;
}

/// The condensed linear part at one frequency `ω` for the harmonics `k = 0..=H` (module docs
/// for the equations). Complex amplitudes are `z = a − i b` for `a cos kτ + b sin kτ`;
/// harmonic-major real coefficients `x` hold coefficient `c` (`[a0, a1, b1, a2, …]`) of `N`
/// DOF `i` at `c·n_N + i`.
pub trait CondensedFrequency: Send + Sync {
    /// `ω` (rad/s).
    fn omega(&self) -> f64;

    /// `H`.
    fn harmonics(&self) -> usize;

    /// The partitioned system.
    fn system(&self) -> &PartitionedSystem;

    /// `G_k = A_NL,k A_LL,k⁻¹ A_LN,k` (`n_N × n_N`, row-major; docs/theory.md (T20)).
    fn interface_stiffness(&self, k: usize) -> &[c64];

    /// `u0_k = A_NL,k A_LL,k⁻¹ f_L,k` (`n_N`; docs/theory.md (T20)).
    fn interface_load(&self, k: usize) -> &[c64];

    /// `q̂_L,k = A_LL,k⁻¹ (f_L,k − A_LN,k z_k)` for the `N` amplitudes `z_k` (all `L` DOFs;
    /// paper eq. 6, docs/theory.md (T17)).
    fn linear_amplitudes(&self, k: usize, z: &[c64]) -> Result<Vec<c64>>;

    /// `out += ∂(A_NL,k q̂_L,k)/∂ω = ∂u0_k/∂ω − ∂G_k/∂ω z_k` at fixed `z_k`, i.e.
    /// `∂A_NL,k/∂ω q̂_L,k + A_NL,k ∂q̂_L,k/∂ω` with
    /// `∂q̂_L,k/∂ω = −A_LL,k⁻¹ (∂A_LL,k/∂ω q̂_L,k + ∂A_LN,k/∂ω z_k)` and
    /// `∂A_k/∂ω = −2k²ω M + i k C` (docs/theory.md (T24), (T14)).
    fn add_coupling_force_derivative(&self, k: usize, z: &[c64], out: &mut [c64]) -> Result<()>;

    /// Number of `N` DOFs.
    fn n_nonlinear(&self) -> usize {
        self.system().n_nonlinear()
    }

    /// The Fourier coefficients `[a0, a1, b1, …]` of `L` DOF `l` for the harmonic-major `N`
    /// coefficients `x` (eq. 6).
    fn linear_dof_coefficients(&self, x: &[f64], l: usize) -> Result<Vec<f64>> {
        let n = self.n_nonlinear();
        let mut out = vec![0.0; n_coefficients(self.harmonics())];
        for k in 0..=self.harmonics() {
            let q = self.linear_amplitudes(k, &complex_harmonic(x, n, k))?;
            store_harmonic(&[q[l]], 1, k, &mut out);
        }
        Ok(out)
    }

    /// The condensed dynamic stiffness `H̃_k = A_NN,k − G_k` (`n_N × n_N`; docs/theory.md
    /// (T23)).
    fn condensed_dynamic_stiffness(&self, k: usize) -> Mat<c64> {
        let n = self.n_nonlinear();
        let g = self.interface_stiffness(k);
        let mut h = self.system().nn.dense(k, self.omega());
        for j in 0..n {
            for i in 0..n {
                h[(i, j)] -= g[i * n + j];
            }
        }
        h
    }

    /// The condensed load `F̃_k = f_N,k − u0_k` (`n_N`; docs/theory.md (T23)).
    fn condensed_load(&self, k: usize) -> Vec<c64> {
        let mut f = self
            .system()
            .load_n
            .complex(k)
            .unwrap_or_else(|| vec![ZERO; self.n_nonlinear()]);
        f.iter_mut()
            .zip(self.interface_load(k))
            .for_each(|(f, u)| *f -= *u);
        f
    }

    /// The Fourier coefficients (harmonic-major) of the load on `N`,
    /// `B_k(x) = f_N,k − u0_k + G_k z_k` (docs/theory.md (T18)–(T20)), for the `N` coefficients
    /// `x` (its first `n_N (2H + 1)` entries).
    fn interface_load_coefficients(&self, x: &[f64]) -> Vec<f64> {
        let load_n = &self.system().load_n;
        let (constant_n, harmonic_n) = (&load_n.constant, &load_n.harmonic);
        let n = constant_n.len();
        let harmonics = self.harmonics();
        let (g0, u0) = (self.interface_stiffness(0), self.interface_load(0));
        let mut b = vec![0.0; n * n_coefficients(harmonics)];
        for (i, mean) in b.iter_mut().enumerate().take(n) {
            *mean =
                -u0[i].re + constant_n[i] + (0..n).map(|j| g0[i * n + j].re * x[j]).sum::<f64>();
        }
        for k in 1..=harmonics {
            let (ci, si) = ((2 * k - 1) * n, 2 * k * n);
            let (gk, uk) = (self.interface_stiffness(k), self.interface_load(k));
            for i in 0..n {
                let mut bc = -uk[i].re;
                let mut bs = uk[i].im;
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

    /// `∂B/∂ω` at `x` (harmonic-major, like [`Self::interface_load_coefficients`]):
    /// `∂B_k/∂ω = −∂(A_NL,k q̂_L,k)/∂ω` ([`Self::add_coupling_force_derivative`]; zero for
    /// `k = 0`; docs/theory.md (T22), (T24)).
    fn interface_load_frequency_derivative(&self, x: &[f64]) -> Result<Vec<f64>> {
        let n = self.n_nonlinear();
        let mut db = vec![0.0; n * n_coefficients(self.harmonics())];
        for k in 1..=self.harmonics() {
            let (ci, si) = ((2 * k - 1) * n, 2 * k * n);
            let mut dp = vec![ZERO; n];
            self.add_coupling_force_derivative(k, &complex_harmonic(x, n, k), &mut dp)?;
            for i in 0..n {
                db[ci + i] = -dp[i].re;
                db[si + i] = dp[i].im;
            }
        }
        Ok(db)
    }
}

/// How [`ExactCondensation`] evaluates the linear response `q̂_L,k(z_k)` (eq. 6). Both are
/// exact; they trade memory for solves, and differ in the last bits of round-off.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinearResponse {
    /// A sparse solve `A_LL,k⁻¹ (f_L,k − A_LN,k z_k)` per evaluation; only the factors are
    /// kept.
    Solve,
    /// `q̂_L,k = u_k − Y_k z_k` (docs/theory.md (T23)) with `Y_k = A_LL,k⁻¹ A_LN,k`
    /// (`n_L × n_N`) and `u_k = A_LL,k⁻¹ f_L,k`, kept from forming `G_k` and `u0_k`: no solve
    /// per evaluation, `n_L (n_N + 1) (H + 1)` complex numbers of memory per frequency.
    Stored,
}

/// The exact condensation: `A_LL,k` factored by a sparse LU per harmonic and frequency
/// ([`LinearPart`]), `G_k` and `u0_k` formed from `n_N + 1` solves per harmonic.
pub struct ExactCondensation {
    system: Arc<PartitionedSystem>,
    /// `None` when `L` is empty.
    linear: Option<Arc<LinearPart>>,
    response: LinearResponse,
}

impl ExactCondensation {
    /// Analyse the sparsity pattern of `A_LL` (once); `response` chooses how `q̂_L,k` is
    /// evaluated.
    pub fn new(system: PartitionedSystem, response: LinearResponse) -> Result<Self> {
        let linear = if system.n_linear() == 0 {
            None
        } else {
            Some(Arc::new(LinearPart::new(system.ll.clone())?))
        };
        Ok(ExactCondensation {
            system: Arc::new(system),
            linear,
            response,
        })
    }
}

impl Condensation for ExactCondensation {
    fn system(&self) -> &PartitionedSystem {
        &self.system
    }

    fn at(&self, omega: f64, harmonics: usize) -> Result<Box<dyn CondensedFrequency>> {
        let s = &*self.system;
        let (n, nl) = (s.n_nonlinear(), s.n_linear());
        let Some(linear) = &self.linear else {
            return Ok(Box::new(ExactFrequency {
                system: self.system.clone(),
                omega,
                factors: None,
                g: vec![vec![ZERO; n * n]; harmonics + 1],
                u0: vec![vec![ZERO; n]; harmonics + 1],
                stored: None,
            }));
        };
        let factors = linear.factor(omega, harmonics)?;
        let mut g = Vec::with_capacity(harmonics + 1);
        let mut u0 = Vec::with_capacity(harmonics + 1);
        let store = self.response == LinearResponse::Stored;
        let (mut ys, mut us) = (Vec::new(), Vec::new());
        let mut column = vec![ZERO; nl];
        let mut product = vec![ZERO; n];
        for k in 0..=harmonics {
            // Y = A_LL⁻¹ A_LN, then G = A_NL Y column by column
            let mut y = s.ln.dense(k, omega);
            factors.solve_in_place(k, &mut y.as_mut())?;
            let mut gk = vec![ZERO; n * n];
            for j in 0..n {
                (0..nl).for_each(|i| column[i] = y[(i, j)]);
                product.iter_mut().for_each(|v| *v = ZERO);
                s.nl.add_times(k, omega, &column, &mut product);
                (0..n).for_each(|i| gk[i * n + j] = product[i]);
            }
            g.push(gk);
            let mut uk = vec![ZERO; n];
            let u = match s.load_l.complex(k) {
                Some(f) => {
                    let u = factors.solve(k, &f)?;
                    s.nl.add_times(k, omega, &u, &mut uk);
                    u
                }
                None => vec![ZERO; nl],
            };
            u0.push(uk);
            if store {
                ys.push(y);
                us.push(u);
            }
        }
        Ok(Box::new(ExactFrequency {
            system: self.system.clone(),
            omega,
            factors: Some(factors),
            g,
            u0,
            stored: store.then_some(StoredResponse { y: ys, u: us }),
        }))
    }
}

/// [`ExactCondensation`] at one frequency.
struct ExactFrequency {
    system: Arc<PartitionedSystem>,
    omega: f64,
    /// `None` when `L` is empty.
    factors: Option<HarmonicFactors>,
    g: Vec<Vec<c64>>,
    u0: Vec<Vec<c64>>,
    /// [`LinearResponse::Stored`]: `Y_k` and `u_k`.
    stored: Option<StoredResponse>,
}

/// `Y_k = A_LL,k⁻¹ A_LN,k` (`n_L × n_N`) and `u_k = A_LL,k⁻¹ f_L,k` (`n_L`), `k = 0..=H`.
struct StoredResponse {
    y: Vec<Mat<c64>>,
    u: Vec<Vec<c64>>,
}

impl ExactFrequency {
    /// `A_LL,k⁻¹ rhs` (nothing to solve when `L` is empty).
    fn solve(&self, k: usize, rhs: &[c64]) -> Result<Vec<c64>> {
        match &self.factors {
            Some(f) => f.solve(k, rhs),
            None => Ok(rhs.to_vec()),
        }
    }
}

impl CondensedFrequency for ExactFrequency {
    fn omega(&self) -> f64 {
        self.omega
    }

    fn harmonics(&self) -> usize {
        self.g.len() - 1
    }

    fn system(&self) -> &PartitionedSystem {
        &self.system
    }

    fn interface_stiffness(&self, k: usize) -> &[c64] {
        &self.g[k]
    }

    fn interface_load(&self, k: usize) -> &[c64] {
        &self.u0[k]
    }

    fn linear_amplitudes(&self, k: usize, z: &[c64]) -> Result<Vec<c64>> {
        if let Some(StoredResponse { y, u }) = &self.stored {
            // u_k − Y_k z_k
            let y = &y[k];
            return Ok((0..y.nrows())
                .map(|i| u[k][i] - (0..y.ncols()).fold(ZERO, |s, j| s + y[(i, j)] * z[j]))
                .collect());
        }
        let s = &*self.system;
        let nl = s.n_linear();
        let mut rhs = vec![ZERO; nl];
        s.ln.add_times(k, self.omega, z, &mut rhs);
        let f = s.load_l.complex(k).unwrap_or_else(|| vec![ZERO; nl]);
        rhs.iter_mut().zip(&f).for_each(|(r, f)| *r = *f - *r);
        self.solve(k, &rhs)
    }

    fn add_coupling_force_derivative(&self, k: usize, z: &[c64], out: &mut [c64]) -> Result<()> {
        let s = &*self.system;
        let omega = self.omega;
        let q = self.linear_amplitudes(k, z)?;
        // ∂q̂_L = −A_LL⁻¹ (∂A_LL q̂_L + ∂A_LN z)
        let mut v = vec![ZERO; s.n_linear()];
        s.ll.add_derivative_times(k, omega, &q, &mut v);
        s.ln.add_derivative_times(k, omega, z, &mut v);
        v.iter_mut().for_each(|v| *v = -*v);
        let dq = self.solve(k, &v)?;
        s.nl.add_derivative_times(k, omega, &q, out);
        s.nl.add_times(k, omega, &dq, out);
        Ok(())
    }
}
