//! Eigenfrequencies of `K φ = ω² M φ`, including singular (redistributed) masses.
//!
//! DOFs without mass (zero rows of `M`, the contact boundary after redistribution) are
//! condensed statically first, `K* = K_dd − K_dc K_cc⁻¹ K_cd` (docs/theory.md (T30)): a singular
//! mass never reaches the symmetric-definite eigensolver. The reduced problem is solved
//! densely through a Cholesky factor of `M_dd` (`L⁻¹ K* L⁻ᵀ ψ = ω² ψ`) up to
//! [`DENSE_EIGEN_LIMIT`] DOFs with mass; larger models use the block Krylov method (with
//! subspace iteration as its fallback) of [`lowest_modes`]. Either path refuses a stiffness that is not positive definite (rigid-body
//! modes, negative stiffness) and plans its memory against [`Limits`] before allocating.
//! [`first_angular_frequency`] uses sparse inverse iteration and works for large models.

use faer::linalg::solvers::Solve;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Mat, Par, Side};

use crate::error::{Error, Result};
use crate::limits::{dense_f64_bytes, Cancel, Limits};
use crate::sparse::SparseMatrix;

mod block_krylov;

use block_krylov::{block_krylov, rayleigh_ritz, Krylov, BLOCK};

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
/// block Krylov method of [`lowest_modes`], whose cost grows linearly with the DOFs.
pub const DENSE_EIGEN_LIMIT: usize = 1500;

/// Eigenvalues `ω²` within this fraction of the largest are zero (rigid-body modes) for the
/// dense path; below minus this fraction the stiffness is indefinite.
const ZERO_EIGENVALUE: f64 = 1e-11;

/// Dense `n × n` matrices alive at once in the dense path (`K*`, `M_dd`, its factor, the
/// symmetric product, eigenvectors and the solver's workspace).
pub(crate) const DENSE_MATRICES: u64 = 6;

/// Dense `n × n` matrices alive at once in [`every_mode`] and the receptance built on it:
/// `K*`, `M_dd`, its factor, the factor of `K*`, `L⁻¹`, the product `Lᵀ K*⁻¹ L`, the
/// eigenvectors and the solver's workspace, then the shapes and damped shapes the
/// receptance keeps (measured on the bar of 1000 elements: 9 `n²` at the peak).
pub(crate) const EVERY_MODE_MATRICES: u64 = 10;

/// Blocks of `n × p` values (`p = 2·count`) alive at once in [`lowest_modes`]: the block
/// Krylov basis of at most `3p` vectors, the Ritz vectors and their products with `K` and
/// `M` (`3p/2`), and a spare; the subspace iteration (`X`, `M X`, `K⁻¹ M X`, its thin QR,
/// `K Y`, `M Y`, Ritz vectors and a spare) needs the same.
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
/// densely; above, by the sparse block Krylov method of [`lowest_modes`] on the whole model
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
            &format!("the lowest {count} modes of {n} DOFs (sparse block Krylov)"),
            block.zip(factor).and_then(|(a, b)| a.checked_add(b)),
        )?;
        let modes =
            lowest_modes_cancellable(mass, stiffness, None, count, limits.cancel).map_err(|e| {
                match e {
                    Error::Singular(_) => not_definite(None),
                    other => other,
                }
            })?;
        return Ok(modes.eigenvalues.into_iter().map(to_hz).collect());
    }
    limits.check_memory(
        &format!("the dense eigenproblem of {} DOFs with mass", massive.len()),
        dense_f64_bytes(massive.len(), massive.len()).and_then(|b| b.checked_mul(DENSE_MATRICES)),
    )?;
    let Condensed {
        stiffness: k_red,
        mass_factor: llt,
        ..
    } = condense_massless(mass, stiffness, &massless, &massive)?;
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

/// Lowest angular eigenfrequency (rad/s) of `K φ = ω² M φ` by [`lowest_modes`]
/// ([`lowest_modes`]) with a sparse Cholesky factor of `K` (positive definite: Dirichlet
/// DOFs removed). Works with massless DOFs (they follow statically). Converges with the
/// ratio `ω₁²/ω₁₀²`, so close second modes (plates) do not slow it down as they slow inverse
/// iteration.
pub fn first_angular_frequency(mass: &SparseMatrix, stiffness: &SparseMatrix) -> Result<f64> {
    first_angular_frequency_cancellable(mass, stiffness, Cancel::NEVER)
}

/// [`first_angular_frequency`], stopped by `cancel` (its factorization and iterations:
/// [`lowest_modes_cancellable`]).
pub fn first_angular_frequency_cancellable(
    mass: &SparseMatrix,
    stiffness: &SparseMatrix,
    cancel: Cancel,
) -> Result<f64> {
    if massless_dofs(mass).len() == mass.nrows() {
        return Err(Error::Singular(
            "the mass matrix has no positive mass".into(),
        ));
    }
    let modes = lowest_modes_cancellable(mass, stiffness, None, 1, cancel).map_err(|e| match e {
        Error::Singular(_) => Error::Singular("a first-mode damping ratio needs a held structure: the stiffness is not positive definite with the Dirichlet DOFs fixed (a rigid-body motion, or a negative stiffness)".into()),
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
    /// Which algorithm of [`lowest_modes`] found them.
    pub solver: ModeSolver,
}

/// The algorithms of [`lowest_modes`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModeSolver {
    /// One Rayleigh–Ritz step on the identity (few DOFs, none massless).
    Dense,
    /// The block Krylov space.
    BlockKrylov,
    /// Subspace iteration (where the Krylov space did not converge within its size).
    SubspaceIteration,
    /// Every mode, by the static condensation of the massless DOFs and a dense symmetric
    /// eigenproblem ([`every_mode`]).
    Condensed,
}

/// Relative residual `‖K φ − ω² M φ‖ / ‖ω² M φ‖` at which the block Krylov method of
/// [`lowest_modes`] accepts a Ritz pair (its eigenvalue is then exact to about the square
/// of this over the relative gap).
pub const MODE_RESIDUAL_TOLERANCE: f64 = 1e-8;

/// The `count` lowest modes of `K φ = ω² M φ` (`K` positive definite, `M` positive
/// definite on the `n_m` DOFs with mass, zero elsewhere), with a sparse Cholesky factor of
/// `K` (docs/theory.md §17, "Modes"):
///
/// 1. **Block Krylov** (block shift-invert Lanczos at `σ = 0` with full
///    reorthogonalisation): the basis `[Y, A Y, A² Y, …]`, `A = K⁻¹ M`, `Y = A X` for `b`
///    deterministic start vectors, is extended one block solve at a time and orthonormalised;
///    Rayleigh–Ritz on it gives Ritz pairs, accepted when the `count` lowest have a relative
///    residual below [`MODE_RESIDUAL_TOLERANCE`]. The Krylov space holds the lowest modes
///    after about `2·count` vectors, where subspace iteration needs tens of block
///    iterations of `2·count` solves each.
/// 2. Where that has not converged at `min(n_m, 6·count + b)` vectors, **subspace
///    iteration** (Bathe's method) from the Ritz vectors: the block `Y = K⁻¹ M X` of
///    `p = min(n_m, max(2·count, count + 8))` vectors improved by a Rayleigh–Ritz step per
///    iteration until the `count` lowest Ritz values change by less than `1e-11`.
///
/// With `p = n` (no massless DOFs and few DOFs) one Rayleigh–Ritz step on the identity is
/// the dense solution.
pub fn lowest_modes(
    mass: &SparseMatrix,
    stiffness: &SparseMatrix,
    count: usize,
) -> Result<LowestModes> {
    lowest_modes_factored(mass, stiffness, None, count)
}

/// The sparse Cholesky factor of `K` that [`lowest_modes_factored`] shares with its caller.
pub type StiffnessFactor = faer::sparse::linalg::solvers::Llt<usize, f64>;

/// The sparse Cholesky factor of `K` (an error when `K` is not positive definite).
pub fn stiffness_factor(stiffness: &SparseMatrix) -> Result<StiffnessFactor> {
    stiffness_factor_cancellable(stiffness, Cancel::NEVER)
}

/// [`stiffness_factor`] that `cancel` stops waiting for ([`Cancel::wait_for`]: faer's
/// factorization cannot check a request itself, and takes tens of seconds on a 3D model).
pub fn stiffness_factor_cancellable(
    stiffness: &SparseMatrix,
    cancel: Cancel,
) -> Result<StiffnessFactor> {
    let k = stiffness.to_faer();
    cancel
        .wait_for(move || k.sp_cholesky(Side::Lower))?
        .map_err(|_| Error::Singular("the stiffness matrix is not positive definite".into()))
}

/// The static condensation of the massless DOFs `c` onto the DOFs with mass `d` (T30).
struct Condensed {
    /// `K* = K_dd − K_cdᵀ K_cc⁻¹ K_cd`.
    stiffness: Mat<f64>,
    /// `K_cc⁻¹ K_cd` (massless × massive): the massless DOFs follow as `−K_cc⁻¹ K_cd q_d`.
    follow: Mat<f64>,
    /// The Cholesky factor of `M_dd`.
    mass_factor: faer::linalg::solvers::Llt<f64>,
}

/// [`Condensed`] for the given `massless` and `massive` DOFs, every product sequential
/// (the same numbers on any number of threads); errors when `K_cc` is singular or `M_dd`
/// not positive definite.
fn condense_massless(
    mass: &SparseMatrix,
    stiffness: &SparseMatrix,
    massless: &[usize],
    massive: &[usize],
) -> Result<Condensed> {
    use faer::linalg::matmul::matmul;
    use faer::Accum;
    let mut k_red = stiffness.submatrix(massive, massive).to_dense();
    let mut follow = Mat::<f64>::zeros(massless.len(), massive.len());
    if !massless.is_empty() {
        let k_cc = stiffness.submatrix(massless, massless).to_dense();
        let k_cd = stiffness.submatrix(massless, massive).to_dense();
        follow = k_cc.full_piv_lu().solve(&k_cd);
        if follow.col_iter().any(|c| c.iter().any(|v| !v.is_finite())) {
            return Err(Error::Singular(
                "the stiffness of the massless DOFs (K_cc) is singular: they are not statically determined".into(),
            ));
        }
        matmul(
            k_red.as_mut(),
            Accum::Add,
            k_cd.transpose(),
            follow.as_ref(),
            -1.0,
            Par::Seq,
        );
    }
    let m_dd = mass.submatrix(massive, massive).to_dense();
    let mass_factor = m_dd.llt(Side::Lower).map_err(|_| {
        Error::Singular(
            "the mass matrix is not positive definite on the DOFs that carry mass".into(),
        )
    })?;
    Ok(Condensed {
        stiffness: k_red,
        follow,
        mass_factor,
    })
}

/// Every mode with mass of `K φ = ω² M φ` (mass-normalised, ascending): the massless DOFs
/// `c` condensed statically (T30), `K* = K_dd − K_cdᵀ K_cc⁻¹ K_cd` on the DOFs with mass `d`,
/// the dense symmetric eigenproblem in shift-invert form `Lᵀ K*⁻¹ L u = u / ω²` with
/// `M_dd = L Lᵀ` (the lowest modes accurate relative to themselves), and the shapes
/// `φ_d = L⁻ᵀ u`, `φ_c = −K_cc⁻¹ K_cd φ_d` (the massless DOFs following statically). Every
/// product and solve is sequential, so the modes are the same numbers on any number of
/// threads. Dense: for models of at most a couple of thousand DOFs with mass (`n³` time,
/// [`EVERY_MODE_MATRICES`] `n²` values).
pub fn every_mode(mass: &SparseMatrix, stiffness: &SparseMatrix) -> Result<LowestModes> {
    use faer::linalg::matmul::matmul;
    use faer::linalg::triangular_solve::solve_upper_triangular_in_place;
    use faer::Accum;
    let n = stiffness.nrows();
    let massless = massless_dofs(mass);
    let mut is_massless = vec![false; n];
    massless.iter().for_each(|&i| is_massless[i] = true);
    let massive: Vec<usize> = (0..n).filter(|&i| !is_massless[i]).collect();
    if massive.is_empty() {
        return Err(Error::Singular(
            "the mass matrix has no positive mass".into(),
        ));
    }
    let Condensed {
        stiffness: k_red,
        follow,
        mass_factor: llt,
    } = condense_massless(mass, stiffness, &massless, &massive)?;
    let l = llt.L();
    // G = Lᵀ K*⁻¹ L, whose eigenvalues are 1/ω²: the shift-invert form keeps the lowest modes,
    // which carry the response, accurate relative to themselves (the direct L⁻¹ K* L⁻ᵀ
    // loses eps·ω_max²/ω_j² of ω_j²)
    let k_llt = k_red.llt(Side::Lower).map_err(|_| {
        Error::Singular(
            "the stiffness is not positive definite with the Dirichlet DOFs fixed".into(),
        )
    })?;
    let mut inverse_l = l.to_owned();
    solve_lower_triangular_in_place(k_llt.L(), inverse_l.as_mut(), Par::Seq);
    solve_upper_triangular_in_place(k_llt.L().transpose(), inverse_l.as_mut(), Par::Seq);
    let d = massive.len();
    let mut g = Mat::<f64>::zeros(d, d);
    matmul(
        g.as_mut(),
        Accum::Replace,
        l.transpose(),
        inverse_l.as_ref(),
        1.0,
        Par::Seq,
    );
    let sym = Mat::<f64>::from_fn(d, d, |i, j| 0.5 * (g[(i, j)] + g[(j, i)]));
    let (inverse_eigenvalues, v) = symmetric_eigen(&sym)?;
    if let Some(j) = inverse_eigenvalues
        .iter()
        .position(|&t| t.is_nan() || t <= 0.0)
    {
        return Err(Error::Singular(format!(
            "mode {j} has 1/ω² = {:e}: the stiffness is not positive definite with the Dirichlet DOFs fixed",
            inverse_eigenvalues[j]
        )));
    }
    // ascending ω² = 1/θ: the eigenvalues θ in reverse
    let eigenvalues: Vec<f64> = inverse_eigenvalues.iter().rev().map(|t| 1.0 / t).collect();
    let mut u = Mat::<f64>::from_fn(d, d, |i, j| v[(i, d - 1 - j)]);
    // ψ = L⁻ᵀ u (mass-normalised: ψᵀ M ψ = uᵀ u = 1)
    solve_upper_triangular_in_place(l.transpose(), u.as_mut(), Par::Seq);
    let mut shapes = Mat::<f64>::zeros(n, massive.len());
    for (r, &i) in massive.iter().enumerate() {
        for j in 0..massive.len() {
            shapes[(i, j)] = u[(r, j)];
        }
    }
    if !massless.is_empty() {
        let mut condensed = Mat::<f64>::zeros(massless.len(), massive.len());
        matmul(
            condensed.as_mut(),
            Accum::Replace,
            follow.as_ref(),
            u.as_ref(),
            -1.0,
            Par::Seq,
        );
        for (r, &i) in massless.iter().enumerate() {
            for j in 0..massive.len() {
                shapes[(i, j)] = condensed[(r, j)];
            }
        }
    }
    Ok(LowestModes {
        eigenvalues,
        shapes,
        solver: ModeSolver::Condensed,
    })
}

/// [`lowest_modes`] with a factor of `K` the caller already has (and keeps: on a 3D solid
/// of 10⁵ DOFs it is a gigabyte and tens of seconds).
pub fn lowest_modes_factored(
    mass: &SparseMatrix,
    stiffness: &SparseMatrix,
    factor: Option<&StiffnessFactor>,
    count: usize,
) -> Result<LowestModes> {
    lowest_modes_cancellable(mass, stiffness, factor, count, Cancel::NEVER)
}

/// [`lowest_modes_factored`] stopped by `cancel`: checked at every block of the Krylov
/// space and every subspace iteration, and while `K` is factored
/// ([`stiffness_factor_cancellable`]).
pub fn lowest_modes_cancellable(
    mass: &SparseMatrix,
    stiffness: &SparseMatrix,
    factor: Option<&StiffnessFactor>,
    count: usize,
    cancel: Cancel,
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
    // deterministic start vectors with components along every DOF (columns `from..to`);
    // the block Krylov space needs only its first block, the whole start block (a third of
    // a gigabyte for 200 modes of 10⁵ DOFs) is formed only for the subspace iteration
    let start_block = |from: usize, to: usize| {
        if p == n {
            Mat::<f64>::from_fn(n, to - from, |i, j| if i == from + j { 1.0 } else { 0.0 })
        } else {
            Mat::<f64>::from_fn(n, to - from, |i, j| {
                let j = from + j;
                if j == 0 {
                    1.0
                } else {
                    ((i + 1) as f64 * (j as f64 * 0.618_033_988_7 + 0.1)).sin()
                }
            })
        }
    };
    let owned = match factor {
        None if p < n => Some(stiffness_factor_cancellable(stiffness, cancel)?),
        _ => None,
    };
    let llt = if p < n {
        owned.as_ref().or(factor)
    } else {
        None
    };
    let mut polished = None;
    if let Some(llt) = llt {
        match block_krylov(
            llt,
            stiffness,
            mass,
            &start_block(0, p.min(BLOCK)),
            p,
            count,
            massive,
            cancel,
        ) {
            Ok(Krylov::Converged(modes)) => return Ok(modes),
            Ok(Krylov::Unconverged(shapes)) if shapes.ncols() == p => polished = Some(shapes),
            // a Krylov space that lost rank (an invariant subspace met early) or stopped
            // short of p vectors: the subspace iteration from the start block
            _ => {}
        }
    }
    let mut x = polished.unwrap_or_else(|| start_block(0, p));
    let k = stiffness.to_faer();
    let m = mass.to_faer();
    let mut previous: Option<Vec<f64>> = None;
    for _ in 0..500 {
        cancel.check()?;
        let y = match llt {
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
                solver: if llt.is_none() {
                    ModeSolver::Dense
                } else {
                    ModeSolver::SubspaceIteration
                },
            });
        }
        previous = Some(values);
        x = shapes;
    }
    Err(Error::Numerical(format!(
        "subspace iteration for the {count} lowest modes did not converge in 500 iterations"
    )))
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
