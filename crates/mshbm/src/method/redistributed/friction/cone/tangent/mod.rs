//! The derivative of the cone law along directions of the free gap (docs/theory.md (T191),
//! (T214)–(T218)): the tangent-linear march through the recorded phases of a periodic state.
//! Every direction is a column of one linear system; the unit anchors of the contacts that
//! do not stick all period are the columns of a march of their own, from which the periodic
//! state's own sensitivity (T218) is solved once for any number of directions (T225).

// the small dense matrices of the law are indexed as the equations write them
#![allow(clippy::needless_range_loop)]

use super::march::March;
use super::mixing::Anderson;
use super::*;

mod collocation;
mod flow;
mod switch;

use collocation::{PathMode, PathStep};
use flow::series_at;

/// How the periodic anchors' system (T218) is solved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(in super::super) enum Anchors {
    /// The cheaper of the two below by the count of columns marched (with the slipping
    /// contacts' unit columns every march carries).
    Cheaper,
    /// `2|R|` unit anchors in a march of their own, then `(I − P_RR)` factored (T225).
    #[cfg_attr(not(test), allow(dead_code))] // chosen by the tests, to compare
    UnitColumns,
    /// `δa₀,R ← δa_end,R` repeated with the directions' columns alone, until it settles.
    #[cfg_attr(not(test), allow(dead_code))]
    Iteration,
}

/// The numbers the recorded slip paths of one periodic state may hold (T225): 128 MiB.
const PATH_RECORD_NUMBERS: usize = 1 << 24;

/// Columns scaled to the free gap's size: `δγ̂`, the `δa` they start from, and their factors.
type ScaledColumns = (Vec<Vec<f64>>, Vec<Vec<f64>>, Vec<f64>);

/// What a tangent march does with the slip phases' primal paths (T225), by phase.
enum Paths<'a> {
    Free,
    Record(&'a mut Vec<Option<Vec<PathStep>>>),
    Replay(&'a [Option<Vec<PathStep>>]),
}

/// Where the iteration of the periodic anchors' derivative has settled, relative to the
/// scaled columns (the free gap's size).
const ITERATION_TOLERANCE: f64 = 1e-11;

/// The periodic anchors' response of one periodic state (T218), (T225): the contacts stuck
/// all period and `G = ∂λ̂/∂a₀,R (I − P_RR)⁻¹`, marched and factored once for any number of
/// products `S v` ([`ConeContacts::tangent_with`]).
#[derive(Clone, Debug)]
pub struct AnchorResponse {
    /// The contacts closed with friction at `τ = 0` and stuck all period (`Z`).
    z: Vec<usize>,
    /// The rows of the other such contacts' anchors (`R`): `c` and `n + c`.
    r_rows: Vec<usize>,
    /// `G`, `3n(2H+1) × 2|R|`.
    gain: Mat<f64>,
    /// The slip phases' primal paths, by phase, for the products' marches to replay (none
    /// past [`PATH_RECORD_NUMBERS`]).
    paths: Vec<Option<Vec<PathStep>>>,
}

impl AnchorResponse {
    /// `S v = δλ̂⁰ + G δa_end,R` of each scaled column (T225), unscaled by its factor.
    fn combine(
        &self,
        d_forces: Vec<Vec<f64>>,
        d_anchors: &[Vec<f64>],
        factors: &[f64],
    ) -> Vec<Vec<f64>> {
        d_forces
            .into_iter()
            .zip(d_anchors.iter().zip(factors))
            .map(|(mut out, (anchors, factor))| {
                for (q, &row) in self.r_rows.iter().enumerate() {
                    let weight = anchors[row];
                    if weight != 0.0 {
                        for (o, g) in out.iter_mut().zip(self.gain.col(q).iter()) {
                            *o += weight * g;
                        }
                    }
                }
                out.into_iter().map(|v| v / factor).collect()
            })
            .collect()
    }

    /// The anchors of the contacts that do not stick all period (`2|R|`), whose periodic
    /// values the response solves for (T218).
    pub fn anchors(&self) -> usize {
        self.r_rows.len()
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
        self.tangent_by(periodic, directions, cells, Anchors::Cheaper)
    }

    /// The anchors' response of `periodic` (T225): one march of the `2|R|` unit anchors.
    pub fn anchor_response(&self, periodic: &ConePeriodic, cells: usize) -> Result<AnchorResponse> {
        let mut march = March::new(self, periodic.harmonics, &periodic.gamma, cells.max(1));
        let (z, r_rows) = self.anchor_split(&periodic.phases)?;
        self.response_in(&mut march, periodic, z, r_rows)
    }

    /// [`ConeContacts::tangent`] with the anchors' response `response` of `periodic` (T225):
    /// one march of the directions alone.
    pub fn tangent_with(
        &self,
        periodic: &ConePeriodic,
        response: &AnchorResponse,
        directions: &[Vec<f64>],
        cells: usize,
    ) -> Result<Vec<Vec<f64>>> {
        self.check_directions(periodic, directions)?;
        let mut march = March::new(self, periodic.harmonics, &periodic.gamma, cells.max(1));
        self.apply_response(&mut march, periodic, response, directions)
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
        self.check_directions(periodic, directions)?;
        let phases = &periodic.phases;
        let mut march = March::new(self, periodic.harmonics, &periodic.gamma, cells.max(1));
        let (z, r_rows) = self.anchor_split(phases)?;
        // a march costs about its columns plus the `2|S|` unit columns of the slipping
        // contacts' rates it always carries (T222), `w` on average over the period: the
        // directions and the `2|R|` unit anchors in one march (T225), or the directions once
        // per pass of the iteration, about as many passes as the law's (both mixed, (T224))
        let w = phases
            .iter()
            .map(|p| (p.end - p.start) * 2.0 * march.slipping(&p.modes).len() as f64)
            .sum::<f64>()
            / (2.0 * PI);
        let ndir = directions.len() as f64;
        let (columns, unit_cost) = (ndir + w, ndir + r_rows.len() as f64 + w);
        let iterate = match how {
            Anchors::Cheaper => periodic.passes as f64 * columns < unit_cost,
            Anchors::UnitColumns => false,
            Anchors::Iteration => true,
        };
        if iterate && !r_rows.is_empty() {
            let limit = (how == Anchors::Cheaper).then_some(unit_cost / columns);
            if let Some(result) =
                self.iterate_anchors(&mut march, periodic, &z, &r_rows, directions, limit)?
            {
                return Ok(result);
            }
        }
        Ok(self
            .march_with_units(&mut march, periodic, z, r_rows, directions, false)?
            .0)
    }

    /// [`ConeContacts::tangent`] by the directions and the unit anchors in one march, and the
    /// anchors' response (T225) that it gives for later products.
    pub fn tangent_and_response(
        &self,
        periodic: &ConePeriodic,
        directions: &[Vec<f64>],
        cells: usize,
    ) -> Result<(Vec<Vec<f64>>, AnchorResponse)> {
        self.check_directions(periodic, directions)?;
        let mut march = March::new(self, periodic.harmonics, &periodic.gamma, cells.max(1));
        let (z, r_rows) = self.anchor_split(&periodic.phases)?;
        self.march_with_units(&mut march, periodic, z, r_rows, directions, true)
    }

    fn check_directions(&self, periodic: &ConePeriodic, directions: &[Vec<f64>]) -> Result<()> {
        let size = 3 * self.n * n_coefficients(periodic.harmonics);
        if let Some(d) = directions.iter().find(|d| d.len() != size) {
            return Err(Error::Numerical(format!(
                "friction cone: a direction of {} coefficients, {size} expected",
                d.len()
            )));
        }
        if periodic.phases.is_empty() {
            return Err(Error::Numerical("friction cone: no phases".into()));
        }
        Ok(())
    }

    /// The contacts closed with friction at `τ = 0` split (T218): stuck all period (`Z`),
    /// and the rows of the others' anchors (`R`).
    fn anchor_split(&self, phases: &[ConePhase]) -> Result<(Vec<usize>, Vec<usize>)> {
        let n = self.n;
        let first = phases
            .first()
            .ok_or_else(|| Error::Numerical("friction cone: no phases".into()))?;
        let (z, r): (Vec<usize>, Vec<usize>) = (0..n)
            .filter(|&c| first.modes[c] != ConeMode::Open && self.mu[c] > 0.0)
            .partition(|&c| phases.iter().all(|p| p.modes[c] == ConeMode::Stick));
        Ok((z, r.iter().flat_map(|&c| [c, n + c]).collect()))
    }

    /// The directions scaled to the free gap's size (the flow's tolerance is absolute), the
    /// anchors they start from (those of `z` by (T218), zero for the others) and the factors.
    fn scaled_columns(
        &self,
        periodic: &ConePeriodic,
        z: &[usize],
        directions: &[Vec<f64>],
        scale: f64,
    ) -> Result<ScaledColumns> {
        let m = 3 * self.n;
        let ncoef = n_coefficients(periodic.harmonics);
        let z_tangent = self.initial_tangent(periodic.harmonics, &periodic.gamma, z, directions)?;
        let mut d_gamma = Vec::with_capacity(directions.len());
        let mut d_anchors = Vec::with_capacity(directions.len());
        let mut factors = Vec::with_capacity(directions.len());
        for (d, a) in directions.iter().zip(z_tangent) {
            let size = (0..ncoef)
                .map(|q| {
                    d[q * m..(q + 1) * m]
                        .iter()
                        .fold(0.0f64, |s, v| s.max(v.abs()))
                })
                .sum::<f64>();
            let factor = if size > 0.0 { scale / size } else { 1.0 };
            d_gamma.push(d.iter().map(|v| v * factor).collect());
            d_anchors.push(a.into_iter().map(|v| v * factor).collect());
            factors.push(factor);
        }
        Ok((d_gamma, d_anchors, factors))
    }

    /// (T225): the march of the `2|R|` unit anchors (scaled to the free gap's size), then
    /// `G = ∂λ̂/∂a₀,R (I − P_RR)⁻¹`.
    fn response_in(
        &self,
        march: &mut March,
        periodic: &ConePeriodic,
        z: Vec<usize>,
        r_rows: Vec<usize>,
    ) -> Result<AnchorResponse> {
        Ok(self
            .march_with_units(march, periodic, z, r_rows, &[], true)?
            .1)
    }

    /// `δλ̂` along `directions` and the anchors' response (T225) from one march of the
    /// directions and the `2|R|` unit anchors together (a march's fixed part, the primal path
    /// and the rates' unit columns (T222), is paid once); the slip paths recorded for later
    /// products where `record`.
    fn march_with_units(
        &self,
        march: &mut March,
        periodic: &ConePeriodic,
        z: Vec<usize>,
        r_rows: Vec<usize>,
        directions: &[Vec<f64>],
        record: bool,
    ) -> Result<(Vec<Vec<f64>>, AnchorResponse)> {
        let n = self.n;
        let size = 3 * n * n_coefficients(march.harmonics);
        let nr = r_rows.len();
        let ndir = directions.len();
        let scale = march.gamma_scale.max(f64::MIN_POSITIVE);
        let (mut d_gamma, mut d_anchors, factors) =
            self.scaled_columns(periodic, &z, directions, scale)?;
        for &row in &r_rows {
            d_gamma.push(vec![0.0; size]);
            let mut a = vec![0.0; 2 * n];
            a[row] = scale;
            d_anchors.push(a);
        }
        let mut paths = vec![None; periodic.phases.len()];
        let mut d_forces = self.march_columns(
            march,
            &periodic.phases,
            &d_gamma,
            &mut d_anchors,
            if record {
                Paths::Record(&mut paths)
            } else {
                Paths::Free
            },
        )?;
        let gain = if nr == 0 {
            Mat::zeros(size, 0)
        } else {
            let mut lhs = vec![0.0; nr * nr];
            for (i, &row) in r_rows.iter().enumerate() {
                for q in 0..nr {
                    lhs[i * nr + q] = -d_anchors[ndir + q][row] / scale;
                }
                lhs[i * nr + i] += 1.0;
            }
            let inverse =
                solve_small_lu_columns(&lhs, Mat::<f64>::identity(nr, nr).as_ref(), 1e-13)
                    .map_err(|_| {
                        Error::Numerical(
                            "friction cone: the periodic state's anchors are not determined \
                             by the free gap (T218)"
                                .into(),
                        )
                    })?;
            let unit = Mat::<f64>::from_fn(size, nr, |i, q| d_forces[ndir + q][i] / scale);
            crate::dense::sequential_product(unit.as_ref(), inverse.as_ref())
        };
        let response = AnchorResponse {
            z,
            r_rows,
            gain,
            paths,
        };
        d_forces.truncate(ndir);
        d_anchors.truncate(ndir);
        let result = response.combine(d_forces, &d_anchors, &factors);
        Ok((result, response))
    }

    /// `δλ̂` along `directions` by one march of them and the anchors' response (T225).
    fn apply_response(
        &self,
        march: &mut March,
        periodic: &ConePeriodic,
        response: &AnchorResponse,
        directions: &[Vec<f64>],
    ) -> Result<Vec<Vec<f64>>> {
        let scale = march.gamma_scale.max(f64::MIN_POSITIVE);
        let (d_gamma, mut d_anchors, factors) =
            self.scaled_columns(periodic, &response.z, directions, scale)?;
        let d_forces = self.march_columns(
            march,
            &periodic.phases,
            &d_gamma,
            &mut d_anchors,
            Paths::Replay(&response.paths),
        )?;
        Ok(response.combine(d_forces, &d_anchors, &factors))
    }

    /// (T218) by iterating `δa₀,R ← δa_end,R` with the directions alone, mixed as (T224);
    /// `None` where the contraction measured on its first passes predicts more than `limit`
    /// passes (the unit anchors are then cheaper).
    fn iterate_anchors(
        &self,
        march: &mut March,
        periodic: &ConePeriodic,
        z: &[usize],
        r_rows: &[usize],
        directions: &[Vec<f64>],
        limit: Option<f64>,
    ) -> Result<Option<Vec<Vec<f64>>>> {
        let ndir = directions.len();
        let scale = march.gamma_scale.max(f64::MIN_POSITIVE);
        let (d_gamma, mut start, factors) = self.scaled_columns(periodic, z, directions, scale)?;
        let mut previous = f64::INFINITY;
        // each column's iteration is affine in its anchors: mixed as the law's (T224)
        let mut mixing: Vec<Anderson> = (0..ndir).map(|_| Anderson::new(MIXING_MEMORY)).collect();
        for pass in 0..=MAX_PASSES {
            let mut end = start.clone();
            let forces =
                self.march_columns(march, &periodic.phases, &d_gamma, &mut end, Paths::Free)?;
            let change = (0..ndir)
                .flat_map(|j| r_rows.iter().map(move |&row| (j, row)))
                .fold(0.0f64, |c, (j, row)| {
                    c.max((end[j][row] - start[j][row]).abs())
                });
            let tolerance = ITERATION_TOLERANCE * scale;
            if change <= tolerance {
                return Ok(Some(
                    forces
                        .into_iter()
                        .zip(&factors)
                        .map(|(f, factor)| f.into_iter().map(|v| v / factor).collect())
                        .collect(),
                ));
            }
            let ratio = change / previous;
            let remaining = if ratio < 1.0 {
                (tolerance / change).ln() / ratio.ln()
            } else {
                f64::INFINITY
            };
            if limit.is_some_and(|l| pass >= 1 && remaining > l) {
                return Ok(None);
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
        if limit.is_some() {
            return Ok(None);
        }
        Err(Error::Numerical(format!(
            "friction cone: the periodic anchors' derivative did not settle in {MAX_PASSES} \
             periods (T218)"
        )))
    }

    /// One tangent march of the recorded phases for the columns `(δγ̂_j, δa_j)` (`d_anchors`
    /// at `τ = 0` on entry, at `2π` on return): `δλ̂` of each column (T214)–(T217).
    fn march_columns(
        &self,
        march: &mut March,
        phases: &[ConePhase],
        d_gamma: &[Vec<f64>],
        d_anchors: &mut [Vec<f64>],
        mut paths: Paths<'_>,
    ) -> Result<Vec<Vec<f64>>> {
        let harmonics = march.harmonics;
        let mut recorded = 0;
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
                let mode = match &mut paths {
                    Paths::Record(all) if recorded < PATH_RECORD_NUMBERS => {
                        PathMode::Record(all[p].insert(Vec::new()))
                    }
                    Paths::Replay(all) => match all.get(p).and_then(Option::as_ref) {
                        Some(steps) => PathMode::Replay(steps),
                        None => PathMode::Free,
                    },
                    _ => PathMode::Free,
                };
                let out = march.tangent_phase(phase, d_gamma, d_anchors, mode)?;
                if let Paths::Record(all) = &paths {
                    recorded += all[p].iter().flatten().map(PathStep::size).sum::<usize>();
                }
                out
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
