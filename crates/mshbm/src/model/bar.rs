//! The paper's clamped bar (Section 3.3, Table 1, Fig. 7): a uniform bar of two-node
//! elements (eq. 45) clamped at one end, a unilateral contact with gap `g0` at the other
//! (free) end, and a harmonic axial force at a node or a position along the bar.
//!
//! The DOFs are the axial displacements of the nodes `0..=elements` (node `i` at
//! `x = i·length/elements`), positive along `+x`. With the clamp on the left, the support is
//! beyond the right end: `g = g0 − u_end` (`W = −1`, docs/theory.md (T3)); with the clamp on the
//! right, the support is beyond the left end: `g = g0 + u_0`.

use std::path::Path;

use crate::error::{Error, Result};
use crate::fe::bar1d;
use crate::limits::Limits;
use crate::model::{Contact, Damping, Model, MODEL_BYTES_PER_DOF};

/// A finite positive parameter `v` of the model from `source`; the error names `field`.
pub(super) fn check_positive(source: &Path, field: &str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(Error::field(
            source,
            field,
            format!("must be positive, got {v}"),
        ))
    }
}

/// The parameters of a uniform bar of two-node elements (eq. 45) as `bar1d::assemble`
/// needs them: at least two elements, few enough for the memory budget (the model's
/// estimate is [`MODEL_BYTES_PER_DOF`] per node), positive length, density, Young's
/// modulus and area; errors name the `bar.*` field of `source`.
pub(super) fn check_uniform_bar(
    source: &Path,
    limits: &Limits,
    elements: usize,
    length: f64,
    density: f64,
    young: f64,
    area: f64,
) -> Result<()> {
    if elements < 2 {
        return Err(Error::field(
            source,
            "bar.elements",
            format!("must be at least 2, got {elements}"),
        ));
    }
    limits.check_items(
        &format!(
            "{}: field `bar.elements`: a bar of {elements} elements",
            source.display()
        ),
        (elements as u64).saturating_add(1),
        MODEL_BYTES_PER_DOF,
    )?;
    check_positive(source, "bar.length", length)?;
    check_positive(source, "bar.density", density)?;
    check_positive(source, "bar.young", young)?;
    check_positive(source, "bar.area", area)
}

/// Which end of the bar is clamped (the contact is at the other end).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ClampedEnd {
    Left,
    Right,
}

/// Where the harmonic force acts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ForceLocation {
    /// At a node (0-based).
    Node(usize),
    /// At a position `x` along the bar (model length unit); between nodes the force is
    /// shared by the two nodes of the element (consistent nodal load).
    Position(f64),
}

/// Parameters of the bar (units are the user's; the paper uses t, mm, s, N, MPa).
#[derive(Clone, Debug, PartialEq)]
pub struct BarParameters {
    pub elements: usize,
    /// Total length of the bar.
    pub length: f64,
    pub density: f64,
    /// Young's modulus.
    pub young: f64,
    /// Cross-section area.
    pub area: f64,
    pub clamped_end: ClampedEnd,
    /// Amplitude of the harmonic force `F cos(ωt)`, positive along `+x`.
    pub force_amplitude: f64,
    pub force_location: ForceLocation,
    /// Initial gap at the free end; `None` for a bar without contact.
    pub gap: Option<f64>,
    pub damping: Damping,
}

impl BarParameters {
    /// Table 1 of the paper: ρ = 9e-9 t/mm³, E = 2.1e5 MPa, A = 1 mm², L = 20 mm, 100
    /// elements, F = 4000 N at the middle (x = 10 mm), gap 0.2 mm, no damping.
    pub fn paper() -> Self {
        BarParameters {
            elements: 100,
            length: 20.0,
            density: 9e-9,
            young: 2.1e5,
            area: 1.0,
            clamped_end: ClampedEnd::Left,
            force_amplitude: 4000.0,
            force_location: ForceLocation::Position(10.0),
            gap: Some(0.2),
            damping: Damping::default(),
        }
    }

    /// Wave speed `c = sqrt(E/ρ)`.
    pub fn wave_speed(&self) -> f64 {
        (self.young / self.density).sqrt()
    }

    /// Build the model with the default [`Limits`]; `source` names the origin in error
    /// messages.
    pub fn build(&self, source: &Path) -> Result<Model> {
        self.build_with(source, &Limits::default())
    }

    /// Build the model; `source` names the origin in error messages, and a bar whose
    /// memory estimate ([`MODEL_BYTES_PER_DOF`] per node) exceeds `limits` is refused
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
        if !self.force_amplitude.is_finite() {
            return Err(Error::field(source, "load.amplitude", "must be finite"));
        }
        let ne = self.elements;
        let n = ne + 1;
        let (mass, stiffness) =
            bar1d::assemble(ne, self.length, self.density, self.young, self.area)?;
        // parameters whose products overflow (`bar.young = 1e308`: E·A/h is infinite) are
        // named here, not blamed later on what the infinity spoils (the damping)
        let h = self.length / ne as f64;
        for (field, matrix, product) in [
            (
                "bar.young",
                &stiffness,
                format!("E·A/h = {:e}·{:e}/{h:e}", self.young, self.area),
            ),
            (
                "bar.density",
                &mass,
                format!("ρ·A·h = {:e}·{:e}·{h:e}", self.density, self.area),
            ),
        ] {
            if matrix.iter().any(|(_, _, v)| !v.is_finite()) {
                return Err(Error::field(
                    source,
                    field,
                    format!("{product} overflows: the bar's matrices would not be finite"),
                ));
            }
        }
        let mut harmonic_load = vec![0.0; n];
        match self.force_location {
            ForceLocation::Node(k) => {
                if k > ne {
                    return Err(Error::field(
                        source,
                        "load.node",
                        format!("node {k} out of range (nodes 0..={ne})"),
                    ));
                }
                harmonic_load[k] = self.force_amplitude;
            }
            ForceLocation::Position(x) => {
                if !(x.is_finite() && (0.0..=self.length).contains(&x)) {
                    return Err(Error::field(
                        source,
                        "load.position",
                        format!("must lie on the bar [0, {}], got {x}", self.length),
                    ));
                }
                let s = x / self.length * ne as f64;
                let e = (s.floor() as usize).min(ne - 1);
                let xi = s - e as f64;
                harmonic_load[e] += (1.0 - xi) * self.force_amplitude;
                harmonic_load[e + 1] += xi * self.force_amplitude;
            }
        }
        let (clamped, free, w) = match self.clamped_end {
            ClampedEnd::Left => (0, ne, -1.0),
            ClampedEnd::Right => (ne, 0, 1.0),
        };
        let contacts = match self.gap {
            Some(gap) => vec![Contact {
                friction: None,
                dofs: vec![free],
                w: vec![w],
                gap,
            }],
            None => vec![],
        };
        let model = Model {
            stiffness_file: None,
            source: source.to_path_buf(),
            input_files: vec![],
            cells: None,
            node_sets: Default::default(),
            node_labels: None,
            interfaces: vec![],
            name: format!("clamped bar, {ne} elements"),
            mass,
            stiffness,
            damping_matrix: None,
            coordinates: bar1d::node_coordinates(ne, self.length),
            dofs_per_node: 1,
            dirichlet: vec![clamped],
            contacts,
            harmonic_load,
            constant_load: vec![0.0; n],
            frictions: vec![],
            acceleration: None,
            damping: self.damping.clone(),
        };
        model.validate()?;
        Ok(model)
    }
}
