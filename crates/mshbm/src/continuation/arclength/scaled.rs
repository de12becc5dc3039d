//! Scaled unknowns and the bordered system `[R_X; cᵀ]` shared by the predictor, the
//! corrector and the fallbacks (docs/theory.md (T72)–(T73)).

use faer::Mat;

use crate::error::{Error, Result, SingularSystem};
use crate::newton::dense_solve;
use crate::problem::PeriodicProblem;

pub(super) fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

pub(super) fn normalized(mut v: Vec<f64>) -> Vec<f64> {
    let n = dot(&v, &v).sqrt();
    v.iter_mut().for_each(|x| *x /= n);
    v
}

/// `a − b`.
pub(super) fn difference(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x - y).collect()
}

/// Scaled unknowns `X = [x / ℓ; ln(ω / ω_ref)]` (docs/theory.md (T72)): displacements
/// relative to the problem's length scale, frequency as a relative (logarithmic) change, so
/// that the weight of the frequency in the arclength is the same at 1 kHz and at 100 kHz
/// and does not depend on where the sweep started.
pub(super) struct Scaling {
    /// `ℓ`, the problem's length scale.
    pub length: f64,
    /// `ω_ref`, the start frequency (rad/s).
    pub omega: f64,
}

impl Scaling {
    pub fn to_scaled(&self, x: &[f64], omega: f64) -> Vec<f64> {
        let mut s: Vec<f64> = x.iter().map(|v| v / self.length).collect();
        s.push((omega / self.omega).ln());
        s
    }

    pub fn unscale(&self, s: &[f64]) -> (Vec<f64>, f64) {
        let n = s.len() - 1;
        (
            s[..n].iter().map(|v| v * self.length).collect(),
            self.omega * s[n].exp(),
        )
    }
}

/// The bordered matrix `[R_X; cᵀ]` in scaled variables (`c`: `border`), with the residual
/// `R(x, ω)`.
pub(super) fn bordered<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    sc: &Scaling,
    x: &[f64],
    omega: f64,
    border: &[f64],
) -> Result<(Mat<f64>, Vec<f64>)> {
    let lin = problem.linearize(x, omega)?;
    let n = x.len();
    let mut a = Mat::<f64>::zeros(n + 1, n + 1);
    for i in 0..n {
        for j in 0..n {
            a[(i, j)] = lin.jacobian[(i, j)] * sc.length;
        }
        a[(i, n)] = lin.d_omega[i] * omega; // dω / d ln ω
    }
    for j in 0..=n {
        a[(n, j)] = border[j];
    }
    Ok((a, lin.residual))
}

/// Solve the bordered system `a y = b` (`b_i = rhs(i)`, `i ≤ n`) with Newton's linear solve.
pub(super) fn solve_bordered(a: &Mat<f64>, rhs: impl Fn(usize) -> f64) -> Result<Vec<f64>> {
    dense_solve(a, a.nrows(), rhs).ok_or(Error::SingularSystem(SingularSystem::BorderedMatrix))
}
