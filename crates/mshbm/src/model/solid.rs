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
//! # mu = 0.3                    # Coulomb friction (redistributed MS-HBM, docs/theory.md
//! #                             #   §20): along (−n_y, n_x) in the plane, in the Coulomb
//! #                             #   cone in space (T185), (T219)
//! # tangent = [0.0, 1.0, 0.0]   #   in space, the first tangent (orthogonal to the normal;
//! #                             #   by default from the normal, (T219))
//! # mu_file = "mu.csv"          #   instead of `mu`: lines `node, mu`, one per node
//! # [[interfaces]] kind = "pairs", sets = ["crack_a", "crack_b"], normal = [1.0, 0.0]:
//! # node-to-node contacts g = n·(u_b − u_a) + g0 between coinciding nodes of the two sets
//! [damping]                     # as for the other kinds
//! first_mode_ratio = 0.01
//! ```
//!
//! Errors name the file and the field.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::error::{Error, Result};
use crate::fe::solid::{assemble_plane, assemble_solid, ElasticMaterial, PlaneKind};
use crate::fe::structured::{cuboid, mesh_face_weights, rectangle, Crack2d, StructuredMesh};
use crate::model::input_files::InputFiles;
use crate::model::interface::{build_interfaces, InterfaceMesh, InterfaceSection};
use crate::model::{Damping, Model, MODEL_BYTES_PER_DOF};

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
    damping: super::damping_section::DampingSection,
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
pub(super) struct DirichletSection {
    set: String,
    components: Vec<usize>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct LoadSection {
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
    let conditions = Conditions {
        clamped: &s.clamped,
        clamped_field: "solid.clamped",
        dirichlet: &f.dirichlet,
        loads: &f.loads,
        interfaces: &f.interfaces,
    };
    let name = f.name.clone().unwrap_or_else(|| format!("{d}D solid"));
    build_solid_model(
        mesh,
        (mass, stiffness),
        &conditions,
        name,
        f.damping,
        path,
        inputs,
    )
}

/// The boundary conditions, loads and interfaces of a solid-like model file (`kind =
/// "solid"`, `kind = "mesh"`), on named node sets.
pub(super) struct Conditions<'a> {
    pub clamped: &'a [String],
    /// The field `clamped` is read from (for messages).
    pub clamped_field: &'a str,
    pub dirichlet: &'a [DirichletSection],
    pub loads: &'a [LoadSection],
    pub interfaces: &'a [InterfaceSection],
}

/// The model of a meshed solid with its matrices `(M, K)` and `conditions`.
pub(super) fn build_solid_model(
    mesh: StructuredMesh,
    (mass, stiffness): (crate::sparse::SparseMatrix, crate::sparse::SparseMatrix),
    conditions: &Conditions,
    name: String,
    damping: super::damping_section::DampingSection,
    path: &Path,
    inputs: &mut InputFiles,
) -> Result<Model> {
    let d = mesh.coordinates.first().map_or(0, Vec::len);
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
    for (k, name) in conditions.clamped.iter().enumerate() {
        for &p in set(name, format!("{}[{k}]", conditions.clamped_field))? {
            dirichlet.extend((0..d).map(|c| p * d + c));
        }
    }
    for (k, sec) in conditions.dirichlet.iter().enumerate() {
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
    for (k, sec) in conditions.loads.iter().enumerate() {
        let nodes = set(&sec.set, format!("loads[{k}].set"))?;
        let weights = match sec.distribution {
            Some(Distribution::Uniform) => vec![1.0 / nodes.len() as f64; nodes.len()],
            Some(Distribution::Traction) => {
                mesh_face_weights(&mesh.coordinates, &mesh.cells, nodes).map_err(|e| {
                    Error::field(path, format!("loads[{k}].distribution"), e.to_string())
                })?
            }
            None => mesh_face_weights(&mesh.coordinates, &mesh.cells, nodes)
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
        conditions.interfaces,
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
        stiffness_file: None,
        source: PathBuf::from(path),
        input_files: std::mem::take(&mut inputs.read),
        name,
        mass,
        stiffness,
        damping_matrix: None,
        coordinates: mesh.coordinates,
        dofs_per_node: d,
        cells: Some(mesh.cells),
        node_sets: mesh.node_sets,
        node_labels: None,
        dirichlet,
        contacts,
        interfaces,
        frictions: vec![],
        harmonic_load,
        constant_load,
        acceleration: None,
        damping: Damping::from(damping),
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
