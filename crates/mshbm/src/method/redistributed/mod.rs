//! The redistributed MS-HBM (paper Sections 3.1–3.2): with a massless contact boundary the
//! nonlinear subsystem is static, so a periodic solution is fully described by the Fourier
//! coefficients `x = q̂_N` of the contact-node DOFs (eq. 31) and solves the connectivity
//! condition `R(x) = x − FFT(q_N(t)) = 0` (eq. 30).
//!
//! Per frequency (eq. 25): for each harmonic `k` the L-part dynamic stiffness
//! `A_k = K_LL − (kω)² M̄_LL + i kω C_LL` is factored once, and the affine map from `x` to the
//! load on the contact subsystem `b(τ) = −K_NL q_L(τ) + f_N(τ)` is precomputed: with the
//! complex amplitude `z_k = a_k − i b_k` of harmonic `k` of `x`,
//! `K_NL q̂_L,k = u0_k − G_k z_k`, `G_k = K_NL A_k⁻¹ K_LN`, `u0_k = K_NL A_k⁻¹ f_L,k`
//! ([`crate::linear::ExactCondensation`]). No factorization happens inside the per-sample loop.
//!
//! Per evaluation: the static contact problem (eqs. 26–29) is solved per sample or per
//! interval ([`quadrature`]), giving `q̂_N = Σ_A (P_A B Γ_Aᵀ + s_A Γ_A[:,0]ᵀ)`. The
//! semi-analytical Jacobian (eqs. 32–44; docs/theory.md (T41)–(T42)) is
//! `J = I − Σ_A (Γ_A ⊗ P_A) ∂vec(B)/∂x`, where `∂B/∂x` is block-diagonal per harmonic
//! (`[[Re G_k, Im G_k], [−Im G_k, Re G_k]]`), and
//! `∂R/∂ω = −Σ_A (Γ_A ⊗ P_A) ∂vec(B)/∂ω` with
//! `∂(K_NL q̂_L,k)/∂ω = −K_NL A_k⁻¹ (∂A_k/∂ω) q̂_L,k`.

pub mod quadrature;

use std::rc::Rc;

use faer::Mat;

use super::partition::{contact_directions, DofLocation, Partition, SingularStiffness};
use super::{check_dimension, fixed_response, n_dof_coefficients};
use super::{periodic_solution, SolutionParts};
use crate::contact::static_contact::StaticContact;
use crate::error::{Error, Result};
use crate::harmonic::{evaluate, golden_section_max, n_coefficients, Quadrature, Sampling};
use crate::limits::Limits;
use crate::linear::PartitionedSystem;
use crate::linear::{Condensation, CondensedFrequency, ExactCondensation, LinearResponse};
use crate::method::default_samples;
use crate::model::{MassKind, Model, System};
use crate::problem::{Linearization, PeriodicProblem};
use crate::solution::{ContactSeries, DofResponse, PeriodicSolution};
use crate::stability::{self, InterfaceModes, ReducedSystem, StabilityOptions};
use quadrature::{integrate, load_at, Integration};

/// Largest linear part for which the dense monodromy matrix is formed.
pub const MAX_DENSE_STABILITY_DOFS: usize = 1500;

/// Settings of the redistributed MS-HBM.
#[derive(Clone, Debug)]
pub struct RedistributedOptions {
    /// Number of harmonics `H ≥ 1`.
    pub harmonics: usize,
    /// Samples per period `N_s ≥ 2H + 1` (`None`: [`default_samples`]).
    pub samples: Option<usize>,
    pub quadrature: Quadrature,
}

impl RedistributedOptions {
    /// `H` harmonics, default samples, exact quadrature.
    pub fn new(harmonics: usize) -> Self {
        RedistributedOptions {
            harmonics,
            samples: None,
            quadrature: Quadrature::Exact,
        }
    }
}

/// The redistributed MS-HBM for one model.
pub struct RedistributedMsHbm {
    system: System,
    harmonics: usize,
    sampling: Sampling,
    quadrature: Quadrature,
    /// The linear part condensed onto the contact DOFs (eq. 25; `M_NL = C_NL = 0`).
    condensation: Box<dyn Condensation>,
    /// `L | N` partition and length scale.
    partition: Partition,
    contact: StaticContact,
    /// The condensation at the last frequency.
    frequency: Option<Box<dyn CondensedFrequency>>,
    stability_options: StabilityOptions,
    /// The L-system of the Floquet analysis (full or reduced), built on first use.
    stability_system: Option<Rc<ReducedSystem>>,
    /// First-order matrix and its eigendecomposition per active set (stability).
    stability_cache: std::collections::HashMap<Vec<bool>, Rc<StabilityData>>,
    /// The memory budget, also of the Floquet analysis.
    limits: Limits,
}

type StabilityData = (Mat<f64>, Option<crate::stability::ModalExponential>);

impl RedistributedMsHbm {
    /// Set up the method for `model` (mass redistribution, partition, checks) within the
    /// default [`Limits`] (the machine's memory).
    pub fn new(model: &Model, options: &RedistributedOptions) -> Result<Self> {
        Self::within(model, options, &Limits::default())
    }

    /// [`RedistributedMsHbm::new`], refusing before allocating when the method's memory
    /// estimate ([`super::memory::redistributed`]) exceeds `limits`.
    pub fn within(model: &Model, options: &RedistributedOptions, limits: &Limits) -> Result<Self> {
        let h = options.harmonics;
        let samples = options.samples.unwrap_or_else(|| default_samples(h));
        super::check_resolution(h, samples, "samples")?;
        if model.contacts.is_empty() {
            return Err(Error::argument(
                "model",
                "the model has no contact; the redistributed MS-HBM needs at least one",
            ));
        }
        let system = model.system(MassKind::Redistributed)?;
        super::memory::redistributed(&system, h, samples).check(
            &format!("the redistributed MS-HBM with {h} harmonics and {samples} samples"),
            limits,
        )?;
        let nl = &system.nonlinear_dofs;
        let all: Vec<usize> = (0..system.n_dofs()).collect();
        if system
            .damping
            .submatrix(nl, &all)
            .iter()
            .any(|(_, _, v)| v != 0.0)
        {
            return Err(Error::field(
                &model.source,
                "damping",
                "the redistributed MS-HBM needs damping that does not act on the massless contact DOFs (C_NN = C_NL = 0); \
                 stiffness-proportional damping (beta) or a damping matrix touching the contact nodes makes the contact subsystem dynamic. \
                 Use mass-proportional damping (damping.alpha or damping.first_mode_ratio)",
            ));
        }
        let k_nn = system.stiffness.submatrix(nl, nl);
        let gap: Vec<f64> = system.contacts.iter().map(|c| c.gap).collect();
        let contact = StaticContact::new(&k_nn, contact_directions(&system), gap)?;
        let condensation =
            ExactCondensation::new(PartitionedSystem::new(&system), LinearResponse::Solve)?;
        // the MS-HBM needs the structure held (K positive definite)
        let partition = Partition::new(&system, SingularStiffness::Refuse)?;
        Ok(RedistributedMsHbm {
            partition,
            harmonics: h,
            sampling: Sampling::within(h, samples, limits)?,
            quadrature: options.quadrature,
            condensation: Box::new(condensation),
            contact,
            frequency: None,
            stability_options: StabilityOptions::default(),
            stability_system: None,
            stability_cache: std::collections::HashMap::new(),
            limits: *limits,
            system,
        })
    }

    /// The system (redistributed mass, Dirichlet DOFs removed).
    pub fn system(&self) -> &System {
        &self.system
    }

    pub fn harmonics(&self) -> usize {
        self.harmonics
    }

    pub fn samples(&self) -> usize {
        self.sampling.len()
    }

    fn n(&self) -> usize {
        self.system.nonlinear_dofs.len()
    }

    fn prepare(&mut self, omega: f64) -> Result<()> {
        if self.frequency.as_ref().is_some_and(|f| f.omega() == omega) {
            return Ok(());
        }
        super::check_frequency(omega)?;
        self.frequency = Some(self.condensation.at(omega, self.harmonics)?);
        Ok(())
    }

    /// The condensation at the prepared frequency.
    fn condensed(&self) -> &dyn CondensedFrequency {
        self.frequency.as_deref().expect("prepared")
    }

    /// Coefficients `B` (harmonic-major, `c·n + i`) of the load `b(τ)` on the contact
    /// subsystem for the unknowns `x`.
    fn load_coefficients(&self, x: &[f64]) -> Vec<f64> {
        self.condensed().interface_load_coefficients(x)
    }

    /// `Σ_A (P_A B Γ_Aᵀ + with_offset · s_A Γ_A[:,0]ᵀ)`.
    fn assemble_coefficients(
        &self,
        integration: &Integration,
        b: &[f64],
        with_offset: bool,
    ) -> Vec<f64> {
        let n = self.n();
        let nc = n_coefficients(self.harmonics);
        let mut q = vec![0.0; n * nc];
        let mut bg = vec![0.0; n];
        for group in &integration.groups {
            let p = &group.set.compliance;
            for m in 0..nc {
                bg.iter_mut().for_each(|v| *v = 0.0);
                for c in 0..nc {
                    let gmc = group.gram[m * nc + c];
                    if gmc != 0.0 {
                        for i in 0..n {
                            bg[i] += b[c * n + i] * gmc;
                        }
                    }
                }
                for i in 0..n {
                    let mut s: f64 = (0..n).map(|j| p[i * n + j] * bg[j]).sum();
                    if with_offset {
                        s += group.set.offset[i] * group.gram[m * nc];
                    }
                    q[m * n + i] += s;
                }
            }
        }
        q
    }

    fn evaluate(&mut self, x: &[f64], omega: f64) -> Result<(Vec<f64>, Integration, Vec<f64>)> {
        check_dimension(x, self.dimension())?;
        self.prepare(omega)?;
        let b = self.load_coefficients(x);
        let integration = integrate(&mut self.contact, &b, &self.sampling, self.quadrature)?;
        let q = self.assemble_coefficients(&integration, &b, true);
        let r: Vec<f64> = x.iter().zip(&q).map(|(a, c)| a - c).collect();
        Ok((r, integration, b))
    }

    /// `J = I − Σ_A (Γ_A ⊗ P_A) ∂vec(B)/∂x`, computed block row by block row: with
    /// `S_mc = Σ_A Γ_A[m, c] P_A` (one pass over the active sets per row `m`), the block
    /// `(m, cos_k)` is `S_{m,cos_k} Re G_k − S_{m,sin_k} Im G_k` and `(m, sin_k)` is
    /// `S_{m,cos_k} Im G_k + S_{m,sin_k} Re G_k` (`G_0` real). That is `(4H + 1)(2H + 1)`
    /// products of `n × n` matrices whatever the number of active sets, which grows with
    /// the samples and the contacts.
    fn jacobian_matrix(&self, integration: &Integration) -> Mat<f64> {
        use faer::linalg::matmul::matmul;
        use faer::reborrow::ReborrowMut;
        use faer::{Accum, Par};
        let f = self.condensed();
        let n = self.n();
        let nc = n_coefficients(self.harmonics);
        let dim = n * nc;
        let mut jac = Mat::<f64>::identity(dim, dim);
        // Re G_k and Im G_k
        let g_parts: Vec<(Mat<f64>, Mat<f64>)> = (0..=self.harmonics)
            .map(|k| {
                let g = f.interface_stiffness(k);
                (
                    Mat::from_fn(n, n, |l, j| g[l * n + j].re),
                    Mat::from_fn(n, n, |l, j| g[l * n + j].im),
                )
            })
            .collect();
        let mut s: Vec<Mat<f64>> = (0..nc).map(|_| Mat::zeros(n, n)).collect();
        for m in 0..nc {
            s.iter_mut().for_each(|s_c| s_c.fill(0.0));
            let mut used = vec![false; nc];
            for group in &integration.groups {
                let p = faer::MatRef::from_row_major_slice(&group.set.compliance, n, n);
                for (c, s_c) in s.iter_mut().enumerate() {
                    let g = group.gram[m * nc + c];
                    if g != 0.0 {
                        used[c] = true;
                        faer::zip!(s_c.as_mut(), p).for_each(|faer::unzip!(s, p)| *s += g * *p);
                    }
                }
            }
            // rows m of the Jacobian, block column `col`: += sign · S · G
            let mut rows = jac.as_mut().subrows_mut(m * n, n);
            let mut add = |col: usize, s: &Mat<f64>, g: &Mat<f64>, sign: f64| {
                let block = rows.rb_mut().subcols_mut(col * n, n);
                matmul(block, Accum::Add, s, g, sign, Par::Seq);
            };
            if used[0] {
                add(0, &s[0], &g_parts[0].0, -1.0);
            }
            for (k, (g_re, g_im)) in g_parts.iter().enumerate().skip(1) {
                let (cc, ss) = (2 * k - 1, 2 * k);
                if used[cc] {
                    add(cc, &s[cc], g_re, -1.0);
                    add(ss, &s[cc], g_im, -1.0);
                }
                if used[ss] {
                    add(cc, &s[ss], g_im, 1.0);
                    add(ss, &s[ss], g_re, -1.0);
                }
            }
        }
        jac
    }

    /// The contact-free linear response at `ω` (the initial guess).
    pub fn linear_response(&mut self, omega: f64) -> Result<Vec<f64>> {
        self.prepare(omega)?;
        let n = self.n();
        let nc = n_coefficients(self.harmonics);
        let open = vec![false; self.contact.n_contacts()];
        let set = self.contact.active_set(&open)?;
        let mut gram = vec![0.0; nc * nc];
        (0..nc).for_each(|m| gram[m * nc + m] = 1.0);
        let integration = Integration {
            groups: vec![quadrature::Group { set, gram }],
            sample_group: vec![],
            switches: vec![],
            intervals: vec![],
        };
        // R(x) = x − P B(x) is affine for the open set: one Newton step from 0 solves it
        let zero_x = vec![0.0; n * nc];
        let b = self.load_coefficients(&zero_x);
        let q0 = self.assemble_coefficients(&integration, &b, true);
        let jac = self.jacobian_matrix(&integration);
        // the Newton step from 0, `J d = −R(0) = q0`
        crate::dense::solve_lu(&jac, &q0, "the Jacobian is singular")
    }

    /// Settings of the Floquet analysis ([`PeriodicProblem::floquet`]); the default is
    /// [`StabilityOptions::default`] (full space for small linear parts, a reduced basis for
    /// large ones).
    pub fn set_stability_options(&mut self, options: StabilityOptions) -> Result<()> {
        if options.modes == Some(0) {
            return Err(Error::argument(
                "stability modes",
                "the reduced basis needs at least one fixed-interface mode",
            ));
        }
        if options != self.stability_options {
            self.stability_options = options;
            self.stability_system = None;
            self.stability_cache.clear();
        }
        Ok(())
    }

    /// The linearised L-system in the coordinates of the Floquet analysis (built once).
    fn stability_system(&mut self) -> Result<Rc<ReducedSystem>> {
        if let Some(s) = &self.stability_system {
            return Ok(s.clone());
        }
        let blocks = self.condensation.system();
        let (lin, k_nl) = (&blocks.ll, &blocks.nl.stiffness);
        let nl = blocks.n_linear();
        let system = match self.stability_options.modes_for(nl) {
            None if nl > MAX_DENSE_STABILITY_DOFS => {
                return Err(Error::argument(
                    "stability modes",
                    format!("the linear part has {nl} DOFs; the full-space monodromy is limited to {MAX_DENSE_STABILITY_DOFS}: use a reduced basis of fewer modes"),
                ))
            }
            None => {
                self.limits.check_memory(
                    &format!("the full-space Floquet analysis of {nl} linear DOFs"),
                    stability::full_space_bytes(nl),
                )?;
                ReducedSystem::full(&lin.mass, &lin.damping, &lin.stiffness, k_nl)?
            }
            Some(m) => {
                let block = nl.saturating_mul(m.saturating_mul(2));
                if self.stability_options.modes.is_none()
                    && block > stability::DEFAULT_REDUCED_BLOCK_LIMIT
                {
                    return Err(Error::argument(
                        "stability modes",
                        format!(
                            "the linear part has {nl} DOFs: the default reduced basis of {m} modes would take minutes \
                             (a subspace of {nl} × {} values, more than the default's {}); the solution is computed without it. \
                             Ask for the multipliers with an explicit number of modes (CLI: --stability-modes N; the cost grows with N²)",
                            2 * m,
                            stability::DEFAULT_REDUCED_BLOCK_LIMIT
                        ),
                    ));
                }
                self.limits.check_memory(
                    &format!("the reduced Floquet basis of {m} modes of {nl} linear DOFs"),
                    stability::reduced_basis_bytes(nl, m),
                )?;
                // the basis whose damping coupling vanishes for the model's damping
                let interface = if self.system.beta_condensed != 0.0 {
                    InterfaceModes::Relaxed {
                        k_nn: &blocks.nn.stiffness,
                    }
                } else {
                    InterfaceModes::Held
                };
                ReducedSystem::reduced(&lin.mass, &lin.damping, &lin.stiffness, k_nl, m, interface)?
            }
        };
        let system = Rc::new(system);
        self.stability_system = Some(system.clone());
        Ok(system)
    }
}

impl PeriodicProblem for RedistributedMsHbm {
    /// Exact Jacobian of a residual that is smooth between grazing events (docs/theory.md
    /// (T41)–(T42)):
    /// Newton contracts quadratically; the branch has isolated corners at grazing contacts.
    fn continuation_policy(&self) -> crate::problem::ContinuationPolicy {
        crate::problem::ContinuationPolicy {
            newton_contraction: crate::problem::NewtonContraction::Quadratic,
            where_arclength_fails: crate::problem::ArclengthFallback::EscapeCorner,
        }
    }

    fn dimension(&self) -> usize {
        self.n() * n_coefficients(self.harmonics)
    }

    fn length_scale(&self) -> f64 {
        self.partition.length_scale()
    }

    fn initial_guess(&mut self, omega: f64) -> Result<Vec<f64>> {
        self.linear_response(omega)
    }

    fn residual(&mut self, x: &[f64], omega: f64) -> Result<Vec<f64>> {
        Ok(self.evaluate(x, omega)?.0)
    }

    fn linearize(&mut self, x: &[f64], omega: f64) -> Result<Linearization> {
        let (residual, integration, _) = self.evaluate(x, omega)?;
        let jacobian = self.jacobian_matrix(&integration);
        let db = self.condensed().interface_load_frequency_derivative(x)?;
        let dq = self.assemble_coefficients(&integration, &db, false);
        let d_omega = dq.iter().map(|v| -v).collect();
        Ok(Linearization {
            residual,
            jacobian,
            d_omega,
        })
    }

    fn solution(&mut self, x: &[f64], omega: f64, response_dof: usize) -> Result<PeriodicSolution> {
        let location = self.partition.locate_response(&self.system, response_dof)?;
        let (residual, integration, b) = self.evaluate(x, omega)?;
        let n = self.n();
        let h = self.harmonics;
        let nc = n_coefficients(h);
        let mut basis_buf = vec![0.0; nc];
        let mut q_s = Vec::with_capacity(self.sampling.len());
        let mut f_s = Vec::with_capacity(self.sampling.len());
        let mut g_s = Vec::with_capacity(self.sampling.len());
        for &tau in &self.sampling.taus {
            let load = load_at(&b, n, h, tau, &mut basis_buf);
            let set = self.contact.solve(&load)?;
            let q = set.displacement(&load);
            g_s.push(self.contact.gaps(&q));
            f_s.push(set.force(&load));
            q_s.push(q);
        }
        let taus = self.sampling.taus.clone();
        // the N displacements at every switching time, once for all DOFs (a switch is an
        // extremum candidate of every DOF, and each costs a static contact solve)
        let mut q_switches = Vec::with_capacity(integration.switches.len());
        for s in &integration.switches {
            let load = load_at(&b, n, h, s.tau, &mut basis_buf);
            q_switches.push(match self.contact.solve(&load) {
                Ok(set) => set.displacement(&load),
                Err(_) => vec![f64::NAN; n],
            });
        }
        let contact = &mut self.contact;
        // exact displacement of N-DOF i at τ (the time signal, not the truncated series)
        let mut q_at = |i: usize, tau: f64| -> f64 {
            let load = load_at(&b, n, h, tau, &mut basis_buf);
            match contact.solve(&load) {
                Ok(set) => set.displacement_of(i, &load),
                Err(_) => f64::NAN,
            }
        };
        let mut n_extremes = |i: usize| -> (f64, f64) {
            let samples: Vec<f64> = q_s.iter().map(|q| q[i]).collect();
            let mut mx = refine_extremum(&taus, &samples, 1.0, |t| q_at(i, t));
            let mut mn = refine_extremum(&taus, &samples, -1.0, |t| q_at(i, t));
            for q in &q_switches {
                mx = mx.max(q[i]);
                mn = mn.min(q[i]);
            }
            (mx, mn)
        };
        let mut contacts = Vec::with_capacity(self.system.contacts.len());
        for (c, sc) in self.system.contacts.iter().enumerate() {
            let i = self.partition.contact_n_index(&self.system, c);
            let (max, min) = n_extremes(i);
            contacts.push(ContactSeries {
                dof: self.system.model_dof[sc.w[0].0],
                coefficients: n_dof_coefficients(x, n, h, i),
                displacement: q_s.iter().map(|q| q[i]).collect(),
                gap: g_s.iter().map(|g| g[c]).collect(),
                force: f_s.iter().map(|l| l[c]).collect(),
                max,
                min,
            });
        }
        let response = match location {
            DofLocation::Fixed => fixed_response(response_dof, h),
            DofLocation::Nonlinear(i) => {
                let (max, min) = n_extremes(i);
                DofResponse {
                    dof: response_dof,
                    coefficients: n_dof_coefficients(x, n, h, i),
                    max,
                    min,
                }
            }
            DofLocation::Linear(l) => {
                let coefficients = self.condensed().linear_dof_coefficients(x, l)?;
                let samples: Vec<f64> = taus.iter().map(|&t| evaluate(&coefficients, t)).collect();
                let max = refine_extremum(&taus, &samples, 1.0, |t| evaluate(&coefficients, t));
                let min = refine_extremum(&taus, &samples, -1.0, |t| evaluate(&coefficients, t));
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
                method: crate::solution::MethodKind::Redistributed,
                quadrature: self.quadrature,
                harmonics: h,
                taus: &taus,
                residual: &residual,
                contacts,
                frictions: vec![],
                response,
            },
        ))
    }

    /// Floquet multipliers (docs/theory.md (T80)–(T82), derived): condensing the static contact
    /// subsystem leaves the linear time-periodic system `M̄ q̈_L + C q̇_L + K_eff(t) q_L = 0`
    /// with `K_eff = K_LL − K_LN P_A(t) K_NL`, piecewise constant between the switching
    /// times; its vector field is continuous, so no saltation terms. The monodromy is the
    /// product of exact matrix exponentials over the intervals of constant active set, in
    /// the full L-space (dense: up to 1500 L-DOFs) or in the reduced basis of
    /// [`ReducedSystem`] (fixed-interface modes plus static interface correction, with its
    /// truncation error), as [`RedistributedMsHbm::set_stability_options`] chooses.
    fn floquet(&mut self, x: &[f64], omega: f64) -> Result<Option<crate::stability::Floquet>> {
        let reduced = self.stability_system()?;
        let (_, integration, _) = self.evaluate(x, omega)?;
        // the first-order matrices depend only on the active set (not on ω): build them,
        // and their eigendecompositions, once per set
        for g in &integration.groups {
            if !self.stability_cache.contains_key(&g.set.closed) {
                let a = reduced.state_matrix(&g.set.compliance)?;
                let modal = crate::stability::ModalExponential::new(&a);
                self.stability_cache
                    .insert(g.set.closed.clone(), Rc::new((a, modal)));
            }
        }
        let data: Vec<Rc<StabilityData>> = integration
            .groups
            .iter()
            .map(|g| self.stability_cache[&g.set.closed].clone())
            .collect();
        let intervals: Vec<(usize, f64)> = integration
            .intervals
            .iter()
            .filter(|(a, b, _)| b > a)
            .map(|&(a, b, g)| (g, (b - a) / omega))
            .collect();
        let phi = if intervals.iter().all(|(g, _)| data[*g].1.is_some()) {
            let pieces: Vec<(&crate::stability::ModalExponential, f64)> = intervals
                .iter()
                .map(|&(g, dt)| (data[g].1.as_ref().expect("checked"), dt))
                .collect();
            crate::stability::modal_monodromy(&pieces)
        } else {
            let pieces: Vec<(&Mat<f64>, f64)> =
                intervals.iter().map(|&(g, dt)| (&data[g].0, dt)).collect();
            crate::stability::piecewise_monodromy(&pieces)
        };
        let values = phi
            .eigenvalues()
            .map_err(|e| Error::Numerical(format!("eigenvalues of the monodromy matrix: {e:?}")))?;
        Ok(Some(crate::stability::Floquet::from_eigenvalues(values)))
    }
}

/// The maximum (`sign = 1`) or minimum (`sign = −1`) of a periodic signal sampled at `taus`
/// (`values`), refined by golden-section search of `f` around the best sample (so that the
/// extreme is that of the time signal, not of the sample grid).
fn refine_extremum(taus: &[f64], values: &[f64], sign: f64, mut f: impl FnMut(f64) -> f64) -> f64 {
    let n = taus.len();
    let (j, best) = values
        .iter()
        .enumerate()
        .fold((0, f64::NEG_INFINITY), |(bj, bv), (j, &v)| {
            if sign * v > bv {
                (j, sign * v)
            } else {
                (bj, bv)
            }
        });
    let step = 2.0 * std::f64::consts::PI / n as f64;
    let refined = golden_section_max(|t| sign * f(t), taus[j] - step, taus[j] + step);
    sign * best.max(refined)
}
