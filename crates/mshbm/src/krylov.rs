//! Restarted GMRES with right preconditioning (Saad & Schultz 1986; Saad, *Iterative Methods
//! for Sparse Linear Systems*, Alg. 9.5 in its flexible form), for Newton systems that are
//! given by their action `y = A x` rather than as a matrix (docs/theory.md §18). faer offers
//! conjugate gradients and BiCGSTAB on operators but no GMRES; GMRES minimises the true
//! residual over the Krylov space, which makes its stopping test the one Newton needs.
//!
//! Right preconditioning (`A M⁻¹ y = b`, `x = M⁻¹ y`) keeps the residual that is minimised
//! and tested the residual of `A x = b` itself. The preconditioned vectors `z_j = M⁻¹ v_j`
//! are kept (flexible GMRES), so `x` needs no second application of `M⁻¹`. Orthogonalisation
//! is modified Gram–Schmidt repeated once (the second pass restores orthogonality lost to
//! cancellation), and the Hessenberg matrix is reduced by Givens rotations as it grows, so
//! the residual norm of every iterate is known without forming it.

/// Settings of [`gmres`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GmresOptions {
    /// Converged when `‖b − A x‖₂ ≤ relative_tolerance · ‖b‖₂`.
    pub relative_tolerance: f64,
    /// Krylov vectors kept before a restart (memory: twice this many vectors).
    pub restart: usize,
    /// Largest number of operator applications.
    pub max_iterations: usize,
}

/// How [`gmres`] ended.
#[derive(Clone, Debug)]
pub struct GmresOutcome {
    pub x: Vec<f64>,
    /// Operator applications made (restarts included).
    pub iterations: usize,
    /// `‖b − A x‖₂ / ‖b‖₂` at `x` (zero for `b = 0`).
    pub relative_residual: f64,
    pub converged: bool,
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// `y ← y + a x`.
fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    y.iter_mut().zip(x).for_each(|(y, x)| *y += a * x);
}

/// Solve `A x = b` from `x = 0`, with `apply(x, y)` writing `y = A x` and
/// `precondition(r, z)` writing `z ≈ A⁻¹ r`. Not converging within the settings is an
/// outcome (`converged = false`, the best iterate returned), as is a non-finite value from
/// either closure (then `converged = false` and `x` is the last finite iterate).
pub fn gmres(
    b: &[f64],
    mut apply: impl FnMut(&[f64], &mut [f64]),
    mut precondition: impl FnMut(&[f64], &mut [f64]),
    options: &GmresOptions,
) -> GmresOutcome {
    let n = b.len();
    let b_norm = norm(b);
    let mut x = vec![0.0; n];
    if b_norm == 0.0 {
        return GmresOutcome {
            x,
            iterations: 0,
            relative_residual: 0.0,
            converged: true,
        };
    }
    let target = options.relative_tolerance * b_norm;
    let m = options.restart.max(1);
    let mut r = b.to_vec();
    let mut beta = b_norm;
    let mut iterations = 0;
    let mut work = vec![0.0; n];
    let mut basis: Vec<Vec<f64>> = Vec::with_capacity(m + 1);
    let mut preconditioned: Vec<Vec<f64>> = Vec::with_capacity(m);
    // Hessenberg columns (after the rotations: upper triangular), rotations, rhs g
    let mut hessenberg: Vec<Vec<f64>> = Vec::with_capacity(m);
    let mut rotations: Vec<(f64, f64)> = Vec::with_capacity(m);
    let mut g: Vec<f64> = Vec::with_capacity(m + 1);
    while beta > target && iterations < options.max_iterations {
        basis.clear();
        preconditioned.clear();
        hessenberg.clear();
        rotations.clear();
        g.clear();
        g.push(beta);
        basis.push(r.iter().map(|v| v / beta).collect());
        let mut breakdown = false;
        for j in 0..m {
            if iterations >= options.max_iterations {
                break;
            }
            let mut z = vec![0.0; n];
            precondition(&basis[j], &mut z);
            apply(&z, &mut work);
            iterations += 1;
            if !work.iter().chain(&z).all(|v| v.is_finite()) {
                breakdown = true;
                break;
            }
            let mut h = vec![0.0; j + 2];
            for _pass in 0..2 {
                for (i, v) in basis.iter().enumerate() {
                    let c = dot(&work, v);
                    h[i] += c;
                    axpy(-c, v, &mut work);
                }
            }
            let next = norm(&work);
            h[j + 1] = next;
            for (i, &(c, s)) in rotations.iter().enumerate() {
                let (a, b) = (h[i], h[i + 1]);
                h[i] = c * a + s * b;
                h[i + 1] = -s * a + c * b;
            }
            let (a, b) = (h[j], h[j + 1]);
            let rho = a.hypot(b);
            let (c, s) = if rho == 0.0 {
                (1.0, 0.0)
            } else {
                (a / rho, b / rho)
            };
            h[j] = rho;
            h[j + 1] = 0.0;
            rotations.push((c, s));
            let gj = g[j];
            g[j] = c * gj;
            g.push(-s * gj);
            hessenberg.push(h);
            preconditioned.push(z);
            let estimate = g[j + 1].abs();
            if next <= f64::EPSILON * rho.max(f64::MIN_POSITIVE) || estimate <= target {
                breakdown = next <= f64::EPSILON * rho.max(f64::MIN_POSITIVE);
                break;
            }
            basis.push(work.iter().map(|v| v / next).collect());
        }
        // y from the triangular system, then x += Z y
        let k = hessenberg.len();
        let mut y = vec![0.0; k];
        for i in (0..k).rev() {
            let s: f64 = (i + 1..k).map(|l| hessenberg[l][i] * y[l]).sum();
            y[i] = (g[i] - s) / hessenberg[i][i];
        }
        if y.iter().all(|v| v.is_finite()) {
            for (yi, z) in y.iter().zip(&preconditioned) {
                axpy(*yi, z, &mut x);
            }
        }
        // the true residual (the recurrence drifts over restarts)
        apply(&x, &mut work);
        r.iter_mut()
            .zip(b)
            .zip(&work)
            .for_each(|((r, b), ax)| *r = b - ax);
        let new_beta = norm(&r);
        if !new_beta.is_finite() {
            return GmresOutcome {
                x,
                iterations,
                relative_residual: f64::NAN,
                converged: false,
            };
        }
        let stalled = new_beta >= beta * (1.0 - 1e-12);
        beta = new_beta;
        if breakdown || (stalled && beta > target) {
            break;
        }
    }
    GmresOutcome {
        x,
        iterations,
        relative_residual: beta / b_norm,
        converged: beta <= target,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A nonsymmetric, diagonally dominant test matrix (row-major).
    fn matrix(n: usize) -> Vec<f64> {
        let mut a = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                a[i * n + j] = ((i * 7 + j * 3) % 11) as f64 / 11.0 - 0.3;
            }
            a[i * n + i] += n as f64 / 4.0;
        }
        a
    }

    fn product(a: &[f64], x: &[f64], y: &mut [f64]) {
        let n = x.len();
        for i in 0..n {
            y[i] = (0..n).map(|j| a[i * n + j] * x[j]).sum();
        }
    }

    /// `‖A x − b‖₂`, formed independently of GMRES.
    fn residual(a: &[f64], x: &[f64], b: &[f64]) -> f64 {
        let mut ax = vec![0.0; x.len()];
        product(a, x, &mut ax);
        norm(&ax.iter().zip(b).map(|(p, q)| p - q).collect::<Vec<f64>>())
    }

    fn options(restart: usize) -> GmresOptions {
        GmresOptions {
            relative_tolerance: 1e-12,
            restart,
            max_iterations: 500,
        }
    }

    #[test]
    fn solves_a_nonsymmetric_system_to_the_tolerance_with_and_without_restarts() {
        let n = 40;
        let a = matrix(n);
        let x_true: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut b = vec![0.0; n];
        product(&a, &x_true, &mut b);
        for restart in [n, 7] {
            let out = gmres(
                &b,
                |x, y| product(&a, x, y),
                |r, z| z.copy_from_slice(r),
                &options(restart),
            );
            assert!(out.converged, "restart {restart}: {out:?}");
            let res = residual(&a, &out.x, &b);
            assert!(res <= 1e-12 * norm(&b) * 1.01, "restart {restart}: {res}");
            assert!((out.relative_residual - res / norm(&b)).abs() < 1e-14);
            let err = out
                .x
                .iter()
                .zip(&x_true)
                .map(|(p, q)| (p - q).abs())
                .fold(0.0, f64::max);
            assert!(err < 1e-10, "restart {restart}: {err}");
        }
    }

    #[test]
    fn an_exact_preconditioner_converges_in_one_iteration() {
        // A diagonal: its inverse as the preconditioner makes A M⁻¹ = I
        let n = 25;
        let d: Vec<f64> = (0..n).map(|i| 1.0 + i as f64).collect();
        let b: Vec<f64> = (0..n).map(|i| (i as f64).cos()).collect();
        let out = gmres(
            &b,
            |x, y| {
                y.iter_mut()
                    .zip(x)
                    .zip(&d)
                    .for_each(|((y, x), d)| *y = d * x)
            },
            |r, z| {
                z.iter_mut()
                    .zip(r)
                    .zip(&d)
                    .for_each(|((z, r), d)| *z = r / d)
            },
            &options(10),
        );
        assert!(out.converged);
        assert_eq!(out.iterations, 1);
        for i in 0..n {
            assert!((out.x[i] - b[i] / d[i]).abs() < 1e-14);
        }
    }

    #[test]
    fn a_limit_too_small_reports_no_convergence_with_the_true_residual() {
        let n = 30;
        let a = matrix(n);
        let b: Vec<f64> = (0..n).map(|i| 1.0 + (i % 3) as f64).collect();
        let out = gmres(
            &b,
            |x, y| product(&a, x, y),
            |r, z| z.copy_from_slice(r),
            &GmresOptions {
                relative_tolerance: 1e-14,
                restart: 3,
                max_iterations: 3,
            },
        );
        assert!(!out.converged);
        assert_eq!(out.iterations, 3);
        let res = residual(&a, &out.x, &b);
        assert!((out.relative_residual - res / norm(&b)).abs() < 1e-14);
        assert!(
            out.relative_residual < 1.0,
            "GMRES never increases the residual"
        );
    }

    #[test]
    fn a_zero_right_hand_side_is_solved_by_zero() {
        let out = gmres(
            &[0.0; 4],
            |x, y| y.copy_from_slice(x),
            |r, z| z.copy_from_slice(r),
            &options(4),
        );
        assert!(out.converged && out.iterations == 0 && out.x == vec![0.0; 4]);
    }

    #[test]
    fn a_non_finite_operator_is_not_converged() {
        let out = gmres(
            &[1.0, 2.0],
            |_x, y| y.iter_mut().for_each(|v| *v = f64::NAN),
            |r, z| z.copy_from_slice(r),
            &options(4),
        );
        assert!(!out.converged);
    }
}
