//! The derivative of the cone law along directions of the free gap (docs/theory.md (T191),
//! (T214)–(T218)): the tangent-linear march through the recorded phases of a periodic state.
//! Every direction is a column of one linear system; the unit anchors of the contacts that
//! do not stick all period are further columns, from which the periodic state's own
//! sensitivity (T218) is solved.

// the small dense matrices of the law are indexed as the equations write them
#![allow(clippy::needless_range_loop)]

use super::march::{Closed, March, Watch};
use super::*;

/// The regularisation of `1/|λ_T|` in the slip direction's variation (T215), as a fraction
/// of the forces' scale: `|λ_T|/(|λ_T|² + ε²)`. It moves the tangent by about this much,
/// relatively; much smaller values make the tangent flow too stiff for the explicit
/// integrator near the apex (a contact closing straight into slip, or slipping into opening).
const APEX: f64 = 1e-8;

/// The law's rates at one instant of a phase and their variations along the columns.
struct Rates {
    /// `λ` and `λ̇` (`3n`).
    lambda: Vec<f64>,
    lambda_rate: Vec<f64>,
    /// `ȧ` (`2n`, zero but for the slipping contacts).
    rate: Vec<f64>,
    /// Per column: `δλ` (`3n`), `δȧ` (`2n`), `δκ` (`n`, zero but for the slipping contacts).
    d_lambda: Vec<Vec<f64>>,
    d_rate: Vec<Vec<f64>>,
    d_speed: Vec<Vec<f64>>,
    /// The slip speeds `κ` (`n`).
    speed: Vec<f64>,
}

/// `Σ_q b_q(τ) x̂_q` and its rate, `m` rows, coefficients harmonic-major.
fn series_at(harmonics: usize, coefficients: &[f64], m: usize, tau: f64) -> (Vec<f64>, Vec<f64>) {
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

    /// (T214), (T215) at `τ` for `modes` with displacements `anchors`, along the columns
    /// `(δγ̂_j, δa_j)`.
    fn rates(
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
        let mut d_lambda = Vec::with_capacity(ncol);
        let mut d_direction = Vec::with_capacity(ncol);
        let mut rhs = Mat::<f64>::zeros(s, ncol);
        for j in 0..ncol {
            let (dg, dg_rate) = series_at(self.harmonics, &d_gamma[j], m, tau);
            // δλ = Y (δr − δγ_K) (T214)
            let mut v = vec![0.0; m];
            for &r in &closed.rows {
                v[r] = -dg[r];
            }
            for c in 0..n {
                if closed.tangent_row[c].is_some() {
                    v[n + c] += d_anchors[j][c];
                    v[2 * n + c] += d_anchors[j][n + c];
                }
            }
            let dl = self.apply_y(closed, &v);
            // δe and u of (T215)
            let mut de = vec![[0.0; 2]; s];
            let mut u = vec![0.0; m];
            for (q, &(i, c)) in active.iter().enumerate() {
                let e = ev.direction[i];
                let norm = ev.lambda[n + c].hypot(ev.lambda[2 * n + c]);
                let dt = [dl[n + c], dl[2 * n + c]];
                let along = e[0] * dt[0] + e[1] * dt[1];
                // 1/|λ_T| regularised at the apex, where the direction is the force's
                // rate's (T193) and its variation relaxes at once
                let inverse = norm / (norm * norm + apex * apex);
                de[q] = [
                    -(dt[0] - e[0] * along) * inverse,
                    -(dt[1] - e[1] * along) * inverse,
                ];
                u[n + c] = speed[c] * de[q][0];
                u[2 * n + c] = speed[c] * de[q][1];
            }
            let mut w = vec![0.0; m];
            for &r in &closed.rows {
                w[r] = dg_rate[r];
            }
            let y_rate = self.apply_y(closed, &w);
            let y_u = self.apply_y(closed, &u);
            for (q, &(i, c)) in active.iter().enumerate() {
                let e = ev.direction[i];
                let mu = self.law.mu[c];
                rhs[(q, j)] = mu * (y_rate[c] - y_u[c])
                    + e[0] * (y_rate[n + c] - y_u[n + c])
                    + e[1] * (y_rate[2 * n + c] - y_u[2 * n + c])
                    - de[q][0] * lambda_rate[n + c]
                    - de[q][1] * lambda_rate[2 * n + c];
            }
            d_lambda.push(dl);
            d_direction.push(de);
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
        let mut d_rate = vec![vec![0.0; 2 * n]; ncol];
        let mut d_speed = vec![vec![0.0; n]; ncol];
        for j in 0..ncol {
            for (q, &c) in contacts.iter().enumerate() {
                let (e, de) = (directions[q], d_direction[j][q]);
                d_speed[j][c] = dk[(q, j)];
                d_rate[j][c] = dk[(q, j)] * e[0] + speed[c] * de[0];
                d_rate[j][n + c] = dk[(q, j)] * e[1] + speed[c] * de[1];
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
    fn project_tangent(
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
        for j in 0..d_gamma.len() {
            let (dg, _) = series_at(self.harmonics, &d_gamma[j], m, tau);
            let mut v = vec![0.0; m];
            for &r in &closed.rows {
                v[r] = -dg[r];
            }
            for c in 0..n {
                if closed.tangent_row[c].is_some() {
                    v[n + c] += d_anchors[j][c];
                    v[2 * n + c] += d_anchors[j][n + c];
                }
            }
            let dl = self.apply_y(closed, &v);
            let margin: Vec<f64> = slipping
                .iter()
                .zip(&direction)
                .map(|(&c, e)| self.law.mu[c] * dl[c] + e[0] * dl[n + c] + e[1] * dl[2 * n + c])
                .collect();
            let delta = self.solve_slip(closed, &slipping, &direction, &margin)?;
            for (i, &c) in slipping.iter().enumerate() {
                d_anchors[j][c] -= delta[i] * direction[i][0];
                d_anchors[j][n + c] -= delta[i] * direction[i][1];
            }
        }
        Ok(())
    }

    /// Integrate the slip phase `phase` with its tangents from its start to its end: the
    /// displacements at the end, and per column `δa` at the end (in `d_anchors`) and the
    /// integrals `∫ δa b_q` in the layout of `accumulate` (`2s` unused, then `2s (2H+1)`).
    fn tangent_phase(
        &mut self,
        phase: &ConePhase,
        d_gamma: &[Vec<f64>],
        d_anchors: &mut [Vec<f64>],
    ) -> Result<(Vec<f64>, Vec<Vec<f64>>)> {
        let n = self.law.n;
        let ncoef = n_coefficients(self.harmonics);
        let slipping = self.slipping(&phase.modes);
        let s = slipping.len();
        let ncol = d_gamma.len();
        let closed = self.closed(&phase.modes)?;
        let block = 2 * s * (1 + ncoef);
        let dim = 2 * s + ncol * block;
        let mut anchors = phase.anchors.clone();
        self.project_tangent(
            phase.start,
            &phase.modes,
            &anchors,
            &closed,
            d_gamma,
            d_anchors,
        )?;
        let mut x = vec![0.0; dim];
        for (i, &c) in slipping.iter().enumerate() {
            x[2 * i] = anchors[c];
            x[2 * i + 1] = anchors[n + c];
            for j in 0..ncol {
                x[2 * s + j * block + 2 * i] = d_anchors[j][c];
                x[2 * s + j * block + 2 * i + 1] = d_anchors[j][n + c];
            }
        }
        let modes = &phase.modes;
        let held = phase.anchors.clone();
        let held_tangent: Vec<Vec<f64>> = d_anchors.to_vec();
        let this = &*self;
        let unpack = |x: &[f64], a: &mut Vec<f64>, da: &mut Vec<Vec<f64>>| {
            a.copy_from_slice(&held);
            for j in 0..ncol {
                da[j].copy_from_slice(&held_tangent[j]);
            }
            for (i, &c) in slipping.iter().enumerate() {
                a[c] = x[2 * i];
                a[n + c] = x[2 * i + 1];
                for j in 0..ncol {
                    da[j][c] = x[2 * s + j * block + 2 * i];
                    da[j][n + c] = x[2 * s + j * block + 2 * i + 1];
                }
            }
        };
        let mut a_work = held.clone();
        let mut da_work = held_tangent.clone();
        let mut b = vec![0.0; ncoef];
        let mut f = |t: f64, x: &[f64], dx: &mut [f64]| -> Result<()> {
            unpack(x, &mut a_work, &mut da_work);
            let r = this.rates(t, modes, &a_work, &closed, d_gamma, &da_work)?;
            basis_into(this.harmonics, t, &mut b);
            for (i, &c) in slipping.iter().enumerate() {
                dx[2 * i] = r.rate[c];
                dx[2 * i + 1] = r.rate[n + c];
            }
            for j in 0..ncol {
                let o = 2 * s + j * block;
                for (i, &c) in slipping.iter().enumerate() {
                    dx[o + 2 * i] = r.d_rate[j][c];
                    dx[o + 2 * i + 1] = r.d_rate[j][n + c];
                }
                for i in 0..2 * s {
                    let value = x[o + i];
                    for q in 0..ncoef {
                        dx[o + 2 * s + i * ncoef + q] = value * b[q];
                    }
                }
            }
            Ok(())
        };
        let tolerance = Tolerance {
            relative: FLOW_TOLERANCE,
            absolute: FLOW_TOLERANCE * self.gamma_scale.max(f64::MIN_POSITIVE),
        };
        let cell = 2.0 * PI / self.cells as f64;
        let mut ode = Dop853::new(dim);
        let mut next = vec![0.0; dim];
        let (mut t, mut h) = (phase.start, cell);
        while t < phase.end {
            let length = h.min(phase.end - t).min(cell);
            let error = ode.step(&mut f, t, &x, length, &mut next, tolerance)?;
            if error <= 1.0 {
                t = if length == phase.end - t {
                    phase.end
                } else {
                    t + length
                };
                x.copy_from_slice(&next);
                // back on the cone as in the law's march, the tangents with it
                let mut a = held.clone();
                let mut da = held_tangent.clone();
                unpack(&x, &mut a, &mut da);
                this.project(t, modes, &mut a, &closed)?;
                this.project_tangent(t, modes, &a, &closed, d_gamma, &mut da)?;
                for (i, &c) in slipping.iter().enumerate() {
                    x[2 * i] = a[c];
                    x[2 * i + 1] = a[n + c];
                    for j in 0..ncol {
                        x[2 * s + j * block + 2 * i] = da[j][c];
                        x[2 * s + j * block + 2 * i + 1] = da[j][n + c];
                    }
                }
            }
            h = Dop853::next_step(length, error);
            if h <= 1e-15 {
                return Err(Error::Numerical(format!(
                    "friction cone: the tangent flow's step fell below round-off at τ = {t} \
                     (phase {} to {}, modes {:?})",
                    phase.start, phase.end, phase.modes
                )));
            }
        }
        let mut da = held_tangent.clone();
        unpack(&x, &mut anchors, &mut da);
        let mut integrals = vec![vec![0.0; 2 * s * (1 + ncoef)]; ncol];
        for j in 0..ncol {
            integrals[j][2 * s..]
                .copy_from_slice(&x[2 * s + j * block + 2 * s..2 * s + (j + 1) * block]);
        }
        d_anchors.clone_from_slice(&da);
        Ok((anchors, integrals))
    }
}

impl ConeContacts {
    /// `δλ̂` of the periodic state `periodic` along each of `directions` (`δγ̂`, harmonic-major,
    /// `3n` per coefficient like the free gap) (T191), (T214)–(T218); `cells` bounds the
    /// integration steps as in [`ConeContacts::periodic`].
    pub fn tangent(
        &self,
        periodic: &ConePeriodic,
        directions: &[Vec<f64>],
        cells: usize,
    ) -> Result<Vec<Vec<f64>>> {
        let n = self.n;
        let m = 3 * n;
        let harmonics = periodic.harmonics;
        let ncoef = n_coefficients(harmonics);
        if let Some(d) = directions.iter().find(|d| d.len() != m * ncoef) {
            return Err(Error::Numerical(format!(
                "friction cone: a direction of {} coefficients, {} expected",
                d.len(),
                m * ncoef
            )));
        }
        let phases = &periodic.phases;
        let Some(first) = phases.first() else {
            return Err(Error::Numerical("friction cone: no phases".into()));
        };
        let mut march = March::new(self, harmonics, &periodic.gamma, cells.max(1));
        let scale = march.gamma_scale.max(f64::MIN_POSITIVE);
        // the anchors at τ = 0: stuck all period (Z) and the rest (R) (T218)
        let with_friction: Vec<usize> = (0..n)
            .filter(|&c| first.modes[c] != ConeMode::Open && self.mu[c] > 0.0)
            .collect();
        let (z, r): (Vec<usize>, Vec<usize>) = with_friction
            .iter()
            .partition(|&&c| phases.iter().all(|p| p.modes[c] == ConeMode::Stick));
        let r_rows: Vec<usize> = r.iter().flat_map(|&c| [c, n + c]).collect();
        // the columns, scaled to the free gap's size (the flow's tolerance is absolute)
        let ndir = directions.len();
        let mut d_gamma: Vec<Vec<f64>> = Vec::with_capacity(ndir + r_rows.len());
        let mut d_anchors: Vec<Vec<f64>> = Vec::with_capacity(ndir + r_rows.len());
        let mut factors = Vec::with_capacity(ndir + r_rows.len());
        let z_tangent =
            self.initial_tangent(harmonics, &first.modes, &periodic.gamma, &z, directions)?;
        for (j, d) in directions.iter().enumerate() {
            let size = (0..ncoef)
                .map(|q| {
                    d[q * m..(q + 1) * m]
                        .iter()
                        .fold(0.0f64, |s, v| s.max(v.abs()))
                })
                .sum::<f64>();
            let factor = if size > 0.0 { scale / size } else { 1.0 };
            d_gamma.push(d.iter().map(|v| v * factor).collect());
            d_anchors.push(z_tangent[j].iter().map(|v| v * factor).collect());
            factors.push(factor);
        }
        for &row in &r_rows {
            d_gamma.push(vec![0.0; m * ncoef]);
            let mut a = vec![0.0; 2 * n];
            a[row] = scale;
            d_anchors.push(a);
            factors.push(scale);
        }
        let ncol = d_gamma.len();
        let mut d_forces = vec![vec![0.0; m * ncoef]; ncol];
        for (p, phase) in phases.iter().enumerate() {
            let closed = march.closed(&phase.modes)?;
            let slipping = march.slipping(&phase.modes);
            let start_tangent = d_anchors.clone();
            let (end_anchors, integrals) = if slipping.is_empty() {
                (
                    phase.anchors.clone(),
                    vec![vec![0.0; 2 * slipping.len() * (1 + ncoef)]; ncol],
                )
            } else {
                march.tangent_phase(phase, &d_gamma, &mut d_anchors)?
            };
            for j in 0..ncol {
                let column = March::new(self, harmonics, &d_gamma[j], march.cells);
                column.accumulate(
                    phase.start,
                    phase.end,
                    &phase.modes,
                    &start_tangent[j],
                    &slipping,
                    &integrals[j],
                    &closed,
                    &mut d_forces[j],
                );
            }
            let Some(next) = phases.get(p + 1) else {
                break;
            };
            march.switch_tangent(
                phase,
                next,
                &end_anchors,
                &closed,
                &d_gamma,
                &mut d_anchors,
                &mut d_forces,
            )?;
        }
        // the periodic state's anchors (T218)
        let nr = r_rows.len();
        let mut result: Vec<Vec<f64>> = Vec::with_capacity(ndir);
        if nr > 0 {
            let mut lhs = vec![0.0; nr * nr];
            for (i, &row) in r_rows.iter().enumerate() {
                for (q, _) in r_rows.iter().enumerate() {
                    lhs[i * nr + q] = -d_anchors[ndir + q][row] / scale;
                }
                lhs[i * nr + i] += 1.0;
            }
            let mut rhs = Mat::<f64>::zeros(nr, ndir);
            for j in 0..ndir {
                for (i, &row) in r_rows.iter().enumerate() {
                    rhs[(i, j)] = d_anchors[j][row];
                }
            }
            let x = solve_small_lu_columns(&lhs, rhs.as_ref(), 1e-13).map_err(|_| {
                Error::Numerical(
                    "friction cone: the periodic state's anchors are not determined by the \
                     free gap (T218)"
                        .into(),
                )
            })?;
            for j in 0..ndir {
                let mut out = d_forces[j].clone();
                for q in 0..nr {
                    let weight = x[(q, j)] / scale;
                    for (o, v) in out.iter_mut().zip(&d_forces[ndir + q]) {
                        *o += weight * v;
                    }
                }
                result.push(out);
            }
        } else {
            result = d_forces[..ndir].to_vec();
        }
        for (j, out) in result.iter_mut().enumerate() {
            for v in out.iter_mut() {
                *v /= factors[j];
            }
        }
        Ok(result)
    }

    /// `δa₀` of the contacts `z` (stuck all period) along `directions`: the tangential
    /// displacements of the frictionless state at `τ = 0` (T218), zero for the others.
    fn initial_tangent(
        &self,
        harmonics: usize,
        modes0: &[ConeMode],
        gamma: &[f64],
        z: &[usize],
        directions: &[Vec<f64>],
    ) -> Result<Vec<Vec<f64>>> {
        let n = self.n;
        let m = 3 * n;
        if z.is_empty() {
            return Ok(vec![vec![0.0; 2 * n]; directions.len()]);
        }
        let (g0, _) = series_at(harmonics, gamma, m, 0.0);
        let dnn: Vec<f64> = (0..n * n).map(|k| self.d(k / n, k % n)).collect();
        let solution = LcpSolver::new(LcpMatrix::new(n, dnn))
            .solve(&g0[..n])
            .map_err(|e| Error::Numerical(format!("friction cone: initial state: {e}")))?;
        let _ = modes0;
        let active: Vec<usize> = (0..n).filter(|&c| solution.active[c]).collect();
        let na = active.len();
        let daa: Vec<f64> = (0..na * na)
            .map(|e| self.d(active[e / na], active[e % na]))
            .collect();
        let mut rhs = Mat::<f64>::zeros(na, directions.len());
        let mut dg0 = Vec::with_capacity(directions.len());
        for (j, d) in directions.iter().enumerate() {
            let (g, _) = series_at(harmonics, d, m, 0.0);
            for (i, &c) in active.iter().enumerate() {
                rhs[(i, j)] = -g[c];
            }
            dg0.push(g);
        }
        let dl = solve_small_lu_columns(&daa, rhs.as_ref(), 1e-13).map_err(|_| {
            Error::Numerical(
                "friction cone: the closed contacts' Delassus block is singular".into(),
            )
        })?;
        Ok((0..directions.len())
            .map(|j| {
                let mut a = vec![0.0; 2 * n];
                for &c in z {
                    for t in 0..2 {
                        let row = (1 + t) * n + c;
                        a[t * n + c] = dg0[j][row]
                            + (0..na)
                                .map(|i| self.d(row, active[i]) * dl[(i, j)])
                                .sum::<f64>();
                    }
                }
                a
            })
            .collect())
    }
}

impl March<'_> {
    /// Across the switch that ends `phase` and starts `next` (T216), (T217): `δa` continued
    /// with the saltation of the rates, the coefficients' boundary term added.
    #[allow(clippy::too_many_arguments)]
    fn switch_tangent(
        &mut self,
        phase: &ConePhase,
        next: &ConePhase,
        end_anchors: &[f64],
        closed: &Closed,
        d_gamma: &[Vec<f64>],
        d_anchors: &mut [Vec<f64>],
        d_forces: &mut [Vec<f64>],
    ) -> Result<()> {
        let n = self.law.n;
        let m = 3 * n;
        let ncoef = n_coefficients(self.harmonics);
        let tau = phase.end;
        let before = self.rates(tau, &phase.modes, end_anchors, closed, d_gamma, d_anchors)?;
        let closed_next = self.closed(&next.modes)?;
        let after = self.rates(tau, &next.modes, &next.anchors, &closed_next, &[], &[])?;
        let (gamma, gamma_rate) = series_at(self.harmonics, self.gamma, m, tau);
        let _ = gamma;
        // the indicator that ended the phase and its rate
        let Some((c, watch)) = phase.event else {
            return Ok(());
        };
        let coupling = |row: usize, v: &[f64]| -> f64 {
            closed.rows.iter().map(|&r| self.law.d(row, r) * v[r]).sum()
        };
        let unit = {
            let (t1, t2) = (before.lambda[n + c], before.lambda[2 * n + c]);
            let norm = t1.hypot(t2);
            if norm > 0.0 {
                [t1 / norm, t2 / norm]
            } else {
                [0.0, 0.0]
            }
        };
        let mu = self.law.mu[c];
        let rate_of_h = match watch {
            Watch::Gap => gamma_rate[c] + coupling(c, &before.lambda_rate),
            Watch::Normal => before.lambda_rate[c],
            Watch::Cone => {
                mu * before.lambda_rate[c]
                    - unit[0] * before.lambda_rate[n + c]
                    - unit[1] * before.lambda_rate[2 * n + c]
            }
            Watch::Speed => {
                // along the flow by a central difference in time
                let eps = 1e-6;
                let speed_at = |t: f64, sign: f64| -> Result<f64> {
                    let a: Vec<f64> = end_anchors
                        .iter()
                        .zip(&before.rate)
                        .map(|(a, r)| a + sign * eps * r)
                        .collect();
                    let r = self.rates(t, &phase.modes, &a, closed, &[], &[])?;
                    Ok(r.speed[c])
                };
                (speed_at(tau + eps, 1.0)? - speed_at(tau - eps, -1.0)?) / (2.0 * eps)
            }
        };
        let mut b = vec![0.0; ncoef];
        basis_into(self.harmonics, tau, &mut b);
        let weight = |q: usize| if q == 0 { 1.0 / (2.0 * PI) } else { 1.0 / PI };
        for j in 0..d_gamma.len() {
            let (dg, _) = series_at(self.harmonics, &d_gamma[j], m, tau);
            let dl = &before.d_lambda[j];
            let dh = match watch {
                Watch::Gap => dg[c] + coupling(c, dl),
                Watch::Normal => dl[c],
                Watch::Cone => mu * dl[c] - unit[0] * dl[n + c] - unit[1] * dl[2 * n + c],
                Watch::Speed => before.d_speed[j][c],
            };
            let d_tau = if rate_of_h != 0.0 {
                -dh / rate_of_h
            } else {
                0.0
            };
            // the coefficients' boundary term
            for q in 0..ncoef {
                for r in 0..m {
                    d_forces[j][q * m + r] +=
                        weight(q) * (before.lambda[r] - after.lambda[r]) * b[q] * d_tau;
                }
            }
            // the displacements (T217)
            let mut da = vec![0.0; 2 * n];
            for d in 0..n {
                if closed_next.tangent_row[d].is_none() {
                    continue;
                }
                for t in 0..2 {
                    let i = t * n + d;
                    da[i] = if closed.tangent_row[d].is_some() {
                        d_anchors[j][i] + (before.rate[i] - after.rate[i]) * d_tau
                    } else {
                        let row = (1 + t) * n + d;
                        let dy = dg[row] + coupling(row, dl);
                        let y_rate = gamma_rate[row] + coupling(row, &before.lambda_rate);
                        dy + (y_rate - after.rate[i]) * d_tau
                    };
                }
            }
            d_anchors[j] = da;
        }
        Ok(())
    }
}
