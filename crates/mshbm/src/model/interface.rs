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
//!
//! [`build_interfaces`] builds the contacts of the `[[interfaces]]` of a model file (the
//! `kind = "solid"` and `kind = "matrices"` kinds, documented in [`crate::model::solid`]):
//! the node sets, the gaps (`gap`, `gap_gradient`, `gap_file`) and the Coulomb friction
//! (`mu`, `mu_file`; docs/theory.md §20).

use std::collections::HashMap;
use std::ops::Range;
use std::path::Path;

use serde::Deserialize;

use crate::error::{Error, Result};
use crate::model::excerpt::data_excerpt;
use crate::model::input_files::InputFiles;
use crate::model::Contact;

mod friction;
use friction::add_friction;
pub use friction::interface_tangents;

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

// ---- building the interfaces of a model file (`[[interfaces]]` of `kind = "solid"` and
// `kind = "matrices"` models) ----

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct InterfaceSection {
    name: String,
    kind: InterfaceKind,
    set: Option<String>,
    sets: Option<[String; 2]>,
    normal: Vec<f64>,
    gap: Option<f64>,
    gap_gradient: Option<Vec<f64>>,
    gap_file: Option<String>,
    /// Coulomb friction coefficient (docs/theory.md §20; in space the Coulomb cone, (T185)).
    mu: Option<f64>,
    /// Instead of `mu`: one coefficient per node (CSV lines `node, mu`).
    mu_file: Option<String>,
    /// The first tangent of a 3D interface with friction (orthogonal to `normal`); by
    /// default derived from the normal ([`interface_tangents`]).
    tangent: Option<Vec<f64>>,
}

#[derive(Deserialize, Clone, Copy, PartialEq)]
#[serde(rename_all = "lowercase")]
pub(crate) enum InterfaceKind {
    Obstacle,
    Pairs,
}

/// What the `[[interfaces]]` of a model are built on.
pub(crate) struct InterfaceMesh<'a> {
    /// Node coordinates.
    pub x: &'a [Vec<f64>],
    pub node_sets: &'a crate::fe::mesh::NodeSets,
    pub dofs_per_node: usize,
    /// Fixed DOFs, sorted.
    pub dirichlet: &'a [usize],
}

/// The contacts of the `[[interfaces]]` and their groups, numbered from `first` (the
/// contacts the model has before them).
pub(crate) fn build_interfaces(
    sections: &[InterfaceSection],
    mesh: &InterfaceMesh,
    first: usize,
    path: &Path,
    inputs: &mut InputFiles,
) -> Result<(Vec<crate::model::Contact>, Vec<ContactInterface>)> {
    let &InterfaceMesh {
        x,
        node_sets,
        dofs_per_node: d,
        dirichlet,
    } = mesh;
    let mut contacts = Vec::new();
    let mut interfaces = Vec::new();
    for (k, sec) in sections.iter().enumerate() {
        let field = |f: &str| format!("interfaces[{k}].{f}");
        let normal = unit_normal(&sec.normal, d, path, &field("normal"))?;
        let (gap_of, listed) =
            interface_gaps(sec, x, d, path, &format!("interfaces[{k}]"), inputs)?;
        let get = |name: &str, f: String| {
            node_sets
                .get(name)
                .ok_or_else(|| Error::field(path, f, format!("unknown node set {name:?}")))
        };
        let (mut new, nodes): (Vec<_>, Vec<Vec<usize>>) = match sec.kind {
            InterfaceKind::Obstacle => {
                let (Some(name), None) = (&sec.set, &sec.sets) else {
                    return Err(Error::field(
                        path,
                        format!("interfaces[{k}]"),
                        "an obstacle interface takes `set` (one node set)",
                    ));
                };
                let nodes = get(name, field("set"))?;
                let gaps = nodes
                    .iter()
                    .map(|&p| gap_of(p))
                    .collect::<Result<Vec<_>>>()?;
                (
                    obstacle_contacts(nodes, &normal, &gaps, d),
                    nodes.iter().map(|&p| vec![p]).collect(),
                )
            }
            InterfaceKind::Pairs => {
                let (None, Some([a, b])) = (&sec.set, &sec.sets) else {
                    return Err(Error::field(
                        path,
                        format!("interfaces[{k}]"),
                        "a pairs interface takes `sets` (two node sets)",
                    ));
                };
                let (na, nb) = (get(a, field("sets"))?, get(b, field("sets"))?);
                let key = |p: usize| -> Vec<i64> {
                    x[p].iter().map(|v| (v * 1e9).round() as i64).collect()
                };
                let mut partner: HashMap<Vec<i64>, usize> = HashMap::with_capacity(nb.len());
                for &q in nb {
                    if let Some(other) = partner.insert(key(q), q) {
                        return Err(Error::field(
                            path,
                            field("sets"),
                            format!(
                                "nodes {other} and {q} of {b:?} are at the same place {:?}: each node of {a:?} needs one partner",
                                x[q]
                            ),
                        ));
                    }
                }
                let mut pairs = Vec::with_capacity(na.len());
                for &p in na {
                    let q = partner.get(&key(p)).ok_or_else(|| {
                        Error::field(
                            path,
                            field("sets"),
                            format!(
                                "node {p} of {a:?} at {:?} has no node of {b:?} at the same place",
                                x[p]
                            ),
                        )
                    })?;
                    pairs.push((p, *q));
                }
                if nb.len() != na.len() {
                    return Err(Error::field(
                        path,
                        field("sets"),
                        format!("{a:?} has {} nodes, {b:?} has {}", na.len(), nb.len()),
                    ));
                }
                let gaps = pairs
                    .iter()
                    .map(|&(p, _)| gap_of(p))
                    .collect::<Result<Vec<_>>>()?;
                (
                    node_pair_contacts(&pairs, &normal, &gaps, d),
                    pairs.iter().map(|&(p, q)| vec![p, q]).collect(),
                )
            }
        };
        // every line of a gap file is for a node of the interface (a line for another
        // node, or one that does not exist, was ignored)
        if !listed.is_empty() {
            let on_interface: std::collections::HashSet<usize> =
                nodes.iter().map(|n| n[0]).collect();
            if let Some((node, at)) = listed.iter().find(|(p, _)| !on_interface.contains(p)) {
                return Err(Error::field(
                    path,
                    field("gap_file"),
                    format!("{at}: node {node} is not a node of the interface"),
                ));
            }
        }
        if let Some(c) = new.iter().find(|c| {
            c.dofs
                .iter()
                .any(|dof| dirichlet.binary_search(dof).is_ok())
        }) {
            return Err(Error::field(
                path,
                field("set"),
                format!(
                    "node {} is held by a Dirichlet condition; a contact there never acts",
                    c.dofs[0] / d
                ),
            ));
        }
        let mus: Option<Vec<f64>> = match (sec.mu, &sec.mu_file) {
            (None, None) => None,
            (Some(mu), None) => Some(vec![mu; nodes.len()]),
            (None, Some(file)) => {
                let name = field("mu_file");
                let (values, listed, shown) = read_node_table(
                    inputs,
                    path,
                    &name,
                    file,
                    "friction coefficient",
                    (|m| m.is_finite() && m >= 0.0, "a finite number ≥ 0"),
                )?;
                let on_interface: std::collections::HashSet<usize> =
                    nodes.iter().map(|n| n[0]).collect();
                if let Some((node, at)) = listed.iter().find(|(p, _)| !on_interface.contains(p)) {
                    return Err(Error::field(
                        path,
                        name,
                        format!("{at}: node {node} is not a node of the interface"),
                    ));
                }
                Some(
                    nodes
                        .iter()
                        .map(|n| {
                            values.get(&n[0]).copied().ok_or_else(|| {
                                Error::field(
                                    path,
                                    name.clone(),
                                    format!(
                                        "{shown} has no friction coefficient for node {} of the interface",
                                        n[0]
                                    ),
                                )
                            })
                        })
                        .collect::<Result<_>>()?,
                )
            }
            (Some(_), Some(_)) => {
                return Err(Error::field(
                    path,
                    field("mu_file"),
                    "give `mu` or `mu_file`, not both",
                ))
            }
        };
        if sec.tangent.is_some() && mus.is_none() {
            return Err(Error::field(
                path,
                field("tangent"),
                "a tangent without friction (`mu` or `mu_file`) has no use",
            ));
        }
        if let Some(mus) = mus {
            let tangents =
                interface_tangents(&normal, sec.tangent.as_deref(), path, &field("tangent"))?;
            add_friction(&mut new, &nodes, &tangents, &mus, d, path, &field("mu"))?;
        }
        // position along the interface: the coordinate that varies most over its nodes
        let lead: Vec<usize> = nodes.iter().map(|n| n[0]).collect();
        let axis = (0..d)
            .max_by(|&a, &b| spread(x, &lead, a).total_cmp(&spread(x, &lead, b)))
            .unwrap_or(0);
        let start = first + contacts.len();
        contacts.extend(new);
        interfaces.push(ContactInterface {
            name: sec.name.clone(),
            contacts: start..first + contacts.len(),
            positions: lead.iter().map(|&p| x[p][axis]).collect(),
            nodes,
        });
    }
    Ok((contacts, interfaces))
}

/// The gap of each node of an interface, and the nodes a `gap_file` lists (with where), so
/// that a line for a node that is not on the interface is refused, not ignored.
type InterfaceGaps<'a> = (Box<dyn Fn(usize) -> Result<f64> + 'a>, Vec<(usize, String)>);

/// The initial gap `g0` of an interface's node (the first node of a pair), from exactly one
/// of: `gap` (uniform), `gap` plus `gap_gradient` (`g0 = gap + gradient · x`, the linear
/// formula of a tilted or offset obstacle), or `gap_file` (CSV lines `node, gap`, one for
/// every node of the interface; `#` starts a comment line).
fn interface_gaps<'a>(
    sec: &InterfaceSection,
    x: &'a [Vec<f64>],
    d: usize,
    path: &'a Path,
    table: &str,
    inputs: &mut InputFiles,
) -> Result<InterfaceGaps<'a>> {
    let field = |f: &str| format!("{table}.{f}");
    match (sec.gap, &sec.gap_gradient, &sec.gap_file) {
        (Some(g0), gradient, None) => {
            if !g0.is_finite() {
                return Err(Error::field(path, field("gap"), "must be finite"));
            }
            let gradient = match gradient {
                None => vec![0.0; d],
                Some(v) if v.len() == d && v.iter().all(|c| c.is_finite()) => v.clone(),
                Some(_) => {
                    return Err(Error::field(
                        path,
                        field("gap_gradient"),
                        format!("expected {d} finite numbers (d g0 / d x per axis)"),
                    ))
                }
            };
            Ok((
                Box::new(move |p| {
                    Ok(g0 + gradient.iter().zip(&x[p]).map(|(a, b)| a * b).sum::<f64>())
                }),
                Vec::new(),
            ))
        }
        (None, None, Some(file)) => {
            let field = field("gap_file");
            let (gaps, listed, shown) = read_node_table(
                inputs,
                path,
                &field,
                file,
                "gap",
                (|g| g.is_finite(), "a finite number"),
            )?;
            Ok((
                Box::new(move |p| {
                    gaps.get(&p).copied().ok_or_else(|| {
                        Error::field(
                            path,
                            field.clone(),
                            format!("{shown} has no gap for node {p} of the interface"),
                        )
                    })
                }),
                listed,
            ))
        }
        _ => Err(Error::field(
            path,
            table.to_string(),
            "give `gap` (optionally with `gap_gradient`) or `gap_file`, not both",
        )),
    }
}

/// What [`read_node_table`] returns: the values by node, the nodes listed with where (file
/// and line), and the file as shown in messages.
type NodeTable = (HashMap<usize, f64>, Vec<(usize, String)>, String);

/// A per-node table (`gap_file`, `mu_file`): CSV lines `node, value` (`#` starts a comment
/// line), each node once, each value `valid` (described as `requirement` in messages). Returns the values, the nodes listed with
/// where (file and line), and the file as shown in messages.
fn read_node_table(
    inputs: &mut InputFiles,
    path: &Path,
    field: &str,
    file: &str,
    value: &str,
    (valid, requirement): (fn(f64) -> bool, &str),
) -> Result<NodeTable> {
    let (shown, text) = inputs.read(field, file)?;
    let mut values = HashMap::new();
    let mut listed = Vec::new();
    for (line_number, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let at = |what: String| {
            Error::field(
                path,
                field.to_string(),
                format!("{}, line {}: {what}", shown.display(), line_number + 1),
            )
        };
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let [node, number] = fields[..] else {
            return Err(at(format!(
                "expected `node, {value}`, found {} fields",
                fields.len()
            )));
        };
        let node: usize = node.parse().map_err(|_| {
            at(format!(
                "node {} is not a non-negative integer",
                data_excerpt(node)
            ))
        })?;
        let number: f64 = number
            .parse()
            .ok()
            .filter(|v: &f64| valid(*v))
            .ok_or_else(|| {
                at(format!(
                    "{value} {} is not {requirement}",
                    data_excerpt(number)
                ))
            })?;
        if values.insert(node, number).is_some() {
            return Err(at(format!("node {node} given twice")));
        }
        listed.push((
            node,
            format!("{}, line {}", shown.display(), line_number + 1),
        ));
    }
    Ok((values, listed, shown.display().to_string()))
}

fn spread(x: &[Vec<f64>], nodes: &[usize], axis: usize) -> f64 {
    let (lo, hi) = nodes
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &p| {
            (l.min(x[p][axis]), h.max(x[p][axis]))
        });
    hi - lo
}
