//! Dense helpers on faer: solves of the small systems of the methods (moment constraints,
//! active contact blocks), where a singular matrix must be reported rather than produce
//! NaNs, the matrix exponential of the Floquet products, and the short dot products of the
//! trigonometric polynomials.

use faer::linalg::solvers::Solve;
use faer::{c64, Mat, MatRef};

use crate::error::{Error, Result};

mod small_lu;
use small_lu::SmallLu;

/// `A x` for a dense matrix.
pub fn mat_vec(a: &Mat<f64>, x: &[f64]) -> Vec<f64> {
    (0..a.nrows())
        .map(|i| (0..a.ncols()).map(|j| a[(i, j)] * x[j]).sum())
        .collect()
}

/// `Σ a_i b_i` with four partial sums (short vectors: a basis row of `2H + 1`
/// coefficients; one running sum makes each addition wait for the previous one).
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut sums = [0.0; 4];
    let (head_a, tail_a) = a.split_at(n - n % 4);
    let (head_b, tail_b) = b.split_at(n - n % 4);
    for (x, y) in head_a.chunks_exact(4).zip(head_b.chunks_exact(4)) {
        for l in 0..4 {
            sums[l] += x[l] * y[l];
        }
    }
    let tail: f64 = tail_a.iter().zip(tail_b).map(|(x, y)| x * y).sum();
    (sums[0] + sums[1]) + (sums[2] + sums[3]) + tail
}

/// Solves of dense square systems by faer's LU with partial pivoting (as
/// `Mat::partial_piv_lu`, the same arithmetic), in storage kept from one solve to the next:
/// once it has grown to the size, a solve allocates nothing (Newton's direction at every
/// corrector iteration).
pub struct DenseLu {
    factors: Mat<f64>,
    forward: Vec<usize>,
    backward: Vec<usize>,
    rhs: Mat<f64>,
    scratch: Option<(usize, faer::dyn_stack::MemBuffer)>,
}

impl Default for DenseLu {
    fn default() -> Self {
        DenseLu {
            factors: Mat::zeros(0, 0),
            forward: Vec::new(),
            backward: Vec::new(),
            rhs: Mat::zeros(0, 1),
            scratch: None,
        }
    }
}

impl DenseLu {
    /// Solve `A y = b`, `b_i = rhs(i)`, into `y`; `false` when the solution is not finite
    /// (`A` singular).
    pub fn solve_into(
        &mut self,
        a: &Mat<f64>,
        rhs: impl Fn(usize) -> f64,
        y: &mut Vec<f64>,
    ) -> bool {
        use faer::linalg::lu::partial_pivoting::{factor, solve};
        let n = a.nrows();
        let par = faer::get_global_parallelism();
        if self.scratch.as_ref().is_none_or(|(size, _)| *size != n) {
            let request = factor::lu_in_place_scratch::<usize, f64>(n, n, par, Default::default())
                .or(solve::solve_in_place_scratch::<usize, f64>(n, 1, par));
            self.scratch = Some((n, faer::dyn_stack::MemBuffer::new(request)));
            self.forward.resize(n, 0);
            self.backward.resize(n, 0);
        }
        let (_, buffer) = self.scratch.as_mut().expect("made above");
        let stack = faer::dyn_stack::MemStack::new(buffer);
        if self.factors.nrows() == n && self.factors.ncols() == n {
            self.factors.copy_from(a);
        } else {
            self.factors = a.clone();
        }
        let (_, permutation) = factor::lu_in_place(
            self.factors.as_mut(),
            &mut self.forward,
            &mut self.backward,
            par,
            stack,
            Default::default(),
        );
        if self.rhs.nrows() != n || self.rhs.ncols() != 1 {
            self.rhs = Mat::zeros(n, 1);
        }
        (0..n).for_each(|i| self.rhs[(i, 0)] = rhs(i));
        solve::solve_in_place(
            self.factors.as_ref(),
            self.factors.as_ref(),
            permutation,
            self.rhs.as_mut(),
            par,
            stack,
        );
        y.clear();
        y.extend((0..n).map(|i| self.rhs[(i, 0)]));
        y.iter().all(|v| v.is_finite())
    }

    /// The sign of `det A` of the last [`Self::solve_into`]: the signs of `U`'s diagonal
    /// times the parity of the row permutation; `None` before any solve or when a pivot is
    /// zero or not a number.
    pub fn determinant_sign(&self) -> Option<f64> {
        let n = self.factors.nrows();
        if n == 0 || self.forward.len() != n {
            return None;
        }
        let mut sign = 1.0;
        for i in 0..n {
            let pivot = self.factors[(i, i)];
            if pivot == 0.0 || !pivot.is_finite() {
                return None;
            }
            if pivot < 0.0 {
                sign = -sign;
            }
        }
        // a permutation of n entries with c cycles is a product of n − c transpositions
        let mut seen = vec![false; n];
        let mut transpositions = 0;
        for start in 0..n {
            let mut i = start;
            let mut length = 0;
            while !seen[i] {
                seen[i] = true;
                i = self.forward[i];
                length += 1;
            }
            transpositions += length.max(1) - 1;
        }
        Some(if transpositions % 2 == 0 { sign } else { -sign })
    }
}

/// A numerically singular matrix met by [`solve_small_lu`]: the first column whose pivot
/// `|U_kk|` of the partial-pivoting LU is at most the relative tolerance times the largest
/// entry of `A` (or not a number).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SingularPivot {
    pub column: usize,
}

/// Solve `A x = b` for a small square `A` (row-major, `n × n`) by faer's LU with partial
/// pivoting. Fails with the first column whose pivot `|U_kk|` is at most `rel_tol` times
/// the largest entry of `A` (numerically singular; a pivot that is not a number counts as
/// singular), which is where Gaussian elimination with partial pivoting meets it.
pub fn solve_small_lu(
    a: &[f64],
    b: &[f64],
    rel_tol: f64,
) -> std::result::Result<Vec<f64>, SingularPivot> {
    let mut x = Vec::new();
    solve_small_lu_into(a, b, rel_tol, &mut x)?;
    Ok(x)
}

/// [`solve_small_lu`] into `x` (resized to `n`; for `n ≤ 1` nothing is allocated once `x`
/// has room).
pub fn solve_small_lu_into(
    a: &[f64],
    b: &[f64],
    rel_tol: f64,
    x: &mut Vec<f64>,
) -> std::result::Result<(), SingularPivot> {
    let n = b.len();
    assert_eq!(a.len(), n * n);
    x.clear();
    if n == 0 {
        return Ok(());
    }
    let scale = a.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    if scale == 0.0 {
        return Err(SingularPivot { column: 0 });
    }
    let threshold = rel_tol * scale;
    // a pivot that is not clearly above the threshold (NaN included) is singular
    let singular =
        |pivot: f64| pivot.abs().partial_cmp(&threshold) != Some(std::cmp::Ordering::Greater);
    if n == 1 {
        // one contact or constraint: the division itself (faer's LU multiplies by the
        // reciprocal pivot, which is not exact: the gap of a closed contact would be 1e-17
        // instead of 0, and every result would move at round-off level)
        if singular(a[0]) {
            return Err(SingularPivot { column: 0 });
        }
        x.push(b[0] / a[0]);
        return Ok(());
    }
    let lu = SmallLu::new(a, n);
    if let Some(column) = lu.singular_column(singular) {
        return Err(SingularPivot { column });
    }
    let mut solution = Mat::<f64>::from_fn(n, 1, |i, _| b[i]);
    lu.solve_in_place(solution.as_mut());
    x.extend((0..n).map(|i| solution[(i, 0)]));
    Ok(())
}

/// Solve `A X = B` for a square `A` (row-major, `n × n`) and the columns of `B` (`n × m`)
/// with one LU factorisation (partial pivoting), refusing a numerically singular `A` as
/// [`solve_small_lu`] does (same threshold; `n = 1` is the exact division).
pub fn solve_small_lu_columns(
    a: &[f64],
    b: faer::MatRef<'_, f64>,
    rel_tol: f64,
) -> std::result::Result<Mat<f64>, SingularPivot> {
    let n = b.nrows();
    assert_eq!(a.len(), n * n);
    if n == 0 {
        return Ok(Mat::zeros(0, b.ncols()));
    }
    let scale = a.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    let threshold = rel_tol * scale;
    let singular =
        |pivot: f64| pivot.abs().partial_cmp(&threshold) != Some(std::cmp::Ordering::Greater);
    if scale == 0.0 {
        return Err(SingularPivot { column: 0 });
    }
    if n == 1 {
        if singular(a[0]) {
            return Err(SingularPivot { column: 0 });
        }
        return Ok(Mat::from_fn(1, b.ncols(), |_, j| b[(0, j)] / a[0]));
    }
    let lu = SmallLu::new(a, n);
    if let Some(column) = lu.singular_column(singular) {
        return Err(SingularPivot { column });
    }
    let mut x = b.to_owned();
    lu.solve_in_place(x.as_mut());
    Ok(x)
}

/// Solve `A x = b` for a small square `A` (row-major, `n × n`) by faer's LU with partial
/// pivoting ([`solve_small_lu`]). Returns `None` when a pivot is below `rel_tol` times the
/// largest entry of `A` (numerically singular).
pub fn solve_small(a: &[f64], b: &[f64], rel_tol: f64) -> Option<Vec<f64>> {
    solve_small_lu(a, b, rel_tol).ok()
}

/// Solve `A x = b` for a dense square `A` by faer's LU with partial pivoting; a result that
/// is not finite means `A` is singular, reported as [`Error::Singular`] with `what` (e.g.
/// "the Jacobian is singular").
pub fn solve_lu(a: &Mat<f64>, b: &[f64], what: &str) -> Result<Vec<f64>> {
    let n = b.len();
    let rhs = Mat::<f64>::from_fn(n, 1, |i, _| b[i]);
    let x = a.partial_piv_lu().solve(&rhs);
    let x: Vec<f64> = (0..n).map(|i| x[(i, 0)]).collect();
    if x.iter().any(|v| !v.is_finite()) {
        return Err(Error::Singular(what.into()));
    }
    Ok(x)
}

/// Matrix exponential `exp(A)` by scaling and squaring with the diagonal (6, 6) Padé
/// approximant (Moler & Van Loan, "Nineteen dubious ways", method 3): relative accuracy
/// near machine precision for the moderately scaled matrices of the Floquet products.
pub fn expm(a: &Mat<f64>) -> Mat<f64> {
    let n = a.nrows();
    let norm1 = (0..n)
        .map(|j| (0..n).map(|i| a[(i, j)].abs()).sum::<f64>())
        .fold(0.0, f64::max);
    let squarings = if norm1 > 0.5 {
        (norm1 / 0.5).log2().ceil() as i32
    } else {
        0
    };
    let scaled = a * (0.5f64).powi(squarings);
    let q = 6;
    let mut c = 1.0;
    let mut x = Mat::<f64>::identity(n, n);
    let mut num = Mat::<f64>::identity(n, n);
    let mut den = Mat::<f64>::identity(n, n);
    for k in 1..=q {
        c *= (q - k + 1) as f64 / (k * (2 * q - k + 1)) as f64;
        x = &scaled * &x;
        num += &x * c;
        den += &x * (if k % 2 == 0 { c } else { -c });
    }
    let mut f = den.partial_piv_lu().solve(&num);
    for _ in 0..squarings {
        f = &f * &f;
    }
    f
}

/// `A B`, on the calling thread. The small dense products of the methods (monodromy
/// factors, modal projections) are done sequentially: their results then do not depend on
/// the thread count, and a pool's hand-offs cost more than such products.
pub fn sequential_product(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> Mat<f64> {
    let mut out = Mat::<f64>::zeros(a.nrows(), b.ncols());
    faer::linalg::matmul::matmul(
        out.as_mut(),
        faer::Accum::Replace,
        a,
        b,
        1.0,
        faer::Par::Seq,
    );
    out
}

/// faer's parameters of the real eigenvalue problem with the Schur form always computed by
/// the double-shift QR algorithm (`lahqr`, LAPACK's `dlahqr`), which gives up after
/// `30 max(10, n)` iterations. faer's default for `n ≥ 75`, the multishift QR with
/// aggressive early deflation, never returned on nearly defective matrices: the bubble
/// sort of its deflation window's eigenvalues can cycle without end (issue 46: the
/// monodromy `[[I, T I], [ε K, I]]` of a bar a trillion times too heavy, all multipliers 1,
/// spun for hours in `real_schur::multishift_qr`). Measured on one core: the same time on
/// the bar's 198 × 198 monodromies, up to 1.8 times longer at 400 × 400.
fn bounded_evd_params() -> faer::Spec<faer::linalg::evd::EvdParams, f64> {
    let mut params: faer::Spec<faer::linalg::evd::EvdParams, f64> = Default::default();
    params.config.schur.blocking_threshold = usize::MAX;
    params
}

/// A square matrix with finite entries for an eigenvalue problem; an error names `what`.
fn check_eigen_input(a: MatRef<'_, f64>, what: &str) -> Result<()> {
    let n = a.nrows();
    if a.ncols() != n {
        return Err(Error::Numerical(format!(
            "{what}: eigenvalues of a {n} × {} matrix: it is not square",
            a.ncols()
        )));
    }
    let finite = (0..n).all(|j| (0..n).all(|i| a[(i, j)].is_finite()));
    if !finite {
        return Err(Error::Numerical(format!(
            "{what}: the {n} × {n} matrix has entries that are not finite (NaN or infinity)"
        )));
    }
    Ok(())
}

/// The eigenvalues of a real square matrix (Hessenberg reduction and the double-shift QR
/// algorithm with its iteration cap, see [`bounded_evd_params`]), on the calling thread:
/// the monodromy matrices of the Floquet analysis are a few hundred wide, where faer's
/// parallel reduction spent more time handing work between threads than computing
/// (BENCHMARKS.md §12). A matrix with a NaN or an infinity, or one whose QR iteration does
/// not converge, is an error, never a hang.
pub fn eigenvalues(a: MatRef<'_, f64>) -> Result<Vec<c64>> {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::evd::{evd_real, evd_scratch, ComputeEigenvectors};
    check_eigen_input(a, "eigenvalue solver")?;
    let n = a.nrows();
    let params = bounded_evd_params();
    let mut re = faer::diag::Diag::<f64>::zeros(n);
    let mut im = faer::diag::Diag::<f64>::zeros(n);
    let mut mem = MemBuffer::new(evd_scratch::<f64>(
        n,
        ComputeEigenvectors::No,
        ComputeEigenvectors::No,
        faer::Par::Seq,
        params,
    ));
    evd_real(
        a,
        re.as_mut(),
        im.as_mut(),
        None,
        None,
        faer::Par::Seq,
        MemStack::new(&mut mem),
        params,
    )
    .map_err(|e| Error::Numerical(format!("eigenvalue solver: {e:?}")))?;
    Ok((0..n).map(|i| c64::new(re[i], im[i])).collect())
}

/// The eigenvalues and right eigenvectors (columns, complex) of a real square matrix, as
/// faer's `Mat::eigen` gives them, but with the iteration cap of [`eigenvalues`]: an error,
/// never a hang, for a non-finite or (nearly) defective matrix.
pub fn eigen(a: MatRef<'_, f64>) -> Result<(Vec<c64>, Mat<c64>)> {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::evd::{evd_real, evd_scratch, ComputeEigenvectors};
    check_eigen_input(a, "eigendecomposition")?;
    let n = a.nrows();
    let params = bounded_evd_params();
    let par = faer::get_global_parallelism();
    let mut u = Mat::<f64>::zeros(n, n);
    let mut re = faer::diag::Diag::<f64>::zeros(n);
    let mut im = faer::diag::Diag::<f64>::zeros(n);
    let mut mem = MemBuffer::new(evd_scratch::<f64>(
        n,
        ComputeEigenvectors::No,
        ComputeEigenvectors::Yes,
        par,
        params,
    ));
    evd_real(
        a,
        re.as_mut(),
        im.as_mut(),
        None,
        Some(u.as_mut()),
        par,
        MemStack::new(&mut mem),
        params,
    )
    .map_err(|e| Error::Numerical(format!("eigendecomposition: {e:?}")))?;
    // a complex pair holds its eigenvector's real and imaginary parts in two columns
    let mut values = Vec::with_capacity(n);
    let mut vectors = Mat::<c64>::zeros(n, n);
    let mut j = 0;
    while j < n {
        if im[j] == 0.0 || j + 1 == n {
            values.push(c64::new(re[j], 0.0));
            for i in 0..n {
                vectors[(i, j)] = c64::new(u[(i, j)], 0.0);
            }
            j += 1;
        } else {
            values.push(c64::new(re[j], im[j]));
            values.push(c64::new(re[j], -im[j]));
            for i in 0..n {
                vectors[(i, j)] = c64::new(u[(i, j)], u[(i, j + 1)]);
                vectors[(i, j + 1)] = c64::new(u[(i, j)], -u[(i, j + 1)]);
            }
            j += 2;
        }
    }
    Ok((values, vectors))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `eigen` gives eigenpairs (`A v = λ v`, a complex pair included) and the values of
    /// `eigenvalues`; a NaN or an infinity is refused by both, never iterated on.
    #[test]
    fn eigen_solves_give_eigenpairs_and_refuse_non_finite_matrices() {
        let rows = [[0.0, 1.0, 0.0], [-2.0, -0.1, 1.0], [0.5, 0.0, -1.0]];
        let mut a = Mat::from_fn(3, 3, |i, j| rows[i][j]);
        let (values, vectors) = eigen(a.as_ref()).unwrap();
        assert!(
            values.iter().any(|v| v.im != 0.0),
            "a complex pair: {values:?}"
        );
        for (k, &l) in values.iter().enumerate() {
            for i in 0..3 {
                let av: c64 = (0..3).map(|j| vectors[(j, k)] * a[(i, j)]).sum();
                assert!(
                    (av - l * vectors[(i, k)]).norm() < 1e-12,
                    "{k}: {av} vs {l}"
                );
            }
        }
        let only = eigenvalues(a.as_ref()).unwrap();
        for l in &values {
            assert!(
                only.iter().any(|m| (m - l).norm() < 1e-12),
                "{l} in {only:?}"
            );
        }
        for bad in [f64::NAN, f64::INFINITY] {
            a[(1, 2)] = bad;
            let err = eigenvalues(a.as_ref()).unwrap_err().to_string();
            assert!(err.contains("not finite"), "{err}");
            assert!(eigen(a.as_ref()).is_err());
        }
    }

    /// The sign of the determinant from the LU against the cofactor expansion of 3 × 3
    /// matrices that need row exchanges (zero leading pivots) and of their row swaps.
    #[test]
    fn the_determinant_sign_matches_the_cofactor_expansion() {
        let det3 = |m: &Mat<f64>| {
            m[(0, 0)] * (m[(1, 1)] * m[(2, 2)] - m[(1, 2)] * m[(2, 1)])
                - m[(0, 1)] * (m[(1, 0)] * m[(2, 2)] - m[(1, 2)] * m[(2, 0)])
                + m[(0, 2)] * (m[(1, 0)] * m[(2, 1)] - m[(1, 1)] * m[(2, 0)])
        };
        let matrices = [
            [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]],
            [[0.0, 2.0, 1.0], [3.0, -1.0, 0.5], [1.0, 1.0, -4.0]],
            [[1e-3, 5.0, 2.0], [4.0, 1.0, -1.0], [-2.0, 0.5, 3.0]],
            [[-1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 3.0]],
        ];
        let mut lu = DenseLu::default();
        let mut y = Vec::new();
        for rows in matrices {
            for swap in [None, Some((0, 2)), Some((1, 2))] {
                let mut m = Mat::<f64>::from_fn(3, 3, |i, j| rows[i][j]);
                if let Some((a, b)) = swap {
                    for j in 0..3 {
                        let (u, v) = (m[(a, j)], m[(b, j)]);
                        m[(a, j)] = v;
                        m[(b, j)] = u;
                    }
                }
                assert!(lu.solve_into(&m, |i| i as f64, &mut y));
                let expected = det3(&m).signum();
                assert_eq!(
                    lu.determinant_sign(),
                    Some(expected),
                    "{rows:?} swap {swap:?}"
                );
            }
        }
        let singular = Mat::<f64>::from_fn(3, 3, |i, j| (i + j) as f64);
        lu.solve_into(&singular, |_| 1.0, &mut y);
        assert_eq!(lu.determinant_sign(), None);
    }

    #[test]
    fn solves_and_detects_singularity() {
        let a = [0.0, 2.0, 1.0, 1.0];
        let x = solve_small(&a, &[4.0, 3.0], 1e-14).unwrap();
        assert!((x[0] - 1.0).abs() < 1e-15 && (x[1] - 2.0).abs() < 1e-15);
        assert!(solve_small(&[1.0, 2.0, 2.0, 4.0], &[1.0, 1.0], 1e-12).is_none());
    }

    #[test]
    fn reports_the_first_singular_column() {
        // x = (1, −2, 3) of a well-conditioned 3×3 system
        let a = [4.0, 1.0, 0.5, 1.0, 3.0, -1.0, 0.5, -1.0, 5.0];
        let b = [4.0 - 2.0 + 1.5, 1.0 - 6.0 - 3.0, 0.5 + 2.0 + 15.0];
        let x = solve_small_lu(&a, &b, 1e-14).unwrap();
        for (xi, want) in x.iter().zip([1.0, -2.0, 3.0]) {
            assert!((xi - want).abs() < 1e-14, "{x:?}");
        }
        // the second column repeats the first: elimination meets a zero pivot in column 1
        let dependent = [1.0, 1.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        let err = solve_small_lu(&dependent, &[1.0, 1.0, 1.0], 1e-14).unwrap_err();
        assert_eq!(err.column, 1);
        // a pivot just below the tolerance is singular, just above is not
        let nearly = [1.0, 1.0, 1.0, 1.0 + 1e-10];
        assert!(solve_small_lu(&nearly, &[1.0, 1.0], 1e-9).is_err());
        assert!(solve_small_lu(&nearly, &[1.0, 1.0], 1e-11).is_ok());
        // 1×1: the exact quotient, a zero is singular
        assert_eq!(
            solve_small_lu(&[3.0], &[1.0], 1e-14).unwrap(),
            vec![1.0 / 3.0]
        );
        assert_eq!(solve_small_lu(&[0.0], &[1.0], 1e-14).unwrap_err().column, 0);
        assert_eq!(
            solve_small_lu(&[f64::NAN], &[1.0], 1e-14)
                .unwrap_err()
                .column,
            0
        );
    }

    #[test]
    fn solve_lu_reports_singular_jacobians() {
        let a = Mat::<f64>::from_fn(2, 2, |i, j| [[2.0, 1.0], [1.0, 3.0]][i][j]);
        let x = solve_lu(&a, &[3.0, 4.0], "singular").unwrap();
        assert!((x[0] - 1.0).abs() < 1e-15 && (x[1] - 1.0).abs() < 1e-15);
        let s = Mat::<f64>::zeros(2, 2);
        let err = solve_lu(&s, &[1.0, 1.0], "the Jacobian is singular").unwrap_err();
        assert!(
            err.to_string().contains("the Jacobian is singular"),
            "{err}"
        );
    }
}
