//! `kind = "solid"` model files: a linear-elastic rectangle (plane stress or strain) or box
//! meshed by [`crate::fe::structured`] and assembled by [`crate::fe::solid`], with clamped
//! faces, partial supports, loads given as resultant forces on node sets, and contact
//! interfaces of many nodes ([`crate::model::interface`]; docs/theory.md (T3), (T110)).
//!
//! ```toml
//! kind = "solid"
//! name = "cantilever with a stop"
//! [solid]
//! dimension = 2                 # 2 (quadrilaterals, 2 DOFs per node) or 3 (hexahedra)
//! size = [100.0, 10.0]          # the box [0, Lx] × [0, Ly] (× [0, Lz]) [mm]
//! divisions = [80, 8]           # elements along each axis
//! young = 2.1e5                 # [MPa]
//! poisson = 0.3
//! density = 7.85e-9             # [t/mm^3]
//! thickness = 1.0               # 2D only [mm]
//! plane = "stress"              # 2D only: "stress" or "strain"
//! # crack = { x = 50.0, from = 0.0, to = 4.0 }   # 2D only: node sets crack_a, crack_b
//! clamped = ["x0"]              # node sets whose every DOF is fixed
//! [[node_sets]]                 # more named node sets (faces x0 … z1 exist already)
//! name = "stop"
//! box = [[77.5, 100.0], [0.0, 0.0]]   # nodes inside the box (per axis [min, max]), or
//! # nodes = [3, 4, 5]                 # node numbers (x fastest: j (nx+1) + i)
//! [[dirichlet]]                 # some components of a node set fixed
//! set = "y0"
//! components = [1]
//! [[loads]]                     # a resultant force on a node set, F cos(ωt) (+ constant)
//! set = "x1"
//! harmonic = [0.0, -50.0]       # [N] per component
//! # constant = [0.0, 0.0]
//! # distribution = "uniform"    # default "traction" on a set that holds faces of cells
//! [[interfaces]]
//! name = "stop"
//! kind = "obstacle"             # every node of `set` against a rigid plane: g = n·u + g0
//! set = "stop"
//! normal = [0.0, 1.0]           # unit normal from the obstacle into the body
//! gap = 0.05                    # g0 [mm], the same at every node; or per node:
//! # gap_gradient = [0.0, 0.0]   #   g0 = gap + gradient · x (a tilted or stepped plane)
//! # gap_file = "gaps.csv"       #   instead of `gap`: lines `node, g0`, one per node
//! #                             #   (for pairs: the node of the first set)
//! # mu = 0.3                   # Coulomb friction along the tangent (−n_y, n_x) (plane
//! #                             #   interfaces; redistributed MS-HBM, docs/theory.md §20)
//! # mu_file = "mu.csv"          #   instead of `mu`: lines `node, mu`, one per node
//! # [[interfaces]] kind = "pairs", sets = ["crack_a", "crack_b"], normal = [1.0, 0.0]:
//! # node-to-node contacts g = n·(u_b − u_a) + g0 between coinciding nodes of the two sets
//! [damping]                     # as for the other kinds
//! first_mode_ratio = 0.01
//! ```
//!
//! Errors name the file and the field.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::error::{Error, Result};
use crate::fe::solid::{assemble_plane, assemble_solid, ElasticMaterial, PlaneKind};
use crate::fe::structured::{cuboid, face_weights, rectangle, Crack2d, StructuredMesh};
use crate::model::excerpt::data_excerpt;
use crate::model::input_files::InputFiles;
use crate::model::interface::{node_pair_contacts, obstacle_contacts, unit_normal};
use crate::model::{ContactInterface, Damping, Model, MODEL_BYTES_PER_DOF};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SolidFile {
    #[allow(dead_code)]
    kind: String,
    name: Option<String>,
    solid: SolidSection,
    #[serde(default)]
    node_sets: Vec<NodeSetSection>,
    #[serde(default)]
    dirichlet: Vec<DirichletSection>,
    #[serde(default)]
    loads: Vec<LoadSection>,
    #[serde(default)]
    interfaces: Vec<InterfaceSection>,
    #[serde(default)]
    damping: super::file::DampingSection,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SolidSection {
    dimension: usize,
    size: Vec<f64>,
    divisions: Vec<usize>,
    young: f64,
    poisson: f64,
    density: f64,
    thickness: Option<f64>,
    plane: Option<Plane>,
    crack: Option<CrackSection>,
    #[serde(default)]
    clamped: Vec<String>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum Plane {
    Stress,
    Strain,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CrackSection {
    x: f64,
    from: f64,
    to: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct NodeSetSection {
    name: String,
    #[serde(rename = "box")]
    bounds: Option<Vec<[f64; 2]>>,
    nodes: Option<Vec<usize>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DirichletSection {
    set: String,
    components: Vec<usize>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LoadSection {
    set: String,
    harmonic: Option<Vec<f64>>,
    constant: Option<Vec<f64>>,
    distribution: Option<Distribution>,
}

#[derive(Deserialize, Clone, Copy, PartialEq)]
#[serde(rename_all = "lowercase")]
enum Distribution {
    Traction,
    Uniform,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct InterfaceSection {
    name: String,
    kind: InterfaceKind,
    set: Option<String>,
    sets: Option<[String; 2]>,
    normal: Vec<f64>,
    gap: Option<f64>,
    gap_gradient: Option<Vec<f64>>,
    gap_file: Option<String>,
    /// Coulomb friction coefficient (plane interfaces; docs/theory.md §20).
    mu: Option<f64>,
    /// Instead of `mu`: one coefficient per node (CSV lines `node, mu`).
    mu_file: Option<String>,
}

#[derive(Deserialize, Clone, Copy, PartialEq)]
#[serde(rename_all = "lowercase")]
enum InterfaceKind {
    Obstacle,
    Pairs,
}

/// Build the model of a `kind = "solid"` file (module docs).
pub(super) fn solid_model(f: SolidFile, path: &Path, inputs: &mut InputFiles) -> Result<Model> {
    let limits = *inputs.limits();
    let s = &f.solid;
    let d = s.dimension;
    let field = |name: &str| format!("solid.{name}");
    if d != 2 && d != 3 {
        return Err(Error::field(
            path,
            field("dimension"),
            format!("must be 2 or 3, got {d}"),
        ));
    }
    for (name, len) in [("size", s.size.len()), ("divisions", s.divisions.len())] {
        if len != d {
            return Err(Error::field(
                path,
                field(name),
                format!("expected {d} values (one per axis), found {len}"),
            ));
        }
    }
    // the model's memory before anything is allocated
    let nodes = s
        .divisions
        .iter()
        .try_fold(1u64, |p, &n| p.checked_mul(n as u64 + 1));
    let dofs = nodes.and_then(|n| n.checked_mul(d as u64));
    limits
        .check_memory(
            &format!("a {d}D solid of {:?} elements", s.divisions),
            dofs.and_then(|n| n.checked_mul(MODEL_BYTES_PER_DOF * (1 << d))),
        )
        .map_err(|e| Error::field(path, field("divisions"), e.to_string()))?;
    let material = ElasticMaterial {
        young: s.young,
        poisson: s.poisson,
        density: s.density,
    };
    material
        .validate()
        .map_err(|e| Error::field(path, "solid", e.to_string()))?;
    // a mesh error names the setting it comes from
    let at = |name: &'static str| {
        move |e: Error| {
            let field = match &e {
                Error::InvalidArgument { name, .. } if name == "mesh divisions" => "divisions",
                Error::InvalidArgument { name, .. } if name == "mesh size" => "size",
                _ => name,
            };
            Error::field(path, format!("solid.{field}"), e.to_string())
        }
    };
    let (mesh, (mass, stiffness)) = if d == 2 {
        let crack = s.crack.as_ref().map(|c| Crack2d {
            x: c.x,
            from: c.from,
            to: c.to,
        });
        let mesh = rectangle(
            [s.size[0], s.size[1]],
            [s.divisions[0], s.divisions[1]],
            crack.as_ref(),
        )
        .map_err(at(if crack.is_some() {
            "crack"
        } else {
            "divisions"
        }))?;
        let plane = match s.plane.unwrap_or(Plane::Stress) {
            Plane::Stress => PlaneKind::Stress,
            Plane::Strain => PlaneKind::Strain,
        };
        let matrices = assemble_plane(
            &mesh.coordinates,
            &mesh.cells,
            &material,
            s.thickness.unwrap_or(1.0),
            plane,
        )
        .map_err(at("thickness"))?;
        (mesh, matrices)
    } else {
        for (name, given) in [
            ("thickness", s.thickness.is_some()),
            ("plane", s.plane.is_some()),
            ("crack", s.crack.is_some()),
        ] {
            if given {
                return Err(Error::field(path, field(name), "applies to 2D solids only"));
            }
        }
        let mesh = cuboid(
            [s.size[0], s.size[1], s.size[2]],
            [s.divisions[0], s.divisions[1], s.divisions[2]],
        )
        .map_err(at("divisions"))?;
        let matrices =
            assemble_solid(&mesh.coordinates, &mesh.cells, &material).map_err(at("divisions"))?;
        (mesh, matrices)
    };
    let mut mesh = mesh;
    add_node_sets(&mut mesh, &f.node_sets, path)?;
    let n = mesh.coordinates.len() * d;
    let set = |name: &str, field: String| -> Result<&Vec<usize>> {
        let nodes = mesh.node_sets.get(name).ok_or_else(|| {
            Error::field(
                path,
                field.clone(),
                format!(
                    "unknown node set {name:?} (known: {})",
                    mesh.node_sets
                        .keys()
                        .cloned()
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )
        })?;
        if nodes.is_empty() {
            return Err(Error::field(
                path,
                field,
                format!("node set {name:?} is empty"),
            ));
        }
        Ok(nodes)
    };
    let mut dirichlet = Vec::new();
    for (k, name) in s.clamped.iter().enumerate() {
        for &p in set(name, format!("solid.clamped[{k}]"))? {
            dirichlet.extend((0..d).map(|c| p * d + c));
        }
    }
    for (k, sec) in f.dirichlet.iter().enumerate() {
        let nodes = set(&sec.set, format!("dirichlet[{k}].set"))?;
        if let Some(&c) = sec.components.iter().find(|&&c| c >= d) {
            return Err(Error::field(
                path,
                format!("dirichlet[{k}].components"),
                format!("component {c} does not exist (0..{})", d - 1),
            ));
        }
        for &p in nodes {
            dirichlet.extend(sec.components.iter().map(|&c| p * d + c));
        }
    }
    dirichlet.sort_unstable();
    dirichlet.dedup();
    let mut harmonic_load = vec![0.0; n];
    let mut constant_load = vec![0.0; n];
    for (k, sec) in f.loads.iter().enumerate() {
        let nodes = set(&sec.set, format!("loads[{k}].set"))?;
        let weights = match sec.distribution {
            Some(Distribution::Uniform) => vec![1.0 / nodes.len() as f64; nodes.len()],
            Some(Distribution::Traction) => face_weights(&mesh, nodes).map_err(|e| {
                Error::field(path, format!("loads[{k}].distribution"), e.to_string())
            })?,
            None => face_weights(&mesh, nodes)
                .unwrap_or_else(|_| vec![1.0 / nodes.len() as f64; nodes.len()]),
        };
        for (name, force, target) in [
            ("harmonic", &sec.harmonic, &mut harmonic_load),
            ("constant", &sec.constant, &mut constant_load),
        ] {
            let Some(force) = force else { continue };
            if force.len() != d || force.iter().any(|v| !v.is_finite()) {
                return Err(Error::field(
                    path,
                    format!("loads[{k}].{name}"),
                    format!("expected {d} finite components of the resultant force"),
                ));
            }
            for (&p, w) in nodes.iter().zip(&weights) {
                for c in 0..d {
                    target[p * d + c] += w * force[c];
                }
            }
        }
    }
    let (contacts, interfaces) = build_interfaces(
        &f.interfaces,
        &InterfaceMesh {
            x: &mesh.coordinates,
            node_sets: &mesh.node_sets,
            dofs_per_node: d,
            dirichlet: &dirichlet,
        },
        0,
        path,
        inputs,
    )?;
    let model = Model {
        source: PathBuf::from(path),
        input_files: std::mem::take(&mut inputs.read),
        name: f.name.clone().unwrap_or_else(|| format!("{d}D solid")),
        mass,
        stiffness,
        damping_matrix: None,
        coordinates: mesh.coordinates,
        dofs_per_node: d,
        cells: Some(mesh.cells),
        node_sets: mesh.node_sets,
        dirichlet,
        contacts,
        interfaces,
        frictions: vec![],
        harmonic_load,
        constant_load,
        acceleration: None,
        damping: Damping::from(f.damping),
    };
    model.validate()?;
    Ok(model)
}

/// Add the `[[node_sets]]` of the file to the mesh's faces.
fn add_node_sets(
    mesh: &mut StructuredMesh,
    sections: &[NodeSetSection],
    path: &Path,
) -> Result<()> {
    let d = mesh.coordinates.first().map_or(0, Vec::len);
    let extent: Vec<f64> = (0..d)
        .map(|a| {
            mesh.coordinates
                .iter()
                .fold(0.0f64, |m, x| m.max(x[a].abs()))
        })
        .collect();
    for (k, sec) in sections.iter().enumerate() {
        let field = |f: &str| format!("node_sets[{k}].{f}");
        if mesh.node_sets.contains_key(&sec.name) {
            return Err(Error::field(
                path,
                field("name"),
                format!("a node set {:?} exists already", sec.name),
            ));
        }
        let nodes = match (&sec.bounds, &sec.nodes) {
            (Some(b), None) => {
                if b.len() != d {
                    return Err(Error::field(
                        path,
                        field("box"),
                        format!("expected {d} ranges [min, max], one per axis"),
                    ));
                }
                (0..mesh.coordinates.len())
                    .filter(|&p| {
                        (0..d).all(|a| {
                            let tol = 1e-9 * extent[a].max(1e-300);
                            let x = mesh.coordinates[p][a];
                            x >= b[a][0] - tol && x <= b[a][1] + tol
                        })
                    })
                    .collect()
            }
            (None, Some(list)) => {
                if let Some(&bad) = list.iter().find(|&&p| p >= mesh.coordinates.len()) {
                    return Err(Error::field(
                        path,
                        field("nodes"),
                        format!(
                            "node {bad} does not exist (the mesh has {} nodes)",
                            mesh.coordinates.len()
                        ),
                    ));
                }
                list.clone()
            }
            _ => {
                return Err(Error::field(
                    path,
                    format!("node_sets[{k}]"),
                    "give exactly one of `box` and `nodes`",
                ))
            }
        };
        if nodes.is_empty() {
            return Err(Error::field(path, field("box"), "no node lies in the box"));
        }
        mesh.node_sets.insert(sec.name.clone(), nodes);
    }
    Ok(())
}

/// Coulomb friction with coefficients `mus` (one per contact) on the contacts `new` of an interface, along the
/// tangent `t = (−n_y, n_x)` of its unit normal `n` (plane interfaces, docs/theory.md
/// (T150)): the tangential displacement `tᵀ u_p` of an obstacle contact's node, `tᵀ (u_b − u_a)`
/// of a pair's.
fn add_friction(
    new: &mut [crate::model::Contact],
    nodes: &[Vec<usize>],
    normal: &[f64],
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
    if dofs_per_node != 2 {
        return Err(Error::field(
            path,
            field,
            "friction is supported on plane (2D) interfaces only; 3D interfaces with the Coulomb cone are not implemented yet (docs/theory.md §20)",
        ));
    }
    let tangent = [-normal[1], normal[0]];
    for ((contact, nodes), &mu) in new.iter_mut().zip(nodes).zip(mus) {
        let mut dofs = Vec::new();
        let mut w = Vec::new();
        // nodes: [p] against an obstacle, [a, b] for a pair (tᵀ (u_b − u_a))
        let signed: Vec<(usize, f64)> = match nodes.as_slice() {
            [p] => vec![(*p, 1.0)],
            [a, b] => vec![(*b, 1.0), (*a, -1.0)],
            _ => unreachable!("a contact has one node or a pair"),
        };
        for (node, sign) in signed {
            for (c, &t) in tangent.iter().enumerate().filter(|(_, &t)| t != 0.0) {
                dofs.push(node * dofs_per_node + c);
                w.push(sign * t);
            }
        }
        contact.friction = Some(crate::model::ContactFriction { dofs, w, mu });
    }
    Ok(())
}

/// What the `[[interfaces]]` of a model are built on.
pub(super) struct InterfaceMesh<'a> {
    /// Node coordinates.
    pub x: &'a [Vec<f64>],
    pub node_sets: &'a crate::fe::mesh::NodeSets,
    pub dofs_per_node: usize,
    /// Fixed DOFs, sorted.
    pub dirichlet: &'a [usize],
}

/// The contacts of the `[[interfaces]]` and their groups, numbered from `first` (the
/// contacts the model has before them).
pub(super) fn build_interfaces(
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
        if let Some(mus) = mus {
            add_friction(&mut new, &nodes, &normal, &mus, d, path, &field("mu"))?;
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
) -> Result<(HashMap<usize, f64>, Vec<(usize, String)>, String)> {
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
