//! The derivative of the cone law along directions of the free gap (docs/theory.md (T191),
//! (T214)–(T218)): the tangent-linear march through the recorded phases of a periodic state.
//! Every direction is a column of one linear system; the unit anchors of the contacts that
//! do not stick all period are further columns, from which the periodic state's own
//! sensitivity (T218) is solved.

// the small dense matrices of the law are indexed as the equations write them
#![allow(clippy::needless_range_loop)]

use super::march::March;
use super::mixing::Anderson;
use super::*;

mod flow;
mod switch;

use flow::series_at;

/// How the periodic anchors' system (T218) is solved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(in super::super) enum Anchors {
    /// The cheaper of the two below by the count of columns marched (with the slipping
    /// contacts' unit columns every march carries).
    Cheaper,
    /// `2|R|` unit anchors as further columns of one march, then `(I − P_RR)` factored.
    #[cfg_attr(not(test), allow(dead_code))] // chosen by the tests, to compare
    UnitColumns,
    /// `δa₀,R ← δa_end,R` repeated with the directions' columns alone, until it settles.
    #[cfg_attr(not(test), allow(dead_code))]
    Iteration,
}

/// Where the iteration of the periodic anchors' derivative has settled, relative to the
/// scaled columns (the free gap's size).
const ITERATION_TOLERANCE: f64 = 1e-11;

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
        self.tangent_by(periodic, directions, cells, Anchors::Cheaper)
    }

    /// [`ConeContacts::tangent`] with the periodic anchors' system (T218) solved as `how`
    /// says.
    pub(in super::super) fn tangent_by(
        &self,
        periodic: &ConePeriodic,
        directions: &[Vec<f64>],
        cells: usize,
        how: Anchors,
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
        let z_tangent = self.initial_tangent(harmonics, &periodic.gamma, &z, directions)?;
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
        // a march costs about its columns plus the `2|S|` unit columns of the slipping
        // contacts' rates it always carries (T222), `w` on average over the period: `2|R|`
        // unit anchors once, or the directions once per pass of the iteration, about as many
        // passes as the law's (both mixed, (T224))
        let w = phases
            .iter()
            .map(|p| (p.end - p.start) * 2.0 * march.slipping(&p.modes).len() as f64)
            .sum::<f64>()
            / (2.0 * PI);
        let (columns, unit_cost) = (ndir as f64 + w, (ndir + r_rows.len()) as f64 + w);
        let iterate = match how {
            Anchors::Cheaper => periodic.passes as f64 * columns < unit_cost,
            Anchors::UnitColumns => false,
            Anchors::Iteration => true,
        };
        if iterate && !r_rows.is_empty() {
            // the iteration contracts as the march does; where the contraction measured on
            // its first passes predicts more columns marched than the unit anchors cost, the
            // unit anchors are used after all
            let mut start = d_anchors.clone();
            let mut previous = f64::INFINITY;
            // each column's iteration is affine in its anchors: mixed as the law's (T224)
            let mut mixing: Vec<Anderson> =
                (0..ndir).map(|_| Anderson::new(MIXING_MEMORY)).collect();
            for pass in 0..=MAX_PASSES {
                let mut end = start.clone();
                let forces = self.march_columns(&mut march, phases, &d_gamma, &mut end)?;
                let change = (0..ndir)
                    .flat_map(|j| r_rows.iter().map(move |&row| (j, row)))
                    .fold(0.0f64, |c, (j, row)| {
                        c.max((end[j][row] - start[j][row]).abs())
                    });
                let tolerance = ITERATION_TOLERANCE * scale;
                if change <= tolerance {
                    return Ok(forces
                        .into_iter()
                        .zip(&factors)
                        .map(|(f, factor)| f.into_iter().map(|v| v / factor).collect())
                        .collect());
                }
                let ratio = change / previous;
                let remaining = if ratio < 1.0 {
                    (tolerance / change).ln() / ratio.ln()
                } else {
                    f64::INFINITY
                };
                if how == Anchors::Cheaper && pass >= 1 && remaining * columns > unit_cost {
                    break;
                }
                previous = change;
                for j in 0..ndir {
                    let x: Vec<f64> = r_rows.iter().map(|&row| start[j][row]).collect();
                    let g: Vec<f64> = r_rows.iter().map(|&row| end[j][row]).collect();
                    for (&row, v) in r_rows.iter().zip(mixing[j].next(&x, &g)) {
                        start[j][row] = v;
                    }
                }
            }
            if how == Anchors::Iteration {
                return Err(Error::Numerical(format!(
                    "friction cone: the periodic anchors' derivative did not settle in \
                     {MAX_PASSES} periods (T218)"
                )));
            }
        }
        for &row in &r_rows {
            d_gamma.push(vec![0.0; m * ncoef]);
            let mut a = vec![0.0; 2 * n];
            a[row] = scale;
            d_anchors.push(a);
            factors.push(scale);
        }
        let d_forces = self.march_columns(&mut march, phases, &d_gamma, &mut d_anchors)?;
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

    /// One tangent march of the recorded phases for the columns `(δγ̂_j, δa_j)` (`d_anchors`
    /// at `τ = 0` on entry, at `2π` on return): `δλ̂` of each column (T214)–(T217).
    fn march_columns(
        &self,
        march: &mut March,
        phases: &[ConePhase],
        d_gamma: &[Vec<f64>],
        d_anchors: &mut [Vec<f64>],
    ) -> Result<Vec<Vec<f64>>> {
        let harmonics = march.harmonics;
        let ncol = d_gamma.len();
        let (m, ncoef) = (3 * self.n, n_coefficients(march.harmonics));
        let mut d_forces = vec![vec![0.0; m * ncoef]; ncol];
        for (p, phase) in phases.iter().enumerate() {
            let closed = march.closed(&phase.modes)?;
            let slipping = march.slipping(&phase.modes);
            let start_tangent = d_anchors.to_vec();
            let (end_anchors, integrals) = if slipping.is_empty() {
                (
                    phase.anchors.clone(),
                    vec![vec![0.0; 2 * slipping.len() * (1 + ncoef)]; ncol],
                )
            } else {
                march.tangent_phase(phase, d_gamma, d_anchors)?
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
                d_gamma,
                d_anchors,
                &mut d_forces,
            )?;
        }
        Ok(d_forces)
    }

    /// `δa₀` of the contacts `z` (stuck all period) along `directions`: the tangential
    /// displacements of the frictionless state at `τ = 0` (T218), zero for the others.
    fn initial_tangent(
        &self,
        harmonics: usize,
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
