//! The massless contact subsystem as a static problem per time sample (paper eqs. 26–29):
//! `K_NN q_N = b + W λ`, `0 ≤ g = Wᵀ q_N + g0 ⊥ λ ≥ 0`, with `b = −K_NL q_L + f_N`.
//!
//! Eliminating `q_N` gives the LCP `0 ≤ D λ + Wᵀ K_NN⁻¹ b + g0 ⊥ λ ≥ 0` with the Delassus
//! matrix `D = Wᵀ K_NN⁻¹ W` (constant over samples, built once). The prox equation (29) is
//! the definition; the LCP solver is exact. For a known active set `A` the solution is
//! affine in `b` (docs/theory.md (T37)):
//!
//! `q_N = P_A b + s_A`, `P_A = K⁻¹ − K⁻¹ W_A D_AA⁻¹ W_Aᵀ K⁻¹`, `s_A = −K⁻¹ W_A D_AA⁻¹ g0_A`,
//! `λ_A = −D_AA⁻¹ (W_Aᵀ K⁻¹ b + g0_A)`.
//!
//! `P_A` is the semi-analytical sensitivity `∂q_N/∂b` of eqs. (42)–(43) (docs/theory.md (T43) shows
//! the equivalence). The data of each active set is computed once and cached: it does not
//! depend on the frequency.

use std::collections::HashMap;
use std::rc::Rc;

use faer::linalg::solvers::Solve;
use faer::Mat;

use crate::contact::lcp::{LcpMatrix, LcpSolver};
use crate::dense::solve_small;
use crate::error::{Error, Result};
use crate::sparse::SparseMatrix;

/// Affine data of one active set (row-major dense matrices).
#[derive(Debug)]
pub struct ActiveSet {
    /// Which contacts are closed.
    pub closed: Vec<bool>,
    /// `P_A` (`n × n`).
    pub compliance: Vec<f64>,
    /// `s_A` (`n`).
    pub offset: Vec<f64>,
    /// Validity indicator `h_A = indicator · b + indicator_offset` (`n_c × n`): the gap for
    /// an open contact, the force for a closed one. The set holds while `h_A ≥ 0`.
    pub indicator: Vec<f64>,
    pub indicator_offset: Vec<f64>,
}

impl ActiveSet {
    /// `q_N = P_A b + s_A`.
    pub fn displacement(&self, b: &[f64]) -> Vec<f64> {
        let n = b.len();
        (0..n)
            .map(|i| {
                self.offset[i]
                    + (0..n)
                        .map(|j| self.compliance[i * n + j] * b[j])
                        .sum::<f64>()
            })
            .collect()
    }

    /// Contact forces `λ` (zero for open contacts).
    pub fn force(&self, b: &[f64]) -> Vec<f64> {
        let n = b.len();
        self.closed
            .iter()
            .enumerate()
            .map(|(i, &c)| {
                if c {
                    self.indicator_offset[i]
                        + (0..n)
                            .map(|j| self.indicator[i * n + j] * b[j])
                            .sum::<f64>()
                } else {
                    0.0
                }
            })
            .collect()
    }
}

/// The static contact subsystem with its LCP solver and active-set cache.
pub struct StaticContact {
    n: usize,
    n_contacts: usize,
    /// `K_NN⁻¹` (`n × n`, row-major).
    stiffness_inverse: Vec<f64>,
    /// `W` (`n × n_c`, row-major).
    w: Vec<f64>,
    /// `K_NN⁻¹ W` (`n × n_c`).
    compliance_w: Vec<f64>,
    /// `D = Wᵀ K_NN⁻¹ W` (`n_c × n_c`).
    delassus: Vec<f64>,
    gap: Vec<f64>,
    solver: LcpSolver,
    cache: HashMap<Vec<bool>, Rc<ActiveSet>>,
}

impl StaticContact {
    /// `stiffness` = `K_NN`; `w` = `W` as `n × n_c` row-major; `gap` = `g0`.
    pub fn new(stiffness: &SparseMatrix, w: Vec<f64>, gap: Vec<f64>) -> Result<Self> {
        let n = stiffness.nrows();
        let n_contacts = gap.len();
        let k = stiffness.to_dense();
        let lu = k.full_piv_lu();
        let inv = lu.solve(Mat::<f64>::identity(n, n));
        let stiffness_inverse: Vec<f64> = (0..n * n).map(|e| inv[(e / n, e % n)]).collect();
        let scale = k.norm_max() * inv.norm_max();
        if n > 0 && (!scale.is_finite() || scale > 1e14) {
            return Err(Error::Singular(format!(
                "K_NN (the stiffness of the {n} contact-node DOFs with everything else held) is singular (condition ~ {scale:.1e}): the contact nodes must not form a free-floating part"
            )));
        }
        let mut compliance_w = vec![0.0; n * n_contacts];
        for i in 0..n {
            for c in 0..n_contacts {
                compliance_w[i * n_contacts + c] = (0..n)
                    .map(|j| stiffness_inverse[i * n + j] * w[j * n_contacts + c])
                    .sum();
            }
        }
        let mut delassus = vec![0.0; n_contacts * n_contacts];
        for a in 0..n_contacts {
            for c in 0..n_contacts {
                delassus[a * n_contacts + c] = (0..n)
                    .map(|i| w[i * n_contacts + a] * compliance_w[i * n_contacts + c])
                    .sum();
            }
        }
        let solver = LcpSolver::new(LcpMatrix::new(n_contacts, delassus.clone()));
        Ok(StaticContact {
            n,
            n_contacts,
            stiffness_inverse,
            w,
            compliance_w,
            delassus,
            gap,
            solver,
            cache: HashMap::new(),
        })
    }

    pub fn n_dofs(&self) -> usize {
        self.n
    }

    pub fn n_contacts(&self) -> usize {
        self.n_contacts
    }

    /// Gaps `Wᵀ q + g0`.
    pub fn gaps(&self, q: &[f64]) -> Vec<f64> {
        (0..self.n_contacts)
            .map(|c| {
                self.gap[c]
                    + (0..self.n)
                        .map(|i| self.w[i * self.n_contacts + c] * q[i])
                        .sum::<f64>()
            })
            .collect()
    }

    /// Solve the LCP for the load `b` (warm-started from the previous call) and return the
    /// active set's data.
    pub fn solve(&mut self, b: &[f64]) -> Result<Rc<ActiveSet>> {
        let nc = self.n_contacts;
        let q: Vec<f64> = (0..nc)
            .map(|c| {
                self.gap[c]
                    + (0..self.n)
                        .map(|i| self.compliance_w[i * nc + c] * b[i])
                        .sum::<f64>()
            })
            .collect();
        let sol = self
            .solver
            .solve(&q)
            .map_err(|e| Error::Numerical(format!("static contact problem: {e}")))?;
        self.active_set(&sol.active)
    }

    /// The (cached) data of the active set `closed`.
    pub fn active_set(&mut self, closed: &[bool]) -> Result<Rc<ActiveSet>> {
        if let Some(a) = self.cache.get(closed) {
            return Ok(a.clone());
        }
        let a = Rc::new(self.build_active_set(closed)?);
        self.cache.insert(closed.to_vec(), a.clone());
        Ok(a)
    }

    fn build_active_set(&self, closed: &[bool]) -> Result<ActiveSet> {
        let (n, nc) = (self.n, self.n_contacts);
        let act: Vec<usize> = (0..nc).filter(|&c| closed[c]).collect();
        let na = act.len();
        // D_AA⁻¹ applied to [W_Aᵀ K⁻¹ | g0_A]: solve column by column
        let d_aa: Vec<f64> = act
            .iter()
            .flat_map(|&a| act.iter().map(move |&c| (a, c)))
            .map(|(a, c)| self.delassus[a * nc + c])
            .collect();
        // rows of W_Aᵀ K⁻¹ (na × n) = (K⁻¹ W_A)ᵀ since K is symmetric
        let mut force_map = vec![0.0; na * n]; // −D_AA⁻¹ W_Aᵀ K⁻¹
        for j in 0..n {
            let rhs: Vec<f64> = act.iter().map(|&a| self.compliance_w[j * nc + a]).collect();
            let sol = solve_small(&d_aa, &rhs, 1e-13).ok_or_else(|| self.dependent_error())?;
            for r in 0..na {
                force_map[r * n + j] = -sol[r];
            }
        }
        let g_a: Vec<f64> = act.iter().map(|&a| self.gap[a]).collect();
        let force_offset: Vec<f64> = solve_small(&d_aa, &g_a, 1e-13)
            .ok_or_else(|| self.dependent_error())?
            .into_iter()
            .map(|v| -v)
            .collect();
        // P_A = K⁻¹ + K⁻¹ W_A (force_map), s_A = K⁻¹ W_A force_offset
        let mut compliance = self.stiffness_inverse.clone();
        let mut offset = vec![0.0; n];
        for i in 0..n {
            for (r, &a) in act.iter().enumerate() {
                let kw = self.compliance_w[i * nc + a];
                for j in 0..n {
                    compliance[i * n + j] += kw * force_map[r * n + j];
                }
                offset[i] += kw * force_offset[r];
            }
        }
        let mut indicator = vec![0.0; nc * n];
        let mut indicator_offset = vec![0.0; nc];
        for c in 0..nc {
            if let Some(r) = act.iter().position(|&a| a == c) {
                indicator[c * n..(c + 1) * n].copy_from_slice(&force_map[r * n..(r + 1) * n]);
                indicator_offset[c] = force_offset[r];
            } else {
                // gap of an open contact: Wᵀ (P_A b + s_A) + g0
                for j in 0..n {
                    indicator[c * n + j] = (0..n)
                        .map(|i| self.w[i * nc + c] * compliance[i * n + j])
                        .sum();
                }
                indicator_offset[c] =
                    self.gap[c] + (0..n).map(|i| self.w[i * nc + c] * offset[i]).sum::<f64>();
            }
        }
        Ok(ActiveSet {
            closed: closed.to_vec(),
            compliance,
            offset,
            indicator,
            indicator_offset,
        })
    }

    fn dependent_error(&self) -> Error {
        Error::Singular("the Delassus matrix of the closed contacts is singular: the gap gradients W of the closed contacts are linearly dependent".into())
    }
}
