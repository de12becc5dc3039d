//! Linear-elastic solid elements (docs/theory.md §15, (T100)–(T104), and §21,
//! (T200)–(T205)): bilinear 4-node quadrilaterals and linear or quadratic triangles (Tri3,
//! Tri6) in plane stress or plane strain (2 DOFs per node), trilinear 8-node hexahedra and
//! linear or quadratic tetrahedra (Tet4, Tet10) in 3D (3 DOFs per node), all isoparametric.
//! The stiffness `K = ∫ Bᵀ D B dV` and the consistent mass `M = ∫ ρ Nᵀ N dV` are integrated
//! by full Gauss rules (2×2 and 2×2×2 points) on quadrilaterals and hexahedra, and by
//! symmetric simplex rules exact for the mass of straight-sided simplices
//! ([`crate::fe::simplex`], (T203)–(T204)). The mass is `m ⊗ I_d` exactly (the same scalar
//! matrix for every component), as the mass redistribution requires.
//!
//! The fully integrated bilinear element locks in bending (parasitic shear, (T104)): use
//! several elements through the thickness of a bent member (the parasitic part of the
//! strain energy falls like `1/n²` with `n` elements through the thickness). The linear
//! simplices (constant strain) are stiffer still; the quadratic ones are not (T205).
//!
//! DOF numbering: `node · d + component`.

// index loops mirror the formulas (B, D, J⁻¹) they implement
#![allow(clippy::needless_range_loop)]

use crate::error::{Error, Result};
use crate::fe::mesh::{CellKind, Cells};
use crate::fe::simplex::{linear_shape, quadratic_shape, tetrahedron_rule, triangle_rule};
use crate::sparse::SparseMatrix;

/// Plane stress (thin plates loaded in their plane) or plane strain (long bodies).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlaneKind {
    Stress,
    Strain,
}

/// Isotropic linear-elastic material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ElasticMaterial {
    /// Young's modulus `E > 0`.
    pub young: f64,
    /// Poisson's ratio `ν ∈ (−1, ½)`.
    pub poisson: f64,
    /// Density `ρ > 0`.
    pub density: f64,
}

impl ElasticMaterial {
    /// Refuse a material no element can use, naming the property.
    pub fn validate(&self) -> Result<()> {
        let ElasticMaterial {
            young,
            poisson,
            density,
        } = *self;
        if !(young.is_finite() && young > 0.0) {
            return Err(Error::argument(
                "Young's modulus",
                format!("must be positive, got {young}"),
            ));
        }
        if !(poisson.is_finite() && poisson > -1.0 && poisson < 0.5) {
            return Err(Error::argument(
                "Poisson's ratio",
                format!("must lie in (-1, 0.5), got {poisson}"),
            ));
        }
        if !(density.is_finite() && density > 0.0) {
            return Err(Error::argument(
                "density",
                format!("must be positive, got {density}"),
            ));
        }
        Ok(())
    }

    /// The elasticity matrix `D` (T101): 3×3 (Voigt `ε_xx, ε_yy, γ_xy`) for plane stress or
    /// strain, 6×6 (`ε_xx, ε_yy, ε_zz, γ_yz, γ_xz, γ_xy`) in 3D (`plane = None`).
    pub fn elasticity(&self, plane: Option<PlaneKind>) -> Vec<Vec<f64>> {
        let (e, nu) = (self.young, self.poisson);
        let mu = e / (2.0 * (1.0 + nu));
        match plane {
            Some(PlaneKind::Stress) => {
                let c = e / (1.0 - nu * nu);
                vec![
                    vec![c, c * nu, 0.0],
                    vec![c * nu, c, 0.0],
                    vec![0.0, 0.0, mu],
                ]
            }
            Some(PlaneKind::Strain) => {
                let c = e / ((1.0 + nu) * (1.0 - 2.0 * nu));
                vec![
                    vec![c * (1.0 - nu), c * nu, 0.0],
                    vec![c * nu, c * (1.0 - nu), 0.0],
                    vec![0.0, 0.0, mu],
                ]
            }
            None => {
                let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
                let mut d = vec![vec![0.0; 6]; 6];
                for i in 0..3 {
                    for j in 0..3 {
                        d[i][j] = lambda;
                    }
                    d[i][i] = lambda + 2.0 * mu;
                    d[i + 3][i + 3] = mu;
                }
                d
            }
        }
    }
}

/// Reference coordinates of the nodes of a quadrilateral (counter-clockwise) and of a
/// hexahedron (bottom face counter-clockwise, then the top face), as VTK orders them.
const QUAD_NODES: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
const HEX_NODES: [[f64; 3]; 8] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
];

/// Shape functions `N_a(ξ) = Π_i (1 + ξ_i ξ_i^a)/2^d` and their reference derivatives
/// `∂N_a/∂ξ_i` (T100) at `xi`, for the element whose reference nodes are `nodes`.
fn shape<const D: usize>(nodes: &[[f64; D]], xi: [f64; D]) -> (Vec<f64>, Vec<[f64; D]>) {
    let scale = 0.5f64.powi(D as i32);
    let n = nodes
        .iter()
        .map(|a| scale * (0..D).map(|i| 1.0 + xi[i] * a[i]).product::<f64>())
        .collect();
    let dn = nodes
        .iter()
        .map(|a| {
            let mut g = [0.0; D];
            for (i, gi) in g.iter_mut().enumerate() {
                *gi = scale
                    * a[i]
                    * (0..D)
                        .filter(|&j| j != i)
                        .map(|j| 1.0 + xi[j] * a[j])
                        .product::<f64>();
            }
            g
        })
        .collect();
    (n, dn)
}

/// The 20-node serendipity hexahedron (T211): at a corner `ξ^a ∈ {±1}³`
/// `N_a = ⅛ Π_i (1 + ξ_i ξ_i^a) (Σ_i ξ_i ξ_i^a − 2)`, at the middle of an edge along axis
/// `k` (`ξ_k^a = 0`) `N_a = ¼ (1 − ξ_k²) Π_{i≠k} (1 + ξ_i ξ_i^a)`; nodes in VTK order.
pub fn hex20_shape(xi: [f64; 3]) -> (Vec<f64>, Vec<[f64; 3]>) {
    let mut n = Vec::with_capacity(20);
    let mut dn = Vec::with_capacity(20);
    for a in &HEX_NODES {
        let f: [f64; 3] = std::array::from_fn(|i| 1.0 + xi[i] * a[i]);
        let s = xi[0] * a[0] + xi[1] * a[1] + xi[2] * a[2] - 2.0;
        n.push(0.125 * f[0] * f[1] * f[2] * s);
        dn.push(std::array::from_fn(|i| {
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            0.125 * f[j] * f[k] * a[i] * (s + f[i])
        }));
    }
    for [p, q] in crate::fe::mesh::HEX20_EDGES {
        let (a, b) = (HEX_NODES[p], HEX_NODES[q]);
        let m: [f64; 3] = std::array::from_fn(|i| 0.5 * (a[i] + b[i]));
        let k = (0..3).find(|&i| m[i] == 0.0).unwrap_or(0);
        let f: [f64; 3] = std::array::from_fn(|i| {
            if i == k {
                1.0 - xi[i] * xi[i]
            } else {
                1.0 + xi[i] * m[i]
            }
        });
        n.push(0.25 * f[0] * f[1] * f[2]);
        dn.push(std::array::from_fn(|i| {
            let (j, l) = ((i + 1) % 3, (i + 2) % 3);
            let d = if i == k { -2.0 * xi[i] } else { m[i] };
            0.25 * d * f[j] * f[l]
        }));
    }
    (n, dn)
}

/// Shape functions and reference derivatives at a point of the reference cell.
type ShapeFn<const D: usize> = fn([f64; D]) -> (Vec<f64>, Vec<[f64; D]>);

/// A reference element: its shape functions and its quadrature rule (points, weights).
struct Reference<const D: usize> {
    shape: ShapeFn<D>,
    rule: Vec<([f64; D], f64)>,
}

/// The tensor Gauss rule of 2 points per direction (`ξ = ±1/√3`, weight 1), first
/// coordinate fastest.
fn gauss2<const D: usize>() -> Vec<([f64; D], f64)> {
    let g = 1.0 / 3f64.sqrt();
    (0..(1usize << D))
        .map(|point| {
            let xi = std::array::from_fn(|i| if point >> i & 1 == 1 { g } else { -g });
            (xi, 1.0)
        })
        .collect()
}

/// The tensor Gauss rule of 3 points per direction (`ξ = 0, ±√(3/5)`, weights 8/9, 5/9),
/// exact to degree 5 in each coordinate: Hex20's mass on parallelepipeds (T211).
fn gauss3<const D: usize>() -> Vec<([f64; D], f64)> {
    let g = [
        (-(0.6f64.sqrt()), 5.0 / 9.0),
        (0.0, 8.0 / 9.0),
        (0.6f64.sqrt(), 5.0 / 9.0),
    ];
    (0..3usize.pow(D as u32))
        .map(|point| {
            let at = |i: usize| g[point / 3usize.pow(i as u32) % 3];
            let xi = std::array::from_fn(|i| at(i).0);
            (xi, (0..D).map(|i| at(i).1).product())
        })
        .collect()
}

/// The reference element of a cell kind of dimension `D`, `None` for another dimension.
fn reference<const D: usize>(kind: CellKind) -> Option<Reference<D>> {
    let shape: ShapeFn<D> = match (kind, D) {
        (CellKind::Quad4, 2) | (CellKind::Hex8, 3) => |xi| {
            if D == 2 {
                let (n, dn) = shape(&QUAD_NODES, std::array::from_fn(|i| xi[i]));
                (
                    n,
                    dn.iter().map(|g| std::array::from_fn(|i| g[i])).collect(),
                )
            } else {
                let (n, dn) = shape(&HEX_NODES, std::array::from_fn(|i| xi[i]));
                (
                    n,
                    dn.iter().map(|g| std::array::from_fn(|i| g[i])).collect(),
                )
            }
        },
        (CellKind::Tri3, 2) | (CellKind::Tet4, 3) => linear_shape::<D>,
        (CellKind::Tri6, 2) | (CellKind::Tet10, 3) => quadratic_shape::<D>,
        (CellKind::Hex20, 3) => |xi| {
            let (n, dn) = hex20_shape(std::array::from_fn(|i| xi[i]));
            (
                n,
                dn.iter().map(|g| std::array::from_fn(|i| g[i])).collect(),
            )
        },
        _ => return None,
    };
    // exact for the consistent mass of straight-sided simplices (T203)–(T204)
    let simplex = |degree: usize| -> Vec<([f64; D], f64)> {
        if D == 2 {
            triangle_rule(degree)
                .into_iter()
                .map(|(p, w)| (std::array::from_fn(|i| p[i]), w))
                .collect()
        } else {
            tetrahedron_rule(degree)
                .into_iter()
                .map(|(p, w)| (std::array::from_fn(|i| p[i]), w))
                .collect()
        }
    };
    let rule = match kind {
        CellKind::Quad4 | CellKind::Hex8 => gauss2::<D>(),
        CellKind::Tri3 | CellKind::Tet4 => simplex(2),
        CellKind::Hex20 => gauss3::<D>(),
        _ => simplex(5),
    };
    Some(Reference { shape, rule })
}

/// Element stiffness and mass (`n_nodes·D` square, row-major) of one cell with node
/// coordinates `x` (T102)–(T103), integrated with the reference element's rule;
/// `thickness` multiplies both in 2D.
fn element<const D: usize>(
    reference: &Reference<D>,
    x: &[[f64; D]],
    d: &[Vec<f64>],
    density: f64,
    thickness: f64,
    cell: usize,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let nn = x.len();
    let size = nn * D;
    let nstrain = d.len();
    let mut k = vec![0.0; size * size];
    let mut m = vec![0.0; size * size];
    for &(xi, weight) in &reference.rule {
        let (n, dn) = (reference.shape)(xi);
        // Jacobian J_ij = ∂x_j/∂ξ_i
        let mut jac = [[0.0; D]; D];
        for a in 0..nn {
            for i in 0..D {
                for j in 0..D {
                    jac[i][j] += dn[a][i] * x[a][j];
                }
            }
        }
        let (det, inv) = invert(&jac);
        if !(det > 0.0 && det.is_finite()) {
            return Err(Error::argument(
                "mesh",
                format!("cell {cell} is degenerate or inverted (Jacobian determinant {det:e} at a Gauss point)"),
            ));
        }
        // physical derivatives ∂N_a/∂x_j = Σ_i (J⁻¹)_ji ∂N_a/∂ξ_i
        let dx: Vec<[f64; D]> = dn
            .iter()
            .map(|g| {
                let mut out = [0.0; D];
                for (j, o) in out.iter_mut().enumerate() {
                    *o = (0..D).map(|i| inv[j][i] * g[i]).sum();
                }
                out
            })
            .collect();
        // strain–displacement matrix B (T102)
        let mut b = vec![vec![0.0; size]; nstrain];
        for a in 0..nn {
            let c = a * D;
            if D == 2 {
                b[0][c] = dx[a][0];
                b[1][c + 1] = dx[a][1];
                b[2][c] = dx[a][1];
                b[2][c + 1] = dx[a][0];
            } else {
                b[0][c] = dx[a][0];
                b[1][c + 1] = dx[a][1];
                b[2][c + 2] = dx[a][2];
                b[3][c + 1] = dx[a][2];
                b[3][c + 2] = dx[a][1];
                b[4][c] = dx[a][2];
                b[4][c + 2] = dx[a][0];
                b[5][c] = dx[a][1];
                b[5][c + 1] = dx[a][0];
            }
        }
        let w = det * thickness * weight;
        // K += Bᵀ D B w
        let db: Vec<Vec<f64>> = (0..nstrain)
            .map(|r| {
                (0..size)
                    .map(|c| (0..nstrain).map(|s| d[r][s] * b[s][c]).sum())
                    .collect()
            })
            .collect();
        for p in 0..size {
            for q in 0..size {
                k[p * size + q] += w * (0..nstrain).map(|r| b[r][p] * db[r][q]).sum::<f64>();
            }
        }
        // M += ρ Nᵀ N w, the same for every component (T103)
        for a in 0..nn {
            for c in 0..nn {
                let v = density * w * n[a] * n[c];
                for comp in 0..D {
                    m[(a * D + comp) * size + c * D + comp] += v;
                }
            }
        }
    }
    Ok((k, m))
}

/// Determinant and inverse of a 2×2 or 3×3 matrix.
fn invert<const D: usize>(a: &[[f64; D]; D]) -> (f64, [[f64; D]; D]) {
    let mut inv = [[0.0; D]; D];
    if D == 2 {
        let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
        inv[0][0] = a[1][1] / det;
        inv[0][1] = -a[0][1] / det;
        inv[1][0] = -a[1][0] / det;
        inv[1][1] = a[0][0] / det;
        return (det, inv);
    }
    let c = |i: usize, j: usize| {
        let (r1, r2) = ((i + 1) % 3, (i + 2) % 3);
        let (c1, c2) = ((j + 1) % 3, (j + 2) % 3);
        a[r1][c1] * a[r2][c2] - a[r1][c2] * a[r2][c1]
    };
    let det: f64 = (0..3).map(|j| a[0][j] * c(0, j)).sum();
    for i in 0..3 {
        for j in 0..3 {
            inv[j][i] = c(i, j) / det;
        }
    }
    (det, inv)
}

/// Assemble `(M, K)` of `D`-dimensional cells.
fn assemble<const D: usize>(
    coordinates: &[Vec<f64>],
    cells: &Cells,
    d: &[Vec<f64>],
    density: f64,
    thickness: f64,
) -> Result<(SparseMatrix, SparseMatrix)> {
    let reference = reference::<D>(cells.kind).ok_or_else(|| {
        Error::argument(
            "mesh",
            format!(
                "{:?} cells in a {D}D model (expected {})",
                cells.kind,
                if D == 2 {
                    "Quad4, Tri3 or Tri6"
                } else {
                    "Hex8, Tet4 or Tet10"
                }
            ),
        )
    })?;
    if coordinates.iter().any(|c| c.len() != D) {
        return Err(Error::argument(
            "mesh",
            format!("every node needs {D} coordinates"),
        ));
    }
    let nn = cells.kind.nodes_per_cell();
    let size = nn * D;
    let n = coordinates
        .len()
        .checked_mul(D)
        .ok_or_else(|| Error::argument("mesh", "too many nodes"))?;
    let entries = cells
        .len()
        .checked_mul(size * size)
        .ok_or_else(|| Error::argument("mesh", "too many cells"))?;
    let too_large = || Error::argument("mesh", format!("cannot allocate {entries} matrix entries"));
    let mut kt = Vec::new();
    let mut mt = Vec::new();
    kt.try_reserve_exact(entries).map_err(|_| too_large())?;
    mt.try_reserve_exact(entries).map_err(|_| too_large())?;
    for c in 0..cells.len() {
        let nodes = cells.cell(c);
        if let Some(&bad) = nodes.iter().find(|&&p| p >= coordinates.len()) {
            return Err(Error::argument(
                "mesh",
                format!(
                    "cell {c} refers to node {bad}, the mesh has {} nodes",
                    coordinates.len()
                ),
            ));
        }
        let x: Vec<[f64; D]> = nodes
            .iter()
            .map(|&p| std::array::from_fn(|i| coordinates[p][i]))
            .collect();
        let (ke, me) = element::<D>(&reference, &x, d, density, thickness, c)?;
        for a in 0..size {
            for b in 0..size {
                let (ga, gb) = (nodes[a / D] * D + a % D, nodes[b / D] * D + b % D);
                kt.push((ga, gb, ke[a * size + b]));
                let v = me[a * size + b];
                if v != 0.0 {
                    mt.push((ga, gb, v));
                }
            }
        }
    }
    Ok((
        SparseMatrix::try_from_triplets(n, n, &mt)?,
        SparseMatrix::try_from_triplets(n, n, &kt)?,
    ))
}

/// Consistent mass and stiffness `(M, K)` of a plane mesh of 4-node quadrilaterals or of
/// 3- or 6-node triangles (2 DOFs per node), plane stress or plane strain, uniform
/// `thickness` (T100)–(T103), (T200)–(T204).
pub fn assemble_plane(
    coordinates: &[Vec<f64>],
    cells: &Cells,
    material: &ElasticMaterial,
    thickness: f64,
    plane: PlaneKind,
) -> Result<(SparseMatrix, SparseMatrix)> {
    material.validate()?;
    if !(thickness.is_finite() && thickness > 0.0) {
        return Err(Error::argument(
            "thickness",
            format!("must be positive, got {thickness}"),
        ));
    }
    assemble::<2>(
        coordinates,
        cells,
        &material.elasticity(Some(plane)),
        material.density,
        thickness,
    )
}

/// Consistent mass and stiffness `(M, K)` of a mesh of 8-node hexahedra or of 4- or
/// 10-node tetrahedra (3 DOFs per node) (T100)–(T103), (T200)–(T204).
pub fn assemble_solid(
    coordinates: &[Vec<f64>],
    cells: &Cells,
    material: &ElasticMaterial,
) -> Result<(SparseMatrix, SparseMatrix)> {
    material.validate()?;
    assemble::<3>(
        coordinates,
        cells,
        &material.elasticity(None),
        material.density,
        1.0,
    )
}
