//! Mechanical models `M q'' + C q' + K q = f_ex(t) + W λ` (paper eq. 1/17) with unilateral
//! contacts, as read from model files or built in code.
//!
//! A [`Model`] holds the *unconstrained* finite-element matrices (all DOFs, Dirichlet DOFs
//! included, as mass redistribution needs them) plus the data that turn it into a problem:
//! Dirichlet DOFs, contacts, loads and damping. [`Model::system`] applies a mass choice
//! (consistent or redistributed), builds the damping and removes the Dirichlet DOFs, giving
//! the [`System`] the methods work on.
//!
//! DOFs are numbered from 0; DOF `node * dofs_per_node + component`.

pub mod abaqus;
pub mod abaqus_matrix;
pub mod bar;
mod damping_section;
pub mod dropped_bar;
pub mod excerpt;
pub mod export;
pub mod file;
pub mod gmsh;
pub mod harwell_boeing;
mod input_files;
pub mod interface;
pub mod lattice;
pub mod matrix_market;
pub mod mesh;
pub mod overrides;
pub mod solid;
mod system;
mod validate;

pub use input_files::LoadOptions;
pub use interface::ContactInterface;
pub use system::{MassKind, System, SystemContact, SystemContactFriction, SystemFriction};

use std::path::PathBuf;

use crate::error::{Error, Result};
use crate::fe::mesh::{Cells, NodeSets};
use crate::limits::Limits;
use crate::modes::{eigenfrequencies_hz_within, MassComparison};
use crate::sparse::SparseMatrix;

/// Memory estimate [bytes] per DOF of a model, used to refuse a model before it is built
/// when it would not fit the memory budget ([`crate::limits::Limits`]): the peak of
/// reading the paper's bar (1 DOF per node, tridiagonal M and K) and building its
/// redistributed [`System`], measured by a counting allocator
/// (tests/input_limits.rs checks that it bounds the measured peak), rounded up. For a
/// model from Matrix Market files it is a lower bound per DOF; the matrices' entries are
/// checked separately when they are read.
pub const MODEL_BYTES_PER_DOF: u64 = 2048;

/// A unilateral contact: gap `g = Σ_i w_i q_{dofs_i} + gap ≥ 0`, force `+w λ` on the
/// structure with `λ ≥ 0` (paper eqs. 23–24, docs/theory.md (T3)–(T4)).
#[derive(Clone, Debug, PartialEq)]
pub struct Contact {
    /// DOFs the gap depends on (model numbering).
    pub dofs: Vec<usize>,
    /// `∂g/∂q` for each of `dofs` (a column of `W`).
    pub w: Vec<f64>,
    /// Initial gap `g0` (model length unit).
    pub gap: f64,
    /// Coulomb friction along a tangent of the contact (redistributed MS-HBM,
    /// docs/theory.md §20); `None`: frictionless.
    pub friction: Option<ContactFriction>,
}

/// Coulomb friction on a contact (docs/theory.md (T150), (T151)): the tangential
/// displacement `y_T = Σ_i w_i q_{dofs_i}` along a unit tangent orthogonal to the contact's
/// normal, and the friction coefficient. A contact of a 3D interface has a second tangent,
/// orthogonal to the normal and the first, and its friction force lies in the Coulomb cone
/// (T185).
#[derive(Clone, Debug, PartialEq)]
pub struct ContactFriction {
    /// DOFs of the tangential displacement (model numbering).
    pub dofs: Vec<usize>,
    /// `∂y_T/∂q` for each of `dofs`.
    pub w: Vec<f64>,
    /// Friction coefficient `μ ≥ 0`.
    pub mu: f64,
    /// The second tangent of a contact in space (`None`: plane friction along `w` alone).
    pub second: Option<ContactTangent>,
}

/// A tangent of a contact: `y = Σ_i w_i q_{dofs_i}` (model numbering).
#[derive(Clone, Debug, PartialEq)]
pub struct ContactTangent {
    pub dofs: Vec<usize>,
    pub w: Vec<f64>,
}

/// What presses a friction element together.
#[derive(Clone, Debug, PartialEq)]
pub enum FrictionNormal {
    /// A prescribed normal force `F_N ≥ 0` (a friction damper): the friction force lies in
    /// `[−μ F_N, μ F_N]` at all times.
    Force(f64),
    /// The force `λ_i` of unilateral contact `i` (index into [`Model::contacts`]): the
    /// friction force lies in `[−μ λ_i, μ λ_i]`, zero while the contact is open.
    Contact(usize),
}

/// A Coulomb friction element (docs/theory.md (T5)): slip velocity `γ_T = Σ_i w_i q̇_{dofs_i}`,
/// friction force `+w λ_T` on the structure with `λ_T ∈ −μ F_N Sign(γ_T)` (set-valued:
/// stick when `|λ_T| < μ F_N`).
#[derive(Clone, Debug, PartialEq)]
pub struct Friction {
    /// DOFs the slip depends on (model numbering).
    pub dofs: Vec<usize>,
    /// `∂γ_T/∂q̇` for each of `dofs` (the slip direction, a column of `W_T`).
    pub w: Vec<f64>,
    /// Friction coefficient `μ ≥ 0`.
    pub mu: f64,
    /// Normal force: prescribed, or that of a unilateral contact.
    pub normal: FrictionNormal,
}

/// Rayleigh-type damping `C = alpha·M + beta·K (+ C_file)`, where `M` is the mass matrix
/// the method uses (redistributed for the redistributed MS-HBM, consistent otherwise).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Damping {
    /// Mass-proportional coefficient (1/s).
    pub alpha: f64,
    /// Stiffness-proportional coefficient (s). Couples into the contact DOFs, so the
    /// redistributed method refuses it.
    pub beta: f64,
    /// Stiffness-proportional coefficient (s) of the linear part only: `C += beta_linear ·
    /// K_LL`, the stiffness with the rows and columns of the contact nodes removed. It
    /// damps the high modes that contact excites while keeping the massless contact DOFs
    /// free of damping (`C_NN = C_NL = 0`), so the redistributed method accepts it.
    pub beta_linear: f64,
    /// Stiffness-proportional coefficient (s) of the linear part with the contact nodes
    /// relaxed: `C_LL += beta_condensed · (K_LL − K_LN K_NN⁻¹ K_NL)` (docs/theory.md (T121)).
    /// Unlike `beta_linear` it does not ground the nodes next to the contact nodes (it
    /// vanishes on rigid motions); with `alpha` it is exact Rayleigh damping of the
    /// redistributed system's contact-free modes. `C_NN = C_NL = 0`.
    pub beta_condensed: f64,
    /// If set, `alpha = 2 ζ ω₁` with `ω₁` the first eigenfrequency (rad/s) of the system
    /// with the mass the method uses and all contacts open, so that the first mode has
    /// modal damping ratio `ζ` (mass-proportional damping gives `ζ_k = alpha / (2 ω_k)`).
    pub first_mode_ratio: Option<f64>,
}

/// A complete model (see the module docs).
#[derive(Clone, Debug)]
pub struct Model {
    /// Where the model came from (file path, or a description for built-in models); used
    /// in error messages.
    pub source: PathBuf,
    /// Canonical paths of every file read to build the model (the model file first when it
    /// was read from disk, then the files it refers to); empty for models built in code. A caller that writes
    /// files uses it to refuse to overwrite an input.
    pub input_files: Vec<PathBuf>,
    /// Human-readable name.
    pub name: String,
    /// Consistent mass matrix of the unconstrained mesh.
    pub mass: SparseMatrix,
    /// Stiffness matrix of the unconstrained mesh.
    pub stiffness: SparseMatrix,
    /// The file the stiffness was read from, as the model file's field
    /// `matrices.stiffness` gives it (a `matrices` model), for the errors that blame the
    /// stiffness ([`crate::model::System::stiffness_error`]); `None` when the stiffness was
    /// built from parameters.
    pub stiffness_file: Option<PathBuf>,
    /// Optional explicit damping matrix, added to the Rayleigh part.
    pub damping_matrix: Option<SparseMatrix>,
    /// Node coordinates (dimension 1, 2 or 3), for mass redistribution.
    pub coordinates: Vec<Vec<f64>>,
    /// DOFs per node.
    pub dofs_per_node: usize,
    /// The mesh's cells when known (built-in solids, or a model file that gives them): for
    /// outputs such as VTK files; the methods never need them.
    pub cells: Option<Cells>,
    /// The label of each model node in the file the mesh or the matrices were read from
    /// (Gmsh node tag, Abaqus node label), for outputs that name nodes (`--contacts-csv`,
    /// VTK point data `node_label`); `None` when the model numbers its nodes itself
    /// (built-in models, Matrix Market matrices). See [`Model::node_label`].
    pub node_labels: Option<Vec<u64>>,
    /// Named node sets (faces of a structured mesh, or read from a file).
    pub node_sets: NodeSets,
    /// DOFs fixed to zero.
    pub dirichlet: Vec<usize>,
    /// Unilateral contacts.
    pub contacts: Vec<Contact>,
    /// Named groups of [`Model::contacts`] generated from node sets (contact interfaces of
    /// many nodes), for outputs along the interface.
    pub interfaces: Vec<ContactInterface>,
    /// Coulomb friction elements (used by the time integration and the general MS-HBM;
    /// the redistributed MS-HBM refuses them).
    pub frictions: Vec<Friction>,
    /// Amplitude `f_h` of the harmonic load `f(t) = harmonic_load · cos(ωt)`, one entry per
    /// DOF; with [`Model::constant_load`] the load `f(t) = f_0 + f_h cos ωt` (docs/theory.md (T2)).
    pub harmonic_load: Vec<f64>,
    /// Constant load, one entry per DOF.
    pub constant_load: Vec<f64>,
    /// Optional uniform acceleration field (one value per component, e.g. gravity
    /// `[-9810]` in mm/s²); its load `M_used (1 ⊗ a)` uses the mass the method uses, so
    /// that free flight stays rigid with a redistributed mass (docs/theory.md (T32)).
    pub acceleration: Option<Vec<f64>>,
    /// Damping.
    pub damping: Damping,
}

impl Model {
    /// The label of model node `p` in the input it was read from ([`Model::node_labels`]),
    /// or `p` itself when the model has no labels.
    pub fn node_label(&self, p: usize) -> u64 {
        match &self.node_labels {
            Some(labels) => labels[p],
            None => p as u64,
        }
    }

    /// Some contact has Coulomb friction (`mu` of an interface, docs/theory.md §20).
    pub fn has_contact_friction(&self) -> bool {
        self.contacts.iter().any(|c| c.friction.is_some())
    }

    /// Refuse contacts with Coulomb friction (docs/theory.md §20) in a method or integrator
    /// (`what`) that models only frictionless contact, naming the first such contact.
    pub fn refuse_contact_friction(&self, what: &str) -> Result<()> {
        match self.contacts.iter().position(|c| c.friction.is_some()) {
            Some(c) => Err(Error::field(
                &self.source,
                "mu",
                format!(
                    "contact {c} has friction (`mu` of an interface); {what} models frictionless contact only. Friction on contacts is solved by the redistributed MS-HBM (`--method redistributed`)"
                ),
            )),
            None => Ok(()),
        }
    }

    /// Refuse contacts with friction in the Coulomb cone (two tangents, docs/theory.md
    /// (T185)) in a method or integrator (`what`) that models plane friction only.
    pub fn refuse_cone_friction(&self, what: &str) -> Result<()> {
        let cone = self
            .contacts
            .iter()
            .position(|c| c.friction.as_ref().is_some_and(|f| f.second.is_some()));
        match cone {
            Some(c) => Err(Error::field(
                &self.source,
                "mu",
                format!(
                    "contact {c} has friction in the Coulomb cone (a 3D interface); {what} models friction along one tangent only. The cone is solved by the redistributed MS-HBM (`--method redistributed`)"
                ),
            )),
            None => Ok(()),
        }
    }
}

impl Model {
    /// The `count` lowest eigenfrequencies with the consistent and with the redistributed
    /// mass (contacts open, Dirichlet DOFs fixed), and the shift redistribution causes.
    pub fn compare_masses(&self, count: usize) -> Result<MassComparison> {
        self.compare_masses_within(count, &Limits::default())
    }

    /// [`Model::compare_masses`], refusing before allocating when the eigensolver's memory
    /// exceeds `limits` ([`eigenfrequencies_hz_within`]).
    pub fn compare_masses_within(&self, count: usize, limits: &Limits) -> Result<MassComparison> {
        // the caller's request to stop is checked between the phases
        let consistent = self.system_cancellable(MassKind::Consistent, limits.cancel)?;
        let redistributed = self.system_cancellable(MassKind::Redistributed, limits.cancel)?;
        limits.cancel.check()?;
        let original_hz =
            eigenfrequencies_hz_within(&consistent.mass, &consistent.stiffness, count, limits)?;
        limits.cancel.check()?;
        let redistributed_hz = eigenfrequencies_hz_within(
            &redistributed.mass,
            &redistributed.stiffness,
            count,
            limits,
        )?;
        let relative_error = original_hz
            .iter()
            .zip(&redistributed_hz)
            .map(|(o, r)| r / o - 1.0)
            .collect();
        Ok(MassComparison {
            original_hz,
            redistributed_hz,
            relative_error,
            norm: self.redistribution()?.norm,
        })
    }

    /// Number of DOFs of the unconstrained mesh.
    pub fn n_dofs(&self) -> usize {
        self.stiffness.nrows()
    }

    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.coordinates.len()
    }

    /// Nodes that carry a contact DOF (these become massless under redistribution).
    /// Friction DOFs are not included (see [`Model::nonlinear_nodes`]).
    pub fn contact_nodes(&self) -> Vec<usize> {
        let mut nodes: Vec<usize> = self
            .contacts
            .iter()
            .flat_map(|c| c.dofs.iter().map(|&d| d / self.dofs_per_node))
            .collect();
        nodes.sort_unstable();
        nodes.dedup();
        nodes
    }

    /// Nodes that carry a contact or a friction DOF: the nonlinear subsystem `N` of the
    /// general MS-HBM (all DOFs of these nodes).
    pub fn nonlinear_nodes(&self) -> Vec<usize> {
        let mut nodes: Vec<usize> = self
            .contacts
            .iter()
            .flat_map(|c| {
                c.dofs
                    .iter()
                    .chain(c.friction.iter().flat_map(|f| f.dofs.iter()))
                    .chain(
                        c.friction
                            .iter()
                            .flat_map(|f| f.second.iter().flat_map(|t| t.dofs.iter())),
                    )
            })
            .chain(self.frictions.iter().flat_map(|f| f.dofs.iter()))
            .map(|&d| d / self.dofs_per_node)
            .collect();
        nodes.sort_unstable();
        nodes.dedup();
        nodes
    }
}
