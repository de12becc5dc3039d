//! `kind = "mesh"` model files: a linear-elastic solid meshed in Gmsh (an MSH 4.1 ASCII or binary
//! file read by [`crate::model::gmsh`]) or written as an Abaqus input file (a file ending
//! in `.inp`, the subset read by [`crate::model::abaqus`]): triangles or quadrilaterals in
//! 2D, linear or quadratic tetrahedra or hexahedra in 3D, docs/theory.md §21, whose
//! physical groups (Abaqus: node sets, element sets, node surfaces) name the clamped set,
//! the loaded sets and the contact interfaces. Everything after the
//! `[mesh]` table is as for `kind = "solid"` ([`crate::model::solid`]), with the physical
//! groups as the node sets.
//!
//! ```toml
//! kind = "mesh"
//! name = "bracket"
//! [mesh]
//! file = "bracket.msh"          # relative to this file; MSH 4.1 ASCII or binary, or Abaqus `.inp`
//! young = 2.1e5                 # [MPa], with the mesh's length unit in mm
//! poisson = 0.3
//! density = 7.85e-9             # [t/mm^3]
//! # thickness = 1.0             # 2D only [mm]
//! # plane = "stress"            # 2D only: "stress" or "strain"
//! clamped = ["root"]            # physical groups whose every DOF is fixed
//! [[dirichlet]]                 # some components of a physical group fixed
//! set = "symmetry"
//! components = [2]
//! [[loads]]                     # a resultant force on a physical group, F cos(ωt)
//! set = "tip"
//! harmonic = [0.0, -50.0, 0.0]  # [N] per component; a group of faces gets a uniform
//!                               # traction (T106), (T206)
//! [[interfaces]]                # as for kind = "solid": obstacle or pairs
//! name = "stop"
//! kind = "obstacle"
//! set = "contact"
//! normal = [0.0, 1.0, 0.0]
//! gap = 0.05
//! [damping]
//! first_mode_ratio = 0.01
//! ```
//!
//! Every node of an interface's group (on a quadratic mesh the vertices and the mid-side
//! nodes of its faces) becomes massless under redistribution, with the total mass and the
//! first and second moments kept (docs/theory.md (T208)–(T210)).
//!
//! From an Abaqus file the groups are its node sets, element sets (the nodes of their
//! elements) and node surfaces, named as the file first writes them; a node set shadows an
//! element set of the same name. Physical groups without a name are
//! `physical_<dim>_<tag>`. The model's node `p` is the `p`-th smallest Gmsh node tag
//! (Abaqus node label) among the nodes of the solid cells; outputs that name nodes
//! (`--contacts-csv`, the VTK point data `node_label`) give the tags (labels) again
//! ([`Model::node_labels`]). Errors name the model file and the field, and for the mesh
//! file its path and line.

use std::path::Path;

use serde::Deserialize;

use crate::error::{Error, Result};
use crate::fe::solid::{assemble_plane, assemble_solid, ElasticMaterial, PlaneKind};
use crate::fe::structured::StructuredMesh;
use crate::model::abaqus::parse_inp;
use crate::model::gmsh::parse_msh_bytes;
use crate::model::input_files::InputFiles;
use crate::model::interface::InterfaceSection;
use crate::model::solid::{build_solid_model, Conditions, DirichletSection, LoadSection};
use crate::model::{Model, MODEL_BYTES_PER_DOF};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct MeshFile {
    #[allow(dead_code)]
    kind: String,
    name: Option<String>,
    mesh: MeshSection,
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
struct MeshSection {
    file: String,
    young: f64,
    poisson: f64,
    density: f64,
    thickness: Option<f64>,
    plane: Option<Plane>,
    #[serde(default)]
    clamped: Vec<String>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum Plane {
    Stress,
    Strain,
}

/// Bytes per entry of the element matrices while they are assembled (a triplet of K and
/// one of M).
const ASSEMBLY_BYTES_PER_ENTRY: u64 = 48;

/// Build the model of a `kind = "mesh"` file (module docs).
pub(super) fn mesh_model(f: MeshFile, path: &Path, inputs: &mut InputFiles) -> Result<Model> {
    let s = &f.mesh;
    // the reader by the file's extension: `.inp` Abaqus, anything else Gmsh (ASCII or
    // binary)
    let abaqus = Path::new(&s.file)
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("inp"));
    let (shown, mesh) = if abaqus {
        let (shown, text) = inputs.read("mesh.file", &s.file)?;
        (shown, parse_inp(&text))
    } else {
        let (shown, bytes) = inputs.read_bytes("mesh.file", &s.file)?;
        (shown, parse_msh_bytes(&bytes))
    };
    let mesh =
        mesh.map_err(|e| Error::field(path, "mesh.file", format!("{}, {e}", shown.display())))?;
    let d = mesh.dimension;
    // the model's memory before the matrices are assembled
    let per_cell = (mesh.cells.kind.nodes_per_cell() * d) as u64;
    let bytes = (mesh.cells.len() as u64)
        .checked_mul(per_cell * per_cell * ASSEMBLY_BYTES_PER_ENTRY)
        .and_then(|a| {
            (mesh.coordinates.len() as u64 * d as u64)
                .checked_mul(MODEL_BYTES_PER_DOF)?
                .checked_add(a)
        });
    inputs
        .limits()
        .check_memory(
            &format!(
                "a mesh of {} {:?} cells and {} nodes",
                mesh.cells.len(),
                mesh.cells.kind,
                mesh.coordinates.len()
            ),
            bytes,
        )
        .map_err(|e| Error::field(path, "mesh.file", e.to_string()))?;
    let material = ElasticMaterial {
        young: s.young,
        poisson: s.poisson,
        density: s.density,
    };
    material
        .validate()
        .map_err(|e| Error::field(path, "mesh", e.to_string()))?;
    let at = |e: Error| Error::field(path, "mesh.file", format!("{}: {e}", shown.display()));
    let matrices = if d == 2 {
        let plane = match s.plane.unwrap_or(Plane::Stress) {
            Plane::Stress => PlaneKind::Stress,
            Plane::Strain => PlaneKind::Strain,
        };
        let thickness = s.thickness.unwrap_or(1.0);
        if !(thickness.is_finite() && thickness > 0.0) {
            return Err(Error::field(
                path,
                "mesh.thickness",
                format!("must be positive, got {thickness}"),
            ));
        }
        assemble_plane(&mesh.coordinates, &mesh.cells, &material, thickness, plane).map_err(at)?
    } else {
        for (name, given) in [
            ("thickness", s.thickness.is_some()),
            ("plane", s.plane.is_some()),
        ] {
            if given {
                return Err(Error::field(
                    path,
                    format!("mesh.{name}"),
                    "applies to 2D meshes only",
                ));
            }
        }
        assemble_solid(&mesh.coordinates, &mesh.cells, &material).map_err(at)?
    };
    let conditions = Conditions {
        clamped: &s.clamped,
        clamped_field: "mesh.clamped",
        dirichlet: &f.dirichlet,
        loads: &f.loads,
        interfaces: &f.interfaces,
    };
    let name = f
        .name
        .clone()
        .unwrap_or_else(|| format!("{d}D mesh of {:?} cells", mesh.cells.kind));
    let solid = StructuredMesh {
        coordinates: mesh.coordinates,
        cells: mesh.cells,
        node_sets: mesh.groups,
    };
    let mut model = build_solid_model(solid, matrices, &conditions, name, f.damping, path, inputs)?;
    model.node_labels = Some(mesh.node_tags);
    Ok(model)
}
