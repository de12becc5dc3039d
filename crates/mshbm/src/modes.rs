//! Eigenfrequencies of `K φ = ω² M φ`, including singular (redistributed) masses.
//!
//! DOFs without mass (zero rows of `M`, the contact boundary after redistribution) are
//! condensed statically first, `K* = K_dd − K_dc K_cc⁻¹ K_cd` (METHODS §8.1): a singular
//! mass never reaches the symmetric-definite eigensolver. The reduced problem is solved
//! densely through a Cholesky factor of `M_dd` (`L⁻¹ K* L⁻ᵀ ψ = ω² ψ`); this suits models of
//! up to a few thousand DOFs. [`first_angular_frequency`] uses sparse inverse iteration
//! and works for large models.

use faer::linalg::solvers::Solve;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Mat, Par, Side};

use crate::error::{Error, Result};
use crate::sparse::SparseMatrix;

/// Indices of DOFs whose mass row is identically zero.
pub fn massless_dofs(mass: &SparseMatrix) -> Vec<usize> {
    let mut has_mass = vec![false; mass.nrows()];
    for (i, _, v) in mass.iter() {
        if v != 0.0 {
            has_mass[i] = true;
        }
    }
    (0..mass.nrows()).filter(|&i| !has_mass[i]).collect()
}

/// The `count` lowest eigenfrequencies (Hz) of `K φ = ω² M φ`, ascending.
pub fn eigenfrequencies_hz(
    mass: &SparseMatrix,
    stiffness: &SparseMatrix,
    count: usize,
) -> Result<Vec<f64>> {
    let n = stiffness.nrows();
    let massless = massless_dofs(mass);
    let mut is_massless = vec![false; n];
    massless.iter().for_each(|&i| is_massless[i] = true);
    let massive: Vec<usize> = (0..n).filter(|&i| !is_massless[i]).collect();
    if count > massive.len() {
        return Err(Error::argument(
            "count",
            format!(
                "asked for {count} eigenfrequencies, the model has {} DOFs with mass",
                massive.len()
            ),
        ));
    }
    let mut k_red = stiffness.submatrix(&massive, &massive).to_dense();
    if !massless.is_empty() {
        let k_cc = stiffness.submatrix(&massless, &massless).to_dense();
        let k_cd = stiffness.submatrix(&massless, &massive).to_dense();
        let lu = k_cc.full_piv_lu();
        let x = lu.solve(&k_cd);
        if x.col_iter().any(|c| c.iter().any(|v| !v.is_finite())) {
            return Err(Error::Singular(
                "the stiffness of the massless DOFs (K_cc) is singular: they are not statically determined".into(),
            ));
        }
        k_red -= k_cd.transpose() * &x;
    }
    let m_dd = mass.submatrix(&massive, &massive).to_dense();
    let llt = m_dd.llt(Side::Lower).map_err(|_| {
        Error::Singular(
            "the mass matrix is not positive definite on the DOFs that carry mass".into(),
        )
    })?;
    let l = llt.L();
    // A = L⁻¹ K* L⁻ᵀ
    let mut x = k_red;
    solve_lower_triangular_in_place(l, x.as_mut(), Par::Seq);
    let mut a = x.transpose().to_owned();
    solve_lower_triangular_in_place(l, a.as_mut(), Par::Seq);
    let sym = (&a + a.transpose()) * 0.5;
    let eig = sym
        .self_adjoint_eigenvalues(Side::Lower)
        .map_err(|e| Error::Numerical(format!("eigenvalue solver: {e:?}")))?;
    Ok(eig
        .into_iter()
        .take(count)
        .map(|lam| lam.max(0.0).sqrt() / (2.0 * std::f64::consts::PI))
        .collect())
}

/// Lowest angular eigenfrequency (rad/s) of `K φ = ω² M φ` by inverse iteration with a
/// sparse Cholesky factor of `K` (positive definite: Dirichlet DOFs removed). Works with
/// massless DOFs (they follow statically). Converges with the ratio `(ω₁/ω₂)²`.
pub fn first_angular_frequency(mass: &SparseMatrix, stiffness: &SparseMatrix) -> Result<f64> {
    let n = stiffness.nrows();
    let llt = stiffness
        .to_faer()
        .sp_cholesky(Side::Lower)
        .map_err(|_| Error::Singular("the stiffness matrix is singular (the structure is not held; a first-mode damping ratio needs a held structure)".into()))?;
    let mut x = Mat::<f64>::from_fn(n, 1, |i, _| 1.0 + (i as f64 * 0.7).sin() * 0.1);
    let mut lambda_old = f64::INFINITY;
    for _ in 0..2000 {
        let mx = mass.mul_vec(x.col(0).try_as_col_major().expect("contiguous").as_slice());
        let mut y = Mat::<f64>::from_fn(n, 1, |i, _| mx[i]);
        llt.solve_in_place(y.as_mut());
        let ky = stiffness.mul_vec(y.col(0).try_as_col_major().expect("contiguous").as_slice());
        let my = mass.mul_vec(y.col(0).try_as_col_major().expect("contiguous").as_slice());
        let num: f64 = (0..n).map(|i| y[(i, 0)] * ky[i]).sum();
        let den: f64 = (0..n).map(|i| y[(i, 0)] * my[i]).sum();
        if den <= 0.0 {
            return Err(Error::Singular(
                "the mass matrix has no positive mass".into(),
            ));
        }
        let lambda = num / den;
        let norm = den.sqrt();
        x = y * (1.0 / norm);
        if (lambda - lambda_old).abs() <= 1e-14 * lambda {
            return Ok(lambda.sqrt());
        }
        lambda_old = lambda;
    }
    Ok(lambda_old.sqrt())
}
