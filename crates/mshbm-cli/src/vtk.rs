//! VTK files for ParaView: a model's mesh with point data (displacement fields, mode
//! shapes) as XML unstructured grids (`.vtu`, written with the `vtkio` crate), and a `.pvd`
//! collection that orders them (time samples of one period, or modes).
//!
//! Points carry three coordinates and three displacement components (padded with zeros in
//! 1D and 2D). The cells are the model's (`Model::cells`); a model without them gets one
//! vertex cell per node, so that it still opens. A model read from a mesh or matrix file
//! with node labels (`Model::node_labels`) also gets the point scalar `node_label`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, Result};
use mshbm::fe::mesh::CellKind;
use mshbm::Model;
use vtkio::model::{
    Attribute, Attributes, ByteOrder, CellType, Cells, DataSet, UnstructuredGridPiece, Version,
    VertexNumbers, Vtk,
};

use crate::output::{write_atomic, OutputKind};

/// Memory of one file of a collection while it is planned and listed (its path in the list,
/// in the output plan and canonical there, and the plan's index), bytes beyond the path.
const BYTES_PER_FILE: u64 = 512;

/// Memory of one grid while it is built and encoded, per node (coordinates and a vector
/// field as `f64`, their base64 text, the XML) and per cell vertex (connectivity, offsets).
const GRID_BYTES_PER_NODE: u64 = 512;
const GRID_BYTES_PER_VERTEX: u64 = 32;

/// Check, before anything is allocated, that a collection of `count` files of `model`'s
/// mesh in `dir` fits the memory budget: the files' names (listed, planned) and one grid at
/// a time (the grids are written as they are built). `option` names the argument that
/// sets `count` (`--vtk-samples 100000000`) in the refusal.
pub fn check_collection_memory(
    option: &str,
    dir: &Path,
    count: usize,
    model: &Model,
    limits: &mshbm::limits::Limits,
) -> Result<()> {
    let path_bytes = dir.as_os_str().len() as u64 + 16;
    let files = (count as u64)
        .checked_add(1)
        .and_then(|n| n.checked_mul(path_bytes.checked_mul(3)?.checked_add(BYTES_PER_FILE)?));
    let vertices = model
        .cells
        .as_ref()
        .map_or(model.n_nodes(), |c| c.connectivity.len()) as u64;
    let grid = (model.n_nodes() as u64)
        .checked_mul(GRID_BYTES_PER_NODE)
        .zip(vertices.checked_mul(GRID_BYTES_PER_VERTEX))
        .and_then(|(a, b)| a.checked_add(b));
    limits.check_memory(
        &format!(
            "{option} ({count} VTK files of {} nodes in {})",
            model.n_nodes(),
            dir.display()
        ),
        files.zip(grid).and_then(|(a, b)| a.checked_add(b)),
    )?;
    Ok(())
}

/// The files of a collection in `dir`: `<stem>_0000.vtu …` and `<stem>.pvd` (the count is
/// checked first by [`check_collection_memory`]).
pub fn collection_paths(dir: &Path, stem: &str, count: usize) -> (Vec<PathBuf>, PathBuf) {
    let files = (0..count)
        .map(|k| dir.join(format!("{stem}_{k:04}.vtu")))
        .collect();
    (files, dir.join(format!("{stem}.pvd")))
}

/// Pad a per-node vector field of `model` (model DOF numbering) to three components.
fn three_components(model: &Model, field: &[f64]) -> Vec<f64> {
    let d = model.dofs_per_node;
    (0..model.n_nodes())
        .flat_map(|p| (0..3).map(move |c| if c < d { field[p * d + c] } else { 0.0 }))
        .collect()
}

/// The `.vtu` text of `model`'s mesh with the point vector fields `fields` (name, values in
/// model DOF numbering).
pub fn unstructured_grid(model: &Model, fields: &[(&str, &[f64])]) -> Result<Vec<u8>> {
    let points: Vec<f64> = model
        .coordinates
        .iter()
        .flat_map(|x| (0..3).map(move |a| x.get(a).copied().unwrap_or(0.0)))
        .collect();
    let (connectivity, per_cell, kind) = match &model.cells {
        Some(c) => (
            c.connectivity.iter().map(|&p| p as u64).collect::<Vec<_>>(),
            c.kind.nodes_per_cell(),
            match c.kind {
                CellKind::Line2 => CellType::Line,
                CellKind::Quad4 => CellType::Quad,
                CellKind::Tri3 => CellType::Triangle,
                CellKind::Tri6 => CellType::QuadraticTriangle,
                CellKind::Tet4 => CellType::Tetra,
                CellKind::Tet10 => CellType::QuadraticTetra,
                CellKind::Hex8 => CellType::Hexahedron,
                CellKind::Hex20 => CellType::QuadraticHexahedron,
            },
        ),
        None => ((0..model.n_nodes() as u64).collect(), 1, CellType::Vertex),
    };
    let n_cells = connectivity.len() / per_cell;
    let mut data = Attributes::new();
    for (name, values) in fields {
        data.point
            .push(Attribute::vectors(*name).with_data(three_components(model, values)));
    }
    if let Some(labels) = &model.node_labels {
        data.point
            .push(Attribute::scalars("node_label", 1).with_data(labels.clone()));
    }
    let vtk = Vtk {
        version: Version::new((1, 0)),
        byte_order: ByteOrder::LittleEndian,
        title: crate::output::one_line(&model.name),
        file_path: None,
        data: DataSet::inline(UnstructuredGridPiece {
            points: points.into(),
            cells: Cells {
                cell_verts: VertexNumbers::XML {
                    connectivity,
                    offsets: (1..=n_cells).map(|c| (c * per_cell) as u64).collect(),
                },
                types: vec![kind; n_cells],
            },
            data,
        }),
    };
    let mut bytes = Vec::new();
    vtk.write_xml(&mut bytes)
        .map_err(|e| anyhow!("cannot encode the VTK file: {e}"))?;
    Ok(bytes)
}

/// Write a collection: `grid(k)` gives the `(value, grid)` of file `k`, written to its
/// `.vtu` as soon as it is built (one grid in memory at a time), then the `.pvd` that
/// lists them with `value` as ParaView's time step. A signal stops it before the next file.
pub fn write_collection(
    files: &[PathBuf],
    pvd: &Path,
    mut grid: impl FnMut(usize) -> Result<(f64, Vec<u8>)>,
) -> Result<()> {
    let mut text = String::from(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  <Collection>\n",
    );
    for (k, path) in files.iter().enumerate() {
        crate::output::interrupt::check(&format!(
            "{k} of the {} VTK files were written, no .pvd",
            files.len()
        ))?;
        let (value, bytes) = grid(k)?;
        write_atomic(path, &bytes, OutputKind::Text)?;
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let _ = writeln!(
            text,
            "    <DataSet timestep=\"{value:.12e}\" group=\"\" part=\"0\" file=\"{name}\"/>"
        );
    }
    text.push_str("  </Collection>\n</VTKFile>\n");
    write_atomic(pvd, text.as_bytes(), OutputKind::Text)
}
