//! The tangent of the slip flow and of the forces within a phase (docs/theory.md (T214),
//! (T215)).

// the small dense matrices of the law are indexed as the equations write them
#![allow(clippy::needless_range_loop)]

use super::super::march::{Closed, March};
use super::super::*;

/// The regularisation of `1/|λ_T|` in the slip direction's variation (T215), as a fraction
/// of the forces' scale: `|λ_T|/(|λ_T|² + ε²)`, which keeps the rates finite at the apex
/// (a contact closing straight into slip, or slipping into opening); the tangent's implicit
/// collocation (T222) integrates the stiff flow there.
const APEX: f64 = 1e-12;

/// The law's rates at one instant of a phase and their variations along the columns.
pub(in super::super) struct Rates {
    /// `λ` and `λ̇` (`3n`).
    pub(in super::super) lambda: Vec<f64>,
    pub(in super::super) lambda_rate: Vec<f64>,
    /// `ȧ` (`2n`, zero but for the slipping contacts).
    pub(in super::super) rate: Vec<f64>,
    /// One column per column asked: `δλ` (`3n` rows), `δȧ` (`2n`), `δκ` (`n`, zero but for
    /// the slipping contacts).
    pub(in super::super) d_lambda: Mat<f64>,
    pub(in super::super) d_rate: Mat<f64>,
    pub(in super::super) d_speed: Mat<f64>,
    /// The slip speeds `κ` (`n`).
    pub(in super::super) speed: Vec<f64>,
}

/// `Σ_q b_q(τ) x̂_q` and its rate, `m` rows, coefficients harmonic-major.
pub(super) fn series_at(
    harmonics: usize,
    coefficients: &[f64],
    m: usize,
    tau: f64,
) -> (Vec<f64>, Vec<f64>) {
    let ncoef = n_coefficients(harmonics);
    let mut b = vec![0.0; ncoef];
    basis_into(harmonics, tau, &mut b);
    let (mut x, mut rate) = (vec![0.0; m], vec![0.0; m]);
    for r in 0..m {
        x[r] = (0..ncoef).map(|q| b[q] * coefficients[q * m + r]).sum();
    }
    for k in 1..=harmonics {
        let (dc, ds) = (-(k as f64) * b[2 * k], k as f64 * b[2 * k - 1]);
        for r in 0..m {
            rate[r] += dc * coefficients[(2 * k - 1) * m + r] + ds * coefficients[2 * k * m + r];
        }
    }
    (x, rate)
}

/// [`series_at`] of every column at once: `Σ_q b_q(τ) x̂_q` and its rate, `m × ncol`.
fn series_columns(
    harmonics: usize,
    columns: &[Vec<f64>],
    m: usize,
    tau: f64,
) -> (Mat<f64>, Mat<f64>) {
    let ncoef = n_coefficients(harmonics);
    let mut b = vec![0.0; ncoef];
    basis_into(harmonics, tau, &mut b);
    // the basis' rates: d/dτ cos kτ = −k sin kτ, d/dτ sin kτ = k cos kτ
    let mut db = vec![0.0; ncoef];
    for k in 1..=harmonics {
        db[2 * k - 1] = -(k as f64) * b[2 * k];
        db[2 * k] = k as f64 * b[2 * k - 1];
    }
    let ncol = columns.len();
    let (mut x, mut rate) = (Mat::<f64>::zeros(m, ncol), Mat::<f64>::zeros(m, ncol));
    for (j, column) in columns.iter().enumerate() {
        for q in 0..ncoef {
            for (r, &v) in column[q * m..(q + 1) * m].iter().enumerate() {
                // the unit directions of the dense Jacobian are zero but for one entry
                if v != 0.0 {
                    x[(r, j)] += b[q] * v;
                    rate[(r, j)] += db[q] * v;
                }
            }
        }
    }
    (x, rate)
}

/// `Y X` for the closed set's `Y` (`k × k`) and `X` (`k × ncol`), on the calling thread.
fn y_times(closed: &Closed, x: faer::MatRef<'_, f64>) -> Mat<f64> {
    let k = closed.rows.len();
    crate::dense::sequential_product(faer::MatRef::from_row_major_slice(&closed.y, k, k), x)
}

impl March<'_> {
    /// `Y v_K` scattered to `3n` rows.
    fn apply_y(&self, closed: &Closed, v: &[f64]) -> Vec<f64> {
        let k = closed.rows.len();
        let mut out = vec![0.0; 3 * self.law.n];
        for i in 0..k {
            out[closed.rows[i]] = (0..k)
                .map(|j| closed.y[i * k + j] * v[closed.rows[j]])
                .sum();
        }
        out
    }

    /// `δr − δγ_K` on the closed rows (`k × ncol`) for the free gap's variations `dg`
    /// (`3n × ncol`, at the instant) and the columns' displacements `d_anchors` (T214):
    /// `Y` times it is `δλ_K`.
    fn closed_columns(&self, closed: &Closed, dg: &Mat<f64>, d_anchors: &[Vec<f64>]) -> Mat<f64> {
        let n = self.law.n;
        let ncol = dg.ncols();
        let mut v = Mat::<f64>::zeros(closed.rows.len(), ncol);
        for (i, &r) in closed.rows.iter().enumerate() {
            for j in 0..ncol {
                v[(i, j)] = -dg[(r, j)];
            }
        }
        for c in 0..n {
            if let Some(t) = closed.tangent_row[c] {
                for j in 0..ncol {
                    v[(t, j)] += d_anchors[j][c];
                    v[(t + 1, j)] += d_anchors[j][n + c];
                }
            }
        }
        v
    }

    /// (T214), (T215) at `τ` for `modes` with displacements `anchors`, along the columns
    /// `(δγ̂_j, δa_j)`.
    pub(in super::super) fn rates(
        &self,
        tau: f64,
        modes: &[ConeMode],
        anchors: &[f64],
        closed: &Closed,
        d_gamma: &[Vec<f64>],
        d_anchors: &[Vec<f64>],
    ) -> Result<Rates> {
        let n = self.law.n;
        let m = 3 * n;
        let ev = self.evaluate(tau, modes, anchors, closed)?;
        let slipping = self.slipping(modes);
        // the loaded slipping contacts (an unloaded one is held, (T187))
        let active: Vec<(usize, usize)> = slipping
            .iter()
            .enumerate()
            .filter(|&(i, _)| ev.speed[i].is_finite())
            .map(|(i, &c)| (i, c))
            .collect();
        let mut rate = vec![0.0; 2 * n];
        let mut speed = vec![0.0; n];
        for &(i, c) in &active {
            speed[c] = ev.speed[i];
            rate[c] = ev.speed[i] * ev.direction[i][0];
            rate[n + c] = ev.speed[i] * ev.direction[i][1];
        }
        let (_, gamma_rate) = series_at(self.harmonics, self.gamma, m, tau);
        // λ̇ = Y (ṙ − γ̇_K)
        let mut v = vec![0.0; m];
        for &r in &closed.rows {
            v[r] = -gamma_rate[r];
        }
        for &(_, c) in &active {
            v[n + c] += rate[c];
            v[2 * n + c] += rate[n + c];
        }
        let lambda_rate = self.apply_y(closed, &v);
        let ncol = d_gamma.len();
        let s = active.len();
        let apex = APEX * self.force_scale;
        // the columns on the closed rows: `δr − δγ_K` (T214) and `δγ̇_K`
        let k = closed.rows.len();
        let (dg, dg_rate) = series_columns(self.harmonics, d_gamma, m, tau);
        let v = self.closed_columns(closed, &dg, d_anchors);
        let mut w = Mat::<f64>::from_fn(k, ncol, |i, j| dg_rate[(closed.rows[i], j)]);
        let dl_k = y_times(closed, v.as_ref());
        // δe of (T215) (`2s` rows), and `w − u` with `u_T,c = κ_c δe_c` on the slipping
        // contacts' tangent rows
        let mut de = Mat::<f64>::zeros(2 * s, ncol);
        // `Y δγ̇_K`, whose tangent rows are `−δλ̇_T` of a stuck contact: the variation of the
        // direction at the apex (T223), computed where some slipping contact is there
        let apex_rates = active
            .iter()
            .any(|&(_, c)| self.at_apex(&ev.lambda, c))
            .then(|| y_times(closed, w.as_ref()));
        for (q, &(i, c)) in active.iter().enumerate() {
            let e = ev.direction[i];
            let t = closed.tangent_row[c].expect("a slipping contact is closed with friction");
            let norm = ev.lambda[n + c].hypot(ev.lambda[2 * n + c]);
            // at the apex the direction is that of the stuck force's rate `s = −(Y γ̇_K)_T`
            // (T193), and its variation `−(I − e eᵀ) δs/|s|`, bounded (T223); elsewhere the
            // force's, with 1/|λ_T| regularised where it vanishes
            let at_rate = match &apex_rates {
                Some(y_rates) if self.at_apex(&ev.lambda, c) => {
                    let rate = self.stick_rate(tau, closed, c);
                    let rate_norm = rate[0].hypot(rate[1]);
                    (rate_norm > 0.0).then_some((y_rates, -1.0 / rate_norm))
                }
                _ => None,
            };
            let (columns, inverse) = at_rate.unwrap_or((&dl_k, norm / (norm * norm + apex * apex)));
            for j in 0..ncol {
                let dt = [columns[(t, j)], columns[(t + 1, j)]];
                let along = e[0] * dt[0] + e[1] * dt[1];
                let d = [
                    -(dt[0] - e[0] * along) * inverse,
                    -(dt[1] - e[1] * along) * inverse,
                ];
                de[(2 * q, j)] = d[0];
                de[(2 * q + 1, j)] = d[1];
                w[(t, j)] -= speed[c] * d[0];
                w[(t + 1, j)] -= speed[c] * d[1];
            }
        }
        // `Y (δγ̇_K − u)`: the rates' part of (T215)
        let z = y_times(closed, w.as_ref());
        let mut rhs = Mat::<f64>::zeros(s, ncol);
        for (q, &(i, c)) in active.iter().enumerate() {
            let e = ev.direction[i];
            let mu = self.law.mu[c];
            let nr = closed.normal_row[c].expect("a slipping contact is closed");
            let t = closed.tangent_row[c].expect("a slipping contact is closed with friction");
            for j in 0..ncol {
                rhs[(q, j)] = mu * z[(nr, j)] + e[0] * z[(t, j)] + e[1] * z[(t + 1, j)]
                    - de[(2 * q, j)] * lambda_rate[n + c]
                    - de[(2 * q + 1, j)] * lambda_rate[2 * n + c];
            }
        }
        let contacts: Vec<usize> = active.iter().map(|&(_, c)| c).collect();
        let directions: Vec<[f64; 2]> = active.iter().map(|&(i, _)| ev.direction[i]).collect();
        let dk = if s == 0 {
            Mat::zeros(0, ncol)
        } else {
            let a = self.slip_matrix(closed, &contacts, &directions);
            solve_small_lu_columns(&a, rhs.as_ref(), 1e-14).map_err(|_| {
                Error::Numerical(
                    "friction cone: the slip speeds' derivative is not determined (T215)".into(),
                )
            })?
        };
        let mut d_lambda = Mat::<f64>::zeros(m, ncol);
        for (i, &r) in closed.rows.iter().enumerate() {
            for j in 0..ncol {
                d_lambda[(r, j)] = dl_k[(i, j)];
            }
        }
        let mut d_rate = Mat::<f64>::zeros(2 * n, ncol);
        let mut d_speed = Mat::<f64>::zeros(n, ncol);
        for (q, &c) in contacts.iter().enumerate() {
            let e = directions[q];
            for j in 0..ncol {
                let (d0, d1) = (de[(2 * q, j)], de[(2 * q + 1, j)]);
                d_speed[(c, j)] = dk[(q, j)];
                d_rate[(c, j)] = dk[(q, j)] * e[0] + speed[c] * d0;
                d_rate[(n + c, j)] = dk[(q, j)] * e[1] + speed[c] * d1;
            }
        }
        Ok(Rates {
            lambda: ev.lambda,
            lambda_rate,
            rate,
            d_lambda,
            d_rate,
            d_speed,
            speed,
        })
    }

    /// The slipping contacts' `δa` moved along their directions so that their cone margins'
    /// variations `μ δλ_N + eᵀ δλ_T` vanish (the tangent of `project`).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn project_tangent(
        &self,
        tau: f64,
        modes: &[ConeMode],
        anchors: &[f64],
        closed: &Closed,
        d_gamma: &[Vec<f64>],
        d_anchors: &mut [Vec<f64>],
    ) -> Result<()> {
        let n = self.law.n;
        let m = 3 * n;
        let lambda = self.forces(tau, modes, anchors, closed);
        let slipping: Vec<usize> = self
            .slipping(modes)
            .into_iter()
            .filter(|&c| lambda[c] > 0.0 && lambda[n + c].hypot(lambda[2 * n + c]) > 0.0)
            .collect();
        if slipping.is_empty() {
            return Ok(());
        }
        let direction = self.directions(&slipping, &lambda);
        // the columns' force variations on the closed rows (T214)
        let ncol = d_gamma.len();
        let (dg, _) = series_columns(self.harmonics, d_gamma, m, tau);
        let v = self.closed_columns(closed, &dg, d_anchors);
        let dl = y_times(closed, v.as_ref());
        let mut margin = Mat::<f64>::zeros(slipping.len(), ncol);
        for (i, (&c, e)) in slipping.iter().zip(&direction).enumerate() {
            let nr = closed.normal_row[c].expect("a slipping contact is closed");
            let t = closed.tangent_row[c].expect("a slipping contact is closed with friction");
            for j in 0..ncol {
                margin[(i, j)] =
                    self.law.mu[c] * dl[(nr, j)] + e[0] * dl[(t, j)] + e[1] * dl[(t + 1, j)];
            }
        }
        let a = self.slip_matrix(closed, &slipping, &direction);
        let delta = solve_small_lu_columns(&a, margin.as_ref(), 1e-14).map_err(|_| {
            Error::Numerical(
                "friction cone: the slip speeds of the slipping contacts are not determined \
                 (T187)"
                    .into(),
            )
        })?;
        for j in 0..ncol {
            for (i, &c) in slipping.iter().enumerate() {
                d_anchors[j][c] -= delta[(i, j)] * direction[i][0];
                d_anchors[j][n + c] -= delta[(i, j)] * direction[i][1];
            }
        }
        Ok(())
    }
}
