//! Simplex elements for [`crate::fe::solid`] (docs/theory.md §21, (T200)–(T204)): the
//! shape functions of the linear and quadratic triangle (Tri3, Tri6) and tetrahedron (Tet4,
//! Tet10) on the reference simplex, the symmetric quadrature rules that integrate their
//! consistent mass exactly on straight-sided cells, and the quadratic mesh of a linear one
//! (a node added at the middle of every edge).
//!
//! Reference simplex: vertices `0, e_1, …, e_d`; barycentric coordinates
//! `λ_0 = 1 − Σ ξ_i`, `λ_i = ξ_i` (T200). Node order as VTK (and [`CellKind`]).

use std::collections::HashMap;

use crate::error::{Error, Result};
use crate::fe::mesh::{CellKind, Cells, HEX20_EDGES};

/// The edges of the quadratic triangle and tetrahedron whose mid-side nodes follow the
/// vertices, in VTK order (T200).
pub const TRIANGLE_EDGES: [[usize; 2]; 3] = [[0, 1], [1, 2], [2, 0]];
pub const TETRAHEDRON_EDGES: [[usize; 2]; 6] = [[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]];

/// Barycentric coordinates of `xi` and their (constant) reference gradients.
fn barycentric<const D: usize>(xi: [f64; D]) -> (Vec<f64>, Vec<[f64; D]>) {
    let mut l = vec![1.0 - xi.iter().sum::<f64>()];
    l.extend(xi);
    let mut g = vec![[-1.0; D]];
    for i in 0..D {
        let mut e = [0.0; D];
        e[i] = 1.0;
        g.push(e);
    }
    (l, g)
}

/// Linear simplex (Tri3, Tet4): `N_a = λ_a` (T201).
pub fn linear_shape<const D: usize>(xi: [f64; D]) -> (Vec<f64>, Vec<[f64; D]>) {
    barycentric(xi)
}

/// Quadratic simplex (Tri6, Tet10): `N_a = λ_a (2λ_a − 1)` at the vertices,
/// `N_ab = 4 λ_a λ_b` at the middle of edge `ab` (T202).
pub fn quadratic_shape<const D: usize>(xi: [f64; D]) -> (Vec<f64>, Vec<[f64; D]>) {
    let (l, g) = barycentric(xi);
    let edges: &[[usize; 2]] = if D == 2 {
        &TRIANGLE_EDGES
    } else {
        &TETRAHEDRON_EDGES
    };
    let mut n = Vec::with_capacity(D + 1 + edges.len());
    let mut dn = Vec::with_capacity(n.capacity());
    for a in 0..=D {
        n.push(l[a] * (2.0 * l[a] - 1.0));
        dn.push(std::array::from_fn(|i| (4.0 * l[a] - 1.0) * g[a][i]));
    }
    for &[a, b] in edges {
        n.push(4.0 * l[a] * l[b]);
        dn.push(std::array::from_fn(|i| {
            4.0 * (l[b] * g[a][i] + l[a] * g[b][i])
        }));
    }
    (n, dn)
}

/// Points of a symmetric rule: the orbit of the barycentric point `(a, …, a, b, …)` under
/// permutation of the `D + 1` barycentric coordinates, as reference points `ξ = (λ_1, …)`.
fn orbit<const D: usize>(lambda: &[f64], weight: f64, out: &mut Vec<([f64; D], f64)>) {
    let mut seen: Vec<Vec<u64>> = Vec::new();
    let k = lambda.len();
    // every permutation of the k barycentric values (k ≤ 4: at most 24)
    let mut perm: Vec<usize> = (0..k).collect();
    loop {
        let p: Vec<f64> = perm.iter().map(|&i| lambda[i]).collect();
        let key: Vec<u64> = p.iter().map(|v| v.to_bits()).collect();
        if !seen.contains(&key) {
            seen.push(key);
            out.push((std::array::from_fn(|i| p[i + 1]), weight));
        }
        // next permutation in lexicographic order
        let Some(i) = (0..k - 1).rev().find(|&i| perm[i] < perm[i + 1]) else {
            break;
        };
        let j = (i + 1..k)
            .rev()
            .find(|&j| perm[j] > perm[i])
            .expect("exists");
        perm.swap(i, j);
        perm[i + 1..].reverse();
    }
}

/// Triangle rules (T203): degree 2 (3 points at `(2/3, 1/6, 1/6)`, Tri3's mass), degree 4
/// (Dunavant's 6 points, Tri6's mass). Weights sum to the reference area ½.
pub fn triangle_rule(degree: usize) -> Vec<([f64; 2], f64)> {
    let mut out = Vec::new();
    if degree <= 2 {
        orbit(&[2.0 / 3.0, 1.0 / 6.0, 1.0 / 6.0], 1.0 / 6.0, &mut out);
    } else {
        let (a, wa) = (0.445_948_490_915_964_9, 0.223_381_589_678_011_47 / 2.0);
        let (b, wb) = (0.091_576_213_509_770_74, 0.109_951_743_655_321_87 / 2.0);
        orbit(&[1.0 - 2.0 * a, a, a], wa, &mut out);
        orbit(&[1.0 - 2.0 * b, b, b], wb, &mut out);
    }
    out
}

/// Tetrahedron rules (T204): degree 2 (4 points at `λ = (5 + 3√5)/20, (5 − √5)/20, …`,
/// Tet4's mass), degree 5 (14 points with positive weights, Tet10's mass). Weights sum
/// to the reference volume ⅙.
pub fn tetrahedron_rule(degree: usize) -> Vec<([f64; 3], f64)> {
    let mut out = Vec::new();
    if degree <= 2 {
        let s5 = 5f64.sqrt();
        let (a, b) = ((5.0 - s5) / 20.0, (5.0 + 3.0 * s5) / 20.0);
        orbit(&[b, a, a, a], 1.0 / 24.0, &mut out);
    } else {
        let (a1, w1) = (0.092_735_250_310_891_22, 0.012_248_840_519_393_658);
        let (a2, w2) = (0.310_885_919_263_300_6, 0.018_781_320_953_002_642);
        let (a3, w3) = (0.454_496_295_874_350_35, 0.007_091_003_462_846_911);
        orbit(&[1.0 - 3.0 * a1, a1, a1, a1], w1, &mut out);
        orbit(&[1.0 - 3.0 * a2, a2, a2, a2], w2, &mut out);
        orbit(&[a3, a3, 0.5 - a3, 0.5 - a3], w3, &mut out);
    }
    out
}

/// The quadratic mesh (Tri6, Tet10 or Hex20) of a linear one (Tri3, Tet4 or Hex8): one new
/// node at the middle of every edge, shared by the cells around it, numbered after the
/// existing nodes in the order the edges are met. Straight-sided cells, so the geometry is
/// unchanged.
pub fn quadratic_mesh(coordinates: &[Vec<f64>], cells: &Cells) -> Result<(Vec<Vec<f64>>, Cells)> {
    let (edges, kind): (&[[usize; 2]], CellKind) = match cells.kind {
        CellKind::Tri3 => (&TRIANGLE_EDGES, CellKind::Tri6),
        CellKind::Tet4 => (&TETRAHEDRON_EDGES, CellKind::Tet10),
        CellKind::Hex8 => (&HEX20_EDGES, CellKind::Hex20),
        other => {
            return Err(Error::argument(
                "mesh",
                format!("only Tri3, Tet4 and Hex8 meshes can be made quadratic, got {other:?}"),
            ))
        }
    };
    let mut coordinates = coordinates.to_vec();
    let mut middle: HashMap<(usize, usize), usize> = HashMap::new();
    let mut connectivity = Vec::with_capacity(cells.len() * kind.nodes_per_cell());
    for c in 0..cells.len() {
        let v = cells.cell(c);
        if let Some(&bad) = v.iter().find(|&&p| p >= coordinates.len()) {
            return Err(Error::argument(
                "mesh",
                format!("cell {c} refers to node {bad}, which does not exist"),
            ));
        }
        connectivity.extend_from_slice(v);
        for &[a, b] in edges {
            let key = (v[a].min(v[b]), v[a].max(v[b]));
            let next = coordinates.len();
            let m = *middle.entry(key).or_insert(next);
            if m == next {
                let x = coordinates[v[a]]
                    .iter()
                    .zip(&coordinates[v[b]])
                    .map(|(p, q)| 0.5 * (p + q))
                    .collect();
                coordinates.push(x);
            }
            connectivity.push(m);
        }
    }
    Ok((coordinates, Cells { kind, connectivity }))
}
