//! Newmark average acceleration with position-level Signorini for a massless contact
//! boundary (docs/theory.md §9, (T67), Khenous-type).
//!
//! With `R` the (redistributed) mass, `C` damping that does not act on the massless DOFs:
//!
//! ```text
//! Â = (4/h²) R + (2/h) C + K                          (factored once; SPD)
//! b = f_{k+1} + R [(4/h²)(u_k + h v_k) + a_k] + C [(2/h) u_k + v_k]
//! u_free = Â⁻¹ b,   D = Wᵀ Â⁻¹ W                       (D precomputed)
//! LCP: 0 ≤ g = D λ + Wᵀ u_free + g0 ⊥ λ ≥ 0             (all contacts, exact solver)
//! u_{k+1} = u_free + Â⁻¹ W λ
//! a_{k+1} = (4/h²)(u_{k+1} − u_k − h v_k) − a_k,   v_{k+1} = v_k + h/2 (a_k + a_{k+1})
//! ```
//!
//! With Coulomb friction on the contacts (docs/theory.md (T170)–(T174)) the LCP becomes the
//! frictional problem of [`super::coulomb`] in the coordinates `y = [W, W_T]ᵀ u + [g0; 0]`:
//! `y = y_free + D λ`, `D = [W, W_T]ᵀ Â⁻¹ [W, W_T]`, with the incremental Coulomb law on
//! `y_T,k+1 − y_T,k` (T171); the positions `u_k` of the massless contact nodes carry the
//! anchors, so the scheme's state is unchanged.
//!
//! (on the massive DOFs; the update makes `R a + C v + K u = f + W λ` hold at every step
//! end, so it is the `a_{k+1,L} = R̄_LL⁻¹ (f − C v − K u)_L` of docs/theory.md (T67) without a
//! second factorization). For the massless DOFs `v = Δu/h` is a diagnostic and `a = 0`;
//! `R` and `C` have no entries there, so neither enters the scheme.

use crate::contact::lcp::{LcpMatrix, LcpSolver};
use crate::error::{Error, Result};
use crate::model::System;
use crate::sparse::{SparseCholesky, SparseMatrix};

use super::coulomb::CoulombContacts;
use super::{Data, State};

pub(crate) struct PositionNewmark {
    ahat: SparseCholesky,
    /// Cholesky of the mass on the massive DOFs (initial accelerations).
    mass_mm: Option<SparseCholesky>,
    /// `Â⁻¹ W_i` per contact (then `Â⁻¹ W_T` per frictional contact, with friction).
    aw: Vec<Vec<f64>>,
    lcp: Option<LcpSolver>,
    /// The frictional problem of a step (T171), when a contact has friction (then no `lcp`).
    coulomb: Option<CoulombContacts>,
    /// `y_free` and the anchors of the frictional problem.
    y_free: Vec<f64>,
    anchor: Vec<f64>,
    /// Accelerations (zero on massless DOFs).
    a: Vec<f64>,
    b: Vec<f64>,
    work: Vec<f64>,
    q_lcp: Vec<f64>,
}

impl PositionNewmark {
    pub(crate) fn new(system: &System, data: &Data) -> Result<Self> {
        let h = data.dt;
        let n = data.n;
        let mut is_massless = vec![false; n];
        data.massless.iter().for_each(|&i| is_massless[i] = true);
        for (c, contact) in system.contacts.iter().enumerate() {
            let tangent = contact.friction.iter().flat_map(|f| f.w.iter());
            if contact
                .w
                .iter()
                .chain(tangent)
                .any(|&(i, _)| !is_massless[i])
            {
                return Err(Error::argument(
                    "scheme",
                    format!(
                        "the position-level scheme needs a massless contact boundary (redistributed mass), \
                         but contact {c} acts on a DOF with mass; use the Moreau-Jean scheme for the consistent mass"
                    ),
                ));
            }
        }
        if system
            .damping
            .iter()
            .any(|(i, j, v)| v != 0.0 && (is_massless[i] || is_massless[j]))
        {
            return Err(Error::argument(
                "damping",
                "the position-level scheme needs damping that does not act on the massless contact DOFs (C_NN = C_NL = 0); \
                 use mass-proportional damping (damping.alpha or damping.first_mode_ratio)",
            ));
        }
        let ahat_m = SparseMatrix::linear_combination(
            1.0,
            &SparseMatrix::linear_combination(
                4.0 / (h * h),
                &system.mass,
                2.0 / h,
                &system.damping,
            ),
            1.0,
            &system.stiffness,
        );
        let mut ahat = SparseCholesky::new(
            &ahat_m,
            "the Newmark iteration matrix (4/h^2) M + (2/h) C + K (the massless DOFs must be held by the stiffness)",
        )?;
        let mass_mm = if data.massive.is_empty() {
            None
        } else {
            Some(SparseCholesky::new(
                &system.mass.submatrix(&data.massive, &data.massive),
                "the mass matrix on the DOFs that carry mass",
            )?)
        };
        let nc = data.contacts.len();
        let mut aw = data.contacts.coordinate_columns(n);
        for c in &mut aw {
            ahat.solve(c);
            if c.iter().any(|x| !x.is_finite()) {
                return Err(Error::Singular(
                    "the Newmark iteration matrix is singular".into(),
                ));
            }
        }
        let m = aw.len();
        let coulomb = data.contacts.has_friction().then(|| {
            // D of (T170) over the normal and tangential coordinates
            let mut d = vec![0.0; m * m];
            for a in 0..m {
                for b in 0..m {
                    d[a * m + b] = coordinate(data, a, &aw[b]);
                }
            }
            CoulombContacts::new(&data.contacts.mu(), d)
        });
        let lcp = (nc > 0 && coulomb.is_none()).then(|| {
            let mut d = vec![0.0; nc * nc];
            for a in 0..nc {
                for b in 0..nc {
                    d[a * nc + b] = data.contacts.dot(a, &aw[b]);
                }
            }
            LcpSolver::new(LcpMatrix::new(nc, d))
        });
        Ok(PositionNewmark {
            ahat,
            mass_mm,
            aw,
            lcp,
            coulomb,
            y_free: vec![0.0; m],
            anchor: vec![0.0; nc],
            a: vec![0.0; n],
            b: vec![0.0; n],
            work: vec![0.0; n],
            q_lcp: vec![0.0; nc],
        })
    }

    /// Initial accelerations `a_M = M_MM⁻¹ (f − C v − K u + W λ)_M` (`W` has no massive rows).
    pub(crate) fn reset(&mut self, d: &Data, s: &mut State) -> Result<()> {
        self.a.iter_mut().for_each(|a| *a = 0.0);
        let Some(mass_mm) = &mut self.mass_mm else {
            return Ok(());
        };
        let mut r = vec![0.0; d.n];
        d.load_into(s.time(d.dt), &mut r);
        d.damping.mul_add(-1.0, &s.v, &mut r);
        d.stiffness.mul_add(-1.0, &s.q, &mut r);
        let mut rm: Vec<f64> = d.massive.iter().map(|&i| r[i]).collect();
        mass_mm.solve(&mut rm);
        if rm.iter().any(|x| !x.is_finite()) {
            return Err(Error::Singular(
                "initial accelerations are not finite".into(),
            ));
        }
        for (k, &i) in d.massive.iter().enumerate() {
            self.a[i] = rm[k];
        }
        Ok(())
    }

    pub(crate) fn step(&mut self, d: &Data, s: &mut State) -> Result<()> {
        let h = d.dt;
        let t1 = s.t0 + (s.steps + 1) as f64 * h;
        // b = f_{k+1} + R [(4/h²)(u + h v) + a] + C [(2/h) u + v]
        d.load_into(t1, &mut self.b);
        for i in 0..d.n {
            self.work[i] = 4.0 / (h * h) * (s.q[i] + h * s.v[i]) + self.a[i];
        }
        d.mass.mul_add(1.0, &self.work, &mut self.b);
        for i in 0..d.n {
            self.work[i] = 2.0 / h * s.q[i] + s.v[i];
        }
        d.damping.mul_add(1.0, &self.work, &mut self.b);
        self.ahat.solve(&mut self.b);
        let u = &mut self.b;
        s.forces.iter_mut().for_each(|f| *f = 0.0);
        if let Some(lcp) = &mut self.lcp {
            for (i, ql) in self.q_lcp.iter_mut().enumerate() {
                *ql = d.contacts.dot(i, u) + d.contacts.gap[i];
            }
            let sol = lcp
                .solve(&self.q_lcp)
                .map_err(|e| Error::Numerical(format!("contact LCP at t = {t1}: {e}")))?;
            for (i, &l) in sol.lambda.iter().enumerate() {
                if l != 0.0 {
                    for (uj, awj) in u.iter_mut().zip(&self.aw[i]) {
                        *uj += awj * l;
                    }
                }
                s.forces[i] = l;
            }
            // the gaps of the LCP solution: exactly complementary, never negative
            s.gaps.copy_from_slice(&sol.w);
        }
        if let Some(coulomb) = &mut self.coulomb {
            // (T170)–(T171): the anchors are the tangential positions at the start of the step
            for (r, y) in self.y_free.iter_mut().enumerate() {
                *y = coordinate(d, r, u) + d.contacts.gap.get(r).copied().unwrap_or(0.0);
            }
            for (c, a) in self.anchor.iter_mut().enumerate() {
                *a = d.contacts.tangent_dot(c, &s.q);
            }
            coulomb.solve(&self.y_free, &self.anchor).map_err(|e| {
                Error::Numerical(format!("frictional contact problem at t = {t1}: {e}"))
            })?;
            for (r, &l) in coulomb.lambda().iter().enumerate() {
                if l != 0.0 {
                    for (uj, awj) in u.iter_mut().zip(&self.aw[r]) {
                        *uj += awj * l;
                    }
                }
            }
            let nc = d.contacts.len();
            s.forces.copy_from_slice(&coulomb.lambda()[..nc]);
            s.gaps.copy_from_slice(&coulomb.y()[..nc]);
            for c in 0..nc {
                s.tangential_forces[c] =
                    coulomb.tangent_row(c).map_or(0.0, |t| coulomb.lambda()[t]);
            }
        }
        for &i in &d.massive {
            let a_new = 4.0 / (h * h) * (u[i] - s.q[i] - h * s.v[i]) - self.a[i];
            s.v[i] += 0.5 * h * (self.a[i] + a_new);
            self.a[i] = a_new;
            s.q[i] = u[i];
        }
        for &i in &d.massless {
            s.v[i] = (u[i] - s.q[i]) / h;
            s.q[i] = u[i];
        }
        Ok(())
    }
}

/// Coordinate `r` of (T170) of `x` without `g0`: the normal `Wᵀ x` of contact `r < n_c`, else
/// the tangent `W_Tᵀ x` of the `(r − n_c)`-th frictional contact.
pub(crate) fn coordinate(d: &Data, r: usize, x: &[f64]) -> f64 {
    let nc = d.contacts.len();
    if r < nc {
        return d.contacts.dot(r, x);
    }
    let (w, _) = d
        .contacts
        .friction
        .iter()
        .flatten()
        .nth(r - nc)
        .expect("a tangential coordinate belongs to a frictional contact");
    w.iter().map(|&(i, v)| v * x[i]).sum()
}
