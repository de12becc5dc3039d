//! The [`Integrator`]: set-up of a scheme for one system, the stepping loop, the static
//! equilibrium of the massless DOFs, loads, contact options and the reported state.

use super::coulomb::CoulombContacts;
use super::data::{Contacts, Data, Frictions, State};
use super::{check_moreau_jean, moreau, newmark, Scheme, Settings};
use crate::contact::static_contact::StaticContact;
use crate::error::{Error, Result};
use crate::limits::Cancel;
use crate::model::System;
use crate::modes::massless_dofs;
use crate::sparse::{SparseCholesky, SparseMatrix};

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
    /// [`System::nonlinear_dofs`], whose harmonics are the redistributed MS-HBM's unknowns.
    nonlinear_dofs: Vec<usize>,
    /// The caller's request to stop, checked before every step ([`Integrator::cancel_on`]).
    cancel: Cancel,
}

impl Integrator {
    /// Set up the scheme for `system` (factors the iteration matrix once).
    pub fn new(system: &System, settings: &Settings) -> Result<Self> {
        let n = system.n_dofs();
        if n == 0 {
            return Err(Error::argument("system", "the system has no free DOFs"));
        }
        let contact_friction = system.contacts.iter().any(|c| c.friction.is_some());
        if let Some(c) = system
            .contacts
            .iter()
            .position(|c| c.friction.as_ref().is_some_and(|f| f.second.is_some()))
        {
            return Err(Error::argument(
                "friction",
                format!(
                    "contact {c} has friction in the Coulomb cone (a 3D interface); the time integration models friction along one tangent only"
                ),
            ));
        }
        if contact_friction && settings.scheme != Scheme::PositionNewmark {
            return Err(Error::argument(
                "scheme",
                "the model's contacts have Coulomb friction (`mu` of an interface), which the position-level scheme \
                 on the redistributed mass integrates (`Scheme::PositionNewmark`, `mshbm simulate --scheme redistributed`); \
                 the Moreau-Jean scheme models friction elements only",
            ));
        }
        if let Some(c) = system.contacts.iter().position(|c| {
            c.friction
                .as_ref()
                .is_some_and(|f| !(f.mu.is_finite() && f.mu >= 0.0) || f.w.is_empty())
        }) {
            return Err(Error::argument(
                "friction",
                format!("the friction of contact {c} needs a finite mu >= 0 and a tangent with a free DOF"),
            ));
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
            friction: system
                .contacts
                .iter()
                .map(|c| c.friction.as_ref().map(|f| (f.w.clone(), f.mu)))
                .collect(),
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
        // a negative stiffness makes any scheme's response grow without bound (it ended in a
        // NaN inside the contact solver, naming nothing)
        system.check_not_indefinite()?;
        let data = Data {
            n,
            dt,
            mass: system.mass.clone(),
            stiffness: system.stiffness.clone(),
            damping: system.damping.clone(),
            constant_load: system.constant_load.clone(),
            harmonic_load: if forced {
                system.harmonic_load.clone()
            } else {
                Vec::new()
            },
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
                         (docs/theory.md (T68)); use the position-level scheme or theta > 0.5",
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
                tangential_forces: vec![0.0; nc],
            },
            data,
            kernel,
            cancel: Cancel::NEVER,
            scheme: settings.scheme,
            model_dof: system.model_dof.clone(),
            n_model_dofs: system.n_model_dofs,
            nonlinear_dofs: system.nonlinear_dofs.clone(),
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
        s.tangential_forces.iter_mut().for_each(|f| *f = 0.0);
        if self.data.contacts.has_friction() {
            self.static_massless_frictional()?;
        } else {
            self.static_massless()?;
        }
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
        let (qz, lambda) = contact.solve_load(&b)?;
        for (k, &i) in z.iter().enumerate() {
            self.state.q[i] = qz[k];
        }
        for (k, &c) in involved.iter().enumerate() {
            self.state.forces[c] = lambda[k];
        }
        Ok(())
    }

    /// [`Integrator::static_massless`] with Coulomb friction on the contacts (docs/theory.md
    /// (T174)): the step problem (T170)–(T171) with `K_ZZ` in place of `Â` and the anchors
    /// at the given positions' tangential coordinates, so that a stuck contact stays where
    /// the given state has it. Every contact DOF is massless (the position-level scheme).
    fn static_massless_frictional(&mut self) -> Result<()> {
        let d = &self.data;
        let z = &d.massless;
        let nz = z.len();
        let mut pos = vec![usize::MAX; d.n];
        z.iter().enumerate().for_each(|(k, &i)| pos[i] = k);
        let mut k_zz = SparseCholesky::new(
            &self.stiffness_nn,
            "the stiffness of the massless DOFs (they must be held by the stiffness)",
        )?;
        // K_ZZ⁻¹ [W, W_T]_Z
        let mut columns: Vec<Vec<f64>> = d
            .contacts
            .coordinate_columns(d.n)
            .iter()
            .map(|c| z.iter().map(|&i| c[i]).collect())
            .collect();
        for c in &mut columns {
            k_zz.solve(c);
        }
        // the free positions q_Z = K_ZZ⁻¹ (f_Z − K_ZM q_M)
        let t = self.state.time(d.dt);
        let mut f = vec![0.0; d.n];
        d.load_into(t, &mut f);
        let qm: Vec<f64> = d.massive.iter().map(|&i| self.state.q[i]).collect();
        let kq = self.stiffness_nm.mul_vec(&qm);
        let mut qz: Vec<f64> = (0..nz).map(|k| f[z[k]] - kq[k]).collect();
        k_zz.solve(&mut qz);
        let mut free = self.state.q.clone();
        z.iter().zip(&qz).for_each(|(&i, &v)| free[i] = v);
        let m = columns.len();
        let nc = d.contacts.len();
        let dense = |c: &[f64]| -> Vec<f64> {
            let mut x = vec![0.0; d.n];
            z.iter().zip(c).for_each(|(&i, &v)| x[i] = v);
            x
        };
        let full: Vec<Vec<f64>> = columns.iter().map(|c| dense(c)).collect();
        let mut delassus = vec![0.0; m * m];
        for a in 0..m {
            for b in 0..m {
                delassus[a * m + b] = newmark::coordinate(d, a, &full[b]);
            }
        }
        let y_free: Vec<f64> = (0..m)
            .map(|r| {
                newmark::coordinate(d, r, &free) + d.contacts.gap.get(r).copied().unwrap_or(0.0)
            })
            .collect();
        let anchor: Vec<f64> = (0..nc)
            .map(|c| d.contacts.tangent_dot(c, &self.state.q))
            .collect();
        let mut problem = CoulombContacts::new(&d.contacts.mu(), delassus);
        problem.solve(&y_free, &anchor).map_err(|e| {
            Error::Numerical(format!("static frictional contact problem at t = {t}: {e}"))
        })?;
        let lambda = problem.lambda();
        for (k, &i) in z.iter().enumerate() {
            self.state.q[i] = qz[k] + (0..m).map(|r| columns[r][k] * lambda[r]).sum::<f64>();
        }
        for c in 0..nc {
            self.state.forces[c] = lambda[c];
            self.state.tangential_forces[c] = problem.tangent_row(c).map_or(0.0, |r| lambda[r]);
        }
        Ok(())
    }

    /// Stop at the next step with [`crate::error::Error::Cancelled`] once `cancel` is
    /// requested (every later [`Integrator::step`], so [`Integrator::run`] and the steady-state
    /// search too). The default never stops.
    pub fn cancel_on(&mut self, cancel: Cancel) {
        self.cancel = cancel;
    }

    /// Advance one step ([`crate::error::Error::Cancelled`] once the caller asked to stop).
    pub fn step(&mut self) -> Result<()> {
        self.cancel.check()?;
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

    /// Tangential (friction) forces `λ_T` of the contacts at the current time, along their
    /// tangents, one per contact (zero for a contact without friction; `|λ_T| ≤ μ λ_N`;
    /// docs/theory.md (T171)). Position-level scheme only.
    pub fn tangential_forces(&self) -> &[f64] {
        &self.state.tangential_forces
    }

    /// Per contact: `μ` of its Coulomb friction and the model DOF of its tangent's first
    /// DOF, `None` without friction.
    pub fn contact_frictions(&self) -> Vec<Option<(f64, usize)>> {
        self.data
            .contacts
            .friction
            .iter()
            .map(|f| f.as_ref().map(|(w, mu)| (*mu, self.model_dof[w[0].0])))
            .collect()
    }

    /// The tangential coordinates `y_T = w_Tᵀ q` of the contacts (zero without friction):
    /// the anchors of the stuck ones.
    pub fn tangents(&self) -> Vec<f64> {
        (0..self.data.contacts.len())
            .map(|c| self.data.contacts.tangent_dot(c, &self.state.q))
            .collect()
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
        // a load kept from the last step is stale now
        if let Kernel::Moreau(k) = &mut self.kernel {
            k.reset(&self.data, &mut self.state)?;
        }
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

    /// Initial gap `g0` of each contact.
    pub fn contact_initial_gaps(&self) -> &[f64] {
        &self.data.contacts.gap
    }

    /// DOFs with mass (the state that a periodic orbit must repeat).
    pub fn massive_dofs(&self) -> &[usize] {
        &self.data.massive
    }

    /// The system's nonlinear DOFs `N` (every DOF of the contact nodes), in the order of the
    /// redistributed MS-HBM's unknowns.
    pub fn nonlinear_dofs(&self) -> &[usize] {
        &self.nonlinear_dofs
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
