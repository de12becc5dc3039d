//! One period's march of the frictional contact law (docs/theory.md (T153)–(T155)):
//! switches located cell by cell, flips at one instant, anchors and their sensitivities,
//! the Fourier coefficients and their derivative accumulated phase by phase.

// the small dense matrices of the law are indexed as the equations write them
#![allow(clippy::needless_range_loop)]

use std::collections::HashMap;
use std::f64::consts::PI;

use super::modes::{Kind, ModeCache, ModeData};
use super::{FrictionalContacts, Mode, Phase, INDICATOR_TOLERANCE};
use crate::error::{Error, Result};
use crate::harmonic::{add_interval_gram, basis_derivative, basis_into, n_coefficients};
use crate::method::redistributed::quadrature::{derivative_into, CellScan};

/// One period's march and its results.
pub(super) struct Marched {
    pub(super) modes_end: Vec<Mode>,
    pub(super) anchors_end: Vec<f64>,
    /// `n × (2n(2H+1) + n)`: anchors at the end against `[γ̂, a₀]`.
    pub(super) d_anchors_end: Vec<f64>,
    /// Contacts whose anchor was set during the period.
    pub(super) released: Vec<bool>,
    pub(super) phases: Vec<Phase>,
    /// The anchors set during the period, in order.
    pub(super) events: Vec<AnchorEvent>,
}

/// Contact `contact` sticks at `tau`, after the first `after` phases of the period: its new
/// anchor's first-order dependence on the state just before the switches at that instant
/// (T154), in the time domain of the Floquet analysis (T182):
/// `δa_c = gᵀ δγ(τ) + vᵀ δγ'(τ) + sᵀ δa`, with `δγ'` the derivative in `τ` and `δa` the
/// anchors before the instant, the modes before it being the set `data`.
#[derive(Clone, Debug)]
pub struct AnchorEvent {
    pub tau: f64,
    pub after: usize,
    pub contact: usize,
    pub(super) data: usize,
    pub gap: Vec<f64>,
    pub rate: Vec<f64>,
    pub anchors: Vec<f64>,
}

pub(super) struct March<'a> {
    pub(super) contacts: &'a FrictionalContacts,
    pub(super) harmonics: usize,
    pub(super) gamma: &'a [f64],
    pub(super) cells: usize,
    pub(super) data: Vec<ModeData>,
    pub(super) index: HashMap<Vec<Mode>, usize>,
}

impl<'a> March<'a> {
    pub(super) fn new(
        contacts: &'a FrictionalContacts,
        harmonics: usize,
        gamma: &'a [f64],
        cells: usize,
        cache: ModeCache,
    ) -> Self {
        March {
            contacts,
            harmonics,
            gamma,
            cells,
            data: cache.data,
            index: cache.index,
        }
    }

    /// The sets of modes met, for later marches.
    pub(super) fn into_cache(self) -> ModeCache {
        ModeCache {
            data: self.data,
            index: self.index,
        }
    }

    pub(super) fn data_of(&mut self, modes: &[Mode]) -> Result<usize> {
        if let Some(&i) = self.index.get(modes) {
            return Ok(i);
        }
        let d = self.contacts.mode_data(modes)?;
        self.data.push(d);
        self.index.insert(modes.to_vec(), self.data.len() - 1);
        Ok(self.data.len() - 1)
    }

    /// `Σ_r κ_r γ_r(τ)` and its slope.
    pub(super) fn combination_at(&self, kappa: &[f64], tau: f64) -> (f64, f64, Vec<f64>) {
        let m = kappa.len();
        let ncoef = n_coefficients(self.harmonics);
        let mut b = vec![0.0; ncoef];
        basis_into(self.harmonics, tau, &mut b);
        let db = basis_derivative(self.harmonics, tau);
        let (mut v, mut s) = (0.0, 0.0);
        for k in 0..ncoef {
            let ck: f64 = (0..m).map(|r| kappa[r] * self.gamma[k * m + r]).sum();
            v += ck * b[k];
            s += ck * db[k];
        }
        (v, s, b)
    }

    /// The indicators' coefficient rows for the modes `data` and anchors `a`.
    fn indicator_coefficients(
        &self,
        data: usize,
        a: &[f64],
        out: &mut Vec<f64>,
        scratch: &mut Vec<f64>,
    ) {
        let ncoef = n_coefficients(self.harmonics);
        let m = 2 * self.contacts.n;
        out.clear();
        let mut row = vec![0.0; ncoef];
        for ind in &self.data[data].indicators {
            for (k, r) in row.iter_mut().enumerate() {
                *r = (0..m).map(|i| ind.kappa[i] * self.gamma[k * m + i]).sum();
            }
            let start = out.len();
            if ind.kind == Kind::Velocity {
                derivative_into(&row, scratch);
                out.extend_from_slice(scratch);
            } else {
                row[0] += ind.theta.iter().zip(a).map(|(t, x)| t * x).sum::<f64>();
                out.extend_from_slice(&row);
            }
            // (T153): an indicator ends its mode where it falls below −ε of its size, so that
            // a contact resting at zero gap and zero force (or a slip at zero velocity) is
            // not flipped back and forth by round-off
            let size: f64 = out[start..].iter().map(|v| v.abs()).sum();
            out[start] += INDICATOR_TOLERANCE * size;
        }
    }

    /// The Fourier coefficients of the forces over the period cut into `phases`, and their
    /// derivative against `[γ̂, a₀]` (T155): `(2n(2H+1), 2n(2H+1) × (2n(2H+1) + n))`. Only
    /// the march that reaches the periodic state needs them (T156), so the marches of the
    /// fixed point leave them out.
    pub(super) fn accumulate(&self, phases: &[Phase]) -> (Vec<f64>, Vec<f64>) {
        let nu = 2 * self.contacts.n * n_coefficients(self.harmonics);
        let nv = nu + self.contacts.n;
        let (mut forces, mut d_forces, mut gram) = (vec![0.0; nu], vec![0.0; nu * nv], Vec::new());
        for phase in phases {
            self.add_phase(phase, &mut forces, &mut d_forces, &mut gram);
        }
        (forces, d_forces)
    }

    /// Add `phase` (its interval, modes, anchors and their sensitivities) to the forces and
    /// their derivative (T155).
    fn add_phase(
        &self,
        phase: &Phase,
        forces: &mut [f64],
        d_forces: &mut [f64],
        gram: &mut Vec<f64>,
    ) {
        let (data, a, b) = (phase.data, phase.start, phase.end);
        let (anchors, d_anchors) = (&phase.anchors, &phase.d_anchors);
        let (n, m) = (self.contacts.n, 2 * self.contacts.n);
        let ncoef = n_coefficients(self.harmonics);
        let nv = m * ncoef + n;
        gram.clear();
        gram.resize(ncoef * ncoef, 0.0);
        add_interval_gram(self.harmonics, a, b, gram);
        let d = &self.data[data];
        // F γ_c per coefficient c, G a
        let mut fg = vec![0.0; ncoef * m];
        for c in 0..ncoef {
            for i in 0..m {
                fg[c * m + i] = (0..m).map(|r| d.f[i * m + r] * self.gamma[c * m + r]).sum();
            }
        }
        let ga: Vec<f64> = (0..m)
            .map(|i| (0..n).map(|c| d.g[i * n + c] * anchors[c]).sum())
            .collect();
        // G ∂a/∂[γ̂, a₀]
        let mut gda = vec![0.0; m * nv];
        for i in 0..m {
            for c in 0..n {
                let gic = d.g[i * n + c];
                if gic == 0.0 {
                    continue;
                }
                for col in 0..nv {
                    gda[i * nv + col] += gic * d_anchors[c * nv + col];
                }
            }
        }
        for mc in 0..ncoef {
            for i in 0..m {
                let row = mc * m + i;
                let mut v = gram[mc * ncoef] * ga[i];
                for c in 0..ncoef {
                    let w = gram[mc * ncoef + c];
                    if w == 0.0 {
                        continue;
                    }
                    v += w * fg[c * m + i];
                    for r in 0..m {
                        d_forces[row * nv + c * m + r] += w * d.f[i * m + r];
                    }
                }
                forces[row] += v;
                let w0 = gram[mc * ncoef];
                if w0 != 0.0 {
                    for col in 0..nv {
                        d_forces[row * nv + col] += w0 * gda[i * nv + col];
                    }
                }
            }
        }
    }

    /// March one period from the modes and anchors at `τ = 0` (T153)–(T155).
    pub(super) fn run(&mut self, modes0: &[Mode], anchors0: &[f64]) -> Result<Marched> {
        let n = self.contacts.n;
        let m = 2 * n;
        let h = self.harmonics;
        let ncoef = n_coefficients(h);
        let nu = m * ncoef;
        let nv = nu + n;
        let mut modes = modes0.to_vec();
        let mut anchors = anchors0.to_vec();
        let mut d_anchors = vec![0.0; n * nv];
        for c in 0..n {
            if modes[c] == Mode::Stick {
                d_anchors[c * nv + nu + c] = 1.0;
            }
        }
        let mut released = vec![false; n];
        let mut phases = Vec::new();
        let mut events = Vec::new();
        let mut scan = CellScan::new(h);
        let (mut coefs, mut scratch) = (Vec::new(), Vec::new());
        let mut current = self.data_of(&modes)?;
        let mut phase_start = 0.0;
        let mut tau = 0.0;
        let (mut flips_here, mut last_flip) = (0usize, f64::NAN);
        let mut cascade: Option<Cascade> = None;
        // the (contact, mode) pairs left at the current instant
        let mut left: Vec<(usize, Mode)> = Vec::new();
        let mut stale = true;
        for cell in 0..self.cells {
            let end = 2.0 * PI * (cell + 1) as f64 / self.cells as f64;
            loop {
                if tau >= end {
                    break;
                }
                // the indicators change only with the modes and anchors, i.e. at a flip
                if stale {
                    self.indicator_coefficients(current, &anchors, &mut coefs, &mut scratch);
                    stale = false;
                }
                if coefs.is_empty() {
                    break;
                }
                scan.fill(&coefs, tau, end);
                let Some((t, which)) = scan.earliest_root(&coefs, ncoef) else {
                    break;
                };
                if t - last_flip <= 1e-13 * 2.0 * PI {
                    flips_here += 1;
                    if flips_here > 4 * n + 8 {
                        return Err(Error::Numerical(format!(
                            "friction: the contact modes cycle at τ = {t} (modes {modes:?})"
                        )));
                    }
                } else {
                    flips_here = 0;
                    left.clear();
                    cascade = Some(Cascade {
                        tau: t,
                        data: current,
                        indicator: which,
                        anchors: anchors.clone(),
                        d_anchors: d_anchors.clone(),
                    });
                }
                last_flip = t;
                stale = true;
                phases.push(Phase::of(
                    phase_start,
                    t,
                    &modes,
                    &anchors,
                    &d_anchors,
                    current,
                ));
                let (contact, kind) = {
                    let ind = &self.data[current].indicators[which];
                    (ind.contact, ind.kind)
                };
                let mu = self.contacts.mu[contact];
                let next = match kind {
                    Kind::Gap if mu > 0.0 => Mode::Stick,
                    Kind::Gap => Mode::SlipPositive,
                    Kind::Normal => Mode::Open,
                    Kind::ConeUpper => Mode::SlipNegative,
                    Kind::ConeLower => Mode::SlipPositive,
                    Kind::Velocity => Mode::Stick,
                };
                let cascade = cascade
                    .as_ref()
                    .expect("a cascade starts at every new instant");
                if modes[contact] == Mode::Stick {
                    released[contact] = true;
                }
                left.push((contact, modes[contact]));
                if left.contains(&(contact, next)) {
                    // a flip that undoes one at this instant: the indicators' signs there
                    // are round-off (a grazing contact); the mode is the one valid a little
                    // after the instant (T153)
                    let probe = t + 1e-3 * (2.0 * PI / self.cells as f64);
                    let chosen =
                        self.mode_after(cascade, contact, t, probe, &modes, &anchors, &d_anchors)?;
                    modes[contact] = chosen.0;
                    anchors = chosen.1;
                    d_anchors = chosen.2;
                    if let Some(mut event) = chosen.3 {
                        event.after = phases.len();
                        events.push(event);
                    }
                    current = self.data_of(&modes)?;
                    phase_start = t;
                    tau = probe;
                    continue;
                }
                if next == Mode::Stick {
                    // (T154): the anchor is the tangential displacement at the instant
                    let mut event = self.stick(cascade, contact, t, &mut anchors, &mut d_anchors);
                    event.after = phases.len();
                    events.push(event);
                }
                modes[contact] = next;
                current = self.data_of(&modes)?;
                phase_start = t;
                tau = t;
            }
            tau = tau.max(end);
        }
        phases.push(Phase::of(
            phase_start,
            2.0 * PI,
            &modes,
            &anchors,
            &d_anchors,
            current,
        ));
        // a contact that stuck during the period has a new anchor even if it was stuck at 0
        Ok(Marched {
            modes_end: modes,
            anchors_end: anchors,
            d_anchors_end: d_anchors,
            released,
            phases,
            events,
        })
    }

    /// The mode of contact `c` after an instant `t` where its indicators' signs are
    /// round-off (a grazing contact, or a slip reversing with the cone's margin growing only
    /// quadratically): among the modes that keep its forces continuous at `t` (a slip
    /// cannot reverse, nor a loaded contact open, at an instant), the one whose indicators
    /// are largest, relative to their coefficients, at `probe` a little after `t`; the
    /// others' modes kept. With the anchors (`c`'s set at `t` if it sticks).
    #[allow(clippy::too_many_arguments, clippy::type_complexity)]
    fn mode_after(
        &mut self,
        cascade: &Cascade,
        c: usize,
        t: f64,
        probe: f64,
        modes: &[Mode],
        anchors: &[f64],
        d_anchors: &[f64],
    ) -> Result<(Mode, Vec<f64>, Vec<f64>, Option<AnchorEvent>)> {
        let candidates: &[Mode] = if self.contacts.mu[c] > 0.0 {
            &[
                Mode::Open,
                Mode::Stick,
                Mode::SlipPositive,
                Mode::SlipNegative,
            ]
        } else {
            &[Mode::Open, Mode::SlipPositive]
        };
        let ncoef = n_coefficients(self.harmonics);
        let n = self.contacts.n;
        let (mut coefs, mut scratch) = (Vec::new(), Vec::new());
        // the contact's forces before the instant
        let force_of = |march: &Self, data: usize, a: &[f64]| -> [f64; 2] {
            let d = &march.data[data];
            let m = 2 * n;
            let at = |row: usize| {
                let (v, _, _) = march.combination_at(&d.f[row * m..(row + 1) * m], t);
                v + (0..n).map(|k| d.g[row * n + k] * a[k]).sum::<f64>()
            };
            [at(c), at(n + c)]
        };
        let before = force_of(self, cascade.data, &cascade.anchors);
        let size = before[0].abs() + before[1].abs();
        let mut best: Option<(bool, f64, Mode, Vec<f64>, Vec<f64>, Option<AnchorEvent>)> = None;
        for &candidate in candidates {
            let mut trial = modes.to_vec();
            trial[c] = candidate;
            let (mut a, mut da) = (anchors.to_vec(), d_anchors.to_vec());
            let event =
                (candidate == Mode::Stick).then(|| self.stick(cascade, c, t, &mut a, &mut da));
            let data = self.data_of(&trial)?;
            self.indicator_coefficients(data, &a, &mut coefs, &mut scratch);
            let worst = self.data[data]
                .indicators
                .iter()
                .zip(coefs.chunks_exact(ncoef))
                .filter(|(ind, _)| ind.contact == c)
                .map(|(_, row)| {
                    let size = row
                        .iter()
                        .map(|v| v.abs())
                        .sum::<f64>()
                        .max(f64::MIN_POSITIVE);
                    crate::harmonic::evaluate(row, probe) / size
                })
                .fold(f64::INFINITY, f64::min);
            let after = force_of(self, data, &a);
            let continuous = (after[0] - before[0]).abs() + (after[1] - before[1]).abs()
                <= 1e-8 * size.max(f64::MIN_POSITIVE);
            if best
                .as_ref()
                .is_none_or(|(cont, w, ..)| (continuous, worst) > (*cont, *w))
            {
                best = Some((continuous, worst, candidate, a, da, event));
            }
        }
        let (_, _, mode, a, da, event) = best.expect("at least one candidate");
        Ok((mode, a, da, event))
    }

    /// Contact `c` sticks at `t`, in the cascade of switches `cascade` started at that
    /// instant: its anchor and the anchor's sensitivity (T154). The tangential displacement
    /// arrives along the modes before the cascade, and the instant is the root of the
    /// cascade's first indicator; where the displacement moves there (a closing contact, or a
    /// slip stopped by another contact's switch) the instant's sensitivity enters.
    pub(super) fn stick(
        &self,
        cascade: &Cascade,
        c: usize,
        t: f64,
        anchors: &mut [f64],
        d_anchors: &mut [f64],
    ) -> AnchorEvent {
        let n = self.contacts.n;
        let m = 2 * n;
        let ncoef = n_coefficients(self.harmonics);
        let nu = m * ncoef;
        let nv = nu + n;
        let d = &self.data[cascade.data];
        let rho = &d.yf[(n + c) * m..(n + c + 1) * m];
        let sigma = &d.yg[(n + c) * n..(n + c + 1) * n];
        let (y, ydot, b) = self.combination_at(rho, t);
        let value = y + sigma
            .iter()
            .zip(&cascade.anchors)
            .map(|(s, a)| s * a)
            .sum::<f64>();
        let mut row = vec![0.0; nv];
        for k in 0..ncoef {
            for r in 0..m {
                row[k * m + r] = b[k] * rho[r];
            }
        }
        for (c2, &s) in sigma.iter().enumerate() {
            if s != 0.0 {
                for col in 0..nv {
                    row[col] += s * cascade.d_anchors[c2 * nv + col];
                }
            }
        }
        let trigger = &d.indicators[cascade.indicator];
        // dτ = −dh/ḣ with h = κᵀγ + θᵀa, or h = κᵀγ̇ for a velocity
        let velocity = trigger.kind == Kind::Velocity;
        let mut event = AnchorEvent {
            tau: t,
            after: 0,
            contact: c,
            data: cascade.data,
            gap: rho.to_vec(),
            rate: vec![0.0; m],
            anchors: sigma.to_vec(),
        };
        let (h_row, hdot) = {
            let db = basis_derivative(self.harmonics, cascade.tau);
            let mut bt = vec![0.0; ncoef];
            basis_into(self.harmonics, cascade.tau, &mut bt);
            let (basis_row, slope_row): (Vec<f64>, Vec<f64>) = if velocity {
                // ḣ = κᵀ γ̈, γ̈ of cos kτ, sin kτ is −k² times them
                let second: Vec<f64> = (0..ncoef)
                    .map(|k| {
                        let kk = k.div_ceil(2) as f64;
                        -kk * kk * bt[k]
                    })
                    .collect();
                (db, second)
            } else {
                (bt, db)
            };
            let mut hdot = 0.0;
            for k in 0..ncoef {
                hdot += slope_row[k]
                    * (0..m)
                        .map(|r| trigger.kappa[r] * self.gamma[k * m + r])
                        .sum::<f64>();
            }
            (basis_row, hdot)
        };
        if hdot != 0.0 && ydot != 0.0 {
            let factor = -ydot / hdot;
            let target = if velocity {
                &mut event.rate
            } else {
                &mut event.gap
            };
            for (e, k) in target.iter_mut().zip(&trigger.kappa) {
                *e += factor * k;
            }
            if !velocity {
                for (e, th) in event.anchors.iter_mut().zip(&trigger.theta) {
                    *e += factor * th;
                }
            }
            for k in 0..ncoef {
                for r in 0..m {
                    row[k * m + r] += factor * h_row[k] * trigger.kappa[r];
                }
            }
            if !velocity {
                for (c2, &th) in trigger.theta.iter().enumerate() {
                    if th != 0.0 {
                        for col in 0..nv {
                            row[col] += factor * th * cascade.d_anchors[c2 * nv + col];
                        }
                    }
                }
            }
        }
        anchors[c] = value;
        d_anchors[c * nv..(c + 1) * nv].copy_from_slice(&row);
        event
    }
}

/// The switches at one instant: the modes before them, the indicator whose root the
/// instant is, and the anchors then.
pub(super) struct Cascade {
    tau: f64,
    data: usize,
    indicator: usize,
    anchors: Vec<f64>,
    d_anchors: Vec<f64>,
}
