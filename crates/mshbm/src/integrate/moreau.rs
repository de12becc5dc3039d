//! Moreau–Jean θ-scheme with Newton's impact law (METHODS §3.1).
//!
//! Given `(q_k, v_k)` and step `h`:
//! 1. `M̂ = M + hθC + h²θ²K` (factored once);
//! 2. `v_free = M̂⁻¹ [(M − h(1−θ)C − h²θ(1−θ)K) v_k − h K q_k + h(θ f_{k+1} + (1−θ) f_k)]`;
//! 3. closed contacts `I = {i : g_i(q_k + h(1−θ) v_k) ≤ 0}`;
//! 4. `0 ≤ U_I + e U_{I,k} ⊥ P_I ≥ 0` with `U = Wᵀ v_{k+1} = Wᵀ v_free + D P`,
//!    `D = Wᵀ M̂⁻¹ W` (precomputed; the LCP is over the sub-block `D_II`);
//! 5. `v_{k+1} = v_free + M̂⁻¹ W_I P_I`, `q_{k+1} = q_k + h(θ v_{k+1} + (1−θ) v_k)`.
//!
//! With `θ = ½` and no contact this is the trapezoidal rule: the energy of an undamped
//! linear system is conserved exactly (up to rounding).

use std::collections::HashMap;

use crate::contact::lcp::{LcpMatrix, LcpSolver};
use crate::error::{Error, Result};
use crate::model::System;
use crate::sparse::SparseMatrix;

use super::{Csc, Data, SpdSolver, State};

pub(crate) struct MoreauJean {
    theta: f64,
    restitution: f64,
    mhat: SpdSolver,
    /// `M − h(1−θ)C − h²θ(1−θ)K`.
    explicit: Csc,
    /// `M̂⁻¹ W_i` per contact.
    mw: Vec<Vec<f64>>,
    /// `D = Wᵀ M̂⁻¹ W` (row-major).
    delassus: Vec<f64>,
    /// LCP solvers per index set of closed contacts (warm-started within a set).
    solvers: HashMap<Vec<bool>, LcpSolver>,
    f_k: Vec<f64>,
    f_k1: Vec<f64>,
    rhs: Vec<f64>,
    closed: Vec<bool>,
}

impl MoreauJean {
    pub(crate) fn new(system: &System, data: &Data, theta: f64, restitution: f64) -> Result<Self> {
        let h = data.dt;
        let n = data.n;
        let mhat_m = SparseMatrix::linear_combination(
            1.0,
            &SparseMatrix::linear_combination(1.0, &system.mass, h * theta, &system.damping),
            h * h * theta * theta,
            &system.stiffness,
        );
        let explicit = SparseMatrix::linear_combination(
            1.0,
            &SparseMatrix::linear_combination(
                1.0,
                &system.mass,
                -h * (1.0 - theta),
                &system.damping,
            ),
            -h * h * theta * (1.0 - theta),
            &system.stiffness,
        );
        let mut mhat = SpdSolver::new(
            &mhat_m,
            "the Moreau-Jean iteration matrix M + h theta C + h^2 theta^2 K",
        )?;
        let nc = data.contacts.len();
        let mut mw = Vec::with_capacity(nc);
        for i in 0..nc {
            let mut c = data.contacts.column(i, n);
            mhat.solve(&mut c);
            if c.iter().any(|x| !x.is_finite()) {
                return Err(Error::Singular(
                    "the Moreau-Jean iteration matrix is singular".into(),
                ));
            }
            mw.push(c);
        }
        let mut delassus = vec![0.0; nc * nc];
        for a in 0..nc {
            for b in 0..nc {
                delassus[a * nc + b] = data.contacts.dot(a, &mw[b]);
            }
        }
        Ok(MoreauJean {
            theta,
            restitution,
            mhat,
            explicit: Csc::new(&explicit),
            mw,
            delassus,
            solvers: HashMap::new(),
            f_k: vec![0.0; n],
            f_k1: vec![0.0; n],
            rhs: vec![0.0; n],
            closed: vec![false; nc],
        })
    }

    pub(crate) fn reset(&mut self, _data: &Data, _state: &mut State) -> Result<()> {
        Ok(())
    }

    pub(crate) fn step(&mut self, d: &Data, s: &mut State) -> Result<()> {
        let h = d.dt;
        let theta = self.theta;
        let t = s.time(h);
        d.load_into(t, &mut self.f_k);
        d.load_into(s.t0 + (s.steps + 1) as f64 * h, &mut self.f_k1);
        // rhs = explicit v − h K q + h (θ f_{k+1} + (1−θ) f_k)
        for i in 0..d.n {
            self.rhs[i] = h * (theta * self.f_k1[i] + (1.0 - theta) * self.f_k[i]);
        }
        self.explicit.mul_add(1.0, &s.v, &mut self.rhs);
        d.stiffness.mul_add(-h, &s.q, &mut self.rhs);
        self.mhat.solve(&mut self.rhs);
        let v_free = &self.rhs;
        // index set at the predicted position
        let nc = d.contacts.len();
        let mut any = false;
        for i in 0..nc {
            let g = d.contacts.gap[i]
                + d.contacts.w[i]
                    .iter()
                    .map(|&(j, w)| w * (s.q[j] + h * (1.0 - theta) * s.v[j]))
                    .sum::<f64>();
            self.closed[i] = g <= 0.0;
            any |= self.closed[i];
        }
        s.forces.iter_mut().for_each(|f| *f = 0.0);
        // new velocity (v_free plus impulses); keep v_k for the position update
        let mut v_new = v_free.clone();
        if any {
            let idx: Vec<usize> = (0..nc).filter(|&i| self.closed[i]).collect();
            let q_lcp: Vec<f64> = idx
                .iter()
                .map(|&i| d.contacts.dot(i, v_free) + self.restitution * d.contacts.dot(i, &s.v))
                .collect();
            let solver = self.solvers.entry(self.closed.clone()).or_insert_with(|| {
                let m = idx.len();
                let block = idx
                    .iter()
                    .flat_map(|&a| idx.iter().map(move |&b| (a, b)))
                    .map(|(a, b)| self.delassus[a * nc + b])
                    .collect();
                LcpSolver::new(LcpMatrix::new(m, block))
            });
            let sol = solver
                .solve(&q_lcp)
                .map_err(|e| Error::Numerical(format!("impact LCP at t = {t}: {e}")))?;
            for (k, &i) in idx.iter().enumerate() {
                let p = sol.lambda[k];
                if p != 0.0 {
                    for (vj, mwj) in v_new.iter_mut().zip(&self.mw[i]) {
                        *vj += mwj * p;
                    }
                }
                s.forces[i] = p / h;
            }
        }
        for ((q, &vn), &v) in s.q.iter_mut().zip(&v_new).zip(&s.v) {
            *q += h * (theta * vn + (1.0 - theta) * v);
        }
        s.v = v_new;
        d.contacts.gaps_into(&s.q, &mut s.gaps);
        Ok(())
    }
}
