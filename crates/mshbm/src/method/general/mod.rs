//! The general MS-HBM (paper Section 2, eqs. 1–13; METHODS §3.4): the linear subsystem in
//! the frequency domain, the nonlinear subsystem — the DOFs the set-valued laws act on, with
//! their mass — integrated over one period by Moreau–Jean time stepping with impacts and
//! Coulomb friction ([`crate::integrate`]), and Newton with a finite-difference Jacobian.
//!
//! **Partition.** `N` = all DOFs of the nodes that carry a contact or a friction DOF
//! ([`System::nonlinear_dofs`], [`crate::model::Model::nonlinear_nodes`]), `L` = the rest.
//! The *consistent* mass is used ([`MassKind::Consistent`]); damping may act on `N`
//! (`C_NN ≠ 0` is fine here, unlike the redistributed method).
//!
//! **Unknowns** (eq. 11): `x = (q̂_N, q_N(0), q̇_N(0)/ω)`, harmonic-major `q̂_N` (coefficient
//! `c` of N-DOF `i` at `c·n_N + i`), then `n_N` displacements and `n_N` velocities divided
//! by ω, so that every unknown is a length. (With the velocities themselves, `|q̇| ≈ ω |q|`
//! ≈ 1e5 |q| on the bar, the velocity components dominated the scaled arclength of the
//! continuation, whose steps then advanced the frequency by hundredths of a hertz.)
//!
//! **Residual** (eq. 12), per evaluation:
//! 1. eq. (6): `q̂_L,k = A_k⁻¹ (f_L,k − H_LN,k z_k)` with the complex per-harmonic dynamic
//!    stiffness `A_k = K_LL − (kω)² M_LL + i kω C_LL` (factored once per
//!    frequency, [`crate::linear::ExactCondensation`]) and `z_k = a_k − i b_k`. The load of eq. (10) on `N` is affine in `x`:
//!    `F_k = f_N,k − H_NL,k q̂_L,k = f_N,k − u0_k + G_k z_k`,
//!    `G_k = H_NL,k A_k⁻¹ H_LN,k`, `u0_k = H_NL,k A_k⁻¹ f_L,k` (precomputed per frequency;
//!    this contains `M_NL q̈_L + C_NL q̇_L + K_NL q_L` with the derivatives of `q_L` taken
//!    analytically);
//! 2. eq. (10): `M_NN q̈_N + C_NN q̇_N + K_NN q_N = F(t) + W λ` is integrated from
//!    `(q_N(0), q̇_N(0))` over `[0, T]` with `N_s` Moreau–Jean steps (θ-scheme, Newton impact
//!    law with restitution `e_N`, Coulomb friction), `F(t)` being a periodic load
//!    ([`Integrator::set_periodic_load`]);
//! 3. `R = [q̂_N − DFT(q_N(t_j)); q_N(T) − q_N(0); (q̇_N(T) − q̇_N(0))/ω]` with the DFT over
//!    the step grid `t_j = jT/N_s` (the velocity block is divided by ω so that all blocks are
//!    lengths, as Newton's tolerance is relative to a length).
//!
//! **Jacobian**: forward differences, columns in parallel (rayon); the per-column work
//! takes `&self` (the frequency data is shared read-only, each column builds its own small
//! N-subsystem integrator). Step `h_j = ε · max(|x_j|, s)` (`ε` = [`GeneralOptions::fd_step`],
//! default 1e-6) with `s` the length scale. `∂R/∂ω` also by a forward difference. The map
//! is piecewise affine (impacts with `e_N = 0` and the anticipating index set, Coulomb
//! friction) and continuous (up to the row switch of the stuck-friction selection below).
//!
//! **Stuck friction**: when a friction element sticks at every step, every constant
//! position in its stick range is a periodic solution and the Jacobian is singular; the
//! residual then selects the member with zero mean friction force (`stuck_frictions`).
//!
//! **Floquet multipliers**: finite differences of the whole model's period map
//! ([`PeriodicProblem::floquet`] below).
//!
//! **Newton on the bar with impacts** (examples/clamped_bar_impact.toml, H = 10, 1024
//! steps, from the linear response; measured, see tests/general_mshbm.rs):
//! * Without the position projection ([`GeneralOptions::project_contacts`]) a persistent
//!   contact keeps the penetration `h(1−θ)U` of its impact step — a saw-tooth of the
//!   impact time, with slope jumps of order one at every step boundary, that enters every
//!   position of the contact phase. Newton stalled at ≈ 6e-4 (30 kHz) and 6e-3 (60 kHz)
//!   relative to the gap. With the projection the map has no such saw-tooth in the
//!   positions and Newton ends in the solution's affine piece (finite termination): 60 kHz
//!   converges to 3e-13 in 28 iterations, 90 kHz to 1e-13 in 6.
//! * With the velocity unknowns in m/s instead of `q̇/ω`, the continuation's scaled
//!   arclength was dominated by them: 5000 points advanced 85 → 85.2 kHz. (With them as
//!   `q̇/ω`, 85–95 kHz took 234 points before the continuation refused far-travelling
//!   correctors; see the last item.)
//! * What remains: after a release the contact DOF rings at the local frequency of the
//!   N-subsystem, `√(K_NN/M_NN)/2π` ≈ 6.7 MHz for the bar (above `Hω` the harmonically
//!   truncated L DOFs act as clamped), i.e. 4.6 steps per local period at 30 kHz. The
//!   ringing is started by the drop of the contact force to zero within one step at the
//!   release (amplitude ≈ `λ_last/K_NN` ≈ 1e-5 mm), so its amplitude is again a saw-tooth
//!   of the release time, and it re-touches the support (micro-impacts near grazing). At
//!   30 kHz Newton stalls at ≈ 1e-4 (1024 steps) or 5e-6 (512 steps) and the FRD branch
//!   stops at such corners near 22.8 and 29.5 kHz; at 45 and 75 kHz Newton from the
//!   linear response stalls at 4e-2 and 2e-2 (continuation from a converged neighbour is
//!   the fallback). A finer step does not cure it (4096 steps: 1e-4 at 30 kHz); resolving
//!   the local mode would need ≈ 20 steps per local period. Neither θ = 0.55/0.6
//!   (numerical damping of the ringing) nor a larger finite-difference step (1e-4…1e-2)
//!   lowers the 30 kHz stall (measured: 2.5e-5…5.7e-3); `fd_step` 1e-3 does converge at
//!   75 kHz from the linear response (22 iterations, min −2.074 mm against −2.042 mm of a
//!   full-system simulation) where 1e-6 stalls at 1.6e-2. At 45 kHz the full-system
//!   simulation settles to a period-3 response: there is no stable `T`-periodic solution
//!   to converge to.
//! * **Frequency response diagrams** (`frf --method mshbm`). The
//!   discrete period map is piecewise affine with pieces at the scale of one time step
//!   (each switch of stick/slip or contact status moving by one step is a new piece), so
//!   a branch is a staircase of corners ≈ 1e-7 apart in the continuation's scaled
//!   arclength, and the Newton noise of a converged point is of the same size (one more
//!   correction moves it by 2.6e-8 at the 86.17 kHz fold of the bar). The continuation
//!   (built for the smooth residual of the redistributed method) refuses correctors that
//!   travel more than half the step, so where the step shrinks to that scale it stops.
//!   Measured (H = 5, bar with impacts, default settings): 1 → 100 kHz stops at 14.89 kHz,
//!   85 → 95 kHz at the fold at 86.17 kHz, 60 → 100 kHz at 62.81 kHz; the friction
//!   oscillator 2 → 40 Hz (H = 10) at 2.409 Hz, where each accepted point meets a 39°
//!   corner. Tried and rejected (it made other ranges worse or crawled: 6789 points within
//!   3e-5 Hz): a travel allowance from the point's estimated error or a fixed floor, and
//!   corner escapes that accept backward turns. What works where Newton at a fixed
//!   frequency converges: stepping in frequency past the corners
//!   ([`crate::problem::ArclengthFallback::StepInFrequency`], this method's continuation
//!   policy): the friction oscillator 2 → 40 Hz (H = 10) then reaches the end
//!   (1318 points, 26 by frequency stepping, 2 min 14 s on 2 cores), 6 → 7 Hz (H = 5, 256
//!   steps) agrees with time integration within 0.6 % (tests/general_mshbm.rs). Such steps
//!   cannot turn at folds, and on the bar with impacts the branch still stops (1 → 100 kHz
//!   at 15.1 kHz, where Newton at fixed frequencies ahead does not converge either; 85 → 95
//!   kHz turns back after the fold pair at 86.17 kHz). What would cure it is a residual that
//!   is smooth between events — switching times located inside the step (event-driven
//!   integration of the N-subsystem) instead of on the step grid.
//! * Cost: every Newton iteration integrates the N-subsystem `dim + 2` times; each
//!   residual evaluation builds its own small N-subsystem integrator (a sparse Cholesky of
//!   the `n_N × n_N` iteration matrix), negligible for the few nonlinear DOFs this method
//!   is meant for.

use faer::linalg::solvers::Solve;
use faer::{c64, Mat};
use rayon::prelude::*;

use super::partition::{DofLocation, Partition, SingularStiffness};
use super::{check_dimension, complex_harmonic, fixed_response, n_dof_coefficients};
use super::{periodic_solution, store_harmonic, SolutionParts};
use crate::error::{Error, Result};
use crate::harmonic::{evaluate, n_coefficients, Sampling};
use crate::integrate::{Integrator, Scheme, Settings};
use crate::linear::PartitionedSystem;
use crate::linear::{Condensation, CondensedFrequency, ExactCondensation, LinearResponse};
use crate::model::{FrictionNormal, MassKind, Model, System, SystemContact, SystemFriction};
use crate::problem::{Linearization, PeriodicProblem};
use crate::solution::{ContactSeries, DofResponse, FrictionSeries, PeriodicSolution};
use crate::sparse::SparseMatrix;
use crate::stability::Floquet;

/// Largest system (DOFs) for which [`GeneralMsHbm`] computes Floquet multipliers: the
/// monodromy is dense, `2n × 2n`, and costs `2n + 1` full-system period integrations.
pub const MAX_FLOQUET_DOFS: usize = 1500;

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
    /// ([`Integrator::set_contact_anticipation`], default `true`): with `e_N = 0` the
    /// period map is then continuous and Newton converges; with the plain index set it jumps
    /// on the step grid and Newton stalls at a small residual.
    pub anticipate_contacts: bool,
    /// Project the positions back onto `g ≥ 0` after each step
    /// ([`Integrator::set_contact_projection`], default `true`): removes the penetration of
    /// persistent contacts, whose saw-tooth dependence on the impact time within a step
    /// otherwise stalls Newton at `≈ h |U| / g₀` (module docs).
    pub project_contacts: bool,
    /// Relative finite-difference step `ε`: `h_j = ε · max(|x_j|, s_j)` (default 1e-6).
    /// Larger steps (1e-5…1e-4) average over the grid-level discontinuities of impacts.
    pub fd_step: f64,
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
        }
    }
}

/// The time history of the nonlinear subsystem over one period for given unknowns.
#[derive(Clone, Debug)]
pub struct Trajectory {
    /// `q_N` at the step times `t_j = jT/N_s`, `j = 0..N_s` (row `j`, N numbering).
    pub displacement: Vec<Vec<f64>>,
    /// `q̇_N` at the step times.
    pub velocity: Vec<Vec<f64>>,
    /// Contact gaps at the step times.
    pub gaps: Vec<Vec<f64>>,
    /// Contact forces (impulse / h) of the step ending at `t_j` (row 0: the last step of
    /// the period, `t_{N_s} ≡ t_0`).
    pub contact_forces: Vec<Vec<f64>>,
    /// Friction forces (impulse / h), same convention.
    pub friction_forces: Vec<Vec<f64>>,
    /// State at `t = T`.
    pub end_q: Vec<f64>,
    pub end_v: Vec<f64>,
}

/// The general MS-HBM for one model.
pub struct GeneralMsHbm {
    system: System,
    harmonics: usize,
    steps: usize,
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
}

impl GeneralMsHbm {
    /// Set up the method for `model` (consistent mass, partition, checks).
    pub fn new(model: &Model, options: &GeneralOptions) -> Result<Self> {
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
        let system = model.system(MassKind::Consistent)?;
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
        };
        let condensation =
            ExactCondensation::new(PartitionedSystem::new(&system), LinearResponse::Solve)?;
        Ok(GeneralMsHbm {
            partition,
            harmonics: h,
            steps,
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

    /// Coefficients (harmonic-major) of the load `F(t)` of eq. (10) on N for `q̂_N`.
    fn load_coefficients(&self, fd: &dyn CondensedFrequency, x: &[f64]) -> Vec<f64> {
        fd.interface_load_coefficients(x)
    }

    fn check_x(&self, x: &[f64]) -> Result<()> {
        check_dimension(x, self.dimension())
    }

    /// Integrate the nonlinear subsystem over one period (eq. 10) from the state in `x`.
    fn integrate(&self, fd: &dyn CondensedFrequency, x: &[f64]) -> Result<Trajectory> {
        let n = self.n();
        let nc = n_coefficients(self.harmonics);
        let omega = fd.omega();
        let period = 2.0 * std::f64::consts::PI / omega;
        let ns = self.steps;
        let mut it = Integrator::new(
            &self.subsystem,
            &Settings {
                dt: period / ns as f64,
                scheme: Scheme::MoreauJean {
                    theta: self.theta,
                    restitution: self.restitution,
                },
                omega: Some(omega),
                energy_offset: 0.0,
            },
        )?;
        it.set_contact_anticipation(self.anticipate);
        it.set_contact_projection(self.project);
        it.set_periodic_load(self.harmonics, self.load_coefficients(fd, x))?;
        let q0 = &x[n * nc..n * nc + n];
        let v0: Vec<f64> = x[n * nc + n..n * nc + 2 * n]
            .iter()
            .map(|v| v * omega)
            .collect();
        it.set_state(0.0, q0, &v0)?;
        let mut tr = Trajectory {
            displacement: Vec::with_capacity(ns),
            velocity: Vec::with_capacity(ns),
            gaps: Vec::with_capacity(ns),
            contact_forces: vec![vec![]; ns],
            friction_forces: vec![vec![]; ns],
            end_q: vec![],
            end_v: vec![],
        };
        for j in 0..ns {
            tr.displacement.push(it.q().to_vec());
            tr.velocity.push(it.v().to_vec());
            tr.gaps.push(it.gaps().to_vec());
            it.step()?;
            let slot = (j + 1) % ns;
            tr.contact_forces[slot] = it.forces().to_vec();
            tr.friction_forces[slot] = it.friction_forces().to_vec();
        }
        tr.end_q = it.q().to_vec();
        tr.end_v = it.v().to_vec();
        Ok(tr)
    }

    fn residual_with(
        &self,
        fd: &dyn CondensedFrequency,
        x: &[f64],
    ) -> Result<(Vec<f64>, Trajectory)> {
        let n = self.n();
        let nc = n_coefficients(self.harmonics);
        let tr = self.integrate(fd, x)?;
        let sampling = Sampling::new(self.harmonics, self.steps);
        let mut r = vec![0.0; n * (nc + 2)];
        for i in 0..n {
            let samples: Vec<f64> = tr.displacement.iter().map(|q| q[i]).collect();
            let dft = sampling.dft(&samples);
            for c in 0..nc {
                r[c * n + i] = x[c * n + i] - dft[c];
            }
            r[nc * n + i] = tr.end_q[i] - x[nc * n + i];
            r[(nc + 1) * n + i] = tr.end_v[i] / fd.omega() - x[(nc + 1) * n + i];
        }
        for (f, i) in self.stuck_frictions(&tr) {
            // a continuum of periodic solutions (any stuck position): select the one with
            // zero mean friction force instead of the (dependent) position periodicity
            let fr = &self.subsystem.frictions[f];
            let w_i: f64 = fr.w.iter().filter(|(d, _)| *d == i).map(|(_, w)| w).sum();
            let mean = tr.friction_forces.iter().map(|p| p[f]).sum::<f64>() / self.steps as f64;
            r[nc * n + i] = w_i * mean / self.stiffness_nn_diagonal[i];
        }
        Ok((r, tr))
    }

    /// Limit `μ F_N` or `μ λ_N` of friction element `f` in step row `j` of `tr`.
    fn friction_limit(&self, tr: &Trajectory, f: usize, j: usize) -> f64 {
        let fr = &self.subsystem.frictions[f];
        match fr.normal {
            FrictionNormal::Force(p) => fr.mu * p,
            FrictionNormal::Contact(c) => fr.mu * tr.contact_forces[j][c].max(0.0),
        }
    }

    /// Friction elements that stick in every step of `tr` (force strictly inside its
    /// limit), each with the N-DOF of its largest direction entry. For such an element the
    /// stuck position is undetermined: every constant position in the stick range is a
    /// periodic solution, `q(T) − q(0)` is identically zero along that family and the
    /// Jacobian is singular. [`Self::residual_with`] replaces that DOF's position
    /// periodicity row by the mean friction force over the period (divided by `K_ii`, a
    /// length): the selected member is the one whose stuck position the linear part alone
    /// determines (the friction force then only balances the oscillating part, and the
    /// mean position is that of the friction-free static response).
    fn stuck_frictions(&self, tr: &Trajectory) -> Vec<(usize, usize)> {
        let mut out: Vec<(usize, usize)> = Vec::new();
        for (f, fr) in self.subsystem.frictions.iter().enumerate() {
            let stuck = (0..self.steps).all(|j| {
                let limit = self.friction_limit(tr, f, j);
                limit > 0.0 && tr.friction_forces[j][f].abs() < limit * (1.0 - 1e-9)
            });
            let dof =
                fr.w.iter()
                    .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
                    .map(|&(d, _)| d);
            if let (true, Some(d)) = (stuck, dof) {
                if !out.iter().any(|&(_, e)| e == d) {
                    out.push((f, d));
                }
            }
        }
        out
    }

    /// Complex amplitudes `z_k` (`q_L(t) = Re Σ_k z_k e^{ikωt}`) of all L DOFs, `k = 0..=H`
    /// (eq. 6).
    fn linear_part_amplitudes(
        &self,
        fd: &dyn CondensedFrequency,
        x: &[f64],
    ) -> Result<Vec<Vec<c64>>> {
        let n = self.n();
        (0..=self.harmonics)
            .map(|k| fd.linear_amplitudes(k, &complex_harmonic(x, n, k)))
            .collect()
    }

    /// State `(q, q̇)` of the whole system (system numbering) at `t = 0` of the solution
    /// `x`: the N part from `x`, the L part from its harmonics (eq. 6).
    pub fn initial_state(&mut self, x: &[f64], omega: f64) -> Result<(Vec<f64>, Vec<f64>)> {
        self.check_x(x)?;
        self.prepare(omega)?;
        let fd = self.frequency.as_deref().expect("prepared");
        self.full_initial_state(fd, x)
    }

    fn full_initial_state(
        &self,
        fd: &dyn CondensedFrequency,
        x: &[f64],
    ) -> Result<(Vec<f64>, Vec<f64>)> {
        let n = self.n();
        let nc = n_coefficients(self.harmonics);
        let mut q = vec![0.0; self.system.n_dofs()];
        let mut v = vec![0.0; self.system.n_dofs()];
        for (i, &d) in self.system.nonlinear_dofs.iter().enumerate() {
            q[d] = x[nc * n + i];
            v[d] = x[(nc + 1) * n + i] * fd.omega();
        }
        let z = self.linear_part_amplitudes(fd, x)?;
        for (l, &d) in self.system.linear_dofs.iter().enumerate() {
            for (k, zk) in z.iter().enumerate() {
                q[d] += zk[l].re;
                v[d] -= k as f64 * fd.omega() * zk[l].im;
            }
        }
        Ok((q, v))
    }

    /// The trajectory of the nonlinear subsystem over one period for `x` at `ω`
    /// (diagnostics: friction forces, contact forces, gaps).
    pub fn trajectory(&mut self, x: &[f64], omega: f64) -> Result<Trajectory> {
        self.check_x(x)?;
        self.prepare(omega)?;
        let fd = self.frequency.as_deref().expect("prepared");
        self.integrate(fd, x)
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
        let mut x = vec![0.0; n * (nc + 2)];
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
        Ok(x)
    }

    /// The monodromy matrix used by [`PeriodicProblem::floquet`] (see there): forward
    /// differences of the whole system's Moreau–Jean period map at the solution's initial
    /// state, in the scaled state `(q, q̇/ω)` of the DOFs with mass (system numbering),
    /// `2n × 2n`.
    pub fn monodromy(&mut self, x: &[f64], omega: f64) -> Result<Mat<f64>> {
        self.check_x(x)?;
        self.prepare(omega)?;
        let n_dofs = self.system.n_dofs();
        if n_dofs > MAX_FLOQUET_DOFS {
            return Err(Error::argument(
                "stability",
                format!("the model has {n_dofs} DOFs; the dense monodromy of the general MS-HBM is limited to {MAX_FLOQUET_DOFS} (use --no-stability)"),
            ));
        }
        let this = &*self;
        let fd = this.frequency.as_deref().expect("prepared");
        let (q0, v0) = this.full_initial_state(fd, x)?;
        let steps = this.steps;
        let settings = Settings {
            dt: 2.0 * std::f64::consts::PI / omega / steps as f64,
            scheme: Scheme::MoreauJean {
                theta: this.theta,
                restitution: this.restitution,
            },
            omega: Some(omega),
            energy_offset: 0.0,
        };
        let new_integrator = || -> Result<Integrator> {
            let mut it = Integrator::new(&this.system, &settings)?;
            it.set_contact_anticipation(this.anticipate);
            it.set_contact_projection(this.project);
            Ok(it)
        };
        let mut first = new_integrator()?;
        let massive = first.massive_dofs().to_vec();
        let m = massive.len();
        let period_map = |it: &mut Integrator, q: &[f64], v: &[f64]| -> Result<Vec<f64>> {
            it.set_state(0.0, q, v)?;
            for _ in 0..steps {
                it.step()?;
            }
            Ok(massive
                .iter()
                .map(|&i| it.q()[i])
                .chain(massive.iter().map(|&i| it.v()[i]))
                .collect())
        };
        let base = period_map(&mut first, &q0, &v0)?;
        let columns: Vec<Result<Vec<f64>>> = (0..2 * m)
            .into_par_iter()
            .map_init(
                || None,
                |slot: &mut Option<Integrator>, j| {
                    if slot.is_none() {
                        *slot = Some(new_integrator()?);
                    }
                    let it = slot.as_mut().expect("created");
                    let (mut q, mut v) = (q0.clone(), v0.clone());
                    let (target, scale) = if j < m {
                        (&mut q[massive[j]], this.partition.length_scale())
                    } else {
                        (
                            &mut v[massive[j - m]],
                            this.partition.length_scale() * omega,
                        )
                    };
                    let before = *target;
                    *target += this.fd_step * before.abs().max(scale);
                    let h = *target - before;
                    let end = period_map(it, &q, &v)?;
                    Ok(end.iter().zip(&base).map(|(a, b)| (a - b) / h).collect())
                },
            )
            .collect();
        // in the scaled state (q, q̇/ω): a similarity (same eigenvalues) that balances the
        // blocks, so that the eigenvalues are computed accurately
        let d = |i: usize| if i < m { 1.0 } else { omega };
        let mut phi = Mat::<f64>::zeros(2 * m, 2 * m);
        for (j, col) in columns.into_iter().enumerate() {
            for (i, v) in col?.into_iter().enumerate() {
                phi[(i, j)] = v * d(j) / d(i);
            }
        }
        Ok(phi)
    }
}

impl PeriodicProblem for GeneralMsHbm {
    /// Finite-difference Jacobian: Newton does not contract quadratically. The time-stepped
    /// residual is piecewise affine with pieces one time step wide, so the branch is a
    /// staircase of corners ≈ 1e-7 apart in scaled arclength (module docs): the continuation
    /// steps in frequency once the arclength step falls below 1e-4, well above them.
    fn continuation_policy(&self) -> crate::problem::ContinuationPolicy {
        crate::problem::ContinuationPolicy {
            newton_contraction: crate::problem::NewtonContraction::Unchecked,
            where_arclength_fails: crate::problem::ArclengthFallback::StepInFrequency {
                min_arclength_step: 1e-4,
            },
        }
    }

    fn dimension(&self) -> usize {
        self.n() * (n_coefficients(self.harmonics) + 2)
    }

    fn length_scale(&self) -> f64 {
        self.partition.length_scale()
    }

    fn initial_guess(&mut self, omega: f64) -> Result<Vec<f64>> {
        self.linear_response(omega)
    }

    fn residual(&mut self, x: &[f64], omega: f64) -> Result<Vec<f64>> {
        self.check_x(x)?;
        self.prepare(omega)?;
        let fd = self.frequency.as_deref().expect("prepared");
        Ok(self.residual_with(fd, x)?.0)
    }

    fn linearize(&mut self, x: &[f64], omega: f64) -> Result<Linearization> {
        self.check_x(x)?;
        self.prepare(omega)?;
        let this = &*self;
        let fd = this.frequency.as_deref().expect("prepared");
        let residual = this.residual_with(fd, x)?.0;
        let dim = this.dimension();
        let columns: Vec<Result<Vec<f64>>> = (0..dim)
            .into_par_iter()
            .map(|j| {
                let h = this.fd_step * x[j].abs().max(this.partition.length_scale());
                let mut xp = x.to_vec();
                xp[j] += h;
                let h = xp[j] - x[j];
                let rp = this.residual_with(fd, &xp)?.0;
                Ok(rp.iter().zip(&residual).map(|(a, b)| (a - b) / h).collect())
            })
            .collect();
        let mut jacobian = Mat::<f64>::zeros(dim, dim);
        for (j, col) in columns.into_iter().enumerate() {
            for (i, v) in col?.into_iter().enumerate() {
                jacobian[(i, j)] = v;
            }
        }
        let dw = 0.1 * this.fd_step * omega;
        let fdp = this.frequency_data(omega + dw)?;
        let dw = (omega + dw) - omega;
        let rp = this.residual_with(&*fdp, x)?.0;
        let d_omega = rp
            .iter()
            .zip(&residual)
            .map(|(a, b)| (a - b) / dw)
            .collect();
        Ok(Linearization {
            residual,
            jacobian,
            d_omega,
        })
    }

    /// Floquet multipliers (METHODS §7.2) as the eigenvalues of the monodromy matrix of
    /// the **whole system's** period map — the state `(q, q̇)` of all DOFs at `t = 0` mapped
    /// to the state at `t = T` by the same Moreau–Jean integrator (same steps, θ, `e_N`,
    /// anticipation and projection) — by forward finite differences around the solution's
    /// initial state ([`Self::initial_state`]), columns in parallel (rayon).
    ///
    /// Why the whole system and not the N-subsystem: the N-subsystem sees the linear part
    /// only through the harmonics `q̂_N` (eq. 6), a non-causal frequency-domain coupling
    /// with no state of its own; a perturbation `e^{st} p(t)` of the orbit needs the L
    /// states anyway. The full-system map is the physical one, and for a linear system it is
    /// linear, so its finite-difference monodromy is exact up to rounding and equals the
    /// discrete (trapezoidal, θ = ½) transition matrix, whose eigenvalues approximate
    /// `exp(s_k T)` to the integrator's accuracy. With contacts the map is piecewise
    /// affine (`e_N = 0`, anticipation, projection): the finite difference gives the slope
    /// of the piece the solution lies in, including the effect of impacts (a persistent
    /// contact with `e_N = 0` contributes zero multipliers). Caveats: the MS-HBM orbit is a
    /// fixed point of the *harmonically truncated* problem, not exactly of the full
    /// discrete map (the multipliers are those of the full map linearised at the orbit's
    /// initial state); near grazing the piece can be smaller than the step and the
    /// multipliers unreliable (METHODS §7.2). So they describe the full model near the
    /// orbit, not the H-truncated branch: on the bar with impacts at H = 5 the branch has a
    /// fold pair at 86.17 / 86.27 kHz, yet no multiplier approaches +1 there (largest
    /// |μ| ≈ 0.94 on all three parts), and full-system simulations started on the lower,
    /// middle and upper orbits all settle to one and the same periodic state (contact-DOF
    /// minimum −0.342 mm against −0.334 / −0.369 / −0.373 mm of the H = 5 orbits): the
    /// full model has a single attractor there and the fold pair is a truncation effect. Cost: `2n + 1` period integrations of the
    /// whole model and a dense `2n × 2n` eigenproblem (`n ≤` [`MAX_FLOQUET_DOFS`]) —
    /// one reason the general method is expensive for FE models.
    fn floquet(&mut self, x: &[f64], omega: f64) -> Result<Option<Floquet>> {
        let phi = self.monodromy(x, omega)?;
        let values = phi
            .eigenvalues()
            .map_err(|e| Error::Numerical(format!("eigenvalues of the monodromy matrix: {e:?}")))?;
        Ok(Some(Floquet::from_eigenvalues(values)))
    }

    fn solution(&mut self, x: &[f64], omega: f64, response_dof: usize) -> Result<PeriodicSolution> {
        let location = self.partition.locate_response(&self.system, response_dof)?;
        self.check_x(x)?;
        self.prepare(omega)?;
        let fd = self.frequency.as_deref().expect("prepared");
        let (residual, tr) = self.residual_with(fd, x)?;
        let n = self.n();
        let h = self.harmonics;
        let ns = self.steps;
        let sampling = Sampling::new(h, ns);
        let extremes = |v: &[f64]| -> (f64, f64) {
            v.iter()
                .fold((f64::NEG_INFINITY, f64::INFINITY), |(mx, mn), &x| {
                    (mx.max(x), mn.min(x))
                })
        };
        let series = |i: usize| -> Vec<f64> { tr.displacement.iter().map(|q| q[i]).collect() };
        let mut contacts = Vec::with_capacity(self.system.contacts.len());
        for (c, sc) in self.system.contacts.iter().enumerate() {
            let i = self.partition.contact_n_index(&self.system, c);
            let disp = series(i);
            let (max, min) = extremes(&disp);
            contacts.push(ContactSeries {
                dof: self.system.model_dof[sc.w[0].0],
                coefficients: n_dof_coefficients(x, n, h, i),
                displacement: disp,
                gap: tr.gaps.iter().map(|g| g[c]).collect(),
                force: tr.contact_forces.iter().map(|f| f[c]).collect(),
                max,
                min,
            });
        }
        let frictions: Vec<FrictionSeries> = self
            .subsystem
            .frictions
            .iter()
            .enumerate()
            .map(|(f, fr)| {
                let force: Vec<f64> = tr.friction_forces.iter().map(|p| p[f]).collect();
                let (max, min) = extremes(&force);
                FrictionSeries {
                    dof: self.subsystem.model_dof[fr.w[0].0],
                    limit: (0..ns).map(|j| self.friction_limit(&tr, f, j)).collect(),
                    force,
                    max,
                    min,
                }
            })
            .collect();
        let response = match location {
            DofLocation::Fixed => fixed_response(response_dof, h),
            DofLocation::Nonlinear(i) => {
                let (max, min) = extremes(&series(i));
                DofResponse {
                    dof: response_dof,
                    coefficients: n_dof_coefficients(x, n, h, i),
                    max,
                    min,
                }
            }
            DofLocation::Linear(l) => {
                let coefficients = fd.linear_dof_coefficients(x, l)?;
                // the truncated series on a grid 4× finer than the steps
                let fine: Vec<f64> = (0..4 * ns)
                    .map(|j| {
                        evaluate(
                            &coefficients,
                            2.0 * std::f64::consts::PI * j as f64 / (4 * ns) as f64,
                        )
                    })
                    .collect();
                let (max, min) = extremes(&fine);
                DofResponse {
                    dof: response_dof,
                    coefficients,
                    max,
                    min,
                }
            }
        };
        Ok(periodic_solution(
            &self.system,
            &self.partition,
            omega,
            SolutionParts {
                method: crate::solution::MethodKind::General,
                quadrature: crate::harmonic::Quadrature::Sampled,
                harmonics: h,
                taus: &sampling.taus,
                residual: &residual,
                contacts,
                frictions,
                response,
            },
        ))
    }
}
