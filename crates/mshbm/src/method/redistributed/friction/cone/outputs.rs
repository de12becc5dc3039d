//! What the solver and its outputs ask of a periodic state of the cone law (docs/theory.md
//! (T220)–(T221)): the dense derivative `S = dλ̂/dγ̂` (columns of the tangent-linear march
//! along unit directions), the forces, contact coordinates and modes at given instants, the
//! energy the friction dissipates per period and the fraction of the period in each state.

use super::march::March;
use super::*;
use crate::solution::{ContactState, StateFractions};

/// Gauss–Legendre nodes and weights on `[−1, 1]`, 8 points (exact for degree 15).
const GAUSS_8: [(f64, f64); 8] = [
    (-0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
    (-0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (-0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (-0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
];

/// The state of the cone law at one instant.
#[derive(Clone, Debug)]
pub struct ConeState {
    /// The forces `λ` (`3n`, `[normals; t₁; t₂]`).
    pub lambda: Vec<f64>,
    /// The contact coordinates `y = γ + D λ` (gaps, then tangential displacements) (T186).
    pub y: Vec<f64>,
    pub modes: Vec<ConeMode>,
}

impl ConeContacts {
    /// `S = dλ̂/dγ̂` of `periodic` (T220), row-major, `3n(2H+1)` square: its columns are the
    /// tangent (T191) along the unit directions of the free gap's coefficients.
    pub fn jacobian(&self, periodic: &ConePeriodic, cells: usize) -> Result<Vec<f64>> {
        Ok(self.jacobian_and_response(periodic, cells)?.0)
    }

    /// [`ConeContacts::jacobian`] and the anchors' response (T225) from the same march.
    pub fn jacobian_and_response(
        &self,
        periodic: &ConePeriodic,
        cells: usize,
    ) -> Result<(Vec<f64>, super::AnchorResponse)> {
        let (columns, response) =
            self.tangent_and_response(periodic, &unit_directions(periodic), cells)?;
        Ok((row_major(columns), response))
    }

    /// [`ConeContacts::jacobian`] with the anchors' response of `periodic` (T225).
    pub fn jacobian_with(
        &self,
        periodic: &ConePeriodic,
        response: &super::AnchorResponse,
        cells: usize,
    ) -> Result<Vec<f64>> {
        let columns = self.tangent_with(periodic, response, &unit_directions(periodic), cells)?;
        Ok(row_major(columns))
    }

    /// The state of `periodic` at each of `taus` (taken modulo the period), the slip flow
    /// integrated from the march's last step before each instant (T221).
    pub fn states_at(&self, periodic: &ConePeriodic, taus: &[f64]) -> Result<Vec<ConeState>> {
        let m = 3 * self.n;
        let mut march = March::new(self, periodic.harmonics, &periodic.gamma, 64);
        let mut out = Vec::with_capacity(taus.len());
        let mut gamma = vec![0.0; m];
        for tau in taus.iter().map(|t| t.rem_euclid(2.0 * PI)) {
            let phase = &periodic.phases[phase_index(&periodic.phases, tau)?];
            let anchors = march.flow_to(phase, tau)?;
            let closed = march.closed(&phase.modes)?;
            let lambda = march.evaluate(tau, &phase.modes, &anchors, &closed)?.lambda;
            march.gamma_at(tau, &mut gamma, None);
            let y = (0..m)
                .map(|r| gamma[r] + (0..m).map(|k| self.d(r, k) * lambda[k]).sum::<f64>())
                .collect();
            out.push(ConeState {
                lambda,
                y,
                modes: phase.modes.clone(),
            });
        }
        Ok(out)
    }

    /// The energy the friction forces dissipate over one period, `−∮ λ_Tᵀ dy_T = ∮ Σ κ_c
    /// |λ_T,c| dτ` over the slipping contacts (T221), by 8-point Gauss–Legendre on pieces of
    /// each slip phase no longer than `2π/(8H)`, the slip flow integrated from the march's
    /// last step before each node.
    pub fn dissipated_energy(&self, periodic: &ConePeriodic) -> Result<f64> {
        let n = self.n;
        let mut march = March::new(self, periodic.harmonics, &periodic.gamma, 64);
        let longest = 2.0 * PI / (8 * periodic.harmonics.max(1)) as f64;
        let mut total = 0.0;
        for phase in &periodic.phases {
            let slipping = march.slipping(&phase.modes);
            if slipping.is_empty() || phase.end <= phase.start {
                continue;
            }
            let closed = march.closed(&phase.modes)?;
            let pieces = ((phase.end - phase.start) / longest).ceil().max(1.0) as usize;
            let width = (phase.end - phase.start) / pieces as f64;
            for piece in 0..pieces {
                let a = phase.start + piece as f64 * width;
                for (x, w) in GAUSS_8 {
                    let tau = a + 0.5 * width * (1.0 + x);
                    let anchors = march.flow_to(phase, tau)?;
                    let e = march.evaluate(tau, &phase.modes, &anchors, &closed)?;
                    let power: f64 = slipping
                        .iter()
                        .zip(&e.speed)
                        .filter(|(&c, s)| e.lambda[c] > 0.0 && s.is_finite())
                        .map(|(&c, s)| s * e.lambda[n + c].hypot(e.lambda[2 * n + c]))
                        .sum();
                    total += 0.5 * width * w * power;
                }
            }
        }
        Ok(total)
    }
}

impl March<'_> {
    /// The displacements at `τ` within `phase`: the march's state at the last of its steps
    /// that ends before `τ` (T221), the slip flow integrated from there.
    pub(super) fn flow_to(&mut self, phase: &ConePhase, tau: f64) -> Result<Vec<f64>> {
        let n = self.law.n;
        let slipping = self.slipping(&phase.modes);
        let mut anchors = phase.anchors.clone();
        if slipping.is_empty() || tau <= phase.start {
            return Ok(anchors);
        }
        let s = slipping.len();
        let dim = 2 * s * (1 + n_coefficients(self.harmonics));
        let mut x = vec![0.0; dim];
        let passed = phase.grid.partition_point(|&t| t <= tau);
        let from = if passed == 0 {
            for (i, &c) in slipping.iter().enumerate() {
                x[2 * i] = anchors[c];
                x[2 * i + 1] = anchors[n + c];
            }
            phase.start
        } else {
            x[..2 * s].copy_from_slice(&phase.track[(passed - 1) * 2 * s..passed * 2 * s]);
            for (i, &c) in slipping.iter().enumerate() {
                anchors[c] = x[2 * i];
                anchors[n + c] = x[2 * i + 1];
            }
            phase.grid[passed - 1]
        };
        if tau <= from {
            return Ok(anchors);
        }
        let closed = self.closed(&phase.modes)?;
        let mut ode = Dop853::new(dim);
        let mut next = vec![0.0; dim];
        // the march's step from `from` was at least this long and within the tolerance
        let (mut t, mut h) = (from, tau - from);
        while t < tau {
            let length = h.min(tau - t);
            let error = self.step(
                &mut ode,
                t,
                &x,
                length,
                &mut next,
                &phase.modes,
                &anchors,
                &closed,
            )?;
            if error <= 1.0 {
                t = if length == tau - t { tau } else { t + length };
                for (i, &c) in slipping.iter().enumerate() {
                    anchors[c] = next[2 * i];
                    anchors[n + c] = next[2 * i + 1];
                }
                self.project(t, &phase.modes, &mut anchors, &closed)?;
                for (i, &c) in slipping.iter().enumerate() {
                    next[2 * i] = anchors[c];
                    next[2 * i + 1] = anchors[n + c];
                }
                x.copy_from_slice(&next);
            }
            h = Dop853::next_step(length, error);
            if h <= 1e-15 {
                return Err(Error::Numerical(
                    "friction cone: the slip flow's step fell below round-off".into(),
                ));
            }
        }
        for (i, &c) in slipping.iter().enumerate() {
            anchors[c] = x[2 * i];
            anchors[n + c] = x[2 * i + 1];
        }
        Ok(anchors)
    }
}

/// The phase holding `τ ∈ [0, 2π]`.
fn phase_index(phases: &[ConePhase], tau: f64) -> Result<usize> {
    if phases.is_empty() {
        return Err(Error::Numerical("friction cone: no phases".into()));
    }
    Ok(phases
        .iter()
        .position(|p| p.start <= tau && tau <= p.end)
        .unwrap_or(phases.len() - 1))
}

impl ConePeriodic {
    /// The modes at `τ`.
    pub fn modes_at(&self, tau: f64) -> &[ConeMode] {
        let tau = tau.rem_euclid(2.0 * PI);
        match phase_index(&self.phases, tau) {
            Ok(p) => &self.phases[p].modes,
            Err(_) => &[],
        }
    }

    /// The fraction of the period each contact spends stuck, slipping and open, from the
    /// located switches (as (T181)); a closed contact without friction counts as slipping.
    pub fn state_fractions(&self) -> Vec<StateFractions> {
        let n = self.phases.first().map_or(0, |p| p.modes.len());
        let mut out = vec![
            StateFractions {
                stick: 0.0,
                slip: 0.0,
                open: 0.0
            };
            n
        ];
        for phase in &self.phases {
            let share = (phase.end - phase.start).max(0.0) / (2.0 * PI);
            for (o, mode) in out.iter_mut().zip(&phase.modes) {
                match mode {
                    ConeMode::Open => o.open += share,
                    ConeMode::Stick => o.stick += share,
                    ConeMode::Slip => o.slip += share,
                }
            }
        }
        out
    }
}

impl From<ConeMode> for ContactState {
    fn from(mode: ConeMode) -> Self {
        match mode {
            ConeMode::Open => ContactState::Open,
            ConeMode::Stick => ContactState::Stick,
            ConeMode::Slip => ContactState::Slip,
        }
    }
}

/// The unit directions of the free gap's coefficients of `periodic`.
fn unit_directions(periodic: &ConePeriodic) -> Vec<Vec<f64>> {
    let size = periodic.gamma.len();
    (0..size)
        .map(|j| {
            let mut d = vec![0.0; size];
            d[j] = 1.0;
            d
        })
        .collect()
}

/// Columns as one row-major square matrix.
fn row_major(columns: Vec<Vec<f64>>) -> Vec<f64> {
    let size = columns.len();
    let mut s = vec![0.0; size * size];
    for (j, column) in columns.iter().enumerate() {
        for (i, v) in column.iter().enumerate() {
            s[i * size + j] = *v;
        }
    }
    s
}
