// size: the method's struct, its set-up and the PeriodicProblem entry points, which share its private state; the residual, Jacobian, outputs and Floquet parts live in the sibling files.
//! The redistributed MS-HBM (paper Sections 3.1–3.2): with a massless contact boundary the
//! nonlinear subsystem is static, and a periodic solution solves the connectivity condition
//! of eq. (30). The code writes it in the contact coordinates (docs/theory.md §16): the
//! unknowns are the Fourier coefficients `v = Wᵀ q̂` of the contacts' displacements
//! (`n_c (2H+1)` of them, whatever the number of `N` DOFs; on one contact DOF, as on the
//! paper's bar, they are exactly the paper's `x = q̂_N`), and per harmonic `k`
//!
//! ```text
//! φ_k = R_k⁻¹ (v_k − Wᵀ A_k⁻¹ f_k)                    the force the structure needs for v,
//! u_k = g0 δ_k0 + v_k − D φ_k                          the free gap (T123),
//! R(v, ω) = D (φ − λ̂(u))                              (docs/theory.md (T128)),
//! ```
//!
//! where `λ̂(u)` are the Fourier coefficients of the contact forces of the static contact
//! problem per instant (eqs. 26–29, solved for the free gap `γ(τ)` of coefficients `u`),
//! `D` the Delassus matrix and `R_k = Wᵀ A_k⁻¹ W` the receptance of the whole structure at
//! the contacts ([`crate::linear::Receptance`]). On one contact DOF `R(v)` is the paper's
//! residual `x − 𝓕[q_N]` itself; in general it is that residual with the contact-free
//! directions solved exactly. The paper's `x = q̂_N` of every contact-node DOF follows from
//! the solution ([`PeriodicSolution::contact_node_harmonics`]).
//!
//! Per frequency: `R_k`, `Wᵀ A_k⁻¹ f_k` and `R_k⁻¹` once. Per evaluation: the static contact
//! problem per sample or per interval ([`quadrature`]) gives `λ̂ = Σ_A (Γ_A ⊗ F_A) u` with
//! the force map `F_A = ∂λ/∂γ` of each active set (docs/theory.md (T124)). The
//! semi-analytical Jacobian (eqs. 32–44 in these coordinates, docs/theory.md (T129)) is
//! `J = blockdiag(D R_k⁻¹) − (I ⊗ D) Σ_A (Γ_A ⊗ F_A) blockdiag(I − D R_k⁻¹)`.

mod evaluation;
mod frequency_maps;
pub mod friction;
mod frictional;
mod frictional_floquet;
mod interval_signal;
mod jacobian;
mod memory_plan;
mod outputs;
pub use memory_plan::memory_plan;
use outputs::refine_extremum;
pub mod quadrature;
mod small_jacobian;

use std::rc::Rc;

use faer::Mat;

use super::n_dof_coefficients;
use super::partition::{contact_directions, Partition, SingularStiffness};
use crate::contact::static_contact::StaticContact;
use crate::error::{Error, Result};
use crate::harmonic::{basis_into, golden_section_max, n_coefficients, Quadrature, Sampling};
use crate::limits::Limits;
use crate::linear::{complex_harmonic, store_harmonic, PartitionedSystem};
use crate::linear::{ExactReceptance, ModalReceptance, Receptance, ReceptanceAtFrequency};
use crate::method::{default_samples, SetupObserver};
use crate::model::{MassKind, Model, System};
use crate::problem::{Jacobian, Linearization, PeriodicProblem};
use crate::solution::{DiagramPoint, PeriodicSolution};
use crate::sparse::SparseMatrix;
use crate::stability::{self, InterfaceModes, ReducedSystem, StabilityOptions};
use evaluation::{Evaluation, EvaluationScratch};
use frequency_maps::{FrequencyMatrices, StaticMaps};
use interval_signal::IntervalSignal;
use jacobian::{dense_jacobian, ContactJacobian, PreconditionerSlot};
use quadrature::{integrate, signal_with_basis, Integration};
use small_jacobian::{SmallJacobianWork, SMALL_INTERFACE_CONTACTS};

/// Instants whose contact forces a solution's extremum search keeps (each `n_c` numbers).
pub(crate) const MAX_CACHED_INSTANTS: usize = 16_384;

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
    /// How the receptance at the contacts (docs/theory.md (T125)) is computed.
    pub receptance: ReceptanceChoice,
    /// How Newton's linear systems are formed and solved (docs/theory.md §18).
    pub jacobian: JacobianForm,
}

/// Newton systems with at least this many unknowns `n_c (2H + 1)` use the operator Jacobian
/// under [`JacobianForm::Auto`] (below it the dense LU is faster; docs/theory.md §18).
pub const OPERATOR_JACOBIAN_UNKNOWNS: usize = 1000;

/// How the Jacobian (T129) reaches Newton and the continuation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum JacobianForm {
    /// [`JacobianForm::Dense`] below [`OPERATOR_JACOBIAN_UNKNOWNS`] unknowns, else
    /// [`JacobianForm::Operator`].
    #[default]
    Auto,
    /// The dense matrix, solved by LU (`O((n_c(2H+1))³)` per solve).
    Dense,
    /// Its action and the harmonic-block preconditioner, solved by GMRES (the dense LU only
    /// where GMRES does not converge).
    Operator,
}

impl JacobianForm {
    /// Whether a system of `unknowns` unknowns uses the operator.
    pub fn is_operator(self, unknowns: usize) -> bool {
        match self {
            JacobianForm::Auto => unknowns >= OPERATOR_JACOBIAN_UNKNOWNS,
            JacobianForm::Dense => false,
            JacobianForm::Operator => true,
        }
    }
}

impl RedistributedOptions {
    /// `H` harmonics, default samples, exact quadrature, receptance chosen by size.
    pub fn new(harmonics: usize) -> Self {
        RedistributedOptions {
            harmonics,
            samples: None,
            quadrature: Quadrature::Exact,
            receptance: ReceptanceChoice::Auto,
            jacobian: JacobianForm::Auto,
        }
    }
}

/// Models with more DOFs than this use the modal receptance under [`ReceptanceChoice::Auto`]
/// when their stiffness factor also has more than [`MODAL_RECEPTANCE_FILL`] values per DOF.
pub const MODAL_RECEPTANCE_DOFS: usize = 20_000;

/// Values per DOF of the sparse Cholesky factor of `K` above which the exact receptance's
/// per-frequency factorizations are costly (3D solids: hundreds; a bar, a beam or a thin
/// lattice: a few, where the exact receptance of 10⁵ DOFs takes a fraction of a second per
/// frequency and 200 modes would take minutes).
pub const MODAL_RECEPTANCE_FILL: usize = 40;

/// Modes of the modal receptance under [`ReceptanceChoice::Auto`] (at most half the DOFs
/// with mass).
pub const DEFAULT_RECEPTANCE_MODES: usize = 200;

/// DOFs with mass up to which [`ReceptanceChoice::Auto`] tries every mode whatever the
/// damping: when the modes diagonalise it, the modal receptance with every mode is exact
/// (T130) and costs `m` complex reciprocals per harmonic and frequency instead of a
/// factorization of the whole structure (docs/theory.md §17, "Diagonal modal damping");
/// its set-up is one dense modal analysis of at most this many DOFs (milliseconds), wasted
/// when the damping turns out to couple the modes.
pub const EVERY_MODE_DOFS: usize = 200;

/// DOFs with mass up to which [`ReceptanceChoice::Auto`] takes every mode when the damping
/// is mass-proportional (`C = α M`, undamped included), which the modes diagonalise for
/// certain. The dense modal analysis grows like `n³` (measured on the cantilever of
/// `examples/cantilever_stop`: 1420 DOFs with mass 1.1 s and 160 MB for a whole solve,
/// 3146 DOFs 15 s and 0.7 GB); at this size it costs a few seconds, as much as a few
/// hundred sparse factorizations, and a diagram makes thousands (BENCHMARKS.md §12).
pub const EVERY_MODE_MASS_PROPORTIONAL_DOFS: usize = 2000;

/// Whether [`ReceptanceChoice::Auto`] tries every mode for `system` with `massive` DOFs with
/// mass.
pub(crate) fn takes_every_mode(system: &System, massive: usize) -> bool {
    massive > 0
        && (massive <= EVERY_MODE_DOFS
            || (massive <= EVERY_MODE_MASS_PROPORTIONAL_DOFS && mass_proportional_damping(system)))
}

/// Whether the damping is a multiple of the mass, `C = α M` (`α ≥ 0`, zero included), to
/// `1e-12` of its largest entry: then every mode diagonalises it.
fn mass_proportional_damping(system: &System) -> bool {
    let (mass, damping) = (&system.mass, &system.damping);
    let largest_mass = mass.max_abs();
    if largest_mass == 0.0 {
        return false;
    }
    let (i, j, _) = mass.iter().fold((0, 0, 0.0f64), |best, (i, j, v)| {
        if v.abs() > best.2.abs() {
            (i, j, v)
        } else {
            best
        }
    });
    let alpha = damping.get(i, j) / mass.get(i, j);
    let tolerance = 1e-12 * (alpha.abs() * largest_mass).max(damping.max_abs());
    damping
        .iter()
        .all(|(i, j, c)| (c - alpha * mass.get(i, j)).abs() <= tolerance)
        && mass
            .iter()
            .all(|(i, j, m)| (damping.get(i, j) - alpha * m).abs() <= tolerance)
}

/// How the receptance at the contacts `R_k = Wᵀ A_k⁻¹ W` is computed (docs/theory.md
/// (T125), (T130)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ReceptanceChoice {
    /// Up to [`EVERY_MODE_DOFS`] DOFs with mass and damping the modes diagonalise, or up
    /// to [`EVERY_MODE_MASS_PROPORTIONAL_DOFS`] with mass-proportional damping,
    /// [`ReceptanceChoice::Modal`] with every mode (exact); otherwise
    /// [`ReceptanceChoice::Exact`] up to [`MODAL_RECEPTANCE_DOFS`] DOFs or
    /// [`MODAL_RECEPTANCE_FILL`] factor values per DOF, above both
    /// [`ReceptanceChoice::Modal`] with [`DEFAULT_RECEPTANCE_MODES`] modes.
    #[default]
    Auto,
    /// A sparse LU of the whole dynamic stiffness per harmonic and frequency
    /// ([`crate::linear::ExactReceptance`]).
    Exact,
    /// The lowest `modes` modes with the exact static part
    /// ([`crate::linear::ModalReceptance`]).
    Modal { modes: usize },
}

impl ReceptanceChoice {
    /// The receptance of `system` this choice stands for.
    fn build(
        self,
        system: &System,
        observer: Option<&SetupObserver>,
        cancel: crate::limits::Cancel,
    ) -> Result<Box<dyn Receptance>> {
        let massive = system.n_dofs() - crate::modes::massless_dofs(&system.mass).len();
        let costly = || -> Result<bool> {
            Ok(system.n_dofs() > MODAL_RECEPTANCE_DOFS
                && crate::sparse::cholesky_fill(&system.stiffness)?
                    > MODAL_RECEPTANCE_FILL * system.n_dofs())
        };
        if self == ReceptanceChoice::Auto && takes_every_mode(system, massive) {
            SetupObserver::phase(observer, || {
                format!(
                    "the modal receptance with every mode: the {massive} modes of {} DOFs",
                    system.n_dofs()
                )
            });
            // exact only if the modes diagonalise the damping; else the exact receptance
            if let Ok(every) = ModalReceptance::every_mode(system) {
                if every.diagonalises_damping() {
                    return Ok(Box::new(every));
                }
            }
        }
        let choice = match self {
            ReceptanceChoice::Auto if costly()? => ReceptanceChoice::Modal {
                modes: DEFAULT_RECEPTANCE_MODES.min(massive / 2).max(1),
            },
            ReceptanceChoice::Auto => ReceptanceChoice::Exact,
            other => other,
        };
        Ok(match choice {
            ReceptanceChoice::Modal { modes } => {
                if modes == 0 || modes > massive {
                    return Err(Error::argument(
                        "modes",
                        format!(
                            "the modal receptance needs between 1 and {massive} modes (the DOFs with mass); asked for {modes}"
                        ),
                    ));
                }
                SetupObserver::phase(observer, || {
                    format!(
                        "the modal receptance: the {modes} lowest modes of {} DOFs",
                        system.n_dofs()
                    )
                });
                Box::new(ModalReceptance::new(system, modes)?)
            }
            _ => {
                SetupObserver::phase(observer, || {
                    format!(
                        "the exact receptance: sparse analysis of {} DOFs",
                        system.n_dofs()
                    )
                });
                Box::new(ExactReceptance::new(system)?.cancellable(cancel))
            }
        })
    }
}

/// The receptance at one frequency with the matrices of the residual (T128).
struct Frequency {
    receptance: Box<dyn ReceptanceAtFrequency>,
    matrices: Rc<FrequencyMatrices>,
}

/// The redistributed MS-HBM for one model.
pub struct RedistributedMsHbm {
    system: System,
    harmonics: usize,
    sampling: Sampling,
    quadrature: Quadrature,
    /// The receptance of the structure at its contacts (docs/theory.md (T125)).
    receptance: Box<dyn Receptance>,
    /// The frequency-independent parts of `P R_k⁻¹` when the receptance is static plus
    /// low rank (docs/theory.md (T136)); `None`: the maps are formed densely per frequency.
    static_maps: Option<Rc<StaticMaps>>,
    /// `L | N` partition and length scale.
    partition: Partition,
    contact: StaticContact,
    /// Coulomb friction on the contacts (docs/theory.md §20): the law that replaces the
    /// static contact problem, on the coordinates `[normals; tangents]`.
    friction: Option<frictional::Law>,
    /// `Λ` of the residual (T128): `‖Λ f‖ = ‖K_NN⁻¹ W f‖` (`n_c × n_c`, row-major).
    residual_scale: Rc<Vec<f64>>,
    /// The factors preconditioning the operator Jacobian (docs/theory.md §18).
    preconditioner: PreconditionerSlot,
    /// How Newton's systems are formed, and whether they are operators at this `H`.
    jacobian_form: JacobianForm,
    operator_jacobian: bool,
    /// `K_NN` and `W` (`n_N × n_c`, row-major) of the contact nodes.
    stiffness_nn: SparseMatrix,
    directions: Vec<f64>,
    /// The receptance at the last frequency.
    frequency: Option<Frequency>,
    stability_options: StabilityOptions,
    /// The L-system of the Floquet analysis (full or reduced), built on first use.
    stability_system: Option<Rc<ReducedSystem>>,
    /// First-order matrix and its eigendecomposition per active set (stability).
    /// The first-order matrices of the active sets met so far (T141).
    stability_pieces: stability::PiecewiseLinearSystems,
    /// The frictional Floquet analysis's per-set data (T182), by the contacts' modes.
    friction_phases: frictional_floquet::PhaseCache,
    /// The memory budget, also of the Floquet analysis.
    limits: Limits,
    /// Scratch space of the dense Jacobian of few contacts.
    small_jacobian: SmallJacobianWork,
    /// The last evaluation of the residual.
    last_evaluation: Option<Evaluation>,
    /// The working storage of the evaluations.
    scratch: EvaluationScratch,
}

impl RedistributedMsHbm {
    /// Set up the method for `model` (mass redistribution, partition, checks) within the
    /// default [`Limits`] (the machine's memory).
    pub fn new(model: &Model, options: &RedistributedOptions) -> Result<Self> {
        Self::within(model, options, &Limits::default())
    }

    /// [`RedistributedMsHbm::new`], refusing before allocating when the method's memory
    /// estimate ([`memory_plan`]) exceeds `limits`.
    pub fn within(model: &Model, options: &RedistributedOptions, limits: &Limits) -> Result<Self> {
        Self::within_observed(model, options, limits, None)
    }

    /// [`RedistributedMsHbm::within`], telling `observer` which phase of the set-up runs.
    pub fn within_observed(
        model: &Model,
        options: &RedistributedOptions,
        limits: &Limits,
        observer: Option<&SetupObserver>,
    ) -> Result<Self> {
        let built = Self::build(model, options, limits, observer);
        SetupObserver::done(observer);
        built
    }

    fn build(
        model: &Model,
        options: &RedistributedOptions,
        limits: &Limits,
        observer: Option<&SetupObserver>,
    ) -> Result<Self> {
        let h = options.harmonics;
        let samples = options.samples.unwrap_or_else(|| default_samples(h));
        super::check_resolution(h, samples, "samples")?;
        if model.contacts.is_empty() {
            return Err(Error::argument(
                "model",
                "the model has no contact; the redistributed MS-HBM needs at least one",
            ));
        }
        SetupObserver::phase(observer, || {
            format!(
                "the system: mass redistribution and damping ({} DOFs)",
                model.stiffness.nrows()
            )
        });
        let system = model.system_cancellable(MassKind::Redistributed, limits.cancel)?;
        limits.cancel.check()?;
        // with friction the contact coordinates are the normals, then the tangents (T150)
        let (system, friction) = frictional::with_tangent_coordinates(system, &model.source)?;
        memory_plan(&system, h, samples).check(
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
        SetupObserver::phase(observer, || {
            format!(
                "the static contact problem ({} contacts, {} contact-node DOFs)",
                system.contacts.len(),
                nl.len()
            )
        });
        let stiffness_nn = system.stiffness.submatrix(nl, nl);
        let gap: Vec<f64> = system.contacts.iter().map(|c| c.gap).collect();
        let directions = contact_directions(&system);
        // K_NN comes from the model's stiffness: its refusal names the model and the field
        let contact =
            StaticContact::new(&stiffness_nn, directions.clone(), gap).map_err(|e| match e {
                Error::Singular(why) => system.stiffness_error(why),
                e => e,
            })?;
        let residual_scale = contact.displacement_scale()?;
        let friction = match friction {
            Some(coordinates) => Some(frictional::Law::new(
                contact.delassus().to_vec(),
                coordinates,
            )?),
            None => None,
        };
        let n_contacts = system.contacts.len();
        // the MS-HBM needs the structure held (K positive definite)
        let partition = Partition::new(&system, SingularStiffness::Refuse)?;
        limits.cancel.check()?;
        let receptance = options.receptance.build(&system, observer, limits.cancel)?;
        limits.cancel.check()?;
        let static_maps = receptance.static_plus_low_rank().and_then(|parts| {
            StaticMaps::new(&parts, contact.delassus(), &residual_scale).map(Rc::new)
        });
        Ok(RedistributedMsHbm {
            static_maps,
            partition,
            harmonics: h,
            sampling: Sampling::within(h, samples, limits)?,
            quadrature: options.quadrature,
            receptance,
            contact,
            residual_scale: Rc::new(residual_scale),
            preconditioner: Default::default(),
            jacobian_form: options.jacobian,
            operator_jacobian: options.jacobian.is_operator(n_contacts * n_coefficients(h)),
            friction,
            stiffness_nn,
            directions,
            frequency: None,
            stability_options: StabilityOptions::default(),
            stability_system: None,
            stability_pieces: stability::PiecewiseLinearSystems::new(),
            friction_phases: Default::default(),
            limits: *limits,
            system,
            small_jacobian: SmallJacobianWork::default(),
            last_evaluation: None,
            scratch: EvaluationScratch::default(),
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

    /// Work with `harmonics` harmonics and `samples` samples per period from now on
    /// (`None`: [`default_samples`]), keeping what does not depend on them: the system, the
    /// receptance (its modes) and the static contact problem. The unknowns change size; a
    /// solution at another `H` is carried over by [`crate::harmonic::with_harmonics`]. This is
    /// the nested start across harmonics of docs/theory.md (T122) without a second set-up:
    /// on a 10⁵-DOF solid the set-up (the factor of `K` and the modes) is minutes, a Newton
    /// solve at a low `H` seconds.
    ///
    /// Refused, with nothing changed, when the new sizes are invalid or their memory
    /// estimate exceeds the limits the method was set up within.
    pub fn set_harmonics(&mut self, harmonics: usize, samples: Option<usize>) -> Result<()> {
        let samples = samples.unwrap_or_else(|| default_samples(harmonics));
        super::check_resolution(harmonics, samples, "samples")?;
        memory_plan(&self.system, harmonics, samples).check(
            &format!("the redistributed MS-HBM with {harmonics} harmonics and {samples} samples"),
            &self.limits,
        )?;
        self.sampling = Sampling::within(harmonics, samples, &self.limits)?;
        self.harmonics = harmonics;
        self.operator_jacobian = self
            .jacobian_form
            .is_operator(self.n() * n_coefficients(harmonics));
        // everything sized by H: the prepared frequency, the preconditioner's factors, the
        // Floquet analysis' per-set data
        self.frequency = None;
        self.last_evaluation = None;
        self.preconditioner = Default::default();
        self.stability_pieces = stability::PiecewiseLinearSystems::new();
        self.friction_phases.clear();
        Ok(())
    }

    /// Number of contacts `n_c`.
    fn n(&self) -> usize {
        self.system.contacts.len()
    }

    fn prepare(&mut self, omega: f64) -> Result<()> {
        if self
            .frequency
            .as_ref()
            .is_some_and(|f| f.receptance.omega() == omega)
        {
            return Ok(());
        }
        super::check_frequency(omega)?;
        // the last frequency's storage is reused where it can be: then nothing is allocated
        let refreshed = self.refresh_frequency(omega);
        if refreshed.is_err() {
            self.frequency = None;
        }
        if refreshed? {
            return Ok(());
        }
        let receptance = self.receptance.at(omega, self.harmonics)?;
        let matrices = self.frequency_matrices(receptance.as_ref())?;
        self.frequency = Some(Frequency {
            receptance,
            matrices: Rc::new(matrices),
        });
        Ok(())
    }

    /// The maps `P R_k⁻¹` at the frequency of `receptance` (static plus low rank where the
    /// receptance has that form, else dense).
    fn frequency_matrices(
        &self,
        receptance: &dyn ReceptanceAtFrequency,
    ) -> Result<FrequencyMatrices> {
        let low_rank = match &self.static_maps {
            Some(parts) => FrequencyMatrices::static_plus_low_rank(receptance, parts)?,
            None => None,
        };
        match low_rank {
            Some(m) => Ok(m),
            None => FrequencyMatrices::dense(
                receptance,
                self.contact.delassus(),
                &self.residual_scale,
                self.n(),
            ),
        }
    }

    /// The prepared frequency moved to `ω` in its own storage
    /// ([`ReceptanceAtFrequency::refresh`], [`FrequencyMatrices::refill_dense`]); `false`
    /// when there is none or its receptance cannot be refreshed.
    fn refresh_frequency(&mut self, omega: f64) -> Result<bool> {
        let (n, harmonics) = (self.n(), self.harmonics);
        let Some(frequency) = self.frequency.as_mut() else {
            return Ok(false);
        };
        if frequency.receptance.harmonics() != harmonics || !frequency.receptance.refresh(omega)? {
            return Ok(false);
        }
        let dense = self.static_maps.is_none();
        match Rc::get_mut(&mut frequency.matrices) {
            Some(maps) if dense && maps.is_dense_of(n, harmonics) => maps.refill_dense(
                frequency.receptance.as_ref(),
                self.contact.delassus(),
                &self.residual_scale,
                n,
            )?,
            _ => {
                let frequency = self.frequency.as_ref().expect("refreshed above");
                let matrices = self.frequency_matrices(frequency.receptance.as_ref())?;
                self.frequency.as_mut().expect("refreshed above").matrices = Rc::new(matrices);
            }
        }
        Ok(true)
    }

    /// The receptance at the prepared frequency.
    fn prepared(&self) -> &Frequency {
        self.frequency.as_ref().expect("prepared")
    }

    /// The residual (T128), the period's active-set decomposition and the forces `λ̂`.
    fn evaluate(&mut self, v: &[f64], omega: f64) -> Result<(Vec<f64>, Rc<Integration>, Vec<f64>)> {
        let e = self.evaluation(v, omega)?;
        Ok((
            e.residual.clone(),
            Rc::clone(&e.integration),
            e.forces.clone(),
        ))
    }

    /// `R`, `∂R/∂ω` and `∂R/∂x` of the evaluation `e` into `out`; `∂R/∂ω` and the dense
    /// Jacobian are kept in `e` (the tangent and the diagram point of a converged point ask
    /// again), in the storage of earlier ones.
    fn linearize_evaluation(&mut self, e: &mut Evaluation, out: &mut Linearization) -> Result<()> {
        let mut scratch = std::mem::take(&mut self.scratch);
        if e.d_omega.is_none() {
            let mut d = scratch.spare_d_omega.take().unwrap_or_default();
            let computed = self.frequency_derivative_into(
                &e.phi,
                &e.integration,
                e.friction.as_deref(),
                &mut d,
                &mut scratch,
            );
            if let Err(error) = computed {
                self.scratch = scratch;
                return Err(error);
            }
            e.d_omega = Some(d);
        }
        out.residual.clone_from(&e.residual);
        out.d_omega
            .clone_from(e.d_omega.as_ref().expect("computed above"));
        let n = self.n();
        let matrices = Rc::clone(&self.prepared().matrices);
        if self.operator_jacobian {
            self.scratch = scratch;
            out.jacobian = Jacobian::Operator(Box::new(ContactJacobian::new(
                n,
                self.harmonics,
                matrices,
                Rc::clone(&self.residual_scale),
                Rc::clone(&e.integration),
                e.friction.clone(),
                Rc::clone(&self.preconditioner),
            )));
            return Ok(());
        }
        if e.dense_jacobian.is_none() {
            let jacobian = if let Some(law) = &e.friction {
                let law_jacobian = match law.jacobian() {
                    Ok(s) => s,
                    Err(error) => {
                        self.scratch = scratch;
                        return Err(error);
                    }
                };
                frictional::dense_jacobian(
                    n,
                    self.harmonics,
                    &matrices,
                    &self.residual_scale,
                    law_jacobian,
                )
            } else if n <= SMALL_INTERFACE_CONTACTS {
                let mut jacobian = scratch
                    .spare_jacobian
                    .take()
                    .unwrap_or_else(|| Mat::zeros(0, 0));
                small_jacobian::jacobian_into(
                    n,
                    self.harmonics,
                    &matrices,
                    &self.residual_scale,
                    &e.integration,
                    &mut self.small_jacobian,
                    &mut jacobian,
                );
                jacobian
            } else {
                dense_jacobian(
                    n,
                    self.harmonics,
                    &matrices,
                    &self.residual_scale,
                    &e.integration,
                )
            };
            e.dense_jacobian = Some(jacobian);
        }
        self.scratch = scratch;
        let jacobian = e.dense_jacobian.as_ref().expect("formed above");
        match &mut out.jacobian {
            Jacobian::Dense(m)
                if m.nrows() == jacobian.nrows() && m.ncols() == jacobian.ncols() =>
            {
                m.copy_from(jacobian)
            }
            other => *other = Jacobian::Dense(jacobian.clone()),
        }
        Ok(())
    }

    /// The contact-free response at `ω` (the initial guess): `v_k = Wᵀ A_k⁻¹ f_k`.
    pub fn linear_response(&mut self, omega: f64) -> Result<Vec<f64>> {
        self.prepare(omega)?;
        let zero = vec![0.0; self.dimension()];
        let mut response = Vec::new();
        self.displacement_by_forces_into(&zero, &mut response);
        response.iter_mut().for_each(|v| *v = -*v);
        Ok(response)
    }

    /// The harmonics of the DOFs `rows` of the structure under the forces `λ̂`
    /// (`q̂_k = A_k⁻¹ (f_k + W λ̂_k)`, harmonic-major, `rows.len()` per coefficient).
    fn structure_rows(&self, forces: &[f64], rows: &[usize]) -> Result<Vec<f64>> {
        let n = self.n();
        let f = self.prepared();
        let mut q = vec![0.0; rows.len() * n_coefficients(self.harmonics)];
        let mut qk = vec![faer::c64::new(0.0, 0.0); rows.len()];
        for k in 0..=self.harmonics {
            f.receptance
                .response_rows(k, &complex_harmonic(forces, n, k), rows, &mut qk)?;
            store_harmonic(&qk, rows.len(), k, &mut q);
        }
        Ok(q)
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
            self.stability_pieces = stability::PiecewiseLinearSystems::new();
            self.friction_phases.clear();
        }
        Ok(())
    }

    /// The linearised L-system in the coordinates of the Floquet analysis (built once).
    fn stability_system(&mut self) -> Result<Rc<ReducedSystem>> {
        if let Some(s) = &self.stability_system {
            return Ok(s.clone());
        }
        let blocks = PartitionedSystem::new(&self.system);
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
    /// (T41)–(T42), (T129)):
    /// Newton contracts quadratically; the branch has isolated corners at grazing contacts.
    fn continuation_policy(&self) -> crate::problem::ContinuationPolicy {
        crate::problem::ContinuationPolicy {
            newton_contraction: crate::problem::NewtonContraction::Quadratic,
            where_arclength_fails: crate::problem::ArclengthFallback::EscapeCorner,
            signals: self.n(),
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
        let mut out = Linearization::empty();
        self.linearize_into(x, omega, &mut out)?;
        Ok(out)
    }

    /// In `out`'s storage, and in the last evaluation's: at a new frequency and with the
    /// dense Jacobian of few contacts, nothing is allocated.
    fn linearize_into(&mut self, x: &[f64], omega: f64, out: &mut Linearization) -> Result<()> {
        self.evaluation(x, omega)?;
        let mut e = self.last_evaluation.take().expect("evaluated");
        let linearized = self.linearize_evaluation(&mut e, out);
        self.last_evaluation = Some(e);
        linearized
    }
    fn solution(&mut self, x: &[f64], omega: f64, response_dof: usize) -> Result<PeriodicSolution> {
        if self.friction.is_some() {
            return self.frictional_solution(x, omega, response_dof, true);
        }
        self.solution_with(x, omega, response_dof, true)
    }

    /// The response DOF only: the contacts' series and extremes are left out (on a face of
    /// 10³ contacts their golden-section searches are most of a point's cost).
    fn diagram_point(
        &mut self,
        x: &[f64],
        omega: f64,
        response_dof: usize,
    ) -> Result<DiagramPoint> {
        if self.friction.is_some() {
            return Ok(DiagramPoint::of(&self.frictional_solution(
                x,
                omega,
                response_dof,
                false,
            )?));
        }
        Ok(DiagramPoint::of(&self.solution_with(
            x,
            omega,
            response_dof,
            false,
        )?))
    }

    /// Floquet multipliers (docs/theory.md (T80)–(T82), derived): condensing the static contact
    /// subsystem leaves the linear time-periodic system `M̄ q̈_L + C q̇_L + K_eff(t) q_L = 0`
    /// with `K_eff = K_LL − K_LN P_A(t) K_NL`, piecewise constant between the switching
    /// times; its vector field is continuous, so no saltation terms. The monodromy is the
    /// product of exact matrix exponentials over the intervals of constant active set,
    /// evaluated as the cyclic product of modal transfers (T141) of the sets' cached real
    /// modal forms, in
    /// the full L-space (dense: up to 1500 L-DOFs) or in the reduced basis of
    /// [`ReducedSystem`] (fixed-interface modes plus static interface correction, with its
    /// truncation error), as [`RedistributedMsHbm::set_stability_options`] chooses.
    fn floquet(&mut self, x: &[f64], omega: f64) -> Result<Option<crate::stability::Floquet>> {
        if self.friction.is_some() {
            return self.frictional_floquet(x, omega);
        }
        let reduced = self.stability_system()?;
        let integration = Rc::clone(&self.evaluation(x, omega)?.integration);
        // the first-order matrices depend only on the active set (not on ω): build them,
        // and their modal forms, once per set
        let mut systems = Vec::with_capacity(integration.groups.len());
        for g in &integration.groups {
            let index = self.stability_pieces.index_of(&g.set.closed, || {
                reduced.state_matrix(&self.contact.compliance(&g.set.closed)?)
            })?;
            systems.push(index);
        }
        let pieces: Vec<(usize, f64)> = integration
            .intervals
            .iter()
            .filter(|(a, b, _)| b > a)
            .map(|&(a, b, g)| (systems[g], (b - a) / omega))
            .collect();
        let values = self.stability_pieces.multipliers(&pieces)?;
        Ok(Some(crate::stability::Floquet::from_eigenvalues(values)))
    }
}
