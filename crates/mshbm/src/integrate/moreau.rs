//! Moreau–Jean θ-scheme with Newton's impact law (docs/theory.md §8, (T59)–(T62)).
//!
//! Given `(q_k, v_k)` and step `h`:
//! 1. `M̂ = M + hθC + h²θ²K` (factored once);
//! 2. `v_free = M̂⁻¹ [(M − h(1−θ)C − h²θ(1−θ)K) v_k − h K q_k + h(θ f_{k+1} + (1−θ) f_k)]`;
//! 3. closed contacts `I = {i : g_i(q_k + h(1−θ) v_k) ≤ 0}`;
//! 4. `0 ≤ U_I + e U_{I,k} ⊥ P_I ≥ 0` with `U = Wᵀ v_{k+1} = Wᵀ v_free + D P`,
//!    `D = Wᵀ M̂⁻¹ W` (precomputed; the LCP is over the sub-block `D_II`);
//! 5. `v_{k+1} = v_free + M̂⁻¹ W_I P_I`, `q_{k+1} = q_k + h(θ v_{k+1} + (1−θ) v_k)`.
//!
//! **Anticipating index set** (optional, `anticipate`): every contact takes part, with the
//! law `0 ≤ U_{k+1} + e U_k + max(g_pred, 0)/(hθ) ⊥ P ≥ 0` (the restitution term only
//! where `g_pred ≤ 0`). Where `g_pred ≤ 0` this is the law above; where `g_pred > 0` it
//! allows the contact to act only if the step would end with `g_{k+1} = g_pred + hθU_{k+1}
//! < 0`. With `e = 0` the step is then a *continuous* (piecewise affine) function of the
//! state and load, instead of jumping when `g_pred` changes sign; this makes the discrete
//! periodic-orbit map of the general MS-HBM continuous (Newton converges) and the
//! simulation settle to an exactly periodic state. It converges to the same solutions as
//! `h → 0`.
//!
//! **Position projection** (optional, `project`): after the step, when a gap is negative,
//! the positions are projected back onto the admissible set in the metric of `M̂`,
//! `q_{k+1} ← q_{k+1} + M̂⁻¹ W μ` with `0 ≤ g_{k+1} + D μ ⊥ μ ≥ 0` (velocities unchanged;
//! the "projected Moreau–Jean scheme" of Acary 2013, Comput. Methods Appl. Mech. Engrg.
//! 263). Without it a persistent contact keeps the penetration `h(1−θ)U` of the impact
//! step, which depends on where in the step the impact falls: a saw-tooth of the step size
//! in every position of the contact phase, with slope jumps of order one at each step
//! boundary (measured: it stalls Newton of the general MS-HBM at ≈ `h |U| / g₀`). With the
//! projection the gap of a persistent contact is exactly zero at every step, and the map
//! stays continuous (the projection is Lipschitz in `q`).
//!
//! With friction elements (docs/theory.md (T63)) the impulses of the closed contacts and the
//! active friction elements are found together by exact-row Gauss–Seidel prox sweeps,
//! polished by an exact solve of the stick/slip/contact status found ([`super`] docs).
//!
//! With `θ = ½` and no contact this is the trapezoidal rule: the energy of an undamped
//! linear system is conserved exactly (up to rounding).

use std::collections::HashMap;

use crate::contact::lcp::{LcpMatrix, LcpSolver};
use crate::error::{Error, Result};
use crate::model::System;
use crate::sparse::{SparseCholesky, SparseMatrix};

use super::{Data, State};

pub(crate) struct MoreauJean {
    theta: f64,
    restitution: f64,
    mhat: SparseCholesky,
    /// `M − h(1−θ)C − h²θ(1−θ)K`.
    explicit: SparseMatrix,
    /// `M̂⁻¹ W_i` per contact.
    mw: Vec<Vec<f64>>,
    /// `D = Wᵀ M̂⁻¹ W` (row-major).
    delassus: Vec<f64>,
    /// `M̂⁻¹ W_T` per friction element.
    mwt: Vec<Vec<f64>>,
    /// `G = [W_N W_T]ᵀ M̂⁻¹ [W_N W_T]` (row-major, contacts first).
    g_all: Vec<f64>,
    /// LCP solvers per index set of closed contacts (warm-started within a set).
    solvers: HashMap<Vec<bool>, LcpSolver>,
    f_k: Vec<f64>,
    f_k1: Vec<f64>,
    /// The time of `f_k1` (the next step's `f_k`).
    f_k1_time: Option<f64>,
    /// The new velocity of a step (swapped into the state).
    v_new: Vec<f64>,
    /// Buffers of the frictional impact problem, kept between steps.
    friction: FrictionWork,
    rhs: Vec<f64>,
    closed: Vec<bool>,
    /// Per contact: the term added to `Wᵢᵀ v_{k+1}` in the impact law (`e Wᵢᵀ v_k`, plus
    /// `max(g_pred, 0)/(hθ)` when anticipating).
    offset: Vec<f64>,
    /// Position-anticipating index set (see [`super::Integrator::set_contact_anticipation`]).
    pub(crate) anticipate: bool,
    /// Project the positions onto `g ≥ 0` after each step (see the module docs).
    pub(crate) project: bool,
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
        let mut mhat = SparseCholesky::new(
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
        let nf = data.frictions.len();
        let mut mwt = Vec::with_capacity(nf);
        for i in 0..nf {
            let mut c = data.frictions.column(i, n);
            mhat.solve(&mut c);
            if c.iter().any(|x| !x.is_finite()) {
                return Err(Error::Singular(
                    "the Moreau-Jean iteration matrix is singular".into(),
                ));
            }
            mwt.push(c);
        }
        let na = nc + nf;
        let mut g_all = vec![0.0; na * na];
        for a in 0..na {
            for b in 0..na {
                let col = if b < nc { &mw[b] } else { &mwt[b - nc] };
                g_all[a * na + b] = if a < nc {
                    data.contacts.dot(a, col)
                } else {
                    data.frictions.dot(a - nc, col)
                };
            }
        }
        Ok(MoreauJean {
            theta,
            restitution,
            mhat,
            mwt,
            g_all,
            explicit,
            mw,
            delassus,
            solvers: HashMap::new(),
            f_k: vec![0.0; n],
            f_k1: vec![0.0; n],
            f_k1_time: None,
            v_new: vec![0.0; n],
            friction: FrictionWork::default(),
            rhs: vec![0.0; n],
            closed: vec![false; nc],
            offset: vec![0.0; nc],
            anticipate: false,
            project: false,
        })
    }

    pub(crate) fn reset(&mut self, _data: &Data, _state: &mut State) -> Result<()> {
        self.f_k1_time = None;
        Ok(())
    }

    pub(crate) fn step(&mut self, d: &Data, s: &mut State) -> Result<()> {
        let h = d.dt;
        let theta = self.theta;
        let t = s.time(h);
        // the last step's f_{k+1} is this step's f_k (the same time, bit for bit)
        if self.f_k1_time == Some(t) {
            std::mem::swap(&mut self.f_k, &mut self.f_k1);
        } else {
            d.load_into(t, &mut self.f_k);
        }
        let t1 = s.t0 + (s.steps + 1) as f64 * h;
        d.load_into(t1, &mut self.f_k1);
        self.f_k1_time = Some(t1);
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
            self.closed[i] = g <= 0.0 || self.anticipate;
            self.offset[i] = if g <= 0.0 {
                self.restitution * d.contacts.dot(i, &s.v)
            } else {
                g / (h * theta)
            };
            any |= self.closed[i];
        }
        s.forces.iter_mut().for_each(|f| *f = 0.0);
        s.friction_forces.iter_mut().for_each(|f| *f = 0.0);
        // new velocity (v_free plus impulses); keep v_k for the position update
        let mut v_new = std::mem::take(&mut self.v_new);
        v_new.clear();
        v_new.extend_from_slice(v_free);
        let nf = d.frictions.len();
        let friction_active = (0..nf).any(|f| match d.frictions.normal[f] {
            Ok(p) => d.frictions.mu[f] * p > 0.0,
            Err(c) => self.closed[c] && d.frictions.mu[f] > 0.0,
        });
        if friction_active {
            self.frictional_impulses(d, s)?;
            let (pn, pt) = (&self.friction.pn, &self.friction.pt);
            for (i, &p) in pn.iter().enumerate() {
                if p != 0.0 {
                    for (vj, mwj) in v_new.iter_mut().zip(&self.mw[i]) {
                        *vj += mwj * p;
                    }
                }
                s.forces[i] = p / h;
            }
            for (f, &p) in pt.iter().enumerate() {
                if p != 0.0 {
                    for (vj, mwj) in v_new.iter_mut().zip(&self.mwt[f]) {
                        *vj += mwj * p;
                    }
                }
                s.friction_forces[f] = p / h;
            }
        } else if any {
            let idx: Vec<usize> = (0..nc).filter(|&i| self.closed[i]).collect();
            let q_lcp: Vec<f64> = idx
                .iter()
                .map(|&i| d.contacts.dot(i, v_free) + self.offset[i])
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
        self.v_new = std::mem::replace(&mut s.v, v_new);
        d.contacts.gaps_into(&s.q, &mut s.gaps);
        if self.project && s.gaps.iter().any(|&g| g < 0.0) {
            self.project_positions(d, s, t)?;
        }
        Ok(())
    }

    /// `q ← q + M̂⁻¹ W μ` with `0 ≤ g + D μ ⊥ μ ≥ 0` over all contacts (module docs).
    fn project_positions(&mut self, d: &Data, s: &mut State, t: f64) -> Result<()> {
        let nc = d.contacts.len();
        let key = vec![true; nc];
        let solver = self
            .solvers
            .entry(key)
            .or_insert_with(|| LcpSolver::new(LcpMatrix::new(nc, self.delassus.clone())));
        let sol = solver
            .solve(&s.gaps)
            .map_err(|e| Error::Numerical(format!("position projection at t = {t}: {e}")))?;
        for (i, &mu) in sol.lambda.iter().enumerate() {
            if mu != 0.0 {
                for (qj, mwj) in s.q.iter_mut().zip(&self.mw[i]) {
                    *qj += mwj * mu;
                }
            }
        }
        d.contacts.gaps_into(&s.q, &mut s.gaps);
        // exact admissibility despite rounding: a closed gap is zero, not −1e-19
        s.gaps.iter_mut().for_each(|g| *g = g.max(0.0));
        Ok(())
    }

    /// Impulses `(P_N per contact, P_T per friction element)` of one step with friction
    /// (see the module docs). `self.rhs` holds `v_free`, `self.closed` the index set.
    fn frictional_impulses(&mut self, d: &Data, s: &State) -> Result<()> {
        let mut work = std::mem::take(&mut self.friction);
        let solved = self.frictional_impulses_into(d, s, &mut work);
        self.friction = work;
        solved
    }

    /// [`Self::frictional_impulses`] with the buffers `work` (results in `work.pn`, `work.pt`).
    fn frictional_impulses_into(&self, d: &Data, s: &State, work: &mut FrictionWork) -> Result<()> {
        let h = d.dt;
        let nc = d.contacts.len();
        let nf = d.frictions.len();
        let na = nc + nf;
        let v_free = &self.rhs;
        let FrictionWork {
            rows,
            pos,
            c,
            p,
            status,
            a,
            rhs,
            pn,
            pt,
        } = work;
        // active rows (global indices into G: contacts first, then frictions)
        rows.clear();
        rows.extend((0..nc).filter(|&i| self.closed[i]));
        for f in 0..nf {
            let on = match d.frictions.normal[f] {
                Ok(p) => d.frictions.mu[f] * p > 0.0,
                Err(c) => self.closed[c] && d.frictions.mu[f] > 0.0,
            };
            if on {
                rows.push(nc + f);
            }
        }
        let m = rows.len();
        pos.clear();
        pos.resize(na, usize::MAX);
        rows.iter().enumerate().for_each(|(k, &r)| pos[r] = k);
        // ξ = c + G P
        c.clear();
        c.extend(rows.iter().map(|&r| {
            if r < nc {
                d.contacts.dot(r, v_free) + self.offset[r]
            } else {
                d.frictions.dot(r - nc, v_free)
            }
        }));
        let (rows, pos, c) = (&*rows, &*pos, &*c);
        let g = |a: usize, b: usize| self.g_all[rows[a] * na + rows[b]];
        // bound of a friction row given the current impulses
        let bound = |k: usize, p: &[f64]| -> f64 {
            let f = rows[k] - nc;
            match d.frictions.normal[f] {
                Ok(fnorm) => h * d.frictions.mu[f] * fnorm,
                Err(ci) => d.frictions.mu[f] * p[pos[ci]].max(0.0),
            }
        };
        p.clear();
        p.resize(m, 0.0);
        let scale = c
            .iter()
            .enumerate()
            .map(|(k, ck)| (ck / g(k, k)).abs())
            .fold(0.0f64, f64::max)
            .max(f64::MIN_POSITIVE);
        let mut converged = false;
        for _sweep in 0..10_000 {
            let mut change = 0.0f64;
            for k in 0..m {
                let xi: f64 = c[k] + (0..m).map(|j| g(k, j) * p[j]).sum::<f64>();
                let trial = p[k] - xi / g(k, k);
                let new = if rows[k] < nc {
                    trial.max(0.0)
                } else {
                    let b = bound(k, p);
                    trial.clamp(-b, b)
                };
                change = change.max((new - p[k]).abs());
                p[k] = new;
            }
            if change <= 1e-14 * scale {
                converged = true;
                break;
            }
        }
        // polish: exact solve of the status found
        status.clear();
        status.extend((0..m).map(|k| {
            if rows[k] < nc {
                if p[k] > 0.0 {
                    1
                } else {
                    0
                }
            } else {
                let b = bound(k, p);
                if b == 0.0 {
                    0
                } else if p[k] >= b * (1.0 - 1e-12) {
                    2
                } else if p[k] <= -b * (1.0 - 1e-12) {
                    -2
                } else {
                    1
                }
            }
        }));
        a.clear();
        a.resize(m * m, 0.0);
        rhs.clear();
        rhs.resize(m, 0.0);
        for k in 0..m {
            match status[k] {
                1 => {
                    for j in 0..m {
                        a[k * m + j] = g(k, j);
                    }
                    rhs[k] = -c[k];
                }
                0 => a[k * m + k] = 1.0,
                sgn => {
                    let sg = f64::from(sgn.signum());
                    a[k * m + k] = 1.0;
                    let f = rows[k] - nc;
                    match d.frictions.normal[f] {
                        Ok(fnorm) => rhs[k] = sg * h * d.frictions.mu[f] * fnorm,
                        Err(ci) => a[k * m + pos[ci]] = -sg * d.frictions.mu[f],
                    }
                }
            }
        }
        let tol = 1e-9;
        let polished = crate::dense::solve_small(a, rhs, 1e-14).filter(|q| {
            (0..m).all(|k| {
                let xi: f64 = c[k] + (0..m).map(|j| g(k, j) * q[j]).sum::<f64>();
                let vs = scale * g(k, k).abs() * tol; // velocity scale
                if rows[k] < nc {
                    q[k] >= -tol * scale && xi >= -vs
                } else {
                    let b = bound(k, q);
                    match status[k] {
                        1 => q[k].abs() <= b * (1.0 + tol) + tol * scale,
                        0 => true,
                        sgn => f64::from(sgn.signum()) * xi <= vs,
                    }
                }
            })
        });
        match polished {
            Some(q) => p.copy_from_slice(&q),
            None if converged => {}
            None => {
                return Err(Error::Numerical(format!(
                    "frictional impact problem at t = {} did not converge",
                    s.time(h)
                )))
            }
        }
        // exact feasibility: P_N ≥ 0, |P_T| ≤ bound
        for k in 0..m {
            if rows[k] < nc {
                p[k] = p[k].max(0.0);
            }
        }
        for k in 0..m {
            if rows[k] >= nc {
                let b = bound(k, p);
                p[k] = p[k].clamp(-b, b);
            }
        }
        pn.clear();
        pn.resize(nc, 0.0);
        pt.clear();
        pt.resize(nf, 0.0);
        for (k, &r) in rows.iter().enumerate() {
            if r < nc {
                pn[r] = p[k];
            } else {
                pt[r - nc] = p[k];
            }
        }
        Ok(())
    }
}

/// Buffers of the frictional impact problem of one step (rows of the active contacts and
/// friction elements, their free velocities, impulses, status and the polishing system).
#[derive(Clone, Debug, Default)]
struct FrictionWork {
    rows: Vec<usize>,
    pos: Vec<usize>,
    c: Vec<f64>,
    p: Vec<f64>,
    status: Vec<i8>,
    a: Vec<f64>,
    rhs: Vec<f64>,
    pn: Vec<f64>,
    pt: Vec<f64>,
}

#[cfg(test)]
mod tests;
