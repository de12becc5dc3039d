//! Contact interfaces of many nodes (docs/theory.md (T3)): a set of unilateral contacts
//! generated from a node set, kept together so that outputs can show the contact state
//! along the interface.
//!
//! * node-to-obstacle: node `p` against a rigid plane with outward unit normal `n` (pointing
//!   from the obstacle into the body): `g_p = nᵀ u_p + g0_p ≥ 0`;
//! * node-to-node: nodes `a` and `b` that coincide in the undeformed mesh (two crack lips,
//!   two bodies), with unit normal `n` pointing from `a` to `b`:
//!   `g = nᵀ (u_b − u_a) + g0 ≥ 0`.
//!
//! The normal is normalised here; its components must be finite and not all zero.

use std::ops::Range;

use crate::error::{Error, Result};
use crate::model::Contact;

/// A named group of consecutive contacts of a model, with the position of each along the
/// interface (for space–time pictures of the contact state).
#[derive(Clone, Debug, PartialEq)]
pub struct ContactInterface {
    /// Name (from the model file).
    pub name: String,
    /// Indices into [`crate::model::Model::contacts`].
    pub contacts: Range<usize>,
    /// Coordinate of each contact along the interface (model length unit), in the order of
    /// `contacts`.
    pub positions: Vec<f64>,
    /// The node(s) of each contact: one node for node-to-obstacle, `[a, b]` for a pair.
    pub nodes: Vec<Vec<usize>>,
}

/// The unit vector of `normal`, or an error naming `field`.
pub fn unit_normal(
    normal: &[f64],
    dim: usize,
    source: &std::path::Path,
    field: &str,
) -> Result<Vec<f64>> {
    if normal.len() != dim {
        return Err(Error::field(
            source,
            field,
            format!(
                "expected {dim} components (one per displacement component of a node), found {}",
                normal.len()
            ),
        ));
    }
    let norm = normal.iter().map(|v| v * v).sum::<f64>().sqrt();
    if !norm.is_finite() || norm == 0.0 {
        return Err(Error::field(
            source,
            field,
            "the normal must be finite and non-zero",
        ));
    }
    Ok(normal.iter().map(|v| v / norm).collect())
}

/// Node-to-obstacle contacts `g_p = nᵀ u_p + g0_p` for every node of `nodes` with gap
/// `gaps[i]` (`normal` a unit vector with one component per DOF of a node; DOF numbering
/// `node * dofs_per_node + component`). Components with a zero normal coefficient are
/// left out of the contact's DOFs.
pub fn obstacle_contacts(
    nodes: &[usize],
    normal: &[f64],
    gaps: &[f64],
    dofs_per_node: usize,
) -> Vec<Contact> {
    nodes
        .iter()
        .zip(gaps)
        .map(|(&p, &gap)| {
            let (dofs, w) = normal
                .iter()
                .enumerate()
                .filter(|(_, &n)| n != 0.0)
                .map(|(c, &n)| (p * dofs_per_node + c, n))
                .unzip();
            Contact {
                dofs,
                w,
                gap,
                friction: None,
            }
        })
        .collect()
}

/// Node-to-node contacts `g = nᵀ (u_b − u_a) + g0` for every pair `(a, b)` of `pairs` with
/// gap `gaps[i]` (`normal` a unit vector from `a` to `b`).
pub fn node_pair_contacts(
    pairs: &[(usize, usize)],
    normal: &[f64],
    gaps: &[f64],
    dofs_per_node: usize,
) -> Vec<Contact> {
    pairs
        .iter()
        .zip(gaps)
        .map(|(&(a, b), &gap)| {
            let mut dofs = Vec::new();
            let mut w = Vec::new();
            for (c, &n) in normal.iter().enumerate().filter(|(_, &n)| n != 0.0) {
                dofs.push(b * dofs_per_node + c);
                w.push(n);
                dofs.push(a * dofs_per_node + c);
                w.push(-n);
            }
            Contact {
                dofs,
                w,
                gap,
                friction: None,
            }
        })
        .collect()
}
