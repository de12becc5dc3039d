//! The tangent-linear march through a slip phase (docs/theory.md (T222)): the primal slip
//! flow by DOP853, the tangent by 3-stage Radau IIA collocation on the same steps, and the
//! primal path recorded for later marches to replay (T225).

// the small dense matrices of the law are indexed as the equations write them
#![allow(clippy::needless_range_loop)]

use super::super::march::March;
use super::super::*;

impl March<'_> {
    /// Integrate the slip phase `phase` with its tangents from its start to its end: the
    /// displacements at the end, and per column `δa` at the end (in `d_anchors`) and the
    /// integrals `∫ δa b_q` in the layout of `accumulate` (`2s` unused, then `2s (2H+1)`).
    ///
    /// The displacements follow DOP853 with error control; the tangent, linear in `δa`
    /// (T215) and stiff where a slipping contact's `|λ_T|` is small, follows the 3-stage
    /// Radau IIA collocation (L-stable, order 5) on the same steps (T222): at each stage the
    /// rates' matrix `A(τ)` in the slipping contacts' `δa` and the part `b_j(τ)` of the
    /// column's free gap and held displacements, then one linear system for all columns.
    ///
    /// `path` records the primal steps (their stages' and end's displacements, back on the
    /// cone) or replays recorded ones instead of integrating again (T225): the steps do not
    /// depend on the columns.
    pub(super) fn tangent_phase(
        &mut self,
        phase: &ConePhase,
        d_gamma: &[Vec<f64>],
        d_anchors: &mut [Vec<f64>],
        path: PathMode<'_>,
    ) -> Result<(Vec<f64>, Vec<Vec<f64>>)> {
        let n = self.law.n;
        let m = 3 * n;
        let ncoef = n_coefficients(self.harmonics);
        let slipping = self.slipping(&phase.modes);
        let s = slipping.len();
        let ncol = d_gamma.len();
        let closed = self.closed(&phase.modes)?;
        let modes = &phase.modes;
        let held = phase.anchors.clone();
        self.project_tangent(phase.start, modes, &held, &closed, d_gamma, d_anchors)?;
        // the slipping contacts' components, in the order of the state
        let component: Vec<usize> = (0..2 * s)
            .map(|k| {
                if k % 2 == 0 {
                    slipping[k / 2]
                } else {
                    n + slipping[k / 2]
                }
            })
            .collect();
        let mut x: Vec<f64> = component.iter().map(|&r| held[r]).collect();
        let this = &*self;
        let unpack = |x: &[f64]| -> Vec<f64> {
            let mut a = held.clone();
            for (k, &r) in component.iter().enumerate() {
                a[r] = x[k];
            }
            a
        };
        let mut f = |t: f64, x: &[f64], dx: &mut [f64]| -> Result<()> {
            let r = this.rates(t, modes, &unpack(x), &closed, &[], &[])?;
            for (k, &c) in component.iter().enumerate() {
                dx[k] = r.rate[c];
            }
            Ok(())
        };
        // the columns' parts that do not move: δγ̂ and the held contacts' δa
        let held_columns: Vec<Vec<f64>> = d_anchors
            .iter()
            .map(|da| {
                let mut da = da.clone();
                component.iter().for_each(|&r| da[r] = 0.0);
                da
            })
            .collect();
        // the rates' variations at a stage along the columns and along unit `δa` of the
        // slipping components (A of (T222)) in one evaluation: the columns first
        let stage_gamma: Vec<Vec<f64>> = d_gamma
            .iter()
            .cloned()
            .chain(std::iter::repeat_n(vec![0.0; m * ncoef], 2 * s))
            .collect();
        let stage_anchors: Vec<Vec<f64>> = held_columns
            .iter()
            .cloned()
            .chain(component.iter().map(|&r| {
                let mut e = vec![0.0; 2 * n];
                e[r] = 1.0;
                e
            }))
            .collect();
        let mut tangent: Vec<Vec<f64>> = d_anchors
            .iter()
            .map(|da| component.iter().map(|&r| da[r]).collect())
            .collect();
        let mut integrals = vec![vec![0.0; 2 * s * (1 + ncoef)]; ncol];
        let tolerance = Tolerance {
            relative: FLOW_TOLERANCE,
            absolute: FLOW_TOLERANCE * self.gamma_scale.max(f64::MIN_POSITIVE),
        };
        // a quarter of the law's cell: the collocation's error falls like the step's cube
        // in the stiff transients (T222)
        let cell = 2.0 * PI / self.cells as f64 / 4.0;
        let mut ode = Dop853::new(2 * s);
        let mut next = vec![0.0; 2 * s];
        let mut basis = vec![0.0; ncoef];
        let (mut t, mut h) = (phase.start, cell);
        let (replay, mut record) = match path {
            PathMode::Free => (None, None),
            PathMode::Record(steps) => (None, Some(steps)),
            PathMode::Replay(steps) => (Some(steps.iter()), None),
        };
        let mut replay = replay;
        let pick = |a: &[f64]| -> Vec<f64> { component.iter().map(|&r| a[r]).collect() };
        while t < phase.end {
            // the primal step: recorded, or by DOP853 with error control
            let (length, error, recorded) = match replay.as_mut() {
                Some(steps) => {
                    let step = steps.next().ok_or_else(|| {
                        Error::Numerical("friction cone: a recorded slip path ended early".into())
                    })?;
                    (step.length, 0.0, Some(step))
                }
                None => {
                    let length = h.min(phase.end - t).min(cell);
                    (
                        length,
                        ode.step(&mut f, t, &x, length, &mut next, tolerance)?,
                        None,
                    )
                }
            };
            if error <= 1.0 {
                // the displacements at the stages, back on the cone, and the rates there
                let mut stage_a = Vec::with_capacity(3);
                for (i, c) in RADAU_C.iter().enumerate() {
                    if let Some(step) = recorded {
                        stage_a.push(unpack(&step.values[i * 2 * s..(i + 1) * 2 * s]));
                        continue;
                    }
                    let tau = t + c * length;
                    let mut xs = next.clone();
                    if i < 2 {
                        ode.step(&mut f, t, &x, c * length, &mut xs, tolerance)?;
                    }
                    let mut a = unpack(&xs);
                    this.project(tau, modes, &mut a, &closed)?;
                    stage_a.push(a);
                }
                let w = 2 * s;
                let mut system = vec![0.0; 9 * w * w];
                let mut rhs = Mat::<f64>::zeros(3 * w, ncol);
                for (i, a) in stage_a.iter().enumerate() {
                    let tau = t + RADAU_C[i] * length;
                    let d_rate = this
                        .rates(tau, modes, a, &closed, &stage_gamma, &stage_anchors)?
                        .d_rate;
                    // row block i of (I − h a_ik A_k): column block k gets A_k's entries
                    for k in 0..3 {
                        for q in 0..w {
                            for (p, &r) in component.iter().enumerate() {
                                let entry = -length * RADAU_A[k][i] * d_rate[(r, ncol + q)];
                                system[(k * w + p) * 3 * w + i * w + q] += entry;
                            }
                        }
                    }
                    for j in 0..ncol {
                        for (p, &r) in component.iter().enumerate() {
                            let b = d_rate[(r, j)];
                            for k in 0..3 {
                                rhs[(k * w + p, j)] += length * RADAU_A[k][i] * b;
                            }
                        }
                    }
                }
                for d in 0..3 * w {
                    system[d * 3 * w + d] += 1.0;
                }
                for j in 0..ncol {
                    for k in 0..3 {
                        for p in 0..w {
                            rhs[(k * w + p, j)] += tangent[j][p];
                        }
                    }
                }
                let stages = solve_small_lu_columns(&system, rhs.as_ref(), 1e-14).map_err(|_| {
                    Error::Numerical(format!(
                        "friction cone: the tangent's collocation system is singular at τ = {t} (T222)"
                    ))
                })?;
                for (i, c) in RADAU_C.iter().enumerate() {
                    basis_into(this.harmonics, t + c * length, &mut basis);
                    let weight = length * RADAU_A[2][i];
                    for j in 0..ncol {
                        for p in 0..w {
                            let value = weight * stages[(i * w + p, j)];
                            for q in 0..ncoef {
                                integrals[j][w + p * ncoef + q] += value * basis[q];
                            }
                        }
                    }
                }
                t = if length == phase.end - t {
                    phase.end
                } else {
                    t + length
                };
                // back on the cone as in the law's march, the tangents with it
                let mut a = stage_a.pop().expect("three stages");
                let third = record.is_some().then(|| pick(&a));
                let mut da: Vec<Vec<f64>> = held_columns.clone();
                for j in 0..ncol {
                    for (p, &r) in component.iter().enumerate() {
                        da[j][r] = stages[(2 * w + p, j)];
                    }
                }
                match recorded {
                    Some(step) => a = unpack(&step.values[3 * w..4 * w]),
                    None => this.project(t, modes, &mut a, &closed)?,
                }
                if let Some(steps) = record.as_mut() {
                    let mut values = Vec::with_capacity(4 * w);
                    stage_a.iter().for_each(|v| values.extend(pick(v)));
                    values.extend(third.unwrap_or_default());
                    values.extend(pick(&a));
                    steps.push(PathStep { length, values });
                }
                this.project_tangent(t, modes, &a, &closed, d_gamma, &mut da)?;
                for (k, &r) in component.iter().enumerate() {
                    x[k] = a[r];
                    for j in 0..ncol {
                        tangent[j][k] = da[j][r];
                    }
                }
            }
            if recorded.is_some() {
                continue;
            }
            h = Dop853::next_step(length, error);
            if h <= 1e-15 {
                return Err(Error::Numerical(format!(
                    "friction cone: the slip flow's step fell below round-off at τ = {t} \
                     (phase {} to {}, modes {:?})",
                    phase.start, phase.end, phase.modes
                )));
            }
        }
        let anchors = unpack(&x);
        for j in 0..ncol {
            for (p, &r) in component.iter().enumerate() {
                d_anchors[j][r] = tangent[j][p];
            }
        }
        Ok((anchors, integrals))
    }
}

/// One accepted step of a slip phase's primal path (T225): its length and the slipping
/// components' displacements at the three stages and at its end, back on the cone.
#[derive(Clone, Debug)]
pub(in super::super) struct PathStep {
    length: f64,
    values: Vec<f64>,
}

impl PathStep {
    /// The numbers it holds.
    pub(in super::super) fn size(&self) -> usize {
        self.values.len() + 1
    }
}

/// What [`March::tangent_phase`] does with the primal path.
pub(in super::super) enum PathMode<'a> {
    /// Integrate it.
    Free,
    /// Integrate it and record its steps.
    Record(&'a mut Vec<PathStep>),
    /// Take its steps as recorded.
    Replay(&'a [PathStep]),
}

/// The 3-stage Radau IIA collocation (T222): nodes `c` and coefficients `a` (its last row
/// the quadrature weights).
const SQRT6: f64 = 2.449_489_742_783_178;
const RADAU_C: [f64; 3] = [(4.0 - SQRT6) / 10.0, (4.0 + SQRT6) / 10.0, 1.0];
const RADAU_A: [[f64; 3]; 3] = [
    [
        (88.0 - 7.0 * SQRT6) / 360.0,
        (296.0 - 169.0 * SQRT6) / 1800.0,
        (-2.0 + 3.0 * SQRT6) / 225.0,
    ],
    [
        (296.0 + 169.0 * SQRT6) / 1800.0,
        (88.0 + 7.0 * SQRT6) / 360.0,
        (-2.0 - 3.0 * SQRT6) / 225.0,
    ],
    [(16.0 - SQRT6) / 36.0, (16.0 + SQRT6) / 36.0, 1.0 / 9.0],
];
