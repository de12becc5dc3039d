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
//! (on the massive DOFs; the update makes `R a + C v + K u = f + W λ` hold at every step
//! end, so it is the `a_{k+1,L} = R̄_LL⁻¹ (f − C v − K u)_L` of docs/theory.md (T67) without a
//! second factorization). For the massless DOFs `v = Δu/h` is a diagnostic and `a = 0`;
//! `R` and `C` have no entries there, so neither enters the scheme.

use crate::contact::lcp::{LcpMatrix, LcpSolver};
use crate::error::{Error, Result};
use crate::model::System;
use crate::sparse::{SparseCholesky, SparseMatrix};

use super::{Data, State};

pub(crate) struct PositionNewmark {
    ahat: SparseCholesky,
    /// Cholesky of the mass on the massive DOFs (initial accelerations).
    mass_mm: Option<SparseCholesky>,
    /// `Â⁻¹ W_i` per contact.
    aw: Vec<Vec<f64>>,
    lcp: Option<LcpSolver>,
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
            if contact.w.iter().any(|&(i, _)| !is_massless[i]) {
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
        let mut aw = Vec::with_capacity(nc);
        for i in 0..nc {
            let mut c = data.contacts.column(i, n);
            ahat.solve(&mut c);
            if c.iter().any(|x| !x.is_finite()) {
                return Err(Error::Singular(
                    "the Newmark iteration matrix is singular".into(),
                ));
            }
            aw.push(c);
        }
        let lcp = (nc > 0).then(|| {
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
