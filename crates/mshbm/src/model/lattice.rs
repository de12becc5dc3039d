//! A planar spring lattice with a unilateral contact under every bottom node: a general
//! (non-bar) model with many contact DOFs, built in code. The integration tests use it for
//! multi-contact checks, the benchmarks for the scaling of the methods with the number of
//! contact DOFs (`benches/scaling.rs`).

use std::path::PathBuf;

use crate::model::{Contact, Damping, Model};
use crate::sparse::SparseMatrix;

/// A planar lattice of `nx × ny` cells (unit spacing, 2 DOFs per node: x, y) with axial
/// springs along edges and diagonals, consistent bilinear mass (`m ⊗ I₂`), the top row
/// clamped, and a unilateral contact under every bottom node (`g = g0_i + u_y`, support
/// below), with gaps that differ so that some contacts close and others do not. A
/// harmonic downward force acts on the top-interior middle node.
pub fn lattice_model(nx: usize, ny: usize, force: f64, damping_alpha: f64) -> Model {
    let nodes_x = nx + 1;
    let n_nodes = (nx + 1) * (ny + 1);
    let idx = |i: usize, j: usize| j * nodes_x + i;
    let coords: Vec<Vec<f64>> = (0..n_nodes)
        .map(|p| vec![(p % nodes_x) as f64, (p / nodes_x) as f64])
        .collect();
    let mut kt = Vec::new();
    let mut spring = |p: usize, q: usize, k: f64| {
        let dx = coords[q][0] - coords[p][0];
        let dy = coords[q][1] - coords[p][1];
        let l = (dx * dx + dy * dy).sqrt();
        let e = [dx / l, dy / l];
        for a in 0..2 {
            for b in 0..2 {
                let v = k / l * e[a] * e[b];
                kt.push((2 * p + a, 2 * p + b, v));
                kt.push((2 * q + a, 2 * q + b, v));
                kt.push((2 * p + a, 2 * q + b, -v));
                kt.push((2 * q + a, 2 * p + b, -v));
            }
        }
    };
    let mut mt = Vec::new();
    let base = [
        [4.0, 2.0, 1.0, 2.0],
        [2.0, 4.0, 2.0, 1.0],
        [1.0, 2.0, 4.0, 2.0],
        [2.0, 1.0, 2.0, 4.0],
    ];
    for j in 0..ny {
        for i in 0..nx {
            let c = [idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)];
            spring(c[0], c[1], 100.0);
            spring(c[0], c[3], 100.0);
            spring(c[0], c[2], 50.0);
            spring(c[1], c[3], 50.0);
            for a in 0..4 {
                for b in 0..4 {
                    for comp in 0..2 {
                        mt.push((2 * c[a] + comp, 2 * c[b] + comp, base[a][b] / 36.0 * 1e-3));
                    }
                }
            }
        }
    }
    for i in 0..nx {
        spring(idx(i, ny), idx(i + 1, ny), 100.0);
    }
    for j in 0..ny {
        spring(idx(nx, j), idx(nx, j + 1), 100.0);
    }
    let n = 2 * n_nodes;
    let stiffness = SparseMatrix::from_triplets(n, n, &kt);
    let mass = SparseMatrix::from_triplets(n, n, &mt);
    let dirichlet: Vec<usize> = (0..nodes_x)
        .flat_map(|i| [2 * idx(i, ny), 2 * idx(i, ny) + 1])
        .collect();
    let contacts = (0..nodes_x)
        .map(|i| Contact {
            dofs: vec![2 * idx(i, 0) + 1],
            w: vec![1.0],
            gap: 0.02 * (1.0 + 0.6 * (i as f64 * 1.3).sin().abs()) + 0.01 * i as f64 / nx as f64,
            friction: None,
        })
        .collect();
    let mut harmonic_load = vec![0.0; n];
    harmonic_load[2 * idx(nx / 2, ny - 1) + 1] = -force;
    Model {
        stiffness_file: None,
        source: PathBuf::from("lattice model (built in code)"),
        input_files: vec![],
        cells: None,
        node_sets: Default::default(),
        node_labels: None,
        interfaces: vec![],
        name: "planar lattice with bottom contacts".into(),
        mass,
        stiffness,
        damping_matrix: None,
        coordinates: coords,
        dofs_per_node: 2,
        dirichlet,
        contacts,
        harmonic_load,
        constant_load: vec![0.0; n],
        frictions: vec![],
        acceleration: None,
        damping: Damping {
            alpha: damping_alpha,
            ..Damping::default()
        },
    }
}
