//! The `L | N` partition as the periodic-solution methods use it (docs/theory.md §1, (T3),
//! (T6); paper eqs. 3
//! and 23): where each system DOF sits in `N` (the DOFs the set-valued laws act on) or `L`,
//! the contact directions `W` in `N` numbering, and the length scale that Newton's
//! tolerance and the continuation's scaling are relative to
//! ([`crate::problem::PeriodicProblem::length_scale`]); the blocks and loads of both parts
//! are [`crate::linear::PartitionedSystem`]. One piece of code for the redistributed
//! MS-HBM, the general MS-HBM and the HBM-AFT, so that their unknowns, tolerances and
//! reported DOFs mean the same.

use faer::linalg::solvers::Solve;
use faer::Mat;

use crate::error::{Error, Result};
use crate::model::System;

/// Where a model DOF sits in the partition.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum DofLocation {
    /// A Dirichlet DOF: it does not move.
    Fixed,
    /// Index in `N`.
    Nonlinear(usize),
    /// Index in `L`.
    Linear(usize),
}

/// What a stiffness matrix that cannot be Cholesky-factored means for the length scale.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum SingularStiffness {
    /// An error: the method needs the structure to be held (`K` positive definite).
    Refuse,
    /// The static deflection is taken as zero (the gaps alone set the scale).
    Ignore,
}

/// The `L | N` partition of a [`System`] with its length scale.
#[derive(Clone, Debug)]
pub(crate) struct Partition {
    /// Index in `N` of each system DOF (`None` for an `L` DOF).
    n_index: Vec<Option<usize>>,
    /// Index in `L` of each system DOF (`None` for an `N` DOF).
    l_index: Vec<Option<usize>>,
    length_scale: f64,
}

impl Partition {
    /// The partition of `system` ([`System::nonlinear_dofs`] / [`System::linear_dofs`]).
    pub fn new(system: &System, singular: SingularStiffness) -> Result<Self> {
        let index_of = |dofs: &[usize]| {
            let mut index = vec![None; system.n_dofs()];
            dofs.iter()
                .enumerate()
                .for_each(|(k, &d)| index[d] = Some(k));
            index
        };
        let static_deflection = match (static_deflection(system), singular) {
            (Ok(d), _) => d,
            (Err(_), SingularStiffness::Ignore) => 0.0,
            (Err(e), SingularStiffness::Refuse) => return Err(e),
        };
        Ok(Partition {
            n_index: index_of(&system.nonlinear_dofs),
            l_index: index_of(&system.linear_dofs),
            length_scale: length_scale(system, static_deflection),
        })
    }

    /// The length scale: the largest gap `|g0|` or static deflection of an `N` DOF, 1 when
    /// both vanish.
    pub fn length_scale(&self) -> f64 {
        self.length_scale
    }

    /// Index in `N` of a system DOF (`None` for an `L` DOF).
    pub fn n_index(&self, system_dof: usize) -> Option<usize> {
        self.n_index[system_dof]
    }

    /// Index in `N` of the (first) DOF of contact `c`, the DOF its [`ContactSeries`]
    /// reports.
    ///
    /// [`ContactSeries`]: crate::solution::ContactSeries
    pub fn contact_n_index(&self, system: &System, c: usize) -> usize {
        self.n_index(system.contacts[c].w[0].0)
            .expect("contact DOFs are in N")
    }

    /// Where the model DOF `response_dof` (the DOF a solution reports) sits; an error names
    /// it when the model has no such DOF.
    pub fn locate_response(&self, system: &System, response_dof: usize) -> Result<DofLocation> {
        if response_dof >= system.n_model_dofs {
            return Err(Error::argument(
                "dof",
                format!(
                    "DOF {response_dof} does not exist (the model has DOFs 0..{})",
                    system.n_model_dofs - 1
                ),
            ));
        }
        Ok(match system.system_dof(response_dof) {
            None => DofLocation::Fixed,
            Some(s) => match (self.n_index[s], self.l_index[s]) {
                (Some(i), _) => DofLocation::Nonlinear(i),
                (None, Some(l)) => DofLocation::Linear(l),
                (None, None) => unreachable!("every system DOF is in L or N"),
            },
        })
    }
}

/// `W = ∂g/∂q_N` (`n_N × n_c`, row-major): the contact directions of `system` in `N`
/// numbering (docs/theory.md (T3)).
pub(crate) fn contact_directions(system: &System) -> Vec<f64> {
    let n = system.nonlinear_dofs.len();
    let nc = system.contacts.len();
    let mut w = vec![0.0; n * nc];
    for (c, contact) in system.contacts.iter().enumerate() {
        for &(dof, coeff) in &contact.w {
            let i = system
                .nonlinear_dofs
                .iter()
                .position(|&d| d == dof)
                .expect("contact DOFs are in N");
            w[i * nc + c] += coeff;
        }
    }
    w
}

/// The largest static deflection `max_{i∈N} |(K⁻¹ (|f_h| + |f_0|))_i|` of an `N` DOF under
/// the magnitudes of the harmonic and the constant load (sparse Cholesky of the full `K`).
/// Fails when `K` is not positive definite, naming the model: the structure is not held
/// (a rigid-body motion) or its stiffness is indefinite (a negative stiffness).
fn static_deflection(system: &System) -> Result<f64> {
    let llt = system
        .stiffness
        .to_faer()
        .sp_cholesky(faer::Side::Lower)
        .map_err(|_| {
            Error::Singular(format!(
                "{}: the stiffness is not positive definite with the Dirichlet DOFs fixed: the structure is not held (it can move as a rigid body) or its stiffness is indefinite (a negative stiffness); this method needs a held structure with a positive definite stiffness",
                system.source.display()
            ))
        })?;
    let f: Vec<f64> = system
        .harmonic_load
        .iter()
        .zip(&system.constant_load)
        .map(|(a, b)| a.abs() + b.abs())
        .collect();
    let mut rhs = Mat::<f64>::from_fn(f.len(), 1, |i, _| f[i]);
    llt.solve_in_place(rhs.as_mut());
    Ok(system
        .nonlinear_dofs
        .iter()
        .fold(0.0f64, |m, &i| m.max(rhs[(i, 0)].abs())))
}

/// The larger of the largest gap `|g0|` and `static_deflection`; 1 when that is zero or
/// not finite.
fn length_scale(system: &System, static_deflection: f64) -> f64 {
    let gap_scale = system
        .contacts
        .iter()
        .fold(0.0f64, |m, c| m.max(c.gap.abs()));
    let s = gap_scale.max(static_deflection);
    if s.is_finite() && s > 0.0 {
        s
    } else {
        1.0
    }
}
