//! Scaled unknowns and the bordered system `[R_X; cᵀ]` shared by the predictor, the
//! corrector and the fallbacks (docs/theory.md (T72)–(T73)).

use std::cell::RefCell;

use faer::Mat;

use crate::error::{Error, Result, SingularSystem};
use crate::problem::{Jacobian, JacobianOperator, Linearization, PeriodicProblem};

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

/// Scaled unknowns `X = [x / (ℓ √s); ln(ω / ω_ref)]` (docs/theory.md (T72)): displacements
/// relative to the problem's length scale per signal (`s` signals, so that the arclength
/// of a change of every contact by `δ` is that of one contact by `δ`), frequency as a
/// relative (logarithmic) change, so that the weight of the frequency in the arclength is
/// the same at 1 kHz and at 100 kHz and does not depend on where the sweep started.
pub(super) struct Scaling {
    /// `ℓ`, the problem's length scale: Newton's tolerance and the comparison of solutions
    /// are relative to it.
    pub length: f64,
    /// `ℓ √s`, the unit of the scaled unknowns.
    pub unknowns: f64,
    /// `ω_ref`, the start frequency (rad/s).
    pub omega: f64,
}

impl Scaling {
    /// The scaling for a problem of length scale `length` whose unknowns hold `signals`
    /// signals, for a sweep from `omega` (rad/s).
    pub fn new(length: f64, signals: usize, omega: f64) -> Self {
        Scaling {
            length,
            unknowns: length * (signals.max(1) as f64).sqrt(),
            omega,
        }
    }

    pub fn to_scaled(&self, x: &[f64], omega: f64) -> Vec<f64> {
        let mut s: Vec<f64> = x.iter().map(|v| v / self.unknowns).collect();
        s.push((omega / self.omega).ln());
        s
    }

    /// [`Scaling::unscale`] with `x` into `x`; `ω`.
    pub fn unscale_into(&self, s: &[f64], x: &mut Vec<f64>) -> f64 {
        let n = s.len() - 1;
        x.clear();
        x.extend(s[..n].iter().map(|v| v * self.unknowns));
        self.omega * s[n].exp()
    }

    pub fn unscale(&self, s: &[f64]) -> (Vec<f64>, f64) {
        let mut x = Vec::with_capacity(s.len() - 1);
        let omega = self.unscale_into(s, &mut x);
        (x, omega)
    }
}

/// The bordered matrix `[R_X; cᵀ]` in scaled variables (`c`: `border`), with the residual
/// `R(x, ω)`: dense when the problem's Jacobian is, else an operator ([`BorderedOperator`]).
pub(super) fn bordered<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    sc: &Scaling,
    x: &[f64],
    omega: f64,
    border: &[f64],
) -> Result<(Jacobian, Vec<f64>)> {
    let mut storage = BorderedStorage::default();
    let mut jacobian = Jacobian::Dense(Mat::zeros(0, 0));
    let mut residual = Vec::new();
    bordered_into(
        problem,
        sc,
        x,
        omega,
        border,
        &mut storage,
        &mut jacobian,
        &mut residual,
    )?;
    Ok((jacobian, residual))
}

/// What [`bordered_into`] keeps between calls: the problem's linearization.
#[derive(Default)]
pub(super) struct BorderedStorage {
    linearization: Linearization,
}

/// [`bordered`] into `jacobian` and `residual`, with the problem's linearization in
/// `storage`: a dense bordered matrix of the same size is overwritten, so that nothing is
/// allocated when the problem's [`PeriodicProblem::linearize_into`] allocates nothing.
#[allow(clippy::too_many_arguments)]
pub(super) fn bordered_into<P: PeriodicProblem + ?Sized>(
    problem: &mut P,
    sc: &Scaling,
    x: &[f64],
    omega: f64,
    border: &[f64],
    storage: &mut BorderedStorage,
    jacobian: &mut Jacobian,
    residual: &mut Vec<f64>,
) -> Result<()> {
    let lin = &mut storage.linearization;
    problem.linearize_into(x, omega, lin)?;
    residual.clone_from(&lin.residual);
    let n = lin.d_omega.len();
    // dR / d ln ω
    let column = |i: usize| lin.d_omega[i] * omega;
    if let Jacobian::Dense(j) = &lin.jacobian {
        match jacobian {
            Jacobian::Dense(m) if m.nrows() == n + 1 && m.ncols() == n + 1 => {
                fill_bordered(m, j, sc.unknowns, column, border)
            }
            other => *other = Jacobian::Dense(bordered_matrix(j, sc.unknowns, column, border)),
        }
        return Ok(());
    }
    let column: Vec<f64> = (0..n).map(column).collect();
    let Jacobian::Operator(inner) =
        std::mem::replace(&mut lin.jacobian, Jacobian::Dense(Mat::zeros(0, 0)))
    else {
        unreachable!("not dense")
    };
    *jacobian = Jacobian::Operator(Box::new(BorderedOperator::new(
        inner,
        sc.unknowns,
        column,
        border.to_vec(),
    )));
    Ok(())
}

/// `[ℓ J, column; borderᵀ]`.
fn bordered_matrix(
    j: &Mat<f64>,
    length: f64,
    column: impl Fn(usize) -> f64,
    border: &[f64],
) -> Mat<f64> {
    let n = j.nrows();
    let mut m = Mat::zeros(n + 1, n + 1);
    fill_bordered(&mut m, j, length, column, border);
    m
}

/// [`bordered_matrix`] into `m` (`(n + 1) × (n + 1)`).
fn fill_bordered(
    m: &mut Mat<f64>,
    j: &Mat<f64>,
    length: f64,
    column: impl Fn(usize) -> f64,
    border: &[f64],
) {
    let n = j.nrows();
    for k in 0..n {
        for i in 0..n {
            m[(i, k)] = j[(i, k)] * length;
        }
        m[(n, k)] = border[k];
    }
    for i in 0..n {
        m[(i, n)] = column(i);
    }
    m[(n, n)] = border[n];
}

/// The bordered matrix `[ℓ J, b; cᵀ, d]` of an operator Jacobian `J` (docs/theory.md §18,
/// (T135)):
/// applied blockwise, and preconditioned by block elimination with `J`'s own
/// preconditioner `P ≈ J⁻¹`: with `y_b = P b / ℓ` and `σ = d − cᵀ y_b`, the right-hand side
/// `(r, ρ)` gives `s = (ρ − cᵀ P r / ℓ) / σ` and `x = P r / ℓ − y_b s`; exact when `P` is.
/// At a fold `J` is singular but the bordered matrix is not; where `σ` vanishes numerically
/// (or `P` is not finite there) the block-diagonal preconditioner `[P / ℓ, 0; 0, 1/d]`
/// (`1` for `d = 0`) is used instead.
pub(super) struct BorderedOperator {
    inner: Box<dyn JacobianOperator>,
    length: f64,
    column: Vec<f64>,
    border: Vec<f64>,
    /// `P b / ℓ` and the Schur complement `σ`, when usable.
    elimination: RefCell<Option<(Vec<f64>, f64)>>,
}

impl BorderedOperator {
    fn new(
        inner: Box<dyn JacobianOperator>,
        length: f64,
        column: Vec<f64>,
        border: Vec<f64>,
    ) -> Self {
        let operator = BorderedOperator {
            inner,
            length,
            column,
            border,
            elimination: RefCell::new(None),
        };
        operator.eliminate();
        operator
    }

    /// `y_b` and `σ` with the inner preconditioner as it is now.
    fn eliminate(&self) {
        let n = self.column.len();
        let mut y_b = vec![0.0; n];
        self.inner.precondition(&self.column, &mut y_b);
        y_b.iter_mut().for_each(|v| *v /= self.length);
        let coupling = dot(&self.border[..n], &y_b);
        let sigma = self.border[n] - coupling;
        let size = self.border[n].abs() + coupling.abs();
        *self.elimination.borrow_mut() =
            (sigma.is_finite() && sigma.abs() > 1e-12 * size).then_some((y_b, sigma));
    }
}

impl JacobianOperator for BorderedOperator {
    fn dimension(&self) -> usize {
        self.column.len() + 1
    }

    fn apply(&self, x: &[f64], out: &mut [f64]) {
        let n = self.column.len();
        self.inner.apply(&x[..n], &mut out[..n]);
        let s = x[n];
        out[..n]
            .iter_mut()
            .zip(&self.column)
            .for_each(|(o, c)| *o = *o * self.length + c * s);
        out[n] = dot(&self.border, x);
    }

    fn precondition(&self, r: &[f64], out: &mut [f64]) {
        let n = self.column.len();
        self.inner.precondition(&r[..n], &mut out[..n]);
        out[..n].iter_mut().for_each(|v| *v /= self.length);
        match &*self.elimination.borrow() {
            Some((y_b, sigma)) => {
                let s = (r[n] - dot(&self.border[..n], &out[..n])) / sigma;
                out[..n].iter_mut().zip(y_b).for_each(|(o, y)| *o -= y * s);
                out[n] = s;
            }
            None => {
                let d = self.border[n];
                out[n] = if d != 0.0 { r[n] / d } else { r[n] };
            }
        }
    }

    fn dense(&self) -> Mat<f64> {
        bordered_matrix(
            &self.inner.dense(),
            self.length,
            |i| self.column[i],
            &self.border,
        )
    }

    fn refresh_preconditioner(&self) -> bool {
        let refreshed = self.inner.refresh_preconditioner();
        if refreshed {
            self.eliminate();
        }
        refreshed
    }
}

/// Solve the bordered system `a y = b` (`b_i = rhs(i)`, `i ≤ n`) with Newton's linear solve.
pub(super) fn solve_bordered(a: &Jacobian, rhs: impl Fn(usize) -> f64) -> Result<Vec<f64>> {
    a.solve(rhs)
        .ok_or(Error::SingularSystem(SingularSystem::BorderedMatrix))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::tests::{spread_matrix, DenseOperator};

    #[test]
    fn the_bordered_operator_is_the_bordered_matrix_and_its_preconditioner_inverts_it() {
        let n = 30;
        let matrix = spread_matrix(n);
        let column: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let border: Vec<f64> = (0..=n).map(|i| 0.1 + (i as f64 * 0.7).cos()).collect();
        let length = 2.5;
        let inner = DenseOperator::new(matrix.clone(), true);
        assert!(
            inner.refresh_preconditioner(),
            "make the inner preconditioner exact"
        );
        let op = BorderedOperator::new(Box::new(inner), length, column.clone(), border.clone());
        let dense = bordered_matrix(&matrix, length, |i| column[i], &border);
        let x: Vec<f64> = (0..=n).map(|i| 1.0 + (i as f64 * 0.37).sin()).collect();
        let mut ax = vec![0.0; n + 1];
        op.apply(&x, &mut ax);
        let expected = Jacobian::Dense(dense).apply(&x);
        let err = ax
            .iter()
            .zip(&expected)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-10, "apply: {err:.2e}");
        let mut back = vec![0.0; n + 1];
        op.precondition(&ax, &mut back);
        let err = back
            .iter()
            .zip(&x)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-10, "precondition: {err:.2e}");
    }
}
