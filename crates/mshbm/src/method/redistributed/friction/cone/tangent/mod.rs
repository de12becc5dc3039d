//! The derivative of the cone law along directions of the free gap (docs/theory.md (T191),
//! (T214)–(T218)): the tangent-linear march through the recorded phases of a periodic state.
//! Every direction is a column of one linear system; the unit anchors of the contacts that
//! do not stick all period are further columns, from which the periodic state's own
//! sensitivity (T218) is solved.

// the small dense matrices of the law are indexed as the equations write them
#![allow(clippy::needless_range_loop)]

use super::march::March;
use super::*;

mod flow;
mod switch;

use flow::series_at;

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
