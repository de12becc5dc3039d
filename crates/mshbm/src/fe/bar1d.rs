//! Two-node linear bar elements (paper eq. 45).

use crate::sparse::SparseMatrix;

/// Consistent mass `ρAl/6 [[2,1],[1,2]]` and stiffness `EA/l [[1,-1],[-1,1]]` of one
/// element of length `l` (paper eq. 45).
pub fn element_matrices(
    density: f64,
    young: f64,
    area: f64,
    l: f64,
) -> ([[f64; 2]; 2], [[f64; 2]; 2]) {
    let m = density * area * l / 6.0;
    let k = young * area / l;
    ([[2.0 * m, m], [m, 2.0 * m]], [[k, -k], [-k, k]])
}

/// Global consistent mass and stiffness of a uniform bar of `n_elements` equal elements
/// over `[0, length]`, nodes `0..=n_elements` at `x_i = i length / n_elements`, no
/// boundary conditions applied.
pub fn assemble(
    n_elements: usize,
    length: f64,
    density: f64,
    young: f64,
    area: f64,
) -> (SparseMatrix, SparseMatrix) {
    let n = n_elements + 1;
    let (me, ke) = element_matrices(density, young, area, length / n_elements as f64);
    let mut mt = Vec::with_capacity(4 * n_elements);
    let mut kt = Vec::with_capacity(4 * n_elements);
    for e in 0..n_elements {
        for a in 0..2 {
            for b in 0..2 {
                mt.push((e + a, e + b, me[a][b]));
                kt.push((e + a, e + b, ke[a][b]));
            }
        }
    }
    (
        SparseMatrix::from_triplets(n, n, &mt),
        SparseMatrix::from_triplets(n, n, &kt),
    )
}

/// Node coordinates of [`assemble`].
pub fn node_coordinates(n_elements: usize, length: f64) -> Vec<Vec<f64>> {
    (0..=n_elements)
        .map(|i| vec![length * i as f64 / n_elements as f64])
        .collect()
}
