//! Friction on `[[interfaces]]`: the tangents of an interface's normal (docs/theory.md
//! (T150), (T219)) and the tangential displacements of its contacts.

use std::path::Path;

use super::unit_normal;
use crate::error::{Error, Result};

/// The unit tangents of a unit normal `n` (docs/theory.md (T150), (T219)): in the plane
/// `t = (−n_y, n_x)`; in space the first tangent `t₁` is `given` (made a unit vector; it must
/// be orthogonal to `n`) or, by default, the coordinate axis least aligned with `n` (the
/// first of equals) with its `n` component removed, and the second `t₂ = n × t₁`.
pub fn interface_tangents(
    normal: &[f64],
    given: Option<&[f64]>,
    path: &Path,
    field: &str,
) -> Result<Vec<Vec<f64>>> {
    match normal.len() {
        2 => match given {
            None => Ok(vec![vec![-normal[1], normal[0]]]),
            Some(_) => Err(Error::field(
                path,
                field,
                "a plane interface's tangent is (-n_y, n_x); give `tangent` on 3D interfaces only",
            )),
        },
        3 => {
            let n = [normal[0], normal[1], normal[2]];
            let t1: Vec<f64> = match given {
                Some(t) => {
                    let t = unit_normal(t, 3, path, field)?;
                    let dot: f64 = t.iter().zip(&n).map(|(a, b)| a * b).sum();
                    if dot.abs() > 1e-9 {
                        return Err(Error::field(
                            path,
                            field,
                            format!(
                                "the tangent must be orthogonal to the normal (their unit vectors' product is {dot:e})"
                            ),
                        ));
                    }
                    t
                }
                None => {
                    let axis = (0..3)
                        .min_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs()))
                        .expect("three axes");
                    let mut t: Vec<f64> = (0..3)
                        .map(|c| f64::from(u8::from(c == axis)) - n[axis] * n[c])
                        .collect();
                    let norm = t.iter().map(|v| v * v).sum::<f64>().sqrt();
                    t.iter_mut().for_each(|v| *v /= norm);
                    t
                }
            };
            let t2 = vec![
                n[1] * t1[2] - n[2] * t1[1],
                n[2] * t1[0] - n[0] * t1[2],
                n[0] * t1[1] - n[1] * t1[0],
            ];
            Ok(vec![t1, t2])
        }
        d => Err(Error::field(
            path,
            field,
            format!(
                "friction needs interfaces of 2 or 3 displacement components per node, not {d}"
            ),
        )),
    }
}

/// Coulomb friction with coefficients `mus` (one per contact) on the contacts `new` of an
/// interface, along the tangents `tangents` of its unit normal ([`interface_tangents`]):
/// the tangential displacement `tᵀ u_p` of an obstacle contact's node, `tᵀ (u_b − u_a)` of a
/// pair's; in space the second tangent makes the friction force's cone (T185).
pub(super) fn add_friction(
    new: &mut [crate::model::Contact],
    nodes: &[Vec<usize>],
    tangents: &[Vec<f64>],
    mus: &[f64],
    dofs_per_node: usize,
    path: &Path,
    field: &str,
) -> Result<()> {
    if let Some(mu) = mus.iter().find(|m| !(m.is_finite() && **m >= 0.0)) {
        return Err(Error::field(
            path,
            field,
            format!("the friction coefficient must be finite and ≥ 0, got {mu}"),
        ));
    }
    for ((contact, nodes), &mu) in new.iter_mut().zip(nodes).zip(mus) {
        // nodes: [p] against an obstacle, [a, b] for a pair (tᵀ (u_b − u_a))
        let signed: Vec<(usize, f64)> = match nodes.as_slice() {
            [p] => vec![(*p, 1.0)],
            [a, b] => vec![(*b, 1.0), (*a, -1.0)],
            _ => unreachable!("a contact has one node or a pair"),
        };
        let along = |tangent: &[f64]| {
            let mut t = crate::model::ContactTangent {
                dofs: Vec::new(),
                w: Vec::new(),
            };
            for &(node, sign) in &signed {
                for (c, &v) in tangent.iter().enumerate().filter(|(_, &v)| v != 0.0) {
                    t.dofs.push(node * dofs_per_node + c);
                    t.w.push(sign * v);
                }
            }
            t
        };
        let first = along(&tangents[0]);
        contact.friction = Some(crate::model::ContactFriction {
            dofs: first.dofs,
            w: first.w,
            mu,
            second: tangents.get(1).map(|t| along(t)),
        });
    }
    Ok(())
}
