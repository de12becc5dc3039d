//! VTK files for ParaView: a model's mesh with point data (displacement fields, mode
//! shapes) as XML unstructured grids (`.vtu`, written with the `vtkio` crate), and a `.pvd`
//! collection that orders them (time samples of one period, or modes).
//!
//! Points carry three coordinates and three displacement components (padded with zeros in
//! 1D and 2D). The cells are the model's (`Model::cells`); a model without them gets one
//! vertex cell per node, so that it still opens.

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

/// The files of a collection in `dir`: `<stem>_0000.vtu …` and `<stem>.pvd`.
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
                CellKind::Hex8 => CellType::Hexahedron,
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

/// Write a collection: each `(value, grid)` to its `.vtu`, then the `.pvd` that lists them
/// with `value` as ParaView's time step.
pub fn write_collection(files: &[PathBuf], pvd: &Path, grids: Vec<(f64, Vec<u8>)>) -> Result<()> {
    let mut text = String::from(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  <Collection>\n",
    );
    for (path, (value, bytes)) in files.iter().zip(grids) {
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
