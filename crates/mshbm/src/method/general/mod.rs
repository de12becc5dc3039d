//! The general MS-HBM (paper Section 2, eqs. 1–13; docs/theory.md §8, (T56)–(T66)): the
//! linear subsystem in the frequency domain, the nonlinear subsystem — the DOFs the
//! set-valued laws act on, with their mass — integrated over one period, and Newton.
//! Two integrations ([`PeriodIntegration`]): **event-driven** for frictionless contacts
//! (closed-form flows between impacts and releases located to round-off, a residual smooth
//! between events, its Jacobian from sensitivities with saltation matrices, contact 0's
//! impact time an unknown so that grazing is a corner; (T143)–(T147),
//! `set_flow.rs`, `event_period.rs`, `event_residual.rs`), and **Moreau–Jean time
//! stepping** with impacts and Coulomb friction ([`crate::integrate`]) and a
//! finite-difference Jacobian, described below. The CLI (`--method mshbm`) and the outputs (JSON
//! `"method": "mshbm"`, [`crate::solution::MethodKind::General`]) call this method `mshbm`.
//!
//! **Partition.** `N` = all DOFs of the nodes that carry a contact or a friction DOF
//! ([`System::nonlinear_dofs`], [`crate::model::Model::nonlinear_nodes`]), `L` = the rest.
//! The *consistent* mass is used ([`MassKind::Consistent`]); damping may act on `N`
//! (`C_NN ≠ 0` is fine here, unlike the redistributed method).
//!
//! **Unknowns** (eq. 11, docs/theory.md (T56)): `x = (q̂_N, q_N(0), q̇_N(0)/ω)`,
//! harmonic-major `q̂_N` (coefficient `c` of N-DOF `i` at `c·n_N + i`), then `n_N`
//! displacements and `n_N` velocities divided by ω, so that every unknown is a length.
//! Event-driven, the state is taken at the section and one more unknown follows:
//! `ℓ ω θ_c`, contact 0's critical time (docs/theory.md (T146), (T147)).
//!
//! **Residual** (eq. 12, docs/theory.md (T57), (T58)), per evaluation (`period.rs`):
//! 1. eq. (6), docs/theory.md (T17): `q̂_L,k = A_k⁻¹ (f_L,k − H_LN,k z_k)` with the complex
//!    per-harmonic dynamic stiffness `A_k = K_LL − (kω)² M_LL + i kω C_LL` (factored once per
//!    frequency, [`crate::linear::ExactCondensation`]) and `z_k = a_k − i b_k`. The load of
//!    eq. (10) on `N` is affine in `x` (docs/theory.md (T20)):
//!    `F_k = f_N,k − H_NL,k q̂_L,k = f_N,k − u0_k + G_k z_k`,
//!    `G_k = H_NL,k A_k⁻¹ H_LN,k`, `u0_k = H_NL,k A_k⁻¹ f_L,k` (precomputed per frequency;
//!    this contains `M_NL q̈_L + C_NL q̇_L + K_NL q_L` with the derivatives of `q_L` taken
//!    analytically);
//! 2. eq. (10): `M_NN q̈_N + C_NN q̇_N + K_NN q_N = F(t) + W λ` is integrated from
//!    `(q_N(0), q̇_N(0))` over `[0, T]` with `N_s` Moreau–Jean steps (θ-scheme, Newton impact
//!    law with restitution `e_N`, Coulomb friction), `F(t)` being a periodic load
//!    ([`crate::integrate::Integrator::set_periodic_load`]);
//! 3. `R = [q̂_N − DFT(q_N(t_j)); q_N(T) − q_N(0); (q̇_N(T) − q̇_N(0))/ω]` with the DFT over
//!    the step grid `t_j = jT/N_s` (the velocity block is divided by ω so that all blocks are
//!    lengths, as Newton's tolerance is relative to a length).
//!
//! **Jacobian** (docs/theory.md (T65)): forward differences, the point's residual, the
//! columns' and the frequency's perturbed residuals integrated as one parallel batch (rayon);
//! the per-column work takes `&self` (the frequency data is shared read-only, each column
//! builds its own small N-subsystem integrator). Step `h_j = ε · max(|x_j|, s)`
//! (`ε` = [`GeneralOptions::fd_step`], default 1e-6) with `s` the length scale. `∂R/∂ω` also
//! by a forward difference. The map is piecewise affine (impacts with `e_N = 0` and the
//! anticipating index set, Coulomb friction) and continuous (up to the row switch of the
//! stuck-friction selection below).
//!
//! **Stuck friction** (docs/theory.md (T64), `friction.rs`): when a friction element sticks
//! at every step, every constant position in its stick range is a periodic solution and
//! the Jacobian is singular; the residual then selects the member with zero mean friction
//! force (`stuck_frictions`).
//!
//! **Floquet multipliers** (docs/theory.md (T83), `floquet.rs`): finite differences of the
//! whole model's period map ([`PeriodicProblem::floquet`] below).
//!
//! **Frequency response diagrams.** The discrete period map is piecewise affine with pieces
//! one time step wide, so a branch is a staircase of corners; `frf` steps in frequency where
//! the arclength step shrinks to them ([`crate::problem::ArclengthFallback::StepInFrequency`],
//! this method's continuation policy; docs/theory.md (T77)).
//!
//! **Start** (event-driven; docs/theory.md (T147), (T147b)): the linear response
//! pre-solved without the critical time; where Newton does not converge from it, a
//! homotopy in an added stiffness-proportional damping of the nonlinear subsystem's own
//! mode (`homotopy.rs`).
//!
//! **Cost**: every Newton iteration integrates the N-subsystem `dim + 2` times; each
//! residual evaluation builds its own small N-subsystem integrator (a sparse Cholesky of
//! the `n_N × n_N` iteration matrix), negligible for the few nonlinear DOFs this method
//! is meant for.
//!
//! **Files**: this one holds the settings, the construction, the linear response and the
//! [`PeriodicProblem`] implementation; `period.rs` the one-period Moreau–Jean integration
//! of the N-subsystem and the residual; `set_flow.rs` the flow of one active set,
//! `event_period.rs` the event-driven period with its sensitivities, `event_residual.rs`
//! the event-driven residual and Jacobian (the section `t_s`); `homotopy.rs` the start's
//! damping homotopy; `friction.rs` the friction limits and the stuck-friction
//! selection; `floquet.rs` the whole system's initial state and monodromy.
//!
//! Measurements and their history (why the position projection and the `q̇/ω` unknowns,
//! what limits Newton and the FRD on the bar with impacts, what was tried and rejected):
//! `docs/general-mshbm.md`.

mod event_period;
mod event_residual;
mod floquet;
mod friction;
mod homotopy;
mod period;
mod periodic_problem;
mod set_flow;

pub use floquet::MAX_FLOQUET_DOFS;
pub use homotopy::{HOMOTOPY_LEVELS, HOMOTOPY_RATIO};
pub use period::Trajectory;

use faer::linalg::solvers::Solve;
use faer::{c64, Mat};

use super::partition::{Partition, SingularStiffness};
use super::{check_dimension, store_harmonic};
use crate::error::{Error, Result};
use crate::harmonic::{n_coefficients, Sampling};
use crate::limits::Limits;
use crate::linear::PartitionedSystem;
use crate::linear::{Condensation, CondensedFrequency, ExactCondensation, LinearResponse};
use crate::model::{MassKind, Model, System, SystemContact, SystemFriction};
use crate::problem::{Jacobian, Linearization, PeriodicProblem};
use crate::sparse::SparseMatrix;

/// Newton iterations without the critical time that improve the event-driven initial
/// guess ([`PeriodicProblem::initial_guess`]).
pub const PRESOLVE_ITERATIONS: usize = 10;

/// Relative residual at which that pre-solve stops: the motion's impacts are in place, and
/// Newton with the critical time does the rest.
pub const PRESOLVE_TOLERANCE: f64 = 1e-3;

/// Default steps per period for `H` harmonics: `max(512, 32 (2H + 1))`.
pub fn default_steps(harmonics: usize) -> usize {
    super::default_resolution(harmonics, 32, 512)
}

/// Settings of the general MS-HBM.
#[derive(Clone, Debug)]
pub struct GeneralOptions {
    /// Number of harmonics `H ≥ 1` of the linear part.
    pub harmonics: usize,
    /// Moreau–Jean steps per period `N_s ≥ 2H + 1` (`None`: [`default_steps`]); also the
    /// DFT grid.
    pub steps: Option<usize>,
    /// θ of the Moreau–Jean scheme, in `[½, 1]` (default ½).
    pub theta: f64,
    /// Newton restitution coefficient `e_N ∈ [0, 1]` (default 0).
    pub restitution: f64,
    /// Use the anticipating index set of the Moreau–Jean scheme
    /// ([`crate::integrate::Integrator::set_contact_anticipation`], default `true`): with
    /// `e_N = 0` the period map is then continuous and Newton converges; with the plain index
    /// set it jumps on the step grid and Newton stalls at a small residual.
    pub anticipate_contacts: bool,
    /// Project the positions back onto `g ≥ 0` after each step
    /// ([`crate::integrate::Integrator::set_contact_projection`], default `true`): removes the
    /// penetration of persistent contacts, whose saw-tooth dependence on the impact time within
    /// a step otherwise stalls Newton at `≈ h |U| / g₀` (docs/theory.md (T62); measured in
    /// docs/general-mshbm.md §1).
    pub project_contacts: bool,
    /// Relative finite-difference step `ε`: `h_j = ε · max(|x_j|, s_j)` (default 1e-6).
    /// Larger steps (1e-5…1e-4) average over the grid-level discontinuities of impacts.
    pub fd_step: f64,
    /// How the N-subsystem is integrated over a period (default
    /// [`PeriodIntegration::Auto`]).
    pub integration: PeriodIntegration,
}

/// How the general MS-HBM integrates the N-subsystem over one period.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PeriodIntegration {
    /// Event-driven for frictionless models, Moreau–Jean time stepping with friction.
    Auto,
    /// Event-driven (docs/theory.md (T143)–(T146)): closed-form flows between impacts and
    /// releases located to round-off, a residual smooth between events and its Jacobian
    /// from sensitivities. Frictionless contacts only; impacts that accumulate (chatter,
    /// possible with `e_N > 0`) are refused.
    EventDriven,
    /// Moreau–Jean time stepping (T59)–(T63) with a finite-difference Jacobian (T65):
    /// friction, and accumulating impacts.
    TimeStepping,
}

impl GeneralOptions {
    /// `H` harmonics, default steps, θ = ½, `e_N = 0`.
    pub fn new(harmonics: usize) -> Self {
        GeneralOptions {
            harmonics,
            steps: None,
            theta: 0.5,
            restitution: 0.0,
            fd_step: 1e-6,
            anticipate_contacts: true,
            project_contacts: true,
            integration: PeriodIntegration::Auto,
        }
    }
}

/// The general MS-HBM for one model.
pub struct GeneralMsHbm {
    system: System,
    harmonics: usize,
    steps: usize,
    /// The DFT over the step grid (`steps` samples).
    sampling: Sampling,
    theta: f64,
    restitution: f64,
    fd_step: f64,
    anticipate: bool,
    project: bool,
    /// The N-subsystem as a system of its own (N numbering, no loads).
    subsystem: System,
    /// The linear part condensed onto N: the affine map `x ↦ F_k` (see the module docs).
    condensation: Box<dyn Condensation>,
    /// `L | N` partition and length scale.
    partition: Partition,
    /// The condensation at the last frequency.
    frequency: Option<Box<dyn CondensedFrequency>>,
    /// Diagonal of `K_NN` (N numbering).
    stiffness_nn_diagonal: Vec<f64>,
    /// The N-subsystem, dense, when the period is event-driven (`None`: time stepping).
    dense: Option<set_flow::DenseSubsystem>,
    /// The active sets' flows met so far (event-driven).
    flows: event_period::FlowCache,
    /// Whether the event-driven unknowns end with contact 0's critical time (T147); off
    /// only while [`PeriodicProblem::initial_guess`] pre-solves without it.
    with_critical_time: bool,
    /// The model, settings and limits this was built from (event-driven only): the damping
    /// homotopy of the start builds its stages from them (`homotopy.rs`).
    source: Option<std::sync::Arc<(Model, GeneralOptions, Limits)>>,
    /// Newton iterations spent by the last start after its pre-solve (`homotopy.rs`).
    guess_iterations: usize,
    /// Whether the last start fell back to the damping homotopy.
    used_homotopy: bool,
}

impl GeneralMsHbm {
    /// Set up the method for `model` (consistent mass, partition, checks) within the
    /// default [`Limits`] (the machine's memory).
    pub fn new(model: &Model, options: &GeneralOptions) -> Result<Self> {
        Self::within(model, options, &Limits::default())
    }

    /// [`GeneralMsHbm::new`], refusing before allocating when the method's memory estimate
    /// ([`super::memory::general`]) exceeds `limits`.
    pub fn within(model: &Model, options: &GeneralOptions, limits: &Limits) -> Result<Self> {
        let h = options.harmonics;
        let steps = options.steps.unwrap_or_else(|| default_steps(h));
        super::check_resolution(h, steps, "steps per period")?;
        crate::integrate::check_moreau_jean(options.theta, options.restitution)?;
        if !(options.fd_step.is_finite() && options.fd_step > 0.0 && options.fd_step < 0.1) {
            return Err(Error::argument(
                "fd_step",
                format!("must lie in (0, 0.1), got {}", options.fd_step),
            ));
        }
        if model.contacts.is_empty() && model.frictions.is_empty() {
            return Err(Error::argument(
                "model",
                "the model has no contact and no friction element; the general MS-HBM needs at least one",
            ));
        }
        model.refuse_contact_friction("the general MS-HBM")?;
        let system = model.system_cancellable(MassKind::Consistent, limits.cancel)?;
        // it integrates the nonlinear subsystem in time: a negative stiffness overflows
        system.check_not_indefinite()?;
        super::memory::general(&system, h, steps).check(
            &format!("the general MS-HBM with {h} harmonics and {steps} steps per period"),
            limits,
        )?;
        let nl_dofs = &system.nonlinear_dofs;
        let n = nl_dofs.len();
        // the N-subsystem is integrated with its mass: a free structure (singular K) is
        // fine, the gaps alone then set the length scale
        let partition = Partition::new(&system, SingularStiffness::Ignore)?;
        let pos = |d: usize| {
            partition
                .n_index(d)
                .expect("contact and friction DOFs are in N")
        };
        let sub = |a: &SparseMatrix, r: &[usize], c: &[usize]| a.submatrix(r, c);
        let mats = [&system.stiffness, &system.mass, &system.damping];
        let nn = mats.map(|a| sub(a, nl_dofs, nl_dofs));
        if nn[1]
            .to_dense()
            .partial_piv_lu()
            .solve(Mat::<f64>::identity(n, n))
            .col_iter()
            .any(|c| c.iter().any(|v| !v.is_finite()))
        {
            return Err(Error::field(
                &model.source,
                "matrices.mass",
                "the mass of the nonlinear subsystem M_NN is singular; the general MS-HBM integrates it with its mass (use a consistent mass with mass on the contact and friction DOFs)",
            ));
        }
        let subsystem = System {
            source: system.source.clone(),
            stiffness_file: system.stiffness_file.clone(),
            mass_kind: MassKind::Consistent,
            mass: nn[1].clone(),
            stiffness: nn[0].clone(),
            damping: nn[2].clone(),
            model_dof: nl_dofs.iter().map(|&d| system.model_dof[d]).collect(),
            n_model_dofs: system.n_model_dofs,
            nonlinear_dofs: (0..n).collect(),
            linear_dofs: vec![],
            contacts: system
                .contacts
                .iter()
                .map(|c| SystemContact {
                    w: c.w.iter().map(|&(d, w)| (pos(d), w)).collect(),
                    gap: c.gap,
                    friction: None,
                })
                .collect(),
            frictions: system
                .frictions
                .iter()
                .map(|f| SystemFriction {
                    w: f.w.iter().map(|&(d, w)| (pos(d), w)).collect(),
                    mu: f.mu,
                    normal: f.normal.clone(),
                })
                .collect(),
            harmonic_load: vec![0.0; n],
            constant_load: vec![0.0; n],
            alpha: system.alpha,
            beta: system.beta,
            // the subsystem has no linear part
            beta_condensed: 0.0,
        };
        let event_driven = match options.integration {
            PeriodIntegration::TimeStepping => false,
            PeriodIntegration::Auto => model.frictions.is_empty(),
            PeriodIntegration::EventDriven => {
                if !model.frictions.is_empty() {
                    return Err(Error::argument(
                        "integration",
                        "event-driven integration handles frictionless contacts only; the model has friction elements (use time stepping)",
                    ));
                }
                true
            }
        };
        let dense = if event_driven {
            let [k, m, c] = nn.clone().map(|a| a.to_dense());
            let mass_inv = m.partial_piv_lu().solve(Mat::<f64>::identity(n, n));
            let mut normals = Mat::<f64>::zeros(n, subsystem.contacts.len());
            for (j, ct) in subsystem.contacts.iter().enumerate() {
                for &(i, w) in &ct.w {
                    normals[(i, j)] += w;
                }
            }
            Some(set_flow::DenseSubsystem {
                mass: m,
                damping: c,
                stiffness: k,
                mass_inv,
                normals,
                gaps: subsystem.contacts.iter().map(|c| c.gap).collect(),
            })
        } else {
            None
        };
        let condensation =
            ExactCondensation::new(PartitionedSystem::new(&system), LinearResponse::Solve)?;
        let source =
            event_driven.then(|| std::sync::Arc::new((model.clone(), options.clone(), *limits)));
        Ok(GeneralMsHbm {
            source,
            guess_iterations: 0,
            used_homotopy: false,
            dense,
            flows: Default::default(),
            with_critical_time: true,
            partition,
            harmonics: h,
            steps,
            sampling: Sampling::within(h, steps, limits)?,
            theta: options.theta,
            restitution: options.restitution,
            fd_step: options.fd_step,
            anticipate: options.anticipate_contacts,
            project: options.project_contacts,
            subsystem,
            condensation: Box::new(condensation),
            frequency: None,
            stiffness_nn_diagonal: {
                let mut d = vec![0.0; n];
                nn[0]
                    .iter()
                    .filter(|(i, j, _)| i == j)
                    .for_each(|(i, _, v)| d[i] += v);
                d.iter().map(|&v| if v > 0.0 { v } else { 1.0 }).collect()
            },
            system,
        })
    }

    /// The system (consistent mass, Dirichlet DOFs removed).
    pub fn system(&self) -> &System {
        &self.system
    }

    pub fn harmonics(&self) -> usize {
        self.harmonics
    }

    /// Moreau–Jean steps per period (= DFT samples).
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// Number of DOFs of the nonlinear subsystem.
    pub fn n_nonlinear(&self) -> usize {
        self.subsystem.n_dofs()
    }

    fn n(&self) -> usize {
        self.subsystem.n_dofs()
    }

    /// The condensation at `ω`.
    fn frequency_data(&self, omega: f64) -> Result<Box<dyn CondensedFrequency>> {
        super::check_frequency(omega)?;
        self.condensation.at(omega, self.harmonics)
    }

    fn prepare(&mut self, omega: f64) -> Result<()> {
        if self.frequency.as_ref().is_some_and(|f| f.omega() == omega) {
            return Ok(());
        }
        self.frequency = Some(self.frequency_data(omega)?);
        Ok(())
    }

    /// Whether the period is integrated event-driven ([`PeriodIntegration`]).
    pub fn is_event_driven(&self) -> bool {
        self.dense.is_some()
    }

    /// The event-driven residual, its sensitivity Jacobian, and `∂R/∂ω` by central
    /// differences of the residual (smooth in ω between events; docs/theory.md (T146)):
    /// the three evaluations run in parallel.
    fn event_linearization(&self, x: &[f64], omega: f64) -> Result<Linearization> {
        let fd = self.frequency.as_deref().expect("prepared");
        // a step small against the distance to the corners of (T147) that continuation
        // passes: a difference across one averages its two pieces and Newton then contracts
        // only linearly (measured: 1e-6 ω stalled the corrector within 1e-8 of a grazing
        // corner); the residual is smooth between events, accurate to round-off
        let dw = 1e-9 * omega;
        let (lo, hi) = (omega - dw, omega + dw);
        let (point, (below, above)) = rayon::join(
            || self.event_residual(fd, x, true),
            || {
                rayon::join(
                    || -> Result<Vec<f64>> {
                        let f = self.frequency_data(lo)?;
                        Ok(self.event_residual(&*f, x, false)?.residual)
                    },
                    || -> Result<Vec<f64>> {
                        let f = self.frequency_data(hi)?;
                        Ok(self.event_residual(&*f, x, false)?.residual)
                    },
                )
            },
        );
        let point = point?;
        let (below, above) = (below?, above?);
        let d_omega = above
            .iter()
            .zip(&below)
            .map(|(a, b)| (a - b) / (hi - lo))
            .collect();
        Ok(Linearization {
            residual: point.residual,
            jacobian: Jacobian::Dense(point.jacobian.expect("asked for")),
            d_omega,
        })
    }

    /// The event-driven start: the linear response improved first by at most
    /// [`PRESOLVE_ITERATIONS`] Newton iterations without the critical time (every impact
    /// located by the scan, docs/theory.md (T146)) down to [`PRESOLVE_TOLERANCE`], whose
    /// basin from the linear response is wider where that response penetrates the stop
    /// deeply, then the critical time set where that motion first meets the stop
    /// ([`Self::initial_critical_time`]). Those iterations are not counted in the solve's
    /// Newton iterations. Time stepping: the linear response.
    pub fn presolved_start(&mut self, omega: f64) -> Result<Vec<f64>> {
        if !self.is_event_driven() {
            return self.linear_response(omega);
        }
        self.with_critical_time = false;
        let presolved = self.linear_response(omega).and_then(|x0| {
            let options = crate::newton::NewtonOptions {
                tolerance: PRESOLVE_TOLERANCE,
                max_iterations: PRESOLVE_ITERATIONS,
                ..Default::default()
            };
            let outcome = crate::newton::solve(self, &x0, omega, &options)?;
            // the better of the start and Newton's last iterate
            Ok(if outcome.residual_norm < outcome.history[0] {
                outcome.x
            } else {
                x0
            })
        });
        self.with_critical_time = true;
        let mut x = presolved?;
        x.push(0.0);
        self.prepare(omega)?;
        let fd = self.frequency.as_deref().expect("prepared");
        self.initial_critical_time(fd, &mut x)?;
        Ok(x)
    }

    fn check_x(&self, x: &[f64]) -> Result<()> {
        check_dimension(x, self.dimension())
    }

    /// Connectivity (`q̂_N − DFT`) and periodicity (`q_N(T) − q_N(0)`, `(q̇_N(T) −
    /// q̇_N(0))/ω`) residuals, max-norms relative to the length scale.
    pub fn residual_parts(&mut self, x: &[f64], omega: f64) -> Result<(f64, f64)> {
        let r = self.residual(x, omega)?;
        let n = self.n();
        let nc = n_coefficients(self.harmonics);
        let norm = |v: &[f64]| {
            v.iter().fold(0.0f64, |m, x| m.max(x.abs())) / self.partition.length_scale()
        };
        Ok((norm(&r[..n * nc]), norm(&r[n * nc..])))
    }

    /// The linear response (all set-valued forces zero) at `ω`, as unknowns `x`: the
    /// direct complex solve of the condensed dynamic stiffness `(H_NN,k − G_k) z_k =
    /// f_N,k − u0_k` per harmonic.
    pub fn linear_response(&mut self, omega: f64) -> Result<Vec<f64>> {
        self.prepare(omega)?;
        let fd = self.frequency.as_deref().expect("prepared");
        let n = self.n();
        let nc = n_coefficients(self.harmonics);
        let mut x = vec![0.0; self.dimension()];
        for k in 0..=self.harmonics {
            let kw = k as f64 * omega;
            let a = fd.condensed_dynamic_stiffness(k);
            let f = fd.condensed_load(k);
            let rhs = Mat::<c64>::from_fn(n, 1, |i, _| f[i]);
            let z = a.partial_piv_lu().solve(&rhs);
            let z: Vec<c64> = (0..n).map(|i| z[(i, 0)]).collect();
            if z.iter().any(|v| !(v.re.is_finite() && v.im.is_finite())) {
                return Err(Error::Singular(format!(
                    "the dynamic stiffness is singular at harmonic {k} (k·f = {} Hz is an eigenfrequency; add damping or move the frequency)",
                    kw / (2.0 * std::f64::consts::PI)
                )));
            }
            store_harmonic(&z, n, k, &mut x);
        }
        // initial state of the harmonic motion: q(0) = Σ a, q̇(0) = Σ kω b
        for i in 0..n {
            let mut q = x[i];
            let mut v = 0.0;
            for k in 1..=self.harmonics {
                q += x[(2 * k - 1) * n + i];
                v += k as f64 * omega * x[2 * k * n + i];
            }
            x[nc * n + i] = q;
            x[(nc + 1) * n + i] = v / omega;
        }
        if self.is_event_driven() {
            // the event-driven unknowns hold the state at the section
            self.harmonic_section_state(&mut x);
            if self.with_critical_time {
                let fd = self.frequency.as_deref().expect("prepared");
                self.initial_critical_time(fd, &mut x)?;
            }
        }
        Ok(x)
    }
}
