//! The system the methods solve: a mass choice applied, damping built, Dirichlet DOFs
//! removed, and DOFs split into the linear part `L` and the nonlinear part `N` (paper
//! eq. 3 / eq. 23).

use std::path::PathBuf;

use crate::error::{Error, Result};
use crate::fe::redistribution::{
    expand_to_dofs, redistribute_scalar_mass, scalar_mass, Redistribution,
};
use crate::limits::Cancel;
use crate::model::Model;
use crate::modes::first_angular_frequency_cancellable;
use crate::sparse::SparseMatrix;

/// Which mass matrix a method uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MassKind {
    /// The consistent mass of the model.
    Consistent,
    /// The redistributed mass with a massless contact boundary (paper eq. 21).
    Redistributed,
}

/// A contact in system numbering.
#[derive(Clone, Debug, PartialEq)]
pub struct SystemContact {
    /// `(system DOF, ∂g/∂q)` pairs.
    pub w: Vec<(usize, f64)>,
    /// Initial gap `g0`.
    pub gap: f64,
    /// Coulomb friction along a tangent (docs/theory.md §20).
    pub friction: Option<SystemContactFriction>,
}

/// Coulomb friction of a contact in system numbering.
#[derive(Clone, Debug, PartialEq)]
pub struct SystemContactFriction {
    /// `(system DOF, ∂y_T/∂q)` pairs.
    pub w: Vec<(usize, f64)>,
    pub mu: f64,
    /// The second tangent of a contact in space, `(system DOF, ∂y_T₂/∂q)` pairs (T185).
    pub second: Option<Vec<(usize, f64)>>,
}

/// A friction element in system numbering.
#[derive(Clone, Debug, PartialEq)]
pub struct SystemFriction {
    /// `(system DOF, ∂γ_T/∂q̇)` pairs.
    pub w: Vec<(usize, f64)>,
    pub mu: f64,
    /// Normal force (a contact index refers to [`System::contacts`]).
    pub normal: crate::model::FrictionNormal,
}

/// The shift of [`System::check_not_indefinite`], relative to `max K_ii / max M_ii`: a
/// negative eigenvalue `λ` of `K φ = λ M φ` with `|λ|` below it (a growth rate below
/// `10⁻⁴` of the highest eigenfrequency) is not seen.
pub const INDEFINITE_SHIFT: f64 = 1e-8;

/// A model with its mass choice applied and Dirichlet DOFs removed.
#[derive(Clone, Debug)]
pub struct System {
    pub mass_kind: MassKind,
    /// Mass (redistributed or consistent), free DOFs only.
    pub mass: SparseMatrix,
    pub stiffness: SparseMatrix,
    /// `alpha M + beta K (+ C_file)` on the free DOFs.
    pub damping: SparseMatrix,
    /// Model DOF of each system DOF.
    pub model_dof: Vec<usize>,
    /// Number of DOFs of the model (Dirichlet DOFs included).
    pub n_model_dofs: usize,
    /// System DOFs of the nonlinear part `N`: all DOFs of the nodes that carry a contact or
    /// a friction DOF ([`Model::nonlinear_nodes`]; with a redistributed mass, which refuses
    /// friction, they are exactly the massless DOFs).
    pub nonlinear_dofs: Vec<usize>,
    /// System DOFs of the linear part `L`: all others.
    pub linear_dofs: Vec<usize>,
    pub contacts: Vec<SystemContact>,
    /// Coulomb friction elements.
    pub frictions: Vec<SystemFriction>,
    /// Cosine amplitude of the harmonic load, system numbering.
    pub harmonic_load: Vec<f64>,
    /// Constant load (including the acceleration field's load), system numbering.
    pub constant_load: Vec<f64>,
    /// Mass-proportional damping coefficient actually used (1/s).
    pub alpha: f64,
    /// Stiffness-proportional damping coefficient used (s).
    pub beta: f64,
    /// Coefficient (s) of the condensed-stiffness damping `β_c S` on the linear part
    /// ([`crate::model::Damping::beta_condensed`]); the Floquet analysis picks its reduced
    /// basis by it.
    pub beta_condensed: f64,
    /// Where the model came from ([`Model::source`]), for the errors of the methods that
    /// find the system unusable (a stiffness that is not positive definite).
    pub source: PathBuf,
    /// [`Model::stiffness_file`].
    pub stiffness_file: Option<PathBuf>,
}

impl Model {
    /// The mass matrix of the unconstrained mesh for `kind`.
    pub fn mass_matrix(&self, kind: MassKind) -> Result<SparseMatrix> {
        match kind {
            MassKind::Consistent => Ok(self.mass.clone()),
            MassKind::Redistributed => Ok(expand_to_dofs(
                &self.redistribution()?.mass,
                self.dofs_per_node,
            )),
        }
    }

    /// The redistributed scalar (per-node) mass with massless contact nodes, and the norm
    /// it was found in ([`redistribute_scalar_mass`], docs/theory.md §4).
    pub fn redistribution(&self) -> Result<Redistribution> {
        let scalar = scalar_mass(&self.mass, self.dofs_per_node).map_err(|why| {
            Error::Redistribution(format!(
                "{}: the mass matrix is not the same for every component of a node ({why}); redistribution needs M = m ⊗ I",
                self.source.display()
            ))
        })?;
        redistribute_scalar_mass(&scalar, &self.coordinates, &self.contact_nodes())
    }

    /// Build the [`System`] for a mass choice (see the module docs).
    pub fn system(&self, kind: MassKind) -> Result<System> {
        self.system_cancellable(kind, Cancel::NEVER)
    }

    /// [`Model::system`] stopped by `cancel` between its phases and in the eigensolver of
    /// a first-mode damping ratio (a factorization of `K`: tens of seconds on a 3D model).
    pub fn system_cancellable(&self, kind: MassKind, cancel: Cancel) -> Result<System> {
        cancel.check()?;
        self.validate()?;
        let n = self.n_dofs();
        let full_mass = self.mass_matrix(kind)?;
        let mut fixed = vec![false; n];
        self.dirichlet.iter().for_each(|&d| fixed[d] = true);
        let model_dof: Vec<usize> = (0..n).filter(|&d| !fixed[d]).collect();
        let mut system_of = vec![usize::MAX; n];
        for (s, &d) in model_dof.iter().enumerate() {
            system_of[d] = s;
        }
        let mass = full_mass.submatrix(&model_dof, &model_dof);
        let stiffness = self.stiffness.submatrix(&model_dof, &model_dof);

        if kind == MassKind::Redistributed && !self.frictions.is_empty() {
            return Err(Error::field(
                &self.source,
                "frictions",
                "the redistributed mass (massless contact boundary) does not support friction; use the general MS-HBM (consistent mass)",
            ));
        }
        let contact_nodes = self.nonlinear_nodes();
        let dpn = self.dofs_per_node;
        let nonlinear_dofs: Vec<usize> = contact_nodes
            .iter()
            .flat_map(|&node| (0..dpn).map(move |c| node * dpn + c))
            .filter(|&d| !fixed[d])
            .map(|d| system_of[d])
            .collect();
        let mut is_nonlinear = vec![false; model_dof.len()];
        nonlinear_dofs.iter().for_each(|&s| is_nonlinear[s] = true);
        let linear_dofs: Vec<usize> = (0..model_dof.len()).filter(|&s| !is_nonlinear[s]).collect();

        let alpha = match self.damping.first_mode_ratio {
            Some(zeta) if zeta > 0.0 => {
                2.0 * zeta
                    * first_angular_frequency_cancellable(&mass, &stiffness, cancel).map_err(
                        |e| match e {
                            Error::Singular(why) => {
                                Error::field(&self.source, "damping.first_mode_ratio", why)
                            }
                            other => other,
                        },
                    )?
            }
            _ => self.damping.alpha,
        };
        cancel.check()?;
        let beta = self.damping.beta;
        let mut damping = SparseMatrix::linear_combination(alpha, &mass, beta, &stiffness);
        // damping on the linear part only (docs/theory.md (T121)): β_L K_LL (the contact-node
        // rows and columns left out) and β_c S (the contact nodes relaxed)
        let mut linear_part: Vec<(usize, usize, f64)> = Vec::new();
        if self.damping.beta_linear != 0.0 {
            linear_part.extend(
                stiffness
                    .iter()
                    .filter(|&(i, j, _)| !is_nonlinear[i] && !is_nonlinear[j])
                    .map(|(i, j, v)| (i, j, self.damping.beta_linear * v)),
            );
        }
        if self.damping.beta_condensed != 0.0 {
            linear_part.extend(condensed_stiffness_triplets(
                &stiffness,
                &linear_dofs,
                &nonlinear_dofs,
                self.damping.beta_condensed,
                &self.source,
            )?);
        }
        if !linear_part.is_empty() {
            let n_free = stiffness.nrows();
            damping = SparseMatrix::linear_combination(
                1.0,
                &damping,
                1.0,
                &SparseMatrix::from_triplets(n_free, n_free, &linear_part),
            );
        }
        if let Some(c) = &self.damping_matrix {
            damping = SparseMatrix::linear_combination(
                1.0,
                &damping,
                1.0,
                &c.submatrix(&model_dof, &model_dof),
            );
        }

        let restrict = |v: &[f64]| -> Vec<f64> { model_dof.iter().map(|&d| v[d]).collect() };
        let harmonic_load = restrict(&self.harmonic_load);
        let mut constant_load = restrict(&self.constant_load);
        if let Some(a) = &self.acceleration {
            let field: Vec<f64> = (0..n).map(|d| a[d % dpn]).collect();
            let f = full_mass.mul_vec(&field);
            for (s, &d) in model_dof.iter().enumerate() {
                constant_load[s] += f[d];
            }
        }
        let contacts = self
            .contacts
            .iter()
            .map(|c| SystemContact {
                w: c.dofs
                    .iter()
                    .zip(&c.w)
                    .map(|(&d, &w)| (system_of[d], w))
                    .collect(),
                gap: c.gap,
                friction: c.friction.as_ref().map(|f| {
                    let free = |dofs: &[usize], w: &[f64]| -> Vec<(usize, f64)> {
                        dofs.iter()
                            .zip(w)
                            .filter(|(&d, _)| !fixed[d])
                            .map(|(&d, &w)| (system_of[d], w))
                            .collect()
                    };
                    SystemContactFriction {
                        w: free(&f.dofs, &f.w),
                        mu: f.mu,
                        second: f.second.as_ref().map(|t| free(&t.dofs, &t.w)),
                    }
                }),
            })
            .collect();
        let frictions = self
            .frictions
            .iter()
            .map(|f| SystemFriction {
                w: f.dofs
                    .iter()
                    .zip(&f.w)
                    .map(|(&d, &w)| (system_of[d], w))
                    .collect(),
                mu: f.mu,
                normal: f.normal.clone(),
            })
            .collect();
        Ok(System {
            mass_kind: kind,
            mass,
            stiffness,
            damping,
            model_dof,
            n_model_dofs: n,
            nonlinear_dofs,
            linear_dofs,
            contacts,
            frictions,
            harmonic_load,
            constant_load,
            alpha,
            beta,
            beta_condensed: self.damping.beta_condensed,
            source: self.source.clone(),
            stiffness_file: self.stiffness_file.clone(),
        })
    }
}

impl System {
    /// An error that blames the stiffness, naming the model file and, when the stiffness
    /// was read from a file, the field `matrices.stiffness` and that file:
    /// `MODEL: field `matrices.stiffness` (FILE): MESSAGE`, else `MODEL: MESSAGE`.
    pub fn stiffness_error(&self, message: impl std::fmt::Display) -> Error {
        match &self.stiffness_file {
            Some(file) => Error::field(
                &self.source,
                "matrices.stiffness",
                format!("{}: {message}", file.display()),
            ),
            None => Error::Singular(format!("{}: {message}", self.source.display())),
        }
    }

    /// Refuse a stiffness with a negative eigenvalue (`K φ = λ M φ`, `λ < 0`) before a
    /// time integration or a method that integrates in time: `K + σ M` must have a
    /// Cholesky factor, with `σ = INDEFINITE_SHIFT · max|K_ii| / max|M_ii|`. A structure
    /// that is not held (rigid-body modes, `K` semidefinite) passes, since its rigid-body
    /// motions carry mass; a negative stiffness, whose response grows exponentially and
    /// ended in a NaN deep inside the contact solver (or a panic), is refused naming the
    /// model. So is a part without mass that the stiffness does not hold.
    pub fn check_not_indefinite(&self) -> Result<()> {
        let diag_max =
            |a: &SparseMatrix| (0..a.nrows()).fold(0.0f64, |m, i| m.max(a.get(i, i).abs()));
        let (k, m) = (diag_max(&self.stiffness), diag_max(&self.mass));
        if self.n_dofs() == 0 || !(k > 0.0 && m > 0.0 && k.is_finite() && m.is_finite()) {
            // nothing to shift by: the methods' own checks decide
            return Ok(());
        }
        let sigma = INDEFINITE_SHIFT * k / m;
        let shifted = SparseMatrix::linear_combination(1.0, &self.stiffness, sigma, &self.mass);
        match shifted.to_faer().sp_cholesky(faer::Side::Lower) {
            Ok(_) => Ok(()),
            Err(_) => Err(self.stiffness_error(format!(
                "the stiffness is indefinite with the Dirichlet DOFs fixed (K + σM is not positive definite for σ = {sigma:.3e} = {INDEFINITE_SHIFT:e} max K_ii / max M_ii): a negative stiffness, whose response grows without bound, or a part without mass that the stiffness does not hold"
            ))),
        }
    }

    /// Number of free DOFs.
    pub fn n_dofs(&self) -> usize {
        self.model_dof.len()
    }

    /// System DOF of a model DOF, `None` for a Dirichlet DOF or one out of range.
    pub fn system_dof(&self, model_dof: usize) -> Option<usize> {
        self.model_dof.iter().position(|&d| d == model_dof)
    }
}

/// The triplets of `β S` on the `L` DOFs (system numbering), with `S = K_LL − K_LN K_NN⁻¹ K_NL`
/// the stiffness of the linear part when the contact nodes `N` follow statically
/// (docs/theory.md (T121)).
fn condensed_stiffness_triplets(
    stiffness: &SparseMatrix,
    linear_dofs: &[usize],
    nonlinear_dofs: &[usize],
    beta: f64,
    source: &std::path::Path,
) -> Result<Vec<(usize, usize, f64)>> {
    let s = crate::sparse::schur_complement(
        &stiffness.submatrix(linear_dofs, linear_dofs),
        &stiffness.submatrix(nonlinear_dofs, linear_dofs),
        &stiffness.submatrix(nonlinear_dofs, nonlinear_dofs),
    )
    .ok_or_else(|| {
        Error::field(
            source,
            "damping.beta_condensed",
            "needs K_NN (the stiffness of the contact nodes with every other DOF held) \
             positive definite",
        )
    })?;
    Ok(s.iter()
        .map(|(i, j, v)| (linear_dofs[i], linear_dofs[j], beta * v))
        .collect())
}
