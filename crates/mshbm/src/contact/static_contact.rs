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
use faer::{Mat, MatRef};

use crate::contact::lcp::{LcpMatrix, LcpSolver};
use crate::dense::solve_small_lu_columns;
use crate::error::{Error, Result};
use crate::sparse::SparseMatrix;

/// Memory the active-set cache of one [`StaticContact`] may hold (bytes).
pub const ACTIVE_SET_CACHE_BYTES: usize = 1 << 31;

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

    /// Component `i` of `q_N = P_A b + s_A`.
    pub fn displacement_of(&self, i: usize, b: &[f64]) -> f64 {
        let n = b.len();
        let row = &self.compliance[i * n..(i + 1) * n];
        self.offset[i] + row.iter().zip(b).map(|(p, v)| p * v).sum::<f64>()
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
        // K_NN is symmetric positive definite when the contact nodes are held by the rest:
        // Cholesky, else a full-pivoting LU for the condition estimate below
        let inv = match k.llt(faer::Side::Lower) {
            Ok(llt) => llt.solve(Mat::<f64>::identity(n, n)),
            Err(_) => k.full_piv_lu().solve(Mat::<f64>::identity(n, n)),
        };
        let scale = k.norm_max() * inv.norm_max();
        if n > 0 && (!scale.is_finite() || scale > 1e14) {
            return Err(Error::Singular(format!(
                "K_NN (the stiffness of the {n} contact-node DOFs with everything else held) is singular (condition ~ {scale:.1e}): the contact nodes must not form a free-floating part"
            )));
        }
        let w_mat = MatRef::from_row_major_slice(&w, n, n_contacts);
        let kw = &inv * w_mat;
        let d = w_mat.transpose() * &kw;
        let stiffness_inverse = row_major(inv.as_ref());
        let compliance_w = row_major(kw.as_ref());
        let delassus = row_major(d.as_ref());
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
        // q = g0 + (K⁻¹W)ᵀ b as one matrix–vector product
        let kw = MatRef::from_row_major_slice(&self.compliance_w, self.n, nc);
        let wkb = kw.transpose() * faer::ColRef::from_slice(b);
        let q: Vec<f64> = (0..nc).map(|c| self.gap[c] + wkb[c]).collect();
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
        // each set holds n² + n_c·n values: on a large interface a few hundred sets would
        // fill the memory, so the cache starts over when it reaches its budget
        let set_bytes = 8 * (self.n * self.n + self.n_contacts * self.n).max(1);
        if (self.cache.len() + 1) * set_bytes > ACTIVE_SET_CACHE_BYTES {
            self.cache.clear();
        }
        self.cache.insert(closed.to_vec(), a.clone());
        Ok(a)
    }

    /// The affine data of (T37) by dense products: with `Y = K⁻¹ W_A` and
    /// `Z = D_AA⁻¹ Yᵀ`, `P_A = K⁻¹ − Y Z`, `s_A = −Y D_AA⁻¹ g0_A`, and the gaps of all
    /// contacts `Wᵀ P_A = (K⁻¹ W)ᵀ − D_{:,A} Z` (`D_{:,A} = Wᵀ Y`).
    fn build_active_set(&self, closed: &[bool]) -> Result<ActiveSet> {
        let (n, nc) = (self.n, self.n_contacts);
        let act: Vec<usize> = (0..nc).filter(|&c| closed[c]).collect();
        let na = act.len();
        let d_aa: Vec<f64> = act
            .iter()
            .flat_map(|&a| act.iter().map(move |&c| (a, c)))
            .map(|(a, c)| self.delassus[a * nc + c])
            .collect();
        let kw = MatRef::from_row_major_slice(&self.compliance_w, n, nc);
        let y = Mat::<f64>::from_fn(n, na, |i, r| kw[(i, act[r])]);
        // [Z | D_AA⁻¹ g0_A] with one factorisation
        let mut rhs = Mat::<f64>::zeros(na, n + 1);
        rhs.as_mut().subcols_mut(0, n).copy_from(y.transpose());
        for (r, &a) in act.iter().enumerate() {
            rhs[(r, n)] = self.gap[a];
        }
        let sol = solve_small_lu_columns(&d_aa, rhs.as_ref(), 1e-13)
            .map_err(|_| self.dependent_error())?;
        let z = sol.as_ref().subcols(0, n);
        // force_map = −Z (λ_A = force_map · b + force_offset)
        let force_offset: Vec<f64> = (0..na).map(|r| -sol[(r, n)]).collect();
        let stiffness_inverse = MatRef::from_row_major_slice(&self.stiffness_inverse, n, n);
        let compliance = stiffness_inverse - &y * z;
        let offset: Vec<f64> = (0..n)
            .map(|i| (0..na).map(|r| y[(i, r)] * force_offset[r]).sum())
            .collect();
        let d = MatRef::from_row_major_slice(&self.delassus, nc, nc);
        let d_ca = Mat::<f64>::from_fn(nc, na, |c, r| d[(c, act[r])]);
        let gaps = kw.transpose() - &d_ca * z;
        let mut indicator = vec![0.0; nc * n];
        let mut indicator_offset = vec![0.0; nc];
        let mut row_of = vec![usize::MAX; nc];
        act.iter().enumerate().for_each(|(r, &a)| row_of[a] = r);
        for c in 0..nc {
            let row = &mut indicator[c * n..(c + 1) * n];
            if row_of[c] != usize::MAX {
                let r = row_of[c];
                row.iter_mut()
                    .enumerate()
                    .for_each(|(j, v)| *v = -z[(r, j)]);
                indicator_offset[c] = force_offset[r];
            } else {
                // gap of an open contact: Wᵀ (P_A b + s_A) + g0
                row.iter_mut()
                    .enumerate()
                    .for_each(|(j, v)| *v = gaps[(c, j)]);
                indicator_offset[c] =
                    self.gap[c] + (0..na).map(|r| d_ca[(c, r)] * force_offset[r]).sum::<f64>();
            }
        }
        Ok(ActiveSet {
            closed: closed.to_vec(),
            compliance: row_major(compliance.as_ref()),
            offset,
            indicator,
            indicator_offset,
        })
    }

    fn dependent_error(&self) -> Error {
        Error::Singular("the Delassus matrix of the closed contacts is singular: the gap gradients W of the closed contacts are linearly dependent".into())
    }
}

/// A dense matrix as a row-major vector.
fn row_major(m: MatRef<'_, f64>) -> Vec<f64> {
    let (r, c) = (m.nrows(), m.ncols());
    (0..r * c).map(|e| m[(e / c, e % c)]).collect()
}
