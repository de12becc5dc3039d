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
pub mod bar;
mod damping_section;
pub mod dropped_bar;
pub mod excerpt;
pub mod export;
pub mod file;
pub mod gmsh;
mod input_files;
pub mod interface;
pub mod lattice;
pub mod matrix_market;
pub mod mesh;
pub mod overrides;
pub mod solid;
mod system;

pub use input_files::LoadOptions;
pub use interface::ContactInterface;
pub use system::{MassKind, System, SystemContact, SystemContactFriction, SystemFriction};

use std::collections::{BTreeMap, HashMap, HashSet};
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
/// normal, and the friction coefficient.
#[derive(Clone, Debug, PartialEq)]
pub struct ContactFriction {
    /// DOFs of the tangential displacement (model numbering).
    pub dofs: Vec<usize>,
    /// `∂y_T/∂q` for each of `dofs`.
    pub w: Vec<f64>,
    /// Friction coefficient `μ ≥ 0`.
    pub mu: f64,
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
    /// Amplitude of the harmonic load `f(t) = harmonic_load · cos(ωt)`, one entry per DOF.
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
            })
            .chain(self.frictions.iter().flat_map(|f| f.dofs.iter()))
            .map(|&d| d / self.dofs_per_node)
            .collect();
        nodes.sort_unstable();
        nodes.dedup();
        nodes
    }

    /// Check the DOFs and the direction coefficients of a contact (`W`, the gap gradient) or
    /// of a friction element (the slip direction): at least one DOF, one coefficient per
    /// DOF, every DOF in range and not a Dirichlet DOF, coefficients finite and not all
    /// zero. `field` names a field of the element (`field("dofs")`); `element` and
    /// `direction` name the element and its coefficients in the messages.
    ///
    /// The coefficients of a DOF that appears more than once are summed; the direction
    /// must not vanish after that (`dofs = [3, 3]`, `w = [-1, 1]` would be a contact that
    /// never acts). Returns the merged direction ([`merged_direction`]).
    /// Check the Coulomb friction of contact `k` (docs/theory.md (T150)): `μ` finite and
    /// non-negative; the tangent a valid direction ([`Model::check_direction`]), orthogonal
    /// to the contact's normal `normal` (merged) and of its norm, so that the friction force
    /// and its bound `μ λ_N` are measured alike.
    fn check_contact_friction(
        &self,
        dirichlet: &HashSet<usize>,
        k: usize,
        friction: &ContactFriction,
        normal: &[(usize, f64)],
    ) -> Result<()> {
        let file = &self.source;
        let field = |f: &str| format!("contacts[{k}].tangent_{f}");
        if !(friction.mu.is_finite() && friction.mu >= 0.0) {
            return Err(Error::field(
                file,
                format!("contacts[{k}].mu"),
                format!(
                    "the friction coefficient must be finite and ≥ 0, got {}",
                    friction.mu
                ),
            ));
        }
        let tangent = self.check_direction(
            dirichlet,
            &friction.dofs,
            &friction.w,
            field,
            "the tangent of a contact with friction",
            "the tangent",
        )?;
        let norm = |v: &[(usize, f64)]| v.iter().map(|(_, x)| x * x).sum::<f64>().sqrt();
        let (nn, nt) = (norm(normal), norm(&tangent));
        let dot: f64 = tangent
            .iter()
            .filter_map(|(d, t)| normal.iter().find(|(e, _)| e == d).map(|(_, n)| n * t))
            .sum();
        if dot.abs() > 1e-9 * nn * nt {
            return Err(Error::field(
                file,
                format!("contacts[{k}].tangent_w"),
                format!(
                    "the tangent is not orthogonal to the contact's normal w (their product is {dot:e}, the norms {nn:e} and {nt:e})"
                ),
            ));
        }
        if (nt - nn).abs() > 1e-9 * nn {
            return Err(Error::field(
                file,
                format!("contacts[{k}].tangent_w"),
                format!(
                    "the tangent's norm {nt:e} differs from the normal's {nn:e}: the friction force and its bound mu * lambda_N would be measured in different units"
                ),
            ));
        }
        Ok(())
    }

    fn check_direction(
        &self,
        dirichlet: &HashSet<usize>,
        dofs: &[usize],
        w: &[f64],
        field: impl Fn(&str) -> String,
        element: &str,
        direction: &str,
    ) -> Result<Vec<(usize, f64)>> {
        let file = &self.source;
        let n = self.n_dofs();
        if dofs.is_empty() {
            return Err(Error::field(
                file,
                field("dofs"),
                format!("{element} needs at least one DOF"),
            ));
        }
        if dofs.len() != w.len() {
            return Err(Error::field(
                file,
                field("w"),
                format!("{} coefficients for {} DOFs", w.len(), dofs.len()),
            ));
        }
        for &d in dofs {
            if d >= n {
                return Err(Error::field(
                    file,
                    field("dofs"),
                    format!("DOF {d} out of range (the model has DOFs 0..{})", n - 1),
                ));
            }
            if dirichlet.contains(&d) {
                return Err(Error::field(
                    file,
                    field("dofs"),
                    format!("DOF {d} is also a Dirichlet DOF"),
                ));
            }
        }
        if w.iter().any(|v| !v.is_finite()) || w.iter().all(|&v| v == 0.0) {
            return Err(Error::field(
                file,
                field("w"),
                format!("{direction} must be finite and non-zero"),
            ));
        }
        let merged = merged_direction(dofs, w);
        if merged.is_empty() {
            return Err(Error::field(
                file,
                field("w"),
                format!("{direction} vanishes: the coefficients of each DOF sum to zero (a DOF listed twice with opposite coefficients cancels)"),
            ));
        }
        Ok(merged)
    }

    /// Refuse two elements of `directions` (contacts or friction elements, merged
    /// directions with their indices) on the same DOFs with parallel directions: their
    /// columns of `W` are linearly dependent, so the Delassus matrix `Wᵀ M⁻¹ W` of the
    /// contact problem (docs/theory.md (T3)–(T5)) is singular. `allowed_opposite(a, b, ratio)`
    /// decides on a pair whose directions are opposite (`w_b = −ratio · w_a`, `ratio > 0`).
    fn check_independent(
        &self,
        directions: &[Vec<(usize, f64)>],
        kind: &str,
        allowed_opposite: impl Fn(usize, usize, f64) -> Result<()>,
    ) -> Result<()> {
        let mut groups: HashMap<Vec<usize>, Vec<usize>> = HashMap::new();
        for (k, d) in directions.iter().enumerate() {
            groups
                .entry(d.iter().map(|&(dof, _)| dof).collect())
                .or_default()
                .push(k);
        }
        let mut groups: Vec<Vec<usize>> = groups.into_values().filter(|g| g.len() > 1).collect();
        groups.sort_unstable();
        for group in groups {
            for (x, &a) in group.iter().enumerate() {
                for &b in &group[x + 1..] {
                    let (wa, wb) = (&directions[a], &directions[b]);
                    let dot: f64 = wa.iter().zip(wb).map(|(p, q)| p.1 * q.1).sum();
                    let na = wa.iter().map(|p| p.1 * p.1).sum::<f64>().sqrt();
                    let nb = wb.iter().map(|p| p.1 * p.1).sum::<f64>().sqrt();
                    if dot.abs() < (1.0 - PARALLEL_TOLERANCE) * na * nb {
                        continue;
                    }
                    if dot < 0.0 {
                        allowed_opposite(a, b, nb / na)?;
                        continue;
                    }
                    return Err(Error::field(
                        &self.source,
                        format!("{kind}[{b}]"),
                        format!("acts on the same DOFs as {kind}[{a}] in the same direction: the two are one {} given twice, and the contact problem would be singular; give it once", if kind == "contacts" { "contact" } else { "friction element" }),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Check the consistency of the model; errors name the field (with the model's source).
    pub fn validate(&self) -> Result<()> {
        let file = &self.source;
        let n = self.n_dofs();
        let square = |name: &str, a: &SparseMatrix| -> Result<()> {
            if a.nrows() != a.ncols() {
                return Err(Error::field(
                    file,
                    name,
                    format!("matrix is not square ({}×{})", a.nrows(), a.ncols()),
                ));
            }
            if a.nrows() != n {
                return Err(Error::field(
                    file,
                    name,
                    format!(
                        "matrix is {}×{}, the stiffness matrix is {n}×{n}",
                        a.nrows(),
                        a.ncols()
                    ),
                ));
            }
            if let Some((i, j, v)) = a.iter().find(|(_, _, v)| !v.is_finite()) {
                return Err(Error::field(
                    file,
                    name,
                    format!(
                        "entry ({}, {}) is {v:e}: every entry must be finite (1-based)",
                        i + 1,
                        j + 1
                    ),
                ));
            }
            if let Some((i, j)) = a.asymmetry(1e-10) {
                return Err(Error::field(
                    file,
                    name,
                    format!("matrix is not symmetric: entry ({}, {}) = {:e} but ({}, {}) = {:e} (1-based)", i + 1, j + 1, a.get(i, j), j + 1, i + 1, a.get(j, i)),
                ));
            }
            Ok(())
        };
        square("matrices.stiffness", &self.stiffness)?;
        square("matrices.mass", &self.mass)?;
        // a mass matrix is positive semidefinite: no negative diagonal entry (it was blamed
        // on the mass redistribution's correction, and HBM-AFT solved with it)
        if let Some((i, v)) = (0..self.mass.nrows())
            .map(|i| (i, self.mass.get(i, i)))
            .find(|&(_, v)| v < 0.0)
        {
            return Err(Error::field(
                file,
                "matrices.mass",
                format!(
                    "diagonal entry ({}, {}) = {v:e} is negative: a mass matrix has no negative diagonal entry (1-based)",
                    i + 1,
                    i + 1
                ),
            ));
        }
        if let Some(c) = &self.damping_matrix {
            square("matrices.damping", c)?;
        }
        if n == 0 {
            return Err(Error::field(
                file,
                "matrices.stiffness",
                "the model has no DOFs",
            ));
        }
        if self.dofs_per_node == 0 {
            return Err(Error::field(
                file,
                "mesh.dofs_per_node",
                "must be at least 1",
            ));
        }
        let mesh_dofs = self.coordinates.len().checked_mul(self.dofs_per_node);
        if mesh_dofs != Some(n) {
            return Err(Error::field(
                file,
                "mesh.coordinates",
                format!(
                    "{} nodes × {} DOFs per node = {} DOFs, but the matrices have {n}",
                    self.coordinates.len(),
                    self.dofs_per_node,
                    mesh_dofs.map_or_else(|| "more than 2^64".to_string(), |d| d.to_string())
                ),
            ));
        }
        let dim = self.coordinates.first().map_or(0, Vec::len);
        if !(1..=3).contains(&dim) {
            return Err(Error::field(
                file,
                "mesh.coordinates",
                format!("nodes must have 1, 2 or 3 coordinates, found {dim}"),
            ));
        }
        for (k, c) in self.coordinates.iter().enumerate() {
            if c.len() != dim || c.iter().any(|v| !v.is_finite()) {
                return Err(Error::field(
                    file,
                    "mesh.coordinates",
                    format!("node {k}: expected {dim} finite coordinates, found {c:?}"),
                ));
            }
        }
        for (k, &d) in self.dirichlet.iter().enumerate() {
            if d >= n {
                return Err(Error::field(
                    file,
                    format!("mesh.dirichlet[{k}]"),
                    format!("DOF {d} out of range (the model has DOFs 0..{})", n - 1),
                ));
            }
        }
        let dirichlet: HashSet<usize> = self.dirichlet.iter().copied().collect();
        let mut contact_directions = Vec::with_capacity(self.contacts.len());
        for (k, c) in self.contacts.iter().enumerate() {
            let field = |f: &str| format!("contacts[{k}].{f}");
            contact_directions.push(self.check_direction(
                &dirichlet,
                &c.dofs,
                &c.w,
                field,
                "a contact",
                "the gap gradient",
            )?);
            if !c.gap.is_finite() {
                return Err(Error::field(file, field("gap"), "must be finite"));
            }
            if let Some(fr) = &c.friction {
                self.check_contact_friction(
                    &dirichlet,
                    k,
                    fr,
                    contact_directions.last().expect("just pushed"),
                )?;
            }
        }
        // two opposing contacts on the same DOFs (a clearance between two stops) are
        // allowed while the clearance is positive: g_a + g_b / ratio > 0 for w_b = −ratio w_a
        self.check_independent(&contact_directions, "contacts", |a, b, ratio| {
            let clearance = self.contacts[a].gap + self.contacts[b].gap / ratio;
            if clearance > 0.0 {
                Ok(())
            } else {
                Err(Error::field(
                    file,
                    format!("contacts[{b}]"),
                    format!("opposes contacts[{a}] on the same DOFs with no clearance left between them ({clearance:e}): the two would lock the DOFs or contradict each other"),
                ))
            }
        })?;
        for (k, i) in self.interfaces.iter().enumerate() {
            let count = i.contacts.len();
            if i.contacts.end > self.contacts.len()
                || i.positions.len() != count
                || i.nodes.len() != count
            {
                return Err(Error::field(
                    file,
                    format!("interfaces[{k}]"),
                    format!(
                        "interface {:?} refers to contacts {:?} with {} positions and {} node lists, but the model has {} contacts",
                        i.name,
                        i.contacts,
                        i.positions.len(),
                        i.nodes.len(),
                        self.contacts.len()
                    ),
                ));
            }
        }
        let mut friction_directions = Vec::with_capacity(self.frictions.len());
        for (k, f) in self.frictions.iter().enumerate() {
            let field = |x: &str| format!("frictions[{k}].{x}");
            friction_directions.push(self.check_direction(
                &dirichlet,
                &f.dofs,
                &f.w,
                field,
                "a friction element",
                "the slip direction",
            )?);
            if !(f.mu.is_finite() && f.mu >= 0.0) {
                return Err(Error::field(
                    file,
                    field("mu"),
                    format!("must be a finite non-negative number, got {}", f.mu),
                ));
            }
            match f.normal {
                FrictionNormal::Force(p) if !(p.is_finite() && p >= 0.0) => {
                    return Err(Error::field(
                        file,
                        field("normal_force"),
                        format!("must be a finite non-negative number, got {p}"),
                    ))
                }
                FrictionNormal::Contact(c) if c >= self.contacts.len() => {
                    return Err(Error::field(
                        file,
                        field("contact"),
                        format!(
                            "contact {c} does not exist (the model has {} contacts)",
                            self.contacts.len()
                        ),
                    ))
                }
                _ => {}
            }
        }
        // a friction law is odd in the slip direction: opposite directions are duplicates too
        self.check_independent(&friction_directions, "frictions", |a, b, _| {
            Err(Error::field(
                file,
                format!("frictions[{b}]"),
                format!("acts on the same DOFs as frictions[{a}] along the same line: the two are one friction element given twice, and the friction problem would be singular; give it once"),
            ))
        })?;
        for (name, v) in [
            ("load.harmonic", &self.harmonic_load),
            ("load.constant", &self.constant_load),
        ] {
            if v.len() != n {
                return Err(Error::field(
                    file,
                    name,
                    format!("load vector has {} entries for {n} DOFs", v.len()),
                ));
            }
            if v.iter().any(|x| !x.is_finite()) {
                return Err(Error::field(file, name, "load values must be finite"));
            }
        }
        if let Some(a) = &self.acceleration {
            if a.len() != self.dofs_per_node || a.iter().any(|x| !x.is_finite()) {
                return Err(Error::field(
                    file,
                    "load.acceleration",
                    format!(
                        "expected {} finite values (one per DOF of a node)",
                        self.dofs_per_node
                    ),
                ));
            }
        }
        let d = &self.damping;
        for (name, v) in [
            ("damping.alpha", d.alpha),
            ("damping.beta", d.beta),
            ("damping.beta_linear", d.beta_linear),
            ("damping.beta_condensed", d.beta_condensed),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::field(
                    file,
                    name,
                    format!("must be a finite non-negative number, got {v}"),
                ));
            }
        }
        if let Some(z) = d.first_mode_ratio {
            if !(z.is_finite() && z >= 0.0) {
                return Err(Error::field(
                    file,
                    "damping.first_mode_ratio",
                    format!("must be a finite non-negative number, got {z}"),
                ));
            }
            if d.alpha != 0.0 {
                return Err(Error::field(
                    file,
                    "damping.first_mode_ratio",
                    "set either `alpha` or `first_mode_ratio`, not both",
                ));
            }
        }
        Ok(())
    }
}

/// Relative tolerance below which two directions count as parallel (`|cos| ≥ 1 − tol`)
/// and a merged coefficient counts as cancelled (`|Σ w| ≤ tol · max |w_i|`).
const PARALLEL_TOLERANCE: f64 = 1e-12;

/// The direction `Σ_i w_i e_{dofs_i}` as `(dof, coefficient)` in DOF order: coefficients
/// of a repeated DOF are summed, and sums that cancel (`|Σ| ≤ 1e-12 · max |w_i|`) are
/// dropped.
fn merged_direction(dofs: &[usize], w: &[f64]) -> Vec<(usize, f64)> {
    let scale = w.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let mut sums: BTreeMap<usize, f64> = BTreeMap::new();
    for (&d, &v) in dofs.iter().zip(w) {
        *sums.entry(d).or_insert(0.0) += v;
    }
    sums.into_iter()
        .filter(|&(_, v)| v.abs() > PARALLEL_TOLERANCE * scale)
        .collect()
}
