//! One march of the period for the cone law (docs/theory.md (T186)–(T190)): phases between
//! switches, the slip flow by DOP853, switches located (T188) and settled, Fourier sums.
#![allow(clippy::needless_range_loop)] // small dense matrices indexed as the equations write them

use std::cell::RefCell;

use super::*;

/// The forces of one set of closed contacts (T186): the constrained coordinates and
/// `Y = D_KK⁻¹`.
#[derive(Debug)]
pub(super) struct Closed {
    /// Global coordinate of each constrained row: normals of the closed contacts, then the
    /// tangents of those with friction (both components of one contact side by side).
    pub(super) rows: Vec<usize>,
    /// Row of contact `c`'s normal, and of its first tangent (the second follows), if
    /// constrained.
    pub(super) normal_row: Vec<Option<usize>>,
    pub(super) tangent_row: Vec<Option<usize>>,
    /// `k × k`, row-major.
    pub(super) y: Vec<f64>,
    /// `−Y γ̂_K`: `k × (2H+1)`, row-major, the forces' free-gap part by coefficient.
    pub(super) free: Vec<f64>,
    /// The stuck contacts, their displacements and their part `Y_{:,T} a` of the forces,
    /// for the last set of displacements asked.
    #[allow(clippy::type_complexity)]
    pub(super) stuck: RefCell<Option<(Vec<usize>, Vec<f64>, Vec<f64>)>>,
}

/// What an indicator (T188) watches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Watch {
    Gap,
    Normal,
    Cone,
    Speed,
}

/// The state of the march at one instant.
#[derive(Clone, Debug)]
pub(super) struct Evaluation {
    /// All `3n` forces.
    pub(super) lambda: Vec<f64>,
    /// Slip speeds `κ` of the slipping contacts with friction (in their order).
    pub(super) speed: Vec<f64>,
    /// Unit slip directions `e` of those contacts.
    pub(super) direction: Vec<[f64; 2]>,
}

pub(super) struct March<'a> {
    pub(super) law: &'a ConeContacts,
    pub(super) harmonics: usize,
    pub(super) gamma: &'a [f64],
    pub(super) cells: usize,
    pub(super) closed: HashMap<Vec<bool>, Rc<Closed>>,
    /// `Σ_k max_r |γ̂_k,r|` and `Σ_k k max_r |γ̂_k,r|`: bounds of `|γ|` and `|γ̇|`.
    pub(super) gamma_scale: f64,
    pub(super) rate_scale: f64,
    pub(super) force_scale: f64,
    pub(super) steps: usize,
    pub(super) trial_steps: usize,
}

/// One march of the period.
pub(super) struct Marched {
    pub(super) end: (Vec<ConeMode>, Vec<f64>),
    pub(super) forces: Vec<f64>,
    pub(super) phases: Vec<ConePhase>,
}

impl<'a> March<'a> {
    pub(super) fn new(
        law: &'a ConeContacts,
        harmonics: usize,
        gamma: &'a [f64],
        cells: usize,
    ) -> Self {
        let m = 3 * law.n;
        let ncoef = n_coefficients(harmonics);
        let (mut gamma_scale, mut rate_scale) = (0.0, 0.0);
        for k in 0..ncoef {
            let largest = gamma[k * m..(k + 1) * m]
                .iter()
                .fold(0.0f64, |s, v| s.max(v.abs()));
            gamma_scale += largest;
            rate_scale += k.div_ceil(2) as f64 * largest;
        }
        let stiffest = law
            .delassus
            .iter()
            .fold(0.0f64, |s, v| s.max(v.abs()))
            .max(f64::MIN_POSITIVE);
        March {
            law,
            harmonics,
            gamma,
            cells,
            closed: HashMap::new(),
            gamma_scale,
            rate_scale,
            force_scale: gamma_scale / stiffest,
            steps: 0,
            trial_steps: 0,
        }
    }

    /// `γ(τ)` into `out` and, if asked, `γ̇(τ)`.
    pub(super) fn gamma_at(&self, tau: f64, out: &mut [f64], rate: Option<&mut [f64]>) {
        let m = 3 * self.law.n;
        let ncoef = n_coefficients(self.harmonics);
        let mut b = vec![0.0; ncoef];
        basis_into(self.harmonics, tau, &mut b);
        out.fill(0.0);
        for k in 0..ncoef {
            for r in 0..m {
                out[r] += b[k] * self.gamma[k * m + r];
            }
        }
        if let Some(rate) = rate {
            rate.fill(0.0);
            for k in 1..=self.harmonics {
                let (dc, ds) = (-(k as f64) * b[2 * k], k as f64 * b[2 * k - 1]);
                for r in 0..m {
                    rate[r] +=
                        dc * self.gamma[(2 * k - 1) * m + r] + ds * self.gamma[2 * k * m + r];
                }
            }
        }
    }

    /// The forces of the closed contacts of `modes` (T186), factored once per set.
    pub(super) fn closed(&mut self, modes: &[ConeMode]) -> Result<Rc<Closed>> {
        let n = self.law.n;
        let key: Vec<bool> = modes.iter().map(|&m| m != ConeMode::Open).collect();
        if let Some(c) = self.closed.get(&key) {
            return Ok(c.clone());
        }
        let mut rows = Vec::new();
        let mut normal_row = vec![None; n];
        let mut tangent_row = vec![None; n];
        for c in 0..n {
            if key[c] {
                normal_row[c] = Some(rows.len());
                rows.push(c);
            }
        }
        for c in 0..n {
            if key[c] && self.law.mu[c] > 0.0 {
                tangent_row[c] = Some(rows.len());
                rows.push(n + c);
                rows.push(2 * n + c);
            }
        }
        let k = rows.len();
        let dkk: Vec<f64> = (0..k * k)
            .map(|e| self.law.d(rows[e / k], rows[e % k]))
            .collect();
        let y = solve_small_lu_columns(&dkk, Mat::<f64>::identity(k, k).as_ref(), 1e-13).map_err(
            |_| {
                Error::Numerical(
                    "friction cone: the Delassus block of the closed contacts is singular".into(),
                )
            },
        )?;
        let y: Vec<f64> = (0..k * k).map(|e| y[(e / k, e % k)]).collect();
        let (m, ncoef) = (3 * n, n_coefficients(self.harmonics));
        let mut free = vec![0.0; k * ncoef];
        for i in 0..k {
            for q in 0..ncoef {
                free[i * ncoef + q] = -(0..k)
                    .map(|j| y[i * k + j] * self.gamma[q * m + rows[j]])
                    .sum::<f64>();
            }
        }
        let closed = Rc::new(Closed {
            rows,
            normal_row,
            tangent_row,
            y,
            free,
            stuck: RefCell::new(None),
        });
        self.closed.insert(key, closed.clone());
        Ok(closed)
    }
}

impl March<'_> {
    /// One DOP853 step of the slip flow (T187) with the Fourier integrals (T189) from `τ`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn step(
        &self,
        ode: &mut Dop853,
        tau: f64,
        x: &[f64],
        h: f64,
        out: &mut [f64],
        modes: &[ConeMode],
        held: &[f64],
        closed: &Closed,
    ) -> Result<f64> {
        let n = self.law.n;
        let slipping = self.slipping(modes);
        let s = slipping.len();
        if s == 0 {
            return Ok(0.0);
        }
        let ncoef = n_coefficients(self.harmonics);
        let mut anchors = held.to_vec();
        let mut b = vec![0.0; ncoef];
        let mut f = |t: f64, x: &[f64], dx: &mut [f64]| -> Result<()> {
            for (i, &c) in slipping.iter().enumerate() {
                anchors[c] = x[2 * i];
                anchors[n + c] = x[2 * i + 1];
            }
            let ev = self.evaluate(t, modes, &anchors, closed)?;
            for i in 0..s {
                // an unloaded contact (infinite speed: not watched) is held
                let speed = if ev.speed[i].is_finite() {
                    ev.speed[i]
                } else {
                    0.0
                };
                dx[2 * i] = speed * ev.direction[i][0];
                dx[2 * i + 1] = speed * ev.direction[i][1];
            }
            basis_into(self.harmonics, t, &mut b);
            for i in 0..2 * s {
                for q in 0..ncoef {
                    dx[2 * s + i * ncoef + q] = x[i] * b[q];
                }
            }
            Ok(())
        };
        let tolerance = Tolerance {
            relative: FLOW_TOLERANCE,
            absolute: FLOW_TOLERANCE * self.gamma_scale.max(f64::MIN_POSITIVE),
        };
        ode.step(&mut f, tau, x, h, out, tolerance)
    }

    /// One march of the period from `(modes, anchors)` at `τ = 0` (T186)–(T190).
    pub(super) fn run(&mut self, modes0: &[ConeMode], anchors0: &[f64]) -> Result<Marched> {
        let n = self.law.n;
        let m = 3 * n;
        let ncoef = n_coefficients(self.harmonics);
        let cell = 2.0 * PI / self.cells as f64;
        let mut modes = modes0.to_vec();
        let mut anchors = anchors0.to_vec();
        let mut forces = vec![0.0; m * ncoef];
        let mut phases = Vec::new();
        let mut tau = 0.0;
        let mut events = 0;
        let mut recent = Vec::new();
        let mut h = cell;
        self.settle(tau, &mut modes, &mut anchors)?;
        while tau < 2.0 * PI {
            let closed = self.closed(&modes)?;
            let slipping = self.slipping(&modes);
            let s = slipping.len();
            let dim = 2 * s * (1 + ncoef);
            let mut x = vec![0.0; dim];
            for (i, &c) in slipping.iter().enumerate() {
                x[2 * i] = anchors[c];
                x[2 * i + 1] = anchors[n + c];
            }
            let start = tau;
            let start_anchors = anchors.clone();
            let mut ode = Dop853::new(dim);
            let mut next = vec![0.0; dim];
            let mut held = anchors.clone();
            let mut event: Option<(usize, Watch)> = None;
            let (mut grid, mut track) = (Vec::new(), Vec::new());
            while tau < 2.0 * PI {
                let length = h.min(2.0 * PI - tau).min(cell);
                let error = self.step(
                    &mut ode, tau, &x, length, &mut next, &modes, &anchors, &closed,
                )?;
                if error > 1.0 {
                    h = Dop853::next_step(length, error);
                    if h <= 1e-15 {
                        return Err(Error::Numerical(
                            "friction cone: the slip flow's step fell below round-off".into(),
                        ));
                    }
                    continue;
                }
                self.steps += 1;
                let end = if length == 2.0 * PI - tau {
                    2.0 * PI
                } else {
                    tau + length
                };
                for (i, &c) in slipping.iter().enumerate() {
                    held[c] = next[2 * i];
                    held[n + c] = next[2 * i + 1];
                }
                self.project(end, &modes, &mut held, &closed)?;
                for (i, &c) in slipping.iter().enumerate() {
                    next[2 * i] = held[c];
                    next[2 * i + 1] = held[n + c];
                }
                let ind = self.indicators(end, &modes, &held, &closed)?;
                let crossing: Vec<usize> = (0..ind.len()).filter(|&i| ind[i].0 < 0.0).collect();
                if crossing.is_empty() {
                    h = Dop853::next_step(length, error);
                    tau = end;
                    x.copy_from_slice(&next);
                    if s > 0 {
                        grid.push(tau);
                        track.extend_from_slice(&x[..2 * s]);
                    }
                    continue;
                }
                // the earliest sign change among the crossing indicators: the first root of
                // their smallest, by safeguarded Newton on the step's length with the
                // indicators' rates along the march (T188)
                let mut trials = 0;
                let mut argmin: Vec<(f64, usize)> = Vec::new();
                let mut trial = vec![0.0; dim];
                let mut trial_held = anchors.clone();
                let mut g = |hh: f64| -> (f64, f64) {
                    trials += 1;
                    if self
                        .step(&mut ode, tau, &x, hh, &mut trial, &modes, &anchors, &closed)
                        .is_err()
                    {
                        return (f64::NAN, f64::NAN);
                    }
                    for (q, &c) in slipping.iter().enumerate() {
                        trial_held[c] = trial[2 * q];
                        trial_held[n + c] = trial[2 * q + 1];
                    }
                    if self
                        .project(tau + hh, &modes, &mut trial_held, &closed)
                        .is_err()
                    {
                        return (f64::NAN, f64::NAN);
                    }
                    let Ok(v) = self.indicators(tau + hh, &modes, &trial_held, &closed) else {
                        return (f64::NAN, f64::NAN);
                    };
                    let (value, i) = crossing
                        .iter()
                        .map(|&i| (v[i].0, i))
                        .min_by(|a, b| a.0.total_cmp(&b.0))
                        .expect("a crossing indicator");
                    argmin.push((hh, i));
                    let slope = self
                        .rates(tau + hh, &modes, &trial_held, &closed, &[], &[])
                        .and_then(|r| {
                            self.indicator_rate(
                                tau + hh,
                                &modes,
                                &trial_held,
                                &closed,
                                &r,
                                v[i].1,
                                v[i].2,
                            )
                        })
                        .unwrap_or(f64::NAN);
                    (value, slope)
                };
                let g_hi = crossing
                    .iter()
                    .map(|&i| ind[i].0)
                    .fold(f64::INFINITY, f64::min);
                let change = find_sign_change_with_slope(&mut g, 0.0, length, 0.0, g_hi);
                let hh = change.non_negative.max(0.0);
                // the indicator that reaches 0 first: the smallest where all are still ≥ 0
                let i = argmin
                    .iter()
                    .rev()
                    .find(|(t, _)| *t == change.non_negative)
                    .map(|&(_, i)| i)
                    .unwrap_or_else(|| {
                        crossing
                            .iter()
                            .copied()
                            .min_by(|&a, &b| ind[a].0.total_cmp(&ind[b].0))
                            .expect("a crossing indicator")
                    });
                self.trial_steps += trials;

                if hh > 0.0 {
                    self.step(&mut ode, tau, &x, hh, &mut next, &modes, &anchors, &closed)?;
                    for (q, &c) in slipping.iter().enumerate() {
                        held[c] = next[2 * q];
                        held[n + c] = next[2 * q + 1];
                    }
                    self.project(tau + hh, &modes, &mut held, &closed)?;
                    for (q, &c) in slipping.iter().enumerate() {
                        next[2 * q] = held[c];
                        next[2 * q + 1] = held[n + c];
                    }
                    x.copy_from_slice(&next);
                    if s > 0 {
                        grid.push(tau + hh);
                        track.extend_from_slice(&x[..2 * s]);
                    }
                }
                tau += hh;
                event = Some((ind[i].1, ind[i].2));
                h = length;
                break;
            }
            // the phase's Fourier coefficients (T189)
            for (i, &c) in slipping.iter().enumerate() {
                anchors[c] = x[2 * i];
                anchors[n + c] = x[2 * i + 1];
            }
            self.accumulate(
                start,
                tau,
                &modes,
                &start_anchors,
                &slipping,
                &x,
                &closed,
                &mut forces,
            );
            phases.push(ConePhase {
                start,
                end: tau,
                modes: modes.clone(),
                anchors: start_anchors,
                event,
                grid,
                track,
            });
            if let Some((c, watch)) = event {
                events += 1;
                // the same contact's slip speed reaching 0 again at the same instant: the
                // slip chosen there (T193) grazes (its speed touches 0 without turning
                // negative); it sticks instead of choosing again, which would repeat
                let repeated =
                    recent
                        .last()
                        .is_some_and(|&(t, d, _, w): &(f64, usize, ConeMode, Watch)| {
                            d == c && w == watch && (t - tau).abs() <= 1e-14 * 2.0 * PI
                        });
                recent.push((tau, c, modes[c], watch));
                if recent.len() > 6 {
                    recent.remove(0);
                }
                if events > MAX_EVENTS_PER_CONTACT * n.max(1) {
                    let last: Vec<String> = recent
                        .iter()
                        .map(|(t, c, m, w)| format!("τ = {t}: contact {c} {m:?} ({w:?} reached 0)"))
                        .collect();
                    return Err(Error::Numerical(format!(
                        "friction cone: more than {} mode changes in one period (a contact \
                         chatters); the last: {}",
                        MAX_EVENTS_PER_CONTACT * n.max(1),
                        last.join(", ")
                    )));
                }
                self.switch(tau, c, watch, &mut modes, &mut anchors)?;
                if matches!(watch, Watch::Cone | Watch::Speed) && !repeated {
                    self.choose_slip(tau, &mut modes, &anchors)?;
                }
                if !repeated {
                    self.settle(tau, &mut modes, &mut anchors)?;
                }
            }
        }
        Ok(Marched {
            end: (modes, anchors),
            forces,
            phases,
        })
    }

    /// The mode change of contact `c` whose indicator `watch` reached 0 at `τ` (T188).
    pub(super) fn switch(
        &mut self,
        tau: f64,
        c: usize,
        watch: Watch,
        modes: &mut [ConeMode],
        anchors: &mut [f64],
    ) -> Result<()> {
        let n = self.law.n;
        match watch {
            Watch::Gap => {
                // closes where it is: its tangential displacement of this instant
                let closed = self.closed(modes)?;
                let ev = self.evaluate(tau, modes, anchors, &closed)?;
                let mut g = vec![0.0; 3 * n];
                self.gamma_at(tau, &mut g, None);
                for t in 0..2 {
                    let row = (1 + t) * n + c;
                    anchors[t * n + c] = g[row]
                        + closed
                            .rows
                            .iter()
                            .map(|&r| self.law.d(row, r) * ev.lambda[r])
                            .sum::<f64>();
                }
                modes[c] = if self.law.mu[c] > 0.0 {
                    ConeMode::Stick
                } else {
                    ConeMode::Slip
                };
            }
            Watch::Normal => modes[c] = ConeMode::Open,
            Watch::Cone => {
                // a force outside the cone (after a jump of the forces, where another contact
                // opened or closed) slips back onto it at once (T194)
                modes[c] = ConeMode::Slip;
                let closed = self.closed(modes)?;
                self.project(tau, modes, anchors, &closed)?;
            }
            Watch::Speed => modes[c] = ConeMode::Stick,
        }
        Ok(())
    }

    /// Flip contacts whose indicators are negative at `τ` itself, until none is (the
    /// cascade of simultaneous switches of (T153)).
    pub(super) fn settle(
        &mut self,
        tau: f64,
        modes: &mut [ConeMode],
        anchors: &mut [f64],
    ) -> Result<()> {
        let n = self.law.n;
        for _ in 0..4 * n + 8 {
            let closed = self.closed(modes)?;
            let ind = self.indicators(tau, modes, anchors, &closed)?;
            let worst = ind
                .iter()
                .filter(|v| v.0 < 0.0)
                .min_by(|a, b| a.0.total_cmp(&b.0));
            match worst {
                None => return Ok(()),
                Some(&(_, c, watch)) => {
                    // slip or stick: chosen for all the contacts on the cone's boundary at
                    // once (T193), one contact flipped where that changes nothing
                    if !(matches!(watch, Watch::Cone | Watch::Speed)
                        && self.choose_slip(tau, modes, anchors)?)
                    {
                        self.switch(tau, c, watch, modes, anchors)?;
                    }
                }
            }
        }
        Err(Error::Numerical(format!(
            "friction cone: the modes do not settle at τ = {tau} (a cycle of switches)"
        )))
    }
}
