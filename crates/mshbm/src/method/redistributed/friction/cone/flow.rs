//! The state of the cone law at one instant (docs/theory.md (T186)–(T188)): the forces of a
//! set of closed contacts, the slip speeds and directions, the indicators of the modes, and
//! the projection of slipping contacts back onto the cone.

// the small dense matrices of the law are indexed as the equations write them
#![allow(clippy::needless_range_loop)]

use super::march::{Closed, Evaluation, March, Watch};
use super::*;

impl March<'_> {
    /// Forces, slip speeds and directions at `τ` for `modes` with tangential displacements
    /// `anchors` (T186), (T187).
    pub(super) fn evaluate(
        &self,
        tau: f64,
        modes: &[ConeMode],
        anchors: &[f64],
        closed: &Closed,
    ) -> Result<Evaluation> {
        let n = self.law.n;
        let lambda = self.forces(tau, modes, anchors, closed);
        let slipping: Vec<usize> = (0..n)
            .filter(|&c| modes[c] == ConeMode::Slip && closed.tangent_row[c].is_some())
            .collect();
        if slipping.is_empty() {
            return Ok(Evaluation {
                lambda,
                speed: Vec::new(),
                direction: Vec::new(),
            });
        }
        let direction = self.directions_at(tau, closed, &slipping, &lambda);
        // a contact whose normal force has reached 0 (within (T153)'s tolerance, as it opens)
        // has no slip direction: it is held where it is until the opening is located
        let loaded: Vec<usize> = (0..slipping.len())
            .filter(|&i| lambda[slipping[i]] > 0.0 && direction[i] != [0.0, 0.0])
            .collect();
        let active: Vec<usize> = loaded.iter().map(|&i| slipping[i]).collect();
        let active_direction: Vec<[f64; 2]> = loaded.iter().map(|&i| direction[i]).collect();
        let b = self.driving_rates(tau, closed, &active, &active_direction);
        let active_speed = self.solve_slip(closed, &active, &active_direction, &b)?;
        let mut speed = vec![f64::INFINITY; slipping.len()];
        for (q, &i) in loaded.iter().enumerate() {
            speed[i] = active_speed[q];
        }
        Ok(Evaluation {
            lambda,
            speed,
            direction,
        })
    }

    /// The slip directions `e_c = −λ_T,c/|λ_T,c|` of `slipping` (T187).
    pub(super) fn directions(&self, slipping: &[usize], lambda: &[f64]) -> Vec<[f64; 2]> {
        let n = self.law.n;
        slipping
            .iter()
            .map(|&c| {
                let (t1, t2) = (lambda[n + c], lambda[2 * n + c]);
                let norm = t1.hypot(t2);
                if norm > 0.0 {
                    [-t1 / norm, -t2 / norm]
                } else {
                    [0.0, 0.0]
                }
            })
            .collect()
    }

    /// Solve `A x = b` with the matrix `A` of (T187): the rate of the cone margins
    /// `μ λ_N,c + e_cᵀ λ_T,c` per unit of slip of each contact along its direction.
    pub(super) fn solve_slip(
        &self,
        closed: &Closed,
        slipping: &[usize],
        direction: &[[f64; 2]],
        b: &[f64],
    ) -> Result<Vec<f64>> {
        let s = slipping.len();
        if s == 0 {
            return Ok(Vec::new());
        }
        let a = self.slip_matrix(closed, slipping, direction);
        if s == 1 {
            if a[0] == 0.0 {
                return Err(Error::Numerical(
                    "friction cone: a slipping contact without tangential force".into(),
                ));
            }
            return Ok(vec![b[0] / a[0]]);
        }
        let x = solve_small_lu_columns(&a, faer::MatRef::from_column_major_slice(b, s, 1), 1e-14)
            .map_err(|_| {
            Error::Numerical(
                "friction cone: the slip speeds of the slipping contacts are not \
                     determined (T187)"
                    .into(),
            )
        })?;
        Ok((0..s).map(|i| x[(i, 0)]).collect())
    }

    /// The matrix `A` of (T187) (`|S| × |S|`, row-major) for the contacts `slipping` moving
    /// along `direction`.
    pub(super) fn slip_matrix(
        &self,
        closed: &Closed,
        slipping: &[usize],
        direction: &[[f64; 2]],
    ) -> Vec<f64> {
        let k = closed.rows.len();
        let s = slipping.len();
        let mut a = vec![0.0; s * s];
        for (i, &c) in slipping.iter().enumerate() {
            let (nc, tc) = (
                closed.normal_row[c].unwrap(),
                closed.tangent_row[c].unwrap(),
            );
            let e = direction[i];
            let mu = self.law.mu[c];
            for (j, &d) in slipping.iter().enumerate() {
                let ts = closed.tangent_row[d].unwrap();
                let es = direction[j];
                let mut v = 0.0;
                for q in 0..2 {
                    v += (mu * closed.y[nc * k + ts + q]
                        + e[0] * closed.y[tc * k + ts + q]
                        + e[1] * closed.y[(tc + 1) * k + ts + q])
                        * es[q];
                }
                a[i * s + j] = v;
            }
        }
        a
    }

    /// Move the slipping contacts' displacements along their directions until their forces
    /// are on the cone to round-off (T187): the flow keeps them there only to its tolerance,
    /// and a force outside the cone by more than (T153)'s tolerance would make a contact
    /// that stops slipping start again at once.
    pub(super) fn project(
        &self,
        tau: f64,
        modes: &[ConeMode],
        anchors: &mut [f64],
        closed: &Closed,
    ) -> Result<()> {
        let n = self.law.n;
        let slipping = self.slipping(modes);
        if slipping.is_empty() {
            return Ok(());
        }
        for _ in 0..3 {
            let lambda = self.forces(tau, modes, anchors, closed);
            let slipping: Vec<usize> = slipping
                .iter()
                .copied()
                .filter(|&c| lambda[c] > 0.0 && lambda[n + c].hypot(lambda[2 * n + c]) > 0.0)
                .collect();
            let direction = self.directions(&slipping, &lambda);
            let margin: Vec<f64> = slipping
                .iter()
                .map(|&c| self.law.mu[c] * lambda[c] - lambda[n + c].hypot(lambda[2 * n + c]))
                .collect();
            if margin.iter().all(|m| m.abs() <= 1e-15 * self.force_scale) {
                break;
            }
            let delta = self.solve_slip(closed, &slipping, &direction, &margin)?;
            for (i, &c) in slipping.iter().enumerate() {
                anchors[c] -= delta[i] * direction[i][0];
                anchors[n + c] -= delta[i] * direction[i][1];
            }
        }
        Ok(())
    }

    /// The forces (T186) at `τ` (`3n`) of the contacts in `modes` with tangential
    /// displacements `anchors`: `λ_C = −Y_C γ_C(τ) + Y_C [0; a_C]`, the first term from its
    /// coefficients `Y_C γ̂_C` (computed once per closed set), the second from the stuck
    /// contacts' part (computed once per set of their displacements) and the slipping
    /// contacts' columns.
    pub(super) fn forces(
        &self,
        tau: f64,
        modes: &[ConeMode],
        anchors: &[f64],
        closed: &Closed,
    ) -> Vec<f64> {
        let n = self.law.n;
        let k = closed.rows.len();
        let ncoef = n_coefficients(self.harmonics);
        let mut b = vec![0.0; ncoef];
        basis_into(self.harmonics, tau, &mut b);
        let mut lambda_k: Vec<f64> = (0..k)
            .map(|i| {
                closed.free[i * ncoef..(i + 1) * ncoef]
                    .iter()
                    .zip(&b)
                    .map(|(f, v)| f * v)
                    .sum()
            })
            .collect();
        let (stuck, slipping): (Vec<usize>, Vec<usize>) = (0..n)
            .filter(|&c| closed.tangent_row[c].is_some())
            .partition(|&c| modes[c] != ConeMode::Slip);
        let add_columns = |contacts: &[usize], out: &mut [f64]| {
            for &c in contacts {
                let t = closed.tangent_row[c].unwrap();
                let (a1, a2) = (anchors[c], anchors[n + c]);
                for (i, v) in out.iter_mut().enumerate() {
                    *v += closed.y[i * k + t] * a1 + closed.y[i * k + t + 1] * a2;
                }
            }
        };
        let held: Vec<f64> = stuck
            .iter()
            .flat_map(|&c| [anchors[c], anchors[n + c]])
            .collect();
        {
            let mut cache = closed.stuck.borrow_mut();
            let fresh = matches!(&*cache, Some((s, h, _)) if *s == stuck && *h == held);
            if !fresh {
                let mut part = vec![0.0; k];
                add_columns(&stuck, &mut part);
                *cache = Some((stuck, held, part));
            }
            let (_, _, part) = cache.as_ref().unwrap();
            for (v, p) in lambda_k.iter_mut().zip(part) {
                *v += p;
            }
        }
        add_columns(&slipping, &mut lambda_k);
        let mut lambda = vec![0.0; 3 * n];
        for (i, &r) in closed.rows.iter().enumerate() {
            lambda[r] = lambda_k[i];
        }
        lambda
    }

    /// The indicators (T188) of every contact at `τ`: `(value + tolerance, contact, what)`,
    /// negative where the mode ends.
    pub(super) fn indicators(
        &self,
        tau: f64,
        modes: &[ConeMode],
        anchors: &[f64],
        closed: &Closed,
    ) -> Result<Vec<(f64, usize, Watch)>> {
        let n = self.law.n;
        let ev = self.evaluate(tau, modes, anchors, closed)?;
        let mut out = Vec::with_capacity(2 * n);
        let mut slip_index = 0;
        let mut g = vec![0.0; 3 * n];
        self.gamma_at(tau, &mut g, None);
        let force_tol = INDICATOR_TOLERANCE * self.force_scale;
        for c in 0..n {
            match modes[c] {
                ConeMode::Open => {
                    let gap = g[c]
                        + closed
                            .rows
                            .iter()
                            .map(|&r| self.law.d(c, r) * ev.lambda[r])
                            .sum::<f64>();
                    out.push((gap + INDICATOR_TOLERANCE * self.gamma_scale, c, Watch::Gap));
                }
                mode => {
                    let ln = ev.lambda[c];
                    out.push((ln + force_tol, c, Watch::Normal));
                    if self.law.mu[c] > 0.0 {
                        if mode == ConeMode::Stick {
                            let lt = ev.lambda[n + c].hypot(ev.lambda[2 * n + c]);
                            out.push((self.law.mu[c] * ln - lt + force_tol, c, Watch::Cone));
                        } else {
                            out.push((
                                ev.speed[slip_index] + INDICATOR_TOLERANCE * self.rate_scale,
                                c,
                                Watch::Speed,
                            ));
                            slip_index += 1;
                        }
                    }
                }
            }
        }
        Ok(out)
    }

    /// The slipping contacts with friction of `modes`.
    pub(super) fn slipping(&self, modes: &[ConeMode]) -> Vec<usize> {
        (0..self.law.n)
            .filter(|&c| modes[c] == ConeMode::Slip && self.law.mu[c] > 0.0)
            .collect()
    }
}
