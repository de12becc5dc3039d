//! Mesh topology kept beside a model's matrices: the cells (for output, e.g. VTK files
//! that ParaView reads) and named node sets (faces, edges, crack lips) that boundary
//! conditions, loads and contact interfaces refer to.

use std::collections::BTreeMap;

/// Kind of the cells of a mesh (node order as in VTK: counter-clockwise for the
/// quadrilateral; bottom face counter-clockwise then top face for the hexahedron).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CellKind {
    /// Two-node line (bars).
    Line2,
    /// Four-node quadrilateral (2D solids).
    Quad4,
    /// Eight-node hexahedron (3D solids).
    Hex8,
}

impl CellKind {
    /// Number of nodes of one cell.
    pub fn nodes_per_cell(self) -> usize {
        match self {
            CellKind::Line2 => 2,
            CellKind::Quad4 => 4,
            CellKind::Hex8 => 8,
        }
    }
}

/// The cells of a mesh: `connectivity[c * nodes_per_cell + a]` is node `a` of cell `c`.
#[derive(Clone, Debug, PartialEq)]
pub struct Cells {
    pub kind: CellKind,
    pub connectivity: Vec<usize>,
}

impl Cells {
    /// Number of cells.
    pub fn len(&self) -> usize {
        self.connectivity.len() / self.kind.nodes_per_cell()
    }

    /// No cells.
    pub fn is_empty(&self) -> bool {
        self.connectivity.is_empty()
    }

    /// The nodes of cell `c`.
    pub fn cell(&self, c: usize) -> &[usize] {
        let k = self.kind.nodes_per_cell();
        &self.connectivity[c * k..(c + 1) * k]
    }
}

/// Named sets of nodes (node numbers from 0), e.g. the faces `x0`, `x1`, `y0`, … of a
/// structured mesh, in a documented order along the set.
pub type NodeSets = BTreeMap<String, Vec<usize>>;
