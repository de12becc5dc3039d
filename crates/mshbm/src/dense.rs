//! Small dense helpers for the tiny systems of the method (moment constraints, active
//! contact blocks), where a singular matrix must be reported rather than produce NaNs.

/// Solve `A x = b` for a small square `A` (row-major, `n × n`) by Gaussian elimination
/// with partial pivoting. Returns `None` when a pivot is below `rel_tol` times the
/// largest entry of `A` (numerically singular).
pub fn solve_small(a: &[f64], b: &[f64], rel_tol: f64) -> Option<Vec<f64>> {
    let n = b.len();
    assert_eq!(a.len(), n * n);
    let mut m = a.to_vec();
    let mut x = b.to_vec();
    let scale = m.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    if n == 0 {
        return Some(x);
    }
    if scale == 0.0 {
        return None;
    }
    for col in 0..n {
        let piv = (col..n)
            .max_by(|&i, &j| m[i * n + col].abs().total_cmp(&m[j * n + col].abs()))
            .expect("non-empty range");
        if m[piv * n + col].abs() <= rel_tol * scale {
            return None;
        }
        if piv != col {
            for k in 0..n {
                m.swap(piv * n + k, col * n + k);
            }
            x.swap(piv, col);
        }
        let p = m[col * n + col];
        for i in col + 1..n {
            let f = m[i * n + col] / p;
            if f != 0.0 {
                for k in col..n {
                    m[i * n + k] -= f * m[col * n + k];
                }
                x[i] -= f * x[col];
            }
        }
    }
    for col in (0..n).rev() {
        let mut s = x[col];
        for k in col + 1..n {
            s -= m[col * n + k] * x[k];
        }
        x[col] = s / m[col * n + col];
    }
    Some(x)
}

/// Matrix exponential `exp(A)` by scaling and squaring with the diagonal (6, 6) Padé
/// approximant (Moler & Van Loan, "Nineteen dubious ways", method 3): relative accuracy
/// near machine precision for the moderately scaled matrices of the Floquet products.
pub fn expm(a: &faer::Mat<f64>) -> faer::Mat<f64> {
    use faer::linalg::solvers::Solve;
    use faer::Mat;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_and_detects_singularity() {
        let a = [0.0, 2.0, 1.0, 1.0];
        let x = solve_small(&a, &[4.0, 3.0], 1e-14).unwrap();
        assert!((x[0] - 1.0).abs() < 1e-15 && (x[1] - 2.0).abs() < 1e-15);
        assert!(solve_small(&[1.0, 2.0, 2.0, 4.0], &[1.0, 1.0], 1e-12).is_none());
    }
}
