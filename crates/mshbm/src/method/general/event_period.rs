//! Event-driven integration of the frictionless N-subsystem over one period, with the
//! sensitivities of its samples and end state (docs/theory.md (T143)–(T147)).
//!
//! Between events the state is the closed-form flow of the active set ([`SetFlow`]):
//! `s(θ) = s_p(θ) + Re V e^{Λ(θ−θ_a)} c`, the periodic particular part plus modes. Events —
//! an open contact's gap reaching zero, a closed contact's force reaching zero — are found
//! by scanning the closed-form gaps and forces on a grid finer than the fastest mode and
//! the highest harmonic, and located to the last bit by bisection
//! ([`crate::roots::find_sign_change`]). An impact applies Newton's law (with `e_N = 0` the
//! plastic impact of (T144), after which the contact stays closed while its force is
//! non-negative); a release changes the set without a jump. Contact 0's impact nearest its
//! critical time `θ_c` ([`CriticalTime`], (T147)) is not located: the law is applied at
//! `θ_c` itself. A contact that has just left the stop is armed (its impacts located) from
//! where its gap first exceeds the tolerance, its peak found within the scan step (T147a),
//! so that a re-impact is located wherever the scan's grid falls.
//!
//! Sensitivities `S(θ) = ∂x(θ)/∂p`, `p = (φ, x_0, θ_c)` (the load's coefficients, the
//! initial state, the critical time), follow the same closed form between events and the
//! saltation matrix (T145) at impacts; at a release the vector fields agree and `S` is
//! continuous; at `θ_c` the jump `J` and the column `J f⁻ − f⁺`.

use std::cell::RefCell;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use faer::{c64, Mat};

use super::set_flow::{DenseSubsystem, SetFlow};
use crate::dense::mat_vec;
use crate::error::Result;

mod march;
mod sample;

use sample::modal_exponentials;

pub(super) use march::integrate;

/// Events allowed in one period before the integration gives up (impacts with `e_N > 0`
/// that accumulate: chatter).
pub(super) const MAX_EVENTS: usize = 10_000;

/// Scan steps allowed in one period before the integration gives up (a frequency many
/// orders of magnitude below the nonlinear subsystem's fastest mode, which only a wild
/// Newton update asks for: the scan needs `8 ω_max/ω` steps per period).
pub(super) const MAX_SCAN_STEPS: usize = 10_000_000;

/// The flows of the active sets met so far (shared by parallel evaluations).
#[derive(Default)]
pub(super) struct FlowCache {
    flows: Mutex<HashMap<Vec<usize>, Arc<SetFlow>>>,
}

impl FlowCache {
    fn get(&self, sub: &DenseSubsystem, closed: &[usize]) -> Result<Arc<SetFlow>> {
        if let Some(f) = self.flows.lock().expect("flow cache").get(closed) {
            return Ok(f.clone());
        }
        let flow = Arc::new(SetFlow::new(sub, closed)?);
        self.flows
            .lock()
            .expect("flow cache")
            .insert(closed.to_vec(), flow.clone());
        Ok(flow)
    }
}

/// One period of the N-subsystem in the section frame (`θ ∈ [0, T]`).
pub(super) struct EventPeriod {
    /// `q(θ_j)` at the samples `θ_j = θ_off + jT/N_s` (rows of `n`).
    pub samples: Vec<f64>,
    /// Gaps at the samples (rows of `n_contacts`).
    pub gaps: Vec<f64>,
    /// Contact forces at the samples (rows of `n_contacts`; impulses of impacts excluded).
    pub forces: Vec<f64>,
    pub end_q: Vec<f64>,
    pub end_v: Vec<f64>,
    /// `∂q(θ_j)/∂p` (rows `j·n + i`, `p = (φ, q_0, q̇_0)`), when asked for.
    pub sample_sensitivity: Option<Mat<f64>>,
    /// `∂(q, q̇)(T)/∂p` (`2n × p`), when asked for.
    pub end_sensitivity: Option<Mat<f64>>,
    /// Number of events (impacts and releases).
    pub events: usize,
    /// Contact 0 at the critical time, when there is one and it was reached.
    pub critical: Option<CriticalState>,
    /// The time of contact 0's first impact located by the scan, if any.
    pub first_impact: Option<f64>,
}

/// What one integration needs.
pub(super) struct EventProblem<'a> {
    pub sub: &'a DenseSubsystem,
    pub flows: &'a FlowCache,
    pub harmonics: usize,
    pub omega: f64,
    /// The load's coefficients `φ` (harmonic-major, `n (2H + 1)`) in the section frame.
    pub load: &'a [f64],
    pub restitution: f64,
    pub steps: usize,
    /// Offset of the sample grid, in `[0, T/N_s)`.
    pub sample_offset: f64,
    /// How long to integrate (`T` for a period; samples after it are not taken).
    pub duration: f64,
    /// Gap below which a contact counts as touching (a length ≪ the motion).
    pub gap_tolerance: f64,
    /// Contact 0's critical time (docs/theory.md (T147)), when the unknowns hold one.
    pub critical: Option<CriticalTime>,
    pub sensitivities: bool,
}

/// Contact `0`'s critical time `θ_c` (docs/theory.md (T147)): at `θ_c` its normal velocity
/// is removed (the plastic impact law applied whatever the gap), and in the window
/// `[θ_c − w, θ_c]` before it, and after it until its gap is positive again, its impacts are
/// not located by the scan. The residual's complementarity `min(g, −ġ⁻/ω) = 0` at `θ_c`
/// then makes `θ_c` the impact time of an orbit that reaches the stop and the time of the
/// smallest gap of one that does not, with no square root at grazing.
#[derive(Clone, Copy, Debug)]
pub(super) struct CriticalTime {
    /// `θ_c` in the section frame, in `(0, T)`.
    pub time: f64,
    /// The window `w` before it.
    pub window: f64,
}

/// Contact 0's gap and normal velocity just before `θ_c`, with their sensitivities.
pub(super) struct CriticalState {
    pub gap: f64,
    /// `ġ⁻ = w_0ᵀ q̇(θ_c⁻)`.
    pub rate: f64,
    /// `∂g/∂p` (the last entry `∂g/∂θ_c = ġ⁻`), when asked for.
    pub gap_sensitivity: Vec<f64>,
    /// `∂ġ⁻/∂p` (the last entry `∂ġ⁻/∂θ_c = w_0ᵀ q̈(θ_c⁻)`), when asked for.
    pub rate_sensitivity: Vec<f64>,
}

/// `e^{ikωθ}`, `k = 0..=H`, by recurrence re-anchored every 16 harmonics.
fn phases(omega: f64, theta: f64, out: &mut [c64]) {
    out[0] = c64::new(1.0, 0.0);
    let (s, c) = (omega * theta).sin_cos();
    let step = c64::new(c, s);
    for k in 1..out.len() {
        out[k] = if k % 16 == 0 {
            let (s, c) = (k as f64 * omega * theta).sin_cos();
            c64::new(c, s)
        } else {
            out[k - 1] * step
        };
    }
}

/// An active set at this frequency and load.
struct ActiveSet {
    flow: Arc<SetFlow>,
    /// `X_k` (`2m × n`).
    responses: Vec<Mat<c64>>,
    /// `X_k F̂_k` (`2m`), `F̂_0 = φ_0 − K q̄`, `F̂_k = φ_{c,k} − i φ_{s,k}`.
    particular: Vec<Vec<c64>>,
}

/// The current interval between events.
struct Interval {
    set: usize,
    start: f64,
    /// `V⁻¹ (s_a − s_p(θ_a))`.
    coefficients: Vec<c64>,
    /// `V⁻¹ (Tᵀ S_a − ∂s_p(θ_a)/∂p)` (`2m × p`).
    sensitivity: Mat<c64>,
}

struct Integration<'a> {
    pb: &'a EventProblem<'a>,
    n: usize,
    n_params: usize,
    sets: Vec<ActiveSet>,
    e: Vec<c64>,
    /// Buffers of the scan's and the root finders' evaluations, so that they allocate
    /// nothing (one set per period integration).
    scratch: RefCell<Scratch>,
}

/// The buffers of [`Integration::evaluate`]: the reduced state, the modes' factors, the
/// state `(q, q̇)`, the load and the unbalanced force.
#[derive(Default)]
struct Scratch {
    s: Vec<f64>,
    growth: Vec<c64>,
    q: Vec<f64>,
    v: Vec<f64>,
    f: Vec<f64>,
    r: Vec<f64>,
    /// `∂y(θ)/∂p` of a sample (`m × p`, column-major).
    ds: Vec<f64>,
}

impl<'a> Integration<'a> {
    fn set_index(&mut self, closed: &[usize]) -> Result<usize> {
        if let Some(i) = self.sets.iter().position(|s| s.flow.closed == closed) {
            return Ok(i);
        }
        let flow = self.pb.flows.get(self.pb.sub, closed)?;
        let responses = flow.harmonic_responses(self.pb.omega, self.pb.harmonics)?;
        let n = self.n;
        let particular = responses
            .iter()
            .enumerate()
            .map(|(k, x)| {
                let f: Vec<c64> = (0..n)
                    .map(|i| {
                        if k == 0 {
                            c64::new(self.pb.load[i] - flow.offset_load()[i], 0.0)
                        } else {
                            c64::new(
                                self.pb.load[(2 * k - 1) * n + i],
                                -self.pb.load[2 * k * n + i],
                            )
                        }
                    })
                    .collect();
                (0..x.nrows())
                    .map(|r| (0..n).map(|j| x[(r, j)] * f[j]).sum())
                    .collect()
            })
            .collect();
        self.sets.push(ActiveSet {
            flow,
            responses,
            particular,
        });
        Ok(self.sets.len() - 1)
    }

    /// The load `F(θ)` from the phases `self.e`.
    fn load(&self) -> Vec<f64> {
        self.load_with(&self.e)
    }

    /// The load `F(θ)` for the phases `e` of `θ`.
    fn load_with(&self, e: &[c64]) -> Vec<f64> {
        let n = self.n;
        let phi = self.pb.load;
        let mut f = phi[..n].to_vec();
        for k in 1..e.len() {
            let (c, s) = (e[k].re, e[k].im);
            for (i, fi) in f.iter_mut().enumerate() {
                *fi += c * phi[(2 * k - 1) * n + i] + s * phi[2 * k * n + i];
            }
        }
        f
    }

    /// `s_p(θ)` from the phases `self.e`.
    fn particular(&self, set: usize) -> Vec<f64> {
        self.particular_with(&self.e, set)
    }

    /// `s_p(θ)` for the phases `e` of `θ`.
    fn particular_with(&self, e: &[c64], set: usize) -> Vec<f64> {
        let p = &self.sets[set].particular;
        let m2 = self.sets[set].flow.reduced();
        (0..m2)
            .map(|i| p.iter().zip(e).map(|(pk, e)| (pk[i] * e).re).sum())
            .collect()
    }

    /// `∂s_p(θ)/∂p` (`2m × p`, zero in the initial-state columns) from the phases.
    fn particular_sensitivity(&self, set: usize) -> Mat<f64> {
        let n = self.n;
        let a = &self.sets[set];
        let m2 = a.flow.reduced();
        let mut out = Mat::<f64>::zeros(m2, self.n_params);
        for (k, x) in a.responses.iter().enumerate() {
            for j in 0..n {
                for i in 0..m2 {
                    let v = x[(i, j)] * self.e[k];
                    if k == 0 {
                        out[(i, j)] = v.re;
                    } else {
                        out[(i, (2 * k - 1) * n + j)] = v.re;
                        out[(i, 2 * k * n + j)] = v.im;
                    }
                }
            }
        }
        out
    }

    /// Set the phases to `θ`.
    fn at(&mut self, theta: f64) {
        phases(self.pb.omega, theta, &mut self.e);
    }

    /// The full state at `θ` (phases already at `θ`).
    fn state(&self, iv: &Interval, theta: f64) -> (Vec<f64>, Vec<f64>) {
        self.state_with(&self.e, iv, theta)
    }

    /// The full state at `θ` for its phases `e`.
    fn state_with(&self, e: &[c64], iv: &Interval, theta: f64) -> (Vec<f64>, Vec<f64>) {
        let a = &self.sets[iv.set];
        let mut s = self.particular_with(e, iv.set);
        let tau = theta - iv.start;
        let v = a.flow.modes();
        let mut growth = Vec::with_capacity(iv.coefficients.len());
        modal_exponentials(&a.flow.eigenvalues, tau, &mut growth);
        for (g, c) in growth.iter_mut().zip(&iv.coefficients) {
            *g = c * *g;
        }
        for (i, si) in s.iter_mut().enumerate() {
            *si += growth
                .iter()
                .enumerate()
                .map(|(m, g)| (v[(i, m)] * g).re)
                .sum::<f64>();
        }
        let (mut q, mut qd) = (vec![0.0; self.n], vec![0.0; self.n]);
        a.flow.expand(&s, &mut q, &mut qd);
        (q, qd)
    }

    /// The full-state sensitivity at `θ` (`2n × p`; phases already at `θ`).
    fn sensitivity(&self, iv: &Interval, theta: f64) -> Mat<f64> {
        let a = &self.sets[iv.set];
        let mut ds = self.particular_sensitivity(iv.set);
        let tau = theta - iv.start;
        let v = a.flow.modes();
        let m2 = a.flow.reduced();
        let mut growth = Vec::with_capacity(a.flow.eigenvalues.len());
        modal_exponentials(&a.flow.eigenvalues, tau, &mut growth);
        for i in 0..m2 {
            for j in 0..self.n_params {
                let mut acc = 0.0;
                for (m, g) in growth.iter().enumerate() {
                    acc += (v[(i, m)] * g * iv.sensitivity[(m, j)]).re;
                }
                ds[(i, j)] += acc;
            }
        }
        a.flow.expand_rows(&ds)
    }

    /// Start an interval of set `set` at `θ` from the state `(q, v)` and its sensitivity
    /// (phases already at `θ`).
    fn start(&self, set: usize, theta: f64, q: &[f64], v: &[f64], sens: &Mat<f64>) -> Interval {
        let a = &self.sets[set];
        let s = a.flow.reduce(q, v);
        let sp = self.particular(set);
        let vinv = a.flow.modes_inv();
        let m2 = a.flow.reduced();
        let d: Vec<f64> = s.iter().zip(&sp).map(|(a, b)| a - b).collect();
        let coefficients = (0..m2)
            .map(|i| (0..m2).map(|j| vinv[(i, j)] * d[j]).sum())
            .collect();
        let sensitivity = if self.pb.sensitivities {
            let ds = a.flow.reduce_rows(sens) - self.particular_sensitivity(set);
            Mat::<c64>::from_fn(m2, self.n_params, |i, k| {
                (0..m2).map(|j| vinv[(i, j)] * ds[(j, k)]).sum()
            })
        } else {
            Mat::<c64>::zeros(0, 0)
        };
        Interval {
            set,
            start: theta,
            coefficients,
            sensitivity,
        }
    }

    /// The state `(q, q̇)` at `θ` for its phases `e` into `sc.q`, `sc.v` (as
    /// [`Integration::state_with`], without allocating).
    fn evaluate(&self, e: &[c64], iv: &Interval, theta: f64, sc: &mut Scratch) {
        let a = &self.sets[iv.set];
        let m2 = a.flow.reduced();
        sc.s.clear();
        let p = &a.particular;
        sc.s.extend((0..m2).map(|i| p.iter().zip(e).map(|(pk, e)| (pk[i] * e).re).sum::<f64>()));
        let tau = theta - iv.start;
        modal_exponentials(&a.flow.eigenvalues, tau, &mut sc.growth);
        for (g, c) in sc.growth.iter_mut().zip(&iv.coefficients) {
            *g = c * *g;
        }
        let v = a.flow.modes();
        for (i, si) in sc.s.iter_mut().enumerate() {
            *si += sc
                .growth
                .iter()
                .enumerate()
                .map(|(m, g)| (v[(i, m)] * g).re)
                .sum::<f64>();
        }
        a.flow.expand(&sc.s, &mut sc.q, &mut sc.v);
    }

    /// The load `F(θ)` for the phases `e` into `f`.
    fn load_into(&self, e: &[c64], f: &mut [f64]) {
        let n = self.n;
        let phi = self.pb.load;
        f.copy_from_slice(&phi[..n]);
        for k in 1..e.len() {
            let (c, s) = (e[k].re, e[k].im);
            for (i, fi) in f.iter_mut().enumerate() {
                *fi += c * phi[(2 * k - 1) * n + i] + s * phi[2 * k * n + i];
            }
        }
    }

    /// The unbalanced force `r = F − K q − C q̇` of the state in `sc` into `sc.r`.
    fn unbalanced_into(&self, e: &[c64], sc: &mut Scratch) {
        self.load_into(e, &mut sc.f);
        let sub = self.pb.sub;
        let n = self.n;
        for i in 0..n {
            sc.r[i] = sc.f[i]
                - (0..n)
                    .map(|j| sub.stiffness[(i, j)] * sc.q[j] + sub.damping[(i, j)] * sc.v[j])
                    .sum::<f64>();
        }
    }

    /// The value of contact `c`'s event function in the interval at `θ` (phases `e`): its
    /// gap when open, its force when closed.
    fn monitor_with(&self, e: &[c64], iv: &Interval, theta: f64, c: usize) -> f64 {
        let mut sc = self.scratch.borrow_mut();
        self.evaluate(e, iv, theta, &mut sc);
        let flow = &self.sets[iv.set].flow;
        match flow.closed.iter().position(|&k| k == c) {
            None => self.pb.sub.gap(c, &sc.q),
            Some(r) => {
                self.unbalanced_into(e, &mut sc);
                flow.contact_force(r, &sc.r)
            }
        }
    }

    /// Every contact's event function at `θ` (phases already at `θ`) into `values`, and
    /// the rates of the open contacts' gaps (zero for the closed ones) into `rates`.
    fn monitors_into(
        &self,
        iv: &Interval,
        theta: f64,
        values: &mut Vec<f64>,
        rates: &mut Vec<f64>,
    ) {
        let mut sc = self.scratch.borrow_mut();
        self.evaluate(&self.e, iv, theta, &mut sc);
        let flow = &self.sets[iv.set].flow;
        if !flow.closed.is_empty() {
            self.unbalanced_into(&self.e, &mut sc);
        }
        values.clear();
        rates.clear();
        for c in 0..self.pb.sub.n_contacts() {
            match flow.closed.iter().position(|&k| k == c) {
                None => {
                    values.push(self.pb.sub.gap(c, &sc.q));
                    rates.push(self.pb.sub.normal_velocity(c, &sc.v));
                }
                Some(r) => {
                    values.push(flow.contact_force(r, &sc.r));
                    rates.push(0.0);
                }
            }
        }
    }

    /// The rate `w_cᵀ q̇` of open contact `c`'s gap at `θ` (phases `e`).
    fn gap_rate_with(&self, e: &[c64], iv: &Interval, theta: f64, c: usize) -> f64 {
        let mut sc = self.scratch.borrow_mut();
        self.evaluate(e, iv, theta, &mut sc);
        self.pb.sub.normal_velocity(c, &sc.v)
    }

    /// The largest scan step in set `set`: an eighth of the fastest mode's and of the
    /// highest harmonic's period.
    fn scan_step(&self, set: usize) -> f64 {
        let fastest = self.sets[set]
            .flow
            .fastest()
            .max(self.pb.harmonics as f64 * self.pb.omega);
        2.0 * std::f64::consts::PI / (8.0 * fastest)
    }

    /// The closed set after a plastic impact on `set` at state `(q, v⁺)` (phases at the
    /// event): contacts whose force would pull are released, most negative first.
    fn settle(&mut self, mut set: Vec<usize>, q: &[f64], v: &[f64]) -> Result<(usize, Vec<usize>)> {
        let f = self.load();
        let r = self.pb.sub.unbalanced_force(&f, q, v);
        let mut released = vec![];
        loop {
            let i = self.set_index(&set)?;
            let lambda = self.sets[i].flow.contact_forces(&r);
            let worst = (0..lambda.len()).fold(None, |b: Option<usize>, k| {
                if lambda[k] < 0.0 && b.is_none_or(|b| lambda[k] < lambda[b]) {
                    Some(k)
                } else {
                    b
                }
            });
            match worst {
                None => return Ok((i, released)),
                Some(k) => released.push(set.remove(k)),
            }
        }
    }
}

/// The state just before an event, with what the event's jump and its sensitivity need.
struct Before {
    q: Vec<f64>,
    v: Vec<f64>,
    /// `S⁻` (empty without sensitivities).
    sensitivity: Mat<f64>,
    load: Vec<f64>,
    acceleration: Vec<f64>,
}

impl Integration<'_> {
    /// The state of interval `iv` just before an event at `θ` (the phases set to `θ`).
    fn before_event(&mut self, iv: &Interval, theta: f64) -> Before {
        self.at(theta);
        let (q, v) = self.state(iv, theta);
        let sensitivity = if self.pb.sensitivities {
            self.sensitivity(iv, theta)
        } else {
            Mat::<f64>::zeros(0, 0)
        };
        let load = self.load();
        let acceleration = self.sets[iv.set]
            .flow
            .acceleration(&self.pb.sub.unbalanced_force(&load, &q, &v));
        Before {
            q,
            v,
            sensitivity,
            load,
            acceleration,
        }
    }

    /// Newton's impact law and the impact equation (paper eqs. 19–20) on contact `c` at the
    /// state `(q, v⁻)` of the interval of set
    /// `current` (closed contacts `closed`; phases at the event): with `e_N = 0` the
    /// plastic impact (T144) on `closed ∪ {c}` followed by the release of contacts whose
    /// force would pull ([`Integration::settle`]; released contacts disarmed), with
    /// `e_N > 0` contact `c`'s normal velocity reversed and scaled, the set unchanged.
    /// Returns the set after the impact and the velocity map `P` (`q̇⁺ = P q̇⁻`).
    fn impact(
        &mut self,
        current: usize,
        closed: &[usize],
        c: usize,
        (q, v): (&[f64], &[f64]),
        armed: &mut [bool],
    ) -> Result<(usize, Mat<f64>)> {
        let sub = self.pb.sub;
        if self.pb.restitution == 0.0 {
            let mut set = closed.to_vec();
            set.push(c);
            set.sort_unstable();
            let p = sub.impact_projector(&set)?;
            let (index, released) = self.settle(set, q, &mat_vec(&p, v))?;
            for k in released {
                armed[k] = false;
            }
            return Ok((index, p));
        }
        let p1 = sub.impact_projector(&[c])?;
        let e = self.pb.restitution;
        let p = Mat::<f64>::from_fn(self.n, self.n, |i, j| {
            let id = if i == j { 1.0 } else { 0.0 };
            id - (1.0 + e) * (id - p1[(i, j)])
        });
        armed[c] = false;
        Ok((current, p))
    }
}

/// The sensitivity after a jump `J = diag(I, P)` at a fixed time: `J S⁻`.
fn jump_sensitivity(p: &Mat<f64>, before: &Mat<f64>) -> Mat<f64> {
    let n = p.nrows();
    let mut after = Mat::<f64>::zeros(2 * n, before.ncols());
    for j in 0..before.ncols() {
        for i in 0..n {
            after[(i, j)] = before[(i, j)];
            after[(n + i, j)] = (0..n).map(|k| p[(i, k)] * before[(n + k, j)]).sum();
        }
    }
    after
}
