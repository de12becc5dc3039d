//! Eigenfrequencies of `K φ = ω² M φ`, including singular (redistributed) masses.
//!
//! DOFs without mass (zero rows of `M`, the contact boundary after redistribution) are
//! condensed statically first, `K* = K_dd − K_dc K_cc⁻¹ K_cd` (docs/theory.md (T30)): a singular
//! mass never reaches the symmetric-definite eigensolver. The reduced problem is solved
//! densely through a Cholesky factor of `M_dd` (`L⁻¹ K* L⁻ᵀ ψ = ω² ψ`) up to
//! [`DENSE_EIGEN_LIMIT`] DOFs with mass; larger models use the sparse subspace iteration
//! [`lowest_modes`]. Either path refuses a stiffness that is not positive definite (rigid-body
//! modes, negative stiffness) and plans its memory against [`Limits`] before allocating.
//! [`first_angular_frequency`] uses sparse inverse iteration and works for large models.

use faer::linalg::solvers::Solve;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Mat, Par, Side};

use crate::error::{Error, Result};
use crate::limits::{dense_f64_bytes, Limits};
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

/// Largest number of DOFs with mass solved by the dense path (a dense symmetric
/// eigenproblem of that size takes about a second and 50 MB); larger models use the sparse
/// subspace iteration [`lowest_modes`], whose cost grows linearly with the DOFs.
pub const DENSE_EIGEN_LIMIT: usize = 1500;

/// Eigenvalues `ω²` within this fraction of the largest are zero (rigid-body modes) for the
/// dense path; below minus this fraction the stiffness is indefinite.
const ZERO_EIGENVALUE: f64 = 1e-11;

/// Dense `n × n` matrices alive at once in the dense path (`K*`, `M_dd`, its factor, the
/// symmetric product, eigenvectors and the solver's workspace).
const DENSE_MATRICES: u64 = 6;

/// Blocks of `n × p` values alive at once in the subspace iteration (`X`, `M X`,
/// `K⁻¹ M X`, its thin QR, `K Y`, `M Y`, Ritz vectors and a spare).
const SUBSPACE_BLOCKS: u64 = 8;

/// The `count` lowest eigenfrequencies (Hz) of `K φ = ω² M φ`, ascending, within the
/// default [`Limits`] (the machine's memory).
pub fn eigenfrequencies_hz(
    mass: &SparseMatrix,
    stiffness: &SparseMatrix,
    count: usize,
) -> Result<Vec<f64>> {
    eigenfrequencies_hz_within(mass, stiffness, count, &Limits::default())
}

/// The `count` lowest eigenfrequencies (Hz) of `K φ = ω² M φ`, ascending, refusing before
/// allocating when the solver's memory exceeds `limits`. Up to [`DENSE_EIGEN_LIMIT`] DOFs
/// with mass the problem is condensed statically (docs/theory.md (T30)) and solved
/// densely; above, by the sparse subspace iteration [`lowest_modes`] on the whole model
/// (massless DOFs need no condensation there: `K⁻¹M` maps them to zero, their eigenvalues
/// are infinite and never among the lowest).
///
/// The stiffness must be positive definite with the Dirichlet DOFs fixed: an indefinite
/// stiffness, or a singular one (rigid-body modes, e.g. a free bar), is an error — never
/// a frequency of 0 Hz or NaN.
pub fn eigenfrequencies_hz_within(
    mass: &SparseMatrix,
    stiffness: &SparseMatrix,
    count: usize,
    limits: &Limits,
) -> Result<Vec<f64>> {
    let n = stiffness.nrows();
    let massless = massless_dofs(mass);
    let mut is_massless = vec![false; n];
    massless.iter().for_each(|&i| is_massless[i] = true);
    let massive: Vec<usize> = (0..n).filter(|&i| !is_massless[i]).collect();
    if count == 0 || count > massive.len() {
        return Err(Error::argument(
            "count",
            format!(
                "asked for {count} eigenfrequencies, the model has {} DOFs with mass",
                massive.len()
            ),
        ));
    }
    let to_hz = |lam: f64| lam.sqrt() / (2.0 * std::f64::consts::PI);
    if massive.len() > DENSE_EIGEN_LIMIT {
        let p = n.min((2 * count).max(count + 8));
        let block = dense_f64_bytes(n, p).and_then(|b| b.checked_mul(SUBSPACE_BLOCKS));
        let factor = (stiffness.nnz() as u64).checked_mul(16 * 4);
        limits.check_memory(
            &format!("the lowest {count} modes of {n} DOFs (sparse subspace iteration)"),
            block.zip(factor).and_then(|(a, b)| a.checked_add(b)),
        )?;
        let modes = lowest_modes(mass, stiffness, count).map_err(|e| match e {
            Error::Singular(_) => not_definite(None),
            other => other,
        })?;
        return Ok(modes.eigenvalues.into_iter().map(to_hz).collect());
    }
    limits.check_memory(
        &format!("the dense eigenproblem of {} DOFs with mass", massive.len()),
        dense_f64_bytes(massive.len(), massive.len()).and_then(|b| b.checked_mul(DENSE_MATRICES)),
    )?;
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
    let largest = eig.iter().fold(0.0f64, |m, &v| m.max(v.abs()));
    if eig.iter().any(|v| !v.is_finite()) || largest == 0.0 {
        return Err(Error::Numerical(
            "eigenvalue solver: non-finite eigenvalues".into(),
        ));
    }
    let negative = eig
        .iter()
        .filter(|&&v| v < -ZERO_EIGENVALUE * largest)
        .count();
    let zero = eig
        .iter()
        .filter(|&&v| v.abs() <= ZERO_EIGENVALUE * largest)
        .count();
    if negative > 0 {
        return Err(Error::Singular(format!(
            "the stiffness is indefinite with the Dirichlet DOFs fixed: {negative} negative eigenvalue(s) of K φ = ω² M φ (down to {:.3e} rad²/s²); eigenfrequencies need a positive definite stiffness",
            eig[0]
        )));
    }
    if zero > 0 {
        return Err(not_definite(Some(zero)));
    }
    Ok(eig.into_iter().take(count).map(to_hz).collect())
}

/// The error of a stiffness that is not positive definite (`rigid`: the number of
/// rigid-body modes, when known).
fn not_definite(rigid: Option<usize>) -> Error {
    Error::Singular(match rigid {
        Some(r) => format!(
            "the stiffness is singular with the Dirichlet DOFs fixed: {r} rigid-body mode(s) of 0 Hz (a free structure); eigenfrequencies need a held structure (Dirichlet DOFs, or a spring)"
        ),
        None => "the stiffness is not positive definite with the Dirichlet DOFs fixed: the structure has rigid-body modes or a negative stiffness; eigenfrequencies need a held structure".into(),
    })
}

/// Lowest angular eigenfrequency (rad/s) of `K φ = ω² M φ` by subspace iteration
/// ([`lowest_modes`]) with a sparse Cholesky factor of `K` (positive definite: Dirichlet
/// DOFs removed). Works with massless DOFs (they follow statically). Converges with the
/// ratio `ω₁²/ω₁₀²`, so close second modes (plates) do not slow it down as they slow inverse
/// iteration.
pub fn first_angular_frequency(mass: &SparseMatrix, stiffness: &SparseMatrix) -> Result<f64> {
    if massless_dofs(mass).len() == mass.nrows() {
        return Err(Error::Singular(
            "the mass matrix has no positive mass".into(),
        ));
    }
    let modes = lowest_modes(mass, stiffness, 1).map_err(|e| match e {
        Error::Singular(_) => Error::Singular("the stiffness matrix is singular (the structure is not held; a first-mode damping ratio needs a held structure)".into()),
        other => other,
    })?;
    Ok(modes.eigenvalues[0].sqrt())
}

/// The lowest eigenpairs of `K φ = ω² M φ` with `K` symmetric positive definite and `M`
/// symmetric positive semi-definite (massless DOFs follow statically), found iteratively for
/// large sparse models.
#[derive(Clone, Debug)]
pub struct LowestModes {
    /// `ω²` (rad²/s²), ascending.
    pub eigenvalues: Vec<f64>,
    /// The mode shapes as columns, mass-normalised (`Φᵀ M Φ = I`, `Φᵀ K Φ = diag(ω²)`).
    pub shapes: Mat<f64>,
}

/// The `count` lowest modes of `K φ = ω² M φ` (`K` positive definite, `M` positive
/// definite on the `n_m` DOFs with mass, zero elsewhere) by subspace iteration with a sparse
/// Cholesky factor of `K` (Bathe's method): the block `Y = K⁻¹ M X` of
/// `p = min(n_m, max(2·count, count + 8))` vectors is improved by a
/// Rayleigh–Ritz step per iteration, and eigenvalue `i` converges with the ratio
/// `λ_i/λ_{p+1}`. Iterates until the `count` lowest Ritz values change by less than
/// `1e-11` (relative). With `p = n` (no massless DOFs) one Rayleigh–Ritz step on the
/// identity is the dense solution; with `p = n_m` the first block spans every mode with mass.
pub fn lowest_modes(
    mass: &SparseMatrix,
    stiffness: &SparseMatrix,
    count: usize,
) -> Result<LowestModes> {
    let n = stiffness.nrows();
    // massless DOFs follow statically: K⁻¹ M x has rank n − massless
    let massive = n - massless_dofs(mass).len();
    if count == 0 || count > massive {
        return Err(Error::argument(
            "count",
            format!("asked for {count} modes of a system with {massive} DOFs with mass"),
        ));
    }
    let p = massive.min((2 * count).max(count + 8));
    let mut x = if p == n {
        Mat::<f64>::identity(n, n)
    } else {
        // deterministic start vectors with components along every DOF
        Mat::<f64>::from_fn(n, p, |i, j| {
            if j == 0 {
                1.0
            } else {
                ((i + 1) as f64 * (j as f64 * 0.618_033_988_7 + 0.1)).sin()
            }
        })
    };
    let llt = (p < n)
        .then(|| {
            stiffness.to_faer().sp_cholesky(Side::Lower).map_err(|_| {
                Error::Singular("the stiffness matrix is not positive definite".into())
            })
        })
        .transpose()?;
    let k = stiffness.to_faer();
    let m = mass.to_faer();
    let mut previous: Option<Vec<f64>> = None;
    for _ in 0..500 {
        let y = match &llt {
            Some(llt) => {
                let mut y = &m * &x;
                llt.solve_in_place(y.as_mut());
                // orthonormal columns: the Rayleigh–Ritz matrices stay well conditioned
                y.qr().compute_thin_Q()
            }
            None => x.clone(),
        };
        let (values, shapes) = rayleigh_ritz(&(&k * &y), &(&m * &y), &y)?;
        let converged = previous.as_ref().is_some_and(|old| {
            (0..count).all(|i| (values[i] - old[i]).abs() <= 1e-11 * values[i].abs())
        });
        if converged || llt.is_none() {
            return Ok(LowestModes {
                eigenvalues: values[..count].to_vec(),
                shapes: shapes.subcols(0, count).to_owned(),
            });
        }
        previous = Some(values);
        x = shapes;
    }
    Err(Error::Numerical(format!(
        "subspace iteration for the {count} lowest modes did not converge in 500 iterations"
    )))
}

/// Rayleigh–Ritz on the span of `y` given `K y` and `M y`: Ritz values (ascending) and
/// mass-normalised Ritz vectors `y Q`.
fn rayleigh_ritz(ky: &Mat<f64>, my: &Mat<f64>, y: &Mat<f64>) -> Result<(Vec<f64>, Mat<f64>)> {
    let kr = y.transpose() * ky;
    let mr = y.transpose() * my;
    let sym = |a: &Mat<f64>| (a + a.transpose()) * 0.5;
    let llt = sym(&mr).llt(Side::Lower).map_err(|_| {
        Error::Numerical(
            "subspace iteration: the block lost rank (M not positive definite?)".into(),
        )
    })?;
    let l = llt.L();
    let mut a = sym(&kr);
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
    Ok((values, y * q))
}

/// Eigenvalues (ascending) and orthonormal eigenvectors of a symmetric matrix by the
/// tridiagonal QR algorithm. faer's default switches to divide and conquer from dimension
/// 128, whose eigenvectors lose accuracy on the wide spectra of stiffness matrices (on the
/// 400-element bar, residuals of 1e-3·‖A‖ that put the lowest Ritz vectors far off); the QR
/// algorithm keeps them at rounding level.
pub fn symmetric_eigen(a: &Mat<f64>) -> Result<(Vec<f64>, Mat<f64>)> {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::evd::{
        self_adjoint_evd, self_adjoint_evd_scratch, ComputeEigenvectors, SelfAdjointEvdParams,
    };
    let n = a.nrows();
    let mut params: faer::Spec<SelfAdjointEvdParams, f64> = Default::default();
    params.recursion_threshold = usize::MAX;
    let mut s = faer::diag::Diag::<f64>::zeros(n);
    let mut u = Mat::<f64>::zeros(n, n);
    let mut mem = MemBuffer::new(self_adjoint_evd_scratch::<f64>(
        n,
        ComputeEigenvectors::Yes,
        Par::Seq,
        params,
    ));
    self_adjoint_evd(
        a.as_ref(),
        s.as_mut(),
        Some(u.as_mut()),
        Par::Seq,
        MemStack::new(&mut mem),
        params,
    )
    .map_err(|e| Error::Numerical(format!("symmetric eigenvalue solver: {e:?}")))?;
    Ok(((0..n).map(|i| s[i]).collect(), u))
}

/// The lowest eigenfrequencies of a model with its consistent and with its redistributed
/// mass (contacts open, Dirichlet DOFs fixed), and the shift that redistribution causes
/// (the paper's Fig. 8; [`crate::model::Model::compare_masses`]).
#[derive(Clone, Debug, serde::Serialize)]
pub struct MassComparison {
    pub original_hz: Vec<f64>,
    pub redistributed_hz: Vec<f64>,
    /// `f_redistributed / f_original − 1` per mode.
    pub relative_error: Vec<f64>,
    /// The norm the redistribution was found in (docs/theory.md §4, "Choice of norm").
    pub norm: crate::fe::redistribution::RedistributionNorm,
}
