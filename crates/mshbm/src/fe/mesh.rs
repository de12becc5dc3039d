//! Mesh topology kept beside a model's matrices: the cells (for output, e.g. VTK files
//! that ParaView reads) and named node sets (faces, edges, crack lips) that boundary
//! conditions, loads and contact interfaces refer to.

use std::collections::BTreeMap;

/// Kind of the cells of a mesh (node order as in VTK: counter-clockwise for the
/// quadrilateral and the triangles; bottom face counter-clockwise then top face for the
/// hexahedron; vertices, then the mid-side nodes of the edges 01, 12, 20 (triangle) or 01,
/// 12, 20, 03, 13, 23 (tetrahedron) for the quadratic simplices, docs/theory.md (T200); the
/// 20-node hexahedron's corners as Hex8, then the mid-side nodes of the edges 01, 12, 23,
/// 30, 45, 56, 67, 74, 04, 15, 26, 37, (T211)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CellKind {
    /// Two-node line (bars).
    Line2,
    /// Four-node quadrilateral (2D solids).
    Quad4,
    /// Eight-node hexahedron (3D solids).
    Hex8,
    /// Three-node triangle (2D solids, linear).
    Tri3,
    /// Six-node triangle (2D solids, quadratic).
    Tri6,
    /// Four-node tetrahedron (3D solids, linear).
    Tet4,
    /// Ten-node tetrahedron (3D solids, quadratic).
    Tet10,
    /// Twenty-node (serendipity) hexahedron (3D solids, quadratic).
    Hex20,
}

impl CellKind {
    /// Number of nodes of one cell.
    pub fn nodes_per_cell(self) -> usize {
        match self {
            CellKind::Line2 => 2,
            CellKind::Quad4 => 4,
            CellKind::Hex8 => 8,
            CellKind::Tri3 => 3,
            CellKind::Tri6 => 6,
            CellKind::Tet4 => 4,
            CellKind::Tet10 => 10,
            CellKind::Hex20 => 20,
        }
    }

    /// Dimension of the cell (1, 2 or 3).
    pub fn dimension(self) -> usize {
        match self {
            CellKind::Line2 => 1,
            CellKind::Quad4 | CellKind::Tri3 | CellKind::Tri6 => 2,
            CellKind::Hex8 | CellKind::Tet4 | CellKind::Tet10 | CellKind::Hex20 => 3,
        }
    }

    /// The faces of a cell (edges in 2D), as local node numbers: corner nodes first, then
    /// the mid-side nodes of a quadratic face, so that a face of a cell is the faces of the
    /// mesh's boundary it lies on.
    pub fn faces(self) -> &'static [&'static [usize]] {
        match self {
            CellKind::Line2 => &[&[0], &[1]],
            CellKind::Quad4 => &[&[0, 1], &[1, 2], &[2, 3], &[3, 0]],
            CellKind::Hex8 => &[
                &[0, 1, 2, 3],
                &[4, 5, 6, 7],
                &[0, 1, 5, 4],
                &[1, 2, 6, 5],
                &[2, 3, 7, 6],
                &[3, 0, 4, 7],
            ],
            CellKind::Tri3 => &[&[0, 1], &[1, 2], &[2, 0]],
            CellKind::Tri6 => &[&[0, 1, 3], &[1, 2, 4], &[2, 0, 5]],
            CellKind::Tet4 => &[&[0, 2, 1], &[0, 1, 3], &[1, 2, 3], &[0, 3, 2]],
            CellKind::Tet10 => &[
                &[0, 2, 1, 6, 5, 4],
                &[0, 1, 3, 4, 8, 7],
                &[1, 2, 3, 5, 9, 8],
                &[0, 3, 2, 7, 9, 6],
            ],
            CellKind::Hex20 => &[
                &[0, 1, 2, 3, 8, 9, 10, 11],
                &[4, 5, 6, 7, 12, 13, 14, 15],
                &[0, 1, 5, 4, 8, 17, 12, 16],
                &[1, 2, 6, 5, 9, 18, 13, 17],
                &[2, 3, 7, 6, 10, 19, 14, 18],
                &[3, 0, 4, 7, 11, 16, 15, 19],
            ],
        }
    }
}

/// The edges of the hexahedron whose mid-side nodes follow the corners of a Hex20, in VTK
/// order (T211).
pub const HEX20_EDGES: [[usize; 2]; 12] = [
    [0, 1],
    [1, 2],
    [2, 3],
    [3, 0],
    [4, 5],
    [5, 6],
    [6, 7],
    [7, 4],
    [0, 4],
    [1, 5],
    [2, 6],
    [3, 7],
];

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
