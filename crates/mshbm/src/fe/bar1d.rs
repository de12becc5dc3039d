//! Two-node linear bar elements (paper eq. 45).

use crate::error::{Error, Result};
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
/// boundary conditions applied. Sizes are computed with checked arithmetic and the
/// triplets are reserved fallibly, so an absurd `n_elements` is an error, not a panic;
/// callers check the memory budget first (`model::MODEL_BYTES_PER_DOF`).
pub fn assemble(
    n_elements: usize,
    length: f64,
    density: f64,
    young: f64,
    area: f64,
) -> Result<(SparseMatrix, SparseMatrix)> {
    let too_many = || {
        Error::argument(
            "bar elements",
            format!("cannot allocate a bar of {n_elements} elements"),
        )
    };
    let n = n_elements.checked_add(1).ok_or_else(too_many)?;
    let entries = n_elements.checked_mul(4).ok_or_else(too_many)?;
    let (me, ke) = element_matrices(density, young, area, length / n_elements as f64);
    let mut mt = Vec::new();
    let mut kt = Vec::new();
    mt.try_reserve_exact(entries).map_err(|_| too_many())?;
    kt.try_reserve_exact(entries).map_err(|_| too_many())?;
    for e in 0..n_elements {
        for a in 0..2 {
            for b in 0..2 {
                mt.push((e + a, e + b, me[a][b]));
                kt.push((e + a, e + b, ke[a][b]));
            }
        }
    }
    Ok((
        SparseMatrix::try_from_triplets(n, n, &mt)?,
        SparseMatrix::try_from_triplets(n, n, &kt)?,
    ))
}

/// Node coordinates of [`assemble`].
pub fn node_coordinates(n_elements: usize, length: f64) -> Vec<Vec<f64>> {
    (0..=n_elements)
        .map(|i| vec![length * i as f64 / n_elements as f64])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn absurd_element_counts_are_errors_not_panics() {
        // n + 1 overflows; 4 n overflows; 4 n triplets cannot be allocated
        for n in [usize::MAX, usize::MAX / 4 + 1, 1 << 61] {
            let err = assemble(n, 1.0, 1.0, 1.0, 1.0).unwrap_err();
            assert!(err.to_string().contains("cannot allocate"), "{n}: {err}");
        }
        // two elements of length 1/2: the diagonal of K is EA/l (1 + [middle node] 1)
        let (m, k) = assemble(2, 1.0, 6.0, 1.0, 1.0).unwrap();
        assert_eq!(k.get(1, 1), 4.0);
        assert_eq!(k.get(0, 1), -2.0);
        // ρAl/6 · (2 + 2) at the middle node, ρAl/6 off the diagonal
        assert_eq!(m.get(1, 1), 2.0);
        assert_eq!(m.get(2, 1), 0.5);
    }
}
