//! The block Krylov method of [`lowest_modes`](super::lowest_modes) (step 1) and the
//! Rayleigh–Ritz projections it and the subspace iteration share.

use faer::linalg::solvers::Solve;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Mat, Par, Side};

use super::{symmetric_eigen, LowestModes, ModeSolver, MODE_RESIDUAL_TOLERANCE};
use crate::error::{Error, Result};
use crate::limits::Cancel;
use crate::sparse::SparseMatrix;

/// Vectors per block of [`block_krylov`]: the Krylov polynomial's degree is the basis size
/// over this, and the block solves stay efficient.
pub(super) const BLOCK: usize = 16;

/// What [`block_krylov`] found.
pub(super) enum Krylov {
    Converged(LowestModes),
    /// Not converged within its size: the Ritz vectors (`p` of them) to polish by subspace
    /// iteration.
    Unconverged(Mat<f64>),
}

/// Step 1 of [`lowest_modes`]: the block Krylov space of `K⁻¹ M` from `first`, the first
/// [`BLOCK`] columns of the start block (`p` columns, the size of the subspace iteration). The projections `Qᵀ K Q`, `Qᵀ M Q` grow
/// with the basis (each vector meets `K` and `M` once); Rayleigh–Ritz is tried every
/// `count/4` vectors from `2·count` on, and the residuals are formed once the `count`
/// lowest Ritz values have settled (relative change below `1e-9` since the last try).
// the factor, both matrices, the start, the sizes and the caller's request
#[allow(clippy::too_many_arguments)]
pub(super) fn block_krylov(
    llt: &faer::sparse::linalg::solvers::Llt<usize, f64>,
    k: &SparseMatrix,
    m: &SparseMatrix,
    first: &Mat<f64>,
    p: usize,
    count: usize,
    massive: usize,
    cancel: Cancel,
) -> Result<Krylov> {
    let block = first.ncols();
    let cap = massive.min(6 * count + block);
    let check_every = (count / 4).max(block);
    let mut next_check = (2 * count).min(cap);
    let apply = |v: &Mat<f64>| -> Mat<f64> {
        let mut y = m.mul_block(v.as_ref());
        llt.solve_in_place(y.as_mut());
        y
    };
    // the basis is filled block by block into storage allocated for the usual size (the
    // Krylov space typically converges within 4·count vectors), enlarged once if needed
    let mut storage = Mat::<f64>::zeros(first.nrows(), cap.min(4 * count + block));
    let mut len = 0;
    let mut kr = Mat::<f64>::zeros(0, 0);
    let mut mr = Mat::<f64>::zeros(0, 0);
    let mut next = apply(first);
    let mut previous: Option<Vec<f64>> = None;
    loop {
        cancel.check()?;
        let basis = storage.subcols(0, len);
        // orthonormalise the new block against the basis (twice) and itself
        for _ in 0..2 {
            let coefficients = basis.transpose() * &next;
            next -= basis * &coefficients;
        }
        let q = next.qr().compute_thin_Q();
        let width = q.ncols().min(cap - len);
        let q = q.subcols(0, width);
        let (kq, mq) = (k.mul_block(q), m.mul_block(q));
        kr = grow(&kr, &(basis.transpose() * &kq), &(q.transpose() * &kq));
        mr = grow(&mr, &(basis.transpose() * &mq), &(q.transpose() * &mq));
        if len + width > storage.ncols() {
            let mut larger = Mat::<f64>::zeros(storage.nrows(), cap);
            larger
                .subcols_mut(0, len)
                .copy_from(storage.subcols(0, len));
            storage = larger;
        }
        storage.subcols_mut(len, width).copy_from(q);
        len += width;
        let basis = storage.subcols(0, len);
        let full = len + block > cap;
        if basis.ncols() >= next_check || full {
            next_check = basis.ncols() + check_every;
            let keep = count.min(basis.ncols());
            // the Ritz values first; the vectors only once the values have settled
            let (values, _) = rayleigh_ritz_projected(&kr, &mr, basis, 0)?;
            let settled = previous.as_ref().is_some_and(|old| {
                (0..keep).all(|i| (values[i] - old[i]).abs() <= 1e-9 * values[i].abs())
            });
            if (settled || full) && keep == count {
                let (values, shapes) = rayleigh_ritz_projected(&kr, &mr, basis, keep)?;
                if residuals_below(k, m, &values, &shapes) {
                    return Ok(Krylov::Converged(LowestModes {
                        eigenvalues: values[..count].to_vec(),
                        shapes,
                        solver: ModeSolver::BlockKrylov,
                    }));
                }
            }
            if full {
                // polish the p lowest Ritz vectors of the whole space
                let keep = p.min(basis.ncols());
                let (_, shapes) = rayleigh_ritz_projected(&kr, &mr, basis, keep)?;
                return Ok(Krylov::Unconverged(shapes));
            }
            previous = Some(values);
        }
        next = apply(&storage.subcols(len - width, width).to_owned());
    }
}

/// `[[a, c], [cᵀ, d]]` for symmetric `a` and `d`.
fn grow(a: &Mat<f64>, c: &Mat<f64>, d: &Mat<f64>) -> Mat<f64> {
    let (n, b) = (a.nrows(), d.nrows());
    Mat::from_fn(n + b, n + b, |i, j| match (i < n, j < n) {
        (true, true) => a[(i, j)],
        (true, false) => c[(i, j - n)],
        (false, true) => c[(j, i - n)],
        (false, false) => d[(i - n, j - n)],
    })
}

/// Whether every Ritz pair has `‖K φ − ω² M φ‖ ≤ MODE_RESIDUAL_TOLERANCE ‖ω² M φ‖`.
fn residuals_below(k: &SparseMatrix, m: &SparseMatrix, values: &[f64], shapes: &Mat<f64>) -> bool {
    // 16 columns at a time: `K Φ` and `M Φ` whole would double the modes' memory
    (0..shapes.ncols()).step_by(16).all(|start| {
        let width = 16.min(shapes.ncols() - start);
        let columns = shapes.subcols(start, width);
        let (ks, ms) = (k.mul_block(columns), m.mul_block(columns));
        (0..width).all(|c| {
            let (mut residual, mut size) = (0.0f64, 0.0f64);
            for r in 0..ks.nrows() {
                let target = values[start + c] * ms[(r, c)];
                residual += (ks[(r, c)] - target).powi(2);
                size += target * target;
            }
            residual.sqrt() <= MODE_RESIDUAL_TOLERANCE * size.sqrt()
        })
    })
}

/// Rayleigh–Ritz on the span of `y` given `K y` and `M y`: Ritz values (ascending) and
/// mass-normalised Ritz vectors `y Q`.
pub(super) fn rayleigh_ritz(
    ky: &Mat<f64>,
    my: &Mat<f64>,
    y: &Mat<f64>,
) -> Result<(Vec<f64>, Mat<f64>)> {
    rayleigh_ritz_projected(
        &(y.transpose() * ky),
        &(y.transpose() * my),
        y.as_ref(),
        y.ncols(),
    )
}

/// Rayleigh–Ritz on the span of `y` given `yᵀ K y` and `yᵀ M y`: every Ritz value and the
/// `keep` lowest Ritz vectors.
fn rayleigh_ritz_projected(
    kr: &Mat<f64>,
    mr: &Mat<f64>,
    y: faer::MatRef<'_, f64>,
    keep: usize,
) -> Result<(Vec<f64>, Mat<f64>)> {
    let sym = |a: &Mat<f64>| (a + a.transpose()) * 0.5;
    let llt = sym(mr).llt(Side::Lower).map_err(|_| {
        Error::Numerical(
            "subspace iteration: the block lost rank (M not positive definite?)".into(),
        )
    })?;
    let l = llt.L();
    let mut a = sym(kr);
    solve_lower_triangular_in_place(l, a.as_mut(), Par::Seq);
    let mut a = a.transpose().to_owned();
    solve_lower_triangular_in_place(l, a.as_mut(), Par::Seq);
    let (values, mut q) = symmetric_eigen(&sym(&a))?;
    // Q = L⁻ᵀ U
    faer::linalg::triangular_solve::solve_upper_triangular_in_place(
        l.transpose(),
        q.as_mut(),
        Par::Seq,
    );
    Ok((values, y * q.subcols(0, keep)))
}
