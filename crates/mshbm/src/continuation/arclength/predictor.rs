//! Predictor: the unit tangent of the branch, oriented along the secant of the last step, and
//! the point ahead along it (docs/theory.md (T73)–(T74)).

use super::scaled::{bordered, dot, normalized, solve_bordered, Scaling};
use crate::dense::DenseLu;
use crate::error::{Error, Result, SingularSystem};
use crate::problem::{Jacobian, PeriodicProblem};

/// Unit tangent at `(x, ω)` (docs/theory.md (T73)), solved from
/// `[R_X; previousᵀ] t = [0; 1]` and oriented so that `t · direction > 0` (`direction`: the
/// previous tangent, or better the secant of the last step, which stays a valid orientation
/// across sharp turns).
pub(super) fn tangent<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    sc: &Scaling,
    x: &[f64],
    omega: f64,
    previous: &[f64],
    direction: &[f64],
) -> Result<Vec<f64>> {
    Ok(oriented_tangent(problem, sc, x, omega, previous, direction)?.0)
}

/// [`tangent`], with the sign of `det [R_X; tᵀ]` for the oriented tangent when the
/// Jacobian is a matrix (docs/theory.md (T73)). Along a smooth branch that sign does not
/// change, through folds included: `det [R_X; qᵀ] = α qᵀt` for every `q` (the cofactors
/// span the kernel of `R_X`), and `α` vanishes only where the bordered matrix is singular.
/// A point whose sign differs from the last point's is the branch travelled backwards —
/// a corrector that jumped across a fold onto the returning piece.
pub(super) fn oriented_tangent<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    sc: &Scaling,
    x: &[f64],
    omega: f64,
    previous: &[f64],
    direction: &[f64],
) -> Result<(Vec<f64>, Option<f64>)> {
    let (a, _) = bordered(problem, sc, x, omega, previous)?;
    let n = x.len();
    let rhs = |i| if i == n { 1.0 } else { 0.0 };
    let (raw, bordered_sign) = match &a {
        Jacobian::Dense(m) => {
            let mut lu = DenseLu::default();
            let mut y = Vec::new();
            if !lu.solve_into(m, rhs, &mut y) {
                return Err(Error::SingularSystem(SingularSystem::BorderedMatrix));
            }
            (y, lu.determinant_sign())
        }
        Jacobian::Operator(_) => (solve_bordered(&a, rhs)?, None),
    };
    // det [R_X; tᵀ] = det [R_X; previousᵀ] / (previousᵀ t) for the unit t solved above
    let along_previous = dot(&raw, previous).signum();
    let t = normalized(raw);
    Ok(if dot(&t, direction) < 0.0 {
        (
            t.iter().map(|v| -v).collect(),
            bordered_sign.map(|s| -s * along_previous),
        )
    } else {
        (t, bordered_sign.map(|s| s * along_previous))
    })
}

/// The predictor `X_0 + Δs t` in scaled variables.
pub(super) fn predict(start: &[f64], t: &[f64], ds: f64) -> Vec<f64> {
    start.iter().zip(t).map(|(a, b)| a + ds * b).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::tests::Scalar;
    use crate::problem::NewtonContraction;

    /// `x² = ω − 1`, one fold at `ω = 1`: travelled with `x` increasing, ω falls to the fold
    /// and rises after it. `det [R_X; tᵀ]` keeps its sign along the whole traversal, and
    /// changes it at a point of the returning piece oriented the way the incoming piece
    /// ran (where a corrector that jumped across the fold would leave the branch).
    #[test]
    fn the_orientation_is_kept_through_a_fold_and_flips_on_a_piece_travelled_backwards() {
        let mut p = Scalar {
            equation: |x: f64, w: f64| (x * x - (w - 1.0), 2.0 * x, -1.0),
            contraction: NewtonContraction::Quadratic,
        };
        let sc = Scaling::new(1.0, 1, 1.0);
        // the traversal's direction in (x, ln ω): d/dx (x, ln(1 + x²)) = (1, 2x/(1 + x²))
        let along = |x: f64| vec![1.0, 2.0 * x / (1.0 + x * x)];
        let sign_at = |p: &mut Scalar<_>, x: f64, direction: &[f64]| {
            let (t, sign) =
                oriented_tangent(p, &sc, &[x], 1.0 + x * x, direction, direction).unwrap();
            assert!(dot(&t, direction) > 0.0);
            sign.expect("a dense Jacobian")
        };
        let first = sign_at(&mut p, -0.3, &along(-0.3));
        for x in [-0.1, -1e-3, 1e-3, 0.1, 0.3] {
            assert_eq!(sign_at(&mut p, x, &along(x)), first, "x = {x}");
        }
        // the returning piece (x > 0) travelled towards the fold, as the incoming piece was
        let backwards: Vec<f64> = along(0.1).iter().map(|v| -v).collect();
        assert_eq!(sign_at(&mut p, 0.1, &backwards), -first);
    }
}
