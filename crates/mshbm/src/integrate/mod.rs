//! Reference time integration of `M q'' + C q' + K q = f(t) + W λ` with unilateral contacts
//! (METHODS §3.1–§3.2), run for a given time or to a periodic steady state — the paper's
//! baseline for the MS-HBM (Figs. 5 and 9).
//!
//! Two schemes ([`Scheme`]):
//!
//! * **Moreau–Jean θ-scheme** ([`Scheme::MoreauJean`], METHODS §3.1): velocity level,
//!   impulses per step, Newton's impact law `0 ≤ U⁺ + e U⁻ ⊥ P ≥ 0` on the contacts that are
//!   closed at the predicted position `q_k + h(1−θ) v_k`. The iteration matrix
//!   `M̂ = M + hθC + h²θ²K` is factored once. With the consistent mass this is the paper's
//!   reference ("original mass matrix, e_N = 0"). On a singular (redistributed) mass it is
//!   only stable for `θ > ½` (METHODS §3.2: the massless rows become a trapezoidal average
//!   of an algebraic equation, with a parasitic `(−1)^k` mode), so `θ = ½` is refused there.
//! * **Position-level Newmark** ([`Scheme::PositionNewmark`], METHODS §3.2, Khenous-type):
//!   average acceleration (β = ¼, γ = ½) on a mass with a massless contact boundary, with
//!   Signorini imposed on the positions at the end of the step (no impact law):
//!   `Â = (4/h²) M + (2/h) C + K` (factored once, positive definite even for a free body),
//!   `u_free = Â⁻¹ b`, `0 ≤ g = Wᵀ(u_free + Â⁻¹ W λ) + g0 ⊥ λ ≥ 0`. The gap is never
//!   negative and, without damping and forcing, the energy is conserved through the impacts.
//!   Needs every contact DOF massless and damping that does not act on the massless DOFs
//!   (`C_NN = C_NL = 0`, as the redistributed MS-HBM).
//!
//! **Coulomb friction** (METHODS §3.3, Moreau–Jean only): friction elements
//! ([`crate::model::Friction`]) add tangential impulses `P_T` along their direction `w_T`
//! with `|P_T| ≤ h μ F_N` (prescribed normal force, always active) or `|P_T| ≤ μ P_N`
//! (normal force of a unilateral contact, active while that contact is in the index set),
//! and the law `P_T ∈ −bound · Sign(γ_T⁺)` on the post-step slip velocity `γ_T⁺ = w_Tᵀ v_{k+1}`
//! (`e_T = 0`). The impulses of one step solve the proximal equations
//! `P_N = prox_{ℝ≥0}(P_N − r ξ_N)`, `P_T = prox_{[−b, b]}(P_T − r γ_T)` by Gauss–Seidel
//! sweeps with `r_i = 1/G_ii` (each row solved exactly given the others, so a single
//! element is exact in one sweep: stick `P_T = −γ_free/G_TT` when `|γ_free/G_TT| ≤ b`, slip
//! `−b sign γ_free` otherwise), then the stick/slip/contact status found is *polished* by
//! one exact linear solve (kept when it satisfies every law), so stick/slip is exact per
//! step. `|P_T| ≤ b` holds exactly (clamped). [`Integrator::friction_forces`] reports
//! `P_T/h`.
//!
//! **Periodic load** ([`Integrator::set_periodic_load`]): a trigonometric polynomial load
//! `Σ_c F_c b_c(ωt)` can be added to `f(t)` — the coupling force of the linear subsystem on
//! the nonlinear one in the general MS-HBM (paper eq. 10).
//!
//! The per-step LCP is solved by the same exact solver as the MS-HBM
//! ([`crate::contact::lcp::LcpSolver`]). Massless DOFs carry no velocity state: after every
//! [`Integrator::set_state`] they are put in static equilibrium with the rest (the static
//! contact problem of eqs. 26–29, [`StaticContact`]).
//!
//! **Energy** ([`Integrator::energy`]): `E = ½ vᵀMv + ½ qᵀKq − qᵀ f_const + E_offset`, with `M`
//! the mass in use, `f_const` the constant load (including an acceleration field) and
//! `E_offset` from the settings. For a free body under an acceleration field (the dropped
//! bar) [`fall_energy`] gives the offset that makes the datum "resting on the support"
//! (METHODS §2.5: `E = ½vᵀMv + ½uᵀKu + g 1ᵀMu + m g h0`), so `E/E(0)` is the normalised
//! energy of the paper's Fig. 5.
//!
//! [`steady_state`] integrates period by period until the state repeats;
//! [`initial`] builds the initial state of a harmonic solution (e.g. from `mshbm solve`);
//! [`crate::analytic`] has the closed-form references.

pub mod initial;
mod moreau;
mod newmark;
pub mod steady_state;

use crate::contact::static_contact::StaticContact;
use crate::error::{Error, Result};
use crate::model::{MassKind, Model, System};
use crate::modes::massless_dofs;
use crate::sparse::SparseMatrix;

/// The time-stepping scheme.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scheme {
    /// Moreau–Jean θ-scheme with Newton's impact law (METHODS §3.1); `theta ∈ [½, 1]`,
    /// `restitution` `e_N ∈ [0, 1]`.
    MoreauJean { theta: f64, restitution: f64 },
    /// Newmark average acceleration with position-level Signorini for a massless contact
    /// boundary (METHODS §3.2).
    PositionNewmark,
}

impl Scheme {
    /// The Moreau–Jean scheme with the defaults θ = ½ (no numerical damping) and `e_N = 0`
    /// where not given.
    pub fn moreau_jean(theta: Option<f64>, restitution: Option<f64>) -> Self {
        Scheme::MoreauJean {
            theta: theta.unwrap_or(0.5),
            restitution: restitution.unwrap_or(0.0),
        }
    }

    /// The mass matrix the scheme integrates: the consistent mass for Moreau–Jean, the
    /// redistributed mass (massless contact boundary) for the position-level Newmark scheme.
    pub fn mass_kind(&self) -> MassKind {
        match self {
            Scheme::MoreauJean { .. } => MassKind::Consistent,
            Scheme::PositionNewmark => MassKind::Redistributed,
        }
    }

    /// The scheme and its mass, in words for reports.
    pub fn description(&self) -> String {
        match *self {
            Scheme::MoreauJean { theta, restitution } => {
                format!("Moreau-Jean (theta = {theta}, e_N = {restitution}), consistent mass")
            }
            Scheme::PositionNewmark => "position-level Newmark, redistributed mass".to_string(),
        }
    }

    /// Short name for reports (`"moreau-jean"`, `"position-newmark"`).
    pub fn name(&self) -> &'static str {
        match self {
            Scheme::MoreauJean { .. } => "moreau-jean",
            Scheme::PositionNewmark => "position-newmark",
        }
    }
}

/// Settings of an [`Integrator`].
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Time step `h > 0`.
    pub dt: f64,
    pub scheme: Scheme,
    /// Angular frequency ω [rad/s] of the harmonic load `F cos ωt`; required when the
    /// system has a non-zero harmonic load, ignored otherwise.
    pub omega: Option<f64>,
    /// Constant added to the energy (e.g. [`fall_energy`]).
    pub energy_offset: f64,
}

/// Energy offset that puts the datum of a free body's potential energy at the first
/// contact: for a model without Dirichlet DOFs under a uniform acceleration `a`, the work
/// of the acceleration load while the body translates rigidly along `a` from `q = 0` until
/// a contact closes (`m |a| h0` for the dropped bar: METHODS §2.5). Zero when the model is
/// held (Dirichlet DOFs), has no acceleration field, or no contact closes along `a`.
pub fn fall_energy(model: &Model, system: &System) -> f64 {
    let Some(acc) = &model.acceleration else {
        return 0.0;
    };
    if !model.dirichlet.is_empty() {
        return 0.0;
    }
    let norm = acc.iter().map(|a| a * a).sum::<f64>().sqrt();
    if norm == 0.0 {
        return 0.0;
    }
    let dpn = model.dofs_per_node;
    // unit translation along a, system numbering (no Dirichlet DOFs: system = model DOFs)
    let d: Vec<f64> = system
        .model_dof
        .iter()
        .map(|&m| acc[m % dpn] / norm)
        .collect();
    let mut distance = f64::INFINITY;
    for c in &system.contacts {
        let rate: f64 = c.w.iter().map(|&(i, w)| w * d[i]).sum();
        if rate < 0.0 && c.gap >= 0.0 {
            distance = distance.min(c.gap / -rate);
        }
    }
    if !distance.is_finite() {
        return 0.0;
    }
    // f_acc = M (1 ⊗ a) = |a| M d;  offset = distance · f_accᵀ d
    let md = system.mass.mul_vec(&d);
    distance * norm * d.iter().zip(&md).map(|(a, b)| a * b).sum::<f64>()
}

/// Contacts in system numbering: `g = Σ w q + g0`.
#[derive(Clone, Debug)]
pub(crate) struct Contacts {
    pub(crate) w: Vec<Vec<(usize, f64)>>,
    pub(crate) gap: Vec<f64>,
}

impl Contacts {
    pub(crate) fn len(&self) -> usize {
        self.gap.len()
    }

    /// `Wᵢᵀ x` (without `g0`).
    pub(crate) fn dot(&self, i: usize, x: &[f64]) -> f64 {
        self.w[i].iter().map(|&(d, w)| w * x[d]).sum()
    }

    /// Gaps `Wᵀ q + g0`.
    pub(crate) fn gaps_into(&self, q: &[f64], out: &mut [f64]) {
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.dot(i, q) + self.gap[i];
        }
    }

    /// Column `i` of `W` as a dense vector of length `n`.
    pub(crate) fn column(&self, i: usize, n: usize) -> Vec<f64> {
        let mut c = vec![0.0; n];
        for &(d, w) in &self.w[i] {
            c[d] += w;
        }
        c
    }
}

/// Friction elements in system numbering (see the module docs).
#[derive(Clone, Debug, Default)]
pub(crate) struct Frictions {
    pub(crate) w: Vec<Vec<(usize, f64)>>,
    pub(crate) mu: Vec<f64>,
    /// `Ok(F_N)` prescribed normal force, `Err(i)` the force of contact `i`.
    pub(crate) normal: Vec<std::result::Result<f64, usize>>,
}

impl Frictions {
    pub(crate) fn len(&self) -> usize {
        self.mu.len()
    }

    pub(crate) fn dot(&self, i: usize, x: &[f64]) -> f64 {
        self.w[i].iter().map(|&(d, w)| w * x[d]).sum()
    }

    pub(crate) fn column(&self, i: usize, n: usize) -> Vec<f64> {
        let mut c = vec![0.0; n];
        for &(d, w) in &self.w[i] {
            c[d] += w;
        }
        c
    }
}

/// The immutable data of an integration: matrices, loads, contacts.
pub(crate) struct Data {
    pub(crate) n: usize,
    pub(crate) dt: f64,
    pub(crate) mass: SparseMatrix,
    pub(crate) stiffness: SparseMatrix,
    pub(crate) damping: SparseMatrix,
    pub(crate) constant_load: Vec<f64>,
    pub(crate) harmonic_load: Vec<f64>,
    pub(crate) omega: f64,
    pub(crate) contacts: Contacts,
    pub(crate) frictions: Frictions,
    /// Harmonics and coefficients (harmonic-major, `c·n + i`) of the periodic load.
    pub(crate) periodic_load: Option<(usize, Vec<f64>)>,
    pub(crate) massless: Vec<usize>,
    pub(crate) massive: Vec<usize>,
    pub(crate) energy_offset: f64,
}

impl Data {
    /// `f(t) = f_const + f_harm cos ωt` into `out`.
    pub(crate) fn load_into(&self, t: f64, out: &mut [f64]) {
        let c = if self.omega != 0.0 {
            (self.omega * t).cos()
        } else {
            0.0
        };
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.constant_load[i] + c * self.harmonic_load[i];
        }
        if let Some((h, coef)) = &self.periodic_load {
            let n = self.n;
            let b = crate::harmonic::basis(*h, self.omega * t);
            for (ci, bc) in b.iter().enumerate() {
                for (i, o) in out.iter_mut().enumerate() {
                    *o += bc * coef[ci * n + i];
                }
            }
        }
    }
}

/// The evolving state.
pub(crate) struct State {
    pub(crate) t0: f64,
    pub(crate) steps: u64,
    pub(crate) q: Vec<f64>,
    pub(crate) v: Vec<f64>,
    pub(crate) gaps: Vec<f64>,
    pub(crate) forces: Vec<f64>,
    /// Friction forces (impulse of the last step / h).
    pub(crate) friction_forces: Vec<f64>,
}

impl State {
    pub(crate) fn time(&self, dt: f64) -> f64 {
        self.t0 + self.steps as f64 * dt
    }
}

enum Kernel {
    Moreau(Box<moreau::MoreauJean>),
    Newmark(Box<newmark::PositionNewmark>),
}

/// A time integrator for one [`System`] (see the module docs).
///
/// It starts at rest at `t = 0` with `q = 0` (massless DOFs in static equilibrium); use
/// [`Integrator::set_state`] for other initial conditions. Each [`Integrator::step`]
/// advances by `dt`; times are `t0 + k·dt` (no accumulated rounding), so a harmonic load
/// keeps its phase over long runs.
pub struct Integrator {
    data: Data,
    state: State,
    kernel: Kernel,
    scheme: Scheme,
    stiffness_nn: SparseMatrix,
    stiffness_nm: SparseMatrix,
    model_dof: Vec<usize>,
    n_model_dofs: usize,
}

/// The parameters of the Moreau–Jean scheme (METHODS §3.1): `θ ∈ [½, 1]` and the Newton
/// restitution coefficient `e_N ∈ [0, 1]`.
pub(crate) fn check_moreau_jean(theta: f64, restitution: f64) -> Result<()> {
    if !(theta.is_finite() && (0.5..=1.0).contains(&theta)) {
        return Err(Error::argument(
            "theta",
            format!("must lie in [0.5, 1], got {theta}"),
        ));
    }
    if !(restitution.is_finite() && (0.0..=1.0).contains(&restitution)) {
        return Err(Error::argument(
            "restitution",
            format!("the restitution coefficient must lie in [0, 1], got {restitution}"),
        ));
    }
    Ok(())
}

impl Integrator {
    /// Set up the scheme for `system` (factors the iteration matrix once).
    pub fn new(system: &System, settings: &Settings) -> Result<Self> {
        let n = system.n_dofs();
        if n == 0 {
            return Err(Error::argument("system", "the system has no free DOFs"));
        }
        let dt = settings.dt;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Error::argument(
                "time step",
                format!("must be positive, got {dt}"),
            ));
        }
        let forced = system.harmonic_load.iter().any(|&f| f != 0.0);
        let omega = match settings.omega {
            Some(w) if w.is_finite() && w > 0.0 => w,
            Some(w) => {
                return Err(Error::argument(
                    "frequency",
                    format!(
                        "must be positive, got {} Hz",
                        w / (2.0 * std::f64::consts::PI)
                    ),
                ))
            }
            None if forced => {
                return Err(Error::argument(
                    "frequency",
                    "the model has a harmonic load: give its frequency",
                ))
            }
            None => 0.0,
        };
        if !settings.energy_offset.is_finite() {
            return Err(Error::argument("energy offset", "must be finite"));
        }
        let massless = massless_dofs(&system.mass);
        let mut is_massless = vec![false; n];
        massless.iter().for_each(|&i| is_massless[i] = true);
        let massive: Vec<usize> = (0..n).filter(|&i| !is_massless[i]).collect();
        let contacts = Contacts {
            w: system.contacts.iter().map(|c| c.w.clone()).collect(),
            gap: system.contacts.iter().map(|c| c.gap).collect(),
        };
        let frictions = Frictions {
            w: system.frictions.iter().map(|f| f.w.clone()).collect(),
            mu: system.frictions.iter().map(|f| f.mu).collect(),
            normal: system
                .frictions
                .iter()
                .map(|f| match f.normal {
                    crate::model::FrictionNormal::Force(p) => Ok(p),
                    crate::model::FrictionNormal::Contact(c) => Err(c),
                })
                .collect(),
        };
        if let Some(bad) = frictions.normal.iter().find_map(|nf| match nf {
            Err(c) if *c >= system.contacts.len() => Some(*c),
            _ => None,
        }) {
            return Err(Error::argument(
                "friction",
                format!("friction refers to contact {bad}, which does not exist"),
            ));
        }
        if frictions.len() > 0 && settings.scheme == Scheme::PositionNewmark {
            return Err(Error::argument(
                "scheme",
                "friction needs the Moreau-Jean scheme (the position-level scheme is frictionless)",
            ));
        }
        let data = Data {
            n,
            dt,
            mass: system.mass.clone(),
            stiffness: system.stiffness.clone(),
            damping: system.damping.clone(),
            constant_load: system.constant_load.clone(),
            harmonic_load: system.harmonic_load.clone(),
            omega,
            contacts,
            frictions,
            periodic_load: None,
            massless,
            massive,
            energy_offset: settings.energy_offset,
        };
        let kernel = match settings.scheme {
            Scheme::MoreauJean { theta, restitution } => {
                check_moreau_jean(theta, restitution)?;
                if !data.massless.is_empty() && theta <= 0.5 {
                    return Err(Error::argument(
                        "theta",
                        "the velocity-level Moreau-Jean scheme with theta = 0.5 is unstable on a singular (redistributed) mass \
                         (METHODS §3.2); use the position-level scheme or theta > 0.5",
                    ));
                }
                Kernel::Moreau(Box::new(moreau::MoreauJean::new(
                    system,
                    &data,
                    theta,
                    restitution,
                )?))
            }
            Scheme::PositionNewmark => {
                Kernel::Newmark(Box::new(newmark::PositionNewmark::new(system, &data)?))
            }
        };
        let nc = data.contacts.len();
        let mut integrator = Integrator {
            stiffness_nn: system.stiffness.submatrix(&data.massless, &data.massless),
            stiffness_nm: system.stiffness.submatrix(&data.massless, &data.massive),
            state: State {
                t0: 0.0,
                steps: 0,
                q: vec![0.0; n],
                v: vec![0.0; n],
                gaps: vec![0.0; nc],
                forces: vec![0.0; nc],
                friction_forces: vec![0.0; data.frictions.len()],
            },
            data,
            kernel,
            scheme: settings.scheme,
            model_dof: system.model_dof.clone(),
            n_model_dofs: system.n_model_dofs,
        };
        integrator.set_state(0.0, &vec![0.0; n], &vec![0.0; n])?;
        Ok(integrator)
    }

    /// Restart from `(q, v)` at `time` (system numbering). The massless DOFs are put in
    /// static equilibrium with the others and the contacts (their given values are
    /// replaced; their velocities are set to zero).
    pub fn set_state(&mut self, time: f64, q: &[f64], v: &[f64]) -> Result<()> {
        let n = self.data.n;
        if q.len() != n || v.len() != n {
            return Err(Error::argument(
                "initial state",
                format!(
                    "expected {n} displacements and velocities, got {} and {}",
                    q.len(),
                    v.len()
                ),
            ));
        }
        if !time.is_finite() || q.iter().chain(v).any(|x| !x.is_finite()) {
            return Err(Error::argument("initial state", "must be finite"));
        }
        let s = &mut self.state;
        s.t0 = time;
        s.steps = 0;
        s.q.copy_from_slice(q);
        s.v.copy_from_slice(v);
        s.forces.iter_mut().for_each(|f| *f = 0.0);
        s.friction_forces.iter_mut().for_each(|f| *f = 0.0);
        self.static_massless()?;
        for &i in &self.data.massless {
            self.state.v[i] = 0.0;
        }
        self.data
            .contacts
            .gaps_into(&self.state.q, &mut self.state.gaps);
        match &mut self.kernel {
            Kernel::Moreau(k) => k.reset(&self.data, &mut self.state),
            Kernel::Newmark(k) => k.reset(&self.data, &mut self.state),
        }
    }

    /// Static equilibrium of the massless DOFs `Z` (eqs. 26–29): `K_ZZ q_Z = f_Z − K_ZM q_M
    /// + W_Z λ` with Signorini on the contacts that involve `Z`.
    fn static_massless(&mut self) -> Result<()> {
        let d = &self.data;
        let z = &d.massless;
        if z.is_empty() {
            return Ok(());
        }
        let nz = z.len();
        let mut pos = vec![usize::MAX; d.n];
        z.iter().enumerate().for_each(|(k, &i)| pos[i] = k);
        // contacts involving Z, with the massive part moved into the gap
        let involved: Vec<usize> = (0..d.contacts.len())
            .filter(|&c| d.contacts.w[c].iter().any(|&(i, _)| pos[i] != usize::MAX))
            .collect();
        let nc = involved.len();
        let mut w = vec![0.0; nz * nc];
        let mut gap = vec![0.0; nc];
        for (k, &c) in involved.iter().enumerate() {
            gap[k] = d.contacts.gap[c];
            for &(i, wi) in &d.contacts.w[c] {
                if pos[i] != usize::MAX {
                    w[pos[i] * nc + k] += wi;
                } else {
                    gap[k] += wi * self.state.q[i];
                }
            }
        }
        let mut contact = StaticContact::new(&self.stiffness_nn, w, gap)?;
        let t = self.state.time(d.dt);
        let mut f = vec![0.0; d.n];
        d.load_into(t, &mut f);
        let qm: Vec<f64> = d.massive.iter().map(|&i| self.state.q[i]).collect();
        let kq = self.stiffness_nm.mul_vec(&qm);
        let b: Vec<f64> = (0..nz).map(|k| f[z[k]] - kq[k]).collect();
        let set = contact.solve(&b)?;
        let qz = set.displacement(&b);
        let lambda = set.force(&b);
        for (k, &i) in z.iter().enumerate() {
            self.state.q[i] = qz[k];
        }
        for (k, &c) in involved.iter().enumerate() {
            self.state.forces[c] = lambda[k];
        }
        Ok(())
    }

    /// Advance one step.
    pub fn step(&mut self) -> Result<()> {
        match &mut self.kernel {
            Kernel::Moreau(k) => k.step(&self.data, &mut self.state)?,
            Kernel::Newmark(k) => k.step(&self.data, &mut self.state)?,
        }
        self.state.steps += 1;
        Ok(())
    }

    /// Advance `steps` steps, calling `observer` after each.
    pub fn run(&mut self, steps: usize, mut observer: impl FnMut(&Integrator)) -> Result<()> {
        for _ in 0..steps {
            self.step()?;
            observer(self);
        }
        Ok(())
    }

    /// The scheme.
    pub fn scheme(&self) -> Scheme {
        self.scheme
    }

    /// Time step.
    pub fn dt(&self) -> f64 {
        self.data.dt
    }

    /// Current time.
    pub fn time(&self) -> f64 {
        self.state.time(self.data.dt)
    }

    /// Steps since the last [`Integrator::set_state`].
    pub fn steps(&self) -> u64 {
        self.state.steps
    }

    /// Displacements (system numbering).
    pub fn q(&self) -> &[f64] {
        &self.state.q
    }

    /// Velocities (system numbering). For massless DOFs this is a diagnostic
    /// (`Δq/h` with the position-level scheme, zero after [`Integrator::set_state`]).
    pub fn v(&self) -> &[f64] {
        &self.state.v
    }

    /// Gaps `Wᵀq + g0` of the contacts at the current time (negative = penetration, which
    /// the velocity-level scheme allows).
    pub fn gaps(&self) -> &[f64] {
        &self.state.gaps
    }

    /// Contact forces `λ ≥ 0`: at the current time for the position-level scheme, the
    /// impulse of the last step divided by `dt` for Moreau–Jean.
    pub fn forces(&self) -> &[f64] {
        &self.state.forces
    }

    /// Moreau–Jean only: use the *anticipating* index set (all contacts take part, a contact
    /// open at the predicted position acts only to prevent `g_{k+1} < 0`; see the `moreau`
    /// module docs). Makes a step a continuous function of the state for `e_N = 0`. Off by
    /// default; ignored by the position-level scheme.
    pub fn set_contact_anticipation(&mut self, on: bool) {
        if let Kernel::Moreau(k) = &mut self.kernel {
            k.anticipate = on;
        }
    }

    /// Moreau–Jean only: after each step project the positions back onto `g ≥ 0` in the
    /// metric of the iteration matrix (velocities unchanged; see the `moreau` module docs),
    /// so that a persistent contact has no penetration. Off by default; ignored by the
    /// position-level scheme (which never penetrates).
    pub fn set_contact_projection(&mut self, on: bool) {
        if let Kernel::Moreau(k) = &mut self.kernel {
            k.project = on;
        }
    }

    /// Friction forces `P_T/h` of the last step, one per friction element (`|·| ≤ μ F_N`).
    pub fn friction_forces(&self) -> &[f64] {
        &self.state.friction_forces
    }

    /// Add the periodic load `Σ_c F_c b_c(ωt)` (coefficients harmonic-major, entry `c·n + i`
    /// for system DOF `i`, `c < 2H + 1`) to `f(t)`, with the integrator's ω (which must
    /// have been given in the settings). Replaces a previous periodic load.
    pub fn set_periodic_load(&mut self, harmonics: usize, coefficients: Vec<f64>) -> Result<()> {
        let n = self.data.n;
        if coefficients.len() != n * crate::harmonic::n_coefficients(harmonics) {
            return Err(Error::argument(
                "periodic load",
                format!(
                    "expected {} coefficients, got {}",
                    n * crate::harmonic::n_coefficients(harmonics),
                    coefficients.len()
                ),
            ));
        }
        if self.data.omega == 0.0 {
            return Err(Error::argument(
                "frequency",
                "a periodic load needs the frequency in the settings",
            ));
        }
        if coefficients.iter().any(|v| !v.is_finite()) {
            return Err(Error::argument("periodic load", "must be finite"));
        }
        self.data.periodic_load = Some((harmonics, coefficients));
        Ok(())
    }

    /// System DOF of a model DOF: `None` for a Dirichlet DOF, an error when out of range.
    pub fn system_dof(&self, model_dof: usize) -> Result<Option<usize>> {
        if model_dof >= self.n_model_dofs {
            return Err(Error::argument(
                "dof",
                format!(
                    "DOF {model_dof} does not exist (the model has DOFs 0..{})",
                    self.n_model_dofs - 1
                ),
            ));
        }
        Ok(self.model_dof.iter().position(|&d| d == model_dof))
    }

    /// `(model DOF, system DOF)` of the first DOF of each contact.
    pub fn contact_first_dofs(&self) -> Vec<(usize, usize)> {
        self.data
            .contacts
            .w
            .iter()
            .map(|w| (self.model_dof[w[0].0], w[0].0))
            .collect()
    }

    /// DOFs with mass (the state that a periodic orbit must repeat).
    pub fn massive_dofs(&self) -> &[usize] {
        &self.data.massive
    }

    /// DOFs without mass (statically determined).
    pub fn massless_dofs(&self) -> &[usize] {
        &self.data.massless
    }

    /// `E = ½ vᵀMv + ½ qᵀKq − qᵀ f_const + E_offset` (see the module docs).
    pub fn energy(&self) -> f64 {
        let d = &self.data;
        let s = &self.state;
        0.5 * d.mass.quadratic_form(&s.v) + 0.5 * d.stiffness.quadratic_form(&s.q)
            - s.q
                .iter()
                .zip(&d.constant_load)
                .map(|(a, b)| a * b)
                .sum::<f64>()
            + d.energy_offset
    }
}
