//! Coulomb friction on massless contact nodes, in contact coordinates (docs/theory.md §20,
//! (T150)–(T160), (T180)–(T181)): the rate-independent law that maps the free-gap signal `γ(τ)` of one
//! period to the periodic contact forces `λ(τ)`, their exact Fourier coefficients `λ̂` and
//! the derivative `∂λ̂/∂γ̂`.
//!
//! Each contact has a normal and one tangential coordinate (plane problems), ordered
//! `[normals; tangents]`, and is open, stuck at an anchor (its tangential displacement when
//! it stuck), or slipping in one direction ([`Mode`]). For a fixed mode of every contact
//! the forces are affine in the free gap and the anchors (T152), so between the instants
//! where a mode changes the forces are trigonometric polynomials and the Fourier integrals
//! are exact Gram blocks, as for frictionless contact (§6). The instants are the first
//! roots of the mode's validity indicators (T153), located cell by cell with the scan of
//! the frictionless quadrature; a contact that sticks takes its tangential displacement of
//! that instant as its anchor (T154). The state at `τ = 0` is found as the fixed point of
//! one period's march (T156), with the convention (T157) for contacts that stay stuck all
//! period. The derivative follows the anchors' sensitivities through the period (T155) and
//! the fixed point (T158); the interval ends drop out because `λ` is continuous in time.

// the small dense matrices of the law are indexed as the equations write them
#![allow(clippy::needless_range_loop)]

mod centring;
pub mod cone;
mod march;
mod modes;

use std::f64::consts::PI;

use faer::Mat;

use crate::contact::lcp::{LcpMatrix, LcpSolver};
use crate::dense::solve_small_lu_columns;
use crate::error::{Error, Result};
use crate::harmonic::{add_interval_gram, basis_into, n_coefficients};
use crate::solution::{ContactState, StateFractions};
pub use march::AnchorEvent;
use std::collections::HashMap;

use march::March;
use modes::ModeCache;
pub use modes::MODE_CACHE_BYTES;

/// The state of one contact (docs/theory.md (T151)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Mode {
    /// Gap open, no force.
    Open,
    /// Closed, the tangential displacement held at the contact's anchor.
    Stick,
    /// Closed, slipping with a positive tangential velocity: `λ_T = −μ λ_N`. A contact
    /// without friction (`μ = 0`) is closed in this mode, with no velocity condition.
    SlipPositive,
    /// Closed, slipping with a negative tangential velocity: `λ_T = +μ λ_N`.
    SlipNegative,
}

/// One interval of constant modes and anchors.
#[derive(Clone, Debug)]
pub struct Phase {
    pub start: f64,
    pub end: f64,
    pub modes: Vec<Mode>,
    /// Anchors of every contact (meaningful for the stuck ones).
    pub anchors: Vec<f64>,
    /// Their sensitivities to `[γ̂, a₀]` (`n × (2n(2H+1) + n)`).
    d_anchors: Vec<f64>,
    data: usize,
}

/// Contacts with Coulomb friction on massless nodes: the Delassus matrix of the normal and
/// tangential contact coordinates and the friction coefficients.
#[derive(Clone, Debug)]
pub struct FrictionalContacts {
    n: usize,
    /// `2n × 2n`, row-major, coordinates `[normals; tangents]` (T150).
    delassus: Vec<f64>,
    mu: Vec<f64>,
    /// The sets of modes earlier marches met (T152), reused by later ones.
    cache: std::cell::RefCell<ModeCache>,
}

/// The periodic contact forces of a free-gap signal (T156).
#[derive(Clone, Debug)]
pub struct PeriodicContact {
    pub harmonics: usize,
    /// `λ̂`, harmonic-major, `2n` per coefficient.
    pub forces: Vec<f64>,
    /// `dλ̂/dγ̂` (square, `2n(2H+1)`, row-major), the fixed point's dependence included.
    pub jacobian: Vec<f64>,
    /// The period cut at the mode changes, in order.
    pub phases: Vec<Phase>,
    /// Marches of one period the fixed point needed.
    pub passes: usize,
    /// The anchors set during the period, in order (the Floquet analysis's jumps, (T182)).
    pub events: Vec<AnchorEvent>,
    gamma: Vec<f64>,
    /// `(F, G, Y_F, Y_G)` of each set of modes met (T152).
    data: Vec<[Vec<f64>; 4]>,
}

/// The last point the safeguarded Newton of the anchors accepted (T156).
struct Accepted {
    anchors: Vec<f64>,
    /// Which rows were periodicity rows (`true`) or centring rows (T157).
    rows: Vec<bool>,
    /// `max_i |r_i / J_ii|`.
    merit: f64,
    /// The Newton step from `anchors` and the fraction of it being tried.
    step: Vec<f64>,
    fraction: f64,
}

/// Relative tolerance of the indicators (T153).
const INDICATOR_TOLERANCE: f64 = 1e-11;

/// Passes of one period before the fixed point of the state at `τ = 0` is given up.
const MAX_PASSES: usize = 100;

impl Phase {
    fn of(
        start: f64,
        end: f64,
        modes: &[Mode],
        anchors: &[f64],
        d_anchors: &[f64],
        data: usize,
    ) -> Self {
        Phase {
            start,
            end,
            modes: modes.to_vec(),
            anchors: anchors.to_vec(),
            d_anchors: d_anchors.to_vec(),
            data,
        }
    }
}

impl FrictionalContacts {
    /// `delassus` is `2n × 2n` row-major in the coordinates `[normals; tangents]`, `mu` the
    /// `n` friction coefficients (finite, non-negative).
    pub fn new(delassus: Vec<f64>, mu: Vec<f64>) -> Result<Self> {
        let n = mu.len();
        if delassus.len() != 4 * n * n {
            return Err(Error::Numerical(format!(
                "friction: the Delassus matrix has {} entries, 4n² = {} expected for {n} contacts",
                delassus.len(),
                4 * n * n
            )));
        }
        if let Some(c) = mu.iter().position(|m| !(m.is_finite() && *m >= 0.0)) {
            return Err(Error::Numerical(format!(
                "friction: the friction coefficient of contact {c} is {} (finite and ≥ 0 expected)",
                mu[c]
            )));
        }
        Ok(FrictionalContacts {
            n,
            delassus,
            mu,
            cache: Default::default(),
        })
    }

    pub fn contacts(&self) -> usize {
        self.n
    }

    /// The friction coefficients.
    pub fn mu(&self) -> &[f64] {
        &self.mu
    }

    fn d(&self, i: usize, j: usize) -> f64 {
        self.delassus[i * 2 * self.n + j]
    }

    /// The state at `τ = 0` without friction forces: the normal LCP on `D_NN`, closed
    /// contacts stuck where they are (T156).
    fn initial_state(&self, gamma0: &[f64]) -> Result<(Vec<Mode>, Vec<f64>)> {
        let n = self.n;
        let dnn: Vec<f64> = (0..n * n).map(|k| self.d(k / n, k % n)).collect();
        let solution = LcpSolver::new(LcpMatrix::new(n, dnn))
            .solve(&gamma0[..n])
            .map_err(|e| Error::Numerical(format!("friction: initial state: {e}")))?;
        let modes = (0..n)
            .map(|c| match (solution.active[c], self.mu[c] > 0.0) {
                (false, _) => Mode::Open,
                (true, true) => Mode::Stick,
                (true, false) => Mode::SlipPositive,
            })
            .collect();
        let anchors = (0..n)
            .map(|c| {
                gamma0[n + c]
                    + (0..n)
                        .map(|k| self.d(n + c, k) * solution.lambda[k])
                        .sum::<f64>()
            })
            .collect();
        Ok((modes, anchors))
    }

    /// The periodic contact forces for the free gap with coefficients `gamma` (harmonic-major,
    /// `2n` per coefficient, `harmonics` harmonics), with switching times located on a grid
    /// of `cells` cells (T153), and their derivative (T155), (T158).
    pub fn periodic(
        &self,
        harmonics: usize,
        gamma: &[f64],
        cells: usize,
    ) -> Result<PeriodicContact> {
        let mut cache = self.cache.take();
        if cache.bytes() > MODE_CACHE_BYTES {
            cache = ModeCache::default();
        }
        let mut march = March::new(self, harmonics, gamma, cells.max(1), cache);
        let result = self.periodic_march(&mut march);
        self.cache.replace(march.into_cache());
        result
    }

    /// [`FrictionalContacts::periodic`] with `march`, whose sets of modes may hold earlier
    /// marches' (T156)–(T158).
    fn periodic_march(&self, march: &mut March) -> Result<PeriodicContact> {
        let (harmonics, gamma) = (march.harmonics, march.gamma);
        let (n, m) = (self.n, 2 * self.n);
        let ncoef = n_coefficients(harmonics);
        if gamma.len() != m * ncoef {
            return Err(Error::Numerical(format!(
                "friction: {} free-gap coefficients, {} expected",
                gamma.len(),
                m * ncoef
            )));
        }
        if gamma.iter().any(|v| !v.is_finite()) {
            return Err(Error::Numerical(
                "friction: the free gap is not finite".into(),
            ));
        }
        let mut gamma0 = vec![0.0; m];
        let b0 = {
            let mut b = vec![0.0; ncoef];
            basis_into(harmonics, 0.0, &mut b);
            b
        };
        for k in 0..ncoef {
            for r in 0..m {
                gamma0[r] += b0[k] * gamma[k * m + r];
            }
        }
        let (mut modes0, mut anchors0) = self.initial_state(&gamma0)?;
        let scale = gamma
            .iter()
            .fold(0.0f64, |s, v| s.max(v.abs()))
            .max(f64::MIN_POSITIVE);
        let mut accepted: Option<Accepted> = None;
        for pass in 1..=MAX_PASSES {
            let out = march.run(&modes0, &anchors0)?;
            if out.modes_end != modes0 {
                modes0 = out.modes_end.clone();
                anchors0 = out.anchors_end.clone();
                accepted = None;
                continue;
            }
            // (T156)–(T158): residual of the stuck contacts' anchors at τ = 0
            let nu = m * ncoef;
            let nv = nu + n;
            let stuck: Vec<usize> = (0..n).filter(|&c| modes0[c] == Mode::Stick).collect();
            let ns = stuck.len();
            let mut residual = vec![0.0; ns];
            let mut j_a = vec![0.0; ns * ns];
            let mut r_u = Mat::<f64>::zeros(ns, nu);
            for (i, &c) in stuck.iter().enumerate() {
                if out.released[c] {
                    residual[i] = anchors0[c] - out.anchors_end[c];
                    for (l, &c2) in stuck.iter().enumerate() {
                        j_a[i * ns + l] =
                            f64::from(u8::from(i == l)) - out.d_anchors_end[c * nv + nu + c2];
                    }
                    for col in 0..nu {
                        r_u[(i, col)] = -out.d_anchors_end[c * nv + col];
                    }
                } else {
                    // (T157): a contact stuck all period is centred in its cone
                    let (value, row) = march.centring(&out.phases, c);
                    residual[i] = value;
                    for (l, &c2) in stuck.iter().enumerate() {
                        j_a[i * ns + l] = row[nu + c2];
                    }
                    for col in 0..nu {
                        r_u[(i, col)] = row[col];
                    }
                }
            }
            let mut rhs = Mat::<f64>::zeros(ns, nu + 1);
            for i in 0..ns {
                rhs[(i, 0)] = residual[i];
                for col in 0..nu {
                    rhs[(i, col + 1)] = r_u[(i, col)];
                }
            }
            let solved = if ns == 0 {
                Mat::zeros(0, nu + 1)
            } else {
                solve_small_lu_columns(&j_a, rhs.as_ref(), 1e-13).map_err(|_| {
                    Error::Singular(
                        "friction: the periodicity of the stuck contacts' anchors is singular"
                            .into(),
                    )
                })?
            };
            let step = (0..ns).fold(0.0f64, |s, i| s.max(solved[(i, 0)].abs()));
            let size = anchors0.iter().fold(scale, |s, a| s.max(a.abs()));
            // the merit in anchor units: each row's residual over its diagonal
            let merit = (0..ns).fold(0.0f64, |s, i| {
                let d = j_a[i * ns + i];
                s.max(if d != 0.0 {
                    (residual[i] / d).abs()
                } else {
                    residual[i].abs()
                })
            });
            let tolerance = 1e-12 * size;
            let converged = step <= tolerance || merit <= tolerance;
            if !converged && pass < MAX_PASSES {
                let rows: Vec<bool> = stuck.iter().map(|&c| out.released[c]).collect();
                if let Some(a) = accepted.as_mut().filter(|a| a.rows == rows) {
                    if merit > (1.0 - 1e-4 * a.fraction) * a.merit && a.fraction > 1e-6 {
                        // no decrease with the same rows: a kink of (T157) between the two
                        // points (its extreme instants jumped); halve the step
                        a.fraction *= 0.5;
                        for (i, &c) in stuck.iter().enumerate() {
                            anchors0[c] = a.anchors[c] - a.fraction * a.step[i];
                        }
                        continue;
                    }
                }
                let step: Vec<f64> = (0..ns).map(|i| solved[(i, 0)]).collect();
                let base = anchors0.clone();
                for (i, &c) in stuck.iter().enumerate() {
                    anchors0[c] -= step[i];
                }
                accepted = Some(Accepted {
                    anchors: base,
                    rows,
                    merit,
                    step,
                    fraction: 1.0,
                });
                continue;
            }
            {
                if !converged {
                    return Err(Error::Numerical(format!(
                        "friction: no periodic contact state after {MAX_PASSES} periods (anchor change {step:e})"
                    )));
                }
                // (T155) over the periodic state's phases
                let (forces, d_forces) = march.accumulate(&out.phases);
                // (T158): dλ̂/dγ̂ = ∂λ̂/∂γ̂ − ∂λ̂/∂a₀ J_a⁻¹ ∂r/∂γ̂
                let mut jacobian = vec![0.0; nu * nu];
                for row in 0..nu {
                    for col in 0..nu {
                        let mut v = d_forces[row * nv + col];
                        for (l, &c2) in stuck.iter().enumerate() {
                            v -= d_forces[row * nv + nu + c2] * solved[(l, col + 1)];
                        }
                        jacobian[row * nu + col] = v;
                    }
                }
                // the sets of modes this state uses, renumbered (the march's cache holds
                // earlier evaluations' too)
                let (mut phases, mut events) = (out.phases, out.events);
                let mut renumbered: HashMap<usize, usize> = HashMap::new();
                let mut data = Vec::new();
                let slots = phases
                    .iter_mut()
                    .map(|p| &mut p.data)
                    .chain(events.iter_mut().map(|e| &mut e.data));
                for slot in slots {
                    *slot = *renumbered.entry(*slot).or_insert_with(|| {
                        let d = &march.data[*slot];
                        data.push([d.f.clone(), d.g.clone(), d.yf.clone(), d.yg.clone()]);
                        data.len() - 1
                    });
                }
                return Ok(PeriodicContact {
                    harmonics,
                    forces,
                    jacobian,
                    phases,
                    passes: pass,
                    events,
                    gamma: gamma.to_vec(),
                    data,
                });
            }
        }
        Err(Error::Numerical(format!(
            "friction: the contact modes at τ = 0 did not repeat within {MAX_PASSES} periods"
        )))
    }
}

impl PeriodicContact {
    /// The contact forces `λ(τ)` (`[normals; tangents]`) of the periodic state.
    pub fn force_at(&self, tau: f64) -> Vec<f64> {
        self.state_at(tau).0
    }

    /// The forces `λ(τ)` and the contact coordinates `y(τ) = γ(τ) + D λ(τ)` (the gaps, then
    /// the tangential displacements) of the periodic state (T152).
    pub fn state_at(&self, tau: f64) -> (Vec<f64>, Vec<f64>) {
        let ncoef = n_coefficients(self.harmonics);
        let m = self.gamma.len() / ncoef;
        let n = m / 2;
        let tau = tau.rem_euclid(2.0 * PI);
        let phase = self.phase_at(tau);
        let [f, g, yf, yg] = &self.data[phase.data];
        let mut b = vec![0.0; ncoef];
        basis_into(self.harmonics, tau, &mut b);
        let gamma_at: Vec<f64> = (0..m)
            .map(|r| (0..ncoef).map(|k| b[k] * self.gamma[k * m + r]).sum())
            .collect();
        let affine = |a: &[f64], ga: &[f64]| -> Vec<f64> {
            (0..m)
                .map(|i| {
                    (0..m).map(|r| a[i * m + r] * gamma_at[r]).sum::<f64>()
                        + (0..n)
                            .map(|c| ga[i * n + c] * phase.anchors[c])
                            .sum::<f64>()
                })
                .collect()
        };
        (affine(f, g), affine(yf, yg))
    }

    /// The phase that holds `τ` (taken modulo the period).
    fn phase_at(&self, tau: f64) -> &Phase {
        let tau = tau.rem_euclid(2.0 * PI);
        self.phases
            .iter()
            .find(|p| tau >= p.start && tau <= p.end)
            .unwrap_or(&self.phases[self.phases.len() - 1])
    }

    /// `(F, G)` of `phase`'s modes (T152): `λ = F γ + G a`, `2n × 2n` and `2n × n`,
    /// row-major.
    pub fn force_maps(&self, phase: &Phase) -> (&[f64], &[f64]) {
        let [f, g, _, _] = &self.data[phase.data];
        (f, g)
    }

    /// `(F, G)` of the modes before the switches of `event` (T152).
    pub fn force_maps_before(&self, event: &AnchorEvent) -> (&[f64], &[f64]) {
        let [f, g, _, _] = &self.data[event.data];
        (f, g)
    }

    /// The mode set of `phase` (an index shared by the phases and events with equal modes).
    pub fn mode_set(phase: &Phase) -> usize {
        phase.data
    }

    /// The mode set before the switches of `event`.
    pub fn mode_set_before(event: &AnchorEvent) -> usize {
        event.data
    }

    /// The modes of every contact at `τ`.
    pub fn modes_at(&self, tau: f64) -> &[Mode] {
        &self.phase_at(tau).modes
    }

    /// The energy the friction forces dissipate over one period, `−∮ λ_Tᵀ dy_T`, exactly:
    /// per slip phase the product of the tangential force's and velocity's trigonometric
    /// polynomials integrated with the phase's Gram block (docs/theory.md (T180)).
    pub fn dissipated_energy(&self) -> f64 {
        let h = self.harmonics;
        let ncoef = n_coefficients(h);
        let m = self.gamma.len() / ncoef;
        let n = m / 2;
        let mut gram = vec![0.0; ncoef * ncoef];
        let mut total = 0.0;
        for phase in &self.phases {
            let slipping: Vec<usize> = (0..n)
                .filter(|&c| matches!(phase.modes[c], Mode::SlipPositive | Mode::SlipNegative))
                .collect();
            if slipping.is_empty() || phase.end <= phase.start {
                continue;
            }
            gram.iter_mut().for_each(|g| *g = 0.0);
            add_interval_gram(h, phase.start, phase.end, &mut gram);
            let [f, g, yf, _] = &self.data[phase.data];
            for &c in &slipping {
                let row = n + c;
                // the force's and the displacement's coefficients in this phase (T180)
                let mut u: Vec<f64> = (0..ncoef)
                    .map(|k| (0..m).map(|r| f[row * m + r] * self.gamma[k * m + r]).sum())
                    .collect();
                u[0] += (0..n)
                    .map(|j| g[row * n + j] * phase.anchors[j])
                    .sum::<f64>();
                let v: Vec<f64> = (0..ncoef)
                    .map(|k| {
                        (0..m)
                            .map(|r| yf[row * m + r] * self.gamma[k * m + r])
                            .sum()
                    })
                    .collect();
                let mut dv = vec![0.0; ncoef];
                for k in 1..=h {
                    dv[2 * k - 1] = k as f64 * v[2 * k];
                    dv[2 * k] = -(k as f64) * v[2 * k - 1];
                }
                for (a, ua) in u.iter().enumerate() {
                    let weight = if a == 0 { 1.0 } else { 2.0 };
                    let row_sum: f64 = (0..ncoef).map(|k| gram[a * ncoef + k] * dv[k]).sum();
                    total -= 2.0 * PI * ua * row_sum / weight;
                }
            }
        }
        total
    }

    /// The fraction of the period each contact spends stuck, slipping and open, exact from
    /// the located switches (docs/theory.md (T181)); a closed contact without friction
    /// counts as slipping.
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
                    Mode::Open => o.open += share,
                    Mode::Stick => o.stick += share,
                    Mode::SlipPositive | Mode::SlipNegative => o.slip += share,
                }
            }
        }
        out
    }
}

impl From<Mode> for ContactState {
    fn from(mode: Mode) -> Self {
        match mode {
            Mode::Open => ContactState::Open,
            Mode::Stick => ContactState::Stick,
            Mode::SlipPositive | Mode::SlipNegative => ContactState::Slip,
        }
    }
}

#[cfg(test)]
mod tests;
