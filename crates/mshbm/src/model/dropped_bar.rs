//! The elastic bar dropped under gravity onto a rigid support (the paper's Figs. 3–5,
//! docs/theory.md §12, (T88)–(T92)): a free bar of two-node elements (eq. 45) along the
//! vertical axis, released at rest and undeformed with its lower end at height `h0` above
//! the support.
//!
//! Node `i` is at height `x_i = i·length/elements` above the lower end (node 0); the DOFs
//! are the upward displacements. The contact is at node 0 with `g = h0 + u_0` (`W = +1`).
//! Gravity is a uniform acceleration `−g` ([`Model::acceleration`]), so its load uses the
//! mass the method uses: `−g M_R 1` with the redistributed mass (docs/theory.md (T32)), which keeps
//! free flight rigid. The stiffness of the free bar is singular (rigid translation); the
//! time integrators' iteration matrices are nevertheless positive definite, but methods
//! that need `K⁻¹` (the MS-HBM) refuse this model.
//!
//! The closed-form solution is [`crate::analytic::DroppedBarSolution`]
//! ([`DroppedBarParameters::analytic`]).

use std::path::Path;

use crate::analytic::DroppedBarSolution;
use crate::error::{Error, Result};
use crate::fe::bar1d;
use crate::limits::Limits;
use crate::model::bar::{check_positive, check_uniform_bar};
use crate::model::{Contact, Damping, Model};

/// Parameters of the dropped bar (units are the user's).
#[derive(Clone, Debug, PartialEq)]
pub struct DroppedBarParameters {
    pub elements: usize,
    /// Length of the bar.
    pub length: f64,
    pub density: f64,
    /// Young's modulus.
    pub young: f64,
    /// Cross-section area.
    pub area: f64,
    /// Height `h0` of the lower end above the support at release.
    pub height: f64,
    /// Gravitational acceleration `g > 0` (acting downward).
    pub gravity: f64,
    pub damping: Damping,
}

impl DroppedBarParameters {
    /// The nondimensional test setup of docs/theory.md §12: 100 elements,
    /// `L = c = g = ρ = E = A = 1`, `κ = 3` (`h0 = 4.5`, period 16).
    pub fn nondimensional() -> Self {
        DroppedBarParameters {
            elements: 100,
            length: 1.0,
            density: 1.0,
            young: 1.0,
            area: 1.0,
            height: DroppedBarSolution::height_for_kappa(3.0, 1.0, 1.0, 1.0),
            gravity: 1.0,
            damping: Damping::default(),
        }
    }

    /// Wave speed `c = sqrt(E/ρ)`.
    pub fn wave_speed(&self) -> f64 {
        (self.young / self.density).sqrt()
    }

    /// `κ = v0 c/(g L)`: the closed form is exactly periodic iff it is an integer ≥ 3.
    pub fn kappa(&self) -> f64 {
        (2.0 * self.gravity * self.height).sqrt() * self.wave_speed() / (self.gravity * self.length)
    }

    /// Drop height giving `κ` for these bar parameters.
    pub fn height_for_kappa(&self, kappa: f64) -> f64 {
        DroppedBarSolution::height_for_kappa(kappa, self.length, self.wave_speed(), self.gravity)
    }

    /// The closed-form solution docs/theory.md (T88)–(T90) (fails unless `κ` is an integer ≥ 3).
    pub fn analytic(&self) -> Result<DroppedBarSolution> {
        DroppedBarSolution::new(
            self.length,
            self.wave_speed(),
            self.gravity,
            self.height,
            self.density * self.area,
        )
    }

    /// Build the model with the default [`Limits`]; `source` names the origin in error
    /// messages.
    pub fn build(&self, source: &Path) -> Result<Model> {
        self.build_with(source, &Limits::default())
    }

    /// Build the model; `source` names the origin in error messages, and a bar whose
    /// memory estimate ([`crate::model::MODEL_BYTES_PER_DOF`] per node) exceeds `limits` is refused
    /// before anything is allocated.
    pub fn build_with(&self, source: &Path, limits: &Limits) -> Result<Model> {
        check_uniform_bar(
            source,
            limits,
            self.elements,
            self.length,
            self.density,
            self.young,
            self.area,
        )?;
        check_positive(source, "drop.gravity", self.gravity)?;
        if !(self.height.is_finite() && self.height >= 0.0) {
            return Err(Error::field(
                source,
                "drop.height",
                format!("must be a finite non-negative height, got {}", self.height),
            ));
        }
        let ne = self.elements;
        let n = ne + 1;
        let (mass, stiffness) =
            bar1d::assemble(ne, self.length, self.density, self.young, self.area)?;
        let model = Model {
            stiffness_file: None,
            source: source.to_path_buf(),
            input_files: vec![],
            cells: None,
            node_sets: Default::default(),
            node_labels: None,
            interfaces: vec![],
            name: format!("bar dropped onto a rigid support, {ne} elements"),
            mass,
            stiffness,
            damping_matrix: None,
            coordinates: bar1d::node_coordinates(ne, self.length),
            dofs_per_node: 1,
            dirichlet: vec![],
            contacts: vec![Contact {
                dofs: vec![0],
                w: vec![1.0],
                gap: self.height,
                friction: None,
            }],
            harmonic_load: vec![0.0; n],
            constant_load: vec![0.0; n],
            frictions: vec![],
            acceleration: Some(vec![-self.gravity]),
            damping: self.damping.clone(),
        };
        model.validate()?;
        Ok(model)
    }
}
