//! Structured meshes of rectangles (4-node quadrilaterals) and boxes (8-node hexahedra)
//! with named faces, and a transverse crack in a rectangle (docs/theory.md §15, (T105)).
//!
//! Nodes are numbered lexicographically, x fastest: node `(i, j)` of a rectangle is
//! `j (n_x + 1) + i`, node `(i, j, k)` of a box is `(k (n_y + 1) + j)(n_x + 1) + i`. The faces
//! `x0`, `x1`, `y0`, `y1` (and `z0`, `z1`) hold the nodes on `x = 0`, `x = L_x`, …, in
//! increasing node number (so along a rectangle's edge by increasing coordinate).

use crate::error::{Error, Result};
use crate::fe::mesh::{CellKind, Cells, NodeSets};

/// A structured mesh: node coordinates, cells and named node sets.
#[derive(Clone, Debug)]
pub struct StructuredMesh {
    pub coordinates: Vec<Vec<f64>>,
    pub cells: Cells,
    pub node_sets: NodeSets,
}

/// A transverse crack of a rectangle along the mesh line `x = x`, from `y = from` to
/// `y = to` (both on mesh lines). The nodes of the crack's lips are doubled: the cells left
/// of the line keep the original nodes (node set `crack_a`), those right of it use the
/// copies (`crack_b`, in the same order, so `crack_a[i]` and `crack_b[i]` coincide). The
/// crack tip (an end inside the rectangle) is not doubled; an end on the edge `y = 0` or
/// `y = L_y` is (an edge crack).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crack2d {
    pub x: f64,
    pub from: f64,
    pub to: f64,
}

fn check(size: &[f64], divisions: &[usize]) -> Result<usize> {
    for (a, (&l, &n)) in size.iter().zip(divisions).enumerate() {
        let axis = ["x", "y", "z"][a];
        if !(l.is_finite() && l > 0.0) {
            return Err(Error::argument(
                "mesh size",
                format!("the length along {axis} must be positive, got {l}"),
            ));
        }
        if n == 0 {
            return Err(Error::argument(
                "mesh divisions",
                format!("the number of elements along {axis} must be at least 1"),
            ));
        }
    }
    divisions
        .iter()
        .try_fold(1usize, |p, &n| p.checked_mul(n.checked_add(1)?))
        .filter(|&nodes| nodes <= 1 << 40)
        .ok_or_else(|| {
            Error::argument(
                "mesh divisions",
                format!("{divisions:?} gives too many nodes"),
            )
        })
}

/// Index of the mesh line at coordinate `v` of an axis of `n` divisions over `[0, l]`.
fn mesh_line(v: f64, l: f64, n: usize, what: &str) -> Result<usize> {
    let s = v / l * n as f64;
    let i = s.round();
    if !(v.is_finite() && (s - i).abs() <= 1e-9 * n as f64 && i >= 0.0 && i <= n as f64) {
        return Err(Error::argument(
            "crack",
            format!(
                "{what} = {v} is not on a mesh line (lines every {})",
                l / n as f64
            ),
        ));
    }
    Ok(i as usize)
}

/// The rectangle `[0, L_x] × [0, L_y]` in `n_x × n_y` quadrilaterals, optionally cracked.
pub fn rectangle(
    size: [f64; 2],
    divisions: [usize; 2],
    crack: Option<&Crack2d>,
) -> Result<StructuredMesh> {
    let nodes = check(&size, &divisions)?;
    let [nx, ny] = divisions;
    let node = |i: usize, j: usize| j * (nx + 1) + i;
    let mut coordinates = Vec::new();
    coordinates
        .try_reserve_exact(nodes)
        .map_err(|_| Error::argument("mesh divisions", "cannot allocate the nodes"))?;
    for j in 0..=ny {
        for i in 0..=nx {
            coordinates.push(vec![
                size[0] * i as f64 / nx as f64,
                size[1] * j as f64 / ny as f64,
            ]);
        }
    }
    let mut connectivity = Vec::with_capacity(4 * nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            connectivity.extend([
                node(i, j),
                node(i + 1, j),
                node(i + 1, j + 1),
                node(i, j + 1),
            ]);
        }
    }
    let mut node_sets = NodeSets::new();
    node_sets.insert("x0".into(), (0..=ny).map(|j| node(0, j)).collect());
    node_sets.insert("x1".into(), (0..=ny).map(|j| node(nx, j)).collect());
    node_sets.insert("y0".into(), (0..=nx).map(|i| node(i, 0)).collect());
    node_sets.insert("y1".into(), (0..=nx).map(|i| node(i, ny)).collect());
    if let Some(c) = crack {
        let ic = mesh_line(c.x, size[0], nx, "crack.x")?;
        let (j0, j1) = (
            mesh_line(c.from, size[1], ny, "crack.from")?,
            mesh_line(c.to, size[1], ny, "crack.to")?,
        );
        if ic == 0 || ic == nx {
            return Err(Error::argument(
                "crack",
                format!(
                    "crack.x = {} lies on the boundary; a crack must cut the interior",
                    c.x
                ),
            ));
        }
        if j0 >= j1 {
            return Err(Error::argument(
                "crack",
                format!("crack.from = {} must be below crack.to = {}", c.from, c.to),
            ));
        }
        // doubled nodes: the open segment, plus an end on the edge of the rectangle
        let first = if j0 == 0 { 0 } else { j0 + 1 };
        let last = if j1 == ny { ny } else { j1 - 1 };
        if first > last {
            return Err(Error::argument(
                "crack",
                "the crack spans one element between two interior lines and has no node to split; make it longer or refine the mesh",
            ));
        }
        let mut lip_a = Vec::new();
        let mut lip_b = Vec::new();
        for j in first..=last {
            let original = node(ic, j);
            let copy = coordinates.len();
            coordinates.push(coordinates[original].clone());
            lip_a.push(original);
            lip_b.push(copy);
            // cells right of the line (cell column ic) use the copy
            for jc in j.saturating_sub(1)..=j.min(ny - 1) {
                let cell = jc * nx + ic;
                for p in &mut connectivity[4 * cell..4 * cell + 4] {
                    if *p == original {
                        *p = copy;
                    }
                }
            }
        }
        // the copies on the edges y0 / y1 belong to those faces too
        for (face, j) in [("y0", 0), ("y1", ny)] {
            if let Some(k) = (first..=last).position(|jj| jj == j) {
                node_sets.get_mut(face).expect("face").push(lip_b[k]);
            }
        }
        node_sets.insert("crack_a".into(), lip_a);
        node_sets.insert("crack_b".into(), lip_b);
    }
    Ok(StructuredMesh {
        coordinates,
        cells: Cells {
            kind: CellKind::Quad4,
            connectivity,
        },
        node_sets,
    })
}

/// The box `[0, L_x] × [0, L_y] × [0, L_z]` in `n_x × n_y × n_z` hexahedra.
pub fn cuboid(size: [f64; 3], divisions: [usize; 3]) -> Result<StructuredMesh> {
    let nodes = check(&size, &divisions)?;
    let [nx, ny, nz] = divisions;
    let node = |i: usize, j: usize, k: usize| (k * (ny + 1) + j) * (nx + 1) + i;
    let mut coordinates = Vec::new();
    coordinates
        .try_reserve_exact(nodes)
        .map_err(|_| Error::argument("mesh divisions", "cannot allocate the nodes"))?;
    for k in 0..=nz {
        for j in 0..=ny {
            for i in 0..=nx {
                coordinates.push(vec![
                    size[0] * i as f64 / nx as f64,
                    size[1] * j as f64 / ny as f64,
                    size[2] * k as f64 / nz as f64,
                ]);
            }
        }
    }
    let mut connectivity = Vec::with_capacity(8 * nx * ny * nz);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                connectivity.extend([
                    node(i, j, k),
                    node(i + 1, j, k),
                    node(i + 1, j + 1, k),
                    node(i, j + 1, k),
                    node(i, j, k + 1),
                    node(i + 1, j, k + 1),
                    node(i + 1, j + 1, k + 1),
                    node(i, j + 1, k + 1),
                ]);
            }
        }
    }
    let all: Vec<(usize, usize, usize)> = (0..=nz)
        .flat_map(|k| (0..=ny).flat_map(move |j| (0..=nx).map(move |i| (i, j, k))))
        .collect();
    let face = |keep: &dyn Fn(usize, usize, usize) -> bool| -> Vec<usize> {
        all.iter()
            .filter(|&&(i, j, k)| keep(i, j, k))
            .map(|&(i, j, k)| node(i, j, k))
            .collect()
    };
    let mut node_sets = NodeSets::new();
    node_sets.insert("x0".into(), face(&|i, _, _| i == 0));
    node_sets.insert("x1".into(), face(&|i, _, _| i == nx));
    node_sets.insert("y0".into(), face(&|_, j, _| j == 0));
    node_sets.insert("y1".into(), face(&|_, j, _| j == ny));
    node_sets.insert("z0".into(), face(&|_, _, k| k == 0));
    node_sets.insert("z1".into(), face(&|_, _, k| k == nz));
    Ok(StructuredMesh {
        coordinates,
        cells: Cells {
            kind: CellKind::Hex8,
            connectivity,
        },
        node_sets,
    })
}

/// Weights of the nodes of `nodes` (a face of the mesh) for a uniform traction with unit
/// resultant (T106): each node gets the integral of its shape function over the face divided
/// by the face's area. The face's cells are the cells' edges (2D) or faces (3D) whose nodes
/// all lie in the set.
pub fn face_weights(mesh: &StructuredMesh, nodes: &[usize]) -> Result<Vec<f64>> {
    mesh_face_weights(&mesh.coordinates, &mesh.cells, nodes)
}

/// [`face_weights`] of any mesh (straight-sided faces; for the simplices (T206)).
pub fn mesh_face_weights(x: &[Vec<f64>], cells: &Cells, nodes: &[usize]) -> Result<Vec<f64>> {
    let index: std::collections::HashMap<usize, usize> =
        nodes.iter().enumerate().map(|(k, &p)| (p, k)).collect();
    // the integral of each node's shape function over a face, as a share of its measure
    let shares: &[f64] = match cells.kind {
        CellKind::Line2 => &[1.0],
        CellKind::Quad4 | CellKind::Tri3 => &[0.5, 0.5],
        CellKind::Hex8 => &[0.25; 4],
        CellKind::Tet4 => &[1.0 / 3.0; 3],
        CellKind::Tri6 => &[1.0 / 6.0, 1.0 / 6.0, 2.0 / 3.0],
        CellKind::Tet10 => &[0.0, 0.0, 0.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
        // the 8-node serendipity face (T212)
        CellKind::Hex20 => &[
            -1.0 / 12.0,
            -1.0 / 12.0,
            -1.0 / 12.0,
            -1.0 / 12.0,
            1.0 / 3.0,
            1.0 / 3.0,
            1.0 / 3.0,
            1.0 / 3.0,
        ],
    };
    let mut weights = vec![0.0; nodes.len()];
    for c in 0..cells.len() {
        let cell = cells.cell(c);
        for f in cells.kind.faces() {
            let face: Vec<usize> = f.iter().map(|&a| cell[a]).collect();
            if !face.iter().all(|p| index.contains_key(p)) {
                continue;
            }
            // the measure of a (flat) face: length of an edge, area of a parallelogram
            // (structured hexahedra) or of a triangle
            let measure = match cells.kind {
                CellKind::Line2 => 1.0,
                CellKind::Quad4 | CellKind::Tri3 | CellKind::Tri6 => dist(&x[face[0]], &x[face[1]]),
                CellKind::Hex8 => dist(&x[face[0]], &x[face[1]]) * dist(&x[face[1]], &x[face[2]]),
                // a flat quadrilateral: half the cross product of its diagonals
                CellKind::Hex20 => {
                    let u: Vec<f64> = (0..3).map(|a| x[face[2]][a] - x[face[0]][a]).collect();
                    let v: Vec<f64> = (0..3).map(|a| x[face[3]][a] - x[face[1]][a]).collect();
                    0.5 * norm(&cross(&u, &v))
                }
                CellKind::Tet4 | CellKind::Tet10 => {
                    let u: Vec<f64> = (0..3).map(|a| x[face[1]][a] - x[face[0]][a]).collect();
                    let v: Vec<f64> = (0..3).map(|a| x[face[2]][a] - x[face[0]][a]).collect();
                    let n = [
                        u[1] * v[2] - u[2] * v[1],
                        u[2] * v[0] - u[0] * v[2],
                        u[0] * v[1] - u[1] * v[0],
                    ];
                    0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
                }
            };
            for (p, share) in face.iter().zip(shares) {
                weights[index[p]] += measure * share;
            }
        }
    }
    let total: f64 = weights.iter().sum();
    if total <= 0.0 || total.is_nan() {
        return Err(Error::argument(
            "load",
            "the node set holds no face of a cell; distribute the load uniformly instead",
        ));
    }
    Ok(weights.iter().map(|w| w / total).collect())
}

fn cross(u: &[f64], v: &[f64]) -> [f64; 3] {
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

fn norm(n: &[f64]) -> f64 {
    n.iter().map(|a| a * a).sum::<f64>().sqrt()
}

fn dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| (p - q) * (p - q))
        .sum::<f64>()
        .sqrt()
}

/// The simplex mesh of a structured one, on the same nodes and node sets (T207): each
/// quadrilateral cut along its diagonal from node 0 to node 2 into two triangles, each
/// hexahedron into the six tetrahedra around its diagonal from node 0 to node 6 (Kuhn's
/// subdivision, conforming between neighbouring boxes), every cell positively oriented.
pub fn simplices(mesh: &StructuredMesh) -> Result<StructuredMesh> {
    let (kind, pieces): (CellKind, &[&[usize]]) = match mesh.cells.kind {
        CellKind::Quad4 => (CellKind::Tri3, &[&[0, 1, 2], &[0, 2, 3]]),
        // the paths 0 → 6 along edges of the box, one per order of the three axes (local
        // nodes in VTK order: 1 = +x, 3 = +y, 4 = +z from node 0)
        CellKind::Hex8 => (
            CellKind::Tet4,
            &[
                &[0, 1, 2, 6],
                &[0, 1, 5, 6],
                &[0, 3, 2, 6],
                &[0, 3, 7, 6],
                &[0, 4, 5, 6],
                &[0, 4, 7, 6],
            ],
        ),
        other => {
            return Err(Error::argument(
                "mesh",
                format!("only Quad4 and Hex8 meshes are split into simplices, got {other:?}"),
            ))
        }
    };
    let x = &mesh.coordinates;
    let mut connectivity = Vec::with_capacity(mesh.cells.len() * pieces.len() * (pieces[0].len()));
    for c in 0..mesh.cells.len() {
        let cell = mesh.cells.cell(c);
        for piece in pieces {
            let mut nodes: Vec<usize> = piece.iter().map(|&a| cell[a]).collect();
            // orientation: the sign of det[x_1 − x_0, …, x_d − x_0]
            let e: Vec<Vec<f64>> = nodes[1..]
                .iter()
                .map(|&p| x[p].iter().zip(&x[nodes[0]]).map(|(a, b)| a - b).collect())
                .collect();
            let det = if e.len() == 2 {
                e[0][0] * e[1][1] - e[0][1] * e[1][0]
            } else {
                e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1])
                    - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0])
                    + e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0])
            };
            if det < 0.0 {
                nodes.swap(1, 2);
            }
            connectivity.extend(nodes);
        }
    }
    Ok(StructuredMesh {
        coordinates: mesh.coordinates.clone(),
        cells: Cells { kind, connectivity },
        node_sets: mesh.node_sets.clone(),
    })
}
