//! The massless contact subsystem as a static problem per time sample (paper eqs. 26–29):
//! `K_NN q_N = b + W λ`, `0 ≤ g = Wᵀ q_N + g0 ⊥ λ ≥ 0` (docs/theory.md (T34); the gap and
//! the law of paper eq. 18), with `b = −K_NL q_L + f_N` (T18).
//!
//! Eliminating `q_N` gives the LCP `0 ≤ D λ + γ ⊥ λ ≥ 0` (T35) in the contact coordinates, with
//! the Delassus matrix `D = Wᵀ K_NN⁻¹ W` (constant, built once) and the **free gap**
//! `γ = Wᵀ K_NN⁻¹ b + g0` (the gap the contacts would have with no contact force at this
//! instant; docs/theory.md (T123)). The prox equation (29), (T36), is the definition; the LCP solver
//! is exact. For a known active set `A` the contact forces and gaps are linear in `γ`
//! (docs/theory.md (T37), (T124)):
//!
//! `λ_A = −D_AA⁻¹ γ_A`, `λ_I = 0`, `g_I = γ_I + D_IA λ_A`, `g_A = 0`,
//!
//! so the data of a set ([`ActiveSet`]) lives in the contact coordinates (`n_c × n_A`: the
//! closed contacts' columns), whatever the number of `N` DOFs. The `N` displacements follow as
//! `q_N = K_NN⁻¹ (b + W λ)`; the compliance `P_A = ∂q_N/∂b` of (T37) (the semi-analytical
//! sensitivity of eqs. 42–43, docs/theory.md (T43)) is formed only on request
//! ([`StaticContact::compliance`], for the Floquet analysis). The data of each active set is
//! cached: it depends neither on the frequency nor on the time.

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

/// Linear data of one active set in the contact coordinates.
///
/// The validity indicators `h_A = H γ` (docs/theory.md (T38), (T124)) are the force `λ_c`
/// of a closed contact and the gap `g_c` of an open one; the set holds while `h_A ≥ 0`, and
/// the rows of the closed contacts are the force map `∂λ/∂γ`. Every row of `H` is zero
/// outside the closed contacts' columns but for the open contact's own unit entry
/// (`λ_A = −D_AA⁻¹ γ_A`, `g_I = γ_I − D_IA D_AA⁻¹ γ_A`), so only those `n_A` columns are
/// stored: `n_c × n_A` numbers instead of `n_c²`.
#[derive(Debug)]
pub struct ActiveSet {
    /// Which contacts are closed.
    pub closed: Vec<bool>,
    /// The closed contacts, ascending.
    closed_list: Vec<usize>,
    /// `H` restricted to the closed contacts' columns (`n_c × n_A`, row-major).
    restricted: Vec<f64>,
}

impl ActiveSet {
    fn n_contacts(&self) -> usize {
        self.closed.len()
    }

    /// Row `c` of the indicator matrix `H` applied to `x` (`n_c` values).
    pub fn indicator_dot(&self, c: usize, x: &[f64]) -> f64 {
        let na = self.closed_list.len();
        let row = &self.restricted[c * na..(c + 1) * na];
        let closed_part: f64 = row
            .iter()
            .zip(&self.closed_list)
            .map(|(h, &a)| h * x[a])
            .sum();
        if self.closed[c] {
            closed_part
        } else {
            closed_part + x[c]
        }
    }

    /// The indicators' coefficients `H Γ` for the free gap with coefficients `gamma`
    /// (harmonic-major, `n_c` per coefficient, `columns` coefficients): `n_c × columns`,
    /// row-major, row `c` that of [`ActiveSet::indicator_dot`] per coefficient. One product
    /// with the closed contacts' columns, plus the open contacts' own entries.
    pub fn indicator_coefficients(&self, gamma: &[f64], columns: usize) -> Vec<f64> {
        let mut rows = Vec::new();
        self.indicator_coefficients_into(gamma, columns, &mut rows);
        rows
    }

    /// [`ActiveSet::indicator_coefficients`] into `rows` (resized to `n_c × columns`); up to
    /// [`DIRECT_INDICATOR_CONTACTS`] contacts by direct loops, allocating nothing once `rows`
    /// has room.
    pub fn indicator_coefficients_into(&self, gamma: &[f64], columns: usize, rows: &mut Vec<f64>) {
        let (nc, na) = (self.n_contacts(), self.closed_list.len());
        rows.clear();
        rows.resize(nc * columns, 0.0);
        for c in 0..nc {
            if !self.closed[c] {
                for m in 0..columns {
                    rows[c * columns + m] = gamma[m * nc + c];
                }
            }
        }
        if na == 0 {
            return;
        }
        if nc <= DIRECT_INDICATOR_CONTACTS {
            for c in 0..nc {
                let h = &self.restricted[c * na..(c + 1) * na];
                for m in 0..columns {
                    let closed = &gamma[m * nc..(m + 1) * nc];
                    rows[c * columns + m] += h
                        .iter()
                        .zip(&self.closed_list)
                        .map(|(h, &a)| h * closed[a])
                        .sum::<f64>();
                }
            }
            return;
        }
        let mut out = faer::Mat::<f64>::zeros(nc, columns);
        let closed =
            faer::Mat::<f64>::from_fn(na, columns, |r, m| gamma[m * nc + self.closed_list[r]]);
        let h = MatRef::from_row_major_slice(&self.restricted, nc, na);
        faer::linalg::matmul::matmul(
            out.as_mut(),
            faer::Accum::Replace,
            h,
            &closed,
            1.0,
            faer::Par::Seq,
        );
        for c in 0..nc {
            for m in 0..columns {
                rows[c * columns + m] += out[(c, m)];
            }
        }
    }

    /// The force map's row of the closed contact `a` (`∂λ_a/∂γ`): its nonzero columns (the
    /// closed contacts) and their values.
    pub fn force_row(&self, a: usize) -> (&[usize], &[f64]) {
        debug_assert!(
            self.closed[a],
            "contact {a} is open: its row is a gap, not a force"
        );
        let na = self.closed_list.len();
        (&self.closed_list, &self.restricted[a * na..(a + 1) * na])
    }

    /// Bytes the set holds.
    pub(crate) fn bytes(&self) -> usize {
        8 * self.restricted.len() + 9 * self.closed.len() + 64
    }

    /// Contact forces `λ` (zero for open contacts) for the free gap `γ`.
    pub fn force(&self, gamma: &[f64]) -> Vec<f64> {
        (0..self.n_contacts())
            .map(|c| {
                if self.closed[c] {
                    self.indicator_dot(c, gamma)
                } else {
                    0.0
                }
            })
            .collect()
    }

    /// Gaps `g` (zero for closed contacts) for the free gap `γ`.
    pub fn gap(&self, gamma: &[f64]) -> Vec<f64> {
        (0..self.n_contacts())
            .map(|c| {
                if self.closed[c] {
                    0.0
                } else {
                    self.indicator_dot(c, gamma)
                }
            })
            .collect()
    }

    /// The closed contacts (indices, ascending).
    pub fn closed_contacts(&self) -> &[usize] {
        &self.closed_list
    }
}

/// Contacts up to which [`ActiveSet::indicator_coefficients_into`] multiplies by direct
/// loops (above, by faer's product).
const DIRECT_INDICATOR_CONTACTS: usize = 8;

/// The static contact subsystem with its LCP solver and active-set cache.
pub struct StaticContact {
    n: usize,
    n_contacts: usize,
    /// Sparse Cholesky factor of `K_NN`.
    factor: faer::sparse::linalg::solvers::Llt<usize, f64>,
    /// `K_NN⁻¹ W` (`n × n_c`).
    compliance_w: Vec<f64>,
    /// `D = Wᵀ K_NN⁻¹ W` (`n_c × n_c`).
    delassus: Vec<f64>,
    gap: Vec<f64>,
    solver: LcpSolver,
    cache: HashMap<Vec<bool>, Rc<ActiveSet>>,
    /// Bytes the cached sets hold.
    cache_bytes: usize,
    /// The LCP's active set, copied out of the solver (reused).
    active_scratch: Vec<bool>,
}

impl StaticContact {
    /// `stiffness` = `K_NN`; `w` = `W` as `n × n_c` row-major; `gap` = `g0`.
    ///
    /// `K_NN` is factored once by a sparse Cholesky factorization (it is positive definite
    /// when the contact nodes are held by the rest of the structure); `K_NN⁻¹ W` (`n × n_c`)
    /// and the Delassus matrix come from `n_c` solves. Nothing of size `n × n` is formed.
    pub fn new(stiffness: &SparseMatrix, w: Vec<f64>, gap: Vec<f64>) -> Result<Self> {
        let n = stiffness.nrows();
        let n_contacts = gap.len();
        let singular = |detail: String| {
            Error::Singular(format!(
                "K_NN (the stiffness of the {n} contact-node DOFs with everything else held) is singular ({detail}): the contact nodes must not form a free-floating part"
            ))
        };
        let factor = stiffness
            .to_faer()
            .sp_cholesky(faer::Side::Lower)
            .map_err(|_| {
                Error::Singular(format!(
                    "K_NN (the stiffness of the {n} contact-node DOFs with everything else held) is not positive definite: the contact nodes form a free-floating part, or their stiffness is negative"
                ))
            })?;
        // condition estimate ‖K‖ / λ_min(K): λ_min by a few inverse iterations (a lower
        // bound of ‖K⁻¹‖ that converges fast when K_NN is nearly singular)
        if n > 0 {
            let mut x = Mat::<f64>::from_fn(n, 1, |i, _| 1.0 + 0.5 * (i as f64 * 0.7).sin());
            let mut growth = 0.0;
            for _ in 0..8 {
                // normalised every iteration: unscaled, K⁻⁸ x underflows (or overflows)
                // for a stiffness far from 1 (a modulus of 1e100 gave "condition ~ NaN")
                let norm = x.norm_l2();
                x /= norm;
                factor.solve_in_place(x.as_mut());
                growth = x.norm_l2();
            }
            let scale = stiffness.max_abs() * growth;
            if !scale.is_finite() || scale > 1e14 {
                return Err(singular(format!("condition ~ {scale:.1e}")));
            }
        }
        let w_mat = MatRef::from_row_major_slice(&w, n, n_contacts);
        let mut kw = w_mat.to_owned();
        factor.solve_in_place(kw.as_mut());
        let d = w_mat.transpose() * &kw;
        let compliance_w = row_major(kw.as_ref());
        let delassus = row_major(d.as_ref());
        let solver = LcpSolver::new(LcpMatrix::new(n_contacts, delassus.clone()));
        Ok(StaticContact {
            n,
            n_contacts,
            factor,
            compliance_w,
            delassus,
            gap,
            solver,
            cache: HashMap::new(),
            cache_bytes: 0,
            active_scratch: vec![false; n_contacts],
        })
    }

    pub fn n_dofs(&self) -> usize {
        self.n
    }

    pub fn n_contacts(&self) -> usize {
        self.n_contacts
    }

    /// The Delassus matrix `D = Wᵀ K_NN⁻¹ W` (`n_c × n_c`, row-major).
    pub fn delassus(&self) -> &[f64] {
        &self.delassus
    }

    /// The initial gaps `g0`.
    pub fn initial_gap(&self) -> &[f64] {
        &self.gap
    }

    /// `Λ` (`n_c × n_c`, row-major, upper triangular) with `ΛᵀΛ = (K_NN⁻¹ W)ᵀ K_NN⁻¹ W`:
    /// `‖Λ f‖ = ‖K_NN⁻¹ W f‖`, the size of the `N` displacement a contact force `f` makes
    /// (docs/theory.md (T128)). With one DOF per contact, `Λ = |D|`.
    pub fn displacement_scale(&self) -> Result<Vec<f64>> {
        let (n, nc) = (self.n, self.n_contacts);
        let y = MatRef::from_row_major_slice(&self.compliance_w, n, nc);
        let gram = y.transpose() * y;
        let llt = gram
            .llt(faer::Side::Lower)
            .map_err(|_| self.dependent_error())?;
        let l = llt.L();
        Ok((0..nc * nc)
            .map(|e| {
                let (i, j) = (e / nc, e % nc);
                if j >= i {
                    l[(j, i)]
                } else {
                    0.0
                }
            })
            .collect())
    }

    /// The free gap `γ = Wᵀ K_NN⁻¹ b + g0` of the load `b` (docs/theory.md (T123)).
    pub fn free_gap(&self, b: &[f64]) -> Vec<f64> {
        let kw = MatRef::from_row_major_slice(&self.compliance_w, self.n, self.n_contacts);
        let wkb = kw.transpose() * faer::ColRef::from_slice(b);
        (0..self.n_contacts).map(|c| self.gap[c] + wkb[c]).collect()
    }

    /// `q_N = K_NN⁻¹ (b + W λ)` (eq. 26): one sparse solve and `K_NN⁻¹ W λ`.
    pub fn displacement(&self, b: &[f64], force: &[f64]) -> Vec<f64> {
        let mut x = Mat::<f64>::from_fn(self.n, 1, |i, _| b[i]);
        self.factor.solve_in_place(x.as_mut());
        let mut q = self.force_displacement(force);
        q.iter_mut().enumerate().for_each(|(i, q)| *q += x[(i, 0)]);
        q
    }

    /// `K_NN⁻¹ W λ`, the displacement of the contact nodes under the contact forces alone
    /// (open contacts, `λ_c = 0`, cost nothing).
    pub fn force_displacement(&self, force: &[f64]) -> Vec<f64> {
        let nc = self.n_contacts;
        let mut q = vec![0.0; self.n];
        for (c, &l) in force.iter().enumerate().filter(|(_, &l)| l != 0.0) {
            q.iter_mut()
                .enumerate()
                .for_each(|(i, qi)| *qi += self.compliance_w[i * nc + c] * l);
        }
        q
    }

    /// `K_NN⁻¹ W` (`n × n_c`): the contact-node displacements per unit contact force.
    pub fn force_compliance(&self) -> MatRef<'_, f64> {
        MatRef::from_row_major_slice(&self.compliance_w, self.n, self.n_contacts)
    }

    /// `K_NN⁻¹`, dense, by `n` solves (for the Floquet analysis of small interfaces).
    pub fn stiffness_inverse(&self) -> Mat<f64> {
        let mut inverse = Mat::<f64>::identity(self.n, self.n);
        self.factor.solve_in_place(inverse.as_mut());
        inverse
    }

    /// Row `i` of `K_NN⁻¹ W` (`n_c`): the displacement of contact-node DOF `i` per unit
    /// contact force.
    pub fn compliance_row(&self, i: usize) -> &[f64] {
        let nc = self.n_contacts;
        &self.compliance_w[i * nc..(i + 1) * nc]
    }

    /// Component `i` of [`StaticContact::force_displacement`].
    pub fn force_displacement_of(&self, i: usize, force: &[f64]) -> f64 {
        let nc = self.n_contacts;
        let kw = &self.compliance_w[i * nc..(i + 1) * nc];
        kw.iter().zip(force).map(|(a, l)| a * l).sum()
    }

    /// Solve the LCP for the free gap `γ` (warm-started from the previous call) and return
    /// the active set's data.
    pub fn solve(&mut self, gamma: &[f64]) -> Result<Rc<ActiveSet>> {
        let mut active = std::mem::take(&mut self.active_scratch);
        match self.solver.solve_active(gamma) {
            Ok(set) => active.clone_from_slice(set),
            Err(e) => {
                self.active_scratch = active;
                return Err(Error::Numerical(format!("static contact problem: {e}")));
            }
        }
        let set = self.active_set(&active);
        self.active_scratch = active;
        set
    }

    /// The static contact problem for the load `b`: `(q_N, λ)`.
    pub fn solve_load(&mut self, b: &[f64]) -> Result<(Vec<f64>, Vec<f64>)> {
        let gamma = self.free_gap(b);
        let set = self.solve(&gamma)?;
        let force = set.force(&gamma);
        Ok((self.displacement(b, &force), force))
    }

    /// The (cached) data of the active set `closed`.
    pub fn active_set(&mut self, closed: &[bool]) -> Result<Rc<ActiveSet>> {
        if let Some(a) = self.cache.get(closed) {
            return Ok(a.clone());
        }
        let a = Rc::new(self.build_active_set(closed)?);
        // each set holds n_c × n_A values: on a large interface a few hundred sets would
        // fill the memory, so the cache starts over when it reaches its budget
        if self.cache_bytes + a.bytes() > ACTIVE_SET_CACHE_BYTES {
            self.cache.clear();
            self.cache_bytes = 0;
        }
        self.cache_bytes += a.bytes();
        self.cache.insert(closed.to_vec(), a.clone());
        Ok(a)
    }

    /// `D_AA⁻¹ rhs` for the closed contacts `act`.
    fn solve_closed(&self, act: &[usize], rhs: MatRef<'_, f64>) -> Result<Mat<f64>> {
        let nc = self.n_contacts;
        let d_aa: Vec<f64> = act
            .iter()
            .flat_map(|&a| act.iter().map(move |&c| (a, c)))
            .map(|(a, c)| self.delassus[a * nc + c])
            .collect();
        solve_small_lu_columns(&d_aa, rhs, 1e-13).map_err(|_| self.dependent_error())
    }

    /// The indicators of (T124) on the closed contacts' columns: with `Z = D_AA⁻¹`, the
    /// forces `λ_A = −Z γ_A` and the open gaps `g_I = γ_I − D_IA Z γ_A`.
    fn build_active_set(&self, closed: &[bool]) -> Result<ActiveSet> {
        let nc = self.n_contacts;
        let act: Vec<usize> = (0..nc).filter(|&c| closed[c]).collect();
        let na = act.len();
        let z = self.solve_closed(&act, Mat::<f64>::identity(na, na).as_ref())?;
        let d = MatRef::from_row_major_slice(&self.delassus, nc, nc);
        let d_ca = Mat::<f64>::from_fn(nc, na, |c, r| d[(c, act[r])]);
        let gaps = &d_ca * &z;
        let mut row_of = vec![usize::MAX; nc];
        act.iter().enumerate().for_each(|(r, &a)| row_of[a] = r);
        let mut restricted = vec![0.0; nc * na];
        for c in 0..nc {
            let row = &mut restricted[c * na..(c + 1) * na];
            let source = if row_of[c] != usize::MAX {
                z.row(row_of[c])
            } else {
                gaps.row(c)
            };
            row.iter_mut().zip(source.iter()).for_each(|(v, s)| *v = -s);
        }
        Ok(ActiveSet {
            closed: closed.to_vec(),
            closed_list: act,
            restricted,
        })
    }

    /// The compliance `P_A = K_NN⁻¹ − K_NN⁻¹ W_A D_AA⁻¹ W_Aᵀ K_NN⁻¹` of the set `closed`
    /// (`n × n`, row-major; docs/theory.md (T37)): `q_N = P_A b + s_A`.
    pub fn compliance(&self, closed: &[bool]) -> Result<Vec<f64>> {
        let (n, nc) = (self.n, self.n_contacts);
        let act: Vec<usize> = (0..nc).filter(|&c| closed[c]).collect();
        let kw = MatRef::from_row_major_slice(&self.compliance_w, n, nc);
        let y = Mat::<f64>::from_fn(n, act.len(), |i, r| kw[(i, act[r])]);
        let z = self.solve_closed(&act, y.transpose())?;
        // K_NN⁻¹ by n solves: only the Floquet analysis of models small enough for dense
        // monodromy matrices asks for it
        let mut stiffness_inverse = Mat::<f64>::identity(n, n);
        self.factor.solve_in_place(stiffness_inverse.as_mut());
        Ok(row_major((stiffness_inverse - &y * &z).as_ref()))
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Two contact DOFs joined by a spring of stiffness 2, the first also held by a spring 1:
    /// `K_NN = [[3, −2], [−2, 2]]`, one contact on the second DOF (`w = −1`, gap 0.1).
    fn pair(held: f64) -> Result<StaticContact> {
        let k = SparseMatrix::from_triplets(
            2,
            2,
            &[(0, 0, held + 2.0), (0, 1, -2.0), (1, 0, -2.0), (1, 1, 2.0)],
        );
        StaticContact::new(&k, vec![0.0, -1.0], vec![0.1])
    }

    #[test]
    fn the_sparse_factor_gives_the_closed_form_statics() {
        // K⁻¹ = [[1, 1], [1, 1.5]]: D = Wᵀ K⁻¹ W = 1.5, q = K⁻¹ (b + W λ)
        let mut c = pair(1.0).unwrap();
        assert!((c.delassus()[0] - 1.5).abs() < 1e-14);
        // pushes the contact DOF up by 0.6 against a gap of 0.1 (g = −q_1 + 0.1)
        let b = [0.0, 0.4];
        let (q, lambda) = c.solve_load(&b).unwrap();
        // closed: g = γ + D λ = −0.5 + 1.5 λ = 0
        assert!((lambda[0] - 1.0 / 3.0).abs() < 1e-14, "{lambda:?}");
        // q = K⁻¹ (b + W λ) = K⁻¹ [0, 0.4 − λ]
        let exact = [0.4 - lambda[0], 1.5 * (0.4 - lambda[0])];
        assert!(
            (q[0] - exact[0]).abs() < 1e-14 && (q[1] - exact[1]).abs() < 1e-14,
            "{q:?}"
        );
        assert!(
            (q[1] - 0.1).abs() < 1e-14,
            "the contact DOF sits on the obstacle: {q:?}"
        );
    }

    /// The condition check does not depend on the stiffness's units: the pair scaled by
    /// 10^±100 (a bar's modulus 10¹⁰⁰ times off) is accepted with the Delassus value of the
    /// closed form scaled back (its inverse iteration underflowed to "condition ~ NaN"),
    /// and the nearly free pair is still refused at any scale.
    #[test]
    fn the_condition_check_holds_at_any_scale_of_the_stiffness() {
        for scale in [1e-100, 1e100, 1e-300, 1e300] {
            let k = |held: f64| {
                SparseMatrix::from_triplets(
                    2,
                    2,
                    &[
                        (0, 0, scale * (held + 2.0)),
                        (0, 1, -2.0 * scale),
                        (1, 0, -2.0 * scale),
                        (1, 1, 2.0 * scale),
                    ],
                )
            };
            let c = StaticContact::new(&k(1.0), vec![0.0, -1.0], vec![0.1])
                .unwrap_or_else(|e| panic!("scale {scale:e}: {e}"));
            let d = c.delassus()[0] * scale;
            assert!((d - 1.5).abs() < 1e-13, "scale {scale:e}: D = {d}");
            let err = StaticContact::new(&k(1e-15), vec![0.0, -1.0], vec![0.1])
                .err()
                .expect("a free-floating pair");
            assert!(err.to_string().contains("free-floating"), "{err}");
        }
    }

    #[test]
    fn free_floating_contact_nodes_are_refused() {
        for held in [0.0, 1e-15] {
            let err = pair(held).err().expect("a free-floating pair");
            let text = err.to_string();
            assert!(text.contains("free-floating"), "{held}: {text}");
        }
    }
}
